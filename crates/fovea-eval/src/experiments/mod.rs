//! The experiments that reproduce the papers' tables, as library functions: each takes the
//! scene (a [`fovea_render::world::World`] and camera, or a planned
//! [`fovea_render::sequence::Sequence`]) and a plain `…Params` struct (serde-serialisable, a
//! documented `Default`, `validate()` with typed errors), and returns a plain result struct
//! with its tables. `fovea` parses its options into these parameters, calls the function and
//! prints or writes the result; `fovea report` calls the same functions.
//!
//! | experiment | reproduces |
//! |---|---|
//! | [`bench`](mod@bench) | VaFR Sec. 6 / Table 1 speedups, Weier Table 1 per-stage timings, binocular Dup/Rep |
//! | [`dof_compare`] | Konrad et al. Sec. IV: DOF filters against a thin-lens reference; Liu Eq. 10–11 culling |
//! | [`flicker`] | peripheral temporal flicker with and without temporal accumulation (Weier 2018 Sec. 4) |
//! | [`inset`] | Liu et al., inset boundary smoothing, Sec. 4: the gradient-intensity table |
//! | [`periphery_flip`] | issue 38's "no magnified noise": ꟻLIP beyond 30° of denoised VaFR and the one-ray full frame |
//!
//! [`scenario`] holds the synthesised gaze scenarios and camera motion the sequences use.

use std::path::Path;

use fovea_core::Image;
use fovea_post::tonemap::{to_srgb8, ToneCurve};
use fovea_post::Rgb;

use crate::error::{EvalError, Result};

pub mod bench;
pub mod dof_compare;
pub mod flicker;
pub mod inset;
pub mod periphery_flip;
pub mod scenario;

/// Writes `img` as 8-bit sRGB PNG after the Reinhard tone curve (as `fovea render` writes
/// frames), whatever the extension, complete or not at all
/// ([`fovea_core::atomic_file::write_atomic`]).
pub fn write_png(path: &Path, img: &Image<Rgb>) -> Result<()> {
    let bytes = to_srgb8(img, 0.0, ToneCurve::Reinhard);
    let buf = image::RgbImage::from_raw(img.width(), img.height(), bytes)
        .ok_or_else(|| EvalError::io(path, "image buffer size"))?;
    let mut png = std::io::Cursor::new(Vec::new());
    buf.write_to(&mut png, image::ImageFormat::Png)
        .map_err(|e| EvalError::io(path, e))?;
    fovea_core::atomic_file::write_atomic(path, png.get_ref())
        .map_err(|e| EvalError::io(path, e.reason))
}

/// Creates `dir` and its parents.
pub fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|e| EvalError::io(dir, format!("cannot create the directory: {e}")))
}

/// Mean of the finite values (frames identical to the reference have an infinite PSNR and are
/// left out); 0 when there are none.
pub(crate) fn finite_mean(v: &[f64]) -> f64 {
    let (sum, n) = v
        .iter()
        .filter(|p| p.is_finite())
        .fold((0.0, 0u64), |(s, n), p| (s + p, n + 1));
    sum / n.max(1) as f64
}

/// Median of `v` (the upper one for an even count), sorting it; NaN when empty.
pub(crate) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The name of the invalid parameter `r` reports (tests of the parameter structs).
#[cfg(test)]
pub(crate) fn invalid_parameter(r: crate::error::Result<()>) -> String {
    match r {
        Err(crate::error::EvalError::InvalidParameter { name, .. }) => name,
        other => panic!("expected an invalid parameter, got {other:?}"),
    }
}
