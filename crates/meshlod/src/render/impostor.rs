//! Impostors: pictures of an object standing in for it far away, on a textured
//! quad (the course notes' LOD chapter: "remplacer un objet polygonal par une boîte
//! englobante texturée à l'aide d'une image produite à partir d'une version
//! détaillée de l'objet"; Maciel & Shirley, "Visual navigation of large
//! environments using textured clusters", I3D 1995).
//!
//! The object is drawn by the CPU rasterizer from `g × g` directions into one
//! RGBA atlas, one square tile per direction, with alpha = the fraction of the
//! texel the object covers (each texel is `s × s` samples). The directions are
//! the centres of the atlas cells mapped onto the sphere by the octahedral map
//! (Cigolle et al., "A Survey of Efficient Representations for Independent Unit
//! Vectors", JCGT 2014; as octahedral impostors use it): the cell centre
//! `(u, v) ∈ [−1, 1]²` (u right, v up) gives `p = (u, v, 1 − |u| − |v|)`, folded
//! to `((1 − |v|) sgn u, (1 − |u|) sgn v, p.z)` where `p.z < 0`, normalised: the
//! atlas centre looks at the object's front (+z), its corners at its back. Every
//! tile frames the bounding sphere the same way (the sphere's diameter is the
//! tile's side), so a runtime picks the tile of the eye direction
//! ([`octahedral_cell`]) and draws it on a camera-facing quad of that size.
//! `g = 1` is a single front view.

use super::camera::{Camera, View};
use super::raster::{self, Shade, Textured};
use super::{vertex_normals, RenderError, Shading, Texture, MAX_SIZE};
use crate::mesh::Mesh;
use rayon::prelude::*;
use std::io::Write;

/// How to build an impostor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpostorOptions {
    /// Tiles per side of the atlas: `grid²` views. Default 8 (64 views).
    pub grid: u32,
    /// Side of the atlas in pixels (each tile is `size / grid`). Default 1024.
    pub size: u32,
    /// Samples per texel side for the alpha coverage (`samples²` per texel).
    /// Default 4.
    pub samples: u32,
    /// Flat or smooth shading of the pictures. Default smooth.
    pub shading: Shading,
}

impl Default for ImpostorOptions {
    fn default() -> Self {
        Self {
            grid: 8,
            size: 1024,
            samples: 4,
            shading: Shading::Smooth,
        }
    }
}

/// An 8-bit RGBA picture (straight alpha), row-major, top row first.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RgbaImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` pixels.
    pub pixels: Vec<[u8; 4]>,
}

impl RgbaImage {
    /// Encodes the picture as an 8-bit RGBA PNG into `out`.
    ///
    /// # Errors
    /// [`RenderError::Png`] when encoding or writing fails.
    pub fn encode_png<W: Write>(&self, out: W) -> Result<(), RenderError> {
        let mut enc = png::Encoder::new(out, self.width, self.height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header()?;
        w.write_image_data(self.pixels.as_flattened())?;
        w.finish()?;
        Ok(())
    }
}

/// An impostor: the atlas and where its views are.
#[derive(Debug, Clone, PartialEq)]
pub struct Impostor {
    /// The atlas: `grid × grid` tiles of `tile` pixels.
    pub atlas: RgbaImage,
    /// Tiles per side.
    pub grid: u32,
    /// Tile side in pixels.
    pub tile: u32,
    /// Centre of the bounding sphere every tile frames (mesh units).
    pub center: [f64; 3],
    /// Its radius (mesh units): a tile's side is `2 × radius`.
    pub radius: f64,
    /// Per tile, row by row from the top, the unit direction from the centre
    /// towards the eye.
    pub directions: Vec<[f64; 3]>,
}

/// The unit direction (from the object towards the eye) of cell `(col, row)` of a
/// `grid × grid` octahedral atlas (row 0 at the top).
#[must_use]
pub fn octahedral_direction(col: u32, row: u32, grid: u32) -> [f64; 3] {
    let g = f64::from(grid.max(1));
    let u = 2.0 * (f64::from(col) + 0.5) / g - 1.0;
    let v = 1.0 - 2.0 * (f64::from(row) + 0.5) / g;
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum())
    } else {
        (u, v)
    };
    let l = (x * x + y * y + z * z).sqrt();
    [x / l, y / l, z / l]
}

