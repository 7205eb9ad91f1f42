//! A certified one-sided maximum: adaptive refinement with a lower and an upper bound.
//!
//! Sampling finds a lower bound of `h(A,B) = max over a ∈ A of d(a, B)`: every sample's
//! distance is exact, but the worst point may lie between samples (the turbine blade
//! against MeshLab's 5% simplification: a sampled 0.04969 where dense edge sampling
//! finds at least 0.05212). Following the bounding idea of Metro's successors
//! (Tang, Lee & Kim, "Interactive Hausdorff distance computation for general polygonal
//! models", SIGGRAPH 2009: cull regions whose upper bound cannot beat the best lower
//! bound, subdivide the rest), each triangle of `A` is a region with an upper bound on
//! `d(·, B)` over it, and regions whose bound exceeds the best sample are split in four
//! (edge midpoints) until every bound is within a tolerance of it.
//!
//! Three upper bounds hold for a region `T` with corners `v_i`:
//! - **Lipschitz**: `d(·, B)` is 1-Lipschitz, so `d(x, B) ≤ d(v_i, B) + |x − v_i|`,
//!   and `|x − v_i|` is at most the longest edge from `v_i` (from the centroid `c`:
//!   its farthest corner).
//! - **Convexity**: for any single triangle `t` of `B`, `d(x, B) ≤ d(x, t)`, and
//!   `d(·, t)` is convex (the distance to a convex set), so its maximum over `T` is at a
//!   corner: `d(x, B) ≤ max_i d(v_i, t)`. The candidates `t` are the triangles closest
//!   to the corners (and the centroid, when it was queried).
//! - **Two triangles and a plane**: a plane cuts `T` in two convex parts; on one
//!   `d(·, B) ≤ d(·, t_a)`, on the other `≤ d(·, t_b)`, each largest at its part's
//!   corners (the corners of `T` on that side and the points where its edges cross
//!   the plane). Any plane is valid. Where `t_a` and `t_b` share an edge, the plane
//!   through it that bisects their dihedral angle makes the bound exact for a region
//!   lying on the two (a region across a crease or an edge of a simplified surface,
//!   where one triangle alone leaves a bound of the region's width times the bend, so
//!   that halving it takes as many splits as the width is above the tolerance).
//!
//! The first pass takes the corners' distances from the vertex samples when the
//! caller passes them (else it queries every point once); only the regions that
//! their corners do not settle query their centroid. A split queries its three edge
//! midpoints.
//!
//! The bound reported is the largest bound of any region left unsplit, so the true
//! maximum lies in `[max_lower, max_upper]`. Refinement stops early when the
//! interval is not closing: when, over an eighth of the budget, the worst bound came
//! less than a quarter closer to the tolerance and the open regions did not become
//! fewer (a mesh against a near copy of itself, at distances far below its
//! triangles' size; or a coarse mesh against a fine one). It reports the wider
//! interval it has.

use super::bvh::Bvh;
use super::triangle::{self, V3};
use rayon::prelude::*;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Relative gap at which refinement stops: `upper ≤ lower × (1 + TOLERANCE)`, so the
/// reported maximum is within 0.4% of the truth.
pub const TOLERANCE: f64 = 0.004;

/// The climb refines regions whose exact distances come within this fraction of the
/// best one found.
const CLIMB_BAND: f64 = 0.5;

/// Regions split together, in parallel.
const BATCH: usize = 256;

/// Closest-point queries of one split (its three edge midpoints).
const SPLIT_QUERIES: u64 = 3;

/// What a split costs against the budget, in queries: its three queries and its four
/// children's bounds (the two-triangle bounds cost about as much as the four more
/// queries a split made when each child queried its centroid).
const SPLIT_COST: u64 = 7;

/// Closest-point queries the refinement may always spend, however few the samples
/// (a few milliseconds): small sample counts still get a certified maximum.
pub const MIN_BUDGET: u64 = 1 << 16;

