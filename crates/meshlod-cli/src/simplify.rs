//! `meshlod simplify IN -o OUT [--ratio R | --triangles N] [--max-error E]
//! [--method qem|melax|cluster|vertex-removal] [--placement optimal|endpoint|midpoint]
//! [--lock-boundary] [--pair-threshold T] [--json]`; vertex clustering adds
//! `[--cell-size E] [--count-tolerance F] [--representative quadric|average|weighted]
//! [--stream]`, vertex removal `[--feature-angle DEG] [--keep-corners]`.
//!
//! `--help` shows the everyday flags grouped by method (at most 20, a test checks);
//! the tuning knobs (`--defer-below`, `--solve-condition`, …) are hidden there but
//! parse as before, and `--help-tuning` lists them ([`tuning_help`]).
//!
//! Reads with `meshlod::io::read_scene`, simplifies, writes with `write_scene`. A glTF
//! input written back as glTF keeps its scene: each part (glTF mesh) is simplified
//! separately with the same ratio, so materials, nodes and skins survive. Any other
//! combination is flattened into one mesh first.
//!
//! `error` and `--max-error` are distances as a fraction of the bounding-box diagonal
//! (`--absolute`: in mesh units). The distance of a collapse is `sqrt(Δ/W)`, the
//! quadric error `Δ` of the new vertex over the area weight `W` accumulated in its
//! quadric: the area-weighted RMS distance to the original planes it replaces.
//! With `--method vertex-removal` it is the accumulated error bound of
//! `meshlod::decimate::vertex_removal` (a distance from the input surface to the
//! output triangle that replaced it).

use crate::memory::{self, MemoryReport, Phases};
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use meshlod::collapse::{CollapseRecord, NonManifoldPoints};
use meshlod::decimate::cluster::{ClusterOptions, ClusterStats, Representative};
use meshlod::decimate::Observer;
use meshlod::io::{read_scene, write_scene, Format, Scene, WriteOptions};
use meshlod::metrics::{self, Distances, SamplingOptions};
use meshlod::simplify::{
    simplify_observed, simplify_stream, Distance, Method, Phases as Steps, Report, SimplifyOptions,
    StopReason,
};
use serde::Serialize;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Headings of `meshlod simplify --help` (the everyday flags, by method).
mod heading {
    pub const TARGET: &str = "Target";
    pub const METHOD: &str = "Method";
    pub const QEM: &str = "QEM (--method qem)";
    pub const CLUSTER: &str = "Clustering (--method cluster)";
    pub const OUTPUT: &str = "Output";
    pub const TUNING_QEM: &str = "Tuning: edge collapse (qem, melax)";
    pub const TUNING_VERTEX_REMOVAL: &str = "Tuning: vertex removal";
    pub const TUNING_CLUSTER: &str = "Tuning: clustering";
    pub const TUNING_ANY: &str = "Tuning: every method";
}

/// The footer of `meshlod simplify --help`, pointing at the tuning options.
const TUNING_FOOTER: &str = "Tuning options (thresholds and orders of each method, whose defaults \
suit most meshes) are hidden here: `meshlod simplify --help-tuning` lists them.";

/// Arguments of `meshlod simplify`.
///
/// The everyday flags are shown by `--help`, grouped by method; the tuning knobs are
/// hidden there (`hide = true`) and listed by `--help-tuning` ([`tuning_help`]). Every
/// flag parses whether shown or not.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true, after_help = TUNING_FOOTER, after_long_help = TUNING_FOOTER)]
pub struct SimplifyArgs {
    /// Input mesh (.obj .ply .stl .off .gltf .glb .m).
    pub input: PathBuf,
    /// List the tuning options hidden from --help, and exit.
    #[arg(long, hide = true, exclusive = true)]
    pub help_tuning: bool,

    // Target.
    /// Keep this fraction of the triangles (0..=1). Default 0.5 when neither
    /// --ratio, --triangles nor --max-error is given.
    #[arg(long, conflicts_with = "triangles", help_heading = heading::TARGET)]
    pub ratio: Option<f64>,
    /// Target triangle count.
    #[arg(long, help_heading = heading::TARGET)]
    pub triangles: Option<usize>,
    /// Stop before a collapse whose error exceeds this distance (a fraction of the
    /// bounding-box diagonal, or mesh units with --absolute).
    #[arg(long, help_heading = heading::TARGET)]
    pub max_error: Option<f64>,
    /// Read --max-error and --pair-threshold, and print `error`, in mesh units.
    #[arg(long, help_heading = heading::TARGET)]
    pub absolute: bool,

    // Method.
    /// Simplification method: `qem`, quadric error metric edge collapse (Garland &
    /// Heckbert); `cluster`, vertex clustering on a uniform grid (Rossignac & Borrel;
    /// Lindstrom); `vertex-removal`, Schroeder vertex decimation (output vertices are
    /// input vertices); `melax`, Melax's edge cost, half-edge collapses (no vertex
    /// moves).
    #[arg(long, value_enum, default_value_t = MethodArg::Qem, hide_possible_values = true, help_heading = heading::METHOD)]
    pub method: MethodArg,
    /// Never move or remove a boundary vertex (qem, melax, vertex-removal).
    #[arg(long, help_heading = heading::METHOD)]
    pub lock_boundary: bool,
    /// Threads (default: all cores). qem on a mesh of a million triangles or more,
    /// to a quarter of it or less, simplifies spatial chunks in parallel, then
    /// the whole; the orientation repair uses them too. The output is the same
    /// for every thread count.
    #[arg(long, value_name = "N", help_heading = heading::METHOD)]
    pub threads: Option<usize>,
    /// qem: simplify a mesh of a million triangles or more as a whole (the
    /// decimation on one thread), in the exact global order, instead of in chunks
    /// (slower).
    #[arg(long, hide = true, help_heading = heading::TUNING_QEM)]
    pub no_chunks: bool,

    // QEM.
    /// Where QEM places a merged vertex: `optimal`, the quadric minimiser (default);
    /// `endpoint`, the better endpoint (half-edge collapses, no vertex moves, as
    /// `meshlod pm build --method qem` records); `midpoint`, the edge midpoint.
    #[arg(long, value_enum, hide_possible_values = true, hide = true, help_heading = heading::TUNING_QEM)]
    pub placement: Option<PlacementArg>,
    /// qem (optimal or midpoint placement): after simplifying, swap diagonals toward
    /// the input (--swap), then move the output's points toward the input surface
    /// without raising the largest distance around them (2 iterations; with the
    /// swaps, Hausdorff mean 6-22% lower on the benchmark meshes than without --fit
    /// and maxima lower or within 0.01%, at 1.8-2.8x the time).
    #[arg(long, help_heading = heading::QEM)]
    pub fit: bool,
    /// qem (optimal or midpoint placement): after simplifying, swap the diagonal of
    /// two triangles where the other one lies nearer the input surface, without
    /// raising the largest distance around it (lowered the Hausdorff mean by 1-10% on
    /// the benchmark meshes, at 1.0-1.5x the time; --fit includes it).
    #[arg(long, hide = true, help_heading = heading::TUNING_QEM)]
    pub swap: bool,
    /// Also contract non-edge vertex pairs closer than T (fraction of the diagonal,
    /// or mesh units with --absolute), joining separate parts. Lets the topology
    /// change (implies --free-topology, without removing parts).
    #[arg(long, value_name = "T", help_heading = heading::QEM)]
    pub pair_threshold: Option<f64>,
    /// qem, melax: let the topology change where that reaches the target (as
    /// MeshLab's QEM without "preserve topology"): a hole closes once it is down
    /// to three border edges, a separate part is removed whole once the collapses
    /// cost more than its distance to the rest (the largest part always stays),
    /// and points where parts touch may slide. For meshes of many parts and holes
    /// (CAD assemblies, scans) that otherwise stop far above low targets. Never
    /// makes fold-overs or non-manifold edges.
    #[arg(long, help_heading = heading::QEM)]
    pub free_topology: bool,
    /// qem: weights of the attributes in the cost, e.g. `normal=0.002,uv=0.1,color=0.1`
    /// (the defaults; names normal, uv, color; 0 leaves one out). An attribute error
    /// of 1/W costs as much as moving a point by the bounding-box diagonal; merged
    /// vertices get the attribute values that minimise it.
    #[arg(long, value_name = "NAME=W,...", hide = true, help_heading = heading::TUNING_QEM)]
    pub attribute_weight: Option<String>,
    /// qem: let points on texture seams and material borders collapse across the
    /// seam at its attribute cost, like any other collapse (by default a seam is
    /// crossed only where keeping it costs ten times more): lower errors and
    /// counts on meshes cut by many seams, some texture distortion near them.
    #[arg(long, help_heading = heading::QEM, conflicts_with = "strict_seams")]
    pub permissive: bool,
    /// qem: never cross a texture seam or material border (points on one only
    /// slide along it, whatever that costs); a mesh cut by many seams may stop
    /// above its target.
    #[arg(long, hide = true, help_heading = heading::TUNING_QEM)]
    pub strict_seams: bool,

