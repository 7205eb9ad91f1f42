//! Orientation repair after edge collapse: diagonal swaps that turn output triangles
//! facing away from the input back toward it, without moving a vertex and without
//! raising the distance to the input.
//!
//! A triangle *faces away* when its normal and the normal of the input triangle
//! closest to its centroid point in opposite directions (negative dot product; the
//! test the peers harness in `../shared/bench` counts). Collapses are checked against
//! their own neighbourhood (a normal may not turn past the operator's limit), so after
//! many collapses a triangle on a thin part (a finger, the rim of an ear) can still end
//! up nearer the opposite face of the part than the face it stands for.
//!
//! The repair is the edge swap of Hoppe, DeRose, Duchamp, McDonald and Stuetzle,
//! "Mesh optimization" (SIGGRAPH 1993), one of its three elementary transformations,
//! used here for orientation only: for each triangle facing away, in index order, each
//! of its edges is tried as the diagonal of the quad it forms with its neighbour, and
//! the other diagonal is taken when all of these hold:
//! - topology: the edge is shared by exactly these two triangles, with the same
//!   vertices on both sides (no UV seam or attribute border) and the same group
//!   (material); the new diagonal is not already an edge (so no duplicate triangles
//!   and no non-manifold edges); boundaries are never touched;
//! - shape: both new triangles have an area above `10⁻¹²·diag²`, a quality
//!   ([`crate::filter::triangle_quality`]) at least half the worse old one's, and a
//!   normal on the same side as the old pair's summed normal (no fold in the quad);
//! - orientation: fewer of the two new triangles face away than of the old two;
//! - distance, output → input: the largest distance of seven points on each new
//!   triangle (centroid, edge midpoints, three inner points) to the input is at most
//!   `R = max(D, G)`, where `D` is the same for the old pair and `G` the largest
//!   centroid distance over the whole output (the error already present elsewhere);
//! - distance, input → output: every input sample near the quad (vertices, centroids
//!   and edge midpoints of input triangles overlapping the quad's box grown by `R`)
//!   whose nearest output triangle was one of the old pair is no farther from the new
//!   pair than `max(its old distance, R)`.
//!
//! So a swap can only lower the facing-away count and never raises the Hausdorff
//! distance beyond the error the output already has. The cost is one closest-point
//! query per output triangle against a tree over the input (a Morton-order tree,
//! [`Bvh::build_morton`], cheap to build; made after the simplifier's own structures
//! are freed, so the peak memory does not grow), started at an input triangle of the
//! input vertex the triangle's first corner descends from; and, only where
//! triangles face away, the checks above. 3–36% of a QEM run's time (Lucy at 1% the
//! most: many thin parts, one closest-point query per sample).

use crate::filter::triangle_quality;
use crate::mesh::{Mesh, Weld};
use crate::metrics::bvh::{Bvh, Closest};
use crate::metrics::triangle::{closest_point, cross, dist2, dot, sub, V3};
use rayon::prelude::*;

/// What the repair did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct FacingRepair {
    /// Output triangles facing away from the input before the repair.
    pub before: usize,
    /// The same after it.
    pub after: usize,
    /// Diagonal swaps performed.
    pub flips: usize,
}

