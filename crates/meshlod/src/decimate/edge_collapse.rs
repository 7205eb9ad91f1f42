//! The edge-collapse driver: a priority queue of pair contractions with lazy
//! invalidation.
//!
//! 1. Every edge (and every extra non-edge pair) is evaluated by the cost model and
//!    queued by cost; ties are broken by point ids, so runs are deterministic.
//!    A flat pair, one whose key is zero in `f32` (a collapse within a plane), is
//!    keyed by its length instead, below every other key: flat regions then
//!    coarsen evenly, shortest edges first. In arbitrary order a point near the
//!    last collapse kept swallowing its neighbours, its fan grew, and most of the
//!    collapses tried around it folded a triangle over and were tried again after
//!    every change nearby: on the Grand Canyon grids (8-bit heights, so wide flat
//!    terraces) the rejections per collapse grew with the grid, 1.0 at 4.2M
//!    triangles, 2.2 at 16.8M, 7.0 at 67M, and the run's time with them. Keyed by
//!    length: 0.9 at 16.8M and 1.2 at 67M; the 67M grid at 10% took 168 s instead
//!    of 355 s (`docs/benchmarks.md`, "QEM at scale").
//! 2. The cheapest entry is popped. Entries carry a stamp of their points' versions
//!    and are dropped when stale. The candidate is re-evaluated (its position is not
//!    stored), checked against the maximum error, the operator's legality and the
//!    filters, and performed.
//!    Just before performing it, the cost model may raise its priority
//!    ([`CostModel::confirm`], for a check too costly to run at every evaluation);
//!    if it does, the candidate is queued again at the higher cost (lazy keys).
//! 3. The survivor's version is bumped and its pairs are re-queued: O(valence) work
//!    per collapse.
//!    When a merged placement would fold a triangle over, the same pair is queued
//!    again restricted to half-edge collapses onto either end, at that cost.
//! 4. A pair rejected by a check that depends on its neighbourhood (link
//!    condition, fold-over, degenerate or duplicate result, a non-manifold edge, a
//!    non-edge pair's shared neighbours, a filter) is dropped but remembered: a later collapse next to it may make it legal
//!    without touching its own points, so nothing would queue it again. Once the
//!    popped cost exceeds `RETRY_GROWTH` times the cheapest remembered pair's (and
//!    that factor times the cost at the previous retry), the remembered pairs are
//!    evaluated and queued again before the pop goes on. Without this, a pair
//!    blocked at cost 10⁻¹⁴ stayed out while collapses costing 12% of the diagonal
//!    went ahead (Hoppe's club at 1%, `docs/methods/qem.md`). A pair rejected again at a retry is
//!    counted again in the report's rejections.
//! 5. A soft filter (the sliver guard) does not veto: a collapse it refuses is
//!    queued again at `SOFT_PENALTY` times its cost and performed when it comes
//!    up at that key.
//! 6. When the queue runs dry before the target, all pairs are queued again (pairs
//!    rejected earlier may have become legal). A re-scan that performs nothing ends
//!    the run.
//!
//! # Memory latency
//! On a mesh larger than the cache, each pop would wait on a chain of dependent
//! cache misses: the pair's point records, then their fans, then the fans'
//! triangles, then the corners' positions. The loop therefore starts loading the
//! *next* pop (most likely the queue's top) one stage per step of an iteration that
//! collapses, as hardware prefetches: the point records right after the pop, the
//! fans after the legality check, the triangles after the re-queue, the positions
//! after the next pop. Nothing waits for a prefetch itself, but each stage reads
//! what the previous one loaded to find its addresses (and waits if it has not
//! arrived); a pop that does not collapse (stale, rejected) starts only the first
//! stage. The points whose pairs a collapse re-queues are prefetched as soon as the
//! check has accepted it, so their loads overlap the filters and the collapse.
//! None of this changes a result (the output meshes and reports are byte for byte
//! those without it); it cut the time of a run by 15–27% on 70k–200k-triangle
//! meshes and by 6–15% on a 3.2M-triangle one (2026-12-02, commit history), for
//! 3–4% more instructions.

use super::heap::{Heap, Item};
use super::prune::Parts;
use super::{Observer, Outcome, Rejections, StopReason, StopRule};
use crate::collapse::DEAD;
use crate::collapse::{Merge, Moves, OperatorLimits, Preview, Reject, Surface};
use crate::cost::{Candidate, CostModel};
use crate::filter::Filter;
use crate::quadric::{dot, sub};

