//! The coverage repair: thin parts whose triangles all collapsed.
//!
//! A part of the input thinner than a cell (a statue's torch, a blade's tip, a small
//! separate piece) can have every triangle fall on one or two cells: all of them
//! collapse to edges or points, and the part vanishes from the output although its
//! cells are occupied. The Hausdorff distance then jumps to the part's length (Lucy at
//! 1%: 9.4% of the diagonal against about 3% at a slightly different count).
//!
//! The repair looks at the *orphan* cells: cells holding a corner of some triangle
//! but no output vertex. Their depth is the number of steps, through 26-neighbouring
//! orphan cells, to a cell with an output vertex; an orphan cell with no such path
//! (a separate piece) is reached from the smallest key of its orphan group. An orphan
//! at depth 1 touches the output's cells, so it is within about two cells of the
//! output, as clustering is anywhere. Every orphan at depth 2 or more gets one
//! triangle over itself, the neighbour it was reached from and that neighbour's
//! own predecessor (three occupied cells a step apart): a thin sliver along the part,
//! which brings it back within a cell or so of the output.
//!
//! A depth-1 orphan is usually as close to the output as clustering keeps anything,
//! but a tip that reaches a few hundredths of a cell into the next cell (the
//! armadillo's toe at 1%: 2.69% of the diagonal, the mesh's maximum) can stand out.
//! A depth-1 orphan whose representative is farther than [`FAR`] cell sides from
//! every covered neighbour's representative gets one triangle over itself and the
//! two nearest of those neighbours; the farthest such orphans first, at most one per
//! [`FAR_BUDGET_PER`] output triangles (a bound on what the rule adds on top of the
//! count: none below 256 triangles). The distance to the first covered neighbour
//! found bounds the nearest, so the full neighbour scan runs only for orphans
//! beyond it. The triangles are ordered by cell key (breadth first; the depth-1 ones
//! by distance, ties by key), not by cell id, so both paths (which number cells
//! differently) add the same ones.

use super::grid::{pack, unpack, CellTable};

/// No cell.
const NONE: u32 = u32::MAX;

/// A depth-1 orphan gets a triangle when its representative is farther than this
/// many cell sides from every covered neighbour's representative.
const FAR: f64 = 0.55;

/// At most one depth-1 triangle per this many output triangles (before the repair).
pub(super) const FAR_BUDGET_PER: usize = 256;

/// The cell triples of the repair (see the module documentation), given the table of
/// `dims` cells, its orphan cells (ids, any order), whether a cell holds a corner
/// (`occupied`), whether it has an output vertex (`covered`), a cell's (welded)
/// representative (`pos`), the cell side `cell` in mesh units and the most depth-1
/// triangles to add (`budget`). Empty when no cell is an orphan at depth 2 and no
/// depth-1 orphan is farther than [`FAR`] cells from its covered neighbours.
#[allow(clippy::too_many_arguments)]
pub(super) fn plan(
    table: &CellTable,
    dims: [u32; 3],
    orphans: &[u32],
    occupied: impl Fn(u32) -> bool,
    covered: impl Fn(u32) -> bool,
    pos: impl Fn(u32) -> [f32; 3],
    cell: f64,
    budget: usize,
) -> Vec<[u32; 3]> {
    let n = table.len() as u32;
    let mut orphans: Vec<(u64, u32)> = orphans.iter().map(|&c| (table.key(c), c)).collect();
    if orphans.is_empty() {
        return Vec::new();
    }
    orphans.sort_unstable();
    // Index of each orphan cell in `orphans` (NONE for the others).
    let mut slot = vec![NONE; n as usize];
    for (i, &(_, c)) in orphans.iter().enumerate() {
        slot[c as usize] = i as u32;
    }
    let m = orphans.len();
    let mut search = Search {
        around: Around {
            table,
            dims,
            occupied: &occupied,
        },
        orphans,
        slot,
        depth: vec![0u32; m],
        parent: vec![NONE; m],
        queue: Vec::with_capacity(m),
    };
    search.depth_one(&covered);
    let mut out = search.far_depth_one(&covered, &pos, FAR * cell, budget);
    // Usually every orphan touches the output's cells: nothing to repair.
    if search.queue.len() == m {
        return out;
    }
    search.breadth_first();
    search.deep(&mut out);
    out
}

/// The occupied 26-neighbours of cells of a table.
struct Around<'a> {
    table: &'a CellTable,
    dims: [u32; 3],
    occupied: &'a dyn Fn(u32) -> bool,
}

impl Around<'_> {
    /// The occupied 26-neighbours of the cell `key`, in a fixed order, until `f`
    /// returns true (then true).
    fn any(&self, key: u64, f: &mut dyn FnMut(u32) -> bool) -> bool {
        let c = unpack(key);
        for dx in -1i64..=1 {
            for dy in -1i64..=1 {
                for dz in -1i64..=1 {
                    if dx == 0 && dy == 0 && dz == 0 {
                        continue;
                    }
                    let q = [dx, dy, dz];
                    let mut d = [0u32; 3];
                    let mut inside = true;
                    for k in 0..3 {
                        let x = i64::from(c[k]) + q[k];
                        inside &= x >= 0 && x < i64::from(self.dims[k]);
                        d[k] = x.max(0) as u32;
                    }
                    if inside {
                        if let Some(id) = self.table.find(pack(d)) {
                            if (self.occupied)(id) && f(id) {
                                return true;
                            }
                        }
                    }
                }
            }
        }
        false
    }
}

