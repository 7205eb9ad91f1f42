//! Wavefront OBJ reader and writer.
//!
//! Follows the polygonal subset of the Wavefront *Object Files (.obj)* specification
//! (Advanced Visualizer manual, appendix B1):
//!
//! - `v x y z [w]` positions (`w` is ignored); the common extension `v x y z r g b [a]`
//!   gives per-vertex colours. Colours are stored as written, except that a file whose
//!   colour values exceed 1 is taken to be in 0–255 and divided by 255.
//! - `vt u [v [w]]` texture coordinates (`w` ignored; a missing `v` is 0), `vn x y z`
//!   normals.
//! - `f` with corners `v`, `v/vt`, `v//vn` or `v/vt/vn`; indices are 1-based, negative
//!   indices count back from the last element defined so far. Every index must refer
//!   to an element defined *before* the face. Polygons are fan-triangulated around
//!   their first corner.
//! - `usemtl NAME` sets the material of the faces that follow: each triangle gets a
//!   group id, ids in order of first appearance ([`Mesh::groups`], names in
//!   [`Mesh::group_names`]). Faces before the first `usemtl` get an unnamed group
//!   (name `""`) — only when the file has `usemtl` lines at all; otherwise
//!   [`Mesh::groups`] is `None`.
//! - `mtllib a.mtl b.mtl` names go to [`Scene::material_libraries`]; the first `o NAME`
//!   becomes the part's name. `g`, `s`, `l`, `p` and every other statement are skipped.
//! - `#` starts a comment (also after the numbers of `v`/`vt`/`vn`/`f`); a line ending
//!   in `\` continues on the next one; CRLF line ends are accepted.
//!
//! # Vertices
//! OBJ indexes positions, texture coordinates and normals separately; a mesh vertex is
//! a *wedge*, a distinct `(v, vt, vn)` triple. Vertex `i` of the mesh is position line
//! `i` (so a file without `vt`/`vn` reads with exactly one vertex per `v` line, in
//! order, and positions that no face uses are kept), carrying the attributes of the
//! first corner that uses it. Corners that use the same position with a different
//! `(vt, vn)` become extra vertices appended after the positions, deduplicated with a
//! hash map so shared corners share vertices.
//!
//! When some corners have a `vt` and others do not, the others get UV `(0, 0)`; when
//! some have a `vn` and others do not, the others get the zero normal. Unreferenced
//! positions also get those defaults.
//!
//! # Writing
//! [`write()`] writes [`Scene::flatten`]: `mtllib` lines, `o` (for a single named part),
//! one `v` (with `r g b` when the mesh has colours), `vt` and `vn` line per vertex, and
//! the triangles grouped by material (stable order within a group) with a `usemtl`
//! before each group. Numbers are printed in the shortest form that reads back as the
//! same `f32`, so write → read is exact.

use super::stream_base::{Sink, Source, StreamError};
use super::text::{parse_f32, parse_i64, show};
use super::{FormatError, Location, Part, Scene, IDENTITY};
use crate::mesh::{Mesh, VertexAttributes};
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// "No `vt`/`vn` index" in a corner.
const NONE: u32 = u32::MAX;
/// `claim` entry of a position no corner has used yet.
const UNCLAIMED: u64 = u64::MAX;

/// Reads an OBJ file from memory into a one-part [`Scene`].
///
/// # Errors
/// [`FormatError`] at the [`Location::Line`] of the first malformed statement: a
/// number that does not parse, a NaN or infinite value, a face with fewer than three
/// corners, an index that is 0 or refers past the elements defined so far (either
/// sign), a corner with more than three `/`-separated fields. A file without a single
/// `v` line is refused ([`Location::File`]).
pub fn read(data: &[u8]) -> Result<Scene, FormatError> {
    let mut reader = ObjReader::with_capacity(data.len());
    let mut joined: Vec<u8> = Vec::new();
    let mut pos = 0usize;
    let mut line_no = 0u64;
    while pos < data.len() {
        let (line, next) = next_line(data, pos);
        pos = next;
        line_no += 1;
        let first_line = line_no;
        if line.ends_with(b"\\") && !is_comment(line) {
            // A continued statement: join its lines with spaces.
            joined.clear();
            let mut part = line;
            loop {
                match part.strip_suffix(b"\\") {
                    Some(head) => {
                        joined.extend_from_slice(head);
                        joined.push(b' ');
                    }
                    None => {
                        joined.extend_from_slice(part);
                        break;
                    }
                }
                if pos >= data.len() {
                    break;
                }
                let (l, n) = next_line(data, pos);
                pos = n;
                line_no += 1;
                part = l;
            }
            reader.statement(&joined, first_line)?;
        } else {
            reader.statement(line, first_line)?;
        }
    }
    reader.finish()
}

/// Writes `scene` (flattened into one mesh) as OBJ text.
///
/// # Errors
/// [`FormatError`] when the mesh is invalid (an index out of range, attribute streams
/// of the wrong length) or holds a NaN or infinite position or attribute value, which
/// OBJ readers (ours included) refuse.
pub fn write(scene: &Scene, out: &mut Vec<u8>) -> Result<(), FormatError> {
    let mesh = scene.flatten();
    check_writable(&mesh)?;
    let attrs = &mesh.attributes;
    out.reserve(mesh.positions.len() * 40 + mesh.triangles.len() * 24);
    for lib in &scene.material_libraries {
        out.extend_from_slice(b"mtllib ");
        push_name(out, lib);
        out.push(b'\n');
    }
    if let [Part {
        name: Some(name), ..
    }] = scene.parts.as_slice()
    {
        out.extend_from_slice(b"o ");
        push_name(out, name);
        out.push(b'\n');
    }
    for (i, p) in mesh.positions.iter().enumerate() {
        out.push(b'v');
        push_floats(out, p);
        if let Some(c) = attrs.colors.as_ref().and_then(|c| c.get(i)) {
            push_floats(out, &c[..3]);
        }
        out.push(b'\n');
    }
    if let Some(uv) = &attrs.uv0 {
        for t in uv {
            out.extend_from_slice(b"vt");
            push_floats(out, t);
            out.push(b'\n');
        }
    }
    if let Some(n) = &attrs.normals {
        for v in n {
            out.extend_from_slice(b"vn");
            push_floats(out, v);
            out.push(b'\n');
        }
    }
    let has_vt = attrs.uv0.is_some();
    let has_vn = attrs.normals.is_some();
    let write_face = |out: &mut Vec<u8>, t: &[u32; 3]| {
        out.push(b'f');
        for &i in t {
            out.push(b' ');
            let k = u64::from(i) + 1;
            push_u64(out, k);
            match (has_vt, has_vn) {
                (false, false) => {}
                (true, false) => {
                    out.push(b'/');
                    push_u64(out, k);
                }
                (false, true) => {
                    out.extend_from_slice(b"//");
                    push_u64(out, k);
                }
                (true, true) => {
                    out.push(b'/');
                    push_u64(out, k);
                    out.push(b'/');
                    push_u64(out, k);
                }
            }
        }
        out.push(b'\n');
    };
    match &mesh.groups {
        None => {
            for t in &mesh.triangles {
                write_face(out, t);
            }
        }
        Some(groups) => {
            let mut order: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
            order.sort_by_key(|&t| groups.get(t as usize).copied().unwrap_or(0));
            let names = material_names(&mesh.group_names, groups);
            let mut current: Option<u32> = None;
            for &t in &order {
                let g = groups.get(t as usize).copied().unwrap_or(0);
                if current != Some(g) {
                    // The first group, when unnamed, stays before any `usemtl`: it
                    // reads back as the unnamed default material.
                    let name = names.get(&g).map_or("", String::as_str);
                    if current.is_some() || !name.is_empty() {
                        out.extend_from_slice(b"usemtl ");
                        push_name(out, name);
                        out.push(b'\n');
                    }
                    current = Some(g);
                }
                if let Some(tri) = mesh.triangles.get(t as usize) {
                    write_face(out, tri);
                }
            }
        }
    }
    Ok(())
}

