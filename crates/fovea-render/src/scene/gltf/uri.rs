//! Buffer and image URIs: `data:` URIs (base64, standard or URL-safe, or percent-encoded),
//! `file:` URIs and relative paths (percent-decoded, against the glTF file's folder); other
//! schemes (http…) are not fetched. Files are read through the load's
//! [`SceneFiles`](crate::scene::files::SceneFiles): regular files inside the scene's folder
//! tree, at most the declared size.

use std::path::{Path, PathBuf};

use crate::error::RenderError;
use crate::scene::files::SceneFiles;

/// Why a URI could not be read.
pub(super) enum UriError {
    /// A file that cannot be read (missing, not a regular file, outside the scene's folder,
    /// over a limit).
    File(RenderError),
    /// Malformed `data:` URI.
    Bad(String),
    /// A scheme we do not fetch (http…).
    Unsupported(String),
}

impl std::fmt::Display for UriError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            UriError::File(e) => write!(f, "{e}"),
            UriError::Bad(m) | UriError::Unsupported(m) => f.write_str(m),
        }
    }
}

/// Reads a buffer or image URI: `data:` (base64 or percent-encoded), `file:`, or a path
/// relative to `base` (percent-decoded). A file is read up to `declared` bytes when given
/// (a buffer's `byteLength`).
pub(super) fn read_uri(
    files: &SceneFiles,
    base: &Path,
    uri: &str,
    declared: Option<u64>,
) -> std::result::Result<Vec<u8>, UriError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (meta, payload) = rest
            .split_once(',')
            .ok_or_else(|| UriError::Bad("data URI without a comma".into()))?;
        return if meta.ends_with(";base64") {
            base64_decode(payload).ok_or_else(|| UriError::Bad("invalid base64 in data URI".into()))
        } else {
            Ok(percent_decode(payload))
        };
    }
    let file = if let Some(rest) = uri.strip_prefix("file://").or(uri.strip_prefix("file:")) {
        PathBuf::from(String::from_utf8_lossy(&percent_decode(rest)).into_owned())
    } else if let Some(scheme) = uri_scheme(uri) {
        return Err(UriError::Unsupported(format!(
            "URI scheme `{scheme}:` is not fetched (only relative paths, file: and data:)"
        )));
    } else {
        base.join(String::from_utf8_lossy(&percent_decode(uri)).into_owned())
    };
    files.read(&file, declared).map_err(UriError::File)
}

/// The scheme of an absolute URI (`http`, …); `None` for relative references (and Windows
/// drive letters).
fn uri_scheme(uri: &str) -> Option<&str> {
    let scheme = &uri[..uri.find(':')?];
    let ok = scheme.len() >= 2
        && scheme.starts_with(|c: char| c.is_ascii_alphabetic())
        && scheme
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c));
    ok.then_some(scheme)
}

/// Percent-decoding (RFC 3986); malformed escapes are kept as they are.
fn percent_decode(s: &str) -> Vec<u8> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok());
            if let Some(v) = hex {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    out
}

/// Base64 (standard or URL-safe alphabet, padding optional, whitespace ignored).
fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(s.len() / 4 * 3 + 3);
    let (mut acc, mut bits) = (0u32, 0u32);
    for &c in s.as_bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            b' ' | b'\n' | b'\r' | b'\t' => continue,
            _ => return None,
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_known_vectors() {
        assert_eq!(base64_decode("").unwrap(), b"");
        assert_eq!(base64_decode("Zg==").unwrap(), b"f");
        assert_eq!(base64_decode("Zm8=").unwrap(), b"fo");
        assert_eq!(base64_decode("Zm9v").unwrap(), b"foo");
        assert_eq!(base64_decode("Zm9vYmFy").unwrap(), b"foobar");
        assert_eq!(base64_decode("Zm9vYg").unwrap(), b"foob");
        assert!(base64_decode("Zm9v!").is_none());
    }

    #[test]
    fn percent_decoding_keeps_malformed_escapes() {
        assert_eq!(percent_decode("a%20b"), b"a b");
        assert_eq!(percent_decode("%FF%FE"), vec![0xFF, 0xFE]);
        assert_eq!(percent_decode("100%"), b"100%");
        assert_eq!(percent_decode("%G1%2"), b"%G1%2");
    }

    #[test]
    fn uri_schemes_are_recognised() {
        assert_eq!(uri_scheme("http://x/y.bin"), Some("http"));
        assert_eq!(uri_scheme("C:/x.bin"), None);
        assert_eq!(uri_scheme("textures/a.png"), None);
        assert_eq!(uri_scheme("a:b.png"), None);
    }
}
