//! The uniform grid of clustering cells, and the two tables the clustering uses in
//! its hot loops: cell key → dense cell id (a flat array over the grid when the grid
//! is small, open addressing otherwise), and a set of unordered index triples
//! (output triangles) for duplicate removal.

/// Bits per axis of a packed cell key: at most `2²¹ = 2,097,152` cells per axis.
const AXIS_BITS: u32 = 21;

/// Most cells along one axis.
pub const MAX_CELLS_PER_AXIS: u32 = (1 << AXIS_BITS) - 1;

/// Axes spanning fewer cells than this keep the grid's origin at the bounding box's
/// minimum (see [`Grid::new`]).
pub const CENTRED_FROM_CELLS: f64 = 8.0;

/// A uniform grid of cubic cells of side `cell`, starting at `origin` (at or below
/// the minimum corner of the bounding box: see [`Grid::new`]), `dims` cells along
/// each axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// The minimum corner of the grid, in mesh units.
    pub origin: [f64; 3],
    /// The side of a cell, in mesh units.
    pub cell: f64,
    inv: f64,
    /// Cells along x, y and z.
    pub dims: [u32; 3],
    /// `dims − 1` as f64.
    last: [f64; 3],
}

impl Grid {
    /// The grid of side `cell` over the box `lo..hi`. The side is raised where needed
    /// so that no axis has more than [`MAX_CELLS_PER_AXIS`] cells; a box of zero size
    /// gets one cell (of side 1 when `cell` is not a positive finite number).
    ///
    /// Placement: along an axis the box spans `t = n + f` cells (`n` whole, `f` the
    /// fraction). When `t` is at least [`CENTRED_FROM_CELLS`] the grid is centred on
    /// the box with `n + 1` cells when `f ≤ ½` and `n + 2` otherwise, so that both
    /// faces of the box lie between a quarter and three quarters of the way into
    /// their outer cells, never on a cell border: the mesh's extreme parts (which
    /// touch the box) sit near the middle of a cell, where its representative is,
    /// not at its edge half a cell away (meshoptimizer centres the box's minimum in
    /// a cell for the same reason, but leaves the maximum face wherever it falls).
    /// Coarser axes start at `lo`: there the grid's count of triangles jumps by a
    /// large fraction when the centring flips between `n + 1` and `n + 2` cells, so
    /// a target count could fall between two grids.
    #[must_use]
    #[inline(always)]
    pub fn new(lo: [f64; 3], hi: [f64; 3], cell: f64) -> Self {
        let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f64, f64::max);
        let finest = extent / f64::from(MAX_CELLS_PER_AXIS - 1);
        let mut cell = if cell.is_finite() && cell > 0.0 {
            cell
        } else {
            extent.max(1.0)
        };
        if cell < finest {
            cell = finest;
        }
        if cell <= 0.0 || !cell.is_finite() {
            cell = 1.0;
        }
        let inv = 1.0 / cell;
        let origin: [f64; 3] = std::array::from_fn(|k| {
            let t = (hi[k] - lo[k]) * inv;
            if !(t >= CENTRED_FROM_CELLS && t < f64::from(MAX_CELLS_PER_AXIS - 2)) {
                return lo[k];
            }
            let f = t - t.floor();
            let margin = if f <= 0.5 { 1.0 - f } else { 2.0 - f };
            lo[k] - 0.5 * margin * cell
        });
        let dims = std::array::from_fn(|k| {
            let n = ((hi[k] - origin[k]) * inv).floor();
            (n.clamp(0.0, f64::from(MAX_CELLS_PER_AXIS - 1)) as u32) + 1
        });
        Self {
            origin,
            cell,
            inv,
            dims,
            last: dims.map(|d| f64::from(d - 1)),
        }
    }

    /// The limit cell side below which [`Self::new`]'s grid over `lo..hi` has more
    /// than `dims` cells along some axis: at exactly this side it may already have
    /// one more (the limit is not reached), so callers ask for a side a little
    /// above it (e.g. `× (1 + 1e-9)`) and check the dimensions of the grid they
    /// get. A centred axis with `d` cells covers up to `d − ½` cells of the box, one
    /// starting at `lo` up to `d`.
    #[must_use]
    pub fn finest_cell(lo: [f64; 3], hi: [f64; 3], dims: [u32; 3]) -> f64 {
        (0..3)
            .map(|k| {
                let d = f64::from(dims[k]);
                let span = if d - 0.5 >= CENTRED_FROM_CELLS {
                    d - 0.5
                } else {
                    d
                };
                (hi[k] - lo[k]) / span
            })
            .fold(0.0f64, f64::max)
    }

    /// The count of cells a surface over `lo..hi` meets on the grid of side `cell`,
    /// relative to the same surface on an average grid: along an axis the box spans
    /// `t` cells of side `cell` and the grid has `d` cells over it, where a grid
    /// starting anywhere has `t + ½` on average; a surface spanning the box then
    /// meets about `Π (dₖ / (tₖ + ½))^⅔` times as many cells (axes of at least one
    /// cell). This follows the count's jumps where a cell count changes (a row
    /// appears, or a centred axis goes from `n + 1` to `n + 2` cells).
    #[must_use]
    #[inline(always)]
    pub fn cover_factor(lo: [f64; 3], hi: [f64; 3], cell: f64) -> f64 {
        let grid = Self::new(lo, hi, cell);
        let r: f64 = (0..3)
            .map(|k| ((hi[k] - lo[k]) * grid.inv, f64::from(grid.dims[k])))
            .filter(|(t, _)| *t >= 1.0 && t.is_finite())
            .map(|(t, d)| d / (t + 0.5))
            .product();
        let c = r.cbrt();
        c * c
    }

    /// The integer cell coordinates of a point (clamped into the grid).
    #[inline]
    #[must_use]
    pub fn coords(&self, p: [f32; 3]) -> [u32; 3] {
        // For x ≥ 0 truncation is floor (and avoids a libm call); negatives and NaN
        // become 0; the clamp to the last cell (an integer, so clamping before or
        // after truncating is the same) keeps rounding at the far face in, and makes
        // the cast a plain conversion of an in-range value.
        let axis = |k: usize| {
            let x = (f64::from(p[k]) - self.origin[k]) * self.inv;
            x.max(0.0).min(self.last[k]) as u32
        };
        [axis(0), axis(1), axis(2)]
    }

    /// The packed key of a point's cell: `i << 42 | j << 21 | k`.
    #[inline]
    #[must_use]
    pub fn key(&self, p: [f32; 3]) -> u64 {
        pack(self.coords(p))
    }

    /// The linear index of a point's cell, `(i·ny + j)·nz + k` (below
    /// [`Self::cell_count`]).
    #[inline]
    #[must_use]
    pub fn linear(&self, p: [f32; 3]) -> u64 {
        let [i, j, k] = self.coords(p).map(u64::from);
        (i * u64::from(self.dims[1]) + j) * u64::from(self.dims[2]) + k
    }

    /// [`Self::linear`] as a `u32`, for grids of at most 2³² cells (larger grids give
    /// the index modulo 2³²). Written so that a loop over points vectorises: the
    /// clamped coordinates (below 2²¹) are floored by adding 2⁵², the index is
    /// formed in wrapping `u32` arithmetic.
    #[inline(always)]
    #[must_use]
    pub fn linear_u32(&self, p: [f32; 3]) -> u32 {
        // 2⁵²: adding it to x in [0, 2²¹] leaves round(x) in the low mantissa bits.
        const MAGIC: f64 = 4_503_599_627_370_496.0;
        let axis = |k: usize| {
            let x = (f64::from(p[k]) - self.origin[k]) * self.inv;
            // Comparisons (not `max`/`min`, which must propagate a NaN operand
            // specially); a NaN becomes 0 at the first.
            let x = if x > 0.0 { x } else { 0.0 };
            let x = if x < self.last[k] { x } else { self.last[k] };
            // floor(x) without a saturating float-to-int conversion: the rounded
            // value, less one where rounding went up.
            let t = x + MAGIC;
            (t.to_bits() as u32).wrapping_sub(u32::from(t - MAGIC > x))
        };
        let (i, j, k) = (axis(0), axis(1), axis(2));
        i.wrapping_mul(self.dims[1])
            .wrapping_add(j)
            .wrapping_mul(self.dims[2])
            .wrapping_add(k)
    }

    /// [`Self::linear_u32`] of every point of `points` into `out` (same length).
    pub fn linear_u32_all(&self, points: &[[f32; 3]], out: &mut [u32]) {
        for (o, &p) in out.iter_mut().zip(points) {
            *o = self.linear_u32(p);
        }
    }

    /// The cell coordinates of a [`Self::linear`] index.
    #[must_use]
    pub fn unlinear(&self, l: u64) -> [u32; 3] {
        let (ny, nz) = (u64::from(self.dims[1]), u64::from(self.dims[2]));
        [(l / nz / ny) as u32, (l / nz % ny) as u32, (l % nz) as u32]
    }

    /// The minimum corner of the cell with coordinates `c`, relative to
    /// [`Self::origin`].
    #[inline]
    #[must_use]
    pub fn corner(&self, c: [u32; 3]) -> [f64; 3] {
        c.map(|x| f64::from(x) * self.cell)
    }

    /// Number of cells of the grid (occupied or not).
    #[must_use]
    pub fn cell_count(&self) -> u64 {
        self.dims.iter().map(|&d| u64::from(d)).product()
    }
}

