//! Analytic cases for the appearance measure.

use super::*;
use crate::mesh::generate;

fn opts() -> SamplingOptions {
    SamplingOptions::default().with_samples(20_000)
}

/// A `k × k` grid on the unit square (z = 0) with UVs equal to the positions plus
/// `shift`.
fn square(k: u32, shift: [f32; 2]) -> Mesh {
    let mut m = generate::grid(k, k, |_, _| 0.0);
    m.attributes.uv0 = Some(
        m.positions
            .iter()
            .map(|p| [p[0] + shift[0], p[1] + shift[1]])
            .collect(),
    );
    m
}

fn close(x: f64, want: f64, tol: f64) {
    assert!((x - want).abs() <= tol, "{x} is not {want} (±{tol})");
}

#[test]
fn shifted_uvs_measure_the_shift() {
    let a = square(4, [0.0, 0.0]);
    let b = square(4, [0.1, 0.0]);
    let r = appearance(&a, &b, &opts()).expect("both have UVs");
    let uv = r.uv.unwrap();
    close(uv.max, 0.1, 1e-6);
    close(uv.mean, 0.1, 1e-6);
    for side in [r.a_to_b, r.b_to_a] {
        let d = side.uv.unwrap();
        close(d.max, 0.1, 1e-6);
        close(d.mean, 0.1, 1e-6);
        // 25 vertices and 20,000 face samples.
        assert_eq!(d.samples, 20_025);
        assert_eq!(side.uv_unmatched, 0);
    }
    assert!(r.normal_deg.is_none() && r.color.is_none());
}

#[test]
fn tilted_normals_measure_the_angle() {
    let mut a = square(3, [0.0, 0.0]);
    a.attributes.uv0 = None;
    let mut b = a.clone();
    a.attributes.normals = Some(vec![[0.0, 0.0, 1.0]; a.positions.len()]);
    let t = 30f32.to_radians();
    // Not unit length: corner normals are normalised before interpolation.
    b.attributes.normals = Some(vec![[0.0, 2.0 * t.sin(), 2.0 * t.cos()]; b.positions.len()]);
    let r = appearance(&a, &b, &opts()).unwrap();
    let n = r.normal_deg.unwrap();
    close(n.max, 30.0, 1e-4);
    close(n.mean, 30.0, 1e-4);
    assert!(r.uv.is_none());
}

#[test]
fn normals_varying_across_the_surface() {
    // A normal field rotating linearly with x from 0° to 40° about the y axis on A,
    // constant on B: the deviation at x is 40·x degrees up to interpolation between
    // the corners (a 40-cell strip keeps the chord error tiny): max 40, mean 20.
    let mut a = generate::grid(40, 1, |_, _| 0.0);
    let mut b = a.clone();
    a.attributes.normals = Some(
        a.positions
            .iter()
            .map(|p| {
                let t = (40.0 * p[0]).to_radians();
                [t.sin(), 0.0, t.cos()]
            })
            .collect(),
    );
    b.attributes.normals = Some(vec![[0.0, 0.0, 1.0]; b.positions.len()]);
    let r = appearance(&a, &b, &SamplingOptions::default().with_samples(200_000)).unwrap();
    let n = r.normal_deg.unwrap();
    close(n.max, 40.0, 1e-3);
    close(n.mean, 20.0, 0.05);
}

#[test]
fn colours_measure_rgba_distance() {
    let mut a = square(2, [0.0, 0.0]);
    a.attributes.uv0 = None;
    let mut b = a.clone();
    a.attributes.colors = Some(vec![[1.0, 0.0, 0.0, 1.0]; a.positions.len()]);
    b.attributes.colors = Some(vec![[0.0, 1.0, 0.0, 0.5]; b.positions.len()]);
    let r = appearance(&a, &b, &opts()).unwrap();
    let c = r.color.unwrap();
    close(c.max, 2.25f64.sqrt(), 1e-6);
    close(c.mean, 2.25f64.sqrt(), 1e-6);
}

/// A `k × k` grid whose triangles each have their own three vertices; UVs are the
/// positions, plus 0.5 in `u` on the right half: a UV seam along x = 0.5, where the
/// vertices on the seam carry u = 0.5 on the left and u = 1.0 on the right.
fn seamed(k: u32) -> Mesh {
    let g = generate::grid(k, k, |_, _| 0.0);
    let mut m = Mesh::default();
    let mut uv = Vec::new();
    for t in &g.triangles {
        let c: Vec<[f32; 3]> = t.iter().map(|&v| g.positions[v as usize]).collect();
        let right = (c[0][0] + c[1][0] + c[2][0]) / 3.0 > 0.5;
        let base = m.positions.len() as u32;
        for p in &c {
            m.positions.push(*p);
            uv.push([p[0] + if right { 0.5 } else { 0.0 }, p[1]]);
        }
        m.triangles.push([base, base + 1, base + 2]);
    }
    m.attributes.uv0 = Some(uv);
    m
}

