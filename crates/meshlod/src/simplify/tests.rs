//! Tests of the public simplification API on generated meshes: invariants (valid
//! indices, no degenerate/duplicate triangles, target reached or explained, no new
//! boundary or non-manifold edges, no fold-overs against an analytic normal),
//! options, errors, attributes and determinism.

use super::*;
use crate::mesh::{generate, MeshStats};
use crate::quadric::{cross, dot, sub};
use proptest::prelude::*;

fn f64x3(p: [f32; 3]) -> [f64; 3] {
    p.map(f64::from)
}

fn normal(m: &Mesh, t: [u32; 3]) -> [f64; 3] {
    let [a, b, c] = t.map(|i| f64x3(m.positions[i as usize]));
    cross(sub(b, a), sub(c, a))
}

/// Checks the invariants every output must satisfy against its input.
/// Boundary and non-manifold counts are compared with the *repaired* input (the
/// input after the documented removal of degenerate and duplicate triangles, which
/// can itself open boundary edges in a soup).
pub(crate) fn check_invariants(input: &Mesh, out: &Mesh, report: &Report) {
    out.validate().expect("output validates");
    let (repaired, r) = simplify(input, &SimplifyOptions::default().with_ratio(1.0)).unwrap();
    assert_eq!(r.collapses, 0);
    let si = MeshStats::of(&repaired);
    let so = MeshStats::of(out);
    assert_eq!(
        so.topology.degenerate_triangles, 0,
        "degenerate output triangles"
    );
    assert_eq!(
        so.topology.duplicate_triangles, 0,
        "duplicate output triangles"
    );
    assert!(
        so.topology.boundary_edges <= si.topology.boundary_edges,
        "boundary edges grew: {} -> {}",
        si.topology.boundary_edges,
        so.topology.boundary_edges
    );
    assert!(
        so.topology.non_manifold_edges <= si.topology.non_manifold_edges,
        "non-manifold edges grew: {} -> {}",
        si.topology.non_manifold_edges,
        so.topology.non_manifold_edges
    );
    assert_eq!(so.unreferenced_vertices, 0);
    assert_eq!(report.triangles_out, out.triangles.len());
    assert_eq!(report.vertices_out, out.positions.len());
    if report.stop_reason == StopReason::TargetReached {
        let t = report.target_triangles as f64;
        let o = out.triangles.len() as f64;
        assert!(o <= t, "{o} triangles for target {t}");
        // Within 1% (one collapse removes up to two triangles), unless the repaired
        // input was already below the target.
        assert!(
            o >= t - (0.01 * t).max(1.0) || report.collapses == 0,
            "{o} for {t}"
        );
    } else if report.stop_reason == StopReason::EmptyInput {
        assert!(out.triangles.is_empty());
    } else {
        assert!(out.triangles.len() > report.target_triangles);
        assert!(!report.stop_detail.is_empty());
    }
}

/// Every output triangle of a convex closed surface around the origin faces out.
fn assert_faces_out(m: &Mesh) {
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| f64x3(m.positions[i as usize]));
        let centroid = [
            (a[0] + b[0] + c[0]) / 3.0,
            (a[1] + b[1] + c[1]) / 3.0,
            (a[2] + b[2] + c[2]) / 3.0,
        ];
        assert!(dot(normal(m, *t), centroid) > 0.0, "a triangle folded over");
    }
}