/// Packs cell coordinates into a key.
#[inline]
#[must_use]
pub fn pack(c: [u32; 3]) -> u64 {
    (u64::from(c[0]) << (2 * AXIS_BITS)) | (u64::from(c[1]) << AXIS_BITS) | u64::from(c[2])
}

/// Unpacks a key into cell coordinates.
#[inline]
#[must_use]
pub fn unpack(key: u64) -> [u32; 3] {
    let m = (1u64 << AXIS_BITS) - 1;
    [
        (key >> (2 * AXIS_BITS)) as u32,
        ((key >> AXIS_BITS) & m) as u32,
        (key & m) as u32,
    ]
}

#[inline]
fn mix(x: u64) -> u64 {
    // A 64-bit finaliser (Stafford's variant 13 of MurmurHash3's fmix64).
    let mut z = x;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

const EMPTY: u64 = u64::MAX;

/// Map from packed cell keys to dense ids `0, 1, 2, …` in order of first insertion.
///
/// Two layouts: when built [`for a grid`](Self::for_grid) of at most `dense_limit`
/// cells, a flat array indexed by the cell's position in the grid (one `u32` per grid
/// cell, no hashing); otherwise open addressing with linear probing, load factor at
/// most 1/2, memory proportional to the cells inserted.
#[derive(Debug, Clone)]
pub struct CellTable {
    slots: Vec<(u64, u32)>,
    mask: usize,
    keys: Vec<u64>,
    /// The flat layout: id of every grid cell (`u32::MAX` when absent), and the grid
    /// dimensions (y and z) to linearise coordinates.
    dense: Vec<u32>,
    dims: [u64; 2],
}

impl CellTable {
    /// A hashed table sized for about `expected` cells.
    #[must_use]
    pub fn with_capacity(expected: usize) -> Self {
        let n = (expected.max(8) * 2).next_power_of_two();
        Self {
            slots: vec![(EMPTY, 0); n],
            mask: n - 1,
            keys: Vec::with_capacity(expected),
            dense: Vec::new(),
            dims: [0; 2],
        }
    }

    /// A table for the cells of `grid`: flat when the grid has at most `dense_limit`
    /// cells, hashed (sized for about `expected` cells) otherwise.
    #[must_use]
    pub fn for_grid(grid: &Grid, expected: usize, dense_limit: usize) -> Self {
        let cells = grid.cell_count();
        if cells <= dense_limit as u64 {
            Self {
                slots: Vec::new(),
                mask: 0,
                keys: Vec::with_capacity(expected),
                dense: vec![u32::MAX; cells as usize],
                dims: [u64::from(grid.dims[1]), u64::from(grid.dims[2])],
            }
        } else {
            Self::with_capacity(expected)
        }
    }

    /// Number of cells inserted.
    #[must_use]
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// True when no cell was inserted.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// The key of dense id `id`.
    #[must_use]
    pub fn key(&self, id: u32) -> u64 {
        self.keys[id as usize]
    }

    /// The keys in dense-id order.
    #[must_use]
    pub fn keys(&self) -> &[u64] {
        &self.keys
    }

    /// The dense id of `key`, inserting it (with the next id) when new. In the flat
    /// layout the key must be a cell of the grid the table was made for.
    #[inline]
    pub fn id(&mut self, key: u64) -> u32 {
        if !self.dense.is_empty() {
            let [i, j, k] = unpack(key).map(u64::from);
            let slot = &mut self.dense[((i * self.dims[0] + j) * self.dims[1] + k) as usize];
            if *slot == u32::MAX {
                *slot = self.keys.len() as u32;
                self.keys.push(key);
            }
            return *slot;
        }
        let mut i = mix(key) as usize & self.mask;
        loop {
            let (k, v) = self.slots[i];
            if k == key {
                return v;
            }
            if k == EMPTY {
                let id = self.keys.len() as u32;
                self.slots[i] = (key, id);
                self.keys.push(key);
                if self.keys.len() * 2 > self.slots.len() {
                    self.grow();
                }
                return id;
            }
            i = (i + 1) & self.mask;
        }
    }

    /// The dense id of `key` when it was inserted (no insertion). In the flat layout
    /// the key must be a cell of the grid the table was made for.
    #[must_use]
    pub fn find(&self, key: u64) -> Option<u32> {
        if !self.dense.is_empty() {
            let [i, j, k] = unpack(key).map(u64::from);
            let id = self.dense[((i * self.dims[0] + j) * self.dims[1] + k) as usize];
            return (id != u32::MAX).then_some(id);
        }
        let mut i = mix(key) as usize & self.mask;
        loop {
            let (k, v) = self.slots[i];
            if k == key {
                return Some(v);
            }
            if k == EMPTY {
                return None;
            }
            i = (i + 1) & self.mask;
        }
    }

    /// [`Self::id`] of the cell with [`Grid::linear`] index `l` on `grid` (the grid
    /// the table was made for): in the flat layout the index is the slot.
    #[inline]
    pub fn id_linear(&mut self, l: u64, grid: &Grid) -> u32 {
        if self.dense.is_empty() {
            return self.id(pack(grid.unlinear(l)));
        }
        let slot = &mut self.dense[l as usize];
        if *slot == u32::MAX {
            *slot = self.keys.len() as u32;
            self.keys.push(pack(grid.unlinear(l)));
        }
        *slot
    }

    fn grow(&mut self) {
        let n = self.slots.len() * 2;
        let old = std::mem::replace(&mut self.slots, vec![(EMPTY, 0); n]);
        self.mask = n - 1;
        for (k, v) in old {
            if k != EMPTY {
                let mut i = mix(k) as usize & self.mask;
                while self.slots[i].0 != EMPTY {
                    i = (i + 1) & self.mask;
                }
                self.slots[i] = (k, v);
            }
        }
    }

    /// Bytes held.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.slots.capacity() * 16 + self.keys.capacity() * 8 + self.dense.capacity() * 4
    }
}

