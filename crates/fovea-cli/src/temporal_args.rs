//! Options of temporal accumulation and peripheral contrast, shared by `fovea sequence` and
//! `fovea flicker`.

use anyhow::Result;
use clap::Args;

use fovea_post::contrast::PeripheralContrast;
use fovea_render::temporal::TemporalSettings;

use crate::choices::Switch;

/// Temporal accumulation options.
#[derive(Args, Debug, Clone)]
pub struct TemporalArgs {
    /// Smallest weight of the new frame in the running estimate (about 1/frames averaged).
    #[arg(long, default_value_t = 0.1)]
    pub alpha_min: f32,
    /// Relative depth difference from which reprojected history is rejected (fully at 2×).
    #[arg(long, default_value_t = 0.03)]
    pub depth_tolerance: f32,
    /// Sub-texel jitter of the samples in sample space: on or off (never for weier; off by
    /// default: in motion it adds more peripheral change than accumulation removes).
    #[arg(long, value_enum, ignore_case = true, default_value_t = Switch::Off)]
    pub jitter: Switch,
    /// Clamp history to the new samples' 3×3 colour range: on or off.
    #[arg(long, value_enum, ignore_case = true, default_value_t = Switch::On)]
    pub history_clamp: Switch,
    /// Peripheral contrast enhancement gain (Weier/Patney; 0 = off; e.g. 0.5).
    #[arg(long, default_value_t = 0.0)]
    pub peripheral_contrast: f32,
}

impl TemporalArgs {
    /// The accumulation settings (validated).
    pub fn settings(&self) -> Result<TemporalSettings> {
        let s = TemporalSettings {
            alpha_min: self.alpha_min,
            depth_tolerance: self.depth_tolerance,
            jitter: self.jitter.is_on(),
            clamp: self.history_clamp.is_on(),
            variance: true,
        };
        s.validate()?;
        Ok(s)
    }

    /// The contrast enhancement, if a gain was given.
    pub fn contrast(&self) -> Result<Option<PeripheralContrast>> {
        if self.peripheral_contrast == 0.0 {
            return Ok(None);
        }
        let c = PeripheralContrast {
            gain: self.peripheral_contrast,
            ..Default::default()
        };
        c.validate()?;
        Ok(Some(c))
    }
}
