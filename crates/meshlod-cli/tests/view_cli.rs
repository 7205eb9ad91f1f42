//! Runs the real `meshlod view` and `--preview`: the page is self-contained (no
//! network address, the embedded mesh decodes back to the input), and, when
//! Chromium is installed (`/usr/bin/chromium`), headless Chromium's screenshot of
//! the page shows the model where the CPU renderer draws it; the preview pictures
//! have one captioned panel per mesh, each showing the model.

use base64::Engine as _;
use meshlod::render::{self, Canvas, RenderOptions};
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

/// Decodes an 8-bit RGB or RGBA PNG: (width, height, RGB pixels).
fn decode(path: &Path) -> (usize, usize, Vec<[u8; 3]>) {
    let file = std::fs::File::open(path).expect("open png");
    let mut dec = png::Decoder::new(std::io::BufReader::new(file));
    dec.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut dec = dec.read_info().expect("png header");
    let mut buf = vec![0; dec.output_buffer_size().expect("size")];
    let info = dec.next_frame(&mut buf).expect("png data");
    let n = info.color_type.samples();
    let px = buf[..info.buffer_size()]
        .chunks_exact(n)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (info.width as usize, info.height as usize, px)
}

/// The text between `<script ... id="ID">` and `</script>`.
fn script<'a>(html: &'a str, id: &str) -> &'a str {
    let at = html.find(&format!("id=\"{id}\">")).expect("script element");
    let rest = &html[at..];
    let start = rest.find('>').expect(">") + 1;
    let end = rest.find("</script>").expect("end");
    &rest[start..end]
}

#[test]
fn page_is_self_contained_and_embeds_the_mesh() {
    let dir = tempfile::tempdir().expect("tempdir");
    let page = dir.path().join("spot.html");
    let spot = data("spot.obj");
    let coarse = dir.path().join("coarse.ply");
    ok(&meshlod(&[
        "simplify",
        s(&spot),
        "-o",
        s(&coarse),
        "--ratio",
        "0.1",
        "--json",
    ]));
    let r = ok(&meshlod(&[
        "view",
        s(&spot),
        s(&coarse),
        "--heatmap-vs",
        s(&spot),
        "-o",
        s(&page),
        "--json",
    ]));
    assert_eq!(r["levels"].as_array().expect("levels").len(), 2);
    assert!(r["heatmap_max"].as_f64().expect("max") > 0.0);
    let html = std::fs::read_to_string(&page).expect("page");
    for net in ["http://", "https://", "src=", "<link", "import("] {
        assert!(!html.contains(net), "the page refers outside: {net}");
    }
    let header: serde_json::Value =
        serde_json::from_str(script(&html, "meshlod-header")).expect("header JSON");
    let blob = base64::engine::general_purpose::STANDARD
        .decode(script(&html, "meshlod-data").trim())
        .expect("base64");
    assert_eq!(blob.len() as u64, header["bytes"].as_u64().expect("bytes"));
    let mesh = meshlod::read_scene(&spot).expect("spot").flatten();
    let l0 = &header["levels"][0];
    assert_eq!(l0["triangles"].as_u64(), Some(mesh.triangle_count() as u64));
    let at = l0["positions"].as_u64().expect("offset") as usize;
    let f = |i: usize| f32::from_le_bytes(blob[at + 4 * i..at + 4 * i + 4].try_into().unwrap());
    let last = mesh.vertex_count() - 1;
    assert_eq!([f(0), f(1), f(2)], mesh.positions[0]);
    assert_eq!(
        [f(3 * last), f(3 * last + 1), f(3 * last + 2)],
        mesh.positions[last]
    );
    // The heat values of LOD0 against itself are zero; the coarse level's are not.
    let heat = |k: usize| {
        let l = &header["levels"][k];
        let at = l["heat"].as_u64().expect("heat") as usize;
        (0..l["vertices"].as_u64().unwrap() as usize)
            .map(|i| f32::from_le_bytes(blob[at + 4 * i..at + 4 * i + 4].try_into().unwrap()))
            .fold(0.0f32, f32::max)
    };
    assert!(heat(0) < 1e-6 && heat(1) > 0.0, "{} {}", heat(0), heat(1));
}

#[test]
fn too_many_triangles_are_refused_with_advice() {
    let dir = tempfile::tempdir().expect("tempdir");
    let page = dir.path().join("x.html");
    let o = meshlod(&[
        "view",
        s(&data("stanford-bunny.obj")),
        "-o",
        s(&page),
        "--max-triangles",
        "1000",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("meshlod simplify"),
        "{err}"
    );
    assert!(!page.exists());
}

/// Pixels that are not (near) white.
fn ink(p: [u8; 3]) -> bool {
    p.iter().any(|&c| c < 235)
}

/// Headless Chromium's 800 × 600 screenshot of `page`, written in `dir`.
fn screenshot(chromium: &Path, page: &Path, dir: &Path) -> PathBuf {
    let shot = dir.join("shot.png");
    let profile = dir.join("profile");
    let url = format!("file://{}", s(page));
    let out = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--enable-unsafe-swiftshader",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            "--hide-scrollbars",
            &format!("--user-data-dir={}", s(&profile)),
            &format!("--screenshot={}", s(&shot)),
            "--window-size=800,600",
            &url,
        ])
        .output()
        .expect("run chromium");
    assert!(
        shot.exists(),
        "no screenshot: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    shot
}

