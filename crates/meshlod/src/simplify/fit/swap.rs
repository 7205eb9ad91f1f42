//! Edge swaps toward the input (`meshlod simplify --swap`, and before the fit's
//! iterations with `--fit`): the distance term of Hoppe, DeRose, Duchamp, McDonald
//! and Stuetzle, "Mesh optimization" (SIGGRAPH 1993), minimised over the
//! connectivity instead of the positions. Their *edge swap* replaces the diagonal
//! `x–y` of the quad formed by two triangles with the other diagonal `c–d`; it is
//! kept when it lowers `E_dist`, the sum of the squared distances from the input's
//! sample points to the output. The collapses choose where each merged point goes,
//! by the quadrics of its two ends; which diagonal of a quad follows the surface
//! better is something no collapse decides, and a curved patch is often crossed by
//! the wrong one.
//!
//! Each interior edge is tried once per sweep ([`SWEEPS`] at most, in triangle
//! order; a triangle swapped in a sweep waits for the next one, and after the first
//! sweep only the edges of swapped triangles and their neighbours are tried again:
//! no other edge's triangles or samples changed). Its two triangles' input samples
//! (the fit's, on their nearest output triangles: each input vertex, and with the
//! fit's iterations each input centroid too) are weighed against the two new
//! triangles; the swap is taken when
//!
//! - the weighted sum of their squared distances falls by at least [`MIN_GAIN`]
//!   of its old value, each sample on the new triangle on its side of the plane
//!   through `c–d` along the quad's normal (old: on its own triangle), and their
//!   largest distance does not grow. Two cheaper tests come first. Over a quad
//!   that is not folded, the two triangulations lie between two parallel planes
//!   `h` apart (`h` the distance between the diagonals' lines), so a sample on
//!   the nearer of its two old triangles gets nearer by at most `h` and the gain
//!   is at most `2 h Σ w d`; edges below that are skipped (a heuristic where the
//!   quad is folded or a sample sits on the farther triangle: it can only miss a
//!   swap). Then the distances to the new triangles' planes, which are at most
//!   those to the triangles, must already show the gain (a true bound);
//! - the edge is not on a border, a non-manifold edge, a UV seam or a material
//!   border (its two ends are one vertex each in both triangles, and both
//!   triangles are in one group), and `c–d` is not an edge already;
//! - neither new triangle turns by more than 60° from the old triangle it replaces
//!   or is a sliver (quality below both the simplifier's floor and the old
//!   triangles' lowest);
//! - the other direction does not get worse: the largest distance to the input
//!   from the new triangles' centroids and the new diagonal's points at ¼, ½ and
//!   ¾ is at most that from the same points of the old pair (seven closest-point
//!   queries against the input's tree, and for the new diagonal's three points
//!   only whether each is within that distance; with the old diagonal's midpoint
//!   alone, one swap on fandisk
//!   at 10% raised the Hausdorff maximum from 0.0377% to 0.0454% of the
//!   diagonal), and no more of the two triangles face away from the input
//!   triangle nearest their centroid than before (the orientation repair's test).
//!
//! The samples of the two triangles then go to the nearer of the new ones. No point
//! moves; topology, attributes and borders are unchanged.
//!
//! Measured (`meshlod simplify --measure`, bunny, armadillo, Nefertiti, Lucy,
//! turbine blade and fandisk at 10% and 1%): alone (vertex samples), Hausdorff mean
//! ×0.902–0.987 (geometric mean ×0.947) at maxima ×0.981–1.030 (×1.001); before
//! the fit's iterations, mean ×0.913–0.985 (×0.952) and maxima ×0.929–1.150
//! (×0.994) against the fit alone. See `docs/methods/qem.md` for the time.

use super::{dot, f64v, norm, sub, Bvh, Connectivity, Frame, Mesh, Sample, V3};
use crate::filter::triangle_quality;
use crate::metrics::triangle::cross;
use crate::simplify::facing;

/// Most sweeps over the edges.
pub(super) const SWEEPS: usize = 4;

