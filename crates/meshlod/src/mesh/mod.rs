//! The in-memory triangle mesh every method in meshlod works on.
//!
//! A [`Mesh`] is an indexed triangle list. Vertices are *wedges*: a vertex carries a
//! position and, optionally, attributes (normal, tangent, two UV sets, colour, skinning).
//! Two wedges may share a position (a UV or normal seam); topology is computed on
//! positions welded by exact equality ([`weld`]), so a seam is not a hole.
//!
//! Per-triangle group ids ([`Mesh::groups`]) carry materials (`usemtl` in OBJ, the
//! primitive's material in glTF). Group names live in [`Mesh::group_names`].
//!
//! Layout follows the data-oriented style of meshoptimizer: dense `u32` ids, flat
//! `Vec`s, no per-element objects.

mod distance;
pub mod generate;
pub mod partition;
pub mod stats;
pub mod subdivide;
pub mod topology;
pub mod weld;

pub use distance::Distance;
pub use stats::{MeshStats, TopologyStats};
pub use topology::{Topology, VertexKind};
pub use weld::Weld;

use thiserror::Error;

/// Length of the diagonal of the box from `lo` to `hi`, in the positions' units.
#[must_use]
pub fn box_diagonal(lo: [f32; 3], hi: [f32; 3]) -> f64 {
    (0..3)
        .map(|k| {
            let d = f64::from(hi[k]) - f64::from(lo[k]);
            d * d
        })
        .sum::<f64>()
        .sqrt()
}

/// Per-vertex attribute streams. Every present stream has one entry per vertex
/// (the length of [`Mesh::positions`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VertexAttributes {
    /// Unit normals (not required to be normalised on input).
    pub normals: Option<Vec<[f32; 3]>>,
    /// glTF tangents: xyz direction and w = ±1 handedness.
    pub tangents: Option<Vec<[f32; 4]>>,
    /// First texture coordinate set (glTF `TEXCOORD_0`, OBJ `vt`, PLY `u v`), with
    /// OBJ's convention: origin at the image's bottom left, `v` up (the glTF reader
    /// and writer turn glTF's top-left `v` into this and back: `v ↦ 1 − v`).
    pub uv0: Option<Vec<[f32; 2]>>,
    /// Second texture coordinate set (glTF `TEXCOORD_1`).
    pub uv1: Option<Vec<[f32; 2]>>,
    /// Linear RGBA colours in `[0, 1]` (PLY `red green blue alpha`, glTF `COLOR_0`).
    pub colors: Option<Vec<[f32; 4]>>,
    /// glTF `JOINTS_0`: four joint indices into the skin.
    pub joints: Option<Vec<[u16; 4]>>,
    /// glTF `WEIGHTS_0`: four skin weights, summing to one.
    pub weights: Option<Vec<[f32; 4]>>,
}

/// Bit pattern of an attribute component, for exact comparison.
trait Bits {
    fn bits(self) -> u32;
}
impl Bits for f32 {
    fn bits(self) -> u32 {
        // +0.0 and -0.0 compare equal.
        (self + 0.0).to_bits()
    }
}
impl Bits for u16 {
    fn bits(self) -> u32 {
        u32::from(self)
    }
}

/// Names of the attribute streams, for reports and messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AttributeKind {
    /// [`VertexAttributes::normals`]
    Normal,
    /// [`VertexAttributes::tangents`]
    Tangent,
    /// [`VertexAttributes::uv0`]
    Uv0,
    /// [`VertexAttributes::uv1`]
    Uv1,
    /// [`VertexAttributes::colors`]
    Color,
    /// [`VertexAttributes::joints`]
    Joints,
    /// [`VertexAttributes::weights`]
    Weights,
}

