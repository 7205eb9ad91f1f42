//! [`Method::VertexRemoval`] through the public API: the shared invariants, the
//! promise that output vertices are input vertices (exact positions and attributes),
//! hand-built cases, the error bound, and random meshes.

use super::tests::check_invariants;
use super::*;
use crate::mesh::{generate, MeshStats};
use crate::metrics::{hausdorff, SamplingOptions};
use proptest::prelude::*;

fn vr() -> SimplifyOptions {
    SimplifyOptions::default().with_method(Method::VertexRemoval)
}

/// Every output vertex is the input vertex it names, bit for bit (position and all
/// attributes).
fn assert_vertices_are_input(input: &Mesh, s: &Simplified) {
    assert_eq!(s.vertex_source.len(), s.mesh.positions.len());
    for (i, &src) in s.vertex_source.iter().enumerate() {
        let (a, b) = (s.mesh.positions[i], input.positions[src as usize]);
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "vertex {i} moved");
    }
    assert_eq!(
        s.mesh.attributes,
        input.attributes.gather(&s.vertex_source),
        "attributes changed"
    );
}

fn run(m: &Mesh, o: &SimplifyOptions) -> Simplified {
    let s = simplify_observed(m, o, &mut NoObserver).expect("valid");
    check_invariants(m, &s.mesh, &s.report);
    assert_vertices_are_input(m, &s);
    s
}

/// A flat 10 × 10 grid (200 triangles) goes down to its 4 corners: 2 triangles,
/// with zero error (every removed point lies on the plane or on a straight border).
#[test]
fn flat_grid_to_two_triangles() {
    let m = generate::grid(10, 10, |_, _| 0.0);
    let s = run(
        &m,
        &vr()
            .with_target_triangles(0)
            .with_max_error(Distance::Absolute(1e-9)),
    );
    assert_eq!(s.mesh.triangles.len(), 2);
    assert_eq!(s.mesh.positions.len(), 4);
    assert_eq!(s.report.stop_reason, StopReason::MaxError);
    assert!(s.report.error_absolute < 1e-9);
    let st = MeshStats::of(&s.mesh);
    assert_eq!(st.topology.boundary_loops, 1);
}

/// A strip of 8 flat quads (16 triangles, one boundary loop, every vertex on the
/// boundary) goes down to 2 triangles over its 4 corners.
/// ```text
///  9--10--11-- ... --17
///  |  / |  \ |        |
///  0---1---2-- ... ---8
/// ```
#[test]
fn boundary_strip_to_two_triangles() {
    let m = generate::grid(8, 1, |_, _| 0.0);
    let s = run(
        &m,
        &vr()
            .with_target_triangles(0)
            .with_max_error(Distance::Absolute(1e-9)),
    );
    assert_eq!(s.mesh.triangles.len(), 2);
    let st = MeshStats::of(&s.mesh);
    assert_eq!(st.topology.boundary_loops, 1);
    assert_eq!(st.topology.boundary_edges, 4);
}

/// A tetrahedron never becomes two triangles back to back.
#[test]
fn tetrahedron_is_kept() {
    let m = generate::tetrahedron();
    let s = run(&m, &vr().with_target_triangles(0));
    assert_eq!(s.mesh.triangles.len(), 4);
    assert_eq!(s.report.stop_reason, StopReason::NoLegalCollapse);
}

/// An octahedron (every vertex a corner at the default feature angle) goes down to a
/// closed tetrahedron when corners may go, and stays whole with `keep_corners`.
#[test]
fn octahedron() {
    let m = generate::icosphere(0); // the level-0 sphere is an icosahedron
    assert_eq!(m.triangles.len(), 20);
    let oct = Mesh::from_triangles(
        vec![
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ],
        vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ],
    );
    let s = run(&oct, &vr().with_target_triangles(0));
    assert_eq!(s.mesh.triangles.len(), 4);
    let st = MeshStats::of(&s.mesh);
    assert_eq!(st.topology.boundary_edges, 0);
    assert_eq!(st.topology.non_manifold_edges, 0);
    let s = run(&oct, &vr().with_target_triangles(0).with_keep_corners(true));
    assert_eq!(s.mesh.triangles.len(), 8);
    // The icosahedron's points are corners too (dihedral 41.8°); with a feature angle
    // above that they are simple and it goes down to a double pyramid over a
    // triangle: the last removal, to a (flat) tetrahedron, would leave a triangle
    // facing away from the input, and the stop detail says so.
    let s = run(&m, &vr().with_target_triangles(0).with_feature_angle(45.0));
    assert_eq!(s.mesh.triangles.len(), 6);
    assert!(
        s.report.stop_detail.contains("facing away"),
        "{}",
        s.report.stop_detail
    );
}

