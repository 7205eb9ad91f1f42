//! Pictures of meshes on the CPU: an orthographic z-buffer rasterizer that writes PNG.
//!
//! - **Camera** ([`Camera`]): orthographic, framing the bounding box of the first
//!   mesh for a [`View`] (front, top, iso or any direction); every panel of a picture
//!   uses the same camera, so sizes compare.
//! - **Rasterization**: triangles are scanned over their pixel bounding box with edge
//!   functions (J. Pineda, "A parallel algorithm for polygon rasterization",
//!   SIGGRAPH 1988), barycentric weights stepped incrementally along each row, pixel
//!   centres at half-integers, a z-buffer keeping the nearest triangle. The depth pass
//!   stores only depth and triangle id; shading then runs once per covered pixel
//!   (deferred shading). Horizontal bands of the picture are rasterized in parallel
//!   (rayon), each streaming over all triangles: no per-triangle allocation, and the
//!   memory beyond the mesh is one projected position per vertex (12 bytes), vertex
//!   normals when smooth shading computes them, and the per-pixel buffers.
//! - **Shading**: a headlight (light from the eye) with a small ambient term, flat
//!   (face normals) or smooth (vertex normals, interpolated); back faces, seen from
//!   behind, are drawn in an orange tint so flipped triangles show.
//! - **Wireframe**: each triangle's edges stepped pixel by pixel (a DDA), drawn where
//!   their depth is within a small offset of the z-buffer's.
//! - **Heat map**: a scalar per vertex (the distance to a reference surface,
//!   [`heat_values`]) interpolated per pixel and coloured with viridis
//!   ([`colormap`]), with a legend bar in mesh units and percent of the reference's
//!   bounding-box diagonal.
//! - **Textures**: a base-colour [`Texture`] per material group, sampled bilinearly
//!   at the interpolated UVs, lit like the untextured surface.
//! - **Text**: captions and legend labels in an embedded 5×7 bitmap font ([`font`]).
//! - **Viewer page** ([`viewer`]): the meshes and meshlod's own WebGL script in one
//!   self-contained HTML file, drawing what this renderer draws, interactively.
//! - **Impostors** ([`impostor`]): the object drawn from octahedrally mapped
//!   directions into an RGBA atlas with alpha coverage, written as a textured GLB
//!   quad (Maciel & Shirley 1995; Cigolle et al. 2014).
//!
//! ```
//! use meshlod::render::{render, RenderOptions};
//! let mesh = meshlod::Mesh::from_triangles(
//!     vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
//!     vec![[0, 1, 2]],
//! );
//! let opts = RenderOptions { width: 64, height: 48, ..RenderOptions::default() };
//! let image = render(&[(&mesh, "tri")], &opts).unwrap();
//! assert_eq!(image.pixels.len(), 64 * 48);
//! ```

mod camera;
pub mod colormap;
pub mod font;
pub mod impostor;
mod raster;
#[cfg(test)]
mod tests;
mod texture;
pub mod viewer;

pub use camera::{Camera, View};
pub use raster::{AMBIENT, BACK, FRONT, HEAT_AMBIENT, WIRE};
pub use texture::Texture;

use crate::mesh::{Mesh, MeshError};
use crate::metrics::bvh::Bvh;
use rayon::prelude::*;
use std::io::Write;
use std::path::Path;
use thiserror::Error;

/// Largest width or height accepted, in pixels.
pub const MAX_SIZE: u32 = 16384;

/// Background colour (sRGB).
pub const BACKGROUND: [u8; 3] = [255, 255, 255];
/// Text colour (sRGB).
pub const TEXT: [u8; 3] = [30, 30, 30];

/// Which normals light the surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shading {
    /// One normal per triangle: facets show (how a simplification looks).
    #[default]
    Flat,
    /// The mesh's vertex normals (or area-weighted ones when it has none),
    /// interpolated across each triangle.
    Smooth,
}

