//! The priority queue of collapse candidates: exact cost order with lazy
//! invalidation, kept cache-friendly by banding.
//!
//! Only the cheapest band of candidates lives in a binary heap; everything costlier
//! than the band's bound waits, unordered, in an overflow list that is appended to
//! sequentially. When the heap runs dry, the cheapest slice of the overflow (found
//! with a linear-time selection) becomes the next band. Every heap entry costs at
//! most the bound and every overflow entry more, so pops come out in exact cost
//! order while the heap stays small enough for the cache.
//!
//! Entries order by `(cost, removed, kept)`: a total order, so runs are
//! deterministic. Lazy invalidation: an entry carries a stamp (the sum of its two
//! points' version counters when pushed); versions only grow, so the sum is
//! unchanged exactly when neither point changed, and the driver drops popped entries
//! whose stamp differs.

/// A queued candidate (32 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Item {
    /// The cost, as `f32` bits (non-negative, so the bits order like the values).
    pub cost_bits: u32,
    /// The point that goes.
    pub removed: u32,
    /// The point that stays.
    pub kept: u32,
    /// Sum of the two points' versions at push time.
    pub stamp: u32,
    /// Where `kept` goes.
    pub position: [f32; 3],
    /// The error (distance) of the candidate.
    pub error: f32,
}

impl Item {
    /// Sets the cost (NaN and negative values become `+∞` and `0`).
    pub(crate) fn with_cost(mut self, cost: f64) -> Self {
        let c = if cost.is_nan() {
            f32::INFINITY
        } else {
            (cost.max(0.0) as f32).max(0.0)
        };
        self.cost_bits = c.to_bits();
        self
    }

    /// The cost.
    pub(crate) fn cost(&self) -> f32 {
        f32::from_bits(self.cost_bits)
    }

    #[inline]
    fn key(&self) -> (u32, u32, u32, u32) {
        (self.cost_bits, self.removed, self.kept, self.stamp)
    }
}

/// Smallest band moved from the overflow into the heap at once.
const MIN_BAND: usize = 4096;

/// The queue.
#[derive(Debug, Default)]
pub(crate) struct Heap {
    heap: Vec<Item>,
    rest: Vec<Item>,
    /// Entries with `key() <= bound` belong in `heap`, the others in `rest`.
    bound: (u32, u32, u32, u32),
}

impl Heap {
    pub(crate) fn with_capacity(n: usize) -> Self {
        Self {
            heap: Vec::with_capacity(MIN_BAND),
            rest: Vec::with_capacity(n),
            bound: (0, 0, 0, 0),
        }
    }

    /// Number of queued entries (stale ones included).
    pub(crate) fn len(&self) -> usize {
        self.heap.len() + self.rest.len()
    }

    /// Queues an item.
    pub(crate) fn push(&mut self, item: Item) {
        if !self.heap.is_empty() && item.key() <= self.bound {
            self.sift_up(item);
        } else {
            self.rest.push(item);
        }
    }

    /// Queues an item during a bulk load (same as [`Self::push`]).
    pub(crate) fn push_unordered(&mut self, item: Item) {
        self.push(item);
    }

    /// Nothing to do: bands are formed on demand.
    pub(crate) fn heapify(&mut self) {}

    fn sift_up(&mut self, item: Item) {
        self.heap.push(item);
        let mut i = self.heap.len() - 1;
        let k = item.key();
        while i > 0 {
            let p = (i - 1) / 2;
            if k < self.heap[p].key() {
                self.heap[i] = self.heap[p];
                i = p;
            } else {
                break;
            }
        }
        self.heap[i] = item;
    }

    fn sift_down(&mut self, mut i: usize) {
        let n = self.heap.len();
        let item = self.heap[i];
        let k = item.key();
        loop {
            let l = 2 * i + 1;
            if l >= n {
                break;
            }
            let r = l + 1;
            let c = if r < n && self.heap[r].key() < self.heap[l].key() {
                r
            } else {
                l
            };
            if self.heap[c].key() < k {
                self.heap[i] = self.heap[c];
                i = c;
            } else {
                break;
            }
        }
        self.heap[i] = item;
    }

