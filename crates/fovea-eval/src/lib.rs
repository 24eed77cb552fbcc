//! # fovea-eval
//!
//! Metrics that compare a rendered frame with a reference, over the whole image or a region:
//!
//! * [`metrics::luma_psnr`]: PSNR of display-encoded luma (the papers' "luma PSNR");
//! * [`metrics::flip_mean`]: mean ꟻLIP error (Andersson et al. 2020, NVIDIA's reference
//!   implementation through the `nv-flip` crate) at the display's pixels per degree;
//! * [`gradient_intensity::gradient_areas`]: Sobel gradient intensity in four areas across an
//!   inset boundary (Liu et al., inset boundary smoothing, Sec. 4);
//! * [`bands::band_quality`]: PSNR, SSIM, ꟻLIP and samples per pixel by eccentricity band;
//! * [`reference`]: the shading the measurements score (a viewer's by default), their
//!   converged reference and its noise floor (two seeds scored against each other);
//! * [`bands::masked_flip`]: ꟻLIP over one band of eccentricity (e.g. beyond 30°);
//! * [`flicker::FlickerMeter`]: temporal flicker of a sequence against the full-resolution
//!   sequence, by eccentricity band.
//!
//! And the experiments built on them ([`experiments`]): the speed harness, the DOF filter
//! comparison, the flicker measurement and the inset analysis, each a function of a scene
//! and a plain parameter struct.

pub mod bands;
pub mod error;
pub mod experiments;
pub mod flicker;
pub mod gradient_intensity;
pub mod metrics;
pub mod reference;
pub mod ssim;

pub use error::{EvalError, Result};
