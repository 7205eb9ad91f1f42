//! Height-field readers: greyscale PNG, SRTM `.hgt`, ESRI ASCII grid `.asc` and
//! single-band GeoTIFF, into one [`HeightField`] (a row-major `f32` grid).
//!
//! Formats followed:
//! - **PNG** (W3C PNG specification, 3rd ed.): 1, 2, 4, 8 or 16-bit greyscale, the grey
//!   level is the height (an alpha channel is ignored; colour images are refused);
//! - **SRTM `.hgt`** (NASA/USGS *SRTM Topography* documentation, "SRTM data
//!   format"): a headerless square of big-endian signed 16-bit heights in metres,
//!   1201 × 1201 (3 arc-seconds) or 3601 × 3601 (1 arc-second), rows north to south,
//!   void −32768;
//! - **ESRI ASCII grid** (ArcGIS documentation, "ESRI ASCII raster format"): the header
//!   `ncols`, `nrows`, `xllcorner`|`xllcenter`, `yllcorner`|`yllcenter`, `cellsize`,
//!   optional `NODATA_value` (default −9999), then `nrows` rows of `ncols` numbers,
//!   north first;
//! - **GeoTIFF** (OGC GeoTIFF 1.1): one greyscale sample per pixel (8/16/32/64-bit
//!   integers or 32/64-bit floats), `ModelPixelScaleTag` for the cell size,
//!   `ModelTiepointTag` for the origin, GDAL's `GDAL_NODATA` tag for voids.
//!
//! **Voids** (the `.hgt` void, `NODATA_value`, `GDAL_NODATA`, NaN) are filled from
//! their neighbours in layers: each void that touches a valid sample (8-neighbourhood)
//! takes the mean of its valid neighbours, then those count as valid and the next
//! layer in is filled, until none is left; a raster with no valid sample is refused.
//!
//! **Sizes** are checked before anything is allocated from a header: an `.hgt` must be
//! exactly one of the two sizes; an `.asc` header's sample count must fit the bytes
//! that follow it (two bytes per number at least); a PNG or TIFF raster may not exceed
//! what its compressed bytes can expand to (deflate at most 1032:1, LZW about 2730:1)
//! nor [`MAX_SAMPLES`]. Every error names the file and the problem; nothing panics.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

/// Largest grid read, in samples (2^30: 4 GiB of `f32` heights).
pub const MAX_SAMPLES: usize = 1 << 30;

/// A regular grid of heights.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightField {
    /// Samples per row (columns).
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Heights, row-major, the file's first row first (north for DEMs), in the file's
    /// units (grey levels for PNG, metres for `.hgt`) times any z-scale applied.
    pub heights: Vec<f32>,
    /// Distance between neighbouring samples, in the file's horizontal units (1 when
    /// the format does not say: PNG, `.hgt`).
    pub cell_size: f64,
    /// Georeferenced position (x, y) of the first sample's centre when the format
    /// gives one (`.asc`, GeoTIFF tie point), in the file's horizontal units.
    pub origin: Option<[f64; 2]>,
    /// Number of void samples filled from their neighbours.
    pub voids_filled: usize,
}

