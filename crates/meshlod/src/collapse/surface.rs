//! [`Surface`]: welded connectivity in flat arrays, vertex kinds, the legality checks
//! and the collapse itself.

use super::{ChangedTriangle, CollapseRecord, Merge, Moves, OperatorLimits, Preview, Reject};
use crate::mesh::{Mesh, VertexAttributes, VertexKind, Weld};
use crate::quadric::{cross, dot, sub};

/// Live triangles as wedge triples, point triples and optional groups.
pub(crate) type OutputTriangles = (Vec<[u32; 3]>, Vec<[u32; 3]>, Option<Vec<u32>>);

/// [`Surface::set_solved_streams`]: normals.
pub const SOLVED_NORMAL: u8 = 1;
/// [`Surface::set_solved_streams`]: the first texture coordinates.
pub const SOLVED_UV0: u8 = 2;
/// [`Surface::set_solved_streams`]: the second texture coordinates.
pub const SOLVED_UV1: u8 = 4;
/// [`Surface::set_solved_streams`]: colours.
pub const SOLVED_COLOR: u8 = 8;

/// Marks a dead triangle (all three corners) and "no triangle" in records.
pub const DEAD: u32 = u32::MAX;

/// Extra slots given to every fan when the fan array is (re)built.
const FAN_SLACK: u32 = 2;

/// The fan array's spare room is `1 / FAN_ROOM` of its length: reserved when it is
/// built and added when it grows (not doubled: it is the largest per-triangle
/// structure, and room reserved but never written is not resident).
const FAN_ROOM: usize = 4;

/// Most triangles on one non-manifold edge that a collapse along it handles (sheets
/// meeting at the edge); a chain edge with more stays.
pub const MAX_SHEETS: usize = 8;

/// Point → triangle fans as one array with room to grow: point `p`'s fan is
/// `fans[start[p]..start[p] + len[p]]`, in triangle order, with `cap[p] = len[p] +`
/// [`FAN_SLACK`] slots reserved (unused ones hold [`DEAD`]; none for an unused point).
/// Vertex removal's surface uses it; [`Surface`] builds the same layout straight into
/// its per-point records.
pub(crate) struct FanCsr {
    pub fans: Vec<u32>,
    pub start: Vec<u32>,
    pub len: Vec<u32>,
    pub cap: Vec<u32>,
}

impl FanCsr {
    /// Fans of `points` points over `tris`, whose live corners `corners` gives
    /// (`None` for a dead triangle); triangle ids are positions in `tris`.
    pub(crate) fn build<T>(
        points: usize,
        tris: &[T],
        corners: impl Fn(&T) -> Option<[u32; 3]>,
    ) -> Self {
        let mut len = vec![0u32; points];
        for t in tris {
            if let Some(c) = corners(t) {
                for p in c {
                    len[p as usize] += 1;
                }
            }
        }
        let mut start = Vec::with_capacity(points);
        let mut cap = Vec::with_capacity(points);
        let mut total = 0u32;
        for &l in &len {
            start.push(total);
            let c = if l == 0 { 0 } else { l + FAN_SLACK };
            cap.push(c);
            total += c;
        }
        let mut fans = vec![DEAD; total as usize];
        let mut fill = vec![0u32; points];
        for (ti, t) in tris.iter().enumerate() {
            if let Some(c) = corners(t) {
                for p in c {
                    let p = p as usize;
                    fans[(start[p] + fill[p]) as usize] = ti as u32;
                    fill[p] += 1;
                }
            }
        }
        Self {
            fans,
            start,
            len: fill,
            cap,
        }
    }
}

/// Options for [`Surface::build`].
#[derive(Debug, Clone, Copy, Default)]
pub struct BuildOptions<'a> {
    /// Per input vertex: `true` locks it (its point is never moved or removed).
    pub locked: Option<&'a [bool]>,
    /// Number the points in Z order of their positions ([`Weld::sort_spatially`])
    /// instead of the input's first-occurrence order, so that the fans, triangles
    /// and per-point records walked together sit together in memory whatever the
    /// input's vertex order. Default `false` (point ids follow the input, which
    /// small hand-built tests rely on); [`crate::simplify()`] turns it on for the
    /// edge-collapse methods.
    pub spatial_order: bool,
    /// Remember, for each point a collapse removes, the point it was merged into, so
    /// that `Surface::vertex_roots` can say where every input vertex ended (4 bytes
    /// a point, plus the input vertex → point map kept). Default `false`.
    pub track_merges: bool,
    /// Let seam junctions move: a point where three or more attribute-seam or
    /// material-border edges meet, or where such edges meet an open border (kinds
    /// that are otherwise frozen), may be removed by a half-edge collapse along one
    /// of its seam edges (along a border edge when it is on a border) onto its
    /// neighbour there. The wedges on the two sides of that edge merge into the
    /// neighbour's; its other wedges move to the neighbour with their attributes
    /// taken at its position, so every seam line through it keeps its end points
    /// and the junction slides along the seam. Default `false`; QEM turns it on.
    pub move_junctions: bool,
    /// Permissive seams: a seam point (or, with [`Self::move_junctions`], a seam
    /// junction) may also collapse across its seam, along any interior edge; the
    /// wedges on that edge's side merge, the others move with the point (their
    /// attributes taken at the new place), so the seam line moves. The cost model
    /// pays for it through its seam planes and attribute terms (and may price it
    /// higher, [`super::Moves::crosses`]). Open borders are still kept. Default
    /// `false`.
    pub permissive: bool,
    /// Let wedges whose dominant skin joints differ merge (with
    /// [`Self::permissive`]: a skin's joint borders are then crossed like other
    /// seams). Default `false`: a collapse that would merge them is refused.
    pub merge_joints: bool,
    /// Let non-manifold chains simplify along themselves: a point whose only
    /// non-manifold edges are two (a point inside a chain of edges shared by three
    /// or more triangles), whose every sheet (fan) runs from one of them to the
    /// other, with no border or seam edge, may be removed by a half-edge collapse
    /// along one of those two edges, onto the chain's next point, or merged with it
    /// on the segment when that is a chain point too. Every sheet then loses its
    /// triangle on the edge, and the chain keeps its shape (the cost model holds it
    /// to its line). Chain ends and points where chains meet, meet a border, or
    /// where several fans touch at one point stay. Default `false`; QEM turns it on.
    pub move_non_manifold: bool,
    /// Let pinches slide: a point where several fans touch (without a
    /// non-manifold edge) may be removed by a half-edge collapse along an edge of
    /// one of its fans (a border edge when it is on a border) onto its neighbour
    /// there, which then holds every fan: the pinch moves by one edge, the fans
    /// stay apart (the link condition), and the point no longer pins the triangles
    /// around it. Default `false`; free topology turns it on.
    pub move_pinches: bool,
}

/// What the up-front repair removed from the input.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Repair {
    /// Triangles with a repeated point (after welding) or exactly zero area.
    pub degenerate_triangles: usize,
    /// Extra copies of triangles over the same three points (any order or winding).
    pub duplicate_triangles: usize,
}

/// The non-manifold points of a surface, by why they stay where they are
/// ([`Surface::non_manifold_census`]). A point counts once, under the first
/// reason that applies in this order.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct NonManifoldPoints {
    /// All of them.
    pub total: usize,
    /// Points where a non-manifold chain ends or where three or more meet (one, or
    /// more than two, non-manifold edges): corners of the chain network, kept.
    pub corner: usize,
    /// Chain points that also lie on an open border: kept, as a border's corner.
    pub border: usize,
    /// Chain points on an attribute seam or material border inside a sheet: kept.
    pub seam: usize,
    /// Chain points whose sheets do not each run from one chain edge to the other
    /// (a sheet folding back onto the same edge) or with more than
    /// [`MAX_SHEETS`] triangles on a chain edge: kept.
    pub irregular: usize,
    /// Points where several fans touch without a non-manifold edge (a pinch, a
    /// "bow-tie"): a point feature, kept.
    pub pinch: usize,
    /// Chain points that could slide along their chain but did not (the run
    /// reached its target first, or every collapse along the chain was illegal or
    /// too costly), or any non-manifold point where chains may not move (methods
    /// other than QEM).
    pub chain: usize,
}

impl NonManifoldPoints {
    /// Adds `other`'s counts `times` times (the parts of a scene, each drawn
    /// `times` times).
    pub fn add(&mut self, other: &Self, times: usize) {
        self.total += times * other.total;
        self.corner += times * other.corner;
        self.border += times * other.border;
        self.seam += times * other.seam;
        self.irregular += times * other.irregular;
        self.pinch += times * other.pinch;
        self.chain += times * other.chain;
    }
}

/// Why a point is non-manifold (`Surface::nm_reason`); 0: it is not.
const NM_CHAIN: u8 = 1;
const NM_CORNER: u8 = 2;
const NM_BORDER: u8 = 3;
const NM_SEAM: u8 = 4;
const NM_IRREGULAR: u8 = 5;
const NM_PINCH: u8 = 6;

/// Fixed inputs of the geometric checks of one proposed collapse.
struct Geometry {
    cos_limit: f64,
    /// Squared height (length²) at or below which a triangle is degenerate: its
    /// smallest height, over its longest edge, is compared (see `Surface::height_eps2`).
    height_eps2: f64,
    p: [f64; 3],
}

/// Where a point's fan lives in the fan array: start, length (its live triangles)
/// and capacity, together so one cache line serves all three.
#[derive(Debug, Clone, Copy, Default)]
struct FanSlot {
    start: u32,
    len: u32,
    cap: u32,
}

/// Per-neighbour scratch used while classifying a point.
#[derive(Debug, Clone, Copy, Default)]
struct EdgeScratch {
    q: u32,
    count: u32,
    t1: u32,
    t2: u32,
    l1: u32,
    l2: u32,
}

/// The triangles a collapse kills: those over both of its points
/// ([`Surface::kill_shared_triangles`]).
#[derive(Debug, Clone, Copy)]
struct Dying {
    /// `(u's wedge, v's wedge)` in the first two of them, with per-corner wedges
    /// (`(DEAD, DEAD)` where none).
    wedge_map: [(u32, u32); 2],
    /// The first two of them ([`DEAD`] where fewer).
    triangles: [u32; 2],
    /// Their third corners ([`DEAD`] where fewer).
    apexes: [u32; 2],
    /// How many died (0 for a non-edge pair).
    count: usize,
    /// `(u's wedge, v's wedge)` in each of them (up to [`MAX_SHEETS`]; the first
    /// two are `wedge_map`), with per-corner wedges.
    wedge_map_all: [(u32, u32); MAX_SHEETS],
    /// The third corners of all of them (up to [`MAX_SHEETS`]).
    apexes_all: [u32; MAX_SHEETS],
}

/// Connectivity of a welded triangle mesh being simplified.
///
/// Points are welded positions (ids `0..point_count`), triangles refer to points and,
/// for attribute meshes with seams, to *wedges* (canonical input vertex ids, one per
/// distinct attribute set at a position). Everything is a flat `Vec`.
#[derive(Debug, Clone)]
pub struct Surface {
    pos: Vec<[f32; 3]>,
    kind: Vec<VertexKind>,
    boundary: Vec<bool>,
    /// Per point: where its fan lives in `fans` (one record, one cache line).
    fan_slot: Vec<FanSlot>,
    fans: Vec<u32>,
    fan_garbage: usize,
    tri: Vec<[u32; 3]>,
    tri_wedge: Option<Vec<[u32; 3]>>,
    tri_group: Option<Vec<u32>>,
    wedge_point: Vec<u32>,
    point_wedge: Vec<u32>,
    attrs: VertexAttributes,
    live_tris: usize,
    center: [f64; 3],
    diag: f64,
    /// `(ε_f32·diag)²`: a triangle whose smallest height is at or below `ε_f32·diag`
    /// (the spacing of `f32` coordinates over a box of that size) is degenerate.
    height_eps2: f64,
    mark: Vec<u32>,
    gen: u32,
    slot: Vec<u32>,
    scratch_edges: Vec<EdgeScratch>,
    scratch_parent: Vec<u32>,
    /// Per point, the point a collapse merged it into ([`DEAD`] while it lives);
    /// empty unless [`BuildOptions::track_merges`].
    merged: Vec<u32>,
    scratch_plans: Vec<(u32, [u32; 3], [f64; 3])>,
    /// Attribute streams (`SOLVED_*` bits) whose values of the survivor's wedges
    /// the cost model writes after every collapse ([`Self::set_solved_streams`]):
    /// not interpolated by the collapse.
    solved_streams: u8,
    kind_changed: [u32; MAX_SHEETS],
    fold_angle: f64,
    fold_cos: f64,
    /// Per point: a complex point whose fan is one disc (open or closed) and that is
    /// complex only through its seam edges ([`BuildOptions::move_junctions`]); all
    /// `false` without that option.
    junction: Vec<bool>,
    move_junctions: bool,
    move_pinches: bool,
    permissive: bool,
    merge_joints: bool,
    /// Per point: a point inside a non-manifold chain that may slide along it
    /// ([`BuildOptions::move_non_manifold`]); empty without that option.
    chain: Vec<bool>,
    /// Per fan triangle while classifying: which chain edges end its fan.
    scratch_ends: Vec<u8>,
    /// Per point: why it is non-manifold (`NM_*`), 0 when it is not.
    nm_reason: Vec<u8>,
    /// `(u's wedge, v's wedge)` on the triangles the last collapse removed.
    last_wedge_map: [(u32, u32); 2],
    /// The same for all of them (more than two on a non-manifold edge), and how many.
    last_wedge_map_all: [(u32, u32); MAX_SHEETS],
    last_dying: usize,
    /// `(u, v, x)` when the last accepted [`Self::check`] closes the hole
    /// `u, v, x` ([`OperatorLimits::close_holes`]; `x` is [`DEAD`] otherwise), for
    /// the collapse that follows it.
    pending_zip: [u32; 3],
}

