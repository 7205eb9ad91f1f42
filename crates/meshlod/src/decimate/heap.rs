//! A 4-ary min-heap of collapse candidates with lazy invalidation.
//!
//! The heap array holds only 8-byte keys, `(cost as f32 bits) << 32 | slot`, so a
//! node's four children share half a cache line; the candidate itself (pair, stamp,
//! position, error) lives in a slab at `slot`, touched once when popped. The cost
//! of a non-negative `f32` orders like its bits; ties are broken by the slot, so
//! the order is total and, slots being handed out deterministically, every run is
//! the same.
//!
//! Lazy invalidation: an entry carries a stamp (the sum of its two points' version
//! counters when pushed). Versions only grow, so the sum is unchanged exactly when
//! neither point changed; a popped entry with another stamp is stale and dropped.

/// A queued candidate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Item {
    /// The point that goes.
    pub removed: u32,
    /// The point that stays.
    pub kept: u32,
    /// Sum of the two points' versions at push time.
    pub stamp: u32,
    /// The error (distance) of the candidate.
    pub error: f32,
    /// Where `kept` goes.
    pub position: [f32; 3],
    /// The cost.
    pub cost: f32,
}

/// The heap.
#[derive(Debug, Default)]
pub(crate) struct Heap {
    keys: Vec<u64>,
    slab: Vec<Item>,
    free: Vec<u32>,
}

#[inline]
fn cost_bits(cost: f64) -> u32 {
    let c = if cost.is_nan() {
        f32::INFINITY
    } else {
        (cost.max(0.0) as f32).max(0.0)
    };
    c.to_bits()
}

impl Heap {
    pub(crate) fn with_capacity(n: usize) -> Self {
        Self {
            keys: Vec::with_capacity(n),
            slab: Vec::with_capacity(n),
            free: Vec::new(),
        }
    }

    pub(crate) fn len(&self) -> usize {
        self.keys.len()
    }

    fn store(&mut self, cost: f64, mut item: Item) -> u64 {
        let bits = cost_bits(cost);
        item.cost = f32::from_bits(bits);
        let slot = match self.free.pop() {
            Some(s) => {
                self.slab[s as usize] = item;
                s
            }
            None => {
                self.slab.push(item);
                (self.slab.len() - 1) as u32
            }
        };
        (u64::from(bits) << 32) | u64::from(slot)
    }

    /// Appends without restoring the heap order (call [`Self::heapify`] after).
    pub(crate) fn push_unordered(&mut self, cost: f64, item: Item) {
        let k = self.store(cost, item);
        self.keys.push(k);
    }

    pub(crate) fn heapify(&mut self) {
        let n = self.keys.len();
        if n > 1 {
            for i in (0..=(n - 2) / 4).rev() {
                self.sift_down(i);
            }
        }
    }

    pub(crate) fn push(&mut self, cost: f64, item: Item) {
        let k = self.store(cost, item);
        self.keys.push(k);
        let mut i = self.keys.len() - 1;
        while i > 0 {
            let p = (i - 1) / 4;
            if k < self.keys[p] {
                self.keys[i] = self.keys[p];
                i = p;
            } else {
                break;
            }
        }
        self.keys[i] = k;
    }

    /// Removes and returns the cheapest item.
    pub(crate) fn pop(&mut self) -> Option<Item> {
        let last = self.keys.pop()?;
        let top = if self.keys.is_empty() {
            last
        } else {
            let top = self.keys[0];
            self.keys[0] = last;
            self.sift_down(0);
            top
        };
        let slot = top as u32;
        self.free.push(slot);
        Some(self.slab[slot as usize])
    }

    fn sift_down(&mut self, mut i: usize) {
        let n = self.keys.len();
        let k = self.keys[i];
        loop {
            let c0 = 4 * i + 1;
            if c0 >= n {
                break;
            }
            let end = (c0 + 4).min(n);
            let mut c = c0;
            let mut ck = self.keys[c0];
            for j in c0 + 1..end {
                let kj = self.keys[j];
                if kj < ck {
                    ck = kj;
                    c = j;
                }
            }
            if ck < k {
                self.keys[i] = ck;
                i = c;
            } else {
                break;
            }
        }
        self.keys[i] = k;
    }

    /// Keeps only items for which `keep` is true and restores the heap order.
    pub(crate) fn retain(&mut self, mut keep: impl FnMut(&Item) -> bool) {
        let slab = &self.slab;
        let free = &mut self.free;
        self.keys.retain(|&k| {
            let s = k as u32;
            let ok = keep(&slab[s as usize]);
            if !ok {
                free.push(s);
            }
            ok
        });
        self.heapify();
    }

    pub(crate) fn clear(&mut self) {
        self.keys.clear();
        self.slab.clear();
        self.free.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(a: u32) -> Item {
        Item {
            removed: a,
            ..Item::default()
        }
    }

    #[test]
    fn pops_in_cost_then_push_order() {
        let mut h = Heap::default();
        for (c, a) in [
            (2.0, 5),
            (1.0, 9),
            (1.0, 3),
            (f64::NAN, 0),
            (0.0, 7),
            (-1.0, 8),
        ] {
            h.push(c, item(a));
        }
        let order: Vec<u32> = std::iter::from_fn(|| h.pop()).map(|e| e.removed).collect();
        // -1 clamps to 0 and ties with 0.0 (pushed before it); NaN sorts last.
        assert_eq!(order, vec![7, 8, 9, 3, 5, 0]);
    }

    #[test]
    fn heapify_retain_and_slot_reuse() {
        let mut h = Heap::with_capacity(8);
        for (i, c) in [5.0, 3.0, 8.0, 1.0, 4.0, 9.0, 7.0].iter().enumerate() {
            h.push_unordered(*c, item(i as u32));
        }
        h.heapify();
        h.retain(|e| e.removed != 3);
        assert_eq!(h.len(), 6);
        assert_eq!(h.pop().map(|e| e.removed), Some(1));
        h.push(0.5, item(42));
        let order: Vec<u32> = std::iter::from_fn(|| h.pop()).map(|e| e.removed).collect();
        assert_eq!(order, vec![42, 4, 0, 6, 2, 5]);
        assert!(h.slab.len() <= 7);
    }
}
