//! Flat-shaded input: normals that belong to triangles, not to points.
//!
//! A flat-shaded export (a low-poly game asset, a CAD tessellation written with
//! facet normals, an STL converted to OBJ or glTF) gives every triangle's three
//! corners the triangle's own normal, so a point shared by `k` triangles is `k`
//! vertices that differ only in their normal. To the simplifier those are attribute
//! seams everywhere: a seam edge may only collapse along its seam and a point where
//! seams meet may not move (the rules of [`crate::collapse`]), so nothing can
//! collapse at all — the bunny written flat shaded went from 69,451 triangles to
//! 69,449.
//!
//! Such normals carry nothing the positions do not: they are the output's own
//! triangles' normals once it is simplified. So when *every* triangle of positive
//! area has three equal corner normals (within `10⁻³` per component, after
//! normalising) that lie within 60° of its geometric normal (or all, consistently,
//! of its opposite), [`FlatShading::detect`] reports the mesh flat shaded:
//! [`FlatShading::merged`] is the mesh with the normals dropped and the vertices
//! that then coincide (same position, same other attributes, bit for bit) made one,
//! which the simplifier reduces like any mesh; [`FlatShading::reshade`] gives the
//! result's triangles their own geometric normals again (one vertex per point and
//! normal, so the output stays flat shaded). Borders, UV seams and material borders
//! are kept as usual: only the normals' seams go.
//!
//! A mesh with smooth normals anywhere (one triangle whose corners differ) is left
//! as it is, as is a mesh with tangents (they would need the normals' seams too).
//! `SimplifyOptions::reshade_flat` switches the detection off.

use crate::collapse::canonical_wedges;
use crate::mesh::{Mesh, VertexAttributes, Weld};
use std::collections::HashMap;

/// Largest per-component difference between two corners' unit normals that still
/// counts as the same normal.
const SAME_NORMAL: f32 = 1e-3;
/// Smallest cosine between a triangle's corner normal and its geometric normal
/// (60°): facet normals computed by an exporter agree to rounding; this only rules
/// out normals that are not facet normals at all.
const FACET_COS: f64 = 0.5;

/// A flat-shaded mesh, merged for simplification.
#[derive(Debug, Clone)]
pub(crate) struct FlatShading {
    /// The input without normals, its vertices merged where only normals differed.
    pub merged: Mesh,
    /// For each input vertex, its vertex in [`Self::merged`].
    pub merged_of: Vec<u32>,
    /// For each vertex of [`Self::merged`], the first input vertex merged into it.
    pub source: Vec<u32>,
    /// `1` when the normals follow the triangles' winding (counter-clockwise
    /// front), `-1` when they all point the other way.
    sign: f64,
}

/// The unit vector along `n`, or `None` for a zero or non-finite one.
fn unit(n: [f32; 3]) -> Option<[f32; 3]> {
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    (l.is_finite() && l > 0.0).then(|| n.map(|c| c / l))
}

/// The geometric normal of triangle `t` (not normalised), in `f64`.
fn face_normal(p: &[[f32; 3]], t: [u32; 3]) -> [f64; 3] {
    let [a, b, c] = t.map(|v| p[v as usize].map(f64::from));
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [
        u[1] * w[2] - u[2] * w[1],
        u[2] * w[0] - u[0] * w[2],
        u[0] * w[1] - u[1] * w[0],
    ]
}

