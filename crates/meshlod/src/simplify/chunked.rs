//! QEM on large meshes in chunks, on every core: the mesh is cut into spatial
//! chunks ([`crate::mesh::partition`]), each chunk is simplified on its own with
//! the points it shares with other chunks locked, then the chunks' outputs are put
//! back together and one global pass takes the whole to the target, the borders
//! now free.
//!
//! 1. **Partition.** `⌈triangles / CHUNK_TRIANGLES⌉` runs of triangles in Z order.
//!    The count depends on the mesh alone, so the output is the same whatever the
//!    number of threads (`SimplifyOptions::threads`), one included.
//! 2. **Chunks, in parallel.** Each chunk is a mesh of its own (its triangles, the
//!    vertices they use with their attributes, its groups), simplified by the same
//!    QEM decimation as a whole mesh, with its border points locked (as well as
//!    the caller's locked vertices), until its cheapest collapse costs more than
//!    a bound common to all chunks (every chunk's costs scaled by the whole
//!    mesh's diagonal), and never below the final ratio. The bound is where
//!    sampled pieces (a quarter of every second chunk, [`SAMPLE_PIECE`]), run
//!    to the final ratio first, kept [`chunk_keep`] (at least [`border_keep`])
//!    of their triangles; without one (the samples stopped above it) the chunks
//!    stop at that fraction. Every chunk then
//!    holds the collapses the whole mesh's greedy order performs first, so a
//!    rough chunk keeps more than a flat one. (A bound on the collapses'
//!    *error* instead does not stop a chunk there: the queue is ordered by cost,
//!    a squared distance times an area, and errors below the bound keep coming
//!    long after the first one above it.) The chunks are independent: no chunk
//!    sees another's state.
//! 3. **Merge.** The chunks' outputs are concatenated; a border vertex, present in
//!    every chunk that uses it and never moved, becomes one vertex again (by its
//!    input vertex).
//! 4. **Global pass.** The merged mesh is decimated to the target with everything
//!    free but the caller's locked vertices, in the exact greedy order, which
//!    spends the remaining budget where the whole mesh needs it (a flat chunk
//!    gives up more than a rough one); then the orientation repair runs against
//!    the original input, as for a whole mesh.
//!
//! The global pass starts from quadrics of the merged mesh, not the input's: the
//! error of step 2 is not carried into its costs, and the reported error is the
//! chunks' largest plus the global pass's (a bound on their sum). The global pass
//! still makes the coarse decisions (at 1% the chunks keep 8% of the mesh or
//! more, [`chunk_keep`] and [`border_keep`]).

use super::{
    decimate_mesh, refine, refine_with, thread_pool, Decimated, Method, Passes, Phases, Piece,
    Placement, Report, Simplified, SimplifyError, SimplifyOptions,
};
use crate::decimate::{NoObserver, Observer, Outcome, StopReason};
use crate::mesh::partition::{partition, Partition};
use crate::mesh::{Distance, Mesh};
use crate::metrics::bvh::Bvh;
use rayon::prelude::*;
use std::collections::HashMap;
use std::time::Instant;

/// Triangles of a chunk.
pub(super) const CHUNK_TRIANGLES: usize = 1 << 18;

/// Meshes with at least this many triangles are simplified in chunks (four
/// chunks or more).
pub(super) const CHUNKED_FROM: usize = 4 * CHUNK_TRIANGLES;

/// Chunks are used up to this final ratio: above it the chunks would keep most of
/// the mesh and the global pass would redo the work.
const CHUNKED_UP_TO: f64 = 0.25;

/// The fraction of its triangles a chunk keeps (at the common cost bound) for a
/// final ratio `ratio`: 8× the ratio up to 20% of the chunk, at least 2× the
/// ratio. The chunk must keep well more than its locked border, which the global
/// pass then coarsens with the rest: at 1% a chunk of 262,144 triangles has a
/// border of a few thousand points, and chunks stopped at 3× the ratio left the
/// 1M-triangle terrain 15 times farther from the input on average (fresh
/// quadrics over a coarse interior and dense strips); at 10% chunks at 2× the
/// ratio come out closer to the input than the whole-mesh run.
fn chunk_keep(ratio: f64) -> f64 {
    (8.0 * ratio).min((2.0 * ratio).max(0.2)).min(1.0)
}

