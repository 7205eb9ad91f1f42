//! Operator tests on tiny hand-made meshes (sketched above each test).

use super::*;
use crate::mesh::{generate, Mesh, MeshStats};

fn surface(m: &Mesh) -> Surface {
    Surface::build(m, &BuildOptions::default()).0
}

/// Every live triangle is in the fan of each of its points and nowhere else; the
/// live count matches.
fn assert_consistent(s: &Surface) {
    let mut live = 0;
    for t in 0..s.triangle_slots() as u32 {
        let tt = s.triangle(t);
        if tt[0] == DEAD {
            continue;
        }
        live += 1;
        for p in tt {
            assert!(
                s.fan(p).contains(&t),
                "triangle {t} missing from fan of {p}"
            );
        }
    }
    assert_eq!(live, s.live_triangles());
    for p in 0..s.point_count() as u32 {
        for &t in s.fan(p) {
            assert!(
                s.triangle(t).contains(&p),
                "fan of {p} holds foreign triangle {t}"
            );
        }
    }
}

fn limits() -> OperatorLimits {
    OperatorLimits::default()
}

/// Closed tetrahedron: every edge collapse would leave two triangles over the same
/// three points (the case the link condition alone misses).
#[test]
fn tetrahedron_collapse_is_duplicate() {
    let m = crate::mesh::generate::tetrahedron();
    let mut s = surface(&m);
    assert!(s.kind(0) == VertexKind::Manifold);
    let mut pv = Preview::default();
    assert_eq!(
        s.check(0, 1, s.position(1), &limits(), &mut pv),
        Err(Reject::Duplicate)
    );
}

/// A 2×1 strip; edge 1–4 is interior but both ends are on the border, so
/// collapsing it would pinch the strip into two parts joined at a point.
/// ```text
/// 3---4---5
/// | / | \ |
/// 0---1---2
/// ```
#[test]
fn interior_edge_between_border_points_is_refused() {
    let m = generate::grid(2, 1, |_, _| 0.0);
    let mut s = surface(&m);
    assert_eq!(s.kind(1), VertexKind::Border);
    assert_eq!(s.kind(4), VertexKind::Border);
    // The operator does not offer the move at all (border only slides along border).
    assert_eq!(s.moves(1, 4, false), None);
    let mut pv = Preview::default();
    assert_eq!(
        s.check(1, 4, s.position(4), &limits(), &mut pv),
        Err(Reject::Link)
    );
    // Along the border 0–1 it is fine, and the strip stays one piece.
    let mv = s.moves(0, 1, false).unwrap();
    assert_eq!(mv.merge, Merge::OnSegment);
    assert!(s.check(0, 1, s.position(1), &limits(), &mut pv).is_ok());
    let rec = s.collapse(0, 1, s.position(1));
    assert_eq!(
        rec.removed_triangles.iter().filter(|&&t| t != DEAD).count(),
        1
    );
    assert_eq!(s.live_triangles(), 3);
    assert_consistent(&s);
}

/// A unit hexagon in the plane z = 0, fanned around its centre: point 0 at the
/// origin, rim points 1..6 counter-clockwise from (1, 0, 0), triangles (0, i, i+1).
fn hexagon_fan() -> Mesh {
    let mut pos = vec![[0.0f32, 0.0, 0.0]];
    for i in 0..6 {
        let a = std::f32::consts::TAU * i as f32 / 6.0;
        pos.push([a.cos(), a.sin(), 0.0]);
    }
    let tris = (0..6u32).map(|i| [0, 1 + i, 1 + (i + 1) % 6]).collect();
    Mesh::from_triangles(pos, tris)
}