impl VertexAttributes {
    /// Which streams are present, in a fixed order.
    #[must_use]
    pub fn kinds(&self) -> Vec<AttributeKind> {
        let mut k = Vec::new();
        if self.normals.is_some() {
            k.push(AttributeKind::Normal);
        }
        if self.tangents.is_some() {
            k.push(AttributeKind::Tangent);
        }
        if self.uv0.is_some() {
            k.push(AttributeKind::Uv0);
        }
        if self.uv1.is_some() {
            k.push(AttributeKind::Uv1);
        }
        if self.colors.is_some() {
            k.push(AttributeKind::Color);
        }
        if self.joints.is_some() {
            k.push(AttributeKind::Joints);
        }
        if self.weights.is_some() {
            k.push(AttributeKind::Weights);
        }
        k
    }

    /// True when no stream is present.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.kinds().is_empty()
    }

    /// Gathers every stream through `map`: output vertex `i` takes input vertex `map[i]`.
    ///
    /// # Panics
    /// Panics if an entry of `map` is out of range for a present stream.
    #[must_use]
    pub fn gather(&self, map: &[u32]) -> Self {
        fn g<T: Copy>(s: &Option<Vec<T>>, map: &[u32]) -> Option<Vec<T>> {
            s.as_ref()
                .map(|v| map.iter().map(|&i| v[i as usize]).collect())
        }
        Self {
            normals: g(&self.normals, map),
            tangents: g(&self.tangents, map),
            uv0: g(&self.uv0, map),
            uv1: g(&self.uv1, map),
            colors: g(&self.colors, map),
            joints: g(&self.joints, map),
            weights: g(&self.weights, map),
        }
    }

    /// Appends `other`'s streams after `self`'s, where `self` holds `n_self` vertices
    /// and `other` `n_other`. A stream present on only one side is filled with a
    /// neutral value on the other (zero normal, zero UV, white, joint 0 with weight 1).
    pub fn append(&mut self, n_self: usize, other: &Self, n_other: usize) {
        fn a<T: Copy>(
            s: &mut Option<Vec<T>>,
            n_self: usize,
            o: &Option<Vec<T>>,
            n_other: usize,
            fill: T,
        ) {
            match (s.as_mut(), o) {
                (None, None) => {}
                (Some(v), Some(w)) => v.extend_from_slice(w),
                (Some(v), None) => v.extend(std::iter::repeat_n(fill, n_other)),
                (None, Some(w)) => {
                    let mut v = vec![fill; n_self];
                    v.extend_from_slice(w);
                    *s = Some(v);
                }
            }
        }
        a(&mut self.normals, n_self, &other.normals, n_other, [0.0; 3]);
        a(
            &mut self.tangents,
            n_self,
            &other.tangents,
            n_other,
            [1.0, 0.0, 0.0, 1.0],
        );
        a(&mut self.uv0, n_self, &other.uv0, n_other, [0.0; 2]);
        a(&mut self.uv1, n_self, &other.uv1, n_other, [0.0; 2]);
        a(&mut self.colors, n_self, &other.colors, n_other, [1.0; 4]);
        a(&mut self.joints, n_self, &other.joints, n_other, [0; 4]);
        a(
            &mut self.weights,
            n_self,
            &other.weights,
            n_other,
            [1.0, 0.0, 0.0, 0.0],
        );
    }

    /// Whether vertex `i` of `self` and vertex `j` of `other` have bitwise-equal
    /// values in every stream (`+0` and `−0` equal, a NaN equal to itself), the
    /// normals compared only when `normals` is true. A stream present on one side
    /// only differs.
    ///
    /// # Panics
    /// Panics if `i` or `j` is out of range for a present stream.
    #[must_use]
    pub(crate) fn same_values(&self, i: usize, other: &Self, j: usize, normals: bool) -> bool {
        fn eq<T: Copy + Bits, const N: usize>(
            x: &Option<Vec<[T; N]>>,
            i: usize,
            y: &Option<Vec<[T; N]>>,
            j: usize,
        ) -> bool {
            match (x, y) {
                (None, None) => true,
                (Some(x), Some(y)) => x[i].iter().zip(&y[j]).all(|(a, b)| a.bits() == b.bits()),
                _ => false,
            }
        }
        (!normals || eq(&self.normals, i, &other.normals, j))
            && eq(&self.tangents, i, &other.tangents, j)
            && eq(&self.uv0, i, &other.uv0, j)
            && eq(&self.uv1, i, &other.uv1, j)
            && eq(&self.colors, i, &other.colors, j)
            && eq(&self.joints, i, &other.joints, j)
            && eq(&self.weights, i, &other.weights, j)
    }

    /// Checks that every present stream has `n` entries.
    ///
    /// # Errors
    /// [`MeshError::AttributeLength`] naming the first stream of the wrong length.
    pub fn check_len(&self, n: usize) -> Result<(), MeshError> {
        let lens = [
            (AttributeKind::Normal, self.normals.as_ref().map(Vec::len)),
            (AttributeKind::Tangent, self.tangents.as_ref().map(Vec::len)),
            (AttributeKind::Uv0, self.uv0.as_ref().map(Vec::len)),
            (AttributeKind::Uv1, self.uv1.as_ref().map(Vec::len)),
            (AttributeKind::Color, self.colors.as_ref().map(Vec::len)),
            (AttributeKind::Joints, self.joints.as_ref().map(Vec::len)),
            (AttributeKind::Weights, self.weights.as_ref().map(Vec::len)),
        ];
        for (kind, len) in lens {
            if let Some(len) = len {
                if len != n {
                    return Err(MeshError::AttributeLength {
                        kind,
                        len,
                        vertices: n,
                    });
                }
            }
        }
        Ok(())
    }
}

