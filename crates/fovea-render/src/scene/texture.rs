//! Textures: decoded to linear RGBA `f32` with a box-filtered mip chain, sampled bilinearly
//! (repeat wrap) at a level of detail chosen from the sample's footprint (ray cones, see
//! `crate::trace`), so a sparse peripheral sample averages the texels it stands for instead of
//! aliasing (DESIGN.md, "the sample footprint").

use std::path::Path;

use glam::{Vec2, Vec4};

use super::files::SceneFiles;
use super::limits::LoadLimits;
use crate::error::{RenderError, Result};

/// Index of a texture in [`crate::scene::Scene::textures`].
pub type TextureId = u32;

/// One mip level.
#[derive(Clone, Debug)]
struct Level {
    width: u32,
    height: u32,
    texels: Vec<Vec4>,
}

/// A decoded texture with its mip chain.
#[derive(Clone, Debug)]
pub struct Texture {
    /// Name (file name or glTF image name).
    pub name: String,
    levels: Vec<Level>,
}

/// Below this fraction of a mip level [`Texture::sample`] reads one level, no trilinear blend
/// (also `crate::trace::model::TRILINEAR_MIN_FRACTION`, which another executor uploads).
pub const TRILINEAR_MIN_FRACTION: f32 = 1e-3;

/// Largest accepted texture side (a 64k × 64k RGBA f32 texture would be 64 GiB).
pub const MAX_TEXTURE_SIDE: u32 = 16384;
/// Bytes a texture takes per base-level texel while it is built: the decoded image (up to
/// RGBA f32, 16), its linear RGBA f32 base level (16) and the mip chain above it (a third
/// more, 6), rounded up.
pub const TEXTURE_BYTES_PER_TEXEL: u64 = 40;

