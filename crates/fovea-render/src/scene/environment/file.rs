//! Reading environment maps from image files: OpenEXR (`.exr`) and Radiance RGBE (`.hdr`)
//! hold linear radiance and are taken as stored; 8- and 16-bit images (PNG, JPEG) are
//! sRGB-decoded to linear (IEC 61966-2-1), so an LDR map lights at most with radiance 1 per
//! unit of `scale`. The image must be a latitude-longitude map (module `envmap`); any aspect
//! ratio is accepted (2:1 is usual).
//!
//! The file is untrusted input: it is read within the scene load's [`LoadLimits`] (a regular
//! file, at most `max_file_bytes`, inside the scene's folder unless allowed; module `files`),
//! its header is read first and a map of more than [`MAX_ENVMAP_PIXELS`] pixels is refused
//! before any pixel is decoded, and the decoder runs under `image`'s allocation limits.
//! Errors name the file: [`RenderError::Io`] when it cannot be read, [`RenderError::BadInput`]
//! when it does not decode or holds NaN or infinite values, [`RenderError::ResourceLimit`]
//! when it is too large. Negative values (which some HDR tools write for out-of-gamut colours)
//! are clamped to 0.
//!
//! [`LoadLimits`]: crate::scene::LoadLimits

use std::io::Cursor;
use std::path::Path;

use glam::Vec3;

use super::envmap::{EnvMap, MAX_ENVMAP_PIXELS};
use super::rgbe;
use super::shrink::Shrink;
use crate::error::{RenderError, Result};
use crate::scene::files::SceneFiles;
use crate::scene::limits::LoadLimits;
use crate::scene::texture::srgb_to_linear;

/// Bytes a built [`EnvMap`] takes per pixel at its peak: the pixels (12), their luminance
/// and the sampling function while the tables are built (4 + 4), the 2D distribution's
/// function and CDF (8), rounded up for the allocator.
pub const ENVMAP_BYTES_PER_PIXEL: u64 = 32;
/// Bytes per pixel `image` needs to decode an OpenEXR, PNG or JPEG map to f32 RGB: its own
/// buffer (up to RGBA f32, 16) and the RGB f32 copy (12).
pub const DECODE_BYTES_PER_PIXEL: u64 = 28;

/// Reads and decodes an environment map file (a regular file of at most the default
/// [`LoadLimits::max_file_bytes`](crate::scene::LoadLimits); it may lie anywhere).
pub fn load(path: &Path) -> Result<EnvMap> {
    let files = SceneFiles::new(path, &LoadLimits::default())?;
    let bytes = files.read_scene_file()?;
    Ok(decode_within(path, &bytes, u64::MAX)?.0)
}

/// Reads (within the load's limits, inside the scene's folder) and decodes an environment map
/// a scene names, within the limits' `max_memory_bytes`; the note says when it was reduced.
pub(crate) fn load_in(files: &SceneFiles, path: &Path) -> Result<(EnvMap, Option<String>)> {
    let bytes = files.read(path, None)?;
    decode_within(path, &bytes, files.limits().max_memory_bytes)
}

/// Decodes the bytes of the image file `path` (format from the content, else the extension)
/// with no memory budget beyond [`MAX_ENVMAP_PIXELS`].
pub fn decode(path: &Path, bytes: &[u8]) -> Result<EnvMap> {
    Ok(decode_within(path, bytes, u64::MAX)?.0)
}

/// The smallest integer reduction `f ≥ 1` whose map (`⌈w/f⌉ × ⌈h/f⌉` pixels at
/// [`ENVMAP_BYTES_PER_PIXEL`], plus `fixed` bytes) fits `budget`; `None` when not even a
/// 1 × 1 map does.
fn reduction(w: u32, h: u32, fixed: u64, budget: u64) -> Option<u32> {
    let cost = |f: u32| {
        fixed.saturating_add(
            u64::from(w.div_ceil(f)) * u64::from(h.div_ceil(f)) * ENVMAP_BYTES_PER_PIXEL,
        )
    };
    (1..=w.max(h)).find(|&f| cost(f) <= budget)
}