/// A key of an [`OpenSet`]: a sentinel that is never inserted, and where its probe
/// sequence starts.
trait SlotKey: Copy + PartialEq {
    /// The value of an empty slot.
    const EMPTY: Self;
    /// Hash choosing the first slot tried.
    fn slot_hash(self) -> u64;
}

impl SlotKey for [u32; 3] {
    const EMPTY: Self = [u32::MAX; 3];
    /// One multiply per entry by odd constants (the fractional part of the golden
    /// ratio and two others), then the high half folded onto the low bits the
    /// table indexes with: cheaper than finalising each entry, and the sets are
    /// only asked about membership (never iterated), so the hash decides nothing.
    #[inline]
    fn slot_hash(self) -> u64 {
        let h = u64::from(self[0]).wrapping_mul(0x9e37_79b9_7f4a_7c15)
            ^ u64::from(self[1]).wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
            ^ u64::from(self[2]).wrapping_mul(0x1656_67b1_9e37_79f9);
        h ^ (h >> 29) ^ (h >> 47)
    }
}

impl SlotKey for u64 {
    const EMPTY: Self = 0;
    #[inline]
    fn slot_hash(self) -> u64 {
        self >> 7
    }
}

/// Linear-probing set of keys, grown to twice its size at half load.
#[derive(Debug, Clone, Default)]
struct OpenSet<K> {
    slots: Vec<K>,
    mask: usize,
    len: usize,
}