/// Names for the group ids used by `groups`: the mesh's name when it has a non-empty
/// one, otherwise `group<id>` (made unique against the real names). The lowest used id
/// keeps an empty name, written as "no `usemtl`".
fn material_names(group_names: &[String], groups: &[u32]) -> HashMap<u32, String> {
    let mut used: Vec<u32> = groups.to_vec();
    used.sort_unstable();
    used.dedup();
    let taken: std::collections::HashSet<&str> = group_names
        .iter()
        .map(String::as_str)
        .filter(|s| !s.is_empty())
        .collect();
    let mut out = HashMap::new();
    for (k, &g) in used.iter().enumerate() {
        let real = group_names.get(g as usize).map_or("", String::as_str);
        let name = if !real.is_empty() || k == 0 {
            real.to_string()
        } else {
            let mut candidate = format!("group{g}");
            while taken.contains(candidate.as_str()) {
                candidate.push('_');
            }
            candidate
        };
        out.insert(g, name);
    }
    out
}

/// Refuses meshes a text writer cannot express: invalid structure, or NaN/infinite
/// values (which print as text no reader accepts).
pub(crate) fn check_writable(mesh: &Mesh) -> Result<(), FormatError> {
    mesh.validate()
        .map_err(|e| FormatError::new(Location::File, format!("cannot write: {e}")))?;
    let a = &mesh.attributes;
    let finite = |kind: &'static str, it: &mut dyn Iterator<Item = &[f32]>| {
        for (i, v) in it.enumerate() {
            if v.iter().any(|x| !x.is_finite()) {
                return Err(FormatError::new(
                    Location::Element("vertex", i as u64),
                    format!("cannot write a non-finite {kind} {v:?}"),
                ));
            }
        }
        Ok(())
    };
    if let Some(n) = &a.normals {
        finite("normal", &mut n.iter().map(|v| &v[..]))?;
    }
    if let Some(t) = &a.uv0 {
        finite("texture coordinate", &mut t.iter().map(|v| &v[..]))?;
    }
    if let Some(c) = &a.colors {
        finite("colour", &mut c.iter().map(|v| &v[..]))?;
    }
    Ok(())
}

/// Appends each value preceded by a space.
pub(crate) fn push_floats(out: &mut Vec<u8>, values: &[f32]) {
    for &v in values {
        out.push(b' ');
        push_f32(out, v);
    }
}

/// Appends the shortest decimal that reads back as exactly `v`, without a trailing
/// `.0` (`1` rather than `1.0`). Non-finite values print as `NaN`/`inf`.
pub(crate) fn push_f32(out: &mut Vec<u8>, v: f32) {
    let mut buf = zmij::Buffer::new();
    let s = buf.format(v);
    let s = s.strip_suffix(".0").unwrap_or(s);
    out.extend_from_slice(s.as_bytes());
}

/// Appends an unsigned integer in decimal.
pub(crate) fn push_u64(out: &mut Vec<u8>, v: u64) {
    let mut buf = itoa::Buffer::new();
    out.extend_from_slice(buf.format(v).as_bytes());
}

/// Appends a name for a one-line statement: line breaks and other control characters
/// become `_` so the name stays on its line.
fn push_name(out: &mut Vec<u8>, name: &str) {
    out.extend(
        name.bytes()
            .map(|b| if b.is_ascii_control() { b'_' } else { b }),
    );
}

/// A fast, non-cryptographic hasher for integer keys (multiply-rotate mixing with a
/// final avalanche), for maps the readers build per corner or per vertex.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct FastHasher(u64);

impl Hasher for FastHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    fn write_u32(&mut self, x: u32) {
        self.write_u64(u64::from(x));
    }

    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(23) ^ x).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }

    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }

    fn finish(&self) -> u64 {
        // murmur3's 64-bit finaliser: every input bit reaches the low and high bits
        // (hashbrown uses both).
        let mut x = self.0;
        x ^= x >> 33;
        x = x.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        x ^= x >> 33;
        x = x.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
        x ^ (x >> 33)
    }
}

/// A `HashMap` with [`FastHasher`].
pub(crate) type FastMap<K, V> = HashMap<K, V, BuildHasherDefault<FastHasher>>;

/// The line starting at `pos` (without `\n` and a trailing `\r`) and the offset of the
/// next line.
fn next_line(data: &[u8], pos: usize) -> (&[u8], usize) {
    let rest = data.get(pos..).unwrap_or_default();
    let (line, next) = match memchr::memchr(b'\n', rest) {
        Some(i) => (rest.get(..i).unwrap_or_default(), pos + i + 1),
        None => (rest, data.len()),
    };
    (line.strip_suffix(b"\r").unwrap_or(line), next)
}

/// True when the line's first non-blank character is `#`.
fn is_comment(line: &[u8]) -> bool {
    line.iter()
        .find(|b| !b.is_ascii_whitespace())
        .is_some_and(|&b| b == b'#')
}

