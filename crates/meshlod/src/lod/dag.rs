//! View-dependent level of detail: a cluster hierarchy (DAG) with crack-free cuts.
//!
//! The construction follows the cluster-DAG scheme of Karis et al., "Nanite: a deep
//! dive" (SIGGRAPH 2021 course), which meshoptimizer's `clusterlod` also implements:
//!
//! 1. the input (welded) is split into clusters of about [`DagOptions::cluster_size`]
//!    triangles, each grown over shared vertices from a seed taken in the Morton
//!    order of the triangle centroids;
//! 2. each round, the clusters not yet simplified are put into groups of about
//!    [`DagOptions::group_size`] clusters (merged smallest first with the neighbour
//!    sharing the most vertices, Kurita's agglomerative clustering, so that few
//!    vertices are shared between groups); each group's triangles are simplified
//!    to half with QEM, every vertex the group shares with another group locked
//!    (so the group's outer border stays where it is), and the result is split
//!    into new clusters;
//! 3. a group that cannot reach three quarters of its triangles is left as it was;
//!    its clusters go into the next round's grouping. Rounds go on until one cluster
//!    is left or a round simplifies no group.
//!
//! Every cluster carries two (error, sphere) pairs: its own — the error and bounds of
//! the group simplification that made it (0 and its own bounds for input clusters) —
//! and its parent's — those of the group it was simplified in (infinite for the
//! clusters never simplified further). A group's error is its simplifier's error
//! plus the largest own error of its clusters, and its sphere encloses their own
//! spheres, so both grow up the hierarchy and the projected error
//! `p = ε x / (2 max(d − r, ·) tan(θ/2))` (distance `d` to the sphere's centre,
//! radius `r`) of a parent is at least its children's. The cut for a view takes the
//! clusters whose own projected error is within the budget and whose parent's is
//! not. All clusters of a group share the parent pair and all clusters made from a
//! group share the own pair, so a group is either wholly replaced by its
//! simplification or not at all: the locked borders meet exactly and the cut has no
//! cracks. (Two neighbouring groups may both cut the corner at a locked border
//! vertex, each leaving one triangle there over the same chord: the cut then holds
//! a flat two-triangle fin, closed but not manifold along the chord. On an
//! 81,920-triangle sphere that happens at two edges of the coarsest cuts.)

use crate::decimate::NoObserver;
use crate::mesh::{Mesh, VertexAttributes, Weld};
use crate::simplify::{simplify_observed, SimplifyError, SimplifyOptions};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Options of [`build_dag`].
#[derive(Debug, Clone, PartialEq)]
pub struct DagOptions {
    /// Triangles per cluster (at most). Default 128.
    pub cluster_size: usize,
    /// Clusters per group (a group may reach a third more). Default 16: a larger
    /// group has relatively fewer locked border vertices, so halving it leaves
    /// better triangles (with 4 the armadillo's coarse cuts were 10× worse).
    pub group_size: usize,
    /// The simplifier's options (targets and locks are set per group). Default QEM.
    pub simplify: SimplifyOptions,
}

impl Default for DagOptions {
    fn default() -> Self {
        Self {
            cluster_size: 128,
            group_size: 16,
            simplify: SimplifyOptions::default(),
        }
    }
}

/// A bounding sphere: centre and radius, mesh units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: [f64; 3],
    /// Radius.
    pub radius: f64,
}

impl Sphere {
    /// The sphere around the bounding box of `points` (a point at the origin when
    /// there are none).
    #[must_use]
    pub fn around(points: impl Iterator<Item = [f32; 3]> + Clone) -> Self {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in points.clone() {
            for k in 0..3 {
                lo[k] = lo[k].min(f64::from(p[k]));
                hi[k] = hi[k].max(f64::from(p[k]));
            }
        }
        if lo[0] > hi[0] {
            return Self {
                center: [0.0; 3],
                radius: 0.0,
            };
        }
        let center = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
        let radius = points
            .map(|p| dist(center, p.map(f64::from)))
            .fold(0.0, f64::max);
        Self { center, radius }
    }

    /// The smallest sphere about the centre of the spheres' centres' box that
    /// encloses them all.
    #[must_use]
    pub fn enclosing(spheres: &[Sphere]) -> Self {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for s in spheres {
            for k in 0..3 {
                lo[k] = lo[k].min(s.center[k] - s.radius);
                hi[k] = hi[k].max(s.center[k] + s.radius);
            }
        }
        if spheres.is_empty() {
            return Self {
                center: [0.0; 3],
                radius: 0.0,
            };
        }
        let center = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
        let radius = spheres
            .iter()
            .map(|s| dist(center, s.center) + s.radius)
            .fold(0.0, f64::max);
        Self { center, radius }
    }
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// One cluster of the hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct Cluster {
    /// Round that made it (0: a cluster of the input).
    pub level: u32,
    /// Its triangles, as indices into [`Dag::positions`].
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle, its group (material) id into [`Dag::group_names`]: one per
    /// triangle when [`Dag::group_names`] is `Some` (group 0 is written for a
    /// cluster without them), empty otherwise.
    pub groups: Vec<u32>,
    /// Its own error (mesh units): that of the group simplification that made it.
    pub error: f64,
    /// Its own bounds: those of that group (its own triangles' for an input cluster).
    pub sphere: Sphere,
    /// The error of the group it was simplified in (`f64::INFINITY` for a root).
    pub parent_error: f64,
    /// That group's bounds.
    pub parent_sphere: Sphere,
}

impl Cluster {
    /// The bounding sphere of its own triangles (`positions`: [`Dag::positions`]),
    /// usually tighter than [`Self::sphere`], which bounds the whole group that
    /// made it (as the cut's monotone errors need): what frustum culling tests.
    #[must_use]
    pub fn bounds(&self, positions: &[[f32; 3]]) -> Sphere {
        Sphere::around(
            self.triangles
                .iter()
                .flatten()
                .filter_map(|&v| positions.get(v as usize).copied()),
        )
    }
}

/// A cluster hierarchy: shared vertices and clusters of every level.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Dag {
    /// Positions of every level's vertices (the input's first: welded when it has
    /// no attributes, as they are when it has).
    pub positions: Vec<[f32; 3]>,
    /// The vertices' attributes (normals, UVs, colours…, as the input had them;
    /// a simplified group's new vertices get the simplifier's values).
    pub attributes: VertexAttributes,
    /// Names of the groups (materials) the clusters' triangles refer to; `None`
    /// when the input had no groups.
    pub group_names: Option<Vec<String>>,
    /// The clusters.
    pub clusters: Vec<Cluster>,
}