/// What the sampling already found, for [`certify`] to start from. Every distance is
/// in mesh units and not above the sampled maximum. The points' distances must be
/// exact (the bounds rest on them); the faces' only order the refinement.
#[derive(Debug, Clone, Copy, Default)]
pub struct Known<'a> {
    /// For every point (indexed as `points`), its distance to the target and the
    /// index of its nearest triangle there, as the vertex samples found them.
    pub points: Option<&'a [(f64, u32)]>,
    /// For every triangle (indexed as `tris`), the largest distance of the samples
    /// taken inside it: the refinement climbs first where these are high.
    pub faces: Option<&'a [f32]>,
}

/// The certified bounds of one direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Certified {
    /// The largest exact distance found (a lower bound of the maximum).
    pub lower: f64,
    /// Where it was found, and its closest point on the other surface.
    pub lower_at: (V3, V3),
    /// An upper bound of the maximum over the whole sampled surface.
    pub upper: f64,
    /// Closest-point queries spent on the refinement.
    pub queries: u64,
}

/// A triangular region of the sampled surface with exact distances at its corners,
/// and the nearest triangles of the other surface found for them.
#[derive(Clone, Copy)]
struct Region {
    v: [V3; 3],
    d: [f64; 3],
    near: [u32; 3],
    upper: f64,
    /// The largest distance found on it: at its corners, its centroid when queried,
    /// and (for a triangle of the first pass) its face samples.
    hi: f64,
}

/// A region ordered by its largest exact distance (the climb's order).
struct ByHigh(Region);