#[inline(always)]
fn f64x3(p: [f32; 3]) -> [f64; 3] {
    [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]
}

impl Surface {
    /// Welds `mesh`, removes degenerate and duplicate triangles (counted in the
    /// returned [`Repair`]), builds the fans and classifies every point.
    ///
    /// Vertices with bitwise-equal positions and equal attributes become one wedge;
    /// with equal positions they share a point.
    ///
    /// # Panics
    /// Panics if `mesh` does not [validate](Mesh::validate) or `options.locked` is
    /// shorter than the vertex list.
    #[must_use]
    pub fn build(mesh: &Mesh, options: &BuildOptions<'_>) -> (Self, Repair) {
        // One box for the Z order and the diagonal.
        let bounds = mesh.bounding_box(false);
        let mut weld = Weld::exact(&mesh.positions);
        if let (true, Some(b)) = (options.spatial_order, bounds) {
            weld.sort_spatially(&mesh.positions, b);
        }
        let np = weld.point_count();
        let has_attrs = !mesh.attributes.is_empty();
        // Without attributes every vertex's wedge is its point's representative, which
        // only the (then absent) per-corner wedges would record.
        let canonical = has_attrs.then(|| canonical_wedges(mesh, &weld, true));
        let point_of = weld.point_of;
        let representative = weld.representative;
        let pos: Vec<[f32; 3]> = representative
            .iter()
            .map(|&v| mesh.positions[v as usize])
            .collect();

        // Triangles without degenerate ones, ordered by their smallest point, then
        // without duplicate copies.
        let mut repair = Repair::default();
        let kept = keep_nondegenerate(mesh, canonical, &point_of, &pos, &mut repair);
        let SortedTriangles {
            mut tri,
            wedge: tri_wedge,
            group: tri_group,
            ends,
        } = sort_by_smallest_point(kept, np);
        let n = tri.len();
        // Junctions exist only where seams do (wedges or groups).
        let move_junctions = options.move_junctions && (tri_wedge.is_some() || tri_group.is_some());
        repair.duplicate_triangles = remove_duplicates(&mut tri, &ends[..np]);

        let (diag, center) = diagonal_and_center(bounds);
        // A triangle is degenerate when its smallest height is at or below the
        // spacing of `f32` coordinates over the bounding box, `ε·diag`: its normal is
        // then no longer set by its stored corners. Relative to the box, so the same
        // shape at any scale is judged the same; relative to the triangle's own
        // longest edge, so a mesh of many small triangles (a 16.7M-triangle terrain,
        // whose cells are far below `ε·diag²` in area) is not judged degenerate
        // everywhere, as an area bound did.
        let height_eps = f64::from(f32::EPSILON) * diag;
        let mut s = Self {
            pos,
            kind: vec![VertexKind::Complex; np],
            boundary: vec![false; np],
            fan_slot: Vec::new(),
            fans: Vec::new(),
            fan_garbage: 0,
            tri,
            tri_wedge,
            tri_group,
            wedge_point: point_of,
            point_wedge: vec![DEAD; np],
            attrs: if has_attrs {
                mesh.attributes.clone()
            } else {
                VertexAttributes::default()
            },
            live_tris: 0,
            center,
            diag,
            height_eps2: height_eps * height_eps,
            mark: vec![0; np],
            gen: 0,
            slot: vec![0; np],
            scratch_edges: Vec::new(),
            scratch_parent: Vec::new(),
            merged: if options.track_merges {
                vec![DEAD; np]
            } else {
                Vec::new()
            },
            solved_streams: 0,
            scratch_plans: Vec::new(),
            kind_changed: [DEAD; MAX_SHEETS],
            fold_angle: f64::NAN,
            junction: if move_junctions {
                vec![false; np]
            } else {
                Vec::new()
            },
            move_junctions,
            move_pinches: options.move_pinches,
            permissive: options.permissive,
            merge_joints: options.merge_joints,
            chain: if options.move_non_manifold {
                vec![false; np]
            } else {
                Vec::new()
            },
            scratch_ends: Vec::new(),
            nm_reason: vec![0; np],
            last_wedge_map: [(DEAD, DEAD); 2],
            last_wedge_map_all: [(DEAD, DEAD); MAX_SHEETS],
            last_dying: 0,
            pending_zip: [DEAD; 3],
            fold_cos: 0.0,
        };
        s.build_fans();
        s.live_tris = n - repair.duplicate_triangles;

        s.assign_point_wedges(&representative);
        for p in 0..np as u32 {
            s.classify(p);
        }
        if let Some(locked) = options.locked {
            s.lock(locked);
        }
        // The wedge → point map is only needed to move seam wedges (non-edge pairs).
        // (Kept to follow the merges.)
        if s.tri_wedge.is_none() && !options.track_merges {
            s.wedge_point = Vec::new();
        }
        (s, repair)
    }

    /// Sets each point's wedge: with per-corner wedges, the wedge of its first
    /// corner (then, when no point has corners with different wedges, the
    /// per-corner wedges are dropped, as no seam needs them); without, its
    /// representative input vertex (`representative[p]`).
    fn assign_point_wedges(&mut self, representative: &[u32]) {
        // Does any point have corners with different wedges?
        let mut seams = false;
        if let Some(tw) = &self.tri_wedge {
            for (t, w) in self.tri.iter().zip(tw.iter()) {
                if t[0] == DEAD {
                    continue;
                }
                for k in 0..3 {
                    let pw = &mut self.point_wedge[t[k] as usize];
                    if *pw == DEAD {
                        *pw = w[k];
                    } else if *pw != w[k] {
                        seams = true;
                    }
                }
            }
        } else {
            for (p, pw) in self.point_wedge.iter_mut().enumerate() {
                *pw = canonical_of_point(representative, p);
            }
        }
        if !seams {
            if let Some(tw) = self.tri_wedge.take() {
                for (t, w) in self.tri.iter().zip(tw.iter()) {
                    if t[0] != DEAD {
                        for k in 0..3 {
                            self.point_wedge[t[k] as usize] = w[k];
                        }
                    }
                }
            }
        }
    }

    /// Locks the points of the input vertices `locked` marks (see
    /// [`BuildOptions::locked`]).
    fn lock(&mut self, locked: &[bool]) {
        for (v, &l) in locked.iter().enumerate() {
            if l {
                if let Some(&p) = self.wedge_point.get(v) {
                    self.kind[p as usize] = VertexKind::Locked;
                }
            }
        }
    }

    /// Builds the fans from the live triangles (as [`FanCsr::build`], straight into
    /// the per-point records).
    fn build_fans(&mut self) {
        let mut slot = vec![FanSlot::default(); self.pos.len()];
        for t in &self.tri {
            if t[0] != DEAD {
                for &p in t {
                    slot[p as usize].len += 1;
                }
            }
        }
        let mut total = 0u32;
        for s in &mut slot {
            s.start = total;
            s.cap = if s.len == 0 { 0 } else { s.len + FAN_SLACK };
            s.len = 0;
            total += s.cap;
        }
        // Room for the merged fans the collapses append, reserved but not written:
        // growing the array later would copy it, the old and the new copy
        // resident at once.
        let total = total as usize;
        let mut fans = Vec::with_capacity(total + total / FAN_ROOM);
        fans.resize(total, DEAD);
        for (ti, t) in self.tri.iter().enumerate() {
            if t[0] != DEAD {
                for &p in t {
                    let s = &mut slot[p as usize];
                    fans[(s.start + s.len) as usize] = ti as u32;
                    s.len += 1;
                }
            }
        }
        self.fan_slot = slot;
        self.fans = fans;
        self.fan_garbage = 0;
    }

    /// Rewrites the fan array compactly (after many merged fans were appended), in
    /// place: fans move towards the front in the order they are stored, each into a
    /// region no larger than the one it had (its capacity was at least its length
    /// plus the slack), so the allocation is kept and reused by later appends instead
    /// of growing. Each fan keeps its order.
    fn compact_fans(&mut self) {
        // Sorted by start through packed keys (one sequential pass to build them,
        // no lookups while sorting).
        // Counted first: the list is allocated once, at its size.
        let live = self.fan_slot.iter().filter(|s| s.len > 0).count();
        let mut order: Vec<u64> = Vec::with_capacity(live);
        for (p, slot) in self.fan_slot.iter().enumerate() {
            if slot.len > 0 {
                order.push((u64::from(slot.start) << 32) | p as u64);
            }
        }
        crate::radix::sort_by_high_half(&mut order);
        let mut w = 0usize;
        for &key in &order {
            let p = key as u32;
            let slot = self.fan_slot[p as usize];
            let (s, l) = (slot.start as usize, slot.len as usize);
            debug_assert!(w <= s && slot.cap >= slot.len);
            if w != s {
                self.fans.copy_within(s..s + l, w);
            }
            let cap = (slot.len + FAN_SLACK).min(slot.cap) as usize;
            self.fans[w + l..w + cap].fill(DEAD);
            self.fan_slot[p as usize].start = w as u32;
            self.fan_slot[p as usize].cap = cap as u32;
            w += cap;
        }
        self.fans.truncate(w);
        for slot in &mut self.fan_slot {
            if slot.len == 0 {
                slot.start = w as u32;
                slot.cap = 0;
            }
        }
        self.fan_garbage = 0;
    }

    #[inline]
    fn next_gen(&mut self) -> u32 {
        self.gen = self.gen.wrapping_add(1);
        if self.gen == 0 {
            self.mark.fill(0);
            self.gen = 1;
        }
        self.gen
    }

    // ----- accessors -------------------------------------------------------------

    /// Number of points (welded positions), alive or not.
    #[must_use]
    pub fn point_count(&self) -> usize {
        self.pos.len()
    }

    /// Number of triangle slots (live or dead).
    #[must_use]
    pub fn triangle_slots(&self) -> usize {
        self.tri.len()
    }

    /// Number of live triangles.
    #[must_use]
    pub fn live_triangles(&self) -> usize {
        self.live_tris
    }

    /// Number of points with at least one triangle.
    #[must_use]
    pub fn live_points(&self) -> usize {
        self.fan_slot.iter().filter(|s| s.len > 0).count()
    }

    /// Position of point `p`.
    #[must_use]
    #[inline]
    pub fn position(&self, p: u32) -> [f32; 3] {
        self.pos[p as usize]
    }

    /// Position of point `p` in `f64`, relative to [`Self::center`].
    #[must_use]
    #[inline]
    pub fn local(&self, p: u32) -> [f64; 3] {
        let q = self.pos[p as usize];
        [
            f64::from(q[0]) - self.center[0],
            f64::from(q[1]) - self.center[1],
            f64::from(q[2]) - self.center[2],
        ]
    }

    /// Kind of point `p`.
    #[must_use]
    #[inline]
    pub fn kind(&self, p: u32) -> VertexKind {
        self.kind[p as usize]
    }

    /// Whether `p` may be removed by some collapse: a manifold, border or seam
    /// point, or a seam junction ([`BuildOptions::move_junctions`]).
    #[must_use]
    pub fn may_move(&self, p: u32) -> bool {
        super::is_movable(self.kind[p as usize])
            || self.junction.get(p as usize).copied().unwrap_or(false)
            || self.is_chain(p)
            || self.slides_pinch(p)
    }

    /// Whether `p` is a pinch that may slide ([`BuildOptions::move_pinches`]).
    #[inline]
    fn slides_pinch(&self, p: u32) -> bool {
        self.move_pinches && self.nm_reason[p as usize] == NM_PINCH
    }

    /// Whether a collapse removing `u` takes along its wedges that no triangle over
    /// the collapsed edge maps (a junction, a point crossing its seam, a sliding
    /// pinch's other fans).
    #[inline]
    fn carries_wedges(&self, u: u32) -> bool {
        self.permissive || self.junction.get(u as usize) == Some(&true) || self.slides_pinch(u)
    }

    /// The live non-manifold points (on an edge of more than two triangles, or
    /// where several fans touch), counted by why they stay. O(points).
    #[must_use]
    pub fn non_manifold_census(&self) -> NonManifoldPoints {
        let mut c = NonManifoldPoints::default();
        for (p, &r) in self.nm_reason.iter().enumerate() {
            if r == 0 || self.fan_slot[p].len == 0 {
                continue;
            }
            c.total += 1;
            match r {
                NM_CHAIN => c.chain += 1,
                NM_CORNER => c.corner += 1,
                NM_BORDER => c.border += 1,
                NM_SEAM => c.seam += 1,
                NM_IRREGULAR => c.irregular += 1,
                _ => c.pinch += 1,
            }
        }
        c
    }

