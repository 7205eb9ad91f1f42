//! Runs the real `meshlod terrain`: the JSON contract, the written mesh matching the
//! report, the tile files and their index, and clean errors on bad height fields.

use std::path::Path;
use std::process::{Command, Output};

fn meshlod(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_meshlod"))
        .args(args)
        .output()
        .expect("run meshlod")
}

/// An ESRI ASCII grid of `w × h` hills, cell size 10, one void.
fn write_asc(path: &Path, w: usize, h: usize) {
    let mut s = format!(
        "ncols {w}\nnrows {h}\nxllcorner 500\nyllcorner 1000\ncellsize 10\nNODATA_value -9999\n"
    );
    for y in 0..h {
        let row: Vec<String> = (0..w)
            .map(|x| {
                if (x, y) == (3, 4) {
                    "-9999".to_string()
                } else {
                    let (fx, fy) = (x as f64, y as f64);
                    format!(
                        "{:.2}",
                        20.0 * (0.21 * fx).sin() * (0.13 * fy).cos() + 0.05 * fx * fy
                    )
                }
            })
            .collect();
        s.push_str(&row.join(" "));
        s.push('\n');
    }
    std::fs::write(path, s).unwrap();
}

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn terrain_json_contract_and_output() {
    let d = tempfile::tempdir().unwrap();
    let asc = d.path().join("hills.asc");
    write_asc(&asc, 65, 49);
    let out = d.path().join("hills.ply");
    let r = json(&meshlod(&[
        "terrain",
        asc.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--max-error",
        "0.5",
        "--json",
    ]));
    for key in ["triangles", "vertices", "max_error", "rms_error", "seconds"] {
        assert!(
            r.get(key).is_some_and(|v| v.is_number()),
            "{key} missing: {r}"
        );
    }
    let max = r["max_error"].as_f64().unwrap();
    assert!(max <= 0.5 && max > 0.0, "{r}");
    assert!(r["rms_error"].as_f64().unwrap() <= max);
    assert_eq!(r["voids_filled"], 1);
    let mesh = meshlod::read_mesh(&out).unwrap();
    assert_eq!(
        mesh.triangles.len() as u64,
        r["triangles"].as_u64().unwrap()
    );
    assert_eq!(mesh.positions.len() as u64, r["vertices"].as_u64().unwrap());
    assert!(mesh.triangles.len() < 64 * 48 * 2);
    // The .asc cell size scales x and y: the far corner is at (640, 480).
    let xmax = mesh.positions.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    let ymax = mesh.positions.iter().map(|p| p[1]).fold(0.0f32, f32::max);
    assert_eq!((xmax, ymax), (640.0, 480.0));
    // Every triangle counter-clockwise seen from +z.
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        assert!(cross > 0.0, "{t:?}");
    }

    // A triangle budget.
    let r = json(&meshlod(&[
        "terrain",
        asc.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--triangles",
        "100",
        "--json",
    ]));
    let n = r["triangles"].as_u64().unwrap();
    assert!((100..=101).contains(&n), "{n}");
}

#[test]
fn terrain_tiles_and_index() {
    let d = tempfile::tempdir().unwrap();
    let asc = d.path().join("hills.asc");
    write_asc(&asc, 65, 49);
    let out = d.path().join("t.obj");
    let r = json(&meshlod(&[
        "terrain",
        asc.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--max-error",
        "0.25",
        "--tile-size",
        "17",
        "--json",
    ]));
    assert_eq!(r["tiles"], 12); // 4 × 3 tiles of 17 samples, stride 16.
    assert!(r["max_error"].as_f64().unwrap() <= 0.25);
    let index: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("t_index.json")).unwrap())
            .unwrap();
    let tiles = index["tiles"].as_array().unwrap();
    assert_eq!(tiles.len(), 12);
    let mut total = 0;
    for t in tiles {
        let file = d.path().join(t["file"].as_str().unwrap());
        let mesh = meshlod::read_mesh(&file).unwrap();
        assert_eq!(
            mesh.triangles.len() as u64,
            t["triangles"].as_u64().unwrap()
        );
        total += mesh.triangles.len() as u64;
    }
    assert_eq!(total, r["triangles"].as_u64().unwrap());
    assert!(d.path().join("t_3_2.obj").exists());
}

#[test]
fn terrain_bad_inputs_are_clean_errors() {
    let d = tempfile::tempdir().unwrap();
    let hgt = d.path().join("N00E000.hgt");
    std::fs::write(&hgt, vec![0u8; 4000]).unwrap();
    let asc = d.path().join("absurd.asc");
    std::fs::write(&asc, "ncols 99999999\nnrows 99999999\n1 2 3\n").unwrap();
    let ok = d.path().join("ok.asc");
    write_asc(&ok, 9, 9);
    let cases: [(&Path, &[&str], &str); 4] = [
        (&hgt, &[], "truncated"),
        (&asc, &[], "header says"),
        (&ok, &["--max-error=-1"], "--max-error"),
        (&ok, &["--tile-size", "1"], "--tile-size"),
    ];
    for (path, extra, want) in cases {
        let o = d.path().join("o.ply");
        let mut args = vec!["terrain", path.to_str().unwrap(), "-o", o.to_str().unwrap()];
        args.extend_from_slice(extra);
        let out = meshlod(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{path:?} accepted");
        assert_ne!(out.status.code(), Some(101), "panicked: {err}");
        assert!(err.contains(want), "{err}");
        if extra.is_empty() {
            assert!(
                err.contains(path.file_name().unwrap().to_str().unwrap()),
                "{err}"
            );
        }
    }
}
