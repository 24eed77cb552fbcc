//! Images: where an image's bytes come from (a buffer view, a `data:` URI or a file) and
//! decoding (PNG and JPEG, at most `MAX_TEXTURE_SIDE` texels a side) into a linear texture,
//! sRGB-decoded for colour, through a lookup table for 8-bit images.

use std::borrow::Cow;
use std::path::Path;

use glam::Vec4;

use super::accessor::view_bytes;
use super::uri::read_uri;
use super::Msg;
use crate::error::Result;
use crate::scene::files::SceneFiles;
use crate::scene::texture::{srgb_to_linear, MAX_TEXTURE_SIDE};
use crate::scene::Texture;

/// The name of an image (its own, else its URI, else `image i`) and its encoded bytes, from a
/// buffer view, a `data:` URI or a file beside the glTF (`base`), or why they are missing.
pub(super) fn image_source<'b>(
    files: &SceneFiles,
    image: &::gltf::Image,
    base: &Path,
    buffers: &'b [Vec<u8>],
) -> (String, Msg<Cow<'b, [u8]>>) {
    let i = image.index();
    match image.source() {
        ::gltf::image::Source::View { view, .. } => (
            image
                .name()
                .map(str::to_owned)
                .unwrap_or_else(|| format!("image {i}")),
            view_bytes(&view, buffers).map(Cow::Borrowed),
        ),
        ::gltf::image::Source::Uri { uri, .. } => {
            let name = match image.name() {
                Some(n) => n.to_owned(),
                None if uri.starts_with("data:") => format!("image {i}"),
                None => uri.to_owned(),
            };
            let bytes = read_uri(files, base, uri, None)
                .map(Cow::Owned)
                .map_err(|e| e.to_string());
            (name, bytes)
        }
    }
}

/// Decodes PNG/JPEG bytes into a texture (sRGB → linear when `srgb`).
pub(super) fn decode_texture(name: &str, bytes: &[u8], srgb: bool) -> Msg<Texture> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    if reader.format().is_none() {
        return Err("unrecognised image format (PNG and JPEG are read)".into());
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    reader.limits(limits);
    let img = reader.decode().map_err(|e| format!("cannot decode: {e}"))?;
    texture_from_image(name, img, srgb).map_err(|e| e.to_string())
}

/// Like [`Texture::from_image`], with a lookup table for 8-bit images (the common case),
/// which is several times faster than converting through `f32` and `powf`.
fn texture_from_image(name: &str, img: image::DynamicImage, srgb: bool) -> Result<Texture> {
    use image::DynamicImage as D;
    if !matches!(
        img,
        D::ImageLuma8(_) | D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_)
    ) {
        return Texture::from_image(name, img, srgb);
    }
    let lut: [f32; 256] = std::array::from_fn(|i| {
        let c = i as f32 / 255.0;
        if srgb {
            srgb_to_linear(c)
        } else {
            c
        }
    });
    let (w, h) = (img.width(), img.height());
    let rgba = img.into_rgba8();
    let texels = rgba
        .pixels()
        .map(|p| {
            let [r, g, b, a] = p.0;
            Vec4::new(
                lut[r as usize],
                lut[g as usize],
                lut[b as usize],
                f32::from(a) / 255.0,
            )
        })
        .collect();
    Texture::from_linear(name, w, h, texels)
}