/// The cell `(col, row)` of a `grid × grid` octahedral atlas whose region holds the
/// direction `d` (from the object towards the eye; need not be unit length, not
/// zero): the inverse of [`octahedral_direction`] up to the cell.
#[must_use]
pub fn octahedral_cell(d: [f64; 3], grid: u32) -> (u32, u32) {
    let n = d[0].abs() + d[1].abs() + d[2].abs();
    let (mut u, mut v) = (d[0] / n, d[1] / n);
    if d[2] < 0.0 {
        let (au, av) = (u.abs(), v.abs());
        u = (1.0 - av) * if u < 0.0 { -1.0 } else { 1.0 };
        v = (1.0 - au) * if v < 0.0 { -1.0 } else { 1.0 };
    }
    let g = f64::from(grid.max(1));
    let cell = |t: f64| ((t * g).floor().max(0.0) as u32).min(grid.max(1) - 1);
    (cell(0.5 * (u + 1.0)), cell(0.5 * (1.0 - v)))
}

/// The camera of a tile: looking along `-eye` at `center`, the sphere of `radius`
/// filling a `pixels`-wide square.
fn tile_camera(eye: [f64; 3], center: [f64; 3], radius: f64, pixels: usize) -> Camera {
    let axes = View::Direction(eye.map(|c| -c)).axes();
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let half = 0.5 * pixels as f64;
    Camera {
        axes,
        center: std::array::from_fn(|a| dot(center, axes[a])),
        scale: if radius > 0.0 { half / radius } else { 1.0 },
        pixel_center: [half, half],
    }
}

/// Builds the impostor of `mesh` (with base-colour `textures` by group, as
/// [`super::Canvas::draw_with`] takes them).
///
/// # Errors
/// [`RenderError::Size`] when the grid is 0, the size is outside
/// 1..=[`MAX_SIZE`] or smaller than the grid, or a tile's samples exceed
/// [`MAX_SIZE`]; [`RenderError::Mesh`] for a malformed mesh.
pub fn build_impostor(
    mesh: &Mesh,
    textures: &[Option<Texture>],
    opts: &ImpostorOptions,
) -> Result<Impostor, RenderError> {
    let (g, size, ss) = (opts.grid, opts.size, opts.samples.max(1));
    let tile = size.checked_div(g).unwrap_or(0);
    if g == 0 || !(1..=MAX_SIZE).contains(&size) || tile == 0 || tile * ss > MAX_SIZE {
        return Err(RenderError::Size {
            width: size,
            height: size,
        });
    }
    mesh.validate()?;
    let (lo, hi) = super::frame_of(Some(mesh));
    let center: [f64; 3] = std::array::from_fn(|k| 0.5 * (f64::from(lo[k]) + f64::from(hi[k])));
    let radius = 0.5
        * (0..3)
            .map(|k| (f64::from(hi[k]) - f64::from(lo[k])).powi(2))
            .sum::<f64>()
            .sqrt();
    let computed;
    let normals = match (opts.shading, &mesh.attributes.normals) {
        (Shading::Flat, _) => None,
        (Shading::Smooth, Some(n)) => Some(n.as_slice()),
        (Shading::Smooth, None) => {
            computed = vertex_normals(mesh);
            Some(computed.as_slice())
        }
    };
    let side = (g * tile) as usize;
    let mut atlas = RgbaImage {
        width: g * tile,
        height: g * tile,
        pixels: vec![[0; 4]; side * side],
    };
    let mut directions = Vec::with_capacity((g * g) as usize);
    let n = (tile * ss) as usize;
    for row in 0..g {
        for col in 0..g {
            let eye = octahedral_direction(col, row, g);
            directions.push(eye);
            let cam = tile_camera(eye, center, radius, n);
            let proj: Vec<[f32; 3]> = mesh.positions.par_iter().map(|&p| cam.project(p)).collect();
            let mut buf = raster::Buffers::new(n, n);
            raster::depth_pass(&mesh.triangles, &proj, &mut buf);
            let shade = Shade {
                triangles: &mesh.triangles,
                proj: &proj,
                positions: &mesh.positions,
                normals,
                heat: None,
                textures: match (&mesh.attributes.uv0, textures.iter().any(Option::is_some)) {
                    (Some(uv), true) => Some(Textured {
                        by_group: textures,
                        uv,
                        groups: mesh.groups.as_deref(),
                    }),
                    _ => None,
                },
                forward: cam.axes[2].map(|c| c as f32),
            };
            let texels = downsample(&buf, &shade, tile as usize, ss as usize);
            for (y, line) in texels.chunks(tile as usize).enumerate() {
                let at = (row as usize * tile as usize + y) * side + col as usize * tile as usize;
                atlas.pixels[at..at + line.len()].copy_from_slice(line);
            }
        }
    }
    Ok(Impostor {
        atlas,
        grid: g,
        tile,
        center,
        radius,
        directions,
    })
}