#[test]
fn icosphere_to_ten_and_one_percent() {
    let sphere = generate::icosphere(4); // 5120 triangles
    for (ratio, target) in [(0.5, 2560), (0.1, 512), (0.01, 51)] {
        let (out, report) =
            simplify(&sphere, &SimplifyOptions::default().with_ratio(ratio)).unwrap();
        check_invariants(&sphere, &out, &report);
        assert_eq!(report.stop_reason, StopReason::TargetReached);
        assert_eq!(report.target_triangles, target);
        assert_faces_out(&out);
        // Closed genus-0 stays closed genus-0.
        assert_eq!(MeshStats::of(&out).topology.genus, Some(0));
        // All vertices stay close to the unit sphere.
        let worst = out
            .positions
            .iter()
            .map(|p| (dot(f64x3(*p), f64x3(*p)).sqrt() - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(
            worst < [0.01, 0.05, 0.3][(ratio < 0.5) as usize + (ratio < 0.1) as usize],
            "{worst}"
        );
        assert!(report.error > 0.0 && report.error < 0.2);
    }
}

/// A flat grid simplifies to (almost) nothing without moving off the plane and
/// without losing its square outline.
#[test]
fn flat_grid_keeps_plane_and_outline() {
    let grid = generate::grid(20, 20, |_, _| 0.0); // 800 triangles
    let (out, report) = simplify(&grid, &SimplifyOptions::default().with_ratio(0.01)).unwrap();
    check_invariants(&grid, &out, &report);
    assert!(out.positions.iter().all(|p| p[2] == 0.0));
    // Corners of the square survive exactly.
    for corner in [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ] {
        assert!(out.positions.contains(&corner), "lost corner {corner:?}");
    }
    // Area preserved: the outline did not shrink.
    let area: f64 = out
        .triangles
        .iter()
        .map(|t| 0.5 * dot(normal(&out, *t), [0.0, 0.0, 1.0]))
        .sum();
    assert!((area - 1.0).abs() < 1e-5, "area {area}");
    assert!(report.error < 1e-6);
}

/// A bumpy height field: every output triangle still faces up (no fold-over).
#[test]
fn height_field_has_no_fold_overs() {
    let grid = generate::grid(40, 40, |x, y| 0.1 * (7.0 * x).sin() * (5.0 * y).cos());
    for ratio in [0.5, 0.1, 0.01] {
        let (out, report) = simplify(&grid, &SimplifyOptions::default().with_ratio(ratio)).unwrap();
        check_invariants(&grid, &out, &report);
        for t in &out.triangles {
            assert!(normal(&out, *t)[2] > 0.0, "fold-over at ratio {ratio}");
        }
    }
}

#[test]
fn torus_keeps_genus() {
    let torus = generate::torus(48, 24, 2.0, 0.6); // 2304 triangles
    for ratio in [0.5, 0.1, 0.02] {
        let (out, report) =
            simplify(&torus, &SimplifyOptions::default().with_ratio(ratio)).unwrap();
        check_invariants(&torus, &out, &report);
        assert_eq!(MeshStats::of(&out).topology.genus, Some(1));
        assert_eq!(report.stop_reason, StopReason::TargetReached);
    }
}

#[test]
fn open_cylinder_keeps_two_border_loops() {
    let tube = generate::cylinder(32, 16, 3.0, false);
    let (out, report) = simplify(&tube, &SimplifyOptions::default().with_ratio(0.1)).unwrap();
    check_invariants(&tube, &out, &report);
    assert_eq!(MeshStats::of(&out).topology.boundary_loops, 2);
    // Border vertices stay on their rims (z = 0 or z = 3).
    let s = MeshStats::of(&out);
    assert_eq!(s.topology.components, 1);
}

#[test]
fn lock_boundary_keeps_every_border_vertex() {
    let grid = generate::grid(10, 10, |x, y| 0.05 * (x * y));
    let (out, report) = simplify(
        &grid,
        &SimplifyOptions::default()
            .with_ratio(0.1)
            .with_lock_boundary(true),
    )
    .unwrap();
    check_invariants(&grid, &out, &report);
    for i in 0..=10 {
        let f = i as f32 / 10.0;
        for p in [[f, 0.0], [f, 1.0], [0.0, f], [1.0, f]] {
            assert!(
                out.positions.iter().any(|q| q[0] == p[0] && q[1] == p[1]),
                "border vertex {p:?} lost"
            );
        }
    }
    assert_eq!(MeshStats::of(&out).topology.boundary_edges, 40);
}

#[test]
fn locked_vertices_stay_put() {
    let sphere = generate::icosphere(3);
    let mut mask = vec![false; sphere.positions.len()];
    for i in (0..mask.len()).step_by(7) {
        mask[i] = true;
    }
    // With and without the vertex fitting, which must not move them either (it
    // moves other points: asserted through `fit_moved`, the locks are sparse).
    for fit in [0, crate::simplify::DEFAULT_FIT_ITERATIONS] {
        let sphere = generate::icosphere(4);
        let mut mask = vec![false; sphere.positions.len()];
        for i in (0..mask.len()).step_by(29) {
            mask[i] = true;
        }
        let (out, report) = simplify(
            &sphere,
            &SimplifyOptions::default()
                .with_ratio(0.1)
                .with_locked_vertices(mask.clone())
                .with_fit_iterations(fit)
                .with_edge_swaps(fit > 0),
        )
        .unwrap();
        check_invariants(&sphere, &out, &report);
        assert_eq!(report.fit_moved > 0, fit > 0, "fit {fit}");
        for (i, &l) in mask.iter().enumerate() {
            if l {
                assert!(out.positions.contains(&sphere.positions[i]), "fit {fit}");
            }
        }
    }
    let bad = simplify(
        &sphere,
        &SimplifyOptions::default().with_locked_vertices(vec![true]),
    );
    assert!(matches!(bad, Err(SimplifyError::LockMask { len: 1, .. })));
}

#[test]
fn max_error_stops_early() {
    let sphere = generate::icosphere(4);
    let opts = SimplifyOptions::default().with_max_error(Distance::Relative(0.001));
    let (out, report) = simplify(&sphere, &opts).unwrap();
    check_invariants(&sphere, &out, &report);
    assert_eq!(report.stop_reason, StopReason::MaxError);
    assert!(report.error <= 0.001);
    assert!(out.triangles.len() < sphere.triangles.len());
    // A loose bound with a ratio: the ratio wins.
    let opts = SimplifyOptions::default()
        .with_ratio(0.5)
        .with_max_error(Distance::Absolute(1.0));
    let (_, report) = simplify(&sphere, &opts).unwrap();
    assert_eq!(report.stop_reason, StopReason::TargetReached);
}

#[test]
fn empty_nan_and_bad_options() {
    let (out, report) = simplify(&Mesh::default(), &SimplifyOptions::default()).unwrap();
    assert!(out.triangles.is_empty());
    assert_eq!(report.stop_reason, StopReason::EmptyInput);
    let mut m = generate::icosphere(1);
    m.positions[3][1] = f32::NAN;
    assert!(matches!(
        simplify(&m, &SimplifyOptions::default()),
        Err(SimplifyError::Invalid(MeshError::NonFinite {
            vertex: 3,
            ..
        }))
    ));
    let m = generate::icosphere(1);
    for o in [
        SimplifyOptions::default().with_ratio(1.5),
        SimplifyOptions::default().with_ratio(f64::NAN),
        SimplifyOptions::default().with_max_error(Distance::Relative(-1.0)),
        SimplifyOptions::default().with_boundary_weight(f64::INFINITY),
        SimplifyOptions::default().with_max_normal_deviation(200.0),
        SimplifyOptions::default().with_min_triangle_quality(2.0),
        SimplifyOptions::default().with_solve_condition(f64::NAN),
        SimplifyOptions::default().with_solve_condition(-1.0),
        SimplifyOptions::default().with_solve_condition(1.0),
        SimplifyOptions::default().with_solve_condition(f64::INFINITY),
        SimplifyOptions::default().with_displacement_guard(f64::NAN),
        SimplifyOptions::default().with_displacement_guard(-1.0),
        SimplifyOptions::default().with_displacement_guard(f64::INFINITY),
    ] {
        assert!(
            matches!(simplify(&m, &o), Err(SimplifyError::Option { .. })),
            "{o:?}"
        );
    }
}

/// The QEM options `solve_condition` and `displacement_guard` reach the cost model:
/// on a bumpy sphere, a near-1 conditioning threshold (every solve refused, so every
/// point goes to the edge) and a dominant guard each give another mesh than the
/// defaults, and their in-range values are accepted.
#[test]
fn qem_solve_condition_and_guard_reach_the_cost_model() {
    let mut m = generate::icosphere(3);
    for (i, p) in m.positions.iter_mut().enumerate() {
        // A deterministic bump per vertex so that the quadrics are not all alike.
        let s = 1.0 + 0.05 * ((i as f32) * 0.618_034).fract();
        *p = [p[0] * s, p[1] * s, p[2] * s];
    }
    let base = SimplifyOptions::default().with_ratio(0.2);
    let (reference, _) = simplify(&m, &base).unwrap();
    for o in [
        base.clone().with_solve_condition(0.999),
        base.clone().with_displacement_guard(1e6),
    ] {
        let (out, report) = simplify(&m, &o).unwrap();
        assert_eq!(report.stop_reason, StopReason::TargetReached, "{o:?}");
        assert!(
            out.positions != reference.positions || out.triangles != reference.triangles,
            "{o:?} gave the default's mesh"
        );
    }
}

/// Degenerate and duplicate triangles are removed up front and counted.
///
/// ```text
/// a quad 0-1-2-3 as two triangles, plus: [0,0,1] (repeated point),
/// [0,1,2] again and [2,1,0] (duplicates), [4,5,6] collinear
/// ```
#[test]
fn repair_counts_degenerate_and_duplicate() {
    let mut m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [5.0, 0.0, 0.0],
            [6.0, 0.0, 0.0],
            [7.0, 0.0, 0.0],
        ],
        vec![
            [0, 1, 2],
            [0, 2, 3],
            [0, 0, 1],
            [0, 1, 2],
            [2, 1, 0],
            [4, 5, 6],
        ],
    );
    m.positions.push([0.0, 0.0, 0.0]); // a duplicate position of vertex 0
    m.triangles.push([7, 2, 3]); // the same as [0, 2, 3] once welded
    let (out, report) = simplify(&m, &SimplifyOptions::default().with_ratio(1.0)).unwrap();
    assert_eq!(report.degenerate_removed, 2);
    assert_eq!(report.duplicate_removed, 3);
    assert_eq!(out.triangles.len(), 2);
}

