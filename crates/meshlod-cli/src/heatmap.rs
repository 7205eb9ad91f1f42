//! Heat-map export: a mesh with a per-vertex scalar, as PLY `quality` plus colours.

use anyhow::{bail, Context, Result};
use meshlod::io::{ply, Format, WriteOptions};
use meshlod::Mesh;
use std::path::Path;

/// Blue (0) → cyan → green → yellow → red (1), the usual error colour ramp.
#[must_use]
pub fn ramp(t: f64) -> [f32; 4] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let stops: [[f64; 3]; 5] = [
        [0.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
    ];
    let x = t * 4.0;
    let i = (x.floor() as usize).min(3);
    let f = x - i as f64;
    let c: [f64; 3] = std::array::from_fn(|k| stops[i][k] + (stops[i + 1][k] - stops[i][k]) * f);
    // 8-bit exact values, as PLY stores them.
    let q = |v: f64| ((v * 255.0).round() / 255.0) as f32;
    [q(c[0]), q(c[1]), q(c[2]), 1.0]
}

/// Writes `mesh` to `path` with a colour from [`ramp`] per vertex, scaled to the
/// largest finite value of `values`; as binary PLY (by the extension) also with
/// `values[i]` as vertex `i`'s `quality`. Other formats that hold vertex colours
/// (OBJ, OFF, glTF) get the colours alone.
///
/// # Errors
/// The file cannot be written, or its format holds no vertex colours (STL) or is
/// unknown.
pub fn write(path: &Path, mesh: &Mesh, values: &[f64]) -> Result<()> {
    let max = values
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let mut m = mesh.clone();
    m.attributes.colors = Some(
        values
            .iter()
            .map(|&v| ramp(if max > 0.0 { v / max } else { 0.0 }))
            .collect(),
    );
    match Format::from_path(path) {
        Some(Format::Ply) => {}
        Some(Format::Stl) => bail!(
            "{}: STL holds no vertex colours; write the heat map as .ply, .obj, .off or .glb",
            path.display()
        ),
        Some(_) => {
            return meshlod::write_mesh(path, &m, &WriteOptions::default())
                .with_context(|| format!("{}: cannot write the heat map", path.display()));
        }
        None => bail!(
            "{}: unknown heat-map format; use .ply (distances and colours), .obj, .off or .glb",
            path.display()
        ),
    }
    let q: Vec<f32> = values.iter().map(|&v| v as f32).collect();
    let mut bytes = Vec::new();
    ply::write_with_quality(&m, &q, false, &mut bytes)
        .with_context(|| format!("{}: cannot encode heat map", path.display()))?;
    std::fs::write(path, bytes).with_context(|| format!("{}: cannot write", path.display()))
}

#[cfg(test)]
mod tests {
    use super::ramp;

    #[test]
    fn ramp_ends_and_middle() {
        assert_eq!(ramp(0.0), [0.0, 0.0, 1.0, 1.0]);
        assert_eq!(ramp(1.0), [1.0, 0.0, 0.0, 1.0]);
        assert_eq!(ramp(0.5), [0.0, 1.0, 0.0, 1.0]);
        assert_eq!(ramp(f64::NAN), [1.0, 0.0, 0.0, 1.0]);
    }
}
