//! Small procedural meshes for tests, examples and benchmarks: an icosphere, a
//! subdivided grid (open, with a border), a capped or open cylinder and a torus.
//!
//! Every generator is deterministic and produces a welded, consistently oriented
//! (counter-clockwise seen from outside) triangle mesh without degenerate triangles.

use super::Mesh;

/// The corner tetrahedron `(0,0,0), (1,0,0), (0,1,0), (0,0,1)`: 4 triangles, closed,
/// outward-facing, genus 0 — the smallest closed mesh, on which every edge collapse
/// would create a duplicate triangle.
#[must_use]
pub fn tetrahedron() -> Mesh {
    Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    )
}

/// A unit icosphere: the icosahedron with every triangle split into four `level`
/// times and the vertices pushed onto the sphere. `20 * 4^level` triangles; closed,
/// genus 0.
#[must_use]
pub fn icosphere(level: u32) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut pos: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for p in &mut pos {
        *p = normalise(*p);
    }
    for _ in 0..level {
        let mut mid: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
        let mut next = Vec::with_capacity(tris.len() * 4);
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<[f64; 3]>| -> u32 {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                let (p, q) = (pos[a as usize], pos[b as usize]);
                pos.push(normalise([p[0] + q[0], p[1] + q[1], p[2] + q[2]]));
                (pos.len() - 1) as u32
            })
        };
        for &[a, b, c] in &tris {
            let ab = midpoint(a, b, &mut pos);
            let bc = midpoint(b, c, &mut pos);
            let ca = midpoint(c, a, &mut pos);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    Mesh::from_triangles(to_f32(&pos), tris)
}

/// A flat `n × m` grid of quads in the z = 0 plane spanning `[0, 1]²`, each quad split
/// into two triangles: `2 n m` triangles, `(n + 1)(m + 1)` vertices, one border loop.
/// `height(x, y)` gives the z coordinate of each vertex (use `|_, _| 0.0` for flat).
#[must_use]
pub fn grid(n: u32, m: u32, height: impl Fn(f64, f64) -> f64) -> Mesh {
    let n = n.max(1);
    let m = m.max(1);
    let mut pos = Vec::with_capacity(((n + 1) * (m + 1)) as usize);
    for j in 0..=m {
        for i in 0..=n {
            let (x, y) = (f64::from(i) / f64::from(n), f64::from(j) / f64::from(m));
            pos.push([x, y, height(x, y)]);
        }
    }
    let id = |i: u32, j: u32| j * (n + 1) + i;
    let mut tris = Vec::with_capacity((2 * n * m) as usize);
    for j in 0..m {
        for i in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            // Alternate the diagonal so the grid has no preferred direction.
            if (i + j) % 2 == 0 {
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            } else {
                tris.push([a, b, d]);
                tris.push([b, c, d]);
            }
        }
    }
    Mesh::from_triangles(to_f32(&pos), tris)
}

/// A cylinder of radius 1 and height `height` around the z axis with `segments`
/// around and `rings` along; with `caps`, both ends are closed by triangle fans
/// around a centre vertex (closed, genus 0), otherwise it is an open tube (two
/// border loops).
#[must_use]
pub fn cylinder(segments: u32, rings: u32, height: f64, caps: bool) -> Mesh {
    let s = segments.max(3);
    let r = rings.max(1);
    let mut pos = Vec::new();
    for j in 0..=r {
        let z = height * f64::from(j) / f64::from(r);
        for i in 0..s {
            let a = std::f64::consts::TAU * f64::from(i) / f64::from(s);
            pos.push([a.cos(), a.sin(), z]);
        }
    }
    let id = |i: u32, j: u32| j * s + (i % s);
    let mut tris = Vec::new();
    for j in 0..r {
        for i in 0..s {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    if caps {
        let bottom = pos.len() as u32;
        pos.push([0.0, 0.0, 0.0]);
        let top = pos.len() as u32;
        pos.push([0.0, 0.0, height]);
        for i in 0..s {
            tris.push([bottom, id(i + 1, 0), id(i, 0)]);
            tris.push([top, id(i, r), id(i + 1, r)]);
        }
    }
    Mesh::from_triangles(to_f32(&pos), tris)
}

/// A torus around the z axis with major radius `major`, minor radius `minor`,
/// `segments` around the axis and `sides` around the tube: closed, genus 1,
/// `2 * segments * sides` triangles.
#[must_use]
pub fn torus(segments: u32, sides: u32, major: f64, minor: f64) -> Mesh {
    let s = segments.max(3);
    let k = sides.max(3);
    let mut pos = Vec::with_capacity((s * k) as usize);
    for i in 0..s {
        let u = std::f64::consts::TAU * f64::from(i) / f64::from(s);
        for j in 0..k {
            let v = std::f64::consts::TAU * f64::from(j) / f64::from(k);
            let rr = major + minor * v.cos();
            pos.push([rr * u.cos(), rr * u.sin(), minor * v.sin()]);
        }
    }
    let id = |i: u32, j: u32| (i % s) * k + (j % k);
    let mut tris = Vec::with_capacity((2 * s * k) as usize);
    for i in 0..s {
        for j in 0..k {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    Mesh::from_triangles(to_f32(&pos), tris)
}

fn normalise(p: [f64; 3]) -> [f64; 3] {
    let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    [p[0] / l, p[1] / l, p[2] / l]
}

fn to_f32(p: &[[f64; 3]]) -> Vec<[f32; 3]> {
    p.iter()
        .map(|q| [q[0] as f32, q[1] as f32, q[2] as f32])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshStats;

    #[test]
    fn generators_have_the_expected_topology() {
        let s = MeshStats::of(&icosphere(2));
        assert_eq!((s.triangles, s.topology.genus), (320, Some(0)));
        let g = MeshStats::of(&grid(4, 3, |_, _| 0.0));
        assert_eq!((g.triangles, g.topology.boundary_loops), (24, 1));
        let c = MeshStats::of(&cylinder(8, 2, 1.0, true));
        assert_eq!((c.triangles, c.topology.genus), (48, Some(0)));
        let o = MeshStats::of(&cylinder(8, 2, 1.0, false));
        assert_eq!(o.topology.boundary_loops, 2);
        let t = MeshStats::of(&torus(12, 8, 2.0, 0.5));
        assert_eq!((t.triangles, t.topology.genus), (192, Some(1)));
        for s in [s, g, c, o, t] {
            assert_eq!(s.topology.degenerate_triangles, 0);
            assert_eq!(s.topology.non_manifold_edges, 0);
        }
    }
}