/// Non-manifold input (three sheets on one edge, a bow-tie) must not panic and must
/// not get worse.
///
/// ```text
///   fins 0-1 shared by triangles to 2, 3 and 4; bow-tie at 5 between (5,6,7),(5,8,9)
/// ```
#[test]
fn non_manifold_input_is_handled() {
    let mut m = generate::grid(6, 6, |_, _| 0.0);
    let base = m.positions.len() as u32;
    m.positions.extend_from_slice(&[
        [0.5, 0.5, 0.0],
        [0.5, 0.5, 1.0],
        [1.5, 0.5, 0.5],
        [-0.5, 0.5, 0.5],
        [0.5, 1.5, 0.5],
    ]);
    m.triangles.extend_from_slice(&[
        [base, base + 1, base + 2],
        [base, base + 1, base + 3],
        [base, base + 1, base + 4],
    ]);
    let (out, report) = simplify(&m, &SimplifyOptions::default().with_ratio(0.1)).unwrap();
    check_invariants(&m, &out, &report);
}

/// UVs on a grid with a seam down the middle (x = 0.5 duplicated with different u):
/// the seam is not torn, UVs stay within range and interpolated consistently.
#[test]
fn uv_seam_is_not_torn() {
    let n = 16u32;
    let mut m = generate::grid(n, n, |x, y| 0.02 * (6.0 * x).sin() * (4.0 * y).cos());
    let mut uv: Vec<[f32; 2]> = m.positions.iter().map(|p| [p[0], p[1]]).collect();
    // Split every vertex with x == 0.5 into a left and right wedge (u offset by 10 on
    // the right half).
    let mut twin = vec![u32::MAX; m.positions.len()];
    for (i, p) in m.positions.clone().iter().enumerate() {
        if p[0] == 0.5 {
            twin[i] = m.positions.len() as u32;
            m.positions.push(*p);
            uv.push([p[0] + 10.0, p[1]]);
        }
    }
    for (q, p) in uv.iter_mut().zip(m.positions.iter()) {
        if p[0] > 0.5 {
            q[0] += 10.0;
        }
    }
    let positions = m.positions.clone();
    for t in &mut m.triangles {
        let right = t.iter().any(|&v| positions[v as usize][0] > 0.5);
        if right {
            for v in t.iter_mut() {
                if twin[*v as usize] != u32::MAX {
                    *v = twin[*v as usize];
                }
            }
        }
    }
    m.attributes.uv0 = Some(uv);
    let (out, report) = simplify(&m, &SimplifyOptions::default().with_ratio(0.2)).unwrap();
    check_invariants(&m, &out, &report);
    let uv = out.attributes.uv0.as_ref().unwrap();
    for t in &out.triangles {
        let right = t
            .iter()
            .map(|&v| uv[v as usize][0] >= 9.9)
            .filter(|&r| r)
            .count();
        // A triangle lies on one side of the seam: its UVs are all left or all right.
        assert!(
            right == 0 || right == 3,
            "triangle straddles the seam: {t:?}"
        );
        for &v in t {
            let (p, q) = (out.positions[v as usize], uv[v as usize]);
            let u = if q[0] >= 9.9 { q[0] - 10.0 } else { q[0] };
            // UV was x,y: interpolation keeps it close to the position.
            assert!(
                (u - p[0]).abs() < 0.02 && (q[1] - p[1]).abs() < 0.02,
                "{p:?} {q:?}"
            );
        }
    }
    // Seam vertices stay on the seam line, their u that of the line (up to the
    // attribute solve's optimum over the bumpy triangles around, whose UV
    // gradients lie in their tilted planes).
    for (i, q) in uv.iter().enumerate() {
        if out.positions[i][0] == 0.5 {
            assert!(
                (q[0] - 0.5).abs() < 1e-3 || (q[0] - 10.5).abs() < 1e-3,
                "u {} on the seam line",
                q[0]
            );
        }
    }
}

