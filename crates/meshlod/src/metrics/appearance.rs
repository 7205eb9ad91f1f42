//! Appearance deviation between two attributed surfaces: texture coordinates, normals
//! and colours compared at corresponding points.
//!
//! The correspondence is the one of the geometric measure (Metro: Cignoni, Rocchini &
//! Scopigno, "Metro: measuring error on simplified surfaces", 1998): each sample of
//! mesh A is paired with its closest point on mesh B. The comparison of the attribute
//! values there follows the attribute deviation of Cohen, Olano & Manocha, "Appearance-
//! preserving simplification" (SIGGRAPH 1998) and of Garland & Heckbert's and Hoppe's
//! appearance quadrics: on each side the attribute is interpolated barycentrically in
//! the triangle that holds the point, and the two values are compared:
//!
//! - **UV** (`TEXCOORD_0` / `vt`): Euclidean distance `|Δuv|` in texture units (1 = the
//!   texture's width), compared only between triangles of the same material (matched
//!   by name) — a texture coordinate means nothing in another material's texture;
//! - **normal**: the angle in degrees between the interpolated normals, each
//!   normalised (corner normals are normalised before interpolation; a zero normal,
//!   as a glTF part without normals gets when parts are merged, is skipped);
//! - **colour**: Euclidean distance of linear RGBA in `[0, 1]` (at most 2).
//!
//! **Seams.** A point on an attribute seam has several values, one per side (the
//! wedges that share the position). The deviation there is the smallest over the
//! pairs of sides: on A, a vertex sample takes every wedge of its position (a face
//! sample lies inside one triangle and has one value); on B, when the closest point
//! lies on an edge or a corner of its triangle (or within a millionth of a
//! barycentric coordinate of one), every triangle of B whose distance to the sample
//! is within `1e-6 ×` B's bounding-box diagonal of the closest is a candidate, each
//! with its own closest point and values. Identical meshes therefore measure zero,
//! seams included.
//!
//! **Samples.** Every distinct vertex position of A (with all its wedges) and `N`
//! points on its faces by area (`N` as [`SamplingOptions::samples_for`]: the same
//! stratified face samples, same seed and generator, as the geometric measure; no
//! edge samples). Each direction is sampled and reported; the symmetric summary is the
//! larger maximum and the larger mean of the two. The work is split into chunks run in
//! parallel and merged in order, so the numbers do not depend on the thread count.
//! Cost: one closest-point query per sample, as the face and vertex part of the
//! geometric measure (0.7–3.2× its time on the glTF sample assets), plus a box query
//! at edges and corners and a second closest-point query, restricted to the sample's
//! material, where the closest triangle belongs to another material.

use super::bvh::Bvh;
use super::triangle::{barycentric, closest_point, dist2, Region, V3};
use super::{allot, Pcg, SamplingOptions};
use crate::mesh::{Mesh, Weld};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;

/// Largest and mean deviation of one attribute over the samples of one direction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Deviation {
    /// Largest deviation (UV: texture units; normal: degrees; colour: RGBA distance).
    pub max: f64,
    /// Mean deviation over the samples that compared this attribute.
    pub mean: f64,
    /// Number of samples that compared this attribute.
    pub samples: u64,
    /// Where the largest deviation occurs (a sample of the measured mesh, mesh units).
    pub max_at: [f64; 3],
}

/// One direction: samples of one mesh against the other. An attribute is `None` when
/// either mesh lacks it (or no sample could compare it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AppearanceOneSided {
    /// `|Δuv|` of the first texture coordinate set, within the same material.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uv: Option<Deviation>,
    /// Angle between normals, in degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub normal_deg: Option<Deviation>,
    /// Euclidean distance of linear RGBA colours in `[0, 1]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub color: Option<Deviation>,
    /// Samples taken.
    pub samples: u64,
    /// Samples whose material does not occur on the other mesh (no UV compared).
    pub uv_unmatched: u64,
}

/// The symmetric summary of one attribute: the larger of the two directions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    /// Larger of the two one-sided maxima.
    pub max: f64,
    /// Larger of the two one-sided means.
    pub mean: f64,
}