/// What [`build_dag`] did.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct DagReport {
    /// Input triangles.
    pub triangles: usize,
    /// Clusters in all.
    pub clusters: usize,
    /// Clusters of the input (level 0).
    pub leaf_clusters: usize,
    /// Clusters never simplified further.
    pub roots: usize,
    /// Triangles of the roots.
    pub root_triangles: usize,
    /// Rounds of grouping and simplification (levels above the input).
    pub depth: u32,
    /// Groups that could not reach three quarters of their triangles.
    pub stuck_groups: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// A camera for [`Dag::cut`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DagView {
    /// Camera position, mesh units.
    pub position: [f64; 3],
    /// A point the camera looks at, mesh units, or `None` for no view direction.
    ///
    /// With it, clusters whose spheres lie wholly outside the view cone (behind the
    /// camera or beyond the corners of the screen, from `screen.fov_degrees` and
    /// `screen.aspect`) count as showing no error, so the cut takes them as coarse as
    /// the hierarchy allows; they are coarsened, not dropped, and the cut stays
    /// closed. Clusters in view are judged as without it (error over the distance to
    /// the sphere).
    pub target: Option<[f64; 3]>,
    /// Screen and pixel budget.
    pub screen: super::Screen,
}

impl DagView {
    /// A view from `position` with no view direction (every direction counts).
    #[must_use]
    pub fn new(position: [f64; 3], screen: super::Screen) -> Self {
        Self {
            position,
            target: None,
            screen,
        }
    }
}

/// The view axis and the cosine and sine of the cone around it that holds the whole
/// screen (its half-diagonal angle), or `None` without a target (or a target at the
/// camera).
fn view_cone(view: &DagView) -> Option<Cone> {
    let t = view.target?;
    let d: [f64; 3] = std::array::from_fn(|k| t[k] - view.position[k]);
    let n = dist(t, view.position);
    if !(n > 0.0 && n.is_finite()) {
        return None;
    }
    let axis = d.map(|x| x / n);
    let half = (view.screen.fov_degrees.to_radians() / 2.0).tan();
    let diagonal = (half * (1.0 + view.screen.aspect * view.screen.aspect).sqrt()).atan();
    Some((axis, diagonal.cos(), diagonal.sin()))
}

/// The view axis and the cosine and sine of its half-diagonal angle (from
/// [`view_cone`]).
type Cone = ([f64; 3], f64, f64);

/// Whether `sphere` reaches into the solid `cone` with its apex at `eye` (always,
/// without a cone).
fn in_view(sphere: &Sphere, eye: [f64; 3], cone: Option<Cone>) -> bool {
    let Some((axis, cos, sin)) = cone else {
        return true;
    };
    let length = dist(sphere.center, eye);
    let along: f64 = (0..3).map(|k| (sphere.center[k] - eye[k]) * axis[k]).sum();
    let across = (length * length - along * along).max(0.0).sqrt();
    // Distance from the centre to the cone: to its apex from the polar region
    // behind it, else to its side (negative inside).
    let to_cone = if along * cos + across * sin < 0.0 {
        length
    } else {
        across * cos - along * sin
    };
    to_cone <= sphere.radius
}

/// Pixels covered by `error` on a sphere seen from `view` (the distance is to the
/// sphere's nearest point; a sphere holding the camera shows any error as
/// infinite), or 0 for a sphere wholly outside the view `cone`. Never smaller for a
/// larger error on a sphere that encloses this one, which keeps cuts crack-free.
fn projected(error: f64, sphere: &Sphere, view: &DagView, cone: Option<Cone>) -> f64 {
    if error.is_infinite() {
        return f64::INFINITY;
    }
    if !in_view(sphere, view.position, cone) {
        return 0.0;
    }
    let d = dist(sphere.center, view.position) - sphere.radius;
    if d <= 0.0 {
        return if error > 0.0 { f64::INFINITY } else { 0.0 };
    }
    view.screen.pixels(error, d)
}

impl Dag {
    /// The clusters a view draws: own projected error within the budget, parent's
    /// above it.
    #[must_use]
    pub fn cut(&self, view: &DagView) -> Vec<usize> {
        let p = view.screen.pixel_error;
        let cone = view_cone(view);
        (0..self.clusters.len())
            .filter(|&i| {
                let c = &self.clusters[i];
                projected(c.error, &c.sphere, view, cone) <= p
                    && projected(c.parent_error, &c.parent_sphere, view, cone) > p
            })
            .collect()
    }

    /// The clusters of `cut` that `view` can see: those whose own triangles'
    /// bounding sphere ([`Cluster::bounds`]) reaches into its view cone (all of
    /// them without a target). Frustum culling, as a renderer does after choosing
    /// the cut: the result has holes where nothing is in view, and is crack-free
    /// wherever something is.
    #[must_use]
    pub fn visible(&self, view: &DagView, cut: &[usize]) -> Vec<usize> {
        let Some(cone) = view_cone(view) else {
            return cut.to_vec();
        };
        cut.iter()
            .copied()
            .filter(|&c| {
                let bounds = self.clusters[c].bounds(&self.positions);
                in_view(&bounds, view.position, Some(cone))
            })
            .collect()
    }

    /// The mesh of a cut (its vertices compacted), with the hierarchy's
    /// attributes and groups.
    #[must_use]
    pub fn cut_mesh(&self, clusters: &[usize]) -> Mesh {
        let mut remap = vec![u32::MAX; self.positions.len()];
        let mut used: Vec<u32> = Vec::new();
        let mut triangles = Vec::new();
        let mut groups = Vec::new();
        for &c in clusters {
            let cl = &self.clusters[c];
            for t in &cl.triangles {
                triangles.push(t.map(|v| {
                    let r = &mut remap[v as usize];
                    if *r == u32::MAX {
                        *r = used.len() as u32;
                        used.push(v);
                    }
                    *r
                }));
            }
            groups.extend_from_slice(&cl.groups);
        }
        let mut mesh = Mesh::from_triangles(
            used.iter().map(|&v| self.positions[v as usize]).collect(),
            triangles,
        );
        mesh.attributes = self.attributes.gather(&used);
        if let Some(names) = &self.group_names {
            if groups.len() == mesh.triangles.len() {
                mesh.groups = Some(groups);
                mesh.group_names = names.clone();
            }
        }
        mesh
    }
}