/// An indexed triangle mesh with optional per-vertex attributes and per-triangle groups.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, in the file's units.
    pub positions: Vec<[f32; 3]>,
    /// Triangles as three vertex indices, counter-clockwise seen from the front.
    pub triangles: Vec<[u32; 3]>,
    /// Optional per-vertex attributes, each stream as long as `positions`.
    pub attributes: VertexAttributes,
    /// Optional per-triangle group (material) id, as long as `triangles`.
    pub groups: Option<Vec<u32>>,
    /// Names of the groups (materials), indexed by group id. May be shorter than the
    /// largest id (unnamed groups).
    pub group_names: Vec<String>,
}

/// Errors from [`Mesh::validate`] and other structural checks.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MeshError {
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index}, but the mesh has {vertices} vertices")]
    IndexOutOfRange {
        /// Triangle number (0-based).
        triangle: usize,
        /// The offending index.
        index: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// A position coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate {value}")]
    NonFinite {
        /// Vertex number (0-based).
        vertex: usize,
        /// The offending value.
        value: f32,
    },
    /// An attribute stream does not have one entry per vertex.
    #[error("attribute {kind:?} has {len} entries for {vertices} vertices")]
    AttributeLength {
        /// The stream.
        kind: AttributeKind,
        /// Its length.
        len: usize,
        /// Number of vertices.
        vertices: usize,
    },
    /// The group stream does not have one entry per triangle.
    #[error("group stream has {len} entries for {triangles} triangles")]
    GroupLength {
        /// Its length.
        len: usize,
        /// Number of triangles.
        triangles: usize,
    },
    /// More vertices than a `u32` index can address.
    #[error("{vertices} vertices is more than 32-bit indices can address")]
    TooManyVertices {
        /// Number of vertices.
        vertices: usize,
    },
}

impl Mesh {
    /// A mesh from positions and triangles, without attributes.
    #[must_use]
    pub fn from_triangles(positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>) -> Self {
        Self {
            positions,
            triangles,
            ..Self::default()
        }
    }

    /// Number of vertices (wedges).
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// True when the mesh has no triangles.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Group id of triangle `t` (0 when the mesh has no groups).
    #[must_use]
    pub fn group(&self, t: usize) -> u32 {
        self.groups.as_ref().map_or(0, |g| g[t])
    }

