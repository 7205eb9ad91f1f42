//! Resident memory of this process, for the reports' `memory` object.
//!
//! On Linux the kernel keeps the current and the peak resident set size in
//! `/proc/self/status` (`VmRSS`, `VmHWM`), and writing `5` to `/proc/self/clear_refs`
//! resets the peak to the current size, so the peak of one phase (simplification
//! after reading) can be told apart from the peak of reading. Elsewhere nothing is
//! measured and the report leaves the fields out.

use serde::Serialize;

/// Current and peak resident set size, in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rss {
    /// Resident now.
    pub current: u64,
    /// Highest resident since the start or the last [`reset_peak`].
    pub peak: u64,
}

/// Parses the `VmRSS` and `VmHWM` lines (values in kB) of a `/proc/PID/status` text.
fn parse_status(text: &str) -> Option<Rss> {
    let field = |name: &str| -> Option<u64> {
        let line = text.lines().find(|l| l.starts_with(name))?;
        let kb: u64 = line[name.len()..]
            .trim()
            .trim_end_matches("kB")
            .trim()
            .parse()
            .ok()?;
        Some(kb * 1024)
    };
    Some(Rss {
        current: field("VmRSS:")?,
        peak: field("VmHWM:")?,
    })
}

/// The process's resident set sizes, or `None` where the platform does not say.
#[must_use]
pub fn rss() -> Option<Rss> {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|t| parse_status(&t))
}

/// Resets the peak to the current size; `false` when the platform cannot.
pub fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The `memory` object of a report (bytes).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct MemoryReport {
    /// Peak resident set size of the whole run up to the output being written.
    pub peak_rss_bytes: u64,
    /// Resident after the input was read (the input mesh and the program).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_rss_bytes: Option<u64>,
    /// Peak resident while simplifying and writing, above `input_rss_bytes`, per
    /// input triangle: the simplifier's working memory.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extra_bytes_per_input_triangle: Option<f64>,
}

impl MemoryReport {
    /// A report with the peak only (reading was not set apart, e.g. streaming).
    #[must_use]
    pub fn peak_only(peak_rss_bytes: u64) -> Self {
        Self {
            peak_rss_bytes,
            input_rss_bytes: None,
            extra_bytes_per_input_triangle: None,
        }
    }
}

/// Tracks the phases of one run.
#[derive(Debug, Clone, Copy)]
pub struct Phases {
    /// Peak and resident size at the end of reading.
    read: Option<Rss>,
    /// Whether the peak was reset after reading.
    reset: bool,
}

impl Phases {
    /// Call when the input has been read.
    #[must_use]
    pub fn after_read() -> Self {
        let read = rss();
        let reset = read.is_some() && reset_peak();
        Self { read, reset }
    }

    /// Call when the output has been written; `triangles_in` scales the extra.
    #[must_use]
    pub fn report(&self, triangles_in: usize) -> Option<MemoryReport> {
        let now = rss()?;
        let Some(read) = self.read else {
            return Some(MemoryReport::peak_only(now.peak));
        };
        let extra = (self.reset && triangles_in > 0)
            .then(|| now.peak.saturating_sub(read.current) as f64 / triangles_in as f64);
        Some(MemoryReport {
            peak_rss_bytes: now.peak.max(read.peak),
            input_rss_bytes: Some(read.current),
            extra_bytes_per_input_triangle: extra,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_proc_status_lines() {
        let text = "Name:\tmeshlod\nVmPeak:\t  900 kB\nVmHWM:\t    2048 kB\nVmRSS:\t    1024 kB\n";
        assert_eq!(
            parse_status(text),
            Some(Rss {
                current: 1024 * 1024,
                peak: 2048 * 1024
            })
        );
        assert_eq!(parse_status("VmRSS:\t12 kB\n"), None, "no peak line");
        assert_eq!(parse_status("VmRSS:\tmany kB\nVmHWM:\t1 kB\n"), None);
    }

    /// Holding 64 MiB, the reported peak is at least that much and at least the
    /// size resident now (robust to other tests allocating in the same process).
    #[cfg(target_os = "linux")]
    #[test]
    fn peak_covers_a_fresh_allocation() {
        let phases = Phases::after_read();
        let big = vec![1u8; 64 << 20];
        std::hint::black_box(&big);
        let r = phases.report(1_000_000).expect("linux reports memory");
        let now = rss().expect("linux reports memory");
        assert!(r.peak_rss_bytes >= 64 << 20, "{r:?}");
        assert!(r.peak_rss_bytes >= now.current, "{r:?} {now:?}");
        assert!(r.input_rss_bytes.is_some());
    }
}
