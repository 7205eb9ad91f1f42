//! A binary min-heap of collapse candidates with lazy invalidation.
//!
//! Entries are 16 bytes: the cost as `f32` bits, the pair, and a stamp (the sum of
//! the two points' version counters when the entry was pushed). Versions only grow,
//! so the sum is unchanged exactly when neither point changed: a popped entry whose
//! stamp differs is stale and dropped. Ties are broken by the pair ids, so the order
//! is total and the run deterministic.

/// One queued candidate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Entry {
    /// `(cost bits << 32) | a`: the cost of a non-negative `f32` orders like its bits.
    pub key: u64,
    /// The second point.
    pub b: u32,
    /// Sum of the two points' versions at push time.
    pub stamp: u32,
}

impl Entry {
    pub(crate) fn new(cost: f64, a: u32, b: u32, stamp: u32) -> Self {
        let c = if cost.is_nan() {
            f32::INFINITY
        } else {
            (cost.max(0.0) as f32).max(0.0)
        };
        Self {
            key: (u64::from(c.to_bits()) << 32) | u64::from(a),
            b,
            stamp,
        }
    }

    #[inline]
    pub(crate) fn a(&self) -> u32 {
        self.key as u32
    }

    #[inline]
    fn less(&self, o: &Self) -> bool {
        (self.key, self.b) < (o.key, o.b)
    }
}

/// The heap.
#[derive(Debug, Default)]
pub(crate) struct Heap {
    v: Vec<Entry>,
}

impl Heap {
    pub(crate) fn with_capacity(n: usize) -> Self {
        Self {
            v: Vec::with_capacity(n),
        }
    }

    pub(crate) fn len(&self) -> usize {
        self.v.len()
    }

    /// Appends without restoring the heap order (call [`Self::heapify`] after).
    pub(crate) fn push_unordered(&mut self, e: Entry) {
        self.v.push(e);
    }

    pub(crate) fn heapify(&mut self) {
        let n = self.v.len();
        for i in (0..n / 2).rev() {
            self.sift_down(i);
        }
    }

    pub(crate) fn push(&mut self, e: Entry) {
        self.v.push(e);
        let mut i = self.v.len() - 1;
        while i > 0 {
            let p = (i - 1) / 2;
            if e.less(&self.v[p]) {
                self.v[i] = self.v[p];
                i = p;
            } else {
                break;
            }
        }
        self.v[i] = e;
    }

    pub(crate) fn pop(&mut self) -> Option<Entry> {
        let last = self.v.pop()?;
        if self.v.is_empty() {
            return Some(last);
        }
        let top = self.v[0];
        self.v[0] = last;
        self.sift_down(0);
        Some(top)
    }

    fn sift_down(&mut self, mut i: usize) {
        let n = self.v.len();
        let e = self.v[i];
        loop {
            let l = 2 * i + 1;
            if l >= n {
                break;
            }
            let r = l + 1;
            let c = if r < n && self.v[r].less(&self.v[l]) {
                r
            } else {
                l
            };
            if self.v[c].less(&e) {
                self.v[i] = self.v[c];
                i = c;
            } else {
                break;
            }
        }
        self.v[i] = e;
    }

    /// Keeps only entries for which `keep` is true and restores the heap order.
    pub(crate) fn retain(&mut self, keep: impl FnMut(&Entry) -> bool) {
        self.v.retain(keep);
        self.heapify();
    }

    pub(crate) fn clear(&mut self) {
        self.v.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pops_in_cost_then_id_order() {
        let mut h = Heap::default();
        h.push(Entry::new(2.0, 5, 6, 0));
        h.push(Entry::new(1.0, 9, 1, 0));
        h.push(Entry::new(1.0, 3, 4, 0));
        h.push(Entry::new(1.0, 3, 2, 0));
        h.push(Entry::new(f64::NAN, 0, 1, 0));
        h.push(Entry::new(0.0, 7, 8, 0));
        let order: Vec<(u32, u32)> = std::iter::from_fn(|| h.pop())
            .map(|e| (e.a(), e.b))
            .collect();
        assert_eq!(order, vec![(7, 8), (3, 2), (3, 4), (9, 1), (5, 6), (0, 1)]);
    }

    #[test]
    fn heapify_and_retain() {
        let mut h = Heap::with_capacity(8);
        for (i, c) in [5.0, 3.0, 8.0, 1.0, 4.0].iter().enumerate() {
            h.push_unordered(Entry::new(*c, i as u32, 0, 0));
        }
        h.heapify();
        h.retain(|e| e.a() != 3);
        assert_eq!(h.len(), 4);
        let order: Vec<u32> = std::iter::from_fn(|| h.pop()).map(|e| e.a()).collect();
        assert_eq!(order, vec![1, 4, 0, 2]);
    }
}
