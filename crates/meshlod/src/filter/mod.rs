//! Filters: vetoes on proposed collapses (the other half of the *criteria*, kept
//! apart from costs — see `DESIGN.md`).
//!
//! A [`Filter`] looks at a [`Preview`] of a collapse the operator already accepted
//! (the surviving triangles with their old and new normals and corners) and says
//! yes or no. A filter is *soft* when it states a preference rather than a
//! guarantee: the edge-collapse driver does not veto what a soft filter refuses but
//! ranks it later, at a multiple of its cost (`decimate::edge_collapse`), so the
//! preference gives way where every alternative costs much more (a terrain's cliffs,
//! where long thin triangles are the right shape).
//!
//! Provided: [`NormalDeviation`] (maximum normal turn), [`AspectRatio`] (no new
//! slivers), [`LockBoundary`] (boundary points neither move nor go).

use crate::collapse::{Preview, Surface};
use crate::quadric::{dot, sub};

/// A veto on collapses.
pub trait Filter {
    /// A short name for reports (`"normal_deviation"`).
    fn name(&self) -> &'static str;

    /// Whether the filter states a preference that ranks collapses rather than a
    /// veto (default `false`: a veto).
    fn is_soft(&self) -> bool {
        false
    }

    /// Whether the previewed collapse is allowed.
    fn allow(&self, surface: &Surface, preview: &Preview) -> bool;
}

/// Vetoes collapses that turn a surviving triangle's normal by more than an angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalDeviation {
    cos_max: f64,
}

impl NormalDeviation {
    /// Allows turns up to `max_degrees` (clamped to `[0, 180]`).
    #[must_use]
    pub fn new(max_degrees: f64) -> Self {
        Self {
            cos_max: max_degrees.clamp(0.0, 180.0).to_radians().cos(),
        }
    }
}

impl Filter for NormalDeviation {
    fn name(&self) -> &'static str {
        "normal_deviation"
    }

    fn allow(&self, _surface: &Surface, preview: &Preview) -> bool {
        preview.changed.iter().all(|c| {
            let d = dot(c.old_normal, c.new_normal);
            let l = (dot(c.old_normal, c.old_normal) * dot(c.new_normal, c.new_normal)).sqrt();
            d >= self.cos_max * l
        })
    }
}

/// Triangle quality `4√3 · area / (l₀² + l₁² + l₂²)`: 1 for an equilateral
/// triangle, 0 for a degenerate one.
#[must_use]
pub fn triangle_quality(corners: &[[f64; 3]; 3], normal: [f64; 3]) -> f64 {
    let e = |i: usize, j: usize| {
        let d = sub(corners[j], corners[i]);
        dot(d, d)
    };
    quality_from_edges(e(0, 1) + e(1, 2) + e(2, 0), normal)
}

/// [`triangle_quality`] from the sum of the squared edge lengths and the normal
/// (length twice the area).
#[must_use]
#[inline]
pub fn quality_from_edges(s: f64, normal: [f64; 3]) -> f64 {
    if s > 0.0 {
        // |normal| = 2 · area, so 4√3 · area = 2√3 · |normal|.
        2.0 * 3f64.sqrt() * dot(normal, normal).sqrt() / s
    } else {
        0.0
    }
}

/// Vetoes collapses that create a triangle of quality below a minimum when that
/// triangle was better before (so existing slivers do not block progress). Soft.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AspectRatio {
    /// Minimum [`triangle_quality`] of a new triangle.
    pub min_quality: f64,
}

impl Filter for AspectRatio {
    fn name(&self) -> &'static str {
        "aspect_ratio"
    }

    fn is_soft(&self) -> bool {
        true
    }

    fn allow(&self, _surface: &Surface, preview: &Preview) -> bool {
        // The edge sums come with the preview (the operator's check had the corners
        // loaded): the same sums, in the same order, as `triangle_quality` forms.
        preview.changed.iter().all(|c| {
            let q1 = quality_from_edges(c.new_edges2, c.new_normal);
            q1 >= self.min_quality || q1 >= quality_from_edges(c.old_edges2, c.old_normal)
        })
    }
}

/// Vetoes collapses that remove or move a point on a boundary edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LockBoundary;

impl Filter for LockBoundary {
    fn name(&self) -> &'static str {
        "lock_boundary"
    }

    fn allow(&self, surface: &Surface, preview: &Preview) -> bool {
        if !preview.touches_boundary {
            return true;
        }
        if surface.is_boundary(preview.removed) {
            return false;
        }
        !(surface.is_boundary(preview.kept) && surface.position(preview.kept) != preview.position)
    }
}
