//! Same-process time ratio of meshlod's QEM simplification against meshoptimizer's
//! `simplify` (target error 1.0, so only the triangle target stops it): a quicker,
//! more repeatable companion of `benches/simplify.rs`.
//!
//! `cargo run --release -p meshlod --example qem_ratio -- [REPS] [MESH…]` runs,
//! alternating, meshoptimizer and ours (single-threaded), REPS times (default 11)
//! per mesh and ratio 0.1 / 0.01, and prints best-of and median time ratios (wall
//! time). Meshes are names (`bunny`, `lucy`, `turbine`, `fandisk`, `armadillo`) or
//! paths; the default is bunny, Lucy and the turbine blade. meshoptimizer gets the
//! exactly welded index buffer, as in the benchmark; ours welds itself, in its time.
//!
//! `MESHLOD_PROFILE=mesh:ratio:n[:meshopt]` runs only ours (or only meshoptimizer)
//! `n` times, for `perf record`.

mod common;
use common::{load, welded};
use meshlod::mesh::Mesh;
use meshlod::simplify::{simplify, SimplifyOptions};
use std::hint::black_box;
use std::time::Instant;

fn ours(m: &Mesh, ratio: f64) -> usize {
    let o = SimplifyOptions::default().with_ratio(ratio);
    simplify(m, &o).expect("valid").0.triangles.len()
}

fn theirs(indices: &[u32], adapter: &meshopt::VertexDataAdapter<'_>, target: usize) -> usize {
    let r = meshopt::simplify(
        indices,
        adapter,
        target * 3,
        1.0,
        meshopt::SimplifyOptions::None,
        None,
    );
    r.len() / 3
}

fn main() {
    if let Ok(p) = std::env::var("MESHLOD_PROFILE") {
        let v: Vec<&str> = p.split(':').collect();
        let m = load(v[0]);
        let ratio: f64 = v[1].parse().expect("ratio");
        let n: usize = v[2].parse().expect("count");
        if v.get(3) == Some(&"meshopt") {
            let (indices, bytes) = welded(&m);
            let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).expect("adapter");
            let target = (m.triangles.len() as f64 * ratio).round() as usize;
            for _ in 0..n {
                black_box(theirs(&indices, &adapter, target));
            }
        } else {
            for _ in 0..n {
                black_box(ours(&m, ratio));
            }
        }
        return;
    }
    let args: Vec<String> = std::env::args().skip(1).collect();
    // A leading number is REPS; the rest name meshes.
    let first: Option<usize> = args.first().and_then(|a| a.parse().ok());
    let reps = first.unwrap_or(11).max(1);
    let rest = &args[usize::from(first.is_some())..];
    let names: Vec<String> = if !rest.is_empty() {
        rest.to_vec()
    } else {
        ["bunny", "lucy", "turbine"].map(String::from).to_vec()
    };
    println!(
        "| mesh | ratio | best ratio | median ratio | meshopt ms | ours ms | tris meshopt / ours |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for name in &names {
        let m = load(name);
        let (indices, bytes) = welded(&m);
        let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).expect("adapter");
        for ratio in [0.1, 0.01] {
            let target = (m.triangles.len() as f64 * ratio).round() as usize;
            let (mut tm, mut to, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
            let (mut nm, mut no) = (0, 0);
            for _ in 0..reps {
                let t = Instant::now();
                nm = black_box(theirs(&indices, &adapter, target));
                let a = t.elapsed().as_secs_f64();
                let t = Instant::now();
                no = black_box(ours(&m, ratio));
                let b = t.elapsed().as_secs_f64();
                tm.push(a);
                to.push(b);
                ratios.push(b / a);
            }
            let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
            // The median (the lower middle value for an even count).
            ratios.sort_by(f64::total_cmp);
            println!(
                "| {name} | {ratio} | {:.2} | {:.2} | {:.1} | {:.1} | {nm} / {no} |",
                best(&to) / best(&tm),
                ratios[(ratios.len() - 1) / 2],
                best(&tm) * 1e3,
                best(&to) * 1e3
            );
        }
    }
}
