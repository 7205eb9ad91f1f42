//! Side-by-side benchmark: meshlod's QEM simplification against meshoptimizer's
//! `meshopt_simplify` (through the `meshopt` crate, target error 1.0 so only the
//! triangle target stops it) on the same meshes, in the same process, at ratios 0.1
//! and 0.01, single-threaded.
//!
//! Meshes: the Stanford bunny, Lucy and the turbine blade from `../shared/meshes`, and
//! the turbine blade subdivided twice (3.2 M triangles); generated meshes when the
//! shared set is absent. meshoptimizer gets the welded index buffer (as the peers
//! benchmark gives it); meshlod gets the mesh as read (it welds itself, included in
//! its time). Before the criterion runs, one timed pass of each prints the time
//! ratio `meshlod / meshopt`.
//!
//! Run: `cargo bench -p meshlod --bench simplify` (set `MESHLOD_BENCH_QUICK=1` to
//! skip the 3.2 M-triangle mesh).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use meshlod::mesh::{generate, Mesh, Weld};
use meshlod::simplify::{simplify, SimplifyOptions};
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

struct Case {
    name: String,
    mesh: Mesh,
    /// Welded index buffer and position bytes for meshopt.
    indices: Vec<u32>,
    bytes: Vec<u8>,
}

fn case(name: &str, mesh: Mesh) -> Case {
    let weld = Weld::exact(&mesh.positions);
    let indices = mesh
        .triangles
        .iter()
        .flat_map(|t| t.map(|v| weld.point_of[v as usize]))
        .collect();
    let bytes = weld
        .representative
        .iter()
        .flat_map(|&v| mesh.positions[v as usize].map(f32::to_le_bytes))
        .flatten()
        .collect();
    Case {
        name: name.to_string(),
        mesh,
        indices,
        bytes,
    }
}

fn cases() -> Vec<Case> {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes/vtk-data");
    let quick = std::env::var_os("MESHLOD_BENCH_QUICK").is_some();
    let mut out = Vec::new();
    let read = |f: &str| meshlod::read_mesh(shared.join(f)).ok();
    match (
        read("bunny.ply"),
        read("lucy.ply"),
        read("turbineblade.ply"),
    ) {
        (Some(b), Some(l), Some(t)) => {
            out.push(case("bunny", b));
            out.push(case("lucy", l));
            if !quick {
                out.push(case(
                    "turbine_x16",
                    t.subdivide_midpoint().subdivide_midpoint(),
                ));
            }
            out.push(case("turbine", t));
        }
        _ => {
            eprintln!("notice: ../shared/meshes absent; benchmarking generated meshes");
            out.push(case("torus", generate::torus(300, 150, 2.0, 0.6)));
            out.push(case("icosphere7", generate::icosphere(7)));
        }
    }
    out
}

fn meshopt_run(c: &Case, ratio: f64) -> usize {
    let adapter = meshopt::VertexDataAdapter::new(&c.bytes, 12, 0).expect("adapter");
    let target = ((c.mesh.triangles.len() as f64) * ratio).round() as usize;
    let r = meshopt::simplify(
        &c.indices,
        &adapter,
        target * 3,
        1.0,
        meshopt::SimplifyOptions::None,
        None,
    );
    r.len() / 3
}

fn ours_run(c: &Case, ratio: f64) -> usize {
    let (m, _) = simplify(&c.mesh, &SimplifyOptions::default().with_ratio(ratio)).expect("valid");
    m.triangles.len()
}

fn time(f: impl Fn() -> usize) -> (Duration, usize) {
    let mut best = Duration::MAX;
    let mut n = 0;
    for _ in 0..3 {
        let t = Instant::now();
        n = black_box(f());
        best = best.min(t.elapsed());
    }
    (best, n)
}

fn bench(c: &mut Criterion) {
    let cases = cases();
    eprintln!("\nmesh            tris      ratio  meshopt ms  meshlod ms  meshlod/meshopt");
    for k in &cases {
        for ratio in [0.1, 0.01] {
            let (tm, _) = time(|| meshopt_run(k, ratio));
            let (to, _) = time(|| ours_run(k, ratio));
            eprintln!(
                "{:14} {:9} {:6} {:11.1} {:11.1} {:8.2}",
                k.name,
                k.mesh.triangles.len(),
                ratio,
                tm.as_secs_f64() * 1e3,
                to.as_secs_f64() * 1e3,
                to.as_secs_f64() / tm.as_secs_f64()
            );
        }
    }
    let mut g = c.benchmark_group("simplify");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(3));
    for k in &cases {
        for ratio in [0.1, 0.01] {
            let id = format!("{}@{ratio}", k.name);
            g.bench_with_input(BenchmarkId::new("meshopt", &id), &ratio, |b, &r| {
                b.iter(|| meshopt_run(k, r));
            });
            g.bench_with_input(BenchmarkId::new("meshlod", &id), &ratio, |b, &r| {
                b.iter(|| ours_run(k, r));
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
