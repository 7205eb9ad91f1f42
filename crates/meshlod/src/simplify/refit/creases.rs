//! Hard creases of the input restored in the output's normals.
//!
//! A collapse may cross a hard crease of the input (a line where the normal is
//! discontinuous: two wedges with different normals at each of its points) when
//! keeping it costs more than crossing it. One vertex normal then serves both sides
//! and the refit can only average them. Before the normals are refitted, each output
//! point's triangles are grouped by the input normals they cover: two triangles
//! sharing an edge at the point stay together unless both cover input triangles at a
//! crease and the mean input normals they cover differ by more than
//! [`CREASE_ANGLE_DEG`]. Where a normal wedge's triangles fall into several groups,
//! each group gets a wedge of its own (a copy of the vertex: same position, UVs and
//! colours), which the refit then fits to its side: the crease is back, as a normal
//! seam, without moving a point or changing a triangle.
//!
//! A smooth input (no point with two normals) is never split: the rule only puts back
//! discontinuities the input had.

use super::{normalise, Pair, Stream, CENTROID, NORMAL};
use crate::mesh::topology::UnionFind;
use crate::mesh::{Mesh, Weld};
use crate::metrics::triangle::dot;

/// Mean input normals of two neighbouring output triangles that differ by more than
/// this (degrees), both covering a crease of the input, are split apart.
pub(super) const CREASE_ANGLE_DEG: f64 = 45.0;
/// Two input wedges at one point whose normals differ by more than this (degrees)
/// make the point a crease point.
const DISCONTINUITY_DEG: f64 = 1.0;

