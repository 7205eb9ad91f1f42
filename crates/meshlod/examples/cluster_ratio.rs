//! Same-process time ratio of meshlod's vertex clustering against meshoptimizer's
//! `simplify_sloppy` (a quicker, more repeatable companion of `benches/cluster.rs`).
//!
//! `cargo run --release -p meshlod --example cluster_ratio -- [REPS] [THREADS] [MESH…]`
//! runs, alternating, meshopt and ours (in a pool of THREADS threads, default 1), REPS
//! times (default 31) per mesh and ratio 0.1 / 0.01, and prints best-of and median
//! time ratios (wall time).
//!
//! `MESHLOD_PROFILE=mesh:ratio:n[:meshopt]` runs only ours (or only meshopt) `n`
//! times on one thread (ours on `MESHLOD_THREADS` threads when set), for `perf record` or for `perf stat -e task-clock` (CPU time,
//! robust to load on a shared machine; `n = 0` measures the loading alone). `MESHLOD_PROFILE=mesh:ratio:n` runs only ours `n` times (for perf).

mod common;
use common::{load, welded};
use meshlod::decimate::cluster::ClusterOptions;
use meshlod::mesh::{Mesh, Weld};
use meshlod::simplify::{simplify, Method, SimplifyOptions};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

fn ours(m: &Mesh, ratio: f64) -> Mesh {
    let o = SimplifyOptions::default()
        .with_method(Method::Cluster)
        .with_ratio(ratio);
    simplify(m, &o).expect("valid").0
}

fn main() {
    if let Ok(p) = std::env::var("MESHLOD_WRITE") {
        // mesh:ratio:dir — write meshopt's result, ours at the target and ours at
        // meshopt's triangle count, as PLY, for `meshlod measure`.
        let v: Vec<&str> = p.split(':').collect();
        let m = load(v[0]);
        let ratio: f64 = v[1].parse().unwrap();
        let dir = Path::new(v[2]);
        let (indices, bytes) = welded(&m);
        let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).unwrap();
        let target = (m.triangles.len() as f64 * ratio).round() as usize;
        let r = meshopt::simplify_sloppy(&indices, &adapter, target * 3, 1.0, None);
        let weld = Weld::exact(&m.positions);
        let positions = weld
            .representative
            .iter()
            .map(|&v| m.positions[v as usize])
            .collect();
        let tris: Vec<[u32; 3]> = r.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let n = tris.len();
        let mut mo = Mesh::from_triangles(positions, tris);
        mo.compact_vertices();
        let w = meshlod::io::WriteOptions::default();
        let name = format!("{}_{}", v[0], v[1]);
        meshlod::write_mesh(dir.join(format!("{name}_meshopt.ply")), &mo, &w).unwrap();
        meshlod::write_mesh(dir.join(format!("{name}_ours.ply")), &ours(&m, ratio), &w).unwrap();
        // Within 1% of meshoptimizer's count (the default 5% band would compare
        // different counts).
        let o = SimplifyOptions::default()
            .with_method(Method::Cluster)
            .with_target_triangles(n)
            .with_cluster(ClusterOptions::default().with_tolerance(0.01));
        let at = simplify(&m, &o).expect("valid").0;
        println!(
            "{name}: meshopt {n}, ours at that count {}",
            at.triangles.len()
        );
        meshlod::write_mesh(dir.join(format!("{name}_ours_at.ply")), &at, &w).unwrap();
        return;
    }
    if let Ok(p) = std::env::var("MESHLOD_PROFILE") {
        let v: Vec<&str> = p.split(':').collect();
        let m = load(v[0]);
        let ratio: f64 = v[1].parse().unwrap();
        let n: usize = v[2].parse().unwrap();
        let threads = std::env::var("MESHLOD_THREADS")
            .ok()
            .and_then(|t| t.parse().ok())
            .unwrap_or(1);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        if v.get(3) == Some(&"meshopt") {
            let (indices, bytes) = welded(&m);
            let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).unwrap();
            let target = (m.triangles.len() as f64 * ratio).round() as usize;
            for _ in 0..n {
                black_box(meshopt::simplify_sloppy(
                    &indices,
                    &adapter,
                    target * 3,
                    1.0,
                    None,
                ));
            }
            return;
        }
        pool.install(|| {
            for _ in 0..n {
                black_box(ours(&m, ratio));
            }
        });
        return;
    }
    let args: Vec<String> = std::env::args().skip(1).collect();
    let reps: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(31);
    let threads: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(1);
    let names: Vec<String> = if args.len() > 2 {
        args[2..].to_vec()
    } else {
        ["bunny", "fandisk", "armadillo", "lucy", "turbine"]
            .map(String::from)
            .to_vec()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    println!("| mesh | ratio | threads | best ratio | median ratio | meshopt Mtri/s | tris meshopt / ours |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for name in &names {
        let m = load(name);
        let (indices, bytes) = welded(&m);
        let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).unwrap();
        for ratio in [0.1, 0.01] {
            let target = (m.triangles.len() as f64 * ratio).round() as usize;
            let mut tm = Vec::new();
            let mut to = Vec::new();
            let mut ratios = Vec::new();
            let (mut nm, mut no) = (0, 0);
            for _ in 0..reps {
                let (a, r) = pool.install(|| {
                    let t = Instant::now();
                    let r = meshopt::simplify_sloppy(&indices, &adapter, target * 3, 1.0, None);
                    (t.elapsed().as_secs_f64(), black_box(r))
                });
                nm = r.len() / 3;
                let (b, o) = pool.install(|| {
                    let t = Instant::now();
                    let o = ours(&m, ratio);
                    (t.elapsed().as_secs_f64(), black_box(o))
                });
                no = o.triangles.len();
                tm.push(a);
                to.push(b);
                ratios.push(b / a);
            }
            let best = |v: &[f64]| v.iter().cloned().fold(f64::INFINITY, f64::min);
            ratios.sort_by(f64::total_cmp);
            println!(
                "| {name} | {ratio} | {threads} | {:.2} | {:.2} | {:.1} | {nm} / {no} |",
                best(&to) / best(&tm),
                ratios[ratios.len() / 2],
                m.triangles.len() as f64 / best(&tm) / 1e6
            );
        }
    }
}
