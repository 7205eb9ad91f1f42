//! Discrete level-of-detail chains and their screen-space selection.
//!
//! A chain is LOD0 (the input) followed by coarser meshes LOD1 … LODn, each
//! simplified from the one before it, so the geometric error grows monotonically
//! and every step costs only the triangles it starts from. Each level carries its
//! two-sided Hausdorff distance to LOD0 (Metro-style sampling, exactly as
//! [`crate::metrics::hausdorff`] with LOD0 as `A`) and the distance at which that
//! error projects to `P` pixels. The projection is the one of the course notes'
//! LOD chapter (after Luebke et al., *Level of Detail for 3D Graphics*, 2003, §4):
//! an error `ε` seen at distance `d` on a screen `x` pixels high with a vertical
//! field of view `θ` covers `p = ε x / (2 d tan(θ/2))` pixels, so the level may be
//! drawn from `d = ε x / (2 P tan(θ/2))` on.
//!
//! Levels come either from fixed triangle ratios of LOD0 ([`LevelSpec::Ratios`]) or
//! by error ([`LevelSpec::ByError`]): LOD1 halves LOD0, then each level aims at
//! twice the previous level's measured error, and is always at most half the
//! triangles of the level before it. The quadric error the simplifier stops on is
//! calibrated against the measured Hausdorff distance level by level. The chain
//! stops early when a level cannot halve the triangle count (the reason is kept).
//!
//! [`select`] picks, for objects placed in a world and a camera, the coarsest level
//! whose projected error stays within `P` pixels. [`screen_coverage`] converts a
//! switch distance into the `MSFT_screencoverage` value of the glTF `MSFT_lod`
//! extension (the object's bounding-sphere area over the screen area, the measure
//! Babylon.js uses).

use crate::decimate::NoObserver;
use crate::mesh::{Distance, Mesh};
use crate::metrics::bvh::Bvh;
use crate::metrics::{self, SamplingOptions};
use crate::simplify::{
    simplify_levels, simplify_observed, supports_levels, LevelStop, Method, SimplifyError,
    SimplifyOptions,
};
use serde::Serialize;
use std::time::Instant;

/// How the levels of a chain are chosen.
#[derive(Debug, Clone, PartialEq)]
pub enum LevelSpec {
    /// Up to this many levels after LOD0, each aiming at about twice the previous
    /// level's error and at most half its triangles.
    ByError(usize),
    /// One level per ratio of LOD0's triangle count, strictly decreasing in (0, 1).
    Ratios(Vec<f64>),
}

/// The camera a chain is switched for: screen height, field of view, and the
/// largest error in pixels a level may show.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Screen {
    /// Largest projected error a level may show, in pixels. Default 1.
    pub pixel_error: f64,
    /// Screen height in pixels. Default 1080.
    pub screen_height_px: f64,
    /// Vertical field of view in degrees, in (0, 180). Default 60.
    pub fov_degrees: f64,
    /// Screen width over height, for screen coverage. Default 16/9.
    pub aspect: f64,
}

impl Default for Screen {
    fn default() -> Self {
        Self {
            pixel_error: 1.0,
            screen_height_px: 1080.0,
            fov_degrees: 60.0,
            aspect: 16.0 / 9.0,
        }
    }
}