/// The page with a heat map shows the model in viridis colours, not grey.
#[test]
fn chromium_shows_the_heat_map() {
    let chromium = Path::new("/usr/bin/chromium");
    if !chromium.exists() {
        eprintln!("notice: /usr/bin/chromium is absent; the viewer's heat-map test is skipped");
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let bunny = data("stanford-bunny.obj");
    let coarse = dir.path().join("coarse.ply");
    ok(&meshlod(&[
        "simplify",
        s(&bunny),
        "-o",
        s(&coarse),
        "--ratio",
        "0.02",
        "--json",
    ]));
    let page = dir.path().join("heat.html");
    ok(&meshlod(&[
        "view",
        s(&coarse),
        "--heatmap-vs",
        s(&bunny),
        "-o",
        s(&page),
        "--json",
    ]));
    let shot = screenshot(chromium, &page, dir.path());
    let (w, h, px) = decode(&shot);
    // Between the tool bar and the legend.
    let inked: Vec<[u8; 3]> = (90..h - 80)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| px[y * w + x])
        .filter(|&p| ink(p))
        .collect();
    assert!(inked.len() > 20_000, "{} pixels of ink", inked.len());
    let coloured = inked
        .iter()
        .filter(|p| {
            let (lo, hi) = (p.iter().min().unwrap(), p.iter().max().unwrap());
            hi - lo > 40
        })
        .count();
    assert!(
        coloured as f64 > 0.8 * inked.len() as f64,
        "{coloured} of {} pixels coloured",
        inked.len()
    );
}

