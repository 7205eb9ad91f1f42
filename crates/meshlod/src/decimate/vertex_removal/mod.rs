//! Vertex decimation by vertex removal and hole re-triangulation (Schroeder, Zarge &
//! Lorensen, *Decimation of Triangle Meshes*, SIGGRAPH 1992; the global error
//! accumulation and priority order of VTK's `vtkDecimatePro`, Schroeder 1997).
//!
//! A point is removed with its fan of triangles and the `k`-sided hole left behind is
//! re-triangulated with `k − 2` triangles over the same (surviving) points, so every
//! output point is an input point at its exact position, with its exact attributes.
//!
//! # Classification
//! Every point is classified from its current fan ([`VertexClass`]): *simple* (one
//! closed, consistently oriented fan, no feature edge), *complex* (anything else
//! topologically: several fans, an edge with more than two triangles, an inconsistent
//! orientation, or a valence above [`MAX_VALENCE`]), *boundary* (one open fan),
//! *interior edge* (closed fan with exactly two non-adjacent feature edges) and
//! *corner* (any other number of feature edges, or a boundary point with feature
//! edges inside its fan). A spoke `v–q` is a feature edge when the dihedral angle of
//! its two triangles exceeds the feature angle, or when it is an attribute seam or a
//! material border (the two triangles disagree on a wedge or a group).
//!
//! # Criteria
//! Simple and corner points: the distance to the area-weighted average plane of the
//! fan (base `Σ Aᵢ cᵢ / Σ Aᵢ`, normal `Σ Aᵢ nᵢ / Σ Aᵢ`). Boundary and interior-edge
//! points: the distance to the line through their two boundary or feature neighbours.
//! Complex and locked points are never removed; corners only when
//! [`VertexRemovalOptions::keep_corners`] is off; boundary points not at all with
//! [`VertexRemovalOptions::lock_boundary`].
//!
//! # Hole triangulation
//! Recursive loop splitting: every split line joins two non-adjacent loop points; its
//! split plane contains the line and is perpendicular to the average plane; it is
//! valid only when it separates the two halves of the loop (strictly, and with the
//! orientation of the loop, so no triangle can flip), and when the line is not an edge
//! of the mesh already. The valid line with the largest aspect ratio (the smallest
//! distance of a loop point to the split plane over the line's length) is chosen and
//! both halves are split again, down to triangles. Where no valid split exists the
//! point is kept. An interior-edge point is first split along its feature line (so the
//! crease or seam survives as an edge) and each half is triangulated against its own
//! average plane; a boundary point's loop is closed by the new boundary edge between
//! its two boundary neighbours. Topology checks: no new edge may exist already (no
//! duplicate edge, no non-manifold edge, no closed hole), the valence-3 case may not
//! recreate an existing triangle (the tetrahedron → two triangles case), a lone
//! triangle is never removed, and every new triangle must face the side of the
//! average plane's normal with a non-zero area.
//!
//! Besides the average-plane test, every new triangle must face the side of the
//! input triangles it stands for: each triangle carries the sum of the area-weighted
//! normals of the input triangles it replaced, and a new triangle must have a positive
//! dot product with its fan's sum and with the sum of the old triangle on each loop
//! edge it keeps. A simple or corner point whose fan does not project one-to-one onto
//! its average plane (a fold) is kept.
//!
//! # Facing the input
//! Those checks look at the surface being replaced only. Across a thin part (a horn,
//! an ear, a wing, a slab) a new triangle between surviving points can pass nearer
//! the opposite face than the face it replaces, and then faces away from the input
//! there (its normal and that of the input triangle nearest its centroid point to
//! opposite sides). Once a removal's accumulated bound `e` reaches [`FACING_FROM`]
//! of the bounding-box diagonal (below it the replaced surface is that near, and
//! only a part thinner than twice that could be nearer on its other side), the
//! planned triangles are tested against the input (a closest-point tree in Morton
//! order, [`Bvh::build_morton`], built on first use: cheap to build for the few
//! thousand queries of a run). A removal that leaves more triangles facing away than it
//! removes goes after every removal that does not (its key is raised above them all, as
//! in the Melax driver); when only such removals are left the run stops, with a stop
//! detail that says so, rather than fold thin parts over.
//!
//! # Error
//! Every triangle carries an error bound `e` (0 on input triangles). Removing `v`
//! has a step distance `δ(v)`: the largest of the Schroeder distance above, the
//! distance from `v` to the new triangles, and — along the average normal — the gap
//! between old and new surface at `v` and wherever `v`'s spokes cross the new edges.
//! The new triangles get `e = max(e of the removed triangles) + δ(v)`.
//!
//! What `e` means: for a simple or corner point the old fan and the new patch both
//! project one-to-one onto the average plane (checked), over the same polygon, so the
//! gap between them — two piecewise-linear height fields — is largest at a vertex of
//! their overlay, `v` or a spoke crossing: `δ` bounds the distance from every point of
//! the old fan to the new patch and back. By induction (triangle inequality), `e` of a
//! triangle bounds the distance from every point of the input surface it replaced to
//! the output surface. For boundary and interior-edge points, whose old and new
//! domains differ by the triangle between `v` and its feature line, `δ` adds the
//! distance to that line, which bounds the distance along the line but is an estimate
//! elsewhere. The largest `e` over the run is the reported error, and
//! [`StopRule::max_error`] caps it over the whole run, not per step. Measured
//! Hausdorff distances stay below it (tests check this).
//!
//! # Strategy
//! A priority queue with lazy invalidation (a version counter per point): the
//! cheapest removal first, its loop points re-evaluated after it. With a maximum
//! error the key is the accumulated bound `e` (`vtkDecimatePro`'s order: most points
//! removed under the bound); with only a target count the key is the step distance
//! `δ`, which measured lower Hausdorff distances and fewer fold-overs at the same count
//! (bunny at 10%: 0.21% against 0.36% of the diagonal). `vtkDecimate`'s alternative —
//! passes over all points with a threshold that grows until the target — removes
//! points in index order inside a pass, so a pass mixes cheap and expensive removals
//! under its threshold; the queue costs one heap operation per evaluation.
//! The initial bounds of all points are independent of each other, so on large
//! meshes they are computed on rayon's threads and queued in point order: the run
//! does not depend on the number of threads. The workers share the mesh (borrowed
//! read-only) and own only their scratch: a plan (a few kilobytes) and the point
//! marks, at most 8 bytes a point per worker (allocated zeroed: only the pages its
//! loops touch become resident), against about 200 bytes a point for the mesh.
//!
//! Lower bounds are loose (the average-plane distance is about a third of the exact
//! key, which the gaps of the new patch dominate), so a point's loop neighbours are
//! often due next after its removal: those whose bound is below every queued key
//! are planned at once, in the same pass as their bound, and queued with the exact
//! key. A plan queued with its exact key is kept (it is a function of the point's
//! fan, so valid while the point's version is unchanged) and performed as kept when
//! the entry comes out, after the deferred checks below.
//!
//! Two options trade that exactness for speed. With an order slack `S > 1`
//! ([`VertexRemovalOptions::order_slack`]) a popped candidate whose exact key is at
//! most `S ×` the next queued key is removed at once instead of being queued again.
//! With deferred re-keying ([`VertexRemovalOptions::defer_neighbours`]) the loop
//! points of a removal keep their previous key (divided by a factor) until it comes
//! out of the queue, and only then are their changed fans evaluated: about half the
//! evaluations, but a point whose key fell waits behind cheaper-looking ones.
//! Deferral can be limited to the fine part of the run
//! ([`VertexRemovalOptions::defer_below`]): from the first removal whose key reaches
//! a fraction of the diagonal on, the points still waiting are evaluated and the
//! order is exact, so the coarse end, which sets the largest errors, is exact. While
//! deferring, its own slack may apply ([`VertexRemovalOptions::defer_slack`], never
//! to keys at or above the switch key). [`VertexRemovalOptions::with_fast_order`]
//! combines them; it is the default of [`crate::simplify::SimplifyOptions`]
//! (measured against `vtkDecimatePro` in `docs/methods/vertex-removal.md`), and
//! [`VertexRemovalOptions::with_exact_order`] the default of this type.
//!
//! A popped lower-bound entry is planned without the checks against existing edges
//! (most such plans are queued again with their exact key and invalidated by a
//! neighbour's removal before they come back); the checks run on the plans about to
//! be performed, and when a planned diagonal turns out to be an edge already the plan
//! is made again with every check, as if planned so at once.

#[cfg(test)]
mod tests;

use super::heap::{Heap, Item};
use super::{Observer, Outcome, Rejections, StopReason, StopRule};
use crate::collapse::{FanCsr, Surface, DEAD};
use crate::mesh::VertexKind;
use crate::metrics::bvh::Bvh;
use crate::metrics::triangle::closest_point;
use crate::quadric::{cross, dot, sub};
use rayon::prelude::*;
use serde::Serialize;

/// Live triangles as wedge (input vertex) triples and point triples, with their
/// groups (materials) when the input had groups.
pub type TriangleLists = (Vec<[u32; 3]>, Vec<[u32; 3]>, Option<Vec<u32>>);

/// Largest fan (number of triangles around a point) that is considered for removal.
pub const MAX_VALENCE: usize = 63;

/// Bytes copied at once per sub-polygon of the split search (at least the longest
/// loop).
const POLY_SPAN: usize = MAX_VALENCE + 1;

/// Room in `Plan::polys`: the loop, one `len + 2` bytes per split (at most
/// `MAX_VALENCE` splits of a loop of at most `POLY_SPAN` points), and the slack of
/// the fixed-size copies.
const POLYS_CAP: usize = POLY_SPAN + MAX_VALENCE * (POLY_SPAN + 2) + 3 * POLY_SPAN;

/// Fewest points per thread of the parallel initial pass
/// ([`VertexRemoval::initial_pass`]).
const INITIAL_CHUNK: usize = 8192;

/// Removals whose accumulated bound `e` reaches this fraction of the bounding-box
/// diagonal are checked against the input surface (module docs, "Facing the
/// input"): below it a new triangle is that near the surface it replaced, and only a
/// part thinner than twice that could be nearer on its other side.
pub const FACING_FROM: f64 = 2e-3;

/// The default feature angle in degrees (`vtkDecimatePro`'s default).
pub const DEFAULT_FEATURE_ANGLE: f64 = 15.0;

/// The default order slack ([`VertexRemovalOptions::order_slack`]).
pub const DEFAULT_ORDER_SLACK: f64 = 1.0;