impl FlatShading {
    /// Whether `mesh` is flat shaded (see the module docs), and if so its merged
    /// form; `None` when it is not, or when merging would join no vertex.
    #[must_use]
    pub(crate) fn detect(mesh: &Mesh) -> Option<Self> {
        let normals = mesh.attributes.normals.as_ref()?;
        if mesh.attributes.tangents.is_some() || mesh.triangles.is_empty() {
            return None;
        }
        let (mut along, mut against) = (0usize, 0usize);
        for &t in &mesh.triangles {
            let f = face_normal(&mesh.positions, t);
            let fl = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
            if fl.is_nan() || fl <= 0.0 {
                continue; // zero area: no geometric normal to compare with
            }
            let [n0, n1, n2] = t.map(|v| unit(normals[v as usize]));
            let (n0, n1, n2) = (n0?, n1?, n2?);
            let same =
                |a: [f32; 3], b: [f32; 3]| (0..3).all(|k| (a[k] - b[k]).abs() <= SAME_NORMAL);
            if !same(n0, n1) || !same(n0, n2) {
                return None;
            }
            let cos = (0..3).map(|k| f[k] * f64::from(n0[k])).sum::<f64>() / fl;
            if cos >= FACET_COS {
                along += 1;
            } else if cos <= -FACET_COS {
                against += 1;
            } else {
                return None;
            }
        }
        if along > 0 && against > 0 || along + against == 0 {
            return None;
        }
        let sign = if along > 0 { 1.0 } else { -1.0 };
        let weld = Weld::exact(&mesh.positions);
        let canonical = canonical_wedges(mesh, &weld, false);
        let mut merged_of = vec![u32::MAX; canonical.len()];
        let mut source = Vec::new();
        for (v, &c) in canonical.iter().enumerate() {
            if c as usize == v {
                merged_of[v] = source.len() as u32;
                source.push(v as u32);
            }
        }
        if source.len() == canonical.len() {
            return None; // no vertex to merge: nothing is in the way
        }
        for (v, &c) in canonical.iter().enumerate() {
            merged_of[v] = merged_of[c as usize];
        }
        let merged = Mesh {
            positions: source.iter().map(|&v| mesh.positions[v as usize]).collect(),
            triangles: mesh
                .triangles
                .iter()
                .map(|t| t.map(|v| merged_of[v as usize]))
                .collect(),
            attributes: VertexAttributes {
                normals: None,
                ..mesh.attributes.gather(&source)
            },
            groups: mesh.groups.clone(),
            group_names: mesh.group_names.clone(),
        };
        Some(Self {
            merged,
            merged_of,
            source,
            sign,
        })
    }

    /// The input's vertex lock mask carried to [`Self::merged`]: a merged vertex is
    /// locked when any input vertex merged into it is.
    #[must_use]
    pub(crate) fn merged_mask(&self, locked: &[bool]) -> Vec<bool> {
        let mut m = vec![false; self.source.len()];
        for (v, &l) in locked.iter().enumerate() {
            if l {
                if let Some(slot) = self.merged_of.get(v).and_then(|&o| m.get_mut(o as usize)) {
                    *slot = true;
                }
            }
        }
        m
    }

