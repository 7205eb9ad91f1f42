//! Spatial partition of a mesh's triangles into chunks of about equal size, for
//! simplifying the chunks independently (in parallel, or one at a time for a
//! mesh larger than memory) with their shared border locked.
//!
//! Triangles are ordered by the Z-order (Morton) code of their centroids on a
//! 1024³ grid over the bounding box (Morton 1966) and cut into `k` runs of
//! consecutive triangles, `k = ⌈triangles / chunk_triangles⌉`. A run of a Z-order
//! curve is a compact region of space (a union of octree cells), so a chunk's
//! border is short beside its area. The partition depends only on the mesh and
//! `chunk_triangles`, never on how many threads will process it: every run over
//! the same mesh sees the same chunks.
//!
//! A *border point* is a position (welded by exact equality) used by triangles of
//! two or more chunks; every vertex at such a position is a border vertex.

use super::{Mesh, Weld};
use crate::radix::{morton3, sort_by_high_half};
use rayon::prelude::*;

/// Triangles of each chunk and the border vertices between chunks.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Partition {
    /// For each chunk, its triangles (indices into [`Mesh::triangles`]), in Z order.
    pub chunks: Vec<Vec<u32>>,
    /// Per vertex of the mesh: whether its position is used by triangles of more
    /// than one chunk.
    pub border: Vec<bool>,
    /// Per vertex of the mesh: its point (position welded by exact equality,
    /// [`Weld::exact`]), for borders drawn inside a chunk.
    pub point_of: Vec<u32>,
}

impl Partition {
    /// Number of border vertices.
    #[must_use]
    pub fn border_vertices(&self) -> usize {
        self.border.iter().filter(|&&b| b).count()
    }
}

/// Cuts `mesh` into `⌈triangles / chunk_triangles⌉` chunks of consecutive
/// triangles in Z order (sizes differ by at most one). `chunk_triangles` is
/// clamped to at least 1. The mesh's indices must be valid ([`Mesh::validate`]).
#[must_use]
pub fn partition(mesh: &Mesh, chunk_triangles: usize) -> Partition {
    let n = mesh.triangles.len();
    let k = n.div_ceil(chunk_triangles.max(1)).max(1);
    // Morton keys of the centroids, packed with the triangle id (ascending ids, so
    // the stable radix sort orders equal codes by id).
    let (lo, hi) = mesh.bounding_box(true).unwrap_or(([0.0; 3], [0.0; 3]));
    let scale: [f64; 3] = std::array::from_fn(|a| {
        let extent = f64::from(hi[a]) - f64::from(lo[a]);
        if extent > 0.0 && extent.is_finite() {
            1023.0 / extent
        } else {
            0.0
        }
    });
    // The Z-order runs and the exact weld are independent: on two threads (the
    // caller's rayon pool) at once.
    let (chunks, weld) = rayon::join(
        || {
            let mut keys: Vec<u64> = mesh
                .triangles
                .par_iter()
                .enumerate()
                .map(|(i, t)| {
                    let cell = |a: usize| {
                        let c = t
                            .iter()
                            .map(|&v| f64::from(mesh.positions[v as usize][a]))
                            .sum::<f64>()
                            / 3.0;
                        ((c - f64::from(lo[a])) * scale[a]).clamp(0.0, 1023.0) as u32
                    };
                    (u64::from(morton3(cell(0), cell(1), cell(2))) << 32) | i as u64
                })
                .collect();
            sort_by_high_half(&mut keys);
            let mut chunks: Vec<Vec<u32>> = Vec::with_capacity(k);
            let (base, extra) = (n / k, n % k);
            let mut at = 0;
            for c in 0..k {
                let len = base + usize::from(c < extra);
                chunks.push(keys[at..at + len].iter().map(|&x| x as u32).collect());
                at += len;
            }
            chunks
        },
        || Weld::exact(&mesh.positions),
    );
    // Border points: used by triangles of two chunks or more.
    let mut owner = vec![u32::MAX; weld.representative.len()];
    let mut shared = vec![false; weld.representative.len()];
    for (c, tris) in chunks.iter().enumerate() {
        for &t in tris {
            for &v in &mesh.triangles[t as usize] {
                let p = weld.point_of[v as usize] as usize;
                if owner[p] == u32::MAX {
                    owner[p] = c as u32;
                } else if owner[p] != c as u32 {
                    shared[p] = true;
                }
            }
        }
    }
    let border = weld.point_of.iter().map(|&p| shared[p as usize]).collect();
    Partition {
        chunks,
        border,
        point_of: weld.point_of,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    /// A 32 × 32 grid (2,048 triangles) cut into chunks of 512: four chunks of
    /// 512, every triangle in exactly one, and the border vertices exactly those
    /// whose triangles lie in different chunks.
    #[test]
    fn chunks_cover_every_triangle_once_and_borders_are_shared_points() {
        let mesh = generate::grid(32, 32, |x, y| 0.1 * (x * y));
        let p = partition(&mesh, 512);
        assert_eq!(p.chunks.len(), 4);
        assert!(p.chunks.iter().all(|c| c.len() == 512));
        let mut seen = vec![0u8; mesh.triangles.len()];
        let mut chunk_of = vec![0usize; mesh.triangles.len()];
        for (c, tris) in p.chunks.iter().enumerate() {
            for &t in tris {
                seen[t as usize] += 1;
                chunk_of[t as usize] = c;
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
        let mut chunks_at = vec![Vec::new(); mesh.positions.len()];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for &v in tri {
                chunks_at[v as usize].push(chunk_of[t]);
            }
        }
        for (v, cs) in chunks_at.iter().enumerate() {
            let expect = cs.iter().any(|&c| c != cs[0]);
            assert_eq!(p.border[v], expect, "vertex {v}");
        }
        // Z-order runs are compact: far fewer border vertices than vertices.
        assert!(p.border_vertices() > 0);
        assert!(p.border_vertices() < mesh.positions.len() / 4);
    }

    /// Fewer triangles than a chunk: one chunk, no border; an empty mesh: one
    /// empty chunk.
    #[test]
    fn small_and_empty_meshes() {
        let mesh = generate::grid(4, 4, |_, _| 0.0);
        let p = partition(&mesh, 1 << 20);
        assert_eq!(p.chunks.len(), 1);
        assert_eq!(p.border_vertices(), 0);
        let empty = Mesh::default();
        let p = partition(&empty, 10);
        assert_eq!(p.chunks, vec![Vec::<u32>::new()]);
    }
}
