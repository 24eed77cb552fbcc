//! Writing frames: PNG (8-bit sRGB after exposure and tone curve) or OpenEXR (linear float),
//! chosen by the file extension, plus false-colour views of depth and sample density.

use std::path::Path;

use anyhow::{bail, Context, Result};
use fovea_core::Image;
use fovea_post::tonemap::{to_srgb8, ToneCurve, ToneMapExecutor};
use fovea_post::Rgb;

/// `left` and `right` (the same size) next to each other.
pub fn side_by_side<T: Copy>(left: &Image<T>, right: &Image<T>) -> Result<Image<T>> {
    let (w, h) = (left.width(), left.height());
    if (right.width(), right.height()) != (w, h) {
        bail!(
            "side by side: {w}x{h} and {}x{} differ",
            right.width(),
            right.height()
        );
    }
    let mut data = Vec::with_capacity(2 * w as usize * h as usize);
    for y in 0..h {
        data.extend_from_slice(left.row(y));
        data.extend_from_slice(right.row(y));
    }
    Ok(Image::from_vec(2 * w, h, data)?)
}

/// A `size × size` crop of `img` centred on `(cx, cy)` (moved inside the image where it would
/// cross an edge; smaller where the image is), enlarged `zoom` times by pixel replication so
/// that single pixels stay visible.
pub fn zoomed_crop(img: &Image<Rgb>, cx: f64, cy: f64, size: u32, zoom: u32) -> Result<Image<Rgb>> {
    let (w, h) = (img.width(), img.height());
    let (sw, sh) = (size.min(w).max(1), size.min(h).max(1));
    let x0 = ((cx - sw as f64 / 2.0).round().max(0.0) as u32).min(w - sw);
    let y0 = ((cy - sh as f64 / 2.0).round().max(0.0) as u32).min(h - sh);
    let zoom = zoom.max(1);
    let mut data = Vec::with_capacity((sw * zoom) as usize * (sh * zoom) as usize);
    for y in 0..sh * zoom {
        for x in 0..sw * zoom {
            data.push(*img.get(x0 + x / zoom, y0 + y / zoom));
        }
    }
    Ok(Image::from_vec(sw * zoom, sh * zoom, data)?)
}

/// Draws a ring of radius `r_px`, about 2 pixels wide, centred on `(x, y)` into `img`, in
/// `colour` (linear RGB), so a viewer can find the gaze point.
pub fn mark_ring(img: &mut Image<Rgb>, x: f64, y: f64, r_px: f64, colour: Rgb) {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let reach = (r_px + 2.0).ceil() as i64;
    let (xi, yi) = (x.floor() as i64, y.floor() as i64);
    for py in (yi - reach).max(0)..(yi + reach + 1).min(h) {
        for px in (xi - reach).max(0)..(xi + reach + 1).min(w) {
            let d = (px as f64 + 0.5 - x).hypot(py as f64 + 0.5 - y);
            if (d - r_px).abs() <= 1.0 {
                *img.get_mut(px as u32, py as u32) = colour;
            }
        }
    }
}

/// The difference of two frames as the viewer sees them: the absolute difference of their
/// display luma (the Reinhard curve, then sRGB encoding, as the PNGs), times `gain`, as a
/// heat map from black through red and yellow to white (linear RGB, to be written with the
/// clamp curve). Also returns the mean absolute display-luma difference (0–1, before the gain).
pub fn difference_map(a: &Image<Rgb>, b: &Image<Rgb>, gain: f32) -> Result<(Image<Rgb>, f64)> {
    if (a.width(), a.height()) != (b.width(), b.height()) {
        bail!(
            "difference: {}x{} and {}x{} differ",
            a.width(),
            a.height(),
            b.width(),
            b.height()
        );
    }
    let display = |c: &Rgb| {
        let l = fovea_post::luma(*c).max(0.0);
        fovea_post::tonemap::linear_to_srgb(l / (1.0 + l))
    };
    let mut sum = 0.0f64;
    let data: Vec<Rgb> = a
        .data()
        .iter()
        .zip(b.data())
        .map(|(p, q)| {
            let d = (display(p) - display(q)).abs();
            sum += d as f64;
            let t = (d * gain).clamp(0.0, 1.0) * 3.0;
            let enc = [
                t.min(1.0),
                (t - 1.0).clamp(0.0, 1.0),
                (t - 2.0).clamp(0.0, 1.0),
            ];
            enc.map(fovea_post::tonemap::srgb_to_linear)
        })
        .collect();
    let n = data.len().max(1) as f64;
    Ok((Image::from_vec(a.width(), a.height(), data)?, sum / n))
}

fn ensure_parent(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create directory {}", dir.display()))?;
        }
    }
    Ok(())
}

fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default()
}

/// Checks that `path` names a format we write.
pub fn check_image_path(path: &Path) -> Result<()> {
    match extension(path).as_str() {
        "png" | "exr" => Ok(()),
        _ => bail!(
            "invalid parameter `out` = {}: expected a .png (8-bit sRGB) or .exr (linear float) file",
            path.display()
        ),
    }
}

