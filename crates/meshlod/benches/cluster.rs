//! Side-by-side benchmark of vertex clustering: meshlod's `Method::Cluster`
//! (quadric representatives) against meshoptimizer's `meshopt_simplifySloppy`
//! (through the `meshopt` crate, target error 1.0 so only the count stops it), on the
//! same meshes, in the same process, at ratios 0.1 and 0.01.
//!
//! For each: best-of-5 wall time, input M triangles per second, output triangles,
//! and the symmetric Hausdorff distance (max and mean, % of the bbox diagonal) of the
//! result against the input with `meshlod::metrics::hausdorff` (Metro sampling,
//! default samples). meshlod runs with the rayon pool (all cores) and, for a
//! single-thread comparison with meshoptimizer, in a 1-thread pool.
//!
//! Meshes: bunny, fandisk, armadillo, lucy, turbine blade from `../shared/meshes`, and
//! the turbine blade subdivided twice (3.2 M triangles; timing only, no Hausdorff);
//! generated meshes when the shared set is absent.
//!
//! Run: `cargo bench -p meshlod --bench cluster` (`MESHLOD_BENCH_QUICK=1` skips the
//! 3.2 M-triangle mesh).

use meshlod::mesh::{generate, Mesh, Weld};
use meshlod::metrics::{hausdorff, SamplingOptions};
use meshlod::simplify::{simplify, Method, SimplifyOptions};
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

struct Case {
    name: String,
    mesh: Mesh,
    indices: Vec<u32>,
    welded: Vec<[f32; 3]>,
    measure: bool,
}

fn case(name: &str, mesh: Mesh, measure: bool) -> Case {
    let weld = Weld::exact(&mesh.positions);
    let indices = mesh
        .triangles
        .iter()
        .flat_map(|t| t.map(|v| weld.point_of[v as usize]))
        .collect();
    let welded = weld
        .representative
        .iter()
        .map(|&v| mesh.positions[v as usize])
        .collect();
    Case {
        name: name.to_string(),
        mesh,
        indices,
        welded,
        measure,
    }
}

fn cases() -> Vec<Case> {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes");
    let quick = std::env::var_os("MESHLOD_BENCH_QUICK").is_some();
    let files = [
        ("bunny", "vtk-data/bunny.ply"),
        ("fandisk", "common-3d-test-models/fandisk.obj"),
        ("armadillo", "libigl-tutorial-data/armadillo.obj"),
        ("lucy", "vtk-data/lucy.ply"),
        ("turbine", "vtk-data/turbineblade.ply"),
    ];
    let mut out = Vec::new();
    for (name, f) in files {
        if let Ok(m) = meshlod::read_mesh(shared.join(f)) {
            if name == "turbine" && !quick {
                out.push(case(
                    "turbine_x16",
                    m.subdivide_midpoint().subdivide_midpoint(),
                    false,
                ));
            }
            out.push(case(name, m, true));
        }
    }
    if out.is_empty() {
        eprintln!("notice: ../shared/meshes absent; benchmarking generated meshes");
        out.push(case("torus", generate::torus(300, 150, 2.0, 0.6), true));
        out.push(case("icosphere7", generate::icosphere(7), true));
    }
    out
}

fn meshopt_run(c: &Case, ratio: f64) -> Mesh {
    let bytes: &[u8] = bytemuck_f32(&c.welded);
    let adapter = meshopt::VertexDataAdapter::new(bytes, 12, 0).expect("adapter");
    let target = ((c.mesh.triangles.len() as f64) * ratio).round() as usize;
    let r = meshopt::simplify_sloppy(&c.indices, &adapter, target * 3, 1.0, None);
    let tris = r.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    let mut m = Mesh::from_triangles(c.welded.clone(), tris);
    m.compact_vertices();
    m
}

/// The welded positions as bytes (little-endian f32, as meshopt reads them).
fn bytemuck_f32(p: &[[f32; 3]]) -> &'static [u8] {
    let v: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    Box::leak(v.into_boxed_slice())
}

fn ours_run(c: &Case, ratio: f64) -> Mesh {
    let o = SimplifyOptions::default()
        .with_method(Method::Cluster)
        .with_ratio(ratio);
    simplify(&c.mesh, &o).expect("valid").0
}

fn time(f: impl Fn() -> Mesh) -> (Duration, Mesh) {
    let mut best = Duration::MAX;
    let mut out = Mesh::default();
    for _ in 0..5 {
        let t = Instant::now();
        out = black_box(f());
        best = best.min(t.elapsed());
    }
    (best, out)
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let cases = cases();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    println!(
        "| mesh | tris | ratio | meshopt sloppy Mtri/s | ours Mtri/s (1 thread / all) | tris out meshopt / ours | H max % meshopt / ours | H mean % meshopt / ours |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for c in &cases {
        let n = c.mesh.triangles.len() as f64;
        for ratio in [0.1, 0.01] {
            let (tm, mm) = time(|| meshopt_run(c, ratio));
            let (t1, _) = one.install(|| time(|| ours_run(c, ratio)));
            let (ta, mo) = time(|| ours_run(c, ratio));
            let rate = |d: Duration| n / d.as_secs_f64() / 1e6;
            let (hm, ho) = if c.measure {
                let s = SamplingOptions::default();
                let a = hausdorff(&c.mesh, &mm, &s);
                let b = hausdorff(&c.mesh, &mo, &s);
                let pct = |x: f64, d: f64| 100.0 * x / d;
                (
                    format!(
                        "{:.3} / {:.3}",
                        pct(a.hausdorff, a.bbox_diagonal),
                        pct(b.hausdorff, b.bbox_diagonal)
                    ),
                    format!(
                        "{:.4} / {:.4}",
                        pct(a.mean, a.bbox_diagonal),
                        pct(b.mean, b.bbox_diagonal)
                    ),
                )
            } else {
                ("-".into(), "-".into())
            };
            println!(
                "| {} | {} | {ratio} | {:.1} | {:.1} / {:.1} | {} / {} | {hm} | {ho} |",
                c.name,
                c.mesh.triangles.len(),
                rate(tm),
                rate(t1),
                rate(ta),
                mm.triangles.len(),
                mo.triangles.len(),
            );
        }
    }
}
