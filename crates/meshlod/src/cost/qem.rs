//! The quadric error metric cost model (Garland & Heckbert 1997).
//!
//! Every point starts with the sum of the area-weighted plane quadrics of its
//! triangles, plus constraint planes for border edges (weight
//! [`QemOptions::boundary_weight`]) and for attribute-seam / material-border edges
//! (weight [`QemOptions::seam_weight`]). Contracting `(a, b)` costs `Δ(x̄) = x̄ᵀ(Q_a +
//! Q_b)x̄` at the chosen position, and the survivor accumulates `Q_a + Q_b` (plain
//! accumulation, as in the paper).
//!
//! Placement ([`Placement::Optimal`]): where both points may move freely, the
//! minimiser of the summed quadric, solved relative to the edge midpoint and accepted
//! only when well conditioned and within reach of the edge; otherwise the minimum
//! along the edge (which includes both endpoints and the midpoint). A border or seam
//! pair is placed on its segment; a half-edge collapse onto a fixed point evaluates
//! that point.
//!
//! The queue cost is the quadric value itself (an area-weighted sum of squared
//! distances); the reported error is [`Quadric::distance`] of it: the area-weighted
//! RMS distance to the accumulated planes.

use super::attributes::WedgeQuadrics;
use super::{AttributeWeights, Candidate, CostModel};
use crate::collapse::{CollapseRecord, Merge, Moves, Surface};
use crate::mesh::VertexKind;
use crate::quadric::{cross, sub, Quadric};

/// Default conditioning threshold of QEM's 3×3 solve ([`Quadric::solve`]): looser
/// than the quadric module's [`crate::quadric::DEFAULT_CONDITION`] (`1e-6`). Near-flat
/// and near-cylindrical neighbourhoods have a nearly singular quadric whose true
/// minimiser is still well defined; at `1e-6` they fell back to the best point on
/// the edge, which on fandisk (CAD, large planar and cylindrical patches) gave a 23%
/// higher mean Hausdorff distance at 10% than at `1e-7`, and at 1% of the bunny and
/// the turbine blade a higher mean and maximum. The reach test
/// ([`QemOptions::max_reach`]) still rejects runaway solutions.
pub const QEM_CONDITION: f64 = 1e-7;

/// Where a free contraction puts the merged vertex.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Placement {
    /// The quadric minimiser, with fallback along the edge (default).
    #[default]
    Optimal,
    /// The better endpoint (half-edge collapse; vertices never move).
    Endpoint,
    /// The edge midpoint.
    Midpoint,
}