/// Barycentric sample points on a triangle for the output → input check.
const SAMPLES: [[f64; 3]; 7] = [
    [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
    [0.5, 0.5, 0.0],
    [0.0, 0.5, 0.5],
    [0.5, 0.0, 0.5],
    [2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0],
    [1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0],
    [1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0],
];

fn f64v(p: [f32; 3]) -> V3 {
    p.map(f64::from)
}

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn lerp3(c: &[V3; 3], w: [f64; 3]) -> V3 {
    std::array::from_fn(|k| w[0] * c[0][k] + w[1] * c[1][k] + w[2] * c[2][k])
}

/// The point of a triangle whose nearest input triangle decides whether it faces
/// away (its centroid, computed as every query of this module computes it).
pub(crate) fn centroid(corners: &[V3; 3]) -> V3 {
    lerp3(corners, SAMPLES[0])
}

/// The (unnormalised) normal of `mesh`'s triangle `t`, twice its area long.
pub(crate) fn face_normal(mesh: &Mesh, t: u32) -> V3 {
    let c = mesh.triangles[t as usize].map(|v| f64v(mesh.positions[v as usize]));
    cross(sub(c[1], c[0]), sub(c[2], c[0]))
}

/// Answers already known for some output triangles: `(centroid, nearest input
/// point)` at the index of the triangle, from an earlier pass (the vertex fitting's
/// orientation guard queries the same points). An entry is used only when the
/// triangle's centroid still equals (`==`) the one it was found for, and it must
/// have been found with the hint the repair starts that triangle's query at
/// ([`query_starts`]): the answer among equally near input triangles can depend on
/// the hint ([`Bvh::closest`]), so the repair then decides exactly as if it had
/// asked itself.
pub(crate) type KnownNearest = Vec<Option<(V3, Closest)>>;

/// For each input vertex, one input triangle that uses it (the last one in input
/// order; `u32::MAX` for an unused vertex).
fn owners(input: &Mesh) -> Vec<u32> {
    let mut tri_at = vec![u32::MAX; input.positions.len()];
    for (t, tri) in input.triangles.iter().enumerate() {
        for &v in tri {
            tri_at[v as usize] = t as u32;
        }
    }
    tri_at
}

/// The input triangle at the input vertex an output triangle's first corner
/// descends from (`source[v]`), for `triangles` of the output.
fn start_at(tri_at: &[u32], source: Option<&[u32]>, triangle: &[u32; 3]) -> Option<u32> {
    let v = source?.get(triangle[0] as usize)?;
    tri_at.get(*v as usize).copied().filter(|&x| x != u32::MAX)
}

/// Where the repair starts the closest-point query of each triangle of `out`
/// (simplified from `input`, `source[v]` the input vertex output vertex `v` descends
/// from): the hint under which [`KnownNearest`] answers must be found.
pub(crate) fn query_starts(input: &Mesh, out: &Mesh, source: &[u32]) -> Vec<Option<u32>> {
    let tri_at = owners(input);
    out.triangles
        .iter()
        .map(|t| start_at(&tri_at, Some(source), t))
        .collect()
}

fn dist_to_tri(p: V3, c: &[V3; 3]) -> f64 {
    dist2(p, closest_point(p, c[0], c[1], c[2]).0).sqrt()
}

struct Repair<'a> {
    input: &'a Mesh,
    bvh: &'a Bvh,
    /// For each input vertex, one input triangle that uses it (its *owner*; `u32::MAX`
    /// for an unused vertex).
    tri_at: Vec<u32>,
    /// Smallest twice-area (|cross|) an output triangle must have to count.
    min_area2: f64,
}

impl Repair<'_> {
    /// Whether the triangle with `corners` faces away from the input triangle closest
    /// to its centroid, and its centroid's distance to the input.
    fn facing(&self, corners: &[V3; 3], hint: &mut Option<u32>) -> (bool, f64) {
        self.facing_known(corners, hint, None)
    }

    /// [`Self::facing`], with the nearest input point taken from `known` where that
    /// was found for this very centroid.
    fn facing_known(
        &self,
        corners: &[V3; 3],
        hint: &mut Option<u32>,
        known: Option<&(V3, Closest)>,
    ) -> (bool, f64) {
        let n = cross(sub(corners[1], corners[0]), sub(corners[2], corners[0]));
        let centroid = centroid(corners);
        let found = match known {
            Some(&(c, cl)) if c == centroid => Some(cl),
            _ => self.bvh.closest(centroid, *hint),
        };
        let Some(cl) = found else {
            return (false, 0.0);
        };
        *hint = Some(cl.triangle);
        let m = face_normal(self.input, cl.triangle);
        let away = dot(n, n).sqrt() > self.min_area2 && dot(n, m) < 0.0;
        (away, cl.dist2.sqrt())
    }

    /// Largest distance of the sample points of `corners` to the input.
    fn sample_distance(&self, corners: &[V3; 3], hint: Option<u32>) -> f64 {
        SAMPLES
            .iter()
            .map(|&w| {
                self.bvh
                    .closest(lerp3(corners, w), hint)
                    .map_or(0.0, |c| c.dist2.sqrt())
            })
            .fold(0.0, f64::max)
    }
}

/// Output triangles per parallel task of the repair's first scan.
pub(super) const SCAN_RUN: usize = 4096;

