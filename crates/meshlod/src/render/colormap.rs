//! The viridis colour map (van der Walt & Smith, designed for matplotlib 2.0, 2015):
//! perceptually uniform, readable in grey and by colour-blind viewers. The table holds
//! the published map's colours at eleven evenly spaced positions (0, 0.1, …, 1), as
//! sRGB bytes; between them colours are interpolated linearly.

/// Viridis at `t = 0, 0.1, …, 1`, sRGB.
pub const VIRIDIS: [[u8; 3]; 11] = [
    [68, 1, 84],
    [72, 36, 117],
    [65, 68, 135],
    [53, 95, 141],
    [42, 120, 142],
    [33, 145, 140],
    [34, 168, 132],
    [68, 191, 112],
    [122, 209, 81],
    [189, 223, 38],
    [253, 231, 37],
];

/// The viridis colour at `t ∈ [0, 1]` (clamped; NaN maps to the top, 1), as sRGB
/// components in `[0, 1]`.
#[must_use]
pub fn viridis(t: f32) -> [f32; 3] {
    let t = if t.is_nan() { 1.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (VIRIDIS.len() - 1) as f32;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f32;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    std::array::from_fn(|k| (f32::from(a[k]) + (f32::from(b[k]) - f32::from(a[k])) * f) / 255.0)
}