/// Smallest gain taken, a fraction of the two triangles' squared sum (0 and 0.001
/// gave the same means to 0.3% on the bunny at 10%; this one lets the bound below
/// rule out nearly flat quads).
const MIN_GAIN: f64 = 0.01;

/// What the swaps need besides the output's triangles.
pub(super) struct SwapContext<'a> {
    /// The input mesh and its closest-point tree.
    pub input: &'a Mesh,
    pub input_tree: &'a Bvh,
    /// Output points' positions.
    pub x: &'a [V3],
    /// Each output triangle's group (material), if the mesh has groups.
    pub groups: Option<&'a [u32]>,
    /// The simplifier's sliver floor.
    pub min_quality: f64,
}

/// The output's triangles over points and over vertices, its connectivity and the
/// input samples grouped by triangle, all updated by the swaps.
pub(super) struct SwapState<'a> {
    pub tris: &'a mut Vec<[u32; 3]>,
    pub out_tris: &'a mut [[u32; 3]],
    pub conn: &'a mut Connectivity,
    pub samples: &'a mut Vec<Sample>,
    pub tri_start: &'a mut Vec<u32>,
    /// Per triangle, the normal of an input triangle near its centroid (the
    /// fit's orientation reference: the nearest among those whose centroids it
    /// received) and that squared distance; a swapped triangle gets the normal of
    /// the input triangle nearest its centroid (a query; the distance is not used
    /// after the sample search and is set to 0).
    pub reference: &'a mut [(V3, f64)],
}

impl SwapState<'_> {
    /// Where triangle `t`'s samples sit in `samples`.
    fn range(&self, t: usize) -> std::ops::Range<usize> {
        self.tri_start[t] as usize..self.tri_start[t + 1] as usize
    }

    /// Triangle `t`'s samples.
    fn group(&self, t: usize) -> &[Sample] {
        &self.samples[self.range(t)]
    }
}

/// Runs the sweeps; returns the number of swaps.
pub(super) fn swap_edges(ctx: &SwapContext<'_>, st: &mut SwapState<'_>) -> usize {
    let x = ctx.x;
    let nt = st.tris.len();
    let np = x.len();
    let mut total = 0usize;
    let mut hint: Option<u32> = None;
    // The largest distance to the input of the points `pts` (the first two the
    // triangles' centroids) and how many of the two triangles face away from the
    // input triangle nearest their centroid.
    let mut out_side = |pts: &[V3], normals: [V3; 2], hint: &mut Option<u32>| {
        let mut dmax = 0.0f64;
        let mut away = 0u32;
        let mut refs = [[0.0; 3]; 2];
        for (i, p) in pts.iter().enumerate() {
            let cl = ctx.input_tree.closest(*p, *hint)?;
            *hint = Some(cl.triangle);
            dmax = dmax.max(cl.dist2.sqrt());
            if i < 2 {
                let r = facing::face_normal(ctx.input, cl.triangle);
                refs[i] = r;
                if dot(normals[i], r) < 0.0 {
                    away += 1;
                }
            }
        }
        Some((dmax, away, refs))
    };
    // Which triangles' edges to try: all in the first sweep, then those of the
    // triangles a swap changed and their neighbours (no other edge's two triangles
    // or samples changed).
    let mut active = vec![true; nt];
    for _ in 0..SWEEPS {
        // Per triangle: its samples' weighted sums of d and d² and their largest d²,
        // d the distance to the triangle.
        let sums: Vec<[f64; 3]> = (0..nt)
            .map(|t| {
                let mut r = [0.0f64; 3];
                if !active[t] {
                    return r;
                }
                let f = Frame::new(&st.tris[t].map(|p| x[p as usize]));
                for s in st.group(t) {
                    let d2 = dist2(&f, f64v(s.p));
                    let w = f64::from(s.weight);
                    r[0] += w * d2.sqrt();
                    r[1] += w * d2;
                    r[2] = r[2].max(d2);
                }
                r
            })
            .collect();
        let mut touched = vec![false; nt];
        // The triangle each sample goes to (its own unless its triangle swapped).
        let mut owner: Vec<u32> = Vec::new();
        let mut swaps = 0usize;
        for t1 in 0..nt {
            if touched[t1] {
                continue;
            }
            for k in 0..3 {
                let t2 = st.conn.across[t1][k] as usize;
                if t2 == u32::MAX as usize || t2 <= t1 || touched[t2] || !(active[t1] && active[t2])
                {
                    continue;
                }
                let (a, b) = (sums[t1], sums[t2]);
                let old_sums = [a[0] + b[0], a[1] + b[1], a[2].max(b[2])];
                let edge = Candidate {
                    t1,
                    k,
                    t2,
                    old_sums,
                };
                let Some(swap) = try_swap(ctx, st, edge, &mut hint, &mut out_side) else {
                    continue;
                };
                let Swap {
                    new_points,
                    new_vertices,
                    frames: [f1, f2],
                    refs,
                } = swap;
                if owner.is_empty() {
                    owner = (0..nt)
                        .flat_map(|t| std::iter::repeat_n(t as u32, st.range(t).len()))
                        .collect();
                }
                for t in [t1, t2] {
                    for s in st.range(t) {
                        let p = f64v(st.samples[s].p);
                        let (a, b) = (dist2(&f1, p), dist2(&f2, p));
                        owner[s] = if a <= b { t1 as u32 } else { t2 as u32 };
                    }
                }
                st.tris[t1] = new_points[0];
                st.tris[t2] = new_points[1];
                st.out_tris[t1] = new_vertices[0];
                st.out_tris[t2] = new_vertices[1];
                st.reference[t1] = (refs[0], 0.0);
                st.reference[t2] = (refs[1], 0.0);
                touched[t1] = true;
                touched[t2] = true;
                swaps += 1;
                break;
            }
        }
        total += swaps;
        if swaps == 0 {
            break;
        }
        *st.conn = super::connectivity(st.tris, np);
        regroup(st, &mut owner);
        active.fill(false);
        for t in 0..nt {
            if touched[t] {
                active[t] = true;
                for &o in &st.conn.across[t] {
                    if o != u32::MAX {
                        active[o as usize] = true;
                    }
                }
            }
        }
    }
    total
}