/// Options of [`VertexRemoval`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexRemovalOptions {
    /// A spoke whose two triangles meet at a dihedral angle above this many degrees
    /// is a feature edge. Default [`DEFAULT_FEATURE_ANGLE`].
    pub feature_angle: f64,
    /// Never remove corner points (more than two, or one, feature edges). Default
    /// `false`: corners are removed by their distance to the average plane, as in
    /// `vtkDecimate`.
    pub keep_corners: bool,
    /// Never remove boundary points. Default `false`.
    pub lock_boundary: bool,
    /// Order slack `S ≥ 1` (module docs, "Strategy"): a candidate whose exact key is
    /// at most `S ×` the next queued key is removed at once rather than queued again.
    /// `1` is the exact order (cheapest removal first). Default
    /// [`DEFAULT_ORDER_SLACK`]; values below 1 (or NaN) count as 1.
    pub order_slack: f64,
    /// Deferred re-keying (module docs, "Strategy"): `Some(p)` (`p ≥ 1`) leaves a
    /// loop point of a removal in the queue at its previous key divided by `p`, and
    /// evaluates its changed fan only when that entry comes out (`1`: the previous
    /// key). Inexact: a point whose key fell waits. `None` (default): every loop
    /// point is evaluated again at once, as the exact order needs.
    pub defer_neighbours: Option<f64>,
    /// With [`Self::defer_neighbours`]: defer only while the removed point's key is
    /// below this fraction of the bounding-box diagonal. At the first removal whose
    /// key reaches it, every point still waiting behind a deferred key is evaluated
    /// again, and the rest of the run is in the exact order (the coarse end, which
    /// sets the largest errors). `None` (default): defer for the whole run.
    pub defer_below: Option<f64>,
    /// With [`Self::defer_neighbours`]: bound a deferred loop point's changed fan at
    /// once (the cheap lower bound, not the plan) and queue it at the larger of that
    /// bound and its previous key divided by `p`, so a point whose bound rose is not
    /// taken early. Default `false`: the fan is not looked at until the entry comes
    /// out.
    pub defer_bound: bool,
    /// With [`Self::defer_neighbours`]: the order slack used while deferring (before
    /// the switch of [`Self::defer_below`]) instead of [`Self::order_slack`]; may be
    /// infinite (every planned candidate is removed when it comes out, in the order
    /// of its queued bound). `None` (default): [`Self::order_slack`] throughout.
    pub defer_slack: Option<f64>,
    /// When to stop.
    pub stop: StopRule,
}

impl Default for VertexRemovalOptions {
    fn default() -> Self {
        Self {
            feature_angle: DEFAULT_FEATURE_ANGLE,
            keep_corners: false,
            lock_boundary: false,
            order_slack: DEFAULT_ORDER_SLACK,
            defer_neighbours: None,
            defer_below: None,
            defer_bound: false,
            defer_slack: None,
            stop: StopRule::default(),
        }
    }
}

/// Where the fast order ([`VertexRemovalOptions::with_fast_order`]) becomes exact: a
/// removed point's key of this fraction of the bounding-box diagonal.
pub const FAST_ORDER_EXACT_FROM: f64 = 2e-3;

/// The order slack of the fast order while it defers
/// ([`VertexRemovalOptions::defer_slack`]).
pub const FAST_ORDER_SLACK: f64 = 1.2;

impl VertexRemovalOptions {
    /// The fast order (module docs, "Strategy"): deferred re-keying at the previous
    /// key (`defer_neighbours = Some(1)`), a planned candidate removed at once when
    /// its key is at most [`FAST_ORDER_SLACK`] times the next queued one
    /// (`defer_slack`), until a removal's key reaches [`FAST_ORDER_EXACT_FROM`] of
    /// the diagonal; the exact order from there on. The default of
    /// [`crate::simplify::SimplifyOptions`].
    #[must_use]
    pub fn with_fast_order(mut self) -> Self {
        self.order_slack = DEFAULT_ORDER_SLACK;
        self.defer_neighbours = Some(1.0);
        self.defer_below = Some(FAST_ORDER_EXACT_FROM);
        self.defer_bound = false;
        self.defer_slack = Some(FAST_ORDER_SLACK);
        self
    }

    /// The exact order: the cheapest removal first, every loop point evaluated again
    /// after each removal (this type's default).
    #[must_use]
    pub fn with_exact_order(mut self) -> Self {
        self.order_slack = DEFAULT_ORDER_SLACK;
        self.defer_neighbours = None;
        self.defer_below = None;
        self.defer_bound = false;
        self.defer_slack = None;
        self
    }
}

/// Schroeder's vertex classes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum VertexClass {
    /// One closed fan, no feature edge.
    Simple,
    /// Non-manifold, several fans, inconsistent orientation, too many triangles, or
    /// no triangle: never removed.
    Complex,
    /// One open fan (two boundary edges), no feature edge inside.
    Boundary,
    /// A closed fan with exactly two non-adjacent feature edges.
    InteriorEdge,
    /// Any other arrangement of feature edges.
    Corner,
}

/// Why a removal was refused (counted in [`Rejections`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Refusal {
    /// Complex, locked, kept corner or boundary.
    Kind,
    /// An attribute seam or material border the split cannot keep.
    Seam,
    /// No valid split of the loop.
    NoSplit,
    /// A new edge or triangle exists already.
    Duplicate,
    /// A new triangle would face away from the average plane.
    Flip,
    /// A (near) zero-area triangle or fan.
    Degenerate,
}

/// The class of a loop and how it must be split.
#[derive(Debug, Clone, Copy)]
struct Shape {
    class: VertexClass,
    /// The two feature spokes (loop indices) of a split.
    features: [usize; 2],
    /// Split along `features` first (the feature line survives as an edge).
    split: bool,
    /// A seam that no split can keep runs through the fan.
    seam_blocked: bool,
}

/// A new triangle: loop indices and their wedges, and the group.
#[derive(Debug, Clone, Copy, Default)]
struct NewTri {
    corner: [u8; 3],
    wedge: [u32; 3],
    group: u32,
}

/// One sub-polygon to triangulate: loop indices `first..=last` (cyclic), the normal
/// of its average plane.
#[derive(Debug, Clone, Copy)]
struct Region {
    first: usize,
    last: usize,
    normal: [f64; 3],
}

/// Scratch of one evaluation; after a successful [`VertexRemoval::evaluate`] it holds
/// the plan that [`VertexRemoval::apply`] performs.
#[derive(Debug, Default)]
struct Plan {
    /// Loop points `q_i`.
    q: Vec<u32>,
    /// The fan's triangles as read by `VertexRemoval::build_loop`: in fan order
    /// (`items`), and the wedges and groups in loop order (`ring[i]` is `tris[i]`).
    items: Vec<FanItem>,
    ring: Vec<RingItem>,
    /// The largest error bound of the fan's triangles (set by `build_loop`).
    ring_err: f64,
    /// `tris[i]` = triangle `(v, q_i, q_{i+1})`.
    tris: Vec<u32>,
    /// Whether the loop is closed.
    closed: bool,
    /// Wedge of `q_i` in `tris[i]` / in `tris[i-1]`.
    right: Vec<u32>,
    left: Vec<u32>,
    /// Positions of `q_i` (local f64) and twice-area normals of `tris[i]`.
    pos: Vec<[f64; 3]>,
    normal: Vec<[f64; 3]>,
    /// Squared lengths of `normal`.
    n2: Vec<f64>,
    /// Original area-weighted normals of `tris[i]` (see `VertexRemoval::origin`) and
    /// their sum.
    origin: Vec<[f64; 3]>,
    origin_sum: [f64; 3],
    /// `adj[i]` bit `j`: `q_i`–`q_j` is an edge of the mesh already (valid for the
    /// rows in `adj_done`).
    adj: Vec<u64>,
    adj_done: u64,
    /// The generation marking the loop points, and the removed point.
    gen: u32,
    v: u32,
    /// Work buffers of the splitting.
    uv: Vec<[f64; 2]>,
    w: Vec<[f64; 2]>,
    forbid: Vec<u64>,
    polys: Vec<u8>,
    stack: Vec<(u32, u32)>,
    diagonals: Vec<[u8; 2]>,
    /// The result.
    out: Vec<NewTri>,
    class: Option<VertexClass>,
    cost: f64,
    /// The step's own distance `δ`.
    delta: f64,
    /// The loop-level edge check of the plan (see `VertexRemoval::check_loop`).
    loop_check: LoopCheck,
    /// Left by `VertexRemoval::evaluate_bound` for `VertexRemoval::evaluate_plan`:
    /// the loop's shape, the unit average normal and the largest bound of the fan.
    shape: Option<Shape>,
    n_avg: [f64; 3],
    e_fan: f64,
    /// Bit `i`: new triangle `out[i]` faces away from the input (set by
    /// `VertexRemoval::more_facing_away`).
    away: u64,
}

/// One triangle `(v, a, b)` of the fan of `v`, read once from its record.
#[derive(Debug, Clone, Copy, Default)]
struct FanItem {
    a: u32,
    b: u32,
    t: u32,
    /// Wedges of `v`, `a` and `b` in the triangle.
    wedge: [u32; 3],
    group: u32,
    err: f64,
    /// Fan index of the triangle whose edge starts at `b` (`u8::MAX`: none).
    next: u8,
}

/// What the classification reads of a fan triangle, in loop order.
#[derive(Debug, Clone, Copy, Default)]
struct RingItem {
    /// Wedges of `v`, `a` and `b` in the triangle.
    wedge: [u32; 3],
    group: u32,
}

/// One point's record.
#[derive(Debug, Clone, Copy, Default)]
struct Pt {
    /// Position (local frame of the surface).
    pos: [f64; 3],
    /// The fan: `fans[start..start + len]`, room for `cap`.
    start: u32,
    len: u32,
    cap: u32,
    /// Bumped whenever the fan changes (lazy queue invalidation).
    version: u32,
    /// Never removed.
    locked: bool,
}

/// A point's generation mark and loop slot in the current evaluation (kept apart
/// from [`Pt`], so the edge lookups over a loop's second ring touch 8 bytes a point).
#[derive(Debug, Clone, Copy, Default)]
struct Mark {
    gen: u32,
    slot: u8,
}

/// One triangle's record.
#[derive(Debug, Clone, Copy)]
#[repr(align(64))]
struct Tri {
    /// Points (`[DEAD; 3]` once removed).
    p: [u32; 3],
    /// Wedges (input vertices) of the corners.
    wedge: [u32; 3],
    /// Group (material), 0 without groups.
    group: u32,
    /// Error bound `e` (module docs).
    err: f64,
    /// The sum of twice-area normals of the input triangles it stands for (a removal
    /// shares its fan's sum among the new triangles).
    origin: [f64; 3],
}

/// How much of a removal [`VertexRemoval::evaluate`] works out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// Classification and the Schroeder distance only: lower bounds of the key.
    Cheap,
    /// The whole plan and its exact key, but without the checks against existing
    /// edges (done by [`VertexRemoval::deferred_checks_pass`] when the plan is used).
    Geometry,
    /// The whole plan with every check.
    Full,
}

/// A plan kept with a queued exact key: it stays valid while the point's version
/// (its fan) is unchanged, since a plan is a function of the fan's triangles alone.
/// The new triangles and the diagonals live in `VertexRemoval::kept_tris` and
/// `VertexRemoval::kept_diagonals`.
#[derive(Debug, Clone, Copy, Default)]
struct KeptPlan {
    valid: bool,
    version: u32,
    tris_at: u32,
    diagonals_at: u32,
    tris: u8,
    diagonals: u8,
    loop_check: LoopCheck,
    cost: f64,
    delta: f64,
}

/// The loop-level check of a plan that needs the mesh's edges.
#[derive(Debug, Clone, Copy, Default)]
enum LoopCheck {
    /// None.
    #[default]
    None,
    /// Loop points `i` and `j` must not share an edge (boundary or feature line).
    Edge(usize, usize),
    /// The valence-3 triangle must not exist already.
    Valence3,
}

/// Read-only connectivity for the lazy edge lookups of a [`Plan`].
struct Links<'a> {
    tri: &'a [Tri],
    fans: &'a [u32],
    pt: &'a [Pt],
    marks: &'a [Mark],
}