impl Screen {
    /// Checks every field is finite and in range.
    ///
    /// # Errors
    /// [`LodError::Option`] naming the field.
    pub fn check(&self) -> Result<(), LodError> {
        let positive = |name: &'static str, v: f64| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(LodError::Option {
                    name,
                    message: format!("{v} must be a positive finite number"),
                })
            }
        };
        positive("pixel_error", self.pixel_error)?;
        positive("screen_height_px", self.screen_height_px)?;
        positive("aspect", self.aspect)?;
        if !(self.fov_degrees > 0.0 && self.fov_degrees < 180.0) {
            return Err(LodError::Option {
                name: "fov_degrees",
                message: format!(
                    "{} must be an angle strictly between 0 and 180 degrees",
                    self.fov_degrees
                ),
            });
        }
        Ok(())
    }

    /// The distance at which `error` (same units) projects to [`Self::pixel_error`]
    /// pixels: `d = ε x / (2 P tan(θ/2))`.
    #[must_use]
    pub fn switch_distance(&self, error: f64) -> f64 {
        metrics::distance_for_pixels(
            error,
            self.pixel_error,
            self.screen_height_px,
            self.fov_degrees,
        )
    }

    /// Pixels covered by `error` seen at `distance`: `p = ε x / (2 d tan(θ/2))`.
    #[must_use]
    pub fn pixels(&self, error: f64, distance: f64) -> f64 {
        metrics::screen_space_error(error, self.screen_height_px, self.fov_degrees, distance)
    }
}

/// Options of [`build_chain`].
#[derive(Debug, Clone, PartialEq)]
pub struct ChainOptions {
    /// Which levels. Default [`LevelSpec::ByError`]`(4)`.
    pub levels: LevelSpec,
    /// The simplifier's options for each step; its targets and error bound are set
    /// per level. Default [`SimplifyOptions::default`] (QEM).
    pub simplify: SimplifyOptions,
    /// How each level's Hausdorff distance to LOD0 is sampled. Default: as
    /// `meshlod measure` (vertices, edges and faces, seed 0), except that without
    /// an explicit count each direction takes 10 samples per triangle of the
    /// sampled mesh, at least [`MIN_SAMPLES`] and at most [`MAX_SAMPLES`]; `meshlod
    /// measure --samples N` with that `N` gives the same distances.
    pub sampling: SamplingOptions,
    /// The screen the switch distances are computed for.
    pub screen: Screen,
    /// Keep, for each coarser level's vertices, the position in the next finer
    /// level of the vertex each descends from ([`Level::morph_from`]). Default false.
    pub geomorph: bool,
}

impl Default for ChainOptions {
    fn default() -> Self {
        Self {
            levels: LevelSpec::ByError(4),
            simplify: SimplifyOptions::default(),
            sampling: SamplingOptions::default(),
            screen: Screen::default(),
            geomorph: false,
        }
    }
}

/// Errors of [`build_chain`] and [`Screen::check`].
#[derive(Debug, thiserror::Error)]
pub enum LodError {
    /// The simplifier refused the mesh or an option.
    #[error(transparent)]
    Simplify(#[from] SimplifyError),
    /// An option is out of range.
    #[error("option {name}: {message}")]
    Option {
        /// The option's name.
        name: &'static str,
        /// What is wrong with it.
        message: String,
    },
}

/// One level of a chain.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Level {
    /// 0 for the input, then 1, 2, … coarser.
    pub level: usize,
    /// Its triangles.
    pub triangles: usize,
    /// Its vertices.
    pub vertices: usize,
    /// Two-sided Hausdorff distance to LOD0 (mesh units); 0 for LOD0.
    pub error_max: f64,
    /// The larger of the two one-sided mean distances to LOD0 (mesh units).
    pub error_mean: f64,
    /// Distance from the camera (mesh units, to the bounding sphere's centre) from
    /// which this level shows at most `P` pixels of error; 0 for LOD0. Computed
    /// from the largest `error_max` of this level and the finer ones, so it never
    /// decreases along the chain.
    pub switch_distance: f64,
    /// `MSFT_screencoverage` value below which this level is drawn (1 for LOD0).
    pub screen_coverage: f64,
    /// Seconds the simplification of this level took (from the previous level).
    pub seconds: f64,
    /// The mesh.
    #[serde(skip)]
    pub mesh: Mesh,
    /// With [`ChainOptions::geomorph`], for each vertex the position of the vertex
    /// of the next finer level it descends from (empty otherwise and for LOD0).
    #[serde(skip)]
    pub morph_from: Vec<[f32; 3]>,
}