/// A swap found acceptable: the two new triangles over points and over vertices,
/// their frames (for the samples' reassignment), and the normals of the input
/// triangles nearest their centroids.
struct Swap {
    new_points: [[u32; 3]; 2],
    new_vertices: [[u32; 3]; 2],
    frames: [Frame; 2],
    refs: [V3; 2],
}

type OutSide<'f> = dyn FnMut(&[V3], [V3; 2], &mut Option<u32>) -> Option<(f64, u32, [V3; 2])> + 'f;

/// Edge `k` of triangle `t1` (its corners `k`, `k + 1`), shared with `t2`, and the
/// sums of `t1`'s and `t2`'s samples together (weighted distances, weighted squared
/// distances, largest squared distance).
#[derive(Clone, Copy)]
struct Candidate {
    t1: usize,
    k: usize,
    t2: usize,
    old_sums: [f64; 3],
}

/// The swap of `edge` if every rule of the module docs allows it.
fn try_swap(
    ctx: &SwapContext<'_>,
    st: &SwapState<'_>,
    edge: Candidate,
    hint: &mut Option<u32>,
    out_side: &mut OutSide<'_>,
) -> Option<Swap> {
    let Candidate {
        t1,
        k,
        t2,
        old_sums,
    } = edge;
    let q = quad_of(ctx, st, edge)?;
    // Over an unfolded quad the two triangulations are at most `h` apart (the
    // distance between the diagonals' lines), so no sample gets nearer by more
    // than `h`: the gain is at most 2 h Σ w d (a heuristic for a folded quad; it
    // can only miss a swap).
    let [s_wd, e_old, _] = old_sums;
    if e_old <= 0.0 {
        return None;
    }
    if 2.0 * q.diagonals_apart(ctx.x) * s_wd <= MIN_GAIN * e_old {
        return None;
    }
    let Quad { px, py, pc, pd, k2 } = q;
    let new = [[px, pd, pc], [py, pc, pd]];
    let pairs = Pairs::new(ctx.x, [[px, py, pc], [py, px, pd]], new);
    for i in 0..2 {
        let (on, nn) = (pairs.on[i], pairs.nn[i]);
        let (lo, ln) = (norm(on), norm(nn));
        if ln.is_nan() || ln <= 0.0 || dot(on, nn) < super::MAX_TURN_COS * lo * ln {
            return None;
        }
    }
    let (oc, nc, on, nn) = (&pairs.oc, &pairs.nc, &pairs.on, &pairs.nn);
    let q_old = triangle_quality(&oc[0], on[0]).min(triangle_quality(&oc[1], on[1]));
    let q_new = triangle_quality(&nc[0], nn[0]).min(triangle_quality(&nc[1], nn[1]));
    if q_new < q_old.min(ctx.min_quality) {
        return None;
    }
    let frames_new = [Frame::new(&nc[0]), Frame::new(&nc[1])];
    if !input_side_gains(ctx.x, st, edge, q, &pairs, &frames_new) {
        return None;
    }
    let refs = output_side_holds(ctx, q, &pairs, hint, out_side)?;
    let (va, vb) = (st.out_tris[t1], st.out_tris[t2]);
    let (vx, vy, vc, vd) = (va[k], va[(k + 1) % 3], va[(k + 2) % 3], vb[(k2 + 2) % 3]);
    Some(Swap {
        new_points: new,
        new_vertices: [[vx, vd, vc], [vy, vc, vd]],
        frames: frames_new,
        refs,
    })
}

