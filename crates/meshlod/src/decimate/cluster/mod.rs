//! Vertex clustering: O(n) simplification for huge meshes, in memory or streamed.
//!
//! Follows Rossignac & Borrel, *Multi-resolution 3D approximations for rendering
//! complex scenes* (1993) for the method, and Lindstrom, *Out-of-core simplification
//! of large polygonal models* (SIGGRAPH 2000) for the quadric representative and the
//! streaming (triangle-soup, one pass) formulation:
//!
//! 1. a uniform grid of cubic cells of side ε covers the bounding box (of all
//!    vertices); along every axis the box spans at least 8 cells on, the grid is
//!    centred so that the box's faces lie a quarter to three quarters into their
//!    outer cells (the mesh's extreme parts near the middle of a cell, where its
//!    representative is), along coarser axes it starts at the box's minimum
//!    ([`Grid::new`]);
//! 2. every vertex goes to its cell; all vertices of a cell become the cell's
//!    *representative*;
//! 3. a triangle whose three corners fall in three different cells becomes a
//!    triangle over their representatives; the others collapse to an edge or a point
//!    and are dropped (counted in [`ClusterStats::collapsed_triangles`]); two cells
//!    are connected when some input edge joined their vertices;
//! 4. clean-up: copies of a triangle over the same three representatives (any order
//!    or winding) are dropped, keeping the first in input order; triangles whose
//!    representatives coincide or are exactly collinear are dropped. The result has
//!    no degenerate or duplicate triangles, but **may be non-manifold** (a thin part
//!    collapses to a sheet, an edge or a point): [`ClusterStats`] counts the
//!    non-manifold edges and vertices of the output.
//!
//! # Representatives ([`Representative`])
//! Every cell sums, over the corners of triangles that fall in it, a weighted
//! position `Σ wᵢ pᵢ` and `Σ wᵢ`; and, for the quadric representative, the
//! area-weighted plane quadric of every triangle touching the cell (once per cell the
//! triangle touches, also when all three corners share the cell: that triangle is
//! dropped but its plane still shapes the representative). The sums are per
//! **triangle corner**, so a vertex counts once per triangle using it; this is what
//! a streamed triangle soup can compute, and the in-memory path computes exactly the
//! same thing. Each triangle's quadric is computed once, in the grid's frame (origin
//! at the grid's minimum corner), and moved to the cell's frame before solving; a
//! corner weight of zero counts as 10⁻¹⁵⁰, so a cell of zero-area corners gets their
//! plain mean. A cell's record is 120 bytes (15 f64).
//! - [`Representative::Average`]: `wᵢ = 1`, the mean of the corners.
//! - [`Representative::Weighted`]: `wᵢ = Aₜ/3 · f(v)`, the triangle's area share times
//!   a per-vertex factor from [`ClusterWeights`]: 1, a feature measure, or a user
//!   stream.
//! - [`Representative::Quadric`] (default, Lindstrom 2000): the minimiser of the
//!   cell's quadric, solved around the area-weighted mean; when the 3×3 system is
//!   ill-conditioned or the solution leaves the cell, the minimiser of the quadric
//!   plus `λ‖x − mean‖²` with `λ = 3·10⁻³·tr(A)` (Tikhonov regularisation toward the
//!   mean: one positive definite 3×3 solve by cofactors), clamped into the cell.
//!   Along an eigenvector of `A` with eigenvalue `l` it takes `l/(l + λ)` of the
//!   full step, so flat directions stay at the mean: the smooth form of Lindstrom's
//!   pseudo-inverse rule (eigenvalues below 10⁻³ of the largest dropped), without
//!   an eigendecomposition.
//!
//! Every representative lies in its cell, so no vertex moves farther than the cell
//! diagonal `ε√3`.
//!
//! # Error reported
//! For the quadric representative, [`ClusterStats::max_error`] is the largest
//! area-weighted RMS distance from a representative to the planes of the triangles of
//! its cell ([`crate::quadric::Quadric::distance`], as for QEM); for the others it is
//! the cell diagonal `ε√3`, the bound on how far a vertex moved.
//!
//! # Attributes and groups
//! Each output vertex takes the attributes (normals, UVs, colours, …) of the input
//! vertex of its cell closest to the representative (ties: the lowest index). Where a
//! UV or normal seam crosses a cell, the triangles on both sides share that one
//! vertex's attributes, so a texture seam may smear by up to a cell: clustering is a
//! sloppy method; use QEM for textured assets. Each output triangle keeps the group
//! (material) of the first input triangle that produced it. That source vertex is
//! [`Clustered::vertex_source`]; an input without attributes has nothing to carry,
//! so it is not computed unless [`ClusterOptions::vertex_sources`] asks for it (it
//! costs marking the vertices triangles use and a pass over the input's vertices,
//! about a tenth of a call at 10% of the triangles).
//!
//! # Target triangle count
//! With a target instead of a cell size, ε is searched. Each probe is one pass: the
//! cell key of every vertex, then the triangles with three distinct cells, copies
//! over the same three cells counted once: the exact count of the first clean-up
//! stage. On the sequential in-memory path (grids of at most 2³² cells, inputs
//! below 2¹⁸ triangles or one thread) the set holds the sorted cell triples
//! themselves and the first triangle over each triple is recorded, which is the
//! first stage when the build is on the probe's grid; otherwise (the parallel path,
//! streaming) it holds 64-bit hashes of them (exact up to collisions, about
//! `n²/2⁶⁵`: about 2·10⁻⁷ for 3M kept triangles; a collision would lower a probe's
//! count by one on that path only). Above 2¹⁶ triples, either is deduplicated by
//! partition (a stable counting sort by hash into cache-sized buckets, the same
//! result); after a parallel probe, the first stage keeps the first triangle over
//! each triple by the same partitioned pass. ε starts from the projected area `P` (the areas of the
//! triangles' projections on the three coordinate planes, estimated on at most 8192
//! triangles): a surface meets about `P/ε²` cells whatever its orientation, and the
//! probe count is about `1.74·P/ε²` on the shared test meshes (1.55–1.87), times
//! `Π (dₖ / (tₖ + ½))^⅔` for the grid's `dₖ` cells over the box's extent of `tₖ`
//! cells per axis (a grid placed anywhere has `t + ½` on average; the centred grid
//! jumps from `n + 1` to `n + 2` cells when the fraction passes ½, the count by up to
//! 9%). The first guess is the ε within ±8% of `√(1.74·P/goal)` where this model
//! is closest to the goal, so it avoids the wrong side of a jump; the first probe
//! then lands within 4.5% on the shared meshes. While all probes lie on one side of
//! the goal the next is the same model scaled to the nearest probe's count; then ε
//! moves by secant steps on `log count`
//! against `log ε` inside the bracket of all probes so far (the count falls roughly
//! as ε⁻²); where the bracket's two sides differ in cells per axis (the count jumps
//! there on coarse grids), the smallest ε with the coarse side's cells is probed
//! first. On coarse grids (an axis of fewer than 8 cells), while every probe is
//! short, the search stays above the finest ε with the probe's cells per axis when
//! the count ∝ ε⁻² reaches the band there. Where a probe's count is the first
//! stage's (in memory, or streamed with every triangle in the sample) probes stop
//! from `0.9·tolerance` below the goal to `tolerance` above it (the second clean-up
//! only removes triangles, and few); on a partial sample (an estimate) within
//! `min(0.4·tolerance, 2%)`, or within `0.8·tolerance` after six probes; after
//! sixteen at most.
//! The first stage (cell ids, distinct triangles) then gives the count exactly (in
//! memory it only visits the last probe's triangles with three distinct cells when
//! that probe was on the same grid); when
//! it misses the target by more than half the tolerance (a streamed sample counts
//! duplicates less well) the goal is rescaled by probe / stage count and the search
//! resumes from its earlier probes (at most three first stages, the closest is
//! built). Coinciding representatives can still remove a few triangles after that.
//!
//! # Coverage repair
//! A part thinner than a cell can have all its triangles collapse and vanish
//! although its cells are occupied (Lucy's torch at 1%: 9.4% of the diagonal instead
//! of about 3%). After the clean-up, every occupied cell without an output vertex
//! that is two or more 26-neighbour steps from the output's cells gets one triangle
//! over itself and its two predecessors toward them (a sliver along the part;
//! `coverage`). A neighbouring orphan whose representative is more than 0.55 cells
//! from every covered neighbour's (a tip just over a cell border) gets one toward
//! the two nearest, at most one per 256 output triangles. Both are counted in
//! [`ClusterStats::coverage_triangles`]. The repair does
//! not look at the target, so those few triangles come on top of the count.
//!
//! # Tables
//! In memory, a vertex's cell is its linear index `(i·ny + j)·nz + k` as a `u32`
//! while the grid has at most 2³² cells (the probes gather 4 bytes per corner, and
//! the index is the flat table's slot), else its packed key `i·2⁴² + j·2²¹ + k`.
//! Cell ids come from a flat array over the grid when the grid is small (in memory:
//! at most eight grid cells per vertex; streamed: sixteen per expected occupied
//! cell, so memory stays proportional to the occupied cells), from open addressing
//! otherwise. The accumulation computes the planes of a block of 64 triangles at a
//! time (square roots and divisions in loops of their own, so that they overlap
//! instead of chaining one triangle after the next; bit for bit the planes of one
//! triangle at a time, as the streaming path computes them), then adds the block's
//! triangles in order (the sequential path also marks the used vertices there, when
//! the attribute sources are wanted). The output's manifold counts group the
//! corners by vertex (a counting sort) and count each vertex's edges and fans
//! locally (linear in the output). The
//! sequential in-memory loops (the accumulation, the probes' cells and counts, the
//! representatives, the attribute sources, the manifold counts) run as an AVX2 build
//! when the CPU has it
//! (`crate::isa`: no FMA, so every operation rounds as in the baseline build and
//! the output is the same bit for bit; `MESHLOD_NO_AVX2=1` forces the baseline).
//!
//! # Parallelism and determinism
//! Vertex keys and the probes' distinct-cell tests are parallel maps. On inputs of
//! 2¹⁸ triangles or more, accumulation is parallel over contiguous ranges of cells:
//! the smallest and largest cell of every block of 64 triangles is found first (in
//! parallel), then each worker visits, in order, the blocks that touch its cells
//! (cells are numbered in vertex order, so on a coherent mesh about its share) and
//! adds the contributions to its own cells, so each cell's sums are added in input
//! order whatever the number of threads, and equal, bit for bit, to the sequential
//! streaming path; the output's manifold counts run beside the attribute sources.
//! Below 2¹⁸ triangles all of this is sequential: on the shared 2-core test machine
//! waking the second thread cost more than it saved. The output is deterministic
//! (the same for any thread count, except for a 64-bit hash collision in a probe's
//! count, see the search above).
//!
//! # Streaming
//! [`cluster_file`] reads the file twice with [`crate::io::stream`]: once for the
//! bounding box, the count and a sample of at most 2²⁰ triangles for the search (all
//! of them when the file has fewer), then once more to accumulate. Memory is the
//! cell table and sums (about 170 bytes per occupied cell), the output triangles
//! and, for indexed formats (PLY, OBJ), the vertex positions (12 bytes per vertex;
//! a binary STL is a true soup). On the same input it gives the same mesh as
//! [`cluster_mesh`] (positions and groups; streaming does not carry attributes).