/// [`decode`] within a memory budget: the map may take half of `max_memory_bytes` (the
/// frame's buffers need the rest). The size is read from the header first; a map whose
/// built form would not fit is reduced by the smallest integer factor that fits
/// (module `shrink`: solid-angle-weighted blocks, the mean radiance kept), and the note says
/// so. Radiance `.hdr` files are decoded one scanline at a time into the reduction (module
/// `rgbe`), so the full-size image is never held; OpenEXR, PNG and JPEG are decoded whole by
/// `image` (refused when that alone exceeds the budget) and then reduced.
pub fn decode_within(
    path: &Path,
    bytes: &[u8],
    max_memory_bytes: u64,
) -> Result<(EnvMap, Option<String>)> {
    let budget = max_memory_bytes / 2;
    let name = path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let rgbe_file = rgbe::looks_like_rgbe(bytes);
    let (w, h, header) = if rgbe_file {
        let hd = rgbe::read_header(bytes).map_err(|e| {
            RenderError::bad(
                path,
                format!("cannot read the environment map's header: {e}"),
            )
        })?;
        (hd.width, hd.height, Some(hd))
    } else {
        let (w, h) = reader(path, bytes)?.into_dimensions().map_err(|e| {
            RenderError::bad(
                path,
                format!("cannot read the environment map's header: {e}"),
            )
        })?;
        (w, h, None)
    };
    if w == 0 || h == 0 {
        return Err(RenderError::bad(
            path,
            format!("the environment map is {w}x{h} pixels"),
        ));
    }
    let px = u64::from(w) * u64::from(h);
    if px > MAX_ENVMAP_PIXELS {
        return Err(RenderError::ResourceLimit {
            what: format!("environment map {}", path.display()),
            needed: format!("{w}x{h} pixels"),
            limit: format!("{MAX_ENVMAP_PIXELS} pixels (8192x4096)"),
        });
    }
    let over = |needed: u64| RenderError::ResourceLimit {
        what: format!("environment map {}", path.display()),
        needed: format!("{} MiB to decode {w}x{h} pixels", needed.div_ceil(1 << 20)),
        limit: format!("half of --max-memory, {} MiB", budget / (1 << 20)),
    };
    // What must be held besides the reduced map: a scanline for RGBE, the whole decoded
    // image otherwise.
    let fixed = if rgbe_file {
        u64::from(w) * 32
    } else {
        px * DECODE_BYTES_PER_PIXEL
    };
    let factor = reduction(w, h, fixed, budget).ok_or_else(|| over(fixed))?;
    let mut shrink = Shrink::new(w, h, factor);
    // Every row: the first non-finite pixel remembered, negative values (out-of-gamut
    // colours some HDR tools write) clamped to 0, then into the reduction.
    let mut bad_pixel = None;
    let mut clamped = Vec::with_capacity(w as usize);
    let mut check_row = |y: u32, row: &[Vec3], shrink: &mut Shrink| {
        if bad_pixel.is_none() {
            if let Some(x) = row.iter().position(|c| !c.is_finite()) {
                bad_pixel = Some((x, y, row[x]));
            }
        }
        clamped.clear();
        clamped.extend(row.iter().map(|c| c.max(Vec3::ZERO)));
        shrink.push_row(y, &clamped);
    };
    if let Some(hd) = header {
        rgbe::for_each_row(bytes, &hd, |y, row| check_row(y, row, &mut shrink))
            .map_err(|e| RenderError::bad(path, format!("cannot decode environment map: {e}")))?;
    } else {
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(w);
        limits.max_image_height = Some(h);
        // RGBA f32 for the decoded image plus the decoder's own buffers.
        limits.max_alloc = Some(px * 16 * 3 + (64 << 20));
        let mut r = reader(path, bytes)?;
        r.limits(limits);
        let img = r
            .decode()
            .map_err(|e| RenderError::bad(path, format!("cannot decode environment map: {e}")))?;
        let linear = matches!(
            img.color(),
            image::ColorType::Rgb32F | image::ColorType::Rgba32F
        );
        let rgb = img.to_rgb32f();
        drop(img);
        let mut row = Vec::with_capacity(w as usize);
        for (y, line) in rgb.as_raw().chunks_exact(3 * w as usize).enumerate() {
            row.clear();
            row.extend(line.chunks_exact(3).map(|p| {
                let c = Vec3::new(p[0], p[1], p[2]);
                if !c.is_finite() || linear {
                    c
                } else {
                    Vec3::new(
                        srgb_to_linear(c.x),
                        srgb_to_linear(c.y),
                        srgb_to_linear(c.z),
                    )
                }
            }));
            check_row(y as u32, &row, &mut shrink);
        }
    }
    if let Some((x, y, c)) = bad_pixel {
        return Err(RenderError::bad(
            path,
            format!("environment map pixel ({x}, {y}) is {c}: radiance must be finite"),
        ));
    }
    let (w2, h2) = shrink.out_size();
    let pixels = shrink.finish();
    let note = (factor > 1).then(|| {
        format!(
            "note: environment map {}: {w}x{h} pixels need {} MiB, over half of the memory \
             limit (--max-memory; {} MiB): reduced {factor}x to {w2}x{h2}",
            path.display(),
            (px * ENVMAP_BYTES_PER_PIXEL).div_ceil(1 << 20),
            budget / (1 << 20)
        )
    });
    Ok((EnvMap::new(&name, w2, h2, pixels)?, note))
}