/// Whitespace tokens of one line; a token starting with `#` ends the line.
struct Cursor<'a> {
    s: &'a [u8],
    i: usize,
}

impl<'a> Cursor<'a> {
    fn new(s: &'a [u8]) -> Self {
        Self { s, i: 0 }
    }

    fn token(&mut self) -> Option<&'a [u8]> {
        let s = self.s;
        let mut i = self.i;
        while s.get(i).is_some_and(u8::is_ascii_whitespace) {
            i += 1;
        }
        if s.get(i).is_none_or(|&b| b == b'#') {
            self.i = s.len();
            return None;
        }
        let start = i;
        while s.get(i).is_some_and(|b| !b.is_ascii_whitespace()) {
            i += 1;
        }
        self.i = i;
        s.get(start..i)
    }

    /// The rest of the line without surrounding blanks (names may contain spaces).
    fn rest(&self) -> &'a [u8] {
        self.s.get(self.i..).unwrap_or_default().trim_ascii()
    }
}

/// Packs a corner's `(vt, vn)` (each [`NONE`] when absent) into one key; never
/// [`UNCLAIMED`].
fn attr_key(vt: u32, vn: u32) -> u64 {
    (u64::from(vt.wrapping_add(1)) << 32) | u64::from(vn.wrapping_add(1))
}

/// The `(vt, vn)` of a key from [`attr_key`].
fn unpack_key(key: u64) -> (u32, u32) {
    (
        ((key >> 32) as u32).wrapping_sub(1),
        (key as u32).wrapping_sub(1),
    )
}

/// Reader state: the separate index streams and the mesh being built.
struct ObjReader {
    positions: Vec<[f32; 3]>,
    /// Per position, present once any `v` line had a colour (white before that).
    colors: Option<Vec<[f32; 4]>>,
    texcoords: Vec<[f32; 2]>,
    normals: Vec<[f32; 3]>,
    /// Per position: the `(vt, vn)` key of the first corner using it, or [`UNCLAIMED`].
    claim: Vec<u64>,
    /// Vertices beyond the positions: `(v, key)` for corners whose key differs from
    /// the position's claim.
    extras: Vec<(u32, u64)>,
    extra_of: FastMap<(u32, u64), u32>,
    /// Triangle corners: a position index, or `!k` for extra vertex `k` (resolved in
    /// [`Self::finish`], once the number of positions is known).
    triangles: Vec<[u32; 3]>,
    any_vt: bool,
    any_vn: bool,
    groups: Option<Vec<u32>>,
    group_names: Vec<String>,
    group_of_name: HashMap<String, u32>,
    current_group: u32,
    name: Option<String>,
    material_libraries: Vec<String>,
    corners: Vec<u32>,
}

impl ObjReader {
    fn with_capacity(bytes: usize) -> Self {
        // Typical OBJ: ~30 bytes per `v` line and twice as many faces as positions.
        let guess = bytes / 90;
        Self {
            positions: Vec::with_capacity(guess),
            colors: None,
            texcoords: Vec::new(),
            normals: Vec::new(),
            claim: Vec::with_capacity(guess),
            extras: Vec::new(),
            extra_of: FastMap::default(),
            triangles: Vec::with_capacity(guess * 2),
            any_vt: false,
            any_vn: false,
            groups: None,
            group_names: Vec::new(),
            group_of_name: HashMap::new(),
            current_group: 0,
            name: None,
            material_libraries: Vec::new(),
            corners: Vec::new(),
        }
    }

    fn statement(&mut self, line: &[u8], ln: u64) -> Result<(), FormatError> {
        let mut c = Cursor::new(line);
        let Some(keyword) = c.token() else {
            return Ok(());
        };
        match keyword {
            b"v" => self.vertex(&mut c, ln),
            b"vt" => self.texcoord(&mut c, ln),
            b"vn" => self.normal(&mut c, ln),
            b"f" => self.face(&mut c, ln),
            b"usemtl" => {
                let name = String::from_utf8_lossy(c.rest()).into_owned();
                self.use_material(name);
                Ok(())
            }
            b"mtllib" => {
                while let Some(t) = c.token() {
                    self.material_libraries
                        .push(String::from_utf8_lossy(t).into_owned());
                }
                Ok(())
            }
            b"o" => {
                let rest = c.rest();
                if self.name.is_none() && !rest.is_empty() {
                    self.name = Some(String::from_utf8_lossy(rest).into_owned());
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Reads up to `N` numbers, all finite; returns how many there were.
    fn numbers<const N: usize>(
        c: &mut Cursor<'_>,
        ln: u64,
        what: &str,
        out: &mut [f32; N],
    ) -> Result<usize, FormatError> {
        let mut n = 0;
        while let Some(t) = c.token() {
            let v = parse_f32(t, ln, what)?;
            if !v.is_finite() {
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!("{what} is not finite ('{}')", show(t)),
                ));
            }
            match out.get_mut(n) {
                Some(slot) => *slot = v,
                None => {
                    return Err(FormatError::new(
                        Location::Line(ln),
                        format!("too many numbers for {what} (more than {N})"),
                    ))
                }
            }
            n += 1;
        }
        Ok(n)
    }

    fn vertex(&mut self, c: &mut Cursor<'_>, ln: u64) -> Result<(), FormatError> {
        let mut v = [0f32; 7];
        let n = Self::numbers(c, ln, "vertex coordinate", &mut v)?;
        let colour = match n {
            3 | 4 => None,
            6 => Some([v[3], v[4], v[5], 1.0]),
            7 => Some([v[3], v[4], v[5], v[6]]),
            _ => {
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!("'v' needs x y z, x y z w, or x y z r g b [a]; found {n} numbers"),
                ))
            }
        };
        if self.positions.len() + self.extras.len() >= (u32::MAX - 1) as usize {
            return Err(FormatError::new(
                Location::Line(ln),
                "more vertices than 32-bit indices can address",
            ));
        }
        match (colour, &mut self.colors) {
            (Some(c), Some(colors)) => colors.push(c),
            (Some(c), None) => {
                let mut colors = vec![[1.0; 4]; self.positions.len()];
                colors.push(c);
                self.colors = Some(colors);
            }
            (None, Some(colors)) => colors.push([1.0; 4]),
            (None, None) => {}
        }
        self.positions.push([v[0], v[1], v[2]]);
        self.claim.push(UNCLAIMED);
        Ok(())
    }

