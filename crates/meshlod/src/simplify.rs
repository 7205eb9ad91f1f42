//! Mesh simplification, the public entry point: [`simplify`] with
//! [`SimplifyOptions`], returning the simplified [`Mesh`] and a [`Report`].
//!
//! The pipeline:
//! 1. **validate** the mesh ([`Mesh::validate`]: indices, NaN/inf, stream lengths);
//! 2. **repair**: weld positions exactly, drop triangles with a repeated point or
//!    exactly zero area and extra copies of a triangle over the same three points
//!    (both counted in the report);
//! 3. **decimate** with the edge-collapse driver ([`crate::decimate::edge_collapse`]):
//!    the cost model of [`SimplifyOptions::method`] (quadric error metric,
//!    [`crate::cost::Qem`], or Melax's edge cost, [`crate::cost::Melax`]), the
//!    always-on collapse operator, and the filters the options ask for;
//! 4. **output**: the surviving triangles over a compacted vertex buffer (first-use
//!    order), attributes interpolated at moved vertices, groups kept.
//!
//! A flat-shaded input (every triangle's corners carry its own facet normal, so
//! every point is split into one vertex per triangle and, taken as seams, no point
//! could move) goes through these steps without its normals, the vertices they
//! alone split made one, and the output's corners get their triangles' facet
//! normals ([`SimplifyOptions::reshade_flat`], [`Report::flat_shading`]).
//!
//! # Errors as distances
//! The reported [`Report::error`] and the [`SimplifyOptions::max_error`] bound are
//! *distances*: for a collapse, `sqrt(Δ / W)` where `Δ` is the quadric error of the
//! new vertex and `W` the total area weight accumulated in its quadric — the
//! area-weighted RMS distance from the new vertex to the original planes it stands
//! for (see [`crate::quadric`]). The report gives the largest such value over all
//! collapses performed, both in mesh units and as a fraction of the input's
//! bounding-box diagonal. It is an estimate from the quadrics, not a Hausdorff
//! distance (measure that with the metrics module). With [`Method::Melax`] the error
//! of a collapse is its Melax cost (edge length × curvature term, see
//! [`crate::cost::Melax`]).
//!
//! With [`Method::VertexRemoval`] step 3 is Schroeder's vertex decimation
//! ([`crate::decimate::vertex_removal`]): no vertex moves, every output vertex is an
//! input vertex with its attributes, and the error is the accumulated per-triangle
//! bound described there (a distance from the input surface to the output).
//!
//! # Example
//! ```
//! use meshlod::mesh::generate;
//! use meshlod::simplify::{simplify, SimplifyOptions, StopReason};
//!
//! let sphere = generate::icosphere(3); // 1280 triangles
//! let options = SimplifyOptions::default().with_ratio(0.1);
//! let (lod, report) = simplify(&sphere, &options).expect("a valid mesh");
//! assert_eq!(report.stop_reason, StopReason::TargetReached);
//! assert_eq!(lod.triangles.len(), 128);
//! assert!(report.error < 0.05); // well under 5% of the diagonal
//! ```

use crate::collapse::{BuildOptions, OperatorLimits, Surface};
use crate::cost::{Melax, Placement, Qem, QemOptions};
use crate::decimate::cluster::{
    cluster_file, cluster_mesh, ClusterError, ClusterOptions, ClusterStats, Clustered,
};
use crate::decimate::edge_collapse::{self, EdgeCollapseOptions};
use crate::decimate::vertex_removal::{TriangleLists, VertexRemoval, VertexRemovalOptions};
use crate::decimate::{NoObserver, Observer, Outcome, Rejections, StopRule};
use crate::filter::{AspectRatio, Filter, LockBoundary, NormalDeviation};
use crate::mesh::{Mesh, MeshError};
use crate::metrics::bvh::Bvh;
use serde::Serialize;
use std::time::Instant;
use thiserror::Error;

pub use crate::cost::AttributeWeights;
pub use crate::decimate::StopReason;
/// A length in mesh units or relative to the diagonal; defined in [`crate::mesh`]
/// (the clustering uses it too), re-exported here where the options use it.
pub use crate::mesh::Distance;
pub use levels::{simplify_levels, supports_levels, LevelOutput, LevelStop};

/// The simplification method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Quadric error metric edge collapse (Garland & Heckbert 1997).
    #[default]
    Qem,
    /// Vertex clustering on a uniform grid (Rossignac & Borrel 1993; quadric
    /// representatives after Lindstrom 2000): O(n), may change the topology. See
    /// [`crate::decimate::cluster`] and [`SimplifyOptions::cluster`].
    Cluster,
    /// Schroeder vertex decimation: vertex removal with split-plane hole
    /// triangulation and accumulated error (Schroeder, Zarge & Lorensen 1992;
    /// `vtkDecimatePro`). Every output vertex is an input vertex, unmoved. See
    /// [`crate::decimate::vertex_removal`].
    VertexRemoval,
    /// Melax's directional edge cost, half-edge collapses only (Melax 1998): no
    /// vertex ever moves, so the result's positions are a subset of the input's.
    Melax,
}

impl Method {
    /// The name used on the command line and in reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Qem => "qem",
            Self::Cluster => "cluster",
            Self::VertexRemoval => "vertex-removal",
            Self::Melax => "melax",
        }
    }
}