/// Two materials on a grid: the material border (x = 0.5) is kept as a line.
#[test]
fn material_border_is_kept() {
    let mut m = generate::grid(12, 12, |_, _| 0.0);
    let groups: Vec<u32> = m
        .triangles
        .iter()
        .map(|t| {
            let cx: f32 = t.iter().map(|&v| m.positions[v as usize][0]).sum::<f32>() / 3.0;
            u32::from(cx > 0.5)
        })
        .collect();
    m.groups = Some(groups);
    m.group_names = vec!["left".into(), "right".into()];
    let (out, report) = simplify(&m, &SimplifyOptions::default().with_ratio(0.05)).unwrap();
    check_invariants(&m, &out, &report);
    let g = out.groups.as_ref().unwrap();
    for (t, &gid) in out.triangles.iter().zip(g) {
        for &v in t {
            let x = out.positions[v as usize][0];
            if gid == 0 {
                assert!(x <= 0.5);
            } else {
                assert!(x >= 0.5);
            }
        }
    }
    assert_eq!(out.group_names, m.group_names);
}

#[test]
fn normals_colors_and_skin_weights_are_carried() {
    let mut m = generate::icosphere(3);
    let n = m.positions.len();
    m.attributes.normals = Some(m.positions.clone());
    m.attributes.colors = Some(
        m.positions
            .iter()
            .map(|p| [p[0].abs(), p[1].abs(), 0.5, 1.0])
            .collect(),
    );
    m.attributes.joints = Some((0..n).map(|i| [(i % 3) as u16, 7, 0, 0]).collect());
    m.attributes.weights = Some(vec![[0.5, 0.5, 0.0, 0.0]; n]);
    let (out, report) = simplify(&m, &SimplifyOptions::default().with_ratio(0.1)).unwrap();
    check_invariants(&m, &out, &report);
    let normals = out.attributes.normals.as_ref().unwrap();
    for (p, nn) in out.positions.iter().zip(normals) {
        let l = dot(f64x3(*nn), f64x3(*nn)).sqrt();
        assert!((l - 1.0).abs() < 1e-4, "normal not unit");
        let pl = dot(f64x3(*p), f64x3(*p)).sqrt();
        assert!(
            dot(f64x3(*nn), f64x3(*p)) / pl > 0.95,
            "normal far from radial"
        );
    }
    let w = out.attributes.weights.as_ref().unwrap();
    let j = out.attributes.joints.as_ref().unwrap();
    for (ww, jj) in w.iter().zip(j) {
        let s: f32 = ww.iter().sum();
        assert!((s - 1.0).abs() < 1e-5);
        // Joint 7 is in every input vertex with weight 0.5: it must keep ~0.5.
        let k = jj.iter().position(|&x| x == 7).unwrap();
        assert!((ww[k] - 0.5).abs() < 1e-4);
    }
}