/// What went wrong reading a height field.
#[derive(Debug, thiserror::Error)]
pub enum Problem {
    /// The operating system refused.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The extension is not one of `.png`, `.hgt`, `.asc`, `.tif`, `.tiff`.
    #[error("unknown height-field format (expected .png, .hgt, .asc, .tif or .tiff)")]
    UnknownFormat,
    /// An `.hgt` file whose size is not one of the SRTM sizes.
    #[error("truncated or wrong size: {0} bytes, but an SRTM .hgt holds 2884802 (1201 x 1201, 3 arc-seconds) or 25934402 (3601 x 3601, 1 arc-second) bytes")]
    HgtSize(u64),
    /// The PNG decoder refused.
    #[error("PNG: {0}")]
    Png(String),
    /// The TIFF decoder refused.
    #[error("TIFF: {0}")]
    Tiff(String),
    /// A colour or multi-band raster.
    #[error("{0}: a height field must have one grey band")]
    NotGrey(String),
    /// The grid is smaller than 2 × 2.
    #[error("a {0} x {1} grid is too small (at least 2 x 2 samples)")]
    TooSmall(usize, usize),
    /// The header's size is absurd for the file.
    #[error("the header says {width} x {height} samples, which {why}")]
    AbsurdSize {
        /// Columns claimed.
        width: u64,
        /// Rows claimed.
        height: u64,
        /// Why it cannot be.
        why: String,
    },
    /// A malformed ESRI ASCII grid.
    #[error("line {line}: {message}")]
    Asc {
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// Every sample is void.
    #[error("every sample is void (no data): nothing to triangulate")]
    AllVoid,
}

/// An error reading a height field: the file and the problem.
#[derive(Debug, thiserror::Error)]
#[error("{}: {problem}", path.display())]
pub struct HeightFieldError {
    /// The file.
    pub path: PathBuf,
    /// The problem.
    #[source]
    pub problem: Problem,
}

/// Reads a height field, choosing the format by extension (`.png`, `.hgt`, `.asc`,
/// `.tif`/`.tiff`, case-insensitive). Voids are filled (see the module docs).
///
/// # Errors
/// [`HeightFieldError`] naming the file: it cannot be read, has an unknown extension,
/// is truncated or of the wrong size, has an absurd header, is not one grey band, is
/// smaller than 2 × 2, or holds no valid sample.
pub fn read_height_field(path: impl AsRef<Path>) -> Result<HeightField, HeightFieldError> {
    let path = path.as_ref();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let result = match ext.as_str() {
        "png" => read_png(path),
        "hgt" => read_hgt(path),
        "asc" => read_asc(path),
        "tif" | "tiff" => read_tiff(path),
        _ => Err(Problem::UnknownFormat),
    };
    result.map_err(|problem| HeightFieldError {
        path: path.to_path_buf(),
        problem,
    })
}

impl HeightField {
    /// Multiplies every height by `s`.
    pub fn scale_heights(&mut self, s: f64) {
        if s != 1.0 {
            for h in &mut self.heights {
                *h = (f64::from(*h) * s) as f32;
            }
        }
    }

