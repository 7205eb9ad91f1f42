//! STL ("stereolithography", 3D Systems 1989) reader and writer, binary and ASCII.
//!
//! Follows the format as 3D Systems' "StereoLithography Interface Specification"
//! (1989) defines it:
//!
//! - binary: an 80-byte header (free text), a little-endian `u32` triangle count,
//!   then per triangle 50 bytes: normal (3 × `f32`), three vertices (9 × `f32`) and a
//!   `u16` "attribute byte count";
//! - ASCII: `solid NAME`, then per triangle
//!   `facet normal nx ny nz / outer loop / vertex x y z (×3) / endloop / endfacet`,
//!   and `endsolid NAME`. Several solids may follow each other; keywords are matched
//!   case-insensitively and may be split over lines in any way.
//!
//! Telling the two apart: a file whose length is exactly `84 + 50·n` (with `n` the
//! count at byte 80) is binary even when its header starts with `solid`, as many
//! exporters write; otherwise a file starting with `solid` and free of NUL bytes in
//! its first kilobyte is ASCII; anything else is binary. Bytes after the last binary
//! triangle are ignored.
//!
//! STL stores every triangle with its own three corners. The reader welds corners
//! with bitwise-equal positions ([`Weld::exact`], `-0.0` equal to `0.0`) so the result
//! is an indexed mesh; vertices are numbered in order of first appearance. The file's
//! facet normals are checked for syntax but not kept: they are per face, not per
//! vertex, and many exporters write zeros. The binary attribute bytes (sometimes a
//! colour) are ignored. A non-standard ASCII `outer loop` with more than three
//! vertices is fan-triangulated.
//!
//! The writer produces binary (or ASCII) STL with facet normals computed from the
//! geometry (unit length; zero for degenerate triangles). The binary header never
//! starts with `solid`, so readers cannot mistake it for ASCII.

use super::stream_base::{Sink, Source, StreamError};
use super::text::{self, Lines};
use super::{max_elements, FormatError, Location};
use crate::mesh::{Mesh, Weld};

/// Reads a binary or ASCII STL file from memory and welds it into an indexed mesh.
///
/// # Errors
/// [`FormatError`]: an empty file; a binary file too short for its header, whose
/// triangle count is more than the file holds (`Location::Byte` of the first
/// incomplete triangle) or with a non-finite coordinate (`Location::Byte` of the
/// triangle); an ASCII file with an unexpected keyword, a malformed or non-finite
/// number, a loop with fewer than three vertices, or that ends inside a solid
/// (`Location::Line`).
pub fn read(data: &[u8]) -> Result<Mesh, FormatError> {
    if data.is_empty() {
        return Err(FormatError::new(Location::File, "empty file"));
    }
    let soup = if is_ascii(data) {
        read_ascii(data)?
    } else {
        read_binary(data)?
    };
    Ok(weld(&soup))
}

/// Writes `mesh` as STL: binary, or ASCII when `ascii` is true. Only positions are
/// written; facet normals are computed from them.
///
/// # Errors
/// [`FormatError`] (at `Location::File`) when the mesh is invalid (an index out of
/// range, a non-finite coordinate), or has more triangles than the binary count
/// (`u32`) can hold.
pub fn write(mesh: &Mesh, ascii: bool, out: &mut Vec<u8>) -> Result<(), FormatError> {
    mesh.validate().map_err(|e| {
        FormatError::new(Location::File, format!("cannot write an invalid mesh: {e}"))
    })?;
    let corners =
        |t: &[u32; 3]| t.map(|v| mesh.positions.get(v as usize).copied().unwrap_or([0.0; 3]));
    if ascii {
        out.reserve(mesh.triangles.len() * 250 + 40);
        out.extend_from_slice(b"solid meshlod\n");
        for t in &mesh.triangles {
            let c = corners(t);
            out.extend_from_slice(b"  facet normal ");
            push_xyz(out, facet_normal(&c));
            out.extend_from_slice(b"\n    outer loop\n");
            for p in c {
                out.extend_from_slice(b"      vertex ");
                push_xyz(out, p);
                out.push(b'\n');
            }
            out.extend_from_slice(b"    endloop\n  endfacet\n");
        }
        out.extend_from_slice(b"endsolid meshlod\n");
        return Ok(());
    }
    let count = u32::try_from(mesh.triangles.len()).map_err(|_| {
        FormatError::new(
            Location::File,
            format!(
                "{} triangles are more than binary STL can count (at most {})",
                mesh.triangles.len(),
                u32::MAX
            ),
        )
    })?;
    out.reserve(84 + 50 * mesh.triangles.len());
    let mut header = [b' '; 80];
    let label = b"binary STL written by meshlod";
    header
        .iter_mut()
        .zip(label)
        .for_each(|(slot, &b)| *slot = b);
    out.extend_from_slice(&header);
    out.extend_from_slice(&count.to_le_bytes());
    for t in &mesh.triangles {
        let c = corners(t);
        for v in std::iter::once(facet_normal(&c)).chain(c) {
            v.iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        }
        out.extend_from_slice(&[0, 0]);
    }
    Ok(())
}