/// A fan around point 0 in the plane (hexagon); moving the centre far outside
/// flips triangles; moving it onto a rim edge line makes a zero-area triangle.
/// ```text
///    2   1
///  3   0   6(=1 neighbour)
///    4   5
/// ```
#[test]
fn fold_over_and_degenerate_are_refused() {
    let m = hexagon_fan();
    let mut s = surface(&m);
    let mut pv = Preview::default();
    // Collapse rim point 1 into centre 0, moving 0 far to the left: folds over.
    assert_eq!(
        s.check(1, 0, [-5.0, 0.0, 0.0], &limits(), &mut pv),
        Err(Reject::FoldOver)
    );
    // Moving 0 onto the line through rim points 3 and 4 (x = -0.75 midpoint of
    // their chord) makes triangle (0,3,4) degenerate.
    let p3 = s.position(4);
    let p4 = s.position(5);
    let on_chord = [(p3[0] + p4[0]) / 2.0, (p3[1] + p4[1]) / 2.0, 0.0];
    assert_eq!(
        s.check(1, 0, on_chord, &limits(), &mut pv),
        Err(Reject::Degenerate)
    );
    // A small move is fine; the preview lists the surviving triangles that change.
    assert!(s.check(1, 0, [0.1, 0.0, 0.0], &limits(), &mut pv).is_ok());
    // u=1 loses 2 of its 2 triangles; v=0 keeps 4 triangles that move.
    assert_eq!(pv.changed.len(), 4);
    let rec = s.collapse(1, 0, [0.1, 0.0, 0.0]);
    assert_eq!(rec.removed, 1);
    assert_eq!(rec.kept_old_position, [0.0, 0.0, 0.0]);
    assert_eq!(rec.position, [0.1, 0.0, 0.0]);
    let apexes = {
        let mut a = rec.apexes;
        a.sort_unstable();
        a
    };
    assert_eq!(apexes, [2, 6]);
    assert_eq!(s.live_triangles(), 4);
    assert!(!s.is_alive(1));
    assert_consistent(&s);
}

/// Kinds: an interior point is manifold, a rim point border; a border point may not
/// be removed onto an interior point, only the other way round.
#[test]
fn kinds_decide_directions() {
    let m = generate::grid(3, 3, |_, _| 0.0);
    let s = surface(&m);
    // Point 5 = (1,1) interior, point 1 = (1,0) border.
    assert_eq!(s.kind(5), VertexKind::Manifold);
    assert_eq!(s.kind(1), VertexKind::Border);
    let mv = s.moves(1, 5, false).unwrap();
    assert!(!mv.a_to_b && mv.b_to_a && mv.merge == Merge::No);
}

/// A bow-tie point is complex: it never moves, but others may collapse onto it.
/// ```text
///  1       3
///  | \   / |
///  2--0---4
/// ```
#[test]
fn complex_point_never_moves() {
    let m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [-1.0, 1.0, 0.0],
            [-1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 4, 3]],
    );
    let mut s = surface(&m);
    assert_eq!(s.kind(0), VertexKind::Complex);
    let mv = s.moves(0, 1, false).unwrap();
    assert!(!mv.a_to_b && mv.b_to_a);
    let mut pv = Preview::default();
    assert_eq!(
        s.check(0, 1, s.position(1), &limits(), &mut pv),
        Err(Reject::Kind)
    );
    assert_eq!(
        s.check(1, 0, [0.5, 0.0, 0.0], &limits(), &mut pv),
        Err(Reject::Kind)
    );
}

/// Collapses on a closed sphere keep the fans consistent and the mesh manifold.
#[test]
fn many_collapses_stay_consistent() {
    let m = generate::icosphere(2);
    let mut s = surface(&m);
    let mut pv = Preview::default();
    let mut nb = Vec::new();
    let mut done = 0;
    for p in 0..s.point_count() as u32 {
        if !s.is_alive(p) || s.kind(p) != VertexKind::Manifold {
            continue;
        }
        s.neighbours(p, &mut nb);
        let q = nb[0];
        let target = s.position(q);
        if s.check(p, q, target, &limits(), &mut pv).is_ok() {
            s.collapse(p, q, target);
            done += 1;
            assert_consistent(&s);
        }
    }
    assert!(done > 20);
    assert_eq!(s.live_triangles(), 320 - 2 * done);
    s.reclassify_all();
    for p in 0..s.point_count() as u32 {
        if s.is_alive(p) {
            assert_eq!(s.kind(p), VertexKind::Manifold);
        }
    }
}