/// The quad around an edge `x–y`: `c` opposite in the first triangle, `d` in the
/// second (which runs `y → x`, its edge `k2`).
#[derive(Clone, Copy)]
struct Quad {
    px: u32,
    py: u32,
    pc: u32,
    pd: u32,
    k2: usize,
}

impl Quad {
    /// The distance between the lines of the two diagonals (infinite when they are
    /// parallel).
    fn diagonals_apart(&self, x: &[V3]) -> f64 {
        let (pxv, pyv, pcv, pdv) = (
            x[self.px as usize],
            x[self.py as usize],
            x[self.pc as usize],
            x[self.pd as usize],
        );
        let m = cross(sub(pyv, pxv), sub(pdv, pcv));
        let lm = norm(m);
        if lm > 0.0 {
            dot(sub(pcv, pxv), m).abs() / lm
        } else {
            f64::INFINITY
        }
    }
}

/// The quad of `edge` when its diagonal can be swapped at all: two distinct
/// opposite points, not a seam (x and y are one vertex each in both triangles),
/// one group, and no edge `c–d` already.
fn quad_of(ctx: &SwapContext<'_>, st: &SwapState<'_>, edge: Candidate) -> Option<Quad> {
    let Candidate { t1, k, t2, .. } = edge;
    let (a, b) = (st.tris[t1], st.tris[t2]);
    let (px, py, pc) = (a[k], a[(k + 1) % 3], a[(k + 2) % 3]);
    // t2 runs y → x (consistently oriented) with d opposite.
    let k2 = (0..3).find(|&j| b[j] == py && b[(j + 1) % 3] == px)?;
    let pd = b[(k2 + 2) % 3];
    if pc == pd || [px, py].contains(&pc) || [px, py].contains(&pd) {
        return None;
    }
    let (va, vb) = (st.out_tris[t1], st.out_tris[t2]);
    if va[k] != vb[(k2 + 1) % 3] || va[(k + 1) % 3] != vb[k2] {
        return None;
    }
    if let Some(g) = ctx.groups {
        if g.get(t1) != g.get(t2) {
            return None;
        }
    }
    if has_edge(st.conn, st.tris, pc, pd) {
        return None;
    }
    Some(Quad { px, py, pc, pd, k2 })
}

/// The old and the new pair of triangles over a quad: their corners and
/// (unnormalised) normals.
struct Pairs {
    oc: [[V3; 3]; 2],
    nc: [[V3; 3]; 2],
    on: [V3; 2],
    nn: [V3; 2],
}

