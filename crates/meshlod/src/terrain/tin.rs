//! Greedy insertion of height-field samples into a Delaunay triangulation: a
//! triangulated irregular network (TIN) within a vertical error bound.
//!
//! The method is Garland & Heckbert, *Fast Polygonal Approximation of Terrains and
//! Height Fields* (CMU-CS-95-181, 1995), algorithm III with Delaunay updates:
//!
//! 1. start from the two triangles spanning the corners of the region (plus any seed
//!    points, inserted first: the tile borders of [`super::tiles`]);
//! 2. each triangle keeps its *candidate*: the grid sample it covers with the largest
//!    vertical distance to the triangle's plane, found by rasterising the triangle over
//!    the grid (a scanline per row, the row's span solved exactly in integers, the
//!    plane evaluated incrementally along the row in `f64`);
//! 3. a max-heap holds `(error, triangle)`; the worst candidate is inserted (splitting
//!    its triangle in three, or the two triangles beside an edge in four when the
//!    sample lies on that edge), the edges opposite the new vertex are made locally
//!    Delaunay by Lawson flips (Lawson 1977; de Berg et al., *Computational Geometry*,
//!    ch. 9), and only the triangles created or changed are rescanned;
//! 4. stop when the worst candidate is within the bound (or a triangle budget is met).
//!
//! The heap is indexed (each triangle knows its place), so a rescanned triangle moves
//! in place and the heap holds only live triangles with an error. Each insertion
//! rescans the area of the triangles it changed, so the cost is about
//! `O((m + n) log m)` for `n` samples and `m` inserted points, as in the paper.
//!
//! All geometric predicates (orientation, in-circle) are exact: vertices are grid
//! samples with integer coordinates, evaluated in `i64`/`i128`. Ties break by
//! triangle number, so the output is deterministic.
//!
//! Storage is compact arrays indexed by `u32`: three vertex ids and three twin
//! half-edges per triangle, the candidate sample and its error (rounded *up* to `f32`,
//! so stopping at `error ≤ E` never under-reports), and the heap's `u32` entries and
//! positions.

/// No twin (a border edge) / no candidate.
const NONE: u32 = u32::MAX;

/// Options for [`build_tin`].
#[derive(Debug, Clone, PartialEq)]
pub struct TinOptions {
    /// Largest vertical distance, in height units, between any grid sample and the
    /// TIN. Insertion stops once every sample is within it. Default 1.
    pub max_error: f64,
    /// Stop once the TIN has at least this many triangles (whichever of this and
    /// [`Self::max_error`] comes first). Default: no limit.
    pub max_triangles: Option<usize>,
    /// After the insertion, remove inserted vertices whose removal keeps every sample
    /// within [`Self::max_error`] (see [`build_tin`]). Ignored with a triangle
    /// budget. Default true.
    pub prune: bool,
}

impl Default for TinOptions {
    fn default() -> Self {
        Self {
            max_error: 1.0,
            max_triangles: None,
            prune: true,
        }
    }
}

/// A rectangle of grid samples, inclusive: columns `x0..=x1`, rows `y0..=y1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// Last column (inclusive).
    pub x1: u32,
    /// Last row (inclusive).
    pub y1: u32,
}

/// A triangulated irregular network over a grid: vertices are grid samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Tin {
    /// Vertex positions as grid `(column, row)`.
    pub points: Vec<[u32; 2]>,
    /// Triangles as three indices into [`Self::points`], counter-clockwise in
    /// `(column, row)` coordinates (positive orientation).
    pub triangles: Vec<[u32; 3]>,
    /// Largest candidate error left when insertion stopped, in height units (an upper
    /// bound of the true maximum, rounded up to `f32`).
    pub max_error: f64,
}

/// Errors from [`build_tin`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TinError {
    /// The region is smaller than 2 × 2 samples or outside the grid.
    #[error(
        "the region {0:?} is not a rectangle of at least 2 x 2 samples inside the {1} x {2} grid"
    )]
    BadRegion(Region, usize, usize),
    /// The grid holds a NaN or infinite height.
    #[error("the height grid holds a non-finite height at sample {0}")]
    NonFinite(usize),
    /// The error bound is negative or NaN.
    #[error("the error bound {0} is not a non-negative number")]
    BadBound(f64),
    /// Too many samples for 32-bit vertex ids.
    #[error("the grid has {0} samples, more than meshlod's 2^31 limit")]
    TooLarge(usize),
}

/// Progress callback: `(triangles, current worst error)`, called every few thousand
/// insertions.
pub type ProgressFn<'a> = &'a mut dyn FnMut(usize, f64);

/// Builds a TIN of the `width × height` row-major grid `heights` (height units)
/// within `options`, by greedy insertion with Delaunay updates (see the module docs).
///
/// # Errors
/// [`TinError`] when the grid is smaller than 2 × 2, holds a non-finite height, or
/// the bound is negative.
pub fn build_tin(
    heights: &[f32],
    width: usize,
    height: usize,
    options: &TinOptions,
) -> Result<Tin, TinError> {
    let full = Region {
        x0: 0,
        y0: 0,
        x1: width.saturating_sub(1) as u32,
        y1: height.saturating_sub(1) as u32,
    };
    let seeding = Seeding {
        region: full,
        seeds: &[],
        frozen_border: false,
    };
    build_tin_region(heights, width, height, seeding, options, None)
}