/// Attribute deviation in both directions and the symmetric summary.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Appearance {
    /// UV distance (texture units).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uv: Option<Summary>,
    /// Normal angle (degrees).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub normal_deg: Option<Summary>,
    /// Colour distance (linear RGBA in `[0, 1]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub color: Option<Summary>,
    /// Samples of A against B.
    pub a_to_b: AppearanceOneSided,
    /// Samples of B against A.
    pub b_to_a: AppearanceOneSided,
}

/// Which attributes both meshes carry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Common {
    uv: bool,
    normal: bool,
    color: bool,
}

impl Common {
    fn of(a: &Mesh, b: &Mesh) -> Self {
        let (x, y) = (&a.attributes, &b.attributes);
        Self {
            uv: x.uv0.is_some() && y.uv0.is_some(),
            normal: x.normals.is_some() && y.normals.is_some(),
            color: x.colors.is_some() && y.colors.is_some(),
        }
    }
    fn any(self) -> bool {
        self.uv || self.normal || self.color
    }
}

/// Attribute deviation between `a` and `b`, both directions sampled with `options`
/// (its `edges` flag is ignored: vertices and faces are sampled). `None` when the two
/// meshes have no attribute in common (UV set 0, normals, colours) or either has no
/// triangle.
///
/// UVs are compared within the same material when both meshes have groups: groups
/// are matched by name ([`Mesh::group_names`]; an unnamed group by its id).
///
/// # Panics
/// Panics if a mesh is invalid (see [`Mesh::validate`]).
#[must_use]
pub fn appearance(a: &Mesh, b: &Mesh, options: &SamplingOptions) -> Option<Appearance> {
    let common = Common::of(a, b);
    if !common.any() || a.triangles.is_empty() || b.triangles.is_empty() {
        return None;
    }
    let (ma, mb) = material_keys(a, b);
    let ta = Target::new(a, ma, common);
    let tb = Target::new(b, mb, common);
    let a_to_b = one_sided(&ta, &tb, options);
    let b_to_a = one_sided(&tb, &ta, options);
    let sym = |x: Option<Deviation>, y: Option<Deviation>| match (x, y) {
        (None, None) => None,
        (x, y) => {
            let (x, y) = (
                x.map_or((0.0, 0.0), |d| (d.max, d.mean)),
                y.map_or((0.0, 0.0), |d| (d.max, d.mean)),
            );
            Some(Summary {
                max: x.0.max(y.0),
                mean: x.1.max(y.1),
            })
        }
    };
    Some(Appearance {
        uv: sym(a_to_b.uv, b_to_a.uv),
        normal_deg: sym(a_to_b.normal_deg, b_to_a.normal_deg),
        color: sym(a_to_b.color, b_to_a.color),
        a_to_b,
        b_to_a,
    })
}

/// Per-triangle material keys in one namespace for both meshes. When either mesh has
/// no groups, every triangle gets key 0 (one material).
fn material_keys(a: &Mesh, b: &Mesh) -> (Vec<u32>, Vec<u32>) {
    let (Some(ga), Some(gb)) = (&a.groups, &b.groups) else {
        return (vec![0; a.triangles.len()], vec![0; b.triangles.len()]);
    };
    let mut ids: HashMap<String, u32> = HashMap::new();
    let mut key = |m: &Mesh, g: u32| -> u32 {
        let name = match m.group_names.get(g as usize) {
            Some(n) if !n.is_empty() => n.clone(),
            _ => format!("\u{0}group {g}"),
        };
        let next = ids.len() as u32;
        *ids.entry(name).or_insert(next)
    };
    let ka: Vec<u32> = ga.iter().map(|&g| key(a, g)).collect();
    let kb: Vec<u32> = gb.iter().map(|&g| key(b, g)).collect();
    (ka, kb)
}

/// A mesh prepared for queries: its BVH, per-triangle material keys and, for UVs,
/// one BVH per material (when there are several).
struct Target<'a> {
    mesh: &'a Mesh,
    bvh: Bvh,
    material: Vec<u32>,
    /// Per material key: the BVH over its triangles and their mesh ids.
    by_material: HashMap<u32, (Bvh, Vec<u32>)>,
    common: Common,
    /// Distance slack for seam candidates (mesh units).
    tol: f64,
}