    // Vertex removal.
    /// vertex-removal: dihedral angle in degrees above which an edge is a feature
    /// (default 15).
    #[arg(long, value_name = "DEG", hide = true, help_heading = heading::TUNING_VERTEX_REMOVAL)]
    pub feature_angle: Option<f64>,
    /// vertex-removal: never remove corner vertices (one or more than two feature
    /// edges).
    #[arg(long, hide = true, help_heading = heading::TUNING_VERTEX_REMOVAL)]
    pub keep_corners: bool,

    // Clustering.
    /// Cluster cell side (--method cluster): a fraction of the bounding-box diagonal,
    /// or mesh units with --absolute. Overrides --ratio/--triangles.
    #[arg(long, value_name = "E", help_heading = heading::CLUSTER)]
    pub cell_size: Option<f64>,
    /// Cluster representative (--method cluster): `quadric`, the minimiser of the
    /// cell's plane quadrics (Lindstrom 2000); `average`, the mean of the cell's
    /// triangle corners; `weighted`, their area-weighted mean.
    #[arg(long, value_enum, default_value_t = RepresentativeArg::Quadric, hide_possible_values = true, help_heading = heading::CLUSTER)]
    pub representative: RepresentativeArg,
    /// Stream the input triangle by triangle (--method cluster; STL, binary PLY, OBJ):
    /// memory proportional to the occupied cells, the file is read twice, attributes
    /// are not carried.
    #[arg(long, help_heading = heading::CLUSTER)]
    pub stream: bool,

    // Output.
    /// Output mesh; the format follows the extension.
    #[arg(short = 'o', long = "output", help_heading = heading::OUTPUT)]
    pub output: PathBuf,
    /// Write ASCII where the format has a choice (PLY, STL).
    #[arg(long, help_heading = heading::OUTPUT)]
    pub ascii: bool,
    /// Print the report as one JSON object.
    #[arg(long, help_heading = heading::OUTPUT)]
    pub json: bool,
    /// Also measure the result against the input: symmetric Hausdorff, mean and RMS
    /// distance (Metro sampling, as `meshlod measure` with default samples), added to
    /// the report as `hausdorff` (relative to the bbox diagonal, or absolute with
    /// --absolute) and `measure` (both directions, absolute units).
    #[arg(long, help_heading = heading::OUTPUT)]
    pub measure: bool,
    /// Also write a PNG picture of the input and the output side by side (same
    /// camera, iso view), captioned with their triangle counts and the error
    /// (measured with --measure, else the simplifier's estimate).
    #[arg(long, value_name = "OUT.png", help_heading = heading::OUTPUT)]
    pub preview: Option<PathBuf>,

    // Tuning (hidden from --help; `--help-tuning`): edge collapse.
    /// Weight of the boundary constraint planes (default 10).
    #[arg(long, value_name = "W", hide = true, help_heading = heading::TUNING_QEM)]
    pub boundary_weight: Option<f64>,
    /// QEM triangle weights area^A (1 = area weighting, default; 0.5 keeps fine
    /// detail and lowers the maximum error on most meshes; 0 = uniform).
    #[arg(long, value_name = "A", hide = true, help_heading = heading::TUNING_QEM)]
    pub area_exponent: Option<f64>,
    /// QEM: conditioning threshold C of the optimal-placement solve, in [0, 1):
    /// where det(A) <= C·(tr(A)/3)³ (A the quadric's 3×3 part) the vertex goes to
    /// the best point on the edge instead. Default 1e-7.
    #[arg(long, value_name = "C", hide = true, help_heading = heading::TUNING_QEM)]
    pub solve_condition: Option<f64>,
    /// QEM: displacement guard weight L (0 = off, default): a collapse whose old
    /// points end up a distance e off the triangles it leaves ranks at least
    /// L · W · e², W the pair's quadric weight (area-scaled; protects thin tips
    /// the plane quadric cannot see shortened).
    #[arg(long, value_name = "L", hide = true, help_heading = heading::TUNING_QEM)]
    pub displacement_guard: Option<f64>,
    /// Refuse collapses that turn a triangle's normal by more than DEG degrees.
    #[arg(long, value_name = "DEG", hide = true, help_heading = heading::TUNING_QEM)]
    pub max_normal_deviation: Option<f64>,
    /// Minimum quality of new triangles (0 disables the sliver guard; default 0.1).
    #[arg(long, value_name = "Q", hide = true, help_heading = heading::TUNING_QEM)]
    pub min_quality: Option<f64>,
    /// qem, melax: skip the orientation repair (diagonal swaps that turn triangles
    /// facing away from the input back toward it without raising the distance).
    #[arg(long, hide = true, help_heading = heading::TUNING_QEM)]
    pub no_facing_repair: bool,
    /// qem: keep the collapses' normals, texture coordinates and colours (skip the
    /// least-squares refit of those values to the input's).
    #[arg(long, hide = true, help_heading = heading::TUNING_QEM)]
    pub no_refit_attributes: bool,
    /// With --fit: no diagonal swaps (the fitting alone; without --fit there are
    /// none anyway).
    #[arg(long, conflicts_with = "swap", hide = true, help_heading = heading::TUNING_QEM)]
    pub no_swap: bool,
    /// qem: iterations of the --fit fitting (default 2; implies --fit when above 0).
    #[arg(long, value_name = "N", hide = true, help_heading = heading::TUNING_QEM)]
    pub fit_iterations: Option<u32>,

    // Tuning: vertex removal.
    /// vertex-removal: the removal order. `fast` (default): neighbours of a removal
    /// wait at their previous cost, and a removal within 1.2x of the next queued
    /// cost is done at once, until a removal's cost reaches 0.2% of the
    /// bounding-box diagonal; the exact order from there on. `exact`: always the
    /// cheapest removal first (lower error, about 1.5-1.9x the instructions).
    /// --order-slack and --defer-neighbours without --order start from `exact`, as
    /// before.
    #[arg(long, value_enum, hide = true, help_heading = heading::TUNING_VERTEX_REMOVAL)]
    pub order: Option<OrderArg>,
    /// vertex-removal: order slack S >= 1: a removal whose exact cost is at most S
    /// times the next queued cost is done at once (1 = exact cheapest-first order;
    /// given without --order it starts from the exact order).
    #[arg(long, value_name = "S", hide = true, help_heading = heading::TUNING_VERTEX_REMOVAL)]
    pub order_slack: Option<f64>,
    /// vertex-removal: deferred re-keying: neighbours of a removal stay queued at
    /// their previous cost divided by P (>= 1) until they come out of the queue
    /// (faster, inexact order; given without --order it starts from the exact
    /// order and defers for the whole run; default: --order).
    #[arg(long, value_name = "P", hide = true, help_heading = heading::TUNING_VERTEX_REMOVAL)]
    pub defer_neighbours: Option<f64>,
    /// vertex-removal, while deferring (the fast order, or --defer-neighbours):
    /// defer only while the removed point's cost is below F times the bounding-box
    /// diagonal; exact order from the first removal that reaches it on (default:
    /// 0.002 in the fast order; the whole run with --defer-neighbours alone).
    #[arg(long, value_name = "F", hide = true, help_heading = heading::TUNING_VERTEX_REMOVAL)]
    pub defer_below: Option<f64>,
    /// vertex-removal, while deferring (the fast order, or --defer-neighbours): bound
    /// a deferred neighbour's changed fan at once and queue it at the larger of that
    /// bound and its deferred cost.
    #[arg(long, hide = true, help_heading = heading::TUNING_VERTEX_REMOVAL)]
    pub defer_bound: bool,
    /// vertex-removal, while deferring (the fast order, or --defer-neighbours): order
    /// slack until --defer-below's switch; `inf`: every planned candidate is removed
    /// when it comes out (default: 1.2 in the fast order; --order-slack with
    /// --defer-neighbours alone).
    #[arg(long, value_name = "S", hide = true, help_heading = heading::TUNING_VERTEX_REMOVAL)]
    pub defer_slack: Option<f64>,