impl PartialEq for ByHigh {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for ByHigh {}
impl PartialOrd for ByHigh {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for ByHigh {
    fn cmp(&self, o: &Self) -> Ordering {
        self.0.hi.total_cmp(&o.0.hi).then_with(|| self.0.cmp(&o.0))
    }
}

impl PartialEq for Region {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Region {}
impl PartialOrd for Region {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Region {
    /// By upper bound, ties broken by the corners so the order (and so the output) is
    /// the same on every run.
    fn cmp(&self, o: &Self) -> Ordering {
        self.upper.total_cmp(&o.upper).then_with(|| {
            let key = |r: &Region| r.v.map(|p| p.map(f64::to_bits));
            key(self).cmp(&key(o))
        })
    }
}

/// A point's exact distance, its closest point and triangle.
#[derive(Clone, Copy)]
struct Hit {
    d: f64,
    at: V3,
    closest: V3,
    tri: u32,
}

fn query(target: &Bvh, p: V3, hint: Option<u32>) -> Hit {
    match target.closest(p, hint) {
        Some(c) => Hit {
            d: c.dist2.sqrt(),
            at: p,
            closest: c.point,
            tri: c.triangle,
        },
        None => Hit {
            d: f64::INFINITY,
            at: p,
            closest: p,
            tri: u32::MAX,
        },
    }
}

fn better(a: Hit, b: Hit) -> Hit {
    if b.d > a.d {
        b
    } else {
        a
    }
}

fn centroid(v: &[V3; 3]) -> V3 {
    std::array::from_fn(|k| (v[0][k] + v[1][k] + v[2][k]) / 3.0)
}

fn mid(a: V3, b: V3) -> V3 {
    std::array::from_fn(|k| 0.5 * (a[k] + b[k]))
}

/// Builds a region from its corners' hits (no query of its own). The bounds from
/// pairs of nearest triangles are tried only while the bound is above `bar` (the
/// level at which a region is settled).
fn region(target: &Bvh, v: [V3; 3], corner: [Hit; 3], bar: f64) -> Region {
    // 1-Lipschitz from a corner: every point of the region is within its longest
    // edge from that corner.
    let e = [
        triangle::dist2(v[0], v[1]),
        triangle::dist2(v[1], v[2]),
        triangle::dist2(v[2], v[0]),
    ];
    let mut r = Region {
        v,
        d: corner.map(|h| h.d),
        near: corner.map(|h| h.tri),
        upper: (0..3)
            .map(|i| corner[i].d + e[i].max(e[(i + 2) % 3]).sqrt())
            .fold(f64::INFINITY, f64::min),
        hi: corner.iter().fold(0.0f64, |m, h| m.max(h.d)),
    };
    let ids = r.near;
    let mut near = [[[0.0; 3]; 3]; 3];
    let mut count = 0;
    for (k, &t) in ids.iter().enumerate() {
        if ids[..k].contains(&t) {
            continue;
        }
        if let Some(tri) = target.corners(t) {
            r.upper = r.upper.min(farthest(&v, &tri));
            near[count] = tri;
            count += 1;
        }
    }
    for i in 0..count {
        for j in i + 1..count {
            if r.upper > bar {
                r.upper = r.upper.min(pair_bound(&v, &near[i], &near[j]));
            }
        }
    }
    r
}

/// Tightens the bound of region `r` with the hit `hc` at its centroid: a
/// Lipschitz bound from the centroid (its farthest corner), its nearest triangle
/// alone and paired with the corners' (while above `bar`).
fn with_centre(target: &Bvh, r: &mut Region, hc: Hit, bar: f64) {
    let c = centroid(&r.v);
    let reach =
        r.v.iter()
            .map(|p| triangle::dist2(*p, c))
            .fold(0.0f64, f64::max)
            .sqrt();
    r.upper = r.upper.min(hc.d + reach);
    r.hi = r.hi.max(hc.d);
    if r.near.contains(&hc.tri) {
        return;
    }
    let Some(tc) = target.corners(hc.tri) else {
        return;
    };
    r.upper = r.upper.min(farthest(&r.v, &tc));
    for (k, &t) in r.near.iter().enumerate() {
        if r.upper <= bar || r.near[..k].contains(&t) {
            continue;
        }
        if let Some(tri) = target.corners(t) {
            r.upper = r.upper.min(pair_bound(&r.v, &tri, &tc));
        }
    }
}

/// The largest distance from the corners of `v` to triangle `t` (a bound of the
/// distance over `v`, by convexity).
fn farthest(v: &[V3; 3], t: &[V3; 3]) -> f64 {
    v.iter()
        .map(|p| dist2_to(*p, t))
        .fold(0.0f64, f64::max)
        .sqrt()
}

/// Squared distance from `p` to triangle `t`.
/// A NaN (which `f64::max` would drop, tightening a bound) counts as infinite.
fn dist2_to(p: V3, t: &[V3; 3]) -> f64 {
    let d = triangle::dist2(p, triangle::closest_point(p, t[0], t[1], t[2]).0);
    if d.is_nan() {
        f64::INFINITY
    } else {
        d
    }
}

fn unit(a: V3) -> Option<V3> {
    let n = triangle::dot(a, a).sqrt();
    (n > 0.0 && n.is_finite()).then(|| a.map(|x| x / n))
}

fn normal(t: &[V3; 3]) -> Option<V3> {
    unit(triangle::cross(
        triangle::sub(t[1], t[0]),
        triangle::sub(t[2], t[0]),
    ))
}

/// An upper bound of `d(·, B)` over the region `v` from two triangles `ta`, `tb` of
/// `B`: a plane cuts the region in two convex parts, and `d(·, B) ≤ d(·, ta)` on one,
/// `≤ d(·, tb)` on the other; each is convex, so its maximum over a part is at the
/// part's corners (the region's corners on that side and the points where its edges
/// cross the plane). Any plane gives a true bound; a good one follows the border
/// between the two triangles' nearest points. When they share an edge, the plane
/// through that edge that bisects their dihedral angle (exact where the region lies on
/// the two triangles, as at a crease of a simplified surface, where one triangle alone
/// leaves a bound of the region's width times the bend); otherwise the plane halfway
/// between their centroids.
fn pair_bound(v: &[V3; 3], ta: &[V3; 3], tb: &[V3; 3]) -> f64 {
    let mut best = f64::INFINITY;
    let mut common = [[0.0; 3]; 3];
    let mut n = 0;
    for p in ta.iter().filter(|p| tb.contains(p)) {
        common[n] = *p;
        n += 1;
    }
    let shared = &common[..n];
    let third = |t: &[V3; 3]| t.iter().find(|p| !shared.contains(p)).copied();
    let normals = normal(ta).zip(normal(tb));
    if let ([p, q], Some(ra), Some(rb), Some((na, nb))) = (shared, third(ta), third(tb), normals) {
        let e = triangle::sub(*q, *p);
        for s in [1.0, -1.0] {
            let m = triangle::cross(e, std::array::from_fn(|k| na[k] + s * nb[k]));
            let (sa, sb) = (
                triangle::dot(m, triangle::sub(ra, *p)),
                triangle::dot(m, triangle::sub(rb, *p)),
            );
            if sa * sb < 0.0 {
                let m = if sa < 0.0 { m } else { m.map(|x| -x) };
                best = best.min(split_bound(v, ta, tb, m, *p));
            }
        }
    }
    let (ga, gb) = (centroid(ta), centroid(tb));
    if let ([o], Some((na, nb))) = (shared, normals) {
        // A shared corner: the plane through it and the mean normal that bisects the
        // angle between the two triangles' directions (around a vertex of a fan).
        for s in [1.0, -1.0] {
            let Some(n) = unit(std::array::from_fn(|k| na[k] + s * nb[k])) else {
                continue;
            };
            let flat = |g: V3| {
                let d = triangle::sub(g, *o);
                unit(std::array::from_fn(|k| d[k] - triangle::dot(d, n) * n[k]))
            };
            if let (Some(ua), Some(ub)) = (flat(ga), flat(gb)) {
                if let Some(m) = unit(triangle::sub(ub, ua)) {
                    best = best.min(split_bound(v, ta, tb, m, *o));
                }
            }
        }
    }
    if let Some(m) = unit(triangle::sub(gb, ga)) {
        best = best.min(split_bound(v, ta, tb, m, mid(ga, gb)));
    }
    best
}

/// The bound of [`pair_bound`] for the plane through `o` with normal `m`: `ta` on its
/// negative side, `tb` on its positive side.
fn split_bound(v: &[V3; 3], ta: &[V3; 3], tb: &[V3; 3], m: V3, o: V3) -> f64 {
    let s: [f64; 3] = std::array::from_fn(|i| triangle::dot(m, triangle::sub(v[i], o)));
    let (mut fa, mut fb) = (0.0f64, 0.0f64);
    for i in 0..3 {
        if s[i] <= 0.0 {
            fa = fa.max(dist2_to(v[i], ta));
        }
        if s[i] >= 0.0 {
            fb = fb.max(dist2_to(v[i], tb));
        }
        let j = (i + 1) % 3;
        if (s[i] < 0.0 && s[j] > 0.0) || (s[i] > 0.0 && s[j] < 0.0) {
            let f = s[i] / (s[i] - s[j]);
            let x = std::array::from_fn(|k| v[i][k] + (v[j][k] - v[i][k]) * f);
            fa = fa.max(dist2_to(x, ta));
            fb = fb.max(dist2_to(x, tb));
        }
    }
    fa.max(fb).sqrt()
}

/// Splits a region in four at its edge midpoints; returns the children and the best
/// hit among the new points.
fn split(target: &Bvh, r: &Region, bar: f64) -> ([Region; 4], Hit, u64) {
    let [a, b, c] = r.v;
    let corner = |i: usize| Hit {
        d: r.d[i],
        at: r.v[i],
        closest: r.v[i],
        tri: r.near[i],
    };
    let (ha, hb, hc) = (corner(0), corner(1), corner(2));
    let mab = query(target, mid(a, b), Some(r.near[0]));
    let mbc = query(target, mid(b, c), Some(r.near[1]));
    let mca = query(target, mid(c, a), Some(r.near[2]));
    let children = [
        region(target, [a, mab.at, mca.at], [ha, mab, mca], bar),
        region(target, [mab.at, b, mbc.at], [mab, hb, mbc], bar),
        region(target, [mca.at, mbc.at, c], [mca, mbc, hc], bar),
        region(target, [mab.at, mbc.at, mca.at], [mab, mbc, mca], bar),
    ];
    (children, better(better(mab, mbc), mca), SPLIT_QUERIES)
}

/// Certifies the maximum distance from the triangles `tris` (indices into `points`)
/// to `target`, starting from the best sample so far (`lower`, found at `lower_at`).
/// `known` carries what the sampling found (see [`Known`]); without its points' hits
/// every point is queried once more. Spends at most `budget` (in closest-point
/// queries, a split counting as seven) on splitting; when the budget runs out,
/// `upper` is the largest bound left, so the interval is still true, only wider.
#[must_use]
pub fn certify(
    points: &[V3],
    tris: &[[u32; 3]],
    target: &Bvh,
    lower: f64,
    lower_at: (V3, V3),
    known: &Known<'_>,
    budget: u64,
) -> Certified {
    let mut best = Hit {
        d: lower,
        at: lower_at.0,
        closest: lower_at.1,
        tri: u32::MAX,
    };
    if target.is_empty() || tris.is_empty() || !lower.is_finite() {
        return Certified {
            lower,
            lower_at,
            upper: if target.is_empty() && !tris.is_empty() {
                f64::INFINITY
            } else {
                lower
            },
            queries: 0,
        };
    }
    let mut used = vec![false; points.len()];
    tris.iter().flatten().for_each(|&p| used[p as usize] = true);
    // The scale below which a gap is rounding: 1e-9 of the sampled surface's extent.
    let (lo, hi) = points.iter().zip(&used).filter(|(_, &u)| u).fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), (p, _)| {
            (
                std::array::from_fn(|k| lo[k].min(p[k])),
                std::array::from_fn(|k| hi[k].max(p[k])),
            )
        },
    );
    let floor = 1e-9 * triangle::dist2(lo, hi).sqrt();
    let threshold = |lower: f64| (lower * (1.0 + TOLERANCE)).max(lower + floor);