#[test]
fn deterministic() {
    let t = generate::torus(40, 20, 2.0, 0.7);
    let o = SimplifyOptions::default().with_ratio(0.1);
    let (a, _) = simplify(&t, &o).unwrap();
    let (b, _) = simplify(&t, &o).unwrap();
    assert_eq!(a, b);
}

/// Two separate spheres 0.05 apart join with pair contraction when topology may
/// change; with topology preserved nothing non-edge happens.
#[test]
fn pair_contraction_joins_parts() {
    let mut a = generate::icosphere(2);
    let mut b = generate::icosphere(2);
    for p in &mut b.positions {
        p[0] += 2.05;
    }
    a.append(&b, 0);
    let t = Distance::Absolute(0.2);
    let (out, report) = simplify(
        &a,
        &SimplifyOptions::default()
            .with_ratio(0.3)
            .with_pair_threshold(t)
            .with_preserve_topology(false),
    )
    .unwrap();
    assert!(report.non_edge_contractions > 0, "{report:?}");
    out.validate().unwrap();
    let s = MeshStats::of(&out);
    assert_eq!(s.topology.components, 1);
    assert_eq!(s.topology.degenerate_triangles, 0);
    assert_eq!(s.topology.duplicate_triangles, 0);
    let (_, report) = simplify(
        &a,
        &SimplifyOptions::default()
            .with_ratio(0.3)
            .with_pair_threshold(t),
    )
    .unwrap();
    assert_eq!(report.non_edge_contractions, 0);
}

