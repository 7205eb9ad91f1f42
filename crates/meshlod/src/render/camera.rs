//! Views and the orthographic camera that frames a bounding box.

use super::RenderError;
use std::fmt;
use std::str::FromStr;

/// Where the camera looks from.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum View {
    /// Looking along −z (the model's +z side faces the viewer), +y up.
    #[default]
    Front,
    /// Looking down along −y, −z up on the picture.
    Top,
    /// From the (1, 1, 1) direction towards the centre, +y up.
    Iso,
    /// Looking along this direction (need not be unit length; not zero).
    Direction([f64; 3]),
}

impl FromStr for View {
    type Err = RenderError;

    /// `front`, `top`, `iso`, or a viewing direction `x,y,z` of three finite numbers,
    /// not all zero (`0,0,-1` is `front`).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "front" => return Ok(Self::Front),
            "top" => return Ok(Self::Top),
            "iso" => return Ok(Self::Iso),
            _ => {}
        }
        let parts: Vec<f64> = s
            .split(',')
            .map(|p| p.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| RenderError::View(s.to_string()))?;
        match parts[..] {
            [x, y, z]
                if [x, y, z].iter().all(|v| v.is_finite())
                    && (x != 0.0 || y != 0.0 || z != 0.0) =>
            {
                Ok(Self::Direction([x, y, z]))
            }
            _ => Err(RenderError::View(s.to_string())),
        }
    }
}

impl fmt::Display for View {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Front => f.write_str("front"),
            Self::Top => f.write_str("top"),
            Self::Iso => f.write_str("iso"),
            Self::Direction([x, y, z]) => write!(f, "{x},{y},{z}"),
        }
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    a.map(|c| c / l)
}

impl View {
    /// The unit viewing direction (from the eye into the scene).
    #[must_use]
    pub fn forward(&self) -> [f64; 3] {
        match *self {
            Self::Front => [0.0, 0.0, -1.0],
            Self::Top => [0.0, -1.0, 0.0],
            Self::Iso => normalize([-1.0, -1.0, -1.0]),
            Self::Direction(d) => normalize(d),
        }
    }

    /// The unit right, up and forward axes of the picture: right × … forms a
    /// right-handed frame with `right = forward × up`. Up is +y, or −z when looking
    /// (nearly) straight down and +z when looking straight up.
    #[must_use]
    pub fn axes(&self) -> [[f64; 3]; 3] {
        let f = self.forward();
        let hint = if f[1] < -0.999 {
            [0.0, 0.0, -1.0]
        } else if f[1] > 0.999 {
            [0.0, 0.0, 1.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let r = normalize(cross(f, hint));
        let u = cross(r, f);
        [r, u, f]
    }
}

/// An orthographic camera: world point `p` lands at picture pixel
/// `(cx + s·(p·right − r0), cy − s·(p·up − u0))` (x right, y down, pixel centres at
/// half-integers) with depth `p·forward − d0` (mesh units, larger is farther).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Unit right, up and forward axes.
    pub axes: [[f64; 3]; 3],
    /// The framed box's centre along the three axes (mesh units).
    pub center: [f64; 3],
    /// Pixels per mesh unit.
    pub scale: f64,
    /// Where the centre lands, in pixels from the panel's top-left corner.
    pub pixel_center: [f64; 2],
}

/// Fraction of the panel the framed box fills along its tighter side.
const FILL: f64 = 0.9;

impl Camera {
    /// The camera for `view` that fits the box `lo..hi` (mesh units) in a
    /// `width × height` pixel panel, centred, filling 90% of its tighter side.
    #[must_use]
    pub fn frame(view: &View, lo: [f32; 3], hi: [f32; 3], width: usize, height: usize) -> Self {
        let axes = view.axes();
        let mut min = [f64::INFINITY; 3];
        let mut max = [f64::NEG_INFINITY; 3];
        for corner in 0..8 {
            let p: [f64; 3] = std::array::from_fn(|k| {
                f64::from(if corner & (1 << k) == 0 { lo[k] } else { hi[k] })
            });
            for a in 0..3 {
                let v = dot(p, axes[a]);
                min[a] = min[a].min(v);
                max[a] = max[a].max(v);
            }
        }
        let center = std::array::from_fn(|a| 0.5 * (min[a] + max[a]));
        let (er, eu) = (max[0] - min[0], max[1] - min[1]);
        let (w, h) = (width as f64, height as f64);
        let fit = |extent: f64, pixels: f64| {
            if extent > 0.0 && extent.is_finite() {
                FILL * pixels / extent
            } else {
                f64::INFINITY
            }
        };
        let mut scale = fit(er, w).min(fit(eu, h));
        if !scale.is_finite() {
            scale = 1.0;
        }
        Self {
            axes,
            center,
            scale,
            pixel_center: [0.5 * w, 0.5 * h],
        }
    }

    /// `p`'s pixel position and depth (see [`Camera`]), in `f32`.
    #[must_use]
    #[inline]
    pub fn project(&self, p: [f32; 3]) -> [f32; 3] {
        let p = p.map(f64::from);
        let r = dot(p, self.axes[0]) - self.center[0];
        let u = dot(p, self.axes[1]) - self.center[1];
        let d = dot(p, self.axes[2]) - self.center[2];
        [
            (self.pixel_center[0] + self.scale * r) as f32,
            (self.pixel_center[1] - self.scale * u) as f32,
            d as f32,
        ]
    }
}
