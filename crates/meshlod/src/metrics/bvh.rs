//! A bounding volume hierarchy over triangles for closest-point queries.
//!
//! Built top-down with the surface area heuristic evaluated on 16 centroid bins per
//! split (Wald, "On fast construction of SAH-based bounding volume hierarchies", 2007);
//! leaves hold at most [`LEAF_SIZE`] triangles. Nodes live in one flat `Vec`, children
//! side by side, triangles copied into leaf order for locality. A query descends the
//! nearer child first and prunes boxes farther than the best distance found so far
//! (branch and bound), optionally warm-started with a hint triangle, which makes
//! spatially coherent query streams (samples walked triangle by triangle) cheap.

use super::triangle::{closest_point, dist2, V3};

/// Most triangles in one leaf.
pub const LEAF_SIZE: usize = 4;
const BINS: usize = 16;

#[derive(Debug, Clone, Copy)]
struct Node {
    lo: [f32; 3],
    /// Leaf: first triangle (in leaf order). Inner: index of the left child (the right
    /// child follows it).
    first: u32,
    hi: [f32; 3],
    /// Number of triangles for a leaf, 0 for an inner node.
    count: u32,
}

impl Node {
    /// A blank root, before its range is split or made a leaf.
    const ROOT: Node = Node {
        lo: [0.0; 3],
        first: 0,
        hi: [0.0; 3],
        count: 0,
    };
}

/// The result of a closest-point query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// Squared distance from the query point.
    pub dist2: f64,
    /// The closest point.
    pub point: V3,
    /// Index of the triangle it lies on (in the mesh's numbering).
    pub triangle: u32,
}

/// Closest-point acceleration structure over a triangle list.
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Triangle corners in leaf order.
    tris: Vec<[[f32; 3]; 3]>,
    /// Mesh triangle index of each entry of `tris`.
    ids: Vec<u32>,
    /// Position of each mesh triangle in `tris` (for hints).
    slot_of: Vec<u32>,
}

/// A triangle while the tree is built: its centroid, its box and its id.
#[derive(Clone, Copy)]
struct Prim {
    centroid: [f32; 3],
    bounds: Aabb,
    id: u32,
}