/// Runs the repair on `out` (the simplified mesh) against `input` (the mesh it was
/// simplified from; `input_tree` is a closest-point tree over it, e.g.
/// [`Bvh::build_morton`]); `diag` is the input's bounding-box diagonal; `source[v]`,
/// when given, is the input vertex output vertex `v` descends from, and `known` the
/// nearest input points some triangles' centroids already have ([`KnownNearest`]);
/// both only save closest-point queries. `parallel`: the first scan runs on the
/// current rayon pool (the result is the same).
pub(crate) fn repair(
    input: &Mesh,
    input_tree: &Bvh,
    out: &mut Mesh,
    diag: f64,
    source: Option<&[u32]>,
    known: Option<&KnownNearest>,
    parallel: bool,
) -> FacingRepair {
    let mut stats = FacingRepair::default();
    if out.triangles.is_empty() || input.triangles.is_empty() || diag.is_nan() || diag <= 0.0 {
        return stats;
    }
    // A start for each output triangle's query: an input triangle at the input
    // vertex its first corner descends from.
    let r = Repair {
        input,
        bvh: input_tree,
        tri_at: owners(input),
        min_area2: 1e-12 * diag * diag,
    };
    let corners_of =
        |out: &Mesh, t: usize| out.triangles[t].map(|v| f64v(out.positions[v as usize]));
    let start = |out: &Mesh, t: usize| start_at(&r.tri_at, source, &out.triangles[t]);
    // Each triangle's query is independent: runs of triangles in parallel (on
    // the caller's rayon pool) when `parallel`, their facing-away lists joined in
    // order.
    let shared: &Mesh = out;
    let scan_run = |run: usize| {
        let mut away = Vec::new();
        let mut g = 0.0f64;
        let first = run * SCAN_RUN;
        for t in first..(first + SCAN_RUN).min(shared.triangles.len()) {
            let mut hint = start(shared, t);
            let k = known.and_then(|k| k.get(t)).and_then(Option::as_ref);
            let (a, d) = r.facing_known(&corners_of(shared, t), &mut hint, k);
            g = g.max(d);
            if a {
                away.push(t as u32);
            }
        }
        (away, g)
    };
    let runs = 0..shared.triangles.len().div_ceil(SCAN_RUN);
    let scanned: Vec<(Vec<u32>, f64)> = if parallel {
        runs.into_par_iter().map(scan_run).collect()
    } else {
        runs.map(scan_run).collect()
    };
    let g = scanned.iter().map(|s| s.1).fold(0.0f64, f64::max);
    let away: Vec<u32> = scanned.into_iter().flat_map(|s| s.0).collect();
    stats.before = away.len();
    stats.after = away.len();
    if away.is_empty() {
        return stats;
    }

    // Points: output vertices at the same position are one point (attribute seams
    // split vertices, not points).
    let weld = Weld::exact(&out.positions);
    let point = weld.point_of;
    let mut fans: Vec<Vec<u32>> = vec![Vec::new(); weld.representative.len()];
    for (t, tri) in out.triangles.iter().enumerate() {
        for &v in tri {
            fans[point[v as usize] as usize].push(t as u32);
        }
    }
    let out_bvh = Bvh::build_morton(&out.positions, &out.triangles);

    for &t in &away {
        let t = t as usize;
        if !r.facing(&corners_of(out, t), &mut start(out, t)).0 {
            continue;
        }
        let mut best: Option<Swap> = None;
        for k in 0..3 {
            let Some(sw) = try_swap(&r, out, &point, &fans, &out_bvh, g, t, k) else {
                continue;
            };
            if best.as_ref().is_none_or(|b| sw.away_new < b.away_new) {
                best = Some(sw);
            }
        }
        if let Some(Swap {
            other: s,
            new_t: nt,
            new_other: ns,
            away_old,
            away_new,
        }) = best
        {
            // Only t and s changed: the count follows without a second scan.
            stats.after = stats.after.saturating_sub(away_old - away_new);
            // Fans: the points of the old edge lose one triangle each, the points of
            // the new diagonal gain one each.
            let old_t = out.triangles[t].map(|v| point[v as usize]);
            let old_s = out.triangles[s].map(|v| point[v as usize]);
            out.triangles[t] = nt;
            out.triangles[s] = ns;
            let new_t = nt.map(|v| point[v as usize]);
            let new_s = ns.map(|v| point[v as usize]);
            for (tri, old, new) in [(t, old_t, new_t), (s, old_s, new_s)] {
                for p in old {
                    if !new.contains(&p) {
                        fans[p as usize].retain(|&x| x as usize != tri);
                    }
                }
                for p in new {
                    if !old.contains(&p) {
                        fans[p as usize].push(tri as u32);
                    }
                }
            }
            stats.flips += 1;
        }
    }
    stats
}