/// Options of [`simplify`]. Build with [`SimplifyOptions::default`] and the `with_*`
/// setters; every field documents its default.
#[derive(Debug, Clone, PartialEq)]
pub struct SimplifyOptions {
    /// The method. Default [`Method::Qem`].
    pub method: Method,
    /// Target as a fraction of the input triangle count (`0.1` keeps 10%). Default
    /// `None`. With neither `ratio` nor `target_triangles` the target is 50% of the
    /// input, or no count at all when `max_error` is given.
    pub ratio: Option<f64>,
    /// Target triangle count. Default `None`. When both targets are given the
    /// larger count wins (whichever is reached first).
    pub target_triangles: Option<usize>,
    /// Stop before any collapse whose error exceeds this distance. Default `None`.
    /// [`Method::Cluster`] has no such stop: there it is refused unless a ratio, a
    /// triangle count or a cell size is given as well.
    pub max_error: Option<Distance>,
    /// Keep every boundary point where it is (never moved, never removed). Default
    /// `false`.
    pub lock_boundary: bool,
    /// Per input vertex: `true` locks its position (never moved or removed) and
    /// its attributes (other points merged onto it leave its normals, UVs and
    /// colours as they were). Default `None`. Must have one entry per vertex.
    pub locked_vertices: Option<Vec<bool>>,
    /// Keep the topology: only edges are collapsed, every hole and part stays.
    /// When `false` (free topology, QEM and Melax; `--free-topology`): a hole
    /// closes once down to three border edges, separate parts are removed whole
    /// at their distance to the rest, and pinches slide (see
    /// `docs/methods/qem.md`, "Free topology"; not on the chunked path); with
    /// [`Self::pair_threshold`] set, close non-edge pairs are contracted too
    /// (joining separate parts; this can change the genus and creates non-manifold
    /// vertices where parts join), and parts are then not removed. Default `true`.
    pub preserve_topology: bool,
    /// Weight of the boundary constraint planes (plane through a border edge,
    /// perpendicular to its triangle), relative to area weights: a border edge of
    /// length `l` adds a plane of weight `w·l²` (an equilateral triangle on it has
    /// area `0.43·l²`). Higher keeps open borders more faithfully. Default `10.0`.
    pub boundary_weight: f64,
    /// Exponent α of QEM's triangle weights `area^α · mean_area^(1−α)`: `1` is
    /// area weighting, `0.5` keeps small triangles (detail) more. Default `1.0`.
    pub area_exponent: f64,
    /// QEM: relative conditioning threshold `c` of the optimal-placement solve, in
    /// `[0, 1)`: a quadric with `det(A) ≤ c·(tr(A)/3)³` (`A` its 3×3 part; the ratio
    /// is at most 1 for any quadric) is placed at the minimum along the edge
    /// instead. Default [`crate::cost::QEM_CONDITION`] (`1e-7`).
    pub solve_condition: f64,
    /// QEM: weight λ of the displacement guard ([`QemOptions::displacement_guard`]):
    /// a collapse whose old points end up a distance `e` (mesh units) off the
    /// triangles it leaves is ranked at least `λ · W · e²`, `W` the pair's summed
    /// quadric weight (area-scaled, including border and seam planes). `0`
    /// (default) turns it off; finite and non-negative.
    pub displacement_guard: f64,
    /// Maximum angle in degrees a triangle's normal may turn in one collapse.
    /// Default `None` (only fold-overs, turns of 90° or more, are refused).
    pub max_normal_deviation: Option<f64>,
    /// Threshold `t` for pair contraction: pairs of points closer than `t` that share
    /// no edge become candidates (Garland & Heckbert's "virtual edges"). Only used
    /// when `preserve_topology` is `false`. Default `None`.
    pub pair_threshold: Option<Distance>,
    /// Minimum quality `4√3·area / Σ edge²` (1 = equilateral) of a triangle created
    /// by a collapse, unless it was already worse; a soft guard against slivers: a
    /// collapse that would make one is not refused but ranked at 16 times its
    /// cost, so it waits for cheaper ones. `0` disables. Default `0.1`.
    pub min_triangle_quality: f64,
    /// Where a merged vertex goes. Default [`Placement::Optimal`].
    pub placement: Placement,
    /// Options of [`Method::Cluster`] (cell size, representative, weights). With a
    /// cell size the targets are ignored. Default [`ClusterOptions::default`].
    pub cluster: ClusterOptions,
    /// [`Method::VertexRemoval`]: a spoke whose two triangles meet at a dihedral
    /// angle above this many degrees is a feature edge (creases are kept as edges,
    /// points on them measured by their distance to the crease line). Default `15.0`.
    pub feature_angle: f64,
    /// [`Method::VertexRemoval`]: never remove corner points (one or more than two
    /// feature edges). Default `false` (corners go by their distance to the average
    /// plane, as in `vtkDecimate`).
    pub keep_corners: bool,
    /// [`Method::VertexRemoval`]: order slack `S ≥ 1`: a removal whose exact key is at
    /// most `S ×` the next queued key is performed without being queued again (`1` =
    /// the exact order). Default
    /// [`DEFAULT_ORDER_SLACK`](crate::decimate::vertex_removal::DEFAULT_ORDER_SLACK).
    /// In the fast order (the default) it applies only after the switch of
    /// [`Self::defer_below`]; before it, [`Self::defer_slack`] does. To refine the
    /// exact order, call [`Self::with_exact_order`] first (it resets this slack).
    pub order_slack: f64,
    /// [`Method::VertexRemoval`]: deferred re-keying: `Some(p)` (`p ≥ 1`) leaves the
    /// neighbours of a removal queued at their previous key divided by `p` until they
    /// come out of the queue (about half the evaluations; inexact order). Default
    /// `Some(1.0)`, part of the fast order (see [`Self::with_exact_order`]; `None`:
    /// re-evaluated at once).
    pub defer_neighbours: Option<f64>,
    /// [`Method::VertexRemoval`], with [`Self::defer_neighbours`]: defer only while
    /// the removed point's key is below this fraction of the bounding-box diagonal;
    /// from the first removal that reaches it on, the exact order. Default
    /// [`FAST_ORDER_EXACT_FROM`](crate::decimate::vertex_removal::FAST_ORDER_EXACT_FROM)
    /// (`None`: defer for the whole run).
    pub defer_below: Option<f64>,
    /// [`Method::VertexRemoval`], with [`Self::defer_neighbours`]: bound a deferred
    /// neighbour's changed fan at once and queue it at the larger of that bound and
    /// its deferred key. Default `false`.
    pub defer_bound: bool,
    /// [`Method::VertexRemoval`], with [`Self::defer_neighbours`]: the order slack
    /// while deferring (may be infinite: every planned candidate is removed when it
    /// comes out). Default
    /// [`FAST_ORDER_SLACK`](crate::decimate::vertex_removal::FAST_ORDER_SLACK)
    /// (`None`: [`Self::order_slack`] throughout).
    pub defer_slack: Option<f64>,
    /// [`Method::Qem`] and [`Method::Melax`]: after simplifying, swap the diagonal
    /// of quads whose triangles face away from the input surface when that turns
    /// them back without raising the distance to the input (see the `facing`
    /// module's rules). No vertex moves; topology, seams and groups are kept; a
    /// closest-point tree over the input is built for it. Default `true`.
    pub facing_repair: bool,
    /// [`Method::Qem`] on a mesh with normals, texture coordinates or colours:
    /// after simplifying, set the output's values of those attributes to the
    /// least-squares fit of the input's at corresponding points, geometry fixed
    /// (the `refit` module's rules; Hoppe 1996's `E_scalar`). Seams and locked
    /// vertices are kept; not with [`Placement::Endpoint`] (no vertex changes
    /// there). Default `true`.
    pub refit_attributes: bool,
    /// [`Method::Qem`] with [`Placement::Optimal`] or [`Placement::Midpoint`]: after
    /// simplifying (before the orientation repair), this many iterations that move
    /// the output's points toward the input surface, the input's vertices and
    /// triangle centroids pulling on their nearest output triangles, without raising
    /// any sample's distance past the largest around it, without turning a triangle
    /// by more than 60° and without turning one to face away from the input (see the
    /// `fit` module's rules). Borders, locked vertices and topology are kept. `0`
    /// turns it off. Default 0 (off: it adds 60–140% to the run's time);
    /// [`DEFAULT_FIT_ITERATIONS`] (2) is what `meshlod simplify --fit` runs, with
    /// [`Self::edge_swaps`] before them. The reported `error` stays the quadric
    /// error of the collapses.
    pub fit_iterations: u32,
    /// [`Method::Qem`] with [`Placement::Optimal`] or [`Placement::Midpoint`]: after
    /// simplifying (before the fitting and the orientation repair), swap the
    /// diagonal of two triangles where the other one lies nearer the input (Hoppe
    /// et al. 1993's edge swap: the input's vertices (and, with the fitting, its
    /// centroids) nearer their output triangles in the squared sum, none of them
    /// farther than the farthest was; the new triangles' centroids and points of
    /// the new diagonal no farther from the input than the old pair's; the new
    /// diagonal not an edge already; see the `fit` module's `swap` rules). No point
    /// moves; borders, seams, material borders and topology are kept. Default
    /// `false` (it adds 2–54% to the run's time, 1–27% on top of the fitting, whose
    /// input samples it shares).
    pub edge_swaps: bool,
    /// Flat-shaded input (every triangle's three corners carry one normal, its
    /// own facet normal, so every point is split into one vertex per triangle and
    /// no point could move): simplify with the normals set aside and the vertices
    /// they alone split made one, then give the output's triangles their own
    /// facet normals (see the `flat` module). A mesh with smooth normals anywhere,
    /// or with tangents, is not affected. Default `true`.
    pub reshade_flat: bool,
    /// Threads for a large mesh's chunks and the orientation repair: QEM on a
    /// mesh of a million triangles or more simplified to a quarter of it or less
    /// (with optimal or midpoint placement, without `fit_iterations`,
    /// `edge_swaps` or non-edge pairs, the topology kept) is simplified in spatial
    /// chunks with their shared borders locked, then as a whole (the `chunked`
    /// module); the orientation repair's first scan (a closest-point query per
    /// output triangle) runs in parallel for every mesh. The chunks depend on the mesh alone, so the output is the
    /// same for every thread count. `None` (default): all cores; `Some(n)`,
    /// `n ≥ 1`: `n` threads.
    pub threads: Option<usize>,
    /// Let a large mesh be simplified in chunks (see [`Self::threads`]). `false`
    /// simplifies it as a whole (the decimation on one thread), in the exact
    /// global greedy order
    /// (slower; the reference the chunked runs are measured against). Default
    /// `true`.
    pub chunks: bool,
    /// [`Method::Qem`]: permissive seams. An attribute-seam or material-border
    /// point slides along its seam (and a seam junction along one of its seams);
    /// by default it may also collapse across the seam, moving the seam line,
    /// where every collapse that keeps the seam costs ten times more
    /// ([`QemOptions::seam_crossing_penalty`]), which keeps meshes cut by many
    /// seams from stalling or tearing at low counts. Permissive, a crossing costs
    /// what its seam constraint planes and attribute terms say, like any other
    /// collapse: lower errors and lower counts, some texture distortion near the
    /// seams; a skinned mesh's wedges of different dominant joints may then merge
    /// too (otherwise refused). Open borders are kept either way. With
    /// [`Placement::Endpoint`] (the half-edge runs a progressive mesh records)
    /// seams are crossed only when permissive. Default `false`.
    pub permissive: bool,
    /// [`Method::Qem`]: seams are never crossed (a seam point only slides along
    /// its seam, whatever that costs; a mesh cut by many seams may stop above its
    /// target). Excludes [`Self::permissive`]. Default `false`.
    pub strict_seams: bool,
    /// [`Method::Qem`]: weights of the normals, texture coordinates and colours in
    /// the cost (Hoppe 1999's attribute quadric; `0` leaves a stream out). The
    /// merged vertices' attributes are then the values that minimise that cost.
    /// Each must be finite and non-negative. Default
    /// [`AttributeWeights::default`] (normal 0.002, uv 0.1, colour 0.1).
    pub attribute_weights: AttributeWeights,
}

