//! Hard creases of the input restored in the output's normals.
//!
//! A collapse may cross a hard crease of the input (a line where the normal is
//! discontinuous: wedges whose normals differ by more than [`CREASE_ANGLE_DEG`] at
//! each of its points) when keeping it costs more than crossing it. One vertex normal
//! then serves both sides and the refit can only average them. Before the normals are
//! refitted, each output point's triangles are grouped by the input normals they
//! cover: two triangles sharing an edge at the point (and a normal value) stay
//! together unless, near both ends of that edge (the third of each triangle closest
//! to the end), both cover input triangles at a crease, and the mean input normals
//! of the two triangles differ by more than [`CREASE_ANGLE_DEG`]: the input's crease
//! runs along the edge. (A coarse bend of a smooth surface next to a crease, such as
//! a cylinder's side meeting its cap, stays smooth.) At a point where that cut
//! anything, each group gets a normal wedge of its own: a vertex whose triangles fall
//! into several groups is copied (same position, UVs and colours) and the refit fits
//! each copy to its side. The crease is back, as a normal seam; no point moves, and
//! each triangle keeps its corners' positions (some corners now name a copy).
//!
//! A smooth input (no point with two normals that far apart) is never split: the rule
//! only puts back discontinuities the input had, where the input had them.

use super::{normalise, Pair, Stream, CENTROID, NORMAL};
use crate::mesh::topology::UnionFind;
use crate::mesh::{Mesh, Weld};
use crate::metrics::triangle::dot;
use std::collections::HashMap;

/// Input wedges at one point whose normals differ by more than this (degrees) make
/// a crease point; mean input normals of two neighbouring output triangles that
/// differ by more than this are split apart.
pub(super) const CREASE_ANGLE_DEG: f64 = 45.0;

/// Splits `out`'s normal wedges across the input's hard creases (module docs).
/// `pairs` are the input triangles' samples paired with `out`; `weld` is `out`'s
/// exact weld (its points), extended here for the copies; no wedge is split at a
/// point with a `locked` vertex. Copies are appended to `out`; returns, for each copy
/// in order, the vertex it copies, and sets `side` (one entry per vertex of `out`,
/// extended for the copies) to a label that differs between the groups of a split
/// point (0 elsewhere).
pub(super) fn split_creases(
    input: &Mesh,
    out: &mut Mesh,
    pairs: &[Pair],
    locked: &[bool],
    weld: &mut Weld,
    side: &mut Vec<u32>,
) -> Vec<u32> {
    let (Some(n_in), Some(n_out)) = (&input.attributes.normals, &out.attributes.normals) else {
        return Vec::new();
    };
    let cos_crease = CREASE_ANGLE_DEG.to_radians().cos();
    // Input points with a hard crease: a wedge's normal that far from the point's
    // first non-zero one.
    let wi = Weld::exact(&input.positions);
    let mut first = vec![u32::MAX; wi.representative.len()];
    let mut crease_point = vec![false; wi.representative.len()];
    for (v, &p) in wi.point_of.iter().enumerate() {
        let n = n_in[v];
        if n == [0.0; 3] {
            continue;
        }
        let f = &mut first[p as usize];
        if *f == u32::MAX {
            *f = v as u32;
        } else if cos_between(n, n_in[*f as usize]) < cos_crease {
            crease_point[p as usize] = true;
        }
    }
    drop(first);
    if !crease_point.contains(&true) {
        return Vec::new();
    }
    // Per output triangle: the area-weighted mean of the input normals its samples
    // carry, and per corner whether a sample in the third of the triangle nearest it
    // comes from an input triangle at a crease.
    let s_in = Stream {
        values: n_in.as_flattened(),
        dim: 3,
    };
    let nt = out.triangles.len();
    let mut mean = vec![[0.0f64; 3]; nt];
    let mut at_crease = vec![[false; 3]; nt];
    for (t, p) in pairs.iter().enumerate() {
        let o = p.triangle[NORMAL];
        if o == u32::MAX {
            continue;
        }
        let mut a = [0.0f64; 3];
        s_in.interp(input, t as u32, CENTROID, true, &mut a);
        normalise(&mut a);
        if !a.iter().all(|x| x.is_finite()) {
            continue;
        }
        let w = f64::from(p.weight);
        let m = &mut mean[o as usize];
        for j in 0..3 {
            m[j] += w * a[j];
        }
        if input.triangles[t]
            .iter()
            .any(|&v| crease_point[wi.point_of[v as usize] as usize])
        {
            for (c, &b) in p.bary[NORMAL].iter().enumerate() {
                at_crease[o as usize][c] |= b >= 1.0 / 3.0;
            }
        }
    }
    drop(wi);
    mean.iter_mut().for_each(|m| normalise(m));
    let crease = |(ta, ka): (u32, u8), (tb, kb): (u32, u8)| {
        let (a, b) = (ta as usize, tb as usize);
        at_crease[a][ka as usize]
            && at_crease[b][kb as usize]
            && mean[a] != [0.0; 3]
            && mean[b] != [0.0; 3]
            && dot(mean[a], mean[b]) < cos_crease
    };

    // The corners at each output point (counting sort by point).
    let np = weld.representative.len();
    let mut start = vec![0u32; np + 1];
    for t in &out.triangles {
        for &v in t {
            start[weld.point_of[v as usize] as usize + 1] += 1;
        }
    }
    for i in 0..np {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut corners = vec![(0u32, 0u8); nt * 3];
    for (t, tri) in out.triangles.iter().enumerate() {
        for (k, &v) in tri.iter().enumerate() {
            let p = weld.point_of[v as usize] as usize;
            corners[fill[p] as usize] = (t as u32, k as u8);
            fill[p] += 1;
        }
    }
    drop(fill);

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
            // A crease along the shared edge: at a crease near both of its ends.
            let (ta, tb) = (cs[a as usize].0, cs[b as usize].0);
            if crease(cs[a as usize], cs[b as usize]) && crease((ta, qa), (tb, qb)) {
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
