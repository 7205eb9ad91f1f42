//! Attribute values refitted to the input after simplifying: the output's normals,
//! texture coordinates and colours, with its geometry held fixed, are set to the
//! least-squares fit of the input's values at corresponding points.
//!
//! The collapses give each merged vertex the attribute values that minimise its
//! attribute quadric (Garland & Heckbert 1998; Hoppe 1999): the values of the input
//! triangles it merged, measured against their planes at the time of the merge. Later
//! collapses around it change which input surface its triangles cover, as they do for
//! positions (the `fit` module), so the values fit the wrong samples. This pass is the
//! scalar-attribute term of Hoppe's "Progressive meshes" (SIGGRAPH 1996), `E_scalar`:
//! with the correspondences fixed (each input sample paired with its closest point on
//! the output) the sum of squared attribute differences is a linear least-squares
//! problem in the output's vertex values, solved here by conjugate gradients, then
//! reweighted toward the mean difference rather than its square.
//!
//! - **Samples.** One per input triangle: its centroid, weighing the triangle's area,
//!   with the triangle's interpolated values (corner normals normalised first), so it
//!   lies on one side of any seam. (Three points per triangle, the quadrature exact
//!   for quadratics, lowered the glTF assets' normal means by 0.3–2.5% more for
//!   twice this pass's time.) When the input has more than
//!   [`SAMPLES_PER_TRIANGLE`] triangles per output triangle (below 1/32 of the
//!   input), that many samples per output triangle are drawn instead, jittered
//!   by area in mesh order, each weighing an equal share of the area, plus every
//!   input triangle touching a hard crease (for the crease split): on the
//!   DamagedHelmet subdivided to 3.96M triangles at 0.1% the pass went from 3.5 s to
//!   0.7 s for a normal-angle mean 0.12% higher (5.424° against 5.418°), on the
//!   coloured 1M Grand Canyon grid at 1% from 0.87 s to 0.45 s for a colour mean 0.18%
//!   higher (draws at a fixed point of each share: 0.08% and 0.09%, but in the same
//!   columns row after row on a grid; 16 samples: 0.55% and 0.46%; 64: within 0.02%).
//! - **Correspondence.** The closest point on the output (queries started at the
//!   previous sample's answer: input triangles come in mesh order). Where it lies on
//!   an edge or a corner, every output triangle as near (within `10⁻⁶` of the
//!   diagonal) is a candidate and the one whose current value is nearest the sample's
//!   is taken, per attribute: a sample on a seam pairs with its own side. A candidate
//!   is left out when the input triangle faces against it (the far side of a thin
//!   part, ICP's normal-compatibility rejection) or belongs to another material, and,
//!   for texture coordinates, when the sample's value lies farther from its current
//!   value than the triangle's own extent in the texture (another chart of the atlas:
//!   pulling toward it would smear the texture).
//! - **Solve.** Per attribute, minimise `Σ_s r_s w_s |Σ_k b_k(s) x_k − a_s|² +
//!   Σ_v μ_v |x_v − x⁰_v|²` over the output's vertex values `x`, with `x⁰` the
//!   collapses' values (the prior) and `μ_v` a tenth of the weight a uniform sampling
//!   of the vertex's own triangles would give it, plus a hundredth of its samples'
//!   (a vertex no sample reaches keeps its value). The normal equations are summed
//!   into a 3 × 3 block per output triangle, so each product costs the output's size;
//!   Jacobi-preconditioned conjugate gradients ([`CG_ITERATIONS`] steps at most).
//!   [`ROUNDS`] solves: the first with `r_s = 1`, the others with `r_s = 1 /
//!   max(|residual|, δ)` from the last (iteratively reweighted least squares: the
//!   mean difference, which `meshlod measure` reports, rather than its square, so a
//!   crease crossed by a collapse does not pull its whole neighbourhood). Normals are
//!   renormalised after, and tangents made perpendicular to them again (their
//!   handedness kept). Joints and weights are left as they are; so are locked
//!   vertices. Wedges at one point with the same value of a stream are one unknown of
//!   that stream, so a UV seam does not become a normal crease. A sample whose value
//!   is not finite pulls nothing.
//! - **Crossed creases.** Before the normals are solved, a normal wedge whose
//!   triangles cover both sides of a hard crease of the input is split in two (the
//!   `creases` module): each side then gets its own normal.

use crate::mesh::{Mesh, Weld};
use crate::metrics::bvh::Bvh;
use crate::metrics::f64v;
use crate::metrics::triangle::{barycentric, closest_point, cross, dist2, dot, sub, Region, V3};
use rayon::prelude::*;

mod creases;

/// The centroid of an input triangle paired with the output: 72 bytes.
struct Pair {
    /// The input triangle sampled.
    input: u32,
    /// Output triangle per stream (normal, uv0, uv1, colour); `u32::MAX` when the
    /// sample is left out for that stream.
    triangle: [u32; 4],
    /// Barycentric weights of the closest point in that triangle, per stream.
    bary: [[f32; 3]; 4],
    /// Weight (the input triangle's area).
    weight: f32,
}

/// Samples per output triangle, on average, above which the input's triangles are
/// subsampled (module docs, "Samples").
const SAMPLES_PER_TRIANGLE: usize = 32;

/// Per input triangle, the weight of its sample: 0 when it is not sampled, [`OWN`]
/// when it is sampled with its own area; `None` when every triangle is (the input
/// has at most `per_triangle` triangles per triangle of an output of
/// `out_triangles`). Otherwise the triangles for which `forced` holds are sampled
/// with their own area, and the others by area in mesh order, `per_triangle` per
/// output triangle in all: their running area is cut into equal shares, each
/// drawn at a jittered point of its share, and a triangle weighs the shares drawn
/// in it (a triangle larger than a share is always drawn), so the weights still
/// sum to the area.
fn sample_weights(
    input: &Mesh,
    out_triangles: usize,
    per_triangle: usize,
    forced: impl Fn(usize) -> bool + Sync,
) -> Option<Vec<f32>> {
    let n = input.triangles.len();
    let budget = per_triangle.saturating_mul(out_triangles);
    if n <= budget {
        return None;
    }
    // The free triangles' areas; [`OWN`] for the forced ones.
    let area: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|t| {
            if forced(t) {
                return f64::from(OWN);
            }
            let n = face_normal(input, t);
            let a = 0.5 * dot(n, n).sqrt();
            if a.is_finite() {
                a
            } else {
                0.0
            }
        })
        .collect();
    let free: f64 = area.iter().filter(|&&a| a > 0.0).sum();
    let share = free / budget as f64;
    // Share `k` is drawn where the running area passes `(k + u_k)·share`, `u_k` in
    // [0, 1) from a hash of `k` (jittered, not at a fixed offset: a row-ordered grid
    // whose rows span whole shares would otherwise be sampled in the same columns
    // row after row).
    let at = |k: u64| (k as f64 + jitter(k)) * share;
    let mut k = 0u64;
    let mut next = at(0);
    let mut acc = 0.0f64;
    Some(
        area.iter()
            .map(|&a| {
                if a < 0.0 {
                    return OWN;
                }
                acc += a;
                if share <= 0.0 {
                    return 0.0;
                }
                let mut shares = 0u32;
                while next <= acc {
                    shares += 1;
                    k += 1;
                    next = at(k);
                }
                (f64::from(shares) * share) as f32
            })
            .collect(),
    )
}