/// The unit normal of a triangle (right-hand rule), zero when it is degenerate.
fn facet_normal(c: &[[f32; 3]; 3]) -> [f32; 3] {
    let d = |i: usize, k: usize| f64::from(c[i][k]) - f64::from(c[0][k]);
    let (u, v) = ([d(1, 0), d(1, 1), d(1, 2)], [d(2, 0), d(2, 1), d(2, 2)]);
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len > 0.0 && len.is_finite() {
        n.map(|x| (x / len) as f32)
    } else {
        [0.0; 3]
    }
}

fn push_xyz(out: &mut Vec<u8>, p: [f32; 3]) {
    for (k, v) in p.into_iter().enumerate() {
        if k > 0 {
            out.push(b' ');
        }
        super::ply::push_f32(out, v);
    }
}

/// True when `data` is to be read as ASCII STL (see the module documentation).
fn is_ascii(data: &[u8]) -> bool {
    if let Some(n) = binary_count(data) {
        if 84 + 50 * n == data.len() as u64 {
            return false;
        }
    }
    let start = data
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(data.len());
    let begins_solid = data
        .get(start..start + 5)
        .is_some_and(|w| w.eq_ignore_ascii_case(b"solid"));
    begins_solid && !data.iter().take(1024).any(|&b| b == 0)
}

/// The triangle count of a binary header, if the file is long enough to have one.
fn binary_count(data: &[u8]) -> Option<u64> {
    let b: [u8; 4] = data.get(80..84)?.try_into().ok()?;
    Some(u64::from(u32::from_le_bytes(b)))
}

/// Triangle corners, three per triangle, before welding.
type Soup = Vec<[f32; 3]>;

fn read_binary(data: &[u8]) -> Result<Soup, FormatError> {
    let Some(n) = binary_count(data) else {
        return Err(FormatError::new(
            Location::Byte(data.len() as u64),
            format!(
                "the file has {} bytes: too short for a binary STL header (84 bytes) and it does not start with 'solid'",
                data.len()
            ),
        ));
    };
    let body = data.get(84..).unwrap_or_default();
    let fits = max_elements(body.len(), 50);
    if n > fits {
        return Err(FormatError::new(
            Location::Byte(84 + 50 * fits),
            format!(
                "the header says {n} triangles ({} bytes), but the file ends inside triangle {fits} ({} bytes)",
                84 + 50 * n,
                data.len()
            ),
        ));
    }
    // n ≤ fits ≤ data.len() / 50, so the allocation is bounded by the file size.
    let n = n as usize;
    let mut soup = Vec::with_capacity(3 * n);
    for (t, rec) in body.chunks_exact(50).take(n).enumerate() {
        for k in 0..3 {
            let at = 12 + 12 * k;
            let f = |j: usize| {
                rec.get(at + 4 * j..at + 4 * j + 4)
                    .and_then(|b| b.try_into().ok())
                    .map_or(f32::NAN, f32::from_le_bytes)
            };
            let p = [f(0), f(1), f(2)];
            if !p.iter().all(|v| v.is_finite()) {
                return Err(FormatError::new(
                    Location::Byte((84 + 50 * t + at) as u64),
                    format!(
                        "triangle {t} vertex {k} has a non-finite coordinate ({}, {}, {})",
                        p[0], p[1], p[2]
                    ),
                ));
            }
            soup.push(p);
        }
    }
    Ok(soup)
}