/// How to draw a picture.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Picture width in pixels, 1 to [`MAX_SIZE`]. Default 1024.
    pub width: u32,
    /// Picture height in pixels, 1 to [`MAX_SIZE`]. Default 768.
    pub height: u32,
    /// Where the camera looks from. Default [`View::Front`].
    pub view: View,
    /// Flat or smooth shading. Default flat.
    pub shading: Shading,
    /// Overlay the triangles' edges. Default false.
    pub wireframe: bool,
    /// Lines of text in each panel's caption strip (0: no captions, the panels use
    /// the whole height). Default 1.
    pub caption_lines: usize,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            width: 1024,
            height: 768,
            view: View::Front,
            shading: Shading::Flat,
            wireframe: false,
            caption_lines: 1,
        }
    }
}

/// Errors of the renderer.
#[derive(Debug, Error)]
pub enum RenderError {
    /// Width or height is 0 or larger than [`MAX_SIZE`].
    #[error("image size {width}x{height}: width and height must be 1 to {MAX_SIZE} pixels")]
    Size {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// More panels than pixel columns, or no panel.
    #[error("{panels} panels do not fit side by side in {width} pixels")]
    Panels {
        /// Number of panels.
        panels: usize,
        /// Picture width.
        width: u32,
    },
    /// A view that is neither a name nor a direction.
    #[error("unknown view {0:?}: use front, top, iso or a direction x,y,z (not 0,0,0)")]
    View(String),
    /// The heat-map values are not one per vertex.
    #[error("{len} heat-map values for {vertices} vertices")]
    Values {
        /// Number of values.
        len: usize,
        /// Number of vertices.
        vertices: usize,
    },
    /// The mesh is malformed (an index out of range, a non-finite position).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A texture could not be decoded.
    #[error("texture: {0}")]
    Texture(String),
    /// The viewer page's header could not be made.
    #[error("HTML page: {0}")]
    Page(String),
    /// PNG encoding or writing failed.
    #[error("PNG: {0}")]
    Png(#[from] png::EncodingError),
    /// The file could not be created.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}

/// An 8-bit sRGB picture, row-major, top row first.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` pixels.
    pub pixels: Vec<[u8; 3]>,
}

impl Image {
    /// A `width × height` picture filled with `colour`.
    #[must_use]
    pub fn new(width: u32, height: u32, colour: [u8; 3]) -> Self {
        Self {
            width,
            height,
            pixels: vec![colour; width as usize * height as usize],
        }
    }

    /// The pixel at column `x`, row `y`.
    ///
    /// # Panics
    /// When `(x, y)` is outside the picture.
    #[must_use]
    pub fn get(&self, x: usize, y: usize) -> [u8; 3] {
        assert!(x < self.width as usize && y < self.height as usize);
        self.pixels[y * self.width as usize + x]
    }

    /// Sets the pixel at `(x, y)`; does nothing outside the picture.
    pub fn set(&mut self, x: usize, y: usize, colour: [u8; 3]) {
        if x < self.width as usize && y < self.height as usize {
            self.pixels[y * self.width as usize + x] = colour;
        }
    }

    /// Encodes the picture as an 8-bit RGB PNG into `out`.
    ///
    /// # Errors
    /// [`RenderError::Png`] when encoding or writing fails.
    pub fn encode_png<W: Write>(&self, out: W) -> Result<(), RenderError> {
        let mut enc = png::Encoder::new(out, self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Fast);
        let mut w = enc.write_header()?;
        w.write_image_data(self.pixels.as_flattened())?;
        w.finish()?;
        Ok(())
    }

    /// Writes the picture to the PNG file `path`.
    ///
    /// # Errors
    /// [`RenderError::Io`] when the file cannot be created, [`RenderError::Png`] when
    /// writing fails.
    pub fn write_png(&self, path: impl AsRef<Path>) -> Result<(), RenderError> {
        let path = path.as_ref();
        let file = std::fs::File::create(path).map_err(|source| RenderError::Io {
            path: path.display().to_string(),
            source,
        })?;
        self.encode_png(std::io::BufWriter::new(file))
    }
}

/// The heat-map scale shared by all panels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeatScale {
    /// The value at the top of the colour map (mesh units; values above it clamp).
    pub max: f64,
    /// The reference's bounding-box diagonal (mesh units), for the legend's percent.
    pub diagonal: f64,
}

/// Each vertex's distance to the surface in `reference` (mesh units), as `f32`:
/// the per-vertex values of a heat map. Infinite when the reference is empty.
#[must_use]
pub fn heat_values(mesh: &Mesh, reference: &Bvh) -> Vec<f32> {
    crate::metrics::vertex_distances(mesh, reference)
        .into_iter()
        .map(|d| d as f32)
        .collect()
}

/// Height of a caption line in font pixels (a glyph and two rows of spacing).
const LINE_H: usize = font::GLYPH_H + 2;

/// Where panels, captions and the legend go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Number of panels, side by side.
    pub panels: usize,
    /// Width of each panel in pixels (columns past `panels × panel_width` stay empty).
    pub panel_width: usize,
    /// Height of the drawing area of each panel, from the top of the picture.
    pub view_height: usize,
    /// Height of the caption strip below each panel's drawing area (0: no captions).
    pub caption_height: usize,
    /// Height of the legend strip at the bottom of the picture (0: none).
    pub legend_height: usize,
    /// Font pixel size in picture pixels.
    pub font_scale: usize,
}