/// Random height fields with holes punched in and junk appended: every invariant
/// holds at every ratio and nothing panics.
pub(super) fn random_mesh() -> impl Strategy<Value = Mesh> {
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
            let tris: Vec<[u32; 3]> = g
                .triangles
                .iter()
                .enumerate()
                .filter(|(i, _)| keep[i % keep.len()] || i % 3 != 0)
                .map(|(_, t)| *t)
                .collect();
            g.triangles = tris;
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
        swaps in any::<bool>(),
        fit in prop::sample::select(vec![0u32, 2]),
    ) {
        let o = SimplifyOptions::default()
            .with_ratio(ratio)
            .with_edge_swaps(swaps)
            .with_fit_iterations(fit);
        let (out, report) = simplify(&m, &o).unwrap();
        check_invariants(&m, &out, &report);
        if !swaps {
            prop_assert_eq!(report.edge_swaps, 0);
        }
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
        let (out, report) = simplify(&m, &SimplifyOptions::default().with_ratio(ratio)).unwrap();
        check_invariants(&m, &out, &report);
        // Swaps and the fitting on a soup: the same invariants.
        let o = SimplifyOptions::default()
            .with_ratio(ratio)
            .with_edge_swaps(true)
            .with_fit_iterations(2);
        let (out, report) = simplify(&m, &o).unwrap();
        check_invariants(&m, &out, &report);
        // Free topology (holes close, parts go, pinches slide): the same.
        let o = SimplifyOptions::default()
            .with_ratio(ratio)
            .with_preserve_topology(false);
        let (out, report) = simplify(&m, &o).unwrap();
        check_invariants(&m, &out, &report);
        let opts = SimplifyOptions::default()
            .with_ratio(ratio)
            .with_preserve_topology(false)
            .with_pair_threshold(Distance::Relative(0.1));
        let (out, _) = simplify(&m, &opts).unwrap();
        out.validate().unwrap();
        let s = MeshStats::of(&out);
        prop_assert_eq!(s.topology.degenerate_triangles, 0);
        prop_assert_eq!(s.topology.duplicate_triangles, 0);
    }
}

