//! The vertex fitting after QEM (`SimplifyOptions::fit_iterations`, `meshlod
//! simplify --fit`) on the repository's test meshes at 10% and 1%: it keeps every
//! triangle (the same index triples as without it: only positions change), keeps
//! border points where they were, moves points, lowers the symmetric Hausdorff mean
//! (over the cases; in each, it rises by less than 10%), does not raise the maximum
//! beyond sampling noise (1%), makes no degenerate triangle and turns no triangle
//! away from the input.

mod common;

use meshlod::io::read_scene;
use meshlod::mesh::MeshStats;
use meshlod::simplify::{simplify, SimplifyOptions, DEFAULT_FIT_ITERATIONS};
use std::collections::HashMap;

/// Positions of the points on a border edge (an edge used by one triangle, by
/// position), as bit patterns.
fn border_points(m: &meshlod::Mesh) -> Vec<[u32; 3]> {
    let key = |v: u32| m.positions[v as usize].map(f32::to_bits);
    let mut count: HashMap<([u32; 3], [u32; 3]), usize> = HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (key(t[k]), key(t[(k + 1) % 3]));
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut out: Vec<[u32; 3]> = count
        .into_iter()
        .filter(|&(_, c)| c == 1)
        .flat_map(|((a, b), _)| [a, b])
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// Runs `check(name, input, options)` for the bunny, fandisk and the cow at 10% and
/// 1%, the options without the orientation repair (so that it cannot change the
/// triangles either way).
fn for_each_case(mut check: impl FnMut(&str, &meshlod::Mesh, SimplifyOptions)) {
    for file in ["stanford-bunny.obj", "fandisk.obj", "cow.obj"] {
        let mesh = read_scene(common::data_dir().join(file))
            .expect("test mesh reads")
            .flatten();
        for ratio in [0.1, 0.01] {
            let base = SimplifyOptions::default()
                .with_ratio(ratio)
                .with_facing_repair(false);
            check(&format!("{file} @ {ratio}"), &mesh, base);
        }
    }
}

/// `on` (a post-pass applied to `off`, both simplified from `mesh`) has no more
/// triangles facing away from the input than `off` (the tests' own count, without
/// the area floor), a symmetric Hausdorff maximum at most 1% above `off`'s (sampling
/// noise) and a mean below `mean_factor` times `off`'s. Prints `what` and the
/// distances; returns the mean's ratio `on / off`.
fn assert_closer_and_facing(
    name: &str,
    mesh: &meshlod::Mesh,
    off: &meshlod::Mesh,
    on: &meshlod::Mesh,
    mean_factor: f64,
    what: &str,
) -> f64 {
    let bvh = meshlod::metrics::bvh::Bvh::build(&mesh.positions, &mesh.triangles);
    let (f_off, f_on) = (
        common::flipped(mesh, &bvh, off),
        common::flipped(mesh, &bvh, on),
    );
    assert!(f_on <= f_off, "{name}: facing away {f_off} -> {f_on}");
    let (d_off, d_on, line) = common::distances_before_after(mesh, off, on);
    eprintln!("{name}: {what}; {line}");
    assert!(
        d_on.hausdorff <= 1.01 * d_off.hausdorff,
        "{name}: H max rose"
    );
    assert!(
        d_on.mean < mean_factor * d_off.mean,
        "{name}: H mean did not fall"
    );
    d_on.mean / d_off.mean
}

#[test]
fn fitting_lowers_the_mean_without_raising_the_maximum() {
    let (mut log_ratio, mut cases) = (0.0f64, 0u32);
    for_each_case(|name, mesh, base| {
        let (off, r_off) = simplify(mesh, &base.clone()).unwrap();
        let (on, r_on) = simplify(mesh, &base.with_fit_iterations(DEFAULT_FIT_ITERATIONS)).unwrap();
        assert_eq!(r_off.fit_moved, 0, "{name}");
        assert!(r_on.fit_moved > 0, "{name}: nothing moved");
        assert_eq!(on.triangles, off.triangles, "{name}: triangles changed");
        assert_eq!(on.positions.len(), off.positions.len(), "{name}");
        assert_eq!(
            border_points(&on),
            border_points(&off),
            "{name}: a border point moved"
        );
        let moved = on
            .positions
            .iter()
            .zip(&off.positions)
            .filter(|(a, b)| a != b)
            .count();
        assert!(moved > 0, "{name}");
        let st = MeshStats::of(&on).topology;
        assert_eq!(st.degenerate_triangles, 0, "{name}");
        let what = format!("{} points moved", r_on.fit_moved);
        // Per case the mean may rise a little where the fit trades it for the
        // maximum: fandisk at 1% (128 triangles) +8%, its maximum −20%.
        log_ratio += assert_closer_and_facing(name, mesh, &off, &on, 1.1, &what).ln();
        cases += 1;
    });
    // Over the cases the mean falls (geometric mean of the ratios).
    let ratio = (log_ratio / f64::from(cases)).exp();
    eprintln!("mean ratio over {cases} cases: {ratio:.3}");
    assert!(ratio < 0.97, "H mean did not fall overall: ×{ratio:.3}");
}

/// Edge swaps toward the input (`SimplifyOptions::edge_swaps`, `meshlod simplify
/// --swap`) on the same meshes: no point moves and the counts, borders and
/// manifoldness stay; the Hausdorff mean falls, the maximum does not rise beyond
/// sampling noise (1%), no triangle degenerates and no more turn away from the input.
#[test]
fn swaps_lower_the_mean_and_keep_the_mesh_sound() {
    for_each_case(|name, mesh, base| {
        let (off, r_off) = simplify(mesh, &base.clone()).unwrap();
        let (on, r_on) = simplify(mesh, &base.with_edge_swaps(true)).unwrap();
        assert_eq!(r_off.edge_swaps, 0, "{name}");
        assert!(r_on.edge_swaps > 0, "{name}: nothing swapped");
        assert_eq!(r_on.fit_moved, 0, "{name}");
        assert_eq!(on.positions, off.positions, "{name}: a point moved");
        assert_eq!(on.triangles.len(), off.triangles.len(), "{name}");
        assert_ne!(on.triangles, off.triangles, "{name}");
        assert_eq!(border_points(&on), border_points(&off), "{name}: borders");
        let (s_off, s_on) = (MeshStats::of(&off).topology, MeshStats::of(&on).topology);
        assert_eq!(s_on.degenerate_triangles, 0, "{name}");
        assert_eq!(s_on.duplicate_triangles, 0, "{name}");
        assert_eq!(s_on.non_manifold_edges, s_off.non_manifold_edges, "{name}");
        assert_eq!(s_on.boundary_edges, s_off.boundary_edges, "{name}");
        let what = format!("{} swaps", r_on.edge_swaps);
        assert_closer_and_facing(name, mesh, &off, &on, 0.995, &what);
    });
}