impl Plan {
    /// Whether loop points `i` and `j` share an edge of the mesh (rows computed on
    /// first use from the fan of `q_i`).
    fn adjacent(&mut self, l: &Links<'_>, i: usize, j: usize) -> bool {
        if self.adj_done & (1u64 << i) == 0 {
            let q = self.q[i];
            let s = l.pt[q as usize].start as usize;
            let mut bits = 0u64;
            for &t in &l.fans[s..s + l.pt[q as usize].len as usize] {
                for &x in &l.tri[t as usize].p {
                    let mk = l.marks[x as usize];
                    if x != q && x != self.v && mk.gen == self.gen {
                        bits |= 1u64 << mk.slot;
                    }
                }
            }
            self.adj[i] = bits;
            self.adj_done |= 1u64 << i;
        }
        self.adj[i] & (1u64 << j) != 0
    }
}

/// The vertex-removal decimator over one welded surface.
///
/// Build it from a repaired [`Surface`] (only its triangles, wedges, groups, positions
/// and lock marks are read), [`run`](Self::run) it, and take the surviving triangles
/// with [`output_triangles`](Self::output_triangles).
#[derive(Debug)]
pub struct VertexRemoval {
    /// Per triangle: points, wedges, group, error bound and origin normal, in one
    /// cache line (an evaluation reads all of them for every triangle of a fan).
    tri: Vec<Tri>,
    /// Whether the input had groups (materials).
    has_groups: bool,
    /// Per point: position, fan slice, version.
    pt: Vec<Pt>,
    /// Per point: the marks of the current evaluation.
    marks: Vec<Mark>,
    fans: Vec<u32>,
    fan_garbage: usize,
    live: usize,
    options: VertexRemovalOptions,
    cos_feature: f64,
    height_eps: f64,
    plan: Plan,
    gen: u32,
    rejections: Rejections,
    /// Queue key: the accumulated bound (with a maximum error) or the step's `δ`.
    order_by_bound: bool,
    /// Per point: the plan behind its queued exact key (see [`KeptPlan`]), and the
    /// arenas of those plans' triangles and diagonals.
    kept: Vec<KeptPlan>,
    kept_tris: Vec<NewTri>,
    kept_diagonals: Vec<[u8; 2]>,
    /// The input surface for the facing test (points and twice-area normals of the
    /// input triangles; the tree is built on first use), per triangle slot whether
    /// its live triangle faces away from the input, the accumulated bound from which
    /// removals are tested, and the key added per extra triangle facing away.
    input_tri: Vec<[u32; 3]>,
    input_normal: Vec<[f64; 3]>,
    input_tree: Option<Bvh>,
    away: Vec<bool>,
    facing_from: f64,
    facing_tier: f64,
    /// The bounding-box diagonal (for [`VertexRemovalOptions::defer_below`]).
    diagonal: f64,
    /// Per point: whether its queue entry is a deferred one (`b = 3`, deferred
    /// re-keying), so the switch to the exact order can evaluate it.
    waiting: Vec<bool>,
    /// Per point: the key bits it was last queued with (0 when refused; the plain
    /// key for a removal queued behind the facing tier), for deferred re-keying.
    queued: Vec<u32>,
}

/// What an evaluation's first part ([`Eval::evaluate_bound`]) reads: the mesh and
/// the options. Only borrowed, so the workers of the parallel initial pass share one.
#[derive(Clone, Copy)]
struct View<'a> {
    tri: &'a [Tri],
    pt: &'a [Pt],
    fans: &'a [u32],
    cos_feature: f64,
    height_eps: f64,
    keep_corners: bool,
    lock_boundary: bool,
}

/// An evaluation's first part: the mesh it reads ([`View`]) and what it writes, the
/// plan and the point marks with their generation (the decimator's own, or a worker's
/// of the parallel initial pass).
struct Eval<'a> {
    m: View<'a>,
    plan: &'a mut Plan,
    marks: &'a mut [Mark],
    gen: &'a mut u32,
}

impl Eval<'_> {
    fn next_gen(&mut self) -> u32 {
        *self.gen = self.gen.wrapping_add(1);
        if *self.gen == 0 {
            for mk in self.marks.iter_mut() {
                mk.gen = 0;
            }
            *self.gen = 1;
        }
        *self.gen
    }

    /// Fills `plan.q`, `plan.tris`, `plan.ring`, `plan.closed` from the fan of `v`,
    /// and marks the loop points (generation `plan.gen`, slot = loop index).
    ///
    /// Each triangle's record is read once. The fan edge `a → b` of each triangle
    /// (`(v, a, b)` in its orientation) is linked to the triangle whose edge starts
    /// at `b` through the marks of the `a` points, so the walk is linear in the
    /// valence. Refused as complex: a point twice as a start or twice as an end of a
    /// fan edge, more than one open end, several fans, `v` in its own loop.
    fn build_loop(&mut self, v: u32) -> Result<(), Refusal> {
        const NEXT: [usize; 3] = [1, 2, 0];
        const PREV: [usize; 3] = [2, 0, 1];
        let fan_len = self.m.pt[v as usize].len as usize;
        if fan_len == 0 || fan_len > MAX_VALENCE {
            return Err(Refusal::Kind);
        }
        let g = self.next_gen();
        let s = self.m.pt[v as usize].start as usize;
        let plan = &mut *self.plan;
        plan.items.clear();
        for (i, &t) in self.m.fans[s..s + fan_len].iter().enumerate() {
            let tt = &self.m.tri[t as usize];
            let k = if tt.p[0] == v {
                0
            } else if tt.p[1] == v {
                1
            } else {
                2
            };
            let (ka, kb) = (NEXT[k], PREV[k]);
            let a = tt.p[ka];
            let pa = &mut self.marks[a as usize];
            if pa.gen == g {
                return Err(Refusal::Kind);
            }
            pa.gen = g;
            pa.slot = i as u8;
            plan.items.push(FanItem {
                a,
                b: tt.p[kb],
                t,
                wedge: [tt.wedge[k], tt.wedge[ka], tt.wedge[kb]],
                group: tt.group,
                err: tt.err,
                next: u8::MAX,
            });
        }
        // Link each edge to its successor; no point may end two edges.
        let mut has_pred = 0u64;
        for i in 0..fan_len {
            let b = plan.items[i].b;
            let pb = &self.marks[b as usize];
            if pb.gen == g {
                let n = pb.slot;
                if has_pred & (1u64 << n) != 0 {
                    return Err(Refusal::Kind);
                }
                has_pred |= 1u64 << n;
                plan.items[i].next = n;
            }
        }
        let starts = fan_len - has_pred.count_ones() as usize;
        if starts > 1 {
            return Err(Refusal::Kind);
        }
        let first = if starts == 1 {
            (!has_pred).trailing_zeros() as usize
        } else {
            0
        };
        plan.q.clear();
        plan.tris.clear();
        plan.ring.clear();
        plan.closed = starts == 0;
        let mut e_fan: f64 = 0.0;
        let mut cur = first;
        loop {
            let it = &plan.items[cur];
            // The marks' slots become loop indices (for `Plan::adjacent`).
            if it.a == v {
                return Err(Refusal::Kind);
            }
            self.marks[it.a as usize].slot = plan.q.len() as u8;
            plan.q.push(it.a);
            plan.tris.push(it.t);
            plan.ring.push(RingItem {
                wedge: it.wedge,
                group: it.group,
            });
            e_fan = e_fan.max(it.err);
            match it.next {
                u8::MAX => {
                    plan.q.push(it.b);
                    break;
                }
                n if usize::from(n) == first => break,
                n => {
                    if plan.tris.len() >= fan_len {
                        return Err(Refusal::Kind);
                    }
                    cur = usize::from(n);
                }
            }
        }
        if plan.tris.len() != fan_len {
            // several fans around v
            return Err(Refusal::Kind);
        }
        // Every start point is a distinct loop point (marked above); the open end is
        // the one point not marked yet.
        if !plan.closed {
            let end = *plan.q.last().unwrap_or(&v);
            let pe = &mut self.marks[end as usize];
            if end == v || pe.gen == g {
                return Err(Refusal::Kind);
            }
            pe.gen = g;
            pe.slot = (plan.q.len() - 1) as u8;
        }
        plan.ring_err = e_fan;
        plan.gen = g;
        plan.v = v;
        Ok(())
    }

    /// Classifies the loop in `plan` and returns the class with the feature spokes
    /// (loop indices) of an interior edge; fills wedges, positions and normals.
    fn classify_loop(&mut self, v: u32) -> Shape {
        let plan = &mut *self.plan;
        let m = plan.q.len();
        let nt = plan.tris.len();
        let pv = self.m.pt[v as usize].pos;
        plan.pos.clear();
        let pt = self.m.pt;
        plan.pos
            .extend(plan.q.iter().map(|&q| sub(pt[q as usize].pos, pv)));
        plan.normal.clear();
        plan.right.clear();
        plan.left.clear();
        {
            let pos = &plan.pos;
            plan.normal
                .extend(pos.windows(2).map(|w| cross(w[0], w[1])));
            if plan.closed {
                plan.normal.push(cross(pos[m - 1], pos[0]));
            }
        }
        plan.n2.clear();
        plan.n2.extend(plan.normal.iter().map(|&n| dot(n, n)));
        for i in 0..m {
            let r = if i < nt { plan.ring[i].wedge[1] } else { DEAD };
            let l = if i > 0 {
                plan.ring[i - 1].wedge[2]
            } else if plan.closed {
                plan.ring[nt - 1].wedge[2]
            } else {
                DEAD
            };
            plan.right.push(if r == DEAD { l } else { r });
            plan.left.push(if l == DEAD { r } else { l });
        }
        // Features on interior spokes.
        let mut seams = [0usize; 2];
        let mut creases = [0usize; 2];
        let (mut ns, mut nc) = (0, 0);
        let (lo, hi) = if plan.closed { (0, m) } else { (1, m - 1) };
        for i in lo..hi {
            let i0 = if i == 0 { nt - 1 } else { i - 1 };
            let (f0, f1) = (&plan.ring[i0], &plan.ring[i]);
            let is_seam =
                plan.left[i] != plan.right[i] || f0.wedge[0] != f1.wedge[0] || f0.group != f1.group;
            if is_seam {
                if ns < 2 {
                    seams[ns] = i;
                }
                ns += 1;
            } else if is_crease(
                plan.normal[i0],
                plan.normal[i],
                plan.n2[i0] * plan.n2[i],
                self.m.cos_feature,
            ) {
                if nc < 2 {
                    creases[nc] = i;
                }
                nc += 1;
            }
        }
        let apart = |f: [usize; 2]| {
            let d = f[1] - f[0];
            d != 1 && d != m - 1
        };
        let mut shape = Shape {
            class: VertexClass::Corner,
            features: [0; 2],
            split: false,
            seam_blocked: false,
        };
        if !plan.closed {
            shape.seam_blocked = ns > 0;
            shape.class = if nc == 0 {
                VertexClass::Boundary
            } else {
                VertexClass::Corner
            };
        } else if ns == 0 {
            if nc == 0 {
                shape.class = VertexClass::Simple;
            } else if nc == 2 && apart(creases) {
                shape.class = VertexClass::InteriorEdge;
                shape.features = creases;
                shape.split = true;
            }
        } else if ns == 2 && apart(seams) {
            // The seam (or material border) is the feature line; other creases make
            // it a corner that is still split along the seam.
            shape.class = if nc == 0 {
                VertexClass::InteriorEdge
            } else {
                VertexClass::Corner
            };
            shape.features = seams;
            shape.split = true;
        } else {
            shape.seam_blocked = true;
        }
        shape
    }

    /// The first part of [`VertexRemoval::evaluate`]: classification, average plane and the
    /// lower bounds of the key (`plan.cost`, `plan.delta`); what the second part,
    /// [`VertexRemoval::evaluate_plan`], needs is left in `plan`.
    fn evaluate_bound(&mut self, v: u32) -> Result<(), Refusal> {
        self.plan.shape = None;
        self.plan.loop_check = LoopCheck::None;
        if self.m.pt[v as usize].locked {
            return Err(Refusal::Kind);
        }
        self.build_loop(v)?;
        let shape = self.classify_loop(v);
        let (class, features) = (shape.class, shape.features);
        self.plan.class = Some(class);
        let open = !self.plan.closed;
        if shape.seam_blocked {
            return Err(Refusal::Seam);
        }
        if class == VertexClass::Corner && self.m.keep_corners {
            return Err(Refusal::Kind);
        }
        if open && self.m.lock_boundary {
            return Err(Refusal::Kind);
        }
        let m = self.plan.q.len();
        let nt = self.plan.tris.len();
        // Existing edges between loop points, found lazily (`Plan::adjacent`, with
        // the marks of `build_loop`).
        self.plan.adj.clear();
        self.plan.adj.resize(m, 0);
        self.plan.adj_done = 0;
        // Average plane.
        let mut area_n = [0.0; 3];
        let mut area_sum = 0.0;
        let mut base = [0.0; 3];
        for i in 0..nt {
            let n = self.plan.normal[i];
            let a = self.plan.n2[i].sqrt();
            area_n = add(area_n, n);
            area_sum += a;
            let j = if i + 1 == m { 0 } else { i + 1 };
            let c = scale(add(self.plan.pos[i], self.plan.pos[j]), 1.0 / 3.0);
            base = add(base, scale(c, a));
        }
        // Degenerate when the fan's triangles are, on average, no taller over their
        // loop edges than `ε·diag` (twice their area over the farthest loop point's
        // distance): their normals are then not set by the stored points.
        let r2_max = self.plan.pos.iter().fold(0.0f64, |r, p| r.max(dot(*p, *p)));
        if area_sum <= self.m.height_eps * r2_max.sqrt() * nt as f64 {
            return Err(Refusal::Degenerate);
        }
        let ln = norm(area_n);
        if ln <= 1e-9 * area_sum {
            return Err(Refusal::Flip);
        }
        let n_avg = scale(area_n, 1.0 / ln);
        base = scale(base, 1.0 / area_sum);
        // v sits at the origin of plan.pos.
        let to_line =
            |i: usize, j: usize| line_distance([0.0; 3], self.plan.pos[i], self.plan.pos[j]);
        let schroeder = if open {
            to_line(0, m - 1)
        } else if class == VertexClass::InteriorEdge {
            to_line(features[0], features[1])
        } else if shape.split {
            dot(base, n_avg)
                .abs()
                .max(to_line(features[0], features[1]))
        } else {
            dot(base, n_avg).abs()
        };
        // Every new triangle spans loop points, so when all loop points lie on one
        // side of `v` along `n_avg` the new patch lies in that slab and `v` is at least
        // the nearest loop point's height from it: a lower bound of every gap below,
        // and a much tighter one than the average plane on a curved surface.
        let (mut h_min, mut h_max) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in &self.plan.pos {
            let h = dot(*p, n_avg);
            h_min = h_min.min(h);
            h_max = h_max.max(h);
        }
        let slab = if h_min > 0.0 {
            h_min
        } else if h_max < 0.0 {
            -h_max
        } else {
            0.0
        };
        let schroeder = schroeder.max(slab);
        let e_fan = self.plan.ring_err;
        self.plan.cost = e_fan + schroeder;
        self.plan.delta = schroeder;
        self.plan.shape = Some(shape);
        self.plan.n_avg = n_avg;
        self.plan.e_fan = e_fan;
        Ok(())
    }
}