/// Splits `out`'s normal wedges across the input's hard creases (module docs).
/// `pairs` are the input triangles' samples paired with `out`; vertices that are
/// `locked` are not split, nor any wedge at their point. Copies of vertices are
/// appended to `out`; returns, for each copy in order, the vertex it copies, and
/// sets `side` (one entry per vertex of `out`, extended for the copies) to a label
/// that differs between the sides of a split.
pub(super) fn split_creases(
    input: &Mesh,
    out: &mut Mesh,
    pairs: &[Pair],
    locked: &[bool],
    side: &mut Vec<u32>,
) -> Vec<u32> {
    let (Some(n_in), Some(n_out)) = (&input.attributes.normals, &out.attributes.normals) else {
        return Vec::new();
    };
    // Input points with a normal discontinuity.
    let wi = Weld::exact(&input.positions);
    let cos_disc = DISCONTINUITY_DEG.to_radians().cos();
    let mut crease_point = vec![false; wi.representative.len()];
    for (v, &p) in wi.point_of.iter().enumerate() {
        let r = wi.representative[p as usize] as usize;
        if v != r && cos_between(n_in[v], n_in[r]) < cos_disc {
            crease_point[p as usize] = true;
        }
    }
    if !crease_point.contains(&true) {
        return Vec::new();
    }
    // Per output triangle: the area-weighted mean of the input normals its samples
    // carry, and whether any of them comes from an input triangle at a crease.
    let s_in = Stream {
        values: n_in.as_flattened(),
        dim: 3,
    };
    let nt = out.triangles.len();
    let mut mean = vec![[0.0f64; 3]; nt];
    let mut at_crease = vec![false; nt];
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
        at_crease[o as usize] |= input.triangles[t]
            .iter()
            .any(|&v| crease_point[wi.point_of[v as usize] as usize]);
    }
    mean.iter_mut().for_each(|m| normalise(m));
    let cos_crease = CREASE_ANGLE_DEG.to_radians().cos();
    let crease = |a: usize, b: usize| {
        at_crease[a]
            && at_crease[b]
            && mean[a] != [0.0; 3]
            && mean[b] != [0.0; 3]
            && dot(mean[a], mean[b]) < cos_crease
    };

    // The corners at each output point (counting sort by point).
    let wo = Weld::exact(&out.positions);
    let np = wo.representative.len();
    let mut start = vec![0u32; np + 1];
    for t in &out.triangles {
        for &v in t {
            start[wo.point_of[v as usize] as usize + 1] += 1;
        }
    }
    for i in 0..np {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut corners = vec![(0u32, 0u8); nt * 3];
    for (t, tri) in out.triangles.iter().enumerate() {
        for (k, &v) in tri.iter().enumerate() {
            let p = wo.point_of[v as usize] as usize;
            corners[fill[p] as usize] = (t as u32, k as u8);
            fill[p] += 1;
        }
    }

    let nv = out.positions.len();
    side.resize(nv, 0);
    let mut next_side = side.iter().copied().max().unwrap_or(0) + 1;
    let mut copies: Vec<u32> = Vec::new();
    let mut owner = vec![u32::MAX; nv];
    let mut joined = UnionFind::new(0);
    let mut kept = UnionFind::new(0);
    let mut edges: Vec<(u32, u32)> = Vec::new();
    let mut copy_of: Vec<(u32, u32, u32)> = Vec::new();
    let mut verts: Vec<u32> = Vec::new();
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
        let vert = |i: usize| verts[i];
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
                let mut u = tri[(k as usize + d) % 3] as usize;
                if u >= nv {
                    u = copies[u - nv] as usize;
                }
                let o = wo.point_of[u];
                edges.push((o, i as u32));
            }
        }
        edges.sort_unstable();
        // `joined`: one normal value and a shared edge; `kept`: the same, and no
        // crease between them.
        joined.reset(n);
        kept.reset(n);
        let mut any_crease = false;
        for w in edges.windows(2) {
            let ((oa, a), (ob, b)) = (w[0], w[1]);
            if oa != ob || a == b {
                continue;
            }
            let (va, vb) = (vert(a as usize) as usize, vert(b as usize) as usize);
            if !same_normal(n_out[va], n_out[vb]) {
                continue;
            }
            joined.union(a, b);
            let (ta, tb) = (cs[a as usize].0 as usize, cs[b as usize].0 as usize);
            if crease(ta, tb) {
                any_crease = true;
            } else {
                kept.union(a, b);
            }
        }
        if !any_crease {
            continue;
        }
        // A joined set split into several kept sets: the first (smallest corner)
        // keeps its wedges, each other one gets a side of its own.
        let mut is_first = vec![false; n];
        let mut sides = vec![0u32; n];
        for i in 0..n as u32 {
            let (j, kr) = (joined.find(i), kept.find(i));
            is_first[i as usize] = kr == j;
            if kr == i && kr != j {
                sides[i as usize] = next_side;
                next_side += 1;
            }
        }
        for (i, _) in is_first.iter().enumerate().filter(|(_, &f)| f) {
            let v = vert(i) as usize;
            if owner[v] == u32::MAX {
                owner[v] = kept.find(i as u32) + start[p];
            }
        }
        copy_of.clear();
        for i in 0..n {
            if is_first[i] {
                continue;
            }
            let kr = kept.find(i as u32);
            let id = kr + start[p];
            let s = sides[kr as usize];
            let v = vert(i);
            let (t, k) = cs[i];
            if owner[v as usize] == u32::MAX {
                owner[v as usize] = id;
                side[v as usize] = s;
            } else if owner[v as usize] != id {
                let c = match copy_of.iter().find(|&&(ov, ok, _)| ov == v && ok == kr) {
                    Some(&(_, _, c)) => c,
                    None => {
                        let c = (nv + copies.len()) as u32;
                        copies.push(v);
                        side.push(s);
                        copy_of.push((v, kr, c));
                        c
                    }
                };
                out.triangles[t as usize][k as usize] = c;
            }
        }
    }
    if !copies.is_empty() {
        let map: Vec<u32> = (0..nv as u32).chain(copies.iter().copied()).collect();
        out.positions = map.iter().map(|&v| out.positions[v as usize]).collect();
        out.attributes = out.attributes.gather(&map);
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
