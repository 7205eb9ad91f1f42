//! Vertex fitting after edge collapse (`meshlod simplify --fit`): the simplified
//! mesh's points are moved toward the input surface, without letting any sample of
//! the input or of the output get farther from the other mesh than the farthest one
//! around it already was.
//!
//! Garland & Heckbert place each merged point at the minimum of its quadric, the sum
//! of the planes of the input triangles its collapses *merged*. After later collapses
//! of its neighbours the point's triangles cover input surface whose planes went to
//! other points, and part of its own planes are covered by its neighbours' triangles:
//! the placement fits the wrong planes. This pass is the distance term of Hoppe,
//! DeRose, Duchamp, McDonald and Stuetzle, "Mesh optimization" (SIGGRAPH 1993), their
//! `E_dist`: the sum over points of the input of the squared distance to the output,
//! minimised over the output's vertex positions with the correspondences (which
//! output triangle each input point is nearest to) held fixed, which makes it a
//! linear least-squares problem. Measured, as the peers are, by the *two-sided*
//! Hausdorff distance, whose larger side is most often the output's (a long
//! triangle whose middle sags off a curved surface while its corners sit on it), we
//! add the other direction's term: samples of the output pulled toward their
//! nearest input points. Here it is solved approximately, point by point:
//!
//! 1. **Samples.** Every used input vertex (weight: a third of its triangles' area)
//!    and every input triangle's centroid (weight: its area), each on its nearest
//!    output triangle, found without a tree: a vertex starts at the triangles of the
//!    output point the collapses merged it into (`Surface::vertex_roots`),
//!    a centroid at its corners' triangles; a triangle is taken at once when the
//!    sample projects inside it farther from each edge than from its plane, otherwise
//!    the nearest candidate is walked across edges while a neighbour is nearer
//!    (bounding spheres skip the hopeless ones). A closest-point query over the
//!    output where no merge is known. The samples are then stored grouped by
//!    output triangle (position and weight, 16 bytes each: a stable counting sort
//!    that makes them a second time straight into their slots, without a copy).
//!    Each free output point also gets its nearest input point (one query against
//!    the input's tree, shared with the orientation repair), for the guard below.
//!    **Output samples** are made again in each iteration: each output triangle's
//!    centroid and each edge's midpoint (an edge once for its two triangles), with
//!    their nearest input points (queries against the input's tree, each started
//!    at its own answer of the last iteration, or at its triangle's centroid's).
//!    One whose nearest input triangle faces against its output triangle (an
//!    edge's: against its two triangles' summed normal) belongs to another sheet,
//!    the far side of a thin part or another part lying against this one, and
//!    pulls nothing (the normal-compatibility test of ICP's correspondence
//!    rejection).
//!    **Edge swaps** ([`FitParams::swaps`]; `--swap`, and `--fit`): before the
//!    iterations, the diagonals of quads are swapped where the other one lies
//!    nearer these samples (the [`swap`] module's rules; the samples follow).
//!    With swaps and no iterations, this pass stops there.
//! 2. **Step.** In each iteration ([`DEFAULT_FIT_ITERATIONS`] by default), each
//!    sample is projected on its output triangle (point `q`, barycentric weights `b`,
//!    unit normal `n`; residual `r = n·(q − p)`, the point-to-plane distance of Chen
//!    & Medioni's ICP). Each corner `v` gathers `A_v = Σ w b_v n nᵀ` and
//!    `g_v = Σ w b_v r n` and steps by `Δ_v = −¾ (A_v + 10⁻³ tr(A_v) I)⁻¹ g_v`, ¾ of
//!    the way to the minimiser of a [`Quadric`] of its samples' planes plus a small
//!    ridge ([`Quadric::solve`]): the
//!    weighted mean of its samples' residuals along their normals (weights `b_v`,
//!    not `b_v²`, so that three corners moving at once do not overshoot; damped, as
//!    in a Jacobi iteration; the small ridge keeps the step along the normals where
//!    the samples are coplanar). An output sample at distance `d` from its nearest
//!    input point `y` adds, for each corner it depends on, the plane through `y`
//!    perpendicular to the offset, weight `b_v` times a quarter of twice its
//!    triangle's area ([`OUT_WEIGHT`]; the input samples weigh twice the input's
//!    area in all).
//!    **Fourth-power term.** The peers are judged by the maximum distance as well
//!    as the mean, and least squares lets a few far samples (a peak cut off, the
//!    middle of a chord across a rounded edge) stay far to serve many near ones.
//!    Each sample counts `d² + K/2 · d⁴ / d_rms²` ([`QUARTIC_WEIGHT`] `K = 0.2`; `d_rms`
//!    the input samples' weighted RMS distance at the iteration's start, so the term
//!    does not depend on the mesh's scale), by one step of iteratively reweighted
//!    least squares per iteration: each sample's weight is multiplied by
//!    `1 + K d² / d_rms²`, `d` its distance at the iteration's start, which makes
//!    the weighted gradient the objective's there (`d_rms` comes from a first pass
//!    of projections). For an input sample `d` is the distance to its nearest
//!    point on the triangle, at least its residual `|r|` (equal where it projects
//!    inside). The factor is not capped: the farthest samples are the ones the term
//!    is for, and the damping and the guards below bound every step.
//! 3. **Guard (Hausdorff).** A sample's distance after the step is bounded by
//!    `|q + Σ b_k Δ_k − p|` (the moved point of its old triangle; the nearest point
//!    can only be nearer). Each point's *local maximum* is the largest current
//!    distance of the samples on its triangles (input and output) and of its own
//!    nearest input point.
//!    A sample whose bound exceeds both its own distance and the local maxima of its
//!    corners halves the steps of its corners (up to four times, then cancels them),
//!    so the largest distance of the input samples and of the output points does
//!    not grow. (The output samples only raise the local maxima; their own
//!    distances after the step are not bounded, as the guard's bound would not be
//!    one for them: they move with their triangle.)
//!    Each round after the first tests again only the triangles around a halved
//!    step (the others passed and are unchanged), and the samples' projections are
//!    computed again rather than stored (bit for bit the same values).
//! 4. **Guard (shape).** A step that would turn a triangle by more than 60°, lower
//!    its quality ([`triangle_quality`]) below both half its old quality and the
//!    simplifier's sliver floor, or turn it away from the input triangle nearest its
//!    centroid among those whose centroids it received, is cancelled for its
//!    corners.
//! 5. **Guard (orientation).** After the iterations, a moved triangle that faces
//!    away from the input triangle nearest its centroid (the orientation repair's
//!    test: one query each, on the positions as they will be stored) and did not
//!    before puts its points back where the collapses left them. The answers go to
//!    the orientation repair, which then asks the tree only for the triangles the
//!    fit did not move ([`facing::KnownNearest`]).
//!
//! Fixed: points on a border or a non-manifold edge (borders keep the positions the
//! collapses gave them), points of locked input vertices, and points no triangle
//! uses; a point whose samples give it nothing to fit (a zero quadric) stays too.
//! Points, not vertices, move: the vertices of a UV seam or a material border at one
//! position move together, so nothing tears. The iterations leave the triangles and
//! attributes unchanged; the swaps change which points a triangle joins, nothing
//! else (borders, seams, material borders and the topology stay).
//!
//! Measured (`meshlod simplify --measure`, bunny, armadillo, Nefertiti, Lucy, turbine
//! blade and fandisk at 10% and 1%): with the input samples alone, Hausdorff mean
//! ×0.82–0.97 (geometric mean ×0.93) and maximum ×0.71–1.01 (×0.906) against no
//! fit; the output samples then took the maxima ×0.73–1.01 (×0.936) and the means
//! ×0.935–1.002 (×0.981) further, and the fourth-power term the maxima ×0.86–1.10
//! (×0.95) at means ×0.997–1.027 (×1.010), for 1.3–2.0× the time of the
//! simplification alone in all; see `docs/methods/qem.md`.

use crate::collapse::{closest_on_triangle, FanCsr};
use crate::filter::triangle_quality;
use crate::mesh::{Mesh, Weld};
use crate::metrics::bvh::{Bvh, Closest};
use crate::metrics::triangle::{closest_point, cross, dot, sub, V3};
use crate::quadric::{norm, Quadric};

use super::facing::{self, KnownNearest};

mod swap;

/// Iterations `meshlod simplify --fit` runs ([`crate::SimplifyOptions::fit_iterations`]
/// is 0, off, by default).
pub const DEFAULT_FIT_ITERATIONS: u32 = 2;

/// Step factor of the damped Jacobi iteration.
const DAMPING: f64 = 0.75;
/// Ridge added to each point's normal matrix, relative to its trace.
const RIDGE: f64 = 1e-3;
/// Halvings of a step before the guard cancels it.
const HALVINGS: usize = 4;
/// Cosine of the largest turn of a triangle's normal in one step (60°).
const MAX_TURN_COS: f64 = 0.5;
/// Weight of the output samples of a triangle (its centroid and its edges'
/// midpoints, a quarter each, an edge's shared by its two triangles), relative to
/// its area; the input samples weigh twice the input's area in all.
const OUT_WEIGHT: f64 = 2.0;
/// Weight `K` of the fourth-power term of the fit's objective: each sample at
/// distance `d` counts `d² + K/2 · d⁴ / d_rms²` (`d_rms`: the input samples' weighted
/// RMS distance), so the largest distances weigh more than in least squares.
const QUARTIC_WEIGHT: f64 = 0.2;
/// Steps of the walk from a sample's first candidate triangles to nearer neighbours.
const WALK_STEPS: usize = 8;

