//! Terrain: height fields to triangulated irregular networks (TINs).
//!
//! - [`heightfield`]: readers for greyscale PNG, SRTM `.hgt`, ESRI ASCII grids and
//!   single-band GeoTIFF DEMs into a [`HeightField`];
//! - [`tin`]: greedy insertion with Delaunay updates (Garland & Heckbert 1995), every
//!   grid sample within a vertical error bound;
//! - [`tiles`]: square tiles with matching borders.
//!
//! A TIN becomes a [`Mesh`] in the *grid frame* by [`tin_to_mesh`]: `x` = column ×
//! cell size, `y` = row × cell size (row 0 is the file's first row, north for DEMs,
//! so `y` points south), `z` = height. Triangles are counter-clockwise in `x, y`
//! (normals up, `+z`). This is the frame of the grid meshes `make_terrain.py` writes,
//! so a TIN can be measured against them.

pub mod heightfield;
pub mod tiles;
pub mod tin;

pub use heightfield::{read_height_field, HeightField, HeightFieldError};
pub use tiles::{build_tiles, build_tin_blocked, Tile};
pub use tin::{build_tin, measure, Deviation, Tin, TinError, TinOptions};

use crate::Mesh;

/// The mesh of `tin` over `hf`, in the grid frame (module docs): positions in the
/// height field's horizontal units (cell size) and height units.
#[must_use]
pub fn tin_to_mesh(tin: &Tin, hf: &HeightField) -> Mesh {
    let cs = hf.cell_size;
    let positions = tin
        .points
        .iter()
        .map(|p| {
            [
                (f64::from(p[0]) * cs) as f32,
                (f64::from(p[1]) * cs) as f32,
                hf.heights[p[1] as usize * hf.width + p[0] as usize],
            ]
        })
        .collect();
    Mesh::from_triangles(positions, tin.triangles.clone())
}