/// The least fraction of its triangles a chunk of `part` (of a mesh of `n`
/// triangles) keeps: [`BORDER_KEEP`] times the share of border points, at most
/// a half. Z-order runs over a rough surface have long, jagged borders (1.5% of
/// the triangle count in border points on the terrain grids, 0.77% on the
/// DamagedHelmet subdivided to 4M triangles): at 0.1% the helmet's chunks, at
/// 8× the ratio, kept about as many points as their locked borders, and came out
/// at 3× the whole mesh's maximum distance and 4.3× its mean.
fn border_keep(part: &Partition, n: usize) -> f64 {
    (BORDER_KEEP * part.border_vertices() as f64 / n.max(1) as f64).min(0.5)
}

/// See [`border_keep`]: on the 1M-triangle terrain at 1%, chunks keeping 2× the
/// border share came out 15× farther from the input on average than the whole
/// mesh, chunks keeping 2.6× it 1.24× farther, 4× and more as close.
const BORDER_KEEP: f64 = 4.0;

/// The chunk size when `options` on `mesh` go through the chunked path: QEM with
/// optimal or midpoint placement on a mesh of [`CHUNKED_FROM`] triangles or more,
/// without the passes that need the whole run's merge history (`fit_iterations`,
/// `edge_swaps`) and with the topology kept (no closed holes, removed parts or
/// non-edge pairs).
pub(super) fn chunking(mesh: &Mesh, options: &SimplifyOptions) -> Option<usize> {
    let n = mesh.triangles.len();
    let ratio = options.target_for(n) as f64 / n.max(1) as f64;
    let eligible = options.chunks
        && ratio <= CHUNKED_UP_TO
        && options.method == Method::Qem
        && options.placement != Placement::Endpoint
        && options.fit_iterations == 0
        // The area weighting's normaliser is each surface's own mean area.
        && options.area_exponent == 1.0
        && !options.edge_swaps
        && options.preserve_topology
        && mesh.triangles.len() >= CHUNKED_FROM;
    eligible.then_some(CHUNK_TRIANGLES)
}

/// One chunk's result, in the input's vertex ids.
struct ChunkResult {
    out: Mesh,
    /// Per output vertex, the input vertex it descends from.
    source: Vec<u32>,
    outcome: Outcome,
    repair: crate::collapse::Repair,
}

/// Forwards progress only (the global pass continues the chunks' count).
struct Continue<'a>(&'a mut dyn Observer);

impl Observer for Continue<'_> {
    fn progress(&mut self, triangles: usize) {
        self.0.progress(triangles);
    }
}

