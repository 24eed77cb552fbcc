//! Analyses that reports and the CLI print: samples per eye for every method and resolution
//! (VaFR Table 1) and shading-rate curves against eccentricity (VaFR Figs. 5, 8–10, 21).

use serde::Serialize;

use crate::acuity::AcuityModel;
use crate::display::{DisplayProfile, Gaze};
use crate::error::Result;
use crate::mapping::{build, BufferSize, MappingConfig, Method};
use crate::units::Degrees;

/// One method with its parameters and a label for tables and legends (e.g. `LaFR(2.2)`).
#[derive(Clone, Debug)]
pub struct MethodEntry {
    /// The method.
    pub method: Method,
    /// Its parameters (only the method's own field is used).
    pub config: MappingConfig,
    /// Legend / table label.
    pub label: String,
}

impl MethodEntry {
    /// An entry with default parameters labelled by the method name.
    pub fn plain(method: Method) -> Self {
        Self {
            method,
            config: MappingConfig::default(),
            label: method.name().to_string(),
        }
    }

    /// VaFR as the paper sizes it: a fixed 60° buffer (Sec. 3.2.2), 1,061,735 samples per
    /// eye (Fig. 4), leaving screen points beyond 60° without samples.
    pub fn vafr_paper() -> Self {
        Self {
            method: Method::Vafr,
            config: MappingConfig {
                vafr: crate::mapping::VafrParams::paper(),
                ..Default::default()
            },
            label: "vafr(60°)".into(),
        }
    }

    /// KFR/LMFR with reduction ratio `delta`.
    pub fn kfr(delta: f64) -> Self {
        let mut config = MappingConfig::default();
        config.kfr.delta = delta;
        Self {
            method: Method::Kfr,
            config,
            label: format!("kfr({delta})"),
        }
    }

    /// LaFR with reduction ratio `delta`.
    pub fn lafr(delta: f64) -> Self {
        let mut config = MappingConfig::default();
        config.lafr.delta = delta;
        Self {
            method: Method::Lafr,
            config,
            label: format!("lafr({delta})"),
        }
    }
}

/// The methods of the default table: the ground truth, VaFR (covering the whole screen, and
/// the paper's 60° buffer), LMFR(1.8), LaFR(1.8), LaFR(2.2) (VaFR Table 1's columns) and the
/// other mappings with their defaults.
pub fn default_entries() -> Vec<MethodEntry> {
    vec![
        MethodEntry::plain(Method::Full),
        MethodEntry::plain(Method::Vafr),
        MethodEntry::vafr_paper(),
        MethodEntry::kfr(1.8),
        MethodEntry::lafr(1.8),
        MethodEntry::lafr(2.2),
        MethodEntry::plain(Method::VisualPolar),
        MethodEntry::plain(Method::Guenter),
        MethodEntry::plain(Method::Inset),
        MethodEntry::plain(Method::Weier),
    ]
}

/// One row of the samples table.
#[derive(Clone, Debug, Serialize)]
pub struct TableRow {
    /// Lower-case method name (`vafr`, `kfr`, `lafr`, `full`, …).
    pub method: String,
    /// Label with the distinguishing parameter, e.g. `lafr(2.2)`.
    pub label: String,
    /// Display profile name.
    pub display: String,
    /// Display width per eye, pixels.
    pub width: u32,
    /// Display height per eye, pixels.
    pub height: u32,
    /// Samples shaded per eye per frame.
    pub samples: u64,
    /// `samples / (width·height)`.
    pub fraction_of_full: f64,
    /// Sample buffers.
    pub buffers: Vec<BufferSize>,
    /// Method parameters.
    pub params: serde_json::Value,
    /// Gaze point used, pixels.
    pub gaze: [f64; 2],
}

