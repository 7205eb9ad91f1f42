//! Error measurement between two surfaces: one-sided and symmetric Hausdorff distance,
//! mean and RMS distance, and screen-space error.
//!
//! Follows Metro (Cignoni, Rocchini & Scopigno, "Metro: measuring error on simplified
//! surfaces", Computer Graphics Forum 17(2), 1998) and the course notes: the one-sided
//! distance `h(A,B) = max over a ∈ A of min over b ∈ B of |a − b|` is estimated by
//! sampling `A` (its vertices, points along its edges by length and points on its faces
//! by area) and finding each sample's exact closest point on `B` with a [`bvh::Bvh`];
//! the symmetric distance is `H = max(h(A,B), h(B,A))`.
//!
//! `--samples N` has MeshLab's `samplenum` meaning, so numbers compare with its
//! Hausdorff filter: every vertex (distinct position) is a sample, plus about `N`
//! samples on edges and `N` on faces. Face samples are stratified (each face receives
//! its share of `N` by area, by error diffusion, placed by a per-face seeded generator);
//! edge samples are evenly spaced along each edge. The same inputs and seed give the
//! same numbers, whatever the number of threads.
//!
//! The sampled maximum is a lower bound of the true one; [`certify`] then refines
//! around the largest distances until an upper bound is within 0.4% of it, so each
//! direction reports an interval `[max, max_upper]` holding the truth.
//!
//! The screen-space error of a geometric error `ε` seen at distance `d` with a vertical
//! field of view `θ` on a screen `x` pixels high is `p = ε x / (2 d tan(θ/2))`
//! ([`screen_space_error`]).

pub mod appearance;
pub mod bvh;
pub mod certify;
pub mod triangle;

use crate::mesh::{Mesh, Topology, Weld};
use bvh::Bvh;
use rayon::prelude::*;
use serde::Serialize;
use triangle::V3;

/// How a mesh is sampled for a one-sided distance.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SamplingOptions {
    /// About this many samples on edges and as many on faces (MeshLab's `samplenum`).
    /// `None` (default): `max(1_000_000, 10 × triangles of the sampled mesh)`.
    pub samples: Option<usize>,
    /// Sample every distinct vertex position. Default: true.
    pub vertices: bool,
    /// Sample along edges, by length. Default: true.
    pub edges: bool,
    /// Sample on faces, by area. Default: true.
    pub faces: bool,
    /// Seed of the face sample placement. Default: 0.
    pub seed: u64,
    /// Certify the maximum ([`certify`]): refine around the largest distances until the
    /// maximum is within [`certify::TOLERANCE`] of an upper bound, spending at most
    /// about as many closest-point queries again as the sampling (at least
    /// [`certify::MIN_BUDGET`]), and less when the interval stops closing (the
    /// interval is then wider, still true). Default: true.
    pub certify: bool,
}

impl Default for SamplingOptions {
    fn default() -> Self {
        Self {
            samples: None,
            vertices: true,
            edges: true,
            faces: true,
            seed: 0,
            certify: true,
        }
    }
}

impl SamplingOptions {
    /// Sets [`Self::samples`].
    #[must_use]
    pub fn with_samples(mut self, n: usize) -> Self {
        self.samples = Some(n);
        self
    }

    /// The `N` used for a sampled mesh of `triangles` triangles.
    #[must_use]
    pub fn samples_for(&self, triangles: usize) -> usize {
        self.samples
            .unwrap_or_else(|| (10 * triangles).max(1_000_000))
    }
}