/// sRGB → linear (IEC 61966-2-1).
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Texture {
    /// A texture from linear RGBA texels, row-major from the top row.
    pub fn from_linear(name: &str, width: u32, height: u32, texels: Vec<Vec4>) -> Result<Self> {
        if width == 0 || height == 0 || texels.len() != width as usize * height as usize {
            return Err(RenderError::invalid(
                "texture",
                format!("{name} {width}x{height} with {} texels", texels.len()),
                "width·height texels, both sides ≥ 1",
            ));
        }
        if width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE {
            return Err(RenderError::ResourceLimit {
                what: format!("texture {name}"),
                needed: format!("{width}x{height}"),
                limit: format!("{MAX_TEXTURE_SIDE} texels per side"),
            });
        }
        let mut levels = vec![Level {
            width,
            height,
            texels,
        }];
        while let Some(last) = levels.last() {
            if last.width == 1 && last.height == 1 {
                break;
            }
            let (w, h) = ((last.width / 2).max(1), (last.height / 2).max(1));
            let mut t = Vec::with_capacity(w as usize * h as usize);
            for y in 0..h {
                for x in 0..w {
                    let mut acc = Vec4::ZERO;
                    let mut n = 0.0;
                    for dy in 0..2 {
                        for dx in 0..2 {
                            let sx = (2 * x + dx).min(last.width - 1);
                            let sy = (2 * y + dy).min(last.height - 1);
                            acc += last.texels[(sy * last.width + sx) as usize];
                            n += 1.0;
                        }
                    }
                    t.push(acc / n);
                }
            }
            levels.push(Level {
                width: w,
                height: h,
                texels: t,
            });
        }
        Ok(Self {
            name: name.into(),
            levels,
        })
    }

    /// Decodes an image (any 8/16-bit format `image` reads). `srgb`: colour data (base colour)
    /// is sRGB-encoded and decoded to linear; data maps (normals, roughness) are not.
    pub fn from_image(name: &str, img: image::DynamicImage, srgb: bool) -> Result<Self> {
        let (w, h) = (img.width(), img.height());
        if w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE {
            return Err(RenderError::ResourceLimit {
                what: format!("texture {name}"),
                needed: format!("{w}x{h}"),
                limit: format!("{MAX_TEXTURE_SIDE} texels per side"),
            });
        }
        let rgba = img.to_rgba32f();
        let texels = rgba
            .pixels()
            .map(|p| {
                let c = p.0;
                if srgb {
                    Vec4::new(
                        srgb_to_linear(c[0]),
                        srgb_to_linear(c[1]),
                        srgb_to_linear(c[2]),
                        c[3],
                    )
                } else {
                    Vec4::from_array(c)
                }
            })
            .collect();
        Self::from_linear(name, w, h, texels)
    }

    /// Reads and decodes an image file (a regular file of at most
    /// [`DEFAULT_MAX_FILE_BYTES`](super::limits::DEFAULT_MAX_FILE_BYTES)).
    pub fn load(path: &Path, srgb: bool) -> Result<Self> {
        let files = SceneFiles::new(path, &LoadLimits::default())?;
        let bytes = files.read_scene_file()?;
        Self::decode_file(path, &bytes, srgb)
    }

    /// Reads (within the load's limits, inside the scene's folder) and decodes an image file
    /// a scene names.
    /// A texture whose decoding and mip chain would take more than half of the load's
    /// `max_memory_bytes` ([`TEXTURE_BYTES_PER_TEXEL`] a texel, from the header's size) is
    /// refused before it is decoded (the loaders then use the flat colour, with a warning).
    pub(crate) fn load_in(files: &SceneFiles, path: &Path, srgb: bool) -> Result<Self> {
        let bytes = files.read(path, None)?;
        let budget = files.limits().max_memory_bytes / 2;
        if budget < u64::MAX / 2 {
            let mut reader = image::ImageReader::new(std::io::Cursor::new(&bytes[..]));
            if let Ok(format) = image::ImageFormat::from_path(path) {
                reader.set_format(format);
            }
            if let Ok((w, h)) = reader
                .with_guessed_format()
                .map_err(|e| RenderError::io(path, &e))?
                .into_dimensions()
            {
                let needed = u64::from(w) * u64::from(h) * TEXTURE_BYTES_PER_TEXEL;
                if needed > budget {
                    return Err(RenderError::ResourceLimit {
                        what: format!("texture {}", path.display()),
                        needed: format!("{} MiB for {w}x{h} texels", needed.div_ceil(1 << 20)),
                        limit: format!("half of --max-memory, {} MiB", budget >> 20),
                    });
                }
            }
        }
        Self::decode_file(path, &bytes, srgb)
    }

    /// Decodes the bytes of the image file `path`: the format is recognised from the content,
    /// else from the file's extension.
    fn decode_file(path: &Path, bytes: &[u8], srgb: bool) -> Result<Self> {
        let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes));
        if let Ok(format) = image::ImageFormat::from_path(path) {
            reader.set_format(format);
        }
        let img = reader
            .with_guessed_format()
            .map_err(|e| RenderError::io(path, &e))?
            .decode()
            .map_err(|e| RenderError::bad(path, format!("cannot decode image: {e}")))?;
        let name = path
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        Self::from_image(&name, img, srgb)
    }

    /// Width of the base level.
    pub fn width(&self) -> u32 {
        self.levels[0].width
    }

    /// Height of the base level.
    pub fn height(&self) -> u32 {
        self.levels[0].height
    }

    /// Number of mip levels.
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Mip level `level` (0: the base level; up to [`Self::level_count`] − 1): its width,
    /// height and linear RGBA texels, row-major from the top row; `None` past the last.
    pub fn level(&self, level: usize) -> Option<(u32, u32, &[Vec4])> {
        self.levels
            .get(level)
            .map(|l| (l.width, l.height, l.texels.as_slice()))
    }

    /// Bilinear lookup with repeat wrap at `uv` in mip level `lod` (fractional: trilinear).
    /// `lod = 0` is the base level; `lod = log2(texels per sample footprint)`.
    pub fn sample(&self, uv: Vec2, lod: f32) -> Vec4 {
        let max = (self.levels.len() - 1) as f32;
        let lod = if lod.is_finite() {
            lod.clamp(0.0, max)
        } else {
            0.0
        };
        let l0 = lod.floor() as usize;
        let f = lod - l0 as f32;
        let a = self.bilinear(l0, uv);
        if f > TRILINEAR_MIN_FRACTION && l0 + 1 < self.levels.len() {
            a.lerp(self.bilinear(l0 + 1, uv), f)
        } else {
            a
        }
    }

    fn bilinear(&self, level: usize, uv: Vec2) -> Vec4 {
        let l = &self.levels[level];
        let x = uv.x * l.width as f32 - 0.5;
        let y = uv.y * l.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return l.texels[0];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let wrap = |v: i64, n: u32| v.rem_euclid(n as i64) as u32;
        let (xi, yi) = (x0 as i64, y0 as i64);
        let (xa, xb) = (wrap(xi, l.width), wrap(xi + 1, l.width));
        let (ya, yb) = (wrap(yi, l.height), wrap(yi + 1, l.height));
        let t = |x: u32, y: u32| l.texels[(y * l.width + x) as usize];
        let top = t(xa, ya).lerp(t(xb, ya), fx);
        let bot = t(xa, yb).lerp(t(xb, yb), fx);
        top.lerp(bot, fy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn mip_chain_preserves_the_mean_and_coarsest_level_is_the_average() {
        let (w, h) = (8, 4);
        let texels: Vec<Vec4> = (0..w * h)
            .map(|i| Vec4::splat(((i % 3) as f32) / 2.0))
            .collect();
        let mean = texels.iter().copied().sum::<Vec4>() / texels.len() as f32;
        let t = Texture::from_linear("t", w, h, texels).unwrap();
        assert_eq!(t.level_count(), 4);
        let top = t.sample(Vec2::new(0.3, 0.7), 10.0);
        assert!((top - mean).abs().max_element() < 1e-6);
    }

    #[test]
    fn bilinear_wraps_and_hits_texel_centres() {
        let texels = vec![Vec4::ZERO, Vec4::ONE];
        let t = Texture::from_linear("t", 2, 1, texels).unwrap();
        assert_eq!(t.sample(Vec2::new(0.25, 0.5), 0.0), Vec4::ZERO);
        assert_eq!(t.sample(Vec2::new(0.75, 0.5), 0.0), Vec4::ONE);
        // Half-way across the wrap seam.
        assert!(
            (t.sample(Vec2::new(1.0, 0.5), 0.0) - Vec4::splat(0.5))
                .abs()
                .max_element()
                < 1e-6
        );
        assert!(Texture::from_linear("bad", 2, 2, vec![Vec4::ZERO]).is_err());
    }
}
