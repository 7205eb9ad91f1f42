//! Progressive meshes (Hoppe 1996) built from half-edge collapses, and a
//! [`Navigator`] that coarsens and refines them in place.
//!
//! # The structure
//! Points, wedges (attribute vertices: a point with one set of attributes) and
//! triangles are numbered in the order they appear when refining: the base mesh's
//! come first, then each vertex split appends exactly one point (the one its
//! collapse removed), the wedges that point (or a neighbour losing its last use of a
//! wedge) brings back, and the one or two triangles the collapse deleted. A vertex
//! split `k` records
//! - the *kept* point `v` it splits (an existing point) and the position of the new
//!   point `u = base_points + k` — `v` never moves, since every collapse was a
//!   half-edge collapse onto `v`;
//! - the new wedges, each with its owner point and attributes;
//! - the *moved corners*: corners of existing triangles (`3·triangle + corner`) that
//!   referred to a wedge of `v` and now refer to a wedge of `u` (Hoppe's split of
//!   `v`'s fan between `vl` and `vr`, stored explicitly so that non-manifold kept
//!   points work too);
//! - the new triangles, as wedge triples with their group.
//!
//! Because no point ever moves, the vertex buffer (one entry per wedge, in this
//! order) is static: a level of detail is a prefix of it plus the current index
//! buffer. A split writes its moved corners and extends the triangle prefix; a
//! collapse (its inverse) writes the previous wedges back and shortens the prefix.
//! Both are O(valence): the [`Navigator`] does no rebuilding.
//!
//! # What "original" means
//! The finest level is the input *after* the repair every simplification does
//! ([`crate::simplify`]): positions welded by exact equality, triangles with a
//! repeated point or zero area and duplicate triangles removed, unreferenced
//! vertices dropped. That is the mesh [`crate::simplify::simplify`] returns at ratio
//! 1; refining the base with every split reproduces it exactly (same positions and
//! attributes bit for bit, same triangles with the same orientation, in another
//! vertex and triangle order).

use crate::collapse::{CollapseRecord, Surface, DEAD};
use crate::cost::Placement;
use crate::decimate::Observer;
use crate::mesh::{Mesh, VertexAttributes, Weld};
use crate::simplify::{simplify_observed, Method, Report, SimplifyError, SimplifyOptions};
use thiserror::Error;

/// Errors of building, reading and writing progressive meshes.
#[derive(Debug, Error)]
pub enum PmError {
    /// The simplification failed (invalid mesh or options).
    #[error(transparent)]
    Simplify(#[from] SimplifyError),
    /// The options do not give half-edge collapses over edges only.
    #[error("progressive meshes need half-edge collapses: {0}")]
    NotHalfEdge(&'static str),
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A `.pmesh` file is truncated or corrupt.
    #[error("{file}: byte {offset}: {message}")]
    Format {
        /// The file name (`<memory>` for a buffer).
        file: String,
        /// Byte offset where the problem was found.
        offset: usize,
        /// What is wrong.
        message: String,
    },
}

/// A base mesh and the ordered vertex splits that refine it back to the original.
/// See the module docs for the numbering; build with [`ProgressiveMesh::build`] or
/// read with [`crate::lod::read_pmesh`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ProgressiveMesh {
    /// Per point, in split order (base points first).
    pub(crate) positions: Vec<[f32; 3]>,
    pub(crate) base_points: u32,
    /// Per wedge: its point.
    pub(crate) wedge_point: Vec<u32>,
    /// Per wedge: attributes (streams of the input mesh).
    pub(crate) attributes: VertexAttributes,
    pub(crate) base_wedges: u32,
    /// Per triangle: wedges when it appears (base triangles: in the base mesh).
    pub(crate) triangles: Vec<[u32; 3]>,
    pub(crate) groups: Option<Vec<u32>>,
    pub(crate) group_names: Vec<String>,
    pub(crate) base_triangles: u32,
    /// Per split: the kept point, the collapse's error, and the ends of its new
    /// wedges, new triangles and moved corners in the flat arrays.
    pub(crate) kept: Vec<u32>,
    pub(crate) error: Vec<f32>,
    pub(crate) wedge_end: Vec<u32>,
    pub(crate) tri_end: Vec<u32>,
    pub(crate) moved_end: Vec<u32>,
    /// Moved corners: `3·triangle + corner` and the new point's wedge it now uses.
    pub(crate) moved_corner: Vec<u32>,
    pub(crate) moved_wedge: Vec<u32>,
}

/// One vertex split, borrowed from a [`ProgressiveMesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct VertexSplit<'a> {
    /// The existing point that is split.
    pub kept: u32,
    /// The new point's id (`base_points + k`).
    pub new_point: u32,
    /// The new point's position.
    pub position: [f32; 3],
    /// The error of the collapse this split undoes (the cost model's distance).
    pub error: f32,
    /// Ids of the wedges it adds.
    pub new_wedges: std::ops::Range<u32>,
    /// Ids of the triangles it adds.
    pub new_triangles: std::ops::Range<u32>,
    /// Corners `3·triangle + corner` moved from a wedge of `kept` to a new wedge.
    pub moved_corners: &'a [u32],
    /// The wedge each moved corner now uses.
    pub moved_wedges: &'a [u32],
}

