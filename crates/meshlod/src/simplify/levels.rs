//! Successive levels of detail in one edge-collapse run: the surface is built
//! once, decimated to the first level's stop, written out (a copy: the surface
//! keeps its attribute streams) and refined like any [`simplify`](super::simplify)
//! output, then decimated further to the next level's stop, and so on. The
//! levels' orientation repairs (against LOD0) and attribute refits run on a
//! second thread, one level after the other, while the next levels are
//! decimated.
//!
//! Each level is thus made from the one before it, by the very collapses a single
//! run to the coarsest level would perform, and QEM's quadrics carry over
//! ([`crate::cost::Qem::keep_quadrics`]): every level's reported error is measured
//! against LOD0's planes, so errors add up instead of restarting at each level
//! (Garland & Heckbert 1997 §5 make the same point for their multiresolution
//! models). The surface and the closest-point tree of the orientation repair are
//! built once instead of once per level.

use super::{
    assemble_report, decimate, output_of, refine_with, Models, Passes, Simplified, SimplifyError,
    SimplifyOptions,
};
use crate::collapse::{BuildOptions, Surface};
use crate::decimate::{NoObserver, Outcome, StopReason, StopRule};
use crate::mesh::Mesh;
use crate::metrics::bvh::Bvh;
use crate::simplify::{Method, Phases};
use std::time::Instant;

/// Where a level of [`simplify_levels`] stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelStop {
    /// Decimate until the next collapse would cost more than this distance (mesh
    /// units, the [`Report::error`](super::Report::error) measure), when given.
    pub max_error: Option<f64>,
    /// Then, or without `max_error`, decimate on to at most this many triangles.
    pub at_most: usize,
}

/// What [`simplify_levels`] tells its `next` of a level as soon as it is decimated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelProgress {
    /// Its triangles.
    pub triangles: usize,
    /// The largest collapse error so far (mesh units; see [`Report::error`](super::Report::error)).
    pub error: f64,
}

/// A level of [`simplify_levels`].
#[derive(Debug, Clone)]
pub struct LevelOutput {
    /// The level, with its report (counts and error since LOD0; `seconds` for this
    /// level alone, its orientation repair included) and each output vertex's
    /// source vertex in LOD0.
    pub simplified: Simplified,
    /// For each output vertex, where its point was at the previous level (LOD0's
    /// position for the first level): the start of a geomorph.
    pub morph_from: Vec<[f32; 3]>,
}

/// Whether [`simplify_levels`] can run with `options` on `mesh`: an edge-collapse
/// method (QEM or Melax) without vertex fitting, edge swaps or non-edge pairs, on a
/// mesh that is not flat-shaded (those go through their own pipelines).
#[must_use]
pub fn supports_levels(mesh: &Mesh, options: &SimplifyOptions) -> bool {
    matches!(options.method, Method::Qem | Method::Melax)
        && options.fit_iterations == 0
        && !options.edge_swaps
        && options.pair_threshold.is_none()
        && !(options.reshade_flat && super::flat::FlatShading::detect(mesh).is_some())
}

/// A level decimated and written out, before its orientation repair.
struct Raw {
    out: Mesh,
    vertex_source: Vec<u32>,
    morph_from: Vec<[f32; 3]>,
    outcome: Outcome,
    at_most: usize,
    phases: Phases,
    /// Seconds before the repair.
    seconds: f64,
}

