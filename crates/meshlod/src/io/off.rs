//! OFF (Object File Format) reader and writer, ASCII flavour.
//!
//! Follows Geomview's OFF description (`geomview.org/docs/html/OFF.html`):
//!
//! ```text
//! [ST][C][N]OFF            header keyword (prefixes: texture coords, colours, normals)
//! NVertices NFaces NEdges  counts, on the header line or the next one
//! x y z [nx ny nz] [r g b [a]] [s t]      one line per vertex, fields in this order
//! n i0 i1 ... i(n-1) [colour]            one line per face, 0-based indices
//! ```
//!
//! - The header keyword may be left out (the file then starts with the counts).
//!   `4OFF`, `nOFF` (other dimensions) and `OFF BINARY` are refused.
//! - `C` colours have three or four components, either 0–255 integers or 0–1 floats;
//!   a file in which any component exceeds 1 is taken as 0–255 and scaled to 0–1.
//!   A missing alpha is 1. Extra numbers on a vertex line of a file without `C` are
//!   ignored.
//! - Polygons are fan-triangulated around their first vertex; per-face colours are
//!   ignored. The edge count is ignored.
//! - `#` starts a comment; blank lines are skipped; vertices and faces are one per
//!   line. Header counts are checked against what the file size can hold before
//!   anything is allocated.
//!
//! The writer emits `[ST][C][N]OFF` with the prefixes for the attributes the mesh has
//! (plain `OFF` for positions only, `COFF` when it has colours), colours as four 0–1
//! floats, and numbers in their shortest exact form, so write → read is exact for
//! positions, triangles, normals, UVs and colours. Groups are not stored.

use super::obj::{check_writable, push_f32, push_floats, push_u64, scale_colours_255};
use super::text::{parse_count, parse_f32, parse_i64, show, tokens, Lines};
use super::{max_elements, FormatError, Location};
use crate::mesh::{Mesh, VertexAttributes};

/// Which optional vertex fields the header announces.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Header {
    texcoords: bool,
    colors: bool,
    normals: bool,
}

/// Reads an ASCII OFF file (also `COFF`, `NOFF`, `STOFF` and combinations).
///
/// # Errors
/// [`FormatError`] at the [`Location::Line`] that is wrong: an empty file or missing
/// counts, a header that is not OFF or names an unsupported variant, counts larger
/// than the file can hold, a vertex line with too few numbers or a NaN/infinite one,
/// a face with fewer than three vertices or fewer indices than it declares, an index
/// that is negative or not below the vertex count, or a file that ends before all
/// declared vertices and faces.
pub fn read(data: &[u8]) -> Result<Mesh, FormatError> {
    let mut lines = Lines::new(data);
    let (header, nv, nf) = read_counts(&mut lines, data)?;
    let vertices = read_vertices(&mut lines, header, nv)?;
    let triangles = read_faces(&mut lines, nv, nf)?;
    Ok(Mesh {
        positions: vertices.positions,
        triangles,
        attributes: VertexAttributes {
            normals: vertices.normals,
            uv0: vertices.uv0,
            colors: vertices.colors,
            ..VertexAttributes::default()
        },
        groups: None,
        group_names: Vec::new(),
    })
}