/// Splits `tris` (indices into `positions`) into clusters of at most `size`
/// triangles, each with its triangles' `groups` (when there are: one per
/// triangle, else empty).
///
/// Clusters are grown over shared vertices, as meshlet builders grow theirs: a
/// cluster starts at the first free triangle in the Morton order of the
/// centroids and takes, one at a time, the free triangle with the most vertices
/// already in it (closing a notch before extending the border), the nearest to
/// its seed on a tie; when its part of the surface runs out it goes on from
/// the next free triangle in Morton order. Runs of the Morton order alone make
/// strips on a height field (the curve follows the contour lines, and at 10 bits
/// an axis many triangles share a key): on the 262,144-triangle terrain they
/// held 118 vertices per 128 triangles, against 92 for these (81 for a square).
fn split(
    positions: &[[f32; 3]],
    tris: &[[u32; 3]],
    groups: &[u32],
    size: usize,
    weld: bool,
) -> Vec<(Vec<[u32; 3]>, Vec<u32>)> {
    let n = tris.len();
    let size = size.max(1);
    let centroids: Vec<[f64; 3]> = tris
        .iter()
        .map(|t| {
            std::array::from_fn(|k| {
                t.iter()
                    .map(|&v| f64::from(positions[v as usize][k]))
                    .sum::<f64>()
                    / 3.0
            })
        })
        .collect();
    let keys = morton_keys(&centroids);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| (keys[i], i));
    // The triangles' vertices as local ids (a table over every position for the
    // input, which uses most of them; a sorted list searched for a group's few),
    // and the vertex of each local id.
    let (mut local, used): (Vec<[u32; 3]>, Vec<u32>) = if positions.len() <= 4 * n {
        let mut id = vec![u32::MAX; positions.len()];
        let mut used = Vec::new();
        let local = tris
            .iter()
            .map(|t| {
                t.map(|v| {
                    let slot = &mut id[v as usize];
                    if *slot == u32::MAX {
                        *slot = used.len() as u32;
                        used.push(v);
                    }
                    *slot
                })
            })
            .collect();
        (local, used)
    } else {
        let mut used: Vec<u32> = tris.iter().flatten().copied().collect();
        used.sort_unstable();
        used.dedup();
        let local = tris
            .iter()
            .map(|t| t.map(|v| used.binary_search(&v).unwrap_or(0) as u32))
            .collect();
        (local, used)
    };
    // With `weld` (attributes split vertices at seams) the local ids become
    // points, so that a cluster grows across seams.
    let nv = if weld {
        let w = Weld::exact(
            &used
                .iter()
                .map(|&v| positions[v as usize])
                .collect::<Vec<_>>(),
        );
        for t in &mut local {
            *t = t.map(|v| w.point_of[v as usize]);
        }
        w.representative.len()
    } else {
        used.len()
    };
    drop(used);
    let mut start = vec![0usize; nv + 1];
    for t in &local {
        for &v in t {
            start[v as usize + 1] += 1;
        }
    }
    for v in 0..nv {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut around = vec![0u32; 3 * n];
    for (t, corners) in local.iter().enumerate() {
        for &v in corners {
            around[fill[v as usize]] = t as u32;
            fill[v as usize] += 1;
        }
    }
    drop(fill);
    let mut grow = Grower {
        local: &local,
        centroids: &centroids,
        start: &start,
        around: &around,
        cluster_of: vec![FREE; n],
        vertex_in: vec![FREE; nv],
        queued: vec![FREE; n],
        inside: vec![0; n],
        valence_cap: 4 * size,
        id: 0,
        members: Vec::with_capacity(size),
        candidates: BinaryHeap::new(),
        origin: [0.0; 3],
    };
    let grouped = groups.len() == n;
    let mut out = Vec::with_capacity(n.div_ceil(size));
    let mut next = 0;
    while next < n {
        let seed = order[next];
        next += 1;
        if grow.cluster_of[seed] != FREE {
            continue;
        }
        grow.take(seed);
        while grow.members.len() < size {
            let t = match grow.best() {
                Some(u) => u,
                None => {
                    // This part of the surface is used up: on from the next
                    // free triangle in Morton order.
                    while next < n && grow.cluster_of[order[next]] != FREE {
                        next += 1;
                    }
                    if next == n {
                        break;
                    }
                    order[next]
                }
            };
            grow.take(t);
        }
        let members = std::mem::take(&mut grow.members);
        let g = if grouped {
            members.iter().map(|&t| groups[t]).collect()
        } else {
            Vec::new()
        };
        out.push((members.iter().map(|&t| tris[t]).collect(), g));
        grow.candidates.clear();
        grow.id += 1;
    }
    out
}

/// A free slot of [`Grower`]'s per-triangle and per-vertex marks.
const FREE: u32 = u32::MAX;

/// The state of [`split`]'s cluster growing: per triangle its cluster and
/// whether the current cluster queued it, per vertex the last cluster that
/// holds it; the current cluster's triangles, its candidates (a heap by
/// vertices inside, then distance to the seed) and its seed's centroid.
struct Grower<'a> {
    local: &'a [[u32; 3]],
    centroids: &'a [[f64; 3]],
    start: &'a [usize],
    around: &'a [u32],
    cluster_of: Vec<u32>,
    vertex_in: Vec<u32>,
    queued: Vec<u32>,
    /// Per queued triangle, its vertices already in the current cluster.
    inside: Vec<u8>,
    /// Vertices with more triangles than this are not expanded (fan apexes).
    valence_cap: usize,
    id: u32,
    members: Vec<usize>,
    candidates: BinaryHeap<(u8, Reverse<u64>, Reverse<usize>)>,
    origin: [f64; 3],
}

impl Grower<'_> {
    /// Puts triangle `t` in the current cluster and queues its free neighbours.
    fn take(&mut self, t: usize) {
        if self.members.is_empty() {
            self.origin = self.centroids[t];
        }
        self.cluster_of[t] = self.id;
        self.members.push(t);
        for &v in &self.local[t] {
            let v = v as usize;
            if self.vertex_in[v] == self.id {
                continue;
            }
            self.vertex_in[v] = self.id;
            // A fan's apex (a vertex of more triangles than a few clusters
            // hold) queues nothing: each cluster around it would scan its whole
            // fan, quadratic in its valence. Its triangles are reached through
            // their other vertices or the Morton order.
            if self.start[v + 1] - self.start[v] > self.valence_cap {
                continue;
            }
            for &u in &self.around[self.start[v]..self.start[v + 1]] {
                let u = u as usize;
                if self.cluster_of[u] != FREE {
                    continue;
                }
                if self.queued[u] != self.id {
                    self.queued[u] = self.id;
                    self.inside[u] = 0;
                }
                self.inside[u] += 1;
                // Squared distances are non-negative: their bits order as they do.
                let d: f64 = (0..3)
                    .map(|k| (self.centroids[u][k] - self.origin[k]).powi(2))
                    .sum();
                self.candidates
                    .push((self.inside[u], Reverse(d.to_bits()), Reverse(u)));
            }
        }
    }

    /// The free candidate with the most vertices in the cluster, the nearest to
    /// its seed on a tie (then the lower index). Entries are queued again as
    /// their count grows; older ones are skipped (lazy invalidation).
    fn best(&mut self) -> Option<usize> {
        while let Some((inside, _, Reverse(u))) = self.candidates.pop() {
            if self.cluster_of[u] == FREE && self.queued[u] == self.id && self.inside[u] == inside {
                return Some(u);
            }
        }
        None
    }
}

/// 30-bit Morton keys of `points` in their bounding box.
fn morton_keys(points: &[[f64; 3]]) -> Vec<u32> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let ext = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let scale = if ext > 0.0 { 1023.0 / ext } else { 0.0 };
    points
        .iter()
        .map(|p| {
            let q = |k: usize| ((p[k] - lo[k]) * scale).clamp(0.0, 1023.0) as u32;
            crate::radix::morton3(q(0), q(1), q(2))
        })
        .collect()
}