impl ProgressiveMesh {
    /// Simplifies `mesh` with `options`, recording every collapse, and returns the
    /// progressive mesh (the simplified result is its base) and the report.
    ///
    /// The collapses must be half-edge collapses over edges: [`Method::Melax`], or
    /// [`Method::Qem`] with [`Placement::Endpoint`], with topology preserved. Use
    /// `with_target_triangles(0)` to record down to the coarsest mesh the operator
    /// allows. Extracting `n` triangles afterwards gives the same mesh as running
    /// [`crate::simplify::simplify`] with the same options and target `n` and
    /// [`SimplifyOptions::facing_repair`] off (its diagonal swaps are not vertex
    /// splits, so the build leaves them out).
    ///
    /// # Errors
    /// [`PmError::NotHalfEdge`] for other methods or placements,
    /// [`PmError::Simplify`] for an invalid mesh or options.
    pub fn build(mesh: &Mesh, options: &SimplifyOptions) -> Result<(Self, Report), PmError> {
        let ok = match options.method {
            Method::Melax => true,
            Method::Qem => options.placement == Placement::Endpoint,
            #[allow(unreachable_patterns)]
            _ => false,
        };
        if !ok {
            return Err(PmError::NotHalfEdge(
                "use the melax method, or qem with endpoint placement",
            ));
        }
        if !options.preserve_topology {
            return Err(PmError::NotHalfEdge(
                "topology changes (non-edge pair contractions, closed holes, removed parts) \
                 cannot be recorded",
            ));
        }
        let mut rec = Recorder::default();
        // The orientation repair's diagonal swaps are not vertex splits: the base
        // mesh is the collapses' result as it stands.
        // Flat re-shading would record the collapses over another vertex buffer;
        // the attribute refit would change values the splits do not restore.
        let options = &options
            .clone()
            .with_facing_repair(false)
            .with_refit_attributes(false)
            .with_reshade_flat(false);
        let s = simplify_observed(mesh, options, &mut rec)?;
        if rec.moved_kept {
            return Err(PmError::NotHalfEdge("a collapse moved the kept vertex"));
        }
        Ok((finish(mesh, &s.mesh, &s.vertex_source, &rec), s.report))
    }

    /// Number of vertex splits.
    #[must_use]
    pub fn split_count(&self) -> usize {
        self.kept.len()
    }

    /// Triangles of the base mesh.
    #[must_use]
    pub fn base_triangle_count(&self) -> usize {
        self.base_triangles as usize
    }

    /// Points of the base mesh.
    #[must_use]
    pub fn base_point_count(&self) -> usize {
        self.base_points as usize
    }

    /// Wedges (output vertices) of the base mesh.
    #[must_use]
    pub fn base_wedge_count(&self) -> usize {
        self.base_wedges as usize
    }

    /// Triangles after applying the first `level` splits (`level` clamped).
    #[must_use]
    pub fn triangles_at(&self, level: usize) -> usize {
        match level.min(self.kept.len()) {
            0 => self.base_triangles as usize,
            l => self.tri_end[l - 1] as usize,
        }
    }

