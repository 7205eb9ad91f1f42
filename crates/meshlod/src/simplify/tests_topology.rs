//! Free topology (`preserve_topology: false`): holes of three border edges close,
//! small separate parts are removed whole, and every other invariant holds (no
//! fold-overs, duplicates, degenerate triangles, new boundary or non-manifold
//! edges).

use super::tests::check_invariants;
use super::*;
use crate::mesh::{generate, MeshStats};
use crate::quadric::{cross, dot};
use proptest::prelude::*;

/// The 80-triangle icosphere without two opposite triangles: an open tube
/// (two holes of three border edges each), so no collapse inside can shrink
/// either hole away: kept, at least the six triangles of a prism's sides stay.
///
/// ```text
///      hole 1 (3 border edges)
///     /      \
///    |  tube  |      free topology: each hole's border edge collapses, joining
///     \      /       its other two border edges: a closed surface
///      hole 2
/// ```
pub(crate) fn tube() -> Mesh {
    let mut m = generate::icosphere(1);
    let centroid = |t: [u32; 3]| {
        let p = t.map(|i| m.positions[i as usize].map(f64::from));
        [
            p[0][0] + p[1][0] + p[2][0],
            p[0][1] + p[1][1] + p[2][1],
            p[0][2] + p[1][2] + p[2][2],
        ]
    };
    let c0 = centroid(m.triangles[0]);
    let opposite = (1..m.triangles.len())
        .min_by(|&a, &b| {
            dot(c0, centroid(m.triangles[a])).total_cmp(&dot(c0, centroid(m.triangles[b])))
        })
        .unwrap();
    m.triangles.remove(opposite);
    m.triangles.remove(0);
    m
}

fn free() -> SimplifyOptions {
    SimplifyOptions::default().with_preserve_topology(false)
}

#[test]
fn a_hole_of_three_border_edges_closes_only_with_free_topology() {
    let m = tube();
    let si = MeshStats::of(&m);
    assert_eq!(si.topology.boundary_edges, 6);
    assert_eq!(si.topology.non_manifold_edges, 0);

    // Kept: both holes stay, however low the target.
    let (out, r) = simplify(&m, &SimplifyOptions::default().with_target_triangles(0)).unwrap();
    check_invariants(&m, &out, &r);
    assert_eq!(r.holes_closed, 0);
    assert_eq!(MeshStats::of(&out).topology.boundary_edges, 6);
    assert!(out.triangles.len() >= 6);

    // Free: both holes close and the closed surface goes down to a tetrahedron.
    let (out, r) = simplify(&m, &free().with_target_triangles(0)).unwrap();
    check_invariants(&m, &out, &r);
    assert_eq!(r.holes_closed, 2, "{r:?}");
    let so = MeshStats::of(&out);
    assert_eq!(so.topology.boundary_edges, 0, "{out:?}");
    assert_eq!(so.topology.non_manifold_edges, 0);
    assert_eq!(so.topology.components, 1);
    assert_eq!(out.triangles.len(), 4);
    assert_eq!(r.stop_reason, StopReason::NoLegalCollapse);
    // Closed and consistently oriented: the signed volume is positive.
    let volume: f64 = out
        .triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| out.positions[i as usize].map(f64::from));
            dot(p[0], cross(p[1], p[2])) / 6.0
        })
        .sum();
    assert!(volume > 0.0, "volume {volume}");
}

