//! The edge-collapse operator: the connectivity it edits and the legality it enforces.
//!
//! This is the *operator* of the three-part split in `DESIGN.md` (operator / criteria /
//! strategy). It knows nothing about costs or about which collapse goes next; it
//! answers "may `u` be merged into `v` at position `p`?" and performs the merge.
//! Legality is always on and is not a plug-in:
//!
//! - **kinds** ([`VertexKind`]): a manifold vertex may go anywhere; a border vertex
//!   only slides along its border (collapses along a border edge, onto a border,
//!   complex or locked vertex); an attribute-seam or material-border vertex only
//!   along its seam; complex (non-manifold input) and locked vertices never move and
//!   are never removed, other vertices may only be merged *onto* them — except
//!   points inside a non-manifold chain when asked
//!   ([`BuildOptions::move_non_manifold`]), which slide along the chain as border
//!   points slide along their border (one triangle of every sheet dies), and, when
//!   asked ([`BuildOptions::move_junctions`]), a seam junction (one fan, complex only
//!   through its seam edges), which may be removed along one of its seam edges (its
//!   border edges when on a border), its wedges off that edge carried to the
//!   survivor; a permissive surface ([`BuildOptions::permissive`]) also lets seam
//!   points and junctions cross their seam;
//! - **link condition** (Dey et al.; Hoppe et al. 1993): the common neighbours of `u`
//!   and `v` are exactly the apexes of the triangles on edge `uv`, and an interior
//!   edge joining two boundary vertices is never collapsed — so a manifold
//!   neighbourhood stays manifold, no boundary edge and no non-manifold edge is
//!   created and no hole is closed; and no point loses its last triangle, so no
//!   small component is collapsed away;
//!   along a non-manifold edge the apexes are one per sheet, and the checks below
//!   run over every sheet around the two points;
//! - **no duplicate triangles** (the tetrahedron case the link condition misses;
//!   along a non-manifold edge, checked for every pair of apexes);
//! - **seams**: the wedges (attribute vertices) of `u` map onto wedges of `v`
//!   consistently on each side of a seam (a junction's or a crossing point's other
//!   wedges move to `v` whole);
//! - **geometry**: no surviving triangle may flip or turn past a limit against its
//!   pre-collapse normal (fold-over), and none may reach zero area.
//!
//! [`Surface`] stores the connectivity in flat arrays: per point a slice of the
//! triangle ids around it (a CSR array with slack; a merged fan is rewritten in place
//! or appended at the end, and the array is compacted when it has doubled). Every
//! check and update touches the one-ring of `u` and `v` only: O(valence).
//!
//! A collapse is recorded as a [`CollapseRecord`]; a half-edge collapse `u → v` onto
//! the existing vertex `v` is the special case `position == v`'s old position.

mod surface;
pub(crate) use surface::FanCsr;

pub(crate) use surface::canonical_wedges;
pub(crate) use surface::closest_on_triangle;
pub use surface::{
    BuildOptions, NonManifoldPoints, Repair, Surface, DEAD, MAX_SHEETS, SOLVED_COLOR,
    SOLVED_NORMAL, SOLVED_UV0, SOLVED_UV1,
};

use crate::mesh::VertexKind;

/// Why the operator refused a collapse.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reject {
    /// A vertex is dead, the two ids are equal, or a locked/complex vertex would move.
    Kind,
    /// A non-manifold edge that may not be collapsed: more triangles on it than
    /// [`MAX_SHEETS`], or (by the driver) a collapse along it that would remove
    /// more triangles than the target leaves room for.
    NonManifoldEdge,
    /// The link condition fails: the merge would pinch the surface, close a hole,
    /// glue two boundary vertices across an interior edge, or make a point vanish
    /// (the last triangle of a small component).
    Link,
    /// Two triangles over the same three vertices would result.
    Duplicate,
    /// The wedges of `u` do not map consistently onto those of `v` (seam).
    Seam,
    /// A surviving triangle would flip or turn past the fold-over limit.
    FoldOver,
    /// A surviving triangle would have (near) zero area.
    Degenerate,
    /// A non-edge contraction would touch a common neighbour (not allowed).
    Pair,
}

/// Which contractions of a pair `(a, b)` the operator allows, from the vertex kinds
/// and the type of the edge between them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Moves {
    /// `a` may be removed, merged onto `b` at `b`'s position (half-edge collapse).
    pub a_to_b: bool,
    /// `b` may be removed, merged onto `a` at `a`'s position.
    pub b_to_a: bool,
    /// Both may move: the merged vertex may be placed as described.
    pub merge: Merge,
    /// Whether `a` and `b` share an edge (`false`: a non-edge pair contraction).
    pub edge: bool,
    /// Whether the half-edge collapse `a → b` (first) and `b → a` (second) would
    /// cross an attribute seam or material border: a seam point or junction leaving
    /// along an edge that is not a seam, which only a surface built with
    /// [`BuildOptions::permissive`] allows. A cost model may price these higher.
    pub crosses: [bool; 2],
}

