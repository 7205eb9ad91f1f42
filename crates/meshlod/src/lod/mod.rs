//! Level of detail: discrete LOD chains with screen-space selection ([`chain`]), and
//! progressive meshes (Hoppe, "Progressive Meshes", SIGGRAPH 1996).
//!
//! View-dependent level of detail is a cluster hierarchy ([`dag`]) whose cut for a
//! camera is crack-free.
//!
//! A [`Chain`] is LOD0 and coarser meshes each simplified from the one before, with
//! its measured error and the distance at which that error projects to a pixel
//! budget; [`select`] picks the level of each object for a camera.
//!
//! A [`ProgressiveMesh`] is a coarse base mesh plus the ordered vertex splits that
//! undo, one at a time, the half-edge collapses a simplification run performed
//! (Melax's cost, or QEM restricted to endpoints). Every prefix of the splits is a
//! valid mesh: this is what the `.pmesh` format ([`write_pmesh`], [`read_pmesh`]) streams, and what the
//! [`Navigator`] moves through in both directions in time proportional to the
//! number of splits applied.

pub mod chain;
pub mod dag;
mod pmesh;
mod progressive;

pub use chain::{
    build_chain, select, select_level, Chain, ChainOptions, Level, LevelSpec, LodError, LodObject,
    Screen, View,
};
pub use pmesh::{read_pmesh, write_pmesh, Decoded, PMESH_MAGIC, PMESH_VERSION};
pub use progressive::{Navigator, PmError, ProgressiveMesh, VertexSplit};

#[cfg(test)]
mod tests;