    fn texcoord(&mut self, c: &mut Cursor<'_>, ln: u64) -> Result<(), FormatError> {
        let mut v = [0f32; 3];
        let n = Self::numbers(c, ln, "texture coordinate", &mut v)?;
        if n == 0 {
            return Err(FormatError::new(
                Location::Line(ln),
                "'vt' needs at least one number (u [v [w]])",
            ));
        }
        if self.texcoords.len() >= (NONE - 1) as usize {
            return Err(FormatError::new(Location::Line(ln), "too many 'vt' lines"));
        }
        self.texcoords.push([v[0], v[1]]);
        Ok(())
    }

    fn normal(&mut self, c: &mut Cursor<'_>, ln: u64) -> Result<(), FormatError> {
        let mut v = [0f32; 3];
        let n = Self::numbers(c, ln, "normal component", &mut v)?;
        if n != 3 {
            return Err(FormatError::new(
                Location::Line(ln),
                format!("'vn' needs 3 numbers, found {n}"),
            ));
        }
        if self.normals.len() >= (NONE - 1) as usize {
            return Err(FormatError::new(Location::Line(ln), "too many 'vn' lines"));
        }
        self.normals.push(v);
        Ok(())
    }

    fn face(&mut self, c: &mut Cursor<'_>, ln: u64) -> Result<(), FormatError> {
        let mut corners = std::mem::take(&mut self.corners);
        corners.clear();
        let result = self.face_corners(c, ln, &mut corners);
        if result.is_ok() {
            if corners.len() < 3 {
                self.corners = corners;
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!(
                        "a face needs at least 3 vertices, this one has {}",
                        self.corners.len()
                    ),
                ));
            }
            if let Some((&first, rest)) = corners.split_first() {
                for pair in rest.windows(2) {
                    if let [b, c] = *pair {
                        self.triangles.push([first, b, c]);
                        if let Some(g) = &mut self.groups {
                            g.push(self.current_group);
                        }
                    }
                }
            }
        }
        self.corners = corners;
        result
    }

    fn face_corners(
        &mut self,
        c: &mut Cursor<'_>,
        ln: u64,
        corners: &mut Vec<u32>,
    ) -> Result<(), FormatError> {
        while let Some(token) = c.token() {
            let mut fields = token.split(|&b| b == b'/');
            let v_field = fields.next().unwrap_or_default();
            let vt_field = fields.next().unwrap_or_default();
            let vn_field = fields.next().unwrap_or_default();
            if fields.next().is_some() {
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!(
                        "face corner '{}' has more than three '/'-separated indices",
                        show(token)
                    ),
                ));
            }
            if v_field.is_empty() {
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!("face corner '{}' has no vertex index", show(token)),
                ));
            }
            let v = resolve_index(v_field, self.positions.len(), "vertex", ln)?;
            let vt = if vt_field.is_empty() {
                NONE
            } else {
                self.any_vt = true;
                resolve_index(vt_field, self.texcoords.len(), "texture coordinate", ln)?
            };
            let vn = if vn_field.is_empty() {
                NONE
            } else {
                self.any_vn = true;
                resolve_index(vn_field, self.normals.len(), "normal", ln)?
            };
            corners.push(self.wedge(v, vt, vn, ln)?);
        }
        Ok(())
    }

    /// The vertex for corner `(v, vt, vn)`: position `v` itself when it is unclaimed or
    /// claimed by the same `(vt, vn)`, otherwise a deduplicated extra vertex.
    fn wedge(&mut self, v: u32, vt: u32, vn: u32, ln: u64) -> Result<u32, FormatError> {
        let key = attr_key(vt, vn);
        let Some(claim) = self.claim.get_mut(v as usize) else {
            return Err(FormatError::new(
                Location::Line(ln),
                format!("vertex {} does not exist", u64::from(v) + 1),
            ));
        };
        if *claim == UNCLAIMED {
            *claim = key;
            return Ok(v);
        }
        if *claim == key {
            return Ok(v);
        }
        let next = self.extras.len() as u32;
        let k = *self.extra_of.entry((v, key)).or_insert(next);
        if k == next {
            if self.positions.len() + self.extras.len() >= (u32::MAX - 1) as usize {
                return Err(FormatError::new(
                    Location::Line(ln),
                    "more vertices than 32-bit indices can address",
                ));
            }
            self.extras.push((v, key));
        }
        Ok(!k)
    }

    fn use_material(&mut self, name: String) {
        if self.groups.is_none() {
            let mut groups = Vec::with_capacity(self.triangles.capacity());
            if !self.triangles.is_empty() {
                let default = self.group_id(String::new());
                groups.resize(self.triangles.len(), default);
            }
            self.groups = Some(groups);
        }
        self.current_group = self.group_id(name);
    }

    fn group_id(&mut self, name: String) -> u32 {
        if let Some(&id) = self.group_of_name.get(&name) {
            return id;
        }
        let id = self.group_names.len() as u32;
        self.group_names.push(name.clone());
        self.group_of_name.insert(name, id);
        id
    }

    fn finish(self) -> Result<Scene, FormatError> {
        if self.positions.is_empty() {
            return Err(FormatError::new(
                Location::File,
                "no vertices ('v' lines): empty or not an OBJ file",
            ));
        }
        let n_pos = self.positions.len();
        let mut triangles = self.triangles;
        if !self.extras.is_empty() {
            // Corners stored as `!k` name extra vertex k, which goes after the
            // positions. Positions are < n_pos and `!k` ≥ n_pos since
            // n_pos + extras < u32::MAX.
            let base = n_pos as u32;
            for t in &mut triangles {
                for i in t.iter_mut() {
                    if *i >= base {
                        *i = base + !*i;
                    }
                }
            }
        }
        let keys = || {
            self.claim
                .iter()
                .copied()
                .chain(self.extras.iter().map(|&(_, key)| key))
        };
        let mut positions = self.positions;
        let extra_positions: Vec<[f32; 3]> = self
            .extras
            .iter()
            .map(|&(v, _)| positions.get(v as usize).copied().unwrap_or_default())
            .collect();
        positions.extend(extra_positions);
        let uv0 = self.any_vt.then(|| {
            keys()
                .map(|k| {
                    let (vt, _) = unpack_key(k);
                    if k == UNCLAIMED {
                        return [0.0; 2];
                    }
                    self.texcoords.get(vt as usize).copied().unwrap_or([0.0; 2])
                })
                .collect()
        });
        let normals = self.any_vn.then(|| {
            keys()
                .map(|k| {
                    let (_, vn) = unpack_key(k);
                    if k == UNCLAIMED {
                        return [0.0; 3];
                    }
                    self.normals.get(vn as usize).copied().unwrap_or([0.0; 3])
                })
                .collect()
        });
        let colors = self.colors.map(|mut c| {
            let extra: Vec<[f32; 4]> = self
                .extras
                .iter()
                .map(|&(v, _)| c.get(v as usize).copied().unwrap_or([1.0; 4]))
                .collect();
            c.extend(extra);
            scale_colours_255(&mut c);
            c
        });
        let mesh = Mesh {
            positions,
            triangles,
            attributes: VertexAttributes {
                normals,
                uv0,
                colors,
                ..VertexAttributes::default()
            },
            groups: self.groups,
            group_names: self.group_names,
        };
        Ok(Scene {
            parts: vec![Part {
                name: self.name,
                mesh,
                instances: vec![IDENTITY],
            }],
            material_libraries: self.material_libraries,
            gltf: None,
        })
    }
}

