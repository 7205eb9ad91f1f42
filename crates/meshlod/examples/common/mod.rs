//! Helpers shared by the same-process comparisons with meshoptimizer
//! (`cluster_ratio`, `qem_ratio`).

use meshlod::mesh::{Mesh, Weld};
use std::path::Path;

/// A mesh by short name (`bunny`, `fandisk`, `armadillo`, `lucy`, `turbine`, from
/// `../shared/meshes`) or by path (relative paths are taken from
/// `../shared/meshes`; absolute ones as they are).
///
/// # Panics
/// When the file cannot be read: these are measurement tools, not library code.
pub fn load(name: &str) -> Mesh {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes");
    let f = match name {
        "bunny" => "vtk-data/bunny.ply",
        "fandisk" => "common-3d-test-models/fandisk.obj",
        "armadillo" => "libigl-tutorial-data/armadillo.obj",
        "lucy" => "vtk-data/lucy.ply",
        "turbine" => "vtk-data/turbineblade.ply",
        other => other,
    };
    meshlod::read_mesh(shared.join(f)).expect("mesh")
}

/// The mesh welded exactly, as meshoptimizer wants it: indices and position bytes
/// (little-endian `f32` triples).
pub fn welded(m: &Mesh) -> (Vec<u32>, Vec<u8>) {
    let weld = Weld::exact(&m.positions);
    let indices: Vec<u32> = m
        .triangles
        .iter()
        .flat_map(|t| t.map(|v| weld.point_of[v as usize]))
        .collect();
    let bytes: Vec<u8> = weld
        .representative
        .iter()
        .flat_map(|&v| m.positions[v as usize])
        .flat_map(|x| x.to_le_bytes())
        .collect();
    (indices, bytes)
}