#[derive(Clone, Copy)]
struct Aabb {
    lo: [f32; 3],
    hi: [f32; 3],
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: [f32::INFINITY; 3],
        hi: [f32::NEG_INFINITY; 3],
    };
    fn grow(&mut self, p: [f32; 3]) {
        for (k, &v) in p.iter().enumerate() {
            self.lo[k] = self.lo[k].min(v);
            self.hi[k] = self.hi[k].max(v);
        }
    }
    /// [`Self::grow`] with plain comparisons (the same result: a NaN coordinate is
    /// skipped by both, and the bounds start infinite, never NaN).
    #[inline(always)]
    fn grow_fast(&mut self, p: [f32; 3]) {
        for (k, &v) in p.iter().enumerate() {
            if v < self.lo[k] {
                self.lo[k] = v;
            }
            if v > self.hi[k] {
                self.hi[k] = v;
            }
        }
    }
    fn merge(&mut self, o: &Aabb) {
        for k in 0..3 {
            self.lo[k] = self.lo[k].min(o.lo[k]);
            self.hi[k] = self.hi[k].max(o.hi[k]);
        }
    }
    fn half_area(&self) -> f32 {
        let d = [
            (self.hi[0] - self.lo[0]).max(0.0),
            (self.hi[1] - self.lo[1]).max(0.0),
            (self.hi[2] - self.lo[2]).max(0.0),
        ];
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

impl Bvh {
    /// Builds the hierarchy over `triangles` of `positions`. O(n log n).
    ///
    /// # Panics
    /// Panics if a triangle index is out of range (validate the mesh first).
    #[must_use]
    pub fn build(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Self {
        let corners = corners_of(positions, triangles);
        let centroid = |c: &[[f32; 3]; 3]| -> [f32; 3] {
            std::array::from_fn(|k| (c[0][k] + c[1][k] + c[2][k]) * (1.0 / 3.0))
        };
        // Each triangle's centroid and box travel with it through the partitions,
        // so every pass over a range reads memory in order.
        let mut prims: Vec<Prim> = corners
            .iter()
            .enumerate()
            .map(|(t, c)| {
                let mut b = Aabb::EMPTY;
                c.iter().for_each(|&p| b.grow(p));
                Prim {
                    centroid: centroid(c),
                    bounds: b,
                    id: t as u32,
                }
            })
            .collect();
        let nodes = Self::build_range(&mut prims, 0, 0);
        let order: Vec<u32> = prims.iter().map(|p| p.id).collect();
        drop(prims);
        let tris: Vec<[[f32; 3]; 3]> = order.iter().map(|&t| corners[t as usize]).collect();
        Self::assemble(nodes, tris, order)
    }

    /// The nodes over `prims` (the triangles `base..` of the leaf order), root first;
    /// leaves index the whole leaf order, inner nodes this vector. Big ranges split
    /// once here and build their halves in parallel (the same tree as one thread
    /// builds: every split depends on its range alone).
    fn build_range(prims: &mut [Prim], base: usize, depth: u32) -> Vec<Node> {
        /// Ranges below this many triangles build on one thread.
        const PARALLEL: usize = 1 << 15;
        /// Levels split this way at most (2⁶ ranges: enough threads; deeper, a very
        /// uneven split would recurse instead of using the serial build's stack).
        const LEVELS: u32 = 6;
        let n = prims.len();
        if n < PARALLEL || depth >= LEVELS {
            return Self::build_serial(prims, base);
        }
        let (bounds, cbounds) = Self::range_bounds(prims);
        let mid = Self::sah_split(prims, &cbounds).unwrap_or(n / 2);
        let (left, right) = prims.split_at_mut(mid);
        let (mut l, mut r) = rayon::join(
            || Self::build_range(left, base, depth + 1),
            || Self::build_range(right, base + mid, depth + 1),
        );
        // Root, the two subtrees' roots side by side, then the rest of each subtree:
        // the left's node i ≥ 1 lands at i + 2, the right's at i + l.len() + 1.
        let shift = |sub: &mut [Node], by: u32| {
            sub.iter_mut()
                .filter(|nd| nd.count == 0)
                .for_each(|nd| nd.first += by);
        };
        shift(&mut l, 2);
        shift(&mut r, l.len() as u32 + 1);
        let mut nodes = Vec::with_capacity(l.len() + r.len() + 1);
        nodes.push(Node {
            lo: bounds.lo,
            first: 1,
            hi: bounds.hi,
            count: 0,
        });
        nodes.push(l[0]);
        nodes.push(r[0]);
        nodes.extend_from_slice(&l[1..]);
        drop(l);
        nodes.extend_from_slice(&r[1..]);
        nodes
    }

    /// The box of `prims` and the box of their centroids.
    fn range_bounds(prims: &[Prim]) -> (Aabb, Aabb) {
        let mut bounds = Aabb::EMPTY;
        let mut cbounds = Aabb::EMPTY;
        for p in prims {
            bounds.merge(&p.bounds);
            cbounds.grow(p.centroid);
        }
        (bounds, cbounds)
    }

    /// [`Self::build_range`] on one thread.
    fn build_serial(prims: &mut [Prim], base: usize) -> Vec<Node> {
        let n = prims.len();
        let mut nodes: Vec<Node> = Vec::with_capacity(2 * n / LEAF_SIZE + 1);
        nodes.push(Node::ROOT);
        // (node index, start, end) ranges still to split.
        let mut work = vec![(0usize, 0usize, n)];
        while let Some((ni, start, end)) = work.pop() {
            let (bounds, cbounds) = Self::range_bounds(&prims[start..end]);
            nodes[ni].lo = bounds.lo;
            nodes[ni].hi = bounds.hi;
            let count = end - start;
            let split = if count <= LEAF_SIZE {
                None
            } else {
                Self::sah_split(&mut prims[start..end], &cbounds)
            };
            match split {
                None if count <= LEAF_SIZE * 4 => {
                    nodes[ni].first = (base + start) as u32;
                    nodes[ni].count = count as u32;
                }
                found => {
                    // No useful SAH split (e.g. identical centroids) on a big range:
                    // split in the middle so leaves stay small.
                    let mid = start + found.unwrap_or(count / 2);
                    split_node(&mut nodes, &mut work, ni, start, mid, end);
                }
            }
        }
        nodes
    }

    /// The tree from its nodes, its triangles in leaf order and their mesh ids.
    fn assemble(nodes: Vec<Node>, tris: Vec<[[f32; 3]; 3]>, ids: Vec<u32>) -> Self {
        let mut slot_of = vec![0u32; ids.len()];
        for (slot, &t) in ids.iter().enumerate() {
            slot_of[t as usize] = slot as u32;
        }
        Self {
            nodes,
            tris,
            ids,
            slot_of,
        }
    }

    /// Builds the same kind of hierarchy in Morton order (a linear BVH, Lauterbach et
    /// al., "Fast BVH construction on GPUs", 2009): triangles sorted by the Morton code
    /// of their centroid (10 bits per axis), every range split where the highest bit
    /// of its codes changes. O(n log n) for the sort, then linear; several times
    /// cheaper to build than [`Self::build`], for a tree that answers the same
    /// queries exactly with somewhat more box tests (worth it when few queries follow).
    ///
    /// # Panics
    /// Panics if a triangle index is out of range (validate the mesh first).
    #[must_use]
    pub fn build_morton(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Self {
        // The AVX2 build where the CPU has it (`crate::isa`; same tree).
        crate::isa::dispatch!(Self::build_morton_impl(positions, triangles))
    }

    #[inline(always)]
    fn build_morton_impl(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Self {
        let n = triangles.len();
        // Centroids (times 3) and their bounds. (Plain loops into sized vectors: the
        // iterator collects here did not vectorise and cost ~60 instructions each.)
        let mut sums = vec![[0f32; 3]; n];
        let mut cb = Aabb::EMPTY;
        for (sum, t) in sums.iter_mut().zip(triangles) {
            let (a, b, c) = (
                positions[t[0] as usize],
                positions[t[1] as usize],
                positions[t[2] as usize],
            );
            *sum = [a[0] + b[0] + c[0], a[1] + b[1] + c[1], a[2] + b[2] + c[2]];
            cb.grow(*sum);
        }
        let scale: [f32; 3] = std::array::from_fn(|k| {
            let e = cb.hi[k] - cb.lo[k];
            if e > 0.0 && e.is_finite() {
                1023.0 / e
            } else {
                0.0
            }
        });
        let mut keys = vec![0u64; n];
        for (t, (key, c)) in keys.iter_mut().zip(&sums).enumerate() {
            // Out-of-range values clamp into the grid: `as` saturates (negative and
            // NaN give 0), the `min` caps at 1023.
            let q = |k: usize| -> u32 { (((c[k] - cb.lo[k]) * scale[k]) as u32).min(1023) };
            *key = (u64::from(crate::radix::morton3(q(0), q(1), q(2))) << 32) | t as u64;
        }
        drop(sums);
        crate::radix::sort_by_high_half(&mut keys);
        let code = |i: usize| (keys[i] >> 32) as u32;
        let mut nodes: Vec<Node> = Vec::with_capacity(3 * n / 4 + 1); // Morton leaves average ~2.8 triangles
        nodes.push(Node::ROOT);
        let mut work = vec![(0usize, 0usize, n)];
        while let Some((ni, start, end)) = work.pop() {
            let count = end - start;
            if count <= LEAF_SIZE {
                nodes[ni].first = start as u32;
                nodes[ni].count = count as u32;
                continue;
            }
            let (c0, c1) = (code(start), code(end - 1));
            let mid = if c0 == c1 {
                start + count / 2
            } else {
                // The first code with the highest differing bit set (codes sorted).
                let bit = 31 - (c0 ^ c1).leading_zeros();
                let (mut lo, mut hi) = (start + 1, end - 1);
                while lo < hi {
                    let m = lo + (hi - lo) / 2;
                    if code(m) >> bit & 1 == 1 {
                        hi = m;
                    } else {
                        lo = m + 1;
                    }
                }
                lo
            };
            split_node(&mut nodes, &mut work, ni, start, mid, end);
        }
        let order: Vec<u32> = keys.iter().map(|&k| k as u32).collect();
        let mut tris = vec![[[0f32; 3]; 3]; n];
        for (c, &k) in tris.iter_mut().zip(&order) {
            let t = &triangles[k as usize];
            *c = [
                positions[t[0] as usize],
                positions[t[1] as usize],
                positions[t[2] as usize],
            ];
        }
        drop(keys);
        // Bounds bottom-up: children always follow their parent.
        for ni in (0..nodes.len()).rev() {
            let nd = nodes[ni];
            let mut b = Aabb::EMPTY;
            if nd.count > 0 {
                let s = nd.first as usize;
                for t in &tris[s..s + nd.count as usize] {
                    t.iter().for_each(|&p| b.grow_fast(p));
                }
            } else if n > 0 {
                let l = nd.first as usize;
                for c in &nodes[l..l + 2] {
                    for k in 0..3 {
                        if c.lo[k] < b.lo[k] {
                            b.lo[k] = c.lo[k];
                        }
                        if c.hi[k] > b.hi[k] {
                            b.hi[k] = c.hi[k];
                        }
                    }
                }
            }
            nodes[ni].lo = b.lo;
            nodes[ni].hi = b.hi;
        }
        Self::assemble(nodes, tris, order)
    }

    /// Partitions `prims` by the best SAH bin boundary; returns the left count, or
    /// `None` when no split beats a leaf.
    fn sah_split(prims: &mut [Prim], cbounds: &Aabb) -> Option<usize> {
        let ext: [f32; 3] = std::array::from_fn(|k| cbounds.hi[k] - cbounds.lo[k]);
        let axis = (0..3)
            .max_by(|&a, &b| ext[a].total_cmp(&ext[b]))
            .unwrap_or(0);
        if ext[axis] <= 0.0 || !ext[axis].is_finite() {
            return None;
        }
        let scale = BINS as f32 / ext[axis];
        let bin_of = |p: &Prim| -> usize {
            let b = ((p.centroid[axis] - cbounds.lo[axis]) * scale) as usize;
            b.min(BINS - 1)
        };
        let mut bin_box = [Aabb::EMPTY; BINS];
        let mut bin_cnt = [0usize; BINS];
        for p in prims.iter() {
            let b = bin_of(p);
            bin_box[b].merge(&p.bounds);
            bin_cnt[b] += 1;
        }
        // Sweep: cost of splitting after bin i.
        let mut right_area = [0f32; BINS];
        let mut acc = Aabb::EMPTY;
        let mut acc_n = 0;
        let mut right_n = [0usize; BINS];
        for i in (1..BINS).rev() {
            acc.merge(&bin_box[i]);
            acc_n += bin_cnt[i];
            right_area[i] = acc.half_area();
            right_n[i] = acc_n;
        }
        let mut best = (f32::INFINITY, 0usize);
        let mut left = Aabb::EMPTY;
        let mut left_n = 0;
        for i in 0..BINS - 1 {
            left.merge(&bin_box[i]);
            left_n += bin_cnt[i];
            if left_n == 0 || right_n[i + 1] == 0 {
                continue;
            }
            let cost = left.half_area() * left_n as f32 + right_area[i + 1] * right_n[i + 1] as f32;
            if cost < best.0 {
                best = (cost, i);
            }
        }
        if !best.0.is_finite() {
            return None;
        }
        // Partition in place: bins <= best.1 to the left.
        let mut i = 0;
        let mut j = prims.len();
        while i < j {
            if bin_of(&prims[i]) <= best.1 {
                i += 1;
            } else {
                j -= 1;
                prims.swap(i, j);
            }
        }
        (i > 0 && i < prims.len()).then_some(i)
    }

    /// The corners of mesh triangle `triangle`, or `None` when it is not indexed.
    #[must_use]
    pub fn corners(&self, triangle: u32) -> Option<[V3; 3]> {
        let slot = *self.slot_of.get(triangle as usize)? as usize;
        let t = self.tris.get(slot)?;
        Some(t.map(|p| [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]))
    }

    /// Number of triangles indexed.
    #[must_use]
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when no triangle is indexed.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// The closest point to `p` on the mesh, or `None` for an empty mesh. `hint` is a
    /// triangle likely to be close (e.g. the answer of the previous, nearby query): it
    /// only speeds the search up: the distance is exact whatever it is. Where several
    /// triangles are equally near (two parts' faces lying on each other, a point
    /// above a shared edge) the one returned can depend on the hint, which tends to
    /// keep the tie on the hint's side (the hint is tested first, and a box only as
    /// near as the best so far is not opened); the same point and hint always give
    /// the same answer.
    #[must_use]
    pub fn closest(&self, p: V3, hint: Option<u32>) -> Option<Closest> {
        // The AVX2 build where the CPU has it (`crate::isa`; same bits).
        crate::isa::dispatch!(self.closest_impl(p, hint))
    }

    #[inline(always)]
    fn closest_impl(&self, p: V3, hint: Option<u32>) -> Option<Closest> {
        if self.tris.is_empty() {
            return None;
        }
        let mut best = Closest {
            dist2: f64::INFINITY,
            point: p,
            triangle: u32::MAX,
        };
        if let Some(h) = hint.filter(|&h| (h as usize) < self.slot_of.len()) {
            self.test_slot(p, self.slot_of[h as usize] as usize, &mut best);
        }
        let mut stack = NodeStack::new();
        let mut node = 0usize;
        loop {
            let nd = &self.nodes[node];
            if nd.count > 0 {
                let s = nd.first as usize;
                for slot in s..s + nd.count as usize {
                    self.test_slot(p, slot, &mut best);
                }
            } else {
                let (near, dn, far, df) = self.children_nearest_first(p, nd.first as usize);
                if dn < best.dist2 {
                    if df < best.dist2 {
                        stack.push(far);
                    }
                    node = near;
                    continue;
                }
            }
            // Pop the next box still worth visiting.
            loop {
                let Some(cand) = stack.pop() else {
                    return Some(best);
                };
                if box_dist2(p, &self.nodes[cand]) < best.dist2 {
                    node = cand;
                    break;
                }
            }
        }
    }

    /// Whether some triangle's squared distance to `p` (as [`Self::closest`] computes
    /// it) satisfies `near`, which must be monotone: `near(x)` and `y <= x` imply
    /// `near(y)`. Boxes whose distance fails `near` are skipped, the nearer child is
    /// opened first, and the walk stops at the first triangle found, so this is
    /// usually far cheaper than [`Self::closest`] and answers exactly
    /// `self.closest(p, _).is_some_and(|c| near(c.dist2))`. `hint` is tried first.
    #[must_use]
    pub fn any_near(&self, p: V3, hint: Option<u32>, near: impl Fn(f64) -> bool) -> bool {
        // The AVX2 build where the CPU has it (`crate::isa`; same bits).
        crate::isa::dispatch!(self.any_near_impl(p, hint, &near))
    }

    #[inline(always)]
    fn any_near_impl(&self, p: V3, hint: Option<u32>, near: &impl Fn(f64) -> bool) -> bool {
        let tri_d2 = |slot: usize| {
            let t = &self.tris[slot];
            let f = |v: [f32; 3]| [f64::from(v[0]), f64::from(v[1]), f64::from(v[2])];
            dist2(p, closest_point(p, f(t[0]), f(t[1]), f(t[2])).0)
        };
        if self.tris.is_empty() {
            return false;
        }
        if let Some(h) = hint.filter(|&h| (h as usize) < self.slot_of.len()) {
            if near(tri_d2(self.slot_of[h as usize] as usize)) {
                return true;
            }
        }
        // (The answer does not depend on the visiting order.)
        let mut stack = NodeStack::new();
        let mut node = 0usize;
        if !near(box_dist2(p, &self.nodes[0])) {
            return false;
        }
        loop {
            let nd = &self.nodes[node];
            if nd.count > 0 {
                let s = nd.first as usize;
                for slot in s..s + nd.count as usize {
                    if near(tri_d2(slot)) {
                        return true;
                    }
                }
            } else {
                let (near_c, dn, far_c, df) = self.children_nearest_first(p, nd.first as usize);
                if near(dn) {
                    if near(df) {
                        stack.push(far_c);
                    }
                    node = near_c;
                    continue;
                }
            }
            match stack.pop() {
                Some(c) => node = c,
                None => return false,
            }
        }
    }

    /// Calls `f(triangle, corners)` for every triangle whose bounding box overlaps the
    /// box `[lo, hi]` (mesh units), in leaf order, until `f` returns `false`. Returns
    /// `false` when `f` stopped the walk. O(log n + k) for k triangles found on a
    /// well-balanced tree.
    pub fn for_each_in_box(
        &self,
        lo: V3,
        hi: V3,
        mut f: impl FnMut(u32, &[[f32; 3]; 3]) -> bool,
    ) -> bool {
        if self.tris.is_empty() {
            return true;
        }
        let overlaps =
            |n: &Node| (0..3).all(|k| f64::from(n.lo[k]) <= hi[k] && f64::from(n.hi[k]) >= lo[k]);
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let nd = &self.nodes[i];
            if !overlaps(nd) {
                continue;
            }
            if nd.count > 0 {
                let s = nd.first as usize;
                for slot in s..s + nd.count as usize {
                    let t = &self.tris[slot];
                    let inside = (0..3).all(|k| {
                        let a = f64::from(t[0][k].min(t[1][k]).min(t[2][k]));
                        let b = f64::from(t[0][k].max(t[1][k]).max(t[2][k]));
                        a <= hi[k] && b >= lo[k]
                    });
                    if inside && !f(self.ids[slot], t) {
                        return false;
                    }
                }
            } else {
                let l = nd.first as usize;
                stack.push(l + 1);
                stack.push(l);
            }
        }
        true
    }

    /// The two children of the inner node whose first child is `l`, nearer first:
    /// `(near, its squared box distance, far, its squared box distance)`; on equal
    /// distances the left child comes first.
    #[inline(always)]
    fn children_nearest_first(&self, p: V3, l: usize) -> (usize, f64, usize, f64) {
        let (dl, dr) = (
            box_dist2(p, &self.nodes[l]),
            box_dist2(p, &self.nodes[l + 1]),
        );
        if dl <= dr {
            (l, dl, l + 1, dr)
        } else {
            (l + 1, dr, l, dl)
        }
    }

    #[inline(always)]
    fn test_slot(&self, p: V3, slot: usize, best: &mut Closest) {
        let t = &self.tris[slot];
        let f = |v: [f32; 3]| [f64::from(v[0]), f64::from(v[1]), f64::from(v[2])];
        let (q, _) = closest_point(p, f(t[0]), f(t[1]), f(t[2]));
        let d = dist2(p, q);
        if d < best.dist2 || (d == best.dist2 && self.ids[slot] < best.triangle) {
            *best = Closest {
                dist2: d,
                point: q,
                triangle: self.ids[slot],
            };
        }
    }
}

/// The three corners of every triangle.
fn corners_of(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<[[f32; 3]; 3]> {
    triangles
        .iter()
        .map(|t| t.map(|i| positions[i as usize]))
        .collect()
}

/// Turns node `ni` (range `start..end`) into an inner node whose two children, side
/// by side at the end of `nodes`, get `start..mid` and `mid..end`, queued in `work`.
#[inline(always)]
fn split_node(
    nodes: &mut Vec<Node>,
    work: &mut Vec<(usize, usize, usize)>,
    ni: usize,
    start: usize,
    mid: usize,
    end: usize,
) {
    let left = nodes.len();
    nodes.push(nodes[ni]);
    nodes.push(nodes[ni]);
    nodes[ni].first = left as u32;
    nodes[ni].count = 0;
    work.push((left + 1, mid, end));
    work.push((left, start, mid));
}

#[inline(always)]
fn box_dist2(p: V3, n: &Node) -> f64 {
    box_gap2(p, &n.lo.map(f64::from), &n.hi.map(f64::from))
}

/// Squared distance from `p` to the box `lo..hi` (0 inside).
#[inline(always)]
pub(crate) fn box_gap2(p: V3, lo: &V3, hi: &V3) -> f64 {
    // Branch-free: at most one of `lo − x` and `x − hi` is positive (`lo ≤ hi`), so
    // the sum is exactly the gap (or zero) of the branching form.
    let mut d = 0.0;
    for k in 0..3 {
        let e = (lo[k] - p[k]).max(0.0) + (p[k] - hi[k]).max(0.0);
        d += e * e;
    }
    d
}

/// The nodes still to visit in a tree walk: a fixed stack of 64, spilling to the
/// heap only on pathological depths (the walk stays exact either way). Last in,
/// first out, the spilled nodes first.
struct NodeStack {
    fixed: [u32; 64],
    len: usize,
    spill: Vec<u32>,
}

impl NodeStack {
    #[inline(always)]
    fn new() -> Self {
        Self {
            fixed: [0; 64],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline(always)]
    fn push(&mut self, node: usize) {
        if self.len < self.fixed.len() {
            self.fixed[self.len] = node as u32;
            self.len += 1;
        } else {
            self.spill.push(node as u32);
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<usize> {
        if let Some(c) = self.spill.pop() {
            Some(c as usize)
        } else if self.len > 0 {
            self.len -= 1;
            Some(self.fixed[self.len] as usize)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f32 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 40) as f32) / (1u64 << 24) as f32
    }

    /// A seeded soup of `n` separate unit-sized triangles in a 10-unit cube, and the
    /// generator's state after it.
    fn random_soup(seed: u64, n: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>, u64) {
        let mut s = seed;
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for t in 0..n {
            let c = [lcg(&mut s) * 10.0, lcg(&mut s) * 10.0, lcg(&mut s) * 10.0];
            for _ in 0..3 {
                positions.push([c[0] + lcg(&mut s), c[1] + lcg(&mut s), c[2] + lcg(&mut s)]);
            }
            triangles.push([3 * t, 3 * t + 1, 3 * t + 2]);
        }
        (positions, triangles, s)
    }

    /// The parallel build gives the serial build's tree: the same nodes in the same
    /// order (boxes bit for bit, children, leaves) and the same leaf order, on a soup
    /// big enough to split twice in parallel.
    #[test]
    fn parallel_build_is_the_serial_tree() {
        let (positions, triangles, _) = random_soup(7, 150_000);
        let prims = |ts: &[[u32; 3]]| -> Vec<Prim> {
            ts.iter()
                .enumerate()
                .map(|(t, tri)| {
                    let c = tri.map(|i| positions[i as usize]);
                    let mut b = Aabb::EMPTY;
                    c.iter().for_each(|&p| b.grow(p));
                    Prim {
                        centroid: std::array::from_fn(|k| (c[0][k] + c[1][k] + c[2][k]) / 3.0),
                        bounds: b,
                        id: t as u32,
                    }
                })
                .collect()
        };
        let (mut a, mut b) = (prims(&triangles), prims(&triangles));
        let par = Bvh::build_range(&mut a, 0, 0);
        let ser = Bvh::build_serial(&mut b, 0);
        assert!(par.len() > 3 && par[0].count == 0);
        // The serial build numbers nodes depth first in another order: compare the
        // trees by walking both from their roots.
        let mut stack = vec![(0usize, 0usize)];
        let mut seen = 0;
        while let Some((i, j)) = stack.pop() {
            let (x, y) = (par[i], ser[j]);
            seen += 1;
            assert_eq!(x.lo.map(f32::to_bits), y.lo.map(f32::to_bits));
            assert_eq!(x.hi.map(f32::to_bits), y.hi.map(f32::to_bits));
            assert_eq!(x.count, y.count);
            if x.count == 0 {
                let (l, r) = (x.first as usize, y.first as usize);
                stack.push((l, r));
                stack.push((l + 1, r + 1));
            } else {
                assert_eq!(x.first, y.first);
            }
        }
        assert_eq!(seen, par.len());
        assert_eq!(par.len(), ser.len());
        assert!(a.iter().zip(&b).all(|(p, q)| p.id == q.id));
    }

    /// The box query finds exactly the triangles whose boxes overlap the query box
    /// (brute force over a seeded soup), each once.
    #[test]
    fn box_query_equals_brute_force() {
        let (positions, triangles, mut s) = random_soup(12345, 2000);
        for bvh in [
            Bvh::build(&positions, &triangles),
            Bvh::build_morton(&positions, &triangles),
        ] {
            for _ in 0..50 {
                let lo = [0; 3].map(|_| f64::from(lcg(&mut s)) * 10.0);
                let hi = lo.map(|v| v + f64::from(lcg(&mut s)) * 3.0);
                let mut got = Vec::new();
                assert!(bvh.for_each_in_box(lo, hi, |t, _| {
                    got.push(t);
                    true
                }));
                // Stopping at the first triangle visits exactly one.
                let mut seen = 0;
                let full = bvh.for_each_in_box(lo, hi, |_, _| {
                    seen += 1;
                    false
                });
                assert_eq!((full, seen), (got.is_empty(), usize::from(!got.is_empty())));
                got.sort_unstable();
                let want: Vec<u32> = (0..triangles.len() as u32)
                    .filter(|&t| {
                        (0..3).all(|k| {
                            let v =
                                triangles[t as usize].map(|i| f64::from(positions[i as usize][k]));
                            v[0].min(v[1]).min(v[2]) <= hi[k] && v[0].max(v[1]).max(v[2]) >= lo[k]
                        })
                    })
                    .collect();
                assert_eq!(got, want);
            }
        }
    }

    /// Seeded random triangle soups: the BVH answer equals brute force over all
    /// triangles (same distance; same triangle unless two are equally close).
    #[test]
    fn bvh_equals_brute_force() {
        for seed0 in 0..6u64 {
            let mut s = seed0 * 7919 + 1;
            let n = [1usize, 3, 17, 100, 1000, 5000][seed0 as usize];
            let mut positions = Vec::new();
            let mut triangles = Vec::new();
            for t in 0..n {
                let c = [lcg(&mut s) * 10.0, lcg(&mut s) * 10.0, lcg(&mut s) * 10.0];
                for _ in 0..3 {
                    positions.push([
                        c[0] + lcg(&mut s) - 0.5,
                        c[1] + lcg(&mut s) - 0.5,
                        c[2] + (lcg(&mut s) - 0.5) * 0.1,
                    ]);
                }
                let b = 3 * t as u32;
                triangles.push([b, b + 1, b + 2]);
            }
            for bvh in [
                Bvh::build(&positions, &triangles),
                Bvh::build_morton(&positions, &triangles),
            ] {
                let mut hint = None;
                for _ in 0..300 {
                    let p = [
                        f64::from(lcg(&mut s)) * 12.0 - 1.0,
                        f64::from(lcg(&mut s)) * 12.0 - 1.0,
                        f64::from(lcg(&mut s)) * 12.0 - 1.0,
                    ];
                    let got = bvh.closest(p, hint).unwrap();
                    hint = Some(got.triangle);
                    let f = |v: [f32; 3]| [f64::from(v[0]), f64::from(v[1]), f64::from(v[2])];
                    let brute = triangles
                        .iter()
                        .map(|t| {
                            let (q, _) = closest_point(
                                p,
                                f(positions[t[0] as usize]),
                                f(positions[t[1] as usize]),
                                f(positions[t[2] as usize]),
                            );
                            dist2(p, q)
                        })
                        .fold(f64::INFINITY, f64::min);
                    assert_eq!(got.dist2, brute, "n={n} p={p:?}");
                }
            }
        }
    }

    /// `any_near` answers exactly what the closest point says, for thresholds just
    /// below, at and just above the nearest distance and random ones, with and
    /// without hints, on both builds.
    #[test]
    fn any_near_equals_closest() {
        let (positions, triangles, mut s) = random_soup(99, 3000);
        let mut yes = 0;
        let mut no = 0;
        for bvh in [
            Bvh::build(&positions, &triangles),
            Bvh::build_morton(&positions, &triangles),
        ] {
            for i in 0..400u32 {
                let p = [0; 3].map(|_| f64::from(lcg(&mut s)) * 12.0 - 1.0);
                let best = bvh.closest(p, None).unwrap().dist2;
                let hint = (i % 2 == 0).then_some(i % 3000);
                for r in [
                    best * (1.0 - 1e-12),
                    best,
                    best * (1.0 + 1e-12),
                    f64::from(lcg(&mut s)) * 4.0,
                ] {
                    let want = best < r;
                    assert_eq!(bvh.any_near(p, hint, |d| d < r), want, "p={p:?} r={r}");
                    if want {
                        yes += 1;
                    } else {
                        no += 1;
                    }
                }
            }
        }
        assert!(yes > 100 && no > 100, "{yes} {no}");
    }

    #[test]
    fn empty_and_identical_centroids() {
        assert!(Bvh::build(&[], &[]).closest([0.0; 3], None).is_none());
        assert!(Bvh::build_morton(&[], &[])
            .closest([0.0; 3], None)
            .is_none());
        // 100 copies of one triangle: no SAH split exists; the build must still end.
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let triangles = vec![[0, 1, 2]; 100];
        for bvh in [
            Bvh::build(&positions, &triangles),
            Bvh::build_morton(&positions, &triangles),
        ] {
            let c = bvh.closest([0.25, 0.25, 2.0], None).unwrap();
            assert!((c.dist2 - 4.0).abs() < 1e-12);
            assert_eq!(c.triangle, 0);
        }
    }
}