/// Writes a linear RGB image.
pub fn write_rgb(path: &Path, img: &Image<Rgb>, exposure: f32, curve: ToneCurve) -> Result<()> {
    write_rgb_on(path, img, exposure, curve, None)
}

/// Writes a linear RGB image, its 8-bit encoding (exposure, tone curve, sRGB) on `tone_map`
/// when given (e.g. the GPU's: `--backend`), else on the CPU.
pub fn write_rgb_on(
    path: &Path,
    img: &Image<Rgb>,
    exposure: f32,
    curve: ToneCurve,
    tone_map: Option<&mut (dyn ToneMapExecutor + 'static)>,
) -> Result<()> {
    check_image_path(path)?;
    ensure_parent(path)?;
    let (w, h) = (img.width(), img.height());
    let bytes = match extension(path).as_str() {
        "exr" => {
            let data: Vec<f32> = img.data().iter().flat_map(|c| *c).collect();
            let buf = image::Rgb32FImage::from_raw(w, h, data).context("image size")?;
            encode(path, |c| buf.write_to(c, image::ImageFormat::OpenExr))?
        }
        _ => {
            let bytes = encode_srgb8(img, exposure, curve, tone_map)?;
            png_bytes(path, w, h, bytes)?
        }
    };
    write_file(path, &bytes)
}

/// Writes `bytes` to `path` complete or not at all (a temporary file in the same folder,
/// flushed, synced and renamed: [`fovea_core::atomic_file`]); the error names `path`.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    Ok(fovea_core::atomic_file::write_atomic(path, bytes)?)
}

/// `rgb8` (`w × h`, 3 bytes a pixel) encoded as PNG in memory (for [`write_file`]); `path`
/// names the file in errors.
pub fn png_bytes(path: &Path, w: u32, h: u32, rgb8: Vec<u8>) -> Result<Vec<u8>> {
    let buf = image::RgbImage::from_raw(w, h, rgb8).context("image size")?;
    encode(path, |c| buf.write_to(c, image::ImageFormat::Png))
}

/// The bytes `write` encodes into memory; its error names `path`.
fn encode(
    path: &Path,
    write: impl FnOnce(&mut std::io::Cursor<Vec<u8>>) -> image::ImageResult<()>,
) -> Result<Vec<u8>> {
    let mut c = std::io::Cursor::new(Vec::new());
    write(&mut c).with_context(|| format!("cannot encode {}", path.display()))?;
    Ok(c.into_inner())
}

/// `img`'s 8-bit sRGB bytes through `exposure` and `curve`, on `tone_map` when given.
pub fn encode_srgb8(
    img: &Image<Rgb>,
    exposure: f32,
    curve: ToneCurve,
    tone_map: Option<&mut (dyn ToneMapExecutor + 'static)>,
) -> Result<Vec<u8>> {
    match tone_map {
        Some(t) => t
            .to_srgb8(img, exposure, curve)
            .map_err(|e| anyhow::anyhow!("tone map on the {}: {e}", t.backend())),
        None => Ok(to_srgb8(img, exposure, curve)),
    }
}

/// A perceptual-ish false-colour ramp (dark blue → cyan → yellow → white) for `t` in [0, 1].
fn ramp(t: f32) -> [f32; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let stops = [
        [0.02, 0.02, 0.15],
        [0.1, 0.3, 0.8],
        [0.1, 0.8, 0.8],
        [0.95, 0.85, 0.2],
        [1.0, 1.0, 1.0],
    ];
    let x = t * 4.0;
    let k = (x.floor() as usize).min(3);
    let f = x - k as f32;
    let (a, b) = (stops[k], stops[k + 1]);
    [
        a[0] + (b[0] - a[0]) * f,
        a[1] + (b[1] - a[1]) * f,
        a[2] + (b[2] - a[2]) * f,
    ]
}

/// Writes a scalar view: EXR keeps raw values (R = G = B); PNG maps `log10` of the value over
/// `[lo, hi]` through a colour ramp (non-finite values black).
pub fn write_scalar(path: &Path, img: &Image<f32>, lo: f32, hi: f32) -> Result<()> {
    check_image_path(path)?;
    if extension(path) == "exr" {
        let rgb = img.map(|&v| [v, v, v]);
        return write_rgb(path, &rgb, 0.0, ToneCurve::Clamp);
    }
    let (l0, l1) = (lo.max(1e-6).log10(), hi.max(lo * 1.0001).log10());
    let rgb = img.map(|&v| {
        if !v.is_finite() || v <= 0.0 {
            [0.0; 3]
        } else {
            // The ramp is in display space: undo sRGB so the PNG shows the ramp's values.
            ramp((v.log10() - l0) / (l1 - l0)).map(fovea_render::scene::texture::srgb_to_linear)
        }
    });
    write_rgb(path, &rgb, 0.0, ToneCurve::Clamp)
}

/// `t` as HTML text or attribute value: `&`, `<`, `>` and `"` escaped (the report's and the
/// demo page's pages quote adapter names, scene paths and messages).
pub fn html_escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