    /// The number of connected components of the live triangles (joined through
    /// shared points) and of live points on a border. O(points + triangles).
    #[must_use]
    pub fn components_and_border_points(&self) -> (usize, usize) {
        let mut uf = self.point_components();
        let (mut components, mut border) = (0, 0);
        for p in 0..self.pos.len() as u32 {
            if self.is_alive(p) {
                components += usize::from(uf.find(p) == p);
                border += usize::from(self.boundary[p as usize]);
            }
        }
        (components, border)
    }

    /// The points joined by the live triangles: `find(p)` is the same for every
    /// point of one connected component (dead points stay alone).
    pub(crate) fn point_components(&self) -> crate::mesh::topology::UnionFind {
        let mut uf = crate::mesh::topology::UnionFind::new(self.pos.len());
        for t in &self.tri {
            if t[0] != DEAD {
                uf.union(t[0], t[1]);
                uf.union(t[0], t[2]);
            }
        }
        uf
    }

    /// Whether `p` is a point inside a non-manifold chain that may slide along it
    /// ([`BuildOptions::move_non_manifold`]).
    #[must_use]
    #[inline]
    pub fn is_chain(&self, p: u32) -> bool {
        self.chain.get(p as usize).copied().unwrap_or(false)
    }

    /// Whether point `p` lies on a boundary edge.
    #[must_use]
    #[inline]
    pub fn is_boundary(&self, p: u32) -> bool {
        self.boundary[p as usize]
    }

    /// Whether point `p` still has triangles.
    #[must_use]
    #[inline]
    pub fn is_alive(&self, p: u32) -> bool {
        self.fan_slot[p as usize].len > 0
    }

    /// The triangles around point `p` (live ones only).
    #[must_use]
    #[inline]
    pub fn fan(&self, p: u32) -> &[u32] {
        let s = self.fan_slot[p as usize].start as usize;
        &self.fans[s..s + self.fan_slot[p as usize].len as usize]
    }

    /// The points of triangle `t` (`[DEAD; 3]` once removed).
    #[must_use]
    #[inline]
    pub fn triangle(&self, t: u32) -> [u32; 3] {
        self.tri[t as usize]
    }

    /// An input vertex at point `p`'s position in the input (its wedge there). For a
    /// mesh with attributes, [`DEAD`] for a point that no kept triangle used (without
    /// attributes, always the point's first vertex). Point ids are the surface's own
    /// (see [`BuildOptions::spatial_order`]); this maps them back to the input.
    #[must_use]
    #[inline]
    pub fn point_vertex(&self, p: u32) -> u32 {
        self.point_wedge[p as usize]
    }

    /// Wedge (canonical input vertex) of corner `k` of triangle `t`.
    #[must_use]
    #[inline]
    pub fn wedge(&self, t: u32, k: usize) -> u32 {
        match &self.tri_wedge {
            Some(tw) => tw[t as usize][k],
            None => self.point_wedge[self.tri[t as usize][k] as usize],
        }
    }

    /// Group (material) id of triangle `t`, 0 without groups.
    #[must_use]
    #[inline]
    pub fn group(&self, t: u32) -> u32 {
        self.tri_group.as_ref().map_or(0, |g| g[t as usize])
    }

    /// Whether the surface has attribute seams (points with several wedges).
    #[must_use]
    pub fn has_seams(&self) -> bool {
        self.tri_wedge.is_some()
    }

    /// The working attribute streams, indexed by wedge (input vertex id).
    #[must_use]
    pub fn attributes(&self) -> &VertexAttributes {
        &self.attrs
    }

    /// Centre of the input's bounding box (origin for [`Self::local`]).
    #[must_use]
    pub fn center(&self) -> [f64; 3] {
        self.center
    }

    /// Bounding-box diagonal of the input (or the one given to
    /// [`Self::set_diagonal`]): the length the cost models and the queue's keys
    /// scale by.
    #[must_use]
    pub fn diagonal(&self) -> f64 {
        self.diag
    }

    /// Makes [`Self::diagonal`] `diag`: a piece of a larger mesh takes the whole
    /// mesh's, so that its costs (attribute weights, queue keys) are the whole's.
    /// (The degenerate-triangle bound stays the piece's own: it follows the
    /// precision of its coordinates.)
    pub fn set_diagonal(&mut self, diag: f64) {
        self.diag = diag;
    }

    /// Calls `f(a, b, t, kind)` for every border edge (`kind = Border`), every
    /// attribute-seam or material-border edge (`kind = Seam`, once per side, with the
    /// triangle of that side) and every non-manifold edge (`kind = Complex`, once per
    /// triangle on it), where `t` is a triangle on the edge.
    pub fn for_each_feature_edge(&self, mut f: impl FnMut(u32, u32, u32, VertexKind)) {
        for (ti, t) in self.tri.iter().enumerate() {
            if t[0] == DEAD {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                // A manifold point has no border or seam edge.
                if self.kind[a as usize] == VertexKind::Manifold
                    || self.kind[b as usize] == VertexKind::Manifold
                {
                    continue;
                }
                // Find the other triangles on edge (a, b).
                let mut others = 0;
                let mut seam = false;
                for &t2 in self.fan(a) {
                    if t2 as usize == ti {
                        continue;
                    }
                    let tt = self.tri[t2 as usize];
                    if let Some(kb) = tt.iter().position(|&x| x == b) {
                        others += 1;
                        let ka = tt.iter().position(|&x| x == a).unwrap_or(0);
                        let ka0 = k;
                        let kb0 = (k + 1) % 3;
                        if self.wedge(ti as u32, ka0) != self.wedge(t2, ka)
                            || self.wedge(ti as u32, kb0) != self.wedge(t2, kb)
                            || self.group(ti as u32) != self.group(t2)
                        {
                            seam = true;
                        }
                    }
                }
                if others == 0 {
                    f(a, b, ti as u32, VertexKind::Border);
                } else if others == 1 && seam {
                    f(a, b, ti as u32, VertexKind::Seam);
                } else if others >= 2 {
                    f(a, b, ti as u32, VertexKind::Complex);
                }
            }
        }
    }

    // ----- classification --------------------------------------------------------

    /// Recomputes the kind and boundary flag of point `p` from its fan (locked points
    /// stay locked).
    fn classify(&mut self, p: u32) {
        let pi = p as usize;
        if self.kind[pi] == VertexKind::Locked {
            return;
        }
        let fl = self.fan_slot[pi].len as usize;
        if self.move_junctions {
            self.junction[pi] = false;
        }
        if let Some(c) = self.chain.get_mut(pi) {
            *c = false;
        }
        self.nm_reason[pi] = 0;
        if fl == 0 {
            self.kind[pi] = VertexKind::Complex;
            self.boundary[pi] = false;
            return;
        }
        if fl <= 16 && self.tri_wedge.is_none() && self.tri_group.is_none() {
            if let Some(border) = self.single_oriented_fan(p) {
                self.kind[pi] = if border {
                    VertexKind::Border
                } else {
                    VertexKind::Manifold
                };
                self.boundary[pi] = border;
                return;
            }
        }
        let small = fl <= 16;
        let g = if small { 0 } else { self.next_gen() };
        let mut edges = std::mem::take(&mut self.scratch_edges);
        let mut parent = std::mem::take(&mut self.scratch_parent);
        edges.clear();
        parent.clear();
        let s = self.fan_slot[pi].start as usize;
        for li in 0..fl {
            let t = self.fans[s + li];
            parent.push(li as u32);
            let tt = self.tri[t as usize];
            let k = tt.iter().position(|&x| x == p).unwrap_or(0);
            for q in [tt[(k + 1) % 3], tt[(k + 2) % 3]] {
                let qi = q as usize;
                // Small fans: linear search (no random access); large: mark/slot.
                let found = if small {
                    edges.iter().position(|e| e.q == q)
                } else if self.mark[qi] == g {
                    Some(self.slot[qi] as usize)
                } else {
                    None
                };
                let e = match found {
                    Some(e) => e,
                    None => {
                        if !small {
                            self.mark[qi] = g;
                            self.slot[qi] = edges.len() as u32;
                        }
                        edges.push(EdgeScratch {
                            q,
                            ..EdgeScratch::default()
                        });
                        edges.len() - 1
                    }
                };
                let es = &mut edges[e];
                match es.count {
                    0 => {
                        es.t1 = t;
                        es.l1 = li as u32;
                    }
                    1 => {
                        es.t2 = t;
                        es.l2 = li as u32;
                    }
                    _ => {}
                }
                es.count += 1;
            }
        }
        let mut complex = false;
        let mut nb = 0;
        let mut ns = 0;
        // The non-manifold edges (more than two triangles): the first two, and how
        // many, with the most triangles on one.
        let mut nm = [DEAD; 2];
        let mut n_nm = 0;
        let mut nm_max = 0;
        for e in &edges {
            match e.count {
                1 => nb += 1,
                2 => {
                    // join the two triangles of this edge in the fan
                    let (mut a, mut b) = (e.l1, e.l2);
                    while parent[a as usize] != a {
                        a = parent[a as usize];
                    }
                    while parent[b as usize] != b {
                        b = parent[b as usize];
                    }
                    if a != b {
                        parent[a.max(b) as usize] = a.min(b);
                    }
                    let ka1 = self.corner_of(e.t1, p);
                    let ka2 = self.corner_of(e.t2, p);
                    let kb1 = self.corner_of(e.t1, e.q);
                    let kb2 = self.corner_of(e.t2, e.q);
                    if self.wedge(e.t1, ka1) != self.wedge(e.t2, ka2)
                        || self.wedge(e.t1, kb1) != self.wedge(e.t2, kb2)
                        || self.group(e.t1) != self.group(e.t2)
                    {
                        ns += 1;
                    }
                }
                c => {
                    complex = true;
                    if c > 2 {
                        if n_nm < 2 {
                            nm[n_nm] = e.q;
                        }
                        n_nm += 1;
                        nm_max = nm_max.max(c);
                    }
                }
            }
        }
        let roots = (0..parent.len()).filter(|&i| parent[i] == i as u32).count();
        if roots != 1 {
            complex = true;
        }
        self.nm_reason[pi] = match (n_nm, nb, ns) {
            (0, _, _) if roots > 1 => NM_PINCH,
            (0, _, _) => 0,
            (1 | 3.., _, _) => NM_CORNER,
            (_, 1.., _) => NM_BORDER,
            (_, _, 1..) => NM_SEAM,
            _ if nm_max as usize > MAX_SHEETS || !self.fans_span_chain(p, &mut parent, nm) => {
                NM_IRREGULAR
            }
            _ => NM_CHAIN,
        };
        if self.nm_reason[pi] == NM_CHAIN && !self.chain.is_empty() {
            self.chain[pi] = true;
        }
        self.kind[pi] = if complex {
            VertexKind::Complex
        } else {
            match (nb, ns) {
                (0, 0) => VertexKind::Manifold,
                (2, 0) => VertexKind::Border,
                (0, 2) => VertexKind::Seam,
                _ => {
                    // One disc, complex through its seam edges only: a junction.
                    if self.move_junctions {
                        self.junction[pi] = ns > 0 && (nb == 0 || nb == 2);
                    }
                    VertexKind::Complex
                }
            }
        };
        self.boundary[pi] = nb > 0;
        self.scratch_edges = edges;
        self.scratch_parent = parent;
    }