/// Non-edge contraction: allowed only when enabled, refused when the two points
/// share a neighbour.
#[test]
fn non_edge_contraction() {
    // Two separate triangles 0-1-2 and 3-4-5.
    let m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.1, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [0.0, 1.0, 1.0],
        ],
        vec![[0, 1, 2], [3, 4, 5]],
    );
    let mut s = surface(&m);
    let mut pv = Preview::default();
    assert_eq!(s.moves(0, 3, false), None);
    assert_eq!(
        s.check(3, 0, s.position(0), &limits(), &mut pv),
        Err(Reject::Pair)
    );
    let allow = OperatorLimits {
        allow_non_edge: true,
        ..limits()
    };
    assert!(s.moves(0, 3, true).is_some_and(|m| !m.edge));
    assert!(s.check(3, 0, s.position(0), &allow, &mut pv).is_ok());
    let rec = s.collapse(3, 0, s.position(0));
    assert!(rec.non_edge);
    assert_eq!(s.live_triangles(), 2);
    assert_eq!(s.kind(0), VertexKind::Complex);
    assert_consistent(&s);
}

/// Repair at build time: degenerate and duplicate triangles leave, counted.
#[test]
fn build_repairs() {
    let m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0],
        ],
        vec![[0, 1, 2], [2, 1, 0], [0, 1, 1], [0, 1, 3]],
    );
    let (s, r) = Surface::build(&m, &BuildOptions::default());
    assert_eq!(
        r,
        Repair {
            degenerate_triangles: 2,
            duplicate_triangles: 1
        }
    );
    assert_eq!(s.live_triangles(), 1);
    assert_consistent(&s);
    let st = MeshStats::of(&m);
    assert_eq!(st.topology.degenerate_triangles, 2);
}

/// Duplicates are found among the triangles sharing a smallest point, both for a
/// small group and for one of more than eight (sorted there): a fan of 12 around
/// point 0 with three copies in either winding, and a copy away from point 0.
/// The first occurrence of each triple stays, in place.
#[test]
fn build_removes_duplicates_in_large_groups() {
    let mut positions = vec![[0.0f32, 0.0, 0.0]];
    let mut triangles = Vec::new();
    for i in 0..12u32 {
        let a = i as f32 * std::f32::consts::TAU / 12.0;
        positions.push([a.cos(), a.sin(), 0.1 * (i % 3) as f32]);
        triangles.push([0, 1 + i, 1 + (i + 1) % 12]);
    }
    // Copies: two in the other winding, one rotated, one of the rim (smallest 1).
    triangles.push([0, 4, 3]);
    triangles.push([7, 0, 8]);
    triangles.push([1, 2, 0]);
    positions.push([0.5, 0.5, 1.0]);
    triangles.push([1, 2, 13]);
    triangles.push([13, 2, 1]);
    let m = Mesh::from_triangles(positions, triangles.clone());
    let (s, r) = Surface::build(&m, &BuildOptions::default());
    assert_eq!(r.duplicate_triangles, 4);
    assert_eq!(r.degenerate_triangles, 0);
    assert_eq!(s.live_triangles(), 13);
    assert_consistent(&s);
    // The survivors are exactly the first occurrences, each triple once.
    let key = |t: [u32; 3]| {
        let mut k = t;
        k.sort_unstable();
        k
    };
    let mut live: Vec<[u32; 3]> = (0..s.triangle_slots() as u32)
        .map(|t| s.triangle(t))
        .filter(|t| t[0] != DEAD)
        .collect();
    let mut firsts: Vec<[u32; 3]> = Vec::new();
    for &t in &triangles {
        if !firsts.iter().any(|&f| key(f) == key(t)) {
            firsts.push(t);
        }
    }
    live.sort_unstable();
    firsts.sort_unstable();
    assert_eq!(live, firsts);
}