#[test]
fn seams_take_the_nearest_side() {
    let a = seamed(4);
    // The same surface with triangles in the opposite order: a lookup that takes one
    // wedge of a seam vertex and the first triangle found on the other side pairs
    // u = 0.5 with u = 1.0 on the seam; the smallest deviation over the sides is 0.
    let mut b = a.clone();
    b.triangles.reverse();
    for (x, y) in [(&a, &a), (&a, &b), (&b, &a)] {
        let r = appearance(x, y, &opts()).unwrap();
        let uv = r.uv.unwrap();
        assert!(uv.max < 1e-6, "{r:?}");
        // 25 distinct positions (5 on the seam) sampled besides the faces.
        assert_eq!(r.a_to_b.samples, 20_025);
    }
    // Only the right half shifted: the seam vertices still match on the left side.
    let mut c = a.clone();
    let uv = c.attributes.uv0.as_mut().unwrap();
    for (v, p) in a.positions.iter().enumerate() {
        if uv[v][0] > p[0] + 0.25 {
            uv[v][0] += 0.2;
        }
    }
    let r = appearance(&a, &c, &opts()).unwrap();
    let d = r.a_to_b.uv.unwrap();
    close(d.max, 0.2, 1e-6);
    // Half the area is shifted; the seam and left-side vertices are not.
    assert!(d.mean > 0.09 && d.mean < 0.11, "{d:?}");
}

#[test]
fn seams_on_the_measured_against_side() {
    // One triangle on each side of B's seam, each with a corner on the seam (its
    // first vertex, so the first query, without a hint) and the UVs of its side,
    // one wedge per vertex. The closest-point query at that corner picks one of B's
    // triangles around it, the same one for both: only taking every side of B's
    // seam matches both triangles.
    let b = seamed(4);
    let only_vertices = SamplingOptions {
        faces: false,
        ..SamplingOptions::default()
    };
    for (dx, du) in [(-0.25f32, 0.0f32), (0.25, 0.5)] {
        let positions = vec![[0.5, 0.5, 0.0], [0.5 + dx, 0.5, 0.0], [0.5 + dx, 0.75, 0.0]];
        let mut a = Mesh::from_triangles(positions, vec![[0, 1, 2]]);
        a.attributes.uv0 = Some(a.positions.iter().map(|p| [p[0] + du, p[1]]).collect());
        let r = appearance(&a, &b, &only_vertices).unwrap();
        assert_eq!(r.a_to_b.samples, 3);
        assert!(r.a_to_b.uv.unwrap().max < 1e-6, "side {dx}: {r:?}");
    }
}

#[test]
fn uvs_are_compared_within_the_same_material() {
    // A: the square in material "wood". B: the same square, plus a second copy lying
    // on it (listed first, so it wins ties) in material "decal" with other UVs.
    let mut a = square(2, [0.0, 0.0]);
    a.groups = Some(vec![0; a.triangles.len()]);
    a.group_names = vec!["wood".into()];
    let decal = square(2, [0.7, 0.0]);
    let mut b = decal.clone();
    b.groups = Some(vec![0; decal.triangles.len()]);
    b.group_names = vec!["decal".into(), "wood".into()];
    let mut wood = a.clone();
    wood.groups = Some(vec![1; a.triangles.len()]);
    b.append(&wood, 0);
    b.group_names = vec!["decal".into(), "wood".into()];
    let r = appearance(&a, &b, &opts()).unwrap();
    assert!(r.a_to_b.uv.unwrap().max < 1e-6, "{r:?}");
    assert_eq!(r.a_to_b.uv_unmatched, 0);
    // B's decal has no counterpart on A: its samples compare no UV.
    assert!(r.b_to_a.uv_unmatched > 0);
    assert!(r.b_to_a.uv.unwrap().max < 1e-6);
    // Without material names the decal is just the nearer surface.
    let (mut a2, mut b2) = (a.clone(), b.clone());
    a2.groups = None;
    b2.groups = None;
    let r = appearance(&a2, &b2, &opts()).unwrap();
    assert!(r.a_to_b.uv.unwrap().max > 0.69, "{r:?}");
}

#[test]
fn identical_meshes_measure_zero() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/Duck/Duck.gltf");
    let duck = crate::read_mesh(&path).expect("the shipped Duck");
    let mut other = duck.clone();
    other.triangles.reverse();
    if let Some(g) = other.groups.as_mut() {
        g.reverse();
    }
    let r = appearance(&duck, &other, &opts()).unwrap();
    for s in [r.uv.unwrap(), r.normal_deg.unwrap()] {
        assert!(s.max < 1e-4 && s.mean < 1e-6, "{r:?}");
    }
    assert_eq!(r.a_to_b.uv_unmatched, 0);
}

#[test]
fn nothing_in_common_gives_none() {
    let a = square(2, [0.0, 0.0]);
    let mut b = a.clone();
    b.attributes.uv0 = None;
    assert!(appearance(&a, &b, &opts()).is_none());
}

#[test]
fn deterministic_across_thread_counts() {
    let a = seamed(8);
    let mut b = square(5, [0.01, 0.02]);
    b.positions.iter_mut().for_each(|p| p[2] = 0.01 * p[0]);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| appearance(&a, &b, &opts()));
    let many = appearance(&a, &b, &opts());
    assert_eq!(one, many);
}