impl Default for SimplifyOptions {
    fn default() -> Self {
        Self {
            method: Method::Qem,
            ratio: None,
            target_triangles: None,
            max_error: None,
            lock_boundary: false,
            locked_vertices: None,
            preserve_topology: true,
            boundary_weight: 10.0,
            area_exponent: 1.0,
            solve_condition: crate::cost::QEM_CONDITION,
            displacement_guard: 0.0,
            max_normal_deviation: None,
            pair_threshold: None,
            min_triangle_quality: 0.1,
            placement: Placement::Optimal,
            cluster: ClusterOptions::default(),
            feature_angle: crate::decimate::vertex_removal::DEFAULT_FEATURE_ANGLE,
            keep_corners: false,
            order_slack: crate::decimate::vertex_removal::DEFAULT_ORDER_SLACK,
            defer_neighbours: Some(1.0),
            defer_below: Some(crate::decimate::vertex_removal::FAST_ORDER_EXACT_FROM),
            defer_bound: false,
            defer_slack: Some(crate::decimate::vertex_removal::FAST_ORDER_SLACK),
            facing_repair: true,
            refit_attributes: true,
            fit_iterations: 0,
            edge_swaps: false,
            reshade_flat: true,
            threads: None,
            chunks: true,
            permissive: false,
            strict_seams: false,
            attribute_weights: AttributeWeights::default(),
        }
    }
}

impl SimplifyOptions {
    /// Whether seam junctions may slide along their seams
    /// ([`crate::collapse::BuildOptions::move_junctions`]): QEM with a placement
    /// that moves points (the half-edge runs a progressive mesh records keep the
    /// junctions fixed).
    pub(crate) fn moves_junctions(&self) -> bool {
        self.method == Method::Qem && self.placement != Placement::Endpoint
    }

    /// Whether collapses may cross seams ([`Self::permissive`], or by default
    /// with QEM's moving placements, at a penalty; never with
    /// [`Self::strict_seams`]).
    pub(crate) fn crosses_seams(&self) -> bool {
        !self.strict_seams
            && (self.permissive && self.method == Method::Qem || self.moves_junctions())
    }