/// A closed tetrahedron cannot lose a triangle without becoming degenerate: the run
/// stops with "no legal collapse left" and says why.
#[test]
fn tetrahedron_stops_with_no_legal_collapse() {
    let m = crate::mesh::generate::tetrahedron();
    let (out, report) = simplify(&m, &SimplifyOptions::default().with_target_triangles(0)).unwrap();
    assert_eq!(out.triangles.len(), 4);
    assert_eq!(report.stop_reason, StopReason::NoLegalCollapse);
    assert!(
        report.stop_detail.contains("no legal collapse left"),
        "{}",
        report.stop_detail
    );
    assert!(report.rejections.duplicate > 0);
}

/// The recorder sees every collapse; half-edge collapses keep the survivor in place,
/// and replaying the removed points accounts for the vertex count.
#[test]
fn recorder_and_progress_observe_the_run() {
    use crate::decimate::{CollapseRecorder, Observer};
    struct Both {
        rec: CollapseRecorder,
        progress: Vec<usize>,
        started: Option<(usize, usize)>,
    }
    impl Observer for Both {
        fn started(&mut self, t: usize, target: usize) {
            self.started = Some((t, target));
        }
        fn collapsed(&mut self, r: &crate::collapse::CollapseRecord) {
            self.rec.collapsed(r);
        }
        fn progress(&mut self, t: usize) {
            self.progress.push(t);
        }
    }
    let grid = generate::grid(16, 16, |x, y| 0.1 * x * y);
    let mut obs = Both {
        rec: CollapseRecorder::default(),
        progress: Vec::new(),
        started: None,
    };
    let s =
        simplify_observed(&grid, &SimplifyOptions::default().with_ratio(0.2), &mut obs).unwrap();
    assert_eq!(obs.started, Some((512, 102)));
    assert_eq!(obs.rec.records.len(), s.report.collapses);
    assert_eq!(obs.progress.last(), Some(&s.mesh.triangles.len()));
    let mut removed: Vec<u32> = obs.rec.records.iter().map(|r| r.removed).collect();
    removed.sort_unstable();
    removed.dedup();
    assert_eq!(removed.len(), s.report.collapses);
    assert_eq!(s.mesh.positions.len(), grid.positions.len() - removed.len());
    // Border points only slide along the border: some collapses are half-edge ones.
    assert!(obs
        .rec
        .records
        .iter()
        .any(|r| r.position == r.kept_old_position));
    for r in &obs.rec.records {
        assert!(r.error >= 0.0 && r.cost >= 0.0);
        assert!(r.removed_triangles[0] != crate::collapse::DEAD);
    }
    // vertex_source maps every output vertex to an input vertex.
    assert_eq!(s.vertex_source.len(), s.mesh.positions.len());
    assert!(s
        .vertex_source
        .iter()
        .all(|&v| (v as usize) < grid.positions.len()));
}

/// Filters veto: with a 5° normal limit a curved surface cannot be simplified as
/// far as without, and the report says the filters refused collapses.
#[test]
fn normal_deviation_filter_limits_simplification() {
    let sphere = generate::icosphere(3);
    let (free, _) = simplify(&sphere, &SimplifyOptions::default().with_ratio(0.05)).unwrap();
    let (tight, report) = simplify(
        &sphere,
        &SimplifyOptions::default()
            .with_ratio(0.05)
            .with_max_normal_deviation(5.0),
    )
    .unwrap();
    assert!(tight.triangles.len() > free.triangles.len());
    assert_eq!(report.stop_reason, StopReason::NoLegalCollapse);
    assert!(report.rejections.filter > 0);
    check_invariants(&sphere, &tight, &report);
}

/// Placement: with `Endpoint` no vertex moves (every output position is an input
/// position); with `Midpoint` interior vertices may move.
#[test]
fn endpoint_placement_keeps_input_positions() {
    let torus = generate::torus(24, 12, 2.0, 0.6);
    let (out, report) = simplify(
        &torus,
        &SimplifyOptions::default()
            .with_ratio(0.2)
            .with_placement(Placement::Endpoint),
    )
    .unwrap();
    check_invariants(&torus, &out, &report);
    assert!(out.positions.iter().all(|p| torus.positions.contains(p)));
    let (mid, report) = simplify(
        &torus,
        &SimplifyOptions::default()
            .with_ratio(0.2)
            .with_placement(Placement::Midpoint),
    )
    .unwrap();
    check_invariants(&torus, &mid, &report);
    assert!(mid.positions.iter().any(|p| !torus.positions.contains(p)));
}

