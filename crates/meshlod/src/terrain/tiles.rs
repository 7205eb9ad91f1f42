//! Square TIN tiles whose shared borders match exactly (no cracks).
//!
//! The grid is cut into tiles of `T × T` samples that share their border rows and
//! columns (a stride of `T − 1`; the last row and column of tiles may be smaller).
//! Each border segment (a tile side, between two tile corners) is first simplified on
//! its own, in one dimension: greedy insertion of the sample farthest (vertically)
//! from the polyline of the samples kept so far, until every sample of the segment is
//! within the bound (the 1D case of Garland & Heckbert 1995; the same as Douglas &
//! Peucker 1973 with vertical distance). The segment's kept samples are computed
//! once and given to both tiles beside it. Each tile is then triangulated by
//! [`super::tin::build_tin_region`] seeded with its four sides' samples and its
//! border frozen: the tile's border edges are exactly the segment's polyline, so
//! neighbours share every border vertex and edge, and the bound holds on the border
//! (by the 1D pass) and inside (by the 2D pass).
//!
//! Tiles are independent once their borders are known, and are built in parallel;
//! the output does not depend on the number of threads. The 1D pass rescans a
//! segment's samples between its kept neighbours at each split: `O(T log T)` for a
//! segment of `T` samples typically, `O(T²)` at worst (a tile side, not the grid).
//!
//! [`build_tin_blocked`] uses the same tiles as blocks of one TIN, merged.

use super::tin::{build_tin_region, Region, Seeding, Tin, TinError, TinOptions};
use rayon::prelude::*;

/// One tile: its place in the tile grid, its samples and its TIN.
#[derive(Debug, Clone, PartialEq)]
pub struct Tile {
    /// Tile column (0 at the first grid column).
    pub x: usize,
    /// Tile row (0 at the first grid row).
    pub y: usize,
    /// The samples it covers (inclusive), sharing its border with its neighbours.
    pub region: Region,
    /// Its TIN, in global grid coordinates.
    pub tin: Tin,
}

/// Starts of the tiles along one axis of `n` samples, stride `t − 1`, and the end.
fn cuts(n: usize, t: usize) -> Vec<u32> {
    let step = t - 1;
    let mut c: Vec<u32> = (0..n - 1).step_by(step).map(|s| s as u32).collect();
    c.push((n - 1) as u32);
    c
}

/// The samples kept on a border segment: indices into `h` (a polyline of heights),
/// both ends included, such that linear interpolation between kept samples is within
/// `e` of every sample.
#[must_use]
pub fn simplify_polyline(h: &[f32], e: f64) -> Vec<usize> {
    let n = h.len();
    let mut keep = vec![false; n];
    if n == 0 {
        return Vec::new();
    }
    keep[0] = true;
    keep[n - 1] = true;
    let mut stack = vec![(0usize, n - 1)];
    while let Some((a, b)) = stack.pop() {
        let (za, zb) = (f64::from(h[a]), f64::from(h[b]));
        let (mut worst, mut at) = (e, None);
        for (k, &z) in h.iter().enumerate().take(b).skip(a + 1) {
            let t = (k - a) as f64 / (b - a) as f64;
            let d = (f64::from(z) - (za + t * (zb - za))).abs();
            if d > worst {
                (worst, at) = (d, Some(k));
            }
        }
        if let Some(k) = at {
            keep[k] = true;
            stack.push((a, k));
            stack.push((k, b));
        }
    }
    (0..n).filter(|&i| keep[i]).collect()
}