    /// The surface's moves these options allow (locked vertices, junctions,
    /// chains, pinches, seam crossings, skin joints), in the input's numbering
    /// (no spatial order) and without merge tracking.
    pub(crate) fn build_options(&self) -> BuildOptions<'_> {
        BuildOptions {
            locked: self.locked_vertices.as_deref(),
            spatial_order: false,
            track_merges: false,
            move_junctions: self.moves_junctions(),
            move_non_manifold: self.moves_junctions(),
            move_pinches: !self.preserve_topology,
            permissive: self.crosses_seams(),
            merge_joints: self.permissive && self.method == Method::Qem,
        }
    }

    /// Sets [`Self::fit_iterations`].
    #[must_use]
    pub fn with_fit_iterations(mut self, iterations: u32) -> Self {
        self.fit_iterations = iterations;
        self
    }

    /// Sets [`Self::edge_swaps`].
    #[must_use]
    pub fn with_edge_swaps(mut self, swaps: bool) -> Self {
        self.edge_swaps = swaps;
        self
    }

    /// Sets [`Self::threads`] (`Some(n)` with `n ≥ 1`, or `None` for all cores).
    #[must_use]
    pub fn with_threads(mut self, threads: Option<usize>) -> Self {
        self.threads = threads;
        self
    }

    /// Sets [`Self::reshade_flat`].
    #[must_use]
    pub fn with_reshade_flat(mut self, on: bool) -> Self {
        self.reshade_flat = on;
        self
    }

    /// Sets [`Self::refit_attributes`].
    #[must_use]
    pub fn with_refit_attributes(mut self, refit: bool) -> Self {
        self.refit_attributes = refit;
        self
    }

    /// Sets [`Self::facing_repair`].
    #[must_use]
    pub fn with_facing_repair(mut self, repair: bool) -> Self {
        self.facing_repair = repair;
        self
    }

    /// Sets [`Self::method`].
    #[must_use]
    pub fn with_method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }
    /// Sets [`Self::ratio`].
    #[must_use]
    pub fn with_ratio(mut self, ratio: f64) -> Self {
        self.ratio = Some(ratio);
        self
    }
    /// Sets [`Self::target_triangles`].
    #[must_use]
    pub fn with_target_triangles(mut self, n: usize) -> Self {
        self.target_triangles = Some(n);
        self
    }
    /// Sets [`Self::max_error`].
    #[must_use]
    pub fn with_max_error(mut self, e: Distance) -> Self {
        self.max_error = Some(e);
        self
    }
    /// Sets [`Self::lock_boundary`].
    #[must_use]
    pub fn with_lock_boundary(mut self, lock: bool) -> Self {
        self.lock_boundary = lock;
        self
    }
    /// Sets [`Self::locked_vertices`].
    #[must_use]
    pub fn with_locked_vertices(mut self, mask: Vec<bool>) -> Self {
        self.locked_vertices = Some(mask);
        self
    }
    /// Sets [`Self::preserve_topology`].
    #[must_use]
    pub fn with_preserve_topology(mut self, preserve: bool) -> Self {
        self.preserve_topology = preserve;
        self
    }
    /// Sets [`Self::area_exponent`].
    #[must_use]
    pub fn with_area_exponent(mut self, alpha: f64) -> Self {
        self.area_exponent = alpha;
        self
    }
    /// Sets [`Self::solve_condition`].
    #[must_use]
    pub fn with_solve_condition(mut self, c: f64) -> Self {
        self.solve_condition = c;
        self
    }
    /// Sets [`Self::displacement_guard`].
    #[must_use]
    pub fn with_displacement_guard(mut self, lambda: f64) -> Self {
        self.displacement_guard = lambda;
        self
    }
    /// Sets [`Self::boundary_weight`].
    #[must_use]
    pub fn with_boundary_weight(mut self, w: f64) -> Self {
        self.boundary_weight = w;
        self
    }
    /// Sets [`Self::max_normal_deviation`] (degrees).
    #[must_use]
    pub fn with_max_normal_deviation(mut self, degrees: f64) -> Self {
        self.max_normal_deviation = Some(degrees);
        self
    }
    /// Sets [`Self::pair_threshold`].
    #[must_use]
    pub fn with_pair_threshold(mut self, t: Distance) -> Self {
        self.pair_threshold = Some(t);
        self
    }
    /// Sets [`Self::min_triangle_quality`].
    #[must_use]
    pub fn with_min_triangle_quality(mut self, q: f64) -> Self {
        self.min_triangle_quality = q;
        self
    }
    /// Sets [`Self::placement`].
    #[must_use]
    pub fn with_placement(mut self, p: Placement) -> Self {
        self.placement = p;
        self
    }
    /// Sets [`Self::cluster`].
    #[must_use]
    pub fn with_cluster(mut self, c: ClusterOptions) -> Self {
        self.cluster = c;
        self
    }
    /// Sets [`Self::feature_angle`] (degrees).
    #[must_use]
    pub fn with_feature_angle(mut self, degrees: f64) -> Self {
        self.feature_angle = degrees;
        self
    }
    /// Sets [`Self::keep_corners`].
    #[must_use]
    pub fn with_keep_corners(mut self, keep: bool) -> Self {
        self.keep_corners = keep;
        self
    }
    /// Sets [`Self::order_slack`].
    #[must_use]
    pub fn with_order_slack(mut self, slack: f64) -> Self {
        self.order_slack = slack;
        self
    }
    /// Sets [`Self::defer_neighbours`].
    #[must_use]
    pub fn with_defer_neighbours(mut self, factor: Option<f64>) -> Self {
        self.defer_neighbours = factor;
        self
    }
    /// [`Method::VertexRemoval`]: the exact order (cheapest removal first; no
    /// deferral, no slack: it resets [`Self::order_slack`], so call it before
    /// [`Self::with_order_slack`]). The default is the fast order
    /// ([`VertexRemovalOptions::with_fast_order`](crate::decimate::vertex_removal::VertexRemovalOptions::with_fast_order)).
    #[must_use]
    pub fn with_exact_order(mut self) -> Self {
        self.order_slack = crate::decimate::vertex_removal::DEFAULT_ORDER_SLACK;
        self.defer_neighbours = None;
        self.defer_below = None;
        self.defer_bound = false;
        self.defer_slack = None;
        self
    }
    /// Sets [`Self::defer_below`].
    #[must_use]
    pub fn with_defer_below(mut self, fraction: Option<f64>) -> Self {
        self.defer_below = fraction;
        self
    }
    /// Sets [`Self::defer_slack`].
    #[must_use]
    pub fn with_defer_slack(mut self, slack: Option<f64>) -> Self {
        self.defer_slack = slack;
        self
    }
    /// Sets [`Self::defer_bound`].
    #[must_use]
    pub fn with_defer_bound(mut self, bound: bool) -> Self {
        self.defer_bound = bound;
        self
    }

    /// The target triangle count for an input of `triangles` triangles.
    #[must_use]
    pub fn target_for(&self, triangles: usize) -> usize {
        let from_ratio = self
            .ratio
            .map(|r| ((triangles as f64) * r.clamp(0.0, 1.0)).round() as usize);
        match (from_ratio, self.target_triangles) {
            (Some(a), Some(b)) => a.max(b),
            (Some(a), None) => a,
            (None, Some(b)) => b,
            (None, None) if self.max_error.is_some() => 0,
            (None, None) => (triangles as f64 * 0.5).round() as usize,
        }
    }

    fn check(&self, vertices: usize) -> Result<(), SimplifyError> {
        let bad =
            |name: &'static str, message: String| Err(SimplifyError::Option { name, message });
        let aw = self.attribute_weights;
        for (what, w) in [("normal", aw.normal), ("uv", aw.uv), ("color", aw.color)] {
            if !(w >= 0.0 && w.is_finite()) {
                return bad(
                    "attribute_weights",
                    format!("the {what} weight {w} is not finite and non-negative"),
                );
            }
        }
        if let Some(r) = self.ratio {
            if !(0.0..=1.0).contains(&r) {
                return bad("ratio", format!("{r} is not in [0, 1]"));
            }
        }
        if let Some(e) = self.max_error {
            if !(e.value() >= 0.0 && e.value().is_finite()) {
                return bad(
                    "max_error",
                    format!("{} is not a finite non-negative distance", e.value()),
                );
            }
        }
        if self.method == Method::Cluster
            && self.max_error.is_some()
            && self.ratio.is_none()
            && self.target_triangles.is_none()
            && self.cluster.cell_size.is_none()
        {
            // The count would be 0 and the grid as coarse as that asks.
            return bad(
                "max_error",
                "vertex clustering does not stop at an error: give a cell size (every \
                 point moves at most its cell's diagonal), a ratio or a triangle count"
                    .to_string(),
            );
        }
        if self.threads == Some(0) {
            return bad("threads", "0 threads: give 1 or more".to_string());
        }
        if self.permissive && self.strict_seams {
            return bad(
                "strict_seams",
                "strict seams and permissive seams exclude each other".to_string(),
            );
        }
        if let Some(t) = self.pair_threshold {
            if !(t.value() >= 0.0 && t.value().is_finite()) {
                return bad(
                    "pair_threshold",
                    format!("{} is not a finite non-negative distance", t.value()),
                );
            }
        }
        if !(0.0..=2.0).contains(&self.area_exponent) {
            return bad(
                "area_exponent",
                format!("{} is not in [0, 2]", self.area_exponent),
            );
        }
        if !(self.displacement_guard >= 0.0 && self.displacement_guard.is_finite()) {
            return bad(
                "displacement_guard",
                format!("{} is not finite and non-negative", self.displacement_guard),
            );
        }
        if !(self.solve_condition >= 0.0 && self.solve_condition < 1.0) {
            return bad(
                "solve_condition",
                format!(
                    "{} is not in [0, 1) (det(A) / (tr(A)/3)³ is at most 1)",
                    self.solve_condition
                ),
            );
        }
        if !(self.boundary_weight >= 0.0 && self.boundary_weight.is_finite()) {
            return bad(
                "boundary_weight",
                format!("{} is not finite and non-negative", self.boundary_weight),
            );
        }
        if let Some(a) = self.max_normal_deviation {
            if !(0.0..=180.0).contains(&a) {
                return bad(
                    "max_normal_deviation",
                    format!("{a} is not in [0, 180] degrees"),
                );
            }
        }
        if !(0.0..=180.0).contains(&self.feature_angle) {
            return bad(
                "feature_angle",
                format!("{} is not in [0, 180] degrees", self.feature_angle),
            );
        }
        if !(0.0..=1.0).contains(&self.min_triangle_quality) {
            return bad(
                "min_triangle_quality",
                format!("{} is not in [0, 1]", self.min_triangle_quality),
            );
        }
        if let Some(m) = &self.locked_vertices {
            if m.len() != vertices {
                return Err(SimplifyError::LockMask {
                    len: m.len(),
                    vertices,
                });
            }
        }
        Ok(())
    }
}

