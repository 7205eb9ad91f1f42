//! The `.pmesh` file format: a progressive mesh as a byte stream whose every prefix
//! ending on a record boundary is usable (progressive transmission: the base mesh
//! first, then one vertex split after another).
//!
//! # Layout (version 1)
//! All fixed-size numbers are little-endian; `varint` is unsigned LEB128 of a `u32`
//! (1 to 5 bytes, the fifth holding at most 4 bits); `f32` is IEEE 754 binary32, so
//! positions round-trip bit for bit.
//!
//! ```text
//! header (28 bytes, then group names)
//!   0  [u8; 4]  magic "MLPM"
//!   4  u16      version = 1
//!   6  u16      flags: bit 0 = triangles carry a group; other bits 0
//!   8  u8       attribute streams present: bit 0 normal (3 f32), 1 tangent (4 f32),
//!               2 uv0 (2 f32), 3 uv1 (2 f32), 4 colour (4 f32), 5 joints (4 u16),
//!               6 weights (4 f32); bit 7 must be 0. A wedge's attributes are these
//!               values in this order.
//!   9  [u8; 3]  reserved, 0
//!  12  u32      base points P0
//!  16  u32      base wedges W0
//!  20  u32      base triangles T0
//!  24  u32      vertex splits S in the complete file (a prefix holds fewer)
//!  28  varint   group-name count, then per name: varint byte length, UTF-8 bytes
//! base mesh
//!      P0 × [f32; 3]                     point positions
//!      W0 × (varint point, attributes)   wedges (vertices) with their point
//!      T0 × (3 × varint wedge [, varint group])   triangles, counter-clockwise
//! vertex split k (k = 0..S), with P, W, T the counts before it
//!      varint   kept point v (< P); the new point is u = P
//!      [f32; 3] position of u
//!      f32      error of the collapse it undoes (the cost model's distance)
//!      varint   nw, then nw × (varint P − owner point, attributes): new wedges
//!               W .. W+nw (owner ≤ P; 0 means u)
//!      varint   nm, then nm × (varint 3·triangle + corner, varint W+nw−1 − wedge):
//!               corners of existing triangles that used a wedge of v and now use
//!               the given wedge of u
//!      varint   nt ∈ {1, 2}, then nt × (3 × varint W+nw−1 − wedge [, varint group]):
//!               new triangles T .. T+nt, each with u and v among its points
//! ```
//!
//! Wedge references inside a split count back from the newest wedge, so the common
//! references (the new point's own wedge) take one byte.
//!
//! # Decoding
//! The decoder bounds-checks every count against the bytes left before allocating
//! and every reference against the counts so far, and replays the splits while it
//! reads them: a moved corner must hold a wedge of `v` and receive a wedge of `u`,
//! a new triangle must have three distinct points including `u` and `v`, positions
//! must be finite. So every decoded prefix is a valid mesh without degenerate
//! triangles. A file cut exactly between two splits decodes to that prefix
//! ([`Decoded::complete`] is then `false`); a file cut inside a record, corrupt
//! values or trailing bytes are [`PmError::Format`] errors naming the file and the
//! byte offset. For streaming, [`ProgressiveMesh::from_bytes_partial`] drops an
//! incomplete last split instead. The format has no checksum: a flipped bit in a
//! coordinate is not detected (the transport's job).

use super::progressive::{PmError, ProgressiveMesh};
use crate::mesh::VertexAttributes;
use std::path::Path;

/// The first four bytes of a `.pmesh` file.
pub const PMESH_MAGIC: [u8; 4] = *b"MLPM";
/// The format version this code writes and reads.
pub const PMESH_VERSION: u16 = 1;

const HEADER_LEN: usize = 28;
/// Smallest possible split record: kept, position, error, nw, nm, nt, one triangle.
const MIN_SPLIT: usize = 1 + 12 + 4 + 1 + 1 + 1 + 3;

/// A decoded `.pmesh` file or prefix.
#[derive(Debug, Clone, PartialEq)]
pub struct Decoded {
    /// The progressive mesh (its splits are those the bytes held).
    pub pm: ProgressiveMesh,
    /// The number of splits the header announces for the complete file.
    pub splits_in_header: usize,
    /// Whether every announced split was present.
    pub complete: bool,
    /// Bytes consumed (the end of the last complete split).
    pub bytes_used: usize,
}