/// Settings of [`Qem`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QemOptions {
    /// Weight of the border constraint planes, relative to an area weight
    /// (a plane through a border edge of length `l` gets weight `w · l²`). Default 10.
    pub boundary_weight: f64,
    /// Weight of the constraint planes along attribute seams and material borders.
    /// Default 0.5.
    pub seam_weight: f64,
    /// Conditioning threshold of the 3×3 solve (relative determinant, see
    /// [`Quadric::solve`]); below it the minimum along the edge is used. Default
    /// [`QEM_CONDITION`] (`1e-7`).
    pub condition: f64,
    /// How far (in edge lengths from the midpoint) a solved position may lie before
    /// the fallback along the edge is used. Default 2.
    pub max_reach: f64,
    /// Placement rule.
    pub placement: Placement,
    /// Exponent α of the triangle weights: a triangle's plane quadric is weighted
    /// by `area^α · Ā^(1−α)` (`Ā` the mean triangle area, so the scale stays that of
    /// an area weight and the border weights keep their meaning). `1` is Garland &
    /// Heckbert's area weighting (default); `0` weighs every triangle alike, which
    /// favours finely tessellated regions (features, in CAD and scan meshes); `0.5`
    /// lowered the maximum Hausdorff distance on most of our test meshes at a small
    /// cost in mean distance (see `docs/methods/qem.md`).
    pub area_exponent: f64,
    /// Weight λ of the displacement guard (`0` = off, default; must be finite and
    /// non-negative, as [`crate::SimplifyOptions`] checks). Checked only when a
    /// candidate is about to be performed ([`CostModel::confirm`]): with `e` the
    /// larger distance of the two old points from the triangles the collapse leaves
    /// around them (current geometry; the candidate position before its rounding to
    /// `f32`) and `W` the pair's summed quadric weight (the area-scaled triangle
    /// weights plus any border and seam constraint planes, so border points are
    /// guarded more strongly), the priority
    /// becomes `max(cost, λ·W·e²)`. The plane quadric cannot see a thin tip being
    /// shortened (its planes run along the tip), but the old tip point then lies
    /// far off the new triangles; ordinary collapses, whose old points lie within
    /// the quadric's own RMS distance of the new surface, keep their cost.
    pub displacement_guard: f64,
    /// Weights of the attribute streams (normals, texture coordinates, colours) in
    /// the cost, in Hoppe's memory-efficient form of the attribute quadric (see
    /// the `attributes` module). With any stream present and weighted, every
    /// wedge keeps its attribute sums, collapses pay for the attribute error of the
    /// wedges they merge, and the survivor's wedges get the attribute values that
    /// minimise it at its position (with [`Placement::Endpoint`], where no vertex
    /// moves, they keep their values). Default [`AttributeWeights::default`].
    pub attribute_weights: AttributeWeights,
    /// Factor on the cost of a collapse that crosses an attribute seam or material
    /// border ([`Moves::crosses`]; the surface must allow them): `1` prices it
    /// like any other (its attribute terms and seam planes), larger values take a
    /// crossing only where every collapse that keeps the seam costs that many
    /// times more. The factor stays in the cost, so it counts in error bounds and
    /// in the reported error; a crossing that costs nothing (no attribute terms,
    /// a straight seam) stays free. Must be finite and at least 1. Default 10.
    pub seam_crossing_penalty: f64,
}

impl Default for QemOptions {
    fn default() -> Self {
        Self {
            boundary_weight: 10.0,
            seam_weight: 0.5,
            condition: QEM_CONDITION,
            max_reach: 2.0,
            placement: Placement::Optimal,
            area_exponent: 1.0,
            displacement_guard: 0.0,
            attribute_weights: AttributeWeights::default(),
            seam_crossing_penalty: 10.0,
        }
    }
}

/// The quadric error metric cost model. Per-point state: one [`Quadric`].
#[derive(Debug, Clone, Default)]
pub struct Qem {
    options: QemOptions,
    quadrics: Vec<Quadric>,
    /// Per-wedge attribute sums (`None` without weighted attributes); the
    /// quadrics above are then the reduced ones (point quadric minus the Schur
    /// terms of its wedges).
    wedges: Option<WedgeQuadrics>,
    /// [`Qem::keep_quadrics`] was called: `init` keeps the quadrics it has.
    keep: bool,
}

impl Qem {
    /// A QEM cost model with `options`.
    ///
    /// # Panics
    /// If [`QemOptions::seam_crossing_penalty`] is not finite and at least 1.
    #[must_use]
    pub fn new(options: QemOptions) -> Self {
        let p = options.seam_crossing_penalty;
        assert!(
            p.is_finite() && p >= 1.0,
            "seam_crossing_penalty {p} is not finite and at least 1"
        );
        Self {
            options,
            quadrics: Vec::new(),
            wedges: None,
            keep: false,
        }
    }

    /// From now on [`CostModel::init`] keeps the quadrics this model has for a
    /// surface with as many points (the same surface, run again after some
    /// collapses), so a later run goes on measuring errors against the original
    /// planes. Used to build successive levels of detail in one run.
    pub fn keep_quadrics(&mut self) {
        self.keep = true;
    }

    /// The quadric of pair `(a, b)`: their sum, with the attribute terms of the
    /// wedges an edge collapse merges.
    #[inline(always)]
    fn pair_quadric(&self, surface: &Surface, a: u32, b: u32) -> Quadric {
        if self.wedges.is_some() {
            return self.pair_quadric_with_attributes(surface, a, b);
        }
        self.quadrics[a as usize].sum(&self.quadrics[b as usize])
    }