/// Errors of [`simplify`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SimplifyError {
    /// The input mesh is invalid (index out of range, NaN/inf coordinate, …).
    #[error("invalid mesh: {0}")]
    Invalid(#[from] MeshError),
    /// An option is out of range.
    #[error("option {name}: {message}")]
    Option {
        /// The option's field name.
        name: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// The lock mask does not have one entry per vertex.
    #[error("lock mask has {len} entries for {vertices} vertices")]
    LockMask {
        /// Its length.
        len: usize,
        /// The vertex count.
        vertices: usize,
    },
}

/// What [`simplify`] did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// The method used (`"qem"`, `"vertex-removal"`).
    pub method: &'static str,
    /// Input triangles (before repair).
    pub triangles_in: usize,
    /// Input vertices.
    pub vertices_in: usize,
    /// The target triangle count that was aimed for.
    pub target_triangles: usize,
    /// Output triangles.
    pub triangles_out: usize,
    /// Output vertices (after compaction).
    pub vertices_out: usize,
    /// Largest collapse error, as a fraction of the bounding-box diagonal (see the
    /// module docs for what the distance is).
    pub error: f64,
    /// The same error in mesh units.
    pub error_absolute: f64,
    /// The input's bounding-box diagonal (mesh units).
    pub bbox_diagonal: f64,
    /// Why it stopped.
    pub stop_reason: StopReason,
    /// A sentence explaining the stop.
    pub stop_detail: String,
    /// Wall-clock seconds for the whole call (repair, simplification, output).
    pub seconds: f64,
    /// Collapses performed.
    pub collapses: usize,
    /// Non-edge pair contractions among them.
    pub non_edge_contractions: usize,
    /// Degenerate input triangles removed by the up-front repair.
    pub degenerate_removed: usize,
    /// Duplicate input triangles removed by the up-front repair.
    pub duplicate_removed: usize,
    /// Non-manifold points (on an edge of more than two triangles, or where
    /// several fans touch) of the input after the repair; `None` for clustering.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub non_manifold_points_in: Option<usize>,
    /// Non-manifold points of the output, by why they stayed (QEM slides the
    /// points inside a non-manifold chain along it; the corners of the chain
    /// network, chains on a border or seam, and pinches are kept); `None` for
    /// vertex removal and clustering.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub non_manifold_kept: Option<crate::collapse::NonManifoldPoints>,
    /// Rejected candidates by reason.
    pub rejections: Rejections,
    /// Full re-scans after the queue ran dry.
    pub rescans: usize,
    /// Retries of rejected pairs once the queue's cost had grown past theirs (QEM,
    /// Melax).
    pub retries: usize,
    /// Whether the soft triangle-quality guard was switched off to reach the target.
    pub soft_filters_relaxed: bool,
    /// Holes of three border edges closed by a collapse (only when
    /// [`SimplifyOptions::preserve_topology`] is `false`).
    pub holes_closed: usize,
    /// Separate parts removed whole (only when
    /// [`SimplifyOptions::preserve_topology`] is `false`).
    pub components_removed: usize,
    /// Diagonal swaps made by the orientation repair ([`SimplifyOptions::facing_repair`]).
    pub facing_flips: usize,
    /// Output triangles facing away from the input surface (normal opposite to the
    /// input triangle nearest their centroid) before the orientation repair, and
    /// after it; `None` when the repair did not run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub facing_away: Option<[usize; 2]>,
    /// Output points (distinct positions) the vertex fitting moved
    /// ([`SimplifyOptions::fit_iterations`]); 0 when it did not run.
    pub fit_moved: usize,
    /// Output vertices whose normals, texture coordinates or colours the attribute
    /// refit changed ([`SimplifyOptions::refit_attributes`]); 0 when it did not run.
    pub attributes_refit: usize,
    /// Diagonals swapped toward the input ([`SimplifyOptions::edge_swaps`]); 0 when
    /// the swaps did not run.
    pub edge_swaps: usize,
    /// Whether the input was flat shaded and its output re-shaded
    /// ([`SimplifyOptions::reshade_flat`]).
    pub flat_shading: bool,
    /// What vertex clustering did ([`Method::Cluster`] only), including the
    /// non-manifold edge and vertex counts of the result.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cluster: Option<ClusterStats>,
    /// Seconds of each step.
    pub phases: Phases,
}

/// Wall-clock seconds of each step of a run, so a long run shows where its time
/// went. They add up to about [`Report::seconds`] (validation and the flat-shading
/// merge are not counted in any step).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Phases {
    /// Building the surface: welding, spatial order, adjacency, the repair of
    /// degenerate and duplicate triangles.
    pub build: f64,
    /// Decimation: the cost model's set-up, the queue and the collapses or
    /// removals (for clustering: the whole clustering).
    pub decimate: f64,
    /// Writing the output mesh: compaction and attributes.
    pub output: f64,
    /// The passes after decimation: edge swaps, vertex fitting and the
    /// orientation repair (with their closest-point tree over the input).
    pub refine: f64,
}

/// The result of [`simplify_observed`]: the mesh, the report, and for every output
/// vertex the input vertex it descends from.
#[derive(Debug, Clone, PartialEq)]
pub struct Simplified {
    /// The simplified mesh.
    pub mesh: Mesh,
    /// What happened.
    pub report: Report,
    /// Output vertex `i` descends from input vertex `vertex_source[i]` (its
    /// attributes were interpolated if its position moved). With
    /// [`Method::Cluster`] it is the input vertex whose attributes the output vertex
    /// carries, and empty when streamed or when the input has no attributes (unless
    /// [`crate::decimate::cluster::ClusterOptions::vertex_sources`] asks for it).
    pub vertex_source: Vec<u32>,
}

/// Simplifies `mesh` as `options` say.
///
/// # Errors
/// [`SimplifyError::Invalid`] when the mesh does not validate, [`SimplifyError::Option`]
/// or [`SimplifyError::LockMask`] for bad options. Empty meshes and non-manifold
/// input are not errors.
pub fn simplify(mesh: &Mesh, options: &SimplifyOptions) -> Result<(Mesh, Report), SimplifyError> {
    let s = simplify_observed(mesh, options, &mut NoObserver)?;
    Ok((s.mesh, s.report))
}

/// Whether [`simplify_observed`] would hand `observer` every collapse it performs
/// ([`Observer::collapsed`], in order) for this mesh and these options: edge
/// collapses (QEM, Melax) on a mesh small enough to run whole. Clustering and
/// vertex removal do not collapse edges, and a mesh run in chunks
/// ([`SimplifyOptions::chunks`], from about a million triangles) reports only its
/// progress, since its chunks collapse at once on several threads.
#[must_use]
pub fn observes_collapses(mesh: &Mesh, options: &SimplifyOptions) -> bool {
    matches!(options.method, Method::Qem | Method::Melax) && !runs_in_chunks(mesh, options)
}

/// Whether [`simplify_observed`] would simplify this mesh in chunks
/// ([`SimplifyOptions::chunks`]: QEM on about a million triangles and more, on
/// every thread of [`SimplifyOptions::threads`]).
#[must_use]
pub fn runs_in_chunks(mesh: &Mesh, options: &SimplifyOptions) -> bool {
    options.method == Method::Qem && chunked::chunking(mesh, options).is_some()
}

/// [`simplify`] with an [`Observer`] (progress, collapse recording) and the vertex
/// provenance.
///
/// The steps: a flat-shaded input goes through `simplify_flat`, clustering
/// through [`cluster_mesh`]; otherwise the surface is built, decimated
/// (`decimate`), written out (`build_output`) and refined (`refine`: the vertex
/// fitting and the orientation repair).
///
/// # Errors
/// As [`simplify`].
pub fn simplify_observed(
    mesh: &Mesh,
    options: &SimplifyOptions,
    observer: &mut dyn Observer,
) -> Result<Simplified, SimplifyError> {
    let start = Instant::now();
    mesh.validate()?;
    options.check(mesh.positions.len())?;
    if let Some(flat) = options
        .reshade_flat
        .then(|| flat::FlatShading::detect(mesh))
        .flatten()
    {
        return simplify_flat(mesh, &flat, options, observer, start);
    }
    if options.method == Method::Cluster {
        let target = options.target_for(mesh.triangles.len());
        let c = cluster_mesh(mesh, Some(target), &options.cluster).map_err(|e| {
            SimplifyError::Option {
                name: "cluster",
                message: e.to_string(),
            }
        })?;
        return Ok(cluster_result(c, options, target, start));
    }
    if let Some(chunk_triangles) = chunked::chunking(mesh, options) {
        return chunked::simplify_chunked(mesh, options, chunk_triangles, observer, start);
    }
    let fit_possible = (options.fit_iterations > 0 || options.edge_swaps)
        && options.method == Method::Qem
        && options.placement != Placement::Endpoint;
    let target = options.target_for(mesh.triangles.len());
    let d = decimate_mesh(mesh, options, target, None, fit_possible, observer);
    let passes = Passes {
        facing: options.facing_repair
            && d.outcome.collapses > 0
            && matches!(options.method, Method::Qem | Method::Melax),
        fit: fit_possible && d.outcome.collapses > 0,
    };
    let Decimated {
        mut out,
        mut vertex_source,
        merged_into,
        outcome,
        repair,
        diag,
        mut phases,
        census,
    } = d;
    let t_refine = Instant::now();
    let (fitted, facing) = refine(
        mesh,
        options,
        &mut out,
        &vertex_source,
        merged_into.as_deref(),
        passes,
        diag,
    );
    let refit = refit_output(
        mesh,
        options,
        &mut out,
        &mut vertex_source,
        outcome.collapses,
    );
    phases.refine = t_refine.elapsed().as_secs_f64();
    let mut report = assemble_report(
        mesh, options, target, &out, outcome, &repair, diag, fitted, facing, phases, start, census,
    );
    report.attributes_refit = refit.0;
    Ok(Simplified {
        mesh: out,
        report,
        vertex_source,
    })
}

