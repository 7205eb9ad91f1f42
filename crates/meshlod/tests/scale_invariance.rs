//! The same mesh at any scale simplifies the same way: a mesh multiplied by a power
//! of two (exact in floating point: every position, area and quadric scales
//! exactly) gives the same output triangles, scaled, with QEM, Melax and vertex
//! removal. Before the degenerate-triangle test and the queue keys were made
//! relative to the mesh's size, a bunny in kilometres (×2⁻²⁰) could not collapse
//! at all and one at ×2⁴⁰ overflowed the `f32` keys (Hausdorff 35% of the diagonal).

mod common;

use meshlod::io::read_scene;
use meshlod::simplify::{simplify, Method, SimplifyOptions, StopReason};
use meshlod::Mesh;

fn scaled(mesh: &Mesh, s: f32) -> Mesh {
    let mut m = mesh.clone();
    for p in &mut m.positions {
        *p = p.map(|c| c * s);
    }
    m
}

#[test]
fn power_of_two_scales_give_the_same_output() {
    let mesh = read_scene(common::data_dir().join("fandisk.obj"))
        .expect("test mesh reads")
        .flatten();
    for method in [Method::Qem, Method::Melax, Method::VertexRemoval] {
        let options = SimplifyOptions::default()
            .with_method(method)
            .with_ratio(0.1);
        let (reference, r) = simplify(&mesh, &options).expect("simplifies");
        assert_eq!(r.stop_reason, StopReason::TargetReached);
        for k in [-20, 40] {
            let s = 2f32.powi(k);
            let (out, report) = simplify(&scaled(&mesh, s), &options).expect("simplifies");
            let name = format!("{} at 2^{k}", method.name());
            assert_eq!(report.stop_reason, StopReason::TargetReached, "{name}");
            assert_eq!(
                out.triangles, reference.triangles,
                "{name}: other triangles"
            );
            assert_eq!(
                out.positions,
                scaled(&reference, s).positions,
                "{name}: other positions"
            );
            assert!(
                (report.error - r.error).abs() <= 1e-12,
                "{name}: relative error"
            );
        }
    }
}

/// A mesh of many small triangles in a large box: a 40 × 40 grid of cells 0.025
/// wide beside a lone triangle 1,400 units away.
///
/// ```text
///   grid [0,1]²                                     far triangle at (1000, 1000)
///   ┌┬┬┬┐
///   ├┼┼┼┤  . . . . . . . . . . . . . . . . . . . . . .  ◺
///   └┴┴┴┘
/// ```
///
/// The box's diagonal is about 1,414, so `f32` coordinates are spaced about
/// `ε·diag ≈ 1.7·10⁻⁴` apart and every grid triangle is far taller than that, but
/// its area (6·10⁻⁴) is below `ε·diag² ≈ 0.24`: when the degenerate test bounded
/// the area, no collapse or removal in the grid was legal (as on a 16.7M-triangle
/// terrain, whose cells are small beside its box). Judged by height, the grid
/// simplifies as it would alone.
#[test]
fn small_triangles_in_a_large_box_simplify() {
    let mut mesh =
        meshlod::mesh::generate::grid(40, 40, |x, y| 0.05 * (6.0 * x).sin() * (5.0 * y).cos());
    let base = mesh.positions.len() as u32;
    mesh.positions.extend([
        [1000.0, 1000.0, 0.0],
        [1001.0, 1000.0, 0.0],
        [1000.0, 1001.0, 0.0],
    ]);
    mesh.triangles.push([base, base + 1, base + 2]);
    let target = 320;
    for method in [Method::Qem, Method::Melax, Method::VertexRemoval] {
        let options = SimplifyOptions::default()
            .with_method(method)
            .with_target_triangles(target);
        let (out, report) = simplify(&mesh, &options).expect("simplifies");
        let name = method.name();
        assert_eq!(
            report.stop_reason,
            StopReason::TargetReached,
            "{name}: {report:?}"
        );
        assert!(
            out.triangles.len() <= target,
            "{name}: {} triangles for a target of {target}",
            out.triangles.len()
        );
        // The bumps are 0.05 high: a tenth of the cells keeps well within that.
        assert!(
            report.error_absolute < 0.02,
            "{name}: error {} for bumps 0.05 high",
            report.error_absolute
        );
    }
}