/// A level-of-detail chain for one mesh.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Chain {
    /// LOD0 (the input), then the coarser levels.
    pub levels: Vec<Level>,
    /// Centre of the bounding sphere (bounding-box centre), mesh units.
    pub center: [f64; 3],
    /// Radius of the bounding sphere about [`Self::center`], mesh units.
    pub radius: f64,
    /// `MSFT_screencoverage` under which nothing need be drawn: where the whole
    /// bounding sphere's diameter projects to `P` pixels.
    pub cull_coverage: f64,
    /// Why the chain has fewer levels than asked, if it has.
    pub stopped_early: Option<String>,
    /// Seconds spent simplifying (all levels).
    pub simplify_seconds: f64,
    /// Seconds spent measuring (all levels).
    pub measure_seconds: f64,
}

impl Chain {
    /// The levels' errors as used for selection: each the largest `error_max` of it
    /// and the finer levels (mesh units), LOD0 first.
    #[must_use]
    pub fn errors(&self) -> Vec<f64> {
        let mut worst = 0.0f64;
        self.levels
            .iter()
            .map(|l| {
                worst = worst.max(l.error_max);
                worst
            })
            .collect()
    }

    /// The `MSFT_screencoverage` list of the glTF `MSFT_lod` extension: one value
    /// per coarser level (where it takes over), then the cull coverage.
    #[must_use]
    pub fn coverages(&self) -> Vec<f64> {
        let mut out: Vec<f64> = self.levels[1..].iter().map(|l| l.screen_coverage).collect();
        let last = out.last().copied().unwrap_or(1.0);
        out.push(self.cull_coverage.min(last));
        out
    }

    /// This chain drawn with the transform `m` (column-major, glTF layout), for
    /// [`select`]: its centre moved, its errors scaled by `m`'s largest stretch.
    #[must_use]
    pub fn placed(&self, m: &crate::io::Matrix4) -> LodObject {
        LodObject::new(self.center, self.radius, self.errors()).placed(m)
    }
}

/// An object to select a level for: where it is and each level's error.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LodObject {
    /// Centre of its bounding sphere, world units.
    pub center: [f64; 3],
    /// Radius of its bounding sphere, world units.
    pub radius: f64,
    /// Each level's error in world units, LOD0 first, never decreasing.
    pub errors: Vec<f64>,
}

impl LodObject {
    /// An object at `center` with `radius` and per-level `errors` (same units).
    #[must_use]
    pub fn new(center: [f64; 3], radius: f64, errors: Vec<f64>) -> Self {
        Self {
            center,
            radius,
            errors,
        }
    }

    /// The object moved by `m` (column-major): centre transformed, radius and
    /// errors scaled by the largest stretch of `m`'s linear part.
    #[must_use]
    pub fn placed(&self, m: &crate::io::Matrix4) -> Self {
        let a = |r: usize, c: usize| f64::from(m[c][r]);
        let c = self.center;
        let center =
            std::array::from_fn(|r| a(r, 0) * c[0] + a(r, 1) * c[1] + a(r, 2) * c[2] + a(r, 3));
        let s = crate::io::stretch(m);
        Self {
            center,
            radius: self.radius * s,
            errors: self.errors.iter().map(|e| e * s).collect(),
        }
    }
}

/// Where the camera is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Camera position, world units.
    pub position: [f64; 3],
    /// The screen (field of view, height, pixel error).
    pub screen: Screen,
}

/// For each object, the coarsest level whose error projects to at most
/// `view.screen.pixel_error` pixels at the object's distance (camera to
/// bounding-sphere centre). Moving the camera away never picks a finer level.
/// An object with no levels gets 0.
#[must_use]
pub fn select(objects: &[LodObject], view: &View) -> Vec<usize> {
    objects
        .iter()
        .map(|o| {
            let d = distance(o.center, view.position);
            select_level(&o.errors, d, &view.screen)
        })
        .collect()
}