    // Tuning: clustering.
    /// Relative tolerance on the triangle count when --method cluster searches its cell
    /// size for --ratio/--triangles (default 0.05: within 5% of the target). Smaller
    /// values cost more probes of the grid.
    #[arg(long, value_name = "F", hide = true, help_heading = heading::TUNING_CLUSTER)]
    pub count_tolerance: Option<f64>,

    // Tuning: every method.
    /// Keep a flat-shaded input's normals as they are. By default, when every
    /// triangle's corners carry its own facet normal (every point split into one
    /// vertex per triangle, so no point could move), the normals are set aside
    /// while simplifying and the output gets its own triangles' facet normals.
    #[arg(long, hide = true, help_heading = heading::TUNING_ANY)]
    pub no_reshade_flat: bool,
}

/// The text of `meshlod simplify --help-tuning`: the flags hidden from `--help`,
/// under their headings, from the same clap definitions (so it cannot drift).
pub fn tuning_help(simplify: &clap::Command) -> String {
    let mut cmd = simplify
        .clone()
        .about("Tuning options of `meshlod simplify`: thresholds and orders of each method, whose defaults suit most meshes. Each flag is accepted with the everyday ones of `meshlod simplify --help`.")
        .long_about(None)
        .after_help("")
        .after_long_help("")
        .override_usage("meshlod simplify INPUT -o OUTPUT [OPTIONS] [TUNING OPTIONS]")
        .disable_help_flag(true)
        .mut_args(|a| {
            let tuning = a.is_hide_set() && a.get_id() != "help_tuning";
            a.hide(!tuning)
        });
    cmd.render_long_help().to_string()
}

/// `--representative` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RepresentativeArg {
    /// Minimiser of the cell's plane quadrics (Lindstrom 2000).
    Quadric,
    /// Mean of the cell's triangle corners.
    Average,
    /// Area-weighted mean.
    Weighted,
}

/// `--order` (vertex removal).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OrderArg {
    /// Deferred neighbours and slack 1.2 while costs are small, exact after.
    Fast,
    /// The cheapest removal first, always.
    Exact,
}

/// `--method` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodArg {
    /// Quadric error metric edge collapse (Garland & Heckbert).
    Qem,
    /// Vertex clustering on a uniform grid (Rossignac & Borrel; Lindstrom).
    Cluster,
    /// Schroeder vertex decimation: vertex removal, split-plane hole triangulation;
    /// output vertices are input vertices.
    VertexRemoval,
    /// Melax's edge cost, half-edge collapses (no vertex moves).
    Melax,
}

/// `--placement` values (QEM).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PlacementArg {
    /// The quadric minimiser (default).
    Optimal,
    /// The better endpoint: half-edge collapses, no vertex moves.
    Endpoint,
    /// The edge midpoint.
    Midpoint,
}

/// The JSON report.
#[derive(Debug, Serialize)]
struct CliReport {
    input: String,
    output: String,
    method: &'static str,
    parts: usize,
    triangles_in: usize,
    vertices_in: usize,
    target_triangles: usize,
    triangles_out: usize,
    vertices_out: usize,
    /// Relative to the diagonal, or absolute with --absolute.
    error: f64,
    error_relative: f64,
    error_absolute: f64,
    error_units: &'static str,
    bbox_diagonal: f64,
    stop_reason: StopReason,
    stop_detail: String,
    seconds: f64,
    read_seconds: f64,
    write_seconds: f64,
    collapses: usize,
    non_edge_contractions: usize,
    degenerate_removed: usize,
    duplicate_removed: usize,
    /// Non-manifold points of the input after the repair (not clustering).
    #[serde(skip_serializing_if = "Option::is_none")]
    non_manifold_points_in: Option<usize>,
    /// Non-manifold points of the output by why they stayed (qem, melax).
    #[serde(skip_serializing_if = "Option::is_none")]
    non_manifold_kept: Option<NonManifoldPoints>,
    /// Diagonal swaps of the orientation repair (qem, melax).
    facing_flips: usize,
    /// Times pairs rejected earlier were queued again once the queue's cost had
    /// grown past theirs (qem, melax).
    retries: usize,
    /// Holes of three border edges closed by a collapse (--free-topology).
    holes_closed: usize,
    /// Separate parts (connected components) removed whole (--free-topology).
    components_removed: usize,
    /// Output points moved by the vertex fitting (qem).
    fit_moved: usize,
    /// Output vertices whose normals, texture coordinates or colours were refitted
    /// to the input's (qem).
    attributes_refit: usize,
    /// Diagonals swapped toward the input (qem).
    edge_swaps: usize,
    /// The input was flat shaded: simplified without its normals, and the output
    /// given its own facet normals (see --no-reshade-flat).
    flat_shading: bool,
    /// Output triangles facing away from the input before and after the repair.
    #[serde(skip_serializing_if = "Option::is_none")]
    facing_away: Option<[usize; 2]>,
    /// Symmetric Hausdorff distance of output vs input (with --measure), in the units
    /// of `error`.
    #[serde(skip_serializing_if = "Option::is_none")]
    hausdorff: Option<f64>,
    /// Full measurement (with --measure), absolute units.
    #[serde(skip_serializing_if = "Option::is_none")]
    measure: Option<Distances>,
    /// Non-manifold edges of the result (--method cluster).
    #[serde(skip_serializing_if = "Option::is_none")]
    non_manifold_edges: Option<usize>,
    /// Non-manifold vertices of the result (--method cluster).
    #[serde(skip_serializing_if = "Option::is_none")]
    non_manifold_vertices: Option<usize>,
    /// Clustering details (--method cluster, single mesh).
    #[serde(skip_serializing_if = "Option::is_none")]
    cluster: Option<ClusterStats>,
    /// Resident memory (Linux only): the peak up to the output being written, and
    /// the simplifier's share per input triangle.
    #[serde(skip_serializing_if = "Option::is_none")]
    memory: Option<MemoryReport>,
    /// Seconds of each step of the simplification (summed over a scene's parts):
    /// `build`, `decimate`, `output`, `refine`.
    phase_seconds: Steps,
    /// The before/after picture written (with --preview).
    #[serde(skip_serializing_if = "Option::is_none")]
    preview: Option<String>,
}

/// Progress bar on stderr, advanced by removed triangles.
struct Progress {
    bar: Option<ProgressBar>,
    start: usize,
}

impl Observer for Progress {
    fn started(&mut self, triangles: usize, target: usize) {
        if let Some(b) = &self.bar {
            b.set_length((self.start.max(triangles) - target.min(triangles)) as u64);
        }
        self.start = triangles;
    }
    fn collapsed(&mut self, _record: &CollapseRecord) {}
    fn progress(&mut self, triangles: usize) {
        if let Some(b) = &self.bar {
            b.set_position(self.start.saturating_sub(triangles) as u64);
        }
    }
}