    /// Checks the structural invariants: indices in range, finite positions, attribute
    /// and group streams of the right length, vertex count addressable by `u32`.
    ///
    /// # Errors
    /// The first violated invariant, as a [`MeshError`] naming the element.
    pub fn validate(&self) -> Result<(), MeshError> {
        crate::isa::dispatch!(self.validate_impl())
    }

    /// [`Self::validate`], inlined into each build of `crate::isa::dispatch!` (the
    /// AVX2 build scans eight indices a step).
    #[inline(always)]
    fn validate_impl(&self) -> Result<(), MeshError> {
        let n = self.positions.len();
        if u32::try_from(n).is_err() {
            return Err(MeshError::TooManyVertices { vertices: n });
        }
        // Branch-free scans (they vectorise); the slow loops below only run to name
        // the offender.
        // A value is not finite when its exponent bits are all ones: adding one unit of
        // the exponent then carries into the sign bit.
        let non_finite = self.positions.as_flattened().chunks(4096).any(|c| {
            c.iter()
                .fold(0u32, |m, x| m | ((x.to_bits() & 0x7f80_0000) + 0x0080_0000))
                & 0x8000_0000
                != 0
        });
        if non_finite {
            for (vertex, p) in self.positions.iter().enumerate() {
                for &value in p {
                    if !value.is_finite() {
                        return Err(MeshError::NonFinite { vertex, value });
                    }
                }
            }
        }
        // `n` fits in a `u32` (checked above). A count of the indices at or above it
        // rather than their maximum: baseline x86-64 (SSE2) has no unsigned 32-bit
        // maximum, but compares and sums vectorise.
        let n32 = n as u32;
        let out_of_range = self
            .triangles
            .as_flattened()
            .chunks(4096)
            .any(|c| c.iter().fold(0u32, |m, &i| m + u32::from(i >= n32)) != 0);
        if out_of_range {
            for (triangle, t) in self.triangles.iter().enumerate() {
                for &index in t {
                    if index as usize >= n {
                        return Err(MeshError::IndexOutOfRange {
                            triangle,
                            index,
                            vertices: n,
                        });
                    }
                }
            }
        }
        self.attributes.check_len(n)?;
        if let Some(g) = &self.groups {
            if g.len() != self.triangles.len() {
                return Err(MeshError::GroupLength {
                    len: g.len(),
                    triangles: self.triangles.len(),
                });
            }
        }
        Ok(())
    }

    /// Axis-aligned bounding box `(min, max)` of the vertices referenced by triangles,
    /// or of all vertices when `referenced_only` is false. `None` when there is nothing.
    #[must_use]
    pub fn bounding_box(&self, referenced_only: bool) -> Option<([f32; 3], [f32; 3])> {
        crate::isa::dispatch!(self.bounding_box_impl(referenced_only))
    }

    /// [`Self::bounding_box`], inlined into each build of `crate::isa::dispatch!`.
    #[inline(always)]
    fn bounding_box_impl(&self, referenced_only: bool) -> Option<([f32; 3], [f32; 3])> {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        let mut any = false;
        let mut add = |p: &[f32; 3]| {
            any = true;
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        };
        if referenced_only {
            for t in &self.triangles {
                for &i in t {
                    add(&self.positions[i as usize]);
                }
            }
        } else {
            // Comparisons rather than `f32::min` (same result, NaN ignored): this loop
            // vectorises.
            // Four points (twelve values) at a time, then the remainder; the lanes
            // `k, k + 3, k + 6, k + 9` hold axis `k`.
            // The minimum is kept negated, `−lo = −x > −lo ? −x : −lo` (the same
            // choice, bit for bit: negation is exact): the compiler turns both into
            // packed maxima (`maxps`), where the direct `x < lo ? x : lo` became
            // emulated selects with shuffles (about 17 instructions a point).
            let flat = self.positions.as_flattened();
            let mut neg_lo12 = [f32::NEG_INFINITY; 12];
            let mut hi12 = [f32::NEG_INFINITY; 12];
            let mut chunks = flat.chunks_exact(12);
            for c in &mut chunks {
                for i in 0..12 {
                    let n = -c[i];
                    neg_lo12[i] = if n > neg_lo12[i] { n } else { neg_lo12[i] };
                    hi12[i] = if c[i] > hi12[i] { c[i] } else { hi12[i] };
                }
            }
            let mut lo12 = neg_lo12.map(|n| -n);
            for (i, &x) in chunks.remainder().iter().enumerate() {
                lo12[i] = if x < lo12[i] { x } else { lo12[i] };
                hi12[i] = if x > hi12[i] { x } else { hi12[i] };
            }
            for k in 0..3 {
                for l in [k, k + 3, k + 6, k + 9] {
                    lo[k] = if lo12[l] < lo[k] { lo12[l] } else { lo[k] };
                    hi[k] = if hi12[l] > hi[k] { hi12[l] } else { hi[k] };
                }
            }
            any = !self.positions.is_empty();
        }
        any.then_some((lo, hi))
    }