/// Settings of [`run`].
#[derive(Debug, Clone, Default)]
pub struct EdgeCollapseOptions {
    /// Limits of the operator's geometric checks (and whether non-edge pairs may be
    /// contracted).
    pub limits: OperatorLimits,
    /// When to stop.
    pub stop: StopRule,
    /// Extra non-edge pairs to consider (point ids), e.g. from
    /// [`crate::simplify::SimplifyOptions::pair_threshold`].
    pub extra_pairs: Vec<[u32; 2]>,
    /// Whether separate parts (connected components) may be removed whole
    /// (see `decimate/prune.rs`), at an error of the largest distance from their points
    /// to the rest of the surface: a part goes before a collapse of a larger
    /// error, and when no collapse is left above the target, parts go cheapest
    /// first if that reaches the target. The part of the largest radius is never
    /// removed, nor one above the maximum error or whose removal would land more
    /// than 1% below the target.
    /// Not with non-edge pairs (they join parts).
    pub prune_parts: bool,
}

/// Pairs rejected by a check that depends on their neighbourhood (every legality
/// rejection but a point's kind and a UV seam, and every filter veto) are retried
/// (re-evaluated and queued again) once the popped cost exceeds this many times the
/// cheapest of them and this many times the popped cost at the previous retry (so
/// at most about `log₄` of the cost range retries between re-scans: 5–12 a run on
/// the shared meshes that reach their target without a re-scan, up to 84 on those
/// that re-scan). The threshold only rises between re-scans: where a cost
/// model raises keys far above the plain costs ([`CostModel::confirm`]: Melax's
/// facing tiers, QEM's opt-in displacement guard) or a key is infinite, later
/// rejections at plain costs wait for a 4-fold rise of those keys or for the next
/// re-scan. Measured
/// against 2 and 16 on the shared meshes at 10% and 1% (2026-12-02, docs/methods/qem.md): all
/// three lower the Hausdorff maximum and mean by 7–11% on geometric average; 4 is
/// nearer the exact greedy order than 16 and, unlike 16, keeps the cow at 1% within
/// the facing-away bound of `tests/simplify_shared.rs`.
const RETRY_GROWTH: f32 = 4.0;
/// A collapse that a soft filter refuses (the sliver guard,
/// [`crate::filter::AspectRatio`]) is queued again at this many times its cost
/// and performed when it comes up at that key: the filter ranks collapses instead
/// of vetoing them. As a veto (a refused pair waited for a retry or a re-scan, and
/// was refused again until the queue ran dry and the filter was switched off), a
/// terrain lost most of its shape before any sliver was allowed: the 262,144-triangle
/// Grand Canyon grid at 1% had a Hausdorff distance of 14.4% of its diagonal and a
/// mean of 1.08% (meshoptimizer 3.2% and 0.18%); at 16× the cost, 3.4% and 0.17%.
/// On the benchmark meshes (bunny, fandisk, armadillo, Lucy, turbine blade,
/// Nefertiti at 10% and 1%) 16 left every cell within ±1% but fandisk 1% (mean
/// +8.5%, a cell that moves by ±50% with any change of order) and the turbine
/// blade 1% (mean +3.5%, maximum −13.5%); 4 and 64 gave the same on the terrain,
/// 4 lost Lucy's torch tip at 1% (maximum +17%). Measured 2026-12-05,
/// `docs/benchmarks.md`.
const SOFT_PENALTY: f64 = 16.0;
/// Full re-scans allowed after the queue runs dry.
const MAX_RESCANS: usize = 8;
/// Queue entries allowed beyond two per live triangle before stale ones are swept.
const STALE_SLACK: usize = 4096;
/// Collapses between progress callbacks.
const PROGRESS_EVERY: usize = 4096;

/// Queue keys whose bits are below this, keys below `f32`'s smallest normal number
/// (1.2·10⁻³⁸; a key is the cost over a power of the diagonal, so such a cost is
/// zero for any practical purpose), are flat: replaced by [`flat_bits`] of the
/// pair's length.
const FLAT_BITS: u32 = 0x0080_0000;

/// The key bits of a flat pair whose squared length is the fraction `l2` of the
/// squared diagonal: non-decreasing in `l2` and below [`FLAT_BITS`], so flat pairs
/// come before every other and the shortest first.
fn flat_bits(l2: f64) -> u32 {
    let x = if l2 >= 0.0 { l2.min(1.0) as f32 } else { 0.0 };
    // Positive floats order as their bits; 1.0 is 0x3f80_0000, so the shifted
    // bits stay below 0x0040_0000.
    x.to_bits() >> 8
}

/// `2^(−power·k)` with `2^k` the power of two nearest `diagonal` (1 for an empty or
/// non-finite diagonal): multiplying by it is exact in floating point.
fn key_scale(power: i32, diagonal: f64) -> f64 {
    if !(diagonal.is_finite() && diagonal > 0.0) || power == 0 {
        return 1.0;
    }
    let k = diagonal.log2().round().clamp(-200.0, 200.0) as i32;
    let e = (-power * k).clamp(-1000, 1000);
    2f64.powi(e)
}