fn options(args: &SimplifyArgs) -> Result<SimplifyOptions> {
    let dist = |v: f64| {
        if args.absolute {
            Distance::Absolute(v)
        } else {
            Distance::Relative(v)
        }
    };
    let mut o = SimplifyOptions::default().with_method(match args.method {
        MethodArg::Qem => Method::Qem,
        MethodArg::Cluster => Method::Cluster,
        MethodArg::VertexRemoval => Method::VertexRemoval,
        MethodArg::Melax => Method::Melax,
    });
    if args.method != MethodArg::Cluster
        && (args.stream
            || args.cell_size.is_some()
            || args.count_tolerance.is_some()
            || args.representative != RepresentativeArg::Quadric)
    {
        bail!(
            "--stream, --cell-size, --count-tolerance and --representative need --method cluster"
        );
    }
    let mut c = ClusterOptions::default().with_representative(match args.representative {
        RepresentativeArg::Quadric => Representative::Quadric,
        RepresentativeArg::Average => Representative::Average,
        RepresentativeArg::Weighted => Representative::Weighted,
    });
    if let Some(e) = args.cell_size {
        if !(e > 0.0 && e.is_finite()) {
            bail!("--cell-size {e} is not a positive distance");
        }
        c = c.with_cell_size(dist(e));
    }
    if let Some(t) = args.count_tolerance {
        if !(t > 0.0 && t < 1.0) {
            bail!("--count-tolerance {t} is not a fraction between 0 and 1");
        }
        c = c.with_tolerance(t);
    }
    o = o.with_cluster(c);
    o.chunks = !args.no_chunks;
    if let Some(t) = args.threads {
        if t == 0 {
            bail!("--threads 0: give 1 or more (default: all cores)");
        }
        o = o.with_threads(Some(t));
    }
    if let Some(p) = args.placement {
        o = o.with_placement(match p {
            PlacementArg::Optimal => meshlod::cost::Placement::Optimal,
            PlacementArg::Endpoint => meshlod::cost::Placement::Endpoint,
            PlacementArg::Midpoint => meshlod::cost::Placement::Midpoint,
        });
    }
    if let Some(r) = args.ratio {
        if !(0.0..=1.0).contains(&r) {
            bail!("--ratio {r} is not in [0, 1]");
        }
        o = o.with_ratio(r);
    }
    if let Some(n) = args.triangles {
        o = o.with_target_triangles(n);
    }
    if let Some(e) = args.max_error {
        o = o.with_max_error(dist(e));
    }
    if let Some(t) = args.pair_threshold {
        o = o.with_pair_threshold(dist(t)).with_preserve_topology(false);
    }
    if let Some(w) = args.boundary_weight {
        o = o.with_boundary_weight(w);
    }
    if let Some(a) = args.area_exponent {
        o = o.with_area_exponent(a);
    }
    if let Some(c) = args.solve_condition {
        o = o.with_solve_condition(c);
    }
    if let Some(g) = args.displacement_guard {
        o = o.with_displacement_guard(g);
    }
    if let Some(s) = &args.attribute_weight {
        o.attribute_weights = parse_attribute_weights(s)?;
    }
    o.permissive = args.permissive;
    o.strict_seams = args.strict_seams;
    if args.free_topology {
        o = o.with_preserve_topology(false);
    }
    if let Some(d) = args.max_normal_deviation {
        o = o.with_max_normal_deviation(d);
    }
    if let Some(q) = args.min_quality {
        o = o.with_min_triangle_quality(q);
    }
    if let Some(a) = args.feature_angle {
        if !(0.0..=180.0).contains(&a) {
            bail!("--feature-angle {a} is not in [0, 180]");
        }
        o = o.with_feature_angle(a);
    }
    o = o.with_keep_corners(args.keep_corners);
    // The older knobs (order slack, deferral) refine the exact order unless
    // `--order fast` asks for the fast one.
    let older_knobs = args.order_slack.is_some() || args.defer_neighbours.is_some();
    match args.order {
        Some(OrderArg::Exact) => o = o.with_exact_order(),
        None if older_knobs => o = o.with_exact_order(),
        _ => {}
    }
    if let Some(s) = args.order_slack {
        if !(s >= 1.0 && s.is_finite()) {
            bail!("--order-slack {s} must be a finite number >= 1");
        }
        o = o.with_order_slack(s);
    }
    if let Some(p) = args.defer_neighbours {
        if !(p >= 1.0 && p.is_finite()) {
            bail!("--defer-neighbours {p} must be a finite number >= 1");
        }
        o = o.with_defer_neighbours(Some(p));
    }
    let defer_knobs = args.defer_below.is_some() || args.defer_slack.is_some() || args.defer_bound;
    if defer_knobs && o.defer_neighbours.is_none() {
        bail!(
            "--defer-below, --defer-slack and --defer-bound apply while deferring: use them \
             with the fast order (the default) or with --defer-neighbours"
        );
    }
    if let Some(f) = args.defer_below {
        if !(f >= 0.0 && f.is_finite()) {
            bail!("--defer-below {f} must be a finite number >= 0");
        }
        o = o.with_defer_below(Some(f));
    }
    o = o.with_defer_bound(args.defer_bound);
    if let Some(s) = args.defer_slack {
        if s.is_nan() || s < 1.0 {
            bail!("--defer-slack {s} must be a number >= 1 (or inf)");
        }
        o = o.with_defer_slack(Some(s));
    }
    o = o.with_facing_repair(!args.no_facing_repair);
    o = o.with_refit_attributes(!args.no_refit_attributes);
    o = o.with_reshade_flat(!args.no_reshade_flat);
    let fitting = match args.fit_iterations {
        Some(n) => n > 0,
        None => args.fit,
    };
    o = o.with_edge_swaps(args.swap || (fitting && !args.no_swap));
    if let Some(n) = args.fit_iterations {
        o = o.with_fit_iterations(n);
    } else if args.fit {
        o = o.with_fit_iterations(meshlod::simplify::DEFAULT_FIT_ITERATIONS);
    }
    warn_ignored(args, fitting);
    Ok(o.with_lock_boundary(args.lock_boundary))
}

/// Warns on stderr about flags that the chosen method or placement does not use
/// (the run goes on without them).
/// Parses `--attribute-weight`: `name=W` items separated by commas (names
/// `normal`, `uv`, `color`/`colour`); names not given keep their defaults.
fn parse_attribute_weights(s: &str) -> Result<meshlod::simplify::AttributeWeights> {
    let mut w = meshlod::simplify::AttributeWeights::default();
    for item in s.split(',').map(str::trim).filter(|x| !x.is_empty()) {
        let Some((name, value)) = item.split_once('=') else {
            bail!("--attribute-weight: `{item}` is not NAME=W (names: normal, uv, color)");
        };
        let v: f64 = value.trim().parse().map_err(|_| {
            anyhow::anyhow!("--attribute-weight: `{value}` (for {name}) is not a number")
        })?;
        if !(v >= 0.0 && v.is_finite()) {
            bail!("--attribute-weight: {name}={v} must be finite and non-negative");
        }
        match name.trim() {
            "normal" | "normals" => w.normal = v,
            "uv" | "texcoord" => w.uv = v,
            "color" | "colour" | "colors" => w.color = v,
            other => {
                bail!("--attribute-weight: unknown attribute `{other}` (names: normal, uv, color)")
            }
        }
    }
    Ok(w)
}

fn warn_ignored(args: &SimplifyArgs, fitting: bool) {
    let method = match args.method {
        MethodArg::Qem => "qem",
        MethodArg::Cluster => "cluster",
        MethodArg::VertexRemoval => "vertex-removal",
        MethodArg::Melax => "melax",
    };
    let mut ignored: Vec<&str> = Vec::new();
    let qem_moves = args.method == MethodArg::Qem && args.placement != Some(PlacementArg::Endpoint);
    if !qem_moves {
        if args.swap {
            ignored.push("--swap");
        }
        if fitting {
            ignored.push("--fit");
        }
    }
    if args.keep_corners && args.method != MethodArg::VertexRemoval {
        ignored.push("--keep-corners");
    }
    if args.lock_boundary && args.method == MethodArg::Cluster {
        ignored.push("--lock-boundary");
    }
    if args.free_topology && matches!(args.method, MethodArg::Cluster | MethodArg::VertexRemoval) {
        ignored.push("--free-topology");
    }
    if args.placement.is_some() && args.method != MethodArg::Qem {
        ignored.push("--placement");
    }
    if args.method != MethodArg::Qem {
        if args.attribute_weight.is_some() {
            ignored.push("--attribute-weight");
        }
        if args.permissive {
            ignored.push("--permissive");
        }
        if args.strict_seams {
            ignored.push("--strict-seams");
        }
    }
    if !ignored.is_empty() {
        eprintln!(
            "meshlod: warning: {} not used by --method {method}{}; ignored",
            ignored.join(", "),
            if args.method == MethodArg::Qem {
                " with --placement endpoint"
            } else {
                ""
            }
        );
    }
}