/// Clustering cannot stop at an error: `max_error` alone used to give it a target of
/// 0 triangles and an empty mesh; now it is refused, and accepted beside a count.
#[test]
fn cluster_with_only_a_max_error_is_refused() {
    let sphere = generate::icosphere(3);
    let only = SimplifyOptions::default()
        .with_method(Method::Cluster)
        .with_max_error(Distance::Relative(0.05));
    match simplify(&sphere, &only) {
        Err(SimplifyError::Option { name, .. }) => assert_eq!(name, "max_error"),
        other => panic!("expected a refusal, got {other:?}"),
    }
    let (out, _) = simplify(&sphere, &only.with_ratio(0.2)).expect("with a ratio");
    assert!(!out.triangles.is_empty());
}

/// A terraced height field (wide flat steps, like 8-bit elevation data) at 10%:
/// collapses within a terrace cost zero; they go shortest first (the driver's
/// step 1), so the terraces coarsen evenly and few collapses are refused. In
/// arbitrary order one point swallowed its neighbours and most collapses around it
/// folded a triangle over.
#[test]
fn terraces_coarsen_without_a_storm_of_rejections() {
    let n = 120; // 28,800 triangles
    let grid = generate::grid(n, n, |x, y| (6.0 * (x + 0.5 * y)).floor() * 0.05);
    let (out, report) = simplify(&grid, &SimplifyOptions::default().with_ratio(0.1)).unwrap();
    check_invariants(&grid, &out, &report);
    assert_eq!(report.stop_reason, StopReason::TargetReached);
    for t in &out.triangles {
        assert!(normal(&out, *t)[2] > 0.0, "fold-over");
    }
    let refused = report.rejections.fold_over + report.rejections.degenerate;
    // 0.74 refusals per collapse; 2.2 in arbitrary order.
    assert!(
        refused <= report.collapses as u64,
        "{refused} fold-over or degenerate refusals for {} collapses",
        report.collapses
    );
}

/// A run stopped by a cost bound holds exactly the first collapses of an
/// unbounded run (the greedy order's prefix below the bound), and none above
/// it; the stop says so. A bumpy 40 × 40 grid, the bound the cost of the
/// unbounded run's 500th collapse.
#[test]
fn a_cost_bound_stops_at_a_prefix_of_the_greedy_order() {
    #[derive(Default)]
    struct Costs(Vec<(u32, u32, f64)>);
    impl Observer for Costs {
        fn collapsed(&mut self, r: &crate::collapse::CollapseRecord) {
            self.0.push((r.removed, r.kept, r.cost));
        }
    }
    let mesh = generate::grid(40, 40, |x, y| {
        0.2 * (7.0 * x).sin() * (5.0 * y).cos() + 0.05 * x
    });
    let o = SimplifyOptions::default();
    let mut all = Costs::default();
    let d = decimate_mesh(&mesh, &o, 100, None, false, &mut all);
    assert_eq!(d.outcome.stop_reason, StopReason::TargetReached);
    let bound = all.0[500].2;
    let mut cut = Costs::default();
    let piece = Piece {
        diagonal: mesh.bbox_diagonal(),
        max_cost: Some(bound),
    };
    let b = decimate_mesh(&mesh, &o, 100, Some(piece), false, &mut cut);
    assert_eq!(
        b.outcome.stop_reason,
        StopReason::MaxError,
        "{}",
        b.outcome.stop_detail
    );
    assert!(cut.0.len() > 500, "{} collapses", cut.0.len());
    assert!(cut.0.len() < all.0.len());
    assert_eq!(
        cut.0[..],
        all.0[..cut.0.len()],
        "a prefix of the unbounded run"
    );
    assert!(cut.0.iter().all(|c| c.2 <= bound * (1.0 + 1e-6)));
}
