//! Time and memory of meshlod's QEM simplification against meshoptimizer's
//! `simplify` as the input grows: the scaling benchmark behind
//! `docs/benchmarks.md` ("QEM at scale"), run by `bench/qem_scale.sh`.
//!
//! `cargo run --release -p meshlod --example qem_scale -- MESH…` loads each mesh
//! (any format meshlod reads, by absolute path; the script writes Grand Canyon grids of 0.26M to 67M
//! triangles), then, for ratios 0.1 and 0.01, runs meshoptimizer (target error 1.0,
//! so only the triangle count stops it; it gets the exactly welded index buffer, as
//! in the other comparisons) and ours (the library's `simplify` with its defaults,
//! welding included in its time) once each, in this one process. It prints one
//! Markdown row per mesh and ratio: seconds, ours / meshoptimizer, µs per input
//! triangle, and each one's peak resident memory above what was resident before
//! its run (the loaded mesh, and for meshoptimizer its welded buffers, made
//! before its clock starts), per input triangle. The peak is the kernel's `VmHWM`, reset before each run by writing `5`
//! to `/proc/self/clear_refs` (Linux; elsewhere the memory columns say `-`).
//!
//! `MESHLOD_SCALE_RATIOS=0.01` limits the ratios.

mod common;
use common::{load, welded};
use meshlod::mesh::Mesh;
use meshlod::simplify::{simplify, SimplifyOptions};
use std::hint::black_box;
use std::time::Instant;

/// Resident and peak resident bytes (`VmRSS`, `VmHWM`), if the platform says.
fn rss() -> Option<(u64, u64)> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let field = |name: &str| -> Option<u64> {
        let line = text.lines().find(|l| l.starts_with(name))?;
        let kb: u64 = line[name.len()..]
            .trim()
            .trim_end_matches("kB")
            .trim()
            .parse()
            .ok()?;
        Some(kb * 1024)
    };
    Some((field("VmRSS:")?, field("VmHWM:")?))
}

/// Runs `f`, returning its result, its seconds and its peak resident bytes above
/// the resident size before it (`None` where not measurable).
fn measured<T>(f: impl FnOnce() -> T) -> (T, f64, Option<u64>) {
    let reset = std::fs::write("/proc/self/clear_refs", "5").is_ok();
    let before = rss();
    let t = Instant::now();
    let out = f();
    let secs = t.elapsed().as_secs_f64();
    let extra = match (reset, before, rss()) {
        (true, Some((cur, _)), Some((_, peak))) => Some(peak.saturating_sub(cur)),
        _ => None,
    };
    (out, secs, extra)
}

fn per_triangle(bytes: Option<u64>, triangles: usize) -> String {
    bytes.map_or("-".into(), |b| {
        format!("{:.0}", b as f64 / triangles as f64)
    })
}

fn main() {
    let paths: Vec<String> = std::env::args().skip(1).collect();
    if paths.is_empty() {
        eprintln!("usage: qem_scale MESH… (see bench/qem_scale.sh)");
        std::process::exit(2);
    }
    let ratios: Vec<f64> = std::env::var("MESHLOD_SCALE_RATIOS")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![0.1, 0.01]);
    println!(
        "| mesh | triangles | ratio | meshopt s | ours s | ours / meshopt | ours µs/tri \
         | meshopt peak B/tri | ours peak B/tri | tris meshopt / ours |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for path in &paths {
        let t = Instant::now();
        let m: Mesh = load(path);
        eprintln!(
            "{path}: {} triangles read in {:.1} s",
            m.triangles.len(),
            t.elapsed().as_secs_f64()
        );
        let n = m.triangles.len();
        let name = std::path::Path::new(path)
            .file_name()
            .map_or(path.clone(), |f| f.to_string_lossy().into_owned());
        for &ratio in &ratios {
            let target = (n as f64 * ratio).round() as usize;
            let (indices, bytes) = welded(&m);
            let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).expect("adapter");
            let (nm, tm, mm) = measured(|| {
                let r = meshopt::simplify(
                    &indices,
                    &adapter,
                    target * 3,
                    1.0,
                    meshopt::SimplifyOptions::None,
                    None,
                );
                black_box(r.len() / 3)
            });
            drop((indices, bytes));
            let options = SimplifyOptions::default().with_ratio(ratio);
            let (no, to, mo) = measured(|| {
                let (out, _) = simplify(&m, &options).expect("valid mesh");
                black_box(out.triangles.len())
            });
            println!(
                "| {name} | {n} | {ratio} | {tm:.2} | {to:.2} | {:.2} | {:.2} | {} | {} | {nm} / {no} |",
                to / tm,
                to * 1e6 / n as f64,
                per_triangle(mm, n),
                per_triangle(mo, n),
            );
        }
    }
}