/// The queue key of an evaluated plan: the accumulated bound with a maximum error,
/// else the step's `δ`.
fn plan_key(plan: &Plan, order_by_bound: bool) -> f64 {
    if order_by_bound {
        plan.cost
    } else {
        plan.delta
    }
}

/// How [`VertexRemoval::run`] orders the removals: the slack, and the deferred
/// re-keying of a removal's neighbours up to the switch key.
#[derive(Debug, Clone, Copy)]
struct RunOrder {
    /// The largest error a removal may have (infinite without a bound).
    max_error: f64,
    /// The order slack (1: the exact cheapest-first order).
    base_slack: f64,
    /// Deferred re-keying: a neighbour's previous key is divided by this; `None`
    /// when not deferring (or no longer).
    defer: Option<f64>,
    /// Deferral stops (for good) at the first removal whose key reaches this.
    defer_until: f64,
    /// Bound a deferred neighbour's changed fan at once.
    defer_bound: bool,
    /// The slack while deferring.
    slack: f64,
}

impl RunOrder {
    /// The slack for a removal of key `key`: the deferring slack below the switch
    /// key, the order slack from there on.
    fn slack_at(&self, key: f64) -> f64 {
        if key < self.defer_until {
            self.slack
        } else {
            self.base_slack
        }
    }
}

/// Why [`VertexRemoval::run`] left its loop early.
#[derive(Debug, Clone, Copy, Default)]
struct RunStop {
    /// Only removals that turn more triangles away from the input were left.
    facing: bool,
    /// The cheapest bound exceeded the maximum error.
    over_error: bool,
}

/// The queue key bits of `slack ×` the key with bits `bits` (`bits` itself when
/// `slack` is 1).
fn slack_bits(bits: u32, slack: f64) -> u32 {
    if slack == 1.0 {
        return bits;
    }
    Item::default()
        .with_cost(f64::from(f32::from_bits(bits)) * slack)
        .cost_bits
}

/// Whether two triangles with (unnormalised) normals `n0` and `n1` meet at a
/// dihedral angle whose cosine is below `cos_feature`; `n2` is
/// `dot(n0, n0) * dot(n1, n1)`.
#[inline]
fn is_crease(n0: [f64; 3], n1: [f64; 3], n2: f64, cos_feature: f64) -> bool {
    dot(n0, n1) < cos_feature * n2.sqrt()
}

#[inline]
fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline]
fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

#[inline]
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Distance from `p` to the line through `a` and `b` (to `a` when they coincide).
fn line_distance(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = sub(b, a);
    let l = norm(d);
    if l == 0.0 {
        return norm(sub(p, a));
    }
    norm(cross(d, sub(p, a))) / l
}