/// Three triangles chained through two bow-tie points: (u,v,x) links the fan of v
/// (v,y,z) with the fan of x (x,s,t). Removing u along the border edge u–v would
/// delete (u,v,x) and split the component in two, so it is refused.
/// ```text
///   y--z       s--t
///    \ |        | /
///      v --u-- x        (u,v,x) is the only link between v's and x's parts
/// ```
#[test]
fn collapse_never_splits_a_component() {
    let m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],  // 0 x
            [-1.0, 0.5, 0.0], // 1 u
            [-2.0, 0.0, 0.0], // 2 v
            [-3.0, 1.0, 0.0], // 3 y
            [-2.0, 1.0, 0.0], // 4 z
            [1.0, 1.0, 0.0],  // 5 s
            [2.0, 1.0, 0.0],  // 6 t
        ],
        vec![[1, 2, 0], [2, 3, 4], [0, 5, 6]],
    );
    let mut s = surface(&m);
    assert_eq!(s.kind(1), VertexKind::Border);
    assert_eq!(s.kind(2), VertexKind::Complex);
    assert_eq!(s.kind(0), VertexKind::Complex);
    let mv = s.moves(1, 2, false).unwrap();
    assert!(mv.a_to_b);
    let mut pv = Preview::default();
    assert_eq!(
        s.check(1, 2, s.position(2), &limits(), &mut pv),
        Err(Reject::Link)
    );
    assert_eq!(MeshStats::of(&m).topology.components, 1);
}

/// The classification fast path (one oriented fan) agrees with the general one
/// wherever it answers, and declines fans it cannot judge: a point whose fan has
/// one triangle wound the other way (point 0 below, triangle (0,2,3) reversed) is
/// still a manifold point by the general rule, but not an oriented fan.
/// ```text
///     3-----2
///    / \   / \
///   4---0-----1     (0,1,2) (0,3,2)! (0,3,4) (0,4,5) (0,5,1)
///    \  |  /
///       5
/// ```
#[test]
fn classification_fast_path_agrees() {
    let mut flipped = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 1.0, 0.0],
            [-0.5, 1.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 3, 2], [0, 3, 4], [0, 4, 5], [0, 5, 1]],
    );
    let mut s = surface(&flipped);
    assert_eq!(s.single_oriented_fan(0), None);
    assert_eq!(s.kind(0), VertexKind::Manifold);
    flipped.triangles[1] = [0, 2, 3];
    let mut s = surface(&flipped);
    assert_eq!(s.single_oriented_fan(0), Some(false));
    // Whole meshes, closed and open: every point is judged by the fast path.
    for m in [
        generate::icosphere(2),
        generate::grid(4, 3, |x, y| x * y),
        generate::torus(8, 5, 2.0, 0.5),
    ] {
        let mut s = surface(&m);
        for p in 0..s.point_count() as u32 {
            match s.single_oriented_fan(p) {
                Some(false) => assert_eq!(s.kind(p), VertexKind::Manifold),
                Some(true) => assert_eq!(s.kind(p), VertexKind::Border),
                None => panic!("point {p} of an oriented mesh was not judged"),
            }
        }
    }
}

