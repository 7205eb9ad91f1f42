//! The rasterizer: a depth pass that keeps, per pixel, the nearest triangle's id and
//! depth (edge functions over the triangle's pixel bounding box, Pineda 1988), an
//! optional wireframe pass (edges stepped pixel by pixel, depth-tested with an
//! offset), and a shading pass that colours each covered pixel once (deferred
//! shading). The image is split into horizontal bands processed in parallel; every
//! band streams over all triangles, skipping those outside its rows, so nothing is
//! allocated per triangle.

use super::colormap::viridis;
use super::texture::Texture;
use rayon::prelude::*;

/// Id of a pixel no triangle covers.
pub const NONE: u32 = u32::MAX;

/// The per-pixel buffers of one panel, `width × height`, row-major.
pub struct Buffers {
    /// Panel width in pixels.
    pub width: usize,
    /// Panel height in pixels.
    pub height: usize,
    /// Depth of the nearest surface (mesh units along the view; `+∞` for none).
    pub depth: Vec<f32>,
    /// Id of the nearest triangle, or [`NONE`].
    pub ids: Vec<u32>,
    /// Whether a visible wireframe edge passes through the pixel.
    pub wire: Vec<bool>,
}

impl Buffers {
    /// Cleared buffers for a `width × height` panel.
    pub fn new(width: usize, height: usize) -> Self {
        let n = width * height;
        Self {
            width,
            height,
            depth: vec![f32::INFINITY; n],
            ids: vec![NONE; n],
            wire: vec![false; n],
        }
    }

    /// Rows per band: about four bands per thread, at least four rows each.
    fn band_rows(&self) -> usize {
        let bands = 4 * rayon::current_num_threads().max(1);
        self.height.div_ceil(bands).max(4)
    }
}

/// Twice the signed area of screen triangle `a b c` (x right, y down): negative for
/// a triangle counter-clockwise in the picture's right/up frame, i.e. front-facing.
#[inline]
pub fn edge(a: [f32; 3], b: [f32; 3], p: [f32; 2]) -> f32 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Pixel range `lo..=hi` whose centres (`i + 0.5`) can lie in `[min, max]`, clamped
/// to `0..n`; `None` when empty (also for NaN bounds).
#[inline]
fn pixel_span(min: f32, max: f32, lo_clamp: usize, hi_clamp: usize) -> Option<(usize, usize)> {
    let lo = (min - 0.5).ceil().max(lo_clamp as f32);
    let hi = (max - 0.5).floor().min(hi_clamp as f32 - 1.0);
    (lo <= hi).then_some((lo as usize, hi as usize))
}

/// Depth pass: fills `buf.depth` and `buf.ids` with the nearest of `triangles`
/// (indices into `proj`, the projected vertices: pixel x, pixel y, depth).
pub fn depth_pass(triangles: &[[u32; 3]], proj: &[[f32; 3]], buf: &mut Buffers) {
    let (w, h) = (buf.width, buf.height);
    if w == 0 || h == 0 {
        return;
    }
    let rows = buf.band_rows();
    buf.depth
        .par_chunks_mut(w * rows)
        .zip(buf.ids.par_chunks_mut(w * rows))
        .enumerate()
        .for_each(|(b, (depth, ids))| {
            let y0 = b * rows;
            let y1 = (y0 + rows).min(h);
            for (t, tri) in triangles.iter().enumerate() {
                let [a, bb, c] = tri.map(|i| proj[i as usize]);
                raster_triangle(a, bb, c, t as u32, w, y0, y1, depth, ids);
            }
        });
}

/// Rasterizes one triangle into the band of rows `y0..y1` (buffers start at row `y0`).
#[inline]
#[allow(clippy::too_many_arguments)]
fn raster_triangle(
    a: [f32; 3],
    b: [f32; 3],
    c: [f32; 3],
    t: u32,
    w: usize,
    y0: usize,
    y1: usize,
    depth: &mut [f32],
    ids: &mut [u32],
) {
    let ymin = a[1].min(b[1]).min(c[1]);
    let ymax = a[1].max(b[1]).max(c[1]);
    let Some((py0, py1)) = pixel_span(ymin, ymax, y0, y1) else {
        return;
    };
    let xmin = a[0].min(b[0]).min(c[0]);
    let xmax = a[0].max(b[0]).max(c[0]);
    let Some((px0, px1)) = pixel_span(xmin, xmax, 0, w) else {
        return;
    };
    let area = edge(a, b, [c[0], c[1]]);
    if area == 0.0
        || !area.is_finite()
        || !(a[2].is_finite() && b[2].is_finite() && c[2].is_finite())
    {
        return;
    }
    let inv = 1.0 / area;
    // Barycentric weights of a, b, c: l0 = E(b, c, p) / area, … , stepping in x.
    let dx = [
        -(c[1] - b[1]) * inv,
        -(a[1] - c[1]) * inv,
        -(b[1] - a[1]) * inv,
    ];
    let x0 = px0 as f32 + 0.5;
    for py in py0..=py1 {
        let p = [x0, py as f32 + 0.5];
        let mut l = [
            edge(b, c, p) * inv,
            edge(c, a, p) * inv,
            edge(a, b, p) * inv,
        ];
        let row = (py - y0) * w;
        for px in px0..=px1 {
            if l[0] >= 0.0 && l[1] >= 0.0 && l[2] >= 0.0 {
                let z = l[0] * a[2] + l[1] * b[2] + l[2] * c[2];
                let i = row + px;
                if z < depth[i] {
                    depth[i] = z;
                    ids[i] = t;
                }
            }
            for k in 0..3 {
                l[k] += dx[k];
            }
        }
    }
}