/// What the fitting did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct FitStats {
    /// Output points (distinct positions) at a new position at the end.
    pub moved: usize,
    /// Iterations run.
    pub iterations: u32,
    /// Edges swapped ([`swap`]).
    pub swaps: usize,
}

/// A point of the input surface; the samples are stored grouped by the output
/// triangle they correspond to (`tri_start` in [`fit`]).
#[derive(Clone, Copy, Default)]
struct Sample {
    /// Position.
    p: [f32; 3],
    /// Weight (an area).
    weight: f32,
}

/// A sample's state for the guard: its offset from the input point to its output
/// point, its barycentric weights there, and that distance (each rounded to `f32`).
#[derive(Clone, Copy)]
struct Projected {
    offset: [f64; 3],
    bary: [f64; 3],
    dist: f64,
}

impl Projected {
    /// The sample at `p` projected on `frame`'s triangle.
    fn new(frame: &Frame, p: V3) -> (Self, V3, [f64; 3], f64) {
        let (q, b) = frame.project(p);
        let off = sub(q, p);
        let d = norm(off);
        let r = |v: f64| f64::from(v as f32);
        (
            Self {
                offset: off.map(r),
                bary: b.map(r),
                dist: r(d),
            },
            off,
            b,
            d,
        )
    }
}

fn f64v(p: [f32; 3]) -> V3 {
    p.map(f64::from)
}

/// A triangle prepared for projecting many points on it.
struct Frame {
    c: [V3; 3],
    e0: V3,
    e1: V3,
    d00: f64,
    d01: f64,
    d11: f64,
    inv: f64,
}

impl Frame {
    fn new(c: &[V3; 3]) -> Self {
        let e0 = sub(c[1], c[0]);
        let e1 = sub(c[2], c[0]);
        let (d00, d01, d11) = (dot(e0, e0), dot(e0, e1), dot(e1, e1));
        let den = d00 * d11 - d01 * d01;
        Self {
            c: *c,
            e0,
            e1,
            d00,
            d01,
            d11,
            inv: if den > 0.0 { 1.0 / den } else { 0.0 },
        }
    }

    /// The closest point of the triangle to `p` and its barycentric weights: the
    /// projection on the plane where it falls inside (the common case, without
    /// branches on regions), otherwise Ericson's closest point. The centroid for a
    /// degenerate triangle (a point of it, so its distance still bounds the true
    /// one from above).
    fn project(&self, p: V3) -> (V3, [f64; 3]) {
        let v = sub(p, self.c[0]);
        let (d20, d21) = (dot(v, self.e0), dot(v, self.e1));
        let b1 = (self.d11 * d20 - self.d01 * d21) * self.inv;
        let b2 = (self.d00 * d21 - self.d01 * d20) * self.inv;
        let mut b = [1.0 - b1 - b2, b1, b2];
        if self.inv == 0.0 {
            b = [1.0 / 3.0; 3];
        } else if b.iter().any(|&w| w < 0.0) {
            b = closest_on_triangle(p, self.c).1;
        }
        let q = std::array::from_fn(|k| {
            b[0] * self.c[0][k] + b[1] * self.c[1][k] + b[2] * self.c[2][k]
        });
        (q, b)
    }
}

/// The output's connectivity over points: fans (CSR) and, per triangle edge `k`
/// (corners `k`, `k+1`), the triangle across it (`u32::MAX` on a border or a
/// non-manifold edge); and which points sit on such an edge.
struct Connectivity {
    fans: FanCsr,
    across: Vec<[u32; 3]>,
    border: Vec<bool>,
}

impl Connectivity {
    /// The triangles around point `p`.
    fn fan(&self, p: usize) -> &[u32] {
        let s = self.fans.start[p] as usize;
        &self.fans.fans[s..s + self.fans.len[p] as usize]
    }
}

fn connectivity(tris: &[[u32; 3]], np: usize) -> Connectivity {
    let fans = FanCsr::build(np, tris, |t| Some(*t));
    if tris
        .iter()
        .any(|t| t[0] == t[1] || t[1] == t[2] || t[2] == t[0])
    {
        return connectivity_sorted(tris, np, fans);
    }
    // An edge a–b is interior when exactly two triangles hold it (those around a
    // that also hold b), else its ends are border points: the result of
    // `connectivity_sorted`, found from a's fan in O(valence) per edge and set on
    // both sides at once instead of sorting every edge.
    let mut across = vec![[u32::MAX; 3]; tris.len()];
    let mut border = vec![false; np];
    let fan = |p: u32| {
        let s = fans.start[p as usize] as usize;
        &fans.fans[s..s + fans.len[p as usize] as usize]
    };
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            if across[t][k] != u32::MAX {
                continue;
            }
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let mut count = 0u32;
            let mut other = u32::MAX;
            for &o in fan(a) {
                if tris[o as usize].contains(&b) {
                    count += 1;
                    if o as usize != t {
                        other = o;
                    }
                }
            }
            if count == 2 {
                let u = tris[other as usize];
                let k2 = (0..3)
                    .find(|&j| {
                        let (x, y) = (u[j], u[(j + 1) % 3]);
                        (x == a && y == b) || (x == b && y == a)
                    })
                    .unwrap_or(0);
                across[t][k] = other;
                across[other as usize][k2] = t as u32;
            } else {
                border[a as usize] = true;
                border[b as usize] = true;
            }
        }
    }
    Connectivity {
        fans,
        across,
        border,
    }
}

/// [`connectivity`] by sorting the undirected edges (kept for triangles with a
/// repeated corner, where an edge can occur twice in one triangle).
fn connectivity_sorted(tris: &[[u32; 3]], np: usize, fans: FanCsr) -> Connectivity {
    // Undirected edges with their (triangle, corner), sorted; runs of two are
    // interior edges.
    let mut edges: Vec<(u64, u32)> = Vec::with_capacity(tris.len() * 3);
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
            edges.push((key, (t as u32) << 2 | k as u32));
        }
    }
    edges.sort_unstable();
    let mut across = vec![[u32::MAX; 3]; tris.len()];
    let mut border = vec![false; np];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 {
            j += 1;
        }
        if j - i == 2 {
            let (t0, k0) = ((edges[i].1 >> 2) as usize, (edges[i].1 & 3) as usize);
            let (t1, k1) = (
                (edges[i + 1].1 >> 2) as usize,
                (edges[i + 1].1 & 3) as usize,
            );
            across[t0][k0] = t1 as u32;
            across[t1][k1] = t0 as u32;
        } else {
            border[(edges[i].0 >> 32) as usize] = true;
            border[(edges[i].0 & 0xffff_ffff) as usize] = true;
        }
        i = j;
    }
    Connectivity {
        fans,
        across,
        border,
    }
}

/// The fitting's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FitParams {
    /// Iterations (0: nothing is done).
    pub iterations: u32,
    /// The simplifier's sliver floor ([`triangle_quality`]).
    pub min_quality: f64,
    /// Weight of the output samples ([`OUT_WEIGHT`]; 0 leaves Hoppe et al.'s
    /// one-sided term).
    pub out_weight: f64,
    /// Weight of the fourth-power term ([`QUARTIC_WEIGHT`]; 0 is plain least squares).
    pub quartic_weight: f64,
    /// Edge swaps toward the input before the iterations ([`swap`]).
    pub swaps: bool,
}

impl FitParams {
    /// `iterations` iterations with the simplifier's `min_quality` and the
    /// default output-sample weight.
    pub(crate) fn new(iterations: u32, min_quality: f64) -> Self {
        Self {
            iterations,
            min_quality,
            out_weight: OUT_WEIGHT,
            quartic_weight: QUARTIC_WEIGHT,
            swaps: false,
        }
    }
}

/// The orientation repair's query starts for a mesh ([`facing::query_starts`]).
pub(crate) type StartsOf<'a> = dyn Fn(&Mesh) -> Vec<Option<u32>> + 'a;