/// Where a merged vertex may be placed when both endpoints may move.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Merge {
    /// Both may not move: only half-edge collapses (`a_to_b` / `b_to_a`).
    No,
    /// Anywhere (two manifold vertices, or a non-edge pair of free vertices).
    Anywhere,
    /// On the segment between the two (border–border along a border edge,
    /// seam–seam along a seam), so a border or seam only slides along itself.
    OnSegment,
}

/// What a performed collapse did, in point ids, for observers and progressive-mesh
/// recorders.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CollapseRecord {
    /// The point that disappeared.
    pub removed: u32,
    /// The point that survived (and moved to `position`).
    pub kept: u32,
    /// Position of `removed` before the collapse.
    pub removed_position: [f32; 3],
    /// Position of `kept` before the collapse.
    pub kept_old_position: [f32; 3],
    /// Position of `kept` after the collapse (equal to `kept_old_position` for a
    /// half-edge collapse onto `kept`).
    pub position: [f32; 3],
    /// Triangles removed by the collapse ([`DEAD`] where fewer than two; the first
    /// two along a non-manifold edge, which removes one per sheet).
    pub removed_triangles: [u32; 2],
    /// How many triangles the collapse removed (two inside a surface, one on a
    /// border, one per sheet along a non-manifold edge, 0 for a non-edge pair).
    pub removed_count: u32,
    /// The apex of each removed triangle (Hoppe's `vl`, `vr`; [`DEAD`] where none).
    pub apexes: [u32; 2],
    /// Whether it was a non-edge pair contraction.
    pub non_edge: bool,
    /// The hole's third point when the collapse closed a hole of three border
    /// edges ([`OperatorLimits::close_holes`]), else [`DEAD`].
    pub closed_hole: u32,
    /// The cost the cost model gave it.
    pub cost: f64,
    /// The error (a distance in mesh units) the cost model gave it.
    pub error: f64,
}

/// Limits of the always-on geometric checks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OperatorLimits {
    /// A surviving triangle whose normal turns by more than this angle (radians)
    /// against its pre-collapse normal is a fold-over. Default `π/2`: a triangle may
    /// not turn to or past perpendicular.
    pub fold_over_angle: f64,
    /// Whether non-edge pairs may be contracted (only when topology need not be
    /// preserved).
    pub allow_non_edge: bool,
    /// Whether a collapse may close a hole of three border edges: `u`, `v` and a
    /// third border point `x` bound the hole, and merging `u` into `v` joins the
    /// border edges `(u, x)` and `(v, x)` into one edge inside the surface (the
    /// link condition refuses it otherwise, as it changes the topology). Only
    /// when every point of the hole is a border point (or a sliding pinch on a
    /// border, [`BuildOptions::move_pinches`]), the joined edge's two triangles
    /// differ in their third corners and agree in orientation.
    pub close_holes: bool,
}

impl Default for OperatorLimits {
    fn default() -> Self {
        Self {
            fold_over_angle: std::f64::consts::FRAC_PI_2,
            allow_non_edge: false,
            close_holes: false,
        }
    }
}

/// One triangle a proposed collapse changes (it survives, with a moved corner).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChangedTriangle {
    /// Triangle id.
    pub triangle: u32,
    /// Normal before (not normalised; its length is twice the area).
    pub old_normal: [f64; 3],
    /// Normal after (not normalised).
    pub new_normal: [f64; 3],
    /// Which corner (0, 1, 2) moves to [`Preview::position`].
    pub corner: u8,
    /// Sum of the squared edge lengths before, added in corner order (edges 0→1,
    /// 1→2, 2→0), as [`crate::filter::triangle_quality`] adds them.
    pub old_edges2: f64,
    /// The same after.
    pub new_edges2: f64,
}

impl ChangedTriangle {
    /// Corner positions before and after the collapse.
    #[must_use]
    pub fn corners(&self, surface: &Surface, preview: &Preview) -> ([[f64; 3]; 3], [[f64; 3]; 3]) {
        let old = surface
            .triangle(self.triangle)
            .map(|p| surface.position(p).map(f64::from));
        let mut new = old;
        new[usize::from(self.corner) % 3] = preview.position.map(f64::from);
        (old, new)
    }
}

/// A proposed collapse after the operator accepted it: what filters look at.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Preview {
    /// The point to remove.
    pub removed: u32,
    /// The point to keep.
    pub kept: u32,
    /// The new position of `kept`.
    pub position: [f32; 3],
    /// Surviving triangles with a moved corner.
    pub changed: Vec<ChangedTriangle>,
    /// Whether `removed` or `kept` is on a boundary.
    pub touches_boundary: bool,
    /// Whether the pair is an edge.
    pub edge: bool,
    /// How many triangles the collapse removes (two inside a surface, one on a
    /// border, one per sheet along a non-manifold edge, 0 for a non-edge pair).
    pub dying: usize,
    /// The hole's third point when the collapse closes a hole of three border
    /// edges ([`OperatorLimits::close_holes`]), else [`DEAD`].
    pub closes_hole: u32,
}

/// True when a point of this kind may be removed or moved.
#[must_use]
pub fn is_movable(kind: VertexKind) -> bool {
    matches!(
        kind,
        VertexKind::Manifold | VertexKind::Border | VertexKind::Seam
    )
}

#[cfg(test)]
mod tests;