    /// Wedges (vertex-buffer prefix) after the first `level` splits.
    #[must_use]
    pub fn wedges_at(&self, level: usize) -> usize {
        match level.min(self.kept.len()) {
            0 => self.base_wedges as usize,
            l => self.wedge_end[l - 1] as usize,
        }
    }

    /// The level with the most splits whose triangle count is at most `n` (0 when
    /// even the base has more): what a simplification to `n` triangles stops at.
    #[must_use]
    pub fn level_for_triangles(&self, n: usize) -> usize {
        self.tri_end.partition_point(|&t| t as usize <= n)
    }

    /// Vertex split `k` (`k < split_count`).
    ///
    /// # Panics
    /// Panics if `k` is out of range.
    #[must_use]
    pub fn split(&self, k: usize) -> VertexSplit<'_> {
        let m0 = if k == 0 {
            0
        } else {
            self.moved_end[k - 1] as usize
        };
        let m1 = self.moved_end[k] as usize;
        VertexSplit {
            kept: self.kept[k],
            new_point: self.base_points + k as u32,
            position: self.positions[self.base_points as usize + k],
            error: self.error[k],
            new_wedges: self.wedges_at(k) as u32..self.wedge_end[k],
            new_triangles: self.triangles_at(k) as u32..self.tri_end[k],
            moved_corners: &self.moved_corner[m0..m1],
            moved_wedges: &self.moved_wedge[m0..m1],
        }
    }

    /// Positions of all points, in split order.
    #[must_use]
    pub fn point_positions(&self) -> &[[f32; 3]] {
        &self.positions
    }

    /// The point of every wedge.
    #[must_use]
    pub fn wedge_points(&self) -> &[u32] {
        &self.wedge_point
    }

    /// The static vertex buffer: the position of every wedge (a level uses a prefix).
    #[must_use]
    pub fn wedge_positions(&self) -> Vec<[f32; 3]> {
        self.wedge_point
            .iter()
            .map(|&p| self.positions[p as usize])
            .collect()
    }

    /// Attribute streams per wedge.
    #[must_use]
    pub fn attributes(&self) -> &VertexAttributes {
        &self.attributes
    }

    /// Keeps only the first `k` splits (what a reader of a file prefix gets).
    pub fn truncate(&mut self, k: usize) {
        if k >= self.kept.len() {
            return;
        }
        let (w, t, m) = (
            self.wedges_at(k),
            self.triangles_at(k),
            if k == 0 {
                0
            } else {
                self.moved_end[k - 1] as usize
            },
        );
        self.positions.truncate(self.base_points as usize + k);
        self.wedge_point.truncate(w);
        self.attributes = self.attributes.gather(&(0..w as u32).collect::<Vec<_>>());
        self.triangles.truncate(t);
        if let Some(g) = &mut self.groups {
            g.truncate(t);
        }
        for v in [
            &mut self.kept,
            &mut self.wedge_end,
            &mut self.tri_end,
            &mut self.moved_end,
        ] {
            v.truncate(k);
        }
        self.error.truncate(k);
        self.moved_corner.truncate(m);
        self.moved_wedge.truncate(m);
    }

    /// The mesh at `level` splits (a convenience over [`Navigator`]).
    #[must_use]
    pub fn mesh_at(&self, level: usize) -> Mesh {
        let mut n = Navigator::new(self);
        n.set_level(level);
        n.to_mesh()
    }
}

/// Records, for every collapse, what the vertex split that undoes it needs.
#[derive(Debug, Default)]
struct Recorder {
    /// Live triangle slots when the first collapse happened.
    initial_live: Vec<bool>,
    /// Per collapse: an input vertex at the removed point and one at the kept point.
    removed: Vec<u32>,
    kept: Vec<u32>,
    error: Vec<f32>,
    dying_end: Vec<u32>,
    /// Dying triangles: slot, wedges, group.
    dying: Vec<(u32, [u32; 3], u32)>,
    moved_end: Vec<u32>,
    /// Surviving triangles of the removed point: `3·slot + corner`, its wedge there.
    moved: Vec<(u32, u32)>,
    moved_kept: bool,
}

