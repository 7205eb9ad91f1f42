//! Shared scanning for the text formats (OBJ, OFF, ASCII PLY, ASCII STL, Hoppe `.m`):
//! lines with their numbers, whitespace tokens, and number parsing that says which
//! line and which token was wrong.
//!
//! Works on raw bytes: a file with non-UTF-8 bytes in a comment still loads, and one
//! with them in a number gets an error naming the line.

use super::{FormatError, Location};

/// Iterates the lines of a byte buffer, with 1-based line numbers; strips `\r`.
pub(crate) struct Lines<'a> {
    data: &'a [u8],
    pos: usize,
    line: u64,
}

impl<'a> Lines<'a> {
    /// Starts at byte 0, line 1.
    pub(crate) fn new(data: &'a [u8]) -> Self {
        Self {
            data,
            pos: 0,
            line: 0,
        }
    }

    /// Number of the line most recently returned (1-based; 0 before the first).
    pub(crate) fn line_number(&self) -> u64 {
        self.line
    }

    /// Byte offset just past the line most recently returned.
    pub(crate) fn offset(&self) -> usize {
        self.pos
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = &'a [u8];

    fn next(&mut self) -> Option<&'a [u8]> {
        if self.pos >= self.data.len() {
            return None;
        }
        let rest = &self.data[self.pos..];
        let (line, adv) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&rest[..i], i + 1),
            None => (rest, rest.len()),
        };
        self.pos += adv;
        self.line += 1;
        Some(line.strip_suffix(b"\r").unwrap_or(line))
    }
}

/// Splits a line into whitespace-separated tokens.
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

/// A token shown in an error message: at most 40 characters, lossy UTF-8.
pub(crate) fn show(token: &[u8]) -> String {
    let s = String::from_utf8_lossy(&token[..token.len().min(40)]).into_owned();
    if token.len() > 40 {
        format!("{s}...")
    } else {
        s
    }
}

/// Parses a float token (decimal, exponent, `inf`/`nan` accepted; callers check
/// finiteness where it matters).
pub(crate) fn parse_f32(token: &[u8], line: u64, what: &str) -> Result<f32, FormatError> {
    match fast_float2::parse::<f32, _>(token) {
        Ok(v) => Ok(v),
        Err(_) => Err(FormatError::new(
            Location::Line(line),
            format!("expected a number for {what}, found '{}'", show(token)),
        )),
    }
}

/// Parses a float token as f64.
pub(crate) fn parse_f64(token: &[u8], line: u64, what: &str) -> Result<f64, FormatError> {
    match fast_float2::parse::<f64, _>(token) {
        Ok(v) => Ok(v),
        Err(_) => Err(FormatError::new(
            Location::Line(line),
            format!("expected a number for {what}, found '{}'", show(token)),
        )),
    }
}

/// Parses a signed decimal integer token.
pub(crate) fn parse_i64(token: &[u8], line: u64, what: &str) -> Result<i64, FormatError> {
    let bad = || {
        FormatError::new(
            Location::Line(line),
            format!("expected an integer for {what}, found '{}'", show(token)),
        )
    };
    let (neg, digits) = match token.first() {
        Some(b'-') => (true, &token[1..]),
        Some(b'+') => (false, &token[1..]),
        _ => (false, token),
    };
    if digits.is_empty() || digits.len() > 18 {
        return Err(bad());
    }
    let mut v: i64 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return Err(bad());
        }
        v = v * 10 + i64::from(d - b'0');
    }
    Ok(if neg { -v } else { v })
}

/// Parses an unsigned count that must be at most `max` (a bound derived from the file
/// size, so an absurd header count is refused instead of allocating).
pub(crate) fn parse_count(
    token: &[u8],
    line: u64,
    what: &str,
    max: u64,
) -> Result<usize, FormatError> {
    let v = parse_i64(token, line, what)?;
    if v < 0 {
        return Err(FormatError::new(
            Location::Line(line),
            format!("{what} is negative ({v})"),
        ));
    }
    if v as u64 > max {
        return Err(FormatError::new(
            Location::Line(line),
            format!("{what} is {v}, more than a file of this size can hold (at most {max})"),
        ));
    }
    Ok(v as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_numbers_and_crlf() {
        let mut l = Lines::new(b"a b\r\n\nc");
        assert_eq!(l.next(), Some(&b"a b"[..]));
        assert_eq!(l.line_number(), 1);
        assert_eq!(l.next(), Some(&b""[..]));
        assert_eq!(l.next(), Some(&b"c"[..]));
        assert_eq!(l.line_number(), 3);
        assert_eq!(l.next(), None);
    }

    #[test]
    fn numbers() {
        assert_eq!(parse_f32(b"1.5e2", 1, "x").unwrap(), 150.0);
        assert!(parse_f32(b"1.5x", 7, "x")
            .unwrap_err()
            .to_string()
            .contains("line 7"));
        assert_eq!(parse_i64(b"-12", 1, "i").unwrap(), -12);
        assert!(parse_i64(b"1e3", 1, "i").is_err());
        assert!(parse_count(b"99999999999", 1, "n", 1000).is_err());
    }
}