/// [`super::simplify_observed`] for a mesh that [`chunking`] accepted.
pub(super) fn simplify_chunked(
    mesh: &Mesh,
    options: &SimplifyOptions,
    chunk_triangles: usize,
    observer: &mut dyn Observer,
    start: Instant,
) -> Result<Simplified, SimplifyError> {
    let n = mesh.triangles.len();
    let target = options.target_for(n);
    let diag = mesh.bbox_diagonal();
    observer.started(n, target);
    let t_build = Instant::now();
    let pool = thread_pool(options.threads)?;
    let part = match &pool {
        Some(p) => p.install(|| partition(mesh, chunk_triangles)),
        None => partition(mesh, chunk_triangles),
    };
    let t_chunks = Instant::now();
    // Distances resolved against the whole mesh's diagonal, not a chunk's.
    let mut inner = options.clone();
    inner.max_error = options
        .max_error
        .map(|e| Distance::Absolute(e.resolve(diag)));
    inner.ratio = None;
    inner.target_triangles = None;
    let ratio = if n > 0 { target as f64 / n as f64 } else { 0.0 };
    // The chunks stop at the cost where the sampled chunks, run to the final
    // ratio, kept `chunk_keep` of their triangles (and never below the final
    // ratio): a rough chunk keeps more triangles than a flat one, as in the
    // global order.
    let sample = sample_curves(mesh, &part, &inner, ratio, diag, pool.as_ref());
    let keep = chunk_keep(ratio).max(border_keep(&part, n));
    let bound = cost_for_count(&sample, keep);
    // Without a bound (the samples stopped above `keep`) the chunks stop at
    // `keep` themselves.
    let piece = Piece {
        diagonal: diag,
        max_cost: bound,
    };
    let floor = if bound.is_some() { ratio } else { keep };
    let results = run_chunks(mesh, &part, &inner, floor, piece, pool.as_ref(), observer);
    release_free_memory();
    let t_merge = Instant::now();
    let (merged, source) = merge(mesh, &part, &results);
    // Only the chunks' counts are needed from here on: their meshes and the
    // partition go before the global pass and the repair, where the run peaks.
    drop(part);
    let results: Vec<ChunkStats> = results
        .into_iter()
        .map(|r| ChunkStats {
            outcome: r.outcome,
            repair: r.repair,
        })
        .collect();
    if let Some(l) = options.locked_vertices.as_deref() {
        inner.locked_vertices = Some(source.iter().map(|&v| l[v as usize]).collect());
    } else {
        inner.locked_vertices = None;
    }
    observer.progress(merged.triangles.len());
    let t_global = Instant::now();
    // The repair's tree over the input depends on the input alone: with a second
    // thread, on a mesh of `OVERLAP_FROM` chunks or more, it is built while the
    // global pass runs on this one.
    let overlap =
        options.facing_repair && options.threads != Some(1) && results.len() >= OVERLAP_FROM;
    let (d, tree) = std::thread::scope(|s| {
        let building =
            overlap.then(|| s.spawn(|| Bvh::build_morton(&mesh.positions, &mesh.triangles)));
        let d = decimate_mesh(
            &merged,
            &inner,
            target,
            None,
            false,
            &mut Continue(observer),
        );
        let tree = building.map(|b| {
            b.join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        });
        (d, tree)
    });
    drop(merged);
    let Decimated {
        mut out,
        vertex_source,
        outcome,
        repair,
        phases: global,
        census,
        ..
    } = d;
    let mut vertex_source: Vec<u32> = vertex_source.iter().map(|&v| source[v as usize]).collect();
    drop(source);
    let t_refine = Instant::now();
    let passes = Passes {
        facing: options.facing_repair && outcome.collapses > 0,
        fit: false,
    };
    // The global pass's freed memory too, before the repair builds its tree over
    // the input, where the run peaks (docs/methods/qem.md, "Sampled pieces").
    release_free_memory();
    let (_, facing) = match &tree {
        Some(tree) => refine_with(
            mesh,
            options,
            &mut out,
            &vertex_source,
            None,
            passes,
            diag,
            Some(tree),
        ),
        None => refine(mesh, options, &mut out, &vertex_source, None, passes, diag),
    };
    drop(tree);
    let collapses = outcome.collapses + results.iter().map(|r| r.outcome.collapses).sum::<usize>();
    let (refit, _) = super::refit_output(mesh, options, &mut out, &mut vertex_source, collapses);
    let phases = Phases {
        build: (t_chunks - t_build).as_secs_f64() + global.build,
        decimate: (t_merge - t_chunks).as_secs_f64() + global.decimate,
        output: (t_global - t_merge).as_secs_f64() + global.output,
        refine: t_refine.elapsed().as_secs_f64(),
    };
    let mut report = chunked_report(ChunkedRun {
        mesh,
        target,
        diag,
        results: &results,
        out: &out,
        global: outcome,
        global_repair: repair,
        facing,
        phases,
        seconds: start.elapsed().as_secs_f64(),
        census,
    });
    report.attributes_refit = refit;
    Ok(Simplified {
        mesh: out,
        report,
        vertex_source,
    })
}

/// `f` over `items` in parallel on `pool` (rayon's global pool when `None`), the
/// results in order.
fn par_map<T: Sync, R: Send>(
    pool: Option<&rayon::ThreadPool>,
    items: &[T],
    f: impl Fn(&T) -> R + Sync + Send,
) -> Vec<R> {
    match pool {
        Some(p) => p.install(|| items.par_iter().map(&f).collect()),
        None => items.par_iter().map(&f).collect(),
    }
}

/// The fewest chunks at which the repair's tree over the input is built beside the
/// global pass. The tree (about 70 bytes per input triangle) then adds to the
/// global pass's structures instead of following them: on the 1M-triangle grid
/// (4 chunks) that took the peak from 119 to 145–159 bytes per input triangle,
/// above the 150 the project allows, for 5–7% of the time; on the 2.1M grid (8
/// chunks) it stays 111 at 10% and 89–90 at 1% (97–105 and 94–98 without), and
/// from 4.2M triangles (16 chunks) 95–118.
const OVERLAP_FROM: usize = 8;

/// A piece of every `SAMPLE_STRIDE`-th chunk is run to the final ratio first, to
/// learn which cost the chunks should stop at.
const SAMPLE_STRIDE: usize = 2;