/// Builds the cluster hierarchy of `mesh`. Without attributes its positions are
/// welded exactly first; with attributes (normals, UVs, colours…) its vertices
/// are kept, so seams stay, and every level carries them (the simplifier solves
/// new vertices' values); triangle groups (materials) are carried too.
///
/// # Errors
/// [`SimplifyError`] when the mesh does not validate or an option is out of range
/// (a cluster or group size of 0 is [`SimplifyError::Option`]).
pub fn build_dag(mesh: &Mesh, options: &DagOptions) -> Result<(Dag, DagReport), SimplifyError> {
    let start = std::time::Instant::now();
    mesh.validate()?;
    for (name, v) in [
        ("cluster_size", options.cluster_size),
        ("group_size", options.group_size),
    ] {
        if v == 0 {
            return Err(SimplifyError::Option {
                name,
                message: "must be at least 1".into(),
            });
        }
    }
    let weld = Weld::exact(&mesh.positions);
    let keep_vertices = !mesh.attributes.is_empty();
    let mut dag = if keep_vertices {
        Dag {
            positions: mesh.positions.clone(),
            attributes: mesh.attributes.clone(),
            group_names: None,
            clusters: Vec::new(),
        }
    } else {
        Dag {
            positions: weld
                .representative
                .iter()
                .map(|&v| mesh.positions[v as usize])
                .collect(),
            ..Dag::default()
        }
    };
    // Triangles degenerate after welding go (the simplifier would drop them).
    let mut tris: Vec<[u32; 3]> = Vec::with_capacity(mesh.triangles.len());
    let mut groups: Vec<u32> = Vec::new();
    for (i, t) in mesh.triangles.iter().enumerate() {
        let w = t.map(|v| weld.point_of[v as usize]);
        if w[0] == w[1] || w[1] == w[2] || w[0] == w[2] {
            continue;
        }
        tris.push(if keep_vertices { *t } else { w });
        if let Some(g) = &mesh.groups {
            groups.push(g[i]);
        }
    }
    if mesh.groups.is_some() {
        let count = groups.iter().max().map_or(0, |&g| g as usize + 1);
        let mut names = mesh.group_names.clone();
        names.resize_with(names.len().max(count), String::new);
        dag.group_names = Some(names);
    }
    let mut report = DagReport {
        triangles: tris.len(),
        ..DagReport::default()
    };
    let mut open: Vec<usize> = Vec::new();
    let weld = !dag.attributes.is_empty();
    for (c, g) in split(&dag.positions, &tris, &groups, options.cluster_size, weld) {
        let sphere = Sphere::around(c.iter().flatten().map(|&v| dag.positions[v as usize]));
        open.push(dag.clusters.len());
        dag.clusters.push(Cluster {
            level: 0,
            triangles: c,
            groups: g,
            error: 0.0,
            sphere,
            parent_error: f64::INFINITY,
            parent_sphere: sphere,
        });
    }
    report.leaf_clusters = open.len();
    let mut level = 0u32;
    while open.len() > 1 {
        level += 1;
        let (next, simplified, stuck) = round(&mut dag, &open, options, level)?;
        report.stuck_groups += stuck;
        if simplified == 0 {
            break;
        }
        report.depth = level;
        open = next;
    }
    report.clusters = dag.clusters.len();
    let roots: Vec<&Cluster> = dag
        .clusters
        .iter()
        .filter(|c| c.parent_error.is_infinite())
        .collect();
    report.roots = roots.len();
    report.root_triangles = roots.iter().map(|c| c.triangles.len()).sum();
    report.seconds = start.elapsed().as_secs_f64();
    Ok((dag, report))
}

/// One round: groups the `open` clusters, simplifies each group; returns the next
/// round's open clusters, how many groups were simplified and how many were stuck.
fn round(
    dag: &mut Dag,
    open: &[usize],
    options: &DagOptions,
    level: u32,
) -> Result<(Vec<usize>, usize, usize), SimplifyError> {
    // Points (a position: with attributes, the vertices on either side of a
    // seam are one point) join clusters into groups, and the vertices of points
    // used by two or more groups are locked.
    let point_of: Option<Vec<u32>> =
        (!dag.attributes.is_empty()).then(|| Weld::exact(&dag.positions).point_of);
    let groups = group_clusters(dag, open, options.group_size, point_of.as_deref());
    let point = |v: u32| point_of.as_ref().map_or(v, |p| p[v as usize]) as usize;
    let mut owner = vec![u32::MAX; dag.positions.len()];
    let mut shared_point = vec![false; dag.positions.len()];
    for (g, members) in groups.iter().enumerate() {
        for &c in members {
            for &v in dag.clusters[c].triangles.iter().flatten() {
                let o = &mut owner[point(v)];
                if *o == u32::MAX {
                    *o = g as u32;
                } else if *o != g as u32 {
                    shared_point[point(v)] = true;
                }
            }
        }
    }
    let shared: Vec<bool> = (0..dag.positions.len() as u32)
        .map(|v| shared_point[point(v)])
        .collect();
    drop(shared_point);
    // The groups are simplified in parallel (each on one thread), then their
    // results applied in group order, so the hierarchy is the same on any number
    // of threads.
    use rayon::prelude::*;
    let results: Vec<Result<Option<Simplified>, SimplifyError>> = groups
        .par_iter()
        .map(|members| simplify_group(dag, members, &shared, options))
        .collect();
    let mut next = Vec::new();
    let (mut simplified, mut stuck) = (0, 0);
    for (members, result) in groups.iter().zip(results) {
        match result? {
            Some(group) => {
                simplified += 1;
                next.extend(apply_group(dag, members, group, options, level));
            }
            None => {
                stuck += 1;
                next.extend(members);
            }
        }
    }
    Ok((next, simplified, stuck))
}

