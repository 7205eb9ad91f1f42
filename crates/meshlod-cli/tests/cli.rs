//! Runs the real `meshlod` binary: the `info` JSON contract on shipped meshes, and every
//! file of the malformed corpus `tests/data/bad/` giving a clean error (non-zero exit,
//! the file named, no panic).

mod common;
use common::meshlod;

use std::path::{Path, PathBuf};
use std::process::Command;

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data")
}

#[test]
fn every_bad_file_gives_a_clean_error() {
    let dir = data_dir().join("bad");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("tests/data/bad exists")
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|e| e != "py"))
        .collect();
    files.sort();
    assert!(
        files.len() >= 30,
        "corpus has {} files, need at least 30",
        files.len()
    );
    let mut failures = Vec::new();
    for f in &files {
        let out = meshlod(&["info", f.to_str().expect("utf-8 path")]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let name = f.file_name().unwrap().to_string_lossy();
        if out.status.success() {
            failures.push(format!("{name}: accepted (exit 0)"));
        } else if out.status.code() == Some(101) || stderr.contains("panicked") {
            failures.push(format!("{name}: panicked: {stderr}"));
        } else if !stderr.contains(name.as_ref()) {
            failures.push(format!("{name}: message does not name the file: {stderr}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn unknown_extension_and_missing_file_are_clear() {
    let out = meshlod(&["info", "no/such/file.obj"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no/such/file.obj"), "{err}");
    let out = meshlod(&["info", "Cargo.toml"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown mesh format"));
}

#[test]
fn info_json_has_the_contract_fields() {
    let cow = data_dir().join("cow.obj");
    let out = meshlod(&["info", cow.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    // The cow of Garland & Heckbert: 2,903 vertices, 5,804 triangles, closed, no
    // non-manifold edge, but one pinched vertex (two fans meet there): χ = V − E + F =
    // 2903 − 8706 + 5804 = 1, so it is not a manifold and has no genus.
    assert_eq!(v["vertices"], 2903);
    assert_eq!(v["triangles"], 5804);
    assert_eq!(v["boundary_edges"], 0);
    assert_eq!(v["non_manifold_edges"], 0);
    assert_eq!(v["non_manifold_vertices"], 1);
    assert_eq!(v["euler_characteristic"], 1);
    assert_eq!(v["components"], 1);
    assert!(v["genus"].is_null());
    assert_eq!(v["degenerate_triangles"], 0);
    assert_eq!(v["duplicate_triangles"], 0);
    let diag = v["bbox_diagonal"].as_f64().unwrap();
    // bbox (-4.446,-3.637,-1.701)..(5.998,2.76,1.701) per the manifest.
    let expect = (10.444f64.powi(2) + 6.397f64.powi(2) + 3.402f64.powi(2)).sqrt();
    assert!((diag - expect).abs() < 0.01, "diagonal {diag} vs {expect}");
}

#[test]
fn info_json_genus_of_a_closed_manifold_and_null_for_open_meshes() {
    // Spot: closed genus-0 manifold (Crane's README says so).
    let spot = data_dir().join("spot.obj");
    let out = meshlod(&["info", spot.to_str().unwrap(), "--json"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["genus"], 0);
    assert_eq!(v["euler_characteristic"], 2);

    let bunny = data_dir().join("stanford-bunny.obj");
    let out = meshlod(&["info", bunny.to_str().unwrap(), "--json"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["triangles"], 69451);
    assert_eq!(v["boundary_edges"], 223);
    assert!(v["genus"].is_null());
    assert_eq!(v["unreferenced_vertices"], 1113);
}

#[test]
fn measure_a_mesh_against_itself_and_write_a_heatmap() {
    let m = data_dir().join("stratocaster.ply");
    let dir = tempfile::tempdir().unwrap();
    let heat = dir.path().join("heat.ply");
    let out = meshlod(&[
        "measure",
        m.to_str().unwrap(),
        m.to_str().unwrap(),
        "--samples",
        "20000",
        "--json",
        "--heatmap",
        heat.to_str().unwrap(),
        "--screen-height",
        "1080",
        "--distance",
        "100",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // Coordinates up to ~340 in f32: sample-to-surface noise stays below 1e-5 units.
    assert!(v["hausdorff"].as_f64().unwrap() < 1e-5, "{v}");
    assert!(v["relative_to_bbox_diagonal"]["mean"].as_f64().unwrap() < 1e-8);
    // 4,500 vertices + 20,000 on edges + 20,000 on faces, each way.
    assert_eq!(v["a_to_b"]["samples"], 44_500);
    assert_eq!(v["samples"], 89_000);
    assert!(v["screen"]["distance_for_one_pixel"].as_f64().is_some());
    for key in ["mean", "rms", "bbox_diagonal"] {
        assert!(v[key].is_number(), "{key} missing");
    }
    let back = meshlod::read_mesh(&heat).unwrap();
    assert_eq!(back.positions.len(), 4500);
    assert!(back.attributes.colors.is_some());
}

#[test]
fn measure_reports_attribute_deviation_in_json() {
    // The Duck (UVs and normals) against itself: zero deviation, both directions.
    let duck = data_dir().join("Duck/Duck.gltf");
    let d = duck.to_str().unwrap();
    let out = meshlod(&["measure", d, d, "--samples", "20000", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ap = &v["appearance"];
    for key in ["uv", "normal_deg"] {
        assert!(ap[key]["max"].as_f64().unwrap() < 1e-4, "{key}: {ap}");
        assert!(ap[key]["mean"].as_f64().unwrap() < 1e-6, "{key}: {ap}");
        assert!(ap["a_to_b"][key]["samples"].as_u64().unwrap() > 20_000);
    }
    // No colours on the Duck: no colour entry.
    assert!(ap.get("color").is_none(), "{ap}");
    assert!(v["appearance_seconds"].is_number());
    // The geometric fields are unchanged.
    assert!(v["hausdorff"].as_f64().unwrap() < 1e-5);
    // Simplified, the deviation is positive; --no-appearance drops it.
    let dir = tempfile::tempdir().unwrap();
    let low = dir.path().join("duck.glb");
    let l = low.to_str().unwrap();
    let s = meshlod(&["simplify", d, "-o", l, "--ratio", "0.1"]);
    assert!(s.status.success(), "{}", String::from_utf8_lossy(&s.stderr));
    let out = meshlod(&["measure", d, l, "--samples", "20000", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let n = &v["appearance"]["normal_deg"];
    assert!(n["max"].as_f64().unwrap() > n["mean"].as_f64().unwrap());
    assert!(n["mean"].as_f64().unwrap() > 0.1, "{n}");
    let out = meshlod(&["measure", d, l, "--no-appearance", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v.get("appearance").is_none() && v["hausdorff"].is_number());
    let out = meshlod(&["measure", d, l, "--samples", "20000"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("normal (deg)") && text.contains("uv"),
        "{text}"
    );
}

#[test]
fn simplify_measure_adds_the_hausdorff_distance() {
    let cow = data_dir().join("cow.obj");
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("cow10.ply");
    let out = meshlod(&[
        "simplify",
        cow.to_str().unwrap(),
        "-o",
        out_path.to_str().unwrap(),
        "--ratio",
        "0.1",
        "--measure",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let h = v["hausdorff"].as_f64().expect("hausdorff with --measure");
    // A 10% cow is visibly coarser (well above float noise) but nowhere near a
    // tenth of the diagonal off.
    assert!(h > 1e-4 && h < 0.05, "hausdorff {h}");
    let m = &v["measure"];
    // Default sampling: at least 1,000,000 on edges and 1,000,000 on faces each way.
    assert!(m["a_to_b"]["samples"].as_u64().unwrap() >= 2_000_000);
    assert!(
        (m["hausdorff"].as_f64().unwrap() / m["bbox_diagonal"].as_f64().unwrap() - h).abs() < 1e-12
    );
}

/// Standard output closed before the report is printed (`meshlod info … | head`
/// where the reader has gone): the process ends with the broken-pipe status 141 and
/// no panic message, like other command-line tools.
#[test]
fn a_closed_stdout_ends_quietly() {
    use std::process::Stdio;
    let child = Command::new(env!("CARGO_BIN_EXE_meshlod"))
        .args([
            "info",
            data_dir().join("stanford-bunny.obj").to_str().unwrap(),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run meshlod");
    let mut child = child;
    // Close the read end now: reading the bunny takes far longer than this.
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("wait");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(141), "{stderr}");
}