/// A sampled piece is the first `1 / SAMPLE_PIECE` of its chunk's triangles (a
/// run in Z order, so a compact patch), its points shared with the rest of the
/// chunk locked as well: an eighth of the mesh in all, as whole chunks at every
/// eighth, but spread over four times as many places and, on a mesh of a few
/// chunks, run on every thread at once (a 1M-triangle mesh has four chunks, so
/// one sampled chunk ran alone).
const SAMPLE_PIECE: usize = 4;

/// A sampled piece's run: its size and, per collapse in order, the triangles it
/// removed and its cost.
struct Curve {
    triangles: usize,
    steps: Vec<(u8, f64)>,
}

/// Records every collapse's removed triangles and cost.
#[derive(Default)]
struct Recorder(Vec<(u8, f64)>);

impl Observer for Recorder {
    fn collapsed(&mut self, record: &crate::collapse::CollapseRecord) {
        let removed = record.removed_count.min(u32::from(u8::MAX)) as u8;
        self.0.push((removed, record.cost));
    }
}

/// Runs the first `1 / SAMPLE_PIECE` of every `SAMPLE_STRIDE`-th chunk (the
/// first chunk at least) to `ratio` of its triangles, recording each collapse.
fn sample_curves(
    mesh: &Mesh,
    part: &Partition,
    options: &SimplifyOptions,
    ratio: f64,
    diagonal: f64,
    pool: Option<&rayon::ThreadPool>,
) -> Vec<Curve> {
    let picked: Vec<&Vec<u32>> = part.chunks.iter().step_by(SAMPLE_STRIDE).collect();
    par_map(pool, &picked, |tris| {
        let (sampled, rest) = tris.split_at(tris.len().div_ceil(SAMPLE_PIECE));
        let mut rec = Recorder::default();
        let piece = Piece {
            diagonal,
            max_cost: None,
        };
        simplify_chunk(mesh, part, sampled, rest, options, ratio, piece, &mut rec);
        Curve {
            triangles: sampled.len(),
            steps: rec.0,
        }
    })
}

/// The smallest cost at which the sampled chunks, stopping when their running
/// maximum cost would pass it, keep at most `keep` of their triangles in total
/// (`None` when no such cost was seen: no sample, or they stopped above it).
fn cost_for_count(curves: &[Curve], keep: f64) -> Option<f64> {
    let total: usize = curves.iter().map(|c| c.triangles).sum();
    let allowed = (keep * total as f64).floor() as usize;
    // Per collapse of each curve: its running maximum cost, the triangles left
    // and the curve.
    let mut points: Vec<(f64, usize, usize)> = Vec::new();
    for (ci, c) in curves.iter().enumerate() {
        let (mut m, mut left) = (0.0f64, c.triangles);
        for &(removed, e) in &c.steps {
            m = m.max(e);
            left = left.saturating_sub(usize::from(removed));
            points.push((m, left, ci));
        }
    }
    // Triangles kept at cost τ: per curve, the count after its last collapse
    // whose running maximum is ≤ τ. Sweep τ up over the maxima.
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut kept = total;
    let mut current: Vec<usize> = curves.iter().map(|c| c.triangles).collect();
    for &(m, left, ci) in &points {
        if left < current[ci] {
            kept -= current[ci] - left;
            current[ci] = left;
        }
        if kept <= allowed {
            return Some(m);
        }
    }
    None
}

/// Simplifies every chunk of `part` (in waves of a few chunks per thread, with
/// progress between waves) on `pool`.
fn run_chunks(
    mesh: &Mesh,
    part: &Partition,
    options: &SimplifyOptions,
    ratio: f64,
    piece: Piece,
    pool: Option<&rayon::ThreadPool>,
    observer: &mut dyn Observer,
) -> Vec<ChunkResult> {
    let width = pool.map_or_else(
        rayon::current_num_threads,
        rayon::ThreadPool::current_num_threads,
    );
    let mut results = Vec::with_capacity(part.chunks.len());
    let mut removed = 0usize;
    for wave in part.chunks.chunks(4 * width.max(1)) {
        let done = par_map(pool, wave, |tris| {
            simplify_chunk(
                mesh,
                part,
                tris,
                &[],
                options,
                ratio,
                piece,
                &mut NoObserver,
            )
        });
        for (tris, r) in wave.iter().zip(&done) {
            removed += tris.len().saturating_sub(r.out.triangles.len());
        }
        observer.progress(mesh.triangles.len() - removed);
        results.extend(done);
    }
    results
}

