//! meshlod's cluster hierarchy (`meshlod::lod::dag`) against meshoptimizer's
//! `clusterlod` (`meshopt::clod_build`, default configuration for 128-triangle
//! clusters), in one process: the comparison behind `docs/lod.md` ("View-dependent
//! LOD").
//!
//! `cargo run --release -p meshlod --example dag_vs_clod -- MESH…` (names as in
//! `examples/common`). Per mesh: build seconds (median of `ROUNDS`, default 3,
//! alternating), the time of one view-dependent cut (`Dag::cut`, mean of 100, camera
//! at twice the diagonal), levels, roots (clusters never simplified further) and
//! their triangles; then, for view-independent cuts at error thresholds of 0.01%, 0.1%
//! and 1% of the diagonal for meshoptimizer, the meshlod cut with the nearest
//! triangle count at or above it, and both cuts' Hausdorff distance to the input
//! (`metrics::hausdorff`, 200,000 samples per direction), as % of the diagonal.

mod common;
use common::{load, welded};
use meshlod::lod::dag::{build_dag, Dag, DagOptions, DagView};
use meshlod::lod::Screen;
use meshlod::mesh::Mesh;
use meshlod::metrics::{hausdorff, SamplingOptions};
use std::time::Instant;

/// meshoptimizer's hierarchy: per group (depth, simplified error), per cluster
/// (group, refined group or -1, indices).
struct Clod {
    groups: Vec<(i32, f32)>,
    clusters: Vec<(usize, i32, Vec<u32>)>,
}

fn clod(indices: &[u32], bytes: &[u8]) -> Clod {
    let adapter = meshopt::VertexDataAdapter::new(bytes, 12, 0).expect("adapter");
    let mesh = meshopt::ClodMesh::new(indices, &adapter);
    let mut out = Clod {
        groups: Vec::new(),
        clusters: Vec::new(),
    };
    meshopt::clod_build(
        meshopt::clod_default_config(128),
        &mesh,
        |group, clusters| {
            let id = out.groups.len();
            out.groups.push((group.depth, group.simplified.error));
            for c in clusters {
                out.clusters.push((id, c.refined, c.indices.to_vec()));
            }
            id as i32
        },
    );
    out
}

fn clod_cut(c: &Clod, positions: &[[f32; 3]], t: f32) -> Mesh {
    let mut tris = Vec::new();
    for (g, refined, idx) in &c.clusters {
        let over = c.groups[*g].1 > t;
        let fine_enough = *refined < 0 || c.groups[*refined as usize].1 <= t;
        if over && fine_enough {
            tris.extend(idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]));
        }
    }
    Mesh::from_triangles(positions.to_vec(), tris)
}

fn dag_cut(d: &Dag, t: f64) -> Mesh {
    let chosen: Vec<usize> = (0..d.clusters.len())
        .filter(|&i| d.clusters[i].error <= t && d.clusters[i].parent_error > t)
        .collect();
    d.cut_mesh(&chosen)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let rounds: usize = std::env::var("ROUNDS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(3);
    let sampling = SamplingOptions::default().with_samples(200_000);
    println!("| mesh | triangles | build s ours / meshopt | one cut ms (ours) | levels ours / meshopt | roots (triangles) ours / meshopt | cut at meshopt's t | triangles ours / meshopt | Hausdorff max % ours / meshopt | mean % ours / meshopt |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for name in std::env::args().skip(1) {
        let m = load(&name);
        let diag = m.bbox_diagonal();
        let (indices, bytes) = welded(&m);
        let positions: Vec<[f32; 3]> = bytes
            .chunks_exact(12)
            .map(|c| {
                std::array::from_fn(|k| {
                    f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().expect("4 bytes"))
                })
            })
            .collect();
        let (mut ours, mut theirs) = (Vec::new(), Vec::new());
        let mut built = None;
        let mut theirs_built = None;
        for _ in 0..rounds {
            let t = Instant::now();
            built = Some(build_dag(&m, &DagOptions::default()).expect("dag"));
            ours.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            theirs_built = Some(clod(&indices, &bytes));
            theirs.push(t.elapsed().as_secs_f64());
        }
        let (dag, report) = built.expect("built");
        // Time of one view-dependent cut, camera at twice the diagonal from the box.
        let (lo, hi) = m.bounding_box(true).expect("triangles");
        let center: [f64; 3] = std::array::from_fn(|k| 0.5 * f64::from(lo[k] + hi[k]));
        let view = DagView::new(
            [center[0], center[1], center[2] + 2.0 * diag],
            Screen::default(),
        );
        let t = Instant::now();
        let mut chosen = 0;
        for _ in 0..100 {
            chosen += dag.cut(&view).len();
        }
        let cut_ms = t.elapsed().as_secs_f64() * 10.0;
        std::hint::black_box(chosen);
        let c = theirs_built.expect("built");
        let levels = c.groups.iter().map(|g| g.0).max().unwrap_or(0) + 1;
        let terminal: Vec<&(usize, i32, Vec<u32>)> = c
            .clusters
            .iter()
            .filter(|(g, _, _)| c.groups[*g].1 == f32::MAX)
            .collect();
        let terminal_tris: usize = terminal.iter().map(|c| c.2.len() / 3).sum();
        let mut errors: Vec<f64> = dag.clusters.iter().map(|c| c.error).collect();
        errors.sort_by(f64::total_cmp);
        errors.dedup();
        for frac in [1e-4, 1e-3, 1e-2] {
            let t = (frac * diag) as f32;
            let mc = clod_cut(&c, &positions, t);
            let want = mc.triangles.len();
            // Our cut with the fewest triangles not below meshoptimizer's count.
            let mut best: Option<Mesh> = None;
            for &e in errors.iter().rev() {
                let cut = dag_cut(&dag, e);
                if cut.triangles.len() >= want {
                    best = Some(cut);
                    break;
                }
            }
            let oc = best.unwrap_or_else(|| dag_cut(&dag, 0.0));
            let ho = hausdorff(&m, &oc, &sampling);
            let hm = hausdorff(&m, &mc, &sampling);
            let pct = |x: f64| 100.0 * x / diag;
            println!(
                "| {name} | {} | {:.2} / {:.2} | {cut_ms:.3} | {} / {levels} | {} ({}) / {} ({terminal_tris}) | {}% | {} / {want} | {:.3} / {:.3} | {:.4} / {:.4} |",
                m.triangles.len(),
                median(&mut ours.clone()),
                median(&mut theirs.clone()),
                report.depth + 1,
                report.roots,
                report.root_triangles,
                terminal.len(),
                100.0 * frac,
                oc.triangles.len(),
                pct(ho.hausdorff),
                pct(hm.hausdorff),
                pct(ho.mean),
                pct(hm.mean),
            );
        }
    }
}
