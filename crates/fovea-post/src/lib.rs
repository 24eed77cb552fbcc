//! # fovea-post
//!
//! Image-space passes of the foveated frame (DESIGN.md stages 5–7):
//!
//! * [`grid`]: neighbour lookups in a sample buffer — clamped for screen-aligned buffers,
//!   angle-aligned and wrapping for polar (log-polar) buffers, so filters see no seam.
//! * [`contrast`]: peripheral contrast enhancement (Weier et al., after Patney et al.).
//! * [`denoise`]: edge-avoiding à-trous denoiser in sample space (SVGF, Schied et al. 2017).
//! * [`fxaa`]: FXAA inside the sample buffer (VaFR Sec. 6).
//! * [`gaussian_aa`]: the 3×3 Gaussian KFR applies in its LP buffer.
//! * [`inset_smoothing`]: high-res inset over an upsampled low-res periphery, with the
//!   boundary smoothing of Liu et al. (alpha blend, Gaussian, Gaussian + alpha, Laplacian).
//! * [`inverse_map`]: sample buffers back to screen pixels with filtered lookups.
//! * [`mip`]: 2×2-box mip pyramid with bilinear and Quincunx lookups (Weier et al.).
//! * [`pull_push`]: hole filling for sparse screen masks (Weier et al.).
//! * [`exposure`]: manual, EV100 and automatic exposure, with clipping and background shares.
//! * [`tonemap`]: exposure, tone curve and sRGB encoding.

#![allow(clippy::needless_range_loop)] // per-channel pixel loops read best indexed

pub mod alloc;
pub mod contrast;
pub mod denoise;
pub mod dof;
pub mod exposure;
pub mod fxaa;
pub mod gaussian_aa;
pub mod grid;
pub mod inset_smoothing;
pub mod inverse_map;
pub mod mip;
pub mod pull_push;
pub mod tonemap;

/// Linear RGB.
pub type Rgb = [f32; 3];

/// Rec. 601 luma of linear RGB.
#[inline]
pub fn luma(c: Rgb) -> f32 {
    0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2]
}

#[inline]
pub(crate) fn lerp3(a: Rgb, b: Rgb, t: f32) -> Rgb {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}