impl<'a> Target<'a> {
    fn new(mesh: &'a Mesh, material: Vec<u32>, common: Common) -> Self {
        let bvh = Bvh::build(&mesh.positions, &mesh.triangles);
        let mut by_material = HashMap::new();
        let several = material.iter().any(|&m| m != material[0]);
        if common.uv && several {
            let mut lists: HashMap<u32, Vec<u32>> = HashMap::new();
            for (t, &m) in material.iter().enumerate() {
                lists.entry(m).or_default().push(t as u32);
            }
            for (m, ids) in lists {
                let tris: Vec<[u32; 3]> = ids.iter().map(|&t| mesh.triangles[t as usize]).collect();
                by_material.insert(m, (Bvh::build(&mesh.positions, &tris), ids));
            }
        }
        let tol = mesh
            .bounding_box(true)
            .map_or(0.0, |(lo, hi)| crate::mesh::box_diagonal(lo, hi))
            * 1e-6;
        Self {
            mesh,
            bvh,
            material,
            by_material,
            common,
            tol,
        }
    }

    fn corner(&self, t: u32, k: usize) -> V3 {
        f64v(self.mesh.positions[self.mesh.triangles[t as usize][k] as usize])
    }

    /// The attribute values of triangle `t` at barycentric weights `w`.
    fn values_at(&self, t: u32, w: [f64; 3]) -> Values {
        let tri = self.mesh.triangles[t as usize];
        let at = &self.mesh.attributes;
        let mut v = Values {
            material: self.material[t as usize],
            ..Values::default()
        };
        if self.common.uv {
            if let Some(uv) = &at.uv0 {
                for k in 0..3 {
                    let c = uv[tri[k] as usize];
                    v.uv[0] += w[k] * f64::from(c[0]);
                    v.uv[1] += w[k] * f64::from(c[1]);
                }
            }
        }
        if self.common.normal {
            if let Some(n) = &at.normals {
                let mut s = [0.0; 3];
                for k in 0..3 {
                    let c = f64v(n[tri[k] as usize]);
                    let len = dot(c, c).sqrt();
                    if len > 0.0 && len.is_finite() {
                        for i in 0..3 {
                            s[i] += w[k] * c[i] / len;
                        }
                    }
                }
                let len = dot(s, s).sqrt();
                if len > 1e-12 && len.is_finite() {
                    v.normal = Some(s.map(|x| x / len));
                }
            }
        }
        if self.common.color {
            if let Some(c) = &at.colors {
                for k in 0..3 {
                    let x = c[tri[k] as usize];
                    for (acc, &y) in v.color.iter_mut().zip(&x) {
                        *acc += w[k] * f64::from(y);
                    }
                }
            }
        }
        v
    }

    /// Pushes onto `out` the values of B's side(s) at the closest point to `p`: the
    /// closest triangle's, and at an edge or corner every triangle (of `bvh`, whose
    /// entries map to mesh triangles through `ids`) within [`Self::tol`] of it.
    /// Returns the closest triangle (mesh numbering), or `None` for an empty tree.
    fn sides(
        &self,
        p: V3,
        bvh: &Bvh,
        ids: Option<&[u32]>,
        hint: Option<u32>,
        out: &mut Vec<Values>,
    ) -> Option<u32> {
        let c = bvh.closest(p, hint)?;
        let mesh_t = |t: u32| ids.map_or(t, |ids| ids[t as usize]);
        let t = mesh_t(c.triangle);
        let (a, b, cc) = (self.corner(t, 0), self.corner(t, 1), self.corner(t, 2));
        let (q, region) = closest_point(p, a, b, cc);
        let w = barycentric(q, a, b, cc);
        out.push(self.values_at(t, w));
        let on_border = region != Region::Face || w.iter().any(|&x| x < 1e-6);
        if on_border {
            let r = dist2(p, q).sqrt() + self.tol;
            let (lo, hi) = (p.map(|x| x - r), p.map(|x| x + r));
            bvh.for_each_in_box(lo, hi, |id, _| {
                let u = mesh_t(id);
                if u != t {
                    let (a, b, cc) = (self.corner(u, 0), self.corner(u, 1), self.corner(u, 2));
                    let (q, _) = closest_point(p, a, b, cc);
                    if dist2(p, q) <= r * r {
                        out.push(self.values_at(u, barycentric(q, a, b, cc)));
                    }
                }
                true
            });
        }
        Some(c.triangle)
    }
}

