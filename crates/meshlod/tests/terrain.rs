//! Terrain: the TIN bound checked at every grid sample, the triangulation's validity,
//! crack-free tiles, and clear errors on bad height-field files.

use meshlod::terrain::heightfield::{read_height_field, HeightField};
use meshlod::terrain::tin::{build_tin, measure, Tin, TinOptions};
use meshlod::terrain::{build_tiles, build_tin_blocked, tin_to_mesh};
use proptest::prelude::*;
use std::collections::{BTreeSet, HashSet};
use std::io::Write;
use std::path::Path;

/// Options with the bound `e`, the budget `n` and the vertex-removal pass.
fn opts(e: f64, n: Option<usize>) -> TinOptions {
    TinOptions {
        max_error: e,
        max_triangles: n,
        prune: true,
    }
}

/// Twice the signed area of a triangle in grid coordinates.
fn orient(a: [u32; 2], b: [u32; 2], c: [u32; 2]) -> i64 {
    let (ax, ay) = (i64::from(a[0]), i64::from(a[1]));
    (i64::from(b[0]) - ax) * (i64::from(c[1]) - ay)
        - (i64::from(b[1]) - ay) * (i64::from(c[0]) - ax)
}

/// Checks what every TIN over the rectangle `[x0, x1] × [y0, y1]` must satisfy:
/// valid indices, distinct vertices, every triangle counter-clockwise, the triangles'
/// areas summing to the rectangle's (no overlap, no gap), and Euler's count
/// `T = 2V − B − 2` with `B` the vertices on the rectangle's border.
fn check_valid(tin: &Tin, r: [u32; 4]) {
    let [x0, y0, x1, y1] = r;
    let n = tin.points.len();
    let distinct: HashSet<[u32; 2]> = tin.points.iter().copied().collect();
    assert_eq!(distinct.len(), n, "duplicate vertices");
    let mut area = 0i64;
    for t in &tin.triangles {
        for &i in t {
            assert!((i as usize) < n, "index {i} out of range");
        }
        let [a, b, c] = t.map(|i| tin.points[i as usize]);
        let o = orient(a, b, c);
        assert!(o > 0, "triangle {t:?} is not counter-clockwise ({o})");
        area += o;
    }
    assert_eq!(area, 2 * i64::from(x1 - x0) * i64::from(y1 - y0), "areas");
    let border = tin
        .points
        .iter()
        .filter(|p| p[0] == x0 || p[0] == x1 || p[1] == y0 || p[1] == y1)
        .count();
    assert_eq!(tin.triangles.len(), 2 * n - border - 2, "Euler count");
}