    // Every point's distance (queried once here unless known), then every triangle as
    // a region, in parallel (in order). Regions already within the tolerance of the
    // best distance are settled at once (the best only rises).
    const CHUNK: usize = 1024;
    let mut queries = 0u64;
    let computed: Vec<(f64, u32)>;
    let near: &[(f64, u32)] = match known.points {
        Some(k) if k.len() == points.len() => k,
        _ => {
            let hits: Vec<Option<Hit>> = points
                .par_chunks(CHUNK)
                .zip(used.par_chunks(CHUNK))
                .flat_map_iter(|(ps, us)| {
                    let mut hint = None;
                    ps.iter()
                        .zip(us)
                        .map(|(&p, &u)| {
                            u.then(|| {
                                let q = query(target, p, hint);
                                hint = Some(q.tri);
                                q
                            })
                        })
                        .collect::<Vec<_>>()
                })
                .collect();
            queries += used.iter().filter(|&&u| u).count() as u64;
            best = hits.iter().flatten().copied().fold(best, better);
            computed = hits
                .iter()
                .map(|h| h.map_or((0.0, u32::MAX), |h| (h.d, h.tri)))
                .collect();
            &computed
        }
    };
    let corner = |p: u32| {
        let (d, tri) = near[p as usize];
        let at = points[p as usize];
        Hit {
            d,
            at,
            closest: at,
            tri,
        }
    };
    let bar = threshold(best.d);
    // A region not settled by its corners alone queries its centroid: a sample
    // inside it (where the distance over a large region peaks), another nearest
    // triangle and a tighter Lipschitz bound.
    let faces = known.faces.filter(|f| f.len() == tris.len());
    let firsts: Vec<(Vec<Region>, f64, Hit, u64)> = tris
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(ci, chunk)| {
            let (mut settled, mut local, mut asked) = (0.0f64, best, 0u64);
            let mut out = Vec::new();
            for (k, t) in chunk.iter().enumerate() {
                let ti = ci * CHUNK + k;
                let h = t.map(corner);
                let v = h.map(|x| x.at);
                let mut r = region(target, v, h, bar);
                if let Some(f) = faces {
                    r.hi = r.hi.max(f64::from(f[ti]));
                }
                if r.upper > bar {
                    let hc = query(target, centroid(&v), Some(h[0].tri));
                    asked += 1;
                    local = better(local, hc);
                    with_centre(target, &mut r, hc, bar);
                }
                if r.upper > bar {
                    out.push(r);
                } else {
                    settled = settled.max(r.upper);
                }
            }
            (out, settled, local, asked)
        })
        .collect();
    let mut settled = best.d;
    for (_, s, h, q) in &firsts {
        settled = settled.max(*s);
        best = better(best, *h);
        queries += q;
    }
    let mut leaves: Vec<Region> = firsts.into_iter().flat_map(|f| f.0).collect();
    let mut spent = 0u64;