/// Streams an OBJ file (see [`super::stream`]): `v` positions are kept, faces are
/// fan-triangulated and passed on as they come, with the group ids [`read`] gives
/// (`usemtl` names in order of first appearance; an unnamed group first when faces
/// come before the first `usemtl`). Errors name the line as [`read`]'s do; the
/// `vt`/`vn` parts of corners are not checked.
pub(crate) fn stream<R: std::io::Read>(
    src: &mut Source<R>,
    sink: &mut Sink<'_>,
) -> Result<(), StreamError> {
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    let mut ids: HashMap<String, u32> = HashMap::new();
    let mut group_of = |name: String, names: &mut Vec<String>| -> u32 {
        *ids.entry(name.clone()).or_insert_with(|| {
            names.push(name);
            names.len() as u32 - 1
        })
    };
    let mut current = 0u32;
    let mut triangles = 0u64;
    let mut line = Vec::new();
    let mut joined = Vec::new();
    let mut ln = 0u64;
    let mut corners: Vec<u32> = Vec::new();
    while src.line(&mut line)? {
        ln += 1;
        let first = ln;
        // A line ending in a backslash continues on the next one.
        let text: &[u8] = if line.last() == Some(&b'\\') && !is_comment(&line) {
            joined.clear();
            joined.extend_from_slice(&line[..line.len() - 1]);
            let mut more = Vec::new();
            while src.line(&mut more)? {
                ln += 1;
                joined.push(b' ');
                if more.last() == Some(&b'\\') {
                    joined.extend_from_slice(&more[..more.len() - 1]);
                } else {
                    joined.extend_from_slice(&more);
                    break;
                }
            }
            &joined
        } else {
            &line
        };
        let mut c = Cursor::new(text);
        match c.token() {
            Some(b"v") => {
                let mut v = [0f32; 7];
                let n = ObjReader::numbers(&mut c, first, "vertex coordinate", &mut v)?;
                if n < 3 {
                    return Err(FormatError::new(
                        Location::Line(first),
                        format!("a vertex needs 3 coordinates, this one has {n}"),
                    )
                    .into());
                }
                let p = [v[0], v[1], v[2]];
                sink.vertex(p);
                positions.push(p);
            }
            Some(b"f") => {
                corners.clear();
                while let Some(token) = c.token() {
                    let v_field = token.split(|&b| b == b'/').next().unwrap_or_default();
                    if v_field.is_empty() {
                        return Err(FormatError::new(
                            Location::Line(first),
                            format!("face corner '{}' has no vertex index", show(token)),
                        )
                        .into());
                    }
                    corners.push(resolve_index(v_field, positions.len(), "vertex", first)?);
                }
                if corners.len() < 3 {
                    return Err(FormatError::new(
                        Location::Line(first),
                        format!(
                            "a face needs at least 3 vertices, this one has {}",
                            corners.len()
                        ),
                    )
                    .into());
                }
                for k in 1..corners.len() - 1 {
                    let t = [corners[0], corners[k], corners[k + 1]].map(|i| positions[i as usize]);
                    sink.triangle(&t, current);
                    triangles += 1;
                }
            }
            Some(b"usemtl") => {
                let name = String::from_utf8_lossy(c.rest()).into_owned();
                if names.is_empty() && triangles > 0 {
                    group_of(String::new(), &mut names);
                }
                current = group_of(name, &mut names);
            }
            _ => {}
        }
    }
    if positions.is_empty() {
        return Err(FormatError::new(
            Location::File,
            "no vertices ('v' lines): empty or not an OBJ file",
        )
        .into());
    }
    sink.summary.group_names = names;
    sink.summary.vertices_held = positions.len() as u64;
    Ok(())
}

/// When any colour component exceeds 1 the colours were written as 0–255: scales all of
/// them (alpha included) to 0–1.
pub(crate) fn scale_colours_255(colors: &mut [[f32; 4]]) {
    if colors.iter().any(|c| c.iter().any(|&x| x > 1.0)) {
        for c in colors {
            for x in c.iter_mut() {
                *x /= 255.0;
            }
        }
    }
}