/// Whitespace-separated tokens across lines, with the line each comes from.
struct Tokens<'a> {
    lines: Lines<'a>,
    rest: &'a [u8],
}

impl<'a> Tokens<'a> {
    fn new(data: &'a [u8]) -> Self {
        Self {
            lines: Lines::new(data),
            rest: &[],
        }
    }

    fn line(&self) -> u64 {
        self.lines.line_number().max(1)
    }

    /// The next token, or `None` at the end of the file.
    fn next(&mut self) -> Option<&'a [u8]> {
        loop {
            let start = self.rest.iter().position(|b| !b.is_ascii_whitespace());
            if let Some(start) = start {
                let rest = self.rest.get(start..).unwrap_or_default();
                let end = rest
                    .iter()
                    .position(u8::is_ascii_whitespace)
                    .unwrap_or(rest.len());
                let (tok, after) = rest.split_at(end);
                self.rest = after;
                return Some(tok);
            }
            self.rest = self.lines.next()?;
        }
    }

    /// Drops the rest of the current line (a solid's name).
    fn skip_line(&mut self) {
        self.rest = &[];
    }

    /// The next token, which must be `word` (any case).
    fn expect(&mut self, word: &str, context: &str) -> Result<(), FormatError> {
        match self.next() {
            Some(t) if t.eq_ignore_ascii_case(word.as_bytes()) => Ok(()),
            Some(t) => Err(FormatError::new(
                Location::Line(self.line()),
                format!("expected '{word}' {context}, found '{}'", text::show(t)),
            )),
            None => Err(self.eof(&format!("'{word}' {context}"))),
        }
    }

    fn number(&mut self, what: &str) -> Result<f32, FormatError> {
        let t = self.next().ok_or_else(|| self.eof(what))?;
        text::parse_f32(t, self.line(), what)
    }

    fn eof(&self, expected: &str) -> FormatError {
        FormatError::new(
            Location::Line(self.line()),
            format!("the file ends where {expected} was expected"),
        )
    }
}

fn read_ascii(data: &[u8]) -> Result<Soup, FormatError> {
    let mut toks = Tokens::new(data);
    let mut soup = Vec::new();
    let mut facet = 0usize;
    let mut loop_corners: Vec<[f32; 3]> = Vec::with_capacity(3);
    while let Some(t) = toks.next() {
        if !t.eq_ignore_ascii_case(b"solid") {
            return Err(FormatError::new(
                Location::Line(toks.line()),
                format!("expected 'solid', found '{}'", text::show(t)),
            ));
        }
        toks.skip_line();
        loop {
            let Some(t) = toks.next() else {
                return Err(toks.eof("'facet' or 'endsolid'"));
            };
            if t.eq_ignore_ascii_case(b"endsolid") {
                toks.skip_line();
                break;
            }
            if !t.eq_ignore_ascii_case(b"facet") {
                return Err(FormatError::new(
                    Location::Line(toks.line()),
                    format!("expected 'facet' or 'endsolid', found '{}'", text::show(t)),
                ));
            }
            toks.expect("normal", "after 'facet'")?;
            for _ in 0..3 {
                // The file's normal is read for syntax only (see the module docs).
                toks.number("a facet normal component")?;
            }
            toks.expect("outer", "after the facet normal")?;
            toks.expect("loop", "after 'outer'")?;
            loop_corners.clear();
            loop {
                let Some(t) = toks.next() else {
                    return Err(toks.eof("'vertex' or 'endloop'"));
                };
                if t.eq_ignore_ascii_case(b"endloop") {
                    break;
                }
                if !t.eq_ignore_ascii_case(b"vertex") {
                    return Err(FormatError::new(
                        Location::Line(toks.line()),
                        format!("expected 'vertex' or 'endloop', found '{}'", text::show(t)),
                    ));
                }
                let p = [
                    toks.number("a vertex x coordinate")?,
                    toks.number("a vertex y coordinate")?,
                    toks.number("a vertex z coordinate")?,
                ];
                if !p.iter().all(|v| v.is_finite()) {
                    return Err(FormatError::new(
                        Location::Line(toks.line()),
                        format!(
                            "facet {facet} has a non-finite vertex coordinate ({}, {}, {})",
                            p[0], p[1], p[2]
                        ),
                    ));
                }
                loop_corners.push(p);
            }
            if loop_corners.len() < 3 {
                return Err(FormatError::new(
                    Location::Line(toks.line()),
                    format!(
                        "facet {facet} has {} vertices; a facet needs 3",
                        loop_corners.len()
                    ),
                ));
            }
            if let Some((&first, rest)) = loop_corners.split_first() {
                for pair in rest.windows(2) {
                    if let [b, c] = pair {
                        soup.extend_from_slice(&[first, *b, *c]);
                    }
                }
            }
            toks.expect("endfacet", "after 'endloop'")?;
            facet += 1;
        }
    }
    Ok(soup)
}