    /// Length of the bounding-box diagonal of all vertices (0 for an empty mesh), in
    /// the mesh's units. This is the scale relative errors are measured against.
    #[must_use]
    pub fn bbox_diagonal(&self) -> f64 {
        self.bounding_box(false)
            .map_or(0.0, |(lo, hi)| box_diagonal(lo, hi))
    }

    /// The spacing of 32-bit floats at the largest absolute coordinate, in the
    /// mesh's units (0 for an empty mesh or one at the origin): no position, and so
    /// no simplified result, is finer than this. A mesh far from the origin (survey
    /// or map coordinates: 4·10⁶ in UTM northings gives 0.25 units) loses detail
    /// when stored in `f32`; compare it with [`Self::bbox_diagonal`].
    #[must_use]
    pub fn position_step(&self) -> f64 {
        let m = self
            .positions
            .iter()
            .flatten()
            .fold(0.0f32, |m, c| m.max(c.abs()));
        if m > 0.0 && m.is_finite() {
            // 2^(e − 23) for m in [2^e, 2^(e+1)): the gap between neighbouring floats.
            f64::from(m).log2().floor().exp2() * (-23.0f64).exp2()
        } else {
            0.0
        }
    }

    /// Appends `other` (its vertices, triangles, attributes and groups; group ids are
    /// offset by `group_offset`).
    pub fn append(&mut self, other: &Mesh, group_offset: u32) {
        let base = u32::try_from(self.positions.len()).expect("vertex count fits u32");
        let n_self = self.positions.len();
        let t_self = self.triangles.len();
        self.attributes
            .append(n_self, &other.attributes, other.positions.len());
        self.positions.extend_from_slice(&other.positions);
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
        if self.groups.is_some() || other.groups.is_some() || group_offset != 0 {
            let g = self.groups.get_or_insert_with(|| vec![0; t_self]);
            match &other.groups {
                Some(o) => g.extend(o.iter().map(|&x| x + group_offset)),
                None => g.extend(std::iter::repeat_n(group_offset, other.triangles.len())),
            }
        }
    }

    /// Removes vertices no triangle refers to and renumbers the rest in first-use order.
    /// Returns, for each output vertex, the input vertex it came from.
    pub fn compact_vertices(&mut self) -> Vec<u32> {
        let n = self.positions.len();
        let mut remap = vec![u32::MAX; n];
        let mut order = Vec::with_capacity(n);
        for t in &mut self.triangles {
            for i in t.iter_mut() {
                let r = &mut remap[*i as usize];
                if *r == u32::MAX {
                    *r = order.len() as u32;
                    order.push(*i);
                }
                *i = *r;
            }
        }
        self.positions = order.iter().map(|&i| self.positions[i as usize]).collect();
        self.attributes = self.attributes.gather(&order);
        order
    }

