//! Pixel tests on tiny hand-built meshes: where the surface is, its shade, depth
//! order, wireframe, back faces, the heat map's colours, panels and captions.

use super::*;
use proptest::prelude::*;

/// One triangle in the z = 0 plane, counter-clockwise seen from +z (the front view):
///
/// ```text
///  y
///  1 c
///    | \
///  0 a--b  x
///    0  1
/// ```
fn triangle() -> Mesh {
    Mesh::from_triangles(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    )
}

fn opts(width: u32, height: u32) -> RenderOptions {
    RenderOptions {
        width,
        height,
        ..RenderOptions::default()
    }
}

/// The pixel (column, row) that point `p` lands in, in panel `panel`.
fn pixel_of(canvas: &Canvas, panel: usize, p: [f32; 3]) -> (usize, usize) {
    let q = canvas.camera().project(p);
    (
        panel * canvas.layout().panel_width + q[0].floor() as usize,
        q[1].floor() as usize,
    )
}

/// `colour` lit head-on (the full headlight): itself, in bytes.
fn lit(colour: [f32; 3]) -> [u8; 3] {
    colour.map(|c| (c * 255.0).round() as u8)
}

fn draw_one(mesh: &Mesh, o: &RenderOptions) -> (Canvas, Image) {
    let mut c = Canvas::new(o, 1, frame_of(Some(mesh)), None).unwrap();
    c.draw(0, mesh, None, "t").unwrap();
    let img = c.clone().finish();
    (c, img)
}

#[test]
fn triangle_inside_is_shaded_and_outside_is_background() {
    let (c, img) = draw_one(&triangle(), &opts(80, 60));
    let (x, y) = pixel_of(&c, 0, [0.25, 0.25, 0.0]);
    assert_eq!(
        img.get(x, y),
        lit(FRONT),
        "facing the headlight: full brightness"
    );
    // The empty half of the box and the picture's corner.
    let (x, y) = pixel_of(&c, 0, [0.8, 0.8, 0.0]);
    assert_eq!(img.get(x, y), BACKGROUND);
    assert_eq!(img.get(0, 0), BACKGROUND);
    // The box fills 90% of the tighter side, centred.
    let (xa, _) = pixel_of(&c, 0, [0.0, 0.0, 0.0]);
    let (xb, _) = pixel_of(&c, 0, [1.0, 0.0, 0.0]);
    let side = xb - xa;
    let vh = c.layout().view_height as f32;
    assert!(
        (side as f32 - 0.9 * vh).abs() <= 1.5,
        "side {side} px, view {vh} px"
    );
}

#[test]
fn flipped_triangle_shows_the_back_tint() {
    let mut m = triangle();
    m.triangles[0] = [0, 2, 1];
    let (c, img) = draw_one(&m, &opts(80, 60));
    let (x, y) = pixel_of(&c, 0, [0.25, 0.25, 0.0]);
    assert_eq!(img.get(x, y), lit(BACK));
}

#[test]
fn tilted_triangle_is_darker() {
    // Rotated 60° about x: the headlight meets it at cos 60° = 0.5.
    let (s, co) = (60f32.to_radians().sin(), 60f32.to_radians().cos());
    let m = Mesh::from_triangles(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, co, s]],
        vec![[0, 1, 2]],
    );
    let (c, img) = draw_one(&m, &opts(80, 60));
    let (x, y) = pixel_of(&c, 0, [0.25, 0.1, 0.2]);
    let k = AMBIENT + (1.0 - AMBIENT) * 0.5;
    let want = FRONT.map(|v| (v * k * 255.0).round() as i32);
    let got = img.get(x, y).map(i32::from);
    for i in 0..3 {
        assert!((got[i] - want[i]).abs() <= 1, "{got:?} vs {want:?}");
    }
}

/// Two overlapping squares: a flipped (back-tinted) one at z = 1, nearer the front
/// camera, and a front-facing one at z = 0, in both orders.
#[test]
fn nearer_triangle_hides_farther_one() {
    let quad = |z: f32, flip: bool| {
        let p = vec![[0.0, 0.0, z], [1.0, 0.0, z], [1.0, 1.0, z], [0.0, 1.0, z]];
        let t = if flip {
            vec![[0, 2, 1], [0, 3, 2]]
        } else {
            vec![[0, 1, 2], [0, 2, 3]]
        };
        Mesh::from_triangles(p, t)
    };
    for near_first in [true, false] {
        let (mut a, b) = (quad(1.0, true), quad(0.0, false));
        let mut m = if near_first { a.clone() } else { b.clone() };
        let other = if near_first { &b } else { &mut a };
        m.append(other, 0);
        let (c, img) = draw_one(&m, &opts(80, 60));
        let (x, y) = pixel_of(&c, 0, [0.5, 0.3, 1.0]);
        assert_eq!(img.get(x, y), lit(BACK), "near_first {near_first}");
    }
}