/// The header keyword (when there is one) and the vertex and face counts, each
/// checked against what the rest of the file (`data`) can hold.
fn read_counts(lines: &mut Lines<'_>, data: &[u8]) -> Result<(Header, usize, usize), FormatError> {
    let Some(first) = next_content(lines) else {
        return Err(FormatError::new(
            Location::File,
            "empty file: no OFF header or counts",
        ));
    };
    let mut first_tokens = tokens(first);
    let keyword = first_tokens.next().unwrap_or_default();
    let (header, counts_line) = match parse_header(keyword, lines.line_number())? {
        Some(header) => {
            let rest: Vec<&[u8]> = first_tokens.collect();
            if rest.first().is_some_and(|t| *t == b"BINARY") {
                return Err(FormatError::new(
                    Location::Line(lines.line_number()),
                    "binary OFF is not supported",
                ));
            }
            if rest.is_empty() {
                match next_content(lines) {
                    Some(l) => (header, tokens(l).collect::<Vec<_>>()),
                    None => {
                        return Err(FormatError::new(
                            Location::Line(lines.line_number()),
                            "file ends after the OFF header: no vertex and face counts",
                        ))
                    }
                }
            } else {
                (header, rest)
            }
        }
        // No keyword: the first line holds the counts.
        None => (Header::default(), tokens(first).collect()),
    };
    let ln = lines.line_number();
    let [nv, nf, rest @ ..] = counts_line.as_slice() else {
        return Err(FormatError::new(
            Location::Line(ln),
            "expected the counts 'vertices faces [edges]'",
        ));
    };
    if rest.len() > 1 {
        return Err(FormatError::new(
            Location::Line(ln),
            format!(
                "expected the counts 'vertices faces [edges]', found {} numbers",
                counts_line.len()
            ),
        ));
    }
    // Smallest vertex line "0 0 0\n" is 6 bytes, smallest face "3 0 1 2\n" 8.
    let room = data.len().saturating_sub(lines.offset()) + 1;
    let nv = parse_count(nv, ln, "the vertex count", max_elements(room, 6))?;
    let nf = parse_count(nf, ln, "the face count", max_elements(room, 8))?;
    if let Some(ne) = rest.first() {
        parse_i64(ne, ln, "the edge count")?;
    }
    Ok((header, nv, nf))
}

/// The vertex streams an OFF file holds (those its header announces).
struct Vertices {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    colors: Option<Vec<[f32; 4]>>,
    uv0: Option<Vec<[f32; 2]>>,
}

/// Reads `nv` vertex lines with the fields `header` announces; colours end on the
/// 0–1 scale (a file with any component above 1 is taken as 0–255).
fn read_vertices(
    lines: &mut Lines<'_>,
    header: Header,
    nv: usize,
) -> Result<Vertices, FormatError> {
    let mut positions = Vec::with_capacity(nv);
    let mut normals = header.normals.then(|| Vec::with_capacity(nv));
    let mut colors = header.colors.then(|| Vec::with_capacity(nv));
    let mut uv0 = header.texcoords.then(|| Vec::with_capacity(nv));
    let base = 3 + if header.normals { 3 } else { 0 } + if header.texcoords { 2 } else { 0 };
    let mut values = [0f32; 16];
    for k in 0..nv {
        let Some(line) = next_content(lines) else {
            return Err(FormatError::new(
                Location::Line(lines.line_number()),
                format!("file ends after {k} of {nv} vertices"),
            ));
        };
        let ln = lines.line_number();
        let n = vertex_numbers(line, ln, k, header, &mut values)?;
        let colour_len = n.saturating_sub(base);
        if n < base || (header.colors && !(3..=4).contains(&colour_len)) {
            let expected = if header.colors {
                format!("{} or {}", base + 3, base + 4)
            } else {
                base.to_string()
            };
            return Err(FormatError::new(
                Location::Line(ln),
                format!("vertex {k} has {n} numbers, expected {expected}"),
            ));
        }
        let v = |i: usize| values.get(i).copied().unwrap_or_default();
        positions.push([v(0), v(1), v(2)]);
        let mut at = 3;
        if let Some(normals) = &mut normals {
            normals.push([v(at), v(at + 1), v(at + 2)]);
            at += 3;
        }
        if let Some(colors) = &mut colors {
            let alpha = if colour_len == 4 { v(at + 3) } else { f32::NAN };
            colors.push([v(at), v(at + 1), v(at + 2), alpha]);
            at += colour_len;
        }
        if let Some(uv0) = &mut uv0 {
            uv0.push([v(at), v(at + 1)]);
        }
    }
    if let Some(colors) = &mut colors {
        // Alpha left out: opaque on either scale.
        let max = if colors.iter().any(|c| c.iter().any(|&x| x > 1.0)) {
            255.0
        } else {
            1.0
        };
        for c in colors.iter_mut() {
            if c[3].is_nan() {
                c[3] = max;
            }
        }
        scale_colours_255(colors);
    }
    Ok(Vertices {
        positions,
        normals,
        colors,
        uv0,
    })
}