/// One direction of the distance: samples of one mesh against the other surface.
///
/// Serialized with its fields and `max_lower` (the same value as `max`), so a report
/// names both ends of the certified interval `[max_lower, max_upper]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(into = "OneSidedReport")]
pub struct OneSided {
    /// Largest sample distance, in mesh units (with [`SamplingOptions::certify`], the
    /// largest after refinement: a lower bound of the true maximum).
    pub max: f64,
    /// With [`SamplingOptions::certify`], an upper bound of the true maximum (mesh
    /// units): the maximum lies in `[max, max_upper]`. `None` without certification;
    /// infinite when the other mesh is empty.
    pub max_upper: Option<f64>,
    /// Mean sample distance.
    pub mean: f64,
    /// Root mean square sample distance.
    pub rms: f64,
    /// The sample where the maximum occurs.
    pub max_at: [f64; 3],
    /// Its closest point on the other surface.
    pub max_closest: [f64; 3],
    /// Number of samples taken.
    pub samples: u64,
}

/// The serialized form of [`OneSided`].
#[derive(Serialize)]
struct OneSidedReport {
    max: f64,
    max_lower: f64,
    max_upper: Option<f64>,
    mean: f64,
    rms: f64,
    max_at: [f64; 3],
    max_closest: [f64; 3],
    samples: u64,
}

impl From<OneSided> for OneSidedReport {
    fn from(o: OneSided) -> Self {
        Self {
            max: o.max,
            max_lower: o.max,
            max_upper: o.max_upper,
            mean: o.mean,
            rms: o.rms,
            max_at: o.max_at,
            max_closest: o.max_closest,
            samples: o.samples,
        }
    }
}

/// Both directions and the symmetric summary, in absolute units with the scales needed
/// to make them relative.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Distances {
    /// `h(A, B)`: samples of A against B.
    pub a_to_b: OneSided,
    /// `h(B, A)`: samples of B against A.
    pub b_to_a: OneSided,
    /// Symmetric Hausdorff distance `max(h(A,B), h(B,A))`.
    pub hausdorff: f64,
    /// Upper bound of the symmetric Hausdorff distance, when both sides are certified.
    pub hausdorff_upper: Option<f64>,
    /// Symmetric mean: the larger of the two one-sided means (as the peers harness).
    pub mean: f64,
    /// Symmetric RMS: the larger of the two one-sided RMS values.
    pub rms: f64,
    /// Bounding-box diagonal of A (the scale of relative errors).
    pub bbox_diagonal: f64,
    /// Largest side of A's bounding box (meshoptimizer's error scale).
    pub max_extent: f64,
}

impl Distances {
    /// A copy with every distance divided by `scale` (e.g. the bbox diagonal).
    #[must_use]
    pub fn scaled(&self, scale: f64) -> Self {
        let s = if scale > 0.0 { 1.0 / scale } else { 0.0 };
        let one = |o: &OneSided| OneSided {
            max: o.max * s,
            mean: o.mean * s,
            rms: o.rms * s,
            max_upper: o.max_upper.map(|u| u * s),
            ..*o
        };
        Self {
            a_to_b: one(&self.a_to_b),
            b_to_a: one(&self.b_to_a),
            hausdorff: self.hausdorff * s,
            hausdorff_upper: self.hausdorff_upper.map(|u| u * s),
            mean: self.mean * s,
            rms: self.rms * s,
            ..*self
        }
    }
}

/// Symmetric distances between meshes `a` and `b` (both directions sampled with
/// `options`). Empty meshes give zero distances with zero samples on their side, and
/// infinite distance from a non-empty mesh to an empty one.
#[must_use]
pub fn hausdorff(a: &Mesh, b: &Mesh, options: &SamplingOptions) -> Distances {
    let a_to_b = one_sided(a, &Bvh::build(&b.positions, &b.triangles), options);
    let b_to_a = one_sided(b, &Bvh::build(&a.positions, &a.triangles), options);
    let (diag, ext) = match a.bounding_box(false) {
        Some((lo, hi)) => {
            let d: [f64; 3] = std::array::from_fn(|k| f64::from(hi[k]) - f64::from(lo[k]));
            (
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt(),
                d[0].max(d[1]).max(d[2]),
            )
        }
        None => (0.0, 0.0),
    };
    Distances {
        hausdorff: a_to_b.max.max(b_to_a.max),
        hausdorff_upper: a_to_b
            .max_upper
            .zip(b_to_a.max_upper)
            .map(|(x, y)| x.max(y)),
        mean: a_to_b.mean.max(b_to_a.mean),
        rms: a_to_b.rms.max(b_to_a.rms),
        a_to_b,
        b_to_a,
        bbox_diagonal: diag,
        max_extent: ext,
    }
}

