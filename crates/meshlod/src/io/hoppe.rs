//! Hugues Hoppe's `.m` mesh format (the format of his Mesh-processing-library and of
//! the progressive-mesh papers' data).
//!
//! A line-oriented text format, one element per line, with optional attributes in
//! braces:
//!
//! ```text
//! # comment
//! Vertex 12  0.1 0.2 0.3 {normal=(0 0 1) uv=(0.5 0.5) rgb=(1 0 0)}
//! Face 7  12 13 14 {rgb=(1 0 0)}
//! Corner 12 7 {normal=(0 0 1)}
//! Edge 12 13 {sharp}
//! ```
//!
//! - Vertex ids are arbitrary positive integers; vertices become dense indices in
//!   order of appearance. A face must refer to vertices defined on earlier lines.
//!   Faces are polygons, fan-triangulated around their first vertex; face ids and face
//!   attributes are ignored.
//! - Vertex attributes `normal=(x y z)`, `uv=(u v)` and `rgb=(r g b)` become normals,
//!   UVs and (opaque) colours — each only when *every* vertex has it. Other keys are
//!   skipped.
//! - `Corner` (per-corner attributes), `Edge` and unknown lines are skipped.
//!
//! The writer emits `Vertex` lines numbered from 1 with `normal=`, `uv=` and `rgb=`
//! for the attributes present, and one `Face` per triangle; numbers are printed in their
//! shortest exact form, so write → read is exact. Colour alpha and groups are not
//! stored.

use super::obj::{check_writable, push_f32, push_floats, push_u64, FastMap};
use super::text::{parse_f32, parse_i64, show, tokens, Lines};
use super::{FormatError, Location};
use crate::mesh::{Mesh, VertexAttributes};

