//! # fovea-core
//!
//! Units, display profiles, acuity models, eye optics and every foveation mapping of the fovea
//! toolkit, with no heavy dependencies so an engine can take just this crate.
//!
//! * [`display`]: per-eye display geometry, presets, VaFR Eq. 3.
//! * [`acuity`]: MAR models (VaFR Eq. 2, 12, 19) and headset caps.
//! * [`mapping`]: VaFR, KFR/LMFR, LaFR, visual-polar, Guenter layers, insets, Weier's sparse
//!   sampling and full resolution, each a forward/inverse/shading-rate triple.
//! * [`optics`]: the thin-lens eye (Liu Eq. 4–13, Weier Eq. 3) and pupil models.
//! * [`analysis`]: sample-count tables and shading-rate curves for reports.

pub mod acuity;
pub mod analysis;
pub mod display;
pub mod error;
pub mod mapping;
pub mod math;
pub mod optics;
pub mod units;

pub use error::{FoveaError, Result};