/// Streams an STL file triangle by triangle (see [`super::stream`]): the same
/// binary/ASCII decision, triangles and errors as [`read`], without welding.
pub(crate) fn stream<R: std::io::Read>(
    src: &mut Source<R>,
    file_len: u64,
    sink: &mut Sink<'_>,
) -> Result<(), StreamError> {
    if file_len == 0 || !src.ensure(1)? {
        return Err(FormatError::new(Location::File, "empty file").into());
    }
    src.ensure(1024)?;
    let head = src.bytes();
    let ascii = {
        let binary_exact = binary_count(head).is_some_and(|n| 84 + 50 * n == file_len);
        let start = head
            .iter()
            .position(|b| !b.is_ascii_whitespace())
            .unwrap_or(head.len());
        let begins_solid = head
            .get(start..start + 5)
            .is_some_and(|w| w.eq_ignore_ascii_case(b"solid"));
        !binary_exact && begins_solid && !head.iter().take(1024).any(|&b| b == 0)
    };
    if ascii {
        return stream_ascii(src, sink);
    }
    if !src.ensure(84)? {
        return Err(FormatError::new(
            Location::Byte(file_len),
            format!(
                "the file has {file_len} bytes: too short for a binary STL header (84 bytes) and it does not start with 'solid'"
            ),
        )
        .into());
    }
    let n = binary_count(src.bytes()).unwrap_or(0);
    let fits = file_len.saturating_sub(84) / 50;
    if n > fits {
        return Err(FormatError::new(
            Location::Byte(84 + 50 * fits),
            format!(
                "the header says {n} triangles ({} bytes), but the file ends inside triangle {fits} ({file_len} bytes)",
                84 + 50 * n,
            ),
        )
        .into());
    }
    src.consume(84);
    for t in 0..n {
        if !src.ensure(50)? {
            return Err(FormatError::new(
                Location::Byte(src.offset()),
                format!("the file ends inside triangle {t} of {n}"),
            )
            .into());
        }
        let rec = src.bytes();
        let mut tri = [[0f32; 3]; 3];
        for (k, corner) in tri.iter_mut().enumerate() {
            let at = 12 + 12 * k;
            for (j, c) in corner.iter_mut().enumerate() {
                let o = at + 4 * j;
                *c = rec
                    .get(o..o + 4)
                    .and_then(|b| b.try_into().ok())
                    .map_or(f32::NAN, f32::from_le_bytes);
            }
            if !corner.iter().all(|v| v.is_finite()) {
                return Err(FormatError::new(
                    Location::Byte(84 + 50 * t + at as u64),
                    format!(
                        "triangle {t} vertex {k} has a non-finite coordinate ({}, {}, {})",
                        corner[0], corner[1], corner[2]
                    ),
                )
                .into());
            }
        }
        for p in &tri {
            sink.vertex(*p);
        }
        sink.triangle(&tri, 0);
        src.consume(50);
    }
    Ok(())
}

/// Whitespace tokens of a streamed text file, one owned token at a time.
struct StreamTokens {
    line: Vec<u8>,
    pos: usize,
    number: u64,
    token: Vec<u8>,
}

impl StreamTokens {
    /// Reads the next token into `self.token`; false at the end of the file.
    fn next<R: std::io::Read>(&mut self, src: &mut Source<R>) -> Result<bool, StreamError> {
        loop {
            let rest = self.line.get(self.pos..).unwrap_or_default();
            if let Some(s) = rest.iter().position(|b| !b.is_ascii_whitespace()) {
                let r = &rest[s..];
                let e = r
                    .iter()
                    .position(u8::is_ascii_whitespace)
                    .unwrap_or(r.len());
                self.token.clear();
                self.token.extend_from_slice(&r[..e]);
                self.pos += s + e;
                return Ok(true);
            }
            if !src.line(&mut self.line)? {
                return Ok(false);
            }
            self.pos = 0;
            self.number += 1;
        }
    }