/// Writes `pm` to `path` as `.pmesh`.
///
/// # Errors
/// [`PmError::Io`] naming the file.
pub fn write_pmesh(path: impl AsRef<Path>, pm: &ProgressiveMesh) -> Result<(), PmError> {
    let path = path.as_ref();
    std::fs::write(path, pm.to_bytes()).map_err(|source| PmError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// Reads a `.pmesh` file (or a prefix of one cut between splits).
///
/// # Errors
/// [`PmError::Io`] when the file cannot be read, [`PmError::Format`] (with the file
/// name and byte offset) when it is truncated inside a record or corrupt.
pub fn read_pmesh(path: impl AsRef<Path>) -> Result<Decoded, PmError> {
    let path = path.as_ref();
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| PmError::Io {
        path: name.clone(),
        source,
    })?;
    decode(&bytes, &name, false)
}

// ----- writing -------------------------------------------------------------------

fn varint(out: &mut Vec<u8>, mut v: u32) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn f32s(out: &mut Vec<u8>, v: &[f32]) {
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

fn attr_mask(a: &VertexAttributes) -> u8 {
    u8::from(a.normals.is_some())
        | u8::from(a.tangents.is_some()) << 1
        | u8::from(a.uv0.is_some()) << 2
        | u8::from(a.uv1.is_some()) << 3
        | u8::from(a.colors.is_some()) << 4
        | u8::from(a.joints.is_some()) << 5
        | u8::from(a.weights.is_some()) << 6
}

/// Bytes of one wedge's attributes for `mask`.
fn attr_size(mask: u8) -> usize {
    [12, 16, 8, 8, 16, 8, 16]
        .iter()
        .enumerate()
        .filter(|(i, _)| mask >> i & 1 == 1)
        .map(|(_, s)| s)
        .sum()
}

fn write_attrs(out: &mut Vec<u8>, a: &VertexAttributes, w: usize) {
    if let Some(s) = &a.normals {
        f32s(out, &s[w]);
    }
    if let Some(s) = &a.tangents {
        f32s(out, &s[w]);
    }
    if let Some(s) = &a.uv0 {
        f32s(out, &s[w]);
    }
    if let Some(s) = &a.uv1 {
        f32s(out, &s[w]);
    }
    if let Some(s) = &a.colors {
        f32s(out, &s[w]);
    }
    if let Some(s) = &a.joints {
        for j in s[w] {
            out.extend_from_slice(&j.to_le_bytes());
        }
    }
    if let Some(s) = &a.weights {
        f32s(out, &s[w]);
    }
}

impl ProgressiveMesh {
    /// Encodes as `.pmesh` (the layout is in the `lod::pmesh` module's source docs;
    /// [`write_pmesh`](crate::lod::write_pmesh) writes it to a file).
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER_LEN + 48 * self.positions.len());
        out.extend_from_slice(&PMESH_MAGIC);
        out.extend_from_slice(&PMESH_VERSION.to_le_bytes());
        out.extend_from_slice(&u16::from(self.groups.is_some()).to_le_bytes());
        out.push(attr_mask(&self.attributes));
        out.extend_from_slice(&[0; 3]);
        for n in [
            self.base_points,
            self.base_wedges,
            self.base_triangles,
            self.kept.len() as u32,
        ] {
            out.extend_from_slice(&n.to_le_bytes());
        }
        varint(&mut out, self.group_names.len() as u32);
        for g in &self.group_names {
            varint(&mut out, g.len() as u32);
            out.extend_from_slice(g.as_bytes());
        }
        for p in &self.positions[..self.base_points as usize] {
            f32s(&mut out, p);
        }
        for w in 0..self.base_wedges as usize {
            varint(&mut out, self.wedge_point[w]);
            write_attrs(&mut out, &self.attributes, w);
        }
        for (t, tw) in self.triangles[..self.base_triangles as usize]
            .iter()
            .enumerate()
        {
            for &w in tw {
                varint(&mut out, w);
            }
            if let Some(g) = &self.groups {
                varint(&mut out, g[t]);
            }
        }
        for k in 0..self.kept.len() {
            let s = self.split(k);
            varint(&mut out, s.kept);
            f32s(&mut out, &s.position);
            f32s(&mut out, &[s.error]);
            let top = s.new_wedges.end - 1;
            varint(&mut out, s.new_wedges.len() as u32);
            for w in s.new_wedges.clone() {
                varint(&mut out, s.new_point - self.wedge_point[w as usize]);
                write_attrs(&mut out, &self.attributes, w as usize);
            }
            varint(&mut out, s.moved_corners.len() as u32);
            for (&c, &w) in s.moved_corners.iter().zip(s.moved_wedges) {
                varint(&mut out, c);
                varint(&mut out, top - w);
            }
            varint(&mut out, s.new_triangles.len() as u32);
            for t in s.new_triangles.clone() {
                for &w in &self.triangles[t as usize] {
                    varint(&mut out, top - w);
                }
                if let Some(g) = &self.groups {
                    varint(&mut out, g[t as usize]);
                }
            }
        }
        out
    }

    /// Decodes a `.pmesh` buffer, or a prefix of one cut between two splits.
    ///
    /// # Errors
    /// [`PmError::Format`] (file `<memory>`, with the byte offset) when the buffer is
    /// cut inside a record, corrupt, or has trailing bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Decoded, PmError> {
        decode(bytes, "<memory>", false)
    }

    /// Decodes as much of a `.pmesh` buffer as has arrived: the header and base mesh
    /// must be complete, an incomplete last split is left out (for streaming).
    ///
    /// # Errors
    /// [`PmError::Format`] when the header or base mesh is incomplete or anything
    /// read is corrupt.
    pub fn from_bytes_partial(bytes: &[u8]) -> Result<Decoded, PmError> {
        decode(bytes, "<memory>", true)
    }
}

