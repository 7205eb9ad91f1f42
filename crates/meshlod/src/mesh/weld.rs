//! Welding vertices that share a position.
//!
//! Topology (boundaries, manifoldness, components) is defined on *points*: vertices
//! whose positions are bitwise equal are one point, whatever their attributes. This is
//! the definition `MANIFEST.md` of the shared test meshes uses, so our counts and its
//! counts agree. `-0.0` and `+0.0` are treated as equal (they are the same place).

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Result of welding: each vertex's point id, and the points' positions.
#[derive(Debug, Clone, PartialEq)]
pub struct Weld {
    /// For each vertex, the id of its point (dense, in first-occurrence order).
    pub point_of: Vec<u32>,
    /// For each point, the vertex that first had its position.
    pub representative: Vec<u32>,
}

impl Weld {
    /// Welds `positions` by exact equality. O(n) expected time.
    #[must_use]
    pub fn exact(positions: &[[f32; 3]]) -> Self {
        let mut map: HashMap<[u32; 3], u32, BuildHasherDefault<PosHasher>> =
            HashMap::with_capacity_and_hasher(positions.len(), BuildHasherDefault::default());
        let mut point_of = Vec::with_capacity(positions.len());
        let mut representative = Vec::new();
        for (i, p) in positions.iter().enumerate() {
            // +0.0 for -0.0 so the two zeros weld.
            let key = [
                (p[0] + 0.0).to_bits(),
                (p[1] + 0.0).to_bits(),
                (p[2] + 0.0).to_bits(),
            ];
            let next = representative.len() as u32;
            let id = *map.entry(key).or_insert_with(|| {
                representative.push(i as u32);
                next
            });
            point_of.push(id);
        }
        Self {
            point_of,
            representative,
        }
    }

    /// The identity weld: every vertex its own point.
    #[must_use]
    pub fn identity(n: usize) -> Self {
        let ids: Vec<u32> = (0..n as u32).collect();
        Self {
            point_of: ids.clone(),
            representative: ids,
        }
    }

    /// Number of distinct points.
    #[must_use]
    pub fn point_count(&self) -> usize {
        self.representative.len()
    }

    /// Triangles with their vertex ids replaced by point ids.
    #[must_use]
    pub fn map_triangles(&self, triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
        triangles
            .iter()
            .map(|t| t.map(|v| self.point_of[v as usize]))
            .collect()
    }

    /// Number of vertices that share their position with an earlier vertex.
    #[must_use]
    pub fn duplicate_count(&self) -> usize {
        self.point_of.len() - self.representative.len()
    }
}

/// A small fast hasher for bit patterns of positions (multiply-rotate, FxHash style).
#[derive(Default)]
struct PosHasher(u64);

impl Hasher for PosHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }
    fn write_u32(&mut self, i: u32) {
        self.write_u64(u64::from(i));
    }
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, i: usize) {
        self.write_u64(i as u64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welds_equal_positions_and_signed_zero() {
        let w = Weld::exact(&[
            [0.0, 1.0, 2.0],
            [1.0, 1.0, 2.0],
            [0.0, 1.0, 2.0],
            [-0.0, 1.0, 2.0],
        ]);
        assert_eq!(w.point_of, vec![0, 1, 0, 0]);
        assert_eq!(w.point_count(), 2);
        assert_eq!(w.duplicate_count(), 2);
    }
}