/// Reads a Hoppe `.m` mesh.
///
/// # Errors
/// [`FormatError`] at the [`Location::Line`] that is wrong: a malformed or NaN/infinite
/// number, a vertex id that is not a positive integer or is defined twice, a
/// `Vertex` line without three coordinates, an attribute with the wrong number of
/// values, an unclosed `(` or `{`, a face with fewer than three vertices or referring
/// to an undefined vertex id. A file without vertices is refused ([`Location::File`]).
pub fn read(data: &[u8]) -> Result<Mesh, FormatError> {
    let mut index_of: FastMap<u64, u32> = FastMap::default();
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut normals: Vec<[f32; 3]> = Vec::new();
    let mut uvs: Vec<[f32; 2]> = Vec::new();
    let mut colors: Vec<[f32; 4]> = Vec::new();
    let (mut with_normal, mut with_uv, mut with_rgb) = (0usize, 0usize, 0usize);
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut corners: Vec<u32> = Vec::new();
    let mut lines = Lines::new(data);
    while let Some(line) = lines.next() {
        let ln = lines.line_number();
        let keyword = tokens(line).next();
        if !matches!(keyword, Some(b"Vertex" | b"Face")) {
            // Comments, blank lines, Corner, Edge and anything else.
            continue;
        }
        let (head, braces) = split_braces(line, ln)?;
        let mut toks = tokens(head).skip(1);
        match keyword {
            Some(b"Vertex") => {
                let id_token = toks.next().unwrap_or_default();
                let id = parse_id(id_token, ln)?;
                let mut xyz = [0f32; 3];
                let n = parse_floats(&mut toks, ln, "vertex coordinate", &mut xyz)?;
                if n != 3 || toks.next().is_some() {
                    return Err(FormatError::new(
                        Location::Line(ln),
                        format!("'Vertex {id}' needs exactly three coordinates"),
                    ));
                }
                let index = positions.len() as u32;
                if index == u32::MAX {
                    return Err(FormatError::new(
                        Location::Line(ln),
                        "more vertices than 32-bit indices can address",
                    ));
                }
                if index_of.insert(id, index).is_some() {
                    return Err(FormatError::new(
                        Location::Line(ln),
                        format!("vertex id {id} is defined twice"),
                    ));
                }
                positions.push(xyz);
                let (mut normal, mut uv, mut rgb) = (None, None, None);
                for (key, value) in Attributes::new(braces) {
                    match key {
                        b"normal" => normal = Some(attr_values::<3>(value, ln, "normal")?),
                        b"uv" => uv = Some(attr_values::<2>(value, ln, "uv")?),
                        b"rgb" => rgb = Some(attr_values::<3>(value, ln, "rgb")?),
                        _ => {}
                    }
                }
                with_normal += usize::from(normal.is_some());
                with_uv += usize::from(uv.is_some());
                with_rgb += usize::from(rgb.is_some());
                normals.push(normal.unwrap_or_default());
                uvs.push(uv.unwrap_or_default());
                let [r, g, b] = rgb.unwrap_or([1.0; 3]);
                colors.push([r, g, b, 1.0]);
            }
            Some(b"Face") => {
                let id_token = toks.next().unwrap_or_default();
                parse_i64(id_token, ln, "the face id")?;
                corners.clear();
                for t in toks {
                    let id = parse_i64(t, ln, "a vertex id")?;
                    let found = u64::try_from(id)
                        .ok()
                        .and_then(|id| index_of.get(&id).copied());
                    match found {
                        Some(i) => corners.push(i),
                        None => {
                            return Err(FormatError::new(
                                Location::Line(ln),
                                format!("face refers to vertex id {id}, which is not defined"),
                            ))
                        }
                    }
                }
                if corners.len() < 3 {
                    return Err(FormatError::new(
                        Location::Line(ln),
                        format!(
                            "a face needs at least 3 vertices, this one has {}",
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
            _ => {}
        }
    }
    if positions.is_empty() {
        return Err(FormatError::new(
            Location::File,
            "no 'Vertex' lines: empty or not a Hoppe .m file",
        ));
    }
    let all = |count: usize| count == positions.len();
    Ok(Mesh {
        attributes: VertexAttributes {
            normals: all(with_normal).then_some(normals),
            uv0: all(with_uv).then_some(uvs),
            colors: all(with_rgb).then_some(colors),
            ..VertexAttributes::default()
        },
        positions,
        triangles,
        groups: None,
        group_names: Vec::new(),
    })
}

/// Splits a line into the part before `{` and the inside of the braces (empty when
/// there are none).
fn split_braces(line: &[u8], ln: u64) -> Result<(&[u8], &[u8]), FormatError> {
    let Some(open) = line.iter().position(|&b| b == b'{') else {
        return Ok((line, &[]));
    };
    let head = line.get(..open).unwrap_or_default();
    let rest = line.get(open + 1..).unwrap_or_default();
    match rest.iter().rposition(|&b| b == b'}') {
        Some(close) => Ok((head, rest.get(..close).unwrap_or_default())),
        None => Err(FormatError::new(
            Location::Line(ln),
            "'{' without a closing '}'",
        )),
    }
}

/// A vertex id: a positive integer.
fn parse_id(token: &[u8], ln: u64) -> Result<u64, FormatError> {
    let id = parse_i64(token, ln, "the vertex id")?;
    u64::try_from(id).ok().filter(|&i| i > 0).ok_or_else(|| {
        FormatError::new(
            Location::Line(ln),
            format!("vertex id {id} is not a positive integer"),
        )
    })
}

/// Parses finite numbers into `out`; returns how many tokens there were (more than
/// `N` is reported as `N + 1`).
fn parse_floats<'a, const N: usize>(
    toks: &mut impl Iterator<Item = &'a [u8]>,
    ln: u64,
    what: &str,
    out: &mut [f32; N],
) -> Result<usize, FormatError> {
    for (n, slot) in out.iter_mut().enumerate() {
        let Some(t) = toks.next() else {
            return Ok(n);
        };
        let v = parse_f32(t, ln, what)?;
        if !v.is_finite() {
            return Err(FormatError::new(
                Location::Line(ln),
                format!("{what} is not finite ('{}')", show(t)),
            ));
        }
        *slot = v;
    }
    Ok(N)
}

/// The `N` numbers of an attribute value `(a b c)`.
fn attr_values<const N: usize>(value: &[u8], ln: u64, key: &str) -> Result<[f32; N], FormatError> {
    let inner = value
        .strip_prefix(b"(")
        .and_then(|v| v.strip_suffix(b")"))
        .ok_or_else(|| {
            FormatError::new(
                Location::Line(ln),
                format!(
                    "'{key}=' needs a value in parentheses, found '{}'",
                    show(value)
                ),
            )
        })?;
    let mut out = [0f32; N];
    let mut toks = tokens(inner);
    let n = parse_floats(&mut toks, ln, key, &mut out)?;
    if n != N || toks.next().is_some() {
        return Err(FormatError::new(
            Location::Line(ln),
            format!("'{key}=' needs {N} numbers, found '{}'", show(value)),
        ));
    }
    Ok(out)
}

/// `key=value` pairs (and bare flags, with an empty value) inside braces. A value is
/// `(...)`, `"..."` or a word.
struct Attributes<'a> {
    s: &'a [u8],
    i: usize,
}

impl<'a> Attributes<'a> {
    fn new(s: &'a [u8]) -> Self {
        Self { s, i: 0 }
    }

    /// Advances while `pred` holds; returns the new position.
    fn skip(&mut self, pred: impl Fn(u8) -> bool) -> usize {
        while self.s.get(self.i).is_some_and(|&b| pred(b)) {
            self.i += 1;
        }
        self.i
    }
}

impl<'a> Iterator for Attributes<'a> {
    type Item = (&'a [u8], &'a [u8]);

    fn next(&mut self) -> Option<Self::Item> {
        self.skip(|b| b.is_ascii_whitespace());
        let start = self.i;
        let end = self.skip(|b| !b.is_ascii_whitespace() && b != b'=');
        if start == end && self.s.get(self.i) != Some(&b'=') {
            return None;
        }
        let key = self.s.get(start..end).unwrap_or_default();
        if self.s.get(self.i) != Some(&b'=') {
            return Some((key, &[]));
        }
        self.i += 1;
        let vstart = self.i;
        let vend = match self.s.get(vstart) {
            Some(b'(') => {
                self.skip(|b| b != b')');
                // Include the ')' when there is one.
                self.i = (self.i + 1).min(self.s.len());
                self.i
            }
            Some(b'"') => {
                self.i += 1;
                self.skip(|b| b != b'"');
                self.i = (self.i + 1).min(self.s.len());
                self.i
            }
            _ => self.skip(|b| !b.is_ascii_whitespace()),
        };
        Some((key, self.s.get(vstart..vend).unwrap_or_default()))
    }
}

/// Writes `mesh` as a Hoppe `.m` file: `Vertex` lines (ids from 1) with `normal=`,
/// `uv=` and `rgb=` attributes as present, then one `Face` per triangle.
///
/// # Errors
/// [`FormatError`] when the mesh is invalid (an index out of range, attribute streams
/// of the wrong length) or holds a NaN or infinite value.
pub fn write(mesh: &Mesh, out: &mut Vec<u8>) -> Result<(), FormatError> {
    check_writable(mesh)?;
    let a = &mesh.attributes;
    out.reserve(mesh.positions.len() * 48 + mesh.triangles.len() * 32);
    for (i, p) in mesh.positions.iter().enumerate() {
        out.extend_from_slice(b"Vertex ");
        push_u64(out, i as u64 + 1);
        out.push(b' ');
        push_floats(out, p);
        let normal = a.normals.as_ref().and_then(|n| n.get(i));
        let uv = a.uv0.as_ref().and_then(|t| t.get(i));
        let rgb = a.colors.as_ref().and_then(|c| c.get(i));
        if normal.is_some() || uv.is_some() || rgb.is_some() {
            out.extend_from_slice(b" {");
            let mut sep = "";
            let mut attr = |out: &mut Vec<u8>, key: &str, values: &[f32]| {
                out.extend_from_slice(sep.as_bytes());
                out.extend_from_slice(key.as_bytes());
                out.extend_from_slice(b"=(");
                if let [first, rest @ ..] = values {
                    push_f32(out, *first);
                    push_floats(out, rest);
                }
                out.push(b')');
                sep = " ";
            };
            if let Some(n) = normal {
                attr(out, "normal", n);
            }
            if let Some(t) = uv {
                attr(out, "uv", t);
            }
            if let Some(c) = rgb {
                attr(out, "rgb", &c[..3]);
            }
            out.push(b'}');
        }
        out.push(b'\n');
    }
    for (k, t) in mesh.triangles.iter().enumerate() {
        out.extend_from_slice(b"Face ");
        push_u64(out, k as u64 + 1);
        out.push(b' ');
        for &i in t {
            out.push(b' ');
            push_u64(out, u64::from(i) + 1);
        }
        out.push(b'\n');
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
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

    // 40 ─ 30
    // │  ╲ │    sparse vertex ids; one quad face (10 20 30 40) fanned from 10,
    // 10 ─ 20   and a triangle (20 50 30) on the right
    //        ╲ 50
    const SPARSE: &str = "# Created by hand {with braces\n\
        Vertex 10  0 0 0\nVertex 20  1 0 0\nVertex 30 1 1 0\nVertex 40 0 1 0\n\
        Vertex 50 2 0.5 0\n\
        Face 1  10 20 30 40\nFace 7 20 50 30 {rgb=(1 0 0)}\n\
        Corner 10 1 {normal=(0 0 1)}\nEdge 10 20 {sharp}\nUnknown line here\n";

    #[test]
    fn sparse_ids_map_to_dense_indices_in_order() {
        let m = mesh(SPARSE);
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[4], [2.0, 0.5, 0.0]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [1, 4, 2]]);
        assert!(m.attributes.is_empty());
        assert_eq!(m.groups, None);
    }

    #[test]
    fn vertex_attributes_when_every_vertex_has_them() {
        let m = mesh(
            "Vertex 1 0 0 0 {normal=(0 0 1) uv=(0.5 0.25) rgb=(1 0 0) wid=3 sharp}\n\
             Vertex 2 1 0 0 {rgb=(0 1 0) normal=(0 1e-05 1) uv=(1 0)}\n\
             Vertex 3 0 1 0 {normal=(0 1 0) uv=(0 1) rgb=(0 0 1) name=\"a b\"}\n\
             Face 1 1 2 3\n",
        );
        assert_eq!(
            m.attributes.normals,
            Some(vec![[0.0, 0.0, 1.0], [0.0, 1e-5, 1.0], [0.0, 1.0, 0.0]])
        );
        assert_eq!(
            m.attributes.uv0,
            Some(vec![[0.5, 0.25], [1.0, 0.0], [0.0, 1.0]])
        );
        assert_eq!(
            m.attributes.colors,
            Some(vec![
                [1.0, 0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0, 1.0],
                [0.0, 0.0, 1.0, 1.0]
            ])
        );
    }

    #[test]
    fn partial_attributes_are_dropped() {
        // Vertex 1 has no normal (like cessna.orig.m, whose sharp vertices carry
        // corner normals instead): no normals at all.
        let m = mesh(
            "Vertex 1 0 0 0\nVertex 2 1 0 0 {normal=(0 0 1)}\n\
             Vertex 3 0 1 0 {normal=(0 0 1)}\nFace 1 1 2 3\n",
        );
        assert_eq!(m.attributes.normals, None);
    }

    #[test]
    fn crlf_and_leading_blanks() {
        let m =
            mesh("  Vertex 1 0 0 0\r\nVertex 2 1 0 0\r\n\r\nVertex 3 0 1 0\r\n\tFace 1 1 2 3\r\n");
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        assert_eq!(m.positions[2], [0.0, 1.0, 0.0]);
    }

    #[test]
    fn errors_name_the_line() {
        let base = "Vertex 1 0 0 0\nVertex 2 1 0 0\nVertex 3 0 1 0\n";
        let cases: &[(&str, &str)] = &[
            ("Face 1 1 2 4\n", "vertex id 4, which is not defined"),
            ("Face 1 1 2 -3\n", "vertex id -3"),
            ("Face 1 1 2\n", "at least 3 vertices, this one has 2"),
            ("Face 1 1 2 x\n", "expected an integer"),
            ("Face x 1 2 3\n", "the face id"),
            ("Vertex 1 5 5 5\n", "vertex id 1 is defined twice"),
            ("Vertex 0 5 5 5\n", "not a positive integer"),
            ("Vertex -2 5 5 5\n", "not a positive integer"),
            ("Vertex 4 5 5\n", "needs exactly three coordinates"),
            ("Vertex 4 5 5 5 5\n", "needs exactly three coordinates"),
            ("Vertex 4 5 5 x\n", "expected a number"),
            ("Vertex 4 5 nan 5\n", "not finite"),
            ("Vertex 4 5 5 5 {normal=(0 0 1)\n", "without a closing"),
            ("Vertex 4 5 5 5 {normal=(0 1)}\n", "needs 3 numbers"),
            ("Vertex 4 5 5 5 {normal=(0 1 2 3)}\n", "needs 3 numbers"),
            ("Vertex 4 5 5 5 {normal=(0 1 inf)}\n", "not finite"),
            ("Vertex 4 5 5 5 {uv=0.5}\n", "in parentheses"),
            ("Vertex 4 5 5 5 {rgb=(1 0 z)}\n", "expected a number"),
        ];
        for (line, message) in cases {
            let e = err(&format!("{base}{line}"));
            assert_eq!(e.location, Location::Line(4), "{line}");
            assert!(e.message.contains(message), "{line}: {}", e.message);
        }
    }

    #[test]
    fn faces_must_follow_their_vertices() {
        let e = err("Vertex 1 0 0 0\nVertex 2 1 0 0\nFace 1 1 2 3\nVertex 3 0 1 0\n");
        assert_eq!(e.location, Location::Line(3));
    }

    #[test]
    fn empty_files_are_refused() {
        for src in ["", "# nothing\n", "Face 1 1 2 3\n"] {
            assert!(read(src.as_bytes()).is_err(), "{src}");
        }
        assert_eq!(err("# nothing\nEdge 1 2\n").location, Location::File);
        // Vertices without faces are a valid point set.
        assert_eq!(mesh("Vertex 5 1 2 3\n").positions, vec![[1.0, 2.0, 3.0]]);
    }

    #[test]
    fn writer_exact_text() {
        let mut m = Mesh::from_triangles(
            vec![[0.0, 0.0, 0.0], [1.5, 0.0, -0.0], [0.0, 0.1, 1e-7]],
            vec![[0, 1, 2], [2, 1, 0]],
        );
        assert_eq!(
            written(&m),
            "Vertex 1  0 0 0\nVertex 2  1.5 0 -0\nVertex 3  0 0.1 1e-7\n\
             Face 1  1 2 3\nFace 2  3 2 1\n"
        );
        m.attributes.normals = Some(vec![[0.0, 0.0, 1.0]; 3]);
        m.attributes.uv0 = Some(vec![[0.5, 1.0]; 3]);
        m.attributes.colors = Some(vec![[1.0, 0.25, 0.0, 0.5]; 3]);
        assert!(
            written(&m).starts_with("Vertex 1  0 0 0 {normal=(0 0 1) uv=(0.5 1) rgb=(1 0.25 0)}\n")
        );
    }

    #[test]
    fn writer_refuses_non_finite() {
        let mut m = Mesh::from_triangles(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        );
        m.attributes.colors = Some(vec![[1.0; 4], [f32::NAN; 4], [1.0; 4]]);
        assert_eq!(
            write(&m, &mut Vec::new()).unwrap_err().location,
            Location::Element("vertex", 1)
        );
    }

    fn finite() -> impl Strategy<Value = f32> {
        any::<f32>().prop_filter("finite", |x| x.is_finite())
    }

    prop_compose! {
        fn random_mesh()(n in 1usize..24)(
            positions in prop::collection::vec([finite(), finite(), finite()], n),
            triangles in prop::collection::vec([0..n as u32, 0..n as u32, 0..n as u32], 0..40),
            uv in prop::option::of(prop::collection::vec([finite(), finite()], n)),
            normals in prop::option::of(prop::collection::vec([finite(), finite(), finite()], n)),
            colors in prop::option::of(prop::collection::vec([finite(), finite(), finite()], n)),
        ) -> Mesh {
            Mesh {
                positions,
                triangles,
                attributes: VertexAttributes {
                    uv0: uv,
                    normals,
                    colors: colors.map(|c| c.into_iter().map(|[r, g, b]| [r, g, b, 1.0]).collect()),
                    ..VertexAttributes::default()
                },
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
            let bits = |m: &Mesh| m.positions.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
            prop_assert_eq!(bits(&back), bits(&m));
        }

        #[test]
        fn never_panics_on_garbage(data in prop::collection::vec(any::<u8>(), 0..200)) {
            let _ = read(&data);
        }

        #[test]
        fn never_panics_on_mutated_file(cut in 0usize..300, byte in any::<u8>(), at in 0usize..300) {
            let mut data = SPARSE.as_bytes().to_vec();
            if let Some(b) = data.get_mut(at) {
                *b = byte;
            }
            data.truncate(cut.max(1));
            let _ = read(&data);
        }
    }
}