impl Layout {
    fn new(width: usize, height: usize, panels: usize, lines: usize, legend: bool) -> Self {
        let font_scale = if height >= 360 && width / panels >= 240 {
            2
        } else {
            1
        };
        let mut caption_height = if lines == 0 {
            0
        } else {
            (2 + LINE_H * lines) * font_scale
        };
        let mut legend_height = if legend { 24 * font_scale } else { 0 };
        if height < 2 * (caption_height + legend_height) {
            caption_height = 0;
            legend_height = 0;
        }
        Self {
            panels,
            panel_width: width / panels,
            view_height: height - caption_height - legend_height,
            caption_height,
            legend_height,
            font_scale,
        }
    }
}

/// What drawing one panel found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PanelStats {
    /// Triangles in the mesh.
    pub triangles: usize,
    /// Pixels the mesh covers.
    pub covered_pixels: usize,
}

/// A picture being drawn panel by panel, so the meshes need not all be in memory at
/// once: [`Canvas::new`], [`Canvas::draw`] for each panel, then [`Canvas::finish`].
#[derive(Debug, Clone)]
pub struct Canvas {
    opts: RenderOptions,
    image: Image,
    camera: Camera,
    layout: Layout,
    heat: Option<HeatScale>,
}

impl Canvas {
    /// A blank picture of `panels` panels side by side, whose camera frames the box
    /// `frame = (lo, hi)` (mesh units; usually the first mesh's bounding box) in each
    /// panel, with a heat-map legend when `heat` is given.
    ///
    /// # Errors
    /// [`RenderError::Size`] for a width or height outside 1..=[`MAX_SIZE`],
    /// [`RenderError::Panels`] when `panels` is 0 or more than the width.
    pub fn new(
        opts: &RenderOptions,
        panels: usize,
        frame: ([f32; 3], [f32; 3]),
        heat: Option<HeatScale>,
    ) -> Result<Self, RenderError> {
        let (width, height) = (opts.width, opts.height);
        if !(1..=MAX_SIZE).contains(&width) || !(1..=MAX_SIZE).contains(&height) {
            return Err(RenderError::Size { width, height });
        }
        if panels == 0 || panels > width as usize {
            return Err(RenderError::Panels { panels, width });
        }
        let layout = Layout::new(
            width as usize,
            height as usize,
            panels,
            opts.caption_lines,
            heat.is_some(),
        );
        let camera = Camera::frame(
            &opts.view,
            frame.0,
            frame.1,
            layout.panel_width,
            layout.view_height,
        );
        Ok(Self {
            opts: opts.clone(),
            image: Image::new(width, height, BACKGROUND),
            camera,
            layout,
            heat,
        })
    }

