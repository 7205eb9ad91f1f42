//! A stable least-significant-digit radix sort of `u64` keys by their high 32 bits
//! (Knuth, *The Art of Computer Programming* vol. 3, §5.2.5: distribution sorting),
//! for the places that sort packed `(key << 32) | id` words built in id order, and the
//! 30-bit Morton (Z-order) code most of those keys are (Morton, "A computer oriented
//! geodetic data base and a new technique in file sequencing", IBM 1966).

/// Interleaves the low 10 bits of `x`, `y` and `z` (`x` lowest): the Z-order code
/// of a cell of a 1024³ grid.
#[inline]
pub(crate) fn morton3(x: u32, y: u32, z: u32) -> u32 {
    fn spread(v: u32) -> u32 {
        let mut v = v & 0x3ff;
        v = (v | (v << 16)) & 0x0300_00ff;
        v = (v | (v << 8)) & 0x0300_f00f;
        v = (v | (v << 4)) & 0x030c_30c3;
        (v | (v << 2)) & 0x0924_9249
    }
    spread(x) | (spread(y) << 1) | (spread(z) << 2)
}

/// Bits per counting pass (2048 counters: they stay in the L1 cache).
const DIGIT: u32 = 11;

/// Below this many keys the comparison sort is as fast.
const SMALL: usize = 512;

/// Sorts `keys` by their high 32 bits, stably. When the low 32 bits are distinct and
/// ascending in the input (keys packed as `(key << 32) | id` in id order), the result
/// is exactly `keys.sort_unstable()`'s. O(n) per 11 bits of the largest high half.
pub(crate) fn sort_by_high_half(keys: &mut Vec<u64>) {
    let n = keys.len();
    if n < SMALL {
        keys.sort_unstable();
        return;
    }
    let max = keys.iter().fold(0u64, |m, &k| m.max(k >> 32));
    let bits = 64 - max.leading_zeros();
    let mut src = std::mem::take(keys);
    let mut dst = vec![0u64; n];
    let mut shift = 32;
    while shift < 32 + bits {
        let mut count = [0u32; 1 << DIGIT];
        let mask = (1u64 << DIGIT) - 1;
        for &k in &src {
            count[((k >> shift) & mask) as usize] += 1;
        }
        let mut sum = 0u32;
        for c in &mut count {
            let x = *c;
            *c = sum;
            sum += x;
        }
        for &k in &src {
            let d = ((k >> shift) & mask) as usize;
            dst[count[d] as usize] = k;
            count[d] += 1;
        }
        std::mem::swap(&mut src, &mut dst);
        shift += DIGIT;
    }
    *keys = src;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton3_interleaves() {
        assert_eq!(morton3(0, 0, 0), 0);
        assert_eq!(morton3(1, 0, 0), 0b001);
        assert_eq!(morton3(0, 1, 0), 0b010);
        assert_eq!(morton3(0, 0, 1), 0b100);
        assert_eq!(morton3(3, 0, 0), 0b1001);
        assert_eq!(morton3(0x3FF, 0x3FF, 0x3FF), (1 << 30) - 1);
        // Bits above the tenth are ignored.
        assert_eq!(morton3(0x400, 0x400, 0x400), 0);
    }

    /// Packed keys in id order, high halves with many repeats and the full range:
    /// the radix sort equals the comparison sort.
    #[test]
    fn equals_comparison_sort() {
        for (n, range) in [
            (10usize, 7u64),
            (5000, 3),
            (5000, 1 << 20),
            (20000, u64::from(u32::MAX)),
        ] {
            let mut x = 0x9e37_79b9_7f4a_7c15u64;
            let mut keys: Vec<u64> = (0..n as u64)
                .map(|i| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    ((x % (range + 1)) << 32) | i
                })
                .collect();
            let mut want = keys.clone();
            want.sort_unstable();
            sort_by_high_half(&mut keys);
            assert_eq!(keys, want, "n {n} range {range}");
        }
    }
}
