//! Analytic cases for the Hausdorff instrument.

use super::*;
use crate::mesh::generate;

/// A `k × k` grid of squares in the plane `z`, spanning `[0, 1]²`, two triangles each.
fn grid(k: u32, z: f32) -> Mesh {
    generate::grid(k, k, |_, _| f64::from(z))
}

/// Axis-aligned cube `[-s, s]³`, 12 triangles, outward.
fn cube(s: f32) -> Mesh {
    let p: Vec<[f32; 3]> = (0..8)
        .map(|i| {
            [
                if i & 1 != 0 { s } else { -s },
                if i & 2 != 0 { s } else { -s },
                if i & 4 != 0 { s } else { -s },
            ]
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut t = Vec::new();
    for q in quads {
        t.push([q[0], q[1], q[2]]);
        t.push([q[0], q[2], q[3]]);
    }
    Mesh::from_triangles(p, t)
}

/// Icosahedron with unit circumradius, subdivided `levels` times onto the unit sphere.
fn icosphere(levels: u32) -> Mesh {
    generate::icosphere(levels)
}

fn opts(n: usize) -> SamplingOptions {
    SamplingOptions::default().with_samples(n)
}

#[test]
fn plane_against_offset_plane_is_exactly_the_offset() {
    let a = grid(8, 0.0);
    let b = grid(5, 0.25);
    let d = hausdorff(&a, &b, &opts(20_000));
    for one in [d.a_to_b, d.b_to_a] {
        assert!((one.max - 0.25).abs() < 1e-7, "{one:?}");
        assert!((one.mean - 0.25).abs() < 1e-7, "{one:?}");
        assert!((one.rms - 0.25).abs() < 1e-7, "{one:?}");
    }
    assert!((d.hausdorff - 0.25).abs() < 1e-7);
}

#[test]
fn mesh_against_itself_is_zero() {
    let m = icosphere(2);
    let d = hausdorff(&m, &m, &opts(50_000));
    assert!(d.hausdorff < 1e-6, "{d:?}");
    assert!(d.mean < 1e-7);
    // Every vertex, plus N on edges and N on faces.
    assert_eq!(d.a_to_b.samples, 162 + 50_000 + 50_000);
}

#[test]
fn cube_against_scaled_cube() {
    // Every point of the small cube's surface is 0.5 from the big cube's surface;
    // the big cube's corners are sqrt(3)/2 from the small cube's corners.
    let d = hausdorff(&cube(1.0), &cube(1.5), &opts(100_000));
    assert!((d.a_to_b.max - 0.5).abs() < 1e-7, "{:?}", d.a_to_b);
    assert!((d.a_to_b.mean - 0.5).abs() < 1e-7);
    assert!(
        (d.b_to_a.max - 0.75f64.sqrt()).abs() < 1e-7,
        "{:?}",
        d.b_to_a
    );
    assert!(d.b_to_a.mean > 0.5 && d.b_to_a.mean < 0.75f64.sqrt());
    assert!((d.hausdorff - 0.75f64.sqrt()).abs() < 1e-7);
    assert!((d.bbox_diagonal - 12f64.sqrt()).abs() < 1e-9);
    assert!((d.max_extent - 2.0).abs() < 1e-12);
    // The maximum sits at a corner of the big cube.
    assert!(d.b_to_a.max_at.iter().all(|c| (c.abs() - 1.5).abs() < 1e-9));
}

#[test]
fn icosahedron_against_the_sphere_it_is_inscribed_in() {
    // The largest gap between a unit-circumradius icosahedron and its sphere is at the
    // face centres: 1 − inradius, inradius = sqrt(10 + 22/sqrt 5)/(4 sin(2π/5)) ... in
    // closed form r_in / R = sqrt(3)/12 (3 + sqrt 5) / (sqrt(10 + 2 sqrt 5)/4).
    let r_in =
        (3f64.sqrt() / 12.0 * (3.0 + 5f64.sqrt())) / ((10.0 + 2.0 * 5f64.sqrt()).sqrt() / 4.0);
    let gap = 1.0 - r_in;
    let ico = icosphere(0);
    let sphere = icosphere(6); // 81,920 triangles: sags below 4e-5
    let d = hausdorff(&ico, &sphere, &opts(200_000));
    assert!(
        (d.a_to_b.max - gap).abs() < 1e-4,
        "{} vs {gap}",
        d.a_to_b.max
    );
    assert!(
        (d.b_to_a.max - gap).abs() < 1e-4,
        "{} vs {gap}",
        d.b_to_a.max
    );
}

#[test]
fn deterministic_and_thread_independent() {
    let a = icosphere(3);
    let b = icosphere(1);
    let d1 = hausdorff(&a, &b, &opts(30_000));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let d2 = pool.install(|| hausdorff(&a, &b, &opts(30_000)));
    assert_eq!(d1, d2);
}

#[test]
fn empty_meshes_do_not_panic() {
    let e = Mesh::default();
    let m = cube(1.0);
    let d = hausdorff(&e, &m, &opts(100));
    assert_eq!(d.a_to_b.samples, 0);
    assert!(d.b_to_a.max.is_infinite());
}

#[test]
fn screen_space_round_trip() {
    // 1 cm error at 10 m, 60° fov, 1080 px: 0.01*1080/(2*10*tan 30°) = 0.9353 px.
    let p = screen_space_error(0.01, 1080.0, 60.0, 10.0);
    assert!((p - 0.935_307).abs() < 1e-5, "{p}");
    let d = distance_for_pixels(0.01, p, 1080.0, 60.0);
    assert!((d - 10.0).abs() < 1e-9);
}

#[test]
fn allot_sums_exactly() {
    let c = allot(&[1.0, 2.0, 0.0, 3.5, 0.1], 1000);
    assert_eq!(c.iter().map(|&x| x as usize).sum::<usize>(), 1000);
    assert_eq!(c[2], 0);
    assert!((i64::from(c[3]) - 530).abs() <= 1);
}
