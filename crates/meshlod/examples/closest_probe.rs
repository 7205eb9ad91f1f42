//! Cost of the closest-point queries the orientation repair and the vertex fitting
//! make: a tree over a mesh's input triangles (`Bvh::build_morton`) queried at the
//! centroids of its simplified version's triangles, the queries started three ways
//! (no hint; the previous query's answer, as the orientation repair does; the exact
//! answer, as the fit's second iteration nearly has it), plus the same queries ten
//! times each in a row (cache-warm: the arithmetic alone).
//!
//! `cargo run --release -p meshlod --example closest_probe -- MESH [RATIO] [ROUNDS]`
//! (MESH as in `qem_ratio`: `bunny`, `lucy`, `turbine`, `fandisk`, `armadillo` or a
//! path; RATIO defaults to 0.1, ROUNDS to 3). Prints nanoseconds per query; wall
//! times, so compare builds by alternating runs.

// Shared with the meshoptimizer comparisons; `welded` is theirs.
#[allow(dead_code)]
mod common;
use meshlod::metrics::bvh::Bvh;
use meshlod::simplify::{simplify, SimplifyOptions};
use std::hint::black_box;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(name) = args.first() else {
        eprintln!("usage: closest_probe MESH [RATIO] [ROUNDS]");
        std::process::exit(2);
    };
    let m = common::load(name);
    let ratio: f64 = args.get(1).map_or(0.1, |r| r.parse().expect("ratio"));
    let rounds: usize = args.get(2).map_or(3, |r| r.parse().expect("rounds"));
    let (out, _) = simplify(&m, &SimplifyOptions::default().with_ratio(ratio)).expect("valid");
    let t0 = Instant::now();
    let bvh = Bvh::build_morton(&m.positions, &m.triangles);
    let build_ms = t0.elapsed().as_secs_f64() * 1e3;
    let points: Vec<[f64; 3]> = out
        .triangles
        .iter()
        .map(|t| {
            let c = t.map(|v| out.positions[v as usize].map(f64::from));
            std::array::from_fn(|k| (c[0][k] + c[1][k] + c[2][k]) / 3.0)
        })
        .collect();
    let exact: Vec<u32> = points
        .iter()
        .map(|&p| bvh.closest(p, None).expect("non-empty").triangle)
        .collect();
    let n = points.len() as f64;
    let per_query = |f: &mut dyn FnMut() -> f64, reps: f64| {
        let t = Instant::now();
        black_box(f());
        t.elapsed().as_secs_f64() / (n * reps) * 1e9
    };
    println!(
        "{name}: {} input triangles, tree built in {build_ms:.1} ms; {} queries",
        m.triangles.len(),
        points.len()
    );
    println!("| round | no hint ns | previous answer ns | exact answer ns | warm ns |");
    println!("|---:|---:|---:|---:|---:|");
    for round in 0..rounds {
        let none = per_query(
            &mut || {
                points
                    .iter()
                    .map(|&p| bvh.closest(p, None).map_or(0.0, |c| c.dist2))
                    .sum()
            },
            1.0,
        );
        let previous = per_query(
            &mut || {
                let mut hint = None;
                let mut s = 0.0;
                for &p in &points {
                    if let Some(c) = bvh.closest(p, hint) {
                        hint = Some(c.triangle);
                        s += c.dist2;
                    }
                }
                s
            },
            1.0,
        );
        let with_exact = per_query(
            &mut || {
                points
                    .iter()
                    .zip(&exact)
                    .map(|(&p, &e)| bvh.closest(p, Some(e)).map_or(0.0, |c| c.dist2))
                    .sum()
            },
            1.0,
        );
        let warm = per_query(
            &mut || {
                let mut s = 0.0;
                for (&p, &e) in points.iter().zip(&exact) {
                    for _ in 0..10 {
                        s += bvh.closest(black_box(p), Some(e)).map_or(0.0, |c| c.dist2);
                    }
                }
                s
            },
            10.0,
        );
        println!("| {round} | {none:.0} | {previous:.0} | {with_exact:.0} | {warm:.0} |");
    }
}