/// Puts the `open` clusters into groups of about `size` (at most a third more),
/// so that groups are compact and the vertices they share, which their
/// simplification must lock, are few.
///
/// Agglomerative clustering with a heap (Kurita, "An efficient agglomerative
/// clustering algorithm using a heap", Pattern Recognition 24(3), 1991), as
/// meshoptimizer's cluster partitioner also does: every cluster starts as a
/// group; the smallest group still below `size` merges into the neighbour that
/// shares the most vertices with it relative to both groups' expected borders
/// (`shared · (1/√v₁ + 1/√v₂)`, `v` a group's vertices: a border grows as the
/// square root of a patch's area) and leaves the merged group at most a third
/// above `size`; a group with no such neighbour is done. Groups left small
/// because no cluster shares a vertex with them (separate parts) are then joined
/// along the Morton order of their centres. Ties go to the lower Morton rank, so
/// the grouping is deterministic. On the 1M-triangle terrain this locked 30% of
/// the first round's group vertices against 33% for groups grown one cluster at
/// a time from Morton-ordered seeds, and 35–44% in later rounds against 42–60%.
fn group_clusters(
    dag: &Dag,
    open: &[usize],
    size: usize,
    point_of: Option<&[u32]>,
) -> Vec<Vec<usize>> {
    let centers: Vec<[f64; 3]> = open
        .iter()
        .map(|&c| dag.clusters[c].sphere.center)
        .collect();
    let keys = morton_keys(&centers);
    let mut order: Vec<usize> = (0..open.len()).collect();
    order.sort_by_key(|&i| (keys[i], i));
    // (vertex, open-cluster slot) pairs, sorted: the clusters sharing each vertex.
    let mut uses: Vec<(u32, u32)> = Vec::new();
    let mut vertices: Vec<f64> = vec![0.0; open.len()];
    for (i, &c) in open.iter().enumerate() {
        let mut vs: Vec<u32> = dag.clusters[c]
            .triangles
            .iter()
            .flatten()
            .map(|&v| point_of.map_or(v, |p| p[v as usize]))
            .collect();
        vs.sort_unstable();
        vs.dedup();
        vertices[i] = vs.len() as f64;
        uses.extend(vs.into_iter().map(|v| (v, i as u32)));
    }
    uses.sort_unstable();
    // Cluster adjacency with shared-vertex counts.
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    for run in uses.chunk_by(|a, b| a.0 == b.0) {
        for (k, a) in run.iter().enumerate() {
            for b in &run[k + 1..] {
                pairs.push((a.1, b.1));
                pairs.push((b.1, a.1));
            }
        }
    }
    pairs.sort_unstable();
    let mut adjacency: Vec<Vec<(u32, u32)>> = vec![Vec::new(); open.len()];
    for run in pairs.chunk_by(|a, b| a == b) {
        adjacency[run[0].0 as usize].push((run[0].1, run.len() as u32));
    }
    let n = open.len();
    let mut rank = vec![0usize; n];
    for (r, &i) in order.iter().enumerate() {
        rank[i] = r;
    }
    let most = size + size / 3;
    // Per slot: its group (a slot id), and per group its members, its vertex
    // count (the members' sum: shared vertices count twice, an estimate) and its
    // lowest Morton rank.
    let mut group: Vec<usize> = (0..n).collect();
    let mut members: Vec<Vec<usize>> = (0..n).map(|i| vec![i]).collect();
    let mut first: Vec<usize> = rank.clone();
    let mut done = vec![false; n];
    let mut heap: BinaryHeap<Reverse<(usize, usize, usize)>> =
        (0..n).map(|g| Reverse((1, rank[g], g))).collect();
    let mut shared: Vec<u32> = vec![0; n];
    let mut finished: Vec<usize> = Vec::new();
    let mut stranded: Vec<usize> = Vec::new();
    while let Some(Reverse((len, _, g))) = heap.pop() {
        // Lazy invalidation: a group merged away, or grown since it was queued.
        if done[g] || members[g].len() != len {
            continue;
        }
        if len >= size {
            done[g] = true;
            finished.push(g);
            continue;
        }
        let mut touched: Vec<usize> = Vec::new();
        let mut alone = true;
        for &c in &members[g] {
            for &(nb, w) in &adjacency[c] {
                let h = group[nb as usize];
                alone &= h == g;
                if h == g || done[h] {
                    continue;
                }
                if shared[h] == 0 {
                    touched.push(h);
                }
                shared[h] += w;
            }
        }
        let mut best: Option<(f64, usize, usize)> = None;
        for &h in &touched {
            let w = f64::from(shared[h]);
            shared[h] = 0;
            if len + members[h].len() > most {
                continue;
            }
            let score = w * (vertices[g].sqrt().recip() + vertices[h].sqrt().recip());
            let better = match best {
                None => true,
                Some((s, r, _)) => score > s || (score == s && first[h] < r),
            };
            if better {
                best = Some((score, first[h], h));
            }
        }
        let Some((_, _, h)) = best else {
            done[g] = true;
            if alone {
                stranded.push(g);
            } else {
                finished.push(g);
            }
            continue;
        };
        let moved = std::mem::take(&mut members[g]);
        for &c in &moved {
            group[c] = h;
        }
        members[h].extend(moved);
        vertices[h] += vertices[g];
        first[h] = first[h].min(first[g]);
        done[g] = true;
        heap.push(Reverse((members[h].len(), first[h], h)));
    }
    // Separate parts: joined in Morton order, up to `size` clusters a group.
    stranded.sort_by_key(|&g| first[g]);
    let mut joined: Vec<usize> = Vec::new();
    for g in stranded {
        match joined.last().copied() {
            Some(j) if members[j].len() + members[g].len() <= size => {
                let moved = std::mem::take(&mut members[g]);
                members[j].extend(moved);
            }
            _ => joined.push(g),
        }
    }
    finished.extend(joined);
    let mut groups: Vec<Vec<usize>> = finished
        .into_iter()
        .map(|g| {
            let mut m = std::mem::take(&mut members[g]);
            m.sort_by_key(|&i| rank[i]);
            m
        })
        .collect();
    groups.sort_by_key(|m| rank[m[0]]);
    groups
        .into_iter()
        .map(|m| m.into_iter().map(|i| open[i]).collect())
        .collect()
}

/// A simplified group: its vertices (ids into [`Dag::positions`]) and the
/// simplifier's result over them.
struct Simplified {
    globals: Vec<u32>,
    result: crate::simplify::Simplified,
}

/// Simplifies the group `members` to half its triangles with the `shared` vertices
/// locked; `None` when it cannot reach three quarters (a stuck group).
fn simplify_group(
    dag: &Dag,
    members: &[usize],
    shared: &[bool],
    options: &DagOptions,
) -> Result<Option<Simplified>, SimplifyError> {
    let mut globals: Vec<u32> = members
        .iter()
        .flat_map(|&c| dag.clusters[c].triangles.iter().flatten().copied())
        .collect();
    globals.sort_unstable();
    globals.dedup();
    let local = |v: u32| globals.binary_search(&v).unwrap_or(0) as u32;
    let triangles: Vec<[u32; 3]> = members
        .iter()
        .flat_map(|&c| dag.clusters[c].triangles.iter().map(|t| t.map(local)))
        .collect();
    let n = triangles.len();
    if n < 4 {
        return Ok(None);
    }
    let mut group = Mesh::from_triangles(
        globals.iter().map(|&v| dag.positions[v as usize]).collect(),
        triangles,
    );
    group.attributes = dag.attributes.gather(&globals);
    if let Some(names) = &dag.group_names {
        group.groups = Some(
            members
                .iter()
                .flat_map(|&c| dag.clusters[c].groups.iter().copied())
                .collect(),
        );
        group.group_names = names.clone();
    }
    let locked: Vec<bool> = globals.iter().map(|&v| shared[v as usize]).collect();
    let mut o = options.simplify.clone();
    o.ratio = None;
    o.max_error = None;
    o.target_triangles = Some(n / 2);
    o.locked_vertices = Some(locked);
    o.chunks = false;
    o.threads = Some(1);
    // A vertex keeps its id only with its values unchanged (`apply_group`).
    o.refit_attributes = false;
    let mut result = simplify_observed(&group, &o, &mut NoObserver)?;
    let seams = !group.attributes.is_empty() || group.groups.is_some();
    if result.mesh.triangles.len() * 4 > n * 3 && seams && !o.permissive && !o.strict_seams {
        // Seams (UV, normal creases, materials) can leave a group no legal
        // collapse that keeps them, or only dear ones: then crossings cost what
        // their attribute terms say, without the last-resort penalty, and skin
        // joints may merge.
        o.permissive = true;
        result = simplify_observed(&group, &o, &mut NoObserver)?;
    }
    if result.mesh.triangles.len() * 4 > n * 3 {
        return Ok(None);
    }
    Ok(Some(Simplified { globals, result }))
}

