//! Progressive meshes: build time against plain simplification, and navigation
//! throughput.
//!
//! For each mesh and method (Melax; QEM with endpoint placement):
//! - **build / simplify**: `ProgressiveMesh::build` down to the coarsest mesh
//!   against `simplify` with the same options and target (the same collapses,
//!   without recording and assembling the splits); goal ≤ 1.3×;
//! - **navigation**: a [`Navigator`] walking base → finest → base repeatedly, in
//!   vertex splits (or collapses) per second; goal ≥ 5 M/s;
//! - **encode / decode**: `.pmesh` bytes per split and decode speed.
//!
//! Best of 3 timings; single-threaded. Meshes: bunny, armadillo and Lucy from
//! `../shared/meshes`, or generated meshes when the set is absent.
//!
//! Run: `cargo bench -p meshlod --bench progressive`.

use meshlod::cost::Placement;
use meshlod::lod::{Navigator, ProgressiveMesh};
use meshlod::mesh::{generate, Mesh};
use meshlod::simplify::{simplify, Method, SimplifyOptions};
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

fn best<T>(n: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut best = Duration::MAX;
    let mut out = None;
    for _ in 0..n {
        let t = Instant::now();
        let r = black_box(f());
        best = best.min(t.elapsed());
        out = Some(r);
    }
    (best, out.expect("n > 0"))
}

fn cases() -> Vec<(String, Mesh)> {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes");
    let mut out = Vec::new();
    for f in [
        "vtk-data/bunny.ply",
        "libigl-tutorial-data/armadillo.obj",
        "vtk-data/lucy.ply",
    ] {
        if let Ok(m) = meshlod::read_mesh(shared.join(f)) {
            let name = Path::new(f)
                .file_stem()
                .map_or(f.to_string(), |s| s.to_string_lossy().into_owned());
            out.push((name, m));
        }
    }
    if out.is_empty() {
        eprintln!("notice: ../shared/meshes absent; benchmarking generated meshes");
        out.push(("torus".into(), generate::torus(300, 150, 2.0, 0.6)));
        out.push(("icosphere6".into(), generate::icosphere(6)));
    }
    out
}

fn main() {
    let methods = [
        (
            "melax",
            SimplifyOptions::default()
                .with_method(Method::Melax)
                .with_target_triangles(0),
        ),
        (
            "qem-endpoint",
            SimplifyOptions::default()
                .with_placement(Placement::Endpoint)
                .with_target_triangles(0),
        ),
    ];
    eprintln!(
        "\n{:11} {:13} {:>7} {:>7} {:>10} {:>10} {:>6} {:>12} {:>9} {:>11}",
        "mesh",
        "method",
        "tris",
        "splits",
        "simplify",
        "pm build",
        "ratio",
        "nav splits/s",
        "B/split",
        "decode MB/s"
    );
    for (name, mesh) in cases() {
        for (mname, o) in &methods {
            let (ts, _) = best(3, || simplify(&mesh, o).expect("valid").0.triangles.len());
            let (tb, (pm, _)) = best(3, || ProgressiveMesh::build(&mesh, o).expect("build"));
            let s = pm.split_count();
            // Navigation: base → finest → base, many times.
            let mut nav = Navigator::new(&pm);
            nav.set_level(0);
            let rounds = (20_000_000 / s.max(1)).clamp(2, 200);
            let t = Instant::now();
            let mut applied = 0usize;
            for _ in 0..rounds {
                applied += nav.refine(s);
                applied += nav.coarsen(s);
            }
            black_box(nav.indices().len());
            let rate = applied as f64 / t.elapsed().as_secs_f64();
            let bytes = pm.to_bytes();
            let (td, d) = best(3, || ProgressiveMesh::from_bytes(&bytes).expect("decode"));
            assert_eq!(d.pm.split_count(), s);
            eprintln!(
                "{:11} {:13} {:7} {:7} {:8.1}ms {:8.1}ms {:6.2} {:10.1}M {:9.1} {:11.0}",
                name,
                mname,
                mesh.triangles.len(),
                s,
                ts.as_secs_f64() * 1e3,
                tb.as_secs_f64() * 1e3,
                tb.as_secs_f64() / ts.as_secs_f64(),
                rate / 1e6,
                bytes.len() as f64 / s.max(1) as f64,
                bytes.len() as f64 / td.as_secs_f64() / 1e6
            );
        }
    }
}