/// Runs `meshlod simplify`.
///
/// # Errors
/// Reading, option, simplification or writing errors, naming the file.
pub fn run(args: &SimplifyArgs) -> Result<()> {
    let opts = options(args)?;
    if args.stream {
        return run_stream(args, &opts);
    }
    let t0 = Instant::now();
    let scene = read_scene(&args.input)?;
    let read_seconds = t0.elapsed().as_secs_f64();
    for part in &scene.parts {
        if crate::warn_precision(&args.input, &part.mesh) {
            break;
        }
    }
    let phases = Phases::after_read();
    let in_format = Format::from_path(&args.input);
    let out_format = Format::from_path(&args.output);
    let is_gltf = |f: Option<Format>| matches!(f, Some(Format::Gltf | Format::Glb));
    let per_part = is_gltf(in_format) && is_gltf(out_format) && scene.gltf.is_some();

    // A progress bar only when a person watches stderr.
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = ProgressBar::new(0);
        b.set_style(
            ProgressStyle::with_template("{spinner} simplifying [{bar:40}] {percent}% {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        b
    });
    let mut progress = Progress { bar, start: 0 };

    let flat_diag = scene.flattened().bbox_diagonal();
    let (out_scene, agg) = if per_part {
        simplify_parts(&scene, &opts, flat_diag, &mut progress)
            .with_context(|| format!("{}", args.input.display()))?
    } else {
        let mesh = scene.flattened();
        let s = simplify_observed(&mesh, &opts, &mut progress)
            .with_context(|| format!("{}", args.input.display()))?;
        let agg = Aggregate::single(s.report);
        let mut out = Scene::from_mesh(s.mesh);
        out.material_libraries = scene.material_libraries.clone();
        (out, agg)
    };
    if let Some(b) = &progress.bar {
        b.finish_and_clear();
    }
    warn_lost_attributes(&args.output, out_format, &out_scene);
    let t1 = Instant::now();
    write_scene(
        &args.output,
        &out_scene,
        &WriteOptions::default().with_ascii(args.ascii),
    )?;
    let write_seconds = t1.elapsed().as_secs_f64();
    let memory = phases.report(agg.triangles_in);
    let measure = args.measure.then(|| {
        metrics::hausdorff(
            &scene.flattened(),
            &out_scene.flattened(),
            &SamplingOptions::default(),
        )
    });
    if let Some(p) = &args.preview {
        preview(
            args,
            p,
            &scene.flattened(),
            &out_scene.flattened(),
            &agg,
            measure.as_ref(),
        )?;
    }
    let times = Times {
        read_seconds,
        write_seconds,
    };
    report(args, &opts, agg, measure, times, memory)
}

/// `--preview`: the input and the output side by side, captioned with their counts
/// and the output's error (the measured Hausdorff distance, or the estimate).
fn preview(
    args: &SimplifyArgs,
    path: &Path,
    input: &meshlod::Mesh,
    output: &meshlod::Mesh,
    agg: &Aggregate,
    measure: Option<&Distances>,
) -> Result<()> {
    use crate::preview::{file_name, percent, thousands};
    let error = match measure {
        Some(d) => format!("Hausdorff {}", percent(d.hausdorff, d.bbox_diagonal)),
        None => format!("est. error {}", percent(agg.error_absolute, agg.diag)),
    };
    let panels = [
        (
            input,
            vec![
                format!("input {}", file_name(&args.input)),
                format!("{} triangles", thousands(input.triangle_count())),
            ],
        ),
        (
            output,
            vec![
                format!("output {}", file_name(&args.output)),
                format!("{} triangles, {error}", thousands(output.triangle_count())),
            ],
        ),
    ];
    crate::preview::write(path, &panels)
}

/// `--stream`: cluster the file without loading it (read twice), write, report.
fn run_stream(args: &SimplifyArgs, opts: &SimplifyOptions) -> Result<()> {
    let s = simplify_stream(&args.input, opts)?;
    let agg = Aggregate::single(s.report);
    let t1 = Instant::now();
    write_scene(
        &args.output,
        &Scene::from_mesh(s.mesh.clone()),
        &WriteOptions::default().with_ascii(args.ascii),
    )?;
    let write_seconds = t1.elapsed().as_secs_f64();
    // The peak so far: reading is part of the run here.
    let memory = memory::rss().map(|r| MemoryReport::peak_only(r.peak));
    // Measuring and the preview need the input in memory.
    let input = if args.measure || args.preview.is_some() {
        Some(read_scene(&args.input)?.flatten())
    } else {
        None
    };
    let measure = match (&input, args.measure) {
        (Some(input), true) => Some(metrics::hausdorff(
            input,
            &s.mesh,
            &SamplingOptions::default(),
        )),
        _ => None,
    };
    if let (Some(p), Some(input)) = (&args.preview, &input) {
        preview(args, p, input, &s.mesh, &agg, measure.as_ref())?;
    }
    let times = Times {
        read_seconds: 0.0,
        write_seconds,
    };
    report(args, opts, agg, measure, times, memory)
}

/// What `format` cannot hold of the scene's meshes, in words (empty for glTF,
/// which holds every attribute meshlod models).
fn lost_attributes(format: Format, scene: &Scene) -> Vec<&'static str> {
    let has = |f: &dyn Fn(&meshlod::Mesh) -> bool| scene.parts.iter().any(|p| f(&p.mesh));
    let (normals, uv0, colors, groups) = match format {
        Format::Gltf | Format::Glb => return Vec::new(),
        Format::Stl => (false, false, false, false),
        Format::Obj => (true, true, true, true),
        Format::Ply | Format::Off | Format::HoppeM => (true, true, true, false),
    };
    let mut lost = Vec::new();
    let mut check = |kept: bool, present: bool, what: &'static str| {
        if !kept && present {
            lost.push(what);
        }
    };
    check(normals, has(&|m| m.attributes.normals.is_some()), "normals");
    check(
        uv0,
        has(&|m| m.attributes.uv0.is_some()),
        "texture coordinates",
    );
    check(colors, has(&|m| m.attributes.colors.is_some()), "colours");
    check(
        false,
        has(&|m| m.attributes.uv1.is_some()),
        "second texture coordinates",
    );
    check(false, has(&|m| m.attributes.tangents.is_some()), "tangents");
    check(
        false,
        has(&|m| m.attributes.joints.is_some() || m.attributes.weights.is_some()),
        "skin weights",
    );
    check(
        groups,
        has(&|m| {
            m.group_names.len() > 1 || m.groups.as_ref().is_some_and(|g| g.iter().any(|&x| x > 0))
        }),
        "material groups",
    );
    lost
}

/// Warns on stderr when the output format drops attributes the result has.
fn warn_lost_attributes(path: &Path, format: Option<Format>, scene: &Scene) {
    let Some(format) = format else { return };
    let lost = lost_attributes(format, scene);
    if !lost.is_empty() {
        eprintln!(
            "meshlod: warning: {}: {} cannot hold the result's {}; written without them (glTF holds them all)",
            path.display(),
            format.name(),
            lost.join(", ")
        );
    }
}

/// Reading and writing times (seconds).
struct Times {
    read_seconds: f64,
    write_seconds: f64,
}

fn report(
    args: &SimplifyArgs,
    opts: &SimplifyOptions,
    agg: Aggregate,
    measure: Option<Distances>,
    times: Times,
    memory: Option<MemoryReport>,
) -> Result<()> {
    let Times {
        read_seconds,
        write_seconds,
    } = times;
    let rel = if agg.diag > 0.0 {
        agg.error_absolute / agg.diag
    } else {
        0.0
    };
    let report = CliReport {
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        method: opts.method.name(),
        parts: agg.parts,
        triangles_in: agg.triangles_in,
        vertices_in: agg.vertices_in,
        target_triangles: agg.target_triangles,
        triangles_out: agg.triangles_out,
        vertices_out: agg.vertices_out,
        error: if args.absolute {
            agg.error_absolute
        } else {
            rel
        },
        error_relative: rel,
        error_absolute: agg.error_absolute,
        error_units: if args.absolute {
            "mesh units"
        } else {
            "fraction of bounding-box diagonal"
        },
        bbox_diagonal: agg.diag,
        stop_reason: agg.stop_reason,
        stop_detail: agg.stop_detail,
        seconds: agg.seconds,
        read_seconds,
        write_seconds,
        collapses: agg.collapses,
        non_edge_contractions: agg.non_edge,
        degenerate_removed: agg.degenerate,
        duplicate_removed: agg.duplicate,
        non_manifold_points_in: agg.nm_in,
        non_manifold_kept: agg.nm_kept,
        facing_flips: agg.facing_flips,
        retries: agg.retries,
        holes_closed: agg.holes_closed,
        components_removed: agg.components_removed,
        fit_moved: agg.fit_moved,
        attributes_refit: agg.attributes_refit,
        edge_swaps: agg.edge_swaps,
        flat_shading: agg.flat_shading,
        facing_away: agg.facing_away,
        hausdorff: measure.map(|d| {
            if args.absolute || d.bbox_diagonal <= 0.0 {
                d.hausdorff
            } else {
                d.hausdorff / d.bbox_diagonal
            }
        }),
        measure,
        non_manifold_edges: agg.cluster.as_ref().map(|c| c.non_manifold_edges),
        non_manifold_vertices: agg.cluster.as_ref().map(|c| c.non_manifold_vertices),
        cluster: agg.cluster,
        memory,
        phase_seconds: agg.phases,
        preview: args.preview.as_ref().map(|p| p.display().to_string()),
    };
    if args.json {
        out!("{}", serde_json::to_string(&report)?);
    } else {
        print_text(&report);
        if let Some(hint) = stall_hint(args, &report) {
            out!("  hint         {hint}");
        }
    }
    Ok(())
}

