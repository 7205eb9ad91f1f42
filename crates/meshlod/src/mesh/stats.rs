//! Everything `meshlod info` reports about a mesh: counts, attributes, bounding box and
//! topology (boundaries, non-manifold structure, components, Euler characteristic and
//! genus, degenerate and duplicate triangles, unreferenced vertices).
//!
//! Topology is counted on positions welded by exact equality; see
//! [`super::topology`] for the definitions.

use super::topology::{Topology, UnionFind};
use super::{AttributeKind, Mesh, Weld};
use serde::Serialize;

/// Topological counts of a triangle list over welded points.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct TopologyStats {
    /// Points (distinct positions) used by at least one triangle.
    pub welded_vertices: usize,
    /// Unique undirected edges.
    pub edges: usize,
    /// Edges with exactly one triangle side.
    pub boundary_edges: usize,
    /// Closed loops of boundary edges (connected components of the boundary graph).
    pub boundary_loops: usize,
    /// Edges with more than two triangle sides.
    pub non_manifold_edges: usize,
    /// Points on a non-manifold edge or with more than one fan of triangles.
    pub non_manifold_vertices: usize,
    /// Connected components (points joined by edges).
    pub components: usize,
    /// V − E + F over referenced points, unique edges and all triangles.
    pub euler_characteristic: i64,
    /// Genus, when the mesh is closed (no boundary) and manifold; `None` otherwise.
    pub genus: Option<i64>,
    /// Triangles with a repeated point or zero area.
    pub degenerate_triangles: usize,
    /// Extra copies of triangles over the same three points (any order or winding).
    pub duplicate_triangles: usize,
}

/// The full `meshlod info` report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MeshStats {
    /// Vertices (wedges) stored.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
    /// Attribute streams present.
    pub attributes: Vec<AttributeKind>,
    /// Number of distinct group (material) ids used.
    pub groups: usize,
    /// Bounding box minimum corner of all vertices, `None` when empty.
    pub bbox_min: Option<[f32; 3]>,
    /// Bounding box maximum corner of all vertices, `None` when empty.
    pub bbox_max: Option<[f32; 3]>,
    /// Length of the bounding-box diagonal, in mesh units.
    pub bbox_diagonal: f64,
    /// Vertices no triangle refers to.
    pub unreferenced_vertices: usize,
    /// Vertices whose position equals an earlier vertex's.
    pub duplicate_positions: usize,
    /// Topology over welded points.
    #[serde(flatten)]
    pub topology: TopologyStats,
}

impl MeshStats {
    /// Measures `mesh`. O(n log n).
    ///
    /// # Panics
    /// Panics if the mesh does not [validate](Mesh::validate).
    #[must_use]
    pub fn of(mesh: &Mesh) -> Self {
        Self::with_weld(mesh, &Weld::exact(&mesh.positions))
    }

    /// Measures `mesh` with topology on the points of `weld` (which must have one entry
    /// per vertex of `mesh`), e.g. a weld of world positions computed in f64
    /// ([`Weld::exact_f64`]), as `meshlod info` does for instanced glTF scenes.
    ///
    /// # Panics
    /// Panics if the mesh does not validate or `weld` does not match it.
    #[must_use]
    pub fn with_weld(mesh: &Mesh, weld: &Weld) -> Self {
        let welded = weld.map_triangles(&mesh.triangles);
        let topology = TopologyStats::of(&welded, weld.point_count(), |p| {
            mesh.positions[weld.representative[p as usize] as usize]
        });
        let mut used = vec![false; mesh.positions.len()];
        for t in &mesh.triangles {
            for &i in t {
                used[i as usize] = true;
            }
        }
        let groups = mesh.groups.as_ref().map_or(1, |g| {
            let mut g = g.clone();
            g.sort_unstable();
            g.dedup();
            g.len()
        });
        let bbox = mesh.bounding_box(false);
        Self {
            vertices: mesh.positions.len(),
            triangles: mesh.triangles.len(),
            attributes: mesh.attributes.kinds(),
            groups: if mesh.triangles.is_empty() { 0 } else { groups },
            bbox_min: bbox.map(|b| b.0),
            bbox_max: bbox.map(|b| b.1),
            bbox_diagonal: mesh.bbox_diagonal(),
            unreferenced_vertices: used.iter().filter(|&&u| !u).count(),
            duplicate_positions: weld.duplicate_count(),
            topology,
        }
    }
}