struct Driver<'a, C: CostModel + ?Sized> {
    surface: &'a mut Surface,
    cost: &'a mut C,
    filters: &'a [&'a dyn Filter],
    limits: OperatorLimits,
    version: Vec<u32>,
    heap: Heap,
    /// Factor from costs to queue keys ([`CostModel::cost_length_power`]).
    key_scale: f64,
    /// Factor from squared lengths to fractions of the squared diagonal (exact, a
    /// power of two), for the keys of flat pairs.
    length_scale: f64,
    partners: Vec<Vec<u32>>,
    forward: Vec<u32>,
    scratch: Vec<u32>,
}

impl<C: CostModel + ?Sized> Driver<'_, C> {
    /// Stamp of an entry for `(a, b)`: the sum of the versions, shifted, with the
    /// low bit saying "endpoint placement only" (a fallback entry).
    #[inline]
    fn stamp(&self, a: u32, b: u32, endpoint_only: bool) -> u32 {
        (self.version[a as usize].wrapping_add(self.version[b as usize]) << 1)
            | u32::from(endpoint_only)
    }

    /// The moves of `(a, b)`, restricted to half-edge collapses for a fallback entry.
    #[inline(always)]
    fn moves(&self, a: u32, b: u32, endpoint_only: bool) -> Option<Moves> {
        let mut m = self.surface.moves(a, b, self.limits.allow_non_edge)?;
        if endpoint_only {
            if !(m.a_to_b || m.b_to_a) {
                return None;
            }
            m.merge = Merge::No;
        }
        Some(m)
    }

    /// The queue entry of `(a, b)` given `pa = surface.local(a)` (a caller queueing
    /// all pairs of `a` converts it once).
    #[inline(always)]
    fn entry_at(&self, a: u32, pa: [f64; 3], b: u32, endpoint_only: bool) -> Option<Item> {
        let m = self.moves(a, b, endpoint_only)?;
        let c = self.cost.evaluate_cost_near(self.surface, a, pa, b, &m)?;
        let mut item = Item {
            a,
            b,
            stamp: self.stamp(a, b, endpoint_only),
            cost_bits: 0,
        }
        .with_cost(c * self.key_scale);
        if item.cost_bits < FLAT_BITS {
            // A flat pair: shortest first (module docs, step 1).
            let d = sub(pa, self.surface.local(b));
            item.cost_bits = flat_bits(dot(d, d) * self.length_scale);
        }
        Some(item)
    }

    #[inline(always)]
    fn entry_with(&self, a: u32, b: u32, endpoint_only: bool) -> Option<Item> {
        self.entry_at(a, self.surface.local(a), b, endpoint_only)
    }

    fn entry(&self, a: u32, b: u32) -> Option<Item> {
        self.entry_with(a, b, false)
    }

    fn resolve(&mut self, mut x: u32) -> u32 {
        while self.forward[x as usize] != x {
            let n = self.forward[x as usize];
            self.forward[x as usize] = self.forward[n as usize];
            x = n;
        }
        x
    }

    /// Queues every edge and extra pair (unordered, then heapified).
    #[inline(always)]
    fn push_all(&mut self) {
        self.heap.clear();
        let mut nb = std::mem::take(&mut self.scratch);
        for p in 0..self.surface.point_count() as u32 {
            if !self.surface.is_alive(p) {
                continue;
            }
            self.surface.neighbours(p, &mut nb);
            let pp = self.surface.local(p);
            for &q in &nb {
                if q > p {
                    if let Some(e) = self.entry_at(p, pp, q, false) {
                        self.heap.push_unordered(e);
                    }
                }
            }
        }
        for p in 0..self.partners.len() {
            for i in 0..self.partners[p].len() {
                let q = self.partners[p][i];
                let (a, b) = (self.resolve(p as u32), self.resolve(q));
                if a < b {
                    if let Some(e) = self.entry(a, b) {
                        self.heap.push_unordered(e);
                    }
                }
            }
        }
        self.scratch = nb;
        self.heap.heapify();
    }

    /// Re-queues the pairs of `v` after it changed.
    #[inline(always)]
    fn push_around(&mut self, v: u32) {
        let mut nb = std::mem::take(&mut self.scratch);
        self.surface.neighbours(v, &mut nb);
        // Read the neighbours' state in one pass first: their cache misses then
        // overlap instead of stalling one evaluation each.
        self.load_points(&nb);
        let pv = self.surface.local(v);
        for &q in &nb {
            if let Some(e) = self.entry_at(v, pv, q, false) {
                self.heap.push(e);
            }
        }
        if !self.partners.is_empty() {
            nb.clear();
            nb.extend_from_slice(&self.partners[v as usize]);
            for &q in &nb {
                let q = self.resolve(q);
                if q != v {
                    if let Some(e) = self.entry(v, q) {
                        self.heap.push(e);
                    }
                }
            }
        }
        self.scratch = nb;
    }

    /// Reads what evaluating a pair of these points reads first (the cost model's
    /// state, the surface's point records, versions) in one pass of independent
    /// loads that the core waits for, so their misses overlap. A hint: nothing
    /// changes.
    #[inline(always)]
    fn load_points(&self, points: &[u32]) {
        self.cost.prefetch(points);
        self.surface.prefetch(points);
        self.cost.prefetch_wedges(self.surface, points);
        let mut s = 0u32;
        for &q in points {
            s = s.wrapping_add(self.version[q as usize]);
        }
        std::hint::black_box(s);
    }

    /// Hardware prefetches of what evaluating a pair of these points reads first
    /// (versions, the cost model's state, the surface's point records). A hint.
    #[inline(always)]
    fn prefetch_points<const N: usize>(&self, points: [u32; N]) {
        for x in points {
            if let Some(v) = self.version.get(x as usize) {
                crate::isa::prefetch(v);
            }
            self.cost.prefetch_hint(x);
            self.surface.prefetch_point_hint(x);
        }
    }

    #[inline(always)]
    fn valid(&self, e: &Item) -> bool {
        let (a, b) = (e.a, e.b);
        self.stamp(a, b, e.stamp & 1 == 1) == e.stamp
            && self.surface.is_alive(a)
            && self.surface.is_alive(b)
    }

    /// The queue ran dry before the target (step 6 of the module docs). When the
    /// last scan performed a collapse and re-scans are left, queues every pair
    /// again (the parked ones included, so they are forgotten) and returns `true`;
    /// otherwise sets the stop reason and its sentence and returns `false`.
    #[inline(always)]
    fn ran_dry(
        &mut self,
        stop: &StopRule,
        scan: &mut ScanCounts,
        parked: &mut Parked,
        parts: Option<&mut Parts>,
        out: &mut Outcome,
    ) -> bool {
        if scan.collapses > 0 && out.rescans < MAX_RESCANS {
            out.rescans += 1;
            // Every pair is queued again, the parked ones included, and the
            // costs start low again: so does the retry threshold.
            parked.reset();
            *scan = ScanCounts::default();
            self.push_all();
            return true;
        }
        // No collapse is left: parts are removed in order of radius if that
        // reaches the target (each at most as far below it as the slack allows);
        // otherwise none (a large part for a few triangles is a poor trade).
        let pruning = parts.is_some();
        if let Some(parts) = parts {
            if parts.remove_to_target(self.surface, &mut self.version, stop, out) {
                return true;
            }
        }
        if scan.error_blocked > 0 {
            out.stop_reason = StopReason::MaxError;
            out.stop_detail = format!(
                "every remaining collapse would exceed the maximum error ({:.6e})",
                stop.max_error.unwrap_or(0.0)
            );
        } else {
            out.stop_reason = StopReason::NoLegalCollapse;
            out.stop_detail =
                no_legal_collapse_detail(self.surface, &self.limits, pruning, &out.rejections);
        }
        false
    }

    /// Retries the parked pairs (step 4): puts the popped entry `e` back, then
    /// evaluates every parked pair whose points are alive and queues it again, and
    /// raises the retry threshold to `e`'s cost.
    #[inline(always)]
    fn retry_parked(&mut self, e: Item, parked: &mut Parked) {
        self.heap.push(e);
        parked.pairs.sort_unstable();
        parked.pairs.dedup();
        for (a, b) in parked.pairs.drain(..) {
            if self.surface.is_alive(a) && self.surface.is_alive(b) {
                if let Some(x) = self.entry(a, b) {
                    self.heap.push(x);
                }
            }
        }
        parked.min = f32::INFINITY;
        parked.retried_at = f32::from_bits(e.cost_bits);
    }

    /// Bookkeeping of popped entry `e` (moves `m`) that the operator's check
    /// rejected with `r`: a merged placement that folds over or degenerates may
    /// still be fine as a half-edge collapse onto either end, so that is queued as
    /// a fallback entry at its own cost; the rejection is counted; and the pair is
    /// parked for a retry unless the reason is one no neighbouring collapse can
    /// lift (a point's kind, a UV seam).
    #[inline(always)]
    fn check_rejected(
        &mut self,
        e: Item,
        m: &Moves,
        r: Reject,
        rejections: &mut Rejections,
        parked: &mut Parked,
    ) {
        let endpoint_only = e.stamp & 1 == 1;
        if !endpoint_only
            && m.merge != Merge::No
            && matches!(r, Reject::FoldOver | Reject::Degenerate)
        {
            if let Some(alt) = self.entry_with(e.a, e.b, true) {
                self.heap.push(alt);
            }
        }
        count_rejection(rejections, r);
        if !matches!(r, Reject::Kind | Reject::Seam) {
            parked.park(e.a, e.b, f32::from_bits(e.cost_bits));
        }
    }

    /// Prefetches once the check has accepted a collapse: the second stage for the
    /// next pop (its fans), and the points whose pairs are re-queued after this
    /// collapse (the corners of the triangles that change), so their loads overlap
    /// the filters and the collapse instead of stalling the re-queue.
    #[inline(always)]
    fn prefetch_after_check(&self, preview: &Preview) {
        // Second stage for the next pop: its fans.
        if let Some(&n) = self.heap.peek_band() {
            self.surface.prefetch_fans_hint(n.a, n.b);
        }
        // Around an interior fan each neighbour follows the moving corner in
        // exactly one triangle, so that corner alone names each of them once (a
        // border fan misses one, and when `v` stays put its own fan is not among
        // the changed triangles: a hint may miss some).
        for ch in &preview.changed {
            let tt = self.surface.triangle(ch.triangle);
            self.prefetch_points([tt[(usize::from(ch.corner) + 1) % 3]]);
        }
    }

    /// Runs the filters on the collapse the check accepted (`c`, popped as `e`) and
    /// confirms its priority. Returns the cost to record when it goes ahead, or
    /// `None` when a filter vetoed it (counted and parked, step 4) or its exact key
    /// is above the queued one (queued again at that key, step 2; counted as a
    /// filter rejection when a soft filter raised it, step 5).
    #[inline(always)]
    fn screen(
        &mut self,
        e: Item,
        c: &Candidate,
        preview: &Preview,
        rejections: &mut Rejections,
        parked: &mut Parked,
    ) -> Option<f64> {
        let mut vetoed = false;
        let mut penalised = false;
        for f in self.filters {
            if !f.allow(self.surface, preview) {
                if f.is_soft() {
                    penalised = true;
                    continue;
                }
                vetoed = true;
                break;
            }
        }
        if vetoed {
            rejections.filter += 1;
            parked.park(e.a, e.b, f32::from_bits(e.cost_bits));
            return None;
        }
        // Lazy keys: the exact priority may be higher than the queued one.
        let mut exact = self.cost.confirm(self.surface, c);
        if penalised {
            // A soft filter's refusal is a priority, not a veto (see
            // `SOFT_PENALTY`).
            // (A zero-cost collapse goes ahead: it changes no shape. Holding
            // it back at the smallest positive key instead raised fandisk's
            // maxima, at 10% by 7%.)
            exact = exact.max(c.cost * SOFT_PENALTY);
        }
        let requeued = Item { cost_bits: 0, ..e }.with_cost(exact * self.key_scale);
        // (A flat key, [`flat_bits`], is not raised by a cost that is still flat.)
        if exact > c.cost && requeued.cost_bits >= FLAT_BITS && requeued.cost_bits > e.cost_bits {
            if penalised {
                rejections.filter += 1;
            }
            self.heap.push(requeued);
            return None;
        }
        Some(exact)
    }

    /// Performs collapse `c` at `p` (the position as stored) with priority `exact`,
    /// tells the cost model and the observer, adds it to the outcome's counts and
    /// re-queues what it changed ([`Self::requeue_after`]).
    #[inline(always)]
    fn perform(
        &mut self,
        c: &Candidate,
        p: [f32; 3],
        exact: f64,
        observer: &mut dyn Observer,
        out: &mut Outcome,
    ) {
        observer.before_collapse(self.surface, c.removed, c.kept);
        let mut record = self.surface.collapse(c.removed, c.kept, p);
        record.cost = exact;
        record.error = c.error;
        self.cost.collapsed(self.surface, &record);
        self.cost.write_attributes(self.surface, &record);
        out.collapses += 1;
        if record.non_edge {
            out.non_edge_contractions += 1;
        }
        if record.closed_hole != DEAD {
            out.holes_closed += 1;
        }
        out.max_error = out.max_error.max(record.error);
        observer.collapsed(&record);
        if out.collapses % PROGRESS_EVERY == 0 {
            observer.progress(self.surface.live_triangles());
        }
        self.requeue_after(record.removed, record.kept);
    }

    /// After `u` was merged into `v` (step 3): bumps both versions (the queued
    /// entries of both go stale), hands `u`'s extra pairs to `v`, and re-queues the
    /// pairs of the apexes whose kind changed and of `v`.
    #[inline(always)]
    fn requeue_after(&mut self, u: u32, v: u32) {
        self.version[v as usize] = self.version[v as usize].wrapping_add(1);
        // The removed point's entries go stale too: a point dies as the removed
        // end of a collapse or in a removed part (whose points' versions are
        // bumped too), so a matching stamp alone means both points are alive.
        self.version[u as usize] = self.version[u as usize].wrapping_add(1);
        if !self.partners.is_empty() {
            self.forward[u as usize] = v;
            let moved = std::mem::take(&mut self.partners[u as usize]);
            self.partners[v as usize].extend(moved);
        }
        // Apexes whose kind may have changed get re-queued too.
        for x in self.surface.kind_changes() {
            if x != crate::collapse::DEAD && self.surface.is_alive(x) {
                self.version[x as usize] = self.version[x as usize].wrapping_add(1);
                self.push_around(x);
            }
        }
        self.push_around(v);
    }

    /// Third prefetch stage for the next pop, after a collapse's re-queue: its
    /// triangles, found through its fans (loaded by the second stage; if the
    /// re-queue changed the top, this waits on the new top's records and fans).
    /// The fourth, their corners, is `prefetch_pair` after the pop. Then its
    /// points' records, versions and the cost model's state with ordinary loads.
    #[inline(always)]
    fn prefetch_next_triangles(&self) {
        if let Some(&n) = self.heap.peek_band() {
            self.surface.prefetch_triangles_hint(n.a, n.b);
            self.load_points(&[n.a, n.b]);
        }
    }

    /// Drops stale entries once the queue holds more than ~2 entries per live
    /// triangle (there are ~1.5 live pairs per triangle): bounds its memory. With
    /// `non_edge_pairs`, not before the queue has doubled since the last sweep
    /// (`swept_to`, its length after that sweep).
    #[inline(always)]
    fn sweep_stale(&mut self, non_edge_pairs: bool, swept_to: &mut usize) {
        let bound = 2 * self.surface.live_triangles() + STALE_SLACK;
        let bound = if non_edge_pairs {
            bound.max(2 * *swept_to)
        } else {
            bound
        };
        if self.heap.len() > bound {
            // A slice, not the `Vec`: its pointer and length are then loaded once,
            // not again for every entry.
            let version = &self.version[..];
            self.heap.retain(|e| {
                let (a, b) = (e.a, e.b);
                (version[a as usize].wrapping_add(version[b as usize]) << 1) | (e.stamp & 1)
                    == e.stamp
            });
            *swept_to = self.heap.len();
        }
    }
}