    // The climb: split the regions with the largest exact distances first (those
    // within `CLIMB_BAND` of the best), to raise the lower bound where the maximum is
    // (at most a quarter of the budget). Bound-first
    // splitting alone can spend the whole budget on wide regions of moderate bound
    // (a coarse mesh against a fine one) before it reaches the maximum.
    {
        let fine = |r: &Region| {
            let c = centroid(&r.v);
            r.v.iter()
                .map(|p| triangle::dist2(*p, c))
                .fold(0.0f64, f64::max)
                .sqrt()
        };
        let mut climb: BinaryHeap<ByHigh> = leaves.drain(..).map(ByHigh).collect();
        let mut done = Vec::new();
        while spent < budget / 4 {
            // A region already finer than the tolerance cannot raise the lower
            // bound by more than it: set aside.
            let mut batch = Vec::with_capacity(BATCH);
            while batch.len() < BATCH {
                match climb.pop() {
                    Some(ByHigh(r)) if r.hi < best.d * (1.0 - CLIMB_BAND) => {
                        climb.push(ByHigh(r));
                        break;
                    }
                    Some(ByHigh(r))
                        if fine(&r) > TOLERANCE * best.d.max(floor)
                            && r.upper > threshold(best.d) =>
                    {
                        batch.push(r);
                    }
                    Some(ByHigh(r)) => done.push(r),
                    None => break,
                }
            }
            if batch.is_empty() {
                break;
            }
            let bar = threshold(best.d);
            let out: Vec<([Region; 4], Hit, u64)> =
                batch.par_iter().map(|r| split(target, r, bar)).collect();
            for (children, h, q) in out {
                best = better(best, h);
                spent += SPLIT_COST;
                queries += q;
                climb.extend(children.into_iter().map(ByHigh));
            }
        }
        leaves = done;
        leaves.extend(climb.into_iter().map(|b| b.0));
    }

