//! Quadric error metrics (Garland & Heckbert, *Surface Simplification Using Quadric
//! Error Metrics*, SIGGRAPH 1997).
//!
//! A plane `nᵀx + d = 0` with unit normal `n` is the vector `p = (n, d)`; the squared
//! distance of a point `x` to it is `(pᵀ x̄)²` with `x̄ = (x, 1)`, i.e. `x̄ᵀ K_p x̄` with
//! the *fundamental error quadric* `K_p = p pᵀ`. A vertex's quadric is the sum of the
//! `K_p` of the planes around it, and its error at `x` is `Δ(x) = x̄ᵀ Q x̄`: the sum of
//! squared distances from `x` to those planes.
//!
//! # Weighting, and how a quadric value maps to a distance
//! Plane quadrics are **area weighted**: a triangle of area `A` contributes `A · K_p`,
//! so `Δ(x)` is an area-weighted sum of squared distances (units: length⁴) and does not
//! depend on how finely a flat region is tessellated. Every quadric also carries the
//! sum of its weights ([`Quadric::weight`], units: length²). The *distance* reported
//! for an error value is
//!
//! ```text
//! distance(x) = sqrt( Δ(x) / weight )
//! ```
//!
//! the root-mean-square distance from `x` to the planes accumulated into the quadric,
//! weighted by area — a length in mesh units. [`Quadric::distance`] computes it; the
//! simplifier's reported `error` and its `max_error` bound are this distance (divided by
//! the bounding-box diagonal when relative).
//!
//! Boundary edges add a *constraint plane* ([`Quadric::from_boundary_edge`]): the plane
//! through the edge perpendicular to its triangle, weighted by `w · |e|²` so it has
//! the same units as an area weight and stays scale invariant.
//!
//! # Storage
//! A quadric is a symmetric 4×4 matrix stored as its 10 upper-triangle entries in
//! `f64`, plus the weight. Callers that work far from the origin should evaluate
//! quadrics in coordinates relative to a nearby centre (the simplifier uses the
//! bounding-box centre) to keep the `d²` terms small.

/// A symmetric 4×4 quadric `Q` in `f64`, with the sum of the weights it was built from.
///
/// Entries, row-major upper triangle: `[a², ab, ac, ad, b², bc, bd, c², cd, d²]` for a
/// single plane `(a, b, c, d)`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Quadric {
    /// The 10 distinct entries of the symmetric matrix.
    pub m: [f64; 10],
    /// Sum of the weights (areas, or `w·|e|²` for constraint planes) accumulated.
    pub weight: f64,
}

/// Result of minimising a quadric: where, the error there, and how it was found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Minimum {
    /// The position.
    pub position: [f64; 3],
    /// `Δ(position)`, clamped to be non-negative.
    pub cost: f64,
    /// Whether the full 3×3 system was solved (`true`) or a fallback along the edge
    /// was used (`false`).
    pub solved: bool,
}

/// Relative conditioning threshold for the 3×3 solve: the determinant must exceed
/// this times the cube of the mean diagonal entry (roughly: the smallest eigenvalue
/// must be at least this fraction of the largest).
pub const DEFAULT_CONDITION: f64 = 1e-6;

impl Quadric {
    /// The zero quadric.
    pub const ZERO: Self = Self {
        m: [0.0; 10],
        weight: 0.0,
    };

    /// `weight · p pᵀ` for the plane `n·x + d = 0`, with `n` a unit normal.
    #[must_use]
    pub fn from_plane(n: [f64; 3], d: f64, weight: f64) -> Self {
        let [a, b, c] = n;
        let w = weight;
        Self {
            m: [
                w * a * a,
                w * a * b,
                w * a * c,
                w * a * d,
                w * b * b,
                w * b * c,
                w * b * d,
                w * c * c,
                w * c * d,
                w * d * d,
            ],
            weight,
        }
    }

    /// The area-weighted plane quadric of triangle `(p0, p1, p2)`: its area times
    /// `K_p` of its plane. `None` when the triangle has zero area (no plane).
    #[must_use]
    pub fn from_triangle(p0: [f64; 3], p1: [f64; 3], p2: [f64; 3]) -> Option<Self> {
        let n = cross(sub(p1, p0), sub(p2, p0));
        let len = norm(n);
        if len.is_nan() || len <= 0.0 || !len.is_finite() {
            return None;
        }
        let un = scale(n, 1.0 / len);
        Some(Self::from_plane(un, -dot(un, p0), 0.5 * len))
    }