// ----- reading -------------------------------------------------------------------

/// A decoding failure: `eof` when the bytes ran out.
struct Fail {
    offset: usize,
    message: String,
    eof: bool,
}

type R<T> = Result<T, Fail>;

struct Reader<'a> {
    b: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn left(&self) -> usize {
        self.b.len() - self.pos
    }

    fn bad<T>(&self, at: usize, message: String) -> R<T> {
        Err(Fail {
            offset: at,
            message,
            eof: false,
        })
    }

    fn take(&mut self, n: usize, what: &str) -> R<&[u8]> {
        if self.left() < n {
            return Err(Fail {
                offset: self.pos,
                message: format!(
                    "unexpected end of data: {what} needs {n} bytes, {} left",
                    self.left()
                ),
                eof: true,
            });
        }
        let s = &self.b[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn u8(&mut self, what: &str) -> R<u8> {
        Ok(self.take(1, what)?[0])
    }

    fn u16(&mut self, what: &str) -> R<u16> {
        let s = self.take(2, what)?;
        Ok(u16::from_le_bytes([s[0], s[1]]))
    }

    fn u32(&mut self, what: &str) -> R<u32> {
        let s = self.take(4, what)?;
        Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }

    fn f32(&mut self, what: &str) -> R<f32> {
        Ok(f32::from_bits(self.u32(what)?))
    }

    fn varint(&mut self, what: &str) -> R<u32> {
        let at = self.pos;
        let mut v: u32 = 0;
        for i in 0..5 {
            let b = self.u8(what)?;
            if i == 4 && b > 0x0f {
                return self.bad(at, format!("{what}: varint overflows 32 bits"));
            }
            v |= u32::from(b & 0x7f) << (7 * i);
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        self.bad(at, format!("{what}: varint longer than 5 bytes"))
    }

    /// A count of elements of at least `min_size` bytes each, checked against the
    /// bytes left so a corrupt count cannot make the decoder allocate wildly.
    fn count(&mut self, what: &str, min_size: usize) -> R<usize> {
        let at = self.pos;
        let n = self.varint(what)? as usize;
        if n.saturating_mul(min_size.max(1)) > self.left() {
            return Err(Fail {
                offset: at,
                message: format!(
                    "{what} {n} needs at least {} bytes, {} left",
                    n.saturating_mul(min_size.max(1)),
                    self.left()
                ),
                eof: true,
            });
        }
        Ok(n)
    }

    fn position(&mut self, what: &str) -> R<[f32; 3]> {
        let at = self.pos;
        let p = [self.f32(what)?, self.f32(what)?, self.f32(what)?];
        if !p.iter().all(|x| x.is_finite()) {
            return self.bad(at, format!("{what}: non-finite coordinate {p:?}"));
        }
        Ok(p)
    }

    fn attrs(&mut self, a: &mut VertexAttributes) -> R<()> {
        fn f<const N: usize>(r: &mut Reader<'_>, s: &mut Option<Vec<[f32; N]>>) -> R<()> {
            if let Some(s) = s {
                let mut v = [0f32; N];
                for x in &mut v {
                    *x = r.f32("attribute")?;
                }
                s.push(v);
            }
            Ok(())
        }
        f(self, &mut a.normals)?;
        f(self, &mut a.tangents)?;
        f(self, &mut a.uv0)?;
        f(self, &mut a.uv1)?;
        f(self, &mut a.colors)?;
        if let Some(s) = &mut a.joints {
            let mut v = [0u16; 4];
            for x in &mut v {
                *x = self.u16("joint")?;
            }
            s.push(v);
        }
        f(self, &mut a.weights)?;
        Ok(())
    }
}

fn empty_streams(mask: u8) -> VertexAttributes {
    let on = |b: u8| mask >> b & 1 == 1;
    VertexAttributes {
        normals: on(0).then(Vec::new),
        tangents: on(1).then(Vec::new),
        uv0: on(2).then(Vec::new),
        uv1: on(3).then(Vec::new),
        colors: on(4).then(Vec::new),
        joints: on(5).then(Vec::new),
        weights: on(6).then(Vec::new),
    }
}

fn truncate_streams(a: &mut VertexAttributes, n: usize) {
    fn t<T>(s: &mut Option<Vec<T>>, n: usize) {
        if let Some(v) = s {
            v.truncate(n);
        }
    }
    t(&mut a.normals, n);
    t(&mut a.tangents, n);
    t(&mut a.uv0, n);
    t(&mut a.uv1, n);
    t(&mut a.colors, n);
    t(&mut a.joints, n);
    t(&mut a.weights, n);
}

fn decode(bytes: &[u8], file: &str, partial: bool) -> Result<Decoded, PmError> {
    let mut r = Reader { b: bytes, pos: 0 };
    let fail = |f: Fail| PmError::Format {
        file: file.to_string(),
        offset: f.offset,
        message: f.message,
    };
    let (mut pm, mut cur, mask, splits_in_header) = header_and_base(&mut r).map_err(fail)?;
    let mut k = 0usize;
    while k < splits_in_header && r.left() > 0 {
        let start = r.pos;
        let snapshot = (pm.positions.len(), pm.wedge_point.len(), pm.triangles.len());
        let moved_len = pm.moved_corner.len();
        match split(&mut r, &mut pm, &mut cur, mask) {
            Ok(()) => k += 1,
            Err(f) if f.eof && partial => {
                // Roll back the incomplete split and stop.
                pm.positions.truncate(snapshot.0);
                pm.wedge_point.truncate(snapshot.1);
                truncate_streams(&mut pm.attributes, snapshot.1);
                pm.triangles.truncate(snapshot.2);
                cur.truncate(snapshot.2);
                if let Some(g) = &mut pm.groups {
                    g.truncate(snapshot.2);
                }
                pm.moved_corner.truncate(moved_len);
                pm.moved_wedge.truncate(moved_len);
                pm.kept.truncate(k);
                pm.error.truncate(k);
                pm.wedge_end.truncate(k);
                pm.tri_end.truncate(k);
                pm.moved_end.truncate(k);
                r.pos = start;
                break;
            }
            Err(mut f) => {
                f.message = format!("vertex split {k} (record at byte {start}): {}", f.message);
                return Err(fail(f));
            }
        }
    }
    if !partial && r.left() > 0 {
        return Err(fail(Fail {
            offset: r.pos,
            message: format!(
                "{} trailing bytes after the {splits_in_header} vertex splits the header announces",
                r.left()
            ),
            eof: false,
        }));
    }
    Ok(Decoded {
        pm,
        splits_in_header,
        complete: k == splits_in_header,
        bytes_used: r.pos,
    })
}

type Base = (ProgressiveMesh, Vec<[u32; 3]>, u8, usize);

fn header_and_base(r: &mut Reader<'_>) -> R<Base> {
    let magic: [u8; 4] = r.take(4, "magic")?.try_into().unwrap_or([0; 4]);
    if magic != PMESH_MAGIC {
        return r.bad(
            0,
            format!("not a .pmesh file (magic {magic:?}, expected \"MLPM\")"),
        );
    }
    let version = r.u16("version")?;
    if version != PMESH_VERSION {
        return r.bad(
            4,
            format!("unsupported version {version} (this reader knows {PMESH_VERSION})"),
        );
    }
    let flags = r.u16("flags")?;
    if flags > 1 {
        return r.bad(6, format!("unknown flags {flags:#06x}"));
    }
    let mask = r.u8("attribute mask")?;
    if mask & 0x80 != 0 {
        return r.bad(8, format!("unknown attribute stream bits {mask:#04x}"));
    }
    let reserved = r.take(3, "reserved bytes")? != [0, 0, 0];
    if reserved {
        return r.bad(9, "reserved bytes are not zero".into());
    }
    let bp = r.u32("base point count")? as usize;
    let bw = r.u32("base wedge count")? as usize;
    let bt = r.u32("base triangle count")? as usize;
    let ns = r.u32("split count")? as usize;
    let groups = flags & 1 == 1;
    let attr_bytes = attr_size(mask);
    let names = r.count("group-name count", 1)?;
    let mut group_names = Vec::with_capacity(names);
    for _ in 0..names {
        let at = r.pos;
        let len = r.count("group-name length", 1)?;
        let s = r.take(len, "group name")?;
        match std::str::from_utf8(s) {
            Ok(s) => group_names.push(s.to_string()),
            Err(_) => return r.bad(at, "group name is not UTF-8".into()),
        }
    }
    let need = bp
        .saturating_mul(12)
        .saturating_add(bw.saturating_mul(1 + attr_bytes))
        .saturating_add(bt.saturating_mul(3));
    if need > r.left() {
        return Err(Fail {
            offset: 12,
            message: format!(
                "base mesh of {bp} points, {bw} wedges, {bt} triangles needs at least {need} bytes, {} left",
                r.left()
            ),
            eof: true,
        });
    }
    if bt == 0 && ns > 0 {
        return r.bad(20, "vertex splits over an empty base mesh".into());
    }
    let mut pm = ProgressiveMesh {
        positions: Vec::with_capacity(bp),
        wedge_point: Vec::with_capacity(bw),
        attributes: empty_streams(mask),
        triangles: Vec::with_capacity(bt),
        groups: groups.then(|| Vec::with_capacity(bt)),
        group_names,
        ..ProgressiveMesh::default()
    };
    for _ in 0..bp {
        let p = r.position("base point")?;
        pm.positions.push(p);
    }
    for _ in 0..bw {
        let at = r.pos;
        let p = r.varint("wedge point")?;
        if p as usize >= bp {
            return r.bad(
                at,
                format!("wedge point {p} out of range ({bp} base points)"),
            );
        }
        pm.wedge_point.push(p);
        r.attrs(&mut pm.attributes)?;
    }
    for _ in 0..bt {
        let at = r.pos;
        let mut t = [0u32; 3];
        for w in &mut t {
            *w = r.varint("triangle wedge")?;
            if *w as usize >= bw {
                return r.bad(
                    at,
                    format!("triangle wedge {w} out of range ({bw} base wedges)"),
                );
            }
        }
        let p = t.map(|w| pm.wedge_point[w as usize]);
        if p[0] == p[1] || p[1] == p[2] || p[0] == p[2] {
            return r.bad(at, format!("degenerate base triangle over points {p:?}"));
        }
        pm.triangles.push(t);
        if let Some(g) = &mut pm.groups {
            g.push(r.varint("triangle group")?);
        }
    }
    pm.base_points = bp as u32;
    pm.base_wedges = bw as u32;
    pm.base_triangles = bt as u32;
    let reserve = ns.min(r.left() / MIN_SPLIT);
    pm.kept.reserve(reserve);
    let cur = pm.triangles.clone();
    Ok((pm, cur, mask, ns))
}

/// Reads, checks and applies split `k`; `cur` holds every triangle's current wedges.
fn split(r: &mut Reader<'_>, pm: &mut ProgressiveMesh, cur: &mut Vec<[u32; 3]>, mask: u8) -> R<()> {
    let p = pm.positions.len() as u32;
    let t0 = cur.len() as u32;
    let at = r.pos;
    let v = r.varint("kept point")?;
    if v >= p {
        return r.bad(at, format!("kept point {v} out of range ({p} points)"));
    }
    let pos = r.position("new point")?;
    let error = r.f32("error")?;
    let nw = r.count("new-wedge count", 1 + attr_size(mask))?;
    pm.positions.push(pos);
    for _ in 0..nw {
        let at = r.pos;
        let d = r.varint("wedge owner")?;
        if d > p {
            return r.bad(at, format!("wedge owner {p} − {d} is negative"));
        }
        pm.wedge_point.push(p - d);
        r.attrs(&mut pm.attributes)?;
    }
    let w1 = pm.wedge_point.len() as u32;
    let wedge_ref = |r: &mut Reader<'_>, what: &str| -> R<u32> {
        let at = r.pos;
        let d = r.varint(what)?;
        if d >= w1 {
            return r.bad(at, format!("{what} {} − {d} out of range", w1 as i64 - 1));
        }
        Ok(w1 - 1 - d)
    };
    let nm = r.count("moved-corner count", 2)?;
    let mut moved = Vec::with_capacity(nm);
    for _ in 0..nm {
        let at = r.pos;
        let c = r.varint("moved corner")?;
        if c >= 3 * t0 {
            return r.bad(
                at,
                format!("moved corner {c} out of range ({t0} triangles)"),
            );
        }
        let w = wedge_ref(r, "moved-corner wedge")?;
        moved.push((at, c, w));
    }
    let at = r.pos;
    let nt = r.varint("new-triangle count")?;
    if !(1..=2).contains(&nt) {
        return r.bad(
            at,
            format!("{nt} new triangles (a vertex split adds 1 or 2)"),
        );
    }
    for _ in 0..nt {
        let at = r.pos;
        let mut t = [0u32; 3];
        for w in &mut t {
            *w = wedge_ref(r, "triangle wedge")?;
        }
        let q = t.map(|w| pm.wedge_point[w as usize]);
        if q[0] == q[1] || q[1] == q[2] || q[0] == q[2] || !q.contains(&p) || !q.contains(&v) {
            return r.bad(
                at,
                format!("new triangle over points {q:?} is degenerate or misses the split points {v} and {p}"),
            );
        }
        pm.triangles.push(t);
        cur.push(t);
        if let Some(g) = &mut pm.groups {
            g.push(r.varint("triangle group")?);
        }
    }
    // Applied last, so a record cut short leaves `cur` untouched.
    for (at, c, w) in moved {
        let slot = &mut cur[(c / 3) as usize][(c % 3) as usize];
        if pm.wedge_point[*slot as usize] != v {
            return r.bad(at, format!("moved corner {c} is not at the kept point {v}"));
        }
        if pm.wedge_point[w as usize] != p {
            return r.bad(
                at,
                format!("moved corner {c} gets wedge {w}, not one of the new point {p}"),
            );
        }
        pm.moved_corner.push(c);
        pm.moved_wedge.push(w);
        *slot = w;
    }
    pm.kept.push(v);
    pm.error.push(error);
    pm.wedge_end.push(w1);
    pm.tri_end.push(cur.len() as u32);
    pm.moved_end.push(pm.moved_corner.len() as u32);
    Ok(())
}