/// Distance from each vertex of `mesh` to the surface indexed by `target` (absolute
/// units), e.g. for a heat map. Unreferenced vertices are measured too.
#[must_use]
pub fn vertex_distances(mesh: &Mesh, target: &Bvh) -> Vec<f64> {
    mesh.positions
        .par_chunks(4096)
        .flat_map_iter(|chunk| {
            let mut hint = None;
            chunk
                .iter()
                .map(|p| {
                    let q = f64v(*p);
                    match target.closest(q, hint) {
                        Some(c) => {
                            hint = Some(c.triangle);
                            c.dist2.sqrt()
                        }
                        None => f64::INFINITY,
                    }
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Partial sums of one chunk of samples; merged in chunk order (deterministic).
#[derive(Clone, Copy)]
struct Acc {
    max2: f64,
    max_at: V3,
    max_closest: V3,
    sum: f64,
    sum2: f64,
    n: u64,
}

impl Acc {
    const ZERO: Acc = Acc {
        max2: -1.0,
        max_at: [0.0; 3],
        max_closest: [0.0; 3],
        sum: 0.0,
        sum2: 0.0,
        n: 0,
    };
    fn merge(&mut self, o: &Acc) {
        if o.max2 > self.max2 {
            self.max2 = o.max2;
            self.max_at = o.max_at;
            self.max_closest = o.max_closest;
        }
        self.sum += o.sum;
        self.sum2 += o.sum2;
        self.n += o.n;
    }
}

/// A sampler that measures points against a BVH, keeping the previous answer as a hint.
struct Probe<'a> {
    target: &'a Bvh,
    hint: Option<u32>,
    acc: Acc,
    /// The squared distance of the last point added.
    last: f64,
    /// The nearest triangle of the last point added (`u32::MAX` if none).
    last_tri: u32,
}

impl Probe<'_> {
    #[inline]
    fn add(&mut self, p: V3) {
        let (d2, q) = match self.target.closest(p, self.hint) {
            Some(c) => {
                self.hint = Some(c.triangle);
                self.last_tri = c.triangle;
                (c.dist2, c.point)
            }
            None => {
                self.last_tri = u32::MAX;
                (f64::INFINITY, p)
            }
        };
        let d = d2.sqrt();
        self.last = d2;
        if d2 > self.acc.max2 {
            self.acc.max2 = d2;
            self.acc.max_at = p;
            self.acc.max_closest = q;
        }
        self.acc.sum += d;
        self.acc.sum2 += d2;
        self.acc.n += 1;
    }
}

#[inline]
pub(crate) fn f64v(p: [f32; 3]) -> V3 {
    [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]
}

/// Allots `n` samples among items of weight `w` (summing to `total`) by error
/// diffusion: item `i` gets `round(W_{i+1} n / total) − round(W_i n / total)` where `W`
/// are prefix sums. The counts sum to exactly `n` and each is within one of its share.
fn allot(weights: &[f64], n: usize) -> Vec<u32> {
    let total: f64 = weights.iter().sum();
    if total <= 0.0 || !total.is_finite() || n == 0 {
        return vec![0; weights.len()];
    }
    let scale = n as f64 / total;
    let mut prefix = 0.0;
    let mut prev = 0u64;
    weights
        .iter()
        .map(|&w| {
            prefix += w;
            let now = ((prefix * scale).round() as u64).min(n as u64);
            let c = now.saturating_sub(prev);
            prev = now.max(prev);
            c as u32
        })
        .collect()
}

/// A small deterministic generator (PCG-XSH-RR 64/32) for face sample placement.
struct Pcg(u64);

impl Pcg {
    fn new(seed: u64, stream: u64) -> Self {
        let mut g = Pcg(seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        g.next_u32();
        g
    }
    fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }
    fn unit(&mut self) -> f64 {
        f64::from(self.next_u32()) * (1.0 / 4_294_967_296.0)
    }
}

const CHUNK: usize = 2048;

/// Samples `mesh` (vertices, edges, faces) and measures every sample against `target`.
#[must_use]
pub fn one_sided(mesh: &Mesh, target: &Bvh, options: &SamplingOptions) -> OneSided {
    let n = options.samples_for(mesh.triangles.len());
    let mut total = Acc::ZERO;
    let weld = Weld::exact(&mesh.positions);
    let points = weld.map_triangles(&mesh.triangles);
    let pos = |p: u32| f64v(mesh.positions[weld.representative[p as usize] as usize]);

    let mut known: Option<Vec<(f64, u32)>> = None;
    let mut face_max: Option<Vec<f32>> = None;
    if options.vertices {
        let mut used = vec![false; weld.point_count()];
        for t in &points {
            for &p in t {
                used[p as usize] = true;
            }
        }
        let ids: Vec<u32> = (0..weld.point_count() as u32)
            .filter(|&p| used[p as usize])
            .collect();
        // With certification, each point's distance and nearest triangle are kept
        // for it (its regions' corners).
        let parts: Vec<(Acc, Vec<(f64, u32)>)> = ids
            .par_chunks(CHUNK)
            .map(|c| {
                let mut probe = Probe {
                    target,
                    hint: None,
                    acc: Acc::ZERO,
                    last: 0.0,
                    last_tri: u32::MAX,
                };
                let mut hits = Vec::with_capacity(if options.certify { c.len() } else { 0 });
                for &p in c {
                    probe.add(pos(p));
                    if options.certify {
                        let d = probe.last.sqrt();
                        hits.push((d, probe.last_tri));
                    }
                }
                (probe.acc, hits)
            })
            .collect();
        if options.certify {
            let mut all = vec![(0.0, u32::MAX); weld.point_count()];
            for (&p, h) in ids.iter().zip(parts.iter().flat_map(|(_, h)| h)) {
                all[p as usize] = *h;
            }
            known = Some(all);
        }
        parts.iter().for_each(|(a, _)| total.merge(a));
    }

    if options.edges && n > 0 {
        let topo = Topology::build(&points, weld.point_count());
        let edges: Vec<[u32; 2]> = topo
            .edges
            .iter()
            .copied()
            .filter(|e| e[0] != e[1])
            .collect();
        let lengths: Vec<f64> = edges
            .iter()
            .map(|e| triangle::dist2(pos(e[0]), pos(e[1])).sqrt())
            .collect();
        let counts = allot(&lengths, n);
        let parts: Vec<Acc> = edges
            .par_chunks(CHUNK)
            .zip(counts.par_chunks(CHUNK))
            .map(|(es, cs)| {
                let mut probe = Probe {
                    target,
                    hint: None,
                    acc: Acc::ZERO,
                    last: 0.0,
                    last_tri: u32::MAX,
                };
                for (e, &c) in es.iter().zip(cs) {
                    let (a, b) = (pos(e[0]), pos(e[1]));
                    for k in 0..c {
                        let t = (f64::from(k) + 0.5) / f64::from(c);
                        probe.add(std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t));
                    }
                }
                probe.acc
            })
            .collect();
        parts.iter().for_each(|a| total.merge(a));
    }

    if options.faces && n > 0 {
        let areas: Vec<f64> = points
            .iter()
            .map(|t| {
                let (a, b, c) = (pos(t[0]), pos(t[1]), pos(t[2]));
                let cr = triangle::cross(triangle::sub(b, a), triangle::sub(c, a));
                0.5 * triangle::dot(cr, cr).sqrt()
            })
            .collect();
        let counts = allot(&areas, n);
        let idx: Vec<u32> = (0..points.len() as u32).collect();
        // With certification, each triangle's largest sample distance is kept for
        // it (where to refine first).
        let parts: Vec<(Acc, Vec<f32>)> = idx
            .par_chunks(CHUNK)
            .map(|ts| {
                let mut probe = Probe {
                    target,
                    hint: None,
                    acc: Acc::ZERO,
                    last: 0.0,
                    last_tri: u32::MAX,
                };
                let mut highs = Vec::with_capacity(if options.certify { ts.len() } else { 0 });
                for &t in ts {
                    let c = counts[t as usize];
                    let tri = points[t as usize];
                    let (a, b, cc) = (pos(tri[0]), pos(tri[1]), pos(tri[2]));
                    let mut rng = Pcg::new(options.seed, u64::from(t));
                    let mut high = 0.0f64;
                    for _ in 0..c {
                        let (mut u, mut v) = (rng.unit(), rng.unit());
                        if u + v > 1.0 {
                            u = 1.0 - u;
                            v = 1.0 - v;
                        }
                        probe.add(std::array::from_fn(|i| {
                            a[i] + (b[i] - a[i]) * u + (cc[i] - a[i]) * v
                        }));
                        high = high.max(probe.last);
                    }
                    if options.certify {
                        highs.push(high.sqrt() as f32);
                    }
                }
                (probe.acc, highs)
            })
            .collect();
        if options.certify {
            face_max = Some(parts.iter().flat_map(|(_, h)| h).copied().collect());
        }
        parts.iter().for_each(|(a, _)| total.merge(a));
    }

    if total.n == 0 {
        return OneSided {
            max: 0.0,
            max_upper: options.certify.then_some(0.0),
            mean: 0.0,
            rms: 0.0,
            max_at: [0.0; 3],
            max_closest: [0.0; 3],
            samples: 0,
        };
    }
    let mut out = OneSided {
        max: total.max2.max(0.0).sqrt(),
        max_upper: None,
        mean: total.sum / total.n as f64,
        rms: (total.sum2 / total.n as f64).sqrt(),
        max_at: total.max_at,
        max_closest: total.max_closest,
        samples: total.n,
    };
    if options.certify {
        let at: Vec<V3> = (0..weld.point_count() as u32).map(pos).collect();
        let c = certify::certify(
            &at,
            &points,
            target,
            out.max,
            (out.max_at, out.max_closest),
            &certify::Known {
                points: known.as_deref(),
                faces: face_max.as_deref(),
            },
            (n as u64).max(certify::MIN_BUDGET),
        );
        out.max = c.lower;
        (out.max_at, out.max_closest) = c.lower_at;
        out.max_upper = Some(c.upper);
    }
    out
}

/// Pixels covered by a geometric error `error` seen at `distance` (same units) with a
/// vertical field of view of `fov_degrees` on a screen `screen_height_px` pixels high:
/// `p = ε x / (2 d tan(θ/2))`.
#[must_use]
pub fn screen_space_error(
    error: f64,
    screen_height_px: f64,
    fov_degrees: f64,
    distance: f64,
) -> f64 {
    let half = (fov_degrees.to_radians() * 0.5).tan();
    error * screen_height_px / (2.0 * distance * half)
}

/// The inverse of [`screen_space_error`]: the distance at which `error` covers
/// `pixels` pixels, `d = ε x / (2 p tan(θ/2))`.
#[must_use]
pub fn distance_for_pixels(
    error: f64,
    pixels: f64,
    screen_height_px: f64,
    fov_degrees: f64,
) -> f64 {
    let half = (fov_degrees.to_radians() * 0.5).tan();
    error * screen_height_px / (2.0 * pixels * half)
}

#[cfg(test)]
mod tests;