/// Attribute values at a point of one side (one wedge).
#[derive(Debug, Clone, Copy, Default)]
struct Values {
    material: u32,
    uv: [f64; 2],
    normal: Option<V3>,
    color: [f64; 4],
}

/// Running maximum and sum of one attribute; merged in chunk order.
#[derive(Debug, Clone, Copy)]
struct Acc {
    max: f64,
    max_at: V3,
    sum: f64,
    n: u64,
}

impl Acc {
    const ZERO: Acc = Acc {
        max: -1.0,
        max_at: [0.0; 3],
        sum: 0.0,
        n: 0,
    };
    fn add(&mut self, d: f64, p: V3) {
        if d > self.max {
            self.max = d;
            self.max_at = p;
        }
        self.sum += d;
        self.n += 1;
    }
    fn merge(&mut self, o: &Acc) {
        if o.max > self.max {
            self.max = o.max;
            self.max_at = o.max_at;
        }
        self.sum += o.sum;
        self.n += o.n;
    }
    fn finish(&self) -> Option<Deviation> {
        (self.n > 0).then(|| Deviation {
            max: self.max.max(0.0),
            mean: self.sum / self.n as f64,
            samples: self.n,
            max_at: self.max_at,
        })
    }
}

/// The partial result of one chunk of samples.
#[derive(Debug, Clone, Copy)]
struct Part {
    uv: Acc,
    normal: Acc,
    color: Acc,
    samples: u64,
    uv_unmatched: u64,
}

impl Part {
    const ZERO: Part = Part {
        uv: Acc::ZERO,
        normal: Acc::ZERO,
        color: Acc::ZERO,
        samples: 0,
        uv_unmatched: 0,
    };
    fn merge(&mut self, o: &Part) {
        self.uv.merge(&o.uv);
        self.normal.merge(&o.normal);
        self.color.merge(&o.color);
        self.samples += o.samples;
        self.uv_unmatched += o.uv_unmatched;
    }
}

/// Measures samples against `target`, with scratch space reused across samples.
struct Probe<'t, 'm> {
    target: &'t Target<'m>,
    hint: Option<u32>,
    sides: Vec<Values>,
    part: Part,
}

impl Probe<'_, '_> {
    /// One sample at `p` whose own side(s) are `mine` (several at a seam).
    fn add(&mut self, p: V3, mine: &[Values]) {
        let tg = self.target;
        self.sides.clear();
        let Some(t) = tg.sides(p, &tg.bvh, None, self.hint, &mut self.sides) else {
            return;
        };
        self.hint = Some(t);
        self.part.samples += 1;
        let pairs = || {
            mine.iter()
                .flat_map(|x| self.sides.iter().map(move |y| (x, y)))
        };
        if tg.common.normal {
            let best = pairs()
                .filter_map(|(x, y)| Some(angle_deg(x.normal?, y.normal?)))
                .fold(f64::INFINITY, f64::min);
            if best.is_finite() {
                self.part.normal.add(best, p);
            }
        }
        if tg.common.color {
            let best = pairs()
                .map(|(x, y)| dist(&x.color, &y.color))
                .fold(f64::INFINITY, f64::min);
            self.part.color.add(best, p);
        }
        if tg.common.uv {
            let mut best = pairs()
                .filter(|(x, y)| x.material == y.material)
                .map(|(x, y)| dist(&x.uv, &y.uv))
                .fold(f64::INFINITY, f64::min);
            if !best.is_finite() {
                // The closest triangle is another material's: the closest point of
                // each of this sample's materials instead.
                let mut seen: Vec<u32> = Vec::new();
                for x in mine {
                    if seen.contains(&x.material) {
                        continue;
                    }
                    seen.push(x.material);
                    if let Some((bvh, ids)) = tg.by_material.get(&x.material) {
                        let mut alt = Vec::new();
                        tg.sides(p, bvh, Some(ids), None, &mut alt);
                        for y in &alt {
                            for x2 in mine.iter().filter(|x2| x2.material == y.material) {
                                best = best.min(dist(&x2.uv, &y.uv));
                            }
                        }
                    }
                }
            }
            if best.is_finite() {
                self.part.uv.add(best, p);
            } else {
                self.part.uv_unmatched += 1;
            }
        }
    }
}