    /// Builds a height field from `width × height` row-major heights, filling the
    /// non-finite ones as voids.
    ///
    /// # Errors
    /// [`Problem::TooSmall`] below 2 × 2 or when `heights` is not `width × height`
    /// long; [`Problem::AllVoid`] when no height is finite.
    pub fn from_heights(width: usize, height: usize, heights: Vec<f32>) -> Result<Self, Problem> {
        if width < 2 || height < 2 || Some(heights.len()) != width.checked_mul(height) {
            return Err(Problem::TooSmall(width, height));
        }
        let mut hf = HeightField {
            width,
            height,
            heights,
            cell_size: 1.0,
            origin: None,
            voids_filled: 0,
        };
        hf.voids_filled = fill_voids(&mut hf.heights, width, height)?;
        Ok(hf)
    }
}

/// Checks a claimed size against [`MAX_SAMPLES`] and against `limit` bytes of raster
/// the file can hold at `bytes_per_sample`.
fn check_size(width: u64, height: u64, bytes_per_sample: u64, limit: u64) -> Result<(), Problem> {
    let absurd = |why: String| Problem::AbsurdSize { width, height, why };
    let n = width
        .checked_mul(height)
        .ok_or_else(|| absurd("overflows".into()))?;
    if n > MAX_SAMPLES as u64 {
        return Err(absurd(format!(
            "is more than the {MAX_SAMPLES} samples meshlod reads"
        )));
    }
    if n.saturating_mul(bytes_per_sample) > limit {
        return Err(absurd(format!(
            "cannot come from a file this size (at most {limit} bytes of raster)"
        )));
    }
    if width < 2 || height < 2 {
        return Err(Problem::TooSmall(width as usize, height as usize));
    }
    Ok(())
}

/// Fills the non-finite samples from their neighbours, layer by layer (module docs).
/// Returns how many were filled.
fn fill_voids(h: &mut [f32], width: usize, height: usize) -> Result<usize, Problem> {
    let voids = h.iter().filter(|v| !v.is_finite()).count();
    if voids == 0 {
        return Ok(0);
    }
    if voids == h.len() {
        return Err(Problem::AllVoid);
    }
    let neighbours = |i: usize| {
        let (x, y) = ((i % width) as i64, (i / width) as i64);
        (-1i64..=1)
            .flat_map(move |dy| (-1i64..=1).map(move |dx| (x + dx, y + dy)))
            .filter(move |&(nx, ny)| {
                (nx, ny) != (x, y) && nx >= 0 && ny >= 0 && nx < width as i64 && ny < height as i64
            })
            .map(move |(nx, ny)| ny as usize * width + nx as usize)
    };
    // queued[i]: the void is in the current or next layer.
    let mut queued = vec![false; h.len()];
    let mut layer: Vec<usize> = (0..h.len())
        .filter(|&i| !h[i].is_finite() && neighbours(i).any(|j| h[j].is_finite()))
        .collect();
    for &i in &layer {
        queued[i] = true;
    }
    let mut values = Vec::new();
    while !layer.is_empty() {
        values.clear();
        for &i in &layer {
            let (mut sum, mut k) = (0.0f64, 0u32);
            for j in neighbours(i) {
                if h[j].is_finite() {
                    sum += f64::from(h[j]);
                    k += 1;
                }
            }
            values.push((sum / f64::from(k.max(1))) as f32);
        }
        for (&i, &v) in layer.iter().zip(&values) {
            h[i] = v;
        }
        let mut next = Vec::new();
        for &i in &layer {
            for j in neighbours(i) {
                if !h[j].is_finite() && !queued[j] {
                    queued[j] = true;
                    next.push(j);
                }
            }
        }
        layer = next;
    }
    Ok(voids)
}

fn file_len(path: &Path) -> Result<u64, Problem> {
    Ok(std::fs::metadata(path)?.len())
}

fn read_hgt(path: &Path) -> Result<HeightField, Problem> {
    let len = file_len(path)?;
    let side = match len {
        2_884_802 => 1201,
        25_934_402 => 3601,
        _ => return Err(Problem::HgtSize(len)),
    };
    let mut bytes = Vec::with_capacity(len as usize);
    File::open(path)?.read_to_end(&mut bytes)?;
    if bytes.len() as u64 != len {
        return Err(Problem::HgtSize(bytes.len() as u64));
    }
    let heights = bytes
        .chunks_exact(2)
        .map(|b| match i16::from_be_bytes([b[0], b[1]]) {
            -32768 => f32::NAN,
            v => f32::from(v),
        })
        .collect();
    HeightField::from_heights(side, side, heights)
}

fn read_png(path: &Path) -> Result<HeightField, Problem> {
    let len = file_len(path)?;
    let png_err = |e: png::DecodingError| Problem::Png(e.to_string());
    let limit = len.saturating_mul(1100).max(1 << 20);
    let mut dec = png::Decoder::new_with_limits(
        BufReader::new(File::open(path)?),
        png::Limits {
            bytes: usize::try_from(limit).unwrap_or(usize::MAX),
        },
    );
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec.read_info().map_err(png_err)?;
    let (w, h) = {
        let info = reader.info();
        (u64::from(info.width), u64::from(info.height))
    };
    let (color, depth) = reader.output_color_type();
    let channels: usize = match color {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        other => return Err(Problem::NotGrey(format!("a {other:?} PNG"))),
    };
    let bytes_per = if depth == png::BitDepth::Sixteen {
        2
    } else {
        1
    };
    check_size(w, h, (channels * bytes_per) as u64, limit)?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| Problem::Png("image too large".into()))?;
    let mut buf = vec![0u8; size];
    let frame = reader.next_frame(&mut buf).map_err(png_err)?;
    let (w, h) = (w as usize, h as usize);
    let stride = frame.line_size;
    let mut heights = Vec::with_capacity(w * h);
    for row in buf.chunks(stride).take(h) {
        for x in 0..w {
            let o = x * channels * bytes_per;
            heights.push(if bytes_per == 2 {
                f32::from(u16::from_be_bytes([row[o], row[o + 1]]))
            } else {
                f32::from(row[o])
            });
        }
    }
    HeightField::from_heights(w, h, heights)
}

