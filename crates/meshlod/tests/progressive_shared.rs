//! Progressive meshes on the shared mesh set (`../shared/meshes`): on every mesh
//! that is manifold or has plain boundaries (no non-manifold edge after welding),
//! refining the base with every split reproduces the repaired input exactly
//! (positions and attributes bit for bit, triangles up to vertex order and
//! rotation); the `.pmesh` bytes decode back to the same structure; extracting a
//! triangle count equals simplifying straight to it with the same method; and cuts of
//! the file at split boundaries decode to valid meshes.
//!
//! "Repaired input" is what `simplify` returns at ratio 1: positions welded by exact
//! equality, degenerate and duplicate triangles and unreferenced vertices dropped.
//! Skips with a notice where `../shared` is absent.

mod common;

use meshlod::cost::Placement;
use meshlod::io::read_scene;
use meshlod::lod::{Navigator, ProgressiveMesh};
use meshlod::mesh::{Mesh, MeshStats};
use meshlod::simplify::{simplify, Method, SimplifyOptions};

fn corner_key(m: &Mesh, v: u32, group: u32) -> Vec<u32> {
    let v = v as usize;
    let a = &m.attributes;
    let mut k: Vec<u32> = m.positions[v].iter().map(|x| x.to_bits()).collect();
    let mut f = |s: &[f32]| k.extend(s.iter().map(|x| x.to_bits()));
    if let Some(s) = &a.normals {
        f(&s[v]);
    }
    if let Some(s) = &a.tangents {
        f(&s[v]);
    }
    if let Some(s) = &a.uv0 {
        f(&s[v]);
    }
    if let Some(s) = &a.uv1 {
        f(&s[v]);
    }
    if let Some(s) = &a.colors {
        f(&s[v]);
    }
    k.push(group);
    k
}

/// Sorted triangles of corner keys, each rotated to its smallest corner.
fn canonical(m: &Mesh) -> Vec<[Vec<u32>; 3]> {
    let mut out: Vec<[Vec<u32>; 3]> = m
        .triangles
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let k = t.map(|v| corner_key(m, v, m.group(i)));
            let r = (0..3).min_by(|&a, &b| k[a].cmp(&k[b])).unwrap_or(0);
            [k[r].clone(), k[(r + 1) % 3].clone(), k[(r + 2) % 3].clone()]
        })
        .collect();
    out.sort();
    out
}

#[test]
fn progressive_meshes_reproduce_the_shared_set() {
    let Some(shared) = common::shared_meshes("progressive_meshes_reproduce_the_shared_set") else {
        return;
    };
    let mut failures = Vec::new();
    let mut done = Vec::new();
    // Extraction and file-cut checks on a few meshes (each costs simplifications).
    let deep = ["fandisk.obj", "spot.obj", "camelhead.off", "cessna.orig.m"];
    for row in common::manifest_rows(&shared) {
        if row.non_manifold_welded != Some(0) {
            continue;
        }
        let Ok(scene) = read_scene(shared.join(&row.file)) else {
            continue;
        };
        let mesh = scene.flatten();
        if mesh.triangles.len() > 120_000 || mesh.triangles.is_empty() {
            continue;
        }
        let (repaired, _) = simplify(&mesh, &SimplifyOptions::default().with_ratio(1.0)).unwrap();
        let want = canonical(&repaired);
        let is_deep = deep.iter().any(|d| row.file.ends_with(d));
        let methods: &[(&str, SimplifyOptions)] = &[
            (
                "melax",
                SimplifyOptions::default()
                    .with_method(Method::Melax)
                    .with_facing_repair(false),
            ),
            (
                "qem",
                SimplifyOptions::default()
                    .with_placement(Placement::Endpoint)
                    .with_facing_repair(false),
            ),
        ];
        for (name, o) in methods {
            // QEM on the small ones only (the Melax run covers the big ones).
            if *name == "qem" && mesh.triangles.len() > 30_000 && !is_deep {
                continue;
            }
            let tag = format!("{} ({name})", row.file);
            let (pm, _) = match ProgressiveMesh::build(&mesh, &o.clone().with_target_triangles(0)) {
                Ok(x) => x,
                Err(e) => {
                    failures.push(format!("{tag}: {e}"));
                    continue;
                }
            };
            let mut nav = Navigator::new(&pm);
            if canonical(&nav.to_mesh()) != want {
                failures.push(format!(
                    "{tag}: finest level differs from the repaired input"
                ));
            }
            let bytes = pm.to_bytes();
            match ProgressiveMesh::from_bytes(&bytes) {
                Ok(d) if d.pm == pm && d.complete => {}
                Ok(_) => failures.push(format!("{tag}: .pmesh round trip differs")),
                Err(e) => failures.push(format!("{tag}: {e}")),
            }
            if !is_deep {
                continue;
            }
            let n0 = repaired.triangles.len();
            for target in [n0 / 10, n0 / 100] {
                let (direct, _) =
                    simplify(&mesh, &o.clone().with_target_triangles(target)).unwrap();
                nav.set_triangles(target);
                if canonical(&nav.to_mesh()) != canonical(&direct) {
                    failures.push(format!("{tag}: extracting {target} differs from simplify"));
                }
            }
            // Cut the file at a few split boundaries (found by the partial decoder):
            // valid meshes, the right prefix.
            let d = ProgressiveMesh::from_bytes(&bytes).unwrap();
            let mut ends = Vec::new();
            for f in [0.0, 0.3, 0.7] {
                let cut = ((f * bytes.len() as f64) as usize).max(1);
                if let Ok(p) = ProgressiveMesh::from_bytes_partial(&bytes[..cut]) {
                    ends.push(p.bytes_used);
                }
            }
            for e in ends {
                match ProgressiveMesh::from_bytes(&bytes[..e]) {
                    Ok(p) => {
                        let k = p.pm.split_count();
                        let m = p.pm.mesh_at(k);
                        let s = MeshStats::of(&m);
                        if m.validate().is_err() || s.topology.degenerate_triangles > 0 {
                            failures.push(format!("{tag}: prefix of {k} splits is invalid"));
                        }
                        if canonical(&m) != canonical(&d.pm.mesh_at(k)) {
                            failures.push(format!("{tag}: prefix of {k} splits differs"));
                        }
                    }
                    Err(e) => failures.push(format!("{tag}: cut at a split boundary: {e}")),
                }
            }
        }
        done.push(row.file.clone());
    }
    eprintln!("checked {} meshes: {}", done.len(), done.join(", "));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