impl Observer for Recorder {
    fn before_collapse(&mut self, surface: &Surface, removed: u32, kept: u32) {
        if self.removed.is_empty() {
            self.initial_live = (0..surface.triangle_slots() as u32)
                .map(|t| surface.triangle(t)[0] != DEAD)
                .collect();
        }
        for &t in surface.fan(removed) {
            let tt = surface.triangle(t);
            if tt.contains(&kept) {
                let w = [0, 1, 2].map(|k| surface.wedge(t, k));
                self.dying.push((t, w, surface.group(t)));
            } else {
                let k = tt.iter().position(|&x| x == removed).unwrap_or(0);
                self.moved.push((3 * t + k as u32, surface.wedge(t, k)));
            }
        }
        // Input vertices, not the surface's point ids (numbered in spatial order):
        // `finish` maps them to points of its own welding.
        self.removed.push(surface.point_vertex(removed));
        self.kept.push(surface.point_vertex(kept));
        self.dying_end.push(self.dying.len() as u32);
        self.moved_end.push(self.moved.len() as u32);
    }

    fn collapsed(&mut self, record: &CollapseRecord) {
        if record.position != record.kept_old_position {
            self.moved_kept = true;
        }
        self.error.push(record.error as f32);
    }
}

/// Assembles the progressive mesh from the input, the simplified base (over wedges
/// `source`) and the recorded collapses.
fn finish(mesh: &Mesh, base: &Mesh, source: &[u32], rec: &Recorder) -> ProgressiveMesh {
    let weld = Weld::exact(&mesh.positions);
    let point_of = &weld.point_of;
    let mut pm_point = vec![DEAD; weld.point_count()];
    let mut pm_wedge = vec![DEAD; mesh.positions.len()];
    let mut pm = ProgressiveMesh {
        group_names: mesh.group_names.clone(),
        groups: mesh.groups.as_ref().map(|_| Vec::new()),
        ..ProgressiveMesh::default()
    };
    let mut wedge_src: Vec<u32> = Vec::new();
    // Assigns PM ids to input wedge `w` (and its point) on first use.
    let mut use_wedge =
        |w: u32, pm: &mut ProgressiveMesh, pm_point: &mut [u32], wedge_src: &mut Vec<u32>| -> u32 {
            let p = point_of[w as usize] as usize;
            if pm_point[p] == DEAD {
                pm_point[p] = pm.positions.len() as u32;
                pm.positions.push(mesh.positions[w as usize]);
            }
            if pm_wedge[w as usize] == DEAD {
                pm_wedge[w as usize] = pm.wedge_point.len() as u32;
                pm.wedge_point.push(pm_point[p]);
                wedge_src.push(w);
            }
            pm_wedge[w as usize]
        };
    for (i, t) in base.triangles.iter().enumerate() {
        let tw = t.map(|v| use_wedge(source[v as usize], &mut pm, &mut pm_point, &mut wedge_src));
        pm.triangles.push(tw);
        if let Some(g) = &mut pm.groups {
            g.push(base.group(i));
        }
    }
    pm.base_points = pm.positions.len() as u32;
    pm.base_wedges = pm.wedge_point.len() as u32;
    pm.base_triangles = pm.triangles.len() as u32;

    // Surface slot → PM triangle id: the base's live slots in ascending order (the
    // order the output was written in), then dying triangles split by split.
    let mut pm_tri = vec![DEAD; rec.initial_live.len()];
    if !rec.removed.is_empty() {
        let mut alive = rec.initial_live.clone();
        for d in &rec.dying {
            alive[d.0 as usize] = false;
        }
        let mut next = 0u32;
        for (slot, &a) in alive.iter().enumerate() {
            if a {
                pm_tri[slot] = next;
                next += 1;
            }
        }
        debug_assert_eq!(next, pm.base_triangles);
    }

    let n = rec.removed.len();
    for c in (0..n).rev() {
        let (u, v) = (
            point_of[rec.removed[c] as usize],
            point_of[rec.kept[c] as usize],
        );
        let d0 = if c == 0 {
            0
        } else {
            rec.dying_end[c - 1] as usize
        };
        let m0 = if c == 0 {
            0
        } else {
            rec.moved_end[c - 1] as usize
        };
        let dying = &rec.dying[d0..rec.dying_end[c] as usize];
        let moved = &rec.moved[m0..rec.moved_end[c] as usize];
        // The new point first, so it takes id base_points + k.
        let rep = weld.representative[u as usize];
        debug_assert_eq!(pm_point[u as usize], DEAD);
        pm_point[u as usize] = pm.positions.len() as u32;
        pm.positions.push(mesh.positions[rep as usize]);
        pm.kept.push(pm_point[v as usize]);
        pm.error.push(rec.error.get(c).copied().unwrap_or(0.0));
        let mut tris = Vec::with_capacity(2);
        for &(slot, w, g) in dying {
            let tw = w.map(|x| use_wedge(x, &mut pm, &mut pm_point, &mut wedge_src));
            tris.push((slot, tw, g));
        }
        for &(corner, w) in moved {
            let nw = use_wedge(w, &mut pm, &mut pm_point, &mut wedge_src);
            let t = pm_tri[(corner / 3) as usize];
            pm.moved_corner.push(3 * t + corner % 3);
            pm.moved_wedge.push(nw);
        }
        for (slot, tw, g) in tris {
            pm_tri[slot as usize] = pm.triangles.len() as u32;
            pm.triangles.push(tw);
            if let Some(gs) = &mut pm.groups {
                gs.push(g);
            }
        }
        pm.wedge_end.push(pm.wedge_point.len() as u32);
        pm.tri_end.push(pm.triangles.len() as u32);
        pm.moved_end.push(pm.moved_corner.len() as u32);
    }
    pm.attributes = mesh.attributes.gather(&wedge_src);
    pm
}

