//! Argument parsing shared by the subcommands: displays, gazes, methods.

use anyhow::{Context, Result};
use clap::Args;
use fovea_core::acuity::AcuityModel;
use fovea_core::display::{parse_resolution, DisplayProfile, Gaze};
use fovea_core::units::Degrees;

/// Which display to use: a preset or a resolution with a field of view.
#[derive(Args, Debug, Clone)]
pub struct DisplayArgs {
    /// Headset or test-resolution preset: vive-pro-eye, pimax-crystal, varjo-xr4, 2k, 4k, 6k,
    /// 8k, retinal.
    #[arg(long, conflicts_with = "res")]
    pub headset: Option<String>,
    /// Custom per-eye resolution WxH (square pixels), e.g. 1920x1080.
    #[arg(long)]
    pub res: Option<String>,
    /// Vertical field of view in degrees for --res.
    #[arg(long, default_value_t = 90.0)]
    pub vfov: f64,
}

impl DisplayArgs {
    /// The chosen display; `default` when neither --headset nor --res is given.
    pub fn display(&self, default: &str) -> Result<DisplayProfile> {
        if let Some(r) = &self.res {
            let (w, h) = parse_resolution(r)?;
            Ok(DisplayProfile::with_vertical_fov(
                r.clone(),
                w,
                h,
                Degrees(self.vfov),
            )?)
        } else {
            Ok(DisplayProfile::preset(
                self.headset.as_deref().unwrap_or(default),
            )?)
        }
    }
}

/// Parses `X,Y` in pixels; `None` text gives the screen centre.
pub fn parse_gaze(display: &DisplayProfile, text: Option<&str>) -> Result<Gaze> {
    let Some(t) = text else {
        return Ok(display.centre_gaze());
    };
    let parts: Vec<&str> = t.split(',').map(str::trim).collect();
    let bad = || {
        anyhow::anyhow!(
            "invalid parameter `gaze` = {t}: expected X,Y in pixels, e.g. --gaze 1280,720"
        )
    };
    if parts.len() != 2 {
        return Err(bad());
    }
    let x: f64 = parts[0].parse().map_err(|_| bad())?;
    let y: f64 = parts[1].parse().map_err(|_| bad())?;
    Ok(display.gaze(x, y)?)
}

/// Parses `--pivots ECC:CPD,…` or the default VaFR pivots.
pub fn acuity(pivots: Option<&str>) -> Result<AcuityModel> {
    match pivots {
        Some(p) => AcuityModel::parse_pivots(p).context("reading --pivots"),
        None => Ok(AcuityModel::vafr_default()),
    }
}

/// Formats an integer with thousands separators.
pub fn thousands(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thousands_separators() {
        assert_eq!(thousands(1_061_734), "1,061,734");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(0), "0");
    }
}
