//! Non-manifold input: chains of edges shared by three or more triangles simplify
//! along themselves (QEM), never tear or join sheets; duplicate triangles are
//! removed and counted; the report says which non-manifold points stayed and why.

use super::*;
use crate::collapse::{BuildOptions, Merge, Surface};
use crate::mesh::topology::Topology;
use crate::mesh::{MeshStats, Weld};
use crate::quadric::{cross, dot, sub};

/// Three flat sheets (fins) at 120° to each other, sharing the chain of `n + 1`
/// points on the x axis, each `m` rows wide; returns the mesh and each sheet's
/// outward direction `d_k` (a point of sheet `k` is `x·x̂ + s·d_k`, `s > 0`).
///
/// ```text
///            sheet 1 (d = (0, -1/2,  √3/2))
///               \
///                \
///   c0 --- c1 --- c2 --- ... --- cn      the chain, on the x axis: every edge
///                /  \                    ci–ci+1 has three triangles
///               /    \
///   sheet 2 (d = (0, -1/2, -√3/2))   sheet 0 (d = (0, 1, 0))
/// ```
/// Triangles of sheet `k` are wound so that their normal is `x̂ × d_k`.
fn three_sheets(n: u32, m: u32) -> (Mesh, [[f64; 3]; 3]) {
    let mut positions: Vec<[f32; 3]> = (0..=n).map(|i| [i as f32, 0.0, 0.0]).collect();
    let mut triangles = Vec::new();
    let mut dirs = [[0.0; 3]; 3];
    for (k, dir) in dirs.iter_mut().enumerate() {
        let th = 2.0 * std::f64::consts::PI * k as f64 / 3.0;
        let d = [0.0, th.cos(), th.sin()];
        *dir = d;
        let base = positions.len() as u32;
        for j in 1..=m {
            for i in 0..=n {
                positions.push([
                    i as f32,
                    (d[1] * f64::from(j)) as f32,
                    (d[2] * f64::from(j)) as f32,
                ]);
            }
        }
        let v = |i: u32, j: u32| {
            if j == 0 {
                i
            } else {
                base + (j - 1) * (n + 1) + i
            }
        };
        for j in 0..m {
            for i in 0..n {
                let (a, b, c, e) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
                triangles.push([a, b, c]);
                triangles.push([a, c, e]);
            }
        }
    }
    (Mesh::from_triangles(positions, triangles), dirs)
}

fn f64x3(p: [f32; 3]) -> [f64; 3] {
    p.map(f64::from)
}

/// Which sheet a point lies in (`None` on the chain's line), by its direction
/// around the x axis.
fn sheet_of(p: [f32; 3], dirs: &[[f64; 3]; 3]) -> Option<usize> {
    let q = f64x3(p);
    let r = (q[1] * q[1] + q[2] * q[2]).sqrt();
    if r < 1e-5 {
        return None;
    }
    let best = (0..3)
        .max_by(|&a, &b| {
            let da = (q[1] * dirs[a][1] + q[2] * dirs[a][2]) / r;
            let db = (q[1] * dirs[b][1] + q[2] * dirs[b][2]) / r;
            da.total_cmp(&db)
        })
        .unwrap_or(0);
    Some(best)
}

/// No tear, no join, no flip: every output triangle lies in one sheet's
/// half-plane (its corners in that sheet or on the chain's line) with the
/// sheet's orientation, and every non-manifold edge of the output lies on the
/// chain's line.
fn assert_sheets_intact(out: &Mesh, dirs: &[[f64; 3]; 3]) {
    for t in &out.triangles {
        let ps = t.map(|i| out.positions[i as usize]);
        let sheets: Vec<usize> = ps.iter().filter_map(|&p| sheet_of(p, dirs)).collect();
        assert!(!sheets.is_empty(), "a triangle lies on the chain's line");
        assert!(
            sheets.iter().all(|&s| s == sheets[0]),
            "a triangle joins two sheets: {ps:?}"
        );
        let d = dirs[sheets[0]];
        let n = cross([1.0, 0.0, 0.0], d);
        for p in ps {
            let off = dot(f64x3(p), n).abs();
            assert!(off < 1e-4, "a corner left its sheet's plane by {off}");
        }
        let [a, b, c] = ps.map(f64x3);
        let tn = cross(sub(b, a), sub(c, a));
        assert!(dot(tn, n) > 0.0, "a triangle flipped: {ps:?}");
    }
    let weld = Weld::exact(&out.positions);
    let tris: Vec<[u32; 3]> = out
        .triangles
        .iter()
        .map(|t| t.map(|v| weld.point_of[v as usize]))
        .collect();
    let topo = Topology::build(&tris, weld.point_count());
    for (e, &[a, b]) in topo.edges.iter().enumerate() {
        if topo.edge_valence(e) > 2 {
            for p in [a, b] {
                let q = out.positions[weld.representative[p as usize] as usize];
                assert!(
                    sheet_of(q, dirs).is_none(),
                    "a non-manifold edge off the input's chain at {q:?}"
                );
            }
        }
    }
}

