//! Every mesh of the shared set (`../shared/meshes/MANIFEST.md`) loads and `MeshStats`
//! agree with the manifest: triangles, and the welded boundary edges, non-manifold edges
//! and components. The meshopt-compressed `pirate.glb` must be refused with a clear
//! message. Skips with a notice where `../shared` is absent.

mod common;

use meshlod::io::read_scene;
use meshlod::mesh::MeshStats;

#[test]
fn manifest_counts_match() {
    let Some(shared) = common::shared_meshes("manifest_counts_match") else {
        return;
    };
    let rows = common::manifest_rows(&shared);
    assert!(
        rows.len() >= 30,
        "manifest table parsed: {} rows",
        rows.len()
    );
    let mut failures = Vec::new();
    for row in &rows {
        let path = shared.join(&row.file);
        let result = read_scene(&path);
        if row.notes.contains("EXT_meshopt_compression") {
            match result {
                Ok(_) => failures.push(format!("{}: compressed glTF was not refused", row.file)),
                Err(e) => {
                    let msg = e.to_string();
                    if !msg.contains("EXT_meshopt_compression") || !msg.contains("pirate.glb") {
                        failures.push(format!("{}: unclear refusal: {msg}", row.file));
                    }
                }
            }
            continue;
        }
        let scene = match result {
            Ok(s) => s,
            Err(e) => {
                failures.push(format!("{}: {e}", row.file));
                continue;
            }
        };
        let mesh = scene.flatten();
        let s = MeshStats::of(&mesh);
        let mut check = |what: &str, ours: usize, theirs: Option<usize>| {
            if let Some(t) = theirs {
                if ours != t {
                    failures.push(format!("{}: {what} ours {ours} manifest {t}", row.file));
                }
            }
        };
        check("triangles", s.triangles, row.triangles);
        check(
            "boundary edges",
            s.topology.boundary_edges,
            row.boundary_welded,
        );
        check(
            "non-manifold edges",
            s.topology.non_manifold_edges,
            row.non_manifold_welded,
        );
        check("components", s.topology.components, row.components_welded);
        // Stored vertices equal V only where no attribute splits them into wedges.
        let is_gltf = row.file.ends_with(".gltf") || row.file.ends_with(".glb");
        if !is_gltf && row.attrs == "-" {
            check("vertices", s.vertices, row.vertices);
        }
    }
    assert!(
        failures.is_empty(),
        "{} mismatches:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
