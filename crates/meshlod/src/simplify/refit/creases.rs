//! Hard creases of the input restored in the output's normals.
//!
//! A collapse may cross a hard crease of the input (a line where the normal is
//! discontinuous: two wedges whose normals differ by more than [`CREASE_ANGLE_DEG`]
//! at each of its points) when keeping it costs more than crossing it. One vertex
//! normal then serves both sides and the refit can only average them. Before the
//! normals are refitted, each output point's triangles are grouped: two triangles
//! sharing an edge at the point (and a normal value) stay together unless the input
//! has crease points near both ends of that edge on both sides (samples whose
//! barycentric weight for the end is at least ⅓) and the mean input normals of the
//! samples near the edge (weight of the opposite corner at most ¼) differ across it
//! by more than [`CREASE_ANGLE_DEG`]: the input's normals jump along that edge. At a
//! point where that cut anything, each group gets a normal wedge of its own: a
//! vertex whose triangles fall into several groups is copied (same position, UVs
//! and colours) and the refit fits each copy to its side. The crease is back, as a
//! normal seam; no point moves, and each triangle keeps its corners' positions (some
//! corners now name a copy).
//!
//! A smooth input (no point with two normals that far apart) is never split, nor a
//! coarse bend of a smooth part between two creases (a cylinder's side from cap to
//! cap): near its edges the input's normals agree on both sides.

use super::{normalise, Pair, Stream, CENTROID, NORMAL};
use crate::mesh::topology::UnionFind;
use crate::mesh::{Mesh, Weld};
use crate::metrics::triangle::dot;
use std::collections::HashMap;

/// Input wedges at one point whose normals differ by more than this (degrees) make
/// a crease point; mean input normals of two neighbouring output triangles that
/// differ by more than this are split apart.
pub(super) const CREASE_ANGLE_DEG: f64 = 45.0;
/// Distinct normals of an input point compared with each new one, at most.
const SEEN: usize = 16;
/// A sample is near an output triangle's edge when its barycentric weight for the
/// opposite corner is at most this, and near a corner when its weight for it is at
/// least [`NEAR_CORNER`].
const NEAR_EDGE: f32 = 0.25;
const NEAR_CORNER: f32 = 1.0 / 3.0;

/// The input's hard-crease points: a point two of whose wedges' normals are more
/// than [`CREASE_ANGLE_DEG`] apart (each compared with the distinct normals seen
/// before it at its point, up to [`SEEN`] of them).
pub(super) struct CreasePoints {
    /// The input's exact weld (its points).
    weld: Weld,
    /// Per point of `weld`.
    crease: Vec<bool>,
}

impl CreasePoints {
    /// `None` when the input has no normals or no crease point.
    pub(super) fn of(input: &Mesh) -> Option<Self> {
        let n_in = input.attributes.normals.as_ref()?;
        let cos_crease = CREASE_ANGLE_DEG.to_radians().cos();
        let weld = Weld::exact(&input.positions);
        let (by_point, wedges) = weld.vertices_by_point();
        let mut crease = vec![false; weld.point_count()];
        let mut seen: Vec<[f32; 3]> = Vec::with_capacity(SEEN);
        for (p, flag) in crease.iter_mut().enumerate() {
            let ws = &wedges[by_point[p] as usize..by_point[p + 1] as usize];
            if ws.len() < 2 {
                continue;
            }
            seen.clear();
            for &v in ws {
                let n = n_in[v as usize];
                if n == [0.0; 3] || seen.iter().any(|&s| same_normal(s, n)) {
                    continue;
                }
                if seen.iter().any(|&s| cos_between(n, s) < cos_crease) {
                    *flag = true;
                    break;
                }
                if seen.len() < SEEN {
                    seen.push(n);
                }
            }
        }
        crease.contains(&true).then_some(Self { weld, crease })
    }