/// The mesh of one chunk (`tris` of `mesh`), simplified to `chunk_ratio` of its
/// triangles, or until its cheapest collapse costs more than the piece's bound
/// (costs scaled by the whole mesh's diagonal), with its border vertices (and
/// the caller's locked ones, and those at a point `beside`'s triangles use: the
/// rest of a chunk `tris` is a piece of) locked.
#[allow(clippy::too_many_arguments)]
fn simplify_chunk(
    mesh: &Mesh,
    part: &Partition,
    tris: &[u32],
    beside: &[u32],
    options: &SimplifyOptions,
    chunk_ratio: f64,
    piece: Piece,
    observer: &mut dyn Observer,
) -> ChunkResult {
    let (sub, verts) = extract(mesh, tris);
    let user = options.locked_vertices.as_deref();
    let point = |v: u32| part.point_of[v as usize];
    let cut: std::collections::HashSet<u32> = beside
        .iter()
        .flat_map(|&t| mesh.triangles[t as usize])
        .map(point)
        .collect();
    let locked: Vec<bool> = verts
        .iter()
        .map(|&v| {
            part.border[v as usize]
                || user.is_some_and(|l| l[v as usize])
                || !cut.is_empty() && cut.contains(&point(v))
        })
        .collect();
    let mut o = options.clone();
    o.locked_vertices = Some(locked);
    let target = (tris.len() as f64 * chunk_ratio).ceil() as usize;
    let d = decimate_mesh(&sub, &o, target, Some(piece), false, observer);
    ChunkResult {
        source: d.vertex_source.iter().map(|&v| verts[v as usize]).collect(),
        out: d.out,
        outcome: d.outcome,
        repair: d.repair,
    }
}

/// The triangles `tris` of `mesh` as a mesh of their own (vertices in input
/// order, with their attributes; groups kept), and its vertices' input ids.
fn extract(mesh: &Mesh, tris: &[u32]) -> (Mesh, Vec<u32>) {
    let mut verts: Vec<u32> = tris
        .iter()
        .flat_map(|&t| mesh.triangles[t as usize])
        .collect();
    verts.sort_unstable();
    verts.dedup();
    let local = |v: u32| verts.binary_search(&v).expect("a chunk's own vertex") as u32;
    let sub = Mesh {
        positions: verts.iter().map(|&v| mesh.positions[v as usize]).collect(),
        triangles: tris
            .iter()
            .map(|&t| mesh.triangles[t as usize].map(local))
            .collect(),
        attributes: mesh.attributes.gather(&verts),
        groups: mesh
            .groups
            .as_ref()
            .map(|g| tris.iter().map(|&t| g[t as usize]).collect()),
        group_names: mesh.group_names.clone(),
    };
    (sub, verts)
}

/// The chunks' outputs as one mesh: a border vertex (one input vertex, locked in
/// every chunk that has it) becomes one vertex; every other output vertex is its
/// chunk's own. Returns the mesh and, per vertex, its input vertex.
fn merge(mesh: &Mesh, part: &Partition, results: &[ChunkResult]) -> (Mesh, Vec<u32>) {
    let vertices: usize = results.iter().map(|r| r.out.positions.len()).sum();
    let triangles: usize = results.iter().map(|r| r.out.triangles.len()).sum();
    let mut merged = Mesh {
        positions: Vec::with_capacity(vertices),
        triangles: Vec::with_capacity(triangles),
        attributes: Default::default(),
        groups: mesh.groups.as_ref().map(|_| Vec::with_capacity(triangles)),
        group_names: mesh.group_names.clone(),
    };
    let mut source: Vec<u32> = Vec::with_capacity(vertices);
    let mut border_at: HashMap<u32, u32> = HashMap::new();
    for r in results {
        // Local vertex → merged vertex; the vertices this chunk adds.
        let mut map = Vec::with_capacity(r.out.positions.len());
        let mut new_local = Vec::with_capacity(r.out.positions.len());
        for (i, &src) in r.source.iter().enumerate() {
            let id = if part.border[src as usize] {
                let next = (source.len() + new_local.len()) as u32;
                let id = *border_at.entry(src).or_insert(next);
                if id == next {
                    new_local.push(i as u32);
                }
                id
            } else {
                new_local.push(i as u32);
                (source.len() + new_local.len() - 1) as u32
            };
            map.push(id);
        }
        let before = merged.positions.len();
        merged
            .positions
            .extend(new_local.iter().map(|&i| r.out.positions[i as usize]));
        let attrs = r.out.attributes.gather(&new_local);
        merged.attributes.append(before, &attrs, new_local.len());
        source.extend(new_local.iter().map(|&i| r.source[i as usize]));
        merged
            .triangles
            .extend(r.out.triangles.iter().map(|t| t.map(|v| map[v as usize])));
        if let (Some(g), Some(rg)) = (&mut merged.groups, &r.out.groups) {
            g.extend_from_slice(rg);
        } else if let Some(g) = &mut merged.groups {
            g.extend(std::iter::repeat_n(0, r.out.triangles.len()));
        }
    }
    (merged, source)
}

