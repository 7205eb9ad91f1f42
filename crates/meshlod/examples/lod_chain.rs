//! What a level-of-detail chain costs against one simplification to its coarsest
//! level, ours and meshoptimizer's, in one process: the speed check of
//! `meshlod lod` in `docs/lod.md`.
//!
//! `cargo run --release -p meshlod --example lod_chain -- MESH…` (names as in
//! `examples/common`: `bunny`, `armadillo`, `lucy`, … or paths). For each mesh it
//! first builds the default chain (4 levels after LOD0, chosen by error) to learn
//! its triangle counts, then, alternating, `ROUNDS` times (default 5):
//! - ours, chain: [`build_chain`] with those counts as ratios, its
//!   `simplify_seconds` (the one run through all levels, orientation repairs on a
//!   second thread), and again with one thread;
//! - ours, one simplification of LOD0 to the coarsest count ([`simplify`]);
//! - meshoptimizer, chain: `simplify` of each level's index buffer from the
//!   previous one (its documented way to build LODs), target error 1 so only the
//!   count stops it; and one `simplify` of LOD0 to the coarsest count.
//!
//! Prints one Markdown row per mesh with the medians and the chain / one-shot
//! ratios. Measurement (the Hausdorff distances the chain reports) is not timed
//! here: it is sampled with 1,000 points only.

mod common;
use common::{load, welded};
use meshlod::lod::{build_chain, ChainOptions, LevelSpec};
use meshlod::metrics::SamplingOptions;
use meshlod::simplify::{simplify, SimplifyOptions};
use std::hint::black_box;
use std::time::Instant;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let rounds: usize = std::env::var("ROUNDS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(5);
    println!("| mesh | triangles | levels (triangles) | ours chain s | ours chain 1 thread s | ours one-shot s | ours chain / one-shot | meshopt chain s | meshopt one-shot s | meshopt chain / one-shot |");
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|");
    for name in std::env::args().skip(1) {
        let m = load(&name);
        let n = m.triangles.len();
        let quick = SamplingOptions::default().with_samples(1000);
        let probe = build_chain(
            &m,
            &ChainOptions {
                sampling: quick.clone(),
                ..ChainOptions::default()
            },
        )
        .expect("chain");
        let counts: Vec<usize> = probe.levels[1..].iter().map(|l| l.triangles).collect();
        let coarsest = *counts.last().expect("at least one level");
        let ratios: Vec<f64> = counts.iter().map(|&c| c as f64 / n as f64).collect();
        let chain_options = |threads: Option<usize>| ChainOptions {
            levels: LevelSpec::Ratios(ratios.clone()),
            sampling: quick.clone(),
            simplify: SimplifyOptions::default().with_threads(threads),
            ..ChainOptions::default()
        };
        let (indices, bytes) = welded(&m);
        let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).expect("adapter");
        let mo = |idx: &[u32], count: usize| {
            meshopt::simplify(
                idx,
                &adapter,
                count * 3,
                1.0,
                meshopt::SimplifyOptions::None,
                None,
            )
        };
        let (mut chain, mut chain1, mut one, mut mchain, mut mone) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for _ in 0..rounds {
            let c = build_chain(&m, &chain_options(None)).expect("chain");
            chain.push(c.simplify_seconds);
            let c = build_chain(&m, &chain_options(Some(1))).expect("chain");
            chain1.push(c.simplify_seconds);
            let t = Instant::now();
            let (out, _) = simplify(
                &m,
                &SimplifyOptions::default().with_target_triangles(coarsest),
            )
            .expect("valid mesh");
            black_box(out.triangles.len());
            one.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            let mut level = indices.clone();
            for &c in &counts {
                level = mo(&level, c);
            }
            black_box(level.len());
            mchain.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            black_box(mo(&indices, coarsest).len());
            mone.push(t.elapsed().as_secs_f64());
        }
        let (c, c1, o, mc, mo1) = (
            median(&mut chain),
            median(&mut chain1),
            median(&mut one),
            median(&mut mchain),
            median(&mut mone),
        );
        let list: Vec<String> = counts.iter().map(ToString::to_string).collect();
        println!(
            "| {name} | {n} | {} | {c:.3} | {c1:.3} | {o:.3} | {:.2} | {mc:.3} | {mo1:.3} | {:.2} |",
            list.join(", "),
            c / o,
            mc / mo1
        );
    }
}
