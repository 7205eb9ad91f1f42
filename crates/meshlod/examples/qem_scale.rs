//! Time and memory of meshlod's QEM simplification against meshoptimizer's
//! `simplify` as the input grows: the scaling benchmark behind
//! `docs/benchmarks.md` ("QEM at scale"), run by `bench/qem_scale.sh`.
//!
//! `cargo run --release -p meshlod --example qem_scale -- MESH…` loads each mesh
//! (any format meshlod reads, by absolute path; the script writes Grand Canyon grids of 0.26M to 67M
//! triangles), then, for ratios 0.1 and 0.01, runs meshoptimizer (target error 1.0,
//! so only the triangle count stops it; it gets the exactly welded index buffer, as
//! in the other comparisons) and ours (the library's `simplify` with its defaults,
//! welding included in its time) once each. Every run is a process of its own
//! (this program again, told what to run by `MESHLOD_SCALE_RUN`), so no run reuses
//! memory another one freed. It prints one Markdown row per mesh, ratio and thread
//! count: seconds, ours / meshoptimizer, µs per input triangle, and each one's
//! peak resident memory above what was resident before its run (the loaded mesh,
//! and for meshoptimizer its welded buffers, made before its clock starts), per
//! input triangle. The peak is the kernel's `VmHWM`, reset before the run by
//! writing `5` to `/proc/self/clear_refs` (Linux; elsewhere the memory columns
//! say `-`).
//!
//! Ours runs on 1 and on 2 threads (`SimplifyOptions::threads`; the output is the
//! same), each as its own row; meshoptimizer is single-threaded.
//! `MESHLOD_SCALE_RATIOS=0.01` limits the ratios, `MESHLOD_SCALE_THREADS=2` the
//! thread counts.

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

/// One run, in this process: `tool` is `meshopt` or `ours`. Prints `triangles
/// seconds peak-bytes` (the last `-` where not measurable).
fn run_one(path: &str, tool: &str, ratio: f64, threads: usize) {
    let m: Mesh = load(path);
    let n = m.triangles.len();
    let target = (n as f64 * ratio).round() as usize;
    let (tris, secs, peak) = if tool == "meshopt" {
        let (indices, bytes) = welded(&m);
        drop(m);
        let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).expect("adapter");
        measured(|| {
            let r = meshopt::simplify(
                &indices,
                &adapter,
                target * 3,
                1.0,
                meshopt::SimplifyOptions::None,
                None,
            );
            black_box(r.len() / 3)
        })
    } else {
        let options = SimplifyOptions {
            threads: Some(threads),
            ..SimplifyOptions::default().with_ratio(ratio)
        };
        measured(|| {
            let (out, _) = simplify(&m, &options).expect("valid mesh");
            black_box(out.triangles.len())
        })
    };
    println!(
        "{tris} {secs} {}",
        peak.map_or("-".to_string(), |b| b.to_string())
    );
}

/// Runs one measurement in a child process: (triangles, seconds, peak bytes).
fn child(path: &str, tool: &str, ratio: f64, threads: usize) -> (usize, f64, Option<u64>) {
    let exe = std::env::current_exe().expect("own path");
    let out = std::process::Command::new(exe)
        .arg(path)
        .env("MESHLOD_SCALE_RUN", format!("{tool},{ratio},{threads}"))
        .output()
        .expect("child run");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let f: Vec<&str> = text.split_whitespace().collect();
    (
        f[0].parse().expect("triangles"),
        f[1].parse().expect("seconds"),
        f[2].parse().ok(),
    )
}

fn list<T: std::str::FromStr>(var: &str, default: Vec<T>) -> Vec<T> {
    std::env::var(var)
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or(default)
}

fn main() {
    let paths: Vec<String> = std::env::args().skip(1).collect();
    if paths.is_empty() {
        eprintln!("usage: qem_scale MESH… (see bench/qem_scale.sh)");
        std::process::exit(2);
    }
    if let Ok(run) = std::env::var("MESHLOD_SCALE_RUN") {
        let f: Vec<&str> = run.split(',').collect();
        let ratio = f[1].parse().expect("ratio");
        let threads = f[2].parse().expect("threads");
        run_one(&paths[0], f[0], ratio, threads);
        return;
    }
    let ratios: Vec<f64> = list("MESHLOD_SCALE_RATIOS", vec![0.1, 0.01]);
    let threads: Vec<usize> = list("MESHLOD_SCALE_THREADS", vec![1, 2]);
    println!(
        "| mesh | triangles | ratio | threads | meshopt s | ours s | ours / meshopt | ours µs/tri \
         | meshopt peak B/tri | ours peak B/tri | tris meshopt / ours |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for path in &paths {
        let n = load(path).triangles.len();
        let name = std::path::Path::new(path)
            .file_name()
            .map_or(path.clone(), |f| f.to_string_lossy().into_owned());
        for &ratio in &ratios {
            let (nm, tm, mm) = child(path, "meshopt", ratio, 1);
            for &k in &threads {
                let (no, to, mo) = child(path, "ours", ratio, k);
                println!(
                    "| {name} | {n} | {ratio} | {k} | {tm:.2} | {to:.2} | {:.2} | {:.2} | {} | {} | {nm} / {no} |",
                    to / tm,
                    to * 1e6 / n as f64,
                    per_triangle(mm, n),
                    per_triangle(mo, n),
                );
            }
        }
    }
}
