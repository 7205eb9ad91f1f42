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