    /// The layout of the picture.
    #[must_use]
    pub fn layout(&self) -> Layout {
        self.layout
    }

    /// The camera every panel uses (pixel positions relative to a panel's corner).
    #[must_use]
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Draws `mesh` into panel `panel` (0 is leftmost), coloured by `values` (one per
    /// vertex, mesh units) when the canvas has a heat scale, with the caption
    /// `"{label}  {n} triangles"` under it.
    ///
    /// # Errors
    /// [`RenderError::Panels`] for a panel out of range, [`RenderError::Values`] when
    /// `values` is not one per vertex, [`RenderError::Mesh`] for a malformed mesh.
    pub fn draw(
        &mut self,
        panel: usize,
        mesh: &Mesh,
        values: Option<&[f32]>,
        label: &str,
    ) -> Result<PanelStats, RenderError> {
        self.draw_with(panel, mesh, values, &[], label)
    }

    /// As [`Canvas::draw`], with base-colour textures: `textures[g]` colours the
    /// front faces of group (material) `g` when the mesh has UVs
    /// ([`crate::mesh::VertexAttributes::uv0`]); groups without one, or every group
    /// when the mesh has no UVs, stay plain. A heat map takes precedence.
    ///
    /// # Errors
    /// As [`Canvas::draw`].
    pub fn draw_with(
        &mut self,
        panel: usize,
        mesh: &Mesh,
        values: Option<&[f32]>,
        textures: &[Option<Texture>],
        label: &str,
    ) -> Result<PanelStats, RenderError> {
        let caption = format!("{label}  {} triangles", mesh.triangle_count());
        self.draw_captioned(panel, mesh, values, textures, &[caption])
    }

    /// As [`Canvas::draw_with`], with the caption's lines given: one per line of
    /// [`RenderOptions::caption_lines`] (extra lines are not drawn), each centred
    /// and cut at the left with `...` when too wide.
    ///
    /// # Errors
    /// As [`Canvas::draw`].
    pub fn draw_captioned(
        &mut self,
        panel: usize,
        mesh: &Mesh,
        values: Option<&[f32]>,
        textures: &[Option<Texture>],
        caption: &[String],
    ) -> Result<PanelStats, RenderError> {
        if panel >= self.layout.panels {
            return Err(RenderError::Panels {
                panels: panel + 1,
                width: self.opts.width,
            });
        }
        if let Some(v) = values {
            if v.len() != mesh.vertex_count() {
                return Err(RenderError::Values {
                    len: v.len(),
                    vertices: mesh.vertex_count(),
                });
            }
        }
        mesh.validate()?;
        let (pw, ph) = (self.layout.panel_width, self.layout.view_height);
        let cam = self.camera;
        let proj: Vec<[f32; 3]> = mesh.positions.par_iter().map(|&p| cam.project(p)).collect();
        let mut buf = raster::Buffers::new(pw, ph);
        raster::depth_pass(&mesh.triangles, &proj, &mut buf);
        if self.opts.wireframe {
            // 1.5 pixels of depth at 45°, plus a little of the box's depth.
            let offset = (1.5 / cam.scale) as f32;
            raster::wire_pass(&mesh.triangles, &proj, &mut buf, offset);
        }
        let computed;
        let normals = match (self.opts.shading, &mesh.attributes.normals) {
            (Shading::Flat, _) => None,
            (Shading::Smooth, Some(n)) => Some(n.as_slice()),
            (Shading::Smooth, None) => {
                computed = vertex_normals(mesh);
                Some(computed.as_slice())
            }
        };
        let heat = match (self.heat, values) {
            (Some(h), Some(v)) => Some((v, h.max as f32)),
            _ => None,
        };
        let fwd = cam.axes[2].map(|c| c as f32);
        let shade = raster::Shade {
            triangles: &mesh.triangles,
            proj: &proj,
            positions: &mesh.positions,
            normals,
            heat,
            textures: match (&mesh.attributes.uv0, textures.iter().any(Option::is_some)) {
                (Some(uv), true) => Some(raster::Textured {
                    by_group: textures,
                    uv,
                    groups: mesh.groups.as_deref(),
                }),
                _ => None,
            },
            forward: fwd,
        };
        let covered = self.compose(panel, &buf, &shade);
        for (line, text) in caption.iter().take(self.opts.caption_lines).enumerate() {
            self.caption(panel, line, text);
        }
        Ok(PanelStats {
            triangles: mesh.triangle_count(),
            covered_pixels: covered,
        })
    }

    /// Shades the covered pixels of `buf` into panel `panel`; returns their number.
    fn compose(&mut self, panel: usize, buf: &raster::Buffers, shade: &raster::Shade) -> usize {
        let (pw, ph) = (buf.width, buf.height);
        let x0 = panel * pw;
        let width = self.image.width as usize;
        self.image
            .pixels
            .par_chunks_mut(width)
            .take(ph)
            .enumerate()
            .map(|(y, row)| {
                let mut n = 0;
                for x in 0..pw {
                    let i = y * pw + x;
                    let t = buf.ids[i];
                    if buf.wire[i] {
                        row[x0 + x] = WIRE;
                    } else if t != raster::NONE {
                        row[x0 + x] = shade.colour(t, [x as f32 + 0.5, y as f32 + 0.5]);
                    }
                    n += usize::from(t != raster::NONE);
                }
                n
            })
            .sum()
    }

    /// Writes `text` centred on line `line` of panel `panel`'s caption strip, cut at
    /// the left with `...` when it is too wide.
    fn caption(&mut self, panel: usize, line: usize, text: &str) {
        let l = self.layout;
        if l.caption_height == 0 {
            return;
        }
        let text = fit_text(text, l.panel_width.saturating_sub(4), l.font_scale);
        let tw = font::text_width(&text, l.font_scale);
        let x = panel * l.panel_width + (l.panel_width.saturating_sub(tw)) / 2;
        let y = l.view_height + (2 + LINE_H * line) * l.font_scale;
        font::draw_text(&mut self.image, x, y, &text, l.font_scale, TEXT);
    }

    /// Draws the legend (when there is a heat scale) and returns the picture.
    #[must_use]
    pub fn finish(mut self) -> Image {
        if let Some(h) = self.heat {
            self.legend(h);
        }
        self.image
    }

    /// The heat-map legend: a viridis bar across the middle half of the picture,
    /// `0` under its left end, the maximum under its right end, and a title line.
    fn legend(&mut self, h: HeatScale) {
        let l = self.layout;
        if l.legend_height == 0 {
            return;
        }
        let s = l.font_scale;
        let width = self.image.width as usize;
        let y0 = l.view_height + l.caption_height + 2 * s;
        let (bx0, bx1) = (width / 4, width - width / 4);
        let bar_h = 5 * s;
        for x in bx0..bx1 {
            let t = (x - bx0) as f32 / (bx1 - bx0).max(2).saturating_sub(1) as f32;
            let c = colormap::viridis(t).map(|v| (v * 255.0).round() as u8);
            for y in y0..y0 + bar_h {
                self.image.set(x, y, c);
            }
        }
        let ty = y0 + bar_h + 2 * s;
        font::draw_text(&mut self.image, bx0, ty, "0", s, TEXT);
        let pct = if h.diagonal > 0.0 {
            format!(" ({}% of diag)", sig3(100.0 * h.max / h.diagonal))
        } else {
            String::new()
        };
        let right = format!("{}{pct}", sig3(h.max));
        let rw = font::text_width(&right, s);
        font::draw_text(&mut self.image, bx1.saturating_sub(rw), ty, &right, s, TEXT);
        let title = "distance to reference (mesh units)";
        let tw = font::text_width(title, s);
        if tw + 8 * s < bx0 {
            font::draw_text(&mut self.image, (bx0 - tw) / 2, y0, title, s, TEXT);
        }
    }
}

/// `text` shortened from the left (with a leading `...`) to fit `width` pixels.
fn fit_text(text: &str, width: usize, scale: usize) -> String {
    let chars: Vec<char> = text.chars().collect();
    let max = (width / scale + 1) / (font::GLYPH_W + 1);
    if chars.len() <= max {
        return text.to_string();
    }
    let keep = max.saturating_sub(3);
    let mut s = String::from(&"..."[..max.min(3)]);
    s.extend(&chars[chars.len() - keep..]);
    s
}

/// `v` with three significant digits, in plain or scientific notation.
#[must_use]
pub fn sig3(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let e = v.abs().log10().floor() as i32;
    if (-4..6).contains(&e) {
        let decimals = (2 - e).max(0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.2e}")
    }
}

/// Area-weighted vertex normals (unit, or zero for vertices on no triangle).
#[must_use]
pub fn vertex_normals(mesh: &Mesh) -> Vec<[f32; 3]> {
    let mut n = vec![[0.0f32; 3]; mesh.vertex_count()];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let f = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        for &i in t {
            for k in 0..3 {
                n[i as usize][k] += f[k];
            }
        }
    }
    n.par_iter_mut().for_each(|v| {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if l > 0.0 && l.is_finite() {
            *v = v.map(|c| c / l);
        } else {
            *v = [0.0; 3];
        }
    });
    n
}