/// Where [`build_tin_region`] works: a rectangle of the grid, the points inserted
/// before the greedy insertion, and whether the rectangle's border is frozen.
#[derive(Debug, Clone, Copy)]
pub struct Seeding<'s> {
    /// The rectangle triangulated (its four corners are always vertices).
    pub region: Region,
    /// Grid `(column, row)` points inserted first, in order; points outside the
    /// region or already vertices are skipped.
    pub seeds: &'s [[u32; 2]],
    /// Never insert a border sample other than the seeds: the caller's seeds already
    /// hold the border within the bound (the tile borders of [`super::tiles`]), so
    /// neighbours sharing the border get the same border vertices.
    pub frozen_border: bool,
}

/// Builds a TIN of `seeding.region` of the `width × height` grid, starting from its
/// four corners and the seeds. `progress`, when given, is called every 4096
/// insertions.
///
/// # Errors
/// As [`build_tin`]; also [`TinError::BadRegion`] when the region leaves the grid.
pub fn build_tin_region(
    heights: &[f32],
    width: usize,
    height: usize,
    seeding: Seeding<'_>,
    options: &TinOptions,
    progress: Option<ProgressFn<'_>>,
) -> Result<Tin, TinError> {
    let region = seeding.region;
    if options.max_error.is_nan() || options.max_error < 0.0 {
        return Err(TinError::BadBound(options.max_error));
    }
    let n = width.saturating_mul(height);
    if n > (1usize << 31) {
        return Err(TinError::TooLarge(n));
    }
    if width < 2
        || height < 2
        || heights.len() != n
        || region.x0 >= region.x1
        || region.y0 >= region.y1
        || region.x1 as usize >= width
        || region.y1 as usize >= height
    {
        return Err(TinError::BadRegion(region, width, height));
    }
    for y in region.y0..=region.y1 {
        let row = y as usize * width;
        for x in region.x0..=region.x1 {
            if !heights[row + x as usize].is_finite() {
                return Err(TinError::NonFinite(row + x as usize));
            }
        }
    }
    let mut b = Builder::new(heights, width, region, seeding.frozen_border);
    for &s in seeding.seeds {
        if s[0] >= region.x0 && s[0] <= region.x1 && s[1] >= region.y0 && s[1] <= region.y1 {
            b.insert_located(s[0] as i32, s[1] as i32);
        }
    }
    for t in 0..b.count() {
        b.scan(t);
    }
    let first = b.pts.len();
    b.run(options, progress);
    if options.prune && options.max_triangles.is_none() {
        b.prune(options.max_error, first);
    }
    Ok(b.finish())
}

#[inline]
fn next(e: u32) -> u32 {
    if e % 3 == 2 {
        e - 2
    } else {
        e + 1
    }
}

#[inline]
fn prev(e: u32) -> u32 {
    if e % 3 == 0 {
        e + 2
    } else {
        e - 1
    }
}

/// Twice the signed area of `(a, b, c)`: positive when counter-clockwise.
#[inline]
fn orient(a: [i32; 2], b: [i32; 2], c: [i32; 2]) -> i64 {
    let (ax, ay) = (i64::from(a[0]), i64::from(a[1]));
    (i64::from(b[0]) - ax) * (i64::from(c[1]) - ay)
        - (i64::from(b[1]) - ay) * (i64::from(c[0]) - ax)
}

/// Whether `d` lies strictly inside the circle through the counter-clockwise
/// triangle `(a, b, c)`. Exact: in `i64` when the coordinates differ by less than
/// 2^14 (every term then stays below 2^62), else in `i128`.
fn in_circle(a: [i32; 2], b: [i32; 2], c: [i32; 2], d: [i32; 2]) -> bool {
    let rel = |p: [i32; 2]| {
        (
            i64::from(p[0]) - i64::from(d[0]),
            i64::from(p[1]) - i64::from(d[1]),
        )
    };
    let ((ax, ay), (bx, by), (cx, cy)) = (rel(a), rel(b), rel(c));
    const SMALL: i64 = 1 << 14;
    if [ax, ay, bx, by, cx, cy].iter().all(|v| v.abs() < SMALL) {
        let (aw, bw, cw) = (ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy);
        let det = ax * (by * cw - bw * cy) - ay * (bx * cw - bw * cx) + aw * (bx * cy - by * cx);
        return det > 0;
    }
    let w = |x: i64, y: i64| {
        (
            i128::from(x),
            i128::from(y),
            i128::from(x) * i128::from(x) + i128::from(y) * i128::from(y),
        )
    };
    let ((ax, ay, aw), (bx, by, bw), (cx, cy, cw)) = (w(ax, ay), w(bx, by), w(cx, cy));
    let det = ax * (by * cw - bw * cy) - ay * (bx * cw - bw * cx) + aw * (bx * cy - by * cx);
    det > 0
}

/// Rounds a non-negative `f64` up to the nearest `f32`.
fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) < x {
        f32::from_bits(f.to_bits() + 1)
    } else {
        f
    }
}

