//! A self-contained HTML page that shows meshes in the browser with WebGL: no
//! network, no library. The meshes travel inside the page as one base64 block of
//! little-endian binary arrays (positions `f32 ×3`, indices `u16` or `u32 ×3`,
//! optional colours `u8 ×4` and heat values `f32`), described by a JSON header; the
//! page's own script (`viewer.js`, written for meshlod) decodes them into WebGL 1
//! buffers and draws them with the same orthographic camera, headlight, back-face
//! tint and viridis heat map as the CPU renderer ([`super::Canvas`]), so the first
//! frame matches `meshlod render --view front` of the first level. A person can
//! orbit (drag, one finger), zoom (wheel, pinch), toggle the wireframe, smooth
//! shading and the heat map, and switch levels.

use super::{colormap, HeatScale, RenderError};
use crate::mesh::Mesh;
use base64::Engine as _;
use serde::Serialize;

const TEMPLATE: &str = include_str!("viewer.html");
const SCRIPT: &str = include_str!("viewer.js");

/// One mesh the page can show (a level of detail, or one of several files).
#[derive(Debug, Clone, Copy)]
pub struct PageLevel<'a> {
    /// The mesh (positions in mesh units).
    pub mesh: &'a Mesh,
    /// Its name on the level buttons (e.g. `LOD1` or the file name).
    pub label: &'a str,
    /// A line shown under the buttons when the level is on screen (counts, error).
    pub info: &'a str,
    /// Heat-map values, one per vertex (mesh units), or `None`.
    pub heat: Option<&'a [f32]>,
}

/// What the page shows besides the meshes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PageOptions {
    /// The page's title.
    pub title: String,
    /// The heat map's scale (shared by every level) and the reference's name, when
    /// the levels carry heat values.
    pub heat: Option<(HeatScale, String)>,
}

#[derive(Serialize)]
struct LevelHeader<'a> {
    label: &'a str,
    info: &'a str,
    vertices: usize,
    triangles: usize,
    positions: usize,
    indices: usize,
    index_bytes: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    colors: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    heat: Option<usize>,
}

#[derive(Serialize)]
struct HeatHeader<'a> {
    max: f64,
    diagonal: f64,
    reference: &'a str,
}

#[derive(Serialize)]
struct Header<'a> {
    title: &'a str,
    bytes: usize,
    bbox: [[f32; 3]; 2],
    levels: Vec<LevelHeader<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    heat: Option<HeatHeader<'a>>,
    viridis: Vec<[f32; 3]>,
    front: [f32; 3],
    back: [f32; 3],
    wire: [u8; 3],
    ambient: f32,
    heat_ambient: f32,
}

/// Appends zero bytes until `out`'s length is a multiple of 4.
fn pad4(out: &mut Vec<u8>) {
    while out.len() % 4 != 0 {
        out.push(0);
    }
}

/// The binary block of `level` appended to `blob`, and its header entry.
fn pack<'a>(level: &PageLevel<'a>, blob: &mut Vec<u8>) -> Result<LevelHeader<'a>, RenderError> {
    let m = level.mesh;
    m.validate()?;
    if let Some(h) = level.heat {
        if h.len() != m.vertex_count() {
            return Err(RenderError::Values {
                len: h.len(),
                vertices: m.vertex_count(),
            });
        }
    }
    pad4(blob);
    let positions = blob.len();
    for p in &m.positions {
        for c in p {
            blob.extend_from_slice(&c.to_le_bytes());
        }
    }
    let indices = blob.len();
    let small = m.vertex_count() <= usize::from(u16::MAX);
    for t in &m.triangles {
        for &i in t {
            if small {
                blob.extend_from_slice(&(i as u16).to_le_bytes());
            } else {
                blob.extend_from_slice(&i.to_le_bytes());
            }
        }
    }
    pad4(blob);
    let colors = m.attributes.colors.as_ref().map(|cs| {
        let at = blob.len();
        for c in cs {
            blob.extend(c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8));
        }
        at
    });
    let heat = level.heat.map(|h| {
        let at = blob.len();
        for v in h {
            let v = if v.is_finite() { *v } else { 0.0 };
            blob.extend_from_slice(&v.to_le_bytes());
        }
        at
    });
    Ok(LevelHeader {
        label: level.label,
        info: level.info,
        vertices: m.vertex_count(),
        triangles: m.triangle_count(),
        positions,
        indices,
        index_bytes: if small { 2 } else { 4 },
        colors,
        heat,
    })
}