    /// The constraint quadric of a boundary edge `(p0, p1)` of a triangle with
    /// (not necessarily unit) normal `face_normal`: the plane containing the edge and
    /// perpendicular to the triangle, weighted by `weight · |p1 − p0|²`. `None` when
    /// the edge or the normal is degenerate.
    #[must_use]
    pub fn from_boundary_edge(
        p0: [f64; 3],
        p1: [f64; 3],
        face_normal: [f64; 3],
        weight: f64,
    ) -> Option<Self> {
        let e = sub(p1, p0);
        let n = cross(e, face_normal);
        let len = norm(n);
        if len.is_nan() || len <= 0.0 || !len.is_finite() {
            return None;
        }
        let un = scale(n, 1.0 / len);
        Some(Self::from_plane(un, -dot(un, p0), weight * dot(e, e)))
    }

    /// Adds `other` (matrix and weight).
    #[inline(always)]
    pub fn add(&mut self, other: &Self) {
        for (a, b) in self.m.iter_mut().zip(other.m.iter()) {
            *a += b;
        }
        self.weight += other.weight;
    }

    /// `self + other`.
    #[must_use]
    #[inline(always)]
    pub fn sum(&self, other: &Self) -> Self {
        let mut s = *self;
        s.add(other);
        s
    }

    /// Multiplies the matrix and the weight by `s`.
    pub fn scale(&mut self, s: f64) {
        for a in &mut self.m {
            *a *= s;
        }
        self.weight *= s;
    }

    /// `Δ(x) = x̄ᵀ Q x̄`. Mathematically non-negative; rounding can make it slightly
    /// negative, so callers that need a distance should use [`Self::distance`].
    #[must_use]
    #[inline(always)]
    pub fn evaluate(&self, x: [f64; 3]) -> f64 {
        let m = &self.m;
        let [x, y, z] = x;
        x * (m[0] * x + 2.0 * (m[1] * y + m[2] * z + m[3]))
            + y * (m[4] * y + 2.0 * (m[5] * z + m[6]))
            + z * (m[7] * z + 2.0 * m[8])
            + m[9]
    }

    /// The distance a quadric value stands for: `sqrt(max(cost, 0) / weight)`, the
    /// area-weighted RMS distance to the accumulated planes (0 when the weight is 0).
    #[must_use]
    pub fn distance(&self, cost: f64) -> f64 {
        if self.weight > 0.0 {
            (cost.max(0.0) / self.weight).sqrt()
        } else {
            0.0
        }
    }

    /// `A x + b` where `A` is the upper-left 3×3 block and `b` the last column.
    #[inline(always)]
    fn gradient_half(&self, x: [f64; 3]) -> [f64; 3] {
        let m = &self.m;
        [
            m[0] * x[0] + m[1] * x[1] + m[2] * x[2] + m[3],
            m[1] * x[0] + m[4] * x[1] + m[5] * x[2] + m[6],
            m[2] * x[0] + m[5] * x[1] + m[7] * x[2] + m[8],
        ]
    }

    /// The minimiser of `Δ` over all of space, found by solving `A x = −b` relative to
    /// `origin` (pass a nearby point, e.g. the edge midpoint, for conditioning).
    /// `None` when the system is ill-conditioned: `det(A) ≤ condition · (tr(A)/3)³`.
    #[must_use]
    #[inline(always)]
    pub fn solve(&self, origin: [f64; 3], condition: f64) -> Option<[f64; 3]> {
        let m = &self.m;
        let (a00, a01, a02, a11, a12, a22) = (m[0], m[1], m[2], m[4], m[5], m[7]);
        let c00 = a11 * a22 - a12 * a12;
        let c01 = a02 * a12 - a01 * a22;
        let c02 = a01 * a12 - a02 * a11;
        let det = a00 * c00 + a01 * c01 + a02 * c02;
        let t = (a00 + a11 + a22) / 3.0;
        if det.is_nan() || det <= condition * t * t * t || t.is_nan() || t <= 0.0 {
            return None;
        }
        let c11 = a00 * a22 - a02 * a02;
        let c12 = a01 * a02 - a00 * a12;
        let c22 = a00 * a11 - a01 * a01;
        // Residual at the origin: r = A o + b; step y = −A⁻¹ r.
        let r = self.gradient_half(origin);
        let inv = 1.0 / det;
        let y = [
            -(c00 * r[0] + c01 * r[1] + c02 * r[2]) * inv,
            -(c01 * r[0] + c11 * r[1] + c12 * r[2]) * inv,
            -(c02 * r[0] + c12 * r[1] + c22 * r[2]) * inv,
        ];
        let x = add(origin, y);
        x.iter().all(|v| v.is_finite()).then_some(x)
    }