/// A sphere keeps its closed topology and reaches the targets it is given.
#[test]
fn sphere_ratios() {
    let m = generate::icosphere(4); // 5120
    for ratio in [0.5, 0.1, 0.01] {
        let s = run(&m, &vr().with_ratio(ratio));
        assert_eq!(s.report.stop_reason, StopReason::TargetReached, "{ratio}");
        let st = MeshStats::of(&s.mesh);
        assert_eq!(st.topology.boundary_edges, 0);
        assert_eq!(st.topology.components, 1);
    }
}

/// Open tube and torus: boundaries stay boundaries, genus stays.
#[test]
fn tube_and_torus_keep_topology() {
    for m in [
        generate::cylinder(32, 16, 3.0, false),
        generate::torus(48, 24, 2.0, 0.6),
    ] {
        let before = MeshStats::of(&m);
        let s = run(&m, &vr().with_ratio(0.05));
        let after = MeshStats::of(&s.mesh);
        assert_eq!(
            after.topology.boundary_loops,
            before.topology.boundary_loops
        );
        assert_eq!(after.topology.genus, before.topology.genus);
    }
}

/// The accumulated bound holds: the measured symmetric Hausdorff distance never
/// exceeds the reported error, and `max_error` caps it.
#[test]
fn error_bound_holds() {
    let m = generate::grid(40, 40, |x, y| 0.1 * (7.0 * x).sin() * (5.0 * y).cos());
    for e in [0.002, 0.01, 0.05] {
        let s = run(&m, &vr().with_max_error(Distance::Absolute(e)));
        assert!(s.report.error_absolute <= e);
        let d = hausdorff(&m, &s.mesh, &SamplingOptions::default());
        assert!(
            d.hausdorff <= s.report.error_absolute * (1.0 + 1e-6) + 1e-12,
            "measured {} above the bound {}",
            d.hausdorff,
            s.report.error_absolute
        );
        assert!(s.mesh.triangles.len() < m.triangles.len());
    }
}

/// A UV seam down the middle of a grid (two wedges per seam point): output vertices
/// are input vertices, and every output triangle stays on one side of the seam (its
/// corners' u coordinates all on the same side).
#[test]
fn uv_seam_respected() {
    let n = 12;
    let g = generate::grid(n, n, |x, y| 0.05 * (3.0 * x).sin() * y);
    // Duplicate the vertices of the right half (x >= 0.5) with shifted UVs.
    let mut positions = g.positions.clone();
    let mut uv: Vec<[f32; 2]> = g.positions.iter().map(|p| [p[0], p[1]]).collect();
    let mut right = vec![u32::MAX; g.positions.len()];
    for (i, p) in g.positions.iter().enumerate() {
        if p[0] >= 0.5 {
            right[i] = positions.len() as u32;
            positions.push(*p);
            uv.push([p[0] + 10.0, p[1]]);
        }
    }
    let triangles = g
        .triangles
        .iter()
        .map(|t| {
            let cx: f32 = t.iter().map(|&i| g.positions[i as usize][0]).sum::<f32>() / 3.0;
            if cx > 0.5 {
                t.map(|i| right[i as usize])
            } else {
                *t
            }
        })
        .collect();
    let mut m = Mesh::from_triangles(positions, triangles);
    m.attributes.uv0 = Some(uv);
    m.compact_vertices();
    let s = run(&m, &vr().with_ratio(0.1));
    let uv = s.mesh.attributes.uv0.as_ref().unwrap();
    for t in &s.mesh.triangles {
        let sides: Vec<bool> = t.iter().map(|&i| uv[i as usize][0] > 5.0).collect();
        assert!(
            sides.iter().all(|&x| x == sides[0]),
            "a triangle crosses the seam"
        );
    }
    assert!(s.mesh.triangles.len() < m.triangles.len() / 2);
}