/// Renders `meshes` (each with its caption label) side by side, framed on the first
/// mesh's bounding box.
///
/// # Errors
/// As [`Canvas::new`] and [`Canvas::draw`].
pub fn render(meshes: &[(&Mesh, &str)], opts: &RenderOptions) -> Result<Image, RenderError> {
    let frame = frame_of(meshes.first().map(|m| m.0));
    let mut canvas = Canvas::new(opts, meshes.len(), frame, None)?;
    for (i, (m, label)) in meshes.iter().enumerate() {
        canvas.draw(i, m, None, label)?;
    }
    Ok(canvas.finish())
}

/// Renders `meshes` side by side as [`render`] does, each coloured by its vertices'
/// distances to `reference` on one scale (0 to the largest distance over all
/// meshes). Returns the picture and the scale.
///
/// # Errors
/// As [`Canvas::new`] and [`Canvas::draw`].
pub fn render_heatmap(
    meshes: &[(&Mesh, &str)],
    reference: &Mesh,
    opts: &RenderOptions,
) -> Result<(Image, HeatScale), RenderError> {
    let bvh = Bvh::build(&reference.positions, &reference.triangles);
    let values: Vec<Vec<f32>> = meshes.iter().map(|(m, _)| heat_values(m, &bvh)).collect();
    let max = values
        .iter()
        .flatten()
        .filter(|v| v.is_finite())
        .fold(0.0f32, |a, &b| a.max(b));
    let scale = HeatScale {
        max: f64::from(max),
        diagonal: reference.bbox_diagonal(),
    };
    let frame = frame_of(meshes.first().map(|m| m.0));
    let mut canvas = Canvas::new(opts, meshes.len(), frame, Some(scale))?;
    for (i, ((m, label), v)) in meshes.iter().zip(&values).enumerate() {
        canvas.draw(i, m, Some(v), label)?;
    }
    Ok((canvas.finish(), scale))
}

/// The box a picture frames: `mesh`'s referenced vertices' bounding box, or the unit
/// cube when there is no mesh or it is empty.
#[must_use]
pub fn frame_of(mesh: Option<&Mesh>) -> ([f32; 3], [f32; 3]) {
    mesh.and_then(|m| m.bounding_box(true))
        .unwrap_or(([0.0; 3], [1.0; 3]))
}