impl TopologyStats {
    /// Counts the topology of `triangles` over points `0..point_count`, with
    /// `position(p)` giving each point's coordinates (for the zero-area test).
    #[must_use]
    pub fn of(
        triangles: &[[u32; 3]],
        point_count: usize,
        position: impl Fn(u32) -> [f32; 3],
    ) -> Self {
        let topo = Topology::build(triangles, point_count);
        let mut boundary_edges = 0;
        let mut non_manifold_edges = 0;
        let mut on_bad_edge = vec![false; point_count];
        let mut boundary_graph = UnionFind::new(point_count);
        let mut on_boundary = vec![false; point_count];
        let mut components = UnionFind::new(point_count);
        let mut edges = 0usize;
        for (e, &[a, b]) in topo.edges.iter().enumerate() {
            if a == b {
                // The loop edge of a degenerate triangle `a a b` is not an edge.
                continue;
            }
            edges += 1;
            components.union(a, b);
            // Distinct triangles on the edge: `a a b` uses `{a, b}` twice but is one side.
            let tris = topo.triangles_of_edge(e);
            let valence = 1 + tris.windows(2).filter(|w| w[0] != w[1]).count();
            match valence {
                1 => {
                    boundary_edges += 1;
                    boundary_graph.union(a, b);
                    on_boundary[a as usize] = true;
                    on_boundary[b as usize] = true;
                }
                2 => {}
                _ => {
                    non_manifold_edges += 1;
                    on_bad_edge[a as usize] = true;
                    on_bad_edge[b as usize] = true;
                }
            }
        }
        let mut welded_vertices = 0;
        let mut non_manifold_vertices = 0;
        let mut n_components = 0;
        let mut boundary_loops = 0;
        for p in 0..point_count as u32 {
            if topo.triangles_of_point(p).is_empty() {
                continue;
            }
            welded_vertices += 1;
            if on_bad_edge[p as usize] || topo.fan_count(p, triangles) > 1 {
                non_manifold_vertices += 1;
            }
            if components.find(p) == p {
                n_components += 1;
            }
            if on_boundary[p as usize] && boundary_graph.find(p) == p {
                boundary_loops += 1;
            }
        }

        let mut degenerate_triangles = 0;
        let mut sorted: Vec<[u32; 3]> = Vec::with_capacity(triangles.len());
        for t in triangles {
            let [a, b, c] = *t;
            if a == b || b == c || a == c || zero_area(position(a), position(b), position(c)) {
                degenerate_triangles += 1;
            }
            let mut s = *t;
            s.sort_unstable();
            sorted.push(s);
        }
        sorted.sort_unstable();
        let duplicate_triangles = sorted.windows(2).filter(|w| w[0] == w[1]).count();

        let euler_characteristic = welded_vertices as i64 - edges as i64 + triangles.len() as i64;
        let genus = (boundary_edges == 0
            && non_manifold_edges == 0
            && non_manifold_vertices == 0
            && !triangles.is_empty())
        .then(|| (2 * n_components as i64 - euler_characteristic) / 2);
        Self {
            welded_vertices,
            edges,
            boundary_edges,
            boundary_loops,
            non_manifold_edges,
            non_manifold_vertices,
            components: n_components,
            euler_characteristic,
            genus,
            degenerate_triangles,
            duplicate_triangles,
        }
    }
}

/// True when the triangle's area is exactly zero in f64 arithmetic.
fn zero_area(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> bool {
    let d = |p: [f32; 3], q: [f32; 3]| {
        [
            f64::from(q[0]) - f64::from(p[0]),
            f64::from(q[1]) - f64::from(p[1]),
            f64::from(q[2]) - f64::from(p[2]),
        ]
    };
    let (u, v) = (d(a, b), d(a, c));
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    n == [0.0; 3]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Octahedron: closed, genus 0, χ = 2.
    fn octahedron() -> Mesh {
        let p = vec![
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let t = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        Mesh::from_triangles(p, t)
    }

    #[test]
    fn octahedron_is_genus_zero() {
        let s = MeshStats::of(&octahedron());
        assert_eq!(s.topology.euler_characteristic, 2);
        assert_eq!(s.topology.genus, Some(0));
        assert_eq!(s.topology.components, 1);
        assert_eq!(s.topology.boundary_edges, 0);
        assert!((s.bbox_diagonal - 12f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn removing_a_face_opens_one_loop() {
        let mut m = octahedron();
        m.triangles.pop();
        let s = MeshStats::of(&m);
        assert_eq!(s.topology.boundary_edges, 3);
        assert_eq!(s.topology.boundary_loops, 1);
        assert_eq!(s.topology.genus, None);
    }

    #[test]
    fn duplicates_degenerates_and_unreferenced() {
        let mut m = octahedron();
        m.triangles.push([4, 2, 0]); // same points as the first, other winding
        m.triangles.push([0, 0, 1]); // repeated point
        m.positions.push([7.0, 7.0, 7.0]); // unused
        let s = MeshStats::of(&m);
        assert_eq!(s.topology.duplicate_triangles, 1);
        assert_eq!(s.topology.degenerate_triangles, 1);
        assert_eq!(s.unreferenced_vertices, 1);
        assert!(s.topology.non_manifold_edges >= 3);
    }
}
