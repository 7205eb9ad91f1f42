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
//!   order of appearance. A face must refer to vertices defined on earlier lines, a
//!   corner to a vertex and a face defined earlier. Faces are polygons,
//!   fan-triangulated around their first vertex; face attributes are ignored.
//! - Vertex attributes `normal=(x y z)`, `uv=(u v)` and `rgb=(r g b)` become normals,
//!   UVs and (opaque) colours. An attribute is kept when every vertex that a face uses
//!   has it (the others get a zero normal, zero UV or white); otherwise it is dropped.
//!   Other keys are skipped.
//! - `Corner v f {normal=(x y z)}` gives the normal of vertex `v` in face `f` (sharp
//!   edges: `cessna.orig.m` stores the normals of its crease vertices this way). A
//!   corner without its own normal takes its vertex's. When every corner has a normal,
//!   the mesh has normals: vertex `i` is `Vertex` line `i` with the normal of its
//!   first corner (its own normal when no face uses it), and corners with another normal
//!   become extra vertices after all `Vertex` lines, one per distinct normal. Other
//!   corner attributes are ignored.
//! - `Edge` and unknown lines are skipped.
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
/// values, an unclosed `{`, a face with fewer than three vertices or referring to an
/// undefined vertex id, a corner whose vertex or face is undefined (or whose face id
/// is used twice) or whose vertex is not on its face. A file without vertices is
/// refused ([`Location::File`]).
pub fn read(data: &[u8]) -> Result<Mesh, FormatError> {
    let mut r = Reader::default();
    let mut lines = Lines::new(data);
    while let Some(line) = lines.next() {
        let ln = lines.line_number();
        let keyword = tokens(line).next();
        if !matches!(keyword, Some(b"Vertex" | b"Face" | b"Corner")) {
            // Comments, blank lines, Edge and anything else.
            continue;
        }
        let (head, braces) = split_braces(line, ln)?;
        let mut toks = tokens(head).skip(1);
        match keyword {
            Some(b"Vertex") => r.vertex(&mut toks, braces, ln)?,
            Some(b"Face") => r.face(&mut toks, ln)?,
            _ => r.corner(&mut toks, braces, ln)?,
        }
    }
    r.finish()
}

/// Face id whose number is used by more than one face.
const AMBIGUOUS: u32 = u32::MAX;

/// Reader state.
#[derive(Default)]
struct Reader {
    index_of: FastMap<u64, u32>,
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    colors: Vec<[f32; 4]>,
    has_normal: Vec<bool>,
    has_uv: Vec<bool>,
    has_rgb: Vec<bool>,
    /// Polygon corners (vertex indices), polygon `p` ending at `poly_end[p]`.
    poly_verts: Vec<u32>,
    poly_end: Vec<usize>,
    /// Face id → polygon, or [`AMBIGUOUS`].
    face_of_id: FastMap<i64, u32>,
    /// `(vertex, polygon)` → the corner's normal.
    corner_normals: FastMap<(u32, u32), [f32; 3]>,
}

