//! Midpoint (1→4) subdivision: every triangle is split into four by its edge midpoints.
//!
//! Used to make large test and benchmark meshes from real ones (a 69k-triangle bunny
//! becomes 1.1M triangles after two rounds) without changing the surface. Midpoints are
//! shared between the triangles of an edge, keyed by the *wedge* pair, so attribute
//! seams stay seams and the output is as watertight as the input.

use super::{Mesh, VertexAttributes};
use std::collections::HashMap;

impl Mesh {
    /// Splits every triangle into four through its edge midpoints; attributes are
    /// averaged (normals renormalised), groups copied. Output has 4× the triangles.
    ///
    /// # Panics
    /// Panics if the mesh is invalid or the result needs more than 2³² vertices.
    #[must_use]
    pub fn subdivide_midpoint(&self) -> Mesh {
        let mut edge_mid: HashMap<(u32, u32), u32> =
            HashMap::with_capacity(self.triangles.len() * 2);
        let mut src: Vec<(u32, u32)> = (0..self.positions.len() as u32).map(|i| (i, i)).collect();
        let mut mid = |a: u32, b: u32, src: &mut Vec<(u32, u32)>| -> u32 {
            let key = if a < b { (a, b) } else { (b, a) };
            *edge_mid.entry(key).or_insert_with(|| {
                src.push(key);
                u32::try_from(src.len() - 1).expect("vertex count fits u32")
            })
        };
        let mut triangles = Vec::with_capacity(self.triangles.len() * 4);
        for &[a, b, c] in &self.triangles {
            let ab = mid(a, b, &mut src);
            let bc = mid(b, c, &mut src);
            let ca = mid(c, a, &mut src);
            triangles.extend_from_slice(&[[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        let avg3 = |v: &[[f32; 3]], (a, b): (u32, u32)| {
            let (p, q) = (v[a as usize], v[b as usize]);
            [
                (p[0] + q[0]) * 0.5,
                (p[1] + q[1]) * 0.5,
                (p[2] + q[2]) * 0.5,
            ]
        };
        let positions = src.iter().map(|&e| avg3(&self.positions, e)).collect();
        let a = &self.attributes;
        fn lerp<const N: usize>(
            v: &Option<Vec<[f32; N]>>,
            src: &[(u32, u32)],
        ) -> Option<Vec<[f32; N]>> {
            v.as_ref().map(|v| {
                src.iter()
                    .map(|&(a, b)| {
                        let (p, q) = (v[a as usize], v[b as usize]);
                        std::array::from_fn(|k| (p[k] + q[k]) * 0.5)
                    })
                    .collect()
            })
        }
        let normals = lerp(&a.normals, &src).map(|mut ns| {
            for n in &mut ns {
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if l > 0.0 {
                    n.iter_mut().for_each(|x| *x /= l);
                }
            }
            ns
        });
        let attributes = VertexAttributes {
            normals,
            tangents: lerp(&a.tangents, &src),
            uv0: lerp(&a.uv0, &src),
            uv1: lerp(&a.uv1, &src),
            colors: lerp(&a.colors, &src),
            // Skinning is not interpolated: a midpoint takes its first endpoint's joints.
            joints: a
                .joints
                .as_ref()
                .map(|j| src.iter().map(|&(x, _)| j[x as usize]).collect()),
            weights: a
                .weights
                .as_ref()
                .map(|w| src.iter().map(|&(x, _)| w[x as usize]).collect()),
        };
        let groups = self
            .groups
            .as_ref()
            .map(|g| g.iter().flat_map(|&x| [x; 4]).collect());
        Mesh {
            positions,
            triangles,
            attributes,
            groups,
            group_names: self.group_names.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::mesh::MeshStats;

    #[test]
    fn subdivision_keeps_topology_and_quadruples_triangles() {
        // Tetrahedron: closed genus 0; after subdivision still closed genus 0.
        let m = crate::mesh::generate::tetrahedron();
        let s = m.subdivide_midpoint();
        assert_eq!(s.triangles.len(), 16);
        assert_eq!(s.positions.len(), 4 + 6);
        let st = MeshStats::of(&s);
        assert_eq!(st.topology.genus, Some(0));
        assert_eq!(st.topology.boundary_edges, 0);
        assert_eq!(st.topology.degenerate_triangles, 0);
    }
}