/// Cuts the `width × height` grid into tiles of `tile_size` samples a side and
/// triangulates each within `options.max_error` (see the module docs). Tiles come in
/// row-major order.
///
/// # Errors
/// [`TinError`] as [`super::tin::build_tin`]; [`TinError::BadRegion`] when
/// `tile_size < 2`.
pub fn build_tiles(
    heights: &[f32],
    width: usize,
    height: usize,
    tile_size: usize,
    options: &TinOptions,
) -> Result<Vec<Tile>, TinError> {
    let full = Region {
        x0: 0,
        y0: 0,
        x1: width.saturating_sub(1) as u32,
        y1: height.saturating_sub(1) as u32,
    };
    if tile_size < 2 || width < 2 || height < 2 || heights.len() != width * height {
        return Err(TinError::BadRegion(full, width, height));
    }
    let (xs, ys) = (cuts(width, tile_size), cuts(height, tile_size));
    let e = options.max_error;
    // Vertical segments: column xs[i], rows ys[j]..=ys[j+1]; horizontal: row ys[j],
    // columns xs[i]..=xs[i+1]. Kept points in global coordinates.
    let vertical: Vec<Vec<[u32; 2]>> = (0..xs.len() * (ys.len() - 1))
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % xs.len(), k / xs.len());
            let (x, y0, y1) = (xs[i], ys[j], ys[j + 1]);
            let line: Vec<f32> = (y0..=y1)
                .map(|y| heights[y as usize * width + x as usize])
                .collect();
            simplify_polyline(&line, e)
                .into_iter()
                .map(|d| [x, y0 + d as u32])
                .collect()
        })
        .collect();
    let horizontal: Vec<Vec<[u32; 2]>> = (0..(xs.len() - 1) * ys.len())
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % (xs.len() - 1), k / (xs.len() - 1));
            let (y, x0, x1) = (ys[j], xs[i], xs[i + 1]);
            let row = &heights[y as usize * width..][x0 as usize..=x1 as usize];
            simplify_polyline(row, e)
                .into_iter()
                .map(|d| [x0 + d as u32, y])
                .collect()
        })
        .collect();
    let (nx, ny) = (xs.len() - 1, ys.len() - 1);
    (0..nx * ny)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % nx, k / nx);
            let region = Region {
                x0: xs[i],
                y0: ys[j],
                x1: xs[i + 1],
                y1: ys[j + 1],
            };
            let mut seeds = Vec::new();
            seeds.extend_from_slice(&horizontal[j * nx + i]);
            seeds.extend_from_slice(&horizontal[(j + 1) * nx + i]);
            seeds.extend_from_slice(&vertical[j * xs.len() + i]);
            seeds.extend_from_slice(&vertical[j * xs.len() + i + 1]);
            let seeding = Seeding {
                region,
                seeds: &seeds,
                frozen_border: true,
            };
            let tin = build_tin_region(heights, width, height, seeding, options, None)?;
            Ok(Tile {
                x: i,
                y: j,
                region,
                tin,
            })
        })
        .collect()
}

/// One TIN of the whole grid built as blocks: the tiles of [`build_tiles`] (blocks of
/// `block` samples a side, crack-free borders) merged into one triangulation, the
/// vertices on shared borders joined. Every sample stays within `options.max_error`.
///
/// Against [`super::tin::build_tin`] on the whole grid at once: about the same
/// triangle count (the block borders are simplified in 1D, then frozen), and about
/// twice as fast on one thread on large grids (the first insertions of a whole-grid
/// run rescan the whole grid; a block's working set stays in cache), faster again on
/// several threads. The output does not depend on the thread count.
///
/// # Errors
/// As [`build_tiles`].
pub fn build_tin_blocked(
    heights: &[f32],
    width: usize,
    height: usize,
    block: usize,
    options: &TinOptions,
) -> Result<Tin, TinError> {
    let tiles = build_tiles(heights, width, height, block, options)?;
    let mut id = std::collections::HashMap::new();
    let mut points = Vec::new();
    let mut triangles = Vec::new();
    let mut max_error = 0.0f64;
    for tile in &tiles {
        let tin = &tile.tin;
        max_error = max_error.max(tin.max_error);
        let map: Vec<u32> = tin
            .points
            .iter()
            .map(|&p| {
                *id.entry(p).or_insert_with(|| {
                    points.push(p);
                    (points.len() - 1) as u32
                })
            })
            .collect();
        triangles.extend(tin.triangles.iter().map(|t| t.map(|v| map[v as usize])));
    }
    Ok(Tin {
        points,
        triangles,
        max_error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cuts_share_borders() {
        assert_eq!(cuts(9, 5), vec![0, 4, 8]);
        assert_eq!(cuts(10, 5), vec![0, 4, 8, 9]);
        assert_eq!(cuts(3, 5), vec![0, 2]);
    }

    #[test]
    fn polyline_keeps_the_peak() {
        // A tent: 0 1 2 3 2 1 0. Only the peak is needed for error 0.
        let h = [0.0, 1.0, 2.0, 3.0, 2.0, 1.0, 0.0];
        assert_eq!(simplify_polyline(&h, 0.0), vec![0, 3, 6]);
        // Within 3 the ends alone do.
        assert_eq!(simplify_polyline(&h, 3.0), vec![0, 6]);
    }
}
