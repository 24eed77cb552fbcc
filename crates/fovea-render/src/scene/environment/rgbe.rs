//! Radiance RGBE (`.hdr`, `.pic`) read one scanline at a time, so a map can be reduced while
//! it is decoded without ever holding the full-size float image (a 2 MB run-length file can
//! declare 8192 × 4096 pixels, 400 MB as f32 RGB).
//!
//! **Format** (Ward, "Real pixels", Graphics Gems II, 1991; the Radiance file format
//! description): text header lines up to an empty line (`#?RADIANCE` or `#?RGBE` first,
//! `FORMAT=32-bit_rle_rgbe`; a `FORMAT` other than that one, `32-bit_rle_xyze` included, is
//! refused), then the resolution line `-Y <height> +X <width>` (top row first, left to right;
//! the other orientations are refused), then `height` scanlines of `width` pixels of four
//! bytes `R G B E`. A scanline is
//! * *adaptive run-length* ("new" RLE) when `8 ≤ width < 32768` and it starts with the bytes
//!   `2 2 w_hi w_lo` (`w_hi < 128`, the two giving `width`): then the four components follow
//!   one after another, each as runs: a count byte `c > 128` repeats the next byte `c − 128`
//!   times, a count `0 < c ≤ 128` is followed by `c` literal bytes;
//! * otherwise *flat*, pixel after pixel, where a pixel `1 1 1 n` ("old" RLE) repeats the
//!   previous pixel `n << s` times, `s` growing by 8 with every consecutive such pixel.
//!
//! **Value.** `E = 0` is black; otherwise each component is `m · 2^(E − 136)` (the mantissa
//! byte `m` over 256, times `2^(E − 128)`), the convention of the `image` crate's decoder this
//! replaces, so maps decode to the same values as before. `EXPOSURE` lines are ignored (as
//! there).
//!
//! Errors are one-line texts (the caller names the file); a truncated file or a run that
//! overflows its scanline is an error, never a panic.

use glam::Vec3;

/// What the header says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Pixels per scanline.
    pub width: u32,
    /// Scanlines.
    pub height: u32,
    /// Byte offset of the first scanline.
    pub data_start: usize,
}

/// Whether `bytes` start like a Radiance file (`#?`).
pub fn looks_like_rgbe(bytes: &[u8]) -> bool {
    bytes.starts_with(b"#?")
}

/// Longest header line accepted (bytes).
const MAX_LINE: usize = 4096;

/// Reads the header and the resolution line.
pub fn read_header(bytes: &[u8]) -> Result<Header, String> {
    let mut pos = 0usize;
    let line = |pos: &mut usize| -> Result<&[u8], String> {
        let rest = &bytes[*pos..];
        let end = rest
            .iter()
            .take(MAX_LINE + 1)
            .position(|&b| b == b'\n')
            .ok_or_else(|| {
                if rest.len() <= MAX_LINE {
                    "the header ends before the resolution line".to_string()
                } else {
                    format!("a header line is longer than {MAX_LINE} bytes")
                }
            })?;
        *pos += end + 1;
        Ok(&rest[..end])
    };
    let first = line(&mut pos)?;
    if !first.starts_with(b"#?") {
        return Err("not a Radiance file (it does not start with `#?`)".into());
    }
    loop {
        let l = line(&mut pos)?;
        if l.is_empty() {
            break;
        }
        if let Some(f) = l.strip_prefix(b"FORMAT=") {
            let f = String::from_utf8_lossy(f);
            if f.trim() != "32-bit_rle_rgbe" {
                return Err(format!(
                    "FORMAT={} is not supported (32-bit_rle_rgbe only)",
                    f.trim().chars().take(40).collect::<String>()
                ));
            }
        }
    }
    let res = String::from_utf8_lossy(line(&mut pos)?).into_owned();
    let parts: Vec<&str> = res.split_whitespace().collect();
    let shown: String = res.chars().take(60).collect();
    match parts.as_slice() {
        ["-Y", h, "+X", w] => {
            let parse = |s: &str| s.parse::<u32>().ok().filter(|&v| v > 0);
            match (parse(h), parse(w)) {
                (Some(height), Some(width)) => Ok(Header {
                    width,
                    height,
                    data_start: pos,
                }),
                _ => Err(format!(
                    "resolution line `{shown}`: sizes must be positive integers"
                )),
            }
        }
        [_, _, _, _] => Err(format!(
            "resolution line `{shown}`: only the standard orientation `-Y height +X width` is \
             read"
        )),
        _ => Err(format!(
            "resolution line `{shown}`: expected `-Y height +X width`"
        )),
    }
}

/// One RGBE pixel as linear RGB.
#[inline]
fn to_rgb(p: [u8; 4]) -> Vec3 {
    if p[3] == 0 {
        return Vec3::ZERO;
    }
    let f = (f32::from(p[3]) - 136.0).exp2();
    Vec3::new(f32::from(p[0]), f32::from(p[1]), f32::from(p[2])) * f
}