/// The inexact orders (order slack, deferred re-keying) keep every invariant, reach
/// the targets, and keep the accumulated bound above the measured distance; a slack
/// below 1 is the exact order, and deferring does change the order.
#[test]
fn inexact_orders_keep_invariants_and_bound() {
    let bumpy = generate::grid(40, 40, |x, y| 0.1 * (7.0 * x).sin() * (5.0 * y).cos());
    let exact = run(&bumpy, &vr().with_exact_order().with_ratio(0.1));
    let below_one = run(
        &bumpy,
        &vr()
            .with_exact_order()
            .with_ratio(0.1)
            .with_order_slack(0.5),
    );
    assert_eq!(exact.mesh, below_one.mesh);
    let mut differs = false;
    for (slack, defer) in [(1.5, None), (1.0, Some(1.0)), (1.2, Some(1.5))] {
        let o = vr()
            .with_exact_order()
            .with_order_slack(slack)
            .with_defer_neighbours(defer);
        for m in [&bumpy, &generate::torus(48, 24, 2.0, 0.6)] {
            let s = run(m, &o.clone().with_ratio(0.1));
            assert_eq!(s.report.stop_reason, StopReason::TargetReached);
            let (a, b) = (MeshStats::of(m), MeshStats::of(&s.mesh));
            assert_eq!(a.topology.genus, b.topology.genus);
            assert_eq!(a.topology.boundary_loops, b.topology.boundary_loops);
        }
        let s = run(&bumpy, &o.clone().with_ratio(0.1));
        differs |= s.mesh != exact.mesh;
        let e = 0.01;
        let s = run(&bumpy, &o.with_max_error(Distance::Absolute(e)));
        assert!(s.report.error_absolute <= e);
        let d = hausdorff(&bumpy, &s.mesh, &SamplingOptions::default());
        assert!(d.hausdorff <= s.report.error_absolute * (1.0 + 1e-6) + 1e-12);
    }
    assert!(differs, "the inexact orders gave the exact order's mesh");
}

/// Deferring only below a key (`defer_below`): at 0 the first removal already
/// switches to the exact order (the exact order's mesh), above every key it is plain
/// deferral (its mesh); in between, and with the deferred bound (`defer_bound`), the
/// runs keep every invariant, reach the target, keep the bound above the measured
/// distance, and are deterministic.
#[test]
fn partial_and_bounded_deferral() {
    let bumpy = generate::grid(40, 40, |x, y| 0.1 * (7.0 * x).sin() * (5.0 * y).cos());
    let torus = generate::torus(48, 24, 2.0, 0.6);
    for m in [&bumpy, &torus] {
        let base = vr().with_exact_order().with_ratio(0.05);
        let exact = run(m, &base);
        let deferred = run(m, &base.clone().with_defer_neighbours(Some(1.0)));
        assert_ne!(exact.mesh, deferred.mesh, "deferral changed nothing");
        let at_zero = base
            .clone()
            .with_defer_neighbours(Some(1.0))
            .with_defer_below(Some(0.0));
        assert_eq!(run(m, &at_zero).mesh, exact.mesh);
        let above_all = base
            .clone()
            .with_defer_neighbours(Some(1.0))
            .with_defer_below(Some(1e9));
        assert_eq!(run(m, &above_all).mesh, deferred.mesh);
        for o in [
            base.clone()
                .with_defer_neighbours(Some(1.0))
                .with_defer_below(Some(2e-3)),
            base.clone()
                .with_defer_neighbours(Some(1.0))
                .with_defer_bound(true),
            base.clone()
                .with_defer_neighbours(Some(1.5))
                .with_defer_below(Some(1e-3))
                .with_defer_bound(true),
        ] {
            let s = run(m, &o);
            assert_eq!(s.report.stop_reason, StopReason::TargetReached);
            assert_eq!(s.mesh, run(m, &o).mesh, "not deterministic");
            let (a, b) = (MeshStats::of(m), MeshStats::of(&s.mesh));
            assert_eq!(a.topology.genus, b.topology.genus);
            assert_eq!(a.topology.boundary_loops, b.topology.boundary_loops);
            let d = hausdorff(m, &s.mesh, &SamplingOptions::default());
            assert!(d.hausdorff <= s.report.error_absolute * (1.0 + 1e-6) + 1e-12);
        }
    }
}