#[allow(clippy::needless_range_loop)] // 3-vectors and 3×3 matrices read best indexed
mod accumulate;
mod coverage;
pub mod grid;

use crate::io::stream;
use crate::io::IoError;
use crate::mesh::topology::UnionFind;
use crate::mesh::{Distance, Mesh, Weld};
use accumulate::{
    add_triangle, prepare_block, representative, Acc, Block, Prepared, BLOCK, MIN_WEIGHT,
};
use grid::KeyTriples;
pub use grid::{CellTable, Grid, TripleSet, MAX_CELLS_PER_AXIS};
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use thiserror::Error;

/// How a cell's representative point is chosen (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Representative {
    /// The minimiser of the cell's summed plane quadrics (Lindstrom 2000).
    #[default]
    Quadric,
    /// The mean of the cell's triangle corners.
    Average,
    /// The weighted mean, weights from triangle areas times [`ClusterWeights`].
    Weighted,
}

impl Representative {
    /// The name used on the command line and in reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Quadric => "quadric",
            Self::Average => "average",
            Self::Weighted => "weighted",
        }
    }
}

/// The per-vertex factor of the [`Representative::Weighted`] corner weights
/// `Aₜ/3 · f(v)`.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum ClusterWeights {
    /// `f = 1`: pure area weighting.
    #[default]
    Area,
    /// A feature measure (after Low & Tan 1997's "floating cells", which favour
    /// vertices on creases): `f = 1 + 8 (1 − cos θ)` where `θ` is the largest angle
    /// between the vertex's area-weighted mean normal and the normals of its triangles
    /// (over positions welded exactly). In memory only.
    Feature,
    /// A user-given weight per input vertex (must be finite and non-negative, one per
    /// vertex). In memory only.
    PerVertex(Vec<f32>),
}

/// Options of [`cluster_mesh`] and [`cluster_file`].
#[derive(Debug, Clone, PartialEq)]
pub struct ClusterOptions {
    /// The cell side ε. When set it wins over any target count. Default `None`
    /// (search ε for the target count).
    pub cell_size: Option<Distance>,
    /// The representative. Default [`Representative::Quadric`].
    pub representative: Representative,
    /// Compute [`Clustered::vertex_source`] (the input vertex whose attributes each
    /// output vertex carries) also for an input without attributes. Default `false`:
    /// then it is computed only when the input has attributes, since finding it
    /// costs a pass over the input's vertices and marking the vertices triangles
    /// use (about a tenth of a call at 10% of the triangles).
    pub vertex_sources: bool,
    /// Weights of [`Representative::Weighted`]. Default [`ClusterWeights::Area`].
    pub weights: ClusterWeights,
    /// Relative tolerance on the triangle count when a target is given. Default 0.05.
    pub tolerance: f64,
}

impl Default for ClusterOptions {
    fn default() -> Self {
        Self {
            cell_size: None,
            representative: Representative::Quadric,
            vertex_sources: false,
            weights: ClusterWeights::Area,
            tolerance: 0.05,
        }
    }
}

impl ClusterOptions {
    /// Sets [`Self::cell_size`].
    #[must_use]
    pub fn with_cell_size(mut self, e: Distance) -> Self {
        self.cell_size = Some(e);
        self
    }
    /// Sets [`Self::representative`].
    #[must_use]
    pub fn with_representative(mut self, r: Representative) -> Self {
        self.representative = r;
        self
    }
    /// Sets [`Self::vertex_sources`].
    #[must_use]
    pub fn with_vertex_sources(mut self, on: bool) -> Self {
        self.vertex_sources = on;
        self
    }
    /// Sets [`Self::weights`].
    #[must_use]
    pub fn with_weights(mut self, w: ClusterWeights) -> Self {
        self.weights = w;
        self
    }
    /// Sets [`Self::tolerance`].
    #[must_use]
    pub fn with_tolerance(mut self, t: f64) -> Self {
        self.tolerance = t;
        self
    }

    fn check(&self, vertices: Option<usize>) -> Result<(), ClusterError> {
        if let Some(e) = self.cell_size {
            let v = match e {
                Distance::Relative(v) | Distance::Absolute(v) => v,
            };
            if !(v > 0.0 && v.is_finite()) {
                return Err(ClusterError::Option(format!(
                    "cell size {v} is not a positive finite distance"
                )));
            }
        }
        if !(self.tolerance >= 0.0 && self.tolerance.is_finite()) {
            return Err(ClusterError::Option(format!(
                "tolerance {} is not finite and non-negative",
                self.tolerance
            )));
        }
        if self.representative == Representative::Weighted {
            match (&self.weights, vertices) {
                (ClusterWeights::Area, _) => {}
                (_, None) => {
                    return Err(ClusterError::Option(
                        "feature and per-vertex weights need the mesh in memory (not --stream)"
                            .into(),
                    ))
                }
                (ClusterWeights::PerVertex(w), Some(n)) => {
                    if w.len() != n {
                        return Err(ClusterError::Option(format!(
                            "{} vertex weights for {n} vertices",
                            w.len()
                        )));
                    }
                    if let Some(i) = w.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
                        return Err(ClusterError::Option(format!(
                            "vertex weight {i} is {}, not finite and non-negative",
                            w[i]
                        )));
                    }
                }
                (ClusterWeights::Feature, Some(_)) => {}
            }
        }
        Ok(())
    }
}

/// Errors of clustering.
#[derive(Debug, Error)]
pub enum ClusterError {
    /// An option is out of range.
    #[error("cluster option: {0}")]
    Option(String),
    /// Reading the streamed file failed.
    #[error(transparent)]
    Io(#[from] IoError),
}

/// What clustering did (besides the mesh).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClusterStats {
    /// The representative used.
    pub representative: Representative,
    /// The cell side ε used, in mesh units.
    pub cell_size: f64,
    /// Cells along x, y and z.
    pub grid: [u32; 3],
    /// Cells holding at least one triangle corner.
    pub occupied_cells: usize,
    /// Counting passes of the ε search (0 with a given cell size).
    pub search_passes: usize,
    /// First stages run (cell ids and distinct triangles; 1 with a given cell size, at
    /// most 3); one of them is completed. Streamed, each is a pass over the file.
    pub builds: usize,
    /// Input triangles with fewer than three distinct cells (became edges or points).
    pub collapsed_triangles: usize,
    /// Triangles dropped as copies of an earlier one over the same representatives.
    pub duplicate_triangles: usize,
    /// Triangles dropped because representatives of distinct cells coincide or are
    /// exactly collinear.
    pub flattened_triangles: usize,
    /// Triangles added by the coverage repair: a thin part whose triangles all
    /// collapsed gets one sliver triangle per occupied cell two or more cells away
    /// from the output's cells, and a tip just over a cell border one toward its two
    /// nearest covered neighbours (at most one per 256 output triangles; see the
    /// module documentation, "Coverage repair").
    pub coverage_triangles: usize,
    /// The error (mesh units): see the module documentation.
    pub max_error: f64,
    /// Edges of the output with more than two triangles.
    pub non_manifold_edges: usize,
    /// Output vertices on a non-manifold edge or with more than one fan of triangles.
    pub non_manifold_vertices: usize,
    /// Output boundary edges (one triangle).
    pub boundary_edges: usize,
    /// Whether the input was streamed from a file.
    pub streamed: bool,
    /// Bytes held by the cell table, cell sums and output while clustering (not the
    /// streamed reader's vertex positions).
    pub working_bytes: usize,
}

impl ClusterStats {
    /// Adds the counts of another run (e.g. another part of a scene): triangle,
    /// edge and vertex counts and the working memory are summed, the error is the
    /// larger one; the settings (representative, cell size, grid, passes) stay this
    /// run's.
    pub fn merge(&mut self, other: &Self) {
        self.occupied_cells += other.occupied_cells;
        self.collapsed_triangles += other.collapsed_triangles;
        self.duplicate_triangles += other.duplicate_triangles;
        self.flattened_triangles += other.flattened_triangles;
        self.coverage_triangles += other.coverage_triangles;
        self.max_error = self.max_error.max(other.max_error);
        self.non_manifold_edges += other.non_manifold_edges;
        self.non_manifold_vertices += other.non_manifold_vertices;
        self.boundary_edges += other.boundary_edges;
        self.working_bytes += other.working_bytes;
    }
}

/// The result of clustering.
#[derive(Debug, Clone, PartialEq)]
pub struct Clustered {
    /// The simplified mesh (compact, vertices in first-use order).
    pub mesh: Mesh,
    /// For every output vertex, the input vertex whose attributes it carries (empty
    /// when streamed, and when the input has no attributes unless
    /// [`ClusterOptions::vertex_sources`] asks for it).
    pub vertex_source: Vec<u32>,
    /// What happened.
    pub stats: ClusterStats,
    /// Input triangles.
    pub triangles_in: usize,
    /// Input vertices (for a streamed STL, three per triangle).
    pub vertices_in: usize,
    /// The input's bounding-box diagonal (all vertices), mesh units.
    pub bbox_diagonal: f64,
}

/// Output triangles of the first clean-up stage: three distinct cells, no repeated
/// cell triple.
struct Stage1 {
    cells: Vec<[u32; 3]>,
    groups: Vec<u32>,
    collapsed: usize,
    duplicates: usize,
}

impl Stage1 {
    fn new(expected: usize) -> (Self, TripleSet) {
        (
            Self {
                cells: Vec::with_capacity(expected),
                groups: Vec::with_capacity(expected),
                collapsed: 0,
                duplicates: 0,
            },
            TripleSet::with_capacity(expected),
        )
    }

    #[inline]
    fn push(&mut self, set: &mut TripleSet, c: [u32; 3], group: u32) {
        if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] {
            self.collapsed += 1;
        } else if set.insert(c) {
            self.cells.push(c);
            self.groups.push(group);
        } else {
            self.duplicates += 1;
        }
    }
}

/// A probe of the search: the cell side ε and the count on its grid.
type Probe = (f64, usize);

/// Where a probe count may stop the search: from `goal·(1 − below)` to
/// `goal·(1 + above)`.
#[derive(Debug, Clone, Copy)]
struct Band {
    below: f64,
    above: f64,
}

impl Band {
    /// The same fraction on both sides.
    fn even(f: f64) -> Self {
        Self { below: f, above: f }
    }

    /// Whether `count` lies in the band around `goal`.
    fn holds(self, count: usize, goal: usize) -> bool {
        let (c, g) = (count as f64, goal as f64);
        c >= g - self.below * g && c <= g + self.above * g
    }
}

/// The search for the cell side ε giving a probe count (triangles with three
/// distinct cells): every probe is kept, so a later goal (rescaled after a build)
/// starts from the bracket the earlier probes give.
struct Search {
    lo: [f64; 3],
    hi: [f64; 3],
    /// `PROJECTED_DENSITY · P`: the count model's scale (0 when there is no area).
    kp: f64,
    /// Every probe, `(ε, count)`, in order.
    probes: Vec<(f64, usize)>,
    /// The band of the current [`Self::run`].
    band: Band,
}