/// Parses the numbers of vertex line `line` (vertex `k`, line `ln`) into `values`
/// and returns how many there are: more than `values` holds is an error with
/// colours and ignored without; a non-finite number is an error.
fn vertex_numbers(
    line: &[u8],
    ln: u64,
    k: usize,
    header: Header,
    values: &mut [f32; 16],
) -> Result<usize, FormatError> {
    let mut n = 0;
    for t in tokens(line) {
        let Some(slot) = values.get_mut(n) else {
            if header.colors {
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!("vertex {k} has more than {} numbers", values.len()),
                ));
            }
            break;
        };
        let v = parse_f32(t, ln, "a vertex field")?;
        if !v.is_finite() {
            return Err(FormatError::new(
                Location::Line(ln),
                format!("vertex {k} has a non-finite value '{}'", show(t)),
            ));
        }
        *slot = v;
        n += 1;
    }
    Ok(n)
}

/// Reads `nf` face lines over `nv` vertices, fan-triangulated around their first
/// vertex (a face colour after the indices is ignored).
fn read_faces(lines: &mut Lines<'_>, nv: usize, nf: usize) -> Result<Vec<[u32; 3]>, FormatError> {
    let mut triangles = Vec::with_capacity(nf);
    let mut corners: Vec<u32> = Vec::new();
    for k in 0..nf {
        let Some(line) = next_content(lines) else {
            return Err(FormatError::new(
                Location::Line(lines.line_number()),
                format!("file ends after {k} of {nf} faces"),
            ));
        };
        let ln = lines.line_number();
        let mut toks = tokens(line);
        let count_token = toks.next().unwrap_or_default();
        let count = parse_i64(count_token, ln, "the face's vertex count")?;
        if count < 3 {
            return Err(FormatError::new(
                Location::Line(ln),
                format!("face {k} has {count} vertices; a face needs at least 3"),
            ));
        }
        corners.clear();
        for t in toks.by_ref() {
            if corners.len() as i64 == count {
                break; // The rest is the face colour.
            }
            let i = parse_i64(t, ln, "a vertex index")?;
            if i < 0 || i as u64 >= nv as u64 {
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!("face {k} refers to vertex {i}, but there are {nv} vertices"),
                ));
            }
            corners.push(i as u32);
        }
        if (corners.len() as i64) < count {
            return Err(FormatError::new(
                Location::Line(ln),
                format!(
                    "face {k} declares {count} vertices but lists {}",
                    corners.len()
                ),
            ));
        }
        if let Some((&a, rest)) = corners.split_first() {
            for pair in rest.windows(2) {
                if let [b, c] = *pair {
                    triangles.push([a, b, c]);
                }
            }
        }
    }
    Ok(triangles)
}

/// Parses the header keyword: `Some` for `[ST][C][N]OFF`, `None` for no keyword
/// (the token is a number).
fn parse_header(keyword: &[u8], ln: u64) -> Result<Option<Header>, FormatError> {
    let digits = keyword.strip_prefix(b"+").unwrap_or(keyword);
    if !digits.is_empty() && digits.iter().all(u8::is_ascii_digit) {
        return Ok(None);
    }
    let mut k = keyword;
    let mut header = Header::default();
    if let Some(r) = k.strip_prefix(b"ST") {
        header.texcoords = true;
        k = r;
    }
    if let Some(r) = k.strip_prefix(b"C") {
        header.colors = true;
        k = r;
    }
    if let Some(r) = k.strip_prefix(b"N") {
        header.normals = true;
        k = r;
    }
    if k == b"OFF" {
        return Ok(Some(header));
    }
    if k.ends_with(b"OFF") && (k.starts_with(b"4") || k.starts_with(b"n")) {
        return Err(FormatError::new(
            Location::Line(ln),
            format!(
                "'{}': OFF files in other than 3 dimensions are not supported",
                show(keyword)
            ),
        ));
    }
    Err(FormatError::new(
        Location::Line(ln),
        format!(
            "not an OFF file: expected an OFF header, found '{}'",
            show(keyword)
        ),
    ))
}