impl<K: SlotKey> OpenSet<K> {
    /// Empties the set, sized for about `expected` keys (the memory is reused).
    fn reset(&mut self, expected: usize) {
        let n = (expected.max(8) * 2).next_power_of_two();
        self.slots.clear();
        self.slots.resize(n, K::EMPTY);
        self.mask = n - 1;
        self.len = 0;
    }

    /// Inserts `k` (never [`SlotKey::EMPTY`]); `true` when it was not there yet.
    #[inline]
    fn insert(&mut self, k: K) -> bool {
        let mut i = k.slot_hash() as usize & self.mask;
        loop {
            let slot = self.slots[i];
            if slot == k {
                return false;
            }
            if slot == K::EMPTY {
                self.slots[i] = k;
                self.len += 1;
                if self.len * 2 > self.slots.len() {
                    self.grow();
                }
                return true;
            }
            i = (i + 1) & self.mask;
        }
    }

    fn grow(&mut self) {
        let n = self.slots.len() * 2;
        let old = std::mem::replace(&mut self.slots, vec![K::EMPTY; n]);
        self.mask = n - 1;
        self.len = 0;
        for k in old {
            if k != K::EMPTY {
                self.insert(k);
            }
        }
    }
}

/// The three entries of `t` in ascending order.
#[inline]
fn sorted3<T: PartialOrd>(mut t: [T; 3]) -> [T; 3] {
    if t[0] > t[1] {
        t.swap(0, 1);
    }
    if t[1] > t[2] {
        t.swap(1, 2);
    }
    if t[0] > t[1] {
        t.swap(0, 1);
    }
    t
}