impl Search {
    /// Probes of one [`Self::run`] after which a count within the loose tolerance
    /// does.
    const PATIENCE: usize = 6;
    /// Most probes of one [`Self::run`].
    const MAX_PROBES: usize = 16;

    fn new(lo: [f64; 3], hi: [f64; 3]) -> Self {
        Self {
            lo,
            hi,
            kp: 0.0,
            probes: Vec::new(),
            band: Band::even(0.0),
        }
    }

    /// The probe closest to `goal` (the first of equals).
    fn closest(&self, goal: usize) -> Option<(f64, usize)> {
        let dist = |n: usize| n.abs_diff(goal);
        let mut best: Option<(f64, usize)> = None;
        for &p in &self.probes {
            if best.is_none_or(|b| dist(p.1) < dist(b.1)) {
                best = Some(p);
            }
        }
        best
    }

    /// The bracket of `goal`: the finest probe with at most `goal` triangles, and the
    /// coarsest probe finer than it with more (the count is not exactly monotone in
    /// ε, so a probe on the wrong side is ignored).
    fn bracket(&self, goal: usize) -> (Option<Probe>, Option<Probe>) {
        let mut large: Option<(f64, usize)> = None;
        for &p in self.probes.iter().filter(|p| p.1 <= goal) {
            if large.is_none_or(|l| p.0 < l.0) {
                large = Some(p);
            }
        }
        let mut small: Option<(f64, usize)> = None;
        for &p in self.probes.iter().filter(|p| p.1 > goal) {
            if large.is_none_or(|l| p.0 < l.0) && small.is_none_or(|s| p.0 > s.0) {
                small = Some(p);
            }
        }
        (small, large)
    }

    /// The ε in `from..to` where the count model ([`model_step`]), scaled to give
    /// `count` at the probe `eps`, comes closest to `goal` (`None` without a model:
    /// no projected area, or an empty probe).
    fn calibrated(&self, eps: f64, count: usize, goal: usize, from: f64, to: f64) -> Option<f64> {
        if !self.kp.is_finite() || self.kp <= 0.0 || count == 0 {
            return None;
        }
        let model = self.kp / (eps * eps) * Grid::cover_factor(self.lo, self.hi, eps);
        let kp = self.kp * count as f64 / model;
        model_step(self.lo, self.hi, kp, goal, from, to)
    }

    /// The next ε to probe for `goal`: a secant step on `log count` against `log ε`
    /// inside the bracket, or, with one side only, the count model ([`model_step`])
    /// scaled to that side's closest probe (a step assuming count ∝ ε⁻² without a
    /// model).
    ///
    /// On coarse grids the count jumps where a cell count along an axis changes
    /// (a whole row of cells appears, or a centred axis shifts by half a cell). When the two sides of the bracket differ in cell counts, the
    /// smallest ε with the coarse side's cell counts is probed first: it gives that
    /// side its most triangles, the candidate closest to the goal from below.
    fn next(&self, goal: usize) -> Option<f64> {
        let g = goal as f64;
        match self.bracket(goal) {
            (Some((es, cs)), Some((el, cl))) => {
                if el / es < 1.0 + 1e-4 {
                    return None;
                }
                let coarse = Grid::new(self.lo, self.hi, el).dims;
                if Grid::new(self.lo, self.hi, es).dims != coarse {
                    let edge = Grid::finest_cell(self.lo, self.hi, coarse) * (1.0 + 1e-9);
                    let probed = self
                        .probes
                        .iter()
                        .any(|p| p.0 <= edge * (1.0 + 1e-6) && p.0 >= edge);
                    if edge > es
                        && edge < el
                        && !probed
                        && Grid::new(self.lo, self.hi, edge).dims == coarse
                    {
                        return Some(edge);
                    }
                }
                let (ls, ll) = (es.ln(), el.ln());
                let t = if cl > 0 && cs > cl {
                    let (ys, yl) = ((cs as f64).ln(), (cl as f64).ln());
                    ((g.ln() - ys) / (yl - ys)).clamp(0.1, 0.9)
                } else {
                    0.5
                };
                Some((ls + t * (ll - ls)).exp())
            }
            (Some((es, cs)), None) => {
                let plain = es * (cs as f64 / g).sqrt().clamp(1.002, 8.0);
                Some(
                    self.calibrated(es, cs, goal, es * 1.002, plain * 1.1)
                        .unwrap_or(plain),
                )
            }
            (None, Some((el, cl))) => Some(if cl == 0 {
                el / 4.0
            } else {
                let plain = el * (cl as f64 / g).sqrt().clamp(0.125, 0.998);
                // On coarse grids (an axis of fewer than 8 cells) the count model is
                // poor where the grid keeps the probe's cells per axis (it
                // predicted 117 where fandisk gave 126) and the count jumps where a
                // row of cells appears: when the count ∝ ε⁻² reaches the band at the
                // finest ε with the probe's cells, search only down to it. The
                // bracket would probe that ε anyway once a probe crossed the jump.
                let dims = Grid::new(self.lo, self.hi, el).dims;
                let edge = Grid::finest_cell(self.lo, self.hi, dims) * (1.0 + 1e-9);
                let reach = cl as f64 * (el / edge) * (el / edge);
                let from = if dims
                    .iter()
                    .any(|&d| f64::from(d) < grid::CENTRED_FROM_CELLS)
                    && edge < el * 0.998
                    && edge > plain / 1.1
                    && Grid::new(self.lo, self.hi, edge).dims == dims
                    && reach >= g - self.band.below * g
                {
                    edge
                } else {
                    plain / 1.1
                };
                self.calibrated(el, cl, goal, from, el * 0.998)
                    .unwrap_or(plain)
            }),
            (None, None) => None,
        }
    }

    /// Searches ε with `count(grid)` in the band `strict` around `goal`, starting at
    /// `eps0` (or from the earlier probes); after [`Self::PATIENCE`] probes a probe in
    /// the band `loose` does, and it stops after [`Self::MAX_PROBES`] (small goals: the
    /// count jumps between neighbouring grids). Returns the ε of the closest probe and
    /// its count (`None` for a goal of 0: the coarsest grid, not probed).
    fn run(
        &mut self,
        goal: usize,
        eps0: f64,
        (strict, loose): (Band, Band),
        mut count: impl FnMut(&Grid) -> usize,
    ) -> (f64, Option<usize>) {
        let extent = (0..3)
            .map(|k| self.hi[k] - self.lo[k])
            .fold(0.0f64, f64::max);
        let coarsest = 2.0 * extent.max(f64::MIN_POSITIVE);
        if goal == 0 {
            return (coarsest, None);
        }
        self.band = strict;
        let within = |c: usize| strict.holds(c, goal);
        if let Some(b) = self.closest(goal) {
            if within(b.1) {
                return (b.0, Some(b.1));
            }
        }
        let mut eps = self.next(goal).unwrap_or(eps0);
        eps = eps.clamp(f64::MIN_POSITIVE, coarsest);
        for probe in 0..Self::MAX_PROBES {
            if probe >= Self::PATIENCE && self.closest(goal).is_some_and(|b| loose.holds(b.1, goal))
            {
                break;
            }
            let grid = Grid::new(self.lo, self.hi, eps);
            eps = grid.cell;
            let c = match self.probes.iter().find(|p| p.0 == eps) {
                Some(p) => p.1,
                None => {
                    let c = count(&grid);
                    self.probes.push((eps, c));
                    c
                }
            };
            if within(c) {
                break;
            }
            let Some(next) = self.next(goal) else { break };
            if next == eps || !next.is_finite() {
                break;
            }
            // The finest grid already gives too few triangles: stop.
            if c <= goal && Grid::new(self.lo, self.hi, next).cell >= eps {
                break;
            }
            eps = next;
        }
        self.closest(goal)
            .map_or((eps, None), |(e, c)| (e, Some(c)))
    }
}

/// The two halves of a build, so that the search can check the exact count of the
/// first clean-up stage before paying for the rest.
trait Pipeline {
    /// What [`Pipeline::stage`] hands to [`Pipeline::complete`].
    type Staged;
    /// Whether [`Pipeline::count`] is the exact count of [`Pipeline::stage`] (in
    /// memory, or streamed when the sample holds every triangle), not an estimate
    /// (streamed from a partial sample). Both paths then search alike.
    fn exact(&self) -> bool;
    /// The probe count on `grid`: triangles with three distinct cells, counting
    /// copies over the same three cells once (`goal` sizes the tables).
    fn count(&mut self, grid: &Grid, goal: usize) -> usize;
    /// The first stage on `grid` (cells, distinct non-duplicate cell triples),
    /// expecting about `expect` triangles; returns it and its triangle count.
    fn stage(&mut self, grid: &Grid, expect: usize) -> (Self::Staged, usize);
    /// The rest of the build.
    fn complete(&mut self, staged: Self::Staged) -> Clustered;
}

/// Clusters `mesh` to about `target` triangles (when [`ClusterOptions::cell_size`]
/// is `None`), or with the given cell size.
///
/// The mesh must [validate](Mesh::validate) (the public [`crate::simplify()`] checks
/// it first).
///
/// # Errors
/// [`ClusterError::Option`] for bad options (cell size not positive, a weight
/// stream of the wrong length, no target and no cell size).
pub fn cluster_mesh(
    mesh: &Mesh,
    target: Option<usize>,
    options: &ClusterOptions,
) -> Result<Clustered, ClusterError> {
    options.check(Some(mesh.positions.len()))?;
    let Some((lo32, hi32)) = mesh.bounding_box(false) else {
        return Ok(empty_result(mesh, options, 0.0));
    };
    let lo = lo32.map(f64::from);
    let hi = hi32.map(f64::from);
    let diag = diagonal(lo, hi);
    let n = mesh.triangles.len();
    let area = crate::isa::dispatch!(area_estimate(n, |t| tri_of(mesh, t)));
    let mut pipeline = InMemory {
        mesh,
        options,
        factors: corner_factors(mesh, options),
        keys: Vec::new(),
        small: Vec::new(),
        keys_cell: f64::NAN,
        triples: KeyTriples::default(),
        distinct: Vec::new(),
        distinct_cell: f64::NAN,
        first_only: false,
        three: 0,
        exact: TripleSet::with_capacity(0),
    };
    let (mut out, search_passes, builds) =
        drive(lo, hi, diag, target, options, area, &mut pipeline);
    out.stats.search_passes = search_passes;
    out.stats.builds = builds;
    Ok(Clustered {
        triangles_in: n,
        vertices_in: mesh.positions.len(),
        bbox_diagonal: diag,
        ..out
    })
}

/// The bounding-box diagonal, as [`Mesh::bbox_diagonal`].
fn diagonal(lo: [f64; 3], hi: [f64; 3]) -> f64 {
    (0..3)
        .map(|k| {
            let d = hi[k] - lo[k];
            d * d
        })
        .sum::<f64>()
        .sqrt()
}