/// The coarsest level of `errors` (never decreasing, LOD0 first) whose error
/// projects to at most `screen.pixel_error` pixels at `distance`.
#[must_use]
pub fn select_level(errors: &[f64], distance: f64, screen: &Screen) -> usize {
    let mut best = 0;
    for (k, &e) in errors.iter().enumerate() {
        // d ≥ switch distance ⇔ p ≤ P, compared on distances so the boundary is
        // exactly the reported switch distance.
        if distance >= screen.switch_distance(e) {
            best = k;
        }
    }
    best
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// The `MSFT_screencoverage` of a bounding sphere of `radius` seen from `distance`
/// (same units): its projected disc's area over the screen's,
/// `π r² / (4 d² tan²(θ/2) a)`, capped at 1.
#[must_use]
pub fn screen_coverage(radius: f64, distance: f64, screen: &Screen) -> f64 {
    if distance <= 0.0 {
        return 1.0;
    }
    let t = (screen.fov_degrees.to_radians() * 0.5).tan();
    let c = std::f64::consts::PI * radius * radius
        / (4.0 * distance * distance * t * t * screen.aspect);
    c.min(1.0)
}

/// Bounding sphere: the bounding-box centre and the farthest vertex from it.
fn bounding_sphere(mesh: &Mesh) -> ([f64; 3], f64) {
    let Some((lo, hi)) = mesh.bounding_box(true) else {
        return ([0.0; 3], 0.0);
    };
    let c: [f64; 3] = std::array::from_fn(|k| 0.5 * (f64::from(lo[k]) + f64::from(hi[k])));
    let mut r2 = 0.0f64;
    for t in &mesh.triangles {
        for &v in t {
            let p = mesh.positions[v as usize];
            let d = (0..3)
                .map(|k| (f64::from(p[k]) - c[k]).powi(2))
                .sum::<f64>();
            r2 = r2.max(d);
        }
    }
    (c, r2.sqrt())
}

/// Decides each level's stop and accepts (measures and records) each level made,
/// for both ways of making them: one run through every level
/// ([`simplify_levels`], QEM and Melax), or one [`simplify_observed`] call per
/// level from the previous level (vertex removal, clustering, flat-shaded input).
struct Planner<'a> {
    mesh: &'a Mesh,
    options: &'a ChainOptions,
    bvh0: Bvh,
    chain: Chain,
    /// Levels wanted after LOD0.
    wanted: usize,
    /// Level by level the simplifier's errors restart at each level, so this
    /// relates the growth of the measured Hausdorff distance over a level to the
    /// simplifier's error on it, learnt from the last level (error mode).
    gain: Option<f64>,
}