/// Wireframe pass: marks in `buf.wire` the pixels of every triangle edge that are
/// not hidden, i.e. whose depth is within `offset` (mesh units) of the depth
/// buffer, or that belong to the edge's own triangle.
pub fn wire_pass(triangles: &[[u32; 3]], proj: &[[f32; 3]], buf: &mut Buffers, offset: f32) {
    let (w, h) = (buf.width, buf.height);
    if w == 0 || h == 0 {
        return;
    }
    let rows = buf.band_rows();
    let Buffers {
        depth, ids, wire, ..
    } = buf;
    wire.par_chunks_mut(w * rows)
        .zip(depth.par_chunks(w * rows).zip(ids.par_chunks(w * rows)))
        .enumerate()
        .for_each(|(band, (wire, (depth, ids)))| {
            let y0 = band * rows;
            let y1 = (y0 + rows).min(h);
            let target = Band {
                w,
                y0,
                y1,
                depth,
                ids,
                offset,
            };
            for (t, tri) in triangles.iter().enumerate() {
                let v = tri.map(|i| proj[i as usize]);
                let ymin = v[0][1].min(v[1][1]).min(v[2][1]);
                let ymax = v[0][1].max(v[1][1]).max(v[2][1]);
                if !(ymax >= y0 as f32 && ymin < y1 as f32) {
                    continue;
                }
                for k in 0..3 {
                    target.line(v[k], v[(k + 1) % 3], t as u32, wire);
                }
            }
        });
}

/// One band's read-only buffers, for the wireframe pass.
struct Band<'a> {
    w: usize,
    y0: usize,
    y1: usize,
    depth: &'a [f32],
    ids: &'a [u32],
    offset: f32,
}

impl Band<'_> {
    /// Steps from `a` to `b` one pixel at a time (clipped to the band), marking the
    /// visible pixels of triangle `t`'s edge.
    fn line(&self, a: [f32; 3], b: [f32; 3], t: u32, wire: &mut [bool]) {
        // Clip the parameter range to the band's rectangle (Liang–Barsky).
        let (mut s0, mut s1) = (0.0f32, 1.0f32);
        let lims = [(0.0, self.w as f32), (self.y0 as f32, self.y1 as f32)];
        for (k, (lo, hi)) in lims.into_iter().enumerate() {
            let d = b[k] - a[k];
            if d == 0.0 {
                if !(a[k] >= lo && a[k] < hi) {
                    return;
                }
                continue;
            }
            let (ta, tb) = ((lo - a[k]) / d, (hi - a[k]) / d);
            s0 = s0.max(ta.min(tb));
            s1 = s1.min(ta.max(tb));
        }
        if s0.partial_cmp(&s1).is_none_or(|o| o.is_gt()) {
            return;
        }
        let len = (b[0] - a[0]).abs().max((b[1] - a[1]).abs()) * (s1 - s0);
        let n = len.ceil().max(1.0) as usize;
        for i in 0..=n {
            let s = s0 + (s1 - s0) * i as f32 / n as f32;
            let p: [f32; 3] = std::array::from_fn(|k| a[k] + (b[k] - a[k]) * s);
            let (x, y) = (p[0].floor(), p[1].floor());
            if !(x >= 0.0 && x < self.w as f32 && y >= self.y0 as f32 && y < self.y1 as f32) {
                continue;
            }
            let idx = (y as usize - self.y0) * self.w + x as usize;
            if self.ids[idx] == t || p[2] <= self.depth[idx] + self.offset {
                wire[idx] = true;
            }
        }
    }
}

