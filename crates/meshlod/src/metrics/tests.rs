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

/// An acute triangle `A` and three slivers of `B` pointing outward from its corners:
///
/// ```text
///            ╱▲╲ (0.4, 0.9)
///           ╱ · ╲          · = circumcentre c, at distance R from every corner
///   ◁(0,0) ─────── (1,0)▷  ◁ ▷ ▲ = B's slivers, one corner on each corner of A
/// ```
///
/// Every point of `A` is at most `R` from some corner, and `c` is exactly `R` from
/// `B` (each sliver lies beyond its corner as seen from `c`), so `h(A, B) = R`, reached
/// only at `c`: an interior point that a few samples miss.
fn circumcentre_case() -> (Mesh, Mesh, f64) {
    let v: [[f64; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.4, 0.9, 0.0]];
    // Circumcentre of a triangle with a corner at the origin, in the plane z = 0.
    let (bx, by, cx, cy) = (v[1][0], v[1][1], v[2][0], v[2][1]);
    let d = 2.0 * (bx * cy - by * cx);
    let ux = (cy * (bx * bx + by * by) - by * (cx * cx + cy * cy)) / d;
    let uy = (bx * (cx * cx + cy * cy) - cx * (bx * bx + by * by)) / d;
    let r = (ux * ux + uy * uy).sqrt();
    let a = Mesh::from_triangles(
        v.iter().map(|p| p.map(|x| x as f32)).collect(),
        vec![[0, 1, 2]],
    );
    let (mut p, mut t) = (Vec::new(), Vec::new());
    for corner in v {
        let (dx, dy) = (corner[0] - ux, corner[1] - uy);
        let n = (dx * dx + dy * dy).sqrt();
        let (ox, oy) = (dx / n, dy / n); // outward
        let (wx, wy) = (-oy, ox);
        let s = 0.05;
        let k = p.len() as u32;
        p.push([corner[0] as f32, corner[1] as f32, 0.0]);
        for side in [1.0, -1.0] {
            p.push([
                (corner[0] + s * ox + side * 0.3 * s * wx) as f32,
                (corner[1] + s * oy + side * 0.3 * s * wy) as f32,
                0.0,
            ]);
        }
        t.push([k, k + 1, k + 2]);
    }
    (a, Mesh::from_triangles(p, t), r)
}

#[test]
fn certified_maximum_finds_the_point_between_samples() {
    let (a, b, r) = circumcentre_case();
    let target = Bvh::build(&b.positions, &b.triangles);
    let few = SamplingOptions {
        certify: false,
        ..opts(20)
    };
    let sampled = one_sided(&a, &target, &few);
    // The samples alone miss the circumcentre by more than the tolerance (else this
    // case would not test the refinement).
    assert!(
        sampled.max < r * (1.0 - 2.0 * certify::TOLERANCE),
        "{sampled:?} vs {r}"
    );
    assert_eq!(sampled.max_upper, None);

    let c = one_sided(&a, &target, &opts(20));
    let upper = c.max_upper.expect("certified");
    // f32 positions: allow rounding at 1e-6.
    assert!(c.max <= r + 1e-6, "lower {} above the truth {r}", c.max);
    assert!(upper >= r - 1e-6, "upper {upper} below the truth {r}");
    assert!(upper <= c.max * (1.0 + certify::TOLERANCE) + 1e-9, "{c:?}");
    assert!(c.max >= r * (1.0 - certify::TOLERANCE), "{} vs {r}", c.max);
    // The reported point is where the distance was found.
    let at = c.max_at;
    let dc = ((at[0] - c.max_closest[0]).powi(2)
        + (at[1] - c.max_closest[1]).powi(2)
        + (at[2] - c.max_closest[2]).powi(2))
    .sqrt();
    assert!((dc - c.max).abs() < 1e-9, "{dc} vs {}", c.max);
}

#[test]
fn certified_interval_holds_the_analytic_maxima() {
    // Offset planes: exact everywhere, so the interval closes on 0.25.
    let d = hausdorff(&grid(8, 0.0), &grid(5, 0.25), &opts(2_000));
    let up = d.hausdorff_upper.expect("certified");
    assert!(
        (d.hausdorff - 0.25).abs() < 1e-7 && up >= 0.25 - 1e-7,
        "{d:?}"
    );
    assert!(up <= 0.25 * (1.0 + certify::TOLERANCE) + 1e-7, "{d:?}");

    // Icosahedron against its sphere with few samples: the gap at the face centres
    // lies in [max, max_upper] both ways, up to the faceted sphere's departure from
    // the true one (1e-4, as in the sampled test above).
    let r_in =
        (3f64.sqrt() / 12.0 * (3.0 + 5f64.sqrt())) / ((10.0 + 2.0 * 5f64.sqrt()).sqrt() / 4.0);
    let gap = 1.0 - r_in;
    let d = hausdorff(&icosphere(0), &icosphere(6), &opts(500));
    for one in [d.a_to_b, d.b_to_a] {
        let up = one.max_upper.expect("certified");
        assert!(
            one.max <= gap + 1e-4 && up >= gap - 1e-4,
            "{one:?} vs {gap}"
        );
        assert!(up <= one.max * (1.0 + certify::TOLERANCE) + 1e-9, "{one:?}");
    }
    assert!(d.hausdorff_upper.unwrap() >= d.hausdorff);
}

#[test]
fn certified_maximum_against_an_empty_mesh_is_unbounded() {
    let d = hausdorff(&cube(1.0), &Mesh::default(), &opts(100));
    assert_eq!(d.a_to_b.max_upper, Some(f64::INFINITY));
    assert_eq!(d.b_to_a.max_upper, Some(0.0));
}

/// A wavy height field against the same field on a slightly different grid: the
/// distances (about 1e-4) are far below the triangles' size, so most regions straddle
/// several nearest triangles and the refinement cannot settle them with its budget.
/// It stops early, and its interval still holds a dense reference.
#[test]
fn near_copies_stop_early_with_a_true_interval() {
    let wave = |x: f64, y: f64| 0.05 * (6.0 * x).sin() * (5.0 * y).cos();
    let a = generate::grid(120, 120, wave);
    let b = generate::grid(113, 127, wave);
    let target = Bvh::build(&b.positions, &b.triangles);
    let dense = one_sided(
        &a,
        &target,
        &SamplingOptions {
            certify: false,
            ..opts(2_000_000)
        },
    );
    let sampled = one_sided(
        &a,
        &target,
        &SamplingOptions {
            certify: false,
            ..opts(20_000)
        },
    );
    let c = one_sided(&a, &target, &opts(20_000));
    let upper = c.max_upper.expect("certified");
    // The refinement only raises the sampled maximum, and never above its bound.
    assert!(c.max >= sampled.max && c.max <= upper, "{c:?}");
    assert!(upper >= dense.max, "{upper} below the dense {}", dense.max);

    // Straight from `certify`: the interval does not close, so it stops at one of
    // the checks, well before the end of its budget.
    let points: Vec<V3> = a.positions.iter().map(|p| f64v(*p)).collect();
    let budget = 200_000;
    let r = certify::certify(
        &points,
        &a.triangles,
        &target,
        0.0,
        ([0.0; 3], [0.0; 3]),
        &certify::Known::default(),
        budget,
    );
    let first = (points.len() + a.triangles.len()) as u64;
    assert!(r.queries < first + budget / 2, "{r:?}");
    assert!(r.upper >= dense.max && r.lower <= r.upper, "{r:?}");
}
