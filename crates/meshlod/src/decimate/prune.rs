//! Removing separate parts whole ([`super::edge_collapse::EdgeCollapseOptions::prune_parts`]).
//!
//! A mesh of many parts (a CAD assembly, a scene, a scan with floating specks)
//! cannot reach a low triangle count while every part keeps its smallest shape
//! (a closed part at least a tetrahedron, an open one a triangle). Edge
//! collapses never remove a part, so parts are removed whole, each at an error
//! that stands for what its removal costs a viewer: the largest distance from
//! its points to the rest of the surface, i.e. the one-sided Hausdorff distance
//! from the input there to the output once the part is gone (the rest measured
//! where it was at the start, which the simplification keeps within its error).
//! Not the part's own size: five fingers, each a small part, are far from the
//! arm once all five are gone, and a thin blade has a small area but a long
//! reach. Removing a part only raises the others' errors, so the queue holds
//! lower bounds, recomputed when they come up (lazy, as the collapse queue).
//!
//! The part of the largest radius (half its bounding box's diagonal) is never
//! removed. Like meshoptimizer's `meshopt_SimplifyPrune` in spirit (parts below
//! the error go); the error here is measured against the rest of the surface,
//! not taken from the part's size.

use super::{Outcome, StopRule};
use crate::collapse::{Surface, DEAD};
use crate::metrics::bvh::{box_gap2, Bvh};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Triangles of a part sampled for its removal error, at most (spread over its
/// triangles): seven points each, its corners, the middles of its edges and its
/// centroid.
const SAMPLED_TRIANGLES: usize = 32;

/// The separate parts of a surface that may be removed whole, queued by their
/// removal error (module docs).
pub(super) struct Parts {
    /// The points of every part, part after part (at the start).
    points: Vec<u32>,
    /// Per part: the range of its points in `points`.
    ranges: Vec<(usize, usize)>,
    /// Points on every part's surface (at the start), part after part, whose
    /// distances to the rest make its removal error.
    samples: Vec<[f64; 3]>,
    /// Per part: the range of its samples in `samples`.
    sample_ranges: Vec<(usize, usize)>,
    /// Per part: the samples (indices into `samples`) of removed parts whose
    /// nearest surface is this part's: they move to another once it goes too.
    carried: Vec<Vec<u32>>,
    /// Per part: removed, or passed over for good (above the maximum error, or
    /// its removal would land too far below the target); the main part too.
    done: Vec<bool>,
    /// Per part: removed.
    removed: Vec<bool>,
    /// Every part's surface at the start, for distances between parts.
    index: PartIndex,
    /// `(lower bound of the removal error's bits, part)`, smallest first.
    queue: BinaryHeap<Reverse<(u64, u32)>>,
}

impl Parts {
    /// The parts of `surface`'s live triangles, or `None` when there is only one.
    /// O(n log n).
    pub(super) fn new(surface: &Surface) -> Option<Self> {
        let np = surface.point_count();
        let mut uf = surface.point_components();
        let mut keyed: Vec<(u32, u32)> = (0..np as u32)
            .filter(|&p| surface.is_alive(p))
            .map(|p| (uf.find(p), p))
            .collect();
        keyed.sort_unstable();
        // Part ids in order of their smallest point's root; per root its id.
        let mut part_of_root = vec![u32::MAX; np];
        let mut ranges = Vec::new();
        let mut radius = Vec::new();
        let mut s = 0;
        while s < keyed.len() {
            let mut e = s;
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            while e < keyed.len() && keyed[e].0 == keyed[s].0 {
                let q = surface.position(keyed[e].1);
                for k in 0..3 {
                    lo[k] = lo[k].min(f64::from(q[k]));
                    hi[k] = hi[k].max(f64::from(q[k]));
                }
                e += 1;
            }
            part_of_root[keyed[s].0 as usize] = ranges.len() as u32;
            let d = crate::quadric::sub(hi, lo);
            radius.push(0.5 * crate::quadric::dot(d, d).sqrt());
            ranges.push((s, e));
            s = e;
        }
        if ranges.len() < 2 {
            return None;
        }
        let points: Vec<u32> = keyed.iter().map(|k| k.1).collect();
        // The main part: the largest radius (ties: the first).
        let main = (0..ranges.len())
            .reduce(|b, i| if radius[i] > radius[b] { i } else { b })
            .unwrap_or(0);
        let positions: Vec<[f32; 3]> = (0..np as u32).map(|p| surface.position(p)).collect();
        let mut tri_part = vec![u32::MAX; surface.triangle_slots()];
        let mut triangles = Vec::with_capacity(surface.live_triangles());
        for t in 0..surface.triangle_slots() as u32 {
            let tt = surface.triangle(t);
            if tt[0] != DEAD {
                tri_part[t as usize] = part_of_root[uf.find(tt[0]) as usize];
            }
            // (Dead slots keep the numbering; `tri_part` leaves them out.)
            triangles.push(tt);
        }
        let n = ranges.len();
        let (samples, sample_ranges, index) = sample_parts(&positions, &triangles, &tri_part, n);
        let mut parts = Self {
            points,
            ranges,
            samples,
            sample_ranges,
            carried: vec![Vec::new(); n],
            done: vec![false; n],
            removed: vec![false; n],
            index,
            queue: BinaryHeap::with_capacity(n),
        };
        parts.done[main] = true;
        for i in 0..n as u32 {
            if i as usize != main {
                let e = parts.error(i);
                parts.queue.push(Reverse((e.to_bits(), i)));
            }
        }
        Some(parts)
    }

    /// The closest point to `x` on the parts not removed but `i`: its squared
    /// distance and part; `None` when there is none.
    fn nearest_other(&self, x: [f64; 3], i: u32) -> Option<(f64, u32)> {
        self.index
            .nearest(x, |q| q == i || self.removed[q as usize])
    }

    /// Part `i`'s removal error now: the largest distance (mesh units) from its
    /// samples, and from those of removed parts it carries, to the surface of
    /// the parts not removed but `i` (∞ when there is none).
    fn error(&self, i: u32) -> f64 {
        self.error_up_to(i, f64::INFINITY).0
    }

    /// [`Self::error`], stopping at the first sample farther than `bound`:
    /// `(error, true)`, or `(a lower bound above bound, false)`.
    fn error_up_to(&self, i: u32, bound: f64) -> (f64, bool) {
        let (s, e) = self.sample_ranges[i as usize];
        let carried = self.carried[i as usize].iter().map(|&k| k as usize);
        let bound2 = bound * bound;
        let mut far = 0.0f64;
        for k in (s..e).chain(carried) {
            match self.nearest_other(self.samples[k], i) {
                Some((d2, _)) => {
                    far = far.max(d2);
                    if far > bound2 {
                        return (far.sqrt(), false);
                    }
                }
                None => return (f64::INFINITY, false),
            }
        }
        (far.sqrt(), true)
    }

    /// The live triangles of part `i`: each has its three corners in it.
    fn triangles(&self, surface: &Surface, i: u32) -> usize {
        let (s, e) = self.ranges[i as usize];
        self.points[s..e]
            .iter()
            .map(|&p| surface.fan(p).len())
            .sum::<usize>()
            / 3
    }

    /// The cheapest part not done, with its exact removal error (lower bounds
    /// recomputed as they come up); `None` when every part is done or the
    /// cheapest error is above `bound`.
    fn cheapest(&mut self, bound: f64) -> Option<(u32, f64)> {
        while let Some(&Reverse((bits, i))) = self.queue.peek() {
            if f64::from_bits(bits) > bound {
                return None;
            }
            self.queue.pop();
            if self.done[i as usize] {
                continue;
            }
            // Only whether it is within `bound` matters now: a sample beyond it
            // is a new lower bound.
            let (exact, complete) = self.error_up_to(i, bound);
            if !complete || exact.to_bits() > bits {
                self.queue.push(Reverse((exact.to_bits().max(bits), i)));
                continue;
            }
            return Some((i, exact));
        }
        None
    }

    /// Removes part `i` (exact error `error`) from `surface` unless its error is
    /// above the maximum or its removal would land more than 1% (at least one
    /// triangle) below the target; either way it is done. Returns whether it
    /// was removed.
    fn remove(
        &mut self,
        surface: &mut Surface,
        version: &mut [u32],
        i: u32,
        error: f64,
        stop: &StopRule,
        out: &mut Outcome,
    ) -> bool {
        self.done[i as usize] = true;
        if stop.max_error.is_some_and(|me| error > me) {
            return false;
        }
        let triangles = self.triangles(surface, i);
        let slack = stop.target_triangles.div_ceil(100).max(1);
        let left = surface.live_triangles().saturating_sub(triangles);
        if triangles == 0 || left + slack < stop.target_triangles {
            return false;
        }
        let (s, e) = self.ranges[i as usize];
        surface.remove_part(&self.points[s..e]);
        // Their queued pairs go stale (the sweep keeps entries by stamp).
        for &p in &self.points[s..e] {
            version[p as usize] = version[p as usize].wrapping_add(1);
        }
        self.removed[i as usize] = true;
        // Its samples and those it carried now measure against the parts left:
        // each goes to the part nearest it, whose removal error it raises.
        let (a, b) = self.sample_ranges[i as usize];
        let mut moved = std::mem::take(&mut self.carried[i as usize]);
        moved.extend(a as u32..b as u32);
        for k in moved {
            if let Some((_, q)) = self.nearest_other(self.samples[k as usize], i) {
                // A part that stays (the main one, or passed over) never
                // needs its error again.
                if !self.done[q as usize] {
                    self.carried[q as usize].push(k);
                }
            }
        }
        out.components_removed += 1;
        out.max_error = out.max_error.max(error);
        true
    }

    /// Before a collapse of error `error` (mesh units): removes every part whose
    /// removal error is at or below it. Returns whether any part was done.
    pub(super) fn remove_below(
        &mut self,
        surface: &mut Surface,
        version: &mut [u32],
        error: f64,
        stop: &StopRule,
        out: &mut Outcome,
    ) -> bool {
        let mut any = false;
        while let Some((i, e)) = self.cheapest(error) {
            self.remove(surface, version, i, e, stop, out);
            any = true;
        }
        any
    }

    /// When no collapse is left above the target: removes parts, cheapest first,
    /// until the target is reached, if removing all of them would reach it;
    /// otherwise none (a large part for a few triangles is a poor trade).
    /// Returns whether any was removed.
    pub(super) fn remove_to_target(
        &mut self,
        surface: &mut Surface,
        version: &mut [u32],
        stop: &StopRule,
        out: &mut Outcome,
    ) -> bool {
        let target = stop.target_triangles;
        let removable: usize = (0..self.ranges.len() as u32)
            .filter(|&i| !self.done[i as usize])
            .map(|i| self.triangles(surface, i))
            .sum();
        if surface.live_triangles().saturating_sub(removable) > target {
            return false;
        }
        let mut any = false;
        while surface.live_triangles() > target {
            let Some((i, e)) = self.cheapest(f64::INFINITY) else {
                break;
            };
            any |= self.remove(surface, version, i, e, stop, out);
        }
        any
    }
}

/// Samples of every part's surface ([`SAMPLED_TRIANGLES`] triangles of each at
/// most, spread over its triangles) and the index of their surfaces:
/// `(samples, per part its range, index)`.
fn sample_parts(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    tri_part: &[u32],
    n: usize,
) -> (Vec<[f64; 3]>, Vec<(usize, usize)>, PartIndex) {
    // The triangles of each part, part after part (counting sort).
    let mut start = vec![0usize; n + 1];
    for &q in tri_part.iter().filter(|&&q| q != u32::MAX) {
        start[q as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut by_part = vec![0u32; start[n]];
    for (t, &q) in tri_part.iter().enumerate() {
        if q != u32::MAX {
            by_part[fill[q as usize]] = t as u32;
            fill[q as usize] += 1;
        }
    }
    let mut samples = Vec::new();
    let mut ranges = Vec::with_capacity(n);
    let mut bvhs = Vec::with_capacity(n);
    for i in 0..n {
        let ts = &by_part[start[i]..start[i + 1]];
        let own: Vec<[u32; 3]> = ts.iter().map(|&t| triangles[t as usize]).collect();
        bvhs.push(Bvh::build(positions, &own));
        let s = samples.len();
        for &t in ts
            .iter()
            .step_by(ts.len().div_ceil(SAMPLED_TRIANGLES).max(1))
        {
            let c = triangles[t as usize].map(|p| positions[p as usize].map(f64::from));
            let mid = |a: [f64; 3], b: [f64; 3]| {
                [
                    0.5 * (a[0] + b[0]),
                    0.5 * (a[1] + b[1]),
                    0.5 * (a[2] + b[2]),
                ]
            };
            let centroid = [
                (c[0][0] + c[1][0] + c[2][0]) / 3.0,
                (c[0][1] + c[1][1] + c[2][1]) / 3.0,
                (c[0][2] + c[1][2] + c[2][2]) / 3.0,
            ];
            samples.extend([
                c[0],
                c[1],
                c[2],
                mid(c[0], c[1]),
                mid(c[1], c[2]),
                mid(c[2], c[0]),
                centroid,
            ]);
        }
        // A point shared by several sampled triangles once (the largest
        // distance is the same).
        let part = &mut samples[s..];
        part.sort_unstable_by(|a, b| {
            a[0].total_cmp(&b[0])
                .then(a[1].total_cmp(&b[1]))
                .then(a[2].total_cmp(&b[2]))
        });
        let kept = dedup_len(part);
        samples.truncate(s + kept);
        ranges.push((s, samples.len()));
    }
    (samples, ranges, PartIndex::new(bvhs))
}

/// Moves the distinct points of the sorted `points` to its front; returns how
/// many there are.
fn dedup_len(points: &mut [[f64; 3]]) -> usize {
    let mut w = 0;
    for r in 0..points.len() {
        if w == 0 || points[r] != points[w - 1] {
            points[w] = points[r];
            w += 1;
        }
    }
    w
}

/// Closest points on the parts' surfaces, leaving some parts out: a tree of
/// the parts' bounding boxes over one closest-point tree per part, so a part
/// left out costs nothing (a query from a part's own surface does not walk past
/// its own triangles, as it would in one tree of all of them).
struct PartIndex {
    /// Per part, its triangles.
    bvhs: Vec<Bvh>,
    /// Per part, its bounding box (`lo`, `hi`).
    boxes: Vec<([f64; 3], [f64; 3])>,
    /// Tree nodes: a box and either two children (`left`, `left + 1`) or a leaf
    /// range of `order`.
    nodes: Vec<BoxNode>,
    /// The parts, in leaf order.
    order: Vec<u32>,
}

/// A node of [`PartIndex`]'s tree.
struct BoxNode {
    lo: [f64; 3],
    hi: [f64; 3],
    /// First child (inner node) or first entry of `order` (leaf).
    first: usize,
    /// Entries of a leaf, 0 for an inner node.
    count: usize,
}

/// Parts per leaf of [`PartIndex`]'s tree, at most.
const PARTS_PER_LEAF: usize = 4;

/// Squared distance from `x` to the box `[lo, hi]` (0 inside).
impl PartIndex {
    /// The index of parts whose triangles are in `bvhs` (an empty part gets an
    /// empty box and is never found). O(n log n) in the parts.
    fn new(bvhs: Vec<Bvh>) -> Self {
        let boxes: Vec<([f64; 3], [f64; 3])> = bvhs
            .iter()
            .map(|b| {
                let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for t in 0..b.len() as u32 {
                    for c in b.corners(t).into_iter().flatten() {
                        for k in 0..3 {
                            lo[k] = lo[k].min(c[k]);
                            hi[k] = hi[k].max(c[k]);
                        }
                    }
                }
                (lo, hi)
            })
            .collect();
        let mut order: Vec<u32> = (0..bvhs.len() as u32)
            .filter(|&i| !bvhs[i as usize].is_empty())
            .collect();
        let mut nodes = vec![BoxNode {
            lo: [0.0; 3],
            hi: [0.0; 3],
            first: 0,
            count: 0,
        }];
        // Split ranges of `order` at the median centre along their longest axis.
        let mut work = vec![(0usize, 0usize, order.len())];
        while let Some((ni, s, e)) = work.pop() {
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for &i in &order[s..e] {
                let (a, b) = boxes[i as usize];
                for k in 0..3 {
                    lo[k] = lo[k].min(a[k]);
                    hi[k] = hi[k].max(b[k]);
                }
            }
            nodes[ni].lo = lo;
            nodes[ni].hi = hi;
            if e - s <= PARTS_PER_LEAF {
                nodes[ni].first = s;
                nodes[ni].count = e - s;
                continue;
            }
            let axis = (0..3)
                .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
                .unwrap_or(0);
            let centre = |i: u32| boxes[i as usize].0[axis] + boxes[i as usize].1[axis];
            let mid = s + (e - s) / 2;
            order[s..e].select_nth_unstable_by(mid - s, |&a, &b| {
                centre(a).total_cmp(&centre(b)).then(a.cmp(&b))
            });
            let left = nodes.len();
            for _ in 0..2 {
                nodes.push(BoxNode {
                    lo: [0.0; 3],
                    hi: [0.0; 3],
                    first: 0,
                    count: 0,
                });
            }
            nodes[ni].first = left;
            work.push((left, s, mid));
            work.push((left + 1, mid, e));
        }
        Self {
            bvhs,
            boxes,
            nodes,
            order,
        }
    }

    /// The closest point to `x` on the parts for which `skip` is false: its
    /// squared distance and part; `None` when there is none.
    fn nearest(&self, x: [f64; 3], skip: impl Fn(u32) -> bool) -> Option<(f64, u32)> {
        let mut best: Option<(f64, u32)> = None;
        let bound = |b: &Option<(f64, u32)>| b.map_or(f64::INFINITY, |b| b.0);
        // A depth-first walk holds at most one pending sibling per level: the
        // tree's depth (≤ 64 for any count of parts) bounds the stack, so it
        // lives on the call stack (no allocation per query).
        let mut stack = [0usize; 2 * 64];
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let ni = stack[len];
            let nd = &self.nodes[ni];
            if box_gap2(x, &nd.lo, &nd.hi) >= bound(&best) {
                continue;
            }
            if nd.count > 0 {
                for &q in &self.order[nd.first..nd.first + nd.count] {
                    let (lo, hi) = &self.boxes[q as usize];
                    if skip(q) || box_gap2(x, lo, hi) >= bound(&best) {
                        continue;
                    }
                    if let Some(c) = self.bvhs[q as usize].closest(x, None) {
                        if c.dist2 < bound(&best) {
                            best = Some((c.dist2, q));
                        }
                    }
                }
            } else {
                // The nearer child last, so it is opened first.
                let (l, r) = (nd.first, nd.first + 1);
                let dl = box_gap2(x, &self.nodes[l].lo, &self.nodes[l].hi);
                let dr = box_gap2(x, &self.nodes[r].lo, &self.nodes[r].hi);
                let (first, second) = if dl <= dr { (r, l) } else { (l, r) };
                stack[len] = first;
                stack[len + 1] = second;
                len += 2;
            }
        }
        best
    }
}