/// A number in [0, 1) from `k` (SplitMix64's finaliser).
fn jitter(k: u64) -> f64 {
    let mut z = k.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// [`sample_weights`]: sampled with its own area.
const OWN: f32 = -1.0;

/// Least-squares solves per attribute: the first plain, then reweighted by the
/// residuals (iteratively reweighted least squares toward the mean difference;
/// one plain solve left the Duck's normal mean at 5.66°, Avocado's at 6.33°, against
/// 5.57° and 5.70° with it, before wedges of one value were one unknown).
const ROUNDS: usize = 4;
/// Residuals below this fraction of the first solve's weighted RMS residual weigh as
/// much as it (the reweighting's floor).
const DELTA: f64 = 0.25;
/// Conjugate-gradient steps per solve at most. The system is a mass matrix, well
/// conditioned: the preconditioned residual's squared norm falls about fivefold
/// per step. Five steps instead of ten (alone) moved the glTF assets'
/// normal-angle means by 0.08% at most (DamagedHelmet at 10%: 11.832° against
/// 11.823°; each round starts from the last one's answer) for about half the
/// conjugate-gradient time.
const CG_ITERATIONS: usize = 5;

/// Streams refitted, in [`Pair`]'s order.
const STREAMS: usize = 4;
/// The sample's barycentric weights in its input triangle.
const CENTROID: [f32; 3] = [1.0 / 3.0; 3];
const NORMAL: usize = 0;
const UV0: usize = 1;
const UV1: usize = 2;

fn face_normal(m: &Mesh, t: usize) -> V3 {
    let [a, b, c] = m.triangles[t].map(|v| f64v(m.positions[v as usize]));
    cross(sub(b, a), sub(c, a))
}

/// Scales `v` to unit length (a zero vector stays zero).
fn normalise(v: &mut [f64]) {
    let l = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if l > 0.0 {
        v.iter_mut().for_each(|x| *x /= l);
    }
}

fn bary32(b: [f64; 3]) -> [f32; 3] {
    b.map(|x| x as f32)
}

/// A stream's values as rows of `D` floats, `None` when absent.
struct Stream<'a> {
    values: &'a [f32],
    dim: usize,
}

impl Stream<'_> {
    fn at(&self, v: u32) -> &[f32] {
        &self.values[v as usize * self.dim..(v as usize + 1) * self.dim]
    }
    /// Interpolated value in triangle `t` of `m` at `b` (normals: corners normalised).
    fn interp(&self, m: &Mesh, t: u32, b: [f32; 3], normalise: bool, out: &mut [f64]) {
        out.iter_mut().for_each(|x| *x = 0.0);
        for (k, &v) in m.triangles[t as usize].iter().enumerate() {
            let row = self.at(v);
            let mut s = f64::from(b[k]);
            if normalise {
                let n = row
                    .iter()
                    .map(|&x| f64::from(x).powi(2))
                    .sum::<f64>()
                    .sqrt();
                if n > 0.0 {
                    s /= n;
                }
            }
            for (o, &x) in out.iter_mut().zip(row) {
                *o += s * f64::from(x);
            }
        }
    }
}

/// The refitted streams of `m`, in [`Pair`]'s order.
fn streams(m: &Mesh) -> [Option<Stream<'_>>; STREAMS] {
    fn rows<const D: usize>(v: Option<&Vec<[f32; D]>>) -> Option<Stream<'_>> {
        v.map(|v| Stream {
            values: v.as_flattened(),
            dim: D,
        })
    }
    let a = &m.attributes;
    [
        rows(a.normals.as_ref()),
        rows(a.uv0.as_ref()),
        rows(a.uv1.as_ref()),
        rows(a.colors.as_ref()),
    ]
}

/// Refits the attribute values of `out` (normals, texture coordinates, colours) to
/// those of `input` at corresponding points; `locked` vertices of `out` keep theirs.
/// Where the output crosses a hard crease of the input, normal wedges are split
/// first (the `creases` module): the copies are appended to `out`'s vertices.
/// Returns the number of output vertices whose values changed and, for each copy in
/// order, the vertex it copies.
pub(crate) fn refit_attributes(input: &Mesh, out: &mut Mesh, locked: &[bool]) -> (usize, Vec<u32>) {
    refit_sampled(input, out, locked, SAMPLES_PER_TRIANGLE)
}

/// [`refit_attributes`] with at most `samples_per_triangle` samples per output
/// triangle on average (plus the input triangles at hard creases).
fn refit_sampled(
    input: &Mesh,
    out: &mut Mesh,
    locked: &[bool],
    samples_per_triangle: usize,
) -> (usize, Vec<u32>) {
    let si = streams(input);
    let so = streams(out);
    let present: Vec<usize> = (0..STREAMS)
        .filter(|&k| si[k].is_some() && so[k].is_some())
        .collect();
    if present.is_empty() || out.triangles.is_empty() || input.triangles.is_empty() {
        return (0, Vec::new());
    }
    // The Morton-order tree: the queries below take 10% longer than with the
    // surface-area tree, which takes 7× as long to build (1.0 s against 0.14 s
    // for a 2M-triangle output, whose pairing took 2 s).
    let bvh = Bvh::build_morton(&out.positions, &out.triangles);
    let diag = out.bbox_diagonal();
    let eps = 1e-6 * diag;
    // The input's hard creases (normals only): every input triangle touching one
    // is sampled, for the crease split.
    let creases = present
        .contains(&NORMAL)
        .then(|| creases::CreasePoints::of(input))
        .flatten();
    let weights = sample_weights(input, out.triangles.len(), samples_per_triangle, |t| {
        creases.as_ref().is_some_and(|c| c.touches(input, t))
    });
    let out_ref: &Mesh = out;
    const CHUNK: usize = 2048;
    let pairs: Vec<Pair> = input
        .triangles
        .par_chunks(CHUNK)
        .enumerate()
        .flat_map_iter(|(c, chunk)| {
            let mut hint = None;
            let mut cands = Vec::new();
            let weights = weights.as_deref();
            (0..chunk.len())
                .filter_map(|j| {
                    let t = (c * CHUNK + j) as u32;
                    let w = weights.map_or(OWN, |w| w[t as usize]);
                    if w == 0.0 {
                        return None;
                    }
                    let scratch = (&mut hint, &mut cands);
                    let mut p = pair(input, out_ref, &bvh, t, scratch, eps, &si, &so, &present);
                    if w != OWN {
                        p.weight = w;
                    }
                    Some(p)
                })
                .collect::<Vec<_>>()
        })
        .collect();
    // Crossed creases split into wedges of their own (normals only): `side` keeps
    // the two sides of a split apart in the normal stream's unknowns.
    // One point per position, for the crease split and the wedge groups of each
    // stream.
    let mut weld = Weld::exact(&out.positions);
    let mut side = Vec::new();
    let copies = match &creases {
        Some(c) => creases::split_creases(input, out, &pairs, c, locked, &mut weld, &mut side),
        None => Vec::new(),
    };
    drop(creases);
    let nv = out.positions.len();
    let mut changed = vec![false; nv];
    // One stream after the other: side by side on two threads they took 1.3 s
    // less of 5.9 s (DamagedHelmet subdivided to 3.96M triangles, at 50%) for a
    // peak a third higher.
    for &k in &present {
        let view = StreamFit {
            input,
            out,
            pairs: &pairs,
            weld: &weld,
            side: &side,
            locked,
        };
        let (x, fixed) = view.fit(k, si[k].as_ref().expect("a present stream"));
        store(out, k, &x, &fixed, &mut changed);
    }
    // Tangents stay perpendicular to the refitted normals (Gram-Schmidt; the
    // handedness kept).
    if let (Some(n), Some(t)) = (&out.attributes.normals, &mut out.attributes.tangents) {
        for (n, t) in n.iter().zip(t.iter_mut()) {
            let n = f64v(*n);
            let v = [t[0], t[1], t[2]].map(f64::from);
            let s = dot(v, n);
            let u = sub(v, [n[0] * s, n[1] * s, n[2] * s]);
            let l = dot(u, u).sqrt();
            if l > 1e-6 * dot(v, v).sqrt() {
                *t = [
                    (u[0] / l) as f32,
                    (u[1] / l) as f32,
                    (u[2] / l) as f32,
                    t[3],
                ];
            }
        }
    }
    (changed.iter().filter(|&&c| c).count(), copies)
}