/// The column where an edge from `p0` to `p1` (`p1` below or level with `p0`)
/// crosses successive rows, exactly: `x = q + rem / dy` with `0 ≤ rem < dy`,
/// stepped row by row with integer adds (a DDA; no division per row).
#[derive(Clone, Copy)]
struct Dda {
    q: i64,
    rem: i64,
    step_q: i64,
    step_rem: i64,
    dy: i64,
}

impl Dda {
    /// The crossing at row `y`.
    fn new(p0: [i32; 2], p1: [i32; 2], y: i64) -> Self {
        let (x0, y0) = (i64::from(p0[0]), i64::from(p0[1]));
        let dx = i64::from(p1[0]) - x0;
        let dy = i64::from(p1[1]) - y0;
        if dy == 0 {
            // Level: used on its own row only, at its first end.
            return Dda {
                q: x0,
                rem: 0,
                step_q: 0,
                step_rem: 0,
                dy: 1,
            };
        }
        let n = (y - y0) * dx;
        Dda {
            q: x0 + n.div_euclid(dy),
            rem: n.rem_euclid(dy),
            step_q: dx.div_euclid(dy),
            step_rem: dx.rem_euclid(dy),
            dy,
        }
    }

    #[inline]
    fn floor(&self) -> i64 {
        self.q
    }

    #[inline]
    fn ceil(&self) -> i64 {
        self.q + i64::from(self.rem > 0)
    }

    #[inline]
    fn step(&mut self) {
        self.q += self.step_q;
        self.rem += self.step_rem;
        if self.rem >= self.dy {
            self.rem -= self.dy;
            self.q += 1;
        }
    }
}

/// Visits every grid sample inside or on the counter-clockwise triangle `v`, clipped
/// to columns `cx0..=cx1` and rows `cy0..=cy1`: `f(row, x_lo, x_hi, z_lo, dz)` per
/// row, where the plane through the vertices' heights `z` is `z_lo + dz·(x − x_lo)`.
///
/// The vertices are taken top to bottom; the long edge bounds one side of every
/// row, the two short edges the other, each followed exactly by a [`Dda`].
#[inline]
pub(crate) fn raster(
    v: &[[i32; 2]; 3],
    z: [f64; 3],
    clip: [i64; 4],
    mut f: impl FnMut(i64, i64, i64, f64, f64),
) {
    let [cx0, cy0, cx1, cy1] = clip;
    let o = [i64::from(v[0][0]), i64::from(v[0][1])];
    let (d1x, d1y) = (i64::from(v[1][0]) - o[0], i64::from(v[1][1]) - o[1]);
    let (d2x, d2y) = (i64::from(v[2][0]) - o[0], i64::from(v[2][1]) - o[1]);
    let det = (d1x * d2y - d1y * d2x) as f64;
    let (dz1, dz2) = (z[1] - z[0], z[2] - z[0]);
    let gx = (dz1 * d2y as f64 - dz2 * d1y as f64) / det;
    let gy = (dz2 * d1x as f64 - dz1 * d2x as f64) / det;
    let mut s = *v;
    s.sort_unstable_by_key(|p| p[1]);
    let [t, m, b] = s;
    // The middle vertex left of the long edge: the short edges bound the left.
    let short_left = orient(t, b, m) > 0;
    let (my, y0, y1) = (
        i64::from(m[1]),
        i64::from(t[1]).max(cy0),
        i64::from(b[1]).min(cy1),
    );
    if y0 > y1 {
        return;
    }
    let mut long = Dda::new(t, b, y0);
    let mut short = if y0 < my {
        Dda::new(t, m, y0)
    } else {
        Dda::new(m, b, y0)
    };
    for y in y0..=y1 {
        if y == my && y > y0 {
            short = Dda::new(m, b, y);
        }
        let (lo, hi) = if short_left {
            (short.ceil(), long.floor())
        } else {
            (long.ceil(), short.floor())
        };
        let (lo, hi) = (lo.max(cx0), hi.min(cx1));
        if lo <= hi {
            let z_lo = z[0] + gx * (lo - o[0]) as f64 + gy * (y - o[1]) as f64;
            f(y, lo, hi, z_lo, gx);
        }
        long.step();
        short.step();
    }
}

/// A max-heap of triangles by `(error bits, triangle)` (errors are non-negative, so
/// their bits order as the values; ties go to the larger id), indexed: `pos[t]` is
/// the triangle's place, or [`NONE`] when it has no error.
#[derive(Default)]
struct TriHeap {
    heap: Vec<u32>,
    pos: Vec<u32>,
}

impl TriHeap {
    #[inline]
    fn key(cerr: &[f32], t: u32) -> u64 {
        (u64::from(cerr[t as usize].to_bits()) << 32) | u64::from(t)
    }

    fn top(&self) -> Option<u32> {
        self.heap.first().copied()
    }