/// Open-addressing set of unordered triples of `u32` (triangles up to rotation and
/// winding): [`Self::insert`] says whether the triple is new.
#[derive(Debug, Clone)]
pub struct TripleSet(
    OpenSet<[u32; 3]>,
    Vec<(u32, [u32; 3])>,
    Vec<(u32, [u32; 3])>,
);

impl TripleSet {
    /// A set sized for about `expected` triples.
    #[must_use]
    pub fn with_capacity(expected: usize) -> Self {
        let mut s = OpenSet::default();
        s.reset(expected);
        Self(s, Vec::new(), Vec::new())
    }

    /// Empties the set, sized for about `expected` triples (the memory is reused).
    pub fn reset(&mut self, expected: usize) {
        self.0.reset(expected);
    }

    /// Inserts the triple `t` (any order); `true` when it was not there yet. The
    /// entries must be distinct and not `u32::MAX`.
    #[inline]
    pub fn insert(&mut self, t: [u32; 3]) -> bool {
        self.0.insert(sorted3(t))
    }

    /// Bytes held.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.0.slots.capacity() * 12 + (self.1.capacity() + self.2.capacity()) * 16
    }

    /// Keeps the items of `items` whose triple `triple(x)` (any order; distinct
    /// entries, not `u32::MAX`) is the first in order over its three entries:
    /// what inserting them one by one into an empty set keeps, in the same
    /// order. Large inputs (over `ONE_SET_MAX` triples) are first partitioned
    /// by a hash of the triple (a stable counting sort, so a triple's copies stay
    /// in order) into buckets of a few thousand, each deduplicated in a small table that stays in cache
    /// (one set over all of them misses the cache on nearly every insert). The
    /// set is left holding every kept triple (small inputs), or empty or holding
    /// the last bucket (partitioned inputs).
    #[inline]
    pub fn retain_first<T: Copy>(&mut self, items: &mut Vec<T>, triple: impl Fn(T) -> [u32; 3]) {
        let n = items.len();
        if n <= ONE_SET_MAX {
            // One set; `retain` as a plain loop (it inlines into the caller).
            self.reset(n);
            let mut kept = 0;
            for i in 0..n {
                let x = items[i];
                if self.insert(triple(x)) {
                    items[kept] = x;
                    kept += 1;
                }
            }
            items.truncate(kept);
            return;
        }
        // (position, sorted triple) in order, partitioned by the triple's hash.
        let indexed = &mut self.2;
        indexed.clear();
        indexed.extend(
            items
                .iter()
                .enumerate()
                .map(|(i, &x)| (i as u32, sorted3(triple(x)))),
        );
        let parts = &mut self.1;
        let start = partition(indexed, |&(_, t)| bucket_hash(t), parts);
        let buckets = start.len() - 1;
        let mut keep = vec![false; n];
        for b in 0..buckets {
            let part = &parts[start[b]..start[b + 1]];
            self.0.reset(part.len());
            for &(i, t) in part {
                keep[i as usize] = self.0.insert(t);
            }
        }
        let mut i = 0;
        items.retain(|_| {
            i += 1;
            keep[i - 1]
        });
    }
}

