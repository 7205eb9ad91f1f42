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
    // The occupied 26-neighbours of the cell `key`, in a fixed order, until `f`
    // returns true (then true).
    let any_neighbour = |key: u64, f: &mut dyn FnMut(u32) -> bool| -> bool {
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
                        inside &= x >= 0 && x < i64::from(dims[k]);
                        d[k] = x.max(0) as u32;
                    }
                    if inside {
                        if let Some(id) = table.find(pack(d)) {
                            if occupied(id) && f(id) {
                                return true;
                            }
                        }
                    }
                }
            }
        }
        false
    };
    let m = orphans.len();
    let mut depth = vec![0u32; m];
    let mut parent = vec![NONE; m];
    let mut queue: Vec<u32> = Vec::with_capacity(m);
    for (i, &(key, _)) in orphans.iter().enumerate() {
        let mut first = NONE;
        if any_neighbour(key, &mut |c| {
            first = c;
            covered(c)
        }) {
            depth[i] = 1;
            parent[i] = first;
            queue.push(i as u32);
        }
    }
    // Depth-1 orphans whose representative is farther than `FAR` cells from every
    // covered neighbour's: the farthest `budget` of them.
    let far = FAR * cell;
    let dist = |p: [f32; 3], q: [f32; 3]| -> f64 {
        (0..3)
            .map(|k| (f64::from(p[k]) - f64::from(q[k])).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let mut near: Vec<(f64, [u32; 3])> = Vec::new();
    if budget > 0 {
        for &i in &queue {
            let (key, c) = orphans[i as usize];
            let p = pos(c);
            // The first covered neighbour found bounds the nearest.
            if dist(p, pos(parent[i as usize])) <= far {
                continue;
            }
            // The two nearest covered neighbours (by representative).
            let mut best = [(f64::INFINITY, NONE); 2];
            any_neighbour(key, &mut |n| {
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
    let mut out: Vec<[u32; 3]> = near.into_iter().map(|(_, t)| t).collect();
    // Usually every orphan touches the output's cells: nothing to repair.
    if queue.len() == m {
        return out;
    }
    let mut head = 0;
    let mut next_root = 0;
    loop {
        while head < queue.len() {
            let i = queue[head] as usize;
            head += 1;
            let (d, from) = (depth[i] + 1, orphans[i].1);
            any_neighbour(orphans[i].0, &mut |c| {
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
        while next_root < m && depth[next_root] != 0 {
            next_root += 1;
        }
        if next_root == m {
            break;
        }
        depth[next_root] = 1;
        queue.push(next_root as u32);
    }
    for &i in &queue {
        let i = i as usize;
        if depth[i] < 2 {
            continue;
        }
        let p = parent[i];
        let pi = slot[p as usize] as usize;
        let pp = if parent[pi] != NONE {
            parent[pi]
        } else {
            // `p` is a separate piece's root: another of its orphan neighbours.
            let mut other = NONE;
            any_neighbour(orphans[pi].0, &mut |c| {
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
    out
}