/// Splits the next whitespace-separated token off `s` at byte `pos`, counting lines.
fn token<'s>(s: &'s [u8], pos: &mut usize, line: &mut usize) -> Option<&'s [u8]> {
    while *pos < s.len() && s[*pos].is_ascii_whitespace() {
        if s[*pos] == b'\n' {
            *line += 1;
        }
        *pos += 1;
    }
    let start = *pos;
    while *pos < s.len() && !s[*pos].is_ascii_whitespace() {
        *pos += 1;
    }
    (*pos > start).then(|| &s[start..*pos])
}

/// The `.asc` header: keys and values, and where the numbers start.
struct AscHeader {
    ncols: u64,
    nrows: u64,
    cellsize: f64,
    corner: [f64; 2],
    center: bool,
    nodata: f64,
}

fn asc_header(s: &[u8], pos: &mut usize, line: &mut usize) -> Result<AscHeader, Problem> {
    let bad = |line: usize, message: String| Problem::Asc { line, message };
    let mut hd = AscHeader {
        ncols: 0,
        nrows: 0,
        cellsize: 1.0,
        corner: [0.0; 2],
        center: false,
        nodata: -9999.0,
    };
    let (mut cols, mut rows) = (false, false);
    loop {
        let save = (*pos, *line);
        let Some(key) = token(s, pos, line) else {
            break;
        };
        if !key[0].is_ascii_alphabetic() {
            (*pos, *line) = save;
            break;
        }
        let key = String::from_utf8_lossy(key).to_ascii_lowercase();
        let value = token(s, pos, line)
            .ok_or_else(|| bad(*line, format!("header key {key} has no value")))?;
        let text = String::from_utf8_lossy(value);
        let num: f64 = text
            .parse()
            .map_err(|_| bad(*line, format!("header {key}: {text:?} is not a number")))?;
        let count = |v: f64| -> Result<u64, Problem> {
            if v >= 0.0 && v.fract() == 0.0 && v < 1e15 {
                Ok(v as u64)
            } else {
                Err(bad(*line, format!("header {key}: {text} is not a count")))
            }
        };
        match key.as_str() {
            "ncols" => (hd.ncols, cols) = (count(num)?, true),
            "nrows" => (hd.nrows, rows) = (count(num)?, true),
            "cellsize" if num > 0.0 && num.is_finite() => hd.cellsize = num,
            "cellsize" => return Err(bad(*line, format!("cellsize {text} is not positive"))),
            "xllcorner" => hd.corner[0] = num,
            "yllcorner" => hd.corner[1] = num,
            "xllcenter" => (hd.corner[0], hd.center) = (num, true),
            "yllcenter" => (hd.corner[1], hd.center) = (num, true),
            "nodata_value" => hd.nodata = num,
            _ => return Err(bad(*line, format!("unknown header key {key}"))),
        }
    }
    if !(cols && rows) {
        return Err(bad(*line, "the header lacks ncols or nrows".into()));
    }
    Ok(hd)
}

fn read_asc(path: &Path) -> Result<HeightField, Problem> {
    let s = std::fs::read(path)?;
    let (mut pos, mut line) = (0usize, 1usize);
    let hd = asc_header(&s, &mut pos, &mut line)?;
    // Each number takes at least one character and one separator.
    let room = (s.len() - pos) as u64 + 1;
    check_size(hd.ncols, hd.nrows, 2, room)?;
    let (w, h) = (hd.ncols as usize, hd.nrows as usize);
    let mut heights = Vec::with_capacity(w * h);
    while let Some(tok) = token(&s, &mut pos, &mut line) {
        if heights.len() == w * h {
            return Err(Problem::Asc {
                line,
                message: format!("more than the {w} x {h} values the header announces"),
            });
        }
        let v: f64 = fast_float2::parse(tok).map_err(|_| Problem::Asc {
            line,
            message: format!("{:?} is not a number", String::from_utf8_lossy(tok)),
        })?;
        heights.push(if v == hd.nodata { f32::NAN } else { v as f32 });
    }
    if heights.len() != w * h {
        return Err(Problem::Asc {
            line,
            message: format!(
                "{} values, but the header announces {w} x {h} = {}",
                heights.len(),
                w * h
            ),
        });
    }
    let mut hf = HeightField::from_heights(w, h, heights)?;
    hf.cell_size = hd.cellsize;
    // The first sample is the north-west one: its centre.
    let half = if hd.center { 0.0 } else { 0.5 * hd.cellsize };
    hf.origin = Some([
        hd.corner[0] + half,
        hd.corner[1] + half + (h as f64 - 1.0) * hd.cellsize,
    ]);
    Ok(hf)
}