/// What the shading pass needs besides the buffers.
pub struct Shade<'a> {
    /// The triangles.
    pub triangles: &'a [[u32; 3]],
    /// Projected vertices: pixel x, pixel y, depth.
    pub proj: &'a [[f32; 3]],
    /// Vertex positions (mesh units), for face normals.
    pub positions: &'a [[f32; 3]],
    /// Vertex normals for smooth shading, `None` for flat shading.
    pub normals: Option<&'a [[f32; 3]]>,
    /// Heat-map values per vertex and the value that maps to the top of the scale.
    pub heat: Option<(&'a [f32], f32)>,
    /// Base-colour textures by group (material) id, with the UVs and the groups.
    pub textures: Option<Textured<'a>>,
    /// Viewing direction (unit).
    pub forward: [f32; 3],
}

/// What texturing needs: the textures by group id, the mesh's UVs and groups.
#[derive(Clone, Copy)]
pub struct Textured<'a> {
    /// Texture of each group (`None`: untextured).
    pub by_group: &'a [Option<Texture>],
    /// Texture coordinates per vertex.
    pub uv: &'a [[f32; 2]],
    /// Group of each triangle (`None`: all group 0).
    pub groups: Option<&'a [u32]>,
}

/// Colour of the front faces without a heat map (light grey-blue), linear in `[0, 1]`.
pub const FRONT: [f32; 3] = [0.80, 0.82, 0.86];
/// Colour of back faces without a heat map (orange-red), so flipped triangles show.
pub const BACK: [f32; 3] = [0.90, 0.38, 0.22];
/// Colour of wireframe pixels.
pub const WIRE: [u8; 3] = [20, 20, 24];
/// Light that reaches surfaces seen edge-on (a fraction of full brightness).
pub const AMBIENT: f32 = 0.15;
/// Smallest brightness of heat-map colours, so dark slopes keep their colour.
pub const HEAT_AMBIENT: f32 = 0.5;

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn unit(a: [f32; 3]) -> Option<[f32; 3]> {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (l > 0.0 && l.is_finite()).then(|| a.map(|c| c / l))
}

impl Shade<'_> {
    /// The colour of a pixel of triangle `t` at pixel position `p` (x, y).
    pub fn colour(&self, t: u32, p: [f32; 2]) -> [u8; 3] {
        let tri = self.triangles[t as usize];
        let [a, b, c] = tri.map(|i| self.proj[i as usize]);
        let area = edge(a, b, [c[0], c[1]]);
        let mut l = [
            edge(b, c, p) / area,
            edge(c, a, p) / area,
            edge(a, b, p) / area,
        ]
        .map(|x| if x.is_finite() { x.max(0.0) } else { 1.0 / 3.0 });
        let sum = l[0] + l[1] + l[2];
        if sum > 0.0 {
            l = l.map(|x| x / sum);
        }
        let [pa, pb, pc] = tri.map(|i| self.positions[i as usize]);
        let face = unit(cross(sub(pb, pa), sub(pc, pa))).unwrap_or(self.forward);
        let n = match self.normals {
            Some(ns) => {
                let [na, nb, nc] = tri.map(|i| ns[i as usize]);
                unit(std::array::from_fn(|k| {
                    l[0] * na[k] + l[1] * nb[k] + l[2] * nc[k]
                }))
                .unwrap_or(face)
            }
            None => face,
        };
        let lambert =
            (n[0] * self.forward[0] + n[1] * self.forward[1] + n[2] * self.forward[2]).abs();
        let (base, ambient) = match self.heat {
            Some((values, max)) => {
                let [va, vb, vc] = tri.map(|i| values[i as usize]);
                let v = l[0] * va + l[1] * vb + l[2] * vc;
                let s = if max > 0.0 { v / max } else { 0.0 };
                (viridis(s), HEAT_AMBIENT)
            }
            None if area >= 0.0 => (BACK, AMBIENT),
            None => (self.base_colour(t, l), AMBIENT),
        };
        let k = ambient + (1.0 - ambient) * lambert.min(1.0);
        base.map(|x| (x * k * 255.0).round().clamp(0.0, 255.0) as u8)
    }

    /// A front face's colour at barycentric weights `l`: its texture's, or [`FRONT`].
    fn base_colour(&self, t: u32, l: [f32; 3]) -> [f32; 3] {
        let Some(tx) = self.textures else {
            return FRONT;
        };
        let g = tx.groups.map_or(0, |g| g[t as usize]) as usize;
        let Some(Some(tex)) = tx.by_group.get(g) else {
            return FRONT;
        };
        let [a, b, c] = self.triangles[t as usize].map(|i| tx.uv[i as usize]);
        tex.sample(std::array::from_fn(|k| {
            l[0] * a[k] + l[1] * b[k] + l[2] * c[k]
        }))
    }
}