/// A diagonal swap found legal by [`try_swap`].
struct Swap {
    /// The triangle across the swapped edge.
    other: usize,
    /// The two triangles after the swap (output vertex indices).
    new_t: [u32; 3],
    new_other: [u32; 3],
    /// Triangles facing away among the pair before and after.
    away_old: usize,
    away_new: usize,
}

/// Tries swapping edge `k` of triangle `t` (from corner `k` to corner `k + 1`):
/// the swap when every condition of the module docs holds.
#[allow(clippy::too_many_arguments)]
fn try_swap(
    r: &Repair,
    out: &Mesh,
    point: &[u32],
    fans: &[Vec<u32>],
    out_bvh: &Bvh,
    g: f64,
    t: usize,
    k: usize,
) -> Option<Swap> {
    let tri = out.triangles[t];
    let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
    let p = |v: u32| point[v as usize];
    let (pa, pb, pc) = (p(a), p(b), p(c));
    // The one other triangle on edge a-b, with the edge the other way round.
    let mut other = None;
    for &s in &fans[pa as usize] {
        let s = s as usize;
        if s == t || !out.triangles[s].iter().any(|&v| p(v) == pb) {
            continue;
        }
        if other.is_some() {
            return None; // more than two triangles on the edge
        }
        other = Some(s);
    }
    let s = other?;
    let st = out.triangles[s];
    let j = (0..3).find(|&j| st[j] == b && st[(j + 1) % 3] == a)?; // same vertices: no seam
    let d = st[(j + 2) % 3];
    let pd = p(d);
    if pd == pc || pd == pa || pd == pb {
        return None;
    }
    if let Some(gr) = &out.groups {
        if gr[t] != gr[s] {
            return None;
        }
    }
    if fans[pc as usize]
        .iter()
        .any(|&x| out.triangles[x as usize].iter().any(|&v| p(v) == pd))
    {
        return None; // the new diagonal already exists
    }
    let pos = |v: u32| f64v(out.positions[v as usize]);
    let (ca, cb, cc, cd) = (pos(a), pos(b), pos(c), pos(d));
    let old = [[ca, cb, cc], [cb, ca, cd]];
    let new = [[cc, ca, cd], [cd, cb, cc]];
    let normal = |x: &[V3; 3]| cross(sub(x[1], x[0]), sub(x[2], x[0]));
    let nsum = add(normal(&old[0]), normal(&old[1]));
    let q_old = old
        .iter()
        .map(|x| triangle_quality(x, normal(x)))
        .fold(f64::INFINITY, f64::min);
    for x in &new {
        let n = normal(x);
        if dot(n, n).sqrt() <= r.min_area2
            || dot(n, nsum) <= 0.0
            || triangle_quality(x, n) < 0.5 * q_old
        {
            return None;
        }
    }
    let mut h = None;
    let away_old = old.iter().filter(|x| r.facing(x, &mut h).0).count();
    let away_new = new.iter().filter(|x| r.facing(x, &mut h).0).count();
    if away_new >= away_old {
        return None;
    }
    // Output → input.
    let d_old = old
        .iter()
        .map(|x| r.sample_distance(x, h))
        .fold(0.0, f64::max);
    let reach = d_old.max(g);
    if new.iter().any(|x| r.sample_distance(x, h) > reach) {
        return None;
    }
    // Input → output, for the input samples the old pair was nearest to.
    let ok = input_stays_near(r, out_bvh, t, &old, &new, reach);
    if !ok {
        return None;
    }
    Some(Swap {
        other: s,
        new_t: [c, a, d],
        new_other: [d, b, c],
        away_old,
        away_new,
    })
}