/// Clusters the mesh file at `path` by streaming it twice (see the module
/// documentation): binary or ASCII STL, binary PLY, OBJ. The target, when there is
/// no cell size, is `target(triangle count)`.
///
/// # Errors
/// [`ClusterError::Io`] naming the file and the place for anything wrong with it
/// (including a format that cannot be streamed); [`ClusterError::Option`] for bad
/// options, including weights that need the mesh in memory.
pub fn cluster_file(
    path: &Path,
    target: impl FnOnce(usize) -> Option<usize>,
    options: &ClusterOptions,
) -> Result<Clustered, ClusterError> {
    options.check(None)?;
    // Pass 1: bounding box, count and a sample.
    let mut sample = Sampler::new(1 << 20);
    let mut index = 0usize;
    let summary = stream::for_each_triangle(path, |tri, _group| {
        sample.push(index, tri);
        index += 1;
    })?;
    let n = summary.triangles as usize;
    let diag = summary.bbox_diagonal();
    let vertices_in = summary.vertices as usize;
    let Some((lo32, hi32)) = summary.bbox else {
        let mut out = empty_result(&Mesh::default(), options, 0.0);
        out.stats.streamed = true;
        return Ok(out);
    };
    let lo = lo32.map(f64::from);
    let hi = hi32.map(f64::from);
    let target = target(n);
    let m = sample.tris.len();
    // With every triangle in the sample this is the in-memory estimate exactly.
    let area = area_estimate(m, |t| sample.tris[t]) * (n as f64 / m.max(1) as f64);
    let mut pipeline = Streamed {
        path,
        options,
        scale: if m == 0 { 1.0 } else { n as f64 / m as f64 },
        whole: m == n,
        sample: sample.tris,
        failure: None,
        triples: KeyTriples::default(),
    };
    let (mut out, search_passes, builds) =
        drive(lo, hi, diag, target, options, area, &mut pipeline);
    if let Some(e) = pipeline.failure {
        return Err(e.into());
    }
    out.stats.search_passes = search_passes;
    out.stats.builds = builds;
    out.stats.streamed = true;
    Ok(Clustered {
        triangles_in: n,
        vertices_in,
        bbox_diagonal: diag,
        ..out
    })
}

/// The search-and-build loop shared by both paths. Returns the result, the number of
/// counting passes and of builds (first stages).
///
/// The probes search ε for the goal within `min(0.4 tol, 2%)`; then the first stage
/// gives the exact count before the representatives. When duplicates removed enough
/// to leave it more than `tol / 2` away from the target, the goal is rescaled by
/// probe / stage count and the search resumes from its earlier probes; at most three
/// first stages, of which the closest is completed.
fn drive<P: Pipeline>(
    lo: [f64; 3],
    hi: [f64; 3],
    diag: f64,
    target: Option<usize>,
    options: &ClusterOptions,
    area: f64,
    p: &mut P,
) -> (Clustered, usize, usize) {
    let target = match (options.cell_size, target) {
        (Some(e), _) => {
            let grid = Grid::new(lo, hi, e.resolve(diag));
            let (s, _) = p.stage(&grid, 0);
            return (p.complete(s), 0, 1);
        }
        (None, Some(t)) => t,
        (None, None) => {
            // Not reachable through the public API (simplify always has a target);
            // one cell per 1% of the diagonal.
            let grid = Grid::new(lo, hi, 0.01 * diag);
            let (s, _) = p.stage(&grid, 0);
            return (p.complete(s), 0, 1);
        }
    };
    let eps0 = if area > 0.0 && target > 0 {
        // The density was measured on grids starting at the box's minimum (about
        // t + ½ cells per axis); the model follows the grid's actual cells.
        let e = (PROJECTED_DENSITY * area / target as f64).sqrt();
        model_step(lo, hi, PROJECTED_DENSITY * area, target, e / 1.08, e * 1.08).unwrap_or(e)
    } else {
        0.01 * diag.max(f64::MIN_POSITIVE)
    };
    let mut search = Search::new(lo, hi);
    search.kp = PROJECTED_DENSITY * area;
    let tol = options.tolerance;
    let dist = |n: usize| (n as f64 - target as f64).abs();
    let mut goal = target;
    let mut eps = eps0;
    let mut builds = 0;
    let mut kept: Option<(usize, P::Staged)> = None;
    let mut done: Option<Clustered> = None;
    for round in 0..3 {
        // A probe of an exact pipeline is the first stage's count, and the second
        // clean-up (coinciding or collinear representatives) can only remove
        // triangles, and few (at most 4 in 10,080 on the shared meshes): above the
        // goal the whole tolerance is safe, below it a tenth is left for that
        // clean-up. Were it exceeded, the rescaled round below would follow.
        let tols = if p.exact() {
            let band = Band {
                below: 0.9 * tol,
                above: tol,
            };
            (band, band)
        } else {
            (Band::even((0.4 * tol).min(0.02)), Band::even(0.8 * tol))
        };
        let (e, probe) = search.run(goal, eps, tols, |g| p.count(g, goal));
        eps = e;
        let (staged, got) = p.stage(&Grid::new(lo, hi, eps), goal);
        builds += 1;
        let last = round == 2;
        let probe = probe.unwrap_or(goal).max(1);
        let rescaled = |got: usize| (target as f64 * probe as f64 / got as f64).round() as usize;
        if !last && got > 0 && dist(got) > 0.5 * tol * target as f64 {
            let next = rescaled(got);
            if next != goal {
                if kept.as_ref().is_none_or(|(k, _)| dist(got) < dist(*k)) {
                    kept = Some((got, staged));
                }
                goal = next;
                continue;
            }
        }
        let staged = match kept.take() {
            Some((k, s)) if dist(k) < dist(got) => s,
            _ => staged,
        };
        let out = p.complete(staged);
        let got = out.mesh.triangles.len();
        let ok = dist(got) <= tol * target as f64 || got == 0;
        if done
            .as_ref()
            .is_none_or(|b| dist(got) < dist(b.mesh.triangles.len()))
        {
            done = Some(out);
        }
        if ok || last {
            break;
        }
        // The second clean-up (coinciding representatives) removed many: rescale.
        let next = rescaled(got);
        if next == goal {
            break;
        }
        goal = next;
    }
    let out = done.unwrap_or_else(|| {
        let (s, _) = p.stage(&Grid::new(lo, hi, eps), goal);
        p.complete(s)
    });
    (out, search.probes.len(), builds)
}

fn empty_result(mesh: &Mesh, options: &ClusterOptions, diag: f64) -> Clustered {
    Clustered {
        mesh: Mesh {
            group_names: mesh.group_names.clone(),
            ..Mesh::default()
        },
        vertex_source: Vec::new(),
        stats: ClusterStats {
            representative: options.representative,
            cell_size: 0.0,
            grid: [0; 3],
            occupied_cells: 0,
            search_passes: 0,
            builds: 0,
            collapsed_triangles: mesh.triangles.len(),
            duplicate_triangles: 0,
            flattened_triangles: 0,
            coverage_triangles: 0,
            max_error: 0.0,
            non_manifold_edges: 0,
            non_manifold_vertices: 0,
            boundary_edges: 0,
            streamed: false,
            working_bytes: 0,
        },
        triangles_in: mesh.triangles.len(),
        vertices_in: mesh.positions.len(),
        bbox_diagonal: diag,
    }
}

#[inline]
fn tri_of(mesh: &Mesh, t: usize) -> [[f32; 3]; 3] {
    mesh.triangles[t].map(|i| mesh.positions[i as usize])
}

/// Triangles the area estimate of the first guess of ε looks at.
const AREA_SAMPLE: usize = 8192;

/// Probe triangles per ε² of projected area (see [`projected_area`]): the first
/// guess of ε for a target `t` is `√(PROJECTED_DENSITY · P / t)`. Measured on the
/// shared meshes at 10% and 1% (bunny, fandisk, armadillo, Lucy, turbine blade,
/// Nefertiti, ogre, rocker arm): 1.55–1.87.
const PROJECTED_DENSITY: f64 = 1.74;

/// The cell side in `from..to` (scanned in 256 geometric steps) where the model
/// count `kp / ε² · cover` ([`Grid::cover_factor`]: the count's jumps where a row of
/// cells appears or a centred axis flips) comes closest to `goal`; `None` for an
/// empty range or no model.
fn model_step(lo: [f64; 3], hi: [f64; 3], kp: f64, goal: usize, from: f64, to: f64) -> Option<f64> {
    // The AVX2 build rounds with one instruction where the baseline calls `floor`
    // (the same value: rounding down is exact).
    crate::isa::dispatch!(model_step_impl(lo, hi, kp, goal, from, to))
}

/// [`model_step`], inlined into each build.
#[inline(always)]
fn model_step_impl(
    lo: [f64; 3],
    hi: [f64; 3],
    kp: f64,
    goal: usize,
    from: f64,
    to: f64,
) -> Option<f64> {
    if !(kp > 0.0 && from > 0.0 && to > from && to.is_finite()) || goal == 0 {
        return None;
    }
    const STEPS: usize = 256;
    let g = goal as f64;
    let step = (to / from).powf(1.0 / STEPS as f64);
    let mut best: Option<(f64, f64)> = None;
    let mut e = from;
    for _ in 0..=STEPS {
        let m = kp / (e * e) * Grid::cover_factor(lo, hi, e);
        // The larger of m / g and g / m: the distance in log count.
        let d = (m / g).max(g / m);
        let here = e;
        e *= step;
        if best.is_none_or(|b| d < b.1) {
            best = Some((here, d));
        }
    }
    best.map(|b| b.0)
}

/// The area of the triangle's projections on the three coordinate planes,
/// `½(|cₓ| + |c_y| + |c_z|)` for the cross product `c` of its edges: a surface of
/// projected area `P` meets about `P/ε²` cells of side ε (each cell it enters it
/// enters through a face, and the faces crossed normal to axis `k` are the
/// projection on that plane over ε²), so the probe count is close to a fixed
/// multiple of `P/ε²` whatever the surface's orientation.
#[inline]
fn projected_area_of(t: &[[f32; 3]; 3]) -> f64 {
    let c = edge_cross(t);
    0.5 * (c[0].abs() + c[1].abs() + c[2].abs())
}

/// The cross product of the triangle's edges from its first corner, in `f64`.
#[inline]
fn edge_cross(t: &[[f32; 3]; 3]) -> [f64; 3] {
    let p = t.map(|c| c.map(f64::from));
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ]
}

/// The total projected area ([`projected_area_of`]) of `n` triangles estimated from
/// every `k`-th one (at most [`AREA_SAMPLE`]), summed in order: only the search's
/// first guess uses it, and both paths compute it the same way.
#[inline(always)]
fn area_estimate(n: usize, tri: impl Fn(usize) -> [[f32; 3]; 3]) -> f64 {
    if n == 0 {
        return 0.0;
    }
    let k = n.div_ceil(AREA_SAMPLE);
    let mut sum = 0.0;
    let mut m = 0usize;
    for t in (0..n).step_by(k) {
        sum += projected_area_of(&tri(t));
        m += 1;
    }
    sum * (n as f64 / m as f64)
}

/// A deterministic stride sample of at most `cap` triangles: every `stride`-th; when
/// full, every other one is dropped and the stride doubles.
struct Sampler {
    tris: Vec<[[f32; 3]; 3]>,
    stride: usize,
    cap: usize,
}