/// Items per bucket aimed at by [`partition`]: a table of 2¹³ slots, which stays in
/// a core's cache.
const PER_BUCKET: usize = 1 << 12;

/// A stable counting sort of `items` into `out` by the high bits of `hash(x)`, in
/// as many buckets (a power of two) as give about [`PER_BUCKET`] items each; returns
/// where each bucket starts in `out` (and, last, `items.len()`).
fn partition<T: Copy + Default>(
    items: &[T],
    hash: impl Fn(&T) -> u64,
    out: &mut Vec<T>,
) -> Vec<usize> {
    let buckets = (items.len() / PER_BUCKET).next_power_of_two();
    let shift = 64 - buckets.trailing_zeros();
    // `checked_shr`: one bucket (shift 64) takes every item.
    let bucket = |x: &T| hash(x).checked_shr(shift).unwrap_or(0) as usize;
    let mut start = vec![0usize; buckets + 1];
    for x in items {
        start[bucket(x) + 1] += 1;
    }
    for b in 0..buckets {
        start[b + 1] += start[b];
    }
    out.clear();
    out.resize(items.len(), T::default());
    let mut next = start.clone();
    for x in items {
        let b = bucket(x);
        out[next[b]] = *x;
        next[b] += 1;
    }
    start
}

/// Up to this many triples are deduplicated in one set (at most 2¹⁷ slots, 1.5 MB
/// at 12 bytes a slot: it mostly stays in a core's cache), more by partition.
const ONE_SET_MAX: usize = 1 << 16;

/// The hash that partitions triples in [`TripleSet::retain_first`] (its high
/// bits); unlike [`SlotKey::slot_hash`] of the sorted triple, so that the triples
/// of one bucket spread over its table.
#[inline]
fn bucket_hash(t: [u32; 3]) -> u64 {
    mix(u64::from(t[0]) | u64::from(t[1]) << 32)
        ^ u64::from(t[2]).wrapping_mul(0x9e37_79b9_7f4a_7c15)
}

/// A reusable multiset of unordered triples of cell keys, for counting the distinct
/// triangles of a probe without numbering the cells. It keeps a 64-bit hash of each
/// triple, not the triple (8 bytes each): two distinct triples count once only if
/// their hashes collide, which for `n` triples has probability about `n²/2⁶⁵`
/// (about 2·10⁻⁷ for 3M triples, 0.03 for a billion). Only the ε search uses it.
///
/// The hashes are gathered first and counted at the end ([`Self::count`]):
/// partitioned by their high bits into buckets of a few thousand, each counted in
/// a small linear-probing set that stays in cache, where one set over all of them
/// would miss the cache on nearly every insert.
#[derive(Debug, Clone, Default)]
pub(crate) struct KeyTriples {
    hashes: Vec<u64>,
    parts: Vec<u64>,
    set: OpenSet<u64>,
}

impl KeyTriples {
    /// Empties the multiset, sized for about `expected` triples (the memory is
    /// reused).
    pub(crate) fn reset(&mut self, expected: usize) {
        self.hashes.clear();
        self.hashes.reserve(expected);
    }

    /// Adds the triple of keys `t`, in any order.
    #[inline]
    pub(crate) fn push(&mut self, t: [u64; 3]) {
        self.hashes.push(Self::hash(t));
    }

    /// The hash kept for the triple of keys `t` (any order; never 0), for
    /// [`Self::push_hash`].
    #[inline]
    pub(crate) fn hash(t: [u64; 3]) -> u64 {
        let s = sorted3(t);
        mix(s[0] ^ mix(s[1] ^ mix(s[2]))).max(1)
    }

    /// Adds a triple by its [`Self::hash`].
    #[inline]
    pub(crate) fn push_hash(&mut self, h: u64) {
        self.hashes.push(h);
    }

