//! Cost models: the *criteria* half that ranks collapses (see `DESIGN.md`).
//!
//! A [`CostModel`] owns its per-vertex state (for [`Qem`]: one quadric per point),
//! proposes a [`Candidate`] — which point goes, where the survivor is placed, the
//! cost that orders the queue and the error it stands for as a distance — and
//! updates its state after each performed collapse. It never decides legality: the
//! operator ([`crate::collapse`]) says which moves are allowed ([`Moves`]) and the
//! filters ([`crate::filter`]) may veto.
//!
//! Cost models are directional where they need to be: a candidate names the
//! `removed` and the `kept` point, so a half-edge cost (Melax's `u → v`) is expressed
//! by evaluating both directions the [`Moves`] allow and returning the better.

mod attributes;
mod melax;
mod qem;

pub use attributes::AttributeWeights;
pub use melax::{Melax, MelaxOptions};
pub use qem::{Placement, Qem, QemOptions, QEM_CONDITION};

use crate::collapse::{CollapseRecord, Moves, Surface};

/// A proposed contraction of a pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The point that disappears.
    pub removed: u32,
    /// The point that survives.
    pub kept: u32,
    /// Where the survivor is placed (absolute coordinates, mesh units).
    pub position: [f64; 3],
    /// The priority: lower goes first. Any non-negative finite value.
    pub cost: f64,
    /// The geometric error the collapse stands for, as a distance in mesh units
    /// (what the stop rule's maximum error and the report use).
    pub error: f64,
}

/// Ranks collapses and keeps the per-vertex state that ranking needs.
///
/// The driver calls [`CostModel::init`] once; [`CostModel::evaluate_cost`] or
/// [`CostModel::evaluate_cost_near`] for every pair it queues, and
/// [`CostModel::evaluate`] when a queued pair is popped (to get its position); and
/// [`CostModel::collapsed`] after every performed collapse. The three evaluations
/// must agree on the cost bit for bit: the driver never compares them, so a model
/// whose leaner methods disagree silently misorders the queue.
pub trait CostModel {
    /// A short name for reports (`"qem"`).
    fn name(&self) -> &'static str;

    /// The power of length in the cost's units (QEM: 4, an area-weighted squared
    /// distance; Melax: 1). The driver scales the costs by `2^(−p·k)`, with `2^k`
    /// near the bounding-box diagonal, before queueing them as `f32`: exact (a power
    /// of two), so the order is unchanged wherever `f32` holds the costs, and a mesh
    /// in kilometres or in nanometres neither overflows nor underflows the keys.
    /// Default 0 (no scaling).
    fn cost_length_power(&self) -> i32 {
        0
    }

    /// Builds the per-point state from the initial surface.
    fn init(&mut self, surface: &Surface);

    /// After [`CostModel::init`]: the attribute streams (`collapse::SOLVED_*` bits)
    /// whose values [`CostModel::write_attributes`] sets for every wedge of the
    /// survivor of each collapse, so the surface need not interpolate them.
    /// Default: none.
    fn solved_streams(&self) -> u8 {
        0
    }

    /// The best contraction of pair `(a, b)` among those `moves` allows, or `None`
    /// when the model proposes none.
    fn evaluate(&self, surface: &Surface, a: u32, b: u32, moves: &Moves) -> Option<Candidate>;

    /// The cost [`CostModel::evaluate`] would give pair `(a, b)` (`None` when it
    /// would propose nothing), without the position and the error: what the driver
    /// queues. Must equal `evaluate(..).map(|c| c.cost)` exactly; a model may
    /// override it with a leaner computation. Default: exactly that.
    fn evaluate_cost(&self, surface: &Surface, a: u32, b: u32, moves: &Moves) -> Option<f64> {
        self.evaluate(surface, a, b, moves).map(|c| c.cost)
    }

    /// [`CostModel::evaluate_cost`] given `pa = surface.local(a)` (what the driver
    /// has at hand when it re-queues all pairs of `a`, so a model need not convert
    /// it again for each). Must equal `evaluate_cost` exactly. Default:
    /// `evaluate_cost`.
    #[inline(always)]
    fn evaluate_cost_near(
        &self,
        surface: &Surface,
        a: u32,
        pa: [f64; 3],
        b: u32,
        moves: &Moves,
    ) -> Option<f64> {
        let _ = pa;
        self.evaluate_cost(surface, a, b, moves)
    }

    /// A hint that the driver is about to evaluate pairs among `points`: a model may
    /// read their state now, in one pass of independent loads, so the cache misses
    /// overlap instead of being paid one evaluation at a time. Must not change any
    /// result. Default: nothing.
    fn prefetch(&self, points: &[u32]) {
        let _ = points;
    }

    /// A hint that `point`'s state will be read soon: start loading it without
    /// waiting for it (a hardware prefetch). Must not change any result. Default:
    /// nothing.
    fn prefetch_hint(&self, point: u32) {
        let _ = point;
    }

    /// A hint that pairs among `points` of `surface` will be evaluated soon: start
    /// loading per-wedge state (attribute sums) without waiting for it (hardware
    /// prefetches). Must not change any result. Default: nothing.
    fn prefetch_wedges(&self, surface: &Surface, points: &[u32]) {
        let _ = (surface, points);
    }

    /// Updates the state after `record` was performed (`surface` is already updated).
    fn collapsed(&mut self, surface: &Surface, record: &CollapseRecord);

    /// After [`CostModel::collapsed`]: a model that solves for attribute values
    /// writes those of the survivor's wedges into the surface. Default: nothing
    /// (the operator's interpolation stands).
    fn write_attributes(&self, _surface: &mut Surface, _record: &CollapseRecord) {}

    /// The exact priority of `candidate` (which the operator and the filters have
    /// accepted), for a model whose [`CostModel::evaluate`] cost is a cheaper lower
    /// bound. The driver calls it just before performing a candidate; a value above
    /// the queued cost re-queues the candidate at that value (lazy keys), so a
    /// costly refinement is computed once per performed collapse instead of once per
    /// evaluation. Must be `>= candidate.cost` and depend only on the surface and the
    /// model's state. Default: `candidate.cost`.
    fn confirm(&self, surface: &Surface, candidate: &Candidate) -> f64 {
        let _ = surface;
        candidate.cost
    }
}
