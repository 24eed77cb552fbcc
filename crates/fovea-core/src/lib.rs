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
//! * [`atomic_file`]: every output file written complete or not at all (temporary name,
//!   flush, fsync, rename).
//! * [`fidelity`]: how coarse a mapping's texels are against the acuity model at every
//!   pixel's true eccentricity, for any gaze.
//! * [`gaze`]: gaze trajectories per frame, from eye-tracker CSV or synthesised (fixations,
//!   main-sequence saccades, smooth pursuit, Gaussian-velocity random walk).
//!
//! ```
//! use fovea_core::display::DisplayProfile;
//! use fovea_core::mapping::{build, FoveationMapping, MappingConfig, Method};
//! use fovea_core::units::ScreenPoint;
//!
//! # fn main() -> fovea_core::Result<()> {
//! let display = DisplayProfile::preset("vive-pro-eye")?;
//! let gaze = display.gaze(700.0, 820.0)?;
//! let vafr = build(Method::Vafr, &display, gaze, &MappingConfig::default())?;
//! let lp = vafr.forward(ScreenPoint::new(900.0, 600.0)).unwrap(); // screen → LP buffer
//! let back = vafr.inverse(lp).unwrap(); // LP buffer → screen
//! assert!(back.distance(ScreenPoint::new(900.0, 600.0)) < 1e-6);
//! println!("{} samples, {:.2} cpd at 20°", vafr.sample_count(), vafr.radial_rate_cpd(20.0));
//! # Ok(())
//! # }
//! ```

pub mod acuity;
pub mod analysis;
pub mod atomic_file;
pub mod display;
pub mod error;
pub mod fidelity;
pub mod gaze;
pub mod image;
pub mod mapping;
pub mod math;
pub mod optics;
pub mod units;

pub use error::{FoveaError, Result};
pub use image::Image;