    /// The minimiser of `Δ` on the segment `[p0, p1]`: `p0 + t (p1 − p0)` with `t` in
    /// `[0, 1]` minimising the quadratic `Δ` (within `10⁻⁶` of an end it snaps to
    /// that end). When `Δ` is flat along the segment the midpoint is returned.
    /// Returns `(t, position, cost)`.
    #[must_use]
    #[inline(always)]
    pub fn minimize_on_segment(&self, p0: [f64; 3], p1: [f64; 3]) -> (f64, [f64; 3], f64) {
        let d = sub(p1, p0);
        let g = self.gradient_half(p0);
        let ad = self.gradient_half(d);
        // Δ(p0 + t d) = Δ(p0) + 2 t dᵀ(A p0 + b) + t² dᵀ A d
        let alpha = dot(d, sub(ad, [self.m[3], self.m[6], self.m[8]]));
        let beta = dot(d, g);
        let t = if alpha > 1e-300 {
            // Snap to the ends within rounding noise, so an endpoint stays exact.
            let t = -beta / alpha;
            if t < 1e-6 {
                0.0
            } else if t > 1.0 - 1e-6 {
                1.0
            } else {
                t
            }
        } else if beta.abs() <= 1e-300 {
            0.5
        } else if beta > 0.0 {
            0.0
        } else {
            1.0
        };
        let x = add(p0, scale(d, t));
        (t, x, self.evaluate(x).max(0.0))
    }

    /// The best position for contracting the edge `(p0, p1)` under this (summed)
    /// quadric: the solution of the 3×3 system when it is well conditioned and lies
    /// within `max_reach` edge lengths of the midpoint, otherwise the minimum along
    /// the segment (which includes both endpoints and the midpoint).
    #[must_use]
    #[inline(always)]
    pub fn minimize(&self, p0: [f64; 3], p1: [f64; 3], condition: f64, max_reach: f64) -> Minimum {
        let mid = scale(add(p0, p1), 0.5);
        if let Some(x) = self.solve(mid, condition) {
            let e2 = dot(sub(p1, p0), sub(p1, p0));
            let off = sub(x, mid);
            if dot(off, off) <= max_reach * max_reach * e2 {
                return Minimum {
                    position: x,
                    cost: self.evaluate(x).max(0.0),
                    solved: true,
                };
            }
        }
        let (_, x, cost) = self.minimize_on_segment(p0, p1);
        Minimum {
            position: x,
            cost,
            solved: false,
        }
    }
}