/// Collapses and maximum-error rejections since the last re-scan (or the start).
#[derive(Debug, Clone, Copy, Default)]
struct ScanCounts {
    /// Collapses performed: a re-scan is only worth it after one.
    collapses: usize,
    /// Candidates rejected for exceeding the maximum error: if any, a run that
    /// stops for want of candidates stops for the maximum error.
    error_blocked: usize,
}

/// Pairs rejected by a check that depends on their neighbourhood, for a retry
/// once the queue's cost has grown past them (step 4 of the module docs, see
/// [`RETRY_GROWTH`]).
struct Parked {
    /// The pairs, in rejection order (repeats possible).
    pairs: Vec<(u32, u32)>,
    /// The cheapest queued cost among them (`∞` when none).
    min: f32,
    /// The popped cost at the previous retry (0 at the start and after a re-scan).
    retried_at: f32,
}

impl Parked {
    fn new() -> Self {
        Self {
            pairs: Vec::new(),
            min: f32::INFINITY,
            retried_at: 0.0,
        }
    }

    /// Forgets every pair and the threshold (a re-scan queues them all again, and
    /// the costs start low again).
    #[inline(always)]
    fn reset(&mut self) {
        self.pairs.clear();
        self.min = f32::INFINITY;
        self.retried_at = 0.0;
    }