/// An `image` reader of the bytes (format from the content, else the extension).
fn reader<'a>(path: &Path, bytes: &'a [u8]) -> Result<image::ImageReader<Cursor<&'a [u8]>>> {
    let mut r = image::ImageReader::new(Cursor::new(bytes));
    if let Ok(format) = image::ImageFormat::from_path(path) {
        r.set_format(format);
    }
    r.with_guessed_format()
        .map_err(|e| RenderError::io(path, &e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hdr_exr_and_png_maps_decode_to_linear_radiance() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (8u32, 4u32);
        let hdr_px: Vec<f32> = (0..w * h)
            .flat_map(|k| [k as f32 * 0.5, 2.0, 0.25])
            .collect();
        let img = image::Rgb32FImage::from_raw(w, h, hdr_px).unwrap();
        for ext in ["exr", "hdr"] {
            let p = dir.path().join(format!("sky.{ext}"));
            image::DynamicImage::ImageRgb32F(img.clone())
                .save(&p)
                .unwrap();
            let m = load(&p).unwrap();
            assert_eq!((m.width(), m.height()), (w, h));
            // Pixel (3, 1) is k = 11 at its centre.
            let uv = glam::Vec2::new(3.5 / 8.0, 1.5 / 4.0);
            let v = m.lookup(uv);
            // RGBE keeps about 1 % precision.
            assert!(
                (v - Vec3::new(5.5, 2.0, 0.25)).abs().max_element() < 0.06,
                "{ext}: {v}"
            );
        }
        // 8-bit sRGB 128 → linear 0.2158.
        let png = dir.path().join("sky.png");
        image::RgbImage::from_pixel(w, h, image::Rgb([128, 128, 128]))
            .save(&png)
            .unwrap();
        let m = load(&png).unwrap();
        assert!((m.mean() - Vec3::splat(0.2158)).abs().max_element() < 1e-3);
        // Garbage and missing files name the path.
        let junk = dir.path().join("junk.exr");
        std::fs::write(&junk, b"not an image at all").unwrap();
        let e = load(&junk).unwrap_err();
        assert!(matches!(e, RenderError::BadInput { .. }), "{e}");
        assert!(e.to_string().contains("junk.exr"), "{e}");
        let e = load(&dir.path().join("missing.hdr")).unwrap_err();
        assert!(e.to_string().contains("missing.hdr"), "{e}");
    }

    #[test]
    fn a_map_over_the_pixel_limit_is_refused_from_its_header() {
        // A Radiance header declaring 65536 × 65536 pixels, and no pixel data.
        let bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 65536 +X 65536\n";
        let e = decode(Path::new("huge.hdr"), bytes).unwrap_err();
        assert!(matches!(e, RenderError::ResourceLimit { .. }), "{e}");
        assert!(e.to_string().contains("huge.hdr"), "{e}");
    }
}
