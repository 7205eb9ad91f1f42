//! Base-colour textures: PNG images decoded with the `png` crate, sampled bilinearly
//! with wrap-around (glTF's default `REPEAT`), in meshlod's UV convention (origin at
//! the image's bottom left, `v` up).

use super::RenderError;

/// An sRGB texture, row-major, top row first.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Texture {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// `width × height` texels.
    pub texels: Vec<[u8; 3]>,
}

impl Texture {
    /// Decodes a PNG (any colour type and bit depth; alpha is dropped, 16-bit
    /// channels keep their high byte).
    ///
    /// # Errors
    /// [`RenderError::Texture`] when the bytes are not a PNG the decoder accepts.
    pub fn from_png(bytes: &[u8]) -> Result<Self, RenderError> {
        let bad = |e: png::DecodingError| RenderError::Texture(e.to_string());
        let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
        dec.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
        let mut reader = dec.read_info().map_err(bad)?;
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| RenderError::Texture("image too large".into()))?;
        let mut buf = vec![0; size];
        let info = reader.next_frame(&mut buf).map_err(bad)?;
        let channels = info.color_type.samples();
        let (w, h) = (info.width as usize, info.height as usize);
        let texels = buf[..info.buffer_size()]
            .chunks_exact(channels)
            .map(|c| match channels {
                1 | 2 => [c[0]; 3],
                _ => [c[0], c[1], c[2]],
            })
            .collect::<Vec<_>>();
        if w == 0 || h == 0 || texels.len() != w * h {
            return Err(RenderError::Texture(format!(
                "{w}x{h} image with {} texels",
                texels.len()
            )));
        }
        Ok(Self {
            width: w,
            height: h,
            texels,
        })
    }

    /// The colour at texture coordinates `uv` (bottom-left origin, wrapping), in
    /// `[0, 1]`, bilinearly interpolated between texel centres.
    #[must_use]
    pub fn sample(&self, uv: [f32; 2]) -> [f32; 3] {
        let wrap = |x: f32| {
            let f = x - x.floor();
            if f.is_finite() {
                f
            } else {
                0.0
            }
        };
        let x = wrap(uv[0]) * self.width as f32 - 0.5;
        let y = (1.0 - wrap(uv[1])) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let idx = |xi: f32, yi: f32| {
            let xi = (xi as i64).rem_euclid(self.width as i64) as usize;
            let yi = (yi as i64).rem_euclid(self.height as i64) as usize;
            self.texels[yi * self.width + xi].map(f32::from)
        };
        let (a, b) = (idx(x0, y0), idx(x0 + 1.0, y0));
        let (c, d) = (idx(x0, y0 + 1.0), idx(x0 + 1.0, y0 + 1.0));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            (top + (bottom - top) * fy) / 255.0
        })
    }
}
