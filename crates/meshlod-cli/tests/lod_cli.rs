//! Runs the real `meshlod lod` and `meshlod lod select` in a temporary directory:
//! one file per level for mesh formats with the reported errors equal to what
//! `meshlod measure` says of those files, `MSFT_lod` glTF output, the selection's
//! levels growing coarser with distance, and bad options refused cleanly.

mod common;
use common::{meshlod, ok};

use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data")
        .join(name)
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// `meshlod dag build INPUT -o MDAG --json`, its report.
fn dag_build(input: &Path, mdag: &Path) -> serde_json::Value {
    ok(&meshlod(&[
        "dag",
        "build",
        s(input),
        "-o",
        s(mdag),
        "--json",
    ]))
}

/// `meshlod dag cut MDAG --camera CAMERA -o OUT --json EXTRA…`, its report.
fn dag_cut(mdag: &Path, camera: &str, out: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "dag",
        "cut",
        s(mdag),
        "--camera",
        camera,
        "-o",
        s(out),
        "--json",
    ];
    args.extend_from_slice(extra);
    ok(&meshlod(&args))
}

#[test]
fn levels_as_files_match_meshlod_measure() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("bunny.ply");
    let bunny = data("stanford-bunny.obj");
    let r = ok(&meshlod(&[
        "lod",
        s(&bunny),
        "-o",
        s(&out),
        "--ratios",
        "0.5,0.1,0.02",
        "--samples",
        "20000",
        "--json",
    ]));
    let levels = r["levels"].as_array().expect("levels");
    assert_eq!(levels.len(), 4);
    for key in [
        "level",
        "triangles",
        "vertices",
        "error_max",
        "error_mean",
        "switch_distance",
        "screen_coverage",
    ] {
        assert!(levels.iter().all(|l| l.get(key).is_some()), "{key} missing");
    }
    for (k, l) in levels.iter().enumerate().skip(1) {
        let file = dir.path().join(format!("bunny-lod{k}.ply"));
        assert!(file.is_file(), "{} missing", file.display());
        let m = ok(&meshlod(&[
            "measure",
            s(&dir.path().join("bunny-lod0.ply")),
            s(&file),
            "--samples",
            "20000",
            "--json",
        ]));
        let reported = l["error_max"].as_f64().expect("error_max");
        let measured = m["hausdorff"].as_f64().expect("hausdorff");
        assert!(
            (reported - measured).abs() <= 1e-12 * measured.max(1e-30),
            "LOD{k}: reported {reported}, measure says {measured}"
        );
        let prev = &levels[k - 1];
        assert!(l["triangles"].as_u64() < prev["triangles"].as_u64());
        assert!(l["error_max"].as_f64() > prev["error_max"].as_f64());
    }
}

#[test]
fn gltf_chain_and_selection() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("duck.glb");
    let r = ok(&meshlod(&[
        "lod",
        s(&data("Duck/Duck.gltf")),
        "-o",
        s(&out),
        "--levels",
        "3",
        "--geomorph",
        "--json",
    ]));
    let meshes = r["meshes"].as_array().expect("meshes");
    assert_eq!(meshes.len(), 1);
    let n = meshes[0]["levels"].as_array().expect("levels").len();
    assert!(n >= 3, "only {n} levels: {:?}", meshes[0]["stopped_early"]);
    // Walking the camera away along +z: the level never gets finer and ends at the
    // coarsest; near the object it is LOD0.
    let mut last = 0;
    for d in [1.0, 100.0, 300.0, 1e3, 3e3, 1e4, 1e5, 1e7] {
        let camera = format!("0,0,{d}");
        let sel = ok(&meshlod(&[
            "lod",
            "select",
            s(&out),
            "--camera",
            &camera,
            "--json",
        ]));
        let level = sel["objects"][0]["level"].as_u64().expect("level") as usize;
        assert!(level >= last, "at {d}: level {level} after {last}");
        let px = sel["objects"][0]["pixels"].as_f64().expect("pixels");
        assert!(px <= 1.0 + 1e-9, "at {d}: {px} px over the budget");
        last = level;
    }
    assert_eq!(last, n - 1);
}