/// Moves the points of `out` (simplified from `input`; `input_tree` is a
/// closest-point tree over `input`) toward the input surface (the module's rules,
/// with `params`). `fixed_vertex(v)` says whether output vertex `v` must keep its
/// position (locked); `merged_into[i]`, when given, is the output vertex input vertex `i` was merged
/// into (`u32::MAX` for none), where the search for its samples' triangles starts
/// (without it, or where it says none, a closest-point query finds them). With
/// `starts` (the orientation repair's query starts for a mesh,
/// [`facing::query_starts`]; asked for after the swaps, which change the
/// triangles), also returns the nearest input points the orientation guard found
/// for the triangles' centroids, for [`facing::repair`].
///
/// The steps, each its own function: the output's points ([`Points::new`]), the
/// input samples on it ([`find_samples`]), the swaps ([`swap::swap_edges`]), each
/// free point's nearest input point ([`nearest_inputs`]), the iterations
/// ([`Fitter::iterate`]) and the orientation guard ([`Fitter::guard_orientation`]).
pub(crate) fn fit(
    input: &Mesh,
    input_tree: &Bvh,
    out: &mut Mesh,
    fixed_vertex: &dyn Fn(usize) -> bool,
    params: FitParams,
    merged_into: Option<&[u32]>,
    starts: Option<&StartsOf<'_>>,
) -> (FitStats, KnownNearest) {
    let mut stats = FitStats::default();
    if (params.iterations == 0 && !params.swaps)
        || out.triangles.is_empty()
        || input.triangles.is_empty()
    {
        return (stats, Vec::new());
    }
    let weld = Weld::exact(&out.positions);
    let point_of = &weld.point_of;
    let mut pts = Points::new(out, &weld, fixed_vertex);
    // Nothing to move: the swaps may still run.
    let iterations = if pts.fixed.iter().all(|&f| f) {
        0
    } else {
        params.iterations
    };
    if iterations == 0 && !params.swaps {
        return (stats, Vec::new());
    }
    let mut found = find_samples(input, out, &pts, point_of, merged_into, iterations > 0);
    if params.swaps {
        let ctx = swap::SwapContext {
            input,
            input_tree,
            x: &pts.x,
            groups: out.groups.as_deref(),
            min_quality: params.min_quality,
        };
        let mut state = swap::SwapState {
            tris: &mut pts.tris,
            out_tris: &mut out.triangles,
            conn: &mut pts.conn,
            samples: &mut found.samples,
            tri_start: &mut found.tri_start,
            reference: &mut found.reference,
        };
        stats.swaps = swap::swap_edges(&ctx, &mut state);
    }
    let starts = starts.map(|f| f(out));
    let starts = starts.as_deref();
    let target = nearest_inputs(input_tree, &pts, &found.tri_at, iterations);
    drop(std::mem::take(&mut found.tri_at));

    let Points {
        mut x,
        tris,
        conn,
        fixed,
    } = pts;
    let x0 = x.clone();
    let fitter = Fitter {
        input,
        input_tree,
        tris: &tris,
        conn: &conn,
        fixed: &fixed,
        samples: &found.samples,
        tri_start: &found.tri_start,
        reference: &found.reference,
        target: &target,
        params,
    };
    let mut work = Work::new(tris.len(), x.len());
    for _ in 0..iterations {
        stats.iterations += 1;
        if !fitter.iterate(&mut x, &mut work) {
            break;
        }
    }
    let known = fitter.guard_orientation(&mut x, &x0, starts);
    stats.moved = (0..x.len()).filter(|&p| x[p] != x0[p]).count();

    for (v, pos) in out.positions.iter_mut().enumerate() {
        let p = point_of[v] as usize;
        if x[p] != x0[p] {
            *pos = x[p].map(|c| c as f32);
        }
    }
    (stats, known)
}

/// The output as the fitting sees it: its points (distinct positions, welded
/// exactly), its triangles over them, their connectivity and which points stay.
struct Points {
    /// Position of each point.
    x: Vec<V3>,
    /// The output's triangles over points.
    tris: Vec<[u32; 3]>,
    /// Fans and edge neighbours of `tris`.
    conn: Connectivity,
    /// Fixed points: borders and non-manifold edges, locked vertices, points no
    /// triangle uses.
    fixed: Vec<bool>,
}

impl Points {
    /// The points of `out` (`weld`: its exact weld), fixed where `fixed_vertex`
    /// says so for one of their vertices.
    fn new(out: &Mesh, weld: &Weld, fixed_vertex: &dyn Fn(usize) -> bool) -> Self {
        let point_of = &weld.point_of;
        let np = weld.representative.len();
        let x: Vec<V3> = weld
            .representative
            .iter()
            .map(|&v| f64v(out.positions[v as usize]))
            .collect();
        let tris: Vec<[u32; 3]> = out
            .triangles
            .iter()
            .map(|t| t.map(|v| point_of[v as usize]))
            .collect();
        let conn = connectivity(&tris, np);
        let mut fixed: Vec<bool> = (0..np)
            .map(|p| conn.border[p] || conn.fan(p).is_empty())
            .collect();
        for (v, &p) in point_of.iter().enumerate() {
            if fixed_vertex(v) {
                fixed[p as usize] = true;
            }
        }
        Self {
            x,
            tris,
            conn,
            fixed,
        }
    }
}

/// The input samples on the output (step 1 of the module's rules), grouped by output
/// triangle, with what the search found on the way.
struct InputSamples {
    /// The samples, grouped by output triangle (a stable counting sort):
    /// `tri_start[t]..tri_start[t + 1]` are those of output triangle `t`.
    samples: Vec<Sample>,
    /// Where each output triangle's samples start in `samples` (one more entry
    /// than triangles).
    tri_start: Vec<u32>,
    /// Per output triangle: the normal of the input triangle nearest its centroid
    /// among those whose centroids it received (the orientation repair's test, see
    /// the `facing` module), and that squared distance.
    reference: Vec<(V3, f64)>,
    /// Per output point: an input triangle of an input vertex merged into it
    /// (`u32::MAX` for none), where its nearest-input query starts.
    tri_at: Vec<u32>,
}

/// Samples: every used input vertex (a third of its triangles' area) and, with
/// `with_centroids`, every input triangle's centroid (its area), each on its nearest
/// output triangle: searched among the triangles of the output points its input
/// vertices were merged into (`merged_into`, through `point_of`), then walked across
/// edges while a neighbour is nearer; a closest-point query where no such point is
/// known.
fn find_samples(
    input: &Mesh,
    out: &Mesh,
    pts: &Points,
    point_of: &[u32],
    merged_into: Option<&[u32]>,
    with_centroids: bool,
) -> InputSamples {
    let ip = &input.positions;
    let start_point = |i: u32| -> Option<u32> {
        let o = *merged_into?.get(i as usize)?;
        point_of.get(o as usize).copied()
    };
    let mut loc = Locator::new(out, &pts.tris, &pts.conn, &pts.x);
    let (vweight, tri_at) = vertex_weights(input, pts.x.len(), &start_point);
    // The output triangle of each sample, in the order they are found (vertices,
    // then centroids; `u32::MAX` where none was found); the samples themselves are
    // written afterwards straight into their groups.
    let mut sample_tri: Vec<u32> = Vec::with_capacity(ip.len() + input.triangles.len());
    let vtri = locate_vertices(&mut loc, ip, &vweight, &start_point, &mut sample_tri);
    let mut reference: Vec<(V3, f64)> = vec![([0.0; 3], f64::INFINITY); pts.tris.len()];
    // The swaps alone (no iterations) take the vertices only: with the centroids
    // too, the means of the six benchmark meshes moved by 0.1% (geometric mean;
    // the largest move 0.4%) for more time (`--swap` 1.05–1.57× the default's
    // instead of 1.02–1.38×, measured side by side).
    if with_centroids {
        locate_centroids(&loc, input, &vtri, &mut sample_tri, &mut reference);
    }
    drop(vtri);
    drop(loc);
    let (tri_start, samples) =
        group_samples(input, &vweight, &sample_tri, pts.tris.len(), with_centroids);
    InputSamples {
        samples,
        tri_start,
        reference,
        tri_at,
    }
}

/// Each input vertex's sample weight (a third of its triangles' area; 0 for one no
/// proper triangle uses) and, per output point (`np` of them), an input triangle at
/// a vertex merged into it (`start_point`), to start the point's own query.
fn vertex_weights(
    input: &Mesh,
    np: usize,
    start_point: &dyn Fn(u32) -> Option<u32>,
) -> (Vec<f32>, Vec<u32>) {
    let ip = &input.positions;
    let mut vweight = vec![0.0f32; ip.len()];
    let mut tri_at = vec![u32::MAX; np];
    for (it, t) in input.triangles.iter().enumerate() {
        let c = t.map(|v| f64v(ip[v as usize]));
        let area = norm(cross(sub(c[1], c[0]), sub(c[2], c[0]))) / 2.0;
        if area.is_nan() || area <= 0.0 {
            continue;
        }
        for &v in t {
            vweight[v as usize] += (area / 3.0) as f32;
            if let Some(q) = start_point(v) {
                if tri_at[q as usize] == u32::MAX {
                    tri_at[q as usize] = it as u32;
                }
            }
        }
    }
    (vweight, tri_at)
}