/// The loading hints of the edge-collapse loop accept any point id (live, dead after
/// a collapse, out of range) and change nothing.
#[test]
fn prefetch_hints_accept_any_point_and_change_nothing() {
    let m = generate::icosphere(2);
    let mut s = surface(&m);
    let (u, v) = {
        let t = s.triangle(0);
        (t[0], t[1])
    };
    let p = s.position(v);
    let mut pv = Preview::default();
    s.check(u, v, p, &limits(), &mut pv)
        .expect("legal collapse");
    s.collapse(u, v, p);
    let before: Vec<[u32; 3]> = (0..s.triangle_slots() as u32)
        .map(|t| s.triangle(t))
        .collect();
    let n = s.point_count() as u32;
    for a in [0, u, v, n - 1, n, n + 7, u32::MAX] {
        for b in [0, v, n, u32::MAX] {
            s.prefetch_point_hint(a);
            s.prefetch_fans_hint(a, b);
            s.prefetch_triangles_hint(a, b);
            s.prefetch_pair(a, b);
        }
    }
    let after: Vec<[u32; 3]> = (0..s.triangle_slots() as u32)
        .map(|t| s.triangle(t))
        .collect();
    assert_eq!(before, after);
    assert!(!s.is_alive(u) && s.is_alive(v));
    assert_consistent(&s);
}

/// A hexagonal fan whose centre is a seam junction: three UV charts (A, B, C; u
/// offset by 10 per chart) meet at the centre 0 along the seam edges 0–1, 0–3 and
/// 0–5 (ring points 1, 3 and 5 have a wedge on each side):
///
/// ```text
///         3 ----- 2
///        / \  A  / \        sectors (triangles (0, k, k+1)):
///       / B \   / A \       A = (0,1,2), (0,2,3)
///      4 --- 0 ----- 1      B = (0,3,4), (0,4,5)
///       \ B / \ C   /       C = (0,5,6), (0,6,1)
///        \ /  C \ /        seams: 0–1 (C|A), 0–3 (A|B), 0–5 (B|C)
///         5 ----- 6
/// ```
///
/// Frozen without `move_junctions`; with it, the centre collapses along the seam
/// edge 0–1 onto 1: the triangles of A and C take point 1's wedges of their side,
/// B's triangles take the centre's B wedge, moved to point 1, and every triangle's
/// UVs stay in its chart.
#[test]
fn seam_junction_slides_along_its_seam() {
    let ring: Vec<[f32; 3]> = (0..6)
        .map(|k| {
            let a = std::f32::consts::FRAC_PI_3 * k as f32;
            [a.cos(), a.sin(), 0.0]
        })
        .collect();
    // Ring point k + 1 is ring[k]; sector of triangle (0, k, k + 1), k = 1..=6.
    let sector = |k: usize| (k - 1) / 2;
    let mut positions = Vec::new();
    let mut uv = Vec::new();
    let mut ids = std::collections::HashMap::new();
    let mut vertex = |p: usize, s: usize, positions: &mut Vec<[f32; 3]>| {
        *ids.entry((p, s)).or_insert_with(|| {
            let x = if p == 0 { [0.0, 0.0, 0.0] } else { ring[p - 1] };
            positions.push(x);
            uv.push([x[0] + 10.0 * s as f32, x[1]]);
            positions.len() as u32 - 1
        })
    };
    let mut tris = Vec::new();
    for k in 1..=6 {
        let s = sector(k);
        let next = k % 6 + 1;
        tris.push([
            vertex(0, s, &mut positions),
            vertex(k, s, &mut positions),
            vertex(next, s, &mut positions),
        ]);
    }
    let mut m = Mesh::from_triangles(positions, tris);
    m.attributes.uv0 = Some(uv);
    let point_at = |s: &Surface, x: [f32; 3]| {
        (0..s.point_count() as u32)
            .find(|&p| s.position(p) == x)
            .expect("point")
    };
    let mut pv = Preview::default();
    let mut frozen = surface(&m);
    let (c, p1) = (point_at(&frozen, [0.0; 3]), point_at(&frozen, ring[0]));
    assert_eq!(frozen.kind(c), VertexKind::Complex);
    assert!(frozen.moves(c, p1, false).is_none());
    assert_eq!(
        frozen.check(c, p1, frozen.position(p1), &limits(), &mut pv),
        Err(Reject::Kind)
    );
    let (mut s, _) = Surface::build(
        &m,
        &BuildOptions {
            move_junctions: true,
            ..BuildOptions::default()
        },
    );
    let mv = s
        .moves(c, p1, false)
        .expect("a junction may slide along its seam");
    assert!(mv.a_to_b && !mv.b_to_a && mv.merge == Merge::No);
    assert_eq!(mv.crosses, [false; 2], "along its seam");
    // Not across a chart: edge 0–2 is inside chart A.
    let p2 = point_at(&s, ring[1]);
    assert!(s.moves(c, p2, false).is_none_or(|m| !m.a_to_b));
    // A surface that may cross seams offers that move, marked as a crossing
    // (the ring point may move onto the junction: no crossing that way).
    let (crossing, _) = Surface::build(
        &m,
        &BuildOptions {
            move_junctions: true,
            permissive: true,
            ..BuildOptions::default()
        },
    );
    let across = crossing.moves(c, p2, false).expect("across the seam");
    assert!(across.a_to_b, "{across:?}");
    assert!(across.crosses[0] && !across.crosses[1], "{across:?}");
    let along = crossing.moves(c, p1, false).expect("along the seam");
    assert_eq!(along.crosses, [false; 2], "{along:?}");
    s.check(c, p1, s.position(p1), &limits(), &mut pv)
        .expect("legal");
    s.collapse(c, p1, s.position(p1));
    assert_consistent(&s);
    assert_eq!(s.live_triangles(), 4);
    let (tw, _, _) = s.output_triangles();
    let u = s.attributes().uv0.as_ref().expect("uv");
    for t in &tw {
        let charts = t.map(|w| (u[w as usize][0] + 5.0).div_euclid(10.0) as i32);
        assert!(
            charts[0] == charts[1] && charts[1] == charts[2],
            "{t:?}: {charts:?}"
        );
    }
    // Point 1 now has three wedges, one per chart.
    let mut w = [DEAD; 8];
    let n = s.point_wedges(p1, &mut w);
    let mut charts: Vec<i32> = w[..n]
        .iter()
        .map(|&x| (u[x as usize][0] + 5.0).div_euclid(10.0) as i32)
        .collect();
    charts.sort_unstable();
    assert_eq!(charts, vec![0, 1, 2]);
}