    fn is(&self, word: &str) -> bool {
        self.token.eq_ignore_ascii_case(word.as_bytes())
    }

    fn expect<R: std::io::Read>(
        &mut self,
        src: &mut Source<R>,
        word: &str,
        context: &str,
    ) -> Result<(), StreamError> {
        if !self.next(src)? {
            return Err(self.eof(&format!("'{word}' {context}")));
        }
        if self.is(word) {
            Ok(())
        } else {
            Err(FormatError::new(
                Location::Line(self.number.max(1)),
                format!(
                    "expected '{word}' {context}, found '{}'",
                    text::show(&self.token)
                ),
            )
            .into())
        }
    }

    fn number<R: std::io::Read>(
        &mut self,
        src: &mut Source<R>,
        what: &str,
    ) -> Result<f32, StreamError> {
        if !self.next(src)? {
            return Err(self.eof(what));
        }
        Ok(text::parse_f32(&self.token, self.number.max(1), what)?)
    }

    fn eof(&self, expected: &str) -> StreamError {
        FormatError::new(
            Location::Line(self.number.max(1)),
            format!("the file ends where {expected} was expected"),
        )
        .into()
    }

    fn unexpected(&self, expected: &str) -> StreamError {
        FormatError::new(
            Location::Line(self.number.max(1)),
            format!("expected {expected}, found '{}'", text::show(&self.token)),
        )
        .into()
    }
}

fn stream_ascii<R: std::io::Read>(
    src: &mut Source<R>,
    sink: &mut Sink<'_>,
) -> Result<(), StreamError> {
    let mut toks = StreamTokens {
        line: Vec::new(),
        pos: 0,
        number: 0,
        token: Vec::new(),
    };
    let mut facet = 0usize;
    let mut corners: Vec<[f32; 3]> = Vec::with_capacity(3);
    while toks.next(src)? {
        if !toks.is("solid") {
            return Err(toks.unexpected("'solid'"));
        }
        toks.pos = toks.line.len();
        loop {
            if !toks.next(src)? {
                return Err(toks.eof("'facet' or 'endsolid'"));
            }
            if toks.is("endsolid") {
                toks.pos = toks.line.len();
                break;
            }
            if !toks.is("facet") {
                return Err(toks.unexpected("'facet' or 'endsolid'"));
            }
            toks.expect(src, "normal", "after 'facet'")?;
            for _ in 0..3 {
                toks.number(src, "a facet normal component")?;
            }
            toks.expect(src, "outer", "after the facet normal")?;
            toks.expect(src, "loop", "after 'outer'")?;
            corners.clear();
            loop {
                if !toks.next(src)? {
                    return Err(toks.eof("'vertex' or 'endloop'"));
                }
                if toks.is("endloop") {
                    break;
                }
                if !toks.is("vertex") {
                    return Err(toks.unexpected("'vertex' or 'endloop'"));
                }
                let p = [
                    toks.number(src, "a vertex x coordinate")?,
                    toks.number(src, "a vertex y coordinate")?,
                    toks.number(src, "a vertex z coordinate")?,
                ];
                if !p.iter().all(|v| v.is_finite()) {
                    return Err(FormatError::new(
                        Location::Line(toks.number.max(1)),
                        format!(
                            "facet {facet} has a non-finite vertex coordinate ({}, {}, {})",
                            p[0], p[1], p[2]
                        ),
                    )
                    .into());
                }
                corners.push(p);
            }
            if corners.len() < 3 {
                return Err(FormatError::new(
                    Location::Line(toks.number.max(1)),
                    format!(
                        "facet {facet} has {} vertices; a facet needs 3",
                        corners.len()
                    ),
                )
                .into());
            }
            for k in 1..corners.len() - 1 {
                let t = [corners[0], corners[k], corners[k + 1]];
                for p in &t {
                    sink.vertex(*p);
                }
                sink.triangle(&t, 0);
            }
            toks.expect(src, "endfacet", "after 'endloop'")?;
            facet += 1;
        }
    }
    Ok(())
}