impl Sampler {
    fn new(cap: usize) -> Self {
        Self {
            tris: Vec::new(),
            stride: 1,
            cap,
        }
    }
    fn push(&mut self, index: usize, t: &[[f32; 3]; 3]) {
        if index % self.stride != 0 {
            return;
        }
        if self.tris.len() == self.cap {
            let mut k = 0;
            self.tris.retain(|_| {
                k += 1;
                (k - 1) % 2 == 0
            });
            self.stride *= 2;
            if index % self.stride != 0 {
                return;
            }
        }
        self.tris.push(*t);
    }
}

/// Minimum items per parallel task in the per-vertex maps.
const PAR_MIN: usize = 1 << 15;

/// Inputs from this many triangles test their cells in parallel in the probes. Below
/// it (the shared test meshes, a few milliseconds a call) waking the pool's threads
/// cost more than they saved on a loaded 2-core machine.
const PAR_COUNT: usize = 1 << 18;

/// Triangles whose three corner keys differ, copies over the same three keys counted
/// once. The distinct-key test is parallel for large inputs; the set is filled in
/// order. With `record`, the indices of the triangles with three distinct keys are
/// written there, in order (duplicates included).
fn count_distinct(
    n: usize,
    keys_of: impl Fn(usize) -> [u64; 3] + Sync,
    set: &mut KeyTriples,
    goal: usize,
    mut record: Option<&mut Vec<u32>>,
) -> usize {
    set.reset(goal + goal / 4);
    if let Some(r) = record.as_deref_mut() {
        r.clear();
    }
    let distinct = |k: &[u64; 3]| (k[0] != k[1]) & (k[1] != k[2]) & (k[0] != k[2]);
    let threads = rayon::current_num_threads();
    if n < PAR_COUNT || threads == 1 {
        // Without a branch per triangle: every triangle is written to the buffer,
        // which only advances past the distinct ones.
        let mut buf = [[0u64; 3]; 256];
        let mut idx = [0u32; 256];
        let mut m = 0;
        let mut flush = |buf: &[[u64; 3]], idx: &[u32]| {
            for k in buf {
                set.push(*k);
            }
            if let Some(r) = record.as_deref_mut() {
                r.extend_from_slice(idx);
            }
        };
        for t in 0..n {
            let k = keys_of(t);
            buf[m] = k;
            idx[m] = t as u32;
            m += usize::from(distinct(&k));
            if m == buf.len() {
                flush(&buf, &idx);
                m = 0;
            }
        }
        flush(&buf[..m], &idx[..m]);
    } else {
        let per = n.div_ceil(4 * threads).max(PAR_COUNT / 4);
        let chunks: Vec<Vec<(u32, u64)>> = (0..n.div_ceil(per))
            .into_par_iter()
            .map(|c| {
                (c * per..((c + 1) * per).min(n))
                    .map(|t| (t as u32, keys_of(t)))
                    .filter(|(_, k)| distinct(k))
                    .map(|(t, k)| (t, KeyTriples::hash(k)))
                    .collect()
            })
            .collect();
        for (t, h) in chunks.into_iter().flatten() {
            set.push_hash(h);
            if let Some(r) = record.as_deref_mut() {
                r.push(t);
            }
        }
    }
    set.count()
}

/// [`count_distinct`] (sequential) on 4-byte cells (`cells[v]` the
/// [`Grid::linear_u32`] index of vertex `v`), exactly: the triangles with three
/// distinct cells are found first (their indices written branch-free), then only
/// they are gathered again and deduplicated exactly by their cell triples
/// ([`TripleSet::retain_first`], partitioned to stay in cache). `record` keeps
/// the first triangle over each triple, in order. Returns the count (the triples)
/// and the number of triangles with three distinct cells.
#[inline(always)]
fn count_small(
    tris: &[[u32; 3]],
    cells: &[u32],
    set: &mut TripleSet,
    record: &mut Vec<u32>,
) -> (usize, usize) {
    record.clear();
    let cell = |v: u32| cells.get(v as usize).copied().unwrap_or(0);
    // Chunks of 256 triangles: the buffer cannot fill within one, so the loop has
    // no flush test (the index is masked, which the compiler sees is in bounds).
    let mut idx = [0u32; 256];
    for (c, chunk) in tris.chunks(256).enumerate() {
        let base = (c * 256) as u32;
        let mut m = 0usize;
        for (i, tri) in chunk.iter().enumerate() {
            let (a, b, d) = (cell(tri[0]), cell(tri[1]), cell(tri[2]));
            idx[m & 255] = base + i as u32;
            m += usize::from((a != b) & (b != d) & (a != d));
        }
        record.extend_from_slice(&idx[..m]);
    }
    let three = record.len();
    set.retain_first(record, |t| tris[t as usize].map(cell));
    (record.len(), three)
}

/// Expected occupied cells for about `triangles` output triangles (about two
/// triangles per cell), for sizing tables.
fn expected_cells(triangles: usize) -> usize {
    triangles / 2 + 64
}

/// Per-vertex factors of the weighted representative (`None`: all 1).
fn corner_factors(mesh: &Mesh, options: &ClusterOptions) -> Option<Vec<f32>> {
    if options.representative != Representative::Weighted {
        return None;
    }
    match &options.weights {
        ClusterWeights::Area => None,
        ClusterWeights::PerVertex(w) => Some(w.clone()),
        ClusterWeights::Feature => Some(feature_factors(mesh)),
    }
}

/// `1 + 8 (1 − cos θ)` per vertex, `θ` the largest angle between the point's mean
/// normal and its triangles' normals (points welded exactly).
fn feature_factors(mesh: &Mesh) -> Vec<f32> {
    let weld = Weld::exact(&mesh.positions);
    let np = weld.point_count();
    let normal = |t: &[u32; 3]| {
        let p = t.map(|i| mesh.positions[i as usize].map(f64::from));
        let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
        let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
        [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ]
    };
    let mut sum = vec![[0.0f64; 3]; np];
    for t in &mesh.triangles {
        let n = normal(t);
        for &v in t {
            let s = &mut sum[weld.point_of[v as usize] as usize];
            for k in 0..3 {
                s[k] += n[k];
            }
        }
    }
    let unit = |v: [f64; 3]| {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if l > 0.0 {
            Some(v.map(|x| x / l))
        } else {
            None
        }
    };
    let mut min_cos = vec![1.0f64; np];
    for t in &mesh.triangles {
        let Some(n) = unit(normal(t)) else { continue };
        for &v in t {
            let p = weld.point_of[v as usize] as usize;
            if let Some(m) = unit(sum[p]) {
                let c = n[0] * m[0] + n[1] * m[1] + n[2] * m[2];
                min_cos[p] = min_cos[p].min(c);
            }
        }
    }
    weld.point_of
        .iter()
        .map(|&p| (1.0 + 8.0 * (1.0 - min_cos[p as usize].clamp(-1.0, 1.0))) as f32)
        .collect()
}

/// Whether the cells of `grid` have [`Grid::linear`] indices that fit in a `u32`.
fn small_grid(grid: &Grid) -> bool {
    grid.cell_count() <= u64::from(u32::MAX)
}

/// The in-memory pipeline: probes and first stages on per-vertex cell keys.
struct InMemory<'a> {
    mesh: &'a Mesh,
    options: &'a ClusterOptions,
    factors: Option<Vec<f32>>,
    /// The cell of every vertex on the grid of side `keys_cell` (NaN: none yet): its
    /// [`Grid::linear`] index in `small` when the grid has at most 2³² cells (half
    /// the memory to gather in the probes), else its key in `keys`.
    keys: Vec<u64>,
    small: Vec<u32>,
    keys_cell: f64,
    triples: KeyTriples,
    /// The triangles with three distinct cells on the grid of side `distinct_cell`
    /// (the last probe's), in order; when `first_only`, only the first of the
    /// triangles over each cell triple (the probe deduplicated them exactly), and
    /// `three` counts them all.
    distinct: Vec<u32>,
    distinct_cell: f64,
    first_only: bool,
    three: usize,
    /// The exact set of cell triples of the sequential probes on small grids.
    exact: TripleSet,
}

/// An in-memory first stage.
struct MemStaged {
    grid: Grid,
    table: CellTable,
    /// The cell of every vertex.
    vcell: Vec<u32>,
    stage1: Stage1,
}

impl InMemory<'_> {
    /// Fills [`Self::keys`] for `grid` (the origin never changes; only the side).
    fn keys_for(&mut self, grid: &Grid) {
        if self.keys_cell.to_bits() == grid.cell.to_bits() {
            return;
        }
        let points = &self.mesh.positions;
        if small_grid(grid) {
            // A plain loop (it vectorises), over chunks in parallel on large inputs
            // (sequentially written as it is computed, not zeroed first).
            self.small.clear();
            if points.len() < PAR_COUNT || rayon::current_num_threads() == 1 {
                let small = &mut self.small;
                small.reserve(points.len());
                // Through a buffer on the stack: a plain loop that vectorises in
                // the AVX2 build (an iterator adapter's `fold` would stay out of
                // line, outside it).
                crate::isa::dispatch!(for chunk in points.chunks(256) {
                    let mut buf = [0u32; 256];
                    for (o, &p) in buf.iter_mut().zip(chunk) {
                        *o = grid.linear_u32(p);
                    }
                    small.extend_from_slice(&buf[..chunk.len()]);
                });
            } else {
                self.small.resize(points.len(), 0);
                points
                    .par_chunks(PAR_MIN)
                    .zip(self.small.par_chunks_mut(PAR_MIN))
                    .for_each(|(p, o)| grid.linear_u32_all(p, o));
            }
            self.keys.clear();
        } else {
            points
                .par_iter()
                .with_min_len(PAR_MIN)
                .map(|&p| grid.key(p))
                .collect_into_vec(&mut self.keys);
            self.small.clear();
        }
        self.keys_cell = grid.cell;
    }
}