    /// Gives the simplified `out` (over [`Self::merged`], with `vertex_source` into
    /// it) flat normals again: each triangle's vertices become, per point, one
    /// vertex per distinct normal, the triangle's geometric normal (an input
    /// normal of the vertex's source where the area is zero). `vertex_source` comes
    /// back in terms of the input's vertices (empty if it came empty).
    #[must_use]
    pub(crate) fn reshade(
        &self,
        input: &Mesh,
        out: Mesh,
        vertex_source: &[u32],
    ) -> (Mesh, Vec<u32>) {
        let input_normals = input.attributes.normals.as_deref().unwrap_or(&[]);
        let source_of = |v: u32| -> u32 {
            vertex_source
                .get(v as usize)
                .and_then(|&m| self.source.get(m as usize))
                .copied()
                .unwrap_or(u32::MAX)
        };
        let mut index: HashMap<(u32, [u32; 3]), u32> = HashMap::new();
        let mut from = Vec::new();
        let mut normals = Vec::new();
        let mut triangles = Vec::with_capacity(out.triangles.len());
        for &t in &out.triangles {
            let f = face_normal(&out.positions, t);
            let fl = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
            let n: [f32; 3] = if fl.is_finite() && fl > 0.0 {
                f.map(|c| (self.sign * c / fl) as f32)
            } else {
                input_normals
                    .get(source_of(t[0]) as usize)
                    .and_then(|&n| unit(n))
                    .unwrap_or([0.0, 0.0, 1.0])
            };
            let key = n.map(|c| (c + 0.0).to_bits());
            triangles.push(t.map(|v| {
                *index.entry((v, key)).or_insert_with(|| {
                    from.push(v);
                    normals.push(n);
                    (from.len() - 1) as u32
                })
            }));
        }
        let mut attributes = out.attributes.gather(&from);
        attributes.normals = Some(normals);
        let mesh = Mesh {
            positions: from.iter().map(|&v| out.positions[v as usize]).collect(),
            triangles,
            attributes,
            groups: out.groups,
            group_names: out.group_names,
        };
        // No provenance in (clustering without attributes to carry): none out.
        let source = if vertex_source.is_empty() {
            Vec::new()
        } else {
            from.iter().map(|&v| source_of(v)).collect()
        };
        (mesh, source)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    /// `mesh` with every triangle's corners split off and given its facet normal
    /// (times `sign`): what a flat-shaded exporter writes.
    fn flat(mesh: &Mesh, sign: f32) -> Mesh {
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut triangles = Vec::new();
        for &t in &mesh.triangles {
            let f = face_normal(&mesh.positions, t);
            let n = unit(f.map(|c| c as f32)).unwrap().map(|c| sign * c);
            let base = positions.len() as u32;
            for v in t {
                positions.push(mesh.positions[v as usize]);
                normals.push(n);
            }
            triangles.push([base, base + 1, base + 2]);
        }
        let mut m = Mesh::from_triangles(positions, triangles);
        m.attributes.normals = Some(normals);
        m
    }

    #[test]
    fn facet_normals_are_detected_and_merged() {
        let sphere = generate::icosphere(2);
        let f = FlatShading::detect(&flat(&sphere, 1.0)).expect("flat shaded");
        assert_eq!(f.merged.positions.len(), sphere.positions.len());
        assert!(f.merged.attributes.normals.is_none());
        assert_eq!(f.merged.triangles.len(), sphere.triangles.len());
        // Normals against the winding: still flat, with the sign kept.
        let g = FlatShading::detect(&flat(&sphere, -1.0)).expect("flat shaded");
        assert!(g.sign < 0.0);
    }

    #[test]
    fn smooth_normals_or_mixed_signs_are_left_alone() {
        // Smooth: the sphere's vertex normals (its positions), shared by corners.
        let mut smooth = generate::icosphere(2);
        smooth.attributes.normals = Some(smooth.positions.clone());
        assert!(FlatShading::detect(&smooth).is_none());
        // One triangle with a corner normal off its facet: not flat shaded.
        let mut f = flat(&generate::icosphere(1), 1.0);
        let n = f.attributes.normals.as_mut().unwrap();
        n[4] = [n[4][0] + 0.1, n[4][1], n[4][2]];
        assert!(FlatShading::detect(&f).is_none());
        // Half the triangles' normals flipped: no consistent convention.
        let mut f = flat(&generate::icosphere(1), 1.0);
        let n = f.attributes.normals.as_mut().unwrap();
        for c in n.iter_mut().take(30) {
            *c = c.map(|x| -x);
        }
        assert!(FlatShading::detect(&f).is_none());
    }

    #[test]
    fn reshaded_output_has_facet_normals_per_triangle() {
        // The merged sphere stands in for a simplified output: every output
        // triangle's three vertices must carry its facet normal.
        let f = FlatShading::detect(&flat(&generate::icosphere(2), 1.0)).unwrap();
        let input = flat(&generate::icosphere(2), 1.0);
        let ids: Vec<u32> = (0..f.merged.positions.len() as u32).collect();
        let (out, source) = f.reshade(&input, f.merged.clone(), &ids);
        let n = out.attributes.normals.as_ref().unwrap();
        for &t in &out.triangles {
            let g = unit(face_normal(&out.positions, t).map(|c| c as f32)).unwrap();
            for v in t {
                for k in 0..3 {
                    assert!((n[v as usize][k] - g[k]).abs() < 1e-5);
                }
            }
        }
        // Each vertex descends from an input vertex at its position.
        for (v, &s) in source.iter().enumerate() {
            assert_eq!(out.positions[v], input.positions[s as usize]);
        }
        // One vertex per corner here (no two faces of an icosphere are coplanar).
        assert_eq!(out.positions.len(), 3 * out.triangles.len());
    }
}
