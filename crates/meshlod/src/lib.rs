//! # meshlod
//!
//! Mesh simplification (decimation) and level of detail, in one toolkit: quadric error
//! metrics (Garland & Heckbert 1997), Melax edge-cost half-edge collapse and progressive
//! meshes (Hoppe 1996), Schroeder vertex decimation (Schroeder, Zarge & Lorensen 1992),
//! vertex clustering (Rossignac & Borrel 1993; Lindstrom 2000), and Metro-class error
//! measurement (Cignoni, Rocchini & Scopigno 1998).
//!
//! The crate is organised by domain nouns:
//! - [`mesh`]: the in-memory [`Mesh`], welding, connectivity, statistics, and the
//!   [`mesh::Distance`] (mesh units or relative to the diagonal) the options take;
//! - [`io`]: OBJ, PLY, STL, OFF, glTF/GLB and Hoppe `.m` readers and writers;
//! - [`metrics`]: closest points (BVH), Hausdorff / mean / RMS distances, screen-space error;
//! - [`simplify()`]: the public simplification entry point (QEM edge collapse, vertex
//!   removal);
//! - [`quadric`]: quadric error metrics;
//! - [`collapse`]: the edge-collapse operator and its legality checks;
//! - [`cost`]: cost models (what to collapse first); [`filter`]: vetoes;
//! - [`decimate`]: the drivers (priority queue, stop rules, reports, observers);
//! - [`lod`]: progressive meshes (vertex splits, `.pmesh` files, navigation, geomorphs);
//! - [`terrain`]: height fields (PNG, SRTM `.hgt`, ESRI `.asc`, GeoTIFF) to triangulated
//!   irregular networks within a vertical bound (Garland & Heckbert 1995), and tiles.
//! - [`render`]: pictures on the CPU (z-buffer rasterizer, heat maps, PNG).

pub mod collapse;
pub mod cost;
pub mod decimate;
pub mod filter;
pub mod io;
mod isa;
pub mod lod;
pub mod mesh;
pub mod metrics;
pub mod quadric;
mod radix;
pub mod render;
pub mod simplify;
pub mod terrain;

pub use io::{read_mesh, read_scene, write_mesh, write_scene, Scene};
pub use mesh::{Mesh, MeshStats};
pub use simplify::{simplify, Report, SimplifyError, SimplifyOptions};