    /// Whether every fan of `p` (the classes of `parent`, a union-find over the
    /// places in `p`'s fan list) is a strip from the chain edge `(p, nm[0])` to
    /// `(p, nm[1])`: it has exactly one triangle side on each of them (so it is an
    /// open disc, as the fans are joined through two-triangle edges only, with its
    /// two ends on the chain).
    fn fans_span_chain(&mut self, p: u32, parent: &mut [u32], nm: [u32; 2]) -> bool {
        let s = self.fan_slot[p as usize].start as usize;
        let fl = self.fan_slot[p as usize].len as usize;
        let mut ends = std::mem::take(&mut self.scratch_ends);
        ends.clear();
        ends.resize(fl, 0);
        let mut ok = true;
        'tris: for li in 0..fl {
            let mut r = li;
            while parent[r] != r as u32 {
                let g = parent[parent[r] as usize];
                parent[r] = g;
                r = g as usize;
            }
            let tt = self.tri[self.fans[s + li] as usize];
            for q in tt {
                let bit = if q == nm[0] {
                    1
                } else if q == nm[1] {
                    2
                } else {
                    continue;
                };
                if ends[r] & bit != 0 {
                    ok = false;
                    break 'tris;
                }
                ends[r] |= bit;
            }
        }
        if ok {
            ok = (0..fl).all(|i| parent[i] != i as u32 || ends[i] == 3);
        }
        self.scratch_ends = ends;
        ok
    }

    /// Fast path of [`Self::classify`] for a fan of at most 16 triangles without
    /// seams: `Some(false)` when the fan is one consistently oriented closed disc,
    /// `Some(true)` when it is one consistently oriented open disc (a border point),
    /// `None` for anything else (left to the general classification).
    ///
    /// With `p` at corner `k` of each fan triangle, `a = tt[k+1]` and `b = tt[k+2]`:
    /// in an oriented disc every `b` is the `a` of exactly the next triangle, so
    /// following `b → a` visits every triangle once. The `a`s must be distinct (two
    /// equal ones cannot both be reached); each is marked with its triangle's place in
    /// the fan, so finding the next triangle is one lookup.
    pub(crate) fn single_oriented_fan(&mut self, p: u32) -> Option<bool> {
        let s = self.fan_slot[p as usize].start as usize;
        let fl = self.fan_slot[p as usize].len as usize;
        if fl > 16 {
            return None;
        }
        let g = self.next_gen();
        // Field borrows: the arrays' pointers and lengths stay in registers.
        let (fans, tri, mark, slot) = (
            &self.fans[..],
            &self.tri[..],
            &mut self.mark[..],
            &mut self.slot[..],
        );
        let mut b = [0u32; 16];
        for (i, &t) in fans[s..s + fl].iter().enumerate() {
            let tt = tri[t as usize];
            let (a, bi) = if tt[0] == p {
                (tt[1], tt[2])
            } else if tt[1] == p {
                (tt[2], tt[0])
            } else {
                (tt[0], tt[1])
            };
            let ai = a as usize;
            if mark[ai] == g {
                return None;
            }
            mark[ai] = g;
            slot[ai] = i as u32;
            b[i] = bi;
        }
        // next[i]: the triangle whose `a` is `b[i]`.
        let mut next = [u8::MAX; 16];
        let mut has_prev = 0u32;
        let mut open = 0;
        for (i, &bi) in b[..fl].iter().enumerate() {
            let bi = bi as usize;
            if mark[bi] == g {
                let j = slot[bi];
                if has_prev >> j & 1 != 0 {
                    return None;
                }
                has_prev |= 1 << j;
                next[i] = j as u8;
            } else {
                open += 1;
            }
        }
        let start = match open {
            0 => 0,
            1 => (!has_prev).trailing_zeros() as usize,
            _ => return None,
        };
        // One walk must visit every triangle (one cycle, or one path for a border).
        let mut i = start;
        let mut steps = 1;
        while next[i] != u8::MAX && next[i] as usize != start {
            i = next[i] as usize;
            steps += 1;
            if steps > fl {
                return None;
            }
        }
        (steps == fl).then_some(open == 1)
    }

    #[inline]
    fn corner_of(&self, t: u32, p: u32) -> usize {
        let tt = self.tri[t as usize];
        if tt[0] == p {
            0
        } else if tt[1] == p {
            1
        } else {
            2
        }
    }

    /// Reads the per-point data of `points` that [`Self::moves`] and
    /// [`Self::local`] use, in one pass of independent loads, so that their cache
    /// misses overlap (a hint: nothing changes).
    pub fn prefetch(&self, points: &[u32]) {
        let mut s = 0u32;
        for &p in points {
            let p = p as usize;
            if p < self.pos.len() {
                s = s
                    .wrapping_add(self.pos[p][0].to_bits())
                    .wrapping_add(self.fan_slot[p].len)
                    .wrapping_add(self.kind[p] as u32);
            }
        }
        std::hint::black_box(s);
    }

    /// Hardware prefetches of the positions of the corners of the triangles around
    /// `u` and `v` (what [`Self::check`] reads next). The fans and triangles are
    /// read to find them (in cache already after [`Self::prefetch_triangles_hint`]
    /// one step earlier, else this waits for them); nothing waits for the
    /// positions. A hint: nothing changes.
    #[inline(always)]
    pub fn prefetch_pair(&self, u: u32, v: u32) {
        for p in [u, v] {
            if (p as usize) < self.fan_slot.len() {
                for &t in self.fan(p) {
                    for c in self.tri[t as usize] {
                        crate::isa::prefetch(&self.pos[c as usize]);
                    }
                }
            }
        }
    }

    /// Hardware prefetches of the per-point state an evaluation of a pair with `p`
    /// reads (kind, fan record, position): the first stage of loading a pair's
    /// neighbourhood ahead of its pop. A hint: nothing waits for it.
    #[inline(always)]
    pub fn prefetch_point_hint(&self, p: u32) {
        let p = p as usize;
        if p < self.pos.len() {
            crate::isa::prefetch(&self.fan_slot[p]);
            crate::isa::prefetch(&self.kind[p]);
            crate::isa::prefetch(&self.pos[p]);
        }
    }

    /// Second stage: with the fan records of `a` and `b` loaded by
    /// [`Self::prefetch_point_hint`] a while ago (read here, so this waits if they
    /// have not arrived), hardware prefetches of the first and last lines of their
    /// fans. A hint.
    #[inline(always)]
    pub fn prefetch_fans_hint(&self, a: u32, b: u32) {
        for p in [a, b] {
            if let Some(slot) = self.fan_slot.get(p as usize) {
                let (s, l) = (slot.start as usize, slot.len as usize);
                if l > 0 && s + l <= self.fans.len() {
                    crate::isa::prefetch(&self.fans[s]);
                    crate::isa::prefetch(&self.fans[s + l - 1]);
                }
            }
        }
    }

    /// Third stage: with the fans of `a` and `b` loaded by
    /// [`Self::prefetch_fans_hint`], hardware prefetches of their triangles (the
    /// fourth, their corners' positions, is [`Self::prefetch_pair`]). A hint.
    #[inline(always)]
    pub fn prefetch_triangles_hint(&self, a: u32, b: u32) {
        for p in [a, b] {
            if (p as usize) < self.fan_slot.len() {
                for &t in self.fan(p) {
                    crate::isa::prefetch(&self.tri[t as usize]);
                }
            }
        }
    }

    /// Replaces `out` with the distinct neighbours of `p`, in fan order.
    pub fn neighbours(&mut self, p: u32, out: &mut Vec<u32>) {
        out.clear();
        let g = self.next_gen();
        let slot = self.fan_slot[p as usize];
        let (s, l) = (slot.start as usize, slot.len as usize);
        let fan = &self.fans[s..s + l];
        let tri = &self.tri[..];
        let mark = &mut self.mark[..];
        // `p` marked first: it is then skipped like an already listed point.
        mark[p as usize] = g;
        for &t in fan {
            for &x in &tri[t as usize] {
                if mark[x as usize] != g {
                    mark[x as usize] = g;
                    out.push(x);
                }
            }
        }
    }

    // ----- rules -----------------------------------------------------------------

    /// Whether `a` and `b` share an edge.
    #[must_use]
    pub fn shares_edge(&self, a: u32, b: u32) -> bool {
        self.fan(a)
            .iter()
            .any(|&t| self.tri[t as usize].contains(&b))
    }

    /// Number of triangles on edge `(a, b)` and whether it is a seam (its two
    /// triangles differ in a wedge or in group).
    fn edge_info(&self, a: u32, b: u32) -> (u32, bool) {
        let mut count = 0;
        let mut ts = [DEAD; 2];
        for &t in self.fan(a) {
            if self.tri[t as usize].contains(&b) {
                if (count as usize) < 2 {
                    ts[count as usize] = t;
                }
                count += 1;
            }
        }
        let seam = count == 2 && {
            let (t1, t2) = (ts[0], ts[1]);
            self.wedge(t1, self.corner_of(t1, a)) != self.wedge(t2, self.corner_of(t2, a))
                || self.wedge(t1, self.corner_of(t1, b)) != self.wedge(t2, self.corner_of(t2, b))
                || self.group(t1) != self.group(t2)
        };
        (count, seam)
    }

    /// The contractions the operator allows for pair `(a, b)`, or `None` when none is
    /// (dead points, a non-manifold edge, a non-edge pair when `allow_non_edge` is
    /// false, or kinds that may not move along this edge).
    #[must_use]
    #[inline(always)]
    pub fn moves(&self, a: u32, b: u32, allow_non_edge: bool) -> Option<Moves> {
        if a == b || !self.is_alive(a) || !self.is_alive(b) {
            return None;
        }
        let (ka, kb) = (self.kind(a), self.kind(b));
        if ka == VertexKind::Manifold && kb == VertexKind::Manifold {
            let edge = !allow_non_edge || self.shares_edge(a, b);
            return Some(Moves {
                a_to_b: true,
                b_to_a: true,
                merge: Merge::Anywhere,
                edge,
                crosses: [false; 2],
            });
        }
        let (count, seam) = self.edge_info(a, b);
        if count == 0 {
            if !allow_non_edge {
                return None;
            }
            let free = |k| matches!(k, VertexKind::Manifold | VertexKind::Border);
            let (fa, fb) = (free(ka), free(kb));
            if !fa && !fb {
                return None;
            }
            return Some(Moves {
                a_to_b: fa,
                b_to_a: fb,
                merge: if fa && fb { Merge::Anywhere } else { Merge::No },
                edge: false,
                crosses: [false; 2],
            });
        }
        if count > 2 {
            // A non-manifold edge: only a chain point slides along it.
            let (ca, cb) = (self.is_chain(a), self.is_chain(b));
            if !(ca || cb) || count as usize > MAX_SHEETS {
                return None;
            }
            return Some(Moves {
                a_to_b: ca,
                b_to_a: cb,
                merge: if ca && cb {
                    Merge::OnSegment
                } else {
                    Merge::No
                },
                edge: true,
                crosses: [false; 2],
            });
        }
        let border_edge = count == 1;
        let crosses_ok = self.permissive && !border_edge;
        let can = |crosses: bool, x: u32, kx: VertexKind, ky: VertexKind| match kx {
            VertexKind::Manifold => true,
            VertexKind::Border => {
                border_edge
                    && matches!(
                        ky,
                        VertexKind::Border | VertexKind::Complex | VertexKind::Locked
                    )
            }
            VertexKind::Seam => {
                crosses
                    || seam
                        && matches!(
                            ky,
                            VertexKind::Seam | VertexKind::Complex | VertexKind::Locked
                        )
            }
            // A seam junction slides along a seam (or its border) only.
            VertexKind::Complex if self.junction.get(x as usize) == Some(&true) => {
                if self.boundary[x as usize] {
                    border_edge
                } else {
                    seam || crosses
                }
            }
            // A pinch slides along an edge of one of its fans (a border edge
            // when it is on a border).
            VertexKind::Complex if self.slides_pinch(x) => {
                border_edge || !self.boundary[x as usize]
            }
            _ => false,
        };
        let (a_to_b, b_to_a) = (can(crosses_ok, a, ka, kb), can(crosses_ok, b, kb, ka));
        // A move only the crossing allows crosses (none without crossings).
        let crosses = if crosses_ok {
            [
                a_to_b && !can(false, a, ka, kb),
                b_to_a && !can(false, b, kb, ka),
            ]
        } else {
            [false; 2]
        };
        if !a_to_b && !b_to_a {
            return None;
        }
        let merge = match (ka, kb) {
            (VertexKind::Border, VertexKind::Border) if border_edge => Merge::OnSegment,
            (VertexKind::Seam, VertexKind::Seam) if seam => Merge::OnSegment,
            _ => Merge::No,
        };
        Some(Moves {
            a_to_b,
            b_to_a,
            merge,
            edge: true,
            crosses,
        })
    }

    // ----- legality --------------------------------------------------------------

    /// Checks whether removing `u` and moving `v` to `p` is legal; on success fills
    /// `preview` with the triangles that change (for filters).
    ///
    /// # Errors
    /// The first [`Reject`] reason found.
    pub fn check(
        &mut self,
        u: u32,
        v: u32,
        p: [f32; 3],
        limits: &OperatorLimits,
        preview: &mut Preview,
    ) -> Result<(), Reject> {
        preview.changed.clear();
        preview.removed = u;
        preview.kept = v;
        preview.position = p;
        preview.closes_hole = DEAD;
        self.pending_zip = [u, v, DEAD];
        if u == v || !self.is_alive(u) || !self.is_alive(v) {
            return Err(Reject::Kind);
        }
        if !self.may_move(u) {
            return Err(Reject::Kind);
        }
        let v_moves = p != self.pos[v as usize];
        if v_moves && !super::is_movable(self.kind(v)) && !self.is_chain(v) {
            return Err(Reject::Kind);
        }
        preview.touches_boundary = self.boundary[u as usize] || self.boundary[v as usize];

        if self.fold_angle != limits.fold_over_angle {
            self.fold_angle = limits.fold_over_angle;
            self.fold_cos = limits.fold_over_angle.cos();
        }
        let geo = Geometry {
            cos_limit: self.fold_cos,
            height_eps2: self.height_eps2,
            p: f64x3(p),
        };
        let mut changed = std::mem::take(&mut preview.changed);
        let r = self.check_fans(u, v, v_moves, limits, &geo, &mut changed);
        preview.changed = changed;
        let (dying, zip) = r?;
        preview.edge = dying > 0;
        preview.dying = dying;
        preview.closes_hole = zip;
        self.pending_zip = [u, v, zip];
        Ok(())
    }

    /// One pass over each fan: dying triangles, the link condition and the geometry
    /// of the surviving triangles together. Returns the number of dying triangles
    /// and the third point of the hole the collapse closes ([`DEAD`] when none).
    /// Runs as the AVX2 build where the CPU has it ([`crate::isa`]; same bits).
    fn check_fans(
        &mut self,
        u: u32,
        v: u32,
        v_moves: bool,
        limits: &OperatorLimits,
        geo: &Geometry,
        changed: &mut Vec<ChangedTriangle>,
    ) -> Result<(usize, u32), Reject> {
        crate::isa::dispatch!(self.check_fans_impl(u, v, v_moves, limits, geo, changed))
    }

    #[inline(always)]
    fn check_fans_impl(
        &mut self,
        u: u32,
        v: u32,
        v_moves: bool,
        limits: &OperatorLimits,
        geo: &Geometry,
        changed: &mut Vec<ChangedTriangle>,
    ) -> Result<(usize, u32), Reject> {
        // Fan of u: dying triangles, apexes, u's neighbours marked, and the
        // triangles that survive with u moved to p.
        let g = self.next_gen();
        let mut dying = 0usize;
        let mut opp = [DEAD; MAX_SHEETS];
        let mut dying_t = [DEAD; MAX_SHEETS];
        let pu = f64x3(self.pos[u as usize]);
        let su = self.fan_slot[u as usize].start as usize;
        let lu = self.fan_slot[u as usize].len as usize;
        // Field borrows: the arrays' pointers and lengths stay in registers (the
        // pushes to `changed` would otherwise make them reload every triangle).
        let (fans, tri, pos, mark) = (
            &self.fans[..],
            &self.tri[..],
            &self.pos[..],
            &mut self.mark[..],
        );
        for &t in &fans[su..su + lu] {
            let tt = tri[t as usize];
            if tt.contains(&v) {
                if dying == MAX_SHEETS {
                    return Err(Reject::NonManifoldEdge);
                }
                opp[dying] = tt[0] ^ tt[1] ^ tt[2] ^ u ^ v;
                dying_t[dying] = t;
                dying += 1;
            } else {
                changed.push(Self::moved_triangle(pos, t, tt, u, pu, geo)?);
            }
            for &x in &tt {
                if x != u {
                    mark[x as usize] = g;
                }
            }
        }
        if dying == 0 && !limits.allow_non_edge {
            return Err(Reject::Pair);
        }
        // A chain point moves only along its chain (a non-manifold edge).
        if dying < 3 && (self.is_chain(u) || (v_moves && self.is_chain(v))) {
            return Err(Reject::Kind);
        }
        if dying == 2 && self.boundary[u as usize] && self.boundary[v as usize] {
            return Err(Reject::Link);
        }
        // Nothing may vanish: the survivor and every apex keep a triangle (so a
        // small component is never collapsed away).
        let left = self.fan_slot[u as usize].len as usize + self.fan_slot[v as usize].len as usize;
        if left <= 2 * dying
            || opp[..dying]
                .iter()
                .any(|&a| self.fan_slot[a as usize].len <= 1)
        {
            return Err(Reject::Link);
        }
        // The collapse removes a dying triangle from each apex's fan: start
        // loading those fans now (a hint; their records were just read).
        for &a in opp.iter().take(dying) {
            crate::isa::prefetch(&self.fans[self.fan_slot[a as usize].start as usize]);
        }
        // An apex keeps an edge to the survivor (else a non-manifold apex joining
        // two parts would lose this side, splitting a component): some other
        // triangle around it must touch u or v.
        for (i, &a) in opp.iter().enumerate().take(dying) {
            if self.kind[a as usize] != VertexKind::Manifold {
                let keeps = self.fan(a).iter().any(|&t| {
                    t != dying_t[i] && {
                        let tt = self.tri[t as usize];
                        tt.contains(&u) || tt.contains(&v)
                    }
                });
                if !keeps {
                    return Err(Reject::Link);
                }
            }
        }
        // Fan of v: the link condition (common neighbours are exactly the apexes; a
        // non-edge pair may have none) and the triangles that survive with v moved.
        // The apexes are the common neighbours allowed: unmarked.
        for &a in &opp[..dying] {
            self.mark[a as usize] = 0;
        }
        let pv = f64x3(self.pos[v as usize]);
        let sv = self.fan_slot[v as usize].start as usize;
        let lv = self.fan_slot[v as usize].len as usize;
        let (fans, tri, pos, mark) = (&self.fans[..], &self.tri[..], &self.pos[..], &self.mark[..]);
        // Another common neighbour breaks the link condition, unless it is the
        // third point of a hole this collapse may close (checked below).
        let may_zip = limits.close_holes && dying == 1;
        let mut zip = DEAD;
        for &t in &fans[sv..sv + lv] {
            let tt = tri[t as usize];
            for &x in &tt {
                if x != v
                    && x != u
                    && mark[x as usize] == g
                    && !(may_zip && (zip == DEAD || zip == x))
                {
                    return Err(if dying == 0 {
                        Reject::Pair
                    } else {
                        Reject::Link
                    });
                } else if x != v && x != u && mark[x as usize] == g {
                    zip = x;
                }
            }
            if v_moves && !tt.contains(&u) {
                changed.push(Self::moved_triangle(pos, t, tt, v, pv, geo)?);
            }
        }
        if dying == 0 {
            return Ok((0, DEAD));
        }
        if zip != DEAD && !self.closes_hole(u, v, zip, opp[0]) {
            return Err(Reject::Link);
        }
        // Duplicate triangles: both u and v have a triangle over the two apexes.
        // u is a single-fan manifold point, so it can only have one when its fan is
        // exactly the three triangles (u,v,a), (u,a,b), (u,b,v).
        // (A sliding pinch has other fans: its own fan may be any size.)
        if dying == 2 && (self.fan_slot[u as usize].len <= 3 || self.slides_pinch(u)) {
            let has = |s: &Self, w: u32, other: u32| {
                s.fan(w).iter().any(|&t| {
                    let tt = s.tri[t as usize];
                    tt.contains(&opp[0]) && tt.contains(&opp[1]) && !tt.contains(&other)
                })
            };
            if has(self, u, v) && has(self, v, u) {
                return Err(Reject::Duplicate);
            }
        }
        // Along a non-manifold edge: a surviving triangle of u over two apexes must
        // not repeat one of v's (the only common neighbours are the apexes).
        if dying > 2 && self.chain_duplicate(u, v, &opp[..dying]) {
            return Err(Reject::Duplicate);
        }
        // Seams: u's wedges map onto v's consistently.
        if self.tri_wedge.is_some() {
            let mut map = [(DEAD, DEAD); MAX_SHEETS];
            for (i, &t) in dying_t.iter().take(dying).enumerate() {
                let wu = self.wedge(t, self.corner_of(t, u));
                let wv = self.wedge(t, self.corner_of(t, v));
                map[i] = (wu, wv);
            }
            for i in 1..dying {
                if map[..i].iter().any(|m| m.0 == map[i].0 && m.1 != map[i].1) {
                    return Err(Reject::Seam);
                }
            }
            // Skins: the dominant joint is a discontinuity that is kept (unless
            // joints may merge): merged wedges must share it.
            if let (false, Some(j), Some(wt)) =
                (self.merge_joints, &self.attrs.joints, &self.attrs.weights)
            {
                let dominant = |w: u32| {
                    let (jj, ww) = (j[w as usize], wt[w as usize]);
                    let k = (1..4).fold(0, |b, k| if ww[k] > ww[b] { k } else { b });
                    jj[k]
                };
                if map[..dying]
                    .iter()
                    .any(|&(wu, wv)| dominant(wu) != dominant(wv))
                {
                    return Err(Reject::Seam);
                }
            }
            // A junction, or a seam point crossing its seam, takes its other wedges
            // along (see `redirect_corners`).
            let takes_wedges = self.carries_wedges(u);
            for &t in self.fan(u) {
                if takes_wedges {
                    break;
                }
                let wu = self.wedge(t, self.corner_of(t, u));
                if !map[..dying.max(2)].iter().any(|m| m.0 == wu) {
                    return Err(Reject::Seam);
                }
            }
        }
        Ok((dying, zip))
    }

    /// Whether collapsing border edge `(u, v)` (its triangle's third corner
    /// `apex`) closes the hole `u, v, x`, their only other common neighbour, into
    /// a manifold surface: `u`, `v` and `x` are border points (one disc, two
    /// border edges each) or sliding pinches on a border
    /// ([`BuildOptions::move_pinches`]), `(u, x)` and `(v, x)` carry one triangle
    /// each (the hole's other two edges); the triangles on them differ in their third corners (else they
    /// would become one triangle twice) and run along `x` in opposite directions
    /// once `u` is `v` (so the joined edge keeps a consistent orientation).
    ///
    /// ```text
    ///   u ------- v        the hole u, v, x: its edges (u, x) and (v, x)
    ///    \  hole /         become one edge inside the surface, with the
    ///     \     /          triangles (x, u, a) and (v, x, b) on its sides
    ///        x
    /// ```
    fn closes_hole(&self, u: u32, v: u32, x: u32, apex: u32) -> bool {
        let border = |p: u32| {
            self.kind[p as usize] == VertexKind::Border
                || (self.slides_pinch(p) && self.boundary[p as usize])
        };
        if !(border(u) && border(v) && border(x)) || x == apex {
            return false;
        }
        // The one triangle of `w`'s fan on edge (w, x), if there is exactly one.
        let only = |w: u32| {
            let mut it = self
                .fan(w)
                .iter()
                .filter(|&&t| self.tri[t as usize].contains(&x));
            match (it.next(), it.next()) {
                (Some(&t), None) => Some(t),
                _ => None,
            }
        };
        let (Some(tu), Some(tv)) = (only(u), only(v)) else {
            return false;
        };
        let (a, b) = (self.tri[tu as usize], self.tri[tv as usize]);
        let third = |tt: [u32; 3], w: u32| tt[0] ^ tt[1] ^ tt[2] ^ w ^ x;
        // `q` follows `p` in the corner order of `tt`.
        let follows = |tt: [u32; 3], p: u32, q: u32| {
            let k = tt.iter().position(|&c| c == p).unwrap_or(0);
            tt[(k + 1) % 3] == q
        };
        third(a, u) != third(b, v) && follows(a, u, x) == follows(b, x, v)
    }

    /// Whether a triangle of `u` not over `v` has its two other corners among
    /// `apexes` and a triangle of `v` not over `u` has the same two: merging `u`
    /// into `v` would make them one triangle twice.
    fn chain_duplicate(&self, u: u32, v: u32, apexes: &[u32]) -> bool {
        self.fan(u).iter().any(|&t| {
            let tt = self.tri[t as usize];
            if tt.contains(&v) {
                return false;
            }
            let (mut w, mut x) = (DEAD, DEAD);
            for &c in &tt {
                if c != u {
                    if w == DEAD {
                        w = c;
                    } else {
                        x = c;
                    }
                }
            }
            apexes.contains(&w)
                && apexes.contains(&x)
                && self.fan(v).iter().any(|&t2| {
                    let t2t = self.tri[t2 as usize];
                    t2t.contains(&w) && t2t.contains(&x) && !t2t.contains(&u)
                })
        })
    }

    /// Triangle `t = tt` with its corner `w` (at `pw`) moved to `geo.p`: refused if it
    /// degenerates or turns past the fold-over limit. With the other corners `q1`,
    /// `q2` in order, the normal is `(q2 − q1) × (x − q1)` for the moving corner `x`,
    /// so old and new share one edge vector.
    #[inline(always)]
    fn moved_triangle(
        pos: &[[f32; 3]],
        t: u32,
        tt: [u32; 3],
        w: u32,
        pw: [f64; 3],
        geo: &Geometry,
    ) -> Result<ChangedTriangle, Reject> {
        let k = if tt[0] == w {
            0
        } else if tt[1] == w {
            1
        } else {
            2
        };
        let q1 = f64x3(pos[tt[(k + 1) % 3] as usize]);
        let q2 = f64x3(pos[tt[(k + 2) % 3] as usize]);
        let f = sub(q2, q1);
        let a0 = sub(pw, q1);
        let a1 = sub(geo.p, q1);
        let n0 = cross(f, a0);
        let n1 = cross(f, a1);
        let l1 = dot(n1, n1);
        // Squared edges: F = |q2 − q1|², A = |x − q1|² and B = |x − q2|² for the
        // moving corner x.
        let ff = dot(f, f);
        let edge2 = |a: [f64; 3], x: [f64; 3]| {
            let b = sub(x, q2);
            (dot(a, a), dot(b, b))
        };
        let (na, nb) = edge2(a1, geo.p);
        // The smallest height is |n1| over the longest edge: degenerate when it is
        // at or below `ε·diag` (compared squared).
        if l1 <= geo.height_eps2 * ff.max(na).max(nb) {
            return Err(Reject::Degenerate);
        }
        let d = dot(n0, n1);
        if d <= geo.cos_limit * (dot(n0, n0) * l1).sqrt() {
            return Err(Reject::FoldOver);
        }
        // Squared edge sums in corner order (for the quality filter): with the
        // moving corner x at k, the order 0→1, 1→2, 2→0 adds them as (A+F)+B,
        // (B+A)+F or (F+B)+A (a difference and its negation square alike).
        let edges = |(ea, eb): (f64, f64)| match k {
            0 => ea + ff + eb,
            1 => eb + ea + ff,
            _ => ff + eb + ea,
        };
        Ok(ChangedTriangle {
            triangle: t,
            old_normal: n0,
            new_normal: n1,
            corner: k as u8,
            old_edges2: edges(edge2(a0, pw)),
            new_edges2: edges((na, nb)),
        })
    }

    // ----- the collapse ----------------------------------------------------------

    /// Removes `u`, merging it into `v`, and moves `v` to `p`. The caller must have
    /// had [`Self::check`] accept exactly this collapse. Returns the record (cost and
    /// error left 0 for the caller to fill in).
    pub fn collapse(&mut self, u: u32, v: u32, p: [f32; 3]) -> CollapseRecord {
        let removed_position = self.pos[u as usize];
        let kept_old_position = self.pos[v as usize];
        let v_moves = p != kept_old_position;
        self.kind_changed = [DEAD; MAX_SHEETS];

        // In steps: the attributes are interpolated (when `v` moves), the triangles
        // over both points die, `u`'s other corners become `v`'s, the two fans merge
        // into `v`'s, and the kinds around are updated.
        if v_moves && self.interpolates_some_stream() {
            self.interpolate_attributes(u, v, p);
        }
        if self.carries_wedges(u) && !self.attrs.is_empty() {
            self.carry_unmapped_wedges(u, v, p);
        }
        // `u`'s fan is `fans[su..su + lu]` until `merge_fans` releases it (the steps
        // before change other fans only): read once.
        let su = self.fan_slot[u as usize].start as usize;
        let lu = self.fan_slot[u as usize].len as usize;
        let dying = self.kill_shared_triangles(u, v, su, lu);
        let non_edge = dying.count == 0;
        let n_all = dying.count.min(MAX_SHEETS);
        self.last_wedge_map = dying.wedge_map;
        self.last_wedge_map_all = dying.wedge_map_all;
        self.last_dying = n_all;
        self.redirect_corners(u, v, su, lu, non_edge, &dying.wedge_map_all[..n_all]);
        let new_len = self.merge_fans(u, v, su, lu, dying.count);
        if let Some(m) = self.merged.get_mut(u as usize) {
            *m = v;
        }
        self.pos[v as usize] = p;
        self.update_kinds(u, v, &dying.apexes_all[..n_all], non_edge, new_len);
        let closed_hole = if self.pending_zip[..2] == [u, v] {
            self.pending_zip[2]
        } else {
            DEAD
        };
        self.pending_zip = [DEAD; 3];
        if closed_hole != DEAD {
            // The hole's third point is inside the surface now; `v` was
            // classified again above (it was a border point).
            self.classify(closed_hole);
            self.kind_changed[n_all] = closed_hole;
        }

        CollapseRecord {
            removed: u,
            kept: v,
            removed_position,
            kept_old_position,
            position: p,
            removed_triangles: dying.triangles,
            removed_count: dying.count as u32,
            apexes: dying.apexes,
            non_edge,
            closed_hole,
            cost: 0.0,
            error: 0.0,
        }
    }

    /// First step of [`Self::collapse`]: the triangles of `u`'s fan over `v` too
    /// die (marked [`DEAD`], removed from their apexes' fans; they stay listed in
    /// `u`'s and `v`'s fans until [`Self::merge_fans`]). With wedges, records how
    /// `u`'s wedge maps to `v`'s in (up to two of) them. `u`'s fan is
    /// `fans[su..su + lu]`.
    #[inline(always)]
    fn kill_shared_triangles(&mut self, u: u32, v: u32, su: usize, lu: usize) -> Dying {
        let mut d = Dying {
            wedge_map: [(DEAD, DEAD); 2],
            triangles: [DEAD; 2],
            apexes: [DEAD; 2],
            count: 0,
            wedge_map_all: [(DEAD, DEAD); MAX_SHEETS],
            apexes_all: [DEAD; MAX_SHEETS],
        };
        let mut nmap = 0;
        for i in 0..lu {
            let t = self.fans[su + i];
            let tt = self.tri[t as usize];
            if tt.contains(&v) {
                if self.tri_wedge.is_some() && nmap < MAX_SHEETS {
                    let m = (
                        self.wedge(t, self.corner_of(t, u)),
                        self.wedge(t, self.corner_of(t, v)),
                    );
                    if nmap < 2 {
                        d.wedge_map[nmap] = m;
                    }
                    d.wedge_map_all[nmap] = m;
                    nmap += 1;
                }
                let x = tt[0] ^ tt[1] ^ tt[2] ^ u ^ v;
                self.remove_from_fan(x, t);
                if d.count < 2 {
                    d.triangles[d.count] = t;
                    d.apexes[d.count] = x;
                }
                if d.count < MAX_SHEETS {
                    d.apexes_all[d.count] = x;
                }
                d.count += 1;
                self.tri[t as usize] = [DEAD; 3];
                self.live_tris -= 1;
            }
        }
        d
    }

    /// Second step of [`Self::collapse`]: `u`'s corners in its surviving triangles
    /// become `v`. With wedges, a non-edge contraction moves the corner's wedge to
    /// `v` (`wedge_point`); an edge collapse gives the corner `v`'s wedge where
    /// `wedge_map` (from the dying triangles) says so. `u`'s fan is
    /// `fans[su..su + lu]`.
    #[inline(always)]
    fn redirect_corners(
        &mut self,
        u: u32,
        v: u32,
        su: usize,
        lu: usize,
        non_edge: bool,
        wedge_map: &[(u32, u32)],
    ) {
        for i in 0..lu {
            let t = self.fans[su + i];
            let tt = &mut self.tri[t as usize];
            if tt[0] == DEAD {
                continue;
            }
            let k = if tt[0] == u {
                0
            } else if tt[1] == u {
                1
            } else {
                2
            };
            tt[k] = v;
            if let Some(tw) = &mut self.tri_wedge {
                if non_edge {
                    self.wedge_point[tw[t as usize][k] as usize] = v;
                } else {
                    let w = tw[t as usize][k];
                    let to = wedge_map.iter().find(|m| m.0 == w).map_or(DEAD, |m| m.1);
                    if to == DEAD {
                        // A wedge of a junction (or of a point crossing its seam)
                        // off the collapsed edge: it moves to `v` whole.
                        self.wedge_point[w as usize] = v;
                    } else {
                        tw[t as usize][k] = to;
                    }
                }
            }
        }
    }

    /// Third step of [`Self::collapse`]: `v`'s fan becomes the live triangles of
    /// both fans (`n_dead` of each died), in place when they fit its capacity, else
    /// at the end of the fan array ([`Self::move_merged_fan`]); `u`'s fan is
    /// released. Returns the merged fan's length. `u`'s fan is `fans[su..su + lu]`.
    #[inline(always)]
    fn merge_fans(&mut self, u: u32, v: u32, su: usize, lu: usize, n_dead: usize) -> usize {
        let sv = self.fan_slot[v as usize].start as usize;
        let lv = self.fan_slot[v as usize].len as usize;
        // A fan lists live triangles only, each once, and the dying ones (over both
        // u and v) are in both fans: what is left of each is its length minus them.
        let (live_v, live_u) = (lv - n_dead, lu - n_dead);
        debug_assert_eq!(
            live_v,
            (0..lv)
                .filter(|&i| self.tri[self.fans[sv + i] as usize][0] != DEAD)
                .count()
        );
        debug_assert_eq!(
            live_u,
            (0..lu)
                .filter(|&i| self.tri[self.fans[su + i] as usize][0] != DEAD)
                .count()
        );
        let new_len = live_v + live_u;
        if new_len <= self.fan_slot[v as usize].cap as usize {
            // Field borrows: the arrays' pointers and lengths stay in registers.
            let (fans, tri) = (&mut self.fans[..], &self.tri[..]);
            let mut w = sv;
            for i in sv..sv + lv {
                let t = fans[i];
                if tri[t as usize][0] != DEAD {
                    fans[w] = t;
                    w += 1;
                }
            }
            for i in su..su + lu {
                let t = fans[i];
                if tri[t as usize][0] != DEAD {
                    fans[w] = t;
                    w += 1;
                }
            }
        } else {
            self.move_merged_fan(u, v, lu, lv, new_len);
        }
        self.fan_slot[v as usize].len = new_len as u32;
        self.fan_garbage += self.fan_slot[u as usize].cap as usize;
        self.fan_slot[u as usize].len = 0;
        self.fan_slot[u as usize].cap = 0;
        new_len
    }

    /// [`Self::merge_fans`] when the merged fan (`new_len` triangles, from `v`'s
    /// `lv` entries and `u`'s `lu`) outgrows `v`'s capacity: it is written at the
    /// end of the fan array with room to grow, after compacting the array when
    /// enough of it is garbage, and `v`'s old slots become garbage.
    #[inline(always)]
    fn move_merged_fan(&mut self, u: u32, v: u32, lu: usize, lv: usize, new_len: usize) {
        let cap = new_len + new_len / 2 + FAN_SLACK as usize;
        // Compact when a quarter is garbage, or instead of growing the
        // allocation when an eighth is (compacting costs what moving it would).
        let grows = self.fans.len() + cap > self.fans.capacity();
        if self.fan_garbage > self.fans.len() / 4
            || (grows && self.fan_garbage > self.fans.len() / 8)
        {
            self.compact_fans();
        }
        // Grow by [`FAN_ROOM`]'s fraction rather than double: still amortised O(1),
        // and the array stays near its live size.
        if self.fans.len() + cap > self.fans.capacity() {
            self.fans.reserve_exact(cap.max(self.fans.len() / FAN_ROOM));
        }
        let sv = self.fan_slot[v as usize].start as usize;
        let su = self.fan_slot[u as usize].start as usize;
        let start = self.fans.len();
        for i in 0..lv {
            let t = self.fans[sv + i];
            if self.tri[t as usize][0] != DEAD {
                self.fans.push(t);
            }
        }
        for i in 0..lu {
            let t = self.fans[su + i];
            if self.tri[t as usize][0] != DEAD {
                self.fans.push(t);
            }
        }
        self.fans.resize(start + cap, DEAD);
        self.fan_garbage += self.fan_slot[v as usize].cap as usize;
        self.fan_slot[v as usize].start = start as u32;
        self.fan_slot[v as usize].cap = cap as u32;
    }

    /// Last step of [`Self::collapse`]: `u` is dead (complex, off the boundary).
    /// After a non-edge contraction `v` becomes complex (unless locked) and
    /// inherits `u`'s boundary flag; after an edge collapse the kinds are unchanged
    /// when `u`, `v` and the `apexes` were all manifold, otherwise `v` and the
    /// apexes are classified again and the apexes whose kind or boundary flag
    /// changed are recorded ([`Self::kind_changes`]). A `v` left with an empty fan
    /// (`new_len`) is complex.
    #[inline(always)]
    fn update_kinds(&mut self, u: u32, v: u32, apexes: &[u32], non_edge: bool, new_len: usize) {
        let ku = self.kind[u as usize];
        let all_manifold = ku == VertexKind::Manifold
            && self.kind[v as usize] == VertexKind::Manifold
            && apexes
                .iter()
                .all(|&x| x == DEAD || self.kind[x as usize] == VertexKind::Manifold);
        let boundary_u = self.boundary[u as usize];
        self.kind[u as usize] = VertexKind::Complex;
        self.boundary[u as usize] = false;
        if non_edge {
            if self.kind[v as usize] != VertexKind::Locked {
                self.kind[v as usize] = VertexKind::Complex;
            }
            self.boundary[v as usize] |= boundary_u;
        } else if !all_manifold {
            self.classify(v);
            for (i, &x) in apexes.iter().enumerate() {
                if x != DEAD {
                    let before = (self.kind[x as usize], self.boundary[x as usize]);
                    self.classify(x);
                    if before != (self.kind[x as usize], self.boundary[x as usize]) {
                        self.kind_changed[i] = x;
                    }
                }
            }
        }
        if new_len == 0 {
            self.kind[v as usize] = VertexKind::Complex;
        }
    }

    /// Removes every live triangle around `points` and leaves them dead (a whole
    /// part of the surface when `points` are all of a connected component's
    /// points: nothing else loses a triangle). Returns how many triangles died.
    /// O(the points' fans).
    pub fn remove_part(&mut self, points: &[u32]) -> usize {
        self.pending_zip = [DEAD; 3];
        let mut removed = 0;
        for &p in points {
            let pi = p as usize;
            if self.fan_slot[pi].len == 0 {
                continue;
            }
            let s = self.fan_slot[pi].start as usize;
            for i in s..s + self.fan_slot[pi].len as usize {
                let t = self.fans[i] as usize;
                if self.tri[t][0] != DEAD {
                    self.tri[t] = [DEAD; 3];
                    self.live_tris -= 1;
                    removed += 1;
                }
            }
            self.fan_garbage += self.fan_slot[pi].cap as usize;
            self.fan_slot[pi].len = 0;
            self.fan_slot[pi].cap = 0;
            if self.kind[pi] != VertexKind::Locked {
                self.kind[pi] = VertexKind::Complex;
            }
            self.boundary[pi] = false;
            self.nm_reason[pi] = 0;
        }
        removed
    }

    /// Apexes of the last collapse whose kind or boundary flag changed ([`DEAD`]
    /// where none): their pairs need re-evaluating.
    #[must_use]
    pub fn kind_changes(&self) -> [u32; MAX_SHEETS] {
        self.kind_changed
    }

    fn remove_from_fan(&mut self, x: u32, t: u32) {
        let s = self.fan_slot[x as usize].start as usize;
        let l = self.fan_slot[x as usize].len as usize;
        if let Some(i) = self.fans[s..s + l].iter().position(|&y| y == t) {
            self.fans[s + i] = self.fans[s + l - 1];
            self.fans[s + l - 1] = DEAD;
            self.fan_slot[x as usize].len -= 1;
            if l == 1 {
                self.fan_garbage += self.fan_slot[x as usize].cap as usize;
                self.fan_slot[x as usize].cap = 0;
            }
        }
    }

    /// The points' kinds after `u` and `v` changed (exposed for tests).
    #[cfg(test)]
    pub(crate) fn reclassify_all(&mut self) {
        for p in 0..self.pos.len() as u32 {
            if self.kind[p as usize] != VertexKind::Locked {
                self.classify(p);
            }
        }
    }

    // ----- attributes ------------------------------------------------------------

    /// Declares which attribute streams (`SOLVED_*` bits) the cost model writes for
    /// every wedge of the survivor after each collapse (the optimal values of its
    /// attribute quadrics): the collapse then leaves them alone instead of
    /// interpolating values that are overwritten at once. A wedge the model does
    /// not write (no weight, a value not finite) keeps its value from before the
    /// collapse. `0` (the default): every stream is interpolated.
    pub fn set_solved_streams(&mut self, streams: u8) {
        self.solved_streams = streams;
    }

    /// Whether a collapse that moves its survivor interpolates any stream.
    fn interpolates_some_stream(&self) -> bool {
        let a = &self.attrs;
        let unsolved = |present: bool, bit: u8| present && self.solved_streams & bit == 0;
        a.tangents.is_some()
            || a.joints.is_some()
            || a.weights.is_some()
            || unsolved(a.normals.is_some(), SOLVED_NORMAL)
            || unsolved(a.uv0.is_some(), SOLVED_UV0)
            || unsolved(a.uv1.is_some(), SOLVED_UV1)
            || unsolved(a.colors.is_some(), SOLVED_COLOR)
    }

    /// Interpolates the attributes of every wedge of `v` at the new position `p` from
    /// the closest point on the pre-collapse triangles around `u` and `v` of the same
    /// side (wedge) of any seam.
    fn interpolate_attributes(&mut self, u: u32, v: u32, p: [f32; 3]) {
        let pn = f64x3(p);
        let mut plans = std::mem::take(&mut self.scratch_plans);
        plans.clear();
        // Target wedges of v and the u-wedge each absorbs.
        let mut targets: [(u32, u32); 4] = [(DEAD, DEAD); 4];
        let mut nt = 0;
        for &t in self.fan(v) {
            let wv = self.wedge(t, self.corner_of(t, v));
            let tt = self.tri[t as usize];
            let wu = if tt.contains(&u) {
                self.wedge(t, self.corner_of(t, u))
            } else {
                DEAD
            };
            if let Some(e) = targets[..nt].iter_mut().find(|e| e.0 == wv) {
                if e.1 == DEAD {
                    e.1 = wu;
                }
            } else if nt < targets.len() {
                targets[nt] = (wv, wu);
                nt += 1;
            }
        }
        for &(wv, wu) in &targets[..nt] {
            let mut best = (f64::INFINITY, DEAD, [0.0; 3]);
            for (w, c) in [(v, wv), (u, wu)] {
                if c == DEAD {
                    continue;
                }
                for &t in self.fan(w) {
                    if self.wedge(t, self.corner_of(t, w)) != c {
                        continue;
                    }
                    let tt = self.tri[t as usize];
                    let q = tt.map(|x| f64x3(self.pos[x as usize]));
                    let (d2, bary) = closest_on_triangle(pn, q);
                    if d2 < best.0 {
                        best = (d2, t, bary);
                    }
                }
            }
            if best.1 != DEAD {
                let t = best.1;
                let ws = [self.wedge(t, 0), self.wedge(t, 1), self.wedge(t, 2)];
                plans.push((wv, ws, best.2));
            }
        }
        interpolate_streams(&mut self.attrs, &plans, self.solved_streams);
        self.scratch_plans = plans;
    }

    /// Before `u` (a junction, or a point crossing its seam) is merged into `v` at
    /// `p`: each wedge of `u` that no triangle over `v` uses moves to `v` whole
    /// (`redirect_corners`); its attributes become those at the closest point to
    /// `p` on `u`'s triangles of that wedge (the linear extension of its side).
    fn carry_unmapped_wedges(&mut self, u: u32, v: u32, p: [f32; 3]) {
        let pn = f64x3(p);
        let mut on_edge = [DEAD; 2];
        let mut n_edge = 0;
        let mut others = [(DEAD, f64::INFINITY, DEAD, [0.0; 3]); 8];
        let mut n = 0;
        for &t in self.fan(u) {
            if self.tri[t as usize].contains(&v) && n_edge < 2 {
                on_edge[n_edge] = self.wedge(t, self.corner_of(t, u));
                n_edge += 1;
            }
        }
        for &t in self.fan(u) {
            let w = self.wedge(t, self.corner_of(t, u));
            if on_edge.contains(&w) {
                continue;
            }
            let q = self.tri[t as usize].map(|x| f64x3(self.pos[x as usize]));
            let (d2, bary) = closest_on_triangle(pn, q);
            let slot = match others[..n].iter().position(|e| e.0 == w) {
                Some(i) => i,
                None if n < others.len() => {
                    n += 1;
                    others[n - 1].0 = w;
                    n - 1
                }
                None => continue,
            };
            if d2 < others[slot].1 {
                others[slot] = (w, d2, t, bary);
            }
        }
        let mut plans = std::mem::take(&mut self.scratch_plans);
        plans.clear();
        for &(w, _, t, bary) in &others[..n] {
            let ws = [self.wedge(t, 0), self.wedge(t, 1), self.wedge(t, 2)];
            plans.push((w, ws, bary));
        }
        // `interpolate_streams` applies up to four plans per call.
        for chunk in plans.chunks(4) {
            interpolate_streams(&mut self.attrs, chunk, 0);
        }
        self.scratch_plans = plans;
    }

    // ----- output ----------------------------------------------------------------

    /// The live triangles as wedge (input vertex) triples and point triples, with
    /// their groups.
    pub(crate) fn output_triangles(&self) -> OutputTriangles {
        let mut out = Vec::with_capacity(self.live_tris);
        let mut points = Vec::with_capacity(self.live_tris);
        let mut groups = self
            .tri_group
            .as_ref()
            .map(|_| Vec::with_capacity(self.live_tris));
        for (t, tt) in self.tri.iter().enumerate() {
            if tt[0] == DEAD {
                continue;
            }
            points.push(*tt);
            out.push([
                self.wedge(t as u32, 0),
                self.wedge(t as u32, 1),
                self.wedge(t as u32, 2),
            ]);
            if let (Some(g), Some(tg)) = (&mut groups, &self.tri_group) {
                g.push(tg[t]);
            }
        }
        (out, points, groups)
    }

    /// With [`BuildOptions::track_merges`]: for each input vertex, the live point it
    /// ended in, following the merges of the collapses ([`DEAD`] where that point has
    /// no triangle left, e.g. an unused or a degenerate-only vertex); `None` without
    /// tracking. O(points + vertices).
    pub(crate) fn vertex_roots(&self) -> Option<Vec<u32>> {
        if self.merged.is_empty() || self.wedge_point.is_empty() {
            return None;
        }
        // The end of each point's chain of merges, each chain walked once.
        let mut end = vec![DEAD; self.merged.len()];
        for p in 0..self.merged.len() as u32 {
            if end[p as usize] != DEAD {
                continue;
            }
            let mut r = p;
            loop {
                let e = end[r as usize];
                if e != DEAD {
                    r = e;
                    break;
                }
                let m = self.merged[r as usize];
                if m == DEAD {
                    break;
                }
                r = m;
            }
            let mut q = p;
            while end[q as usize] == DEAD {
                end[q as usize] = r;
                let m = self.merged[q as usize];
                if m == DEAD {
                    break;
                }
                q = m;
            }
        }
        Some(
            self.wedge_point
                .iter()
                .map(|&p| {
                    let r = end.get(p as usize).copied().unwrap_or(DEAD);
                    if r != DEAD && self.is_alive(r) {
                        r
                    } else {
                        DEAD
                    }
                })
                .collect(),
        )
    }

    /// The wedge streams' length (input vertices; 0 without attributes).
    pub(crate) fn wedge_count(&self) -> usize {
        let a = &self.attrs;
        [
            a.normals.as_ref().map(Vec::len),
            a.tangents.as_ref().map(Vec::len),
            a.uv0.as_ref().map(Vec::len),
            a.uv1.as_ref().map(Vec::len),
            a.colors.as_ref().map(Vec::len),
            a.joints.as_ref().map(Vec::len),
            a.weights.as_ref().map(Vec::len),
        ]
        .into_iter()
        .flatten()
        .max()
        .unwrap_or(0)
    }

    /// The working attribute streams, for a cost model that solves them.
    pub(crate) fn attributes_mut(&mut self) -> &mut VertexAttributes {
        &mut self.attrs
    }

    /// The distinct wedges of `p`'s live triangles into `out` (at most its
    /// length); returns how many.
    pub(crate) fn point_wedges(&self, p: u32, out: &mut [u32]) -> usize {
        let mut n = 0;
        for &t in self.fan(p) {
            let w = self.wedge(t, self.corner_of(t, p));
            if !out[..n].contains(&w) && n < out.len() {
                out[n] = w;
                n += 1;
            }
        }
        n
    }

    /// `(a's wedge, b's wedge)` in (up to) the first two triangles on edge `(a, b)`
    /// ([`DEAD`] where fewer): the wedges a collapse of the edge merges.
    pub(crate) fn edge_wedges(&self, a: u32, b: u32) -> [(u32, u32); 2] {
        let mut out = [(DEAD, DEAD); 2];
        let mut n = 0;
        for &t in self.fan(a) {
            if n < 2 && self.tri[t as usize].contains(&b) {
                out[n] = (
                    self.wedge(t, self.corner_of(t, a)),
                    self.wedge(t, self.corner_of(t, b)),
                );
                n += 1;
            }
        }
        out
    }

    /// `(u's wedge, v's wedge)` on the (up to two) triangles the last collapse
    /// removed ([`DEAD`] where fewer).
    pub(crate) fn last_wedge_map(&self) -> [(u32, u32); 2] {
        self.last_wedge_map
    }

    /// `(u's wedge, v's wedge)` on every triangle the last collapse removed (more
    /// than two along a non-manifold edge).
    pub(crate) fn last_wedge_map_all(&self) -> &[(u32, u32)] {
        &self.last_wedge_map_all[..self.last_dying]
    }

    /// `(a's wedge, b's wedge)` in every triangle on edge `(a, b)` (up to
    /// [`MAX_SHEETS`]), into `out`; returns how many.
    pub(crate) fn edge_wedges_all(
        &self,
        a: u32,
        b: u32,
        out: &mut [(u32, u32); MAX_SHEETS],
    ) -> usize {
        let mut n = 0;
        for &t in self.fan(a) {
            if n < MAX_SHEETS && self.tri[t as usize].contains(&b) {
                out[n] = (
                    self.wedge(t, self.corner_of(t, a)),
                    self.wedge(t, self.corner_of(t, b)),
                );
                n += 1;
            }
        }
        n
    }

    /// Takes the working attribute streams out (for building the output).
    pub(crate) fn take_attributes(&mut self) -> VertexAttributes {
        std::mem::take(&mut self.attrs)
    }
}

