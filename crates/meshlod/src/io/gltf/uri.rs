//! URIs in glTF documents (RFC 3986 as the glTF spec uses them): base64 data URIs,
//! percent-encoded relative paths, and the file name / media type helpers the writer
//! needs for images.

use base64::alphabet;
use base64::engine::general_purpose::{GeneralPurpose, GeneralPurposeConfig};
use base64::engine::DecodePaddingMode;
use base64::Engine;
use std::path::{Component, Path, PathBuf};

/// Standard base64 that accepts input with or without padding.
const BASE64: GeneralPurpose = GeneralPurpose::new(
    &alphabet::STANDARD,
    GeneralPurposeConfig::new().with_decode_padding_mode(DecodePaddingMode::Indifferent),
);

/// What a URI refers to.
#[derive(Debug, PartialEq, Eq)]
pub(super) enum Uri {
    /// A `data:` URI: its media type and decoded bytes.
    Data { media_type: String, bytes: Vec<u8> },
    /// A relative reference to a file (percent-decoded).
    Relative(PathBuf),
}

/// Interprets `uri`.
///
/// # Errors
/// A message (without location) for a data URI that is not base64 or does not
/// decode, an absolute path or a URL with a scheme (which meshlod refuses to follow),
/// or a path that is not valid UTF-8 after percent-decoding.
pub(super) fn parse(uri: &str) -> Result<Uri, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (header, payload) = rest
            .split_once(',')
            .ok_or_else(|| "data URI has no ',' before its data".to_string())?;
        let media_type = header
            .strip_suffix(";base64")
            .ok_or_else(|| "data URI is not base64-encoded (no \";base64\")".to_string())?;
        let bytes = BASE64
            .decode(payload.trim_end())
            .map_err(|e| format!("data URI has invalid base64: {e}"))?;
        return Ok(Uri::Data {
            media_type: media_type.to_string(),
            bytes,
        });
    }
    let has_scheme = uri.split_once(':').is_some_and(|(scheme, _)| {
        !scheme.is_empty()
            && !scheme.contains(['/', '\\', '?', '#'])
            && scheme.starts_with(|c: char| c.is_ascii_alphabetic())
    });
    if has_scheme || uri.starts_with(['/', '\\']) {
        return Err(format!(
            "URI \"{uri}\" is an absolute path or URL; meshlod only loads files given relative to the glTF file"
        ));
    }
    let path = percent_decode(uri)?;
    Ok(Uri::Relative(PathBuf::from(path)))
}

/// Decodes `%XX` escapes (query and fragment parts are cut off first).
fn percent_decode(s: &str) -> Result<String, String> {
    let s = s.split(['?', '#']).next().unwrap_or("");
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("URI \"{s}\" has a malformed % escape"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("URI \"{s}\" is not UTF-8 after decoding"))
}

/// Percent-encodes a relative path for use as a URI (`/` separators kept).
pub(super) fn percent_encode(path: &str) -> String {
    let mut out = String::with_capacity(path.len());
    for &c in path.as_bytes() {
        let keep = c.is_ascii_alphanumeric() || b"-._~!$&'()*+,;=:@/".contains(&c);
        if keep {
            out.push(char::from(c));
        } else if c == b'\\' {
            out.push('/');
        } else {
            out.push_str(&format!("%{c:02X}"));
        }
    }
    out
}

/// A `data:` URI holding `bytes` of `media_type`.
pub(super) fn data_uri(media_type: &str, bytes: &[u8]) -> String {
    format!("data:{media_type};base64,{}", BASE64.encode(bytes))
}

/// True when `path` stays inside the directory it is relative to (no `..`, no root).
pub(super) fn is_contained(path: &Path) -> bool {
    path.components()
        .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
}

/// The media type of an image, from its bytes (PNG, JPEG, WebP, KTX2, DDS, AVIF) or,
/// failing that, from the file extension.
pub(super) fn image_media_type(bytes: &[u8], path: Option<&Path>) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        return Some("image/png");
    }
    if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        return Some("image/jpeg");
    }
    if bytes.starts_with(b"RIFF") && bytes.get(8..12) == Some(b"WEBP".as_slice()) {
        return Some("image/webp");
    }
    if bytes.starts_with(b"\xABKTX 20\xBB\r\n\x1a\n") {
        return Some("image/ktx2");
    }
    if bytes.starts_with(b"DDS ") {
        return Some("image/vnd-ms.dds");
    }
    if bytes.get(4..12) == Some(b"ftypavif".as_slice()) {
        return Some("image/avif");
    }
    let ext = path?.extension()?.to_str()?.to_ascii_lowercase();
    Some(match ext.as_str() {
        "png" => "image/png",
        "jpg" | "jpeg" => "image/jpeg",
        "webp" => "image/webp",
        "ktx2" => "image/ktx2",
        "dds" => "image/vnd-ms.dds",
        "avif" => "image/avif",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris_decode_with_and_without_padding() {
        let with = parse("data:application/octet-stream;base64,AAEC").unwrap();
        assert_eq!(
            with,
            Uri::Data {
                media_type: "application/octet-stream".into(),
                bytes: vec![0, 1, 2]
            }
        );
        let no_pad = parse("data:application/gltf-buffer;base64,AAE").unwrap();
        assert!(matches!(no_pad, Uri::Data { bytes, .. } if bytes == [0, 1]));
        assert!(parse("data:text/plain,hello")
            .unwrap_err()
            .contains("base64"));
        assert!(parse("data:;base64,@@@@")
            .unwrap_err()
            .contains("invalid base64"));
    }

    #[test]
    fn relative_paths_are_percent_decoded_and_absolute_ones_refused() {
        assert_eq!(
            parse("my%20mesh.bin").unwrap(),
            Uri::Relative(PathBuf::from("my mesh.bin"))
        );
        assert_eq!(
            parse("sub/a.bin?x=1").unwrap(),
            Uri::Relative(PathBuf::from("sub/a.bin"))
        );
        for bad in [
            "/etc/passwd",
            "http://example.com/a.bin",
            "file:///a.bin",
            "C:/a.bin",
        ] {
            assert!(parse(bad).unwrap_err().contains("absolute"), "{bad}");
        }
        assert!(parse("a%2.bin").unwrap_err().contains("malformed"));
        assert!(parse("a%FF.bin").unwrap_err().contains("UTF-8"));
    }

    #[test]
    fn encoding_round_trips() {
        let p = "dir/ä b%.png";
        let e = percent_encode(p);
        assert_eq!(e, "dir/%C3%A4%20b%25.png");
        assert_eq!(percent_decode(&e).unwrap(), p);
        assert!(is_contained(Path::new("a/b.png")));
        assert!(!is_contained(Path::new("../b.png")));
    }
}