impl Pipeline for InMemory<'_> {
    type Staged = MemStaged;

    fn exact(&self) -> bool {
        true
    }

    fn count(&mut self, grid: &Grid, goal: usize) -> usize {
        self.keys_for(grid);
        let (tris, keys, small) = (&self.mesh.triangles, &self.keys, &self.small);
        let sequential = tris.len() < PAR_COUNT || rayon::current_num_threads() == 1;
        self.first_only = small_grid(grid) && sequential;
        let c = if self.first_only {
            let (exact, distinct) = (&mut self.exact, &mut self.distinct);
            let (c, three) =
                crate::isa::dispatch!(count_small(tris, small, &mut *exact, &mut *distinct));
            self.three = three;
            c
        } else if small_grid(grid) {
            count_distinct(
                tris.len(),
                |t| tris[t].map(|v| u64::from(small[v as usize])),
                &mut self.triples,
                goal,
                Some(&mut self.distinct),
            )
        } else {
            count_distinct(
                tris.len(),
                |t| tris[t].map(|v| keys[v as usize]),
                &mut self.triples,
                goal,
                Some(&mut self.distinct),
            )
        };
        self.distinct_cell = grid.cell;
        c
    }

    fn stage(&mut self, grid: &Grid, expect: usize) -> (MemStaged, usize) {
        self.keys_for(grid);
        let mesh = self.mesh;
        let expect = if expect == 0 {
            mesh.triangles.len() / 8
        } else {
            expect + expect / 8
        };
        // Cells of the vertices, ids in vertex order (the streaming path numbers them
        // in corner order; the numbering changes nothing else). The flat table costs 4
        // bytes per grid cell: allowed up to eight per vertex.
        let dense_limit = (8 * mesh.positions.len()).max(1 << 12);
        let mut table = CellTable::for_grid(grid, expected_cells(expect), dense_limit);
        let vcell: Vec<u32> = if small_grid(grid) {
            self.small
                .iter()
                .map(|&l| table.id_linear(u64::from(l), grid))
                .collect()
        } else {
            self.keys.iter().map(|&k| table.id(k)).collect()
        };
        let cells_of = |t: usize| mesh.triangles[t].map(|v| vcell[v as usize]);
        let same = self.distinct_cell.to_bits() == grid.cell.to_bits();
        if same && !self.first_only {
            // The last probe was on this grid: only its triangles with three
            // distinct cells (distinct keys are distinct ids) can be kept; the first
            // over each cell triple, found as the sequential probe does.
            self.three = self.distinct.len();
            self.exact
                .retain_first(&mut self.distinct, |t| cells_of(t as usize));
            self.first_only = true;
        }
        let stage1 = if same && self.first_only {
            // The last probe was on this grid and kept the first triangle over each
            // cell triple (distinct linear indices are distinct ids): the first
            // stage, without a set.
            let n = self.distinct.len();
            let mut cells = Vec::with_capacity(expect.max(n));
            cells.extend(self.distinct.iter().map(|&t| cells_of(t as usize)));
            let mut groups = Vec::with_capacity(expect.max(n));
            groups.extend(self.distinct.iter().map(|&t| mesh.group(t as usize)));
            Stage1 {
                cells,
                groups,
                collapsed: mesh.triangles.len() - self.three,
                duplicates: self.three - n,
            }
        } else {
            let (mut stage1, mut set) = Stage1::new(expect);
            for t in 0..mesh.triangles.len() {
                stage1.push(&mut set, cells_of(t), mesh.group(t));
            }
            stage1
        };
        let got = stage1.cells.len();
        (
            MemStaged {
                grid: *grid,
                table,
                vcell,
                stage1,
            },
            got,
        )
    }

    fn complete(&mut self, staged: MemStaged) -> Clustered {
        let MemStaged {
            grid,
            table,
            vcell,
            stage1,
        } = staged;
        let mesh = self.mesh;
        let how = self.options.representative;
        // The vertices some triangle uses, for the attribute sources below: only an
        // input with attributes (or a caller asking for the map) needs them.
        let want_sources = self.options.vertex_sources || !mesh.attributes.is_empty();
        let (accs, used) = self.accumulate(&grid, &vcell, table.len(), want_sources);
        let mut out = finish(
            &grid,
            &table,
            &accs,
            stage1,
            how,
            mesh.group_names.clone(),
            false,
        );
        let source = attribute_sources(mesh, &mut out, &used, &vcell, want_sources);
        if want_sources {
            out.mesh.attributes = mesh.attributes.gather(&source);
        }
        out.stats.working_bytes += vcell.len() * 4 + self.keys.len() * 8 + self.small.len() * 4;
        Clustered {
            mesh: out.mesh,
            vertex_source: source,
            stats: out.stats,
            triangles_in: mesh.triangles.len(),
            vertices_in: mesh.positions.len(),
            bbox_diagonal: 0.0,
        }
    }
}

impl InMemory<'_> {
    /// Each of the `cells` cells' sums of its triangles' contributions (the vertices'
    /// cells `vcell` on `grid`), and, `want_sources`, which vertices a triangle uses
    /// (empty otherwise).
    ///
    /// Workers own contiguous ranges of cells; each scans the triangles in order, so
    /// every cell adds its contributions in input order (as the streaming path).
    /// Triangles go in blocks: the planes of a block are computed in one tight loop
    /// (square roots and divisions overlap), then added to the cells in order.
    fn accumulate(
        &self,
        grid: &Grid,
        vcell: &[u32],
        cells: usize,
        want_sources: bool,
    ) -> (Vec<Acc>, Vec<bool>) {
        let mesh = self.mesh;
        let how = self.options.representative;
        let factors = self.factors.as_deref();
        let mut accs = vec![Acc::default(); cells];
        let mut used = if want_sources {
            vec![false; mesh.positions.len()]
        } else {
            Vec::new()
        };
        let accumulate = |part: &mut [Acc], start: u32, spans: Option<&[Span]>| {
            let factors = if how == Representative::Quadric {
                None
            } else {
                factors
            };
            let a = Accumulation {
                mesh,
                vcell,
                origin: grid.origin,
                how,
                factors,
                spans,
            };
            match how {
                Representative::Quadric => a.run::<true>(part, start),
                _ => a.run::<false>(part, start),
            }
        };
        let shards = rayon::current_num_threads().clamp(1, 64);
        let n = mesh.triangles.len();
        if shards == 1 || n < PAR_ACCUMULATE {
            // One pass over every triangle: its AVX2 build when the CPU has it (the
            // same operations, so the same sums bit for bit; see `crate::isa`).
            let a = Accumulation {
                mesh,
                vcell,
                origin: grid.origin,
                how,
                factors: if how == Representative::Quadric {
                    None
                } else {
                    factors
                },
                spans: None,
            };
            let (accs, used) = (&mut accs[..], &mut used[..]);
            match (how, want_sources) {
                (Representative::Quadric, true) => {
                    crate::isa::dispatch!(a.run_all::<true, true>(accs, &mut *used))
                }
                (Representative::Quadric, false) => {
                    crate::isa::dispatch!(a.run_all::<true, false>(accs, &mut *used))
                }
                (_, true) => crate::isa::dispatch!(a.run_all::<false, true>(accs, &mut *used)),
                (_, false) => crate::isa::dispatch!(a.run_all::<false, false>(accs, &mut *used)),
            }
        } else {
            // Workers own contiguous ranges of cells. The span of cell ids of every
            // block of triangles (and the used vertices) first, in parallel, so that a
            // worker only visits the blocks that touch its cells: cells are numbered in
            // vertex order, so on coherent meshes a worker visits about its share.
            let marks: Vec<AtomicBool> = (0..used.len()).map(|_| AtomicBool::new(false)).collect();
            let spans: Vec<Span> = (0..n.div_ceil(BLOCK))
                .into_par_iter()
                .with_min_len(64)
                .map(|b| {
                    let mut span = (u32::MAX, 0u32);
                    for tri in &mesh.triangles[b * BLOCK..((b + 1) * BLOCK).min(n)] {
                        for &v in tri {
                            let c = vcell[v as usize];
                            span = (span.0.min(c), span.1.max(c));
                            if want_sources {
                                marks[v as usize].store(true, Ordering::Relaxed);
                            }
                        }
                    }
                    span
                })
                .collect();
            let per = cells.div_ceil(shards).max(1);
            accs.par_chunks_mut(per)
                .enumerate()
                .for_each(|(s, part)| accumulate(part, (s * per) as u32, Some(&spans)));
            for (u, m) in used.iter_mut().zip(marks) {
                *u = m.into_inner();
            }
        }
        (accs, used)
    }
}

/// Attributes: per output vertex of `out` the closest input vertex of its cells
/// (that a triangle uses, `used`; `vcell`: the input vertices' cells), or nothing
/// without `want_sources`; beside it the output's manifold counts, recorded in
/// `out.stats`. In parallel over ranges of vertices, merged in range order (ties
/// keep the lowest index, as sequentially).
fn attribute_sources(
    mesh: &Mesh,
    out: &mut Finished,
    used: &[bool],
    vcell: &[u32],
    want_sources: bool,
) -> Vec<u32> {
    let shards = rayon::current_num_threads().clamp(1, 64);
    let n = mesh.triangles.len();
    let n_out = out.mesh.positions.len();
    let (outp, of_cell) = (&out.mesh.positions[..], &out.vertex_of_cell[..]);
    let closest = |range: std::ops::Range<usize>| {
        closest_sources(outp, of_cell, used, vcell, &mesh.positions, range)
    };
    let nv = vcell.len();
    let parts = if shards > 2 && nv >= 2 * PAR_MIN {
        (shards - 1).min(nv / PAR_MIN)
    } else {
        1
    };
    let per = nv.div_ceil(parts);
    let triangles = &out.mesh.triangles;
    let topo = || edge_counts(triangles, n_out);
    let sources = || -> Vec<Vec<(f64, u32)>> {
        if !want_sources {
            return vec![Vec::new()];
        }
        if parts == 1 {
            // One range: no pool.
            let points = &mesh.positions[..];
            return vec![crate::isa::dispatch!(closest_sources(
                outp,
                of_cell,
                used,
                vcell,
                points,
                0..nv
            ))];
        }
        (0..parts)
            .into_par_iter()
            .map(|i| closest(i * per..((i + 1) * per).min(nv)))
            .collect()
    };
    let (topo, mut partial) = if n < PAR_ACCUMULATE {
        (topo(), sources())
    } else {
        rayon::join(topo, sources)
    };
    topo.record(&mut out.stats);
    let mut best = partial.swap_remove(0);
    for other in &partial {
        for (b, o) in best.iter_mut().zip(other) {
            if o.0 < b.0 {
                *b = *o;
            }
        }
    }
    best.iter().map(|b| b.1).collect()
}

/// Per output vertex (`outp`) the closest of the input vertices `range` (`points`)
/// that a triangle uses (`used`) whose cell (`vcell`) maps to it (`of_cell`), as
/// (squared distance, index); `(∞, u32::MAX)` where none. Ties keep the lowest
/// index.
#[inline(always)]
fn closest_sources(
    outp: &[[f32; 3]],
    of_cell: &[u32],
    used: &[bool],
    vcell: &[u32],
    points: &[[f32; 3]],
    range: std::ops::Range<usize>,
) -> Vec<(f64, u32)> {
    let n_out = outp.len();
    let mut best = vec![(f64::INFINITY, u32::MAX); n_out];
    // Slices of one length per index kind: one bounds check each.
    let best_of = &mut best[..n_out];
    let start = range.start;
    let own = used[range.clone()]
        .iter()
        .zip(&vcell[range.clone()])
        .zip(&points[range]);
    for (i, ((&u, &c), p)) in own.enumerate() {
        if !u {
            continue;
        }
        let o = of_cell[c as usize] as usize;
        if o >= n_out {
            continue;
        }
        let r = outp[o];
        let x = [0, 1, 2].map(|k| f64::from(p[k]) - f64::from(r[k]));
        // The sum in this order (a sum from ±0 adds the same).
        let d = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
        let b = &mut best_of[o];
        // Selects, not a branch: which vertex is closer is as good as random.
        let closer = d < b.0;
        *b = (
            if closer { d } else { b.0 },
            if closer { (start + i) as u32 } else { b.1 },
        );
    }
    best
}

/// Inputs from this many triangles accumulate in parallel (over ranges of cells).
const PAR_ACCUMULATE: usize = 1 << 18;

/// From this many cells the representatives are computed in parallel.
const PAR_REPS: usize = 1 << 14;

/// The smallest and largest cell id of the corners of a block of [`BLOCK`] triangles.
type Span = (u32, u32);

/// What [`Accumulation::run`] reads.
struct Accumulation<'a> {
    mesh: &'a Mesh,
    /// The cell of every vertex.
    vcell: &'a [u32],
    origin: [f64; 3],
    how: Representative,
    factors: Option<&'a [f32]>,
    /// The [`Span`] of every block of triangles: blocks outside a worker's cells are
    /// skipped unread (`None`: visit all).
    spans: Option<&'a [Span]>,
}