/// Marks every triangle that repeats an earlier one over the same three points (any
/// order or winding) [`DEAD`]; returns how many. `tri` is ordered by smallest point and
/// `ends[m]` is where point `m`'s triangles end, so copies are in one group.
/// The input's triangles that [`Surface::build`] keeps, in input order: as point
/// triples, with their wedges (canonical input vertices, when the mesh has
/// attributes) and groups.
struct KeptTriangles {
    tri: Vec<[u32; 3]>,
    wedge: Option<Vec<[u32; 3]>>,
    group: Option<Vec<u32>>,
    /// `count[m + 1]`: how many of them have `m` as their smallest point.
    count: Vec<u32>,
}

/// The triangles of `mesh` but those with a repeated point (after welding:
/// `point_of` maps a vertex to its point, `canonical` to its wedge when the mesh
/// has attributes) or exactly zero area (at the points' positions `pos`), which
/// are counted in `repair`.
fn keep_nondegenerate(
    mesh: &Mesh,
    canonical: Option<Vec<u32>>,
    point_of: &[u32],
    pos: &[[f32; 3]],
    repair: &mut Repair,
) -> KeptTriangles {
    let np = pos.len();
    let mut kept = Vec::with_capacity(mesh.triangles.len());
    let mut kept_wedge = canonical
        .is_some()
        .then(|| Vec::with_capacity(mesh.triangles.len()));
    let mut kept_group = mesh
        .groups
        .as_ref()
        .map(|_| Vec::with_capacity(mesh.triangles.len()));
    let mut count = vec![0u32; np + 1];
    for (ti, t) in mesh.triangles.iter().enumerate() {
        let w = match &canonical {
            Some(c) => t.map(|v| c[v as usize]),
            None => *t,
        };
        let p = w.map(|v| point_of[v as usize]);
        if p[0] == p[1] || p[1] == p[2] || p[0] == p[2] {
            repair.degenerate_triangles += 1;
            continue;
        }
        let (a, b, c) = (
            f64x3(pos[p[0] as usize]),
            f64x3(pos[p[1] as usize]),
            f64x3(pos[p[2] as usize]),
        );
        if cross(sub(b, a), sub(c, a)) == [0.0; 3] {
            repair.degenerate_triangles += 1;
            continue;
        }
        count[p[0].min(p[1]).min(p[2]) as usize + 1] += 1;
        kept.push(p);
        if let Some(tw) = &mut kept_wedge {
            tw.push(w);
        }
        if let (Some(tg), Some(g)) = (&mut kept_group, &mesh.groups) {
            tg.push(g[ti]);
        }
    }
    KeptTriangles {
        tri: kept,
        wedge: kept_wedge,
        group: kept_group,
        count,
    }
}