impl Planner<'_> {
    /// The stop of the next level, or `None` when the chain is complete.
    fn next_stop(&self) -> Option<LevelStop> {
        let k = self.chain.levels.len();
        if k > self.wanted || self.chain.stopped_early.is_some() {
            return None;
        }
        let prev = self.chain.levels.last().expect("LOD0 is there");
        Some(match &self.options.levels {
            LevelSpec::Ratios(r) => LevelStop {
                max_error: None,
                at_most: ((r[k - 1] * self.mesh.triangles.len() as f64).round() as usize).max(1),
            },
            LevelSpec::ByError(_) => LevelStop {
                // Doubling the error: growing it by as much as it is. Clustering
                // has no error stop: it halves the count.
                max_error: self
                    .gain
                    .filter(|_| {
                        prev.error_max > 0.0 && self.options.simplify.method != Method::Cluster
                    })
                    .map(|g| prev.error_max / g),
                at_most: prev.triangles / 2,
            },
        })
    }

    /// Measures the new level `mesh` (made to `stop`; `qem_error`: the error the
    /// simplifier reported) and records it, or ends the chain when it did not get
    /// fewer triangles than the previous level, or stalled short of its target.
    /// Returns whether it was recorded (its mesh is left for the caller to fill in).
    fn accept(&mut self, mesh: &Mesh, stop: LevelStop, qem_error: f64, seconds: f64) -> bool {
        let k = self.chain.levels.len();
        let prev = self.chain.levels.last().expect("LOD0 is there");
        let prev_tris = prev.triangles;
        let got = mesh.triangles.len();
        let target = stop.at_most;
        self.chain.simplify_seconds += seconds;
        // Within 1% (or 2 triangles) of the target counts as reached: a collapse
        // removes two triangles at a time.
        if got == 0 || got >= prev_tris || got > target + (target / 100).max(2) {
            self.chain.stopped_early = Some(format!(
                "LOD{k}: the simplifier stopped at {got} triangles of LOD{}'s {prev_tris} (target {target})",
                k - 1
            ));
            return false;
        }
        let t = Instant::now();
        let bvh = Bvh::build(&mesh.positions, &mesh.triangles);
        let sampling0 = sampling(&self.options.sampling, self.mesh);
        let a_to_b = metrics::one_sided(self.mesh, &bvh, &sampling0);
        let b_to_a = metrics::one_sided(mesh, &self.bvh0, &sampling(&self.options.sampling, mesh));
        self.chain.measure_seconds += t.elapsed().as_secs_f64();
        let error_max = a_to_b.max.max(b_to_a.max);
        let error_mean = a_to_b.mean.max(b_to_a.mean);
        let grown = error_max - prev.error_max;
        if qem_error > 0.0 && grown > 0.0 {
            self.gain = Some(grown / qem_error);
        }
        let worst = self
            .chain
            .errors()
            .last()
            .copied()
            .unwrap_or(0.0)
            .max(error_max);
        let screen = self.options.screen;
        let switch_distance = screen.switch_distance(worst);
        self.chain.levels.push(Level {
            level: k,
            triangles: got,
            vertices: mesh.positions.len(),
            error_max,
            error_mean,
            switch_distance,
            screen_coverage: screen_coverage(self.chain.radius, switch_distance, &screen),
            seconds,
            mesh: Mesh::default(),
            morph_from: Vec::new(),
        });
        true
    }
}

/// Builds the chain of `mesh`: LOD0 and the levels [`ChainOptions::levels`] asks
/// for, each measured against LOD0. With QEM or Melax (without fitting or
/// non-edge pairs) every level comes out of one run ([`simplify_levels`]): the
/// quadrics carry over, so each level's simplifier error is measured against
/// LOD0; otherwise each level is one simplification of the previous level.
///
/// # Errors
/// [`LodError::Option`] for ratios that are not strictly decreasing in (0, 1), a
/// zero level count or a bad [`Screen`]; [`LodError::Simplify`] when the
/// simplifier refuses the mesh (invalid indices, NaN coordinates) or an option.
pub fn build_chain(mesh: &Mesh, options: &ChainOptions) -> Result<Chain, LodError> {
    options.screen.check()?;
    check_levels(&options.levels)?;
    mesh.validate().map_err(SimplifyError::from)?;
    let (center, radius) = bounding_sphere(mesh);
    let screen = options.screen;
    let chain = Chain {
        levels: vec![Level {
            level: 0,
            triangles: mesh.triangles.len(),
            vertices: mesh.positions.len(),
            error_max: 0.0,
            error_mean: 0.0,
            switch_distance: 0.0,
            screen_coverage: 1.0,
            seconds: 0.0,
            mesh: mesh.clone(),
            morph_from: Vec::new(),
        }],
        center,
        radius,
        cull_coverage: screen_coverage(radius, screen.switch_distance(2.0 * radius), &screen),
        stopped_early: None,
        simplify_seconds: 0.0,
        measure_seconds: 0.0,
    };
    if mesh.triangles.is_empty() {
        return Ok(Chain {
            stopped_early: Some("the input has no triangles".into()),
            ..chain
        });
    }
    let t = Instant::now();
    let bvh0 = Bvh::build(&mesh.positions, &mesh.triangles);
    let one_run = supports_levels(mesh, &options.simplify);
    let mut planner = Planner {
        mesh,
        options,
        bvh0,
        chain,
        wanted: match &options.levels {
            LevelSpec::ByError(n) => *n,
            LevelSpec::Ratios(r) => r.len(),
        },
        gain: None,
    };
    planner.chain.measure_seconds += t.elapsed().as_secs_f64();
    if one_run {
        chain_in_one_run(&mut planner)?;
    } else {
        chain_level_by_level(&mut planner)?;
    }
    Ok(planner.chain)
}