/// The attribute refit of `out` against `mesh` ([`SimplifyOptions::refit_attributes`])
/// where it applies: QEM that collapsed something, an output with attributes, not
/// endpoint placement (no vertex changes there, attributes included: what a
/// progressive mesh's vertex splits restore). Output vertices descending from a
/// locked input vertex keep their values. Vertices copied to split a crossed crease
/// are appended to `out` and to `vertex_source` (their source's source). Returns the
/// vertices changed and, for each copy in order, the vertex it copies.
pub(crate) fn refit_output(
    mesh: &Mesh,
    options: &SimplifyOptions,
    out: &mut Mesh,
    vertex_source: &mut Vec<u32>,
    collapses: usize,
) -> (usize, Vec<u32>) {
    if !options.refit_attributes
        || options.method != Method::Qem
        || options.placement == Placement::Endpoint
        || collapses == 0
        || out.attributes.is_empty()
    {
        return (0, Vec::new());
    }
    let locked: Vec<bool> = match &options.locked_vertices {
        Some(l) => vertex_source.iter().map(|&s| l[s as usize]).collect(),
        None => Vec::new(),
    };
    let (changed, copies) = refit::refit_attributes(mesh, out, &locked);
    let more: Vec<u32> = copies.iter().map(|&c| vertex_source[c as usize]).collect();
    vertex_source.extend(more);
    debug_assert_eq!(vertex_source.len(), out.positions.len());
    (changed, copies)
}

/// The [`Report`] of an edge-collapse or vertex-removal run of `mesh` to `out`.
#[allow(clippy::too_many_arguments)]
fn assemble_report(
    mesh: &Mesh,
    options: &SimplifyOptions,
    target: usize,
    out: &Mesh,
    outcome: Outcome,
    repair: &crate::collapse::Repair,
    diag: f64,
    fitted: fit::FitStats,
    facing: Option<facing::FacingRepair>,
    phases: Phases,
    start: Instant,
    census: Option<Census>,
) -> Report {
    Report {
        method: options.method.name(),
        triangles_in: mesh.triangles.len(),
        vertices_in: mesh.positions.len(),
        target_triangles: target,
        triangles_out: out.triangles.len(),
        vertices_out: out.positions.len(),
        error: if diag > 0.0 {
            outcome.max_error / diag
        } else {
            0.0
        },
        error_absolute: outcome.max_error,
        bbox_diagonal: diag,
        stop_reason: outcome.stop_reason,
        stop_detail: outcome.stop_detail,
        seconds: start.elapsed().as_secs_f64(),
        collapses: outcome.collapses,
        non_edge_contractions: outcome.non_edge_contractions,
        degenerate_removed: repair.degenerate_triangles,
        duplicate_removed: repair.duplicate_triangles,
        non_manifold_points_in: census.map(|c| c.0),
        non_manifold_kept: census.and_then(|c| c.1),
        rejections: outcome.rejections,
        rescans: outcome.rescans,
        retries: outcome.retries,
        soft_filters_relaxed: outcome.soft_filters_relaxed,
        holes_closed: outcome.holes_closed,
        components_removed: outcome.components_removed,
        facing_flips: facing.map_or(0, |f| f.flips),
        facing_away: facing.map(|f| [f.before, f.after]),
        fit_moved: fitted.moved,
        attributes_refit: 0,
        edge_swaps: fitted.swaps,
        flat_shading: false,
        cluster: None,
        phases,
    }
}

/// What [`decimate_mesh`] leaves: the decimated mesh before the passes after
/// decimation, with what they and the report need.
struct Decimated {
    /// The output mesh.
    out: Mesh,
    /// Per output vertex, the input vertex it descends from.
    vertex_source: Vec<u32>,
    /// Per input vertex, the output vertex it was merged into (when tracked).
    merged_into: Option<Vec<u32>>,
    /// What the decimation did.
    outcome: Outcome,
    /// What the up-front repair removed.
    repair: crate::collapse::Repair,
    /// The input's bounding-box diagonal.
    diag: f64,
    /// Seconds of the build, decimation and output steps (`refine` left 0).
    phases: Phases,
    /// Non-manifold points of the repaired input, and those of the output by
    /// reason (edge-collapse methods).
    census: Option<Census>,
}

/// [`Report::non_manifold_points_in`] and [`Report::non_manifold_kept`].
pub(crate) type Census = (usize, Option<crate::collapse::NonManifoldPoints>);

/// A piece of a larger mesh ([`chunked`]): its costs are scaled by the whole
/// mesh's bounding-box diagonal, so that one cost bound means the same in every
/// piece, and its run stops above `max_cost` ([`StopRule::max_cost`]).
#[derive(Debug, Clone, Copy)]
struct Piece {
    /// The whole mesh's bounding-box diagonal (mesh units).
    diagonal: f64,
    /// The cost bound, if any.
    max_cost: Option<f64>,
}

/// Builds the surface of `mesh`, decimates it toward `target` triangles with the
/// method of `options` and writes the output mesh (tracking, when `track_merges`,
/// which output vertex each input vertex was merged into, for the fitting).
fn decimate_mesh(
    mesh: &Mesh,
    options: &SimplifyOptions,
    target: usize,
    piece: Option<Piece>,
    track_merges: bool,
    observer: &mut dyn Observer,
) -> Decimated {
    let t_build = Instant::now();
    let (mut surface, repair) = Surface::build(
        mesh,
        &BuildOptions {
            // The edge-collapse loop's memory walks follow the one-ring; vertex
            // removal keeps the input's numbering (its measured outputs).
            spatial_order: matches!(options.method, Method::Qem | Method::Melax),
            track_merges,
            ..options.build_options()
        },
    );
    if let Some(p) = &piece {
        surface.set_diagonal(p.diagonal);
    }
    let diag = surface.diagonal();
    let nm_in = surface.non_manifold_census().total;
    let t_decimate = Instant::now();
    let stop = StopRule {
        target_triangles: target,
        max_error: options.max_error.map(|e| e.resolve(diag)),
        max_cost: piece.and_then(|p| p.max_cost),
    };
    let mut models = Models::new(options);
    let (outcome, triangles) = decimate(&mut surface, options, stop, &mut models, observer);
    let kept = matches!(options.method, Method::Qem | Method::Melax)
        .then(|| surface.non_manifold_census());
    let t_output = Instant::now();
    let roots = if track_merges {
        surface.vertex_roots()
    } else {
        None
    };
    let (out, vertex_source, point_out) =
        build_output(mesh, triangles, &mut surface, roots.is_some());
    // For each input vertex, the output vertex it was merged into.
    let merged_into: Option<Vec<u32>> = roots.map(|r| {
        r.iter()
            .map(|&p| point_out.get(p as usize).copied().unwrap_or(u32::MAX))
            .collect()
    });
    // The simplifier's structures go before any closest-point tree is built.
    drop(surface);
    Decimated {
        out,
        vertex_source,
        merged_into,
        outcome,
        repair,
        diag,
        phases: Phases {
            build: (t_decimate - t_build).as_secs_f64(),
            decimate: (t_output - t_decimate).as_secs_f64(),
            output: t_output.elapsed().as_secs_f64(),
            refine: 0.0,
        },
        census: Some((nm_in, kept)),
    }
}

/// A flat-shaded input (`flat`): simplified without its normals, the vertices they
/// alone split made one, and the output re-shaded with its own facet normals.
fn simplify_flat(
    mesh: &Mesh,
    flat: &flat::FlatShading,
    options: &SimplifyOptions,
    observer: &mut dyn Observer,
    start: Instant,
) -> Result<Simplified, SimplifyError> {
    let mut inner = options.clone().with_reshade_flat(false);
    if let Some(l) = options.locked_vertices.as_deref() {
        inner.locked_vertices = Some(flat.merged_mask(l));
    }
    let s = simplify_observed(&flat.merged, &inner, observer)?;
    let (out, vertex_source) = flat.reshade(mesh, s.mesh, &s.vertex_source);
    let mut report = s.report;
    report.vertices_in = mesh.positions.len();
    report.vertices_out = out.positions.len();
    report.flat_shading = true;
    report.seconds = start.elapsed().as_secs_f64();
    Ok(Simplified {
        mesh: out,
        report,
        vertex_source,
    })
}