/// The next line with content (comments removed), or `None` at the end of the file.
fn next_content<'a>(lines: &mut Lines<'a>) -> Option<&'a [u8]> {
    for line in lines.by_ref() {
        let content = match line.iter().position(|&b| b == b'#') {
            Some(i) => line.get(..i).unwrap_or_default(),
            None => line,
        };
        let content = content.trim_ascii();
        if !content.is_empty() {
            return Some(content);
        }
    }
    None
}

/// Writes `mesh` as ASCII OFF: `[ST][C][N]OFF` for the attributes present.
///
/// # Errors
/// [`FormatError`] when the mesh is invalid (an index out of range, attribute streams
/// of the wrong length) or holds a NaN or infinite value.
pub fn write(mesh: &Mesh, out: &mut Vec<u8>) -> Result<(), FormatError> {
    check_writable(mesh)?;
    let a = &mesh.attributes;
    out.reserve(mesh.positions.len() * 40 + mesh.triangles.len() * 24);
    if a.uv0.is_some() {
        out.extend_from_slice(b"ST");
    }
    if a.colors.is_some() {
        out.push(b'C');
    }
    if a.normals.is_some() {
        out.push(b'N');
    }
    out.extend_from_slice(b"OFF\n");
    push_u64(out, mesh.positions.len() as u64);
    out.push(b' ');
    push_u64(out, mesh.triangles.len() as u64);
    out.extend_from_slice(b" 0\n");
    for (i, p) in mesh.positions.iter().enumerate() {
        let [x, yz @ ..] = p;
        push_f32(out, *x);
        push_floats(out, yz);
        if let Some(n) = a.normals.as_ref().and_then(|n| n.get(i)) {
            push_floats(out, n);
        }
        if let Some(c) = a.colors.as_ref().and_then(|c| c.get(i)) {
            push_floats(out, c);
        }
        if let Some(t) = a.uv0.as_ref().and_then(|t| t.get(i)) {
            push_floats(out, t);
        }
        out.push(b'\n');
    }
    for t in &mesh.triangles {
        out.push(b'3');
        for &i in t {
            out.push(b' ');
            push_u64(out, u64::from(i));
        }
        out.push(b'\n');
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::test_support::{mutated, position_bits};
    use proptest::prelude::*;

    fn mesh(src: &str) -> Mesh {
        read(src.as_bytes()).unwrap()
    }

    fn err(src: &str) -> FormatError {
        read(src.as_bytes()).unwrap_err()
    }

    fn written(m: &Mesh) -> String {
        let mut out = Vec::new();
        write(m, &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    // 3 ─ 2
    // │ ╲ │   a quad (0 1 2 3) and a triangle (1 4 2) sharing edge 1-2
    // 0 ─ 1 ─ 4
    const BASIC: &str = "# comment\nOFF\n\n5 2 0   # counts\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\
                         2 0 0\n4 0 1 2 3\n3 1 4 2\n";

    #[test]
    fn basic_polygons_are_fan_triangulated() {
        let m = mesh(BASIC);
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[4], [2.0, 0.0, 0.0]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [1, 4, 2]]);
        assert!(m.attributes.is_empty());
        assert_eq!(m.groups, None);
    }

    #[test]
    fn counts_on_header_line_crlf_and_no_header() {
        let m = mesh("OFF 3 1 0\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n");
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        // No header keyword: the file starts with the counts; the edge count is optional.
        let m = mesh("3 1\n0 0 0\n1 0 0\n0 1 0\n3 2 1 0\n");
        assert_eq!(m.triangles, vec![[2, 1, 0]]);
    }

    #[test]
    fn face_colours_and_trailing_content_are_ignored() {
        let m = mesh("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 255 0 0\nextra stuff\n");
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        assert!(m.attributes.is_empty());
    }

    #[test]
    fn coff_integer_and_float_colours() {
        // 0–255 integers, three and four components mixed.
        let m = mesh("COFF\n3 1 0\n0 0 0 255 0 0\n1 0 0 0 51 0 255\n0 1 0 0 0 255 0\n3 0 1 2\n");
        assert_eq!(
            m.attributes.colors,
            Some(vec![
                [1.0, 0.0, 0.0, 1.0],
                [0.0, 0.2, 0.0, 1.0],
                [0.0, 0.0, 1.0, 0.0]
            ])
        );
        // 0–1 floats.
        let m = mesh("COFF\n3 1 0\n0 0 0 1 0 0 0.5\n1 0 0 0 1 0\n0 1 0 0 0 0.25 1\n3 0 1 2\n");
        assert_eq!(
            m.attributes.colors,
            Some(vec![
                [1.0, 0.0, 0.0, 0.5],
                [0.0, 1.0, 0.0, 1.0],
                [0.0, 0.0, 0.25, 1.0]
            ])
        );
    }

    #[test]
    fn noff_stoff_and_all_prefixes() {
        let m = mesh("NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 1 0\n3 0 1 2\n");
        assert_eq!(
            m.attributes.normals,
            Some(vec![[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
        );
        let m = mesh("STOFF\n3 1 0\n0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n3 0 1 2\n");
        assert_eq!(
            m.attributes.uv0,
            Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
        );
        // Order on the line: position, normal, colour, texture coordinates.
        let m = mesh(
            "STCNOFF\n3 1 0\n0 0 0  0 0 1  1 0 0 1  0.5 0.25\n1 0 0  0 0 1  0 1 0 1  1 0\n\
                      0 1 0  0 0 1  0 0 1  0 1\n3 0 1 2\n",
        );
        assert_eq!(m.attributes.normals, Some(vec![[0.0, 0.0, 1.0]; 3]));
        assert_eq!(
            m.attributes.colors,
            Some(vec![
                [1.0, 0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0, 1.0],
                [0.0, 0.0, 1.0, 1.0]
            ])
        );
        assert_eq!(
            m.attributes.uv0,
            Some(vec![[0.5, 0.25], [1.0, 0.0], [0.0, 1.0]])
        );
    }

    #[test]
    fn extra_vertex_numbers_without_c_are_ignored() {
        let m = mesh("OFF\n3 1 0\n0 0 0 9 9 9\n1 0 0\n0 1 0\n3 0 1 2\n");
        assert_eq!(m.positions[0], [0.0, 0.0, 0.0]);
        assert!(m.attributes.is_empty());
    }

    #[test]
    fn errors_name_the_line() {
        let cases: &[(&str, Location, &str)] = &[
            ("", Location::File, "empty file"),
            ("# only comments\n\n", Location::File, "empty file"),
            ("PLY\n3 1 0\n", Location::Line(1), "not an OFF file"),
            (
                "4OFF\n3 1 0\n",
                Location::Line(1),
                "other than 3 dimensions",
            ),
            ("nOFF\n3\n", Location::Line(1), "other than 3 dimensions"),
            ("OFF BINARY\n", Location::Line(1), "binary OFF"),
            ("OFF\n", Location::Line(1), "no vertex and face counts"),
            ("OFF\n3\n", Location::Line(2), "expected the counts"),
            ("OFF\n3 1 0 7\n", Location::Line(2), "found 4 numbers"),
            ("OFF\n-3 1 0\n", Location::Line(2), "negative"),
            (
                "OFF\n3 x 0\n0 0 0\n1 0 0\n0 1 0\n",
                Location::Line(2),
                "expected an integer",
            ),
            (
                "OFF\n99999 1 0\n0 0 0\n",
                Location::Line(2),
                "more than a file of this size",
            ),
            (
                "OFF\n3 99999 0\n0 0 0\n",
                Location::Line(2),
                "more than a file of this size",
            ),
            (
                "OFF\n3 1 0\n0.000000 0 0\n1.000000 0 0\n",
                Location::Line(4),
                "after 2 of 3 vertices",
            ),
            (
                "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
                Location::Line(6),
                "after 1 of 2 faces",
            ),
            (
                "OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n",
                Location::Line(4),
                "has 2 numbers, expected 3",
            ),
            (
                "OFF\n3 1 0\n0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n",
                Location::Line(4),
                "expected a number",
            ),
            (
                "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
                Location::Line(4),
                "non-finite",
            ),
            (
                "OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n",
                Location::Line(4),
                "non-finite",
            ),
            (
                "COFF\n3 1 0\n0 0 0 1 1\n1 0 0 1 1 1\n0 1 0 1 1 1\n3 0 1 2\n",
                Location::Line(3),
                "expected 6 or 7",
            ),
            (
                "NOFF\n3 1 0\n0 0 0 0 0\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n",
                Location::Line(3),
                "expected 6",
            ),
            (
                "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
                Location::Line(6),
                "at least 3",
            ),
            (
                "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n",
                Location::Line(6),
                "declares 4 vertices but lists 3",
            ),
            (
                "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
                Location::Line(6),
                "refers to vertex 3, but there are 3",
            ),
            (
                "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n",
                Location::Line(6),
                "refers to vertex -1",
            ),
            (
                "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n",
                Location::Line(6),
                "expected an integer",
            ),
            (
                "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\nx 0 1 2\n",
                Location::Line(6),
                "expected an integer",
            ),
        ];
        for (src, location, message) in cases {
            let e = err(src);
            assert_eq!(&e.location, location, "{src:?}: {e}");
            assert!(e.message.contains(message), "{src:?}: {}", e.message);
        }
    }

    #[test]
    fn non_utf8_comment_is_fine() {
        let data = b"OFF # \xff\xfe\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert_eq!(read(data).unwrap().triangles.len(), 1);
    }

    #[test]
    fn writer_exact_text() {
        let m = Mesh::from_triangles(
            vec![[0.0, 0.0, 0.0], [1.5, 0.0, -0.0], [0.0, 0.1, 1e-7]],
            vec![[0, 1, 2]],
        );
        assert_eq!(
            written(&m),
            "OFF\n3 1 0\n0 0 0\n1.5 0 -0\n0 0.1 1e-7\n3 0 1 2\n"
        );
        let mut c = m.clone();
        c.attributes.colors = Some(vec![[1.0, 0.5, 0.0, 1.0]; 3]);
        assert!(written(&c).starts_with("COFF\n3 1 0\n0 0 0 1 0.5 0 1\n"));
        let mut all = c;
        all.attributes.normals = Some(vec![[0.0, 0.0, 1.0]; 3]);
        all.attributes.uv0 = Some(vec![[0.25, 0.75]; 3]);
        assert!(written(&all).starts_with("STCNOFF\n3 1 0\n0 0 0 0 0 1 1 0.5 0 1 0.25 0.75\n"));
    }

    #[test]
    fn writer_refuses_non_finite() {
        let mut m = Mesh::from_triangles(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        );
        m.attributes.normals = Some(vec![[0.0; 3], [0.0; 3], [f32::INFINITY, 0.0, 0.0]]);
        assert_eq!(
            write(&m, &mut Vec::new()).unwrap_err().location,
            Location::Element("vertex", 2)
        );
    }

    fn finite() -> impl Strategy<Value = f32> {
        any::<f32>().prop_filter("finite", |x| x.is_finite())
    }

    prop_compose! {
        fn random_mesh()(n in 3usize..24)(
            positions in prop::collection::vec([finite(), finite(), finite()], n),
            triangles in prop::collection::vec([0..n as u32, 0..n as u32, 0..n as u32], 0..40),
            uv in prop::option::of(prop::collection::vec([finite(), finite()], n)),
            normals in prop::option::of(prop::collection::vec([finite(), finite(), finite()], n)),
            colors in prop::option::of(prop::collection::vec([0f32..=1.0, 0f32..=1.0, 0f32..=1.0, 0f32..=1.0], n)),
        ) -> Mesh {
            Mesh {
                positions,
                triangles,
                attributes: VertexAttributes { uv0: uv, normals, colors, ..VertexAttributes::default() },
                groups: None,
                group_names: Vec::new(),
            }
        }
    }

    proptest! {
        #[test]
        fn round_trip(m in random_mesh()) {
            let mut out = Vec::new();
            write(&m, &mut out).unwrap();
            let back = read(&out).unwrap();
            prop_assert_eq!(&back, &m);
            prop_assert_eq!(position_bits(&back), position_bits(&m));
        }

        #[test]
        fn never_panics_on_garbage(data in prop::collection::vec(any::<u8>(), 0..200)) {
            let _ = read(&data);
        }

        #[test]
        fn never_panics_on_mutated_file(cut in 0usize..80, byte in any::<u8>(), at in 0usize..80) {
            let _ = read(&mutated(BASIC.as_bytes(), at, byte, cut));
        }
    }
}