/// The `tile × tile` texels of a tile drawn at `ss` samples per texel side: alpha
/// is the covered fraction, the colour the mean of the covered samples' (the
/// tile's mean colour where nothing is covered, so filtering brings no dark rim).
fn downsample(buf: &raster::Buffers, shade: &Shade, tile: usize, ss: usize) -> Vec<[u8; 4]> {
    let n = tile * ss;
    let sums: Vec<([u32; 3], u32)> = (0..tile * tile)
        .into_par_iter()
        .map(|t| {
            let (tx, ty) = (t % tile, t / tile);
            let mut sum = [0u32; 3];
            let mut count = 0;
            for y in ty * ss..(ty + 1) * ss {
                for x in tx * ss..(tx + 1) * ss {
                    let id = buf.ids[y * n + x];
                    if id != raster::NONE {
                        let c = shade.colour(id, [x as f32 + 0.5, y as f32 + 0.5]);
                        for k in 0..3 {
                            sum[k] += u32::from(c[k]);
                        }
                        count += 1;
                    }
                }
            }
            (sum, count)
        })
        .collect();
    let (mut all, mut covered) = ([0u64; 3], 0u64);
    for (s, c) in &sums {
        for k in 0..3 {
            all[k] += u64::from(s[k]);
        }
        covered += u64::from(*c);
    }
    let mean = all.map(|v| v.checked_div(covered).unwrap_or(200) as u8);
    let full = (ss * ss) as u32;
    sums.into_iter()
        .map(|(s, c)| {
            if c == 0 {
                [mean[0], mean[1], mean[2], 0]
            } else {
                let rgb = s.map(|v| ((v + c / 2) / c) as u8);
                let a = ((255 * c + full / 2) / full) as u8;
                [rgb[0], rgb[1], rgb[2], a]
            }
        })
        .collect()
}