impl Accumulation<'_> {
    /// Adds every triangle of the mesh (in order) to the cells `start .. start +
    /// part.len()` it touches. Triangles whose cells are all outside the range are
    /// skipped before their planes are computed. (The parallel workers' pass; one
    /// worker owning every cell runs [`Self::run_all`].)
    fn run<const QUADRIC: bool>(&self, part: &mut [Acc], start: u32) {
        let mesh = self.mesh;
        let vcell = self.vcell;
        let len = part.len() as u32;
        let owned = |c: u32| c.wrapping_sub(start) < len;
        let mut which = [0u32; BLOCK];
        let mut cells_of = [[0u32; 3]; BLOCK];
        let mut planes = Block::new();
        let n = mesh.triangles.len();
        for (b, first) in (0..n).step_by(BLOCK).enumerate() {
            if let Some(spans) = self.spans {
                let (lo, hi) = spans[b];
                if hi < start || lo >= start + len {
                    continue;
                }
            }
            let last = (first + BLOCK).min(n);
            let mut m = 0;
            for t in first..last {
                let c = mesh.triangles[t].map(|v| vcell[v as usize]);
                which[m] = t as u32;
                cells_of[m] = c;
                m += usize::from(owned(c[0]) | owned(c[1]) | owned(c[2]));
            }
            prepare_block(
                m,
                |i| mesh.triangles[which[i] as usize].map(|v| mesh.positions[v as usize]),
                self.origin,
                &mut planes,
            );
            for (i, (&t, &c)) in which[..m].iter().zip(&cells_of[..m]).enumerate() {
                let plane = &planes.plane(i);
                let w = corner_weights(plane, self.how, |k| {
                    self.factors.map_or(1.0, |f| {
                        f64::from(f[mesh.triangles[t as usize][k] as usize])
                    })
                });
                add_triangle::<QUADRIC>(part, start, c, plane, w);
            }
        }
    }

    /// [`Self::run`] for one worker owning every cell: a block's planes are prepared
    /// first, then each of its triangles, in order, has its cells gathered, its
    /// vertices marked in `used` (when `MARK`; `used` is then one flag per vertex)
    /// and its contributions added.
    #[inline(always)]
    fn run_all<const QUADRIC: bool, const MARK: bool>(&self, accs: &mut [Acc], used: &mut [bool]) {
        let mesh = self.mesh;
        let nv = mesh.positions.len();
        // One length for the three per-vertex arrays: one bounds check per index.
        let vcell = &self.vcell[..nv];
        let positions = &mesh.positions[..nv];
        let used = if MARK { &mut used[..nv] } else { used };
        let mut planes = Block::new();
        for block in mesh.triangles.chunks(BLOCK) {
            // The square roots and divisions of a block in loops of their own, so
            // that they pipeline instead of chaining one triangle after another.
            prepare_block(
                block.len(),
                |i| block[i].map(|v| positions[v as usize]),
                self.origin,
                &mut planes,
            );
            for (i, tri) in block.iter().enumerate() {
                let c = tri.map(|v| vcell[v as usize]);
                if MARK {
                    for &v in tri {
                        used[v as usize] = true;
                    }
                }
                let plane = &planes.plane(i);
                let w = corner_weights(plane, self.how, |k| {
                    self.factors.map_or(1.0, |f| f64::from(f[tri[k] as usize]))
                });
                add_triangle::<QUADRIC>(accs, 0, c, plane, w);
            }
        }
    }
}

/// The streaming pipeline: probes on the sample, and every first stage is a whole
/// build over the file (the second pass).
struct Streamed<'a> {
    path: &'a Path,
    options: &'a ClusterOptions,
    sample: Vec<[[f32; 3]; 3]>,
    /// Triangles in the file per sampled triangle.
    scale: f64,
    /// Whether the sample holds every triangle of the file.
    whole: bool,
    /// The first read error (the builds after it return empty results).
    failure: Option<IoError>,
    triples: KeyTriples,
}

impl Pipeline for Streamed<'_> {
    type Staged = Clustered;

    fn exact(&self) -> bool {
        self.whole
    }

    fn count(&mut self, grid: &Grid, goal: usize) -> usize {
        let tris = &self.sample;
        let sample_goal = (goal as f64 / self.scale) as usize;
        let c = count_distinct(
            tris.len(),
            |t| tris[t].map(|p| grid.key(p)),
            &mut self.triples,
            sample_goal,
            None,
        );
        (c as f64 * self.scale).round() as usize
    }

    fn stage(&mut self, grid: &Grid, expect: usize) -> (Clustered, usize) {
        if self.failure.is_none() {
            match build_streamed(self.path, grid, self.options, expect) {
                Ok(b) => return b,
                Err(e) => self.failure = Some(e),
            }
        }
        (empty_result(&Mesh::default(), self.options, 0.0), 0)
    }

    fn complete(&mut self, staged: Clustered) -> Clustered {
        staged
    }
}

/// The streaming build: one pass over the file. Returns the result and the count of
/// its first stage.
fn build_streamed(
    path: &Path,
    grid: &Grid,
    options: &ClusterOptions,
    expect: usize,
) -> Result<(Clustered, usize), IoError> {
    let how = options.representative;
    let quadric = how == Representative::Quadric;
    let expect = if expect == 0 {
        1 << 12
    } else {
        expect + expect / 8
    };
    // The flat table is allowed up to 16 grid cells (64 bytes) per expected occupied
    // cell, well under the 150 bytes of a cell's sums: memory stays proportional to
    // the occupied cells.
    let cells = expected_cells(expect);
    let mut table = CellTable::for_grid(grid, cells, (16 * cells).max(1 << 16));
    let mut accs: Vec<Acc> = Vec::with_capacity(cells);
    let (mut stage1, mut set) = Stage1::new(expect);
    let s = stream::for_each_triangle(path, |tri, group| {
        let c = tri.map(|p| {
            let id = table.id(grid.key(p));
            if id as usize == accs.len() {
                accs.push(Acc::default());
            }
            id
        });
        stage1.push(&mut set, c, group);
        let t = Prepared::new(tri, grid.origin);
        let w = corner_weights(&t, how, |_| 1.0);
        if quadric {
            add_triangle::<true>(&mut accs, 0, c, &t, w);
        } else {
            add_triangle::<false>(&mut accs, 0, c, &t, w);
        }
    })?;
    let set_bytes = set.bytes();
    drop(set);
    let got = stage1.cells.len();
    let mut out = finish(grid, &table, &accs, stage1, how, s.group_names, true);
    out.stats.working_bytes += set_bytes;
    Ok((
        Clustered {
            mesh: out.mesh,
            vertex_source: Vec::new(),
            stats: out.stats,
            triangles_in: s.triangles as usize,
            vertices_in: s.vertices as usize,
            bbox_diagonal: 0.0,
        },
        got,
    ))
}

/// Corner weights of the representative's mean (at least [`MIN_WEIGHT`], so that
/// a cell of zero-weight corners gets their plain mean).
#[inline(always)]
fn corner_weights(t: &Prepared, how: Representative, factor: impl Fn(usize) -> f64) -> [f64; 3] {
    match how {
        Representative::Average => [1.0; 3],
        // The mean is Σ wᵢ pᵢ / Σ wᵢ: the common factor 1/3 of `Aₜ/3` cancels.
        Representative::Quadric => [t.area.max(MIN_WEIGHT); 3],
        Representative::Weighted => std::array::from_fn(|k| (t.area * factor(k)).max(MIN_WEIGHT)),
    }
}

struct Finished {
    mesh: Mesh,
    stats: ClusterStats,
    /// Output vertex of each cell (`u32::MAX` when unused).
    vertex_of_cell: Vec<u32>,
}

/// Output vertices created on first use: `of_point[q]` is welded point `q`'s output
/// vertex (`u32::MAX` until used), placed at its representative's position.
struct OutVertices<'a> {
    of_point: Vec<u32>,
    positions: Vec<[f32; 3]>,
    reps: &'a [[f32; 3]],
    weld: &'a Weld,
}

impl OutVertices<'_> {
    /// The output vertex of welded point `q`, created on first use.
    #[inline]
    fn vertex(&mut self, q: u32) -> u32 {
        let v = &mut self.of_point[q as usize];
        if *v == u32::MAX {
            *v = self.positions.len() as u32;
            self.positions
                .push(self.reps[self.weld.representative[q as usize] as usize]);
        }
        *v
    }
}

/// Representatives, the second clean-up (coinciding representatives, zero area,
/// duplicates over welded positions) and compaction: shared by both paths. Without
/// `topology` the manifold counts are left at 0 (the caller computes them).
#[allow(clippy::too_many_arguments)]
fn finish(
    grid: &Grid,
    table: &CellTable,
    accs: &[Acc],
    stage1: Stage1,
    how: Representative,
    group_names: Vec<String>,
    topology: bool,
) -> Finished {
    let reps = representatives(grid, table, accs, how);
    let max_error = if how == Representative::Quadric {
        reps.iter().filter_map(|r| r.1).fold(0.0f64, f64::max)
    } else {
        grid.cell * 3f64.sqrt()
    };
    let positions: Vec<[f32; 3]> = reps.iter().map(|r| r.0).collect();
    let weld = Weld::exact(&positions);
    // Copies over the welded points can only appear when representatives of
    // distinct cells coincide (the cell triples are already distinct).
    let merged = weld.point_count() < positions.len();
    // Room for the coverage repair's few triangles as well: growing these vectors
    // afterwards would copy them whole.
    let room = stage1.cells.len() + stage1.cells.len() / coverage::FAR_BUDGET_PER + 16;
    let mut emit = Emit {
        out: OutVertices {
            of_point: vec![u32::MAX; weld.point_count()],
            positions: Vec::new(),
            reps: &positions,
            weld: &weld,
        },
        // One length for the per-cell arrays: one bounds check per cell.
        point_of: &weld.point_of[..positions.len()],
        positions: &positions,
        merged,
        set: TripleSet::with_capacity(if merged { stage1.cells.len() } else { 0 }),
        triangles: Vec::with_capacity(room),
        groups: Vec::with_capacity(room),
    };
    let mut flattened = 0;
    let mut duplicates = stage1.duplicates;
    for (c, &g) in stage1.cells.iter().zip(&stage1.groups) {
        match emit.triangle(*c, g) {
            Emitted::Flat => flattened += 1,
            Emitted::Duplicate => duplicates += 1,
            Emitted::Added => {}
        }
    }
    let point_of = emit.point_of;
    // The output vertex of each cell and, in the same pass, the coverage repair's
    // orphans: occupied cells without one (parts whose triangles all collapsed).
    let mut vertex_of_cell: Vec<u32> = Vec::with_capacity(point_of.len());
    let mut orphans: Vec<u32> = Vec::new();
    for (c, (&p, a)) in point_of.iter().zip(accs).enumerate() {
        let v = emit.out.of_point[p as usize];
        if v == u32::MAX && a.w > 0.0 {
            orphans.push(c as u32);
        }
        vertex_of_cell.push(v);
    }
    let repair = coverage::plan(
        table,
        grid.dims,
        &orphans,
        |c| accs[c as usize].w > 0.0,
        |c| vertex_of_cell[c as usize] != u32::MAX,
        |c| positions[weld.representative[point_of[c as usize] as usize] as usize],
        grid.cell,
        emit.triangles.len() / coverage::FAR_BUDGET_PER,
    );
    let coverage = emit.coverage(repair, &mut vertex_of_cell);
    let Emit {
        out,
        set,
        triangles,
        groups,
        ..
    } = emit;
    let working_bytes = table.bytes()
        + std::mem::size_of_val(accs)
        + reps.len() * 32
        + stage1.cells.capacity() * 16
        + set.bytes();
    let topo = if topology {
        edge_counts(&triangles, out.positions.len())
    } else {
        EdgeCounts::default()
    };
    let has_groups = !group_names.is_empty() || groups.iter().any(|&g| g != 0);
    let mesh = Mesh {
        positions: out.positions,
        triangles,
        attributes: Default::default(),
        groups: has_groups.then_some(groups),
        group_names,
    };
    Finished {
        stats: ClusterStats {
            representative: how,
            cell_size: grid.cell,
            grid: grid.dims,
            occupied_cells: accs.iter().filter(|a| a.w > 0.0).count(),
            search_passes: 0,
            builds: 1,
            collapsed_triangles: stage1.collapsed,
            duplicate_triangles: duplicates,
            flattened_triangles: flattened,
            coverage_triangles: coverage,
            max_error,
            non_manifold_edges: topo.non_manifold_edges,
            non_manifold_vertices: topo.non_manifold_vertices,
            boundary_edges: topo.boundary_edges,
            streamed: false,
            working_bytes,
        },
        mesh,
        vertex_of_cell,
    }
}

