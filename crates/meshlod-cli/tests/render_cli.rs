//! Runs the real `meshlod render`: a PNG of the asked size (decoded back), the JSON
//! report, side-by-side panels with a heat map, and bad arguments refused cleanly.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn meshlod(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_meshlod"))
        .args(args)
        .output()
        .expect("run meshlod")
}

fn ok(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "meshlod failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(stdout.lines().last().expect("a line")).expect("JSON")
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data")
        .join(name)
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Decodes an RGB PNG: (width, height, pixels).
fn decode(path: &Path) -> (u32, u32, Vec<[u8; 3]>) {
    let file = std::fs::File::open(path).expect("open png");
    let mut dec = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .expect("png header");
    let mut buf = vec![0; dec.output_buffer_size().expect("size")];
    let info = dec.next_frame(&mut buf).expect("png data");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let px = buf[..info.buffer_size()]
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (info.width, info.height, px)
}

#[test]
fn bunny_renders_to_a_png_of_the_asked_size() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("tmp.png");
    let bunny = data("stanford-bunny.obj");
    let r = ok(&meshlod(&[
        "render",
        s(&bunny),
        "-o",
        s(&out),
        "--width",
        "320",
        "--height",
        "240",
        "--json",
    ]));
    assert_eq!(r["width"], 320);
    assert_eq!(r["height"], 240);
    assert_eq!(r["output"], s(&out));
    assert_eq!(r["panels"][0]["triangles"], 69451);
    assert!(r["panels"][0]["seconds"].as_f64().expect("seconds") >= 0.0);
    let (w, h, px) = decode(&out);
    assert_eq!((w, h), (320, 240));
    let white = px.iter().filter(|&&p| p == [255, 255, 255]).count();
    assert!(
        white > 1000 && white < px.len() - 10_000,
        "{white} background pixels"
    );
    // The default size.
    ok(&meshlod(&["render", s(&bunny), "-o", s(&out), "--json"]));
    assert_eq!(decode(&out).0, 1024);
}

#[test]
fn panels_with_a_heat_map() {
    let dir = tempfile::tempdir().expect("tempdir");
    let coarse = dir.path().join("coarse.obj");
    let bunny = data("stanford-bunny.obj");
    let o = meshlod(&["simplify", s(&bunny), "-o", s(&coarse), "--ratio", "0.02"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("heat.png");
    let r = ok(&meshlod(&[
        "render",
        s(&bunny),
        s(&coarse),
        "--heatmap-vs",
        s(&bunny),
        "-o",
        s(&out),
        "--width",
        "600",
        "--height",
        "300",
        "--view",
        "iso",
        "--wireframe",
        "--json",
    ]));
    assert_eq!(r["panels"].as_array().expect("panels").len(), 2);
    let max = r["heatmap"]["max"].as_f64().expect("max");
    let pct = r["heatmap"]["percent_of_diagonal"].as_f64().expect("pct");
    assert!(max > 0.0 && pct > 0.0 && pct < 5.0, "{max} {pct}");
    let (w, h, _) = decode(&out);
    assert_eq!((w, h), (600, 300));
}

#[test]
fn bad_arguments_are_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("x.png");
    let bunny = data("stanford-bunny.obj");
    for (args, needle) in [
        (vec!["--width", "0"], "1 to 16384"),
        (vec!["--height", "16385"], "1 to 16384"),
        (vec!["--view", "sideways"], "unknown view"),
        (vec!["--view", "0,0,0"], "unknown view"),
    ] {
        let mut a = vec!["render", s(&bunny), "-o", s(&out)];
        a.extend(args);
        let o = meshlod(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(needle), "{a:?}: {err}");
    }
    let missing = dir.path().join("missing.obj");
    let o = meshlod(&["render", s(&missing), "-o", s(&out)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("missing.obj"), "{err}");
    assert!(!out.exists());
}