/// Decodes the scanlines top to bottom, handing each to `row(y, pixels)` as linear RGB.
pub fn for_each_row(
    bytes: &[u8],
    header: &Header,
    mut row: impl FnMut(u32, &[Vec3]),
) -> Result<(), String> {
    let w = header.width as usize;
    let mut pos = header.data_start;
    let mut rgbe = vec![[0u8; 4]; w];
    let mut out = vec![Vec3::ZERO; w];
    let eof = |y: u32| format!("the file ends in scanline {y}");
    for y in 0..header.height {
        let next4 = bytes.get(pos..pos + 4).ok_or_else(|| eof(y))?;
        let adaptive = (8..0x8000).contains(&w)
            && next4[0] == 2
            && next4[1] == 2
            && next4[2] < 128
            && ((next4[2] as usize) << 8 | next4[3] as usize) == w;
        if adaptive {
            pos += 4;
            for c in 0..4 {
                let mut x = 0usize;
                while x < w {
                    let count = *bytes.get(pos).ok_or_else(|| eof(y))? as usize;
                    pos += 1;
                    if count > 128 {
                        let n = count - 128;
                        let v = *bytes.get(pos).ok_or_else(|| eof(y))?;
                        pos += 1;
                        if x + n > w {
                            return Err(format!("scanline {y}: a run overflows the line"));
                        }
                        for p in &mut rgbe[x..x + n] {
                            p[c] = v;
                        }
                        x += n;
                    } else {
                        if count == 0 || x + count > w {
                            return Err(format!(
                                "scanline {y}: a literal run of {count} bytes does not fit"
                            ));
                        }
                        let src = bytes.get(pos..pos + count).ok_or_else(|| eof(y))?;
                        for (p, &v) in rgbe[x..x + count].iter_mut().zip(src) {
                            p[c] = v;
                        }
                        pos += count;
                        x += count;
                    }
                }
            }
        } else {
            let mut x = 0usize;
            let mut shift = 0u32;
            while x < w {
                let b = bytes.get(pos..pos + 4).ok_or_else(|| eof(y))?;
                pos += 4;
                let p = [b[0], b[1], b[2], b[3]];
                if p[0] == 1 && p[1] == 1 && p[2] == 1 {
                    if x == 0 || shift > 16 {
                        return Err(format!("scanline {y}: a repeat without a pixel before it"));
                    }
                    let n = (p[3] as usize) << shift;
                    if x + n > w {
                        return Err(format!("scanline {y}: a run overflows the line"));
                    }
                    let prev = rgbe[x - 1];
                    rgbe[x..x + n].fill(prev);
                    x += n;
                    shift += 8;
                } else {
                    rgbe[x] = p;
                    x += 1;
                    shift = 0;
                }
            }
        }
        for (o, &p) in out.iter_mut().zip(&rgbe) {
            *o = to_rgb(p);
        }
        row(y, &out);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(w: u32, h: u32, body: &[u8]) -> Vec<u8> {
        let mut f = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
        f.extend_from_slice(body);
        f
    }

    #[test]
    fn flat_old_and_adaptive_scanlines_decode_alike() {
        // 8 pixels of (128, 64, 32, e=129): (1, 0.5, 0.25) · 2^(129−128−1) … = m · 2^(E−136).
        let px = [128u8, 64, 32, 129];
        let want = Vec3::new(128.0, 64.0, 32.0) * 2f32.powi(129 - 136);
        let flat: Vec<u8> = px.repeat(8);
        let mut old = px.to_vec();
        old.extend_from_slice(&[1, 1, 1, 7]);
        let mut adaptive = vec![2u8, 2, 0, 8];
        for c in px {
            adaptive.extend_from_slice(&[128 + 8, c]);
        }
        for body in [flat, old, adaptive] {
            let f = file(8, 1, &body);
            let h = read_header(&f).unwrap();
            assert_eq!((h.width, h.height), (8, 1));
            let mut rows = 0;
            for_each_row(&f, &h, |y, r| {
                assert_eq!(y, 0);
                assert!(r.iter().all(|&p| p == want), "{r:?}");
                rows += 1;
            })
            .unwrap();
            assert_eq!(rows, 1);
        }
    }

    #[test]
    fn truncated_and_overflowing_files_are_errors() {
        let f = file(8, 2, &[1, 2, 3, 4]);
        let h = read_header(&f).unwrap();
        assert!(for_each_row(&f, &h, |_, _| {})
            .unwrap_err()
            .contains("ends"));
        let mut run = vec![2u8, 2, 0, 8, 128 + 9, 1];
        run.extend_from_slice(&[0; 16]);
        let f = file(8, 1, &run);
        let h = read_header(&f).unwrap();
        assert!(for_each_row(&f, &h, |_, _| {})
            .unwrap_err()
            .contains("overflows"));
        assert!(read_header(b"#?RADIANCE\n\n+Y 2 +X 2\n").is_err());
        assert!(read_header(b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 2 +X 2\n").is_err());
        assert!(read_header(b"P6\n").is_err());
    }
}