/// The GLB file of an impostor: one quad (two triangles) of side `2 × radius`
/// centred on the object's bounding sphere in the z = centre plane, facing +z, its
/// UVs on the tile looking most nearly from the front; the atlas as its PNG
/// base-colour texture (`alphaMode` `MASK`, unlit: the lighting is in the
/// pictures); the layout in the node's `extras.meshlod_impostor`, together with
/// `extra` (merged in).
///
/// # Errors
/// [`RenderError::Png`] when the atlas cannot be encoded.
pub fn impostor_glb(imp: &Impostor, extra: serde_json::Value) -> Result<Vec<u8>, RenderError> {
    use serde_json::json;
    let mut png = Vec::new();
    imp.atlas.encode_png(&mut png)?;
    let (c, r) = (imp.center.map(|v| v as f32), imp.radius as f32);
    let positions: [[f32; 3]; 4] = [
        [c[0] - r, c[1] - r, c[2]],
        [c[0] + r, c[1] - r, c[2]],
        [c[0] + r, c[1] + r, c[2]],
        [c[0] - r, c[1] + r, c[2]],
    ];
    let front = imp
        .directions
        .iter()
        .enumerate()
        .max_by(|a, b| a.1[2].total_cmp(&b.1[2]))
        .map_or(0, |(i, _)| i) as u32;
    let (col, row) = (front % imp.grid, front / imp.grid);
    let g = imp.grid as f32;
    let (u0, u1) = (col as f32 / g, (col + 1) as f32 / g);
    let (v0, v1) = (row as f32 / g, (row + 1) as f32 / g);
    let uvs: [[f32; 2]; 4] = [[u0, v1], [u1, v1], [u1, v0], [u0, v0]];
    let indices: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let mut bin: Vec<u8> = Vec::new();
    bin.extend(positions.iter().flatten().flat_map(|v| v.to_le_bytes()));
    let uv_at = bin.len();
    bin.extend(uvs.iter().flatten().flat_map(|v| v.to_le_bytes()));
    let idx_at = bin.len();
    bin.extend(indices.iter().flat_map(|v| v.to_le_bytes()));
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let img_at = bin.len();
    bin.extend_from_slice(&png);
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let mut layout = json!({
        "mapping": if imp.grid == 1 { "single" } else { "octahedral" },
        "grid": imp.grid,
        "views": imp.grid * imp.grid,
        "tile_px": imp.tile,
        "atlas_px": [imp.atlas.width, imp.atlas.height],
        "center": imp.center,
        "radius": imp.radius,
        "quad_side": 2.0 * imp.radius,
        "front_tile": [col, row],
        "directions": imp.directions,
        "direction_to_tile": "cell of the eye direction d (from the centre): p = d / (|x|+|y|+|z|); where z < 0, (x, y) = ((1-|y|) sgn x, (1-|x|) sgn y); col = floor((x+1)/2 grid), row = floor((1-y)/2 grid)",
        "tile_up": "up = right x forward with right = normalize(forward x Y), forward = -d, Y = +y (or -z looking straight down, +z looking straight up)",
        "alpha": "fraction of the texel the object covers",
        "lighting": "a headlight from each view's eye, baked in",
    });
    if let (Some(l), serde_json::Value::Object(e)) = (layout.as_object_mut(), extra) {
        l.extend(e);
    }
    let doc = json!({
        "asset": { "version": "2.0", "generator": "meshlod impostor" },
        "extensionsUsed": ["KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "name": "impostor", "extras": { "meshlod_impostor": layout } }],
        "meshes": [{ "name": "impostor", "primitives": [{
            "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "indices": 2, "material": 0 }] }],
        "materials": [{
            "name": "impostor",
            "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "metallicFactor": 0.0, "roughnessFactor": 1.0 },
            "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": true,
            "extensions": { "KHR_materials_unlit": {} } }],
        "textures": [{ "sampler": 0, "source": 0 }],
        "samplers": [{ "magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071 }],
        "images": [{ "bufferView": 3, "mimeType": "image/png" }],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [c[0] - r, c[1] - r, c[2]], "max": [c[0] + r, c[1] + r, c[2]] },
            { "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2" },
            { "bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR" }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": uv_at, "target": 34962 },
            { "buffer": 0, "byteOffset": uv_at, "byteLength": idx_at - uv_at, "target": 34962 },
            { "buffer": 0, "byteOffset": idx_at, "byteLength": 12, "target": 34963 },
            { "buffer": 0, "byteOffset": img_at, "byteLength": png.len() }],
        "buffers": [{ "byteLength": bin.len() }],
    });
    let mut json = serde_json::to_vec(&doc).map_err(|e| RenderError::Page(e.to_string()))?;
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octahedral_cells_round_trip() {
        assert_eq!(octahedral_direction(0, 0, 1), [0.0, 0.0, 1.0]);
        for g in 1..=12 {
            for row in 0..g {
                for col in 0..g {
                    let d = octahedral_direction(col, row, g);
                    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    assert!((l - 1.0).abs() < 1e-12);
                    assert_eq!(octahedral_cell(d, g), (col, row), "grid {g}");
                }
            }
        }
        // The back is at the corners, up at the top edge's middle.
        assert_eq!(octahedral_cell([0.0, 0.0, -1.0], 8).0 % 7, 0);
        assert_eq!(octahedral_cell([0.0, 1.0, 0.0], 9), (4, 0));
    }

    /// A unit square in the z = 0 plane seen from the front: its alpha covers the
    /// square's share of the tile (side 1 in a tile of side √2, so one half), with
    /// partial coverage only along its edges.
    #[test]
    fn alpha_is_the_covered_fraction() {
        let m = Mesh::from_triangles(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        );
        let o = ImpostorOptions {
            grid: 1,
            size: 101,
            samples: 4,
            shading: Shading::Flat,
        };
        let imp = build_impostor(&m, &[], &o).unwrap();
        assert_eq!((imp.atlas.width, imp.tile), (101, 101));
        let total: f64 = imp
            .atlas
            .pixels
            .iter()
            .map(|p| f64::from(p[3]) / 255.0)
            .sum();
        let share = total / (101.0 * 101.0);
        assert!((share - 0.5).abs() < 0.01, "covered share {share}");
        let px = |x: usize, y: usize| imp.atlas.pixels[y * 101 + x];
        assert_eq!(px(50, 50)[3], 255);
        assert_eq!(px(50, 50)[..3], [204, 209, 219]);
        assert_eq!(px(0, 0)[3], 0);
        let partial = imp
            .atlas
            .pixels
            .iter()
            .filter(|p| p[3] > 0 && p[3] < 255)
            .count();
        // Four edges of about 71 texels, at most two texels each across.
        assert!((100..=4 * 72 * 2).contains(&partial), "{partial}");
    }

    #[test]
    fn every_view_sees_a_closed_object_and_the_glb_holds_the_atlas() {
        // A tetrahedron: seen from anywhere, it covers part of its tile.
        let m = Mesh::from_triangles(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        );
        let o = ImpostorOptions {
            grid: 4,
            size: 128,
            ..ImpostorOptions::default()
        };
        let imp = build_impostor(&m, &[], &o).unwrap();
        assert_eq!(imp.directions.len(), 16);
        for t in 0..16usize {
            let (c, r) = (t % 4, t / 4);
            let covered = (0..32)
                .flat_map(|y| (0..32).map(move |x| (x, y)))
                .filter(|&(x, y)| imp.atlas.pixels[(r * 32 + y) * 128 + c * 32 + x][3] > 0)
                .count();
            assert!(covered > 50, "tile {t}: {covered} texels");
        }
        let glb = impostor_glb(&imp, serde_json::json!({"source": "tet"})).unwrap();
        assert_eq!(&glb[..4], b"glTF");
        assert_eq!(
            u32::from_le_bytes(glb[8..12].try_into().unwrap()) as usize,
            glb.len()
        );
        let jl = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
        let doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + jl]).unwrap();
        let l = &doc["nodes"][0]["extras"]["meshlod_impostor"];
        assert_eq!(l["grid"], 4);
        assert_eq!(l["source"], "tet");
        assert_eq!(doc["images"][0]["mimeType"], "image/png");
        // The embedded PNG is the atlas.
        let view = &doc["bufferViews"][3];
        let at = 20 + jl + 8 + view["byteOffset"].as_u64().unwrap() as usize;
        let len = view["byteLength"].as_u64().unwrap() as usize;
        let dec = png::Decoder::new(std::io::Cursor::new(&glb[at..at + len]));
        let mut r = dec.read_info().unwrap();
        let mut buf = vec![0; r.output_buffer_size().unwrap()];
        let info = r.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.color_type), (128, png::ColorType::Rgba));
        assert_eq!(buf.as_slice(), imp.atlas.pixels.as_flattened());
    }
}