/// Turns a 1-based (or negative, relative) OBJ index into a 0-based one, checking it
/// against the `count` elements defined so far.
fn resolve_index(field: &[u8], count: usize, what: &str, ln: u64) -> Result<u32, FormatError> {
    let i = parse_i64(field, ln, "a face index")?;
    let resolved = if i > 0 {
        (i as u64 <= count as u64).then(|| i as u64 - 1)
    } else if i < 0 {
        (i.unsigned_abs() <= count as u64).then(|| count as u64 - i.unsigned_abs())
    } else {
        return Err(FormatError::new(
            Location::Line(ln),
            format!("{what} index 0 (OBJ indices start at 1)"),
        ));
    };
    match resolved {
        Some(r) => Ok(r as u32),
        None => Err(FormatError::new(
            Location::Line(ln),
            format!("{what} index {i} is out of range: {count} defined so far"),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::test_support::{assert_line_errors, mutated, position_bits};
    use proptest::prelude::*;

    fn scene(src: &str) -> Scene {
        read(src.as_bytes()).unwrap()
    }

    fn mesh(src: &str) -> Mesh {
        scene(src).parts[0].mesh.clone()
    }

    fn err(src: &str) -> FormatError {
        read(src.as_bytes()).unwrap_err()
    }

    fn written(scene: &Scene) -> String {
        let mut out = Vec::new();
        write(scene, &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    // 4 ─ 3
    // │ ╲ │   one quad, fanned from its first corner into (1 2 3) and (1 3 4)
    // 1 ─ 2
    const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";

    #[test]
    fn quad_is_fan_triangulated_positions_in_order() {
        let m = mesh(QUAD);
        assert_eq!(
            m.positions,
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0]
            ]
        );
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(m.attributes.is_empty());
        assert_eq!(m.groups, None);
    }

    #[test]
    fn pentagon_fan_and_w_coordinate_ignored() {
        let m = mesh("v 0 0 0 1\nv 1 0 0 1\nv 2 1 0\nv 1 2 0\nv 0 1 0 0.5\nf 1 2 3 4 5\n");
        assert_eq!(m.positions[4], [0.0, 1.0, 0.0]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    }

    #[test]
    fn negative_indices_count_back_from_the_last_defined() {
        // The second face uses -3 -2 -1 = the three vertices defined just before it.
        let m = mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf -4 -1 -2\n");
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 3, 2]]);
        let m = mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf -3/-3 -2/-2 -1/-1\n");
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        assert_eq!(
            m.attributes.uv0,
            Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
        );
    }

    #[test]
    fn all_corner_forms() {
        let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0.25\nvn 0 0 1\n";
        // v/vt
        let m = mesh(&format!("{head}f 1/1 2/1 3/1\n"));
        assert_eq!(m.attributes.uv0, Some(vec![[0.5, 0.25]; 3]));
        assert_eq!(m.attributes.normals, None);
        // v//vn
        let m = mesh(&format!("{head}f 1//1 2//1 3//1\n"));
        assert_eq!(m.attributes.uv0, None);
        assert_eq!(m.attributes.normals, Some(vec![[0.0, 0.0, 1.0]; 3]));
        // v/vt/vn
        let m = mesh(&format!("{head}f 1/1/1 2/1/1 3/1/1\n"));
        assert_eq!(m.attributes.uv0, Some(vec![[0.5, 0.25]; 3]));
        assert_eq!(m.attributes.normals, Some(vec![[0.0, 0.0, 1.0]; 3]));
        assert_eq!(m.positions.len(), 3);
        // A trailing slash is an empty field.
        let m = mesh(&format!("{head}f 1/ 2/ 3/\n"));
        assert!(m.attributes.is_empty());
        // vt with only u: v = 0.
        let m = mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.75\nf 1/1 2/1 3/1\n");
        assert_eq!(m.attributes.uv0, Some(vec![[0.75, 0.0]; 3]));
    }

    #[test]
    fn wedges_are_deduplicated_and_seams_split() {
        // Two triangles over the quad 1 2 3 4 sharing edge 1-3. Corner 3 has UV 3 in
        // the first triangle and UV 5 in the second (a seam), corner 1 has UV 1 in
        // both: position 3 gets one extra vertex (index 4), shared by nothing else.
        let m = mesh(
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
             vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 9 9\n\
             f 1/1 2/2 3/3\nf 1/1 3/5 4/4\nf 3/5 4/4 1/1\n",
        );
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[4], [1.0, 1.0, 0.0]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 4, 3], [4, 3, 0]]);
        assert_eq!(
            m.attributes.uv0,
            Some(vec![
                [0.0, 0.0],
                [1.0, 0.0],
                [1.0, 1.0],
                [0.0, 1.0],
                [9.0, 9.0]
            ])
        );
    }

    #[test]
    fn extra_vertices_go_after_positions_defined_later() {
        // The seam vertex is created before the 4th position is read, and still ends
        // up after all positions.
        let m = mesh(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 1\n\
             f 1/1 2/1 3/1\nf 1/2 2/1 3/1\nv 7 7 7\n",
        );
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[3], [7.0, 7.0, 7.0]);
        assert_eq!(m.positions[4], [0.0, 0.0, 0.0]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [4, 1, 2]]);
        assert_eq!(m.attributes.uv0.as_ref().unwrap()[4], [1.0, 1.0]);
        // The unreferenced position gets the default UV.
        assert_eq!(m.attributes.uv0.as_ref().unwrap()[3], [0.0, 0.0]);
    }

    #[test]
    fn missing_vt_and_vn_get_defaults() {
        // Face 1 has UVs, face 2 (over position 4) has normals only.
        let m = mesh(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0.5 0.5\nvn 0 1 0\n\
             f 1/1 2/1 3/1\nf 2//1 4//1 3//1\n",
        );
        // Positions 2 and 3 are claimed by face 1 (uv, no normal); face 2 uses them
        // with (no uv, normal) and gets two extra vertices.
        assert_eq!(m.positions.len(), 6);
        let uv = m.attributes.uv0.unwrap();
        let n = m.attributes.normals.unwrap();
        assert_eq!(uv[0], [0.5, 0.5]);
        assert_eq!(n[0], [0.0, 0.0, 0.0]);
        assert_eq!(uv[3], [0.0, 0.0]);
        assert_eq!(n[3], [0.0, 1.0, 0.0]);
        assert_eq!(m.triangles[1], [4, 3, 5]);
        assert_eq!(n[4], [0.0, 1.0, 0.0]);
    }

    #[test]
    fn unreferenced_positions_are_kept() {
        let m = mesh("v 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 8 8 8\nf 2 3 4\n");
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[0], [9.0, 9.0, 9.0]);
        assert_eq!(m.triangles, vec![[1, 2, 3]]);
    }

    #[test]
    fn vertex_colours_unit_and_255_scales() {
        let m = mesh("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1 0.5\nf 1 2 3\n");
        assert_eq!(
            m.attributes.colors,
            Some(vec![
                [1.0, 0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0, 1.0],
                [0.0, 0.0, 1.0, 0.5]
            ])
        );
        // A value above 1: the file is 0–255.
        let m = mesh("v 0 0 0 255 0 51\nv 1 0 0\nv 0 1 0 0 0 0\nf 1 2 3\n");
        let c = m.attributes.colors.unwrap();
        assert_eq!(c[0], [1.0, 0.0, 0.2, 1.0 / 255.0]);
        // Vertices without a colour are white (alpha scaled with the rest).
        assert_eq!(c[1], [1.0 / 255.0; 4]);
    }

    #[test]
    fn colour_appears_midway_and_seams_copy_it() {
        let m =
            mesh("v 0 0 0\nv 1 0 0 0 0 1\nv 0 1 0\nvt 0 0\nvt 1 1\nf 1/1 2/1 3/1\nf 1/1 2/2 3/1\n");
        let c = m.attributes.colors.unwrap();
        assert_eq!(c.len(), 4);
        assert_eq!(c[0], [1.0; 4]);
        assert_eq!(c[1], [0.0, 0.0, 1.0, 1.0]);
        assert_eq!(c[3], [0.0, 0.0, 1.0, 1.0]);
    }

    #[test]
    fn usemtl_groups_in_first_appearance_order() {
        // Triangle 0 before any usemtl → unnamed default group 0; then b, a, b again.
        let s = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl b\nf 1 2 3\n\
                 usemtl a\nf 1 2 3\nusemtl b\nf 1 2 3 \nusemtl   with space  \nf 1 2 3\n";
        let m = mesh(s);
        assert_eq!(m.groups, Some(vec![0, 1, 2, 1, 3]));
        assert_eq!(m.group_names, vec!["", "b", "a", "with space"]);
    }

    #[test]
    fn usemtl_first_means_no_default_group() {
        let m = mesh("mtllib x.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        assert_eq!(m.groups, Some(vec![0]));
        assert_eq!(m.group_names, vec!["a"]);
        // No usemtl at all: no groups.
        assert_eq!(mesh(QUAD).groups, None);
    }

    #[test]
    fn mtllib_object_name_and_ignored_statements() {
        let s = scene(
            "# a comment\nmtllib a.mtl b.mtl\nmtllib c.mtl\no  First Object \no Second\n\
             g group1\ns 1\nvp 0.5\ncstype bezier\nv 0 0 0\nv 1 0 0\nv 0 1 0\n\
             l 1 2\np 3\nf 1 2 3\n",
        );
        assert_eq!(s.material_libraries, vec!["a.mtl", "b.mtl", "c.mtl"]);
        assert_eq!(s.parts.len(), 1);
        assert_eq!(s.parts[0].name.as_deref(), Some("First Object"));
        assert_eq!(s.parts[0].instances, vec![IDENTITY]);
        assert_eq!(s.parts[0].mesh.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn continuation_comments_crlf_and_blank_lines() {
        let m = mesh(
            "\r\n  # comment \\\r\nv 0 0 0 # trailing comment\r\nv 1 \\\r\n 0 0\r\n\r\n\
             \tv 0 1 0\r\nf 1 \\\n2 \\\n3\r\nf 1 2 3 # another\n",
        );
        assert_eq!(
            m.positions,
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        );
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 1, 2]]);
        // A continued line's errors name the line it starts on.
        let e = err("v 0 0 0\nv 1 \\\n0 x\n");
        assert_eq!(e.location, Location::Line(2));
        // A continuation at the end of the file.
        assert_eq!(
            mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 \\")
                .triangles
                .len(),
            1
        );
    }

    #[test]
    fn non_utf8_is_fine_outside_numbers() {
        let mut data = b"# caf\xe9\nusemtl m\xe9tal\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec();
        let s = read(&data).unwrap();
        assert_eq!(s.parts[0].mesh.group_names, vec!["m\u{fffd}tal"]);
        data.extend_from_slice(b"v 1 \xff 0\n");
        assert_eq!(read(&data).unwrap_err().location, Location::Line(7));
    }

    #[test]
    fn errors_name_the_line() {
        let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        let cases: &[(&str, &str)] = &[
            ("v 1 2 x\n", "expected a number"),
            ("v 1 2\n", "found 2 numbers"),
            ("v 1 2 3 4 5\n", "found 5 numbers"),
            ("v 1 2 3 4 5 6 7 8\n", "too many numbers"),
            ("v nan 0 0\n", "not finite"),
            ("v 0 inf 0\n", "not finite"),
            ("vt\n", "at least one number"),
            ("vt 0 nan\n", "not finite"),
            ("vn 0 1\n", "needs 3 numbers"),
            ("vn 0 1 -inf\n", "not finite"),
            ("f 1 2 0\n", "index 0"),
            ("f 1 2 4\n", "out of range: 3 defined so far"),
            ("f 1 2 -4\n", "index -4 is out of range"),
            ("f 1 2 3.5\n", "expected an integer"),
            ("f 1 2\n", "at least 3 vertices, this one has 2"),
            ("f\n", "this one has 0"),
            (
                "f 1/1 2 3\n",
                "texture coordinate index 1 is out of range: 0",
            ),
            ("f 1//2 2 3\n", "normal index 2 is out of range"),
            ("f 1/1/1/1 2 3\n", "more than three"),
            ("f /1 2 3\n", "no vertex index"),
        ];
        assert_line_errors(err, base, cases, 4);
    }

    #[test]
    fn forward_references_are_errors() {
        let e = err("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n");
        assert_eq!(e.location, Location::Line(3));
        assert!(e.message.contains("2 defined so far"));
    }

    #[test]
    fn empty_or_foreign_files_are_refused() {
        for src in [
            "",
            "\n\n",
            "# only a comment\n",
            "solid x\nfacet normal 0 0 1\n",
        ] {
            let e = err(src);
            assert_eq!(e.location, Location::File);
            assert!(e.message.contains("no vertices"));
        }
        // Vertices but no faces: a point set, returned as is.
        let m = mesh("v 1 2 3\n");
        assert_eq!(m.positions.len(), 1);
        assert!(m.triangles.is_empty());
    }

    #[test]
    fn writer_exact_text_with_attributes_and_groups() {
        let mut m = Mesh::from_triangles(
            vec![[0.0, 0.0, 0.0], [1.5, 0.0, -0.0], [0.0, 0.1, 1e-7]],
            vec![[0, 1, 2], [2, 1, 0], [0, 2, 1]],
        );
        m.attributes.uv0 = Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        m.attributes.normals = Some(vec![[0.0, 0.0, 1.0]; 3]);
        m.groups = Some(vec![1, 0, 1]);
        m.group_names = vec!["red".into(), "blue\nline".into()];
        let mut scene = Scene::from_mesh(m);
        scene.parts[0].name = Some("thing".into());
        scene.material_libraries = vec!["x.mtl".into()];
        let text = written(&scene);
        assert_eq!(
            text,
            "mtllib x.mtl\no thing\nv 0 0 0\nv 1.5 0 -0\nv 0 0.1 1e-7\n\
             vt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\n\
             usemtl red\nf 3/3/3 2/2/2 1/1/1\n\
             usemtl blue_line\nf 1/1/1 2/2/2 3/3/3\nf 1/1/1 3/3/3 2/2/2\n"
        );
    }

    #[test]
    fn writer_face_forms_and_colours() {
        let mut m = Mesh::from_triangles(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        );
        assert!(written(&Scene::from_mesh(m.clone())).ends_with("f 1 2 3\n"));
        m.attributes.uv0 = Some(vec![[0.0; 2]; 3]);
        assert!(written(&Scene::from_mesh(m.clone())).ends_with("f 1/1 2/2 3/3\n"));
        m.attributes.uv0 = None;
        m.attributes.normals = Some(vec![[0.0; 3]; 3]);
        assert!(written(&Scene::from_mesh(m.clone())).ends_with("f 1//1 2//2 3//3\n"));
        m.attributes.colors = Some(vec![[0.25, 0.5, 1.0, 1.0]; 3]);
        assert!(written(&Scene::from_mesh(m)).starts_with("v 0 0 0 0.25 0.5 1\n"));
    }

    #[test]
    fn writer_unnamed_groups() {
        // Group 0 unnamed: written first without usemtl; group 2 unnamed gets a
        // generated name that does not clash with the real "group2".
        let mut m = Mesh::from_triangles(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]; 3],
        );
        m.groups = Some(vec![2, 0, 1]);
        m.group_names = vec![String::new(), "group2".into()];
        let text = written(&Scene::from_mesh(m));
        assert!(
            text.ends_with("f 1 2 3\nusemtl group2\nf 1 2 3\nusemtl group2_\nf 1 2 3\n"),
            "{text}"
        );
        let back = mesh(&text);
        assert_eq!(back.groups, Some(vec![0, 1, 2]));
        assert_eq!(back.group_names, vec!["", "group2", "group2_"]);
    }

    #[test]
    fn writer_refuses_non_finite_and_invalid() {
        let mut m = Mesh::from_triangles(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        );
        m.attributes.uv0 = Some(vec![[0.0, 0.0], [f32::NAN, 0.0], [0.0, 0.0]]);
        let e = write(&Scene::from_mesh(m.clone()), &mut Vec::new()).unwrap_err();
        assert_eq!(e.location, Location::Element("vertex", 1));
        m.attributes.uv0 = None;
        m.triangles.push([0, 1, 3]);
        assert!(write(&Scene::from_mesh(m), &mut Vec::new()).is_err());
    }

    #[test]
    fn fast_hasher_spreads_low_bits() {
        let mut seen = std::collections::HashSet::new();
        for i in 0u64..1024 {
            let mut h = FastHasher::default();
            h.write_u64(i);
            seen.insert(h.finish() & 1023);
        }
        // A good hash of 1024 keys fills well over half the 1024 buckets.
        assert!(seen.len() > 550, "{}", seen.len());
    }

    /// What reading back a written mesh gives: triangles stably sorted by group, group
    /// ids renumbered in order of appearance, attributes of unreferenced vertices reset
    /// to the reader's defaults (no face carries them), colour alpha 1.
    fn expected_after_round_trip(m: &Mesh) -> Mesh {
        let mut e = m.clone();
        let mut used = vec![false; m.positions.len()];
        for t in &m.triangles {
            for &i in t {
                used[i as usize] = true;
            }
        }
        for (i, u) in used.iter().enumerate() {
            if !u {
                if let Some(uv) = &mut e.attributes.uv0 {
                    uv[i] = [0.0; 2];
                }
                if let Some(n) = &mut e.attributes.normals {
                    n[i] = [0.0; 3];
                }
            }
        }
        if let Some(g) = &m.groups {
            let mut order: Vec<usize> = (0..m.triangles.len()).collect();
            order.sort_by_key(|&t| g[t]);
            e.triangles = order.iter().map(|&t| m.triangles[t]).collect();
            let mut ids: Vec<u32> = g.clone();
            ids.sort_unstable();
            ids.dedup();
            e.groups = Some(
                order
                    .iter()
                    .map(|&t| ids.binary_search(&g[t]).unwrap() as u32)
                    .collect(),
            );
            e.group_names = ids
                .iter()
                .map(|&i| m.group_names[i as usize].clone())
                .collect();
        }
        e
    }

    fn finite() -> impl Strategy<Value = f32> {
        any::<f32>().prop_filter("finite", |x| x.is_finite())
    }

    prop_compose! {
        fn random_mesh()(n in 3usize..24)(
            positions in prop::collection::vec([finite(), finite(), finite()], n),
            triangles in prop::collection::vec([0..n as u32, 0..n as u32, 0..n as u32], 1..40),
            uv in prop::option::of(prop::collection::vec([finite(), finite()], n)),
            normals in prop::option::of(prop::collection::vec([finite(), finite(), finite()], n)),
            colors in prop::option::of(prop::collection::vec([0f32..=1.0, 0f32..=1.0, 0f32..=1.0], n)),
            groups in prop::option::of((1u32..5).prop_flat_map(|k| prop::collection::vec(0..k, 40))),
        ) -> Mesh {
            let t = triangles.len();
            Mesh {
                positions,
                triangles,
                attributes: VertexAttributes {
                    uv0: uv,
                    normals,
                    colors: colors.map(|c| c.into_iter().map(|[r, g, b]| [r, g, b, 1.0]).collect()),
                    ..VertexAttributes::default()
                },
                group_names: if groups.is_some() {
                    (0..5).map(|i| format!("mat{i}")).collect()
                } else {
                    Vec::new()
                },
                groups: groups.map(|g| g[..t].to_vec()),
            }
        }
    }

    proptest! {
        #[test]
        fn round_trip(m in random_mesh()) {
            let mut out = Vec::new();
            write(&Scene::from_mesh(m.clone()), &mut out).unwrap();
            let back = read(&out).unwrap();
            let expected = expected_after_round_trip(&m);
            prop_assert_eq!(&back.parts[0].mesh, &expected);
            // Bit-exact, including the sign of zero.
            prop_assert_eq!(position_bits(&back.parts[0].mesh), position_bits(&expected));
        }

        #[test]
        fn never_panics_on_garbage(data in prop::collection::vec(any::<u8>(), 0..200)) {
            let _ = read(&data);
        }

        #[test]
        fn never_panics_on_mutated_file(cut in 0usize..120, byte in any::<u8>(), at in 0usize..120) {
            let sample = b"v 0 0 0\nv 1 0 0 1 0 0\nvt 0 0\nvn 0 0 1\nusemtl a\n\
                           f 1/1/1 2//1 -1/1\nf 1 2 2 2 \\\n1\no x\n";
            let _ = read(&mutated(sample, at, byte, cut));
        }
    }
}
