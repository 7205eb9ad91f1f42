//! Preview pictures written by `meshlod simplify --preview` (input and output side
//! by side) and `meshlod lod --preview` (the chain as a strip, LOD0 first): the
//! meshes drawn by `meshlod::render` with one camera framing the first, captioned
//! with their counts, errors and switch distances.

use anyhow::{Context, Result};
use meshlod::render::{self, Canvas, RenderOptions, View, MAX_SIZE};
use meshlod::Mesh;
use std::path::Path;

/// Width of each panel of a preview, in pixels.
pub const PANEL_WIDTH: u32 = 640;
/// Height of a preview, in pixels (two caption lines included).
pub const HEIGHT: u32 = 560;

/// `n` with thousands separators: `69,451`.
pub fn thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// A distance as a percentage of `diagonal` with three significant digits, or in
/// mesh units when the diagonal is 0.
pub fn percent(d: f64, diagonal: f64) -> String {
    if diagonal > 0.0 {
        format!("{}% of diag", render::sig3(100.0 * d / diagonal))
    } else {
        format!("{} units", render::sig3(d))
    }
}

/// Draws `panels` (a mesh and its caption lines each) side by side, iso view, flat
/// shading, framed on the first mesh, and writes the PNG `path`. Each panel is
/// [`PANEL_WIDTH`] wide unless that makes the picture wider than the renderer's
/// largest size, when the panels share that width.
///
/// # Errors
/// A mesh cannot be drawn or the file cannot be written.
pub fn write(path: &Path, panels: &[(&Mesh, Vec<String>)]) -> Result<()> {
    let n = panels.len().max(1) as u32;
    let width = (PANEL_WIDTH.saturating_mul(n)).min(MAX_SIZE).max(n);
    let lines = panels.iter().map(|p| p.1.len()).max().unwrap_or(1);
    let opts = RenderOptions {
        width,
        height: HEIGHT,
        view: View::Iso,
        caption_lines: lines,
        ..RenderOptions::default()
    };
    let frame = render::frame_of(panels.first().map(|p| p.0));
    let mut canvas = Canvas::new(&opts, panels.len(), frame, None)?;
    for (i, (mesh, caption)) in panels.iter().enumerate() {
        canvas
            .draw_captioned(i, mesh, None, &[], caption)
            .with_context(|| format!("{}: cannot draw panel {}", path.display(), i + 1))?;
    }
    canvas
        .finish()
        .write_png(path)
        .with_context(|| format!("{}: cannot write the preview", path.display()))
}

/// The file name of `path` (or the whole path when it has none).
pub fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thousands_groups_digits() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1000), "1,000");
        assert_eq!(thousands(69451), "69,451");
        assert_eq!(thousands(1_234_567), "1,234,567");
    }
}