/// The tetrahedron without its face `(0, 2, 1)`: the hole `0, 1, 2` has border
/// edges whose triangles share their third corner, 3, so closing it (collapsing
/// border edge 0–1) would make `(1, 2, 3)` twice: refused even when holes may
/// close.
/// ```text
///        3 (inside)
///      / | \
///     0--+--2     hole: 0, 1, 2
///      \ | /
///        1
/// ```
#[test]
fn closing_a_hole_that_would_duplicate_a_triangle_is_refused() {
    let mut m = generate::tetrahedron();
    m.triangles.remove(0);
    let mut s = surface(&m);
    let close = OperatorLimits {
        close_holes: true,
        ..limits()
    };
    let mut pv = Preview::default();
    assert_eq!(s.kind(0), VertexKind::Border);
    assert_eq!(
        s.check(0, 1, s.position(1), &close, &mut pv),
        Err(Reject::Link)
    );
}

/// A tube (an icosphere without two opposite triangles): collapsing a border
/// edge of a hole closes it when holes may close, and only then; the hole's
/// three points are inside the surface afterwards.
#[test]
fn a_border_edge_collapse_closes_a_hole_of_three_edges() {
    let m = crate::simplify::tests_topology::tube();
    let mut s = surface(&m);
    let border: Vec<u32> = (0..s.point_count() as u32)
        .filter(|&p| s.is_boundary(p))
        .collect();
    assert_eq!(border.len(), 6);
    // A border neighbour of `u` is on its hole (the holes are apart).
    let u = border[0];
    let v = *border[1..].iter().find(|&&q| s.shares_edge(u, q)).unwrap();
    let mut pv = Preview::default();
    assert_eq!(
        s.check(u, v, s.position(v), &limits(), &mut pv),
        Err(Reject::Link)
    );
    let close = OperatorLimits {
        close_holes: true,
        ..limits()
    };
    s.check(u, v, s.position(v), &close, &mut pv).unwrap();
    let x = pv.closes_hole;
    assert!(x != DEAD && x != u && x != v && s.is_boundary(x));
    let rec = s.collapse(u, v, s.position(v));
    assert_eq!(rec.closed_hole, x);
    assert_eq!(rec.removed_count, 1);
    assert_consistent(&s);
    for p in [v, x] {
        assert!(!s.is_boundary(p), "{p} is still on a border");
        assert_eq!(s.kind(p), VertexKind::Manifold);
    }
    assert!(s.kind_changes().contains(&x));
    let left = (0..s.point_count() as u32)
        .filter(|&p| s.is_alive(p) && s.is_boundary(p))
        .count();
    assert_eq!(left, 3, "the other hole's points");
}