/// Each cell's representative (sums `accs`) and its error ([`rep_point`]), in
/// parallel for many cells.
fn representatives(
    grid: &Grid,
    table: &CellTable,
    accs: &[Acc],
    how: Representative,
) -> Vec<([f32; 3], Option<f64>)> {
    let rep_of = |(i, a): (usize, &Acc)| rep_point(grid, table, how, i, a);
    if accs.len() < PAR_REPS || rayon::current_num_threads() == 1 {
        // Sequentially (no pool), as the AVX2 build when the CPU has it.
        // A plain loop: an iterator adapter's `fold` would stay out of line,
        // outside the AVX2 build.
        let mut reps = Vec::with_capacity(accs.len());
        crate::isa::dispatch!(for (i, a) in accs.iter().enumerate() {
            reps.push(rep_point(grid, table, how, i, a));
        });
        reps
    } else {
        accs.par_iter()
            .with_min_len(1024)
            .enumerate()
            .map(rep_of)
            .collect()
    }
}

/// What [`Emit::triangle`] did with a cell triple.
enum Emitted {
    /// Dropped: two corners on one welded point, or zero area.
    Flat,
    /// Dropped: a copy of a triangle over the same welded points.
    Duplicate,
    /// Written out.
    Added,
}

/// The output triangles over the cells' representatives, written as they come.
struct Emit<'a> {
    /// The output vertices, created on first use.
    out: OutVertices<'a>,
    /// The welded point of each cell.
    point_of: &'a [u32],
    /// The representative of each cell.
    positions: &'a [[f32; 3]],
    /// Whether representatives of distinct cells coincide (then copies over the
    /// welded points are looked for in `set`).
    merged: bool,
    set: TripleSet,
    triangles: Vec<[u32; 3]>,
    groups: Vec<u32>,
}

impl Emit<'_> {
    /// Writes the triangle over cells `c` (group `g`) unless it is flat or a copy.
    #[inline]
    fn triangle(&mut self, c: [u32; 3], g: u32) -> Emitted {
        let p = c.map(|x| self.point_of[x as usize]);
        if p[0] == p[1] || p[1] == p[2] || p[0] == p[2] {
            return Emitted::Flat;
        }
        let pos = c.map(|x| self.positions[x as usize]);
        // Zero area is a zero cross product (the square root changes nothing).
        let e = edge_cross(&pos);
        if e[0] * e[0] + e[1] * e[1] + e[2] * e[2] == 0.0 {
            return Emitted::Flat;
        }
        if self.merged && !self.set.insert(p) {
            return Emitted::Duplicate;
        }
        // Written out (`map` calls its closure out of line), in corner order.
        let out = &mut self.out;
        let t = [out.vertex(p[0]), out.vertex(p[1]), out.vertex(p[2])];
        self.triangles.push(t);
        self.groups.push(g);
        Emitted::Added
    }

    /// Writes the coverage repair's triangles (`repair`, group 0) and keeps
    /// `vertex_of_cell` up to date; returns how many were written.
    fn coverage(&mut self, repair: Vec<[u32; 3]>, vertex_of_cell: &mut [u32]) -> usize {
        let mut coverage = 0;
        // Without coinciding representatives `triangle` fills no triple set: a
        // repair triangle (over an orphan cell) cannot repeat a first-stage one,
        // but two repair triangles can cover the same three cells, in either
        // order (a random soup of 13 triangles gave one such pair), so the set,
        // empty until now, takes the repair's triples.
        for c in repair {
            let p = c.map(|x| self.point_of[x as usize]);
            // (A triple with a repeated point is flat: `triangle` drops it.)
            let distinct = p[0] != p[1] && p[1] != p[2] && p[0] != p[2];
            if !self.merged && distinct && !self.set.insert(p) {
                continue;
            }
            if !matches!(self.triangle(c, 0), Emitted::Added) {
                continue;
            }
            coverage += 1;
            if !self.merged {
                // One cell per point: only these three cells can have gained a vertex.
                for x in c {
                    vertex_of_cell[x as usize] =
                        self.out.of_point[self.point_of[x as usize] as usize];
                }
            }
        }
        if coverage > 0 && self.merged {
            for (v, &p) in vertex_of_cell.iter_mut().zip(self.point_of) {
                *v = self.out.of_point[p as usize];
            }
        }
        coverage
    }
}

/// The representative of cell `i` (sums `a`) in mesh coordinates, and its error.
#[inline(always)]
fn rep_point(
    grid: &Grid,
    table: &CellTable,
    how: Representative,
    i: usize,
    a: &Acc,
) -> ([f32; 3], Option<f64>) {
    let corner = grid.corner(grid::unpack(table.key(i as u32)));
    let (x, err) = representative(a, corner, grid.cell, how);
    let p: [f32; 3] = std::array::from_fn(|k| (grid.origin[k] + corner[k] + x[k]) as f32);
    (p, err)
}

/// The manifold counts of the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct EdgeCounts {
    non_manifold_edges: usize,
    non_manifold_vertices: usize,
    boundary_edges: usize,
}

impl EdgeCounts {
    /// Writes the counts into `stats`.
    fn record(self, stats: &mut ClusterStats) {
        stats.non_manifold_edges = self.non_manifold_edges;
        stats.non_manifold_vertices = self.non_manifold_vertices;
        stats.boundary_edges = self.boundary_edges;
    }
}

/// Boundary and non-manifold edges and non-manifold vertices of `triangles` over
/// `vertices` points, as [`crate::mesh::stats::TopologyStats`] counts them, for
/// triangles with three distinct points and no two over the same points (the
/// output's invariants). Linear in the output size: the `3t` corners are grouped by
/// vertex (a counting sort), each with its triangle's other two points; scanning
/// vertex `v`'s group, the number of its corners whose triangle holds `x` is the
/// number of sides of edge `vx` (a table indexed by `x`, stamped per vertex), so
/// every vertex sees its own edges' valences without a global edge table, and each
/// edge is counted at its smaller end. A vertex's fans are the connected components
/// of its corners, two corners joined when their triangles share an edge at the
/// vertex with exactly two sides (a union–find over the group); a vertex on a
/// non-manifold edge is non-manifold whatever its fans. Everything a vertex needs
/// lies in its own group, so the work stays in cache on large outputs, where the
/// earlier per-corner link walk waited on memory.
fn edge_counts(triangles: &[[u32; 3]], vertices: usize) -> EdgeCounts {
    crate::isa::dispatch!(edge_counts_impl(triangles, vertices))
}

/// [`edge_counts`], inlined into each build.
#[inline(always)]
fn edge_counts_impl(triangles: &[[u32; 3]], vertices: usize) -> EdgeCounts {
    let flat = triangles.as_flattened();
    // The corners grouped by vertex (a counting sort): `start[v] .. start[v + 1]`
    // holds, per corner of `v`, the triangle's other two points. (`3t` stays below
    // 2³²: the corners are `u32` and a mesh has fewer than 2³²/3 triangles in
    // memory.)
    let mut start = vec![0u32; vertices + 1];
    let ends = &mut start[..vertices];
    for &v in flat {
        if let Some(e) = ends.get_mut(v as usize) {
            *e += 1;
        }
    }
    let mut sum = 0u32;
    for e in ends.iter_mut() {
        sum += *e;
        *e = sum;
    }
    start[vertices] = sum;
    // Filled backwards from each group's end, so `start[v]` ends at its beginning.
    let mut others = vec![[0u32; 2]; sum as usize];
    let ends = &mut start[..vertices];
    for tri in triangles {
        for k in 0..3 {
            if let Some(e) = ends.get_mut(tri[k] as usize) {
                *e -= 1;
                if let Some(o) = others.get_mut(*e as usize) {
                    *o = [tri[(k + 1) % 3], tri[(k + 2) % 3]];
                }
            }
        }
    }
    let mut counts = EdgeCounts::default();
    // Per other point `x` while vertex `v`'s corners are scanned: `v + 1` when `x`
    // was last seen there, the sides over edge `vx` so far and the corner that
    // brought the first.
    let mut seen = vec![[0u32; 3]; vertices];
    // The fans of `v`: a union–find over its corners (a local index), two corners
    // joined when their triangles share an edge at `v` that has exactly two sides.
    let mut fans_of = UnionFind::new(0);
    for v in 0..vertices {
        let (lo, hi) = (start[v] as usize, start[v + 1] as usize);
        let Some(own) = others.get(lo..hi) else {
            continue;
        };
        let stamp = v as u32 + 1;
        fans_of.reset(own.len());
        let mut fans = own.len();
        let mut non_manifold = false;
        for (i, pair) in own.iter().enumerate() {
            for &x in pair {
                let Some(e) = seen.get_mut(x as usize) else {
                    continue;
                };
                // Each edge is counted at its smaller end; its sides are seen at both.
                let ours = u32::from(x > v as u32) as usize;
                if e[0] != stamp {
                    *e = [stamp, 1, i as u32];
                    counts.boundary_edges += ours;
                    continue;
                }
                e[1] += 1;
                match e[1] {
                    2 => {
                        counts.boundary_edges -= ours;
                        if fans_of.union(e[2], i as u32) {
                            fans -= 1;
                        }
                    }
                    3 => {
                        counts.non_manifold_edges += ours;
                        non_manifold = true;
                    }
                    _ => {}
                }
            }
        }
        // On a non-manifold edge the fans above are not meaningful, and not needed.
        counts.non_manifold_vertices += usize::from(non_manifold || fans > 1);
    }
    counts
}

#[cfg(test)]
mod tests;