/// What may take an edge-collapse run that stopped above its target (by more
/// than 1%, for lack of a legal collapse) further: `--free-topology` when the
/// topology was kept, else crossing seams when `--strict-seams` kept them.
/// `None` when neither applies.
fn stall_hint(args: &SimplifyArgs, r: &CliReport) -> Option<&'static str> {
    let above = r.triangles_out as f64 > r.target_triangles as f64 * 1.01 + 1.0;
    let collapse = matches!(args.method, MethodArg::Qem | MethodArg::Melax);
    if !above || !collapse || r.stop_reason != StopReason::NoLegalCollapse {
        return None;
    }
    if !args.free_topology {
        Some("--free-topology lets holes close and separate parts go whole, which may reach the target")
    } else if args.strict_seams {
        Some("without --strict-seams, seams may be crossed where keeping them costs more")
    } else {
        None
    }
}

/// Totals over the parts of a scene.
struct Aggregate {
    parts: usize,
    triangles_in: usize,
    vertices_in: usize,
    target_triangles: usize,
    triangles_out: usize,
    vertices_out: usize,
    error_absolute: f64,
    diag: f64,
    stop_reason: StopReason,
    stop_detail: String,
    seconds: f64,
    collapses: usize,
    non_edge: usize,
    degenerate: usize,
    duplicate: usize,
    facing_flips: usize,
    retries: usize,
    holes_closed: usize,
    components_removed: usize,
    fit_moved: usize,
    attributes_refit: usize,
    edge_swaps: usize,
    flat_shading: bool,
    facing_away: Option<[usize; 2]>,
    cluster: Option<ClusterStats>,
    nm_in: Option<usize>,
    nm_kept: Option<NonManifoldPoints>,
    phases: Steps,
}

impl Aggregate {
    /// No part yet, for a scene of `parts` parts with bounding-box diagonal `diag`.
    fn empty(parts: usize, diag: f64) -> Self {
        Self {
            parts,
            triangles_in: 0,
            vertices_in: 0,
            target_triangles: 0,
            triangles_out: 0,
            vertices_out: 0,
            error_absolute: 0.0,
            diag,
            stop_reason: StopReason::TargetReached,
            stop_detail: String::new(),
            seconds: 0.0,
            collapses: 0,
            non_edge: 0,
            degenerate: 0,
            duplicate: 0,
            facing_flips: 0,
            retries: 0,
            holes_closed: 0,
            components_removed: 0,
            fit_moved: 0,
            attributes_refit: 0,
            edge_swaps: 0,
            flat_shading: false,
            facing_away: None,
            cluster: None,
            nm_in: None,
            nm_kept: None,
            phases: Steps::default(),
        }
    }

    /// The totals of one run over the whole input.
    fn single(r: Report) -> Self {
        let mut a = Self::empty(1, r.bbox_diagonal);
        a.add(&r, 1, 1.0);
        a.stop_reason = r.stop_reason;
        a.stop_detail = r.stop_detail;
        a
    }

    /// Adds one part's counts, drawn `instances` times and scaled by at most
    /// `scale` into the scene (the stop reason is the caller's to set).
    fn add(&mut self, r: &Report, instances: usize, scale: f64) {
        self.triangles_in += instances * r.triangles_in;
        self.vertices_in += instances * r.vertices_in;
        self.target_triangles += instances * r.target_triangles;
        self.triangles_out += instances * r.triangles_out;
        self.vertices_out += instances * r.vertices_out;
        self.error_absolute = self.error_absolute.max(scale * r.error_absolute);
        self.seconds += r.seconds;
        add_steps(&mut self.phases, &r.phases);
        self.collapses += r.collapses;
        self.non_edge += r.non_edge_contractions;
        self.degenerate += r.degenerate_removed;
        self.duplicate += r.duplicate_removed;
        self.facing_flips += r.facing_flips;
        self.retries += r.retries;
        self.holes_closed += instances * r.holes_closed;
        self.components_removed += instances * r.components_removed;
        self.fit_moved += r.fit_moved;
        self.attributes_refit += r.attributes_refit;
        self.edge_swaps += r.edge_swaps;
        self.flat_shading |= r.flat_shading;
        if let Some(n) = r.non_manifold_points_in {
            *self.nm_in.get_or_insert(0) += instances * n;
        }
        if let Some(k) = &r.non_manifold_kept {
            self.nm_kept
                .get_or_insert_with(NonManifoldPoints::default)
                .add(k, instances);
        }
        if let Some([b, a]) = r.facing_away {
            let [sb, sa] = self.facing_away.get_or_insert([0, 0]);
            *sb += b;
            *sa += a;
        }
        if let Some(c) = &r.cluster {
            // Per-part clustering: the counts are summed in the first part's stats.
            match &mut self.cluster {
                Some(a) => a.merge(c),
                None => self.cluster = Some(c.clone()),
            }
        }
    }
}