    /// Transforms positions by the column-major 4×4 affine matrix `m` (glTF layout);
    /// normals and tangents by its inverse transpose, renormalised. A matrix with a
    /// negative determinant also flips triangle winding so fronts stay fronts.
    pub fn transform(&mut self, m: &[[f32; 4]; 4]) {
        let a = |r: usize, c: usize| f64::from(m[c][r]);
        for p in &mut self.positions {
            let v = [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])];
            for (r, out) in p.iter_mut().enumerate() {
                *out = (a(r, 0) * v[0] + a(r, 1) * v[1] + a(r, 2) * v[2] + a(r, 3)) as f32;
            }
        }
        // 3x3 linear part, its cofactor matrix = det * inverse transpose.
        let l = [
            [a(0, 0), a(0, 1), a(0, 2)],
            [a(1, 0), a(1, 1), a(1, 2)],
            [a(2, 0), a(2, 1), a(2, 2)],
        ];
        let cof = |r: usize, c: usize| {
            let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
            let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
            l[r1][c1] * l[r2][c2] - l[r1][c2] * l[r2][c1]
        };
        let det = l[0][0] * cof(0, 0) + l[0][1] * cof(0, 1) + l[0][2] * cof(0, 2);
        let sign = if det < 0.0 { -1.0 } else { 1.0 };
        let normalise = |v: [f64; 3]| {
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if len > 0.0 {
                [
                    (v[0] / len) as f32,
                    (v[1] / len) as f32,
                    (v[2] / len) as f32,
                ]
            } else {
                [0.0; 3]
            }
        };
        if let Some(ns) = &mut self.attributes.normals {
            for n in ns.iter_mut() {
                let v = [f64::from(n[0]), f64::from(n[1]), f64::from(n[2])];
                let w = [
                    sign * (cof(0, 0) * v[0] + cof(0, 1) * v[1] + cof(0, 2) * v[2]),
                    sign * (cof(1, 0) * v[0] + cof(1, 1) * v[1] + cof(1, 2) * v[2]),
                    sign * (cof(2, 0) * v[0] + cof(2, 1) * v[1] + cof(2, 2) * v[2]),
                ];
                *n = normalise(w);
            }
        }
        if let Some(ts) = &mut self.attributes.tangents {
            for t in ts.iter_mut() {
                let v = [f64::from(t[0]), f64::from(t[1]), f64::from(t[2])];
                let w = [
                    l[0][0] * v[0] + l[0][1] * v[1] + l[0][2] * v[2],
                    l[1][0] * v[0] + l[1][1] * v[1] + l[1][2] * v[2],
                    l[2][0] * v[0] + l[2][1] * v[1] + l[2][2] * v[2],
                ];
                let n = normalise(w);
                *t = [n[0], n[1], n[2], t[3]];
            }
        }
        if det < 0.0 {
            for t in &mut self.triangles {
                t.swap(1, 2);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn position_step_is_the_float_spacing_at_the_largest_coordinate() {
        let m = super::Mesh::from_triangles(
            vec![[4.0e6, 0.0, 0.0], [4.0e6, 1.0, 0.0], [4.0e6, 0.0, 1.0]],
            vec![[0, 1, 2]],
        );
        // 4·10⁶ lies in [2^21, 2^22): floats are 2^(21 − 23) = 0.25 apart there.
        assert_eq!(m.position_step(), 0.25);
        let next = 4.0e6f32 + 0.25;
        assert!(next > 4.0e6 && 4.0e6f32 + 0.1 == 4.0e6);
        let unit = super::Mesh::from_triangles(
            vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.5]],
            vec![[0, 1, 2]],
        );
        assert_eq!(unit.position_step(), (-23.0f64).exp2());
        assert_eq!(super::Mesh::default().position_step(), 0.0);
    }

    use super::*;

    #[test]
    fn validate_catches_bad_index_and_nan() {
        let mut m = Mesh::from_triangles(vec![[0.0; 3], [1.0, 0.0, 0.0]], vec![[0, 1, 2]]);
        assert!(matches!(
            m.validate(),
            Err(MeshError::IndexOutOfRange { index: 2, .. })
        ));
        m.positions.push([0.0, f32::NAN, 0.0]);
        assert!(matches!(
            m.validate(),
            Err(MeshError::NonFinite { vertex: 2, .. })
        ));
        m.positions[2] = [0.0, 1.0, 0.0];
        assert_eq!(m.validate(), Ok(()));
    }

    #[test]
    fn bounding_box_matches_direct_selects_bit_for_bit() {
        // Every length around the chunks of four points, values of both signs,
        // zeros of both signs (which of two equal extremes is kept shows in the
        // sign) and a NaN (ignored).
        for n in 0..30usize {
            let positions: Vec<[f32; 3]> = (0..n)
                .map(|i| {
                    let f = i as f32;
                    let z = if i % 3 == 0 { -0.0 } else { 0.0 };
                    let y = if i == 7 {
                        f32::NAN
                    } else {
                        (f * 1.7).sin() * 10.0
                    };
                    [(f * 0.9).cos() * (f - 11.0), y, z]
                })
                .collect();
            // The reference: the same twelve lanes (four points at a time, then the
            // remainder, then the lanes of each axis in order) with direct selects.
            let flat = positions.as_flattened();
            let mut lo12 = [f32::INFINITY; 12];
            let mut hi12 = [f32::NEG_INFINITY; 12];
            for (j, &x) in flat.iter().enumerate() {
                let i = j % 12;
                lo12[i] = if x < lo12[i] { x } else { lo12[i] };
                hi12[i] = if x > hi12[i] { x } else { hi12[i] };
            }
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for k in 0..3 {
                for l in [k, k + 3, k + 6, k + 9] {
                    lo[k] = if lo12[l] < lo[k] { lo12[l] } else { lo[k] };
                    hi[k] = if hi12[l] > hi[k] { hi12[l] } else { hi[k] };
                }
            }
            let m = Mesh::from_triangles(positions, Vec::new());
            let got = m.bounding_box(false);
            if n == 0 {
                assert_eq!(got, None);
                continue;
            }
            let (glo, ghi) = got.unwrap();
            let bits = |a: [f32; 3]| a.map(f32::to_bits);
            assert_eq!((bits(glo), bits(ghi)), (bits(lo), bits(hi)), "n {n}");
            // And the values are the plain extremes (NaN ignored).
            let ys = m.positions.iter().map(|p| p[1]).filter(|y| !y.is_nan());
            assert_eq!(glo[1], ys.clone().fold(f32::INFINITY, f32::min));
            assert_eq!(ghi[1], ys.fold(f32::NEG_INFINITY, f32::max));
        }
    }

    #[test]
    fn compact_drops_unreferenced() {
        let mut m = Mesh::from_triangles(
            vec![[9.0; 3], [0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[1, 2, 3]],
        );
        m.attributes.uv0 = Some(vec![[9.0; 2], [0.0; 2], [1.0, 0.0], [0.0, 1.0]]);
        let order = m.compact_vertices();
        assert_eq!(order, vec![1, 2, 3]);
        assert_eq!(m.positions.len(), 3);
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        assert_eq!(m.attributes.uv0.as_ref().unwrap()[1], [1.0, 0.0]);
    }

    #[test]
    fn mirror_transform_flips_winding_and_normals() {
        let mut m = Mesh::from_triangles(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        );
        m.attributes.normals = Some(vec![[0.0, 0.0, 1.0]; 3]);
        // Mirror in x, translate by 2 in z (column-major).
        let mat = [
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 2.0, 1.0],
        ];
        m.transform(&mat);
        assert_eq!(m.positions[1], [-1.0, 0.0, 2.0]);
        assert_eq!(m.triangles[0], [0, 2, 1]);
        // The geometric normal of (0,2,1) after mirroring is still +z.
        assert_eq!(m.attributes.normals.as_ref().unwrap()[0], [0.0, 0.0, 1.0]);
    }
}