/// The default order is the fast one (deferred neighbours, slack 1.2, exact from
/// `FAST_ORDER_EXACT_FROM` on): it differs from the exact order, keeps every
/// invariant, reaches the target and keeps the bound above the measured distance;
/// and with a tiny switch key it is the exact order.
#[test]
fn default_fast_order_and_exact_order() {
    let bumpy = generate::grid(40, 40, |x, y| 0.1 * (7.0 * x).sin() * (5.0 * y).cos());
    let fast = vr().with_ratio(0.05);
    assert_eq!(fast.defer_neighbours, Some(1.0));
    let exact = run(&bumpy, &vr().with_exact_order().with_ratio(0.05));
    let s = run(&bumpy, &fast);
    assert_eq!(s.report.stop_reason, StopReason::TargetReached);
    assert_ne!(s.mesh, exact.mesh, "the fast order is the exact order here");
    let d = hausdorff(&bumpy, &s.mesh, &SamplingOptions::default());
    assert!(d.hausdorff <= s.report.error_absolute * (1.0 + 1e-6) + 1e-12);
    assert_eq!(
        run(&bumpy, &fast.with_defer_below(Some(0.0))).mesh,
        exact.mesh
    );
}

/// Deterministic: the same input gives the same output.
#[test]
fn deterministic() {
    let m = generate::torus(40, 20, 2.0, 0.7);
    let a = run(&m, &vr().with_ratio(0.2));
    let b = run(&m, &vr().with_ratio(0.2));
    assert_eq!(a.mesh, b.mesh);
}

/// Options are checked.
#[test]
fn bad_feature_angle() {
    let m = generate::tetrahedron();
    assert!(matches!(
        simplify(&m, &vr().with_feature_angle(200.0)),
        Err(SimplifyError::Option {
            name: "feature_angle",
            ..
        })
    ));
}

/// Random height fields with holes and junk triangles (the QEM tests' generator).
fn random_mesh() -> impl Strategy<Value = Mesh> {
    (
        3u32..14,
        3u32..14,
        prop::collection::vec(-1.0f32..1.0, 256),
        prop::collection::vec(any::<bool>(), 400),
        prop::collection::vec((0u32..300, 0u32..300, 0u32..300), 0..6),
    )
        .prop_map(|(n, m, heights, keep, junk)| {
            let mut g = generate::grid(n, m, |_, _| 0.0);
            for (i, p) in g.positions.iter_mut().enumerate() {
                p[2] = 0.3 * heights[i % heights.len()];
            }
            g.triangles = g
                .triangles
                .iter()
                .enumerate()
                .filter(|(i, _)| keep[i % keep.len()] || i % 3 != 0)
                .map(|(_, t)| *t)
                .collect();
            let nv = g.positions.len() as u32;
            for (a, b, c) in junk {
                g.triangles.push([a % nv, b % nv, c % nv]);
            }
            g
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn random_meshes_keep_invariants(
        m in random_mesh(),
        ratio in prop::sample::select(vec![0.5, 0.1, 0.01]),
        keep_corners in any::<bool>(),
        angle in prop::sample::select(vec![0.0, 15.0, 60.0, 180.0]),
    ) {
        let o = vr().with_ratio(ratio).with_keep_corners(keep_corners).with_feature_angle(angle);
        run(&m, &o);
    }

    #[test]
    fn random_soups_never_panic(
        pos in prop::collection::vec((-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0), 3..40),
        idx in prop::collection::vec((0u32..40, 0u32..40, 0u32..40), 0..80),
        ratio in 0.0f64..1.0,
    ) {
        let n = pos.len() as u32;
        let m = Mesh::from_triangles(
            pos.iter().map(|&(x, y, z)| [x, y, z]).collect(),
            idx.iter().map(|&(a, b, c)| [a % n, b % n, c % n]).collect(),
        );
        run(&m, &vr().with_ratio(ratio));
    }
}