/// Simplifies `mesh` through successive levels in one run. `next` gets what the
/// levels decimated so far are (as soon as each is decimated) and gives the next
/// level's stop, or `None` to end; every level decimated is returned, in order.
/// The options' own targets and error bound are ignored. Each level's orientation
/// repair runs on another thread while the next level is decimated (unless
/// [`SimplifyOptions::threads`] is 1).
///
/// # Errors
/// As [`simplify`](super::simplify); [`SimplifyError::Option`] when
/// [`supports_levels`] is false.
pub fn simplify_levels(
    mesh: &Mesh,
    options: &SimplifyOptions,
    next: &mut dyn FnMut(&[LevelProgress]) -> Option<LevelStop>,
) -> Result<Vec<LevelOutput>, SimplifyError> {
    mesh.validate()?;
    options.check(mesh.positions.len())?;
    if !supports_levels(mesh, options) {
        return Err(SimplifyError::Option {
            name: "method",
            message: "levels in one run need QEM or Melax without fitting, edge swaps, \
                      non-edge pairs or a flat-shaded input"
                .into(),
        });
    }
    let t_build = Instant::now();
    let (mut surface, repair) = Surface::build(
        mesh,
        &BuildOptions {
            spatial_order: true,
            ..options.build_options()
        },
    );
    let diag = surface.diagonal();
    let nm_in = surface.non_manifold_census().total;
    let tree = (options.facing_repair && !mesh.triangles.is_empty())
        .then(|| Bvh::build_morton(&mesh.positions, &mesh.triangles));
    let build_seconds = t_build.elapsed().as_secs_f64();
    let parallel = options.threads != Some(1);
    let finish = |raw: Raw| -> LevelOutput {
        let t_refine = Instant::now();
        let Raw {
            mut out,
            mut vertex_source,
            mut morph_from,
            outcome,
            at_most,
            mut phases,
            seconds,
        } = raw;
        let passes = Passes {
            facing: options.facing_repair && outcome.collapses > 0,
            fit: false,
        };
        let (fitted, facing) = refine_with(
            mesh,
            options,
            &mut out,
            &vertex_source,
            None,
            passes,
            diag,
            tree.as_ref(),
        );
        let (refit, copies) = super::refit_output(
            mesh,
            options,
            &mut out,
            &mut vertex_source,
            outcome.collapses,
        );
        let more: Vec<[f32; 3]> = copies.iter().map(|&c| morph_from[c as usize]).collect();
        morph_from.extend(more);
        debug_assert_eq!(morph_from.len(), out.positions.len());
        phases.refine = t_refine.elapsed().as_secs_f64();
        let mut report = assemble_report(
            mesh,
            options,
            at_most,
            &out,
            outcome,
            &repair,
            diag,
            fitted,
            facing,
            phases,
            t_refine,
            Some((nm_in, None)),
        );
        report.seconds += seconds;
        report.attributes_refit = refit;
        LevelOutput {
            simplified: Simplified {
                mesh: out,
                report,
                vertex_source,
            },
            morph_from,
        }
    };
    let levels = std::thread::scope(|scope| {
        let mut done: Vec<LevelOutput> = Vec::new();
        // One thread finishes the levels in order while the next ones are
        // decimated. A thread per level ran every level's repair and refit at
        // once: `meshlod lod` on the DamagedHelmet subdivided to 3.96M
        // triangles peaked at 3.35–3.95 GB; with one finisher it peaks at
        // 3.07–3.13 GB and takes 2.5 s more of 76 s (the same outputs). The
        // queue holds the levels decimated but not yet finished.
        let (send, levels) = std::sync::mpsc::channel::<Raw>();
        let finisher = parallel.then(|| {
            let finish = &finish;
            scope.spawn(move || levels.iter().map(finish).collect::<Vec<_>>())
        });
        let mut progress: Vec<LevelProgress> = Vec::new();
        let mut decimator = Decimator {
            surface: &mut surface,
            models: Models::new(options),
            previous: Vec::new(),
            total: Outcome::nothing(),
        };
        decimator.models.qem.keep_quadrics();
        decimator.previous = (0..decimator.surface.point_count() as u32)
            .map(|p| decimator.surface.position(p))
            .collect();
        while let Some(stop) = next(&progress) {
            let build = if progress.is_empty() {
                build_seconds
            } else {
                0.0
            };
            let raw = decimator.level(mesh, options, stop, build);
            progress.push(LevelProgress {
                triangles: raw.out.triangles.len(),
                error: raw.outcome.max_error,
            });
            if finisher.is_some() {
                // The finisher takes levels until `send` is dropped, below; it is
                // gone early only if it panicked, which its join passes on.
                if send.send(raw).is_err() {
                    break;
                }
            } else {
                done.push(finish(raw));
            }
        }
        drop(send);
        if let Some(handle) = finisher {
            match handle.join() {
                Ok(levels) => done = levels,
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        done
    });
    Ok(levels)
}

/// The decimation side of [`simplify_levels`]: the surface, the cost models kept
/// between levels, each point's position at the previous level.
struct Decimator<'s> {
    surface: &'s mut Surface,
    models: Models,
    previous: Vec<[f32; 3]>,
    total: Outcome,
}

impl Decimator<'_> {
    /// Decimates to `stop` and writes the level out (`build`: seconds spent
    /// building the surface, counted in the first level).
    fn level(
        &mut self,
        mesh: &Mesh,
        options: &SimplifyOptions,
        stop: LevelStop,
        build: f64,
    ) -> Raw {
        let t_decimate = Instant::now();
        let mut phases = Phases {
            build,
            ..Phases::default()
        };
        let mut run = |surface: &mut Surface, rule: StopRule| {
            decimate(surface, options, rule, &mut self.models, &mut NoObserver).0
        };
        let mut outcome = match stop.max_error {
            Some(e) => run(
                self.surface,
                StopRule {
                    target_triangles: 0,
                    max_error: Some(e),
                    max_cost: None,
                },
            ),
            None => Outcome::nothing(),
        };
        if self.surface.live_triangles() > stop.at_most {
            let more = run(
                self.surface,
                StopRule {
                    target_triangles: stop.at_most,
                    max_error: None,
                    max_cost: None,
                },
            );
            outcome.merge(more);
        } else if stop.max_error.is_some() {
            outcome.stop_reason = StopReason::TargetReached;
        }
        self.total.collapses += outcome.collapses;
        self.total.max_error = self.total.max_error.max(outcome.max_error);
        outcome.collapses = self.total.collapses;
        outcome.max_error = self.total.max_error;
        let t_output = Instant::now();
        phases.decimate = (t_output - t_decimate).as_secs_f64();
        let lists = self.surface.output_triangles();
        let points = lists.1.clone();
        let (out, vertex_source, _) = output_of(mesh, lists, self.surface, false, true);
        let mut morph_from = vec![[0.0f32; 3]; out.positions.len()];
        for (t, p) in out.triangles.iter().zip(&points) {
            for k in 0..3 {
                morph_from[t[k] as usize] = self.previous[p[k] as usize];
            }
        }
        for &p in points.iter().flatten() {
            self.previous[p as usize] = self.surface.position(p);
        }
        phases.output = t_output.elapsed().as_secs_f64();
        Raw {
            out,
            vertex_source,
            morph_from,
            outcome,
            at_most: stop.at_most,
            phases,
            seconds: build + t_decimate.elapsed().as_secs_f64(),
        }
    }
}
