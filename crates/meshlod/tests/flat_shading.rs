//! Flat-shaded input (`SimplifyOptions::reshade_flat`): the repository's meshes
//! written the way a flat-shaded exporter writes them — every triangle's corners
//! split off and given the triangle's normal, UVs kept — simplify to their target
//! like the smooth originals (without the re-shading no point could move), with
//! every output corner carrying its triangle's own normal, no new border or
//! non-manifold edge, no degenerate or duplicate triangle, and a Hausdorff distance
//! close to the smooth run's.

mod common;

use meshlod::io::read_scene;
use meshlod::mesh::MeshStats;
use meshlod::simplify::{simplify, Method, SimplifyOptions, StopReason};
use meshlod::Mesh;

/// `mesh` flat shaded: three vertices per triangle, each with the triangle's unit
/// normal and the corner's other attributes.
fn flat_shaded(mesh: &Mesh) -> Mesh {
    let corners: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let mut attributes = mesh.attributes.gather(&corners);
    attributes.normals = Some(
        mesh.triangles
            .iter()
            .flat_map(|&t| {
                let n = common::normal(mesh, t);
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                let u = if l > 0.0 {
                    n.map(|c| (c / l) as f32)
                } else {
                    [0.0, 0.0, 1.0]
                };
                [u; 3]
            })
            .collect(),
    );
    Mesh {
        positions: corners
            .iter()
            .map(|&v| mesh.positions[v as usize])
            .collect(),
        triangles: (0..mesh.triangles.len() as u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect(),
        attributes,
        groups: mesh.groups.clone(),
        group_names: mesh.group_names.clone(),
    }
}

/// A test mesh from `tests/data`, and the same flat shaded.
fn smooth_and_flat(file: &str) -> (Mesh, Mesh) {
    let smooth = read_scene(common::data_dir().join(file))
        .expect("test mesh reads")
        .flatten();
    let flat = flat_shaded(&smooth);
    (smooth, flat)
}

/// Every corner's normal is its triangle's geometric unit normal.
fn assert_facet_normals(name: &str, m: &Mesh) {
    let normals = m.attributes.normals.as_ref().expect("normals written");
    for &t in &m.triangles {
        let g = common::normal(m, t);
        let l = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        assert!(l > 0.0, "{name}: degenerate output triangle");
        for v in t {
            let n = normals[v as usize].map(f64::from);
            let dot = (0..3).map(|k| n[k] * g[k] / l).sum::<f64>();
            assert!(dot > 0.9999, "{name}: corner normal off its facet ({dot})");
        }
    }
}

#[test]
fn flat_shaded_meshes_simplify_like_smooth_ones() {
    for file in ["stanford-bunny.obj", "fandisk.obj", "spot.obj"] {
        let (smooth, flat) = smooth_and_flat(file);
        let input_topology = MeshStats::of(&smooth).topology;
        for (method, ratio) in [
            (Method::Qem, 0.1),
            (Method::Qem, 0.01),
            (Method::VertexRemoval, 0.1),
            (Method::Melax, 0.1),
        ] {
            let name = format!("{file} {} @ {ratio}", method.name());
            let options = SimplifyOptions::default()
                .with_method(method)
                .with_ratio(ratio);
            let (out, report) = simplify(&flat, &options).expect("simplifies");
            assert!(report.flat_shading, "{name}: not detected");
            assert_eq!(report.vertices_in, flat.positions.len(), "{name}");
            assert_eq!(report.vertices_out, out.positions.len(), "{name}");
            let target = report.target_triangles as f64;
            assert!(
                (out.triangles.len() as f64 - target).abs() <= 0.01 * target + 1.0,
                "{name}: {} triangles for a target of {target} ({:?}: {})",
                out.triangles.len(),
                report.stop_reason,
                report.stop_detail
            );
            assert_eq!(report.stop_reason, StopReason::TargetReached, "{name}");
            assert_facet_normals(&name, &out);
            assert_eq!(
                out.attributes.uv0.is_some(),
                smooth.attributes.uv0.is_some(),
                "{name}: UVs"
            );
            let st = MeshStats::of(&out).topology;
            assert!(
                st.boundary_edges <= input_topology.boundary_edges,
                "{name}: new border edges"
            );
            assert_eq!(st.non_manifold_edges, 0, "{name}");
            assert_eq!(st.degenerate_triangles, 0, "{name}");
            assert_eq!(st.duplicate_triangles, 0, "{name}");
            // As good as the smooth mesh's run (the same points and seams, another
            // vertex numbering): the distances within a fifth of it.
            let (reference, _) = simplify(&smooth, &options).expect("simplifies");
            let (d_smooth, d_flat, line) =
                common::distances_before_after(&smooth, &reference, &out);
            eprintln!("{name}: smooth -> flat: {line}");
            assert!(d_flat.mean <= 1.2 * d_smooth.mean, "{name}: mean");
            assert!(d_flat.hausdorff <= 1.5 * d_smooth.hausdorff, "{name}: max");
        }
    }
}

#[test]
fn without_the_reshading_a_flat_mesh_moves_by_its_junctions() {
    // The bunny has no two coplanar neighbours, so every point is a seam junction
    // (fandisk's planar patches would share normals). Junctions slide along their
    // seams, so even kept as seams the normals no longer freeze the run: it reaches
    // the target (the re-shading stays the better path: fewer seams to keep).
    let (_, flat) = smooth_and_flat("stanford-bunny.obj");
    let options = SimplifyOptions::default()
        .with_ratio(0.1)
        .with_reshade_flat(false);
    let (out, report) = simplify(&flat, &options).expect("simplifies");
    assert!(!report.flat_shading);
    assert_eq!(report.stop_reason, StopReason::TargetReached);
    assert!(out.triangles.len() <= flat.triangles.len() / 10 + flat.triangles.len() / 1000 + 1);
}

#[test]
fn locked_vertices_stay_locked_through_the_merge() {
    // Lock every corner of the first 50 input triangles: their points must come
    // out where they were.
    let (_, flat) = smooth_and_flat("fandisk.obj");
    let mut mask = vec![false; flat.positions.len()];
    mask[..150].iter_mut().for_each(|m| *m = true);
    let options = SimplifyOptions::default()
        .with_ratio(0.1)
        .with_locked_vertices(mask);
    let (out, report) = simplify(&flat, &options).expect("simplifies");
    assert!(report.flat_shading);
    let kept: std::collections::HashSet<[u32; 3]> =
        out.positions.iter().map(|p| p.map(f32::to_bits)).collect();
    for p in &flat.positions[..150] {
        assert!(kept.contains(&p.map(f32::to_bits)), "a locked point moved");
    }
}