/// The kept triangles ordered by their smallest point ([`sort_by_smallest_point`]).
struct SortedTriangles {
    tri: Vec<[u32; 3]>,
    wedge: Option<Vec<[u32; 3]>>,
    group: Option<Vec<u32>>,
    /// `ends[m]`: the end of point `m`'s triangles (the start of `m + 1`'s), for
    /// each of the `np` points (one entry more, unused).
    ends: Vec<u32>,
}

/// Orders the kept triangles (and their wedges and groups) of the `np` points by
/// their smallest point, a stable counting sort in O(n): the triangles around a
/// point then sit close together in memory, which is what every fan walk touches,
/// and copies of one triangle sit in one group.
fn sort_by_smallest_point(kept: KeptTriangles, np: usize) -> SortedTriangles {
    let mut count = kept.count;
    for i in 0..np {
        count[i + 1] += count[i];
    }
    let n = kept.tri.len();
    let mut tri = vec![[0u32; 3]; n];
    let mut dest = Vec::with_capacity(n);
    for t in &kept.tri {
        let m = t[0].min(t[1]).min(t[2]) as usize;
        let d = count[m];
        count[m] += 1;
        tri[d as usize] = *t;
        dest.push(d);
    }
    drop(kept.tri);
    // `count[m]` is now the end of point `m`'s group (and the start of `m + 1`'s).
    let scatter = |v: Vec<[u32; 3]>| {
        let mut out = vec![[0u32; 3]; n];
        for (&d, x) in dest.iter().zip(v) {
            out[d as usize] = x;
        }
        out
    };
    let tri_wedge = kept.wedge.map(scatter);
    let tri_group = kept.group.map(|v| {
        let mut out = vec![0u32; n];
        for (&d, x) in dest.iter().zip(v) {
            out[d as usize] = x;
        }
        out
    });
    SortedTriangles {
        tri,
        wedge: tri_wedge,
        group: tri_group,
        ends: count,
    }
}