/// The output triangle of each weighted input vertex (positions `ip`), pushed to
/// `sample_tri` in vertex order; returns it per input vertex (`u32::MAX` for none),
/// where the centroids' searches start.
fn locate_vertices(
    loc: &mut Locator<'_>,
    ip: &[[f32; 3]],
    vweight: &[f32],
    start_point: &dyn Fn(u32) -> Option<u32>,
    sample_tri: &mut Vec<u32>,
) -> Vec<u32> {
    let mut vtri = vec![u32::MAX; ip.len()];
    let mut last = u32::MAX;
    for (i, &w) in vweight.iter().enumerate() {
        if w > 0.0 {
            let p = f64v(ip[i]);
            let found = if loc.accept(p, last) {
                Some(last)
            } else {
                loc.locate(p, &[start_point(i as u32)])
            };
            sample_tri.push(found.unwrap_or(u32::MAX));
            if let Some(tri) = found {
                last = tri;
                vtri[i] = tri;
            }
        }
    }
    vtri
}

/// The output triangle of each input triangle's centroid, from the nearest of its
/// corners' triangles (`vtri`), pushed to `sample_tri` in triangle order (none for
/// a degenerate triangle); each centroid also offers its triangle's normal as its
/// output triangle's `reference`.
fn locate_centroids(
    loc: &Locator<'_>,
    input: &Mesh,
    vtri: &[u32],
    sample_tri: &mut Vec<u32>,
    reference: &mut [(V3, f64)],
) {
    let ip = &input.positions;
    for t in &input.triangles {
        let Some((n, _, centroid)) = centroid_sample(ip, t) else {
            continue;
        };
        let mut best = (f64::INFINITY, u32::MAX);
        let first = t
            .iter()
            .map(|&v| vtri[v as usize])
            .find(|&tri| tri != u32::MAX && loc.accept(centroid, tri))
            .unwrap_or(u32::MAX);
        if first != u32::MAX {
            best = (0.0, first);
        }
        for (k, &v) in t.iter().enumerate() {
            if first != u32::MAX {
                break;
            }
            let tri = vtri[v as usize];
            if tri == u32::MAX || t[..k].iter().any(|&u| vtri[u as usize] == tri) {
                continue;
            }
            let d = loc.tri_dist(centroid, tri, best.0);
            if d < best.0 {
                best = (d, tri);
            }
        }
        if best.1 == u32::MAX {
            sample_tri.push(u32::MAX);
            continue;
        }
        let tri = if best.0 == 0.0 && best.1 == first {
            first
        } else {
            loc.walk(centroid, best)
        };
        sample_tri.push(tri);
        let oc = loc.tris[tri as usize].map(|q| loc.x[q as usize]);
        let d = sub(
            centroid,
            std::array::from_fn(|k| (oc[0][k] + oc[1][k] + oc[2][k]) / 3.0),
        );
        let r = &mut reference[tri as usize];
        if dot(d, d) < r.1 {
            *r = (n, dot(d, d));
        }
    }
}

/// An input triangle's normal, area and centroid (positions `ip`), or `None` for a
/// degenerate one.
fn centroid_sample(ip: &[[f32; 3]], t: &[u32; 3]) -> Option<(V3, f64, V3)> {
    let c = t.map(|v| f64v(ip[v as usize]));
    let n = cross(sub(c[1], c[0]), sub(c[2], c[0]));
    let area = norm(n) / 2.0;
    if area.is_nan() || area <= 0.0 {
        return None;
    }
    let centroid: V3 = std::array::from_fn(|k| (c[0][k] + c[1][k] + c[2][k]) / 3.0);
    Some((n, area, centroid))
}

/// The samples grouped by output triangle (a counting sort, stable), so each
/// triangle's corners are loaded once per pass: returns `tri_start` (the samples of
/// output triangle `t` are `tri_start[t]..tri_start[t + 1]`; `ntris` triangles) and
/// the samples, made again in the order they were found (`sample_tri`: vertices
/// with a weight, then, `with_centroids`, centroids) and written to their slots.
fn group_samples(
    input: &Mesh,
    vweight: &[f32],
    sample_tri: &[u32],
    ntris: usize,
    with_centroids: bool,
) -> (Vec<u32>, Vec<Sample>) {
    let ip = &input.positions;
    let mut tri_start = vec![0u32; ntris + 1];
    for &t in sample_tri.iter().filter(|&&t| t != u32::MAX) {
        tri_start[t as usize + 1] += 1;
    }
    for i in 0..ntris {
        tri_start[i + 1] += tri_start[i];
    }
    let mut samples = vec![Sample::default(); tri_start[ntris] as usize];
    let mut slot = tri_start.clone();
    let made = vweight
        .iter()
        .enumerate()
        .filter(|(_, &w)| w > 0.0)
        .map(|(i, &w)| Sample {
            p: ip[i],
            weight: w,
        })
        .chain(
            input
                .triangles
                .iter()
                .filter(|_| with_centroids)
                .filter_map(|t| {
                    let (_, area, centroid) = centroid_sample(ip, t)?;
                    Some(Sample {
                        p: centroid.map(|v| v as f32),
                        weight: area as f32,
                    })
                }),
        );
    for (sample, &t) in made.zip(sample_tri) {
        if t != u32::MAX {
            let k = &mut slot[t as usize];
            samples[*k as usize] = sample;
            *k += 1;
        }
    }
    (tri_start, samples)
}

/// Finds the output triangle nearest a point, without a tree where it can: from
/// candidate triangles, then across edges while a neighbour is nearer.
struct Locator<'a> {
    /// The output mesh (for the closest-point tree where no start is known).
    out: &'a Mesh,
    /// The output's triangles over points.
    tris: &'a [[u32; 3]],
    /// Their connectivity.
    conn: &'a Connectivity,
    /// The points' positions.
    x: &'a [V3],
    /// Bounding spheres of the output triangles (centre, radius), for a cheap lower
    /// bound on a sample's distance before the exact one.
    spheres: Vec<(V3, f64)>,
    /// Per output triangle: a corner, unit normal, inward unit normals of its edges
    /// in its plane and their offsets, to accept a sample's triangle at once when
    /// the sample projects inside it farther from every edge than from the plane
    /// (no neighbour that is not folded over it can then be nearer).
    inner: Vec<(V3, V3, [V3; 3], V3)>,
    /// A closest-point tree over the output, built when first needed.
    out_tree: Option<Bvh>,
}

impl<'a> Locator<'a> {
    fn new(out: &'a Mesh, tris: &'a [[u32; 3]], conn: &'a Connectivity, x: &'a [V3]) -> Self {
        let spheres: Vec<(V3, f64)> = tris
            .iter()
            .map(|t| {
                let c = t.map(|q| x[q as usize]);
                let m: V3 = std::array::from_fn(|k| (c[0][k] + c[1][k] + c[2][k]) / 3.0);
                let r = c.iter().map(|&v| norm(sub(v, m))).fold(0.0, f64::max);
                (m, r)
            })
            .collect();
        let inner: Vec<(V3, V3, [V3; 3], V3)> = tris
            .iter()
            .map(|t| {
                let c = t.map(|q| x[q as usize]);
                let nn = cross(sub(c[1], c[0]), sub(c[2], c[0]));
                let l = norm(nn);
                if l.is_nan() || l <= 0.0 {
                    return (c[0], [0.0; 3], [[0.0; 3]; 3], [f64::INFINITY; 3]);
                }
                let n = nn.map(|v| v / l);
                let mut m = [[0.0; 3]; 3];
                let mut o = [0.0; 3];
                for k in 0..3 {
                    let e = cross(n, sub(c[(k + 1) % 3], c[k]));
                    let le = norm(e);
                    m[k] = e.map(|v| v / le);
                    o[k] = dot(m[k], c[k]);
                }
                (c[0], n, m, o)
            })
            .collect();
        Self {
            out,
            tris,
            conn,
            x,
            spheres,
            inner,
            out_tree: None,
        }
    }

    /// Squared distance from `p` to output triangle `t` if it can beat `best`
    /// (infinity otherwise).
    fn tri_dist(&self, p: V3, t: u32, best: f64) -> f64 {
        let (m, r) = self.spheres[t as usize];
        let lb = (norm(sub(p, m)) - r).max(0.0);
        if lb * lb >= best {
            return f64::INFINITY;
        }
        let c = self.tris[t as usize].map(|q| self.x[q as usize]);
        let (q, _) = closest_point(p, c[0], c[1], c[2]);
        let d = sub(q, p);
        dot(d, d)
    }

    /// From `best` (a triangle and its squared distance), across edges while a
    /// neighbour is nearer.
    fn walk(&self, p: V3, mut best: (f64, u32)) -> u32 {
        for _ in 0..WALK_STEPS {
            let mut next = best;
            for &t in &self.conn.across[best.1 as usize] {
                if t != u32::MAX {
                    let d = self.tri_dist(p, t, next.0);
                    if d < next.0 {
                        next = (d, t);
                    }
                }
            }
            if next.1 == best.1 {
                break;
            }
            best = next;
        }
        best.1
    }

    /// Whether `p` projects inside output triangle `t` farther from each edge than
    /// from its plane (false for `u32::MAX`).
    fn accept(&self, p: V3, t: u32) -> bool {
        let Some((c0, n, m, o)) = self.inner.get(t as usize) else {
            return false;
        };
        let h = dot(*n, sub(p, *c0)).abs();
        (0..3).all(|k| dot(m[k], p) - o[k] >= h)
    }