    /// Puts `t` where its (new) error `cerr[t]` belongs; out when the error is 0.
    fn update(&mut self, cerr: &[f32], t: u32) {
        if self.pos.len() <= t as usize {
            self.pos.resize(t as usize + 1, NONE);
        }
        let i = self.pos[t as usize];
        if cerr[t as usize] > 0.0 {
            if i == NONE {
                self.heap.push(t);
                let i = self.heap.len() - 1;
                self.pos[t as usize] = i as u32;
                self.up(cerr, i);
            } else {
                let i = self.up(cerr, i as usize);
                self.down(cerr, i);
            }
        } else if i != NONE {
            let last = self.heap.pop().unwrap_or(t);
            self.pos[t as usize] = NONE;
            if last != t {
                self.heap[i as usize] = last;
                self.pos[last as usize] = i;
                let i = self.up(cerr, i as usize);
                self.down(cerr, i);
            }
        }
    }

    fn up(&mut self, cerr: &[f32], mut i: usize) -> usize {
        let t = self.heap[i];
        let k = Self::key(cerr, t);
        while i > 0 {
            let parent = (i - 1) / 2;
            let pt = self.heap[parent];
            if Self::key(cerr, pt) >= k {
                break;
            }
            self.heap[i] = pt;
            self.pos[pt as usize] = i as u32;
            i = parent;
        }
        self.heap[i] = t;
        self.pos[t as usize] = i as u32;
        i
    }

    fn down(&mut self, cerr: &[f32], mut i: usize) {
        let n = self.heap.len();
        let t = self.heap[i];
        let k = Self::key(cerr, t);
        loop {
            let l = 2 * i + 1;
            if l >= n {
                break;
            }
            let r = l + 1;
            let c = if r < n && Self::key(cerr, self.heap[r]) > Self::key(cerr, self.heap[l]) {
                r
            } else {
                l
            };
            let ct = self.heap[c];
            if Self::key(cerr, ct) <= k {
                break;
            }
            self.heap[i] = ct;
            self.pos[ct as usize] = i as u32;
            i = c;
        }
        self.heap[i] = t;
        self.pos[t as usize] = i as u32;
    }
}

struct Builder<'a> {
    grid: &'a [f32],
    width: usize,
    /// Rows and columns the candidates come from: the region, less its border when
    /// the border is frozen.
    clip: [i64; 4],
    pts: Vec<[i32; 2]>,
    /// Three vertex ids per triangle; half-edge `e` runs from `tri[e]` to `tri[next(e)]`.
    tri: Vec<u32>,
    /// The opposite half-edge of each half-edge, or [`NONE`].
    twin: Vec<u32>,
    /// Candidate sample (grid index) of each triangle, or [`NONE`].
    cand: Vec<u32>,
    /// Candidate error of each triangle, rounded up; 0 when none.
    cerr: Vec<f32>,
    /// Triangles with an error, the worst first.
    heap: TriHeap,
    /// Triangles touched by the current insertion.
    touched: Vec<u32>,
    flips: Vec<u32>,
    /// Triangles emptied by vertex removal (empty until [`Builder::prune`]).
    dead: Vec<bool>,
    /// Largest error of the triangles vertex removal made.
    pruned_max: f64,
}

impl<'a> Builder<'a> {
    fn new(grid: &'a [f32], width: usize, region: Region, frozen: bool) -> Self {
        let inset = i64::from(frozen);
        let clip = [
            i64::from(region.x0) + inset,
            i64::from(region.y0) + inset,
            i64::from(region.x1) - inset,
            i64::from(region.y1) - inset,
        ];
        let mut b = Builder {
            grid,
            width,
            clip,
            pts: Vec::new(),
            tri: Vec::new(),
            twin: Vec::new(),
            cand: Vec::new(),
            cerr: Vec::new(),
            heap: TriHeap::default(),
            touched: Vec::new(),
            flips: Vec::new(),
            dead: Vec::new(),
            pruned_max: 0.0,
        };
        let (x0, y0, x1, y1) = (
            region.x0 as i32,
            region.y0 as i32,
            region.x1 as i32,
            region.y1 as i32,
        );
        b.pts = vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        // Two triangles (0 1 2) and (0 2 3), sharing the diagonal 0–2.
        b.tri = vec![0, 1, 2, 0, 2, 3];
        b.twin = vec![NONE, NONE, 3, 2, NONE, NONE];
        b.cand = vec![NONE; 2];
        b.cerr = vec![0.0; 2];
        b
    }

    fn count(&self) -> u32 {
        (self.tri.len() / 3) as u32
    }

    fn vert(&self, e: u32) -> [i32; 2] {
        self.pts[self.tri[e as usize] as usize]
    }

    fn z(&self, p: [i32; 2]) -> f64 {
        f64::from(self.grid[p[1] as usize * self.width + p[0] as usize])
    }

    fn link(&mut self, a: u32, b: u32) {
        if a != NONE {
            self.twin[a as usize] = b;
        }
        if b != NONE {
            self.twin[b as usize] = a;
        }
    }

    /// Sets triangle `t` to `(a, b, c)` and the twins of its edges `a→b`, `b→c`,
    /// `c→a` (linking both ways), and marks it touched.
    fn set(&mut self, t: u32, v: [u32; 3], tw: [u32; 3]) {
        let e = 3 * t as usize;
        self.tri[e..e + 3].copy_from_slice(&v);
        for (k, &o) in (0u32..).zip(&tw) {
            self.link(3 * t + k, o);
        }
        self.touched.push(t);
    }