    /// Whether input triangle `t` has a corner at a crease point.
    pub(super) fn touches(&self, input: &Mesh, t: usize) -> bool {
        input.triangles[t]
            .iter()
            .any(|&v| self.crease[self.weld.point_of[v as usize] as usize])
    }
}

/// Splits `out`'s normal wedges across the input's hard creases (module docs).
/// `pairs` are the input triangles' samples paired with `out` (every input triangle
/// touching one of `creases` among them); `weld` is `out`'s exact weld (its points),
/// extended here for the copies; no wedge is split at a point with a `locked`
/// vertex. Copies are appended to `out`; returns, for each copy in order, the vertex
/// it copies, and sets `side` (one entry per vertex of `out`, extended for the
/// copies) to a label that differs between the groups of a split point (0
/// elsewhere).
pub(super) fn split_creases(
    input: &Mesh,
    out: &mut Mesh,
    pairs: &[Pair],
    creases: &CreasePoints,
    locked: &[bool],
    weld: &mut Weld,
    side: &mut Vec<u32>,
) -> Vec<u32> {
    let (Some(n_in), Some(n_out)) = (&input.attributes.normals, &out.attributes.normals) else {
        return Vec::new();
    };
    let cos_crease = CREASE_ANGLE_DEG.to_radians().cos();
    // Per output triangle: for each edge (named by its opposite corner) the
    // area-weighted mean of the input normals of the samples near it, and per corner
    // whether a sample near it comes from an input triangle at a crease point.
    let s_in = Stream {
        values: n_in.as_flattened(),
        dim: 3,
    };
    let nt = out.triangles.len();
    let mut band = vec![[[0.0f64; 3]; 3]; nt];
    let mut at_crease = vec![[false; 3]; nt];
    for p in pairs {
        let o = p.triangle[NORMAL];
        if o == u32::MAX {
            continue;
        }
        let t = p.input as usize;
        let mut a = [0.0f64; 3];
        s_in.interp(input, p.input, CENTROID, true, &mut a);
        normalise(&mut a);
        if !a.iter().all(|x| x.is_finite()) {
            continue;
        }
        let w = f64::from(p.weight);
        let b = p.bary[NORMAL];
        for (c, m) in band[o as usize].iter_mut().enumerate() {
            if b[c] <= NEAR_EDGE {
                for j in 0..3 {
                    m[j] += w * a[j];
                }
            }
        }
        if creases.touches(input, t) {
            for (c, &bc) in b.iter().enumerate() {
                at_crease[o as usize][c] |= bc >= NEAR_CORNER;
            }
        }
    }
    band.iter_mut().flatten().for_each(|m| normalise(m));
    // Triangles `ta` and `tb` share the edge from their corners `ka`, `kb` to their
    // corners `qa`, `qb`: a crease when the input has crease points near both ends
    // on both sides and the normals near the edge differ across it.
    let crease = |(ta, ka, qa): (usize, usize, usize), (tb, kb, qb): (usize, usize, usize)| {
        let (ea, eb) = (band[ta][3 - ka - qa], band[tb][3 - kb - qb]);
        at_crease[ta][ka]
            && at_crease[ta][qa]
            && at_crease[tb][kb]
            && at_crease[tb][qb]
            && ea != [0.0; 3]
            && eb != [0.0; 3]
            && dot(ea, eb) < cos_crease
    };

    // The corners at each output point (counting sort by point).
    let np = weld.point_count();
    let (start, corners) = weld.corners_by_point(&out.triangles);

    let nv = out.positions.len();
    side.clear();
    side.resize(nv, 0);
    let mut next_side = 1u32;
    let mut copies: Vec<u32> = Vec::new();
    // Per vertex, the group (global id of its first corner) that keeps it.
    let mut owner = vec![u32::MAX; nv];
    let mut kept = UnionFind::new(0);
    let mut edges: Vec<(u32, u32, u8)> = Vec::new();
    let mut verts: Vec<u32> = Vec::new();
    let mut labels: Vec<u32> = Vec::new();
    let mut copy_of: HashMap<(u32, u32), u32> = HashMap::new();
    for p in 0..np {
        let cs = &corners[start[p] as usize..start[p + 1] as usize];
        let n = cs.len();
        if n < 2 {
            continue;
        }
        verts.clear();
        verts.extend(
            cs.iter()
                .map(|&(t, k)| out.triangles[t as usize][k as usize]),
        );
        if verts
            .iter()
            .any(|&v| locked.get(v as usize).copied().unwrap_or(false))
        {
            continue;
        }
        // Neighbours at this point: corners whose triangles share the edge to
        // another point.
        edges.clear();
        for (i, &(t, k)) in cs.iter().enumerate() {
            let tri = out.triangles[t as usize];
            for d in [1, 2] {
                // A corner copied at an earlier point is at its original's point.
                let kq = (k as usize + d) % 3;
                let mut u = tri[kq] as usize;
                if u >= nv {
                    u = copies[u - nv] as usize;
                }
                edges.push((weld.point_of[u], i as u32, kq as u8));
            }
        }
        edges.sort_unstable();
        // Groups: one normal value and a shared edge, and no crease between them.
        kept.reset(n);
        let mut any_crease = false;
        for w in edges.windows(2) {
            let ((oa, a, qa), (ob, b, qb)) = (w[0], w[1]);
            if oa != ob || a == b {
                continue;
            }
            let (va, vb) = (verts[a as usize] as usize, verts[b as usize] as usize);
            if !same_normal(n_out[va], n_out[vb]) {
                continue;
            }
            let ((ta, ka), (tb, kb)) = (cs[a as usize], cs[b as usize]);
            let side_a = (ta as usize, ka as usize, qa as usize);
            if crease(side_a, (tb as usize, kb as usize, qb as usize)) {
                any_crease = true;
            } else {
                kept.union(a, b);
            }
        }
        if !any_crease {
            continue;
        }
        // Each group a wedge of its own: the first group to reach a vertex keeps
        // it, the others get a copy (one per group and vertex).
        labels.clear();
        labels.resize(n, 0);
        copy_of.clear();
        for i in 0..n {
            let kr = kept.find(i as u32);
            if labels[kr as usize] == 0 {
                labels[kr as usize] = next_side;
                next_side += 1;
            }
            let label = labels[kr as usize];
            let id = kr + start[p];
            let v = verts[i];
            if owner[v as usize] == u32::MAX {
                owner[v as usize] = id;
                side[v as usize] = label;
            } else if owner[v as usize] != id {
                let c = *copy_of.entry((v, kr)).or_insert_with(|| {
                    copies.push(v);
                    side.push(label);
                    (nv + copies.len() - 1) as u32
                });
                let (t, k) = cs[i];
                out.triangles[t as usize][k as usize] = c;
            }
        }
    }
    if !copies.is_empty() {
        let map: Vec<u32> = (0..nv as u32).chain(copies.iter().copied()).collect();
        out.positions = map.iter().map(|&v| out.positions[v as usize]).collect();
        out.attributes = out.attributes.gather(&map);
        let more: Vec<u32> = copies.iter().map(|&c| weld.point_of[c as usize]).collect();
        weld.point_of.extend(more);
    }
    copies
}

/// Cosine of the angle between two (not necessarily unit) normals.
fn cos_between(a: [f32; 3], b: [f32; 3]) -> f64 {
    let (a, b) = (a.map(f64::from), b.map(f64::from));
    let l = (dot(a, a) * dot(b, b)).sqrt();
    if l > 0.0 {
        dot(a, b) / l
    } else {
        1.0
    }
}

/// The same normal value, bit for bit (`-0` equal to `+0`).
fn same_normal(a: [f32; 3], b: [f32; 3]) -> bool {
    a.map(|x| (x + 0.0).to_bits()) == b.map(|x| (x + 0.0).to_bits())
}