/// A unit sphere with thirty small ones (radius 0.02) sitting on its equator,
/// rivets on a body: kept, the rivets (four triangles at least each) hold the
/// run far above the target; free, they are removed whole (each is within 0.04
/// of the body) and the body is simplified to the target.
#[test]
fn small_parts_are_removed_whole_and_the_largest_stays() {
    let mut m = generate::icosphere(3);
    for k in 0..30 {
        let mut s = generate::icosphere(1);
        let a = f64::from(k) * std::f64::consts::TAU / 30.0;
        for p in &mut s.positions {
            p[0] = p[0] * 0.02 + a.cos() as f32;
            p[1] = p[1] * 0.02 + a.sin() as f32;
            p[2] *= 0.02;
        }
        m.append(&s, 0);
    }
    let n = m.triangles.len();
    let target = 60;
    let (out, r) = simplify(
        &m,
        &SimplifyOptions::default().with_target_triangles(target),
    )
    .unwrap();
    check_invariants(&m, &out, &r);
    assert_eq!(r.components_removed, 0);
    assert!(
        out.triangles.len() >= 30 * 4,
        "{} of {n}",
        out.triangles.len()
    );
    assert_eq!(MeshStats::of(&out).topology.components, 31);

    let (out, r) = simplify(&m, &free().with_target_triangles(target)).unwrap();
    check_invariants(&m, &out, &r);
    assert_eq!(
        r.stop_reason,
        StopReason::TargetReached,
        "{}",
        r.stop_detail
    );
    assert_eq!(r.components_removed, 30);
    let so = MeshStats::of(&out);
    assert_eq!(so.topology.components, 1);
    assert_eq!(so.topology.boundary_edges, 0);
    // What is left is the body: every point at a radius of 0.7 to 1.1.
    for p in &out.positions {
        let r = dot(p.map(f64::from), p.map(f64::from)).sqrt();
        assert!((0.7..=1.1).contains(&r), "a point at radius {r}");
    }
    // A rivet's removal error, the distance from its far side to the body, is
    // at least 0.04 less the chord's sag (the body is an 80-sided polygon there).
    assert!(r.error_absolute >= 0.035, "{}", r.error_absolute);
}

/// A maximum error below the small parts' radius keeps them.
#[test]
fn parts_above_the_maximum_error_stay() {
    let mut m = generate::icosphere(2);
    let mut s = generate::icosphere(1);
    for p in &mut s.positions {
        p[0] = p[0] * 0.1 + 3.0;
        p[1] *= 0.1;
        p[2] *= 0.1;
    }
    m.append(&s, 0);
    let o = free()
        .with_target_triangles(0)
        .with_max_error(Distance::Absolute(0.05));
    let (out, r) = simplify(&m, &o).unwrap();
    check_invariants(&m, &out, &r);
    assert_eq!(r.components_removed, 0);
    assert_eq!(MeshStats::of(&out).topology.components, 2);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Random height fields with holes punched in and junk appended, free
    /// topology: every invariant holds (boundary and non-manifold edges only
    /// fewer) and the target is reached or the stop says why.
    #[test]
    fn random_meshes_keep_invariants_with_free_topology(
        m in super::tests::random_mesh(),
        ratio in prop::sample::select(vec![0.5, 0.1, 0.01]),
    ) {
        let (out, report) = simplify(&m, &free().with_ratio(ratio)).unwrap();
        check_invariants(&m, &out, &report);
    }

}

/// Two tetrahedra sharing one corner P (a pinch): sliding P onto a corner a of
/// one of them would turn its triangle (P, b, c) into (a, b, c), which exists:
/// refused, with either cost model, down to any target.
/// ```text
///   b   c        the first tetrahedron: P, a, b, c; the second: P, d, e, f
///    \ /
///  a--P--d
///    / \
///   e   f
/// ```
#[test]
fn a_sliding_pinch_never_makes_a_triangle_twice() {
    let mut m = generate::tetrahedron();
    let mut other = generate::tetrahedron();
    for p in &mut other.positions {
        for x in p.iter_mut() {
            *x = -*x;
        }
    }
    m.append(&other, 0);
    for method in [Method::Qem, Method::Melax] {
        for target in [0, 4, 6] {
            let o = free().with_method(method).with_target_triangles(target);
            let (out, report) = simplify(&m, &o).unwrap();
            check_invariants(&m, &out, &report);
        }
    }
}