    fn alloc(&mut self) -> u32 {
        let t = self.count();
        self.tri.extend_from_slice(&[0; 3]);
        self.twin.extend_from_slice(&[NONE; 3]);
        self.cand.push(NONE);
        self.cerr.push(0.0);
        t
    }

    /// Rescans triangle `t` for its worst sample and queues it.
    fn scan(&mut self, t: u32) {
        let e = 3 * t;
        let v = [self.vert(e), self.vert(e + 1), self.vert(e + 2)];
        let z = [self.z(v[0]), self.z(v[1]), self.z(v[2])];
        let (mut best, mut best_i) = (0.0f64, NONE);
        let (grid, width) = (self.grid, self.width);
        raster(&v, z, self.clip, |y, lo, hi, z_lo, dz| {
            let row = &grid[y as usize * width..][lo as usize..=hi as usize];
            for (i, &h) in row.iter().enumerate() {
                let d = (f64::from(h) - (z_lo + i as f64 * dz)).abs();
                if d > best {
                    let x = lo as i32 + i as i32;
                    let p = [x, y as i32];
                    if p != v[0] && p != v[1] && p != v[2] {
                        best = d;
                        best_i = (y as usize * width + x as usize) as u32;
                    }
                }
            }
        });
        let err = if best_i == NONE { 0.0 } else { round_up(best) };
        self.cand[t as usize] = best_i;
        self.cerr[t as usize] = err;
        self.heap.update(&self.cerr, t);
    }

    /// Greedy insertion until the bound or the budget holds.
    fn run(&mut self, options: &TinOptions, mut progress: Option<ProgressFn<'_>>) {
        let budget = options.max_triangles.unwrap_or(usize::MAX);
        let mut inserted = 0usize;
        while let Some(t) = self.heap.top() {
            let err = self.cerr[t as usize];
            if f64::from(err) <= options.max_error || self.count() as usize >= budget {
                break;
            }
            let c = self.cand[t as usize] as usize;
            let p = [(c % self.width) as i32, (c / self.width) as i32];
            self.insert_in(t, p);
            self.touched.sort_unstable();
            self.touched.dedup();
            let touched = std::mem::take(&mut self.touched);
            for &u in &touched {
                self.scan(u);
            }
            self.touched = touched;
            self.touched.clear();
            inserted += 1;
            if inserted % 4096 == 0 {
                if let Some(f) = progress.as_mut() {
                    f(self.count() as usize, f64::from(err));
                }
            }
        }
    }

    /// Inserts `p` (inside or on the border of triangle `t`, not a vertex of it).
    fn insert_in(&mut self, t: u32, p: [i32; 2]) {
        let e = 3 * t;
        let on_edge = (0..3).find(|&k| orient(self.vert(e + k), self.vert(next(e + k)), p) == 0);
        self.pts.push(p);
        let pi = (self.pts.len() - 1) as u32;
        match on_edge {
            Some(k) => self.split_edge(e + k, pi),
            None => self.split_triangle(t, pi),
        }
        while let Some(h) = self.flips.pop() {
            self.legalize(h);
        }
    }