impl Pairs {
    /// The pairs over points `old` and `new` (positions `x`).
    fn new(x: &[V3], old: [[u32; 3]; 2], new: [[u32; 3]; 2]) -> Self {
        let corners = |t: [u32; 3]| t.map(|p| x[p as usize]);
        let normal = |c: &[V3; 3]| cross(sub(c[1], c[0]), sub(c[2], c[0]));
        let (oc, nc) = (old.map(corners), new.map(corners));
        let (on, nn) = (oc.each_ref().map(normal), nc.each_ref().map(normal));
        Self { oc, nc, on, nn }
    }
}

/// Input → output: whether the samples of both triangles of `edge` lie nearer the
/// new pair (`frames_new`) than the old by at least the minimum gain, none farther
/// than the farthest was. Each sample on the new triangle on its side of the plane
/// through the new diagonal along the quad's normal.
fn input_side_gains(
    x: &[V3],
    st: &SwapState<'_>,
    edge: Candidate,
    q: Quad,
    pairs: &Pairs,
    frames_new: &[Frame; 2],
) -> bool {
    let Candidate {
        t1, t2, old_sums, ..
    } = edge;
    let [_, e_old, m_old] = old_sums;
    let Quad { px, py, pc, pd, .. } = q;
    let (on, nn) = (&pairs.on, &pairs.nn);
    let (pcv, pdv) = (x[pc as usize], x[pd as usize]);
    let side = cross(add(on[0], on[1]), sub(pdv, pcv));
    let x_side = dot(sub(x[px as usize], pcv), side) > 0.0;
    let (mut e_new, mut m_new) = (0.0f64, 0.0f64);
    let bound = e_old * (1.0 - MIN_GAIN);
    // First by the distances to the new triangles' planes (at most the distances
    // to the triangles), which rules out most edges for a few operations a sample.
    let units = nn.map(|n| {
        let l = norm(n);
        n.map(|v| v / l)
    });
    let offs = [dot(units[0], x[px as usize]), dot(units[1], x[py as usize])];
    for t in [t1, t2] {
        for s in st.group(t) {
            let p = f64v(s.p);
            let i = usize::from((dot(sub(p, pcv), side) > 0.0) != x_side);
            let r = dot(units[i], p) - offs[i];
            e_new += f64::from(s.weight) * r * r;
        }
    }
    if e_new >= bound {
        return false;
    }
    e_new = 0.0;
    for t in [t1, t2] {
        for s in st.group(t) {
            let p = f64v(s.p);
            let on_x = (dot(sub(p, pcv), side) > 0.0) == x_side;
            let d_new = dist2(&frames_new[usize::from(!on_x)], p);
            e_new += f64::from(s.weight) * d_new;
            m_new = m_new.max(d_new);
            if e_new >= bound || m_new > m_old {
                return false;
            }
        }
    }
    true
}

/// Output → input, and facing: whether the new pair is no farther from the input
/// than the old (the triangles' centroids and the diagonal's points at ½, ¼ and ¾)
/// and faces away no more; then the normals of the input triangles nearest the new
/// triangles' centroids.
fn output_side_holds(
    ctx: &SwapContext<'_>,
    q: Quad,
    pairs: &Pairs,
    hint: &mut Option<u32>,
    out_side: &mut OutSide<'_>,
) -> Option<[V3; 2]> {
    let x = ctx.x;
    let Quad { px, py, pc, pd, .. } = q;
    // The triangles' centroids and the diagonal `p–q`'s points at ½, ¼ and ¾.
    let points = |c: &[[V3; 3]; 2], p: u32, q: u32| -> [V3; 5] {
        let at =
            |f: f64| std::array::from_fn(|j| (1.0 - f) * x[p as usize][j] + f * x[q as usize][j]);
        [
            facing::centroid(&c[0]),
            facing::centroid(&c[1]),
            at(0.5),
            at(0.25),
            at(0.75),
        ]
    };
    let (d_old, away_old, _) = out_side(&points(&pairs.oc, px, py), pairs.on, hint)?;
    // The new pair: its centroids' nearest input triangles (their facing and
    // normals are needed), then only whether each point of the new diagonal is
    // within `d_old` of the input (a cheaper query that stops at the first
    // triangle near enough; the same answer as comparing the exact distance).
    let new_points = points(&pairs.nc, pc, pd);
    let (d_new, away_new, refs) = out_side(&new_points[..2], pairs.nn, hint)?;
    if d_new > d_old || away_new > away_old {
        return None;
    }
    for p in &new_points[2..] {
        if !ctx.input_tree.any_near(*p, *hint, |d2| d2.sqrt() <= d_old) {
            return None;
        }
    }
    Some(refs)
}