#[inline(always)]
pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline(always)]
pub(crate) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline(always)]
pub(crate) fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
#[inline(always)]
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline(always)]
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
#[inline(always)]
pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
    }

    /// K_p = p pᵀ: the error of a point is its squared distance to the plane.
    #[test]
    fn plane_quadric_is_squared_distance() {
        // z = 2 plane: n = (0,0,1), d = -2.
        let q = Quadric::from_plane([0.0, 0.0, 1.0], -2.0, 1.0);
        assert!(close(q.evaluate([5.0, -3.0, 2.0]), 0.0));
        assert!(close(q.evaluate([0.0, 0.0, 5.0]), 9.0));
        assert!(close(q.distance(q.evaluate([1.0, 1.0, -1.0])), 3.0));
    }

    /// Triangle (0,0,0) (2,0,0) (0,2,0): area 2, plane z = 0.
    #[test]
    fn triangle_quadric_is_area_weighted() {
        let q = Quadric::from_triangle([0.0; 3], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]).unwrap();
        assert!(close(q.weight, 2.0));
        assert!(close(q.evaluate([7.0, 7.0, 3.0]), 2.0 * 9.0));
        assert!(close(q.distance(q.evaluate([7.0, 7.0, 3.0])), 3.0));
        assert!(Quadric::from_triangle([0.0; 3], [1.0; 3], [2.0; 3]).is_none());
    }

    /// Three orthogonal planes through (1,2,3) meet in a single point: the solve finds it.
    #[test]
    fn corner_is_solved_exactly() {
        let mut q = Quadric::ZERO;
        q.add(&Quadric::from_plane([1.0, 0.0, 0.0], -1.0, 1.0));
        q.add(&Quadric::from_plane([0.0, 1.0, 0.0], -2.0, 1.0));
        q.add(&Quadric::from_plane([0.0, 0.0, 1.0], -3.0, 1.0));
        let x = q.solve([0.0; 3], DEFAULT_CONDITION).unwrap();
        assert!(close(x[0], 1.0) && close(x[1], 2.0) && close(x[2], 3.0));
        let m = q.minimize([0.0; 3], [2.0, 4.0, 6.0], DEFAULT_CONDITION, 10.0);
        assert!(m.solved && m.cost < 1e-12);
    }

    /// A single plane is rank 1: the solve refuses and the segment fallback is used.
    /// Edge from (0,0,1) to (0,0,-3) through z = 0: the minimum on it is at z = 0.
    #[test]
    fn flat_quadric_falls_back_to_segment() {
        let q = Quadric::from_plane([0.0, 0.0, 1.0], 0.0, 1.0);
        assert!(q.solve([0.0; 3], DEFAULT_CONDITION).is_none());
        let m = q.minimize([0.0, 0.0, 1.0], [0.0, 0.0, -3.0], DEFAULT_CONDITION, 2.0);
        assert!(!m.solved);
        assert!(close(m.position[2], 0.0) && m.cost < 1e-12);
        // Flat along the segment: the midpoint.
        let (t, _, _) = q.minimize_on_segment([0.0; 3], [1.0, 0.0, 0.0]);
        assert!(close(t, 0.5));
        // Minimum outside the segment is clamped to the nearer end.
        let (t, x, c) = q.minimize_on_segment([0.0, 0.0, 1.0], [0.0, 0.0, 2.0]);
        assert!(close(t, 0.0) && close(x[2], 1.0) && close(c, 1.0));
    }

    /// A far-away optimum (nearly parallel planes) is rejected by `max_reach`.
    #[test]
    fn far_optimum_is_rejected() {
        let mut q = Quadric::ZERO;
        let s = 1e-3_f64;
        let n1 = [s, 0.0, 1.0];
        let l = norm(n1);
        q.add(&Quadric::from_plane(scale(n1, 1.0 / l), 0.0, 1.0));
        q.add(&Quadric::from_plane([0.0, 0.0, 1.0], -1e-2, 1.0));
        q.add(&Quadric::from_plane([0.0, 1.0, 0.0], 0.0, 1.0));
        let m = q.minimize([0.0; 3], [1.0, 0.0, 0.0], 0.0, 2.0);
        assert!(!m.solved);
        assert!(m.position.iter().all(|v| v.abs() <= 1.0));
    }

    /// Boundary constraint plane: perpendicular to the face, through the edge.
    #[test]
    fn boundary_plane_contains_edge() {
        let q =
            Quadric::from_boundary_edge([0.0; 3], [2.0, 0.0, 0.0], [0.0, 0.0, 1.0], 3.0).unwrap();
        assert!(close(q.weight, 12.0));
        assert!(close(q.evaluate([5.0, 0.0, 7.0]), 0.0));
        assert!(close(q.evaluate([0.0, 1.0, 0.0]), 12.0));
    }

    #[test]
    fn add_and_scale() {
        let a = Quadric::from_plane([1.0, 0.0, 0.0], 0.0, 1.0);
        let mut b = a.sum(&a);
        assert!(close(b.evaluate([2.0, 0.0, 0.0]), 8.0));
        b.scale(0.5);
        assert_eq!(b, a);
    }
}
