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
use crate::error::{RenderError, Result};
use crate::scene::files::SceneFiles;
use crate::scene::limits::LoadLimits;
use crate::scene::texture::srgb_to_linear;

/// Reads and decodes an environment map file (a regular file of at most the default
/// [`LoadLimits::max_file_bytes`](crate::scene::LoadLimits); it may lie anywhere).
pub fn load(path: &Path) -> Result<EnvMap> {
    let files = SceneFiles::new(path, &LoadLimits::default())?;
    let bytes = files.read_scene_file()?;
    decode(path, &bytes)
}

/// Reads (within the load's limits, inside the scene's folder) and decodes an environment map
/// a scene names.
pub(crate) fn load_in(files: &SceneFiles, path: &Path) -> Result<EnvMap> {
    let bytes = files.read(path, None)?;
    decode(path, &bytes)
}

/// Decodes the bytes of the image file `path` (format from the content, else the extension).
pub fn decode(path: &Path, bytes: &[u8]) -> Result<EnvMap> {
    let reader = || -> Result<image::ImageReader<Cursor<&[u8]>>> {
        let mut r = image::ImageReader::new(Cursor::new(bytes));
        if let Ok(format) = image::ImageFormat::from_path(path) {
            r.set_format(format);
        }
        r.with_guessed_format()
            .map_err(|e| RenderError::io(path, &e))
    };
    let (w, h) = reader()?.into_dimensions().map_err(|e| {
        RenderError::bad(
            path,
            format!("cannot read the environment map's header: {e}"),
        )
    })?;
    if w as u64 * h as u64 > MAX_ENVMAP_PIXELS || w == 0 || h == 0 {
        if w == 0 || h == 0 {
            return Err(RenderError::bad(
                path,
                format!("the environment map is {w}x{h} pixels"),
            ));
        }
        return Err(RenderError::ResourceLimit {
            what: format!("environment map {}", path.display()),
            needed: format!("{w}x{h} pixels"),
            limit: format!("{MAX_ENVMAP_PIXELS} pixels (8192x4096)"),
        });
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(w);
    limits.max_image_height = Some(h);
    // RGBA f32 for the decoded image plus the decoder's own buffers.
    limits.max_alloc = Some(w as u64 * h as u64 * 16 * 3 + (64 << 20));
    let mut r = reader()?;
    r.limits(limits);
    let img = r
        .decode()
        .map_err(|e| RenderError::bad(path, format!("cannot decode environment map: {e}")))?;
    let linear = matches!(
        img.color(),
        image::ColorType::Rgb32F | image::ColorType::Rgba32F
    );
    let rgb = img.to_rgb32f();
    let mut bad_pixel = None;
    let pixels: Vec<Vec3> = rgb
        .pixels()
        .enumerate()
        .map(|(k, p)| {
            let c = Vec3::from_array(p.0);
            if !c.is_finite() {
                bad_pixel.get_or_insert((k, c));
                return Vec3::ZERO;
            }
            if linear {
                c.max(Vec3::ZERO)
            } else {
                Vec3::new(
                    srgb_to_linear(c.x),
                    srgb_to_linear(c.y),
                    srgb_to_linear(c.z),
                )
            }
        })
        .collect();
    if let Some((k, c)) = bad_pixel {
        return Err(RenderError::bad(
            path,
            format!(
                "environment map pixel ({}, {}) is {c}: radiance must be finite",
                k % w as usize,
                k / w as usize
            ),
        ));
    }
    let name = path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    EnvMap::new(&name, w, h, pixels)
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