/// The diagonal's length and the center of the bounding box `bounds` (0 and the
/// origin for none); the diagonal as `Mesh::bbox_diagonal` computes it.
fn diagonal_and_center(bounds: Option<([f32; 3], [f32; 3])>) -> (f64, [f64; 3]) {
    bounds.map_or((0.0, [0.0; 3]), |(lo, hi)| {
        let diag = crate::mesh::box_diagonal(lo, hi);
        let center = [
            0.5 * (f64::from(lo[0]) + f64::from(hi[0])),
            0.5 * (f64::from(lo[1]) + f64::from(hi[1])),
            0.5 * (f64::from(lo[2]) + f64::from(hi[2])),
        ];
        (diag, center)
    })
}

fn remove_duplicates(tri: &mut [[u32; 3]], ends: &[u32]) -> usize {
    let mut dups = 0;
    let mut keys: Vec<(u64, u32)> = Vec::new();
    let mut lo = 0usize;
    for &end in ends {
        let hi = end as usize;
        let group = &mut tri[lo..hi];
        let key = |t: [u32; 3]| {
            let [_, b, c] = sorted3(t);
            (u64::from(b) << 32) | u64::from(c)
        };
        if group.len() <= 8 {
            for i in 1..group.len() {
                let k = key(group[i]);
                if group[..i].iter().any(|&t| t[0] != DEAD && key(t) == k) {
                    group[i] = [DEAD; 3];
                    dups += 1;
                }
            }
        } else {
            // Sorted by key then position: a copy follows its first occurrence.
            keys.clear();
            keys.extend(group.iter().enumerate().map(|(i, &t)| (key(t), i as u32)));
            keys.sort_unstable();
            for w in 1..keys.len() {
                if keys[w].0 == keys[w - 1].0 {
                    group[keys[w].1 as usize] = [DEAD; 3];
                    dups += 1;
                }
            }
        }
        lo = hi;
    }
    dups
}

