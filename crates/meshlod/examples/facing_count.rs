//! Counts the triangles of simplified meshes that face away from the input: the
//! normal of an output triangle and that of the input triangle nearest its centroid
//! point to opposite sides (the count `tests/simplify_vertex_removal_shared.rs`
//! bounds).
//!
//! `cargo run --release -p meshlod --example facing_count -- INPUT OUTPUT...` prints
//! one line per output: its path, its triangles and how many of them face away.

use meshlod::mesh::Mesh;
use meshlod::metrics::bvh::Bvh;

/// The unnormalised normal of triangle `t` of `m`.
fn normal(m: &Mesh, t: [u32; 3]) -> [f64; 3] {
    let [a, b, c] = t.map(|i| m.positions[i as usize].map(f64::from));
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((input, outputs)) = args.split_first() else {
        eprintln!("usage: facing_count INPUT OUTPUT...");
        std::process::exit(2);
    };
    let original = meshlod::read_mesh(input).expect("readable input");
    let bvh = Bvh::build(&original.positions, &original.triangles);
    for path in outputs {
        let out = meshlod::read_mesh(path).expect("readable output");
        let mut away = 0usize;
        for &t in &out.triangles {
            let [a, b, c] = t.map(|i| out.positions[i as usize].map(f64::from));
            let centroid = [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0);
            if let Some(cl) = bvh.closest(centroid, None) {
                let no = normal(&original, original.triangles[cl.triangle as usize]);
                let ns = normal(&out, t);
                if no[0] * ns[0] + no[1] * ns[1] + no[2] * ns[2] < 0.0 {
                    away += 1;
                }
            }
        }
        println!("{path} {} {away}", out.triangles.len());
    }
}