/// Three sheets on a chain of 16 edges: QEM reaches 10% and 5% of the 576
/// triangles within 1% (a collapse along the chain removes three), the chain
/// slides along itself (only its two ends, corners where it meets the sheets'
/// borders, are kept), nothing tears, joins or flips, and no non-manifold edge is
/// made.
#[test]
fn three_sheets_simplify_along_their_chain() {
    let (m, dirs) = three_sheets(16, 6);
    assert_eq!(m.triangles.len(), 576);
    let stats_in = MeshStats::of(&m);
    assert_eq!(stats_in.topology.non_manifold_edges, 16);
    for ratio in [0.1, 0.05] {
        let (out, report) = simplify(&m, &SimplifyOptions::default().with_ratio(ratio)).unwrap();
        let t = report.target_triangles;
        assert_eq!(report.stop_reason, StopReason::TargetReached, "{ratio}");
        assert!(
            out.triangles.len() <= t && out.triangles.len() + t.div_ceil(100).max(1) >= t,
            "{} triangles for {t}",
            out.triangles.len()
        );
        assert_sheets_intact(&out, &dirs);
        let so = MeshStats::of(&out);
        assert!(so.topology.non_manifold_edges <= 16);
        assert!(so.topology.non_manifold_edges >= 1, "the chain vanished");
        assert_eq!(so.topology.duplicate_triangles, 0);
        assert_eq!(report.non_manifold_points_in, Some(17));
        let kept = report
            .non_manifold_kept
            .expect("QEM reports the kept points");
        assert_eq!(kept.corner, 2, "{kept:?}");
        assert_eq!(kept.pinch + kept.seam + kept.irregular + kept.border, 0);
        // 17 chain points at the start; the run had to slide most of them away.
        assert!(kept.chain <= 3, "{kept:?}");
        super::tests::check_invariants(&m, &out, &report);
    }
}

/// The same run is the same, bit for bit.
#[test]
fn chain_runs_are_deterministic() {
    let (m, _) = three_sheets(12, 4);
    let o = SimplifyOptions::default().with_ratio(0.1);
    let (a, ra) = simplify(&m, &o).unwrap();
    let (b, rb) = simplify(&m, &o).unwrap();
    assert_eq!(a, b);
    assert_eq!(ra.non_manifold_kept, rb.non_manifold_kept);
}

/// Without chain moves (Melax, half-edge collapses recorded as progressive
/// meshes) the chain points stay, and the report says so.
#[test]
fn melax_keeps_chain_points() {
    let (m, dirs) = three_sheets(16, 6);
    let o = SimplifyOptions {
        method: Method::Melax,
        ..SimplifyOptions::default()
    }
    .with_ratio(0.1);
    let (out, report) = simplify(&m, &o).unwrap();
    assert_sheets_intact(&out, &dirs);
    let kept = report.non_manifold_kept.unwrap();
    assert_eq!(kept.chain + kept.corner, 17, "{kept:?}");
}

/// The operator: a chain point may move along its chain only (both ways when its
/// neighbour there is a chain point too, on the segment), never along a sheet
/// edge; the chain's ends stay.
#[test]
fn chain_point_moves_along_its_chain_only() {
    let (m, _) = three_sheets(4, 2);
    let (s, _) = Surface::build(
        &m,
        &BuildOptions {
            move_non_manifold: true,
            ..BuildOptions::default()
        },
    );
    // Point ids follow the input's first occurrences: the chain is 0..=4.
    assert!(
        !s.is_chain(0) && !s.is_chain(4),
        "the chain's ends are corners"
    );
    assert!((1..4).all(|p| s.is_chain(p)));
    let mv = s.moves(1, 2, false).expect("along the chain");
    assert!(mv.a_to_b && mv.b_to_a && mv.merge == Merge::OnSegment);
    let mv = s.moves(1, 0, false).expect("onto the chain's end");
    assert!(mv.a_to_b && !mv.b_to_a && mv.merge == Merge::No);
    // Point 6 is sheet 0's first row above chain point 1.
    let off = 5 + 1;
    assert!(s.shares_edge(1, off));
    assert!(s.moves(1, off, false).is_some_and(|mv| !mv.a_to_b));
    let census = s.non_manifold_census();
    assert_eq!((census.total, census.chain, census.corner), (5, 3, 2));

    // Without the option, every non-manifold point is fixed.
    let (s, _) = Surface::build(&m, &BuildOptions::default());
    assert!(!s.is_chain(2) && !s.may_move(2));
    assert!(s.moves(1, 2, false).is_none());
}