fn canonical_of_point(representative: &[u32], p: usize) -> u32 {
    representative[p]
}

fn sorted3(t: [u32; 3]) -> [u32; 3] {
    let [mut a, mut b, mut c] = t;
    if a > b {
        std::mem::swap(&mut a, &mut b);
    }
    if b > c {
        std::mem::swap(&mut b, &mut c);
    }
    if a > b {
        std::mem::swap(&mut a, &mut b);
    }
    [a, b, c]
}

/// For every vertex, the first vertex with the same point and bitwise-equal
/// attributes (the normals compared only when `normals` is true: the flat-shading
/// merge sets them aside).
pub(crate) fn canonical_wedges(mesh: &Mesh, weld: &Weld, normals: bool) -> Vec<u32> {
    let np = weld.point_count();
    let n = mesh.positions.len();
    let (count, order) = weld.vertices_by_point();
    let a = &mesh.attributes;
    let same = |x: usize, y: usize| a.same_values(x, a, y, normals);
    let mut canonical: Vec<u32> = (0..n as u32).collect();
    for p in 0..np {
        let vs = &order[count[p] as usize..count[p + 1] as usize];
        for (i, &v) in vs.iter().enumerate() {
            for &w in &vs[..i] {
                if canonical[w as usize] == w && same(v as usize, w as usize) {
                    canonical[v as usize] = w;
                    break;
                }
            }
        }
    }
    canonical
}

/// Closest point on triangle `q` to `p`: squared distance and barycentric weights
/// (Ericson, *Real-Time Collision Detection*, 5.1.5).
pub(crate) fn closest_on_triangle(p: [f64; 3], q: [[f64; 3]; 3]) -> (f64, [f64; 3]) {
    let [a, b, c] = q;
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    let bary = if d1 <= 0.0 && d2 <= 0.0 {
        [1.0, 0.0, 0.0]
    } else {
        let bp = sub(p, b);
        let d3 = dot(ab, bp);
        let d4 = dot(ac, bp);
        if d3 >= 0.0 && d4 <= d3 {
            [0.0, 1.0, 0.0]
        } else {
            let vc = d1 * d4 - d3 * d2;
            if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
                let v = d1 / (d1 - d3);
                [1.0 - v, v, 0.0]
            } else {
                let cp = sub(p, c);
                let d5 = dot(ab, cp);
                let d6 = dot(ac, cp);
                if d6 >= 0.0 && d5 <= d6 {
                    [0.0, 0.0, 1.0]
                } else {
                    let vb = d5 * d2 - d1 * d6;
                    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
                        let w = d2 / (d2 - d6);
                        [1.0 - w, 0.0, w]
                    } else {
                        let va = d3 * d6 - d5 * d4;
                        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
                            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
                            [0.0, 1.0 - w, w]
                        } else {
                            let denom = 1.0 / (va + vb + vc);
                            let v = vb * denom;
                            let w = vc * denom;
                            [1.0 - v - w, v, w]
                        }
                    }
                }
            }
        }
    };
    let bary = if bary.iter().all(|x| x.is_finite()) {
        bary
    } else {
        [1.0, 0.0, 0.0]
    };
    let x = [
        a[0] * bary[0] + b[0] * bary[1] + c[0] * bary[2],
        a[1] * bary[0] + b[1] * bary[1] + c[1] * bary[2],
        a[2] * bary[0] + b[2] * bary[1] + c[2] * bary[2],
    ];
    let d = sub(p, x);
    (dot(d, d), bary)
}

/// Applies interpolation plans `(target wedge, source wedges, weights)` to every
/// attribute stream; all plans read the values from before any is written.
fn interpolate_streams(
    attrs: &mut VertexAttributes,
    plans: &[(u32, [u32; 3], [f64; 3])],
    solved: u8,
) {
    fn lerp<const N: usize>(
        s: &mut Option<Vec<[f32; N]>>,
        plans: &[(u32, [u32; 3], [f64; 3])],
        post: impl Fn(&mut [f64; N]),
        skip: bool,
    ) {
        let Some(v) = s else { return };
        if skip {
            return;
        }
        let mut out: [[f32; N]; 4] = [[0.0; N]; 4];
        for (i, (_, ws, l)) in plans.iter().enumerate().take(4) {
            let mut acc = [0.0f64; N];
            for (w, &lw) in ws.iter().zip(l.iter()) {
                let src = v[*w as usize];
                for k in 0..N {
                    acc[k] += lw * f64::from(src[k]);
                }
            }
            post(&mut acc);
            out[i] = acc.map(|x| x as f32);
        }
        for (i, (target, _, _)) in plans.iter().enumerate().take(4) {
            v[*target as usize] = out[i];
        }
    }
    let normalise3 = |a: &mut [f64; 3]| {
        let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        if l > 0.0 {
            a.iter_mut().for_each(|x| *x /= l);
        }
    };
    lerp(
        &mut attrs.normals,
        plans,
        normalise3,
        solved & SOLVED_NORMAL != 0,
    );
    // Tangents: direction interpolated and normalised, handedness of the dominant corner.
    if let Some(t) = &mut attrs.tangents {
        let mut out = [[0.0f32; 4]; 4];
        for (i, (_, ws, l)) in plans.iter().enumerate().take(4) {
            let mut acc = [0.0f64; 3];
            let mut best = 0;
            for k in 0..3 {
                let src = t[ws[k] as usize];
                for j in 0..3 {
                    acc[j] += l[k] * f64::from(src[j]);
                }
                if l[k] > l[best] {
                    best = k;
                }
            }
            normalise3(&mut acc);
            let w = t[ws[best] as usize][3];
            out[i] = [acc[0] as f32, acc[1] as f32, acc[2] as f32, w];
        }
        for (i, (target, _, _)) in plans.iter().enumerate().take(4) {
            t[*target as usize] = out[i];
        }
    }
    lerp(&mut attrs.uv0, plans, |_| {}, solved & SOLVED_UV0 != 0);
    lerp(&mut attrs.uv1, plans, |_| {}, solved & SOLVED_UV1 != 0);
    lerp(&mut attrs.colors, plans, |_| {}, solved & SOLVED_COLOR != 0);
    // Skinning: accumulate weight per joint over the three corners, keep the four
    // largest, renormalise.
    if let (Some(j), Some(wt)) = (&mut attrs.joints, &mut attrs.weights) {
        let mut out = [([0u16; 4], [0f32; 4]); 4];
        for (i, (_, ws, l)) in plans.iter().enumerate().take(4) {
            let mut acc: [(u16, f64); 12] = [(0, 0.0); 12];
            let mut n = 0;
            for k in 0..3 {
                let (jj, ww) = (j[ws[k] as usize], wt[ws[k] as usize]);
                for m in 0..4 {
                    let c = l[k] * f64::from(ww[m]);
                    if let Some(e) = acc[..n].iter_mut().find(|e| e.0 == jj[m]) {
                        e.1 += c;
                    } else {
                        acc[n] = (jj[m], c);
                        n += 1;
                    }
                }
            }
            let acc = &mut acc[..n];
            acc.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            let top = &acc[..n.min(4)];
            let sum: f64 = top.iter().map(|e| e.1.max(0.0)).sum();
            let mut jo = [0u16; 4];
            let mut wo = [0f32; 4];
            for (m, e) in top.iter().enumerate() {
                jo[m] = e.0;
                wo[m] = if sum > 0.0 {
                    (e.1.max(0.0) / sum) as f32
                } else {
                    0.0
                };
            }
            if sum <= 0.0 {
                wo[0] = 1.0;
            }
            out[i] = (jo, wo);
        }
        for (i, (target, _, _)) in plans.iter().enumerate().take(4) {
            j[*target as usize] = out[i].0;
            wt[*target as usize] = out[i].1;
        }
    } else {
        lerp(&mut attrs.weights, plans, |_| {}, false);
    }
}