/// Samples per eye of every entry at every display, for one normalised gaze position
/// (`gaze_frac` = (0.5, 0.5) is the screen centre).
pub fn sample_table(
    displays: &[DisplayProfile],
    entries: &[MethodEntry],
    gaze_frac: (f64, f64),
) -> Result<Vec<TableRow>> {
    let mut rows = Vec::new();
    for d in displays {
        let g = d.gaze(
            gaze_frac.0 * d.width_px as f64,
            gaze_frac.1 * d.height_px as f64,
        )?;
        for e in entries {
            let m = build(e.method, d, g, &e.config)?;
            let samples = m.sample_count();
            rows.push(TableRow {
                method: e.method.name().to_string(),
                label: e.label.clone(),
                display: d.name.clone(),
                width: d.width_px,
                height: d.height_px,
                samples,
                fraction_of_full: samples as f64 / d.pixel_count() as f64,
                buffers: m.buffers(),
                params: m.params(),
                gaze: [g.point.x_px, g.point.y_px],
            });
        }
    }
    Ok(rows)
}

/// Radial and tangential shading rate of one method.
#[derive(Clone, Debug, Serialize)]
pub struct Curve {
    /// Legend label.
    pub label: String,
    /// Radial rate (cpd) at each eccentricity of [`CurveSet::eccentricity_deg`].
    pub radial_cpd: Vec<f64>,
    /// Tangential rate (cpd).
    pub tangential_cpd: Vec<f64>,
}

/// Shading-rate curves with the acuity model and the display's own rate.
#[derive(Clone, Debug, Serialize)]
pub struct CurveSet {
    /// Display name.
    pub display: String,
    /// Display resolution.
    pub width: u32,
    /// Display resolution.
    pub height: u32,
    /// Gaze point, pixels.
    pub gaze: [f64; 2],
    /// Eccentricities sampled, degrees.
    pub eccentricity_deg: Vec<f64>,
    /// The acuity model `1/ω(e)`.
    pub acuity_cpd: Vec<f64>,
    /// The full-resolution display's own rate.
    pub display_cpd: Vec<f64>,
    /// One curve per method.
    pub curves: Vec<Curve>,
}

/// Samples every entry's shading rates on `n` eccentricities in `(0, e_max]`.
pub fn shading_rate_curves(
    display: &DisplayProfile,
    gaze: Gaze,
    entries: &[MethodEntry],
    acuity: &AcuityModel,
    e_max: Degrees,
    n: usize,
) -> Result<CurveSet> {
    let n = n.max(2);
    let es: Vec<f64> = (1..=n).map(|i| e_max.0 * i as f64 / n as f64).collect();
    let full = build(Method::Full, display, gaze, &MappingConfig::default())?;
    let mut curves = Vec::new();
    for e in entries {
        let m = build(e.method, display, gaze, &e.config)?;
        curves.push(Curve {
            label: e.label.clone(),
            radial_cpd: es.iter().map(|&x| m.radial_rate_cpd(x)).collect(),
            tangential_cpd: es.iter().map(|&x| m.tangential_rate_cpd(x)).collect(),
        });
    }
    Ok(CurveSet {
        display: display.name.clone(),
        width: display.width_px,
        height: display.height_px,
        gaze: [gaze.point.x_px, gaze.point.y_px],
        acuity_cpd: es.iter().map(|&x| acuity.cpd(Degrees(x)).0).collect(),
        display_cpd: es.iter().map(|&x| full.radial_rate_cpd(x)).collect(),
        eccentricity_deg: es,
        curves,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_has_every_method_and_vafr_is_constant() {
        let displays: Vec<_> = ["2k", "8k"]
            .iter()
            .map(|n| DisplayProfile::preset(n).unwrap())
            .collect();
        let rows = sample_table(&displays, &default_entries(), (0.5, 0.5)).unwrap();
        assert_eq!(rows.len(), 2 * default_entries().len());
        for label in ["vafr", "vafr(60°)"] {
            let vafr: Vec<u64> = rows
                .iter()
                .filter(|r| r.label == label)
                .map(|r| r.samples)
                .collect();
            assert_eq!(vafr.len(), 2);
            if label == "vafr" {
                // Texels off the screen are unshaded, found with a margin of screen pixels.
                let spread = vafr[0].abs_diff(vafr[1]) as f64 / vafr[0] as f64;
                assert!(spread < 2e-3, "{label}: {vafr:?}");
            } else {
                assert_eq!(vafr[0], vafr[1], "{label}");
            }
        }
        let full = rows.iter().find(|r| r.method == "full").unwrap();
        assert_eq!(full.samples, 3_686_400);
    }
}