/// Text safe inside an HTML `<script>` element and between tags: `<`, `>` and `&`
/// escaped as JSON unicode escapes (valid JSON, parsed back by `JSON.parse`).
fn script_safe(json: &str) -> String {
    json.replace('<', "\\u003c")
        .replace('>', "\\u003e")
        .replace('&', "\\u0026")
}

/// `text` with HTML's special characters escaped.
fn html_escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Size in bytes of the binary block [`page`] embeds for `levels` (before base64,
/// which adds a third).
#[must_use]
pub fn payload_bytes(levels: &[PageLevel]) -> usize {
    levels
        .iter()
        .map(|l| {
            let m = l.mesh;
            let ib = if m.vertex_count() <= usize::from(u16::MAX) {
                2
            } else {
                4
            };
            let idx = (m.triangle_count() * 3 * ib).div_ceil(4) * 4;
            m.vertex_count() * 12
                + idx
                + m.attributes.colors.as_ref().map_or(0, |c| 4 * c.len())
                + l.heat.map_or(0, |h| 4 * h.len())
        })
        .sum()
}

/// The HTML page showing `levels` (the first is framed and shown first).
///
/// # Errors
/// [`RenderError::Panels`] when there is no level, [`RenderError::Mesh`] for a
/// malformed mesh, [`RenderError::Values`] when heat values are not one per
/// vertex.
pub fn page(levels: &[PageLevel], opts: &PageOptions) -> Result<String, RenderError> {
    if levels.is_empty() {
        return Err(RenderError::Panels {
            panels: 0,
            width: 0,
        });
    }
    let mut blob = Vec::with_capacity(payload_bytes(levels) + 4 * levels.len());
    let headers = levels
        .iter()
        .map(|l| pack(l, &mut blob))
        .collect::<Result<Vec<_>, _>>()?;
    let (lo, hi) = super::frame_of(Some(levels[0].mesh));
    let header = Header {
        title: &opts.title,
        bytes: blob.len(),
        bbox: [lo, hi],
        levels: headers,
        heat: opts.heat.as_ref().map(|(s, r)| HeatHeader {
            max: s.max,
            diagonal: s.diagonal,
            reference: r,
        }),
        viridis: (0..=10)
            .map(|i| colormap::viridis(i as f32 / 10.0))
            .collect(),
        front: super::FRONT,
        back: super::BACK,
        wire: super::WIRE,
        ambient: super::AMBIENT,
        heat_ambient: super::HEAT_AMBIENT,
    };
    let json = serde_json::to_string(&header).map_err(|e| RenderError::Page(e.to_string()))?;
    let data = base64::engine::general_purpose::STANDARD.encode(&blob);
    drop(blob);
    let mut out = String::with_capacity(data.len() + TEMPLATE.len() + SCRIPT.len() + json.len());
    let mut rest = TEMPLATE;
    while let Some(at) = rest.find("{{") {
        out.push_str(&rest[..at]);
        let end = rest[at..].find("}}").map_or(rest.len(), |e| at + e + 2);
        match &rest[at..end] {
            "{{TITLE}}" => out.push_str(&html_escape(&opts.title)),
            "{{HEADER}}" => out.push_str(&script_safe(&json)),
            "{{DATA}}" => out.push_str(&data),
            "{{SCRIPT}}" => out.push_str(SCRIPT),
            other => out.push_str(other),
        }
        rest = &rest[end..];
    }
    out.push_str(rest);
    Ok(out)
}