/// Distance from `p` to the segment `ab`.
fn segment_distance(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = sub(b, a);
    let l2 = dot(d, d);
    let t = if l2 > 0.0 {
        (dot(sub(p, a), d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    norm(sub(p, add(a, scale(d, t))))
}

/// Two unit vectors completing `n` (unit) to an orthonormal frame.
fn frame(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let a = if n[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let e1 = cross(n, a);
    let e1 = scale(e1, 1.0 / norm(e1));
    (e1, cross(n, e1))
}

impl VertexRemoval {
    /// Takes the live triangles, wedges, groups and positions of `surface`; points the
    /// surface marks [`VertexKind::Locked`] are never removed.
    #[must_use]
    pub fn new(surface: &Surface, options: VertexRemovalOptions) -> Self {
        let (wedge, tri, group) = surface.output_triangles();
        let np = surface.point_count();
        let pt: Vec<Pt> = (0..np as u32)
            .map(|p| Pt {
                pos: surface.local(p),
                locked: surface.kind(p) == VertexKind::Locked,
                ..Pt::default()
            })
            .collect();
        // A height (length) at or below which a triangle or a hole is degenerate:
        // `ε·diag`, the spacing of `f32` coordinates over the box, the same relative
        // size at any scale and for triangles of any size (as the collapse
        // operator's test).
        let eps = f64::from(f32::EPSILON) * surface.diagonal();
        let has_groups = group.is_some();
        let tri: Vec<Tri> = tri
            .iter()
            .zip(&wedge)
            .enumerate()
            .map(|(i, (&p, &w))| {
                let [a, b, c] = p.map(|x| pt[x as usize].pos);
                Tri {
                    p,
                    wedge: w,
                    group: group.as_ref().map_or(0, |g| g[i]),
                    err: 0.0,
                    origin: cross(sub(b, a), sub(c, a)),
                }
            })
            .collect();
        let input_tri = tri.iter().map(|t| t.p).collect();
        let input_normal = tri.iter().map(|t| t.origin).collect();
        let mut s = Self {
            input_tri,
            input_normal,
            input_tree: None,
            away: vec![false; tri.len()],
            // Above every plain key (a distance within the model, or a sum of a few).
            facing_tier: 16.0 * surface.diagonal() + 1.0,
            facing_from: FACING_FROM * surface.diagonal(),
            diagonal: surface.diagonal(),
            waiting: Vec::new(),
            queued: vec![0; np],
            pt,
            live: tri.len(),
            tri,
            has_groups,
            fans: Vec::new(),
            fan_garbage: 0,
            cos_feature: options.feature_angle.clamp(0.0, 180.0).to_radians().cos(),
            options,
            height_eps: eps,
            plan: Plan::default(),
            gen: 0,
            rejections: Rejections::default(),
            order_by_bound: options.stop.max_error.is_some(),
            kept: vec![KeptPlan::default(); np],
            marks: vec![Mark::default(); np],
            kept_tris: Vec::new(),
            kept_diagonals: Vec::new(),
        };
        s.build_fans();
        s
    }

    fn build_fans(&mut self) {
        let csr = FanCsr::build(self.pt.len(), &self.tri, |t| {
            (t.p[0] != DEAD).then_some(t.p)
        });
        for (p, pt) in self.pt.iter_mut().enumerate() {
            pt.start = csr.start[p];
            pt.len = csr.len[p];
            pt.cap = csr.cap[p];
        }
        self.fans = csr.fans;
        self.fan_garbage = 0;
    }

    /// Number of live triangles.
    #[must_use]
    pub fn live_triangles(&self) -> usize {
        self.live
    }

    /// The triangles around point `p`.
    fn fan(&self, p: u32) -> &[u32] {
        let s = self.pt[p as usize].start as usize;
        &self.fans[s..s + self.pt[p as usize].len as usize]
    }

    fn fan_push(&mut self, p: u32, t: u32) {
        let pi = p as usize;
        if self.pt[pi].len == self.pt[pi].cap {
            let cap = (self.pt[pi].cap * 2).max(4);
            let s = self.pt[pi].start as usize;
            let l = self.pt[pi].len as usize;
            let new_start = self.fans.len();
            self.fans.extend_from_within(s..s + l);
            self.fans.resize(new_start + cap as usize, DEAD);
            self.fan_garbage += self.pt[pi].cap as usize;
            self.pt[pi].start = new_start as u32;
            self.pt[pi].cap = cap;
        }
        let at = (self.pt[pi].start + self.pt[pi].len) as usize;
        self.fans[at] = t;
        self.pt[pi].len += 1;
    }

    /// Drops dead triangles from the fan of `p`.
    fn fan_prune(&mut self, p: u32) {
        let pi = p as usize;
        let s = self.pt[pi].start as usize;
        let l = self.pt[pi].len as usize;
        let mut w = s;
        for r in s..s + l {
            let t = self.fans[r];
            if self.tri[t as usize].p[0] != DEAD {
                self.fans[w] = t;
                w += 1;
            }
        }
        self.pt[pi].len = (w - s) as u32;
    }

    /// The evaluation state: the mesh read, the plan and marks written.
    fn eval(&mut self) -> Eval<'_> {
        Eval {
            m: View {
                tri: &self.tri,
                pt: &self.pt,
                fans: &self.fans,
                cos_feature: self.cos_feature,
                height_eps: self.height_eps,
                keep_corners: self.options.keep_corners,
                lock_boundary: self.options.lock_boundary,
            },
            plan: &mut self.plan,
            marks: &mut self.marks,
            gen: &mut self.gen,
        }
    }

    /// The class of point `p` in the current mesh (Schroeder's five classes).
    pub fn classify(&mut self, p: u32) -> VertexClass {
        let mut e = self.eval();
        match e.build_loop(p) {
            Ok(()) => e.classify_loop(p).class,
            Err(_) => VertexClass::Complex,
        }
    }

    /// [`Eval::build_loop`] on the current mesh.
    fn build_loop(&mut self, v: u32) -> Result<(), Refusal> {
        self.eval().build_loop(v)
    }

    /// Evaluates removing `v`: on success `plan` holds the new triangles and the cost.
    /// Without `full`, stops after the classification and the Schroeder distance:
    /// `plan.delta` and `plan.cost` are then lower bounds of the full values (`δ`
    /// includes the Schroeder distance), and no triangles are planned.
    fn evaluate(&mut self, v: u32, mode: Mode) -> Result<(), Refusal> {
        self.evaluate_bound(v)?;
        if mode == Mode::Cheap {
            return Ok(());
        }
        self.evaluate_plan(mode == Mode::Full)
    }

    /// [`Eval::evaluate_bound`] on the current mesh.
    fn evaluate_bound(&mut self, v: u32) -> Result<(), Refusal> {
        self.eval().evaluate_bound(v)
    }

    /// The second part of [`Self::evaluate`], after a successful
    /// [`Self::evaluate_bound`]: the triangulation and the exact key, with the checks
    /// against existing edges when `checks`.
    fn evaluate_plan(&mut self, checks: bool) -> Result<(), Refusal> {
        let Some(shape) = self.plan.shape else {
            return Err(Refusal::Kind);
        };
        let features = shape.features;
        let open = !self.plan.closed;
        let m = self.plan.q.len();
        let n_avg = self.plan.n_avg;
        let e_fan = self.plan.e_fan;
        let schroeder = self.plan.delta;
        let group_of = |s: &Self, t: u32| s.tri[t as usize].group;
        self.plan.origin.clear();
        self.plan.origin_sum = [0.0; 3];
        for &t in &self.plan.tris {
            let o = self.tri[t as usize].origin;
            self.plan.origin.push(o);
            self.plan.origin_sum = add(self.plan.origin_sum, o);
        }
        self.plan.out.clear();
        self.plan.diagonals.clear();
        let mut delta = schroeder;
        if open && m == 2 {
            // A lone corner triangle of a boundary: removed when its opposite edge
            // has exactly one other triangle (which then carries the boundary).
            let (a, b) = (self.plan.q[0], self.plan.q[1]);
            let on_edge = self
                .fan(a)
                .iter()
                .filter(|&&t| self.tri[t as usize].p.contains(&b))
                .count();
            if on_edge != 2 {
                return Err(Refusal::Duplicate);
            }
            delta = delta.max(segment_distance(
                [0.0; 3],
                self.plan.pos[0],
                self.plan.pos[1],
            ));
        } else {
            let mut regions = [Region {
                first: 0,
                last: m - 1,
                normal: n_avg,
            }; 2];
            let mut nr = 1;
            if open {
                self.plan.loop_check = LoopCheck::Edge(0, m - 1);
            } else if shape.split {
                let (i0, j0) = (features[0], features[1]);
                self.plan.loop_check = LoopCheck::Edge(i0, j0);
                let half = |from: usize, to: usize| -> [f64; 3] {
                    let mut n = [0.0; 3];
                    let mut i = from;
                    while i != to {
                        n = add(n, self.plan.normal[i]);
                        i = if i + 1 == m { 0 } else { i + 1 };
                    }
                    n
                };
                let na = half(i0, j0);
                let nb = half(j0, i0);
                let (la, lb) = (norm(na), norm(nb));
                if la <= 0.0 || lb <= 0.0 {
                    return Err(Refusal::Degenerate);
                }
                regions = [
                    Region {
                        first: i0,
                        last: j0,
                        normal: scale(na, 1.0 / la),
                    },
                    Region {
                        first: j0,
                        last: i0,
                        normal: scale(nb, 1.0 / lb),
                    },
                ];
                nr = 2;
            } else if m == 3 {
                self.plan.loop_check = LoopCheck::Valence3;
            }
            if checks {
                self.check_loop()?;
            }
            let closed_whole = !open && !shape.split;
            for r in &regions[..nr] {
                let group = group_of(self, self.plan.tris[r.first]);
                let before = self.plan.out.len();
                let d0 = self.plan.diagonals.len();
                self.split_region(r, group, checks)?;
                delta = delta.max(self.region_gap(r, before, d0, closed_whole));
            }
            if closed_whole && !self.fan_is_height_field(n_avg) {
                return Err(Refusal::Flip);
            }
        }
        self.plan.cost = e_fan + delta;
        self.plan.delta = delta;
        Ok(())
    }

    /// Triangulates region `r` of the loop by recursive splitting, appending to
    /// `plan.out` and `plan.diagonals`.
    fn split_region(&mut self, r: &Region, group: u32, checks: bool) -> Result<(), Refusal> {
        let links = Links {
            tri: &self.tri,
            fans: &self.fans,
            pt: &self.pt,
            marks: &self.marks,
        };
        let plan = &mut self.plan;
        let m = plan.q.len();
        if plan.polys.len() < POLYS_CAP {
            plan.polys.resize(POLYS_CAP, 0);
        }
        plan.stack.clear();
        let mut i = r.first;
        let mut k = 0;
        loop {
            plan.polys[k] = i as u8;
            k += 1;
            if i == r.last {
                break;
            }
            i = if i + 1 == m { 0 } else { i + 1 };
        }
        plan.stack.push((0, k as u32));
        let n = r.normal;
        // The split-plane tests in the frame of the region's plane: for a line
        // direction `d` the split plane's normal is `d × n`, and `(p − a)·(d × n)` is
        // the 2D cross product of the projections of `p − a` and `d`.
        let (e1, e2) = frame(n);
        let mut uv = std::mem::take(&mut plan.uv);
        uv.clear();
        uv.extend(plan.pos.iter().map(|p| [dot(*p, e1), dot(*p, e2)]));
        let mut w_all = std::mem::take(&mut plan.w);
        w_all.clear();
        w_all.resize(m, [0.0; 2]);
        let mut forbid = std::mem::take(&mut plan.forbid);
        forbid.clear();
        forbid.resize(m, 0);
        let result = Self::split_loop(
            plan,
            &links,
            r,
            group,
            checks,
            self.height_eps,
            &uv,
            &mut w_all,
            &mut forbid,
        );
        plan.uv = uv;
        plan.w = w_all;
        plan.forbid = forbid;
        result
    }

    /// The loop of [`Self::split_region`] (its buffers passed in).
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn split_loop(
        plan: &mut Plan,
        links: &Links<'_>,
        r: &Region,
        group: u32,
        checks: bool,
        height_eps: f64,
        uv: &[[f64; 2]],
        w_all: &mut [[f64; 2]],
        forbid: &mut [u64],
    ) -> Result<(), Refusal> {
        // Sub-polygons are copied `POLY_SPAN` bytes at a time (fixed-size copies,
        // no library calls); `polys` has room for that past its used length `used`.
        let mut buf = [0u8; 2 * POLY_SPAN];
        let mut used = plan.stack.last().map_or(0, |&(o, l)| (o + l) as usize);
        while let Some((off, len)) = plan.stack.pop() {
            let (off, len) = (off as usize, len as usize);
            buf[..POLY_SPAN].copy_from_slice(&plan.polys[off..off + POLY_SPAN]);
            let poly = &buf[..len];
            if len < 3 {
                continue;
            }
            if len == 3 {
                Self::push_triangle(plan, r, group, height_eps, [poly[0], poly[1], poly[2]])?;
                continue;
            }
            // Best split line; existing edges are checked for the winner only (and
            // the search repeated without it when it is one).
            forbid[..len].fill(0);
            for (k, &pk) in poly.iter().enumerate() {
                w_all[k] = uv[pk as usize];
            }
            let w = &w_all[..len];
            let best = loop {
                let best = Self::best_split(plan, poly, w, forbid);
                match best {
                    Some((_, i, j))
                        if checks && plan.adjacent(links, poly[i] as usize, poly[j] as usize) =>
                    {
                        forbid[i] |= 1u64 << j;
                    }
                    _ => break best,
                }
            };
            let Some((_, i, j)) = best else {
                return Err(Refusal::NoSplit);
            };
            plan.diagonals.push([poly[i], poly[j]]);
            // `poly[i..=j]`, then `poly[j..]` followed by `poly[..=i]`.
            let o1 = used;
            plan.polys[o1..o1 + POLY_SPAN].copy_from_slice(&buf[i..i + POLY_SPAN]);
            used += j - i + 1;
            plan.stack.push((o1 as u32, (j - i + 1) as u32));
            let o2 = used;
            plan.polys[o2..o2 + POLY_SPAN].copy_from_slice(&buf[j..j + POLY_SPAN]);
            let o3 = o2 + len - j;
            plan.polys[o3..o3 + POLY_SPAN].copy_from_slice(&buf[..POLY_SPAN]);
            used += len - j + i + 1;
            plan.stack.push((o2 as u32, (len - j + i + 1) as u32));
        }
        Ok(())
    }

    /// A sub-polygon of three loop points `c` (region `r`, group `group`) becomes a
    /// new triangle, unless it is degenerate (its smallest height at or below
    /// `height_eps`) or flips against the region's normal or the input surface.
    #[inline]
    fn push_triangle(
        plan: &mut Plan,
        r: &Region,
        group: u32,
        height_eps: f64,
        c: [u8; 3],
    ) -> Result<(), Refusal> {
        let m = plan.q.len();
        let n = r.normal;
        let [a, b, cc] = c.map(|k| plan.pos[k as usize]);
        let tn = cross(sub(b, a), sub(cc, a));
        let l2 = dot(tn, tn);
        // The smallest height, `|tn|` over the longest edge, at or below
        // `height_eps` (compared squared).
        let e2 = dot(sub(b, a), sub(b, a))
            .max(dot(sub(cc, a), sub(cc, a)))
            .max(dot(sub(cc, b), sub(cc, b)));
        if l2 <= height_eps * height_eps * e2 {
            return Err(Refusal::Degenerate);
        }
        if dot(tn, n) <= 1e-6 * l2.sqrt() {
            return Err(Refusal::Flip);
        }
        // No flip against the input surface: the new triangle faces the side
        // of the input triangles the fan stands for, and of those the old
        // triangle on each shared loop edge stands for.
        if dot(tn, plan.origin_sum) <= 0.0 {
            return Err(Refusal::Flip);
        }
        for e in 0..3 {
            let (x, y) = (c[e] as usize, c[(e + 1) % 3] as usize);
            let next = if x + 1 == m { 0 } else { x + 1 };
            if next == y && x < plan.origin.len() && dot(tn, plan.origin[x]) <= 0.0 {
                return Err(Refusal::Flip);
            }
        }
        let wedge = c.map(|k| {
            let k = k as usize;
            if k == r.first {
                plan.right[k]
            } else {
                plan.left[k]
            }
        });
        plan.out.push(NewTri {
            corner: c,
            wedge,
            group,
        });
        Ok(())
    }

    /// The best split line of sub-polygon `poly` (its points projected on the
    /// region's plane: `w`): the diagonal `i`–`j` (not one `forbid` rules out) that
    /// leaves both halves strictly on their own sides with the largest aspect
    /// (smallest distance of a point to the line over the line's length), as
    /// (aspect², i, j); `None` when no line splits it.
    #[inline]
    fn best_split(
        plan: &Plan,
        poly: &[u8],
        w: &[[f64; 2]],
        forbid: &[u64],
    ) -> Option<(f64, usize, usize)> {
        let len = poly.len();
        let mut best: Option<(f64, usize, usize)> = None;
        for i in 0..len {
            let pi = poly[i] as usize;
            let a = plan.pos[pi];
            let a2 = w[i];
            for j in i + 2..len {
                if i == 0 && j == len - 1 {
                    continue;
                }
                let pj = poly[j] as usize;
                if forbid[i] & (1u64 << j) != 0 {
                    continue;
                }
                let d = sub(plan.pos[pj], a);
                let ld2 = dot(d, d);
                // Split-plane normal `d × n`, unnormalised: its length is
                // |d| sin(d, n), the length of the projection of `d`.
                let d2 = [w[j][0] - a2[0], w[j][1] - a2[1]];
                let ls2 = d2[0] * d2[0] + d2[1] * d2[1];
                if ld2 == 0.0 || ls2 <= 1e-24 * ld2 {
                    continue;
                }
                // Signed distances (times |d × n|) of the other points: those
                // strictly between i and j on one side, the rest on the other.
                let side = |k: usize| (w[k][0] - a2[0]) * d2[1] - (w[k][1] - a2[1]) * d2[0];
                // A line whose nearest point is below `lim` cannot beat the
                // best so far (`aspect2 <= best`, with a margin for rounding),
                // so the scan stops at the first such point; the scans start
                // next to the line's ends, where the nearest points usually are.
                let lim = best.map_or(0.0, |b| b.0 * (ls2 * ld2) * (1.0 - 1e-9));
                // Both halves strictly on their own side, at least `min` away.
                let mut min = f64::INFINITY;
                let valid = 'scan: {
                    for k in i + 1..j {
                        let s = side(k);
                        if s <= 0.0 || s * s < lim {
                            break 'scan false;
                        }
                        min = min.min(s);
                    }
                    for k in (j + 1..len).chain(0..i) {
                        let s = -side(k);
                        if s <= 0.0 || s * s < lim {
                            break 'scan false;
                        }
                        min = min.min(s);
                    }
                    true
                };
                if !valid {
                    continue;
                }
                // aspect = (min / |s|) / |d|, compared squared (no square roots).
                let aspect2 = min * min / (ls2 * ld2);
                if best.is_none_or(|b| aspect2 > b.0) {
                    best = Some((aspect2, i, j));
                }
            }
        }
        best
    }

    /// The gap between the old fan and the new triangles `out[from..]` of region `r`:
    /// along the region's normal at `v` (when `vertical` and `v` projects into the
    /// patch) and where the spokes cross the new diagonals `diagonals[d0..]`;
    /// otherwise the Euclidean distance from `v` to the patch.
    #[inline(never)]
    fn region_gap(&self, r: &Region, from: usize, d0: usize, vertical: bool) -> f64 {
        let plan = &self.plan;
        let m = plan.q.len();
        let n = r.normal;
        // The loop's coordinates in the frame of `n`, left by `split_region` for
        // this region (`[dot(p, e1), dot(p, e2)]` with `frame(n)`).
        let uv = &plan.uv;
        debug_assert_eq!(uv.len(), plan.pos.len());
        // The vertical gap at `v` when `v` projects into the patch; it is never below
        // the Euclidean distance from `v` to the patch (the point above `v` is on the
        // patch), so that is only computed when there is no vertical gap.
        let mut gap_v = f64::INFINITY;
        if vertical {
            for t in &plan.out[from..] {
                let [a, b, c] = t.corner.map(|k| plan.pos[k as usize]);
                let [a2, b2, c2] = t.corner.map(|k| uv[k as usize]);
                let det = (b2[0] - a2[0]) * (c2[1] - a2[1]) - (b2[1] - a2[1]) * (c2[0] - a2[0]);
                if det > 0.0 {
                    let w1 = (-a2[0] * (c2[1] - a2[1]) + a2[1] * (c2[0] - a2[0])) / det;
                    let w2 = ((b2[0] - a2[0]) * -a2[1] - (b2[1] - a2[1]) * -a2[0]) / det;
                    let w0 = 1.0 - w1 - w2;
                    if w0 >= -1e-12 && w1 >= -1e-12 && w2 >= -1e-12 {
                        let x = add(add(scale(a, w0), scale(b, w1)), scale(c, w2));
                        gap_v = dot(x, n).abs();
                        break;
                    }
                }
            }
        }
        let mut gap = gap_v;
        if gap.is_infinite() {
            for t in &plan.out[from..] {
                let [a, b, c] = t.corner.map(|k| plan.pos[k as usize]);
                let (cp, _) = closest_point([0.0; 3], a, b, c);
                gap = gap.min(norm(cp));
            }
        }
        if gap.is_infinite() {
            gap = 0.0;
        }
        // Spokes of the region against its diagonals.
        let mut i = r.first;
        loop {
            let q = plan.pos[i];
            let q2 = uv[i];
            for dg in &plan.diagonals[d0..] {
                let (ia, ib) = (dg[0] as usize, dg[1] as usize);
                if ia == i || ib == i {
                    continue;
                }
                let (a2, b2) = (uv[ia], uv[ib]);
                // v2 = origin; spoke s*q2, diagonal a2 + u (b2 - a2).
                let db = [b2[0] - a2[0], b2[1] - a2[1]];
                let den = q2[0] * db[1] - q2[1] * db[0];
                if den.abs() <= 1e-300 {
                    continue;
                }
                let s = (a2[0] * db[1] - a2[1] * db[0]) / den;
                let u = (a2[0] * q2[1] - a2[1] * q2[0]) / den;
                if s > 0.0 && s < 1.0 && u > 0.0 && u < 1.0 {
                    let (a, b) = (plan.pos[ia], plan.pos[ib]);
                    let on_spoke = scale(q, s);
                    let on_diag = add(a, scale(sub(b, a), u));
                    gap = gap.max(dot(sub(on_spoke, on_diag), n).abs());
                }
            }
            if i == r.last {
                break;
            }
            i = if i + 1 == m { 0 } else { i + 1 };
        }
        gap
    }

    /// Whether the closed fan projects one-to-one onto the plane of `n`: every
    /// triangle faces `n`'s side and the spokes turn once around `v`.
    #[inline(never)]
    fn fan_is_height_field(&self, n: [f64; 3]) -> bool {
        let plan = &self.plan;
        if plan.normal.iter().any(|&t| dot(t, n) <= 0.0) {
            return false;
        }
        // Every triangle faces `n`, so each spoke-to-spoke step turns the projected
        // spoke counterclockwise by less than π; the number of times it crosses the
        // positive `e1` axis (`e2` coordinate from negative to non-negative) is the winding number of the fan around `v`.
        let (_, e2) = frame(n);
        let m = plan.q.len();
        let mut windings = 0;
        let mut prev = plan.pos[m - 1];
        for &p in &plan.pos {
            let (ya, yb) = (dot(prev, e2), dot(p, e2));
            if ya < 0.0 && yb >= 0.0 {
                windings += 1;
            }
            prev = p;
        }
        windings == 1
    }

    /// The loop-level edge checks of the planned removal (they do not depend on the
    /// triangulation): the boundary or feature line must not be an edge already, and
    /// the valence-3 triangle must not exist already (tetrahedron).
    fn check_loop(&mut self) -> Result<(), Refusal> {
        let dup = match self.plan.loop_check {
            LoopCheck::None => false,
            LoopCheck::Edge(i, j) => self.loop_adjacent(i, j),
            LoopCheck::Valence3 => {
                let [a, b, c] = [self.plan.q[0], self.plan.q[1], self.plan.q[2]];
                let v = self.plan.v;
                self.fan(a).iter().any(|&t| {
                    let tt = self.tri[t as usize].p;
                    !tt.contains(&v) && tt.contains(&b) && tt.contains(&c)
                })
            }
        };
        if dup {
            Err(Refusal::Duplicate)
        } else {
            Ok(())
        }
    }

    /// After an evaluation in [`Mode::Geometry`]: the deferred checks. `Err` when the
    /// loop-level check fails (the removal is refused in any mode), `Ok(false)` when
    /// a planned diagonal is an edge already (the full evaluation then picks another
    /// split), `Ok(true)` when the plan is what [`Mode::Full`] would have made.
    #[inline(never)]
    fn deferred_checks_pass(&mut self) -> Result<bool, Refusal> {
        self.check_loop()?;
        for d in 0..self.plan.diagonals.len() {
            let [i, j] = self.plan.diagonals[d];
            if self.loop_adjacent(i as usize, j as usize) {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// Performs the removal planned by the last successful `evaluate(v)`.
    #[inline(never)]
    fn apply(&mut self, v: u32) {
        let e_new = self.plan.cost;
        let share = if self.plan.out.is_empty() {
            [0.0; 3]
        } else {
            scale(self.plan.origin_sum, 1.0 / self.plan.out.len() as f64)
        };
        let plan = std::mem::take(&mut self.plan);
        for &t in &plan.tris {
            self.tri[t as usize].p = [DEAD; 3];
        }
        self.pt[v as usize].len = 0;
        for &q in &plan.q {
            self.fan_prune(q);
        }
        for &t in &plan.tris {
            self.away[t as usize] = false;
        }
        for (slot, nt) in plan.out.iter().enumerate() {
            let t = plan.tris[slot];
            self.away[t as usize] = plan.away & (1u64 << slot) != 0;
            let pts = nt.corner.map(|k| plan.q[k as usize]);
            self.tri[t as usize] = Tri {
                p: pts,
                wedge: nt.wedge,
                group: nt.group,
                err: e_new,
                origin: share,
            };
            for p in pts {
                self.fan_push(p, t);
            }
        }
        self.live -= plan.tris.len() - plan.out.len();
        self.pt[v as usize].version = self.pt[v as usize].version.wrapping_add(1);
        for &q in &plan.q {
            self.pt[q as usize].version = self.pt[q as usize].version.wrapping_add(1);
        }
        self.plan = plan;
        if self.fan_garbage > self.fans.len() / 2 && self.fan_garbage > 1 << 16 {
            self.compact_fans();
        }
    }

    fn compact_fans(&mut self) {
        let np = self.pt.len();
        let mut fans = Vec::with_capacity(self.fans.len() - self.fan_garbage);
        for p in 0..np {
            let l = self.pt[p].len;
            let s = self.pt[p].start as usize;
            self.pt[p].start = fans.len() as u32;
            if l == 0 {
                self.pt[p].cap = 0;
                continue;
            }
            fans.extend_from_slice(&self.fans[s..s + l as usize]);
            fans.extend(std::iter::repeat_n(DEAD, 2));
            self.pt[p].cap = l + 2;
        }
        self.fans = fans;
        self.fan_garbage = 0;
    }

    /// Keeps the evaluated plan of `v` (made without the edge checks or with them)
    /// for its queued exact key.
    fn keep_plan(&mut self, v: u32) {
        let np = self.pt.len();
        if self.kept_tris.len() > 16 * np + 4096 {
            // Drop the plans of points whose fan changed since.
            let (tris, diagonals) = (
                std::mem::take(&mut self.kept_tris),
                std::mem::take(&mut self.kept_diagonals),
            );
            for (p, k) in self.kept.iter_mut().enumerate() {
                if !k.valid || k.version != self.pt[p].version {
                    k.valid = false;
                    continue;
                }
                let (t, d) = (k.tris_at as usize, k.diagonals_at as usize);
                k.tris_at = self.kept_tris.len() as u32;
                k.diagonals_at = self.kept_diagonals.len() as u32;
                self.kept_tris
                    .extend_from_slice(&tris[t..t + usize::from(k.tris)]);
                self.kept_diagonals
                    .extend_from_slice(&diagonals[d..d + usize::from(k.diagonals)]);
            }
        }
        let plan = &self.plan;
        self.kept[v as usize] = KeptPlan {
            valid: true,
            version: self.pt[v as usize].version,
            tris_at: self.kept_tris.len() as u32,
            diagonals_at: self.kept_diagonals.len() as u32,
            tris: plan.out.len() as u8,
            diagonals: plan.diagonals.len() as u8,
            loop_check: plan.loop_check,
            cost: plan.cost,
            delta: plan.delta,
        };
        self.kept_tris.extend_from_slice(&plan.out);
        self.kept_diagonals.extend_from_slice(&plan.diagonals);
    }

    /// Makes the kept plan of `v` the current plan (as an evaluation in
    /// [`Mode::Geometry`] would); `false` when there is none for its current fan.
    #[inline(never)]
    fn restore_plan(&mut self, v: u32) -> bool {
        let k = self.kept[v as usize];
        if !k.valid || k.version != self.pt[v as usize].version {
            return false;
        }
        self.kept[v as usize].valid = false;
        if self.build_loop(v).is_err() {
            return false;
        }
        let plan = &mut self.plan;
        let m = plan.q.len();
        plan.adj.clear();
        plan.adj.resize(m, 0);
        plan.adj_done = 0;
        plan.out.clear();
        let t = k.tris_at as usize;
        plan.out
            .extend_from_slice(&self.kept_tris[t..t + usize::from(k.tris)]);
        plan.diagonals.clear();
        let d = k.diagonals_at as usize;
        plan.diagonals
            .extend_from_slice(&self.kept_diagonals[d..d + usize::from(k.diagonals)]);
        plan.loop_check = k.loop_check;
        plan.cost = k.cost;
        plan.delta = k.delta;
        plan.origin_sum = [0.0; 3];
        for &t in &plan.tris {
            plan.origin_sum = add(plan.origin_sum, self.tri[t as usize].origin);
        }
        true
    }

    /// How many more of the planned triangles face away from the input than of the
    /// triangles they replace (0 below [`FACING_FROM`]); marks them in `plan.away`.
    /// A triangle faces away when its normal and that of the input triangle nearest
    /// to its centroid point to opposite sides.
    #[inline(never)]
    fn more_facing_away(&mut self) -> usize {
        self.plan.away = 0;
        if self.plan.cost < self.facing_from || self.plan.out.is_empty() {
            return 0;
        }
        if self.input_tree.is_none() {
            let pos: Vec<[f32; 3]> = self.pt.iter().map(|p| p.pos.map(|x| x as f32)).collect();
            self.input_tree = Some(Bvh::build_morton(&pos, &self.input_tri));
        }
        let Some(tree) = &self.input_tree else {
            return 0;
        };
        let plan = &mut self.plan;
        let before = plan.tris.iter().filter(|&&t| self.away[t as usize]).count();
        // Hints: the previous answer (the patch is small), else the input triangle
        // of the slot the new triangle takes.
        let mut hint = None;
        let mut after = 0usize;
        for (i, t) in plan.out.iter().enumerate() {
            let [a, b, c] = t.corner.map(|k| self.pt[plan.q[k as usize] as usize].pos);
            let n = cross(sub(b, a), sub(c, a));
            let ln = norm(n);
            if ln == 0.0 {
                continue;
            }
            // The centroid, nudged along the normal by a hundredth of the threshold:
            // a point midway between two faces (the first cut of an octahedron) is
            // nearest to the face on the side it faces, not to either of a tie.
            let centroid = add(
                scale(add(add(a, b), c), 1.0 / 3.0),
                scale(n, 0.01 * self.facing_from / ln),
            );
            if let Some(cl) = tree.closest(centroid, hint.or(Some(plan.tris[i]))) {
                hint = Some(cl.triangle);
                if dot(n, self.input_normal[cl.triangle as usize]) < 0.0 {
                    plan.away |= 1u64 << i;
                    after += 1;
                }
            }
        }
        after.saturating_sub(before)
    }

    /// [`Plan::adjacent`] for the current plan.
    fn loop_adjacent(&mut self, i: usize, j: usize) -> bool {
        let links = Links {
            tri: &self.tri,
            fans: &self.fans,
            pt: &self.pt,
            marks: &self.marks,
        };
        self.plan.adjacent(&links, i, j)
    }

    fn count(&mut self, r: Refusal) {
        let c = &mut self.rejections;
        match r {
            Refusal::Kind => c.kind += 1,
            Refusal::Seam => c.seam += 1,
            Refusal::NoSplit => c.link += 1,
            Refusal::Duplicate => c.duplicate += 1,
            Refusal::Flip => c.fold_over += 1,
            Refusal::Degenerate => c.degenerate += 1,
        }
    }

    /// The queue key of the evaluated plan.
    fn key(&self) -> f64 {
        plan_key(&self.plan, self.order_by_bound)
    }

    /// Queues `v` with the cheap lower bound of its key (`b = 0`), or, when that
    /// bound is below `plan_below` (the point would be next out of the queue), plans
    /// it at once (without the edge checks) and queues its exact key (`b = 1`) with
    /// the plan kept.
    fn push(&mut self, heap: &mut Heap, v: u32, plan_below: u32) {
        let item = Item {
            a: v,
            b: 0,
            stamp: self.pt[v as usize].version,
            cost_bits: 0,
        };
        if let Err(r) = self.evaluate_bound(v) {
            self.queued[v as usize] = 0;
            self.count(r);
            return;
        }
        let bound = item.with_cost(self.key());
        if bound.cost_bits >= plan_below {
            self.queued[v as usize] = bound.cost_bits;
            heap.push(bound);
            return;
        }
        if let Err(r) = self.evaluate_plan(false) {
            self.queued[v as usize] = 0;
            self.count(r);
            return;
        }
        self.keep_plan(v);
        let exact = Item { b: 1, ..item }.with_cost(self.key());
        self.queued[v as usize] = exact.cost_bits;
        heap.push(exact);
    }

    /// Queues every point with the cheap lower bound of its key (as
    /// [`Self::push`] with nothing due). The bounds are independent of each other
    /// before the first removal, so with several rayon threads they are computed
    /// in parallel, by workers that share the mesh and own only their scratch, and then
    /// queued in point order: the queue, and so the run, is the same for any number
    /// of threads.
    fn initial_pass(&mut self, heap: &mut Heap) {
        let np = self.pt.len();
        // (Small meshes do not start rayon's thread pool.)
        let threads = if np < 2 * INITIAL_CHUNK {
            1
        } else {
            rayon::current_num_threads().min(np / INITIAL_CHUNK).max(1)
        };
        if threads == 1 {
            for v in 0..np as u32 {
                if self.pt[v as usize].len > 0 {
                    self.push(heap, v, 0);
                }
            }
            return;
        }
        let chunk = np.div_ceil(threads);
        let order_by_bound = self.order_by_bound;
        // The read-only part of the evaluation state, shared by all workers.
        let view = self.eval().m;
        let results: Vec<Vec<Result<u32, Refusal>>> = (0..threads)
            .into_par_iter()
            .map(|c| {
                // The worker's own scratch (the mesh is shared): a plan and 8 bytes a
                // point of marks, zeroed pages resident only where its loops touch.
                let mut plan = Plan::default();
                let mut marks = vec![Mark::default(); np];
                let mut gen = 0;
                let mut w = Eval {
                    m: view,
                    plan: &mut plan,
                    marks: &mut marks,
                    gen: &mut gen,
                };
                (c * chunk..np.min((c + 1) * chunk))
                    .map(|v| {
                        if w.m.pt[v].len == 0 {
                            return Err(Refusal::Kind);
                        }
                        w.evaluate_bound(v as u32).map(|()| {
                            Item::default()
                                .with_cost(plan_key(w.plan, order_by_bound))
                                .cost_bits
                        })
                    })
                    .collect()
            })
            .collect();
        for (v, r) in results.into_iter().flatten().enumerate() {
            if self.pt[v].len == 0 {
                continue;
            }
            match r {
                Ok(cost_bits) => {
                    self.queued[v] = cost_bits;
                    heap.push(Item {
                        a: v as u32,
                        b: 0,
                        stamp: self.pt[v].version,
                        cost_bits,
                    });
                }
                Err(r) => {
                    self.queued[v] = 0;
                    self.count(r);
                }
            }
        }
    }

    /// Removes points, cheapest first, until the stop rule holds or nothing can be
    /// removed; returns what happened (`collapses` counts removed points, `max_error`
    /// is the largest accumulated bound of a performed removal). The observer sees
    /// `started` and `progress`, not `collapsed` (a removal is not an edge collapse).
    ///
    /// Each queued entry is planned (`plan_removal`), removed, and its loop points
    /// queued again (`requeue_neighbours`) in the order `RunOrder` describes.
    pub fn run(&mut self, observer: &mut dyn Observer) -> Outcome {
        let target = self.options.stop.target_triangles;
        let mut order = self.run_order();
        if order.defer.is_some() {
            self.waiting = vec![false; self.pt.len()];
        }
        observer.started(self.live, target);
        let mut outcome = Outcome {
            stop_reason: StopReason::NoLegalCollapse,
            ..Outcome::nothing()
        };
        if self.live == 0 {
            outcome.stop_reason = StopReason::EmptyInput;
            outcome.stop_detail = "the input has no triangles".into();
            return outcome;
        }
        let mut heap = Heap::with_capacity(self.pt.len());
        if self.live > target {
            self.initial_pass(&mut heap);
        }
        let mut removed = 0usize;
        let mut stopped = RunStop::default();
        let mut loop_pts = Vec::new();
        while self.live > target {
            let Some(item) = heap.pop() else { break };
            let v = item.a;
            if item.stamp != self.pt[v as usize].version || self.pt[v as usize].len == 0 {
                continue;
            }
            // Only removals that turn more triangles away from the input are left:
            // stop rather than fold thin parts over.
            if item.b == 2 {
                stopped.facing = true;
                break;
            }
            if self.order_by_bound && f64::from(f32::from_bits(item.cost_bits)) > order.max_error {
                stopped.over_error = true;
                break;
            }
            if !self.plan_removal(&mut heap, item, &order) {
                continue;
            }
            if self.plan.cost > order.max_error {
                self.rejections.max_error += 1;
                self.queued[v as usize] = 0;
                continue;
            }
            outcome.max_error = outcome.max_error.max(self.plan.cost);
            let removed_key = self.key();
            loop_pts.clear();
            loop_pts.extend_from_slice(&self.plan.q);
            self.apply(v);
            removed += 1;
            if removed % 4096 == 0 {
                observer.progress(self.live);
            }
            self.requeue_neighbours(&mut heap, &loop_pts, removed_key, &mut order);
        }
        observer.progress(self.live);
        outcome.collapses = removed;
        outcome.rejections = self.rejections;
        self.set_stop_reason(&mut outcome, removed, stopped);
        outcome
    }

    /// The removal order of a run, from the options.
    fn run_order(&self) -> RunOrder {
        let max_error = self.options.stop.max_error.unwrap_or(f64::INFINITY);
        let base_slack = if self.options.order_slack > 1.0 {
            self.options.order_slack
        } else {
            1.0
        };
        let defer = self
            .options
            .defer_neighbours
            .map(|p| if p > 1.0 { p } else { 1.0 });
        let defer_until = match (defer, self.options.defer_below) {
            (Some(_), Some(f)) if f.is_nan() => 0.0,
            (Some(_), Some(f)) => f.max(0.0) * self.diagonal,
            _ => f64::INFINITY,
        };
        // (No key is below 0: the exact order from the start.)
        let defer = if defer_until > 0.0 { defer } else { None };
        // The slack while deferring (NaN or below 1 counts as 1).
        let slack = match (defer, self.options.defer_slack) {
            (Some(_), Some(s)) if s > 1.0 => s,
            (Some(_), Some(_)) => 1.0,
            _ => base_slack,
        };
        RunOrder {
            max_error,
            base_slack,
            defer,
            defer_until,
            defer_bound: self.options.defer_bound,
            slack,
        }
    }

    /// Plans the removal of the point of the popped `item` (into `self.plan`):
    /// true when it is to be removed now, false when it was refused or queued again
    /// (with its exact key, or behind every removal that turns no triangle away).
    fn plan_removal(&mut self, heap: &mut Heap, item: Item, order: &RunOrder) -> bool {
        let Some(mode) = self.plan_popped(heap, item, order) else {
            return false;
        };
        if mode == Mode::Geometry && !self.recheck_edges(heap, item, order) {
            return false;
        }
        !self.requeue_if_facing_away(heap, item)
    }

    /// The plan of the popped `item`'s point: restored (an exact key), or made, and
    /// queued again with its exact key when that is above the next entry (beyond
    /// the slack). Returns how it was planned, or `None` when it was refused or
    /// queued again.
    fn plan_popped(&mut self, heap: &mut Heap, item: Item, order: &RunOrder) -> Option<Mode> {
        let v = item.a;
        // An entry with a lower bound (`b = 0`) is planned without the edge
        // checks first: most such plans are queued again with their exact key
        // (below) and invalidated by a neighbour's removal before they come
        // back, so the checks are left to the plans that are used. An entry
        // with its exact key (`b = 1`) has its plan kept.
        if (item.b == 1 || item.b == 2) && self.restore_plan(v) {
            return Some(Mode::Geometry);
        }
        let mode = if item.b == 0 || item.b == 3 {
            Mode::Geometry
        } else {
            Mode::Full
        };
        let planned = if item.b == 3 {
            // A deferred point (its fan changed since its key): bound it now,
            // and queue the bound unless it is still due.
            self.waiting[v as usize] = false;
            match self.evaluate_bound(v) {
                Ok(()) => {
                    let bound = Item { b: 0, ..item }.with_cost(self.key());
                    if heap
                        .peek_cost_bits()
                        .is_some_and(|c| slack_bits(c, order.base_slack) < bound.cost_bits)
                    {
                        self.queued[v as usize] = bound.cost_bits;
                        heap.push(bound);
                        return None;
                    }
                    self.evaluate_plan(false)
                }
                Err(r) => Err(r),
            }
        } else {
            self.evaluate(v, mode)
        };
        if let Err(r) = planned {
            self.queued[v as usize] = 0;
            self.count(r);
            return None;
        }
        // The entry held a lower bound (or a key planned without the edge
        // checks): if the exact key is above the next entry, queue it again
        // with the exact key (best-first stays exact) and keep the plan.
        let exact = Item { b: 1, ..item }.with_cost(self.key());
        // (While deferring, the slack stops at the switch key: a removal
        // that reaches it goes in the exact order.)
        let s = order.slack_at(self.key());
        if exact.cost_bits > item.cost_bits
            && heap
                .peek_cost_bits()
                .is_some_and(|c| slack_bits(c, s) < exact.cost_bits)
        {
            self.keep_plan(v);
            self.queued[v as usize] = exact.cost_bits;
            heap.push(exact);
            return None;
        }
        Some(mode)
    }

    /// The edge checks left out of a plan made without them: true when they pass,
    /// or when the plan made again with every check still comes first; false when
    /// it was refused or queued again with its new key.
    fn recheck_edges(&mut self, heap: &mut Heap, item: Item, order: &RunOrder) -> bool {
        let v = item.a;
        match self.deferred_checks_pass() {
            Ok(true) => true,
            Ok(false) => {
                // A planned diagonal is an edge already: plan with every
                // check, and compare the new key again.
                if let Err(r) = self.evaluate(v, Mode::Full) {
                    self.queued[v as usize] = 0;
                    self.count(r);
                    return false;
                }
                let exact = Item { b: 1, ..item }.with_cost(self.key());
                let s = order.slack_at(self.key());
                if heap
                    .peek_cost_bits()
                    .is_some_and(|c| slack_bits(c, s) < exact.cost_bits)
                {
                    self.keep_plan(v);
                    heap.push(exact);
                    return false;
                }
                true
            }
            Err(r) => {
                self.queued[v as usize] = 0;
                self.count(r);
                false
            }
        }
    }

    /// A removal leaving more triangles facing away from the input goes after
    /// every removal that does not (queued again with a key above them all):
    /// true when the plan was queued so.
    fn requeue_if_facing_away(&mut self, heap: &mut Heap, item: Item) -> bool {
        let v = item.a;
        let extra = self.more_facing_away();
        if extra > 0 {
            let last =
                Item { b: 2, ..item }.with_cost(self.key() + self.facing_tier * extra as f64);
            if last.cost_bits > item.cost_bits
                && heap.peek_cost_bits().is_some_and(|c| c < last.cost_bits)
            {
                self.keep_plan(v);
                self.queued[v as usize] = Item::default().with_cost(self.key()).cost_bits;
                heap.push(last);
                return true;
            }
        }
        false
    }

    /// Queues the loop points of a removal (key `removed_key`) again: those whose
    /// bound is below every queued key are planned at once (they would be next out
    /// of the queue), sparing a second classification; while deferring, the others
    /// wait at their deferred key. The first removal at the switch key ends the
    /// deferral (`order` changes).
    fn requeue_neighbours(
        &mut self,
        heap: &mut Heap,
        loop_pts: &[u32],
        removed_key: f64,
        order: &mut RunOrder,
    ) {
        let next = heap.peek_cost_bits().unwrap_or(u32::MAX);
        if order.defer.is_some() && removed_key >= order.defer_until {
            // The coarse end: back to the exact order. Every point still behind
            // a deferred key is evaluated now (its old entry made stale).
            order.defer = None;
            order.slack = order.base_slack;
            for q in 0..self.pt.len() as u32 {
                let qi = q as usize;
                if self.waiting[qi] && self.pt[qi].len > 0 {
                    self.waiting[qi] = false;
                    self.pt[qi].version = self.pt[qi].version.wrapping_add(1);
                    self.push(heap, q, next);
                }
            }
        }
        if let Some(defer) = order.defer {
            for &q in loop_pts {
                self.defer_neighbour(heap, q, next, defer, order.defer_bound);
            }
        } else {
            for &q in loop_pts {
                self.push(heap, q, next);
            }
        }
    }

    /// Queues loop point `q` while deferring: planned at once when its deferred key
    /// (its previous key over `defer`) is below `next`, else queued at the deferred
    /// key (`defer_bound`: at the larger of it and a bound of its changed fan).
    fn defer_neighbour(
        &mut self,
        heap: &mut Heap,
        q: u32,
        next: u32,
        defer: f64,
        defer_bound: bool,
    ) {
        let qi = q as usize;
        let prov = slack_bits(self.queued[qi], 1.0 / defer);
        if prov < next || self.pt[qi].len == 0 {
            self.waiting[qi] = false;
            self.push(heap, q, next);
        } else if defer_bound {
            // Bound the changed fan now; queue the larger of the bound
            // and the deferred key (planned when it comes out). Queued at
            // the deferred key, the point still waits: the switch to the
            // exact order evaluates it again.
            self.waiting[qi] = false;
            if let Err(r) = self.evaluate_bound(q) {
                self.queued[qi] = 0;
                self.count(r);
                return;
            }
            let bound = Item::default().with_cost(self.key()).cost_bits;
            self.waiting[qi] = bound < prov;
            let cost_bits = bound.max(prov);
            if bound > prov {
                self.queued[qi] = bound;
            }
            heap.push(Item {
                a: q,
                b: 0,
                stamp: self.pt[qi].version,
                cost_bits,
            });
        } else {
            self.waiting[qi] = true;
            heap.push(Item {
                a: q,
                b: 3,
                stamp: self.pt[qi].version,
                cost_bits: prov,
            });
        }
    }

    /// Why the run stopped, in `outcome` (after `removed` removals).
    fn set_stop_reason(&self, outcome: &mut Outcome, removed: usize, stopped: RunStop) {
        let target = self.options.stop.target_triangles;
        let max_error = self.options.stop.max_error.unwrap_or(f64::INFINITY);
        if self.live <= target {
            outcome.stop_reason = StopReason::TargetReached;
            outcome.stop_detail = format!(
                "{} triangles left, target {target}, after removing {removed} points",
                self.live
            );
        } else if stopped.facing {
            outcome.stop_reason = StopReason::NoLegalCollapse;
            outcome.stop_detail = format!(
                "every remaining removal would leave more triangles facing away from the \
                 input surface (a thin part folding over); {} triangles left, target {target}",
                self.live
            );
        } else if stopped.over_error || self.rejections.max_error > 0 {
            outcome.stop_reason = StopReason::MaxError;
            outcome.stop_detail = format!(
                "every remaining removal would exceed the maximum error {max_error:.6}; \
                 {} triangles left, target {target}",
                self.live
            );
        } else {
            outcome.stop_reason = StopReason::NoLegalCollapse;
            outcome.stop_detail = format!(
                "no point can be removed any more (complex, locked or kept corners and \
                 boundaries, no valid split of the hole, or a duplicate edge or \
                 triangle would result); {} triangles left, target {target}",
                self.live
            );
        }
    }

    /// The live triangles as wedge triples and point triples, with their groups.
    #[must_use]
    pub fn output_triangles(&self) -> TriangleLists {
        let mut wedges = Vec::with_capacity(self.live);
        let mut points = Vec::with_capacity(self.live);
        let mut groups = self.has_groups.then(|| Vec::with_capacity(self.live));
        for tt in &self.tri {
            if tt.p[0] == DEAD {
                continue;
            }
            points.push(tt.p);
            wedges.push(tt.wedge);
            if let Some(g) = &mut groups {
                g.push(tt.group);
            }
        }
        (wedges, points, groups)
    }

    /// The error bound carried by each live triangle (see the module docs), in the
    /// order of [`Self::output_triangles`].
    #[must_use]
    pub fn triangle_errors(&self) -> Vec<f64> {
        self.tri
            .iter()
            .filter(|t| t.p[0] != DEAD)
            .map(|t| t.err)
            .collect()
    }
}