/// The breadth-first search over the orphan cells.
struct Search<'a> {
    around: Around<'a>,
    /// The orphan cells (key, id), by key.
    orphans: Vec<(u64, u32)>,
    /// Index of each cell in `orphans` (NONE for the others).
    slot: Vec<u32>,
    /// Per orphan, its depth (0: not reached yet).
    depth: Vec<u32>,
    /// Per orphan, the cell it was reached from (NONE for none).
    parent: Vec<u32>,
    /// The orphans reached, in order.
    queue: Vec<u32>,
}

impl Search<'_> {
    /// The depth-1 orphans: those with a covered neighbour (the first occupied
    /// neighbour looked at becomes the parent).
    fn depth_one(&mut self, covered: &dyn Fn(u32) -> bool) {
        for (i, &(key, _)) in self.orphans.iter().enumerate() {
            let mut first = NONE;
            if self.around.any(key, &mut |c| {
                first = c;
                covered(c)
            }) {
                self.depth[i] = 1;
                self.parent[i] = first;
                self.queue.push(i as u32);
            }
        }
    }

    /// Depth-1 orphans whose representative (`pos`) is farther than `far` from
    /// every covered neighbour's: the farthest `budget` of them, each with its two
    /// nearest covered neighbours.
    fn far_depth_one(
        &self,
        covered: &dyn Fn(u32) -> bool,
        pos: &dyn Fn(u32) -> [f32; 3],
        far: f64,
        budget: usize,
    ) -> Vec<[u32; 3]> {
        let dist = |p: [f32; 3], q: [f32; 3]| -> f64 {
            (0..3)
                .map(|k| (f64::from(p[k]) - f64::from(q[k])).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let mut near: Vec<(f64, [u32; 3])> = Vec::new();
        if budget > 0 {
            for &i in &self.queue {
                let (key, c) = self.orphans[i as usize];
                let p = pos(c);
                // The first covered neighbour found bounds the nearest.
                if dist(p, pos(self.parent[i as usize])) <= far {
                    continue;
                }
                // The two nearest covered neighbours (by representative).
                let mut best = [(f64::INFINITY, NONE); 2];
                self.around.any(key, &mut |n| {
                    if covered(n) {
                        let d = dist(p, pos(n));
                        if d < best[0].0 {
                            best[1] = best[0];
                            best[0] = (d, n);
                        } else if d < best[1].0 {
                            best[1] = (d, n);
                        }
                    }
                    false
                });
                if best[0].0 > far && best[1].1 != NONE {
                    near.push((best[0].0, [c, best[0].1, best[1].1]));
                }
            }
            // Farthest first; ties by the order of the keys (stable sort).
            near.sort_by(|a, b| b.0.total_cmp(&a.0));
            near.truncate(budget);
        }
        near.into_iter().map(|(_, t)| t).collect()
    }

    /// Reaches every orphan: breadth first from the depth-1 ones, then from the
    /// smallest key of each orphan group out of reach of the output.
    fn breadth_first(&mut self) {
        let m = self.orphans.len();
        let mut head = 0;
        let mut next_root = 0;
        loop {
            while head < self.queue.len() {
                let i = self.queue[head] as usize;
                head += 1;
                let (d, from) = (self.depth[i] + 1, self.orphans[i].1);
                let (slot, depth, parent, queue) = (
                    &self.slot,
                    &mut self.depth,
                    &mut self.parent,
                    &mut self.queue,
                );
                self.around.any(self.orphans[i].0, &mut |c| {
                    let j = slot[c as usize];
                    if j != NONE && depth[j as usize] == 0 {
                        depth[j as usize] = d;
                        parent[j as usize] = from;
                        queue.push(j);
                    }
                    false
                });
            }
            // An orphan group out of reach of the output (a separate piece): from its
            // smallest key.
            while next_root < m && self.depth[next_root] != 0 {
                next_root += 1;
            }
            if next_root == m {
                break;
            }
            self.depth[next_root] = 1;
            self.queue.push(next_root as u32);
        }
    }

    /// One triangle per orphan at depth 2 or more: itself, its parent and its
    /// parent's parent (for a separate piece's root, another of its orphan
    /// neighbours), appended to `out` in the order reached.
    fn deep(&self, out: &mut Vec<[u32; 3]>) {
        let (orphans, slot, parent) = (&self.orphans, &self.slot, &self.parent);
        for &i in &self.queue {
            let i = i as usize;
            if self.depth[i] < 2 {
                continue;
            }
            let p = parent[i];
            let pi = slot[p as usize] as usize;
            let pp = if parent[pi] != NONE {
                parent[pi]
            } else {
                // `p` is a separate piece's root: another of its orphan neighbours.
                let mut other = NONE;
                self.around.any(orphans[pi].0, &mut |c| {
                    other = c;
                    c != orphans[i].1 && slot[c as usize] != NONE
                });
                if other == NONE || other == orphans[i].1 || slot[other as usize] == NONE {
                    continue;
                }
                other
            };
            out.push([orphans[i].1, p, pp]);
        }
    }
}