/// Moves a [`ProgressiveMesh`] between levels in place: applying a split or its
/// inverse costs O(valence), whatever the mesh size.
///
/// The vertex buffer is the progressive mesh's static wedge buffer
/// ([`ProgressiveMesh::wedge_positions`], [`ProgressiveMesh::attributes`]); the
/// current level uses its first [`Navigator::vertex_count`] entries and the index
/// buffer [`Navigator::indices`].
#[derive(Debug, Clone)]
pub struct Navigator<'a> {
    pm: &'a ProgressiveMesh,
    /// Current wedges of every triangle (those past the prefix: as created).
    tris: Vec<[u32; 3]>,
    /// The wedge each moved corner used before its split.
    moved_old: Vec<u32>,
    level: usize,
}

impl<'a> Navigator<'a> {
    /// A navigator at the finest level (every split applied). O(size).
    #[must_use]
    pub fn new(pm: &'a ProgressiveMesh) -> Self {
        let mut tris = pm.triangles.clone();
        let mut moved_old = vec![0; pm.moved_corner.len()];
        for (i, (&c, &w)) in pm.moved_corner.iter().zip(&pm.moved_wedge).enumerate() {
            let slot = &mut tris[(c / 3) as usize][(c % 3) as usize];
            moved_old[i] = *slot;
            *slot = w;
        }
        Self {
            pm,
            tris,
            moved_old,
            level: pm.split_count(),
        }
    }

    /// Splits applied (0 = the base mesh).
    #[must_use]
    pub fn level(&self) -> usize {
        self.level
    }