#[test]
fn wireframe_marks_edges_not_interiors() {
    let o = RenderOptions {
        wireframe: true,
        ..opts(80, 60)
    };
    let (c, img) = draw_one(&triangle(), &o);
    // The bottom edge a–b at mid length, and the diagonal b–c.
    for p in [[0.5, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 0.5, 0.0]] {
        let (x, y) = pixel_of(&c, 0, p);
        let near = (0..3)
            .flat_map(|dy| (0..3).map(move |dx| (x + dx - 1, y + dy - 1)))
            .any(|(x, y)| img.get(x, y) == WIRE);
        assert!(near, "no wire pixel near {p:?}");
    }
    let (x, y) = pixel_of(&c, 0, [0.25, 0.25, 0.0]);
    assert_eq!(img.get(x, y), lit(FRONT));
    // Without the flag, no wire pixel anywhere.
    let (_, plain) = draw_one(&triangle(), &opts(80, 60));
    assert!(!plain.pixels.contains(&WIRE));
}

#[test]
fn hidden_wireframe_edges_stay_hidden() {
    // A small square at z = 0 behind a large one at z = 1: the small one's edges
    // are behind the large surface and must not show.
    let mut m = Mesh::from_triangles(
        vec![
            [-1.0, -1.0, 1.0],
            [2.0, -1.0, 1.0],
            [2.0, 2.0, 1.0],
            [-1.0, 2.0, 1.0],
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let small = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    m.append(&small, 0);
    let o = RenderOptions {
        wireframe: true,
        ..opts(120, 90)
    };
    let (c, img) = draw_one(&m, &o);
    let (x, y) = pixel_of(&c, 0, [0.5, 0.0, 0.0]);
    assert_eq!(img.get(x, y + 1), lit(FRONT));
    assert_eq!(img.get(x, y.saturating_sub(1)), lit(FRONT));
}

/// Index of the viridis sample (of 256) whose direction best matches `rgb` (the
/// colour may be darkened by shading, so the best scale of each sample is tried).
fn viridis_index(rgb: [u8; 3]) -> usize {
    let v = rgb.map(f32::from);
    (0..256)
        .map(|i| {
            let c = colormap::viridis(i as f32 / 255.0).map(|x| x * 255.0);
            let k = (v[0] * c[0] + v[1] * c[1] + v[2] * c[2])
                / (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
            let r: f32 = (0..3).map(|j| (v[j] - k * c[j]).powi(2)).sum();
            (i, r)
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap()
        .0
}

/// A flat `n × n` grid of unit cells in the z = 0 plane.
fn grid(n: u32) -> Mesh {
    let mut p = Vec::new();
    let mut t = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            p.push([i as f32, j as f32, 0.0]);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            t.push([a, a + 1, a + n + 2]);
            t.push([a, a + n + 2, a + n + 1]);
        }
    }
    Mesh::from_triangles(p, t)
}

#[test]
fn heat_map_colours_follow_distances() {
    let flat = grid(8);
    let mut bumped = flat.clone();
    let v = 2 * 9 + 2; // the vertex at (2, 2)
    bumped.positions[v as usize][2] = 1.0;
    let (img, scale) = render_heatmap(&[(&bumped, "b")], &flat, &opts(200, 150)).unwrap();
    assert!((scale.max - 1.0).abs() < 1e-6, "max {}", scale.max);
    let canvas = Canvas::new(&opts(200, 150), 1, frame_of(Some(&bumped)), Some(scale)).unwrap();
    let at = |p: [f32; 3]| {
        let (x, y) = pixel_of(&canvas, 0, p);
        viridis_index(img.get(x, y))
    };
    let peak = at([2.0, 2.0, 1.0]);
    let slope = at([2.6, 2.0, 0.4]);
    let far = at([6.5, 6.5, 0.0]);
    assert!(peak > 200, "near the raised vertex: index {peak}");
    assert!(slope > far && slope < peak, "{far} < {slope} < {peak}");
    assert!(far < 10, "far from it: index {far}");
    // The legend: the bar's two ends are viridis' ends.
    let l = canvas.layout();
    assert!(l.legend_height > 0);
    let y = l.view_height + l.caption_height + 2 * l.font_scale + 1;
    assert!(viridis_index(img.get(200 / 4 + 1, y)) < 5);
    assert!(viridis_index(img.get(200 - 200 / 4 - 2, y)) > 250);
}

#[test]
fn side_by_side_panels_split_the_width_and_carry_captions() {
    let a = triangle();
    let mut b = triangle();
    b.triangles[0] = [0, 2, 1];
    let o = opts(240, 120);
    let img = render(&[(&a, "a.obj"), (&b, "b.obj")], &o).unwrap();
    let c = Canvas::new(&o, 2, frame_of(Some(&a)), None).unwrap();
    let l = c.layout();
    assert_eq!(l.panel_width, 120);
    let (x0, y0) = pixel_of(&c, 0, [0.25, 0.25, 0.0]);
    let (x1, y1) = pixel_of(&c, 1, [0.25, 0.25, 0.0]);
    assert_eq!(x1 - x0, 120);
    assert_eq!(img.get(x0, y0), lit(FRONT));
    assert_eq!(img.get(x1, y1), lit(BACK));
    for panel in 0..2 {
        let ink = (l.view_height..l.view_height + l.caption_height)
            .flat_map(|y| (panel * 120..(panel + 1) * 120).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get(x, y) == TEXT)
            .count();
        assert!(ink > 20, "panel {panel}: {ink} caption pixels");
    }
}

#[test]
fn smooth_shading_interpolates_normals() {
    // A flat quad whose vertex normals lean left on one side and right on the
    // other: flat shading is uniform, smooth shading varies across.
    let mut m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let s = std::f32::consts::FRAC_1_SQRT_2;
    m.attributes.normals = Some(vec![
        [-s, 0.0, s],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
        [-s, 0.0, s],
    ]);
    let o = RenderOptions {
        shading: Shading::Smooth,
        ..opts(80, 60)
    };
    let (c, img) = draw_one(&m, &o);
    let (xl, y) = pixel_of(&c, 0, [0.05, 0.5, 0.0]);
    let (xr, _) = pixel_of(&c, 0, [0.95, 0.5, 0.0]);
    assert!(img.get(xl, y)[0] < img.get(xr, y)[0]);
    let (_, flat) = draw_one(&m, &opts(80, 60));
    assert_eq!(flat.get(xl, y), flat.get(xr, y));
}

#[test]
fn bad_sizes_views_and_values_are_refused() {
    let m = triangle();
    for (w, h) in [(0, 10), (10, 0), (MAX_SIZE + 1, 10)] {
        assert!(matches!(
            render(&[(&m, "t")], &opts(w, h)),
            Err(RenderError::Size { .. })
        ));
    }
    assert!(matches!(
        render(&[(&m, "a"), (&m, "b"), (&m, "c")], &opts(2, 10)),
        Err(RenderError::Panels { .. })
    ));
    for bad in ["side", "1,2", "0,0,0", "1,x,2", "nan,1,1"] {
        assert!(bad.parse::<View>().is_err(), "{bad}");
    }
    assert_eq!("ISO".parse::<View>().unwrap(), View::Iso);
    assert_eq!(
        "0,0,-2".parse::<View>().unwrap().forward(),
        View::Front.forward()
    );
    let mut c = Canvas::new(&opts(10, 10), 1, frame_of(Some(&m)), None).unwrap();
    assert!(matches!(
        c.draw(0, &m, Some(&[0.0]), "t"),
        Err(RenderError::Values { .. })
    ));
    let mut broken = m.clone();
    broken.triangles[0][2] = 7;
    assert!(matches!(
        c.draw(0, &broken, None, "t"),
        Err(RenderError::Mesh(_))
    ));
}

#[test]
fn views_frame_the_box_from_their_side() {
    // Top: looking down −y, a triangle in the y = 0 plane is seen face-on.
    let m = Mesh::from_triangles(
        vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
        vec![[0, 1, 2]],
    );
    for view in [View::Top, View::Iso, View::Direction([0.0, -1.0, 0.0])] {
        let o = RenderOptions {
            view,
            ..opts(80, 60)
        };
        let (c, img) = draw_one(&m, &o);
        let (x, y) = pixel_of(&c, 0, [0.25, 0.0, 0.25]);
        assert_ne!(img.get(x, y), BACKGROUND, "{view}");
    }
    // The front view sees this triangle edge-on: nothing is drawn.
    let (_, img) = draw_one(&m, &opts(80, 60));
    let c = Canvas::new(&opts(80, 60), 1, frame_of(Some(&m)), None).unwrap();
    let vh = c.layout().view_height;
    assert!(img.pixels[..80 * vh].iter().all(|&p| p == BACKGROUND));
}

#[test]
fn png_round_trip() {
    let img = render(&[(&triangle(), "t")], &opts(33, 21)).unwrap();
    let mut bytes = Vec::new();
    img.encode_png(&mut bytes).unwrap();
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .unwrap();
    let mut data = vec![0; dec.output_buffer_size().unwrap()];
    let info = dec.next_frame(&mut data).unwrap();
    assert_eq!((info.width, info.height), (33, 21));
    assert_eq!(&data[..info.buffer_size()], img.pixels.as_flattened());
}

#[test]
fn fonts_and_numbers() {
    assert_eq!(font::glyph('é'), font::glyph('?'));
    assert_ne!(font::glyph('a'), font::glyph('b'));
    assert_eq!(font::text_width("ab", 2), 22);
    assert_eq!(fit_text("abcdefghij", 6 * 6, 1), "...hij");
    assert_eq!(sig3(0.012345), "0.0123");
    assert_eq!(sig3(123.456), "123");
    assert_eq!(sig3(1.5e-7), "1.50e-7");
}

fn arb_mesh() -> impl Strategy<Value = Mesh> {
    (1usize..12).prop_flat_map(|n| {
        (
            prop::collection::vec(prop::array::uniform3(-1e3f32..1e3), n),
            prop::collection::vec(prop::array::uniform3(0..n as u32), 0..20),
        )
            .prop_map(|(p, t)| Mesh::from_triangles(p, t))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn random_meshes_render(
        m in arb_mesh(),
        other in arb_mesh(),
        w in 1u32..90,
        h in 1u32..70,
        wire in any::<bool>(),
        smooth in any::<bool>(),
        dir in prop::array::uniform3(-1.0f64..1.0),
    ) {
        let view = if dir.iter().all(|&c| c == 0.0) { View::Iso } else { View::Direction(dir) };
        let o = RenderOptions {
            width: w,
            height: h,
            view,
            wireframe: wire,
            shading: if smooth { Shading::Smooth } else { Shading::Flat },
            caption_lines: 1,
        };
        let img = render(&[(&m, "m")], &o).unwrap();
        prop_assert_eq!(img.pixels.len(), (w * h) as usize);
        if w >= 2 {
            let (img, scale) = render_heatmap(&[(&m, "m"), (&other, "o")], &other, &o).unwrap();
            prop_assert!(scale.max.is_finite() && scale.max >= 0.0);
            prop_assert_eq!(img.pixels.len(), (w * h) as usize);
        }
        let cam = Camera::frame(&view, [-1e3; 3], [1e3; 3], w as usize, h as usize);
        for p in &m.positions {
            prop_assert!(cam.project(*p).iter().all(|c| c.is_finite()));
        }
    }
}

/// A PNG of `w × h` RGB texels.
fn png_bytes(w: u32, h: u32, texels: &[[u8; 3]]) -> Vec<u8> {
    let img = Image {
        width: w,
        height: h,
        pixels: texels.to_vec(),
    };
    let mut bytes = Vec::new();
    img.encode_png(&mut bytes).unwrap();
    bytes
}

/// A unit square with UVs equal to its x, y, textured with a 2×2 image whose top row
/// (v near 1) is red, green and bottom row blue, white: each quarter of the square
/// shows one texel.
#[test]
fn textures_colour_front_faces_by_uv() {
    let mut m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    m.attributes.uv0 = Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    let (r, g, b, w) = ([255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]);
    let tex = Texture::from_png(&png_bytes(2, 2, &[r, g, b, w])).unwrap();
    assert_eq!((tex.width, tex.height), (2, 2));
    let o = opts(80, 60);
    let mut c = Canvas::new(&o, 1, frame_of(Some(&m)), None).unwrap();
    c.draw_with(0, &m, None, &[Some(tex.clone())], "t").unwrap();
    let img = c.clone().finish();
    for (p, want) in [
        ([0.25, 0.75, 0.0], r),
        ([0.75, 0.75, 0.0], g),
        ([0.25, 0.25, 0.0], b),
        ([0.75, 0.25, 0.0], w),
    ] {
        let (x, y) = pixel_of(&c, 0, p);
        let got = img.get(x, y);
        for k in 0..3 {
            assert!(got[k].abs_diff(want[k]) <= 40, "{p:?}: {got:?} vs {want:?}");
        }
    }
    // Without UVs the texture is ignored.
    m.attributes.uv0 = None;
    let mut c = Canvas::new(&o, 1, frame_of(Some(&m)), None).unwrap();
    c.draw_with(0, &m, None, &[Some(tex)], "t").unwrap();
    let (x, y) = pixel_of(&c, 0, [0.25, 0.75, 0.0]);
    assert_eq!(c.finish().get(x, y), lit(FRONT));
    assert!(matches!(
        Texture::from_png(b"not a png"),
        Err(RenderError::Texture(_))
    ));
}

#[test]
fn texture_sampling_wraps_and_interpolates() {
    let tex = Texture {
        width: 2,
        height: 1,
        texels: vec![[0, 0, 0], [200, 200, 200]],
    };
    // Texel centres at u = 0.25 and 0.75; halfway between them, the mean.
    assert_eq!(tex.sample([0.25, 0.5]), [0.0; 3]);
    assert!((tex.sample([0.5, 0.5])[0] - 100.0 / 255.0).abs() < 1e-5);
    assert_eq!(tex.sample([1.25, 7.5]), tex.sample([0.25, 0.5]));
    assert!(tex.sample([f32::NAN, 0.0]).iter().all(|c| c.is_finite()));
}