/// The levels of `planner` from one [`simplify_levels`] run. The stops depend only
/// on what the simplifier reports (in error mode each level doubles the previous
/// level's quadric error, which is measured against LOD0's planes here), so every
/// level is decimated before any is measured, and the orientation repairs run
/// beside the decimation.
fn chain_in_one_run(planner: &mut Planner<'_>) -> Result<(), LodError> {
    let n0 = planner.mesh.triangles.len();
    let mut stops: Vec<LevelStop> = Vec::new();
    let mut stalled: Option<String> = None;
    let wanted = planner.wanted;
    let levels = planner.options.levels.clone();
    let t = Instant::now();
    let outputs = simplify_levels(planner.mesh, &planner.options.simplify, &mut |made| {
        let k = made.len();
        if let (Some(last), Some(stop)) = (made.last(), stops.last()) {
            let prev = if k >= 2 { made[k - 2].triangles } else { n0 };
            let target = stop.at_most;
            if last.triangles == 0
                || last.triangles >= prev
                || last.triangles > target + (target / 100).max(2)
            {
                stalled = Some(format!(
                    "LOD{k}: the simplifier stopped at {} triangles of LOD{}'s {prev} (target {target})",
                    last.triangles,
                    k - 1
                ));
                return None;
            }
        }
        if k >= wanted {
            return None;
        }
        let stop = match &levels {
            LevelSpec::Ratios(r) => LevelStop {
                max_error: None,
                at_most: ((r[k] * n0 as f64).round() as usize).max(1),
            },
            LevelSpec::ByError(_) => match made.last() {
                None => LevelStop {
                    max_error: None,
                    at_most: n0 / 2,
                },
                Some(last) => LevelStop {
                    max_error: (last.error > 0.0).then_some(2.0 * last.error),
                    at_most: last.triangles / 2,
                },
            },
        };
        stops.push(stop);
        Some(stop)
    })?;
    let wall = t.elapsed().as_secs_f64();
    let keep = if stalled.is_some() {
        outputs.len().saturating_sub(1)
    } else {
        outputs.len()
    };
    for (out, stop) in outputs.into_iter().take(keep).zip(stops) {
        let s = out.simplified;
        if !planner.accept(&s.mesh, stop, s.report.error_absolute, s.report.seconds) {
            break;
        }
        let level = planner.chain.levels.last_mut().expect("just pushed");
        level.mesh = s.mesh;
        if planner.options.geomorph {
            level.morph_from = out.morph_from;
        }
    }
    if planner.chain.stopped_early.is_none() {
        planner.chain.stopped_early = stalled;
    }
    // The levels' own seconds overlap (repairs beside decimation): the wall time.
    planner.chain.simplify_seconds = wall;
    Ok(())
}