    /// [`Self::pair_quadric`] with attribute terms (out of line, so that the
    /// attribute-free path stays as lean as without them).
    #[inline(never)]
    fn pair_quadric_with_attributes(&self, surface: &Surface, a: u32, b: u32) -> Quadric {
        let mut q = self.quadrics[a as usize].sum(&self.quadrics[b as usize]);
        if let Some(w) = &self.wedges {
            if surface.is_chain(a) || surface.is_chain(b) {
                // Possibly a non-manifold edge: every sheet's wedges merge.
                let mut pairs =
                    [(crate::collapse::DEAD, crate::collapse::DEAD); crate::collapse::MAX_SHEETS];
                let n = surface.edge_wedges_all(a, b, &mut pairs);
                q.add(&w.correction(&pairs[..n]));
            } else {
                q.add(&w.correction(&surface.edge_wedges(a, b)));
            }
        }
        q
    }

    /// The quadric of point `p` (zero before [`CostModel::init`]); with weighted
    /// attributes, reduced by the attribute terms of its wedges.
    #[must_use]
    pub fn quadric(&self, p: u32) -> Quadric {
        self.quadrics
            .get(p as usize)
            .copied()
            .unwrap_or(Quadric::ZERO)
    }
}

/// Where [`Qem::choose`] puts the survivor of a pair.
#[derive(Debug, Clone, Copy)]
enum Choice {
    /// A half-edge collapse of `removed` onto `kept`, at `kept`'s exact position.
    At { removed: u32, kept: u32 },
    /// A merge at a new position (local frame of the surface).
    Free([f64; 3]),
}

impl Qem {
    /// The placement rule for pair `(a, b)` under the summed quadric `q`, and its
    /// cost `q(x)` (clamped at 0): shared, through [`Self::choose_at`], by
    /// [`CostModel::evaluate`] and the queue's leaner [`CostModel::evaluate_cost`] and
    /// [`CostModel::evaluate_cost_near`], so all three give the same cost bit for bit.
    ///
    /// Inlined into its callers: the driver's queue loop runs as the AVX2 build where
    /// the CPU has it ([`crate::isa`]; same bits), and this with it.
    #[inline(always)]
    fn choose(
        &self,
        q: &Quadric,
        surface: &Surface,
        a: u32,
        b: u32,
        moves: &Moves,
    ) -> Option<(Choice, f64)> {
        self.choose_at(q, surface, a, surface.local(a), b, moves)
    }

    /// [`Self::choose`] with `a`'s local position `pa` given.
    #[inline(always)]
    fn choose_at(
        &self,
        q: &Quadric,
        surface: &Surface,
        a: u32,
        pa: [f64; 3],
        b: u32,
        moves: &Moves,
    ) -> Option<(Choice, f64)> {
        let pb = surface.local(b);
        let at = |removed: u32, kept: u32, p: [f64; 3]| {
            (Choice::At { removed, kept }, q.evaluate(p).max(0.0))
        };
        match (moves.merge, self.options.placement) {
            (Merge::Anywhere, Placement::Optimal) => {
                let m = q.minimize(pa, pb, self.options.condition, self.options.max_reach);
                return Some((Choice::Free(m.position), m.cost));
            }
            (Merge::OnSegment, Placement::Optimal) => {
                let (t, x, cost) = q.minimize_on_segment(pa, pb);
                // At an end: a half-edge collapse onto that end, position exact.
                return Some(if t == 0.0 {
                    at(b, a, pa)
                } else if t == 1.0 {
                    at(a, b, pb)
                } else {
                    (Choice::Free(x), cost)
                });
            }
            (Merge::Anywhere | Merge::OnSegment, Placement::Midpoint) => {
                let x = [
                    0.5 * (pa[0] + pb[0]),
                    0.5 * (pa[1] + pb[1]),
                    0.5 * (pa[2] + pb[2]),
                ];
                return Some((Choice::Free(x), q.evaluate(x).max(0.0)));
            }
            _ => {}
        }
        // Half-edge collapses only: the cheaper direction; on a tie, removing `a`.
        let penalty = self.options.seam_crossing_penalty;
        let priced = |(choice, cost): (Choice, f64), crosses: bool| {
            (choice, if crosses { cost * penalty } else { cost })
        };
        let onto_b = moves.a_to_b.then(|| priced(at(a, b, pb), moves.crosses[0]));
        let onto_a = moves.b_to_a.then(|| priced(at(b, a, pa), moves.crosses[1]));
        match (onto_b, onto_a) {
            (Some(x), Some(y)) => Some(if (y.1, b) < (x.1, a) { y } else { x }),
            (x, y) => x.or(y),
        }
    }
}