/// A height field: smooth hills plus pseudo-random noise of amplitude `noise`.
fn field(w: usize, h: usize, seed: u64, noise: f32) -> Vec<f32> {
    let mut s = seed | 1;
    (0..w * h)
        .map(|i| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let r = (s % 1000) as f32 / 1000.0;
            10.0 * (0.3 * x).sin() * (0.2 * y).cos() + noise * r
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The bound holds at every sample, the TIN is valid, and the reported error is
    /// the measured one (rounded up); with and without the vertex-removal pass, which
    /// only ever removes triangles.
    #[test]
    fn bound_holds_at_every_sample(
        w in 2usize..40, h in 2usize..40, seed in any::<u64>(),
        noise in 0.0f32..8.0, e in 0.0f64..4.0,
    ) {
        let heights = field(w, h, seed, noise);
        let plain = TinOptions { prune: false, ..opts(e, None) };
        let mut counts = Vec::new();
        for o in [opts(e, None), plain] {
            let tin = build_tin(&heights, w, h, &o).unwrap();
            check_valid(&tin, [0, 0, w as u32 - 1, h as u32 - 1]);
            let dev = measure(&tin, &heights, w);
            prop_assert_eq!(dev.covered, w * h);
            prop_assert!(dev.max <= e + 1e-9, "max {} > bound {}", dev.max, e);
            prop_assert!(dev.max <= tin.max_error + 1e-9, "measured {} > reported {}", dev.max, tin.max_error);
            let hf = HeightField::from_heights(w, h, heights.clone()).unwrap();
            let mesh = tin_to_mesh(&tin, &hf);
            prop_assert_eq!(mesh.triangles.len(), tin.triangles.len());
            prop_assert_eq!(mesh.positions.len(), tin.points.len());
            counts.push(tin.triangles.len());
        }
        prop_assert!(counts[0] <= counts[1], "pruned {} > plain {}", counts[0], counts[1]);
    }

    /// A triangle budget stops the insertion as soon as it is met.
    #[test]
    fn budget_is_met(w in 8usize..40, h in 8usize..40, seed in any::<u64>(), n in 2usize..200) {
        let heights = field(w, h, seed, 5.0);
        let tin = build_tin(&heights, w, h, &opts(0.0, Some(n))).unwrap();
        check_valid(&tin, [0, 0, w as u32 - 1, h as u32 - 1]);
        // One insertion adds one triangle (a border edge split) or two.
        prop_assert!(tin.triangles.len() <= n.max(2) + 1);
        prop_assert!(tin.triangles.len() >= n || tin.max_error == 0.0);
    }
}

#[test]
fn a_spike_on_the_diagonal_splits_the_edge() {
    // 3 × 3, all 0 but the centre, 10. The first two triangles share the diagonal
    // (0,0)–(2,2); the centre lies on it, so both split in two:
    //
    //   (0,0)---(2,0)        (0,0)-----(2,0)
    //     | \     |            | \     / |
    //     |   \   |     ->     |  (1,1)  |
    //     |     \ |            | /     \ |
    //   (0,2)---(2,2)        (0,2)-----(2,2)
    let mut h = vec![0.0f32; 9];
    h[4] = 10.0;
    let tin = build_tin(&h, 3, 3, &opts(1.0, None)).unwrap();
    check_valid(&tin, [0, 0, 2, 2]);
    assert_eq!(tin.triangles.len(), 4);
    assert!(tin.points.contains(&[1, 1]));
    assert_eq!(measure(&tin, &h, 3).max, 0.0);
}

#[test]
fn a_plane_needs_two_triangles() {
    let (w, h) = (17, 9);
    let heights: Vec<f32> = (0..w * h)
        .map(|i| (2 * (i % w) + 3 * (i / w)) as f32)
        .collect();
    let tin = build_tin(&heights, w, h, &opts(0.0, None)).unwrap();
    assert_eq!(tin.triangles.len(), 2);
    assert_eq!(tin.points.len(), 4);
}

#[test]
fn output_is_deterministic() {
    let heights = field(61, 47, 7, 6.0);
    let o = opts(0.5, None);
    assert_eq!(
        build_tin(&heights, 61, 47, &o).unwrap(),
        build_tin(&heights, 61, 47, &o).unwrap()
    );
}

/// The vertices of `tin` on the line `x = c` (or `y = c` when `rows`), with the
/// border edges along it, as sorted sets.
fn on_line(tin: &Tin, c: u32, rows: bool) -> (BTreeSet<[u32; 2]>, BTreeSet<[[u32; 2]; 2]>) {
    let at = |p: [u32; 2]| if rows { p[1] == c } else { p[0] == c };
    let verts = tin.points.iter().copied().filter(|&p| at(p)).collect();
    let mut edges = BTreeSet::new();
    for t in &tin.triangles {
        for k in 0..3 {
            let (a, b) = (
                tin.points[t[k] as usize],
                tin.points[t[(k + 1) % 3] as usize],
            );
            if at(a) && at(b) {
                edges.insert(if a < b { [a, b] } else { [b, a] });
            }
        }
    }
    (verts, edges)
}

/// Reassembles tiles: each is a valid TIN of its rectangle within the bound, and the
/// two tiles beside each shared border have the same vertices and edges on it.
fn check_tiles(heights: &[f32], w: usize, h: usize, t: usize, e: f64) {
    let tiles = build_tiles(heights, w, h, t, &opts(e, None)).unwrap();
    let nx = tiles.iter().map(|t| t.x).max().unwrap() + 1;
    let ny = tiles.iter().map(|t| t.y).max().unwrap() + 1;
    assert_eq!(tiles.len(), nx * ny);
    assert_eq!(tiles.last().unwrap().region.x1 as usize, w - 1);
    assert_eq!(tiles.last().unwrap().region.y1 as usize, h - 1);
    let mut covered = 0;
    for tile in &tiles {
        let r = tile.region;
        check_valid(&tile.tin, [r.x0, r.y0, r.x1, r.y1]);
        let dev = measure(&tile.tin, heights, w);
        assert!(
            dev.max <= e + 1e-9,
            "tile {},{}: {} > {e}",
            tile.x,
            tile.y,
            dev.max
        );
        assert_eq!(
            dev.covered,
            ((r.x1 - r.x0 + 1) * (r.y1 - r.y0 + 1)) as usize
        );
        covered += dev.covered;
        if tile.x + 1 < nx {
            let right = &tiles[tile.y * nx + tile.x + 1];
            assert_eq!(right.region.x0, r.x1);
            let (a, b) = (
                on_line(&tile.tin, r.x1, false),
                on_line(&right.tin, r.x1, false),
            );
            assert_eq!(
                a, b,
                "crack between tiles ({},{}) and the right",
                tile.x, tile.y
            );
            assert!(
                a.0.len() >= 2 && a.1.len() == a.0.len() - 1,
                "border is one polyline"
            );
        }
        if tile.y + 1 < ny {
            let below = &tiles[(tile.y + 1) * nx + tile.x];
            assert_eq!(below.region.y0, r.y1);
            let (a, b) = (
                on_line(&tile.tin, r.y1, true),
                on_line(&below.tin, r.y1, true),
            );
            assert_eq!(
                a, b,
                "crack between tiles ({},{}) and the one below",
                tile.x, tile.y
            );
            assert!(
                a.0.len() >= 2 && a.1.len() == a.0.len() - 1,
                "border is one polyline"
            );
        }
    }
    // Shared rows and columns are counted by both tiles.
    assert_eq!(covered, (w + nx - 1) * (h + ny - 1));
}

#[test]
fn tiles_match_on_their_borders_and_hold_the_bound() {
    let (w, h) = (77, 58);
    let heights = field(w, h, 11, 4.0);
    check_tiles(&heights, w, h, 17, 1.0);
    check_tiles(&heights, w, h, 2, 0.5);
    check_tiles(&heights, w, h, 200, 0.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Blocks merged into one TIN: a valid triangulation of the whole grid (no
    /// duplicate vertex on the joins, areas summing to the rectangle's: no crack, no
    /// overlap) within the bound at every sample.
    #[test]
    fn blocked_tin_is_one_valid_triangulation(
        w in 2usize..60, h in 2usize..60, b in 2usize..24, seed in any::<u64>(), e in 0.0f64..3.0,
    ) {
        let heights = field(w, h, seed, 6.0);
        let tin = build_tin_blocked(&heights, w, h, b, &opts(e, None)).unwrap();
        check_valid(&tin, [0, 0, w as u32 - 1, h as u32 - 1]);
        let dev = measure(&tin, &heights, w);
        prop_assert_eq!(dev.covered, w * h);
        prop_assert!(dev.max <= e + 1e-9, "max {} > bound {}", dev.max, e);
    }

    #[test]
    fn random_tiles_have_no_cracks(
        w in 3usize..50, h in 3usize..50, t in 2usize..20, seed in any::<u64>(), e in 0.0f64..3.0,
    ) {
        check_tiles(&field(w, h, seed, 6.0), w, h, t, e);
    }
}

// ---- Readers and bad input ----

fn write(dir: &Path, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::File::create(&p).unwrap().write_all(bytes).unwrap();
    p
}

fn err_text(p: &Path) -> String {
    let e = read_height_field(p).expect_err("should be refused");
    let s = e.to_string();
    assert!(
        s.contains(&p.display().to_string()),
        "{s} does not name the file"
    );
    s
}

#[test]
fn hgt_sizes_and_voids() {
    let d = tempfile::tempdir().unwrap();
    let p = write(d.path(), "trunc.hgt", &vec![0u8; 1000]);
    assert!(err_text(&p).contains("truncated"));
    let p = write(d.path(), "short.hgt", &vec![0u8; 1201 * 1200 * 2]);
    assert!(err_text(&p).contains("2884802"));
    // All void.
    let void: Vec<u8> = std::iter::repeat_n([0x80u8, 0x00], 1201 * 1201)
        .flatten()
        .collect();
    let p = write(d.path(), "void.hgt", &void);
    assert!(err_text(&p).contains("void"));
    // A ramp with a 3 × 3 hole: filled with values within the ramp's range.
    let mut bytes = Vec::with_capacity(1201 * 1201 * 2);
    for i in 0..1201 * 1201 {
        let (x, y) = (i % 1201, i / 1201);
        let v: i16 = if (500..503).contains(&x) && (600..603).contains(&y) {
            -32768
        } else {
            (x / 10) as i16
        };
        bytes.extend_from_slice(&v.to_be_bytes());
    }
    let p = write(d.path(), "N00E000.hgt", &bytes);
    let hf = read_height_field(&p).unwrap();
    assert_eq!((hf.width, hf.height, hf.voids_filled), (1201, 1201, 9));
    for y in 600..603 {
        for x in 500..503 {
            let v = hf.heights[y * 1201 + x];
            assert!((49.0..=50.0).contains(&v), "filled {v}");
        }
    }
}

#[test]
fn asc_headers_and_bodies() {
    let d = tempfile::tempdir().unwrap();
    let good = "ncols 3\nnrows 2\nxllcorner 100\nyllcorner 200\ncellsize 30\nNODATA_value -9999\n1 2 3\n4 -9999 6\n";
    let hf = read_height_field(write(d.path(), "g.asc", good.as_bytes())).unwrap();
    assert_eq!((hf.width, hf.height, hf.cell_size), (3, 2, 30.0));
    assert_eq!(hf.voids_filled, 1);
    assert_eq!(hf.heights[..4], [1.0, 2.0, 3.0, 4.0]);
    // The void: the mean of its five valid neighbours.
    assert_eq!(hf.heights[4], (1.0 + 2.0 + 3.0 + 4.0 + 6.0) / 5.0);
    assert_eq!(hf.origin, Some([115.0, 245.0]));
    let absurd = "ncols 100000\nnrows 100000\ncellsize 1\n1 2 3\n";
    let s = err_text(&write(d.path(), "a.asc", absurd.as_bytes()));
    assert!(s.contains("header says 100000 x 100000"), "{s}");
    let s = err_text(&write(
        d.path(),
        "b.asc",
        b"ncols 3\nnrows 3\n1 2 3 4 5 6 7 8\n",
    ));
    assert!(s.contains("8 values") && s.contains("3 x 3"), "{s}");
    let s = err_text(&write(d.path(), "c.asc", b"ncols 2\nnrows 2\n1 2 3 4 5\n"));
    assert!(s.contains("more than"), "{s}");
    let s = err_text(&write(
        d.path(),
        "n.asc",
        b"ncols 2\nnrows 2\nNODATA_value 0\n0 0\n0 0\n",
    ));
    assert!(s.contains("void"), "{s}");
    let s = err_text(&write(d.path(), "t.asc", b"ncols 1\nnrows 5\n1 2 3 4 5\n"));
    assert!(s.contains("too small"), "{s}");
    let s = err_text(&write(d.path(), "x.asc", b"ncols 2\nnrows 2\n1 2 oops 4\n"));
    assert!(s.contains("line 3") && s.contains("oops"), "{s}");
    let s = err_text(&write(d.path(), "h.asc", b"ncols -2\nnrows 2\n1 2 3 4\n"));
    assert!(s.contains("not a count"), "{s}");
    let s = err_text(&write(d.path(), "u.dem", b"1 2 3"));
    assert!(s.contains("unknown height-field format"), "{s}");
    let s = err_text(&d.path().join("missing.png"));
    assert!(s.contains("missing.png"), "{s}");
}

fn png_bytes(w: u32, h: u32, color: png::ColorType, depth: png::BitDepth, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(color);
        enc.set_depth(depth);
        let mut wr = enc.write_header().unwrap();
        wr.write_image_data(data).unwrap();
    }
    out
}

/// CRC-32 (ISO-HDLC) of PNG chunks, to forge a header.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

#[test]
fn png_depths_colours_and_forged_headers() {
    let d = tempfile::tempdir().unwrap();
    // 16-bit, big-endian samples: 0, 256, 65535, 1.
    let data = [0u8, 0, 1, 0, 255, 255, 0, 1];
    let p = write(
        d.path(),
        "h16.png",
        &png_bytes(
            2,
            2,
            png::ColorType::Grayscale,
            png::BitDepth::Sixteen,
            &data,
        ),
    );
    let hf = read_height_field(&p).unwrap();
    assert_eq!(hf.heights, vec![0.0, 256.0, 65535.0, 1.0]);
    let p = write(
        d.path(),
        "h8.png",
        &png_bytes(
            2,
            2,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            &[1, 2, 3, 4],
        ),
    );
    assert_eq!(
        read_height_field(&p).unwrap().heights,
        vec![1.0, 2.0, 3.0, 4.0]
    );
    let p = write(
        d.path(),
        "rgb.png",
        &png_bytes(2, 2, png::ColorType::Rgb, png::BitDepth::Eight, &[0; 12]),
    );
    assert!(err_text(&p).contains("grey band"));
    // A 2 × 2 PNG whose header claims 1,000,000 × 1,000,000.
    let mut b = png_bytes(
        2,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[1, 2, 3, 4],
    );
    b[16..20].copy_from_slice(&1_000_000u32.to_be_bytes());
    b[20..24].copy_from_slice(&1_000_000u32.to_be_bytes());
    let crc = crc32(&b[12..29]);
    b[29..33].copy_from_slice(&crc.to_be_bytes());
    let s = err_text(&write(d.path(), "forged.png", &b));
    assert!(s.contains("1000000"), "{s}");
    let s = err_text(&write(d.path(), "junk.png", b"not a png at all"));
    assert!(s.contains("PNG"), "{s}");
    let s = err_text(&write(
        d.path(),
        "line.png",
        &png_bytes(
            5,
            1,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            &[1; 5],
        ),
    ));
    assert!(s.contains("too small"), "{s}");
}

#[test]
fn geotiff_types_nodata_and_nan() {
    use tiff::encoder::{colortype, TiffEncoder};
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("dem.tif");
    {
        let mut enc = TiffEncoder::new(std::fs::File::create(&p).unwrap()).unwrap();
        let mut img = enc.new_image::<colortype::GrayI16>(3, 2).unwrap();
        img.encoder()
            .write_tag(
                tiff::tags::Tag::ModelPixelScaleTag,
                &[30.0f64, 30.0, 0.0][..],
            )
            .unwrap();
        img.encoder()
            .write_tag(tiff::tags::Tag::GdalNodata, "-32768")
            .unwrap();
        img.write_data(&[-5i16, 0, 7, 100, -32768, 3]).unwrap();
    }
    let hf = read_height_field(&p).unwrap();
    assert_eq!(
        (hf.width, hf.height, hf.cell_size, hf.voids_filled),
        (3, 2, 30.0, 1)
    );
    assert_eq!(hf.heights[..4], [-5.0, 0.0, 7.0, 100.0]);
    let p = d.path().join("nan.tif");
    {
        let mut enc = TiffEncoder::new(std::fs::File::create(&p).unwrap()).unwrap();
        enc.write_image::<colortype::Gray32Float>(4, 4, &[f32::NAN; 16])
            .unwrap();
    }
    assert!(err_text(&p).contains("void"));
    let p = d.path().join("rgb.tif");
    {
        let mut enc = TiffEncoder::new(std::fs::File::create(&p).unwrap()).unwrap();
        enc.write_image::<colortype::RGB8>(2, 2, &[0u8; 12])
            .unwrap();
    }
    assert!(err_text(&p).contains("grey band"));
    let s = err_text(&write(d.path(), "junk.tiff", b"II*\0junk"));
    assert!(s.contains("TIFF"), "{s}");
}

#[test]
fn shared_srtm_tiles_hold_the_bound() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes/srtm");
    let path = dir.join("N57E011.hgt");
    if !path.exists() {
        eprintln!("skipping: {} is absent", path.display());
        return;
    }
    let hf = read_height_field(&path).unwrap();
    assert_eq!((hf.width, hf.height), (1201, 1201));
    for e in [1.0, 5.0] {
        let tin = build_tin(&hf.heights, 1201, 1201, &opts(e, None)).unwrap();
        check_valid(&tin, [0, 0, 1200, 1200]);
        let dev = measure(&tin, &hf.heights, 1201);
        assert_eq!(dev.covered, 1201 * 1201);
        assert!(dev.max <= e, "{} > {e}", dev.max);
        assert!(
            tin.triangles.len() < 1200 * 1200 * 2 / 4,
            "hardly simplified"
        );
    }
}