/// The levels of `planner`, each one simplification of the previous level.
fn chain_level_by_level(planner: &mut Planner<'_>) -> Result<(), LodError> {
    while let Some(stop) = planner.next_stop() {
        let prev = &planner.chain.levels.last().expect("LOD0 is there").mesh;
        let base = &planner.options.simplify;
        let t = Instant::now();
        let mut o = base.clone();
        o.ratio = None;
        o.target_triangles = Some(stop.at_most);
        o.max_error = None;
        let (s, qem_error) = match stop.max_error {
            Some(e) => {
                let mut first_o = base.clone();
                first_o.ratio = None;
                first_o.target_triangles = None;
                first_o.max_error = Some(Distance::Absolute(e));
                let first = simplify_observed(prev, &first_o, &mut NoObserver)?;
                if first.mesh.triangles.len() <= stop.at_most {
                    let q = first.report.error_absolute;
                    (first, q)
                } else {
                    let second = simplify_observed(&first.mesh, &o, &mut NoObserver)?;
                    let q = first
                        .report
                        .error_absolute
                        .max(second.report.error_absolute);
                    let source = second
                        .vertex_source
                        .iter()
                        .map(|&v| first.vertex_source.get(v as usize).copied().unwrap_or(v))
                        .collect();
                    (
                        crate::simplify::Simplified {
                            vertex_source: source,
                            ..second
                        },
                        q,
                    )
                }
            }
            None => {
                let s = simplify_observed(prev, &o, &mut NoObserver)?;
                let q = s.report.error_absolute;
                (s, q)
            }
        };
        let morph_from = if planner.options.geomorph {
            s.vertex_source
                .iter()
                .map(|&v| prev.positions.get(v as usize).copied().unwrap_or([0.0; 3]))
                .collect()
        } else {
            Vec::new()
        };
        let seconds = t.elapsed().as_secs_f64();
        if !planner.accept(&s.mesh, stop, qem_error, seconds) {
            break;
        }
        let level = planner.chain.levels.last_mut().expect("just pushed");
        level.mesh = s.mesh;
        level.morph_from = morph_from;
    }
    Ok(())
}

/// The fewest samples per direction a level is measured with by default.
pub const MIN_SAMPLES: usize = 20_000;

/// The most samples per direction a level is measured with by default (beside the
/// sampled mesh's vertices, which are all taken).
pub const MAX_SAMPLES: usize = 2_000_000;

/// `options` with its sample count fixed for sampling `mesh`: as given, or by
/// default 10 per triangle, at least [`MIN_SAMPLES`] (a chain of a scene measures
/// every mesh at every level, so `meshlod measure`'s floor of a million would make
/// small meshes cost as much as large ones) and at most [`MAX_SAMPLES`] (every
/// level samples LOD0: on a 3.96M-triangle LOD0, 10 per triangle took 60 s a
/// level).
fn sampling(options: &SamplingOptions, mesh: &Mesh) -> SamplingOptions {
    SamplingOptions {
        samples: Some(
            options
                .samples
                .unwrap_or_else(|| (10 * mesh.triangles.len()).clamp(MIN_SAMPLES, MAX_SAMPLES)),
        ),
        ..options.clone()
    }
}

fn check_levels(levels: &LevelSpec) -> Result<(), LodError> {
    match levels {
        LevelSpec::ByError(0) => Err(LodError::Option {
            name: "levels",
            message: "at least one level is needed".into(),
        }),
        LevelSpec::ByError(_) => Ok(()),
        LevelSpec::Ratios(r) => {
            if r.is_empty() {
                return Err(LodError::Option {
                    name: "ratios",
                    message: "at least one ratio is needed".into(),
                });
            }
            let mut last = 1.0;
            for &x in r {
                if !(x > 0.0 && x < last) {
                    return Err(LodError::Option {
                        name: "ratios",
                        message: format!(
                            "{x} must be in (0, 1) and below the ratio before it ({last})"
                        ),
                    });
                }
                last = x;
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod sampling_tests {
    use super::*;
    use crate::mesh::generate;

    /// The default count: 10 per triangle between the floor and the cap; an
    /// explicit count as given.
    #[test]
    fn default_samples_are_bounded() {
        let n_of = |m: &Mesh| sampling(&SamplingOptions::default(), m).samples;
        assert_eq!(n_of(&generate::grid(10, 10, |_, _| 0.0)), Some(MIN_SAMPLES));
        assert_eq!(n_of(&generate::grid(100, 100, |_, _| 0.0)), Some(200_000));
        assert_eq!(
            n_of(&generate::grid(400, 400, |_, _| 0.0)),
            Some(MAX_SAMPLES)
        );
        let given = SamplingOptions::default().with_samples(5_000_000);
        let big = generate::grid(400, 400, |_, _| 0.0);
        assert_eq!(sampling(&given, &big).samples, Some(5_000_000));
    }
}