    /// The output triangle nearest `p`, searched from the fans of the points
    /// `starts`: one that accepts it, else the nearest of them walked on; a
    /// closest-point query over the output when no start is known.
    fn locate(&mut self, p: V3, starts: &[Option<u32>]) -> Option<u32> {
        for s in starts.iter().flatten() {
            let s = *s as usize;
            for &t in self.conn.fan(s) {
                if self.accept(p, t) {
                    return Some(t);
                }
            }
        }
        let mut best = (f64::INFINITY, u32::MAX);
        for (i, s) in starts.iter().enumerate() {
            let Some(s) = *s else { continue };
            if starts[..i].contains(&Some(s)) {
                continue;
            }
            let s = s as usize;
            for &t in self.conn.fan(s) {
                let d = self.tri_dist(p, t, best.0);
                if d < best.0 {
                    best = (d, t);
                }
            }
        }
        if best.1 == u32::MAX {
            let out = self.out;
            let tree = self
                .out_tree
                .get_or_insert_with(|| Bvh::build_morton(&out.positions, &out.triangles));
            return tree.closest(p, None).map(|c| c.triangle);
        }
        Some(self.walk(p, best))
    }
}

/// Each free point's nearest input point (the output → input samples; none when
/// `iterations` is 0), the query started at an input triangle of a vertex merged
/// into it (`tri_at`), else at the previous answer.
fn nearest_inputs(input_tree: &Bvh, pts: &Points, tri_at: &[u32], iterations: u32) -> Vec<V3> {
    let np = pts.x.len();
    let mut target: Vec<V3> = vec![[0.0; 3]; np];
    let mut hint = None;
    for p in 0..np {
        if pts.fixed[p] || iterations == 0 {
            continue;
        }
        if tri_at[p] != u32::MAX {
            hint = Some(tri_at[p]);
        }
        if let Some(c) = input_tree.closest(pts.x[p], hint) {
            hint = Some(c.triangle);
            target[p] = c.point;
        }
    }
    target
}

/// The fourth-power term's factor on a sample's weight, `1 + K d²/d_rms²`
/// (`k_rms = K/d_rms²`).
fn reweight(k_rms: f64, d: f64) -> f64 {
    1.0 + k_rms * d * d
}

/// What the iterations read: the output's triangles, samples and guards' data.
struct Fitter<'a> {
    input: &'a Mesh,
    input_tree: &'a Bvh,
    /// The output's triangles over points.
    tris: &'a [[u32; 3]],
    conn: &'a Connectivity,
    fixed: &'a [bool],
    /// The input samples grouped by output triangle ([`InputSamples`]).
    samples: &'a [Sample],
    tri_start: &'a [u32],
    reference: &'a [(V3, f64)],
    /// Each free point's nearest input point ([`nearest_inputs`]).
    target: &'a [V3],
    params: FitParams,
}

/// The buffers of an iteration (per output triangle or point), kept between
/// iterations.
struct Work {
    /// Per output triangle, the input triangles nearest its centroid and its
    /// edges' midpoints in the last iteration, where the next one's queries start.
    /// (Keeping them as the correspondences, as Hoppe et al. hold theirs fixed
    /// while solving, and projecting on them alone was measured: maxima up to 4%
    /// higher.)
    out_match: Vec<[u32; 4]>,
    /// Per output triangle, its (unnormalised) normal at the iteration's start.
    normals: Vec<V3>,
    /// Per point, the quadric of its samples' planes.
    quad: Vec<Quadric>,
    /// Per point, its step.
    step: Vec<V3>,
    /// Per point, the fraction of its step the guards let it take.
    scale: Vec<f64>,
    /// Per point, the largest distance around it (the guard's local maximum).
    local_max: Vec<f64>,
}

impl Work {
    fn new(ntris: usize, np: usize) -> Self {
        Self {
            out_match: vec![[u32::MAX; 4]; ntris],
            normals: vec![[0.0; 3]; ntris],
            quad: vec![Quadric::ZERO; np],
            step: vec![[0.0; 3]; np],
            scale: vec![0.0; np],
            local_max: vec![0.0; np],
        }
    }
}

/// The output samples' pull toward their nearest input points (a query each),
/// added to the points' quadrics.
struct Pull<'a> {
    input: &'a Mesh,
    input_tree: &'a Bvh,
    x: &'a [V3],
    quad: &'a mut [Quadric],
    k_rms: f64,
    /// Where the next query starts when the sample has no answer of its own.
    hint: Option<u32>,
}

impl Pull<'_> {
    /// The sample at `q` (its triangle facing `facing`): its nearest input point
    /// (the query started at `last`, its answer in the last iteration, else at the
    /// hint), and its planes for `corners` (point, weight). Returns the input
    /// triangle found (`u32::MAX` for none) and the distance (0 when it pulls
    /// nothing).
    fn pull(&mut self, q: V3, facing: V3, last: u32, corners: &[(usize, f64)]) -> (u32, f64) {
        if last != u32::MAX {
            self.hint = Some(last);
        }
        let Some(cl) = self.input_tree.closest(q, self.hint) else {
            return (u32::MAX, 0.0);
        };
        self.hint = Some(cl.triangle);
        let (point, triangle) = (cl.point, cl.triangle);
        // A nearest input triangle facing the other way belongs to another
        // sheet (the far side of a thin part, another part lying against this
        // one): no correspondence.
        if dot(facing, facing::face_normal(self.input, triangle)) < 0.0 {
            return (triangle, 0.0);
        }
        let off = sub(q, point);
        let d = norm(off);
        if d > 0.0 {
            let u = off.map(|v| v / d);
            for &(v, w) in corners {
                let w = w * reweight(self.k_rms, d);
                self.quad[v].add(&Quadric::from_plane(u, d - dot(u, self.x[v]), w));
            }
        }
        (triangle, d)
    }
}