/// Whether some triangle has the edge `a–b`, with `conn` (the fans) as it was at the
/// start of the sweep and `tris` as the swaps since left them. A triangle slot
/// changes at most once a sweep, and then each of its new edges keeps an end the
/// slot held at the sweep's start (`x–d` and `c–x` in `x`'s slot, `y–c` and `d–y`
/// in `y`'s, `c–d` in both), so the fans of `a` and `b` together find every edge.
/// `a`'s alone would miss a border edge `x–d` moved into `x`'s slot when asked
/// from `d`'s side.
fn has_edge(conn: &Connectivity, tris: &[[u32; 3]], a: u32, b: u32) -> bool {
    conn.fan(a as usize)
        .iter()
        .chain(conn.fan(b as usize))
        .any(|&t| tris[t as usize].contains(&a) && tris[t as usize].contains(&b))
}

/// Squared distance from `p` to the frame's triangle.
fn dist2(f: &Frame, p: V3) -> f64 {
    let (q, _) = f.project(p);
    let d = sub(q, p);
    dot(d, d)
}

/// The samples sorted again by their triangles, in place (a counting sort that
/// swaps each sample to its triangle's next free slot: the "American flag" pass of
/// McIlroy, Bostic and McIlroy, "Engineering radix sort", 1993): no second copy of the samples at the
/// fitting's peak memory. `owner` is permuted along.
fn regroup(st: &mut SwapState<'_>, owner: &mut [u32]) {
    let nt = st.tris.len();
    let start = &mut *st.tri_start;
    start.fill(0);
    for &t in owner.iter() {
        start[t as usize + 1] += 1;
    }
    for i in 0..nt {
        start[i + 1] += start[i];
    }
    let mut next: Vec<u32> = start[..nt].to_vec();
    let samples = &mut st.samples[..];
    for t in 0..nt {
        while next[t] < start[t + 1] {
            let i = next[t] as usize;
            let o = owner[i] as usize;
            if o == t {
                next[t] += 1;
            } else {
                let j = next[o] as usize;
                samples.swap(i, j);
                owner.swap(i, j);
                next[o] += 1;
            }
        }
    }
}

fn add(a: V3, b: V3) -> V3 {
    std::array::from_fn(|k| a[k] + b[k])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A swap within a sweep moves the border edge `x–d` (0–3) from `t1`'s slot into
    /// `t0`'s, which did not hold 3 when the fans were built:
    ///
    /// ```text
    ///       2 (c)                2
    ///     /   \     t0         / | \
    ///   0(x)---1(y)    →     0  |  1
    ///     \   /     t1         \ | /
    ///       3 (d)                3
    /// ```
    /// (every outer edge a border). The stale fans of both ends still find every
    /// edge of the new triangles, and not the removed diagonal.
    #[test]
    fn has_edge_finds_edges_moved_within_a_sweep() {
        let mut tris = vec![[0, 1, 2], [1, 0, 3]];
        let conn = super::super::connectivity(&tris, 4);
        tris[0] = [0, 3, 2];
        tris[1] = [1, 2, 3];
        for (a, b) in [(3, 0), (0, 3), (2, 3), (3, 2), (1, 2), (3, 1), (2, 0)] {
            assert!(has_edge(&conn, &tris, a, b), "{a}-{b}");
        }
        assert!(!has_edge(&conn, &tris, 0, 1));
        assert!(!has_edge(&conn, &tris, 1, 0));
    }
}