/// Input → output: whether every input sample (vertices, centroids and edge
/// midpoints of the input triangles near the quad) that the old pair (`old`) was
/// nearest to stays within `max(before, reach)` of the new pair (`new`); `t` is
/// the output triangle where the nearest-output queries start.
fn input_stays_near(
    r: &Repair,
    out_bvh: &Bvh,
    t: usize,
    old: &[[V3; 3]; 2],
    new: &[[V3; 3]; 2],
    reach: f64,
) -> bool {
    let [[ca, cb, cc], [_, _, cd]] = *old;
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for q in [ca, cb, cc, cd] {
        for i in 0..3 {
            lo[i] = lo[i].min(q[i] - reach);
            hi[i] = hi[i].max(q[i] + reach);
        }
    }
    let inside = |q: V3| (0..3).all(|i| q[i] >= lo[i] && q[i] <= hi[i]);
    r.bvh.for_each_in_box(lo, hi, |id, tri| {
        // A vertex is shared by several input triangles: it is checked once, with
        // its owner (which overlaps the box too, since the vertex is inside it).
        let ids = r.input.triangles[id as usize];
        let v = tri.map(f64v);
        let mid = |i: usize, j: usize| {
            lerp3(
                &v,
                std::array::from_fn(|m| if m == i || m == j { 0.5 } else { 0.0 }),
            )
        };
        let pts = [
            v[0],
            v[1],
            v[2],
            lerp3(&v, SAMPLES[0]),
            mid(0, 1),
            mid(1, 2),
            mid(0, 2),
        ];
        for (i, q) in pts.into_iter().enumerate() {
            if (i < 3 && r.tri_at[ids[i] as usize] != id) || !inside(q) {
                continue;
            }
            // `after <= max(before, reach)`, with `before` computed only when needed.
            let after = dist_to_tri(q, &new[0]).min(dist_to_tri(q, &new[1]));
            if after <= reach {
                continue;
            }
            let before = dist_to_tri(q, &old[0]).min(dist_to_tri(q, &old[1]));
            if after <= before {
                continue;
            }
            // Farther than allowed: a violation only if the old pair was its nearest,
            // i.e. `before <= nearest * (1 + 1e-9) + 1e-12 * reach` for the output's
            // nearest distance; the right side grows with the distance, so that is
            // "no output triangle has its right side below `before`" (the first one
            // found ends the search).
            let slack = 1e-12 * reach;
            if before.is_nan() || slack.is_nan() {
                continue; // the comparison above is false then
            }
            if !out_bvh.any_near(q, Some(t as u32), |d2| {
                d2.sqrt() * (1.0 + 1e-9) + slack < before
            }) {
                return false;
            }
        }
        true
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Input: a large square in the plane z = 0, facing +z.
    fn plane() -> Mesh {
        Mesh {
            positions: vec![
                [-1.0, -1.0, 0.0],
                [3.0, -1.0, 0.0],
                [3.0, 3.0, 0.0],
                [-1.0, 3.0, 0.0],
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            ..Mesh::default()
        }
    }

    /// Output: two triangles on edge a-b, folded over each other in the plane:
    ///
    /// ```text
    ///        c (1,1)
    ///       /  \
    ///      / d  \      d = (1, 0.5) lies inside abc, so s = (b, a, d)
    ///     /      \     faces -z (away); the quad a-d-b-c has its reflex
    ///    a--------b    corner at d, and diagonal c-d unfolds it.
    /// ```
    ///
    /// With `seam`, `s` uses its own copies of a and b (same positions).
    fn folded(seam: bool) -> Mesh {
        let mut positions = vec![
            [0.0, 0.0, 0.0], // a
            [2.0, 0.0, 0.0], // b
            [1.0, 1.0, 0.0], // c
            [1.0, 0.5, 0.0], // d
        ];
        let s = if seam {
            positions.push([0.0, 0.0, 0.0]);
            positions.push([2.0, 0.0, 0.0]);
            [5, 4, 3]
        } else {
            [1, 0, 3]
        };
        Mesh {
            positions,
            triangles: vec![[0, 1, 2], s],
            ..Mesh::default()
        }
    }

    fn diagonal() -> f64 {
        32f64.sqrt()
    }

    /// The repair with a tree over `input`.
    fn run(input: &Mesh, out: &mut Mesh, diag: f64) -> FacingRepair {
        let tree = Bvh::build_morton(&input.positions, &input.triangles);
        repair(input, &tree, out, diag, None, None, true)
    }

    #[test]
    fn swap_unfolds_a_triangle_facing_away() {
        let mut out = folded(false);
        let f = run(&plane(), &mut out, diagonal());
        assert_eq!(
            f,
            FacingRepair {
                before: 1,
                after: 0,
                flips: 1
            }
        );
        // Same vertices, the other diagonal (c-d), both facing +z.
        assert_eq!(out.triangles, vec![[2, 0, 3], [3, 1, 2]]);
        for t in &out.triangles {
            let c = t.map(|v| f64v(out.positions[v as usize]));
            assert!(cross(sub(c[1], c[0]), sub(c[2], c[0]))[2] > 0.0);
        }
    }

    /// Known answers are taken only where the centroid is the one they were found
    /// for. The input is the plane plus a far triangle facing −z (index 2); a
    /// known answer naming it for the folded triangle `s` (which faces −z) makes
    /// `s` count as facing the input, while the same answer recorded at another
    /// centroid is ignored, and true answers change nothing.
    #[test]
    fn known_answers_only_for_their_own_centroid() {
        let mut input = plane();
        input
            .positions
            .extend([[0.0, 0.0, 9.0], [0.0, 1.0, 9.0], [1.0, 0.0, 9.0]]);
        input.triangles.push([4, 5, 6]);
        let tree = Bvh::build_morton(&input.positions, &input.triangles);
        let out0 = folded(false);
        let corners = |t: usize| out0.triangles[t].map(|v| f64v(out0.positions[v as usize]));
        let truth: KnownNearest = (0..2)
            .map(|t| {
                let c = centroid(&corners(t));
                Some((c, tree.closest(c, None).unwrap()))
            })
            .collect();
        let plain = {
            let mut out = folded(false);
            (
                repair(&input, &tree, &mut out, diagonal(), None, None, true),
                out,
            )
        };
        assert_eq!(plain.0.before, 1);
        let with = |known: &KnownNearest| {
            let mut out = folded(false);
            (
                repair(
                    &input,
                    &tree,
                    &mut out,
                    diagonal(),
                    None,
                    Some(known),
                    false,
                ),
                out,
            )
        };
        let same = with(&truth);
        assert_eq!((same.0, &same.1.triangles), (plain.0, &plain.1.triangles));
        let c1 = centroid(&corners(1));
        let poisoned = |at: V3| -> KnownNearest {
            let mut k = truth.clone();
            let far = Closest {
                dist2: 81.0,
                point: [0.0, 0.0, 9.0],
                triangle: 2,
            };
            k[1] = Some((at, far));
            k
        };
        assert_eq!(with(&poisoned(c1)).0.before, 0, "a matching entry is used");
        let stale = with(&poisoned([c1[0] + 1e-9, c1[1], c1[2]]));
        assert_eq!((stale.0, &stale.1.triangles), (plain.0, &plain.1.triangles));
    }

    #[test]
    fn seams_and_group_borders_are_not_swapped() {
        let mut out = folded(true);
        let f = run(&plane(), &mut out, diagonal());
        assert_eq!(
            f,
            FacingRepair {
                before: 1,
                after: 1,
                flips: 0
            }
        );
        let mut out = folded(false);
        out.groups = Some(vec![0, 1]);
        let f = run(&plane(), &mut out, diagonal());
        assert_eq!(f.flips, 0);
        assert_eq!(out.triangles, folded(false).triangles);
    }

    /// A swap that would move the surface away from the input is refused: here the
    /// input is a roof folded along a-b (c's side rises, d's side is flat), so the
    /// new diagonal c-d would cut under the ridge.
    #[test]
    fn swaps_that_leave_the_input_are_refused() {
        let input = Mesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [1.0, 1.0, 1.0],
                [1.0, 0.5, 0.0],
                [1.0, -1.0, 0.0],
            ],
            // The roof abc and a flat apron below a-b; d sits under the roof.
            triangles: vec![[0, 1, 2], [1, 0, 4]],
            ..Mesh::default()
        };
        let mut out = Mesh {
            positions: input.positions.clone(),
            triangles: vec![[0, 1, 2], [1, 0, 3]],
            ..Mesh::default()
        };
        let f = run(&input, &mut out, 3.0);
        assert_eq!(f.flips, 0, "{f:?}");
    }
}