    /// Remembers pair `(a, b)`, rejected when popped at queued cost `cost`.
    #[inline(always)]
    fn park(&mut self, a: u32, b: u32, cost: f32) {
        self.pairs.push((a, b));
        self.min = self.min.min(cost);
    }

    /// Whether a pop at cost `cost` is [`RETRY_GROWTH`] times above the cheapest
    /// parked pair and the previous retry: then the parked pairs are retried first.
    #[inline(always)]
    fn due(&self, cost: f32) -> bool {
        cost > RETRY_GROWTH * self.min && cost > RETRY_GROWTH * self.retried_at
    }
}

/// Adds a rejection by the operator's check to its reason's count.
#[inline(always)]
fn count_rejection(rj: &mut Rejections, r: Reject) {
    match r {
        Reject::Kind => rj.kind += 1,
        Reject::NonManifoldEdge => rj.non_manifold_edge += 1,
        Reject::Link => rj.link += 1,
        Reject::Duplicate => rj.duplicate += 1,
        Reject::Seam => rj.seam += 1,
        Reject::FoldOver => rj.fold_over += 1,
        Reject::Degenerate => rj.degenerate += 1,
        Reject::Pair => rj.pair += 1,
    }
}

/// The stop sentence when no legal collapse is left: how many of the live points
/// may not move, and the rejections so far by reason.
fn no_legal_collapse_detail(
    surface: &Surface,
    limits: &OperatorLimits,
    pruning: bool,
    r: &Rejections,
) -> String {
    let (mut live, mut fixed) = (0usize, 0usize);
    for p in 0..surface.point_count() as u32 {
        if surface.is_alive(p) {
            live += 1;
            if !surface.may_move(p) {
                fixed += 1;
            }
        }
    }
    let (components, border) = surface.components_and_border_points();
    let nm = surface.non_manifold_census();
    let parts = if pruning {
        "the largest part is kept, and no part above the maximum error or whose \
         removal would land more than 1% below the target"
    } else {
        "no part is collapsed away"
    };
    let holes = if limits.close_holes {
        "a hole is closed once down to three border edges between border points or pinches"
    } else {
        "holes are not closed"
    };
    format!(
        "no legal collapse left: {fixed} of the {live} points left may not move \
         (seam or material-border junctions, non-manifold or locked points); \
         the surface keeps its {components} components ({parts}), \
         {border} border points ({holes}) and {} non-manifold points \
         ({} chain corners, {} on a border, {} on a seam, {} irregular, {} pinches, \
         {} chain points); \
         rejected so far: link {}, fold-over {}, degenerate {}, duplicate {}, \
         seam {}, kind {}, non-manifold edge {}, filters {}",
        nm.total,
        nm.corner,
        nm.border,
        nm.seam,
        nm.irregular,
        nm.pinch,
        nm.chain,
        r.link,
        r.fold_over,
        r.degenerate,
        r.duplicate,
        r.seam,
        r.kind,
        r.non_manifold_edge,
        r.filter
    )
}