/// Simplifies every part of a glTF scene with the same ratio. Distances are the
/// scene's (world) ones, the relative ones times its flattened diagonal: a part
/// drawn with a scale works in its own units, so its bounds are divided by its
/// instances' largest stretch and its error multiplied by it. Triangle counts are
/// per instance, as `meshlod info` counts them.
fn simplify_parts(
    scene: &Scene,
    opts: &SimplifyOptions,
    diag: f64,
    progress: &mut Progress,
) -> Result<(Scene, Aggregate)> {
    let started = Instant::now();
    let total: usize = scene
        .parts
        .iter()
        .map(|p| p.mesh.triangles.len() * p.instances.len())
        .sum();
    let mut part_opts = opts.clone();
    if opts.ratio.is_none() {
        if let Some(n) = opts.target_triangles {
            let r = if total > 0 {
                (n as f64 / total as f64).min(1.0)
            } else {
                1.0
            };
            part_opts.ratio = Some(r);
            part_opts.target_triangles = None;
        }
    }
    let abs = |d: Option<Distance>| {
        d.map(|d| match d {
            Distance::Relative(f) => Distance::Absolute(f * diag),
            a @ Distance::Absolute(_) => a,
        })
    };
    let (max_error, pair_threshold) = (abs(opts.max_error), abs(opts.pair_threshold));
    let run = |i: usize, part_opts: &SimplifyOptions, progress: &mut dyn Observer| {
        let part = &scene.parts[i];
        let scale = part_scale(part);
        let local = |d: Option<Distance>| {
            d.map(|d| match d {
                Distance::Absolute(a) => Distance::Absolute(a / scale),
                r @ Distance::Relative(_) => r,
            })
        };
        let mut o = part_opts.clone();
        o.max_error = local(max_error);
        o.pair_threshold = local(pair_threshold);
        simplify_observed(&part.mesh, &o, progress)
            .with_context(|| format!("part {i} ({})", part.name.as_deref().unwrap_or("unnamed")))
    };
    let n_parts = scene.parts.len();
    let instances = |i: usize| scene.parts[i].instances.len();
    // The scene's target: each part's share at the ratio, as many times as drawn.
    let want: usize = (0..n_parts)
        .map(|i| part_opts.target_for(scene.parts[i].mesh.triangles.len()) * instances(i))
        .sum();
    let drawn = (0..n_parts).filter(|&i| instances(i) > 0).count();
    // The probes run every part to 0 triangles: their curves need every collapse
    // (edge collapses on parts that run whole, not in chunks).
    let mut probe = part_opts.clone();
    probe.ratio = None;
    probe.target_triangles = Some(0);
    let by_error_wanted = opts.max_error.is_none()
        && drawn > 1
        && want < total
        && scene
            .parts
            .iter()
            .all(|p| meshlod::simplify::observes_collapses(&p.mesh, &probe));
    let threads = opts
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from));
    // The bar counts each pass over the parts as their triangles: the probes and
    // the runs to the counts share one length, split in proportion to size.
    let bar = progress.bar.clone();
    let work: usize = scene.parts.iter().map(|p| p.mesh.triangles.len()).sum();
    if let Some(b) = &bar {
        let passes = if by_error_wanted { 2 } else { 1 };
        b.set_length((passes * work) as u64);
        b.set_position(0);
    }
    let size = |i: usize| scene.parts[i].mesh.triangles.len();
    // Every run's phase times, each run once (the report gives their sums).
    let mut spent = Steps::default();
    let mut run_all = |jobs: &[(usize, SimplifyOptions)],
                       units: u64,
                       curves: Option<&mut Vec<crate::budget::Curve>>|
     -> Result<Vec<meshlod::simplify::Simplified>> {
        let recording = curves.is_some();
        let sizes: u64 = jobs.iter().map(|(i, _)| size(*i) as u64).sum();
        let share = |i: usize| (units * size(i) as u64).checked_div(sizes).unwrap_or(0);
        let one = |i: usize, o: &SimplifyOptions| {
            let mut shown = PartBar::new(bar.as_ref(), share(i));
            let mut rec =
                crate::budget::CurveRecorder::new(&mut shown, part_scale(&scene.parts[i]));
            let r = if recording {
                run(i, o, &mut rec)
            } else {
                run(i, o, rec.inner())
            }?;
            let curve = rec.into_curve();
            shown.finish();
            Ok((r, curve))
        };
        // A part that runs in chunks uses every thread itself, as does a single
        // part; the others run at once, one thread each, the largest first.
        let alone = |(i, o): &(usize, SimplifyOptions)| {
            threads == 1
                || jobs.len() == 1
                || meshlod::simplify::runs_in_chunks(&scene.parts[*i].mesh, o)
        };
        let mut done: Vec<Option<_>> = (0..jobs.len()).map(|_| None).collect();
        for (j, job) in jobs.iter().enumerate() {
            if alone(job) {
                done[j] = Some(one(job.0, &job.1)?);
            }
        }
        let mut together: Vec<usize> = (0..jobs.len()).filter(|&j| done[j].is_none()).collect();
        together.sort_by_key(|&j| std::cmp::Reverse(size(jobs[j].0)));
        let ran = crate::budget::run_parallel(together.len(), threads, |k| {
            let (i, o) = &jobs[together[k]];
            let mut o = o.clone();
            o.threads = Some(1);
            one(*i, &o)
        })?;
        for (k, r) in ran.into_iter().enumerate() {
            done[together[k]] = Some(r);
        }
        let (results, c): (Vec<_>, Vec<_>) = done.into_iter().flatten().unzip();
        for r in &results {
            add_steps(&mut spent, &r.report.phases);
        }
        if let Some(curves) = curves {
            *curves = c;
        }
        Ok(results)
    };
    let mut results = Vec::with_capacity(n_parts);
    // With the budget split by error: that error (scene units) and the parts
    // left as far as they go.
    let mut by_error: Option<(f64, usize)> = None;
    if by_error_wanted {
        // Split the budget by error (`budget`): every part as far as it goes
        // first, recording its error curve, then again to its count.
        let jobs: Vec<_> = (0..n_parts).map(|i| (i, probe.clone())).collect();
        let mut curves = Vec::new();
        let probes = run_all(&jobs, work as u64, Some(&mut curves))?;
        // A curve that missed collapses (a run that did not report them all)
        // would misplace the budget: then the split by size is used.
        let whole = curves
            .iter()
            .zip(&probes)
            .all(|(c, p)| c.recorded() && c.floor() == p.report.triangles_out);
        let k: Vec<usize> = (0..n_parts).map(instances).collect();
        let split = whole
            .then(|| crate::budget::split(&curves, &k, want))
            .flatten();
        if let Some((e, counts)) = split {
            let again: Vec<_> = (0..n_parts)
                .filter(|&i| counts[i] > probes[i].report.triangles_out)
                .map(|i| {
                    let mut o = part_opts.clone();
                    o.ratio = None;
                    o.target_triangles = Some(counts[i]);
                    (i, o)
                })
                .collect();
            let mut rerun = run_all(&again, work as u64, None)?.into_iter();
            let mut at_floor = 0;
            let mut next = again.iter().map(|(i, _)| *i).peekable();
            for (i, probe) in probes.into_iter().enumerate() {
                if next.peek() == Some(&i) {
                    next.next();
                    results.extend(rerun.next());
                } else {
                    at_floor += usize::from(k[i] > 0);
                    results.push(probe);
                }
            }
            by_error = Some((e, at_floor));
        }
    }
    if results.is_empty() {
        let jobs: Vec<_> = (0..n_parts).map(|i| (i, part_opts.clone())).collect();
        if by_error_wanted {
            if let Some(b) = &bar {
                b.inc_length(work as u64);
            }
        }
        results = run_all(&jobs, work as u64, None)?;
    }
    // Parts that cannot reach their share (a bolt of 12 triangles, a part whose
    // holes all stay) leave the scene above its target: the parts that reached
    // theirs are simplified again, further, to make up the difference (in
    // proportion to their size), up to three times. When even that cannot reach
    // the target, the first results stay: squeezing every other part as far as
    // it goes doubled VC's error for a scene still above its target.
    let mut squeezed = vec![false; results.len()];
    let first = results.clone();
    if opts.max_error.is_none() {
        for _ in 0..3 {
            let have: usize = (0..results.len())
                .map(|i| results[i].report.triangles_out * instances(i))
                .sum();
            let slack: Vec<usize> = (0..results.len())
                .filter(|&i| {
                    results[i].report.stop_reason == StopReason::TargetReached
                        && results[i].report.triangles_out > 1
                })
                .collect();
            let room: usize = slack
                .iter()
                .map(|&i| results[i].report.triangles_out * instances(i))
                .sum();
            if have <= want || room == 0 {
                break;
            }
            let keep = (room.saturating_sub(have - want)) as f64 / room as f64;
            let jobs: Vec<_> = slack
                .into_iter()
                .filter_map(|i| {
                    let n = results[i].report.triangles_out;
                    let target = ((n as f64 * keep).floor() as usize).max(1);
                    (target < n).then(|| {
                        let mut o = part_opts.clone();
                        o.ratio = None;
                        o.target_triangles = Some(target);
                        (i, o)
                    })
                })
                .collect();
            let units: u64 = jobs.iter().map(|(i, _)| size(*i) as u64).sum();
            if let Some(b) = &bar {
                b.inc_length(units);
            }
            for ((i, _), r) in jobs.iter().zip(run_all(&jobs, units, None)?) {
                results[*i] = r;
                squeezed[*i] = true;
            }
        }
    }
    let have: usize = (0..results.len())
        .map(|i| results[i].report.triangles_out * instances(i))
        .sum();
    let mut gave_up = false;
    if have > want && squeezed.contains(&true) {
        for (i, s) in first.into_iter().enumerate() {
            if squeezed[i] {
                results[i] = s;
            }
        }
        squeezed.fill(false);
        gave_up = true;
    }
    let mut out = scene.clone();
    let mut agg = Aggregate::empty(scene.parts.len(), diag);
    let mut first_other: Option<(StopReason, String)> = None;
    let mut short = 0;
    for (i, s) in results.into_iter().enumerate() {
        let r = &s.report;
        agg.add(r, instances(i), part_scale(&scene.parts[i]));
        if !matches!(
            r.stop_reason,
            StopReason::TargetReached | StopReason::EmptyInput
        ) {
            short += 1;
            if first_other.is_none() {
                first_other = Some((r.stop_reason, format!("part {i}: {}", r.stop_detail)));
            }
        }
        if let Some(p) = out.parts.get_mut(i) {
            p.mesh = s.mesh;
        }
    }
    agg.target_triangles = want;
    // The parts' runs (some at once on several threads): the wall time, and
    // each phase summed over every run.
    agg.seconds = started.elapsed().as_secs_f64();
    agg.phases = spent;
    let more = squeezed.iter().filter(|&&q| q).count();
    let parts = |n: usize| {
        if n == 1 {
            "1 part".to_string()
        } else {
            format!("{n} parts")
        }
    };
    let (stopped, others) = (parts(short), parts(more));
    match first_other {
        _ if by_error.is_some() && agg.triangles_out <= want => {
            let (e, at_floor) = by_error.unwrap_or_default();
            agg.stop_reason = StopReason::TargetReached;
            let limit = if e.is_finite() {
                format!(
                    " (collapses up to an error of {:.4}% of the diagonal)",
                    100.0 * e.max(0.0) / diag.max(f64::MIN_POSITIVE)
                )
            } else {
                String::new()
            };
            agg.stop_detail = format!(
                "the scene reached its target ({} triangles for {want}), its budget split \
                 between the parts by error{limit}{}{}",
                agg.triangles_out,
                if at_floor > 0 {
                    format!(", {} simplified as far as they go", parts(at_floor))
                } else {
                    String::new()
                },
                if more > 0 {
                    format!(", {others} simplified further to make up for parts above their count")
                } else {
                    String::new()
                }
            );
        }
        Some((_, detail)) if agg.triangles_out <= want => {
            agg.stop_reason = StopReason::TargetReached;
            agg.stop_detail = format!(
                "the scene reached its target ({} triangles for {want}): {stopped} \
                 stopped above {} share of the target{}; first stopped: {detail}",
                agg.triangles_out,
                if short == 1 { "its" } else { "their" },
                if more > 0 {
                    format!(", made up for by simplifying {others} further")
                } else {
                    String::new()
                }
            );
        }
        Some((reason, detail)) => {
            agg.stop_reason = reason;
            agg.stop_detail = if gave_up {
                format!(
                    "{detail} ({stopped} stopped above {} share of the target; the \
                     others, simplified further as far as they could go, would not make \
                     up for {}, so every part keeps its first result)",
                    if short == 1 { "its" } else { "their" },
                    if short == 1 { "it" } else { "them" }
                )
            } else {
                detail
            };
        }
        None => {
            agg.stop_detail = format!(
                "every part reached its target ({} triangles in all)",
                agg.target_triangles
            );
        }
    }
    Ok((out, agg))
}