    /// Inserts `p` located by walking from the newest triangle (seeds). Points that
    /// are already vertices are skipped.
    fn insert_located(&mut self, x: i32, y: i32) {
        let p = [x, y];
        let mut t = self.count() - 1;
        'walk: loop {
            let e = 3 * t;
            for k in 0..3 {
                let (a, b) = (self.vert(e + k), self.vert(next(e + k)));
                if orient(a, b, p) < 0 {
                    let tw = self.twin[(e + k) as usize];
                    if tw == NONE {
                        return; // Outside the region: ignored.
                    }
                    t = tw / 3;
                    continue 'walk;
                }
            }
            break;
        }
        if (0..3).any(|k| self.vert(3 * t + k) == p) {
            return;
        }
        self.insert_in(t, p);
        self.touched.clear();
    }

    /// Splits triangle `t = (a, b, c)` into `(a, b, p)`, `(b, c, p)`, `(c, a, p)`.
    fn split_triangle(&mut self, t: u32, p: u32) {
        let e = 3 * t as usize;
        let [a, b, c] = [self.tri[e], self.tri[e + 1], self.tri[e + 2]];
        let [oab, obc, oca] = [self.twin[e], self.twin[e + 1], self.twin[e + 2]];
        let t1 = self.alloc();
        let t2 = self.alloc();
        self.set(t, [a, b, p], [oab, 3 * t1 + 2, 3 * t2 + 1]);
        self.set(t1, [b, c, p], [obc, 3 * t2 + 2, 3 * t + 1]);
        self.set(t2, [c, a, p], [oca, 3 * t + 2, 3 * t1 + 1]);
        self.flips.extend_from_slice(&[3 * t, 3 * t1, 3 * t2]);
    }

    /// Splits the edge `h` (from `a` to `b`, in triangle `(a, b, c)`) at `p`, and the
    /// triangle `(b, a, d)` across it if any: two or four triangles, each with `p` as
    /// its third vertex.
    fn split_edge(&mut self, h: u32, p: u32) {
        let t = h / 3;
        let (a, b, c) = (
            self.tri[h as usize],
            self.tri[next(h) as usize],
            self.tri[prev(h) as usize],
        );
        let (obc, oca) = (self.twin[next(h) as usize], self.twin[prev(h) as usize]);
        let f = self.twin[h as usize];
        let t1 = self.alloc();
        if f == NONE {
            self.set(t, [c, a, p], [oca, NONE, 3 * t1 + 1]);
            self.set(t1, [b, c, p], [obc, 3 * t + 2, NONE]);
            self.flips.extend_from_slice(&[3 * t, 3 * t1]);
            return;
        }
        let u = f / 3;
        let d = self.tri[prev(f) as usize];
        let (oad, odb) = (self.twin[next(f) as usize], self.twin[prev(f) as usize]);
        let u1 = self.alloc();
        self.set(t, [c, a, p], [oca, 3 * u + 2, 3 * t1 + 1]);
        self.set(t1, [b, c, p], [obc, 3 * t + 2, 3 * u1 + 1]);
        self.set(u, [a, d, p], [oad, 3 * u1 + 2, 3 * t + 1]);
        self.set(u1, [d, b, p], [odb, 3 * t1 + 2, 3 * u + 1]);
        self.flips
            .extend_from_slice(&[3 * t, 3 * t1, 3 * u, 3 * u1]);
    }

    /// Makes the edge `h` (the edge of triangle `(a, b, p)` opposite the new vertex
    /// `p`, at offset 0) locally Delaunay, flipping it to `p–q` when the vertex `q`
    /// across it lies inside the circle through `a, b, p`; the two edges that then
    /// face `p` are queued.
    fn legalize(&mut self, h: u32) {
        let f = self.twin[h as usize];
        if f == NONE {
            return;
        }
        let t = h / 3;
        let u = f / 3;
        let (a, b, p) = (
            self.tri[h as usize],
            self.tri[next(h) as usize],
            self.tri[prev(h) as usize],
        );
        let q = self.tri[prev(f) as usize];
        let pt = |i: u32| self.pts[i as usize];
        if !in_circle(pt(a), pt(b), pt(p), pt(q)) {
            return;
        }
        let (obp, opa) = (self.twin[next(h) as usize], self.twin[prev(h) as usize]);
        let (oaq, oqb) = (self.twin[next(f) as usize], self.twin[prev(f) as usize]);
        self.set(t, [a, q, p], [oaq, 3 * u + 2, opa]);
        self.set(u, [q, b, p], [oqb, obp, 3 * t + 1]);
        self.flips.extend_from_slice(&[3 * t, 3 * u]);
    }

    fn finish(self) -> Tin {
        let max_error = self
            .cerr
            .iter()
            .map(|&e| f64::from(e))
            .fold(self.pruned_max, f64::max);
        let alive = |t: usize| self.dead.get(t).is_none_or(|d| !d);
        // Drop removed vertices and dead triangles, keeping the order of the rest.
        let mut used = vec![false; self.pts.len()];
        for (t, c) in self.tri.chunks_exact(3).enumerate() {
            if alive(t) {
                for &v in c {
                    used[v as usize] = true;
                }
            }
        }
        let mut remap = vec![NONE; self.pts.len()];
        let mut points = Vec::with_capacity(self.pts.len());
        for (i, p) in self.pts.iter().enumerate() {
            if used[i] {
                remap[i] = points.len() as u32;
                points.push([p[0] as u32, p[1] as u32]);
            }
        }
        let triangles = self
            .tri
            .chunks_exact(3)
            .enumerate()
            .filter(|&(t, _)| alive(t))
            .map(|(_, c)| [c[0], c[1], c[2]].map(|v| remap[v as usize]))
            .collect();
        Tin {
            points,
            triangles,
            max_error,
        }
    }
}

/// Largest star (vertex degree) vertex removal tries.
const MAX_STAR: usize = 32;