    /// Live triangles.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.pm.triangles_at(self.level)
    }

    /// Vertices (wedges) in use: a prefix of the static vertex buffer.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.pm.wedges_at(self.level)
    }

    /// The current index buffer, over the static wedge buffer.
    #[must_use]
    pub fn indices(&self) -> &[[u32; 3]] {
        &self.tris[..self.triangle_count()]
    }

    /// Applies up to `n` more splits; returns how many were applied.
    pub fn refine(&mut self, n: usize) -> usize {
        let end = (self.level + n).min(self.pm.split_count());
        let pm = self.pm;
        let mut m = if self.level == 0 {
            0
        } else {
            pm.moved_end[self.level - 1] as usize
        };
        for k in self.level..end {
            let m1 = pm.moved_end[k] as usize;
            for i in m..m1 {
                let c = pm.moved_corner[i];
                self.tris[(c / 3) as usize][(c % 3) as usize] = pm.moved_wedge[i];
            }
            m = m1;
        }
        let done = end - self.level;
        self.level = end;
        done
    }

    /// Undoes up to `n` splits (edge collapses); returns how many were undone.
    pub fn coarsen(&mut self, n: usize) -> usize {
        let end = self.level.saturating_sub(n);
        let pm = self.pm;
        for k in (end..self.level).rev() {
            let m0 = if k == 0 {
                0
            } else {
                pm.moved_end[k - 1] as usize
            };
            for i in (m0..pm.moved_end[k] as usize).rev() {
                let c = pm.moved_corner[i];
                self.tris[(c / 3) as usize][(c % 3) as usize] = self.moved_old[i];
            }
        }
        let done = self.level - end;
        self.level = end;
        done
    }

    /// Moves to `level` splits (clamped), in whichever direction.
    pub fn set_level(&mut self, level: usize) {
        let level = level.min(self.pm.split_count());
        if level > self.level {
            self.refine(level - self.level);
        } else {
            self.coarsen(self.level - level);
        }
    }

    /// Moves to the finest level with at most `n` triangles (the base when it has
    /// more); returns the level. This is the mesh a simplification to `n` triangles
    /// with the same options gives.
    pub fn set_triangles(&mut self, n: usize) -> usize {
        let l = self.pm.level_for_triangles(n);
        self.set_level(l);
        l
    }

    /// The current level as a standalone mesh: the used wedges in first-use order,
    /// with their attributes; groups kept.
    #[must_use]
    pub fn to_mesh(&self) -> Mesh {
        self.to_mesh_with_sources().0
    }

    /// [`Self::to_mesh`] and, per output vertex, its wedge id.
    fn to_mesh_with_sources(&self) -> (Mesh, Vec<u32>) {
        let pm = self.pm;
        let mut remap = vec![DEAD; self.vertex_count()];
        let mut source = Vec::new();
        let mut positions = Vec::new();
        let tris = self.indices();
        let mut triangles = Vec::with_capacity(tris.len());
        for t in tris {
            triangles.push(t.map(|w| {
                let r = &mut remap[w as usize];
                if *r == DEAD {
                    *r = source.len() as u32;
                    source.push(w);
                    positions.push(pm.positions[pm.wedge_point[w as usize] as usize]);
                }
                *r
            }));
        }
        let groups = pm.groups.as_ref().map(|g| g[..tris.len()].to_vec());
        let mesh = Mesh {
            positions,
            triangles,
            attributes: pm.attributes.gather(&source),
            groups,
            group_names: pm.group_names.clone(),
        };
        (mesh, source)
    }

    /// The current level as a mesh, and for each of its vertices the position it
    /// has at the coarser level `coarse` (its ancestor's position): the start of a
    /// geomorph. A renderer blends `lerp(coarse, fine, α)` for α from 0 to 1 to move
    /// smoothly from level `coarse` to this one. Only positions morph; attributes
    /// are this level's. `coarse` is clamped to the current level.
    #[must_use]
    pub fn to_mesh_with_geomorph(&self, coarse: usize) -> (Mesh, Vec<[f32; 3]>) {
        let (mesh, source) = self.to_mesh_with_sources();
        let pm = self.pm;
        let coarse_points = pm.base_points as usize + coarse.min(self.level);
        let points = pm.base_points as usize + self.level;
        // Ancestor of every point: itself below the coarse level, else its split's
        // kept point's ancestor (kept points are older, so one forward pass).
        let mut anc: Vec<u32> = (0..points as u32).collect();
        for p in coarse_points..points {
            let k = p - pm.base_points as usize;
            anc[p] = anc[pm.kept[k] as usize];
        }
        let morph = source
            .iter()
            .map(|&w| pm.positions[anc[pm.wedge_point[w as usize] as usize] as usize])
            .collect();
        (mesh, morph)
    }
}