/// Adds the simplified `group` of `members` to the hierarchy: new positions for
/// the vertices that moved, the members' parent error and sphere, and the group's
/// new clusters (returned).
fn apply_group(
    dag: &mut Dag,
    members: &[usize],
    group: Simplified,
    options: &DagOptions,
    level: u32,
) -> Vec<usize> {
    let Simplified { globals, result: s } = group;
    // Back to shared vertices: a vertex still where its source was, with the same
    // attributes, keeps its id (every locked vertex does), a changed one is new.
    let mut fresh: Vec<u32> = Vec::new();
    let ids: Vec<u32> = (0..s.mesh.positions.len())
        .map(|i| {
            let g = globals[s.vertex_source[i] as usize];
            let same = dag.positions[g as usize] == s.mesh.positions[i]
                && dag
                    .attributes
                    .same_values(g as usize, &s.mesh.attributes, i, true);
            if same {
                g
            } else {
                fresh.push(i as u32);
                (dag.positions.len() + fresh.len() - 1) as u32
            }
        })
        .collect();
    let n_before = dag.positions.len();
    dag.positions
        .extend(fresh.iter().map(|&i| s.mesh.positions[i as usize]));
    dag.attributes
        .append(n_before, &s.mesh.attributes.gather(&fresh), fresh.len());
    let tris: Vec<[u32; 3]> = s
        .mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| ids[v as usize]))
        .collect();
    let tri_groups: Vec<u32> = if dag.group_names.is_some() {
        s.mesh.groups.clone().unwrap_or_else(|| vec![0; tris.len()])
    } else {
        Vec::new()
    };
    let child_error = members
        .iter()
        .map(|&c| dag.clusters[c].error)
        .fold(0.0, f64::max);
    let error = child_error + s.report.error_absolute;
    let spheres: Vec<Sphere> = members.iter().map(|&c| dag.clusters[c].sphere).collect();
    let sphere = Sphere::enclosing(&spheres);
    for &c in members {
        dag.clusters[c].parent_error = error;
        dag.clusters[c].parent_sphere = sphere;
    }
    let mut made = Vec::new();
    let weld = !dag.attributes.is_empty();
    for (c, g) in split(
        &dag.positions,
        &tris,
        &tri_groups,
        options.cluster_size,
        weld,
    ) {
        made.push(dag.clusters.len());
        dag.clusters.push(Cluster {
            level,
            triangles: c,
            groups: g,
            error,
            sphere,
            parent_error: f64::INFINITY,
            parent_sphere: sphere,
        });
    }
    made
}

/// The first bytes of a `.mdag` file.
pub const MDAG_MAGIC: &[u8; 12] = b"MESHLOD-DAG\0";
/// The `.mdag` format version this build writes for a hierarchy with attributes
/// or groups (it writes [`MDAG_VERSION_PLAIN`] for one without, and reads both).
pub const MDAG_VERSION: u32 = 2;
/// The `.mdag` format version of a hierarchy with neither attributes nor groups.
pub const MDAG_VERSION_PLAIN: u32 = 1;

/// Bits of the attribute mask of a version-2 file, in stream order: normals,
/// tangents, UV set 0, UV set 1, colours, joints, weights.
const ATTRIBUTE_BITS: u32 = 0x7f;

/// A malformed `.mdag` file: where and what.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("byte {offset}: {message}")]
pub struct MdagError {
    /// Byte offset of the problem.
    pub offset: u64,
    /// What is wrong.
    pub message: String,
}

/// Serialises `dag` as a `.mdag` file (little-endian):
///
/// | bytes | content |
/// |---|---|
/// | 12 | [`MDAG_MAGIC`] |
/// | 4 | version `u32`: [`MDAG_VERSION_PLAIN`] (1) without attributes and groups, else [`MDAG_VERSION`] (2) |
/// | 8, 8 | position count `u64`, cluster count `u64` |
/// | 12 per position | `f32` x, y, z |
/// | version 2 only | attribute mask `u32` (bit 0 normals, 1 tangents, 2 UV set 0, 3 UV set 1, 4 colours, 5 joints, 6 weights), then each present stream for every vertex: normals `3 × f32`, tangents `4 × f32`, UVs `2 × f32`, colours `4 × f32`, joints `4 × u16`, weights `4 × f32`; then group-name count plus one `u32` (0: no groups), and per name its byte length `u32` and UTF-8 bytes |
/// | per cluster | level `u32`, triangle count `u32`, error `f64`, sphere (centre `3 × f64`, radius `f64`), parent error `f64` (infinite for a root), parent sphere (`4 × f64`), then `3 × u32` per triangle; version 2 with groups: then a group id `u32` per triangle |
#[must_use]
pub fn write_mdag(dag: &Dag) -> Vec<u8> {
    let plain = dag.attributes.is_empty() && dag.group_names.is_none();
    let mut out = Vec::new();
    out.extend_from_slice(MDAG_MAGIC);
    let version = if plain {
        MDAG_VERSION_PLAIN
    } else {
        MDAG_VERSION
    };
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(dag.positions.len() as u64).to_le_bytes());
    out.extend_from_slice(&(dag.clusters.len() as u64).to_le_bytes());
    for x in dag.positions.iter().flatten() {
        out.extend_from_slice(&x.to_le_bytes());
    }
    if !plain {
        write_attributes(&mut out, &dag.attributes);
        match &dag.group_names {
            None => out.extend_from_slice(&0u32.to_le_bytes()),
            Some(names) => {
                out.extend_from_slice(&(names.len() as u32 + 1).to_le_bytes());
                for n in names {
                    out.extend_from_slice(&(n.len() as u32).to_le_bytes());
                    out.extend_from_slice(n.as_bytes());
                }
            }
        }
    }
    for c in &dag.clusters {
        out.extend_from_slice(&c.level.to_le_bytes());
        out.extend_from_slice(&(c.triangles.len() as u32).to_le_bytes());
        for x in [c.error]
            .into_iter()
            .chain(c.sphere.center)
            .chain([c.sphere.radius, c.parent_error])
            .chain(c.parent_sphere.center)
            .chain([c.parent_sphere.radius])
        {
            out.extend_from_slice(&x.to_le_bytes());
        }
        for v in c.triangles.iter().flatten() {
            out.extend_from_slice(&v.to_le_bytes());
        }
        if dag.group_names.is_some() {
            for i in 0..c.triangles.len() {
                let g = c.groups.get(i).copied().unwrap_or(0);
                out.extend_from_slice(&g.to_le_bytes());
            }
        }
    }
    out
}