    let mut heap: BinaryHeap<Region> = BinaryHeap::new();
    for r in leaves {
        if r.upper > threshold(best.d) {
            heap.push(r);
        } else {
            settled = settled.max(r.upper);
        }
    }

    // Bound first: split the worst regions in batches (in parallel, in a fixed order)
    // until every bound is within the tolerance of the best distance found, or the
    // budget ends, or the interval is not closing: at every eighth of the budget
    // (after the first), the worst bound must have come at least a quarter closer to
    // the tolerance since the last check, or the open regions must be fewer than then
    // and than the splits the budget still pays for. Otherwise the rest of the budget
    // would only narrow the interval a little (a mesh against a near copy of itself,
    // where most regions straddle several nearest triangles).
    let step = (budget / 8).max(1);
    let (mut check, mut open, mut gap) = (spent + step, usize::MAX, f64::INFINITY);
    while heap.peek().is_some_and(|r| r.upper > threshold(best.d)) && spent < budget {
        if spent >= check {
            let now = heap.peek().map_or(0.0, |r| r.upper - threshold(best.d));
            let fewer = heap.len() < open && heap.len() as u64 * SPLIT_COST <= budget - spent;
            if now > 0.75 * gap && !fewer {
                break;
            }
            (check, open, gap) = (spent + step, heap.len(), now);
        }
        let mut batch = Vec::with_capacity(BATCH);
        let bar = threshold(best.d);
        while batch.len() < BATCH {
            match heap.pop() {
                Some(r) if r.upper > bar => batch.push(r),
                Some(r) => {
                    heap.push(r);
                    break;
                }
                None => break,
            }
        }
        let done: Vec<([Region; 4], Hit, u64)> =
            batch.par_iter().map(|r| split(target, r, bar)).collect();
        for (_, h, q) in &done {
            best = better(best, *h);
            spent += SPLIT_COST;
            queries += q;
        }
        for (children, _, _) in done {
            for r in children {
                if r.upper > threshold(best.d) {
                    heap.push(r);
                } else {
                    settled = settled.max(r.upper);
                }
            }
        }
    }
    // Regions left (budget spent, or within the tolerance now that the best rose).
    let left = heap.iter().fold(0.0f64, |m, r| m.max(r.upper));
    Certified {
        lower: best.d,
        lower_at: (best.at, best.closest),
        upper: settled.max(left).max(best.d),
        queries,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The largest of `min(d(x, ta), d(x, tb))` over a dense barycentric grid of `v`.
    fn dense_max(v: &[V3; 3], ta: &[V3; 3], tb: &[V3; 3]) -> f64 {
        let n = 60;
        let mut m = 0.0f64;
        for i in 0..=n {
            for j in 0..=n - i {
                let (u, w) = (f64::from(i) / f64::from(n), f64::from(j) / f64::from(n));
                let x = std::array::from_fn(|k| {
                    v[0][k] + (v[1][k] - v[0][k]) * u + (v[2][k] - v[0][k]) * w
                });
                m = m.max(dist2_to(x, ta).min(dist2_to(x, tb)).sqrt());
            }
        }
        m
    }

    /// Two coplanar triangles sharing the edge `(0,0,0)–(0,2,0)`, and a region at
    /// height 0.1 straddling that edge:
    ///
    /// ```text
    ///   y
    ///   2 +-----+-----+        ta: x ≤ 0, tb: x ≥ 0 (z = 0)
    ///     | ta  |  tb |        region (z = 0.1): (-0.5, 0.5), (0.5, 0.5), (0, 1.5)
    ///   0 +-----+-----+ x
    ///    -2     0     2
    /// ```
    /// Every point of the region is 0.1 above one of the two; one triangle alone
    /// bounds the far corner by its distance past the shared edge.
    #[test]
    fn a_plane_through_the_shared_edge_makes_the_bound_exact() {
        let ta = [[0.0, 0.0, 0.0], [0.0, 2.0, 0.0], [-2.0, 1.0, 0.0]];
        let tb = [[0.0, 2.0, 0.0], [0.0, 0.0, 0.0], [2.0, 1.0, 0.0]];
        let v = [[-0.5, 0.5, 0.1], [0.5, 0.5, 0.1], [0.0, 1.5, 0.1]];
        let single = [ta, tb]
            .iter()
            .map(|t| v.iter().map(|p| dist2_to(*p, t)).fold(0.0, f64::max).sqrt())
            .fold(f64::INFINITY, f64::min);
        assert!(single > 0.5, "{single}");
        let pair = pair_bound(&v, &ta, &tb);
        assert!((pair - 0.1).abs() < 1e-12, "{pair}");
    }

    /// A fan corner: two triangles sharing only the origin, with a gap between
    /// them; a region around the origin at height 0.05. The bound holds and is
    /// tighter than either triangle alone.
    #[test]
    fn a_plane_through_a_shared_corner_bounds_both_sides() {
        let ta = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
        let tb = [[0.0, 0.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, 0.0, 0.0]];
        let v = [[0.4, 0.1, 0.05], [-0.4, 0.1, 0.05], [0.0, -0.1, 0.05]];
        let single = [ta, tb]
            .iter()
            .map(|t| v.iter().map(|p| dist2_to(*p, t)).fold(0.0, f64::max).sqrt())
            .fold(f64::INFINITY, f64::min);
        let pair = pair_bound(&v, &ta, &tb);
        assert!(pair >= dense_max(&v, &ta, &tb) - 1e-12);
        assert!(pair < 0.6 * single, "{pair} vs {single}");
    }

    fn point() -> impl Strategy<Value = V3> {
        prop::array::uniform3(-1.0f64..1.0)
    }

    proptest! {
        /// Whatever the triangles (sharing an edge, a corner or nothing), the pair
        /// bound is never below the largest distance over the region.
        #[test]
        fn the_pair_bound_is_never_below_the_truth(
            v in prop::array::uniform3(point()),
            shared in prop::array::uniform2(point()),
            a in point(),
            b in point(),
            c in point(),
            kind in 0u8..3,
        ) {
            let ta = [shared[0], shared[1], a];
            let tb = match kind {
                0 => [shared[1], shared[0], b],
                1 => [shared[0], b, c],
                _ => [a.map(|x| x + 2.0), b, c],
            };
            let bound = pair_bound(&v, &ta, &tb);
            let truth = dense_max(&v, &ta, &tb);
            prop_assert!(bound >= truth - 1e-9, "{bound} < {truth}");
        }
    }
}