const CHUNK: usize = 2048;

/// Samples `from` (vertices with all their wedges, and faces by area) and compares the
/// attributes with `target`'s at the closest points.
fn one_sided(
    from: &Target<'_>,
    target: &Target<'_>,
    options: &SamplingOptions,
) -> AppearanceOneSided {
    let mesh = from.mesh;
    let mut total = Part::ZERO;
    let probe = || Probe {
        target,
        hint: None,
        sides: Vec::new(),
        part: Part::ZERO,
    };

    if options.vertices {
        // Each distinct position with every (vertex, material) wedge around it.
        let weld = Weld::exact(&mesh.positions);
        let np = weld.point_count();
        let (start, corners) = weld.corners_by_point(&mesh.triangles);
        let ids: Vec<u32> = (0..np as u32)
            .filter(|&p| start[p as usize + 1] > start[p as usize])
            .collect();
        let parts: Vec<Part> = ids
            .par_chunks(CHUNK)
            .map(|c| {
                let mut pr = probe();
                let mut mine: Vec<Values> = Vec::new();
                let mut wedges: Vec<(u32, u32)> = Vec::new();
                for &pt in c {
                    mine.clear();
                    wedges.clear();
                    let range = start[pt as usize] as usize..start[pt as usize + 1] as usize;
                    for &(t, k) in &corners[range] {
                        let key = (
                            mesh.triangles[t as usize][k as usize],
                            from.material[t as usize],
                        );
                        if !wedges.contains(&key) {
                            wedges.push(key);
                            let mut w = [0.0; 3];
                            w[k as usize] = 1.0;
                            mine.push(from.values_at(t, w));
                        }
                    }
                    let v = weld.representative[pt as usize];
                    pr.add(f64v(mesh.positions[v as usize]), &mine);
                }
                pr.part
            })
            .collect();
        parts.iter().for_each(|p| total.merge(p));
    }

    let n = options.samples_for(mesh.triangles.len());
    if options.faces && n > 0 {
        let areas: Vec<f64> = (0..mesh.triangles.len() as u32)
            .map(|t| {
                let (a, b, c) = (from.corner(t, 0), from.corner(t, 1), from.corner(t, 2));
                let cr = cross(sub(b, a), sub(c, a));
                0.5 * dot(cr, cr).sqrt()
            })
            .collect();
        let counts = allot(&areas, n);
        let idx: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
        let parts: Vec<Part> = idx
            .par_chunks(CHUNK)
            .map(|ts| {
                let mut pr = probe();
                let mut mine = [Values::default()];
                for &t in ts {
                    let c = counts[t as usize];
                    if c == 0 {
                        continue;
                    }
                    let (a, b, cc) = (from.corner(t, 0), from.corner(t, 1), from.corner(t, 2));
                    let mut rng = Pcg::new(options.seed, u64::from(t));
                    for _ in 0..c {
                        let (mut u, mut v) = (rng.unit(), rng.unit());
                        if u + v > 1.0 {
                            u = 1.0 - u;
                            v = 1.0 - v;
                        }
                        let p =
                            std::array::from_fn(|i| a[i] + (b[i] - a[i]) * u + (cc[i] - a[i]) * v);
                        mine[0] = from.values_at(t, [1.0 - u - v, u, v]);
                        pr.add(p, &mine);
                    }
                }
                pr.part
            })
            .collect();
        parts.iter().for_each(|p| total.merge(p));
    }

    let c = target.common;
    AppearanceOneSided {
        uv: total.uv.finish().filter(|_| c.uv),
        normal_deg: total.normal.finish().filter(|_| c.normal),
        color: total.color.finish().filter(|_| c.color),
        samples: total.samples,
        uv_unmatched: total.uv_unmatched,
    }
}

fn angle_deg(a: V3, b: V3) -> f64 {
    // atan2 of |a × b| and a · b: accurate for small and large angles alike.
    let cr = cross(a, b);
    dot(cr, cr).sqrt().atan2(dot(a, b)).to_degrees()
}

fn dist<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

#[inline]
fn f64v(p: [f32; 3]) -> V3 {
    [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]
}

#[inline]
fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests;