    /// Number of distinct triples added.
    pub(crate) fn count(&mut self) -> usize {
        let n = self.hashes.len();
        if n <= ONE_SET_MAX {
            self.set.reset(n);
            self.hashes.iter().for_each(|&h| _ = self.set.insert(h));
            return self.set.len;
        }
        // The buckets are the high bits; the slots (`h >> 7`) the low ones.
        let start = partition(&self.hashes, |&h| h, &mut self.parts);
        let buckets = start.len() - 1;
        let mut distinct = 0;
        for b in 0..buckets {
            let part = &self.parts[start[b]..start[b + 1]];
            self.set.reset(part.len());
            part.iter().for_each(|&h| _ = self.set.insert(h));
            distinct += self.set.len;
        }
        distinct
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pack_round_trips() {
        for c in [[0, 0, 0], [1, 2, 3], [MAX_CELLS_PER_AXIS; 3], [7, 0, 99]] {
            assert_eq!(unpack(pack(c)), c);
        }
    }

    /// Axes of at least [`CENTRED_FROM_CELLS`] cells are centred with both box faces
    /// a quarter to three quarters into their outer cells; coarser ones start at
    /// the box's minimum; every point of the box is in the grid.
    #[test]
    fn grid_centres_fine_axes() {
        // x: 10.2 cells (f ≤ ½: 11 cells, margins 0.4); y: 12.7 (f > ½: 14 cells,
        // margins 0.65); z: 3.5 cells (coarse: starts at lo).
        let g = Grid::new([1.0, -2.0, 0.0], [11.2, 10.7, 3.5], 1.0);
        assert_eq!(g.dims, [11, 14, 4]);
        let expect = [1.0 - 0.4, -2.0 - 0.65, 0.0];
        for (o, e) in g.origin.iter().zip(expect) {
            assert!((o - e).abs() < 1e-12, "{:?}", g.origin);
        }
        for (k, (lo, hi)) in [(1.0, 11.2), (-2.0, 10.7)].into_iter().enumerate() {
            let first = (lo - g.origin[k]) / g.cell;
            let last = (hi - g.origin[k]) / g.cell - f64::from(g.dims[k] - 1);
            assert!((0.25..=0.75).contains(&first), "axis {k}: {first}");
            assert!((0.25..=0.75).contains(&last), "axis {k}: {last}");
        }
        assert_eq!(g.coords([1.0, -2.0, 0.0]), [0, 0, 0]);
        assert_eq!(g.coords([11.2, 10.7, 3.5]), [10, 13, 3]);
        // The finest side with these dimensions has them; a little finer has more.
        let lo = [1.0, -2.0, 0.0];
        let hi = [11.2, 10.7, 3.5];
        let e = Grid::finest_cell(lo, hi, g.dims) * (1.0 + 1e-9);
        assert_eq!(Grid::new(lo, hi, e).dims, g.dims);
        assert_ne!(Grid::new(lo, hi, e * 0.999).dims, g.dims);
    }

    #[test]
    fn grid_clamps_resolution_and_points() {
        let g = Grid::new([0.0; 3], [1.0, 2.0, 0.0], 0.5);
        assert_eq!(g.dims, [3, 5, 1]);
        assert_eq!(g.coords([1.0, 2.0, 0.0]), [2, 4, 0]);
        assert_eq!(g.coords([-1.0, 9.0, 0.0]), [0, 4, 0]);
        let fine = Grid::new([0.0; 3], [1.0; 3], 1e-30);
        assert!(fine.dims.iter().all(|&d| d <= MAX_CELLS_PER_AXIS));
        let point = Grid::new([2.0; 3], [2.0; 3], 0.0);
        assert_eq!(point.dims, [1, 1, 1]);
        assert_eq!(point.cell, 1.0);
    }

    /// The vectorisable [`Grid::linear_u32`] floors exactly as [`Grid::linear`]:
    /// points on cell faces, just below them, halfway, outside the box, NaN.
    #[test]
    fn linear_u32_matches_linear() {
        let g = Grid::new([-1.0, 0.0, 2.0], [3.0, 1.5, 9.0], 0.25);
        let mut checked = 0;
        for n in -40..80 {
            let f = n as f32 * 0.125;
            for d in [0.0, -1e-6, 1e-6, 0.0625] {
                let x = f + d;
                for p in [[x, 0.3, 4.0], [0.1, x, 8.9], [2.9, 1.4, x + 2.0], [x; 3]] {
                    assert_eq!(u64::from(g.linear_u32(p)), g.linear(p), "{p:?}");
                    checked += 1;
                }
            }
        }
        let nan = [f32::NAN, 1.0, f32::INFINITY];
        assert_eq!(u64::from(g.linear_u32(nan)), g.linear(nan));
        assert_eq!(checked, 120 * 16);
    }

    #[test]
    fn tables_insert_and_find() {
        let mut t = CellTable::with_capacity(1);
        let ids: Vec<u32> = (0..1000u64).map(|k| t.id(k * 7919)).collect();
        assert_eq!(ids, (0..1000).collect::<Vec<_>>());
        assert_eq!(t.id(7919 * 5), 5);
        assert_eq!(t.len(), 1000);
        let mut s = TripleSet::with_capacity(1);
        assert!(s.insert([1, 2, 3]));
        assert!(!s.insert([3, 1, 2]));
        assert!(!s.insert([2, 1, 3]));
        for i in 0..500 {
            assert!(s.insert([i, i + 1, i + 7]));
        }
        assert!(!s.insert([250, 257, 251]));
        let mut k = KeyTriples::default();
        k.reset(1);
        for i in 0..500u64 {
            k.push([i << 40, i + 1, i + 7]);
        }
        k.push([251, 250 << 40, 257]);
        k.push([251, 250, 257]);
        assert_eq!(k.count(), 501);
        k.reset(4);
        assert_eq!(k.count(), 0);
        k.push([3, 2, 1]);
        k.push([1, 3, 2]);
        assert_eq!(k.count(), 1);
    }

    /// The partitioned passes (large inputs) keep what one set keeps: the first
    /// triangle over each triple in order, and the count of distinct triples.
    #[test]
    fn partitioned_dedup_matches_one_set() {
        // 210k triples over 70k distinct ones, copies scattered, in various orders.
        let t = |i: u32| {
            let j = i * 7919 % 70_000;
            let t = [j, j + 1 + j % 7, j + 70_001];
            [
                t[(i % 3) as usize],
                t[((i + 1) % 3) as usize],
                t[((i + 2) % 3) as usize],
            ]
        };
        let mut items: Vec<u32> = (0..210_000).collect();
        let mut one = TripleSet::with_capacity(210_000);
        let expect: Vec<u32> = items
            .iter()
            .copied()
            .filter(|&i| one.insert(t(i)))
            .collect();
        assert_eq!(expect.len(), 70_000);
        let mut s = TripleSet::with_capacity(0);
        s.retain_first(&mut items, t);
        assert_eq!(items, expect);
        let mut k = KeyTriples::default();
        k.reset(0);
        for i in 0..210_000 {
            k.push(t(i).map(u64::from));
        }
        assert_eq!(k.count(), 70_000);
    }

    /// The flat and the hashed layouts give the same ids for the same keys.
    #[test]
    fn flat_and_hashed_tables_agree() {
        let g = Grid::new([0.0; 3], [3.0, 5.0, 2.0], 0.5);
        let mut flat = CellTable::for_grid(&g, 4, 1 << 20);
        let mut hashed = CellTable::for_grid(&g, 4, 0);
        assert!(!flat.dense.is_empty() && hashed.dense.is_empty());
        let mut seen = Vec::new();
        for n in 0..500u32 {
            let f = n as f32;
            let p = [(f * 0.37) % 3.0, (f * 0.71) % 5.0, (f * 0.13) % 2.0];
            let key = g.key(p);
            let a = flat.id(key);
            assert_eq!(a, hashed.id(key));
            assert_eq!(flat.key(a), key);
            if !seen.contains(&key) {
                assert_eq!(a as usize, seen.len());
                seen.push(key);
            }
        }
        assert_eq!(flat.keys(), hashed.keys());
        // Linear indices give the same ids in both layouts.
        let mut flat2 = CellTable::for_grid(&g, 4, 1 << 20);
        let mut hashed2 = CellTable::for_grid(&g, 4, 0);
        for n in 0..500u32 {
            let f = n as f32;
            let p = [(f * 0.37) % 3.0, (f * 0.71) % 5.0, (f * 0.13) % 2.0];
            let l = g.linear(p);
            assert!(l < g.cell_count());
            assert_eq!(u64::from(g.linear_u32(p)), l);
            assert_eq!(pack(g.unlinear(l)), g.key(p));
            assert_eq!(flat2.id_linear(l, &g), flat.id(g.key(p)));
            assert_eq!(hashed2.id_linear(l, &g), flat.id(g.key(p)));
        }
        assert_eq!(flat2.keys(), flat.keys());
        assert_eq!(hashed2.keys(), flat.keys());
    }
}
