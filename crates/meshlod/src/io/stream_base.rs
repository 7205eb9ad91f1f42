//! What the streaming readers share ([`super::stream`]): a buffered byte [`Source`]
//! that knows its offset, the [`Sink`] the readers put vertices and triangles in
//! (counting them into a [`StreamSummary`]), and the [`StreamError`] they return
//! before the file name is attached. It depends on no format module: the formats'
//! streaming readers (`stl::stream`, `ply::stream`, `obj::stream`) build on it, and
//! [`super::stream::for_each_triangle`] picks one of them.

use super::FormatError;
use std::io::Read;

/// What a streaming read saw.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StreamSummary {
    /// Triangles passed to the closure.
    pub triangles: u64,
    /// Vertices read (for STL, three per triangle: corners are not welded).
    pub vertices: u64,
    /// Bounding box `(min, max)` of every vertex read (for PLY and OBJ also those no
    /// face uses, as [`crate::Mesh::bounding_box`] with `referenced_only = false` on
    /// the in-memory read); `None` when there was none.
    pub bbox: Option<([f32; 3], [f32; 3])>,
    /// Group (material) names by id (OBJ `usemtl`).
    pub group_names: Vec<String>,
    /// Vertex positions held in memory at the end (PLY and OBJ).
    pub vertices_held: u64,
}

impl StreamSummary {
    /// The bounding-box diagonal (0 when empty), mesh units.
    #[must_use]
    pub fn bbox_diagonal(&self) -> f64 {
        self.bbox
            .map_or(0.0, |(lo, hi)| crate::mesh::box_diagonal(lo, hi))
    }
}

/// An error of a streaming reader before the file name is attached.
#[derive(Debug)]
pub(crate) enum StreamError {
    Io(std::io::Error),
    Format(FormatError),
}

impl From<std::io::Error> for StreamError {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e)
    }
}

impl From<FormatError> for StreamError {
    fn from(e: FormatError) -> Self {
        Self::Format(e)
    }
}

/// Where the readers put what they read.
pub(crate) struct Sink<'a> {
    f: &'a mut dyn FnMut(&[[f32; 3]; 3], u32),
    pub(crate) summary: StreamSummary,
}

impl<'a> Sink<'a> {
    pub(crate) fn new(f: &'a mut dyn FnMut(&[[f32; 3]; 3], u32)) -> Self {
        Self {
            f,
            summary: StreamSummary::default(),
        }
    }

    /// A vertex read (counted, and grown into the bounding box).
    #[inline]
    pub(crate) fn vertex(&mut self, p: [f32; 3]) {
        self.summary.vertices += 1;
        match &mut self.summary.bbox {
            Some((lo, hi)) => {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            None => self.summary.bbox = Some((p, p)),
        }
    }

    /// A triangle read.
    #[inline]
    pub(crate) fn triangle(&mut self, t: &[[f32; 3]; 3], group: u32) {
        self.summary.triangles += 1;
        (self.f)(t, group);
    }
}

/// A buffered byte source that knows its absolute offset and can guarantee a number
/// of bytes ahead.
pub(crate) struct Source<R> {
    r: R,
    buf: Vec<u8>,
    start: usize,
    end: usize,
    base: u64,
    eof: bool,
}

impl<R: Read> Source<R> {
    pub(crate) fn new(r: R) -> Self {
        Self {
            r,
            buf: vec![0; 1 << 20],
            start: 0,
            end: 0,
            base: 0,
            eof: false,
        }
    }

    /// Absolute offset of the next unread byte.
    #[inline]
    pub(crate) fn offset(&self) -> u64 {
        self.base + self.start as u64
    }

    /// Makes at least `n` bytes available if the file has them; false at the end.
    #[inline]
    pub(crate) fn ensure(&mut self, n: usize) -> std::io::Result<bool> {
        if self.end - self.start >= n {
            return Ok(true);
        }
        self.refill(n)
    }

    #[cold]
    fn refill(&mut self, n: usize) -> std::io::Result<bool> {
        self.buf.copy_within(self.start..self.end, 0);
        self.base += self.start as u64;
        self.end -= self.start;
        self.start = 0;
        if n > self.buf.len() {
            self.buf.resize(n.next_power_of_two(), 0);
        }
        while self.end < n && !self.eof {
            let got = match self.r.read(&mut self.buf[self.end..]) {
                Ok(g) => g,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if got == 0 {
                self.eof = true;
            }
            self.end += got;
        }
        Ok(self.end - self.start >= n)
    }

    /// The bytes available.
    #[inline]
    pub(crate) fn bytes(&self) -> &[u8] {
        &self.buf[self.start..self.end]
    }

    /// Skips `n` available bytes.
    #[inline]
    pub(crate) fn consume(&mut self, n: usize) {
        self.start = (self.start + n).min(self.end);
    }

    /// Reads the next line into `out` (without `\n` and a trailing `\r`); false at
    /// the end of the file.
    pub(crate) fn line(&mut self, out: &mut Vec<u8>) -> std::io::Result<bool> {
        out.clear();
        loop {
            let avail = &self.buf[self.start..self.end];
            if let Some(i) = memchr::memchr(b'\n', avail) {
                out.extend_from_slice(&avail[..i]);
                self.start += i + 1;
                break;
            }
            out.extend_from_slice(avail);
            self.start = self.end;
            if !self.ensure(1)? {
                if out.is_empty() {
                    return Ok(false);
                }
                break;
            }
        }
        if out.last() == Some(&b'\r') {
            out.pop();
        }
        Ok(true)
    }
}