#[test]
fn bad_lod_options_are_clean_errors() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("x.ply");
    let bunny = data("stanford-bunny.obj");
    for args in [
        vec!["--ratios", "0.5,0.7"],
        vec!["--ratios", "1.5"],
        vec!["--levels", "0"],
        vec!["--fov", "0"],
        vec!["--pixel-error", "-1"],
        vec!["--method", "cluster", "--geomorph"],
    ] {
        let mut all = vec!["lod", s(&bunny), "-o", s(&out)];
        all.extend(&args);
        let o = meshlod(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("error"), "{args:?}: {err}");
    }
    // `lod select` on a file without chains names the file.
    let o = meshlod(&[
        "lod",
        "select",
        s(&data("Duck/Duck.gltf")),
        "--camera",
        "0,0,1",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("Duck.gltf"));
}

#[test]
fn dag_build_and_cut() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mdag = dir.path().join("bunny.mdag");
    let r = dag_build(&data("stanford-bunny.obj"), &mdag);
    assert_eq!(r["triangles"].as_u64(), Some(69_451));
    assert!(r["roots"].as_u64().expect("roots") >= 1);
    let mut last = u64::MAX;
    for z in ["0.3", "1", "10", "1000"] {
        let out = dir.path().join(format!("cut-{z}.ply"));
        let c = dag_cut(&mdag, &format!("0,0.1,{z}"), &out, &[]);
        let n = c["triangles"].as_u64().expect("triangles");
        assert!(n <= last && n > 0, "at z = {z}: {n} after {last}");
        last = n;
        let info = ok(&meshlod(&["info", s(&out), "--json"]));
        assert_eq!(info["triangles"].as_u64(), Some(n));
    }
    // Looking at the bunny from close with a narrow view: no more triangles than
    // without a target; culled, fewer clusters; looking away, the coarsest cut.
    let t = dir.path().join("t.ply");
    let cut = |extra: &[&str]| dag_cut(&mdag, "0,0.1,0.3", &t, extra);
    let all = cut(&["--fov", "10"]);
    let aimed = cut(&["--fov", "10", "--target", "0.05,0.15,0"]);
    let culled = cut(&["--fov", "10", "--target", "0.05,0.15,0", "--cull"]);
    let away = cut(&["--target", "0,0.1,1"]);
    let n = |r: &serde_json::Value| r["triangles"].as_u64().expect("triangles");
    assert!(n(&aimed) <= n(&all), "{aimed} vs {all}");
    assert!(n(&culled) < n(&aimed), "{culled} vs {aimed}");
    assert!(culled["culled_clusters"].as_u64().expect("culled") > 0);
    assert!(n(&away) < n(&aimed), "{away} vs {aimed}");
    // A target at the camera gives no direction; --cull needs a target; a width
    // must be positive.
    for extra in [
        &["--target", "0,0.1,0.3"][..],
        &["--cull"][..],
        &["--width", "0"][..],
    ] {
        let mut args = vec!["dag", "cut", s(&mdag), "--camera", "0,0.1,0.3", "-o"];
        let o = dir.path().join("u.ply");
        args.push(s(&o));
        args.extend_from_slice(extra);
        assert_ne!(meshlod(&args).status.code(), Some(0), "{extra:?}");
    }
    // A damaged file is a clean error naming it.
    let bad = dir.path().join("bad.mdag");
    let bytes = std::fs::read(&mdag).expect("read");
    std::fs::write(&bad, &bytes[..bytes.len() / 2]).expect("write");
    let o = meshlod(&[
        "dag",
        "cut",
        s(&bad),
        "--camera",
        "0,0,1",
        "-o",
        s(&dir.path().join("x.ply")),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.mdag") && err.contains("byte "), "{err}");
}

#[test]
fn dag_cuts_keep_uvs_and_groups() {
    // The textured cow: its UVs reach every cut, written as a glTF binary.
    let dir = tempfile::tempdir().expect("tempdir");
    let mdag = dir.path().join("spot.mdag");
    let spot = data("spot.obj");
    dag_build(&spot, &mdag);
    for z in ["1", "100"] {
        let out = dir.path().join(format!("cut-{z}.glb"));
        let c = dag_cut(&mdag, &format!("0,0.2,{z}"), &out, &[]);
        assert_eq!(c["attributes"], serde_json::json!(["uv0"]), "{c}");
        let info = ok(&meshlod(&["info", s(&out), "--json"]));
        assert_eq!(info["attributes"], serde_json::json!(["uv0"]), "{info}");
        assert_eq!(info["triangles"], c["triangles"]);
        // Closed once welded: the seams did not open.
        assert_eq!(info["boundary_edges"].as_u64(), Some(0), "{info}");
    }
}