impl CostModel for Qem {
    fn name(&self) -> &'static str {
        "qem"
    }

    fn cost_length_power(&self) -> i32 {
        4
    }

    #[inline(always)]
    fn init(&mut self, surface: &Surface) {
        let n = surface.point_count();
        if self.keep && self.quadrics.len() == n {
            return;
        }
        self.quadrics.clear();
        self.quadrics.resize(n, Quadric::ZERO);
        self.wedges = WedgeQuadrics::new(surface, &self.options.attribute_weights);
        // Mean triangle area (the scale of non-area weights, `area_exponent`).
        let mut mean_area = 0.0f64;
        if self.options.area_exponent != 1.0 {
            let mut cnt = 0.0f64;
            for t in 0..surface.triangle_slots() as u32 {
                let tt = surface.triangle(t);
                if tt[0] == crate::collapse::DEAD {
                    continue;
                }
                let [a, b, c] = tt.map(|p| surface.local(p));
                mean_area += 0.5 * crate::quadric::norm(cross(sub(b, a), sub(c, a)));
                cnt += 1.0;
            }
            mean_area /= cnt.max(1.0);
        }
        for t in 0..surface.triangle_slots() as u32 {
            let tt = surface.triangle(t);
            if tt[0] == crate::collapse::DEAD {
                continue;
            }
            // (Not `tt.map`: an out-of-line call per triangle.)
            let [a, b, c] = [
                surface.local(tt[0]),
                surface.local(tt[1]),
                surface.local(tt[2]),
            ];
            if let Some(mut q) = Quadric::from_triangle(a, b, c) {
                // Weight area^α · mean^(1−α): α = 1 is the classic area weight.
                let alpha = self.options.area_exponent;
                if alpha != 1.0 && q.weight > 0.0 && mean_area > 0.0 {
                    q.scale((mean_area / q.weight).powf(1.0 - alpha));
                }
                for p in tt {
                    self.quadrics[p as usize].add(&q);
                }
                if let Some(w) = &mut self.wedges {
                    w.add_triangle(surface, t, [a, b, c], q.weight, &mut self.quadrics);
                }
            }
        }
        let (wb, ws) = (self.options.boundary_weight, self.options.seam_weight);
        surface.for_each_feature_edge(|a, b, t, kind| {
            // Borders and non-manifold edges (one plane per sheet: together they
            // hold the chain to its line) at the border weight, seams at theirs.
            let w = if matches!(kind, VertexKind::Border | VertexKind::Complex) {
                wb
            } else {
                ws
            };
            if w <= 0.0 {
                return;
            }
            let tt = surface.triangle(t);
            let [p0, p1, p2] = tt.map(|p| surface.local(p));
            let normal = cross(sub(p1, p0), sub(p2, p0));
            if let Some(q) =
                Quadric::from_boundary_edge(surface.local(a), surface.local(b), normal, w)
            {
                self.quadrics[a as usize].add(&q);
                self.quadrics[b as usize].add(&q);
            }
        });
        if let Some(w) = &self.wedges {
            w.reduce(surface, &mut self.quadrics);
        }
    }

    #[inline(always)]
    fn evaluate(&self, surface: &Surface, a: u32, b: u32, moves: &Moves) -> Option<Candidate> {
        let q = self.pair_quadric(surface, a, b);
        let (choice, cost) = self.choose(&q, surface, a, b, moves)?;
        let (removed, kept, position) = match choice {
            Choice::At { removed, kept } => (removed, kept, surface.position(kept).map(f64::from)),
            Choice::Free(x) => {
                let c = surface.center();
                // The survivor of a merge is the smaller id.
                (a.max(b), a.min(b), [x[0] + c[0], x[1] + c[1], x[2] + c[2]])
            }
        };
        Some(Candidate {
            removed,
            kept,
            position,
            cost,
            error: q.distance(cost),
        })
    }

    #[inline(always)]
    fn evaluate_cost(&self, surface: &Surface, a: u32, b: u32, moves: &Moves) -> Option<f64> {
        self.evaluate_cost_near(surface, a, surface.local(a), b, moves)
    }

    #[inline(always)]
    fn evaluate_cost_near(
        &self,
        surface: &Surface,
        a: u32,
        pa: [f64; 3],
        b: u32,
        moves: &Moves,
    ) -> Option<f64> {
        let q = self.pair_quadric(surface, a, b);
        self.choose_at(&q, surface, a, pa, b, moves)
            .map(|(_, cost)| cost)
    }

    fn prefetch(&self, points: &[u32]) {
        // One load per cache line a quadric may span (88 bytes: up to three lines of
        // 64), all independent.
        let mut s = 0.0;
        for &p in points {
            if let Some(q) = self.quadrics.get(p as usize) {
                s += q.m[0] + q.m[5] + q.weight;
            }
        }
        std::hint::black_box(s);
    }

    fn solved_streams(&self) -> u8 {
        match &self.wedges {
            // Endpoint placement writes nothing (`write_attributes`).
            Some(w) if self.options.placement != Placement::Endpoint => w.solved_streams(),
            _ => 0,
        }
    }

    #[inline(always)]
    fn prefetch_wedges(&self, surface: &Surface, points: &[u32]) {
        if let Some(w) = &self.wedges {
            for &p in points {
                if (p as usize) < surface.point_count() {
                    w.prefetch(surface.point_vertex(p));
                }
            }
        }
    }

    #[inline(always)]
    fn prefetch_hint(&self, point: u32) {
        if let Some(q) = self.quadrics.get(point as usize) {
            // 88 bytes at an 8-byte alignment span up to three cache lines: the
            // first, a middle and the last field cover each of them.
            crate::isa::prefetch(&q.m[0]);
            crate::isa::prefetch(&q.m[5]);
            crate::isa::prefetch(&q.weight);
        }
    }

    fn confirm(&self, surface: &Surface, candidate: &Candidate) -> f64 {
        let lambda = self.options.displacement_guard;
        if lambda <= 0.0 {
            return candidate.cost;
        }
        let (u, v) = (candidate.removed, candidate.kept);
        let c = surface.center();
        let p = candidate.position;
        let x = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
        let (pu, pv) = (surface.local(u), surface.local(v));
        let (mut du, mut dv) = (f64::INFINITY, f64::INFINITY);
        for owner in [u, v] {
            for &t in surface.fan(owner) {
                let tt = surface.triangle(t);
                // A triangle holding both points dies; one in both fans holds both.
                if tt[0] == crate::collapse::DEAD || (tt.contains(&u) && tt.contains(&v)) {
                    continue;
                }
                let q = tt.map(|k| {
                    if k == u || k == v {
                        x
                    } else {
                        surface.local(k)
                    }
                });
                du = du.min(crate::collapse::closest_on_triangle(pu, q).0);
                dv = dv.min(crate::collapse::closest_on_triangle(pv, q).0);
            }
        }
        let e2 = du.max(dv);
        if !e2.is_finite() {
            return candidate.cost;
        }
        let w = self.quadrics[u as usize].weight + self.quadrics[v as usize].weight;
        // An overflow must not drop the guard: cap it at the largest finite cost.
        let guard = (lambda * w * e2).min(f64::MAX);
        if guard > candidate.cost {
            guard
        } else {
            candidate.cost
        }
    }

    fn collapsed(&mut self, surface: &Surface, record: &CollapseRecord) {
        let r = self.quadrics[record.removed as usize];
        self.quadrics[record.kept as usize].add(&r);
        if let Some(w) = &mut self.wedges {
            if !record.non_edge {
                let two = surface.last_wedge_map();
                // Along a non-manifold edge every sheet's wedges merge.
                let map: &[(u32, u32)] = if record.removed_count > 2 {
                    surface.last_wedge_map_all()
                } else {
                    &two
                };
                self.quadrics[record.kept as usize].add(&w.correction(map));
                w.merge(map);
            }
        }
    }

    fn write_attributes(&self, surface: &mut Surface, record: &CollapseRecord) {
        // Endpoint placement keeps every vertex as it was, attributes included
        // (what a progressive mesh's vertex splits restore).
        if self.options.placement == Placement::Endpoint {
            return;
        }
        // A locked point keeps its attributes as well as its position (a chunk's
        // or a hierarchy group's border: the neighbours on the other side keep
        // theirs, and the two must still agree).
        if surface.kind(record.kept) == VertexKind::Locked {
            return;
        }
        if let Some(w) = &self.wedges {
            w.write_point(surface, record.kept);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collapse::BuildOptions;
    use crate::mesh::Mesh;

    /// A half-edge collapse that crosses a seam costs `seam_crossing_penalty` times
    /// the same collapse that does not; with both directions open, the cheaper
    /// priced one wins.
    #[test]
    fn a_seam_crossing_costs_its_penalty() {
        let mesh = crate::mesh::generate::grid(6, 5, |x, y| 0.2 * (2.0 * x).sin() * y);
        let (surface, _) = Surface::build(&mesh, &BuildOptions::default());
        let mut qem = Qem::new(QemOptions::default());
        qem.init(&surface);
        let penalty = QemOptions::default().seam_crossing_penalty;
        let moves = |a_to_b, b_to_a, crosses| Moves {
            a_to_b,
            b_to_a,
            merge: Merge::No,
            edge: true,
            crosses,
        };
        let mut checked = 0;
        for t in 0..surface.triangle_slots() as u32 {
            let [a, b, _] = surface.triangle(t);
            let cost = |m: Moves| qem.evaluate_cost(&surface, a, b, &m).expect("a move");
            let plain = cost(moves(true, false, [false; 2]));
            assert_eq!(cost(moves(true, false, [true, false])), plain * penalty);
            let back = cost(moves(false, true, [false; 2]));
            let both = cost(moves(true, true, [true, false]));
            assert_eq!(both, back.min(plain * penalty));
            checked += usize::from(plain > 0.0);
        }
        assert!(checked > 10, "{checked} edges with a positive cost");
    }

    /// `evaluate_cost` and `evaluate_cost_near` (what the driver queues) are bit for
    /// bit the cost of `evaluate`, for every edge of a bumpy open grid (interior,
    /// border and corner points), every placement and every combination of allowed
    /// moves.
    #[test]
    fn evaluate_cost_matches_evaluate() {
        let mesh = crate::mesh::generate::grid(9, 7, |x, y| {
            0.3 * (3.0 * x).sin() * (2.0 * y).cos() + 0.05 * x * y
        });
        let (surface, _) = Surface::build(&mesh, &BuildOptions::default());
        let mut checked = 0;
        for placement in [Placement::Optimal, Placement::Endpoint, Placement::Midpoint] {
            let mut qem = Qem::new(QemOptions {
                placement,
                ..QemOptions::default()
            });
            qem.init(&surface);
            for t in 0..surface.triangle_slots() as u32 {
                let tt = surface.triangle(t);
                for k in 0..3 {
                    let (a, b) = (tt[k], tt[(k + 1) % 3]);
                    for merge in [Merge::Anywhere, Merge::OnSegment, Merge::No] {
                        let dirs = [(true, true), (true, false), (false, true)];
                        let crossings = [[false; 2], [true, false], [false, true]];
                        for ((a_to_b, b_to_a), crosses) in
                            dirs.into_iter().flat_map(|d| crossings.map(|c| (d, c)))
                        {
                            let moves = Moves {
                                a_to_b,
                                b_to_a,
                                merge,
                                edge: true,
                                crosses,
                            };
                            let full = qem.evaluate(&surface, a, b, &moves).map(|c| c.cost);
                            let lean = qem.evaluate_cost(&surface, a, b, &moves);
                            assert_eq!(
                                full.map(f64::to_bits),
                                lean.map(f64::to_bits),
                                "pair ({a}, {b}) {moves:?} {placement:?}"
                            );
                            let near =
                                qem.evaluate_cost_near(&surface, a, surface.local(a), b, &moves);
                            assert_eq!(
                                full.map(f64::to_bits),
                                near.map(f64::to_bits),
                                "pair ({a}, {b}) {moves:?} {placement:?}, a's position given"
                            );
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(checked > 1000);
    }

    /// The AVX2 build of the placement rule ([`crate::isa`]) gives the baseline's
    /// positions and costs bit for bit (no fused multiply-adds), on every edge of a
    /// bumpy open grid with all moves allowed and with border rules.
    #[test]
    fn avx2_choice_is_bit_identical() {
        let mesh = crate::mesh::generate::grid(9, 7, |x, y| {
            0.3 * (3.0 * x).sin() * (2.0 * y).cos() + 0.05 * x * y
        });
        let (surface, _) = Surface::build(&mesh, &BuildOptions::default());
        let mut qem = Qem::new(QemOptions::default());
        qem.init(&surface);
        let bits = |r: Option<(Choice, f64)>| {
            r.map(|(c, cost)| {
                let p = match c {
                    Choice::Free(x) => x.map(f64::to_bits),
                    Choice::At { removed, kept } => [u64::from(removed), u64::from(kept), 0],
                };
                (p, cost.to_bits())
            })
        };
        let (mut compared, mut solved) = (0, 0);
        for t in 0..surface.triangle_slots() as u32 {
            let tt = surface.triangle(t);
            for k in 0..3 {
                let (a, b) = (tt[k], tt[(k + 1) % 3]);
                let Some(moves) = surface.moves(a, b, false) else {
                    continue;
                };
                let q = qem.quadric(a).sum(&qem.quadric(b));
                let (base, avx) = crate::isa::both!(bits(qem.choose(&q, &surface, a, b, &moves)));
                if let Some(avx) = avx {
                    assert_eq!(base, avx, "pair ({a}, {b})");
                    compared += 1;
                }
                solved += usize::from(matches!(
                    qem.choose(&q, &surface, a, b, &moves),
                    Some((Choice::Free(_), _))
                ));
            }
        }
        assert!(solved > 100);
        // Without AVX2 on the test machine there is nothing to compare.
        assert!(compared == 0 || compared > 300);
    }

    /// A nearly singular quadric (two unit planes `y = 0`, `z = 0` and a faint
    /// plane `x = 0.3` of weight `1.5e-7`: relative determinant ≈ 5·10⁻⁷) has a
    /// well-defined minimiser `(0.3, 0, 0)` off the edge `(0, 0.1, 0)–(1, 0.1, 0)`.
    /// QEM's default conditioning ([`QEM_CONDITION`]) solves for it (cost ≈ 0);
    /// the quadric module's stricter `1e-6` falls back to the edge (cost 0.01).
    #[test]
    fn default_condition_solves_nearly_singular_quadrics() {
        let mut q = Quadric::from_plane([0.0, 1.0, 0.0], 0.0, 1.0);
        q.add(&Quadric::from_plane([0.0, 0.0, 1.0], 0.0, 1.0));
        q.add(&Quadric::from_plane([1.0, 0.0, 0.0], -0.3, 1.5e-7));
        let (p0, p1) = ([0.0, 0.1, 0.0], [1.0, 0.1, 0.0]);
        let reach = QemOptions::default().max_reach;
        let loose = q.minimize(p0, p1, QemOptions::default().condition, reach);
        assert!(loose.solved);
        assert!(loose.cost < 1e-12, "cost {}", loose.cost);
        assert!((loose.position[0] - 0.3).abs() < 1e-6 && loose.position[1].abs() < 1e-9);
        let strict = q.minimize(p0, p1, crate::quadric::DEFAULT_CONDITION, reach);
        assert!(!strict.solved);
        assert!((strict.cost - 0.01).abs() < 1e-9, "cost {}", strict.cost);
    }

    /// The displacement guard on a flat 8×8 grid with one spike of height 2 at
    /// the centre: collapsing the spike onto a flat neighbour leaves the old tip 2
    /// off the (flat) new triangles, so the guarded priority is at least
    /// `λ · W · 2²`, above the quadric cost; a collapse between two flat points far
    /// from the spike keeps its cost, and with `λ = 0` nothing changes.
    #[test]
    fn displacement_guard_raises_tip_collapses_only() {
        let mesh = crate::mesh::generate::grid(8, 8, |x, y| {
            if (x - 0.5).abs() < 1e-9 && (y - 0.5).abs() < 1e-9 {
                2.0
            } else {
                0.0
            }
        });
        let (surface, _) = Surface::build(&mesh, &BuildOptions::default());
        let find = |x: [f32; 3]| {
            (0..surface.point_count() as u32)
                .find(|&p| surface.position(p) == x)
                .expect("point exists")
        };
        let tip = find([0.5, 0.5, 2.0]);
        let base = find([0.625, 0.5, 0.0]);
        let (f0, f1) = (find([0.125, 0.25, 0.0]), find([0.25, 0.25, 0.0]));
        for lambda in [0.0, 1.0] {
            let mut qem = Qem::new(QemOptions {
                displacement_guard: lambda,
                ..QemOptions::default()
            });
            qem.init(&surface);
            let moves = |a, b| {
                let mut m = surface.moves(a, b, false).expect("an edge");
                m.merge = Merge::No;
                m.b_to_a = false;
                m
            };
            let c = qem
                .evaluate(&surface, tip, base, &moves(tip, base))
                .expect("a candidate");
            assert_eq!((c.removed, c.kept), (tip, base));
            let w = qem.quadric(tip).weight + qem.quadric(base).weight;
            let guarded = qem.confirm(&surface, &c);
            if lambda == 0.0 {
                assert_eq!(guarded.to_bits(), c.cost.to_bits());
            } else {
                assert!(guarded > c.cost, "{guarded} vs {}", c.cost);
                assert!(
                    (guarded - 4.0 * w).abs() <= 1e-9 * guarded,
                    "{guarded} vs {}",
                    4.0 * w
                );
            }
            let flat = qem
                .evaluate(&surface, f0, f1, &moves(f0, f1))
                .expect("a candidate");
            assert_eq!(qem.confirm(&surface, &flat).to_bits(), flat.cost.to_bits());
        }
    }

    /// Two separate right triangles, legs 1 and 2 (areas 0.5 and 2):
    ///
    /// ```text
    ///   2 +             5 +
    ///     | \             |  \
    ///   0 +--+ 1        3 +----+ 4
    /// ```
    ///
    /// Each point's quadric weight is its triangle's weight `area^α · Ā^(1−α)`
    /// (`Ā = 1.25`; no border planes with `boundary_weight = 0`).
    #[test]
    fn area_exponent_sets_triangle_weights() {
        let mesh = Mesh::from_triangles(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [5.0, 0.0, 0.0],
                [7.0, 0.0, 0.0],
                [5.0, 2.0, 0.0],
            ],
            vec![[0, 1, 2], [3, 4, 5]],
        );
        let (surface, _) = Surface::build(&mesh, &BuildOptions::default());
        let mean: f64 = 1.25;
        for (alpha, small, big) in [
            (1.0, 0.5, 2.0),
            (0.0, mean, mean),
            (0.5, (0.5 * mean).sqrt(), (2.0 * mean).sqrt()),
        ] {
            let mut qem = Qem::new(QemOptions {
                boundary_weight: 0.0,
                area_exponent: alpha,
                ..QemOptions::default()
            });
            qem.init(&surface);
            let w = |x: [f32; 3]| {
                let p = (0..surface.point_count() as u32)
                    .find(|&p| surface.position(p) == x)
                    .expect("point exists");
                qem.quadric(p).weight
            };
            assert!((w([0.0, 0.0, 0.0]) - small).abs() < 1e-12, "alpha {alpha}");
            assert!((w([7.0, 0.0, 0.0]) - big).abs() < 1e-12, "alpha {alpha}");
        }
    }
}