/// Duplicate triangles (the same three points in either winding) are removed
/// before simplifying, counted in the report; a sheet doubled by reversed copies
/// is no longer non-manifold once they are gone, and the run reaches its target.
#[test]
fn duplicate_triangles_are_removed_and_counted() {
    let (mut m, dirs) = three_sheets(16, 6);
    let n = m.triangles.len();
    // Copy every 10th triangle of the first sheet twice: once as is, once reversed.
    let mut extra = Vec::new();
    for t in m.triangles.iter().take(n / 3).step_by(10) {
        extra.push(*t);
        extra.push([t[0], t[2], t[1]]);
    }
    let copies = extra.len();
    m.triangles.extend(extra);
    assert!(MeshStats::of(&m).topology.non_manifold_edges > 16);
    let (same, r) = simplify(&m, &SimplifyOptions::default().with_ratio(1.0)).unwrap();
    assert_eq!(r.duplicate_removed, copies);
    assert_eq!(same.triangles.len(), n);
    assert_eq!(MeshStats::of(&same).topology.non_manifold_edges, 16);
    let (out, report) = simplify(&m, &SimplifyOptions::default().with_ratio(0.1)).unwrap();
    assert_eq!(report.duplicate_removed, copies);
    assert_eq!(report.stop_reason, StopReason::TargetReached);
    assert_sheets_intact(&out, &dirs);
}

/// Sheets on a chain with random extra fins glued onto sheet edges, random
/// duplicate copies and random heights: any run keeps the invariants (no new
/// non-manifold or boundary edge, no duplicate or degenerate triangle, the target
/// reached or the stop explained) and never panics.
mod random {
    use super::*;
    use proptest::prelude::*;

    fn fins() -> impl Strategy<Value = Mesh> {
        (
            3u32..10,
            1u32..4,
            prop::collection::vec((0usize..1000, -1.0f32..1.0), 0..12),
            prop::collection::vec(0usize..1000, 0..6),
            prop::collection::vec(-0.3f32..0.3, 64),
        )
            .prop_map(|(n, m, extra, dups, bumps)| {
                let (mut mesh, _) = three_sheets(n, m);
                for (i, p) in mesh.positions.iter_mut().enumerate() {
                    if p[1] != 0.0 || p[2] != 0.0 {
                        p[0] += bumps[i % bumps.len()] * 0.5;
                    }
                }
                // A fin on an edge of an existing triangle: that edge gets one more
                // triangle (non-manifold where it had two).
                for (t, h) in extra {
                    let tri = mesh.triangles[t % mesh.triangles.len()];
                    let [a, b] = [tri[0], tri[1]];
                    let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
                    let apex = [
                        0.5 * (pa[0] + pb[0]),
                        0.5 * (pa[1] + pb[1]) + h,
                        0.5 * (pa[2] + pb[2]) + 0.7,
                    ];
                    mesh.positions.push(apex);
                    let c = mesh.positions.len() as u32 - 1;
                    mesh.triangles.push([a, b, c]);
                }
                for d in dups {
                    let t = mesh.triangles[d % mesh.triangles.len()];
                    mesh.triangles.push([t[0], t[2], t[1]]);
                }
                mesh
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn random_fins_keep_invariants(
            m in fins(),
            ratio in prop::sample::select(vec![0.5, 0.1, 0.01]),
        ) {
            let (out, report) = simplify(&m, &SimplifyOptions::default().with_ratio(ratio)).unwrap();
            super::super::tests::check_invariants(&m, &out, &report);
            let kept = report.non_manifold_kept.unwrap();
            prop_assert!(kept.total <= report.non_manifold_points_in.unwrap());
        }
    }
}
