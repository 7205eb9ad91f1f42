//! Runs the real `meshlod pm build` / `pm extract` and `simplify --method melax`
//! binaries in a temporary directory: extracting N triangles gives the same mesh as
//! simplifying straight to N with the same method, the geomorph file has the same
//! connectivity, and truncated or foreign files are clean errors naming the file.

mod common;
use common::{meshlod, ok};

use meshlod::io::WriteOptions;
use meshlod::mesh::{generate, Mesh};
use std::path::Path;

/// Triangles as sorted position triples (rotated to the smallest corner).
fn canonical(m: &Mesh) -> Vec<[[u32; 3]; 3]> {
    let mut v: Vec<[[u32; 3]; 3]> = m
        .triangles
        .iter()
        .map(|t| {
            let k = t.map(|i| m.positions[i as usize].map(f32::to_bits));
            let r = (0..3).min_by_key(|&a| k[a]).unwrap_or(0);
            [k[r], k[(r + 1) % 3], k[(r + 2) % 3]]
        })
        .collect();
    v.sort_unstable();
    v
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

#[test]
fn build_extract_equals_simplify_and_geomorph() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("torus.ply");
    meshlod::write_mesh(
        &input,
        &generate::torus(40, 20, 2.0, 0.6),
        &WriteOptions::default(),
    )
    .unwrap();
    for method in ["melax", "qem"] {
        let pm = dir.path().join(format!("t_{method}.pmesh"));
        let r = ok(&meshlod(&[
            "pm",
            "build",
            s(&input),
            "-o",
            s(&pm),
            "--method",
            method,
            "--json",
        ]));
        assert_eq!(r["triangles_full"], 1600);
        assert!(r["vertex_splits"].as_u64().unwrap() > 700);
        let a = dir.path().join("a.obj");
        let g = dir.path().join("g.obj");
        let b = dir.path().join("b.obj");
        let r = ok(&meshlod(&[
            "pm",
            "extract",
            s(&pm),
            "--triangles",
            "300",
            "-o",
            s(&a),
            "--geomorph",
            s(&g),
            "--json",
        ]));
        assert!(r["triangles"].as_u64().unwrap() <= 300);
        let mut args = vec![
            "simplify",
            s(&input),
            "-o",
            s(&b),
            "--method",
            method,
            "--triangles",
            "300",
            "--json",
            // The orientation repair's swaps are not part of the .pmesh.
            "--no-facing-repair",
        ];
        if method == "qem" {
            args.extend(["--placement", "endpoint"]);
        }
        ok(&meshlod(&args));
        let (ma, mb, mg) = (
            meshlod::read_mesh(&a).unwrap(),
            meshlod::read_mesh(&b).unwrap(),
            meshlod::read_mesh(&g).unwrap(),
        );
        assert_eq!(
            canonical(&ma),
            canonical(&mb),
            "{method}: extract vs simplify"
        );
        assert_eq!(mg.triangles, ma.triangles);
        assert_eq!(mg.positions.len(), ma.positions.len());
        assert_ne!(mg.positions, ma.positions, "some vertices start elsewhere");
    }
}

#[test]
fn bad_pmesh_files_are_clean_errors() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("sphere.obj");
    meshlod::write_mesh(&input, &generate::icosphere(2), &WriteOptions::default()).unwrap();
    let pm = dir.path().join("s.pmesh");
    ok(&meshlod(&[
        "pm",
        "build",
        s(&input),
        "-o",
        s(&pm),
        "--json",
    ]));
    let bytes = std::fs::read(&pm).unwrap();
    let out = dir.path().join("o.obj");
    // Cut inside a record, a foreign file, an empty file.
    let cases: [(&str, Vec<u8>, &str); 3] = [
        (
            "cut.pmesh",
            bytes[..bytes.len() - 3].to_vec(),
            "unexpected end",
        ),
        ("obj.pmesh", b"v 0 0 0\n".to_vec(), "not a .pmesh"),
        ("empty.pmesh", Vec::new(), "byte 0"),
    ];
    for (name, data, want) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, data).unwrap();
        let o = meshlod(&["pm", "extract", s(&p), "--ratio", "0.5", "-o", s(&out)]);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(name) && err.contains(want), "{name}: {err}");
    }
    // Melax is a simplify method too; other placements cannot build a .pmesh.
    ok(&meshlod(&[
        "simplify",
        s(&input),
        "-o",
        s(&out),
        "--method",
        "melax",
        "--ratio",
        "0.2",
        "--json",
    ]));
}
