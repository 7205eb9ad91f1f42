//! Side-by-side benchmark of vertex clustering: meshlod's `Method::Cluster`
//! (quadric representatives) against meshoptimizer's `meshopt_simplifySloppy`
//! (through the `meshopt` crate, target error 1.0 so only the count stops it), on the
//! same meshes, in the same process, at ratios 0.1 and 0.01.
//!
//! For each: best-of-N wall time (the three runs alternate, so load on a shared
//! machine hits them alike; N = 9, 5 on the 3.2 M mesh), input M triangles per
//! second, the time ratio ours / meshoptimizer (below 1: we are faster), output
//! triangles, and the symmetric Hausdorff distance (max and mean, % of the bbox
//! diagonal) of the result against the input with `meshlod::metrics::hausdorff`
//! (Metro sampling, default samples). meshlod runs in a 1-thread pool (the
//! comparison with the single-threaded meshoptimizer) and with the rayon pool (all
//! cores).
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
    /// `welded` as little-endian bytes, as meshopt reads them.
    bytes: Vec<u8>,
    measure: bool,
}

fn case(name: &str, mesh: Mesh, measure: bool) -> Case {
    let weld = Weld::exact(&mesh.positions);
    let indices = mesh
        .triangles
        .iter()
        .flat_map(|t| t.map(|v| weld.point_of[v as usize]))
        .collect();
    let welded: Vec<[f32; 3]> = weld
        .representative
        .iter()
        .map(|&v| mesh.positions[v as usize])
        .collect();
    let bytes = welded
        .iter()
        .flatten()
        .flat_map(|x: &f32| x.to_le_bytes())
        .collect();
    Case {
        name: name.to_string(),
        mesh,
        indices,
        welded,
        bytes,
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

/// meshoptimizer's sloppy simplification; only the call and the index copy are
/// timed: the result holds the triangles over the welded vertices, no positions
/// ([`meshopt_mesh`] makes the mesh).
fn meshopt_run(c: &Case, ratio: f64) -> Mesh {
    let adapter = meshopt::VertexDataAdapter::new(&c.bytes, 12, 0).expect("adapter");
    let target = ((c.mesh.triangles.len() as f64) * ratio).round() as usize;
    let r = meshopt::simplify_sloppy(&c.indices, &adapter, target * 3, 1.0, None);
    let tris = r.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    Mesh::from_triangles(Vec::new(), tris)
}

/// The mesh of a [`meshopt_run`] result.
fn meshopt_mesh(c: &Case, r: Mesh) -> Mesh {
    let mut m = Mesh::from_triangles(c.welded.clone(), r.triangles);
    m.compact_vertices();
    m
}

fn ours_run(c: &Case, ratio: f64) -> Mesh {
    let o = SimplifyOptions::default()
        .with_method(Method::Cluster)
        .with_ratio(ratio);
    simplify(&c.mesh, &o).expect("valid").0
}

/// Best-of-`n` wall times of the three runs, alternating, and the last outputs.
fn time3(n: usize, runs: [&dyn Fn() -> Mesh; 3]) -> ([Duration; 3], [Mesh; 3]) {
    let mut best = [Duration::MAX; 3];
    let mut out: [Mesh; 3] = Default::default();
    for _ in 0..n {
        for (k, f) in runs.iter().enumerate() {
            let t = Instant::now();
            out[k] = black_box(f());
            best[k] = best[k].min(t.elapsed());
        }
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
        "| mesh | tris | ratio | meshopt sloppy Mtri/s | ours Mtri/s (1 thread / all) | time ours / meshopt (1 thread / all) | tris out meshopt / ours | H max % meshopt / ours | H mean % meshopt / ours |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for c in &cases {
        let n = c.mesh.triangles.len() as f64;
        let reps = if c.mesh.triangles.len() > 1_000_000 {
            5
        } else {
            9
        };
        for ratio in [0.1, 0.01] {
            let sloppy = || meshopt_run(c, ratio);
            let single = || one.install(|| ours_run(c, ratio));
            let all = || ours_run(c, ratio);
            let ([tm, t1, ta], [mm, _, mo]) = time3(reps, [&sloppy, &single, &all]);
            let mm = meshopt_mesh(c, mm);
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
            let per = |d: Duration| d.as_secs_f64() / tm.as_secs_f64();
            println!(
                "| {} | {} | {ratio} | {:.1} | {:.1} / {:.1} | {:.2} / {:.2} | {} / {} | {hm} | {ho} |",
                c.name,
                c.mesh.triangles.len(),
                rate(tm),
                rate(t1),
                rate(ta),
                per(t1),
                per(ta),
                mm.triangles.len(),
                mo.triangles.len(),
            );
        }
    }
}