/// Adds one run's phase times to a sum.
fn add_steps(sum: &mut Steps, r: &Steps) {
    sum.build += r.build;
    sum.decimate += r.decimate;
    sum.output += r.output;
    sum.refine += r.refine;
}

/// A part's share of the scene's progress bar: `units`, advanced as the part
/// goes from its first triangle count toward its target (several parts may
/// advance the bar at once).
struct PartBar<'a> {
    bar: Option<&'a ProgressBar>,
    units: u64,
    start: usize,
    target: usize,
    shown: u64,
}

impl<'a> PartBar<'a> {
    fn new(bar: Option<&'a ProgressBar>, units: u64) -> Self {
        Self {
            bar,
            units,
            start: 0,
            target: 0,
            shown: 0,
        }
    }

    fn show(&mut self, upto: u64) {
        let upto = upto.min(self.units);
        if let Some(b) = self.bar {
            if upto > self.shown {
                b.inc(upto - self.shown);
                self.shown = upto;
            }
        }
    }

    /// The part is done: its whole share shown.
    fn finish(&mut self) {
        self.show(self.units);
    }
}

impl Observer for PartBar<'_> {
    fn started(&mut self, triangles: usize, target: usize) {
        self.start = triangles;
        self.target = target.min(triangles);
    }
    fn progress(&mut self, triangles: usize) {
        let span = self.start - self.target;
        if span > 0 {
            let gone = self.start.saturating_sub(triangles).min(span);
            self.show((self.units as f64 * gone as f64 / span as f64) as u64);
        }
    }
}

/// How much a part's instances stretch it into the scene, at most (1 for one
/// unscaled instance).
fn part_scale(part: &meshlod::io::Part) -> f64 {
    part.instances
        .iter()
        .map(meshlod::io::stretch)
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE)
}

fn print_text(r: &CliReport) {
    let pct = |a: usize, b: usize| {
        if b > 0 {
            100.0 * a as f64 / b as f64
        } else {
            0.0
        }
    };
    out!("{} -> {}  ({})", r.input, r.output, r.method);
    if r.parts > 1 {
        out!("  parts        {} (each simplified separately)", r.parts);
    }
    out!(
        "  triangles    {} -> {} ({:.2}%; target {})",
        r.triangles_in,
        r.triangles_out,
        pct(r.triangles_out, r.triangles_in),
        r.target_triangles
    );
    out!("  vertices     {} -> {}", r.vertices_in, r.vertices_out);
    out!(
        "  error        {:.4}% of the diagonal ({:.4e} mesh units; quadric RMS distance)",
        100.0 * r.error_relative,
        r.error_absolute
    );
    out!("  stopped      {}: {}", r.stop_reason, r.stop_detail);
    if let Some(c) = &r.cluster {
        out!(
            "  clustering   {} representative, cell {:.4e}, {} occupied cells; {} triangles collapsed, {} duplicates, {} flattened, {} added by the coverage repair",
            c.representative.name(),
            c.cell_size,
            c.occupied_cells,
            c.collapsed_triangles,
            c.duplicate_triangles,
            c.flattened_triangles,
            c.coverage_triangles
        );
        out!(
            "  topology     {} non-manifold edges, {} non-manifold vertices, {} boundary edges",
            c.non_manifold_edges,
            c.non_manifold_vertices,
            c.boundary_edges
        );
    }
    out!(
        "  collapses    {} ({} non-edge); repaired {} degenerate, {} duplicate triangles",
        r.collapses,
        r.non_edge_contractions,
        r.degenerate_removed,
        r.duplicate_removed
    );
    if let (Some(n), Some(k)) = (r.non_manifold_points_in, &r.non_manifold_kept) {
        if n > 0 || k.total > 0 {
            out!(
                "  non-manifold {} points in, {} kept: {} corners, {} on a border, {} on a seam, \
                 {} irregular, {} pinches, {} chain points",
                n,
                k.total,
                k.corner,
                k.border,
                k.seam,
                k.irregular,
                k.pinch,
                k.chain
            );
        }
    }
    if let Some([before, after]) = r.facing_away {
        out!(
            "  orientation  {before} triangles facing away from the input, {after} after {} diagonal swaps",
            r.facing_flips
        );
    }
    if r.fit_moved > 0 {
        out!(
            "  fitting      {} points moved toward the input",
            r.fit_moved
        );
    }
    if r.attributes_refit > 0 {
        out!(
            "  attributes   {} vertices' normals, texture coordinates or colours refitted to the input",
            r.attributes_refit
        );
    }
    if r.flat_shading {
        out!("  normals      flat shaded input: simplified without them, output given its facet normals");
    }
    if r.edge_swaps > 0 {
        out!(
            "  swaps        {} diagonals swapped toward the input",
            r.edge_swaps
        );
    }
    if let Some(d) = &r.measure {
        let diag = d.bbox_diagonal.max(f64::MIN_POSITIVE);
        out!(
            "  measured     Hausdorff {:.4}%, mean {:.5}%, rms {:.5}% of the diagonal ({} samples)",
            100.0 * d.hausdorff / diag,
            100.0 * d.mean / diag,
            100.0 * d.rms / diag,
            d.a_to_b.samples + d.b_to_a.samples
        );
    }
    if let Some(p) = &r.preview {
        out!("  preview      {p} (input and output side by side)");
    }
    let p = &r.phase_seconds;
    out!(
        "  time         {:.3} s simplify (build {:.3}, decimate {:.3}, output {:.3}, refine {:.3}), {:.3} s read, {:.3} s write",
        r.seconds,
        p.build,
        p.decimate,
        p.output,
        p.refine,
        r.read_seconds,
        r.write_seconds
    );
    if let Some(m) = &r.memory {
        let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
        match m.extra_bytes_per_input_triangle {
            Some(extra) => out!(
                "  memory       peak {:.1} MiB resident; simplifying added {:.0} bytes per input triangle",
                mib(m.peak_rss_bytes),
                extra
            ),
            None => out!("  memory       peak {:.1} MiB resident", mib(m.peak_rss_bytes)),
        }
    }
}