/// Two separate triangles: removing the points of one removes it whole and
/// nothing of the other.
#[test]
fn remove_part_removes_exactly_its_triangles() {
    let m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [5.0, 0.0, 0.0],
            [6.0, 0.0, 0.0],
            [5.0, 1.0, 0.0],
        ],
        vec![[0, 1, 2], [3, 4, 5]],
    );
    let mut s = surface(&m);
    assert_eq!(s.remove_part(&[3, 4, 5]), 1);
    assert_eq!(s.live_triangles(), 1);
    assert!((3..6).all(|p| !s.is_alive(p)));
    assert!((0..3).all(|p| s.is_alive(p)));
    assert_consistent(&s);
}

/// Two icospheres touching at one point `p` (the second is the first moved by
/// twice `p`, so its point `-p` lands on `p`): a pinch, two fans. Kept, it never
/// moves; sliding, it moves onto a neighbour in one sphere, which then holds
/// both fans: still one pinch, the spheres still apart but for it.
/// ```text
///    ( A )p( B )      p slides to its neighbour q in A:   ( A )q( B )
/// ```
#[test]
fn a_pinch_slides_onto_a_neighbour_only_when_allowed() {
    let mut m = generate::icosphere(1);
    let (p, _) = m
        .positions
        .iter()
        .enumerate()
        .max_by(|a, b| a.1[0].total_cmp(&b.1[0]))
        .unwrap();
    let shift = m.positions[p].map(|x| 2.0 * x);
    let mut b = m.clone();
    for q in &mut b.positions {
        for k in 0..3 {
            q[k] += shift[k];
        }
    }
    m.append(&b, 0);
    for slide in [false, true] {
        let (mut s, _) = Surface::build(
            &m,
            &BuildOptions {
                move_pinches: slide,
                ..BuildOptions::default()
            },
        );
        assert_eq!(s.non_manifold_census().pinch, 1);
        let u = (0..s.point_count() as u32)
            .find(|&x| s.kind(x) == VertexKind::Complex)
            .unwrap();
        let mut nb = Vec::new();
        s.neighbours(u, &mut nb);
        let v = nb[0];
        let mv = s.moves(u, v, false);
        assert_eq!(slide, mv.is_some_and(|m| m.a_to_b), "slide {slide}");
        assert_eq!(s.may_move(u), slide);
        if !slide {
            continue;
        }
        let mut pv = Preview::default();
        s.check(u, v, s.position(v), &limits(), &mut pv).unwrap();
        s.collapse(u, v, s.position(v));
        assert_consistent(&s);
        assert_eq!(s.non_manifold_census().pinch, 1);
        assert_eq!(s.kind(v), VertexKind::Complex);
        assert_eq!(s.components_and_border_points(), (1, 0));
    }
}