    /// Moves the cheapest slice of the overflow into the heap.
    fn refill(&mut self) {
        let m = self.rest.len();
        if m == 0 {
            return;
        }
        let k = (m / 8).max(MIN_BAND).min(m);
        // The k cheapest go to the end, then move over.
        let (_, pivot, _) = self
            .rest
            .select_nth_unstable_by(m - k, |a, b| b.key().cmp(&a.key()));
        self.bound = pivot.key();
        self.heap.extend_from_slice(&self.rest[m - k..]);
        self.rest.truncate(m - k);
        let n = self.heap.len();
        for i in (0..n / 2).rev() {
            self.sift_down(i);
        }
    }

    /// Removes and returns the cheapest item.
    pub(crate) fn pop(&mut self) -> Option<Item> {
        if self.heap.is_empty() {
            self.refill();
        }
        let last = self.heap.pop()?;
        if self.heap.is_empty() {
            return Some(last);
        }
        let top = self.heap[0];
        self.heap[0] = last;
        self.sift_down(0);
        Some(top)
    }

    /// Keeps only items for which `keep` is true.
    pub(crate) fn retain(&mut self, mut keep: impl FnMut(&Item) -> bool) {
        self.rest.retain(&mut keep);
        let before = self.heap.len();
        self.heap.retain(&mut keep);
        if self.heap.len() != before {
            let n = self.heap.len();
            for i in (0..n / 2).rev() {
                self.sift_down(i);
            }
        }
    }

    pub(crate) fn clear(&mut self) {
        self.heap.clear();
        self.rest.clear();
        self.bound = (0, 0, 0, 0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(cost: f64, a: u32, b: u32) -> Item {
        Item {
            removed: a,
            kept: b,
            ..Item::default()
        }
        .with_cost(cost)
    }

    #[test]
    fn pops_in_cost_then_id_order() {
        let mut h = Heap::default();
        for (c, a) in [
            (2.0, 5),
            (1.0, 9),
            (1.0, 3),
            (f64::NAN, 0),
            (0.0, 7),
            (-1.0, 8),
        ] {
            h.push(item(c, a, 0));
        }
        let order: Vec<u32> = std::iter::from_fn(|| h.pop()).map(|e| e.removed).collect();
        // -1 clamps to 0 and ties with 0.0 (ids break the tie); NaN sorts last.
        assert_eq!(order, vec![7, 8, 3, 9, 5, 0]);
    }

    /// Many entries, pushes interleaved with pops (some cheaper than the current
    /// band): the output is exactly sorted, like a reference sort.
    #[test]
    fn banding_keeps_exact_order() {
        let mut h = Heap::with_capacity(16);
        let mut x = 12345u64;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let mut reference = Vec::new();
        for i in 0..20_000u32 {
            let c = (rnd() % 1000) as f64;
            h.push(item(c, i, 0));
            reference.push((c as u32, i));
        }
        let mut out = Vec::new();
        let mut last = 0.0f32;
        for i in 0..30_000u32 {
            if i % 3 == 0 {
                // A new entry no cheaper than what was popped last keeps the
                // sequence monotone.
                let c = f64::from(last) + (rnd() % 50) as f64;
                h.push(item(c, 100_000 + i, 0));
                reference.push((c as u32, 100_000 + i));
            } else if let Some(e) = h.pop() {
                assert!(e.cost() >= last);
                last = e.cost();
                out.push((e.cost() as u32, e.removed));
            }
        }
        while let Some(e) = h.pop() {
            out.push((e.cost() as u32, e.removed));
        }
        reference.sort_unstable();
        assert_eq!(out, reference);
    }

    #[test]
    fn retain_drops() {
        let mut h = Heap::default();
        for i in 0..3000u32 {
            h.push(item(f64::from(i % 7), i, 0));
        }
        h.pop();
        h.retain(|e| e.removed % 2 == 0);
        let all: Vec<Item> = std::iter::from_fn(|| h.pop()).collect();
        assert!(all.iter().all(|e| e.removed % 2 == 0));
        assert_eq!(all.len(), 1499);
        assert!(all.windows(2).all(|w| w[0].key() <= w[1].key()));
    }
}