/// Vertex removal after the insertion: greedy insertion adds each vertex for the
/// worst sample of its time, and later vertices nearby often make it unnecessary.
/// Each inserted interior vertex is tried once, newest first: its star polygon is
/// re-triangulated by ear clipping (preferring Delaunay ears: no polygon vertex
/// inside the ear's circumcircle; Devillers 1999), and the removal is kept when every
/// sample under the new triangles stays within the bound. The samples outside the
/// star are unaffected (the polygon's edges stay), so the bound keeps holding.
impl Builder<'_> {
    fn prune(&mut self, max_error: f64, first: usize) {
        self.dead = vec![false; self.count() as usize];
        let mut vedge = vec![NONE; self.pts.len()];
        for (e, &v) in self.tri.iter().enumerate() {
            vedge[v as usize] = e as u32;
        }
        let (mut ring_e, mut ring_v, mut ears) = (Vec::new(), Vec::new(), Vec::new());
        for v in (first..self.pts.len()).rev() {
            if !self.star(vedge[v], &mut ring_e, &mut ring_v) {
                continue;
            }
            let Some(worst) = self.ear_clip(&ring_v, &mut ears, max_error) else {
                continue;
            };
            self.pruned_max = self.pruned_max.max(worst);
            self.replace_star(&ring_e, &ring_v, &ears, &mut vedge);
        }
    }

    /// The half-edges leaving the vertex of `e0` (one per incident triangle, counter-
    /// clockwise) and the ring of its neighbours; `false` on the region's border or
    /// beyond [`MAX_STAR`].
    fn star(&self, e0: u32, ring_e: &mut Vec<u32>, ring_v: &mut Vec<u32>) -> bool {
        ring_e.clear();
        ring_v.clear();
        if e0 == NONE {
            return false;
        }
        let mut e = e0;
        loop {
            ring_e.push(e);
            ring_v.push(self.tri[next(e) as usize]);
            let t = self.twin[prev(e) as usize];
            if t == NONE || ring_e.len() > MAX_STAR {
                return false;
            }
            e = t;
            if e == e0 {
                return true;
            }
        }
    }

    /// Triangulates the counter-clockwise polygon `ring` (indices into `pts`) into
    /// `ears` (positions in `ring`), checking each ear's samples as it is cut: the
    /// largest error, or `None` when an ear exceeds `max_error` or no valid ear is
    /// left. A convex ear with no polygon vertex inside its circumcircle (Delaunay)
    /// has none inside it either; when there is none such, any convex ear with no
    /// vertex inside or on it.
    fn ear_clip(&self, ring: &[u32], ears: &mut Vec<[usize; 3]>, max_error: f64) -> Option<f64> {
        ears.clear();
        let p = |i: usize| self.pts[ring[i] as usize];
        let mut left: Vec<usize> = (0..ring.len()).collect();
        let mut worst = 0.0f64;
        while left.len() > 3 {
            let n = left.len();
            let corner = |k: usize| (left[(k + n - 1) % n], left[k], left[(k + 1) % n]);
            let others = |a: usize, b: usize, c: usize| {
                left.iter()
                    .copied()
                    .filter(move |&o| o != a && o != b && o != c)
            };
            let convex = |k: usize| {
                let (a, b, c) = corner(k);
                orient(p(a), p(b), p(c)) > 0
            };
            let delaunay = (0..n).find(|&k| {
                let (a, b, c) = corner(k);
                convex(k) && others(a, b, c).all(|o| !in_circle(p(a), p(b), p(c), p(o)))
            });
            let k = delaunay.or_else(|| {
                (0..n).find(|&k| {
                    let (a, b, c) = corner(k);
                    convex(k)
                        && !others(a, b, c).any(|o| {
                            orient(p(a), p(b), p(o)) >= 0
                                && orient(p(b), p(c), p(o)) >= 0
                                && orient(p(c), p(a), p(o)) >= 0
                        })
                })
            })?;
            let (a, b, c) = corner(k);
            worst = worst.max(self.ear_error([ring[a], ring[b], ring[c]], max_error)?);
            ears.push([a, b, c]);
            left.remove(k);
        }
        let last = [left[0], left[1], left[2]];
        if orient(p(last[0]), p(last[1]), p(last[2])) <= 0 {
            return None;
        }
        worst = worst.max(self.ear_error(last.map(|i| ring[i]), max_error)?);
        ears.push(last);
        Some(worst)
    }

    /// The largest error of the samples under the triangle of vertices `tri`, or
    /// `None` past `max_error`.
    fn ear_error(&self, tri: [u32; 3], max_error: f64) -> Option<f64> {
        let v = tri.map(|i| self.pts[i as usize]);
        let z = v.map(|p| self.z(p));
        let (grid, width) = (self.grid, self.width);
        let mut worst = 0.0f64;
        let mut over = false;
        raster(&v, z, self.clip, |y, lo, hi, z_lo, dz| {
            if over {
                return;
            }
            let row = &grid[y as usize * width..][lo as usize..=hi as usize];
            for (i, &h) in row.iter().enumerate() {
                let d = (f64::from(h) - (z_lo + i as f64 * dz)).abs();
                worst = if d > worst { d } else { worst };
            }
            over = worst > max_error;
        });
        (!over).then_some(worst)
    }

    /// Replaces the star's triangles by the ears (positions in `ring_v`), linking the
    /// polygon's edges to the triangles outside and the diagonals to each other; the
    /// two triangles left over are marked dead.
    fn replace_star(
        &mut self,
        ring_e: &[u32],
        ring_v: &[u32],
        ears: &[[usize; 3]],
        vedge: &mut [u32],
    ) {
        let k = ring_v.len();
        // The twin outside each polygon edge ring[i] → ring[i + 1].
        let outer: Vec<u32> = ring_e
            .iter()
            .map(|&e| self.twin[next(e) as usize])
            .collect();
        let slots: Vec<u32> = ring_e.iter().map(|&e| e / 3).collect();
        for (j, ear) in ears.iter().enumerate() {
            let t = slots[j] as usize;
            for (m, &i) in ear.iter().enumerate() {
                self.tri[3 * t + m] = ring_v[i];
                vedge[ring_v[i] as usize] = (3 * t + m) as u32;
            }
        }
        for (j, ear) in ears.iter().enumerate() {
            let t = slots[j];
            for m in 0..3 {
                let (a, b) = (ear[m], ear[(m + 1) % 3]);
                let h = 3 * t + m as u32;
                if b == (a + 1) % k {
                    self.link(h, outer[a]);
                } else if let Some((j2, m2)) = ears.iter().enumerate().find_map(|(j2, e2)| {
                    (0..3)
                        .find(|&m2| e2[m2] == b && e2[(m2 + 1) % 3] == a)
                        .map(|m2| (j2, m2))
                }) {
                    self.link(h, 3 * slots[j2] + m2 as u32);
                }
            }
        }
        for &t in &slots[ears.len()..] {
            self.dead[t as usize] = true;
            let e = 3 * t as usize;
            self.twin[e..e + 3].fill(NONE);
        }
    }
}

