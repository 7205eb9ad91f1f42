//! Classification and operator tests on tiny hand-built meshes.

use super::*;
use crate::collapse::BuildOptions;
use crate::decimate::NoObserver;
use crate::mesh::{generate, Mesh};

fn remover(m: &Mesh, options: VertexRemovalOptions) -> VertexRemoval {
    let (s, _) = Surface::build(m, &BuildOptions::default());
    VertexRemoval::new(&s, options)
}

/// The point of `m` at `p` (positions are unique in these meshes).
fn point_at(m: &Mesh, p: [f32; 3]) -> u32 {
    // Surface points are numbered in first-occurrence order of the welded positions,
    // which for these meshes (no duplicate positions) is the vertex order.
    m.positions.iter().position(|&q| q == p).unwrap() as u32
}

/// A flat 2 × 2 grid:
/// ```text
///  6---7---8
///  |   |   |
///  3---4---5
///  |   |   |
///  0---1---2
/// ```
/// 4 is simple, 1 (straight border) is a boundary vertex.
#[test]
fn grid_classes() {
    let m = generate::grid(2, 2, |_, _| 0.0);
    let mut vr = remover(&m, VertexRemovalOptions::default());
    assert_eq!(vr.classify(4), VertexClass::Simple);
    assert_eq!(vr.classify(1), VertexClass::Boundary);
    assert_eq!(vr.classify(0), VertexClass::Boundary);
}

/// The same grid folded by 90° along the line x = 0.5 (points 1, 4, 7): 4 has two
/// feature edges (to 1 and 7) and is an interior-edge vertex; with a feature angle
/// above the fold it is simple again.
#[test]
fn crease_is_interior_edge() {
    let m = generate::grid(2, 2, |x, _| if x > 0.75 { 0.5 } else { 0.0 });
    // Fold: z = 0 for x <= 0.5, z rises to 0.5 at x = 1 (45° slope).
    let mut vr = remover(&m, VertexRemovalOptions::default());
    assert_eq!(vr.classify(4), VertexClass::InteriorEdge);
    let mut vr = remover(
        &m,
        VertexRemovalOptions {
            feature_angle: 60.0,
            ..VertexRemovalOptions::default()
        },
    );
    assert_eq!(vr.classify(4), VertexClass::Simple);
}

/// A tetrahedron: every vertex has three feature edges (dihedral 109°), so all are
/// corners; removing one would recreate the opposite face (two triangles back to
/// back), so nothing is removed.
#[test]
fn tetrahedron_stays() {
    let m = generate::tetrahedron();
    let mut vr = remover(
        &m,
        VertexRemovalOptions {
            stop: StopRule {
                target_triangles: 0,
                max_error: None,
                max_cost: None,
            },
            ..VertexRemovalOptions::default()
        },
    );
    assert_eq!(vr.classify(0), VertexClass::Corner);
    let out = vr.run(&mut NoObserver);
    assert_eq!(vr.live_triangles(), 4);
    assert_eq!(out.stop_reason, StopReason::NoLegalCollapse);
    assert!(out.rejections.duplicate > 0);
}

/// Two triangles sharing only point 0 (a bow-tie): 0 is complex and is never
/// removed.
/// ```text
///  1       3
///  | \   / |
///  |  0    |
///  | /   \ |
///  2       4
/// ```
#[test]
fn bow_tie_is_complex() {
    let m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [-1.0, 1.0, 0.0],
            [-1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, -1.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 4, 3]],
    );
    let mut vr = remover(&m, VertexRemovalOptions::default());
    assert_eq!(
        vr.classify(point_at(&m, [0.0, 0.0, 0.0])),
        VertexClass::Complex
    );
}

/// A closed cube (8 corners of 3 feature edges each, plus face centres): corners are
/// kept with `keep_corners`, and the face centres (simple) go.
/// Each face is 4 triangles around a centre point.
#[test]
fn cube_corners_kept_on_request() {
    let mut pos: Vec<[f32; 3]> = Vec::new();
    for i in 0..8 {
        pos.push([(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32]);
    }
    // faces as CCW (from outside) corner quads
    let faces = [
        [0, 2, 3, 1], // z = 0
        [4, 5, 7, 6], // z = 1
        [0, 1, 5, 4], // y = 0
        [2, 6, 7, 3], // y = 1
        [0, 4, 6, 2], // x = 0
        [1, 3, 7, 5], // x = 1
    ];
    let mut tris = Vec::new();
    for f in faces {
        let c: [f32; 3] = [0, 1, 2].map(|k| f.iter().map(|&i| pos[i][k]).sum::<f32>() / 4.0);
        let ci = pos.len() as u32;
        pos.push(c);
        for k in 0..4 {
            tris.push([f[k] as u32, f[(k + 1) % 4] as u32, ci]);
        }
    }
    let m = Mesh::from_triangles(pos, tris);
    let mut vr = remover(
        &m,
        VertexRemovalOptions {
            keep_corners: true,
            stop: StopRule {
                target_triangles: 0,
                max_error: None,
                max_cost: None,
            },
            ..VertexRemovalOptions::default()
        },
    );
    assert_eq!(vr.classify(0), VertexClass::Corner);
    assert_eq!(vr.classify(8), VertexClass::Simple);
    let out = vr.run(&mut NoObserver);
    // 6 centres removed, 2 triangles per face.
    assert_eq!(out.collapses, 6);
    assert_eq!(vr.live_triangles(), 12);
    assert!(out.max_error < 1e-12);
}

/// The initial pass over all points runs in parallel with several rayon threads;
/// the run must not depend on how many: same triangles, same removals, same
/// refusals with one thread and with two (a bumpy sphere large enough for two
/// chunks of the pass).
#[test]
fn initial_pass_is_the_same_for_any_thread_count() {
    let mut m = generate::icosphere(6);
    for p in &mut m.positions {
        let bump =
            1.0 + 0.05 * (7.0 * p[0]).sin() * (5.0 * p[1]).cos() + 0.02 * (11.0 * p[2]).sin();
        *p = p.map(|x| x * bump);
    }
    let target = m.triangle_count() / 10;
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut vr = remover(
                &m,
                VertexRemovalOptions {
                    stop: StopRule {
                        target_triangles: target,
                        max_error: None,
                        max_cost: None,
                    },
                    ..VertexRemovalOptions::default()
                },
            );
            assert!(vr.pt.len() >= 2 * INITIAL_CHUNK);
            let out = vr.run(&mut NoObserver);
            (vr.output_triangles(), out.collapses, out.rejections)
        })
    };
    let one = run(1);
    let two = run(2);
    assert!(one.0 .1.len() <= target);
    assert_eq!(one.0 .1, two.0 .1);
    assert_eq!(one.0 .0, two.0 .0);
    assert_eq!(one.1, two.1);
    assert_eq!(one.2, two.2);
}