/// The extra non-edge pairs as lists of partners (each pair once, under its
/// smaller point) and the identity forwarding map that follows merged points;
/// both empty when there are none or non-edge pairs are not allowed.
fn extra_partners(np: usize, options: &EdgeCollapseOptions) -> (Vec<Vec<u32>>, Vec<u32>) {
    let mut partners: Vec<Vec<u32>> = Vec::new();
    let mut forward = Vec::new();
    if !options.extra_pairs.is_empty() && options.limits.allow_non_edge {
        partners = vec![Vec::new(); np];
        forward = (0..np as u32).collect();
        for &[a, b] in &options.extra_pairs {
            if (a as usize) < np && (b as usize) < np && a != b {
                partners[a.min(b) as usize].push(a.max(b));
            }
        }
    }
    (partners, forward)
}

/// Simplifies `surface` in place with `cost` and `filters` until `options.stop`
/// holds or nothing legal is left. `observer` sees the start, every collapse and
/// periodic progress.
///
/// The whole loop, with the cost model's evaluation and the queue inlined into it,
/// runs as the AVX2 build where the CPU has it (see the crate's `isa` module; same bits).
pub fn run<C: CostModel + ?Sized>(
    surface: &mut Surface,
    cost: &mut C,
    filters: &[&dyn Filter],
    options: &EdgeCollapseOptions,
    observer: &mut dyn Observer,
) -> Outcome {
    let outcome = crate::isa::dispatch!(run_impl(surface, cost, filters, options, observer));
    // The cost model writes the solved streams only within this run.
    surface.set_solved_streams(0);
    outcome
}