/// The edge-collapse cost models of a run, kept between runs over the same surface
/// by [`levels`] (QEM's quadrics then carry over).
struct Models {
    qem: Qem,
    melax: Melax,
}

impl Models {
    fn new(options: &SimplifyOptions) -> Self {
        let qo = QemOptions {
            boundary_weight: options.boundary_weight,
            area_exponent: options.area_exponent,
            placement: options.placement,
            condition: options.solve_condition,
            displacement_guard: options.displacement_guard,
            attribute_weights: options.attribute_weights,
            seam_crossing_penalty: if options.permissive {
                1.0
            } else {
                QemOptions::default().seam_crossing_penalty
            },
            ..QemOptions::default()
        };
        Self {
            qem: Qem::new(qo),
            melax: Melax::default(),
        }
    }
}

/// Decimates `surface` until `stop` with the method of `options` (edge collapse
/// with the QEM or Melax cost of `models` and the filters the options ask for, or
/// vertex removal); returns what happened and the surviving triangles.
fn decimate(
    surface: &mut Surface,
    options: &SimplifyOptions,
    stop: StopRule,
    models: &mut Models,
    observer: &mut dyn Observer,
) -> (Outcome, TriangleLists) {
    let diag = surface.diagonal();
    let allow_non_edge = !options.preserve_topology && options.pair_threshold.is_some();
    let extra_pairs = match options.pair_threshold {
        Some(t) if allow_non_edge => close_pairs(surface, t.resolve(diag)),
        _ => Vec::new(),
    };
    let driver_options = EdgeCollapseOptions {
        limits: OperatorLimits {
            allow_non_edge,
            close_holes: !options.preserve_topology,
            ..OperatorLimits::default()
        },
        stop,
        extra_pairs,
        prune_parts: !options.preserve_topology,
    };
    let normal = options.max_normal_deviation.map(NormalDeviation::new);
    let aspect = (options.min_triangle_quality > 0.0).then_some(AspectRatio {
        min_quality: options.min_triangle_quality,
    });
    let lock = options.lock_boundary.then_some(LockBoundary);
    let mut filters: Vec<&dyn Filter> = Vec::new();
    if let Some(f) = &lock {
        filters.push(f);
    }
    if let Some(f) = &normal {
        filters.push(f);
    }
    if let Some(f) = &aspect {
        filters.push(f);
    }
    match options.method {
        Method::Cluster => unreachable!("clustering does not decimate a surface"),
        Method::Qem => {
            let outcome = edge_collapse::run(
                surface,
                &mut models.qem,
                &filters,
                &driver_options,
                observer,
            );
            (outcome, surface.output_triangles())
        }
        Method::VertexRemoval => {
            let mut vr = VertexRemoval::new(
                surface,
                VertexRemovalOptions {
                    feature_angle: options.feature_angle,
                    keep_corners: options.keep_corners,
                    order_slack: options.order_slack,
                    defer_neighbours: options.defer_neighbours,
                    defer_below: options.defer_below,
                    defer_bound: options.defer_bound,
                    defer_slack: options.defer_slack,
                    lock_boundary: options.lock_boundary,
                    stop: driver_options.stop,
                },
            );
            let outcome = vr.run(observer);
            (outcome, vr.output_triangles())
        }
        Method::Melax => {
            let outcome = edge_collapse::run(
                surface,
                &mut models.melax,
                &filters,
                &driver_options,
                observer,
            );
            (outcome, surface.output_triangles())
        }
    }
}

/// Which of the passes after decimation run.
#[derive(Debug, Clone, Copy)]
pub(super) struct Passes {
    /// The vertex fitting and edge swaps ([`fit`]).
    fit: bool,
    /// The orientation repair ([`facing`]).
    facing: bool,
}

/// The passes after decimation on the output `out` of `mesh` (`vertex_source`: the
/// input vertex of each output vertex; `merged_into`: the output vertex each input
/// vertex was merged into, when tracked; `diag`: the input's diagonal): the vertex
/// fitting, then the orientation repair, sharing one closest-point tree over the
/// input. Returns what each did (the repair's `None` when it did not run).
fn refine(
    mesh: &Mesh,
    options: &SimplifyOptions,
    out: &mut Mesh,
    vertex_source: &[u32],
    merged_into: Option<&[u32]>,
    passes: Passes,
    diag: f64,
) -> (fit::FitStats, Option<facing::FacingRepair>) {
    let tree =
        (passes.facing || passes.fit).then(|| Bvh::build_morton(&mesh.positions, &mesh.triangles));
    refine_with(
        mesh,
        options,
        out,
        vertex_source,
        merged_into,
        passes,
        diag,
        tree.as_ref(),
    )
}

/// [`refine`] with the closest-point tree over `mesh` given (`None` when neither
/// pass runs).
#[allow(clippy::too_many_arguments)]
pub(super) fn refine_with(
    mesh: &Mesh,
    options: &SimplifyOptions,
    out: &mut Mesh,
    vertex_source: &[u32],
    merged_into: Option<&[u32]>,
    passes: Passes,
    diag: f64,
    tree: Option<&Bvh>,
) -> (fit::FitStats, Option<facing::FacingRepair>) {
    let Passes {
        fit: fit_on,
        facing: facing_on,
    } = passes;
    let fitted = match tree {
        Some(tree) if fit_on => {
            let locked_out =
                locked_outputs(options, out.positions.len(), vertex_source, merged_into);
            let fixed = |v: usize| locked_out[v];
            // The repair's query starts (for the triangles as the swaps leave them),
            // so that it can reuse the fit's answers.
            let starts = |m: &Mesh| facing::query_starts(mesh, m, vertex_source);
            fit::fit(
                mesh,
                tree,
                out,
                &fixed,
                fit::FitParams {
                    swaps: options.edge_swaps,
                    ..fit::FitParams::new(options.fit_iterations, options.min_triangle_quality)
                },
                merged_into,
                facing_on.then_some(&starts as &fit::StartsOf<'_>),
            )
        }
        _ => (fit::FitStats::default(), Vec::new()),
    };
    let (fitted, known) = fitted;
    let facing = match tree {
        Some(tree) if facing_on => {
            // On `threads` threads (rayon's global pool, all cores, when `None` or
            // when a pool cannot be started); on this one, with no pool to start,
            // for one thread or one run of the scan (the cluster hierarchy
            // simplifies thousands of groups, each on one thread).
            let parallel = options.threads != Some(1) && out.triangles.len() > facing::SCAN_RUN;
            let mut repair = || {
                let known = Some(&known);
                facing::repair(mesh, tree, out, diag, Some(vertex_source), known, parallel)
            };
            Some(match thread_pool(options.threads.filter(|_| parallel)) {
                Ok(Some(pool)) => pool.install(repair),
                _ => repair(),
            })
        }
        _ => None,
    };
    (fitted, facing)
}

/// The thread pool of `threads` threads (`None`: rayon's global pool, all cores).
pub(super) fn thread_pool(
    threads: Option<usize>,
) -> Result<Option<rayon::ThreadPool>, SimplifyError> {
    threads
        .map(|t| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| SimplifyError::Option {
                    name: "threads",
                    message: format!("cannot start {t} threads: {e}"),
                })
        })
        .transpose()
}

/// Output vertices (`n` of them) at a locked input vertex's point: the one
/// descending from it, and the one it was "merged" into (itself, never moved; this
/// also covers a locked duplicate of another input vertex).
fn locked_outputs(
    options: &SimplifyOptions,
    n: usize,
    vertex_source: &[u32],
    merged_into: Option<&[u32]>,
) -> Vec<bool> {
    let mut locked_out = vec![false; n];
    if let Some(l) = options.locked_vertices.as_deref() {
        for (v, &s) in vertex_source.iter().enumerate() {
            locked_out[v] = l.get(s as usize).copied().unwrap_or(false);
        }
        if let Some(m) = merged_into {
            for (i, _) in l.iter().enumerate().filter(|(_, &b)| b) {
                if let Some(slot) = m.get(i).and_then(|&o| locked_out.get_mut(o as usize)) {
                    *slot = true;
                }
            }
        }
    }
    locked_out
}

