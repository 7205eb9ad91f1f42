//! [`Distance`]: a length given either in mesh units or relative to a mesh's
//! bounding-box diagonal, as the simplification options
//! ([`crate::simplify::SimplifyOptions`]) and the clustering
//! ([`crate::decimate::cluster`]) take it. It lives here, beside the [`Mesh`] whose
//! diagonal resolves it, so that neither of those modules imports the other for it.
//!
//! [`Mesh`]: super::Mesh

use serde::Serialize;

/// A length, either in mesh units or as a fraction of the bounding-box diagonal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Distance {
    /// A fraction of the input's bounding-box diagonal (`0.01` = 1%).
    Relative(f64),
    /// In the mesh's units.
    Absolute(f64),
}

impl Distance {
    /// The length in mesh units for a mesh with bounding-box diagonal `diagonal`.
    #[must_use]
    pub fn resolve(self, diagonal: f64) -> f64 {
        match self {
            Self::Relative(f) => f * diagonal,
            Self::Absolute(d) => d,
        }
    }

    /// The number as given (a fraction or mesh units).
    pub(crate) fn value(self) -> f64 {
        match self {
            Self::Relative(v) | Self::Absolute(v) => v,
        }
    }
}