/// Error of a TIN against its grid: the largest and the root-mean-square vertical
/// distance, in height units, over the samples its triangles cover.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deviation {
    /// Largest vertical distance.
    pub max: f64,
    /// Root-mean-square vertical distance.
    pub rms: f64,
    /// Samples covered by at least one triangle.
    pub covered: usize,
}

/// Measures `tin` against the grid sample by sample: every sample covered by a
/// triangle (each counted once), its height compared with the triangle's linear
/// interpolation (barycentric, in `f64`). Independent of the insertion's bookkeeping:
/// the check of the bound.
#[must_use]
pub fn measure(tin: &Tin, heights: &[f32], width: usize) -> Deviation {
    let height = heights.len() / width.max(1);
    let mut seen = vec![0u64; heights.len().div_ceil(64)];
    let (mut max, mut sum, mut covered) = (0.0f64, 0.0f64, 0usize);
    for t in &tin.triangles {
        let v = t.map(|i| {
            let p = tin.points[i as usize];
            [p[0] as i32, p[1] as i32]
        });
        let z = v.map(|p| f64::from(heights[p[1] as usize * width + p[0] as usize]));
        let det = orient(v[0], v[1], v[2]) as f64;
        let clip = [0, 0, width as i64 - 1, height as i64 - 1];
        raster(&v, z, clip, |y, lo, hi, _, _| {
            for x in lo..=hi {
                let i = y as usize * width + x as usize;
                if seen[i / 64] & (1 << (i % 64)) != 0 {
                    continue;
                }
                seen[i / 64] |= 1 << (i % 64);
                let p = [x as i32, y as i32];
                let w0 = orient(v[1], v[2], p) as f64;
                let w1 = orient(v[2], v[0], p) as f64;
                let w2 = orient(v[0], v[1], p) as f64;
                let zi = (w0 * z[0] + w1 * z[1] + w2 * z[2]) / det;
                let d = (f64::from(heights[i]) - zi).abs();
                max = max.max(d);
                sum += d * d;
                covered += 1;
            }
        });
    }
    Deviation {
        max,
        rms: if covered > 0 {
            (sum / covered as f64).sqrt()
        } else {
            0.0
        },
        covered,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spans of `raster` against a brute-force test of every sample.
    fn check_raster(v: [[i32; 2]; 3], clip: [i64; 4]) {
        let mut got = Vec::new();
        raster(&v, [0.0; 3], clip, |y, lo, hi, _, _| {
            got.extend((lo..=hi).map(|x| (y, x)));
        });
        let mut want = Vec::new();
        for y in clip[1]..=clip[3] {
            for x in clip[0]..=clip[2] {
                let p = [x as i32, y as i32];
                if (0..3).all(|k| orient(v[k], v[(k + 1) % 3], p) >= 0) {
                    want.push((y, x));
                }
            }
        }
        assert_eq!(got, want, "{v:?}");
    }

    #[test]
    fn raster_covers_exactly_the_closed_triangle() {
        // (0,0) (4,0) (0,4): row y covers x in 0..=4−y.
        check_raster([[0, 0], [4, 0], [0, 4]], [-2, -2, 9, 9]);
        // A sliver (0,0) (7,3) (6,3): rows 1 and 2 hold one sample each.
        check_raster([[0, 0], [7, 3], [6, 3]], [-2, -2, 9, 9]);
        // Clipped.
        check_raster([[0, 0], [7, 3], [6, 3]], [1, 1, 6, 2]);
        // Every small triangle on a 5 × 5 lattice, both orientations fixed to CCW.
        let pts: Vec<[i32; 2]> = (0..25).map(|i| [i % 5, i / 5]).collect();
        for a in 0..25 {
            for b in 0..25 {
                for c in 0..25 {
                    let v = [pts[a], pts[b], pts[c]];
                    if orient(v[0], v[1], v[2]) > 0 {
                        check_raster(v, [-1, -1, 5, 5]);
                        check_raster(v, [1, 0, 3, 4]);
                    }
                }
            }
        }
    }

    #[test]
    fn in_circle_of_a_square() {
        // The fourth corner of a square is on the circle: not strictly inside.
        assert!(!in_circle([0, 0], [2, 0], [2, 2], [0, 2]));
        assert!(in_circle([0, 0], [2, 0], [2, 2], [1, 1]));
        assert!(!in_circle([0, 0], [2, 0], [2, 2], [5, 5]));
    }
}