impl Fitter<'_> {
    /// The samples of output triangle `tri`.
    fn group(&self, tri: usize) -> &[Sample] {
        &self.samples[self.tri_start[tri] as usize..self.tri_start[tri + 1] as usize]
    }

    /// One iteration (step 2 to 4 of the module's rules): moves the points `x`;
    /// false when no point moved (the iterations stop).
    fn iterate(&self, x: &mut [V3], work: &mut Work) -> bool {
        work.quad.fill(Quadric::ZERO);
        work.local_max.fill(0.0);
        for (n, t) in work.normals.iter_mut().zip(self.tris) {
            let c = t.map(|q| x[q as usize]);
            *n = cross(sub(c[1], c[0]), sub(c[2], c[0]));
        }
        let k_rms = self.quartic_factor(x);
        self.gather_input(x, work, k_rms);
        self.gather_output(x, work, k_rms);
        self.solve_steps(x, work);
        self.guard_hausdorff(x, work);
        self.guard_shape(x, work);
        apply_steps(x, work)
    }

    /// The fourth-power term, by iteratively reweighted least squares: the
    /// gradient of Σ w (d² + K/2 · d⁴/d_rms²) is that of least squares with each
    /// weight times 1 + K d²/d_rms² (d at the iteration's start). Returns
    /// `K/d_rms²`, from the input samples' RMS distance (a pass of projections: a
    /// second quadric per point, to add once it is known, took 4% more memory at
    /// the peak); 0 for no term.
    fn quartic_factor(&self, x: &[V3]) -> f64 {
        let quartic_weight = self.params.quartic_weight;
        let mut k_rms = 0.0;
        if quartic_weight > 0.0 {
            let (mut sum_w, mut sum_wd2) = (0.0f64, 0.0f64);
            for (tri, &t) in self.tris.iter().enumerate() {
                if self.group(tri).is_empty() {
                    continue;
                }
                let frame = Frame::new(&t.map(|q| x[q as usize]));
                for s in self.group(tri) {
                    let d = Projected::new(&frame, f64v(s.p)).3;
                    sum_w += f64::from(s.weight);
                    sum_wd2 += f64::from(s.weight) * d * d;
                }
            }
            let rms2 = sum_wd2 / sum_w;
            // (A subnormal RMS would make the factor infinite: no term then.)
            if rms2 > 0.0 && (quartic_weight / rms2).is_finite() {
                k_rms = quartic_weight / rms2;
            }
        }
        k_rms
    }

    /// The input samples' planes, into their triangles' corners' quadrics, and
    /// their distances into the corners' local maxima.
    fn gather_input(&self, x: &[V3], work: &mut Work, k_rms: f64) {
        for (tri, &t) in self.tris.iter().enumerate() {
            if self.group(tri).is_empty() {
                continue;
            }
            let c = t.map(|q| x[q as usize]);
            let nn = work.normals[tri];
            let l = norm(nn);
            let n = if l > 0.0 { nn.map(|v| v / l) } else { [0.0; 3] };
            let mut wb = [0.0f64; 3];
            let mut wbr = [0.0f64; 3];
            let mut dmax = 0.0f64;
            let frame = Frame::new(&c);
            for s in self.group(tri) {
                let (_, off, b, d) = Projected::new(&frame, f64v(s.p));
                dmax = dmax.max(d);
                let w = f64::from(s.weight) * reweight(k_rms, d);
                let r = dot(n, off);
                for k in 0..3 {
                    wb[k] += w * b[k];
                    wbr[k] += w * b[k] * r;
                }
            }
            for k in 0..3 {
                let v = t[k] as usize;
                work.local_max[v] = work.local_max[v].max(dmax);
                // Σ w b (n·(y − x_v) + r)² over the samples, as the plane quadric of
                // weight Σ w b whose offset is their weighted mean residual.
                if wb[k] > 0.0 {
                    let d = wbr[k] / wb[k] - dot(n, x[v]);
                    work.quad[v].add(&Quadric::from_plane(n, d, wb[k]));
                }
            }
        }
    }

    /// Output samples (output → input): each triangle's centroid and each edge's
    /// midpoint, pulled toward its nearest input point along the offset (the plane
    /// through that point perpendicular to it), into the corners' quadrics and
    /// local maxima.
    fn gather_output(&self, x: &[V3], work: &mut Work, k_rms: f64) {
        let out_weight = self.params.out_weight;
        let Work {
            out_match,
            normals,
            quad,
            local_max,
            ..
        } = work;
        let mut pull = Pull {
            input: self.input,
            input_tree: self.input_tree,
            x,
            quad,
            k_rms,
            hint: None,
        };
        let area = |tri: usize| norm(normals[tri]) / 2.0;
        for (tri, &t) in self.tris.iter().enumerate() {
            let a = area(tri);
            if out_weight <= 0.0
                || t.iter().all(|&v| self.fixed[v as usize])
                || a.is_nan()
                || a <= 0.0
            {
                continue;
            }
            let c = t.map(|q| x[q as usize]);
            let w = out_weight * area(tri) / 4.0;
            let m: V3 = std::array::from_fn(|j| (c[0][j] + c[1][j] + c[2][j]) / 3.0);
            let corners = t.map(|v| (v as usize, w / 3.0));
            let matched = &mut out_match[tri];
            let (found, mut dmax) = pull.pull(m, normals[tri], matched[0], &corners);
            matched[0] = found;
            // Each edge once, from the triangle with the smaller index (or its only
            // one), weighted by both triangles' areas.
            for k in 0..3 {
                let other = self.conn.across[tri][k] as usize;
                // (The other triangle took it unless it was skipped: degenerate, or
                // all its corners fixed, and then so are this edge's ends.)
                if other < tri && other != u32::MAX as usize && area(other) > 0.0 {
                    continue;
                }
                let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                if self.fixed[a] && self.fixed[b] {
                    continue;
                }
                let mut we = w;
                if other != u32::MAX as usize && area(other) > 0.0 {
                    we += out_weight * area(other) / 4.0;
                }
                let mid: V3 = std::array::from_fn(|j| 0.5 * (x[a][j] + x[b][j]));
                if found != u32::MAX {
                    pull.hint = Some(found);
                }
                let ends = [(a, we / 2.0), (b, we / 2.0)];
                let facing = match self.conn.across[tri][k] {
                    u32::MAX => normals[tri],
                    o => std::array::from_fn(|j| normals[tri][j] + normals[o as usize][j]),
                };
                let (edge_found, d) = pull.pull(mid, facing, out_match[tri][k + 1], &ends);
                out_match[tri][k + 1] = edge_found;
                dmax = dmax.max(d);
                if other != u32::MAX as usize {
                    for v in self.tris[other] {
                        local_max[v as usize] = local_max[v as usize].max(d);
                    }
                }
            }
            for &v in &t {
                local_max[v as usize] = local_max[v as usize].max(dmax);
            }
        }
    }

    /// Each free point's step: ¾ of the way to the minimiser of its quadric plus
    /// the ridge (scale 1; 0 where nothing is to fit). Also adds the point's own
    /// distance to its nearest input point to its local maximum.
    fn solve_steps(&self, x: &[V3], work: &mut Work) {
        for (p, &xp) in x.iter().enumerate() {
            work.step[p] = [0.0; 3];
            work.scale[p] = 0.0;
            if self.fixed[p] {
                continue;
            }
            work.local_max[p] = work.local_max[p].max(norm(sub(xp, self.target[p])));
            let mut q = work.quad[p];
            let tr = q.m[0] + q.m[4] + q.m[7];
            if tr.is_nan() || tr <= 0.0 {
                continue;
            }
            // The ridge: the squared distance to the point itself, three axis planes.
            for k in 0..3 {
                let mut e = [0.0; 3];
                e[k] = 1.0;
                q.add(&Quadric::from_plane(e, -xp[k], RIDGE * tr));
            }
            if let Some(y) = q.solve(xp, 0.0) {
                work.step[p] = sub(y, xp).map(|v| DAMPING * v);
                work.scale[p] = 1.0;
            }
        }
    }

    /// Whether a sample of output triangle `tri` would end up, after the scaled
    /// steps, farther from its output point than its own distance and its corners'
    /// local maxima.
    ///
    /// The projections of the step's start are made again (as in
    /// [`Fitter::gather_input`]) rather than stored: 28 bytes a sample saved.
    fn steps_too_far(&self, x: &[V3], work: &Work, tri: usize) -> bool {
        let t = self.tris[tri];
        if t.iter().all(|&v| work.scale[v as usize] == 0.0) {
            return false;
        }
        let frame = Frame::new(&t.map(|q| x[q as usize]));
        for s in self.group(tri) {
            let (pr, ..) = Projected::new(&frame, f64v(s.p));
            let mut e = pr.offset;
            for (&v, &b) in t.iter().zip(&pr.bary) {
                let v = v as usize;
                let f = b * work.scale[v];
                for (ej, sj) in e.iter_mut().zip(work.step[v]) {
                    *ej += f * sj;
                }
            }
            let limit = t
                .iter()
                .map(|&v| work.local_max[v as usize])
                .fold(pr.dist, f64::max);
            if dot(e, e) > limit * limit {
                return true;
            }
        }
        false
    }

    /// Guard (Hausdorff): halve the steps that carry a sample past the local
    /// maxima, then cancel them.
    /// Only the samples and points touching a step halved in the previous round can
    /// change their verdict: the others passed then and still do.
    fn guard_hausdorff(&self, x: &[V3], work: &mut Work) {
        let mut changed: Vec<u32> = Vec::new();
        for round in 0..=HALVINGS {
            let mut bad_points: Vec<u32> = Vec::new();
            if round == 0 {
                for tri in 0..self.tris.len() {
                    if self.steps_too_far(x, work, tri) {
                        bad_points.extend_from_slice(&self.tris[tri]);
                    }
                }
            } else {
                let mut near: Vec<u32> = changed
                    .iter()
                    .flat_map(|&p| self.conn.fan(p as usize).iter().copied())
                    .collect();
                near.sort_unstable();
                near.dedup();
                for &tri in &near {
                    if self.steps_too_far(x, work, tri as usize) {
                        bad_points.extend_from_slice(&self.tris[tri as usize]);
                    }
                }
            }
            // (Every point: a pass over the output's points is cheap, and an
            // unchanged one passes again.)
            for (p, xp) in x.iter().enumerate() {
                if work.scale[p] > 0.0 {
                    let to: V3 = std::array::from_fn(|j| xp[j] + work.scale[p] * work.step[p][j]);
                    if norm(sub(to, self.target[p])) > work.local_max[p] {
                        bad_points.push(p as u32);
                    }
                }
            }
            bad_points.sort_unstable();
            bad_points.dedup();
            changed.clear();
            for &p in &bad_points {
                let p = p as usize;
                if work.scale[p] > 0.0 {
                    work.scale[p] = if round == HALVINGS {
                        0.0
                    } else {
                        work.scale[p] * 0.5
                    };
                    changed.push(p as u32);
                }
            }
            if changed.is_empty() {
                break;
            }
        }
    }

    /// Guard (shape): cancel steps that turn, squash or turn away a triangle.
    fn guard_shape(&self, x: &[V3], work: &mut Work) {
        let min_quality = self.params.min_quality;
        loop {
            let mut changed = false;
            for (tri, t) in self.tris.iter().enumerate() {
                if t.iter().all(|&v| work.scale[v as usize] == 0.0) {
                    continue;
                }
                let n0 = work.normals[tri];
                let c0 = t.map(|p| x[p as usize]);
                let c1 = t.map(|p| {
                    let p = p as usize;
                    std::array::from_fn(|j| x[p][j] + work.scale[p] * work.step[p][j])
                });
                let n1 = cross(sub(c1[1], c1[0]), sub(c1[2], c1[0]));
                let (l0, l1) = (norm(n0), norm(n1));
                let turned = dot(n0, n1) < MAX_TURN_COS * l0 * l1;
                let q0 = triangle_quality(&c0, n0);
                let q1 = triangle_quality(&c1, n1);
                let squashed = q1 < 0.5 * q0 && q1 < min_quality;
                let r = self.reference[tri].0;
                let away = dot(n1, r) <= 0.0 && dot(n0, r) > 0.0;
                if turned || squashed || away || l1.is_nan() || l1 <= 0.0 {
                    for &p in t {
                        if work.scale[p as usize] != 0.0 {
                            work.scale[p as usize] = 0.0;
                            changed = true;
                        }
                    }
                }
            }
            if !changed {
                break;
            }
        }
    }

    /// Whether the triangle `tri` with corners `c` faces away from the input
    /// triangle nearest its centroid (queried from `starts`' entry, else from
    /// `hint`, which is updated), and the answer to keep (with `starts` only).
    fn faces_away(
        &self,
        starts: Option<&[Option<u32>]>,
        tri: u32,
        c: &[V3; 3],
        hint: &mut Option<u32>,
    ) -> (bool, Option<(V3, Closest)>) {
        let n = cross(sub(c[1], c[0]), sub(c[2], c[0]));
        let m = facing::centroid(c);
        let start = match starts {
            Some(st) => st.get(tri as usize).copied().flatten(),
            None => *hint,
        };
        let Some(cl) = self.input_tree.closest(m, start) else {
            return (false, None);
        };
        *hint = Some(cl.triangle);
        let r = facing::face_normal(self.input, cl.triangle);
        let away = dot(n, n) > 0.0 && dot(n, r) < 0.0;
        (away, starts.is_some().then_some((m, cl)))
    }

    /// Guard (orientation): a moved triangle that now faces away from the input
    /// triangle nearest its centroid (the orientation repair's test) and did not
    /// before (at `x0`) puts its points back; then the triangles around those
    /// points are checked again.
    /// Tested on the positions as they will be stored (`f32`), at the centroid the
    /// repair computes and, where `starts` is given, with the repair's own hint, so
    /// that the repair can reuse the answers (returned).
    fn guard_orientation(
        &self,
        x: &mut [V3],
        x0: &[V3],
        starts: Option<&[Option<u32>]>,
    ) -> KnownNearest {
        let tris = self.tris;
        let mut known: KnownNearest = vec![None; tris.len()];
        let stored = |p: u32, x: &[V3]| x[p as usize].map(|c| f64::from(c as f32));
        let mut check: Vec<u32> = (0..tris.len() as u32)
            .filter(|&t| {
                tris[t as usize]
                    .iter()
                    .any(|&p| x[p as usize] != x0[p as usize])
            })
            .collect();
        while !check.is_empty() {
            let mut back: Vec<u32> = Vec::new();
            let mut hint = None;
            for &tri in &check {
                let t = tris[tri as usize];
                if !t.iter().any(|&p| x[p as usize] != x0[p as usize]) {
                    continue;
                }
                // The answer kept is the one for where the triangle ends up.
                let (away_now, answer) =
                    self.faces_away(starts, tri, &t.map(|p| stored(p, x)), &mut hint);
                known[tri as usize] = answer;
                if away_now {
                    let (away_before, before) =
                        self.faces_away(starts, tri, &t.map(|p| stored(p, x0)), &mut hint);
                    if !away_before {
                        back.extend(t.iter().filter(|&&p| x[p as usize] != x0[p as usize]));
                        known[tri as usize] = before;
                    }
                }
            }
            check.clear();
            for &p in &back {
                x[p as usize] = x0[p as usize];
                let p = p as usize;
                check.extend_from_slice(self.conn.fan(p));
            }
            check.sort_unstable();
            check.dedup();
        }
        known
    }
}