fn read_tiff(path: &Path) -> Result<HeightField, Problem> {
    use tiff::decoder::{Decoder, DecodingResult, Limits};
    use tiff::tags::Tag;
    let len = file_len(path)?;
    let terr = |e: tiff::TiffError| Problem::Tiff(e.to_string());
    let limit = len.saturating_mul(3000).max(1 << 20);
    let mut limits = Limits::default();
    limits.decoding_buffer_size = usize::try_from(limit).unwrap_or(usize::MAX);
    let mut dec = Decoder::new(BufReader::new(File::open(path)?))
        .map_err(terr)?
        .with_limits(limits);
    let (w, h) = dec.dimensions().map_err(terr)?;
    let bits = match dec.colortype().map_err(terr)? {
        tiff::ColorType::Gray(b) => b,
        other => return Err(Problem::NotGrey(format!("a {other:?} TIFF"))),
    };
    check_size(
        u64::from(w),
        u64::from(h),
        u64::from(bits).div_ceil(8),
        limit,
    )?;
    let nodata: Option<f64> = dec
        .find_tag(Tag::GdalNodata)
        .ok()
        .flatten()
        .and_then(|v| v.into_string().ok())
        .and_then(|s| s.trim().trim_end_matches('\0').parse().ok());
    let scale = dec
        .find_tag(Tag::ModelPixelScaleTag)
        .ok()
        .flatten()
        .and_then(|v| v.into_f64_vec().ok());
    let tie = dec
        .find_tag(Tag::ModelTiepointTag)
        .ok()
        .flatten()
        .and_then(|v| v.into_f64_vec().ok());
    let img = dec.read_image().map_err(terr)?;
    fn conv<T: Copy>(v: &[T], f: impl Fn(T) -> f64, nodata: Option<f64>) -> Vec<f32> {
        v.iter()
            .map(|&x| {
                let x = f(x);
                if Some(x) == nodata {
                    f32::NAN
                } else {
                    x as f32
                }
            })
            .collect()
    }
    let heights = match &img {
        DecodingResult::U8(v) => conv(v, f64::from, nodata),
        DecodingResult::U16(v) => conv(v, f64::from, nodata),
        DecodingResult::U32(v) => conv(v, f64::from, nodata),
        DecodingResult::U64(v) => conv(v, |x| x as f64, nodata),
        DecodingResult::I8(v) => conv(v, f64::from, nodata),
        DecodingResult::I16(v) => conv(v, f64::from, nodata),
        DecodingResult::I32(v) => conv(v, f64::from, nodata),
        DecodingResult::I64(v) => conv(v, |x| x as f64, nodata),
        DecodingResult::F32(v) => conv(v, f64::from, nodata),
        DecodingResult::F64(v) => conv(v, |x| x, nodata),
        DecodingResult::F16(v) => conv(v, |x| f64::from(x.to_f32()), nodata),
    };
    let (w, h) = (w as usize, h as usize);
    if heights.len() != w * h {
        return Err(Problem::NotGrey(format!(
            "a TIFF with {} samples for {w} x {h} pixels",
            heights.len()
        )));
    }
    let mut hf = HeightField::from_heights(w, h, heights)?;
    if let Some(s) = scale.filter(|s| s.len() >= 2 && s[0] > 0.0 && s[0].is_finite()) {
        hf.cell_size = s[0];
        if let Some(t) = tie.filter(|t| t.len() >= 6) {
            // Raster (i, j) maps to model (x, y); the first pixel's centre is at (0.5, 0.5).
            hf.origin = Some([t[3] + (0.5 - t[0]) * s[0], t[4] - (0.5 - t[1]) * s[1]]);
        }
    }
    Ok(hf)
}