/// The whole run (see the module docs): the setup, then the queue loop, whose
/// steps are methods of [`Driver`]. Each step the loop runs per pop is
/// `#[inline(always)]`, so that it is compiled into the AVX2 copy `run` dispatches
/// to; `extra_partners` (setup) and `no_legal_collapse_detail` (the stop sentence)
/// run once and are plain functions.
#[inline(always)]
fn run_impl<C: CostModel + ?Sized>(
    surface: &mut Surface,
    cost: &mut C,
    filters: &[&dyn Filter],
    options: &EdgeCollapseOptions,
    observer: &mut dyn Observer,
) -> Outcome {
    let stop = options.stop;
    let mut out = Outcome {
        stop_reason: StopReason::NoLegalCollapse,
        ..Outcome::nothing()
    };
    if surface.live_triangles() == 0 {
        out.stop_reason = StopReason::EmptyInput;
        out.stop_detail = "the input has no triangles".into();
        return out;
    }
    observer.started(surface.live_triangles(), stop.target_triangles);
    cost.init(surface);
    surface.set_solved_streams(cost.solved_streams());
    let np = surface.point_count();
    let surface_triangles = surface.live_triangles();
    let (partners, forward) = extra_partners(np, options);
    let scale = key_scale(cost.cost_length_power(), surface.diagonal());
    // With non-edge pairs a point has more live pairs than its triangles' edges, so
    // the queue can stay above the sweep's bound even when nothing in it is stale;
    // then a sweep waits until the queue has doubled since the last one (amortised
    // O(1) per entry instead of a sweep per collapse).
    let non_edge_pairs = !options.extra_pairs.is_empty() && options.limits.allow_non_edge;
    let mut swept_to = 0usize;
    let length_scale = key_scale(2, surface.diagonal());
    let mut d = Driver {
        surface,
        cost,
        filters,
        limits: options.limits,
        version: vec![0; np],
        // Room for what the stale-entry sweep allows (2 per live triangle), so the
        // overflow list never reallocates on the way.
        heap: Heap::with_capacity(2 * surface_triangles + STALE_SLACK + 1024),
        key_scale: scale,
        length_scale,
        partners,
        forward,
        scratch: Vec::new(),
    };
    d.push_all();
    let mut parts = if options.prune_parts && !options.limits.allow_non_edge {
        Parts::new(d.surface)
    } else {
        None
    };
    let mut preview = Preview::default();
    let mut scan = ScanCounts::default();
    let mut parked = Parked::new();
    // The cost bound as a key, rounded as keys are (a collapse costing exactly the
    // bound goes ahead).
    let bound = stop
        .max_cost
        .map(|mc| (mc, Item::default().with_cost(mc * d.key_scale).cost_bits));
    loop {
        if d.surface.live_triangles() <= stop.target_triangles {
            out.stop_reason = StopReason::TargetReached;
            out.stop_detail = format!("reached the target of {} triangles", stop.target_triangles);
            break;
        }
        let Some(e) = d.heap.pop() else {
            if d.ran_dry(&stop, &mut scan, &mut parked, parts.as_mut(), &mut out) {
                continue;
            }
            break;
        };
        if let Some((mc, bits)) = bound {
            if e.cost_bits >= FLAT_BITS && e.cost_bits > bits {
                // The heap pops in cost order: every queued pair costs at least
                // this (flat pairs' keys sit below every other key). Pairs parked
                // after a rejection are not retried.
                out.stop_reason = StopReason::MaxError;
                out.stop_detail =
                    format!("every remaining collapse costs more than the bound ({mc:.6e})");
                break;
            }
        }
        // Loading the next pop's neighbourhood is a chain of dependent cache misses
        // (point records, fans, triangles, positions) that would stall the loop at
        // every pop on a mesh larger than the cache. The next pop is most likely
        // the new top: its stages are started one per step of this iteration, as
        // hardware prefetches, so each has usually arrived when the next needs it.
        // First stage: its points' records.
        if let Some(&n) = d.heap.peek_band() {
            d.prefetch_points([n.a, n.b]);
        }
        if !d.valid(&e) {
            continue;
        }
        if parked.due(f32::from_bits(e.cost_bits)) {
            // Cheaper pairs were rejected since the last retry and their
            // neighbourhoods may have changed since: queue them again first.
            d.retry_parked(e, &mut parked);
            out.retries += 1;
            continue;
        }
        // Recompute the candidate (same inputs as at push time, so the same result).
        let Some(m) = d.moves(e.a, e.b, e.stamp & 1 == 1) else {
            continue;
        };
        let Some(c) = d.cost.evaluate(d.surface, e.a, e.b, &m) else {
            continue;
        };
        if stop.max_error.is_some_and(|me| c.error > me) {
            out.rejections.max_error += 1;
            scan.error_blocked += 1;
            continue;
        }
        let p = c.position.map(|x| x as f32);
        // Fourth stage: the corners' positions, before the check walks them.
        d.surface.prefetch_pair(c.removed, c.kept);
        if let Err(r) = d
            .surface
            .check(c.removed, c.kept, p, &d.limits, &mut preview)
        {
            d.check_rejected(e, &m, r, &mut out.rejections, &mut parked);
            continue;
        }
        // A collapse along a non-manifold edge removes one triangle per sheet: not
        // one that would land further below the target than a plain collapse may
        // (1% of it, or one triangle).
        if preview.dying > 2 {
            let slack = stop.target_triangles.div_ceil(100).max(1);
            let left = d.surface.live_triangles().saturating_sub(preview.dying);
            if left + slack < stop.target_triangles {
                let r = Reject::NonManifoldEdge;
                d.check_rejected(e, &m, r, &mut out.rejections, &mut parked);
                continue;
            }
        }
        d.prefetch_after_check(&preview);
        let Some(exact) = d.screen(e, &c, &preview, &mut out.rejections, &mut parked) else {
            continue;
        };
        if let Some(parts) = parts.as_mut() {
            if parts.remove_below(d.surface, &mut d.version, c.error, &stop, &mut out) {
                // Parts whose removal costs less than this collapse went first:
                // it comes up again (its neighbourhood may be gone).
                d.heap.push(e);
                continue;
            }
        }
        d.perform(&c, p, exact, observer, &mut out);
        scan.collapses += 1;
        d.prefetch_next_triangles();
        d.sweep_stale(non_edge_pairs, &mut swept_to);
    }
    observer.progress(d.surface.live_triangles());
    out
}