/// [`Method::Cluster`] on a file streamed twice instead of a mesh in memory
/// ([`crate::decimate::cluster::cluster_file`]): memory proportional to the occupied
/// cells (plus 12 bytes per vertex for PLY and OBJ), no attributes carried.
/// `options.method` must be [`Method::Cluster`].
///
/// # Errors
/// [`ClusterError`]: the file cannot be read or streamed (naming the file and place),
/// or an option is out of range.
pub fn simplify_stream(
    path: impl AsRef<std::path::Path>,
    options: &SimplifyOptions,
) -> Result<Simplified, ClusterError> {
    let start = Instant::now();
    if options.method != Method::Cluster {
        return Err(ClusterError::Option(format!(
            "only the cluster method can stream, not {}",
            options.method.name()
        )));
    }
    options
        .check(0)
        .map_err(|e| ClusterError::Option(e.to_string()))?;
    let mut target = 0;
    let c = cluster_file(
        path.as_ref(),
        |n| {
            target = options.target_for(n);
            Some(target)
        },
        &options.cluster,
    )?;
    Ok(cluster_result(c, options, target, start))
}

fn cluster_result(
    c: Clustered,
    options: &SimplifyOptions,
    target: usize,
    start: Instant,
) -> Simplified {
    let st = &c.stats;
    let out_n = c.mesh.triangles.len();
    let diag = c.bbox_diagonal;
    let (stop_reason, stop_detail, target) = if c.triangles_in == 0 {
        (
            StopReason::EmptyInput,
            "the input has no triangles".to_string(),
            0,
        )
    } else if options.cluster.cell_size.is_some() {
        (
            StopReason::TargetReached,
            format!(
                "clustered on a {}×{}×{} grid of cells of side {:.6e} (given)",
                st.grid[0], st.grid[1], st.grid[2], st.cell_size
            ),
            out_n,
        )
    } else if (out_n as f64 - target as f64).abs() <= options.cluster.tolerance * target as f64 {
        (
            StopReason::TargetReached,
            format!(
                "{out_n} triangles, within {}% of the target {target}: cells of side {:.6e} ({} counting passes, {} builds)",
                100.0 * options.cluster.tolerance,
                st.cell_size,
                st.search_passes,
                st.builds
            ),
            target,
        )
    } else {
        (
            StopReason::NoLegalCollapse,
            format!(
                "no grid gives {target} triangles within {}%: the closest found gives {out_n} (cells of side {:.6e})",
                100.0 * options.cluster.tolerance,
                st.cell_size
            ),
            target,
        )
    };
    let report = Report {
        method: Method::Cluster.name(),
        triangles_in: c.triangles_in,
        vertices_in: c.vertices_in,
        target_triangles: target,
        triangles_out: out_n,
        vertices_out: c.mesh.positions.len(),
        error: if diag > 0.0 { st.max_error / diag } else { 0.0 },
        error_absolute: st.max_error,
        bbox_diagonal: diag,
        stop_reason,
        stop_detail,
        seconds: start.elapsed().as_secs_f64(),
        collapses: 0,
        non_edge_contractions: 0,
        degenerate_removed: 0,
        duplicate_removed: 0,
        non_manifold_points_in: None,
        non_manifold_kept: None,
        rejections: Rejections::default(),
        rescans: 0,
        retries: 0,
        soft_filters_relaxed: false,
        holes_closed: 0,
        components_removed: 0,
        facing_flips: 0,
        facing_away: None,
        fit_moved: 0,
        attributes_refit: 0,
        edge_swaps: 0,
        flat_shading: false,
        cluster: Some(c.stats),
        phases: Phases {
            decimate: start.elapsed().as_secs_f64(),
            ..Phases::default()
        },
    };
    Simplified {
        mesh: c.mesh,
        report,
        vertex_source: c.vertex_source,
    }
}

/// The surviving triangles over a compacted vertex buffer in first-use order, the
/// input vertex each output vertex descends from, and (when `want_point_out`) for
/// each surface point the first output vertex at it (`u32::MAX` for none; empty
/// otherwise).
fn build_output(
    mesh: &Mesh,
    lists: TriangleLists,
    surface: &mut Surface,
    want_point_out: bool,
) -> (Mesh, Vec<u32>, Vec<u32>) {
    let (out, source, point_out) = output_of(mesh, lists, surface, want_point_out, false);
    (out, source, point_out)
}

/// [`build_output`], leaving the surface's attribute streams in place when `keep`
/// (a copy is gathered; the surface can go on collapsing).
fn output_of(
    mesh: &Mesh,
    (wedges, points, groups): TriangleLists,
    surface: &mut Surface,
    want_point_out: bool,
    keep: bool,
) -> (Mesh, Vec<u32>, Vec<u32>) {
    let mut remap = vec![u32::MAX; mesh.positions.len()];
    let mut point_out = if want_point_out {
        vec![u32::MAX; surface.point_count()]
    } else {
        Vec::new()
    };
    let mut source = Vec::new();
    let mut positions = Vec::new();
    let mut triangles = Vec::with_capacity(wedges.len());
    for (w, p) in wedges.iter().zip(points.iter()) {
        let mut t = [0u32; 3];
        for k in 0..3 {
            let r = &mut remap[w[k] as usize];
            if *r == u32::MAX {
                *r = source.len() as u32;
                source.push(w[k]);
                positions.push(surface.position(p[k]));
            }
            t[k] = *r;
            if let Some(o) = point_out.get_mut(p[k] as usize) {
                if *o == u32::MAX {
                    *o = *r;
                }
            }
        }
        triangles.push(t);
    }
    let attributes = if keep {
        surface.attributes().gather(&source)
    } else {
        surface.take_attributes().gather(&source)
    };
    (
        Mesh {
            positions,
            triangles,
            attributes,
            groups,
            group_names: mesh.group_names.clone(),
        },
        source,
        point_out,
    )
}

/// Pairs of live points closer than `t` that share no edge, found with a uniform
/// grid of cell size `t` (points sorted by cell; each point looks at the 27 cells
/// around it). At most the 8 nearest partners per point are kept, so a dense
/// cluster cannot make this quadratic.
fn close_pairs(surface: &mut Surface, t: f64) -> Vec<[u32; 2]> {
    if t.is_nan() || t <= 0.0 {
        return Vec::new();
    }
    let n = surface.point_count() as u32;
    let cell = |p: [f32; 3]| -> [i64; 3] {
        p.map(|x| (f64::from(x) / t).floor().clamp(-1e15, 1e15) as i64)
    };
    let mut order: Vec<([i64; 3], u32)> = (0..n)
        .filter(|&p| surface.is_alive(p))
        .map(|p| (cell(surface.position(p)), p))
        .collect();
    order.sort_unstable();
    let mut pairs = Vec::new();
    let mut near: Vec<(f64, u32)> = Vec::new();
    let mut nb = Vec::new();
    let t2 = t * t;
    for &(c, p) in &order {
        near.clear();
        let pp = surface.position(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = [c[0] + dx, c[1] + dy, c[2] + dz];
                    let lo = order.partition_point(|e| e.0 < key);
                    for &(k, q) in &order[lo..] {
                        if k != key {
                            break;
                        }
                        if q <= p {
                            continue;
                        }
                        let qq = surface.position(q);
                        let d2: f64 = (0..3)
                            .map(|i| {
                                let d = f64::from(pp[i]) - f64::from(qq[i]);
                                d * d
                            })
                            .sum();
                        if d2 < t2 {
                            near.push((d2, q));
                        }
                    }
                }
            }
        }
        if near.is_empty() {
            continue;
        }
        near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        surface.neighbours(p, &mut nb);
        let mut kept = 0;
        for &(_, q) in near.iter() {
            if kept == 8 {
                break;
            }
            if !nb.contains(&q) {
                pairs.push([p, q]);
                kept += 1;
            }
        }
    }
    pairs
}

mod chunked;
mod facing;
mod fit;
mod flat;
mod levels;
mod refit;
pub use fit::DEFAULT_FIT_ITERATIONS;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_non_manifold;
#[cfg(test)]
pub(crate) mod tests_topology;
#[cfg(test)]
mod tests_vertex_removal;