impl Reader {
    fn vertex<'a>(
        &mut self,
        toks: &mut impl Iterator<Item = &'a [u8]>,
        braces: &[u8],
        ln: u64,
    ) -> Result<(), FormatError> {
        let id = parse_id(toks.next().unwrap_or_default(), ln)?;
        let mut xyz = [0f32; 3];
        let n = parse_floats(toks, ln, "vertex coordinate", &mut xyz)?;
        if n != 3 || toks.next().is_some() {
            return Err(FormatError::new(
                Location::Line(ln),
                format!("'Vertex {id}' needs exactly three coordinates"),
            ));
        }
        let index = self.positions.len() as u32;
        if index == u32::MAX {
            return Err(FormatError::new(
                Location::Line(ln),
                "more vertices than 32-bit indices can address",
            ));
        }
        if self.index_of.insert(id, index).is_some() {
            return Err(FormatError::new(
                Location::Line(ln),
                format!("vertex id {id} is defined twice"),
            ));
        }
        let (mut normal, mut uv, mut rgb) = (None, None, None);
        for (key, value) in Attributes::new(braces) {
            match key {
                b"normal" => normal = Some(attr_values::<3>(value, ln, "normal")?),
                b"uv" => uv = Some(attr_values::<2>(value, ln, "uv")?),
                b"rgb" => rgb = Some(attr_values::<3>(value, ln, "rgb")?),
                _ => {}
            }
        }
        self.positions.push(xyz);
        self.has_normal.push(normal.is_some());
        self.has_uv.push(uv.is_some());
        self.has_rgb.push(rgb.is_some());
        self.normals.push(normal.unwrap_or_default());
        self.uvs.push(uv.unwrap_or_default());
        let [r, g, b] = rgb.unwrap_or([1.0; 3]);
        self.colors.push([r, g, b, 1.0]);
        Ok(())
    }

    /// The index of vertex id token `t`.
    fn vertex_index(&self, t: &[u8], ln: u64, user: &str) -> Result<u32, FormatError> {
        let id = parse_i64(t, ln, "a vertex id")?;
        u64::try_from(id)
            .ok()
            .and_then(|id| self.index_of.get(&id).copied())
            .ok_or_else(|| {
                FormatError::new(
                    Location::Line(ln),
                    format!("{user} refers to vertex id {id}, which is not defined"),
                )
            })
    }

    fn face<'a>(
        &mut self,
        toks: &mut impl Iterator<Item = &'a [u8]>,
        ln: u64,
    ) -> Result<(), FormatError> {
        let id = parse_i64(toks.next().unwrap_or_default(), ln, "the face id")?;
        let start = self.poly_verts.len();
        for t in toks {
            let v = self.vertex_index(t, ln, "face")?;
            self.poly_verts.push(v);
        }
        let n = self.poly_verts.len() - start;
        if n < 3 {
            return Err(FormatError::new(
                Location::Line(ln),
                format!("a face needs at least 3 vertices, this one has {n}"),
            ));
        }
        let polygon = self.poly_end.len() as u32;
        self.poly_end.push(self.poly_verts.len());
        self.face_of_id
            .entry(id)
            .and_modify(|p| *p = AMBIGUOUS)
            .or_insert(polygon);
        Ok(())
    }

    fn corner<'a>(
        &mut self,
        toks: &mut impl Iterator<Item = &'a [u8]>,
        braces: &[u8],
        ln: u64,
    ) -> Result<(), FormatError> {
        let v = self.vertex_index(toks.next().unwrap_or_default(), ln, "corner")?;
        let face_id = parse_i64(toks.next().unwrap_or_default(), ln, "the face id")?;
        let polygon = match self.face_of_id.get(&face_id) {
            None => {
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!("corner refers to face id {face_id}, which is not defined"),
                ))
            }
            Some(&AMBIGUOUS) => {
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!("corner refers to face id {face_id}, which several faces use"),
                ))
            }
            Some(&p) => p,
        };
        let start = match polygon.checked_sub(1) {
            Some(prev) => self.poly_end.get(prev as usize).copied().unwrap_or(0),
            None => 0,
        };
        let end = self.poly_end.get(polygon as usize).copied().unwrap_or(0);
        let on_face = self
            .poly_verts
            .get(start..end)
            .is_some_and(|verts| verts.contains(&v));
        if !on_face {
            return Err(FormatError::new(
                Location::Line(ln),
                format!("corner's vertex is not a vertex of face {face_id}"),
            ));
        }
        for (key, value) in Attributes::new(braces) {
            if key == b"normal" {
                let n = attr_values::<3>(value, ln, "normal")?;
                self.corner_normals.insert((v, polygon), n);
            }
        }
        Ok(())
    }

    fn finish(mut self) -> Result<Mesh, FormatError> {
        if self.positions.is_empty() {
            return Err(FormatError::new(
                Location::File,
                "no 'Vertex' lines: empty or not a Hoppe .m file",
            ));
        }
        let mut referenced = vec![false; self.positions.len()];
        for &v in &self.poly_verts {
            if let Some(r) = referenced.get_mut(v as usize) {
                *r = true;
            }
        }
        let kept = |has: &[bool]| {
            has.iter().any(|&h| h) && has.iter().zip(&referenced).all(|(&h, &r)| h || !r)
        };
        let keep_uv = kept(&self.has_uv);
        let keep_rgb = kept(&self.has_rgb);
        let keep_normals = if self.corner_normals.is_empty() {
            kept(&self.has_normal)
        } else {
            self.split_corner_normals()?
        };
        let mut triangles = Vec::with_capacity(self.poly_verts.len());
        let mut start = 0;
        for &end in &self.poly_end {
            if let Some((&a, rest)) = self
                .poly_verts
                .get(start..end)
                .and_then(<[u32]>::split_first)
            {
                for pair in rest.windows(2) {
                    if let [b, c] = *pair {
                        triangles.push([a, b, c]);
                    }
                }
            }
            start = end;
        }
        Ok(Mesh {
            attributes: VertexAttributes {
                normals: keep_normals.then_some(self.normals),
                uv0: keep_uv.then_some(self.uvs),
                colors: keep_rgb.then_some(self.colors),
                ..VertexAttributes::default()
            },
            positions: self.positions,
            triangles,
            groups: None,
            group_names: Vec::new(),
        })
    }

    /// Gives every corner its normal (the corner's own, else its vertex's), adding a
    /// vertex for each distinct extra normal of a position. Returns false, changing
    /// nothing, when some corner has no normal at all.
    fn split_corner_normals(&mut self) -> Result<bool, FormatError> {
        let normal_of = |r: &Self, v: u32, p: u32| {
            r.corner_normals.get(&(v, p)).copied().or_else(|| {
                r.has_normal
                    .get(v as usize)
                    .copied()
                    .unwrap_or(false)
                    .then(|| r.normals.get(v as usize).copied().unwrap_or_default())
            })
        };
        let mut start = 0;
        for (p, &end) in self.poly_end.iter().enumerate() {
            for &v in self.poly_verts.get(start..end).unwrap_or_default() {
                if normal_of(self, v, p as u32).is_none() {
                    return Ok(false);
                }
            }
            start = end;
        }
        let bits = |n: [f32; 3]| n.map(f32::to_bits);
        // Vertex i takes the normal of its first corner, so no vertex is left unused.
        let mut claim: Vec<Option<[u32; 3]>> = vec![None; self.positions.len()];
        let mut extra_of: FastMap<(u32, [u32; 3]), u32> = FastMap::default();
        let mut extra_source: Vec<u32> = Vec::new();
        let mut start = 0;
        for p in 0..self.poly_end.len() {
            let end = self.poly_end.get(p).copied().unwrap_or(start);
            for k in start..end {
                let Some(&v) = self.poly_verts.get(k) else {
                    continue;
                };
                let n = normal_of(self, v, p as u32).unwrap_or_default();
                let b = bits(n);
                let Some(slot) = claim.get_mut(v as usize) else {
                    continue;
                };
                match slot {
                    None => {
                        *slot = Some(b);
                        if let Some(out) = self.normals.get_mut(v as usize) {
                            *out = n;
                        }
                    }
                    Some(c) if *c == b => {}
                    Some(_) => {
                        let next = self.positions.len() + extra_source.len();
                        let next = u32::try_from(next)
                            .ok()
                            .filter(|&i| i != u32::MAX)
                            .ok_or_else(|| {
                                FormatError::new(
                                    Location::File,
                                    "more vertices than 32-bit indices can address",
                                )
                            })?;
                        let index = *extra_of.entry((v, b)).or_insert_with(|| {
                            extra_source.push(v);
                            self.normals.push(n);
                            next
                        });
                        if let Some(out) = self.poly_verts.get_mut(k) {
                            *out = index;
                        }
                    }
                }
            }
            start = end;
        }
        for &v in &extra_source {
            let v = v as usize;
            let p = self.positions.get(v).copied().unwrap_or_default();
            self.positions.push(p);
            let uv = self.uvs.get(v).copied().unwrap_or_default();
            self.uvs.push(uv);
            let c = self.colors.get(v).copied().unwrap_or([1.0; 4]);
            self.colors.push(c);
        }
        Ok(true)
    }
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
    use crate::io::test_support::{assert_line_errors, mutated, position_bits};
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

    // 3          two faces sharing edge 1-3, with a crease along it: vertex 1 has no
    // │ ╲        vertex normal; its corner in face 1 has normal +z, in face 2 +x.
    // 1 ─ 2      4 sits above 1 (z = 1).
    const CREASE: &str = "Vertex 1 0 0 0\nVertex 2 1 0 0 {normal=(0 0 1)}\n\
        Vertex 3 0 1 0 {normal=(0 0 1)}\nVertex 4 0 0 1 {normal=(1 0 0)}\n\
        Face 1 1 2 3\nFace 2 1 3 4\n\
        Corner 1 1 {normal=(0 0 1)}\nCorner 1 2 {normal=(1 0 0)}\n";

    #[test]
    fn corner_normals_split_vertices() {
        let m = mesh(CREASE);
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[4], [0.0, 0.0, 0.0]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [4, 2, 3]]);
        assert_eq!(
            m.attributes.normals,
            Some(vec![
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 1.0],
                [1.0, 0.0, 0.0],
                [1.0, 0.0, 0.0]
            ])
        );
        // A corner normal equal to the vertex's own adds nothing.
        let m = mesh(&format!("{CREASE}Corner 3 2 {{normal=(0 0 1)}}\n"));
        assert_eq!(m.positions.len(), 5);
        // A different one for vertex 3 in face 2 adds a vertex.
        let m = mesh(&format!("{CREASE}Corner 3 2 {{normal=(0 1 0)}}\n"));
        assert_eq!(m.positions.len(), 6);
        assert_eq!(m.triangles[1], [4, 5, 3]);
        assert_eq!(m.attributes.normals.unwrap()[5], [0.0, 1.0, 0.0]);
    }

    #[test]
    fn corner_without_any_normal_drops_normals() {
        // Vertex 1's corner in face 2 has neither a corner nor a vertex normal.
        let src = CREASE.replace("Corner 1 2 {normal=(1 0 0)}\n", "Corner 1 2 {uv=(0 0)}\n");
        let m = mesh(&src);
        assert_eq!(m.attributes.normals, None);
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn unused_vertices_need_no_attributes() {
        // Vertex 9 is used by no face and has no uv: the others' uvs are kept.
        let m = mesh(
            "Vertex 1 0 0 0 {uv=(0 0)}\nVertex 2 1 0 0 {uv=(1 0)}\nVertex 9 5 5 5\n\
             Vertex 3 0 1 0 {uv=(0 1)}\nFace 1 1 2 3\n",
        );
        assert_eq!(
            m.attributes.uv0,
            Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
        );
    }

    #[test]
    fn corner_errors() {
        let cases: &[(&str, &str)] = &[
            (
                "Corner 7 1 {normal=(0 0 1)}\n",
                "vertex id 7, which is not defined",
            ),
            (
                "Corner 1 9 {normal=(0 0 1)}\n",
                "face id 9, which is not defined",
            ),
            ("Corner 2 2 {normal=(0 0 1)}\n", "not a vertex of face 2"),
            ("Corner 1 1 {normal=(0 x 1)}\n", "expected a number"),
            (
                "Face 2 2 3 4\nCorner 3 2 {normal=(0 0 1)}\n",
                "several faces use",
            ),
        ];
        for (lines, message) in cases {
            let e = err(&format!("{CREASE}{lines}"));
            let last = 8 + lines.lines().count() as u64;
            assert_eq!(e.location, Location::Line(last), "{lines}");
            assert!(e.message.contains(message), "{lines}: {}", e.message);
        }
        // Reused face ids are fine while no corner refers to them.
        assert_eq!(mesh(&format!("{CREASE}Face 2 2 3 4\n")).triangles.len(), 3);
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
        assert_line_errors(err, base, cases, 4);
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
            prop_assert_eq!(position_bits(&back), position_bits(&m));
        }

        #[test]
        fn never_panics_on_garbage(data in prop::collection::vec(any::<u8>(), 0..200)) {
            let _ = read(&data);
        }

        #[test]
        fn never_panics_on_mutated_file(cut in 0usize..300, byte in any::<u8>(), at in 0usize..300) {
            let _ = read(&mutated(SPARSE.as_bytes(), at, byte, cut));
        }
    }
}