/// What every stream's fit reads: the input, the output (its geometry and
/// current values), the samples, the output's points and crease sides, the
/// locked vertices.
struct StreamFit<'a> {
    input: &'a Mesh,
    out: &'a Mesh,
    pairs: &'a [Pair],
    weld: &'a Weld,
    side: &'a [u32],
    locked: &'a [bool],
}

impl StreamFit<'_> {
    /// The refitted values of stream `k` (`s_in` on the input), rows of its
    /// dimension per output vertex, and which vertices were held fixed.
    fn fit(&self, k: usize, s_in: &Stream<'_>) -> (Vec<f64>, Vec<bool>) {
        let StreamFit {
            input,
            out,
            pairs,
            weld,
            side,
            locked,
        } = *self;
        let nv = out.positions.len();
        let d = s_in.dim;
        let targets: Vec<[f64; 4]> = pairs
            .iter()
            .map(|p| {
                let mut a = [0.0f64; 4];
                if p.triangle[k] != u32::MAX {
                    s_in.interp(input, p.input, CENTROID, k == NORMAL, &mut a[..d]);
                }
                a
            })
            .collect();
        let x0: Vec<f64> = streams(out)[k].as_ref().map_or_else(Vec::new, |s| {
            s.values.iter().map(|&x| f64::from(x)).collect()
        });
        // Wedges at one point with the same value of this stream are one unknown:
        // a UV seam does not become a normal crease, nor a crease a UV seam.
        let sides = if k == NORMAL { side } else { &[] };
        let group = same_value_groups(weld, &x0, d, sides);
        let tris: Vec<[u32; 3]> = out
            .triangles
            .iter()
            .map(|t| t.map(|v| group[v as usize]))
            .collect();
        let mut held = vec![false; nv];
        for (v, &g) in group.iter().enumerate() {
            held[g as usize] |= locked.get(v).copied().unwrap_or(false);
        }
        // A sample whose value is not finite (a NaN in the file) pulls nothing.
        let mut rw: Vec<f64> = targets
            .iter()
            .map(|a| f64::from(u8::from(a.iter().all(|x| x.is_finite()))))
            .collect();
        let finite = rw.clone();
        let mut delta = 0.0;
        let mut x = x0.clone();
        let mut fixed = vec![true; nv];
        for round in 0..ROUNDS {
            let system = System {
                out,
                tris: &tris,
                pairs,
                targets: &targets,
                rw: &rw,
                k,
            };
            let (xr, fx) = system.solve(d, &x0, &x, &held);
            x = xr;
            fixed = fx;
            for (v, &g) in group.iter().enumerate() {
                let g = g as usize;
                for j in 0..d {
                    x[v * d + j] = x[g * d + j];
                }
                fixed[v] = fixed[g];
            }
            if round + 1 == ROUNDS {
                break;
            }
            // Robust weights: 1 / max(|residual|, δ) (iteratively reweighted least
            // squares toward the mean distance, not its square).
            let mut xs = x.clone();
            if k == NORMAL {
                xs.chunks_exact_mut(3).for_each(normalise);
            }
            let mut res = vec![0.0f64; pairs.len()];
            for (i, p) in pairs.iter().enumerate() {
                let t = p.triangle[k];
                if t == u32::MAX || finite[i] == 0.0 {
                    continue;
                }
                let tri = tris[t as usize];
                let mut v = [0.0f64; 4];
                for c in 0..3 {
                    for j in 0..d {
                        v[j] += f64::from(p.bary[k][c]) * xs[tri[c] as usize * d + j];
                    }
                }
                let mut target = targets[i];
                if k == NORMAL {
                    normalise(&mut v[..3]);
                    normalise(&mut target[..3]);
                }
                let r = (0..d)
                    .map(|j| (v[j] - target[j]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                res[i] = r;
            }
            if round == 0 {
                let (sw, sr) = pairs
                    .iter()
                    .zip(&res)
                    .zip(&finite)
                    .filter(|((p, _), &f)| p.triangle[k] != u32::MAX && f > 0.0)
                    .map(|(x, _)| x)
                    .fold((0.0, 0.0), |(w, r2), (p, &r)| {
                        (w + f64::from(p.weight), r2 + f64::from(p.weight) * r * r)
                    });
                delta = if sw > 0.0 {
                    DELTA * (sr / sw).sqrt()
                } else {
                    0.0
                };
            }
            for ((w, &r), &f) in rw.iter_mut().zip(&res).zip(&finite) {
                *w = f / r.max(delta).max(1e-12);
            }
        }
        (x, fixed)
    }
}

/// Pairs input triangle `t`'s centroid with the output (see the module docs).
#[allow(clippy::too_many_arguments)]
fn pair(
    input: &Mesh,
    out: &Mesh,
    bvh: &Bvh,
    t: u32,
    (hint, cands): (&mut Option<u32>, &mut Vec<(u32, [f32; 3])>),
    eps: f64,
    si: &[Option<Stream<'_>>; STREAMS],
    so: &[Option<Stream<'_>>; STREAMS],
    present: &[usize],
) -> Pair {
    let corners = input.triangles[t as usize].map(|v| f64v(input.positions[v as usize]));
    let n_in = cross(sub(corners[1], corners[0]), sub(corners[2], corners[0]));
    let area = 0.5 * dot(n_in, n_in).sqrt();
    let b = CENTROID;
    let p = [0, 1, 2].map(|k| (corners[0][k] + corners[1][k] + corners[2][k]) / 3.0);
    let mut pair = Pair {
        input: t,
        triangle: [u32::MAX; STREAMS],
        bary: [[0.0; 3]; STREAMS],
        weight: area as f32,
    };
    let Some(c) = bvh.closest(p, *hint) else {
        return pair;
    };
    *hint = Some(c.triangle);
    let tri = |i: u32| out.triangles[i as usize].map(|v| f64v(out.positions[v as usize]));
    // Candidates: the closest triangle and, where the closest point is on an edge or
    // a corner, every triangle as near.
    cands.clear();
    let [a0, b0, c0] = tri(c.triangle);
    let (_, region) = closest_point(p, a0, b0, c0);
    if region == Region::Face {
        cands.push((c.triangle, bary32(barycentric(c.point, a0, b0, c0))));
    } else {
        let r = c.dist2.sqrt() + eps;
        bvh.for_each_in_box(
            [p[0] - r, p[1] - r, p[2] - r],
            [p[0] + r, p[1] + r, p[2] + r],
            |i, _| {
                let [a, bb, cc] = tri(i);
                let (q, _) = closest_point(p, a, bb, cc);
                if dist2(p, q) <= r * r {
                    cands.push((i, bary32(barycentric(q, a, bb, cc))));
                }
                true
            },
        );
        if cands.is_empty() {
            cands.push((c.triangle, bary32(barycentric(c.point, a0, b0, c0))));
        }
    }
    let group_in = input.groups.as_ref().map(|g| g[t as usize]);
    cands.retain(|&(i, _)| {
        dot(n_in, face_normal(out, i as usize)) > 0.0
            && match (group_in, out.groups.as_ref()) {
                (Some(g), Some(go)) => go[i as usize] == g,
                _ => true,
            }
    });
    let mut sample = [0.0f64; 4];
    let mut cur = [0.0f64; 4];
    for &k in present {
        let (Some(s_in), Some(s_out)) = (&si[k], &so[k]) else {
            continue;
        };
        let d = s_in.dim;
        s_in.interp(input, t, b, k == NORMAL, &mut sample[..d]);
        let mut best: Option<(f64, u32, [f32; 3])> = None;
        for &(i, bo) in cands.iter() {
            s_out.interp(out, i, bo, k == NORMAL, &mut cur[..d]);
            let diff: f64 = (0..d).map(|j| (cur[j] - sample[j]).powi(2)).sum();
            if k == UV0 || k == UV1 {
                // Another chart: farther than the triangle's own extent.
                let uv = out.triangles[i as usize].map(|v| s_out.at(v));
                let ext = [(0, 1), (1, 2), (2, 0)]
                    .iter()
                    .map(|&(x, y)| {
                        (0..d)
                            .map(|j| f64::from(uv[x][j] - uv[y][j]).powi(2))
                            .sum::<f64>()
                    })
                    .fold(0.0, f64::max);
                if diff > ext {
                    continue;
                }
            }
            if best.is_none_or(|(bd, _, _)| diff < bd) {
                best = Some((diff, i, bo));
            }
        }
        if let Some((_, i, bo)) = best {
            pair.triangle[k] = i;
            pair.bary[k] = bo;
        }
    }
    pair
}

/// The entries of a symmetric 3 × 3 block, in the order stored.
const SYMMETRIC: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

/// One stream's least-squares system: the output, its triangles' unknowns, the
/// samples with their targets and robust weights, and the stream.
struct System<'a> {
    out: &'a Mesh,
    tris: &'a [[u32; 3]],
    pairs: &'a [Pair],
    targets: &'a [[f64; 4]],
    rw: &'a [f64],
    k: usize,
}

impl System<'_> {
    /// One weighted least-squares solve of rows of `d` values from `start`,
    /// held toward `x0`: the values and which vertices were held fixed.
    fn solve(&self, d: usize, x0: &[f64], start: &[f64], locked: &[bool]) -> (Vec<f64>, Vec<bool>) {
        match d {
            2 => solve_rows::<2>(self, x0, start, locked),
            3 => solve_rows::<3>(self, x0, start, locked),
            4 => solve_rows::<4>(self, x0, start, locked),
            _ => unreachable!("streams have 2, 3 or 4 values per vertex"),
        }
    }
}

/// [`System::solve`] for rows of `D` values (a constant, so the loops over a row unroll).
fn solve_rows<const D: usize>(
    system: &System<'_>,
    x0: &[f64],
    start: &[f64],
    locked: &[bool],
) -> (Vec<f64>, Vec<bool>) {
    let System {
        out,
        tris,
        pairs,
        targets,
        rw,
        k,
    } = *system;
    let d = D;
    let nv = out.positions.len();
    // The normal equations' matrix, summed per output triangle (a 3 × 3 block of
    // its corners), so each product below costs the output's size, not the input's.
    // Symmetric, so six entries (00, 01, 02, 11, 12, 22), in single precision: a
    // third of the memory of a full block in double precision (the products
    // below are bound by memory).
    let mut blocks = vec![[0.0f32; 6]; out.triangles.len()];
    let mut diag_m = vec![0.0f64; nv];
    let mut rhs = vec![0.0f64; nv * d];
    for (p, (a, &w)) in pairs.iter().zip(targets.iter().zip(rw)) {
        let i = p.triangle[k];
        if i == u32::MAX {
            continue;
        }
        let b = p.bary[k].map(f64::from);
        let ww = w * f64::from(p.weight);
        let m = &mut blocks[i as usize];
        for (e, (r, c)) in m.iter_mut().zip(SYMMETRIC) {
            *e += (ww * b[r] * b[c]) as f32;
        }
        for (c, &v) in tris[i as usize].iter().enumerate() {
            diag_m[v as usize] += ww * b[c] * b[c];
            for j in 0..d {
                rhs[v as usize * d + j] += ww * b[c] * a[j];
            }
        }
    }
    let fixed: Vec<bool> = (0..nv)
        .map(|v| diag_m[v] <= 0.0 || locked.get(v).copied().unwrap_or(false))
        .collect();
    // Each vertex held toward its value by a tenth of the weight a uniform
    // sampling of its own triangles would give it.
    let mut mu: Vec<f64> = diag_m.iter().map(|&m| 0.01 * m).collect();
    // The prior scales with the samples' mean weight (over those that count).
    let (sw, swr) = pairs
        .iter()
        .zip(rw)
        .filter(|(p, &w)| p.triangle[k] != u32::MAX && w > 0.0)
        .fold((0.0, 0.0), |(a, b), (p, &w)| {
            let pw = f64::from(p.weight);
            (a + pw, b + pw * w)
        });
    let mean_w = if sw > 0.0 { swr / sw } else { 1.0 };
    for (t, g) in out.triangles.iter().zip(tris) {
        let [a, b, c] = t.map(|v| f64v(out.positions[v as usize]));
        let n = cross(sub(b, a), sub(c, a));
        let area = 0.5 * dot(n, n).sqrt();
        for &v in g {
            mu[v as usize] += 0.1 * mean_w * area / 6.0;
        }
    }
    for (v, &m) in mu.iter().enumerate() {
        for j in 0..d {
            rhs[v * d + j] += m * x0[v * d + j];
        }
    }
    let apply = |x: &[f64], y: &mut [f64]| {
        y.iter_mut().for_each(|e| *e = 0.0);
        for (t, m) in tris.iter().zip(&blocks) {
            let [m00, m01, m02, m11, m12, m22] = m.map(f64::from);
            let [a, b, c] = t.map(|v| v as usize * d);
            for j in 0..d {
                let (xa, xb, xc) = (x[a + j], x[b + j], x[c + j]);
                y[a + j] += m00 * xa + m01 * xb + m02 * xc;
                y[b + j] += m01 * xa + m11 * xb + m12 * xc;
                y[c + j] += m02 * xa + m12 * xb + m22 * xc;
            }
        }
        for v in 0..nv {
            for j in 0..d {
                y[v * d + j] += mu[v] * x[v * d + j];
            }
        }
    };
    let mut x = start.to_vec();
    let mut ax = vec![0.0; nv * d];
    apply(&x, &mut ax);
    // Per vertex, by rows of `d` (no integer division per entry).
    let mask = |v: &mut [f64]| {
        for (row, &f) in v.chunks_exact_mut(d).zip(&fixed) {
            if f {
                row.fill(0.0);
            }
        }
    };
    let mut r: Vec<f64> = rhs.iter().zip(&ax).map(|(b, a)| b - a).collect();
    mask(&mut r);
    let scale: Vec<f64> = diag_m.iter().zip(&mu).map(|(&a, &b)| a + b).collect();
    let pre = |r: &[f64], z: &mut [f64]| {
        for ((zr, rr), &s) in z.chunks_exact_mut(d).zip(r.chunks_exact(d)).zip(&scale) {
            for (e, &x) in zr.iter_mut().zip(rr) {
                *e = if s > 0.0 { x / s } else { 0.0 };
            }
        }
    };
    let mut z = vec![0.0; nv * d];
    pre(&r, &mut z);
    let mut pdir = z.clone();
    let mut rz: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
    let r0 = rz;
    let mut ap = vec![0.0; nv * d];
    for _ in 0..CG_ITERATIONS {
        if rz <= 1e-6 * r0 {
            break;
        }
        apply(&pdir, &mut ap);
        mask(&mut ap);
        let pap: f64 = pdir.iter().zip(&ap).map(|(a, b)| a * b).sum();
        if pap.is_nan() || pap <= 0.0 {
            break;
        }
        let alpha = rz / pap;
        for i in 0..x.len() {
            x[i] += alpha * pdir[i];
            r[i] -= alpha * ap[i];
        }
        pre(&r, &mut z);
        let rz2: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
        let beta = rz2 / rz;
        rz = rz2;
        for i in 0..x.len() {
            pdir[i] = z[i] + beta * pdir[i];
        }
    }
    if x.iter().any(|v| !v.is_finite()) {
        // Not expected (non-finite samples weigh nothing): keep the start.
        return (start.to_vec(), fixed);
    }
    (x, fixed)
}

/// Per vertex, the first vertex at the same point (`weld`) with the same value
/// (`d` floats of `x`) of the stream and the same `side` (none when empty): one
/// unknown of the solve.
fn same_value_groups(weld: &Weld, x: &[f64], d: usize, side: &[u32]) -> Vec<u32> {
    let mut first = crate::io::obj::FastMap::default();
    first.reserve(weld.point_of.len());
    let mut bits = [0u64; 4];
    (0..weld.point_of.len())
        .map(|v| {
            for (b, &c) in bits.iter_mut().zip(&x[v * d..(v + 1) * d]) {
                *b = (c + 0.0).to_bits();
            }
            let s = side.get(v).copied().unwrap_or(0);
            *first.entry((weld.point_of[v], bits, s)).or_insert(v as u32)
        })
        .collect()
}

fn store(m: &mut Mesh, k: usize, x: &[f64], fixed: &[bool], changed: &mut [bool]) {
    let a = &mut m.attributes;
    match k {
        0 => {
            for (v, n) in a.normals.as_mut().unwrap().iter_mut().enumerate() {
                if fixed[v] {
                    continue;
                }
                let y = [x[v * 3], x[v * 3 + 1], x[v * 3 + 2]];
                let l = dot(y, y).sqrt();
                if l > 1e-12 {
                    let new = y.map(|e| (e / l) as f32);
                    changed[v] |= new != *n;
                    *n = new;
                }
            }
        }
        1 | 2 => {
            let s = if k == 1 {
                a.uv0.as_mut()
            } else {
                a.uv1.as_mut()
            };
            for (v, u) in s.unwrap().iter_mut().enumerate() {
                if fixed[v] {
                    continue;
                }
                let new = [x[v * 2] as f32, x[v * 2 + 1] as f32];
                changed[v] |= new != *u;
                *u = new;
            }
        }
        _ => {
            for (v, c) in a.colors.as_mut().unwrap().iter_mut().enumerate() {
                if fixed[v] {
                    continue;
                }
                let new = [0, 1, 2, 3].map(|j| x[v * 4 + j].clamp(0.0, 1.0) as f32);
                changed[v] |= new != *c;
                *c = new;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;
    use crate::simplify::{simplify, SimplifyOptions};

    /// The UV map of the chart of a point at `x` (two charts, seam at `x = ½`):
    ///
    /// ```text
    ///  y=1 +--------+--------+
    ///      | chart 0| chart 1|   chart 0: uv = (x, y)
    ///      |        |        |   chart 1: uv = (x + 5, 2y), far away in the texture
    ///  y=0 +--------+--------+
    ///     x=0      x=½      x=1
    /// ```
    fn chart_uv(chart: usize, p: [f32; 3]) -> [f32; 2] {
        if chart == 0 {
            [p[0], p[1]]
        } else {
            [p[0] + 5.0, 2.0 * p[1]]
        }
    }

    /// A flat 16 × 16-cell grid with the two charts above (one wedge per grid
    /// point and chart).
    fn two_charts() -> Mesh {
        let g = generate::grid(16, 16, |_, _| 0.0);
        let mut positions = Vec::new();
        let mut uv = Vec::new();
        let mut wedge = std::collections::HashMap::new();
        let triangles = g
            .triangles
            .iter()
            .map(|t| {
                let cx: f32 = t.iter().map(|&v| g.positions[v as usize][0]).sum::<f32>() / 3.0;
                let chart = usize::from(cx > 0.5);
                t.map(|v| {
                    *wedge.entry((v, chart)).or_insert_with(|| {
                        let p = g.positions[v as usize];
                        positions.push(p);
                        uv.push(chart_uv(chart, p));
                        (positions.len() - 1) as u32
                    })
                })
            })
            .collect();
        let mut m = Mesh::from_triangles(positions, triangles);
        m.attributes.uv0 = Some(uv);
        m
    }

    fn chart_of(uv: [f32; 2]) -> usize {
        usize::from(uv[0] > 2.5)
    }

    /// Perturbed UVs of a simplified two-chart plane come back to the linear maps
    /// (the least-squares fit of a linear field is exact), each on its own chart:
    /// samples across the seam never pull a wedge toward the other chart; a locked
    /// vertex keeps its perturbed value.
    #[test]
    fn perturbed_uvs_return_to_their_charts() {
        let input = two_charts();
        let o = SimplifyOptions::default()
            .with_ratio(0.2)
            .with_refit_attributes(false);
        let (mut out, _) = simplify(&input, &o).expect("valid");
        assert!(out.triangles.len() < input.triangles.len() / 3);
        let uv = out.attributes.uv0.as_mut().expect("uv kept");
        for (i, t) in uv.iter_mut().enumerate() {
            let s = if i % 2 == 0 { 0.01 } else { -0.02 };
            t[0] += s;
            t[1] -= 0.5 * s;
        }
        let perturbed = uv.clone();
        let mut locked = vec![false; out.positions.len()];
        locked[0] = true;
        let (changed, _) = refit_attributes(&input, &mut out, &locked);
        assert!(changed > out.positions.len() / 2, "{changed} changed");
        let uv = out.attributes.uv0.as_ref().expect("uv kept");
        assert_eq!(uv[0], perturbed[0], "a locked vertex keeps its value");
        let mut worst = 0.0f32;
        for (v, t) in uv.iter().enumerate().skip(1) {
            let want = chart_uv(chart_of(*t), out.positions[v]);
            worst = worst.max((t[0] - want[0]).abs().max((t[1] - want[1]).abs()));
        }
        // The locked vertex's error spreads a little into its neighbours through
        // their shared triangles; every wedge stays on its own chart.
        assert!(worst < 0.02, "worst UV error {worst}");
        let far: Vec<usize> = (1..uv.len())
            .filter(|&v| {
                let p = out.positions[v];
                let q = out.positions[0];
                (p[0] - q[0]).hypot(p[1] - q[1]) > 0.3
            })
            .collect();
        assert!(!far.is_empty());
        // Perturbed by 0.011 or 0.022 (mean 0.0168); the fit holds each vertex
        // toward its value (the prior) by a tenth of a uniform sampling's weight,
        // which keeps more of it where few samples reach (a border, a corner: a
        // quarter of it on average on this small mesh, most of whose vertices are
        // on its border or the seam).
        let mut sum = 0.0;
        for &v in &far {
            let want = chart_uv(chart_of(uv[v]), out.positions[v]);
            sum += (uv[v][0] - want[0]).hypot(uv[v][1] - want[1]);
        }
        let mean = sum / far.len() as f32;
        assert!(mean < 0.3 * 0.0168, "mean UV error {mean}");
    }

    /// Normals turned at random on a simplified sphere come back toward the
    /// sphere's: the mean angle to the true normal falls to under a third.
    #[test]
    fn turned_normals_come_back() {
        let mut input = generate::icosphere(4);
        input.attributes.normals = Some(
            input
                .positions
                .iter()
                .map(|p| {
                    let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    [p[0] / l, p[1] / l, p[2] / l]
                })
                .collect(),
        );
        let o = SimplifyOptions::default()
            .with_ratio(0.1)
            .with_refit_attributes(false);
        let (mut out, _) = simplify(&input, &o).expect("valid");
        let angle = |m: &Mesh| {
            let n = m.attributes.normals.as_ref().expect("normals kept");
            n.iter()
                .zip(&m.positions)
                .map(|(a, p)| {
                    let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    let c = (a[0] * p[0] + a[1] * p[1] + a[2] * p[2]) / l;
                    f64::from(c.clamp(-1.0, 1.0)).acos().to_degrees()
                })
                .sum::<f64>()
                / n.len() as f64
        };
        let mut seed = 12345u32;
        for n in out.attributes.normals.as_mut().expect("normals kept") {
            for c in n.iter_mut() {
                seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                *c += (f64::from(seed >> 8) / f64::from(1u32 << 24) - 0.5) as f32 * 0.6;
            }
        }
        let before = angle(&out);
        assert!(before > 5.0, "perturbation {before}°");
        let (_, copies) = refit_attributes(&input, &mut out, &[]);
        assert!(copies.is_empty(), "a smooth input is never split");
        let after = angle(&out);
        assert!(after < before / 3.0, "{before}° -> {after}°");
    }

    /// A UV seam stays a UV seam only: wedges of a seam point that share one normal
    /// before the refit share one after it (one unknown), though each side's
    /// samples differ. The output here is the input itself with its normals turned
    /// by a smooth field (the same at both wedges of a seam point).
    #[test]
    fn a_uv_seam_does_not_become_a_crease() {
        let mut input = two_charts();
        let normal = |p: [f32; 3], s: f32| {
            let (x, y) = (s * (p[0] - 0.5), s * (p[1] - 0.5));
            let l = (x * x + y * y + 1.0).sqrt();
            [x / l, y / l, 1.0 / l]
        };
        input.attributes.normals = Some(input.positions.iter().map(|&p| normal(p, 1.0)).collect());
        let mut out = input.clone();
        out.attributes.normals = Some(out.positions.iter().map(|&p| normal(p, 3.0)).collect());
        let mut seam = Vec::new();
        for a in 0..out.positions.len() {
            for b in a + 1..out.positions.len() {
                if out.positions[a] == out.positions[b] {
                    seam.push((a, b));
                }
            }
        }
        assert!(seam.len() >= 10, "{} seam points", seam.len());
        assert!(refit_attributes(&input, &mut out, &[]).0 > 0);
        let n = out.attributes.normals.as_ref().expect("normals kept");
        let uv = out.attributes.uv0.as_ref().expect("uv kept");
        for &(a, b) in &seam {
            assert_ne!(uv[a], uv[b], "wedges {a}, {b} differ in UV");
            assert_eq!(n[a], n[b], "wedges {a}, {b} at a seam point");
        }
        // And the normals came back toward the input's.
        let input_n = input.attributes.normals.as_ref().expect("normals");
        let err = |m: &[[f32; 3]]| {
            m.iter()
                .zip(input_n)
                .map(|(a, b)| (0..3).map(|j| (a[j] - b[j]).powi(2)).sum::<f32>().sqrt())
                .sum::<f32>()
        };
        let turned: Vec<[f32; 3]> = out.positions.iter().map(|&p| normal(p, 3.0)).collect();
        assert!(
            err(n) < 0.2 * err(&turned),
            "{} against {}",
            err(n),
            err(&turned)
        );
    }

    /// The coarse roof of the crease tests: points 0–2 along `y = 0`, 3–5 along
    /// `y = 1`, at `x = 0, 1, 2`, on `z = -|x - 1|`.
    const COARSE_ROOF: [[f32; 3]; 6] = [
        [0.0, 0.0, -1.0],
        [1.0, 0.0, 0.0],
        [2.0, 0.0, -1.0],
        [0.0, 1.0, -1.0],
        [1.0, 1.0, 0.0],
        [2.0, 1.0, -1.0],
    ];

    /// A roof: two planes meeting at a ridge (`x = 1`) at a right angle, the input
    /// finely meshed with a hard crease (each side its own normal, two wedges per
    /// ridge point); the output is the coarse roof whose ridge points have one
    /// normal each, as after a collapse crossed the crease:
    ///
    /// ```text
    ///  y=1  3-------4-------5      z = -|x - 1|
    ///       | \  left | \ right|     left normal  (-1, 0, 1)/√2
    ///       |   \     |   \    |     right normal ( 1, 0, 1)/√2
    ///  y=0  0-------1-------2
    ///      x=0     x=1     x=2
    /// ```
    ///
    /// The refit splits each ridge point into two wedges, and each side's normals
    /// come back to within 5° of its plane's (one normal shared by both sides is at
    /// least 45° from one of them).
    #[test]
    fn a_crossed_crease_is_split_again() {
        let n = 8;
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut triangles = Vec::new();
        for (x0, nx) in [(0.0f32, -1.0f32), (1.0, 1.0)] {
            let base = positions.len() as u32;
            for j in 0..=n {
                for i in 0..=n {
                    let x = x0 + i as f32 / n as f32;
                    let y = j as f32 / n as f32;
                    positions.push([x, y, -(x - 1.0).abs()]);
                    normals.push([
                        nx * std::f32::consts::FRAC_1_SQRT_2,
                        0.0,
                        std::f32::consts::FRAC_1_SQRT_2,
                    ]);
                }
            }
            let at = |i: u32, j: u32| base + j * (n + 1) + i;
            for j in 0..n {
                for i in 0..n {
                    triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                    triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
        let mut input = Mesh::from_triangles(positions, triangles);
        input.attributes.normals = Some(normals);
        let mut out = Mesh::from_triangles(
            COARSE_ROOF.to_vec(),
            vec![[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]],
        );
        out.attributes.normals = Some(vec![[0.0, 0.0, 1.0]; 6]);
        let (_, copies) = refit_attributes(&input, &mut out, &[]);
        let mut copied = copies.clone();
        copied.sort_unstable();
        assert_eq!(copied, vec![1, 4], "the ridge points are split");
        assert_eq!(out.positions.len(), 8);
        out.validate().expect("valid");
        let nrm = out.attributes.normals.as_ref().expect("normals kept");
        for (t, tri) in out.triangles.iter().enumerate() {
            let side = if t < 2 { -1.0 } else { 1.0 };
            for &v in tri {
                let m = nrm[v as usize];
                let c = (side * m[0] + m[2]) * std::f32::consts::FRAC_1_SQRT_2;
                let deg = f64::from(c.clamp(-1.0, 1.0)).acos().to_degrees();
                assert!(deg < 5.0, "triangle {t}, vertex {v}: {deg}° from its plane");
            }
        }
        // Locked ridge points stay one wedge.
        let mut out2 = out.clone();
        out2.triangles = vec![[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]];
        out2.positions.truncate(6);
        out2.attributes = out2.attributes.gather(&[0, 1, 2, 3, 4, 5]);
        let (_, copies) =
            refit_attributes(&input, &mut out2, &[false, true, false, false, true, false]);
        assert!(copies.is_empty());
    }

    /// The crease split is local: a roof of two planes (`z = -|x - 1|`) shaded
    /// smooth (the normal turns steadily from one plane's to the other's over
    /// `0.5 ≤ x ≤ 1.5`) between two walls rising along its edges `y = 0` and
    /// `y = 1` (hard creases of about 90° all along them). In the output every point
    /// has one normal:
    ///
    /// ```text
    ///            wall: 6 --- 7 --- 8   (above 3, 4, 5)
    ///  y=1  3-------4-------5
    ///       |  roof |  roof |         bend 1-4 (smooth in the input)
    ///  y=0  0-------1-------2
    ///            wall: 9 --- 10 -- 11  (above 0, 1, 2)
    /// ```
    ///
    /// The walls' feet, 0 to 5, get a wedge for the roof and one for the wall; the
    /// roof's two sides stay one wedge at 1 and 4: the bend runs from crease to
    /// crease and the two sides' mean normals are about 60° apart, but near the bend
    /// the input's normals agree on both sides (within about 26°).
    #[test]
    fn the_crease_split_is_local() {
        let n = 8u32;
        let roof = |x: f32| -(x - 1.0).abs();
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut triangles = Vec::new();
        // Orients triangle `t` so that it faces along `d`.
        let facing = |pos: &[[f32; 3]], t: [u32; 3], d: [f32; 3]| {
            let [a, b, c] = t.map(|v| f64v(pos[v as usize]));
            let f = cross(sub(b, a), sub(c, a));
            if dot(f, d.map(f64::from)) >= 0.0 {
                t
            } else {
                [t[0], t[2], t[1]]
            }
        };
        let row = 2 * n + 1;
        let grid = |positions: &mut Vec<[f32; 3]>,
                    normals: &mut Vec<[f32; 3]>,
                    triangles: &mut Vec<[u32; 3]>,
                    at: &dyn Fn(f32, f32) -> ([f32; 3], [f32; 3])| {
            let base = positions.len() as u32;
            for j in 0..=n {
                for i in 0..row {
                    let (p, nrm) = at(i as f32 / n as f32, j as f32 / n as f32);
                    positions.push(p);
                    normals.push(nrm);
                }
            }
            for j in 0..n {
                for i in 0..row - 1 {
                    let id = |i: u32, j: u32| base + j * row + i;
                    let d = normals[id(i, j) as usize];
                    for t in [
                        [id(i, j), id(i + 1, j), id(i + 1, j + 1)],
                        [id(i, j), id(i + 1, j + 1), id(i, j + 1)],
                    ] {
                        triangles.push(facing(positions, t, d));
                    }
                }
            }
        };
        let unit = |v: [f32; 3]| {
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|c| c / l)
        };
        grid(&mut positions, &mut normals, &mut triangles, &|x, y| {
            let turn = (2.0 * (x - 1.0)).clamp(-1.0, 1.0);
            ([x, y, roof(x)], unit([turn, 0.0, 1.0]))
        });
        for (y, ny) in [(1.0f32, 1.0f32), (0.0, -1.0)] {
            grid(&mut positions, &mut normals, &mut triangles, &|x, h| {
                ([x, y, roof(x) + h], [0.0, ny, 0.0])
            });
        }
        let mut input = Mesh::from_triangles(positions, triangles);
        input.attributes.normals = Some(normals);
        let mut pos = COARSE_ROOF.to_vec();
        pos.extend([
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 1.0],
            [2.0, 1.0, 0.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 1.0],
            [2.0, 0.0, 0.0],
        ]);
        let (up, back, front) = ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]);
        let tris = vec![
            facing(&pos, [0, 1, 4], up),
            facing(&pos, [0, 4, 3], up),
            facing(&pos, [1, 2, 5], up),
            facing(&pos, [1, 5, 4], up),
            facing(&pos, [3, 4, 7], back),
            facing(&pos, [3, 7, 6], back),
            facing(&pos, [4, 5, 8], back),
            facing(&pos, [4, 8, 7], back),
            facing(&pos, [0, 1, 10], front),
            facing(&pos, [0, 10, 9], front),
            facing(&pos, [1, 2, 11], front),
            facing(&pos, [1, 11, 10], front),
        ];
        let mut out = Mesh::from_triangles(pos, tris);
        out.attributes.normals = Some(vec![[0.0, 0.0, 1.0]; 12]);
        let (_, copies) = refit_attributes(&input, &mut out, &[]);
        let mut copied = copies.clone();
        copied.sort_unstable();
        assert_eq!(copied, vec![0, 1, 2, 3, 4, 5], "the walls' feet only");
        out.validate().expect("valid");
        // At 1 and 4 the roof's corners share one wedge.
        for p in [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]] {
            let roof_at: Vec<u32> = out.triangles[..4]
                .iter()
                .flat_map(|t| t.iter().copied())
                .filter(|&v| out.positions[v as usize] == p)
                .collect();
            assert_eq!(roof_at.len(), 3);
            assert!(
                roof_at.windows(2).all(|w| w[0] == w[1]),
                "{p:?}: {roof_at:?}"
            );
        }
    }

    /// Nothing to fit: no attributes, or an empty output.
    #[test]
    fn nothing_to_fit() {
        let input = generate::icosphere(2);
        let mut out = input.clone();
        assert_eq!(refit_attributes(&input, &mut out, &[]), (0, Vec::new()));
        let mut empty = Mesh::from_triangles(Vec::new(), Vec::new());
        let mut with = two_charts();
        assert_eq!(refit_attributes(&with, &mut empty, &[]), (0, Vec::new()));
        let copy = with.clone();
        // The input fits itself: no value moves by more than rounding.
        refit_attributes(&copy, &mut with, &[]);
        let (a, b) = (copy.attributes.uv0.unwrap(), with.attributes.uv0.unwrap());
        assert!(a
            .iter()
            .zip(&b)
            .all(|(x, y)| (x[0] - y[0]).abs() < 1e-5 && (x[1] - y[1]).abs() < 1e-5));
    }

    /// The subsample: none while the input has at most 32 triangles per
    /// output triangle; otherwise 32 per output triangle by area, forced triangles
    /// with their own area, the weights summing to the free triangles' area, and a
    /// triangle larger than a share always sampled.
    #[test]
    fn subsampled_weights_keep_the_area() {
        // A 40 × 40 grid whose columns widen to the right (x ↦ x³ spacing), so the
        // triangles' areas vary by a factor of hundreds; one big sliver at the end
        // (1/40 of the grid's area).
        let mut m = generate::grid(40, 40, |_, _| 0.0);
        for p in &mut m.positions {
            p[0] = p[0].powi(3);
        }
        let n = m.triangles.len();
        let big = m.positions.len() as u32;
        m.positions
            .extend_from_slice(&[[2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [2.0, 0.05, 0.0]]);
        m.triangles.push([big, big + 1, big + 2]);
        let area = |t: usize| {
            let x = face_normal(&m, t);
            0.5 * dot(x, x).sqrt()
        };
        let spt = SAMPLES_PER_TRIANGLE;
        assert!(sample_weights(&m, (n + 1).div_ceil(spt), spt, |_| false).is_none());
        let out_triangles = 20;
        let forced = |t: usize| t % 97 == 5;
        let w = sample_weights(&m, out_triangles, spt, forced).expect("subsampled");
        assert_eq!(w.len(), n + 1);
        let free: f64 = (0..=n).filter(|&t| !forced(t)).map(area).sum();
        let sum: f64 = w.iter().filter(|&&x| x > 0.0).map(|&x| f64::from(x)).sum();
        assert!((sum - free).abs() <= 1e-5 * free, "{sum} vs {free}");
        for (t, &x) in w.iter().enumerate() {
            assert_eq!(x == OWN, forced(t), "triangle {t}");
        }
        let sampled = w.iter().filter(|&&x| x > 0.0).count();
        let budget = SAMPLES_PER_TRIANGLE * out_triangles;
        // The sliver spans about 15 shares but is one sample (and a jittered draw
        // may fall in the triangle of the one before).
        assert!(
            sampled <= budget && sampled > budget - 40,
            "{sampled} of {budget}"
        );
        assert!(f64::from(w[n]) >= area(n) - free / budget as f64);
    }

    /// A colour field over a fine grid refitted on a coarse output from the
    /// subsample comes out as from every sample, and far closer to the field than
    /// the wrong start.
    #[test]
    fn the_subsample_fits_as_every_sample_does() {
        let field = |p: [f32; 3]| [0.2 + 0.5 * p[0] * p[0], 0.7 - 0.3 * p[1], 0.1, 1.0];
        let mut input = generate::grid(48, 48, |_, _| 0.0);
        input.attributes.colors = Some(input.positions.iter().map(|&p| field(p)).collect());
        let mut start = generate::grid(3, 3, |_, _| 0.0);
        start.attributes.colors = Some(vec![[0.9, 0.1, 0.5, 1.0]; start.positions.len()]);
        assert!(input.triangles.len() > SAMPLES_PER_TRIANGLE * start.triangles.len());
        let fitted = |per_triangle| {
            let mut out = start.clone();
            refit_sampled(&input, &mut out, &[], per_triangle);
            out.attributes.colors.unwrap()
        };
        let (sub, all) = (fitted(SAMPLES_PER_TRIANGLE), fitted(usize::MAX));
        let error = |c: &[[f32; 4]]| -> f32 {
            (start.positions.iter().zip(c))
                .map(|(&p, c)| {
                    (0..4)
                        .map(|j| (c[j] - field(p)[j]).abs())
                        .fold(0.0, f32::max)
                })
                .fold(0.0, f32::max)
        };
        let e0 = error(start.attributes.colors.as_ref().unwrap());
        assert!(error(&all) < 0.2 * e0 && error(&sub) < 0.2 * e0, "{e0}");
        for (a, b) in sub.iter().zip(&all) {
            for j in 0..4 {
                assert!((a[j] - b[j]).abs() < 0.02, "{a:?} vs {b:?}");
            }
        }
    }

    /// A row-ordered grid whose rows span whole shares is not sampled in the same
    /// columns row after row (the draws are jittered within their shares).
    #[test]
    fn draws_do_not_line_up_in_columns() {
        // 64 × 64 quads, 128 triangles per row, all of one area; 128 draws in all:
        // one share per 64 triangles, two per row.
        let m = generate::grid(64, 64, |_, _| 0.0);
        let w = sample_weights(&m, 4, SAMPLES_PER_TRIANGLE, |_| false).expect("subsampled");
        let drawn: Vec<usize> = (0..w.len()).filter(|&t| w[t] > 0.0).collect();
        assert!(drawn.len() >= 127 && drawn.len() <= 128, "{}", drawn.len());
        let mut columns: Vec<usize> = drawn.iter().map(|t| t % 128).collect();
        columns.sort_unstable();
        columns.dedup();
        assert!(columns.len() > 50, "{} distinct columns", columns.len());
    }
}