/// A skinned 4 × 4 grid over the unit square: points left of x = 0.5 follow
/// joint 0, the others joint 1 (weight 0.7; joint 2 takes the rest); the column
/// of squares right of x = 0.75 is a UV chart of its own (a seam, so the surface
/// keeps wedges).
///
/// ```text
///   +--+--+--+ +--+
///   |  |  |  | |  |      a = (0.25, 0.5), joint 0
///   +--a--b--+ +--+      b = (0.5, 0.5), joint 1
///   |  |  |  | |  |
/// ```
///
/// Collapsing `a` onto `b` merges wedges of different dominant joints: refused
/// on a surface that may cross seams (the default with QEM), allowed only when
/// joints may merge (`--permissive`).
#[test]
fn dominant_joints_stay_apart_unless_they_may_merge() {
    let g = generate::grid(4, 4, |_, _| 0.0);
    let mut positions = g.positions.clone();
    let mut uv: Vec<[f32; 2]> = g.positions.iter().map(|p| [p[0], p[1]]).collect();
    let mut copies = std::collections::HashMap::new();
    let mut tris = Vec::new();
    for t in &g.triangles {
        let right = t.iter().all(|&v| g.positions[v as usize][0] >= 0.75);
        tris.push(t.map(|v| {
            if !right {
                return v;
            }
            *copies.entry(v).or_insert_with(|| {
                let p = g.positions[v as usize];
                positions.push(p);
                uv.push([p[0] + 10.0, p[1]]);
                positions.len() as u32 - 1
            })
        }));
    }
    let mut m = Mesh::from_triangles(positions, tris);
    let joint = |p: &[f32; 3]| u16::from(p[0] >= 0.5);
    m.attributes.joints = Some(m.positions.iter().map(|p| [joint(p), 2, 0, 0]).collect());
    m.attributes.weights = Some(vec![[0.7, 0.3, 0.0, 0.0]; m.positions.len()]);
    m.attributes.uv0 = Some(uv);
    for (merge_joints, want) in [(false, Err(Reject::Seam)), (true, Ok(()))] {
        let (mut s, _) = Surface::build(
            &m,
            &BuildOptions {
                permissive: true,
                merge_joints,
                ..BuildOptions::default()
            },
        );
        let at = |x: [f32; 3]| {
            (0..s.point_count() as u32)
                .find(|&p| s.position(p) == x)
                .expect("point")
        };
        let (a, b) = (at([0.25, 0.5, 0.0]), at([0.5, 0.5, 0.0]));
        let mut pv = Preview::default();
        let p = s.position(b);
        assert_eq!(
            s.check(a, b, p, &limits(), &mut pv),
            want,
            "merge_joints {merge_joints}"
        );
    }
}

/// A stream the cost model declares solved is left alone by a collapse that moves
/// its survivor; the others are still interpolated at the new position.
///
/// ```text
///        3
///      /   \        a hexagon fan around centre 0, rim 1..6; colours and UVs
///     4  0  2       both equal x (the first component), so the collapse of
///      \   /        rim 1 into 0 at x = 0.1 interpolates 0.1 for both
///        5 ...
/// ```
#[test]
fn solved_streams_are_not_interpolated() {
    let mut m = hexagon_fan();
    m.attributes.colors = Some(m.positions.iter().map(|p| [p[0], 0.0, 0.0, 1.0]).collect());
    m.attributes.uv0 = Some(m.positions.iter().map(|p| [p[0], 0.0]).collect());
    for solved in [0, SOLVED_COLOR] {
        let mut s = surface(&m);
        s.set_solved_streams(solved);
        let mut pv = Preview::default();
        assert!(s.check(1, 0, [0.1, 0.0, 0.0], &limits(), &mut pv).is_ok());
        s.collapse(1, 0, [0.1, 0.0, 0.0]);
        let w = s.point_vertex(0) as usize;
        let uv = s.attributes().uv0.as_ref().unwrap()[w];
        let c = s.attributes().colors.as_ref().unwrap()[w];
        assert!((uv[0] - 0.1).abs() < 1e-6, "uv {uv:?}");
        let expect = if solved == 0 { 0.1 } else { 0.0 };
        assert!(
            (c[0] - expect).abs() < 1e-6,
            "solved {solved}: colour {c:?}"
        );
    }
}