/// What the report needs of a chunk's run once its mesh is merged.
struct ChunkStats {
    outcome: Outcome,
    repair: crate::collapse::Repair,
}

/// What [`chunked_report`] sums up.
struct ChunkedRun<'a> {
    mesh: &'a Mesh,
    target: usize,
    diag: f64,
    results: &'a [ChunkStats],
    out: &'a Mesh,
    global: Outcome,
    global_repair: crate::collapse::Repair,
    facing: Option<super::facing::FacingRepair>,
    phases: Phases,
    seconds: f64,
    /// The global pass's non-manifold census.
    census: Option<super::Census>,
}

/// The report of a chunked run: the chunks' and the global pass's counts added,
/// the stop reason the global pass's.
fn chunked_report(run: ChunkedRun<'_>) -> Report {
    let mut rejections = run.global.rejections;
    let (mut collapses, mut retries, mut rescans) =
        (run.global.collapses, run.global.retries, run.global.rescans);
    let (mut degenerate, mut duplicate) = (
        run.global_repair.degenerate_triangles,
        run.global_repair.duplicate_triangles,
    );
    let mut chunk_error = 0.0f64;
    for r in run.results {
        rejections.add(&r.outcome.rejections);
        collapses += r.outcome.collapses;
        retries += r.outcome.retries;
        rescans += r.outcome.rescans;
        degenerate += r.repair.degenerate_triangles;
        duplicate += r.repair.duplicate_triangles;
        chunk_error = chunk_error.max(r.outcome.max_error);
    }
    let error = if run.global.collapses > 0 || chunk_error > 0.0 {
        chunk_error + run.global.max_error
    } else {
        0.0
    };
    let stop_detail = match run.global.stop_reason {
        StopReason::TargetReached => format!(
            "reached the target of {} triangles ({} chunks, then the whole)",
            run.target,
            run.results.len()
        ),
        _ => run.global.stop_detail,
    };
    Report {
        method: Method::Qem.name(),
        triangles_in: run.mesh.triangles.len(),
        vertices_in: run.mesh.positions.len(),
        target_triangles: run.target,
        triangles_out: run.out.triangles.len(),
        vertices_out: run.out.positions.len(),
        error: if run.diag > 0.0 {
            error / run.diag
        } else {
            0.0
        },
        error_absolute: error,
        bbox_diagonal: run.diag,
        stop_reason: run.global.stop_reason,
        stop_detail,
        seconds: run.seconds,
        collapses,
        non_edge_contractions: 0,
        degenerate_removed: degenerate,
        duplicate_removed: duplicate,
        non_manifold_points_in: run.census.map(|c| c.0),
        non_manifold_kept: run.census.and_then(|c| c.1),
        rejections,
        rescans,
        retries,
        soft_filters_relaxed: false,
        holes_closed: 0,
        components_removed: 0,
        facing_flips: run.facing.map_or(0, |f| f.flips),
        facing_away: run.facing.map(|f| [f.before, f.after]),
        fit_moved: 0,
        attributes_refit: 0,
        edge_swaps: 0,
        flat_shading: false,
        cluster: None,
        phases: run.phases,
    }
}

/// Hands the memory the chunks freed back to the system. glibc keeps freed blocks
/// in each thread's arena; the global pass, on the calling thread, would otherwise
/// allocate afresh on top of them. (The crate's one foreign call besides the
/// CPU feature checks of `crate::isa`.)
#[allow(unsafe_code)]
fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `malloc_trim` only returns free memory to the system; it has no
    // preconditions.
    unsafe {
        libc::malloc_trim(0);
    }
}
