//! Welding vertices that share a position.
//!
//! Topology (boundaries, manifoldness, components) is defined on *points*: vertices
//! whose positions are bitwise equal are one point, whatever their attributes. This is
//! the definition `MANIFEST.md` of the shared test meshes uses, so our counts and its
//! counts agree. `-0.0` and `+0.0` are treated as equal (they are the same place).

/// Result of welding: each vertex's point id, and the points' positions.
#[derive(Debug, Clone, PartialEq)]
pub struct Weld {
    /// For each vertex, the id of its point (dense, in first-occurrence order).
    pub point_of: Vec<u32>,
    /// For each point, the vertex that first had its position.
    pub representative: Vec<u32>,
}

impl Weld {
    /// Welds `positions` by exact equality. O(n) expected time: an open-addressing
    /// table of vertex ids (4 bytes a slot, load ≤ 1/2) probed linearly.
    #[must_use]
    pub fn exact(positions: &[[f32; 3]]) -> Self {
        // +0.0 for -0.0 so the two zeros weld.
        Self::by_key(positions.len(), |i| {
            let p = positions[i];
            let k = [
                (p[0] + 0.0).to_bits(),
                (p[1] + 0.0).to_bits(),
                (p[2] + 0.0).to_bits(),
            ];
            (k, hash3(k))
        })
    }

    /// Welds f64 positions by exact equality (e.g. world positions of scene instances
    /// computed in f64, so that two points that differ only below f32 precision stay
    /// apart, as the shared `MANIFEST.md` counts them).
    #[must_use]
    pub fn exact_f64(positions: &[[f64; 3]]) -> Self {
        Self::by_key(positions.len(), |i| {
            let p = positions[i];
            let k = [
                (p[0] + 0.0).to_bits(),
                (p[1] + 0.0).to_bits(),
                (p[2] + 0.0).to_bits(),
            ];
            let h = hash3(k.map(|w| (w ^ (w >> 32)) as u32));
            (k, h)
        })
    }

    /// Welds `n` items whose `key(i)` gives an equality key and its hash.
    fn by_key<K: PartialEq>(n: usize, key: impl Fn(usize) -> (K, u32)) -> Self {
        let cap = (n * 2).next_power_of_two().max(16);
        let mask = cap - 1;
        let mut slots = vec![u32::MAX; cap];
        let mut point_of = Vec::with_capacity(n);
        let mut representative = Vec::new();
        for i in 0..n {
            let (k, hash) = key(i);
            let mut h = hash as usize & mask;
            let id = loop {
                let s = slots[h];
                if s == u32::MAX {
                    let id = representative.len() as u32;
                    slots[h] = i as u32;
                    representative.push(i as u32);
                    break id;
                }
                if key(s as usize).0 == k {
                    break point_of[s as usize];
                }
                h = (h + 1) & mask;
            };
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

/// Mixes three 32-bit words into a well-spread 32-bit hash (multiply-xorshift).
#[inline]
fn hash3(k: [u32; 3]) -> u32 {
    let mut h = k[0].wrapping_mul(0x9E37_79B1)
        ^ k[1].wrapping_mul(0x85EB_CA77)
        ^ k[2].wrapping_mul(0xC2B2_AE3D);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7FEB_352D);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846C_A68B);
    h ^ (h >> 16)
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