/// Moves each point by its scaled step; false when none moved.
fn apply_steps(x: &mut [V3], work: &Work) -> bool {
    let mut any = false;
    for (p, xp) in x.iter_mut().enumerate() {
        if work.scale[p] > 0.0 {
            for (c, s) in xp.iter_mut().zip(work.step[p]) {
                *c += work.scale[p] * s;
            }
            any = true;
        }
    }
    any
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fitting of `out` toward `input` (a fresh tree over it, no query starts).
    fn run(
        input: &Mesh,
        out: &mut Mesh,
        fixed: &dyn Fn(usize) -> bool,
        params: FitParams,
        map: Option<&[u32]>,
    ) -> FitStats {
        let tree = Bvh::build_morton(&input.positions, &input.triangles);
        fit(input, &tree, out, fixed, params, map, None).0
    }

    /// `coarse` fitted toward `input` (no point locked) for `iterations`
    /// iterations with output-sample weight `out_weight`.
    fn fitted(input: &Mesh, coarse: &Mesh, iterations: u32, out_weight: f64) -> Mesh {
        let mut out = coarse.clone();
        let params = FitParams {
            out_weight,
            ..FitParams::new(iterations, 0.1)
        };
        run(input, &mut out, &|_| false, params, None);
        out
    }

    /// An `n`×`n` grid of points over `[0, 4]²` at height `z(x, y)`, two triangles
    /// per cell, facing +z.
    fn grid(n: u32, z: impl Fn(f32, f32) -> f32) -> Mesh {
        let s = 4.0 / (n - 1) as f32;
        let mut positions = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (i as f32 * s, j as f32 * s);
                positions.push([x, y, z(x, y)]);
            }
        }
        let mut triangles = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = j * n + i;
                triangles.push([a, a + 1, a + n + 1]);
                triangles.push([a, a + n + 1, a + n]);
            }
        }
        Mesh::from_triangles(positions, triangles)
    }

    /// The input is the flat 9×9 grid; the output its 3×3 version (corners, edge
    /// midpoints, centre) with the centre lifted to z = 0.3:
    ///
    /// ```text
    ///   6---7---8
    ///   | / | / |     4 = (2, 2, 0.3), the only point off the border
    ///   3---4---5
    ///   | / | / |
    ///   0---1---2
    /// ```
    /// The fitting pulls the centre down toward the plane and leaves the border
    /// where it is, with or without the merge map.
    #[test]
    fn a_lifted_point_is_pulled_back_and_the_border_stays() {
        let input = grid(9, |_, _| 0.0);
        let coarse = grid(3, |x, y| if x == 2.0 && y == 2.0 { 0.3 } else { 0.0 });
        // Each input vertex merged into the nearest coarse vertex.
        let merged: Vec<u32> = input
            .positions
            .iter()
            .map(|p| {
                let c = |v: f32| ((v / 2.0).round() as u32).min(2);
                c(p[1]) * 3 + c(p[0])
            })
            .collect();
        for map in [None, Some(merged.as_slice())] {
            let mut out = coarse.clone();
            let stats = run(&input, &mut out, &|_| false, FitParams::new(4, 0.1), map);
            assert_eq!(stats.moved, 1, "{map:?}");
            assert_eq!(out.triangles, coarse.triangles);
            for v in (0..9).filter(|&v| v != 4) {
                assert_eq!(out.positions[v], coarse.positions[v], "border point {v}");
            }
            let c = out.positions[4];
            assert!(c[2] < 0.3 * 0.5 && c[2] >= 0.0, "centre at {c:?}");
            // It moves along its triangles' normals, which lean: a little sideways.
            assert!(
                (c[0] - 2.0).abs() < 0.25 && (c[1] - 2.0).abs() < 0.25,
                "{c:?}"
            );
        }
    }

    /// The output samples lower the output → input distance where the output's
    /// chords sag below a curved input: a bump `z = (1 + cos(π r / 2)) / 2` for
    /// `r < 2` around the centre of `[0, 4]²`, flat beyond (33×33 points), and its
    /// 5×5 version with every point on it (the nine interior ones free). The largest distance from points of the output
    /// (a 10×10 barycentric lattice on every triangle) to the input falls further
    /// with them than without (Hoppe et al.'s one-sided term alone), and the
    /// input → output maximum does not grow past the output → input one.
    #[test]
    fn output_samples_lower_the_output_to_input_distance() {
        let dome = |x: f32, y: f32| {
            let r = ((x - 2.0).powi(2) + (y - 2.0).powi(2)).sqrt();
            if r < 2.0 {
                0.5 * (1.0 + (std::f32::consts::FRAC_PI_2 * r).cos())
            } else {
                0.0
            }
        };
        let input = grid(33, dome);
        let tree = Bvh::build_morton(&input.positions, &input.triangles);
        let coarse = grid(5, dome);
        let out_to_in = |m: &Mesh| {
            let mut worst = 0.0f64;
            for t in &m.triangles {
                let c = t.map(|v| f64v(m.positions[v as usize]));
                for i in 0..=10 {
                    for j in 0..=10 - i {
                        let (u, v) = (f64::from(i) / 10.0, f64::from(j) / 10.0);
                        let p: V3 = std::array::from_fn(|k| {
                            (1.0 - u - v) * c[0][k] + u * c[1][k] + v * c[2][k]
                        });
                        worst = worst.max(tree.closest(p, None).unwrap().dist2.sqrt());
                    }
                }
            }
            worst
        };
        let after = |out_weight: f64| out_to_in(&fitted(&input, &coarse, 2, out_weight));
        let (before, without, with) = (out_to_in(&coarse), after(0.0), after(OUT_WEIGHT));
        assert!(
            with < without && without < before,
            "{before} {without} {with}"
        );
    }

    /// An output sample whose nearest input triangle faces the other way (the far
    /// side of a thin part, another part lying against this one) pulls nothing:
    /// with the input's plane turned over (facing −z under the coarse grid, which
    /// faces +z, centre lifted to 0.3), the output samples change nothing, so the
    /// fit with them ends where the fit without them does.
    #[test]
    fn output_samples_ignore_input_facing_the_other_way() {
        let mut input = grid(9, |_, _| 0.0);
        for t in &mut input.triangles {
            t.swap(1, 2);
        }
        let coarse = grid(3, |x, y| if x == 2.0 && y == 2.0 { 0.3 } else { 0.0 });
        let after = |out_weight: f64| fitted(&input, &coarse, 1, out_weight).positions[4];
        let (without, with) = (after(0.0), after(OUT_WEIGHT));
        assert!(without[2] < 0.3, "{without:?}");
        assert_eq!(with, without);
    }

    /// The fourth-power term lowers the largest distance: a narrow peak
    /// `z = exp(−r²/0.1)` at (1.5, 1.5), the middle of a cell of the 5×5 output
    /// (whose points sit on the input, nearly flat there), under the diagonal
    /// edge (1, 1)–(2, 2):
    ///
    /// ```text
    ///   (1,2)---(2,2)
    ///     |    / |
    ///     |  ^   |     ^ the peak: 1 high, half that 0.26 from its centre
    ///     | /    |
    ///   (1,1)---(2,1)
    /// ```
    /// The fit moves the diagonal's ends toward the peak, up and inward (the flat
    /// input around them holds them back); weighting the far samples more moves
    /// them further, so the largest input → output distance (the peak's) is lower
    /// with the term than without it.
    #[test]
    fn fourth_power_term_lowers_the_largest_distance() {
        let peak = |x: f32, y: f32| (-((x - 1.5).powi(2) + (y - 1.5).powi(2)) / 0.1).exp();
        let input = grid(33, peak);
        let coarse = grid(5, peak);
        let in_to_out = |quartic_weight: f64| {
            let mut out = coarse.clone();
            let params = FitParams {
                quartic_weight,
                ..FitParams::new(2, 0.1)
            };
            run(&input, &mut out, &|_| false, params, None);
            let tree = Bvh::build_morton(&out.positions, &out.triangles);
            input
                .positions
                .iter()
                .map(|&p| tree.closest(f64v(p), None).unwrap().dist2.sqrt())
                .fold(0.0, f64::max)
        };
        let (plain, weighted) = (in_to_out(0.0), in_to_out(QUARTIC_WEIGHT));
        assert!(weighted < 0.99 * plain, "{plain} {weighted}");
    }

    /// The input is a tent over `[0, 4]²`, `z = 0.5 − |x − y| / 8`: two planes
    /// meeting along the ridge from (0, 0) to (4, 4) (9×9 points, the grid's
    /// diagonals along the ridge). The output is its four corners, split the wrong
    /// way, across the ridge (a valley):
    ///
    /// ```text
    ///   2-------3        2-------3
    ///   | ⟍   B |        | A   ⟋ |
    ///   |   ⟍   |   →    |   ⟋   |
    ///   | A   ⟍ |        | ⟋   B |
    ///   0-------1        0-------1
    /// ```
    /// The swap turns the diagonal 1–2 into 0–3, which puts the output on the
    /// input; no point moves.
    fn tent_and_valley() -> (Mesh, Mesh) {
        let tent = |x: f32, y: f32| 0.5 - (x - y).abs() / 8.0;
        let input = grid(9, tent);
        let corners = [[0.0, 0.0], [4.0, 0.0], [0.0, 4.0], [4.0, 4.0]];
        let positions = corners.iter().map(|&[x, y]| [x, y, tent(x, y)]).collect();
        let valley = Mesh::from_triangles(positions, vec![[0, 1, 2], [1, 3, 2]]);
        (input, valley)
    }

    /// Largest distance from the input's vertices to `out`.
    fn in_to_out(input: &Mesh, out: &Mesh) -> f64 {
        let tree = Bvh::build_morton(&out.positions, &out.triangles);
        input
            .positions
            .iter()
            .map(|&p| {
                tree.closest(f64v(p), None)
                    .map_or(f64::INFINITY, |c| c.dist2.sqrt())
            })
            .fold(0.0, f64::max)
    }

    /// The triangles, each rotated to start at its smallest index (orientation
    /// kept), sorted.
    fn canonical(tris: &[[u32; 3]]) -> Vec<[u32; 3]> {
        let mut out: Vec<[u32; 3]> = tris
            .iter()
            .map(|t| {
                let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
                [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
            })
            .collect();
        out.sort_unstable();
        out
    }

    fn swaps_only() -> FitParams {
        FitParams {
            swaps: true,
            ..FitParams::new(0, 0.1)
        }
    }

    #[test]
    fn a_swap_puts_the_diagonal_on_the_ridge() {
        let (input, valley) = tent_and_valley();
        let before = in_to_out(&input, &valley);
        assert!(before > 0.2, "{before}");
        let mut out = valley.clone();
        let stats = run(&input, &mut out, &|_| false, swaps_only(), None);
        assert_eq!(stats.swaps, 1);
        assert_eq!(stats.moved, 0);
        assert_eq!(out.positions, valley.positions);
        assert_eq!(
            canonical(&out.triangles),
            vec![[0, 1, 3], [0, 3, 2]],
            "diagonal 0–3, facing +z"
        );
        let after = in_to_out(&input, &out);
        assert!(after < 1e-5, "{after}");
        // Vertex ids other than point ids: point 3 is vertex 4 in triangle B
        // (vertex 3, at the same position, unused): the new triangles take the
        // vertices, not the points.
        let mut other = valley.clone();
        other.positions.push(other.positions[3]);
        other.triangles[1] = [1, 4, 2];
        let stats = run(&input, &mut other, &|_| false, swaps_only(), None);
        assert_eq!(stats.swaps, 1);
        assert_eq!(canonical(&other.triangles), vec![[0, 1, 4], [0, 4, 2]]);
        // Already on the ridge: nothing to swap.
        let stats = run(&input, &mut out, &|_| false, swaps_only(), None);
        assert_eq!(stats.swaps, 0);
    }

    /// The same quad with its diagonal on a UV seam (points 1 and 2 are other
    /// vertices in triangle B, at the same positions) or on a material border
    /// (the two triangles in different groups): no swap.
    #[test]
    fn no_swap_across_a_seam_or_a_material_border() {
        let (input, valley) = tent_and_valley();
        let mut seam = valley.clone();
        seam.positions.push(seam.positions[1]);
        seam.positions.push(seam.positions[2]);
        seam.triangles[1] = [4, 3, 5];
        let mut groups = valley.clone();
        groups.groups = Some(vec![0, 1]);
        for (name, m) in [("seam", seam), ("groups", groups)] {
            let mut out = m.clone();
            let stats = run(&input, &mut out, &|_| false, swaps_only(), None);
            assert_eq!(stats.swaps, 0, "{name}");
            assert_eq!(out.triangles, m.triangles, "{name}");
        }
    }

    /// A locked vertex keeps its position, and zero iterations do nothing.
    #[test]
    fn locked_points_and_zero_iterations_stay() {
        let input = grid(9, |_, _| 0.0);
        let coarse = grid(3, |x, y| if x == 2.0 && y == 2.0 { 0.3 } else { 0.0 });
        let mut out = coarse.clone();
        let stats = run(&input, &mut out, &|v| v == 4, FitParams::new(4, 0.1), None);
        assert_eq!(stats.moved, 0);
        assert_eq!(out.positions, coarse.positions);
        let stats = run(&input, &mut out, &|_| false, FitParams::new(0, 0.1), None);
        assert_eq!(stats, FitStats::default());
        assert_eq!(out.positions, coarse.positions);
    }

    /// The same neighbours and border points from the fans as from sorting the
    /// edges, on small random triangle sets over few points (so edges with one,
    /// two, three or more triangles, both orientations and repeated triangles
    /// all occur), and on closed and open meshes.
    #[test]
    fn fan_connectivity_matches_the_sorted_edges() {
        use proptest::prelude::*;
        let same = |tris: &[[u32; 3]], np: usize| {
            let fans = FanCsr::build(np, tris, |t| Some(*t));
            let (a, b) = (connectivity(tris, np), connectivity_sorted(tris, np, fans));
            assert_eq!(a.across, b.across, "{tris:?}");
            assert_eq!(a.border, b.border, "{tris:?}");
        };
        let ico = crate::mesh::generate::icosphere(2);
        same(&ico.triangles, ico.positions.len());
        let open = grid(5, |_, _| 0.0);
        same(&open.triangles, open.positions.len());
        let soup = prop::collection::vec(
            (0u32..7, 0u32..7, 0u32..7)
                .prop_filter("distinct", |(a, b, c)| a != b && b != c && c != a),
            0..24,
        );
        proptest!(ProptestConfig::with_cases(512), |(t in soup)| {
            let tris: Vec<[u32; 3]> = t.iter().map(|&(a, b, c)| [a, b, c]).collect();
            same(&tris, 7);
        });
    }
}