/// The attribute mask and streams of a version-2 file.
fn write_attributes(out: &mut Vec<u8>, a: &VertexAttributes) {
    fn floats<const N: usize>(out: &mut Vec<u8>, s: &[[f32; N]]) {
        for x in s.iter().flatten() {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    let present = [
        a.normals.is_some(),
        a.tangents.is_some(),
        a.uv0.is_some(),
        a.uv1.is_some(),
        a.colors.is_some(),
        a.joints.is_some(),
        a.weights.is_some(),
    ];
    let mask = present
        .iter()
        .enumerate()
        .fold(0u32, |m, (i, &p)| m | (u32::from(p) << i));
    out.extend_from_slice(&mask.to_le_bytes());
    if let Some(s) = &a.normals {
        floats(out, s);
    }
    if let Some(s) = &a.tangents {
        floats(out, s);
    }
    if let Some(s) = &a.uv0 {
        floats(out, s);
    }
    if let Some(s) = &a.uv1 {
        floats(out, s);
    }
    if let Some(s) = &a.colors {
        floats(out, s);
    }
    if let Some(s) = &a.joints {
        for x in s.iter().flatten() {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    if let Some(s) = &a.weights {
        floats(out, s);
    }
}

/// Reads the attribute mask and streams of a version-2 file for `np` vertices.
fn read_attributes(b: &mut Bytes<'_>, np: usize) -> Result<VertexAttributes, MdagError> {
    fn floats<const N: usize>(
        b: &mut Bytes<'_>,
        np: usize,
        what: &str,
    ) -> Result<Vec<[f32; N]>, MdagError> {
        if (np as u64) * (4 * N as u64) > b.left() as u64 {
            return Err(b.err(format!("{np} {what} values do not fit in the file")));
        }
        // Attribute values are taken as written (the input's own, whatever they
        // are): unlike positions and spheres, no step of a cut depends on them.
        let mut v = Vec::with_capacity(np);
        for _ in 0..np {
            let mut x = [0f32; N];
            for c in &mut x {
                *c = f32::from_le_bytes(b.take::<4>(what)?);
            }
            v.push(x);
        }
        Ok(v)
    }
    let at = b.at;
    let mask = b.u32("attribute mask")?;
    if mask & !ATTRIBUTE_BITS != 0 {
        return Err(MdagError {
            offset: at as u64,
            message: format!("attribute mask {mask:#x} has unknown bits"),
        });
    }
    let has = |bit: u32| mask & (1 << bit) != 0;
    let mut a = VertexAttributes::default();
    if has(0) {
        a.normals = Some(floats(b, np, "normal")?);
    }
    if has(1) {
        a.tangents = Some(floats(b, np, "tangent")?);
    }
    if has(2) {
        a.uv0 = Some(floats(b, np, "UV")?);
    }
    if has(3) {
        a.uv1 = Some(floats(b, np, "UV (set 1)")?);
    }
    if has(4) {
        a.colors = Some(floats(b, np, "colour")?);
    }
    if has(5) {
        if (np as u64) * 8 > b.left() as u64 {
            return Err(b.err(format!("{np} joint values do not fit in the file")));
        }
        let mut v = Vec::with_capacity(np);
        for _ in 0..np {
            let mut x = [0u16; 4];
            for c in &mut x {
                *c = u16::from_le_bytes(b.take::<2>("joints")?);
            }
            v.push(x);
        }
        a.joints = Some(v);
    }
    if has(6) {
        a.weights = Some(floats(b, np, "weight")?);
    }
    Ok(a)
}

/// Reads the group names of a version-2 file (`None`: no groups).
fn read_group_names(b: &mut Bytes<'_>) -> Result<Option<Vec<String>>, MdagError> {
    let count = b.u32("group-name count")?;
    if count == 0 {
        return Ok(None);
    }
    let count = count - 1;
    if u64::from(count) * 4 > b.left() as u64 {
        return Err(b.err(format!("{count} group names do not fit in the file")));
    }
    let mut names = Vec::with_capacity(count as usize);
    for _ in 0..count {
        let len = b.u32("group-name length")? as usize;
        if len > b.left() {
            return Err(b.err(format!(
                "a group name of {len} bytes does not fit in the file"
            )));
        }
        let at = b.at;
        let bytes = &b.data[b.at..b.at + len];
        b.at += len;
        let name = std::str::from_utf8(bytes).map_err(|_| MdagError {
            offset: at as u64,
            message: "group name is not UTF-8".into(),
        })?;
        names.push(name.to_owned());
    }
    Ok(Some(names))
}

/// A little-endian reader over a byte slice that knows its offset.
struct Bytes<'a> {
    data: &'a [u8],
    at: usize,
}

impl Bytes<'_> {
    fn err(&self, message: impl Into<String>) -> MdagError {
        MdagError {
            offset: self.at as u64,
            message: message.into(),
        }
    }

    fn take<const N: usize>(&mut self, what: &str) -> Result<[u8; N], MdagError> {
        let end = self.at.checked_add(N).filter(|&e| e <= self.data.len());
        let Some(end) = end else {
            return Err(self.err(format!("truncated: {what} missing")));
        };
        let mut b = [0u8; N];
        b.copy_from_slice(&self.data[self.at..end]);
        self.at = end;
        Ok(b)
    }

    fn u32(&mut self, what: &str) -> Result<u32, MdagError> {
        self.take::<4>(what).map(u32::from_le_bytes)
    }

    fn u64(&mut self, what: &str) -> Result<u64, MdagError> {
        self.take::<8>(what).map(u64::from_le_bytes)
    }

    fn f64(&mut self, what: &str) -> Result<f64, MdagError> {
        self.take::<8>(what).map(f64::from_le_bytes)
    }

    fn left(&self) -> usize {
        self.data.len() - self.at
    }

    fn sphere(&mut self, what: &str) -> Result<Sphere, MdagError> {
        let at = self.at;
        let center = [self.f64(what)?, self.f64(what)?, self.f64(what)?];
        let radius = self.f64(what)?;
        if !(center.iter().all(|x| x.is_finite()) && radius.is_finite() && radius >= 0.0) {
            return Err(MdagError {
                offset: at as u64,
                message: format!("{what} is not a finite sphere"),
            });
        }
        Ok(Sphere { center, radius })
    }
}

/// Reads a `.mdag` file written by [`write_mdag`].
///
/// # Errors
/// [`MdagError`] with the byte offset: wrong magic or version, counts the file
/// cannot hold, truncation, non-finite positions or spheres, negative or NaN
/// errors, indices out of range, degenerate triangles, trailing bytes.
pub fn read_mdag(data: &[u8]) -> Result<Dag, MdagError> {
    let mut b = Bytes { data, at: 0 };
    if b.take::<12>("magic")? != *MDAG_MAGIC {
        return Err(MdagError {
            offset: 0,
            message: "not a meshlod .mdag file (wrong magic)".into(),
        });
    }
    let version = b.u32("version")?;
    if version != MDAG_VERSION && version != MDAG_VERSION_PLAIN {
        return Err(b.err(format!(
            "version {version}; this build reads versions {MDAG_VERSION_PLAIN} and {MDAG_VERSION}"
        )));
    }
    let np = b.u64("position count")?;
    let nc = b.u64("cluster count")?;
    if np > (b.left() / 12) as u64 || np > u64::from(u32::MAX) {
        return Err(b.err(format!("{np} positions do not fit in the file")));
    }
    if nc > (b.left() / 88) as u64 {
        return Err(b.err(format!("{nc} clusters do not fit in the file")));
    }
    let mut positions = Vec::with_capacity(np as usize);
    for _ in 0..np {
        let at = b.at;
        let p = b.take::<12>("position")?;
        let x = |k: usize| f32::from_le_bytes([p[4 * k], p[4 * k + 1], p[4 * k + 2], p[4 * k + 3]]);
        let p = [x(0), x(1), x(2)];
        if !p.iter().all(|v| v.is_finite()) {
            return Err(MdagError {
                offset: at as u64,
                message: "position is not finite".into(),
            });
        }
        positions.push(p);
    }
    let (attributes, group_names) = if version == MDAG_VERSION {
        let a = read_attributes(&mut b, np as usize)?;
        (a, read_group_names(&mut b)?)
    } else {
        (VertexAttributes::default(), None)
    };
    let groups = group_names.as_ref().map(Vec::len);
    let mut clusters = Vec::with_capacity(nc as usize);
    for _ in 0..nc {
        clusters.push(read_cluster(&mut b, np, groups)?);
    }
    if b.left() != 0 {
        return Err(b.err(format!("{} bytes after the last cluster", b.left())));
    }
    Ok(Dag {
        positions,
        attributes,
        group_names,
        clusters,
    })
}

/// One cluster; `groups`: the number of group names when the file has groups.
fn read_cluster(b: &mut Bytes<'_>, np: u64, groups: Option<usize>) -> Result<Cluster, MdagError> {
    let level = b.u32("cluster level")?;
    let nt = b.u32("triangle count")?;
    let at = b.at;
    let error = b.f64("error")?;
    if !(error.is_finite() && error >= 0.0) {
        return Err(MdagError {
            offset: at as u64,
            message: format!("cluster error {error} is not a finite distance"),
        });
    }
    let sphere = b.sphere("cluster sphere")?;
    let at = b.at;
    let parent_error = b.f64("parent error")?;
    if parent_error.is_nan() || parent_error < error {
        return Err(MdagError {
            offset: at as u64,
            message: format!("parent error {parent_error} is below the cluster's {error}"),
        });
    }
    let parent_sphere = b.sphere("parent sphere")?;
    if u64::from(nt) * 12 > b.left() as u64 {
        return Err(b.err(format!("{nt} triangles do not fit in the file")));
    }
    let mut triangles = Vec::with_capacity(nt as usize);
    for _ in 0..nt {
        let at = b.at;
        let t = [b.u32("index")?, b.u32("index")?, b.u32("index")?];
        if t.iter().any(|&v| u64::from(v) >= np) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            return Err(MdagError {
                offset: at as u64,
                message: format!("triangle {t:?} is out of range ({np} positions) or degenerate"),
            });
        }
        triangles.push(t);
    }
    let mut tri_groups = Vec::new();
    if let Some(count) = groups {
        if u64::from(nt) * 4 > b.left() as u64 {
            return Err(b.err(format!("{nt} group ids do not fit in the file")));
        }
        for _ in 0..nt {
            let at = b.at;
            let g = b.u32("group id")?;
            if g as usize >= count {
                return Err(MdagError {
                    offset: at as u64,
                    message: format!("group id {g} is out of range ({count} groups)"),
                });
            }
            tri_groups.push(g);
        }
    }
    Ok(Cluster {
        level,
        triangles,
        groups: tri_groups,
        error,
        sphere,
        parent_error,
        parent_sphere,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    /// A fan of 20,000 triangles around one apex (an n-gon fanned from a
    /// corner): the apex is not expanded, so the split stays linear, and every
    /// triangle lands in exactly one cluster of at most 128.
    #[test]
    fn a_fan_is_split_without_scanning_its_apex() {
        let k = 20_000u32;
        let mut positions = vec![[0.0f32, 0.0, 0.0]];
        for i in 0..=k {
            let a = f64::from(i) / f64::from(k) * 6.0;
            positions.push([a.cos() as f32, a.sin() as f32, 0.0]);
        }
        let tris: Vec<[u32; 3]> = (1..=k).map(|i| [0, i, i + 1]).collect();
        let parts = split(&positions, &tris, &[], 128, false);
        let mut seen = vec![0u8; tris.len()];
        for (c, _) in &parts {
            assert!(!c.is_empty() && c.len() <= 128);
            for t in c {
                seen[(t[1] - 1) as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&x| x == 1));
        assert_eq!(parts.len(), (k as usize).div_ceil(128));
    }

    /// A hilly ramp (64 × 64 cells, 8,192 triangles): the clusters take every
    /// triangle once, at most 128 each, and are compact (a square patch of 128
    /// triangles has 81 vertices; runs of the Morton order follow the ramp's
    /// contour lines and hold more).
    ///
    /// ```text
    ///   z ↑     _/‾\_/‾‾
    ///       _/‾             z = 0.8 x + 0.3 sin 9x cos 7y
    /// ```
    #[test]
    fn clusters_are_compact_and_take_every_triangle_once() {
        let mesh = generate::grid(64, 64, |x, y| {
            0.8 * x + 0.3 * (9.0 * x).sin() * (7.0 * y).cos()
        });
        let parts = split(&mesh.positions, &mesh.triangles, &[], 128, false);
        let mut seen = vec![0; mesh.triangles.len()];
        let index: std::collections::HashMap<[u32; 3], usize> = mesh
            .triangles
            .iter()
            .enumerate()
            .map(|(i, &t)| (t, i))
            .collect();
        let (mut vertices, mut pieces) = (0, 0);
        for (tris, groups) in &parts {
            assert!(groups.is_empty());
            assert!(!tris.is_empty() && tris.len() <= 128);
            for t in tris {
                seen[index[t]] += 1;
            }
            let mut vs: Vec<u32> = tris.iter().flatten().copied().collect();
            vs.sort_unstable();
            vs.dedup();
            vertices += vs.len();
            // Its pieces (over shared vertices).
            let mut reached = vec![false; tris.len()];
            for first in 0..tris.len() {
                if reached[first] {
                    continue;
                }
                pieces += 1;
                reached[first] = true;
                let mut stack = vec![first];
                while let Some(a) = stack.pop() {
                    for b in 0..tris.len() {
                        if !reached[b] && tris[a].iter().any(|v| tris[b].contains(v)) {
                            reached[b] = true;
                            stack.push(b);
                        }
                    }
                }
            }
        }
        assert!(
            seen.iter().all(|&k| k == 1),
            "a triangle not used exactly once"
        );
        assert_eq!(parts.len(), 64);
        let per = vertices as f64 / parts.len() as f64;
        // Runs of the Morton order hold 95.8 here.
        assert!(per < 90.0, "{per} vertices per cluster");
        // A cluster whose part of the surface runs out goes on elsewhere.
        assert!(pieces <= 2 * parts.len(), "{pieces} pieces");
    }
}
