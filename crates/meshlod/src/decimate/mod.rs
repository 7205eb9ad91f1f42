//! Decimation drivers: the *strategy* half (see `DESIGN.md`) — which candidate goes
//! next, and when to stop.
//!
//! [`edge_collapse`] runs any [`crate::cost::CostModel`] with any
//! [`crate::filter::Filter`]s over the always-on collapse operator
//! ([`crate::collapse`]), in cost order from a priority queue with lazy
//! invalidation, until the [`StopRule`] holds; it reports through an [`Observer`]
//! and returns an [`Outcome`] that says why it stopped. [`cluster`] is vertex
//! clustering (Rossignac & Borrel 1993, Lindstrom 2000): one pass over a grid, in
//! memory or streamed from a file. [`vertex_removal`] is
//! Schroeder's vertex decimation (its own operator: remove a point, re-triangulate
//! the hole) with the same queue, stop rules and outcome.

pub mod cluster;
pub mod edge_collapse;
mod heap;
mod prune;
pub mod vertex_removal;

use crate::collapse::{CollapseRecord, Surface};
use serde::Serialize;

/// When to stop: whichever comes first.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StopRule {
    /// Stop once at most this many triangles are left.
    pub target_triangles: usize,
    /// Never perform a collapse whose error (a distance in mesh units) exceeds this.
    pub max_error: Option<f64>,
    /// Stop once the cheapest queued collapse costs more than this (the cost
    /// model's priority; QEM: a squared distance times an area, mesh units⁴): the
    /// run then holds exactly the collapses that a longer run does first. Used to
    /// stop pieces of a mesh at the same point of the whole mesh's greedy order.
    pub max_cost: Option<f64>,
}

/// Why a run stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The triangle count reached the target.
    TargetReached,
    /// Every remaining collapse would exceed the maximum error (or the cost
    /// bound, [`StopRule::max_cost`]).
    MaxError,
    /// No collapse is legal any more (topology, kinds, fold-overs, filters).
    NoLegalCollapse,
    /// The input had no triangles (after repair).
    EmptyInput,
}

impl StopReason {
    /// The snake-case name used in JSON reports.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::TargetReached => "target_reached",
            Self::MaxError => "max_error",
            Self::NoLegalCollapse => "no_legal_collapse",
            Self::EmptyInput => "empty_input",
        }
    }
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Watches a run: progress for a progress bar, every collapse for a recorder.
pub trait Observer {
    /// Called once before the first collapse.
    fn started(&mut self, _triangles: usize, _target: usize) {}
    /// Called just before a collapse that passed every check is performed: `removed`
    /// is about to be merged onto `kept`, and `surface` is still the state before
    /// (what a progressive-mesh recorder reads the removed point's fan from).
    fn before_collapse(&mut self, _surface: &Surface, _removed: u32, _kept: u32) {}
    /// Called after every performed collapse.
    fn collapsed(&mut self, _record: &CollapseRecord) {}
    /// Called every few thousand collapses with the current triangle count.
    fn progress(&mut self, _triangles: usize) {}
}

/// An observer that does nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoObserver;

impl Observer for NoObserver {}

/// Records every collapse (e.g. for progressive meshes).
#[derive(Debug, Clone, Default)]
pub struct CollapseRecorder {
    /// The collapses, in order.
    pub records: Vec<CollapseRecord>,
}

impl Observer for CollapseRecorder {
    fn collapsed(&mut self, record: &CollapseRecord) {
        self.records.push(*record);
    }
}

/// Counts of rejected candidates, by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Rejections {
    /// Kinds (locked/complex vertex would move, dead points).
    pub kind: u64,
    /// Non-manifold edge: more sheets than a collapse along it handles, or a
    /// collapse along it that would land too far below the target.
    pub non_manifold_edge: u64,
    /// Link condition.
    pub link: u64,
    /// Duplicate triangle.
    pub duplicate: u64,
    /// Seam wedges inconsistent.
    pub seam: u64,
    /// Fold-over.
    pub fold_over: u64,
    /// Zero-area triangle.
    pub degenerate: u64,
    /// Non-edge pair touching a common neighbour.
    pub pair: u64,
    /// Vetoed by a filter.
    pub filter: u64,
    /// Error above the maximum.
    pub max_error: u64,
}

impl Rejections {
    /// Adds the counts of `other` (e.g. the runs of several chunks).
    pub fn add(&mut self, other: &Self) {
        self.kind += other.kind;
        self.non_manifold_edge += other.non_manifold_edge;
        self.link += other.link;
        self.duplicate += other.duplicate;
        self.seam += other.seam;
        self.fold_over += other.fold_over;
        self.degenerate += other.degenerate;
        self.pair += other.pair;
        self.filter += other.filter;
        self.max_error += other.max_error;
    }

    /// Total of all counts.
    #[must_use]
    pub fn total(&self) -> u64 {
        self.kind
            + self.non_manifold_edge
            + self.link
            + self.duplicate
            + self.seam
            + self.fold_over
            + self.degenerate
            + self.pair
            + self.filter
            + self.max_error
    }
}

/// What a run did and why it stopped.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outcome {
    /// Why it stopped.
    pub stop_reason: StopReason,
    /// A sentence explaining the stop.
    pub stop_detail: String,
    /// Collapses performed (edge collapses and non-edge contractions).
    pub collapses: usize,
    /// Non-edge pair contractions among them.
    pub non_edge_contractions: usize,
    /// Largest error (distance, mesh units) of a performed collapse.
    pub max_error: f64,
    /// Rejected candidates by reason.
    pub rejections: Rejections,
    /// Full re-scans of all pairs done after the queue ran dry.
    pub rescans: usize,
    /// Times the pairs rejected since the previous retry were queued again because
    /// the queue's cost had grown past theirs (edge collapse).
    pub retries: usize,
    /// Whether soft filters were switched off to reach the target. Always `false`
    /// since soft filters rank collapses instead of vetoing them (kept for
    /// compatibility).
    pub soft_filters_relaxed: bool,
    /// Holes of three border edges closed by a collapse
    /// ([`crate::collapse::OperatorLimits::close_holes`]).
    pub holes_closed: usize,
    /// Separate parts removed whole ([`edge_collapse::EdgeCollapseOptions::prune_parts`]).
    pub components_removed: usize,
}

impl Outcome {
    /// A run that did nothing because it had nothing to do: at its target.
    pub(crate) fn nothing() -> Self {
        Self {
            stop_reason: StopReason::TargetReached,
            stop_detail: String::new(),
            collapses: 0,
            non_edge_contractions: 0,
            max_error: 0.0,
            rejections: Rejections::default(),
            rescans: 0,
            retries: 0,
            soft_filters_relaxed: false,
            holes_closed: 0,
            components_removed: 0,
        }
    }

    /// This run followed by `later` on the same surface: counts added, the largest
    /// error, `later`'s stop.
    pub(crate) fn merge(&mut self, later: Outcome) {
        self.stop_reason = later.stop_reason;
        self.stop_detail = later.stop_detail;
        self.collapses += later.collapses;
        self.non_edge_contractions += later.non_edge_contractions;
        self.max_error = self.max_error.max(later.max_error);
        self.rejections.add(&later.rejections);
        self.rescans += later.rescans;
        self.retries += later.retries;
        self.soft_filters_relaxed |= later.soft_filters_relaxed;
        self.holes_closed += later.holes_closed;
        self.components_removed += later.components_removed;
    }
}