/// Welds triangle corners into an indexed mesh.
fn weld(soup: &[[f32; 3]]) -> Mesh {
    let w = Weld::exact(soup);
    let positions = w
        .representative
        .iter()
        .map(|&i| soup.get(i as usize).copied().unwrap_or([0.0; 3]))
        .collect();
    let triangles = w
        .point_of
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    Mesh::from_triangles(positions, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::test_support::corrupted;
    use proptest::prelude::*;

    fn err(data: &[u8]) -> FormatError {
        match read(data) {
            Ok(m) => panic!("expected an error, read {m:?}"),
            Err(e) => e,
        }
    }

    /// A binary STL with `header` (padded to 80 bytes), the given count and records
    /// made of the triangles' corners (normals zero, attribute 0).
    fn binary(header: &[u8], count: u32, tris: &[[[f32; 3]; 3]]) -> Vec<u8> {
        let mut out = header.to_vec();
        out.resize(80, b' ');
        out.extend_from_slice(&count.to_le_bytes());
        for t in tris {
            out.extend_from_slice(&[0; 12]);
            for v in t.iter().flatten() {
                out.extend_from_slice(&v.to_le_bytes());
            }
            out.extend_from_slice(&[0, 0]);
        }
        out
    }

    const A: [f32; 3] = [0.0, 0.0, 0.0];
    const B: [f32; 3] = [1.0, 0.0, 0.0];
    const C: [f32; 3] = [0.0, 1.0, 0.0];
    const D: [f32; 3] = [0.0, 0.0, 1.0];

    // Two solids (one in capitals, one split oddly over lines) sharing corners:
    // the corners are welded into 4 vertices.
    #[test]
    fn ascii_two_solids_welded() {
        let data = b"solid first one\n\
  facet normal 0 0 -1\n    outer loop\n      vertex 0 0 0\n      vertex 0 1 0\n      vertex 1 0 0\n    endloop\n  endfacet\n\
endsolid first one\r\n\
SOLID second\r\nFACET NORMAL 0 0 0 OUTER LOOP\r\nVERTEX 0 0 0 VERTEX 1 0 0\r\nvertex 0 0 1e0\r\nENDLOOP ENDFACET\r\n\
endsolid\n";
        let m = read(data).unwrap();
        assert_eq!(m.positions, vec![A, C, B, D]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(m.attributes.is_empty());
    }

    // A non-standard loop of four vertices becomes a fan of two triangles.
    #[test]
    fn ascii_quad_loop() {
        let data = b"solid q\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid q\n";
        let m = read(data).unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        // An empty solid is an empty mesh.
        assert_eq!(
            read(b"solid empty\nendsolid empty\n").unwrap(),
            Mesh::default()
        );
    }

    // A binary file whose header starts with "solid" is recognised by its size.
    #[test]
    fn binary_with_solid_header() {
        let data = binary(b"solid but binary", 2, &[[A, B, C], [A, C, D]]);
        let m = read(&data).unwrap();
        assert_eq!(m.positions, vec![A, B, C, D]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        // -0.0 welds with 0.0.
        let data = binary(b"x", 2, &[[A, B, C], [[-0.0, 0.0, -0.0], C, D]]);
        assert_eq!(read(&data).unwrap().triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    // Bytes after the last triangle are ignored (some exporters pad files).
    #[test]
    fn binary_trailing_bytes() {
        let mut data = binary(b"pad", 1, &[[A, B, C]]);
        data.extend_from_slice(&[0; 7]);
        assert_eq!(read(&data).unwrap().triangles, vec![[0, 1, 2]]);
        // Zero triangles.
        assert_eq!(read(&binary(b"none", 0, &[])).unwrap(), Mesh::default());
    }

    #[test]
    fn binary_errors() {
        assert_eq!(err(b"").location, Location::File);
        // Too short for a header and not ASCII.
        let e = err(b"garbage");
        assert_eq!(e.location, Location::Byte(7));
        assert!(e.message.contains("too short"), "{e}");
        // Header says 3 triangles, the file has 1 and a half.
        let mut data = binary(b"t", 3, &[[A, B, C]]);
        data.extend_from_slice(&[0; 25]);
        let e = err(&data);
        assert_eq!(e.location, Location::Byte(84 + 50));
        assert!(e.message.contains("header says 3 triangles"), "{e}");
        // An absurd count is refused without allocating.
        let e = err(&binary(b"t", u32::MAX, &[[A, B, C]]));
        assert!(e.message.contains("4294967295"), "{e}");
        // A NaN coordinate in triangle 1, vertex 2.
        let data = binary(b"n", 2, &[[A, B, C], [A, B, [0.0, f32::NAN, 0.0]]]);
        let e = err(&data);
        assert_eq!(e.location, Location::Byte(84 + 50 + 12 + 24));
        assert!(e.message.contains("triangle 1 vertex 2"), "{e}");
        // "solid" with NUL bytes early and a wrong size is binary, and truncated.
        let mut data = binary(b"solid x", 2, &[[A, B, C]]);
        data.push(0);
        assert!(matches!(err(&data).location, Location::Byte(134)));
    }

    #[test]
    fn ascii_errors() {
        let facet = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n";
        let cases: Vec<(String, u64, &str)> = vec![
            (format!("solid a\n{facet}"), 8, "'facet' or 'endsolid'"),
            (format!("solid a\n{facet}endsolid a\nfacet"), 10, "expected 'solid'"),
            ("solid a\nfacet normal 0 0\nouter loop\n".into(), 3, "a number for a facet normal"),
            ("solid a\nfacet 0 0 1\n".into(), 2, "expected 'normal'"),
            ("solid a\nfacet normal 0 0 1\ninner loop\n".into(), 3, "expected 'outer'"),
            ("solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid\n".into(), 6, "facet 0 has 2 vertices"),
            ("solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 zero\n".into(), 4, "a number for a vertex z"),
            ("solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 inf 0\n".into(), 4, "non-finite"),
            ("solid a\nfacet normal 0 0 1\nouter loop\nvertx 0 0 0\n".into(), 4, "expected 'vertex' or 'endloop'"),
            ("solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendsolid\n".into(), 8, "expected 'endfacet'"),
            ("solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0".into(), 4, "ends where a vertex z"),
        ];
        for (data, line, msg) in cases {
            let e = err(data.as_bytes());
            assert_eq!(e.location, Location::Line(line), "{e} for {data:?}");
            assert!(e.message.contains(msg), "{e} (wanted '{msg}')");
        }
    }

    // The writers: binary size and header, computed unit normals, ASCII layout.
    #[test]
    fn writers() {
        let m = Mesh::from_triangles(
            vec![A, [2.0, 0.0, 0.0], [0.0, 3.0, 0.0]],
            vec![[0, 1, 2], [0, 0, 1]],
        );
        let mut out = Vec::new();
        write(&m, false, &mut out).unwrap();
        assert_eq!(out.len(), 84 + 2 * 50);
        assert!(!out.starts_with(b"solid"));
        assert_eq!(out.get(80..84), Some(&2u32.to_le_bytes()[..]));
        let f = |at: usize| f32::from_le_bytes(out[at..at + 4].try_into().unwrap());
        assert_eq!([f(84), f(88), f(92)], [0.0, 0.0, 1.0]);
        // The degenerate triangle gets a zero normal.
        assert_eq!([f(134), f(138), f(142)], [0.0, 0.0, 0.0]);
        assert_eq!([f(84 + 12 + 12), f(84 + 12 + 16)], [2.0, 0.0]);

        let mut text = Vec::new();
        write(
            &Mesh::from_triangles(m.positions.clone(), vec![[0, 1, 2]]),
            true,
            &mut text,
        )
        .unwrap();
        assert_eq!(
            String::from_utf8(text).unwrap(),
            "solid meshlod\n  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      vertex 2 0 0\n      vertex 0 3 0\n    endloop\n  endfacet\nendsolid meshlod\n"
        );
        let bad = Mesh::from_triangles(vec![A], vec![[0, 1, 0]]);
        assert!(write(&bad, true, &mut Vec::new()).is_err());
    }

    // gears.stl of the shared test set (ASCII, 19426 triangles, 58278 corners of
    // which 48555 repeat a position); skipped where it is not present.
    #[test]
    fn shared_gears() {
        let Ok(data) = std::fs::read("/work/shared/meshes/vtk-data/gears.stl") else {
            eprintln!("skipping gears.stl: not found");
            return;
        };
        let m = read(&data).unwrap();
        assert_eq!(m.triangles.len(), 19426);
        assert_eq!(m.positions.len(), 58278 - 48555);
        // The same mesh through the binary writer and back.
        let mut out = Vec::new();
        write(&m, false, &mut out).unwrap();
        assert_eq!(read(&out).unwrap(), m);
    }

    // Throughput on a 1M-triangle binary STL (reading includes welding); run with
    // `cargo test --release -p meshlod --lib io::stl::tests::throughput -- --ignored --nocapture`.
    #[test]
    #[ignore = "measurement, run by hand in release"]
    fn throughput() {
        let side = 710u32;
        let positions: Vec<[f32; 3]> = (0..side * side)
            .map(|i| {
                [
                    (i % side) as f32 * 0.01,
                    (i / side) as f32 * 0.01,
                    (i % 7) as f32,
                ]
            })
            .collect();
        let mut triangles = Vec::new();
        for y in 0..side - 1 {
            for x in 0..side - 1 {
                let v = y * side + x;
                triangles.push([v, v + 1, v + side]);
                triangles.push([v + 1, v + side + 1, v + side]);
            }
        }
        let m = Mesh::from_triangles(positions, triangles);
        let mut out = Vec::new();
        write(&m, false, &mut out).unwrap();
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let t = std::time::Instant::now();
            let back = read(&out).unwrap();
            best = best.min(t.elapsed().as_secs_f64());
            assert_eq!(back.triangles.len(), m.triangles.len());
            assert_eq!(back.positions.len(), m.positions.len());
        }
        let t = std::time::Instant::now();
        let soup = read_binary(&out).unwrap();
        let parse = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let welded = Weld::exact(&soup);
        let weld_time = t.elapsed().as_secs_f64();
        assert_eq!(welded.point_count(), m.positions.len());
        eprintln!(
            "STL binary: parse {:.1} ms, weld {:.1} ms",
            parse * 1e3,
            weld_time * 1e3
        );
        eprintln!(
            "STL binary read + weld: {:.1} MB in {:.1} ms = {:.0} MB/s",
            out.len() as f64 / 1e6,
            best * 1e3,
            out.len() as f64 / 1e6 / best
        );
    }

    /// Triangles as sorted lists of corner bit patterns (zero sign ignored).
    fn triangle_set(m: &Mesh) -> Vec<[[u32; 3]; 3]> {
        let mut v: Vec<_> = m
            .triangles
            .iter()
            .map(|t| t.map(|i| m.positions[i as usize].map(|x| (x + 0.0).to_bits())))
            .collect();
        v.sort_unstable();
        v
    }

    fn arb_mesh() -> impl Strategy<Value = Mesh> {
        let coord = prop::num::f32::POSITIVE
            | prop::num::f32::NEGATIVE
            | prop::num::f32::NORMAL
            | prop::num::f32::SUBNORMAL
            | prop::num::f32::ZERO;
        (1usize..12, 0usize..20).prop_flat_map(move |(n, t)| {
            (
                prop::collection::vec(prop::array::uniform3(coord), n),
                prop::collection::vec(prop::array::uniform3(0..n as u32), t),
            )
                .prop_map(|(p, t)| Mesh::from_triangles(p, t))
        })
    }

    proptest! {
        #[test]
        fn round_trip(m in arb_mesh()) {
            for ascii in [false, true] {
                let mut out = Vec::new();
                write(&m, ascii, &mut out).unwrap();
                let back = read(&out).unwrap();
                prop_assert_eq!(triangle_set(&back), triangle_set(&m));
                // Welded: no two vertices share a position.
                prop_assert_eq!(Weld::exact(&back.positions).duplicate_count(), 0);
            }
        }

        #[test]
        fn no_panic_on_corrupted_files(
            m in arb_mesh(),
            ascii in any::<bool>(),
            edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
            cut in any::<prop::sample::Index>(),
        ) {
            let mut out = Vec::new();
            write(&m, ascii, &mut out).unwrap();
            let (out, keep) = corrupted(out, &edits, &cut);
            let _ = read(&out);
            let _ = read(&out[..keep]);
        }

        #[test]
        fn no_panic_on_garbage(body in prop::collection::vec(any::<u8>(), 0..300), solid in any::<bool>()) {
            let mut data = if solid { b"solid x\n".to_vec() } else { Vec::new() };
            data.extend_from_slice(&body);
            let _ = read(&data);
        }
    }
}