#[test]
fn chromium_shows_the_model_where_the_cpu_renderer_draws_it() {
    let chromium = Path::new("/usr/bin/chromium");
    if !chromium.exists() {
        eprintln!("notice: /usr/bin/chromium is absent; the viewer's browser test is skipped");
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let page = dir.path().join("bunny.html");
    let bunny = data("stanford-bunny.obj");
    ok(&meshlod(&["view", s(&bunny), "-o", s(&page), "--json"]));
    let shot = screenshot(chromium, &page, dir.path());
    let (w, h, px) = decode(&shot);
    assert_eq!((w, h), (800, 600));
    // The CPU renderer's picture of the same view, without captions.
    let mesh = meshlod::read_scene(&bunny).expect("bunny").flatten();
    let opts = RenderOptions {
        width: 800,
        height: 600,
        caption_lines: 0,
        ..RenderOptions::default()
    };
    let mut canvas = Canvas::new(&opts, 1, render::frame_of(Some(&mesh)), None).expect("canvas");
    canvas.draw(0, &mesh, None, "").expect("draw");
    let cpu = canvas.finish();
    // Compare below the page's tool bar (the top 90 rows).
    let (mut both, mut either, mut browser) = (0usize, 0usize, 0usize);
    let (mut sx, mut sy, mut cx, mut cy) = (0.0, 0.0, 0.0, 0.0);
    for y in 90..h {
        for x in 0..w {
            let a = ink(px[y * w + x]);
            let b = cpu.pixels[y * w + x] != render::BACKGROUND;
            both += usize::from(a && b);
            either += usize::from(a || b);
            browser += usize::from(a);
            if a {
                sx += x as f64;
                sy += y as f64;
            }
            if b {
                cx += x as f64;
                cy += y as f64;
            }
        }
    }
    let cpu_count = either - browser + both;
    assert!(
        browser > 20_000,
        "the screenshot is (nearly) blank: {browser} pixels of ink"
    );
    let iou = both as f64 / either as f64;
    assert!(iou > 0.9, "silhouettes overlap by {iou:.3} only");
    let (dx, dy) = (
        sx / browser as f64 - cx / cpu_count as f64,
        sy / browser as f64 - cy / cpu_count as f64,
    );
    assert!(
        dx.abs() < 3.0 && dy.abs() < 3.0,
        "centres differ by {dx:.1}, {dy:.1} px"
    );
}

#[test]
fn previews_show_input_and_output_and_the_lod_strip() {
    let dir = tempfile::tempdir().expect("tempdir");
    let spot = data("spot.obj");
    let out = dir.path().join("out.obj");
    let pic = dir.path().join("ba.png");
    let r = ok(&meshlod(&[
        "simplify",
        s(&spot),
        "-o",
        s(&out),
        "--ratio",
        "0.05",
        "--preview",
        s(&pic),
        "--json",
    ]));
    assert_eq!(r["preview"], s(&pic));
    let (w, h, px) = decode(&pic);
    assert_eq!((w, h), (1280, 560));
    // Each half shows the cow over about the same pixels (same camera), and the
    // coarse one differs from the input somewhere.
    let half = |x0: usize| -> Vec<bool> {
        (0..h - 40)
            .flat_map(|y| (x0..x0 + w / 2).map(move |x| (x, y)))
            .map(|(x, y)| px[y * w + x] != render::BACKGROUND)
            .collect()
    };
    let (a, b) = (half(0), half(w / 2));
    let na = a.iter().filter(|&&v| v).count();
    let both = a.iter().zip(&b).filter(|(x, y)| **x && **y).count();
    let either = a.iter().zip(&b).filter(|(x, y)| **x || **y).count();
    assert!(na > 10_000, "{na} pixels of ink");
    assert!(both as f64 / either as f64 > 0.9);
    // Captions: ink in each caption strip.
    for x0 in [0, w / 2] {
        let caption = (h - 20..h)
            .flat_map(|y| (x0..x0 + w / 2).map(move |x| (x, y)))
            .filter(|&(x, y)| px[y * w + x] != render::BACKGROUND)
            .count();
        assert!(caption > 50, "no caption under panel at {x0}");
    }

    let strip = dir.path().join("strip.png");
    let r = ok(&meshlod(&[
        "lod",
        s(&spot),
        "-o",
        s(&dir.path().join("spot.ply")),
        "--ratios",
        "0.5,0.1",
        "--preview",
        s(&strip),
        "--json",
    ]));
    assert_eq!(r["preview"], s(&strip));
    let (w, h, _) = decode(&strip);
    assert_eq!((w, h), (3 * 640, 560));

    // A glTF scene kept as a scene: one panel per level of its chain.
    let duck = std::fs::read_dir(data("Duck"))
        .expect("Duck")
        .map(|e| e.expect("entry").path())
        .find(|p| p.extension().is_some_and(|e| e == "gltf" || e == "glb"))
        .expect("a glTF duck");
    let strip = dir.path().join("duck.png");
    let r = ok(&meshlod(&[
        "lod",
        s(&duck),
        "-o",
        s(&dir.path().join("duck.glb")),
        "--levels",
        "2",
        "--preview",
        s(&strip),
        "--json",
    ]));
    let levels = r["levels"].as_array().expect("levels").len();
    let (w, _, px) = decode(&strip);
    assert_eq!(w, levels * 640);
    for k in 0..levels {
        let ink = (0..500)
            .flat_map(|y| (k * 640..(k + 1) * 640).map(move |x| (x, y)))
            .filter(|&(x, y)| px[y * w + x] != render::BACKGROUND)
            .count();
        assert!(ink > 5_000, "level {k}: {ink} pixels");
    }
}

#[test]
fn impostor_writes_a_glb_with_the_atlas_and_refuses_bad_view_counts() {
    let dir = tempfile::tempdir().expect("tempdir");
    let glb = dir.path().join("spot.glb");
    let atlas = dir.path().join("atlas.png");
    let spot = data("spot.obj");
    let r = ok(&meshlod(&[
        "impostor",
        s(&spot),
        "-o",
        s(&glb),
        "--views",
        "16",
        "--size",
        "256",
        "--atlas",
        s(&atlas),
        "--json",
    ]));
    assert_eq!(
        (r["grid"].as_u64(), r["tile_px"].as_u64()),
        (Some(4), Some(64))
    );
    let covered = r["covered_fraction"].as_f64().expect("fraction");
    assert!(covered > 0.05 && covered < 0.6, "{covered}");
    let bytes = std::fs::read(&glb).expect("glb");
    assert_eq!(&bytes[..4], b"glTF");
    let jl = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + jl]).expect("JSON");
    let layout = &doc["nodes"][0]["extras"]["meshlod_impostor"];
    assert_eq!(layout["mapping"], "octahedral");
    assert_eq!(layout["directions"].as_array().expect("dirs").len(), 16);
    assert_eq!(layout["source_triangles"].as_u64(), r["triangles"].as_u64());
    assert_eq!(doc["materials"][0]["alphaMode"], "MASK");
    // The atlas file: every tile shows the cow (some opaque texels), the
    // background is transparent.
    let file = std::fs::File::open(&atlas).expect("atlas");
    let mut dec = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .expect("png");
    let mut buf = vec![0; dec.output_buffer_size().expect("size")];
    let info = dec.next_frame(&mut buf).expect("data");
    assert_eq!((info.width, info.color_type), (256, png::ColorType::Rgba));
    assert_eq!(buf[3], 0, "the corner is transparent");
    for t in 0..16 {
        let (c, row) = (t % 4, t / 4);
        let opaque = (0..64)
            .flat_map(|y| (0..64).map(move |x| (x, y)))
            .filter(|&(x, y)| buf[4 * ((row * 64 + y) * 256 + c * 64 + x) + 3] == 255)
            .count();
        assert!(opaque > 200, "tile {t}: {opaque} opaque texels");
    }
    for bad in ["0", "10"] {
        let o = meshlod(&["impostor", s(&spot), "-o", s(&glb), "--views", bad]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains("square"), "{err}");
    }
}
