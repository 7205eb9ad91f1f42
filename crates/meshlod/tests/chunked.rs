//! QEM on a mesh large enough to be simplified in chunks (a million triangles or
//! more): the output is the same for every thread count, reaches the target,
//! keeps the border loop, and stays close to the whole-mesh run.

use meshlod::mesh::generate;
use meshlod::metrics::{hausdorff, SamplingOptions};
use meshlod::simplify::{simplify, SimplifyOptions, StopReason};
use meshlod::{Mesh, MeshStats};

/// A 730 × 730 grid (1,065,800 triangles) of bumpy terrain: hills on a slope.
fn terrain() -> Mesh {
    generate::grid(730, 730, |x, y| {
        0.08 * (9.0 * x).sin() * (7.0 * y).cos() + 0.03 * (31.0 * x + 17.0 * y).sin() + 0.1 * x
    })
}

#[test]
fn chunked_output_is_the_same_for_every_thread_count() {
    let mesh = terrain();
    assert!(mesh.triangles.len() >= 1 << 20);
    // At 1% the chunks keep 8× the ratio; at 10%, 2×; at 0.1%, four times the
    // share of border points (the terrain's 0.8% at 8× would leave chunks of
    // locked borders: 1.9× the whole mesh's maximum, 1.6× its mean).
    for ratio in [0.001, 0.01, 0.1] {
        chunked_run(&mesh, ratio);
    }
}

/// `mesh` simplified to `ratio` in chunks on 1, 2 and 4 threads (the same
/// output), against the whole mesh at once.
fn chunked_run(mesh: &Mesh, ratio: f64) {
    let run = |threads: usize| {
        let o = SimplifyOptions::default()
            .with_ratio(ratio)
            .with_threads(Some(threads));
        simplify(mesh, &o).expect("simplifies")
    };
    let (one, r1) = run(1);
    assert_eq!(
        r1.stop_reason,
        StopReason::TargetReached,
        "{}",
        r1.stop_detail
    );
    assert!(r1.stop_detail.contains("chunks"), "{}", r1.stop_detail);
    assert!(one.triangles.len() <= r1.target_triangles);
    assert!(one
        .triangles
        .iter()
        .flatten()
        .all(|&v| (v as usize) < one.positions.len()));
    let stats = MeshStats::of(&one);
    assert_eq!(stats.topology.non_manifold_edges, 0);
    assert_eq!(
        stats.topology.boundary_loops, 1,
        "the grid's one border loop is kept"
    );
    for threads in [2, 4] {
        let (out, _) = run(threads);
        assert_eq!(out.positions, one.positions, "{threads} threads");
        assert_eq!(out.triangles, one.triangles, "{threads} threads");
    }
    // Close to the whole mesh simplified at once (the exact global order).
    let mut whole = SimplifyOptions::default().with_ratio(ratio);
    whole.chunks = false;
    let (w, _) = simplify(mesh, &whole).expect("simplifies");
    let s = SamplingOptions::default().with_samples(200_000);
    let dc = hausdorff(mesh, &one, &s);
    let dw = hausdorff(mesh, &w, &s);
    assert!(
        dc.mean <= 1.25 * dw.mean && dc.hausdorff <= 1.5 * dw.hausdorff,
        "ratio {ratio}: chunked {:.3e} / {:.3e} against whole {:.3e} / {:.3e}",
        dc.hausdorff,
        dc.mean,
        dw.hausdorff,
        dw.mean
    );
}
