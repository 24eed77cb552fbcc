//! How closely a mapping's samples follow the acuity model wherever the eye looks.
//!
//! At a screen pixel `p`, the mapping's sample point there (`forward(p)`) and the points one
//! texel further along each buffer axis (`inverse(s + 1)`, or `inverse(s − 1)` at the buffer's
//! far edge) lie an angle apart as the eye sees them: the angle between the eye's rays through
//! the two screen points ([`DisplayProfile::eye_direction`]). Along `v` that angle is the
//! spacing; across, the spacing is the distance between neighbouring lines of constant `u`
//! (the `u`-step's angle times the sine of its angle to the `v`-step, so that a polar buffer
//! whose columns hold different numbers of rows is measured between its rings). The acuity model asks for samples
//! half a minimum angle of resolution apart, `ω(e)/2`, at the pixel's *true* eccentricity `e`
//! (the angle from the gaze ray, [`DisplayProfile::eccentricity_exact`]). Their ratio is the
//! texel's **coarseness** along that axis: 1 where the buffer samples at the acuity's Nyquist
//! rate, above 1 where it samples coarser (detail the eye resolves there is lost), below 1
//! where finer.
//!
//! Two closed forms check it (tests below). A full-resolution frame's step is one pixel, which
//! at the principal point spans `atan(1/f)`. VaFR's Eq. 3 (`e = atan(c_r·r)`) is exact for a
//! gaze at the principal point, and its Eq. 6 makes texels square in screen pixels, so there
//! VaFR's coarseness is 1 along `u` (radially) and `1/cos e` along `v` (tangentially: a pixel
//! spans `c_r·cos e` radians across the radius and `c_r·cos² e` along it). Away from the
//! principal point Eq. 3 no longer holds, and this measures by how much VaFR then departs from
//! its own acuity model.

use serde::Serialize;

use crate::acuity::AcuityModel;
use crate::display::{DisplayProfile, Gaze};
use crate::error::{FoveaError, Result};
use crate::mapping::{FoveationMapping, SamplePoint};
use crate::math::{angle_between_deg, cross3, norm3, sub3};
use crate::units::ScreenPoint;

/// A texel's coarseness at one screen pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coarseness {
    /// True eccentricity of the pixel from the gaze, degrees.
    pub eccentricity_deg: f64,
    /// The distance between neighbouring lines of constant `u` (for polar mappings, between
    /// rings: the radial spacing), in units of the acuity's Nyquist spacing `ω(e)/2`.
    pub u: f64,
    /// One texel along a line of constant `u` (for polar mappings, along the ring: the
    /// tangential spacing), likewise.
    pub v: f64,
}

/// The coarseness of `mapping`'s texel at screen point `p`, against `acuity` at the true
/// eccentricity; `None` where the mapping has no sample at `p`, or its texel there has no
/// neighbour on either side along an axis.
pub fn coarseness_at(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    gaze: &Gaze,
    acuity: &AcuityModel,
    p: ScreenPoint,
) -> Option<Coarseness> {
    let e = display.eccentricity_exact(p, gaze).0;
    coarseness_at_eccentricity(mapping, display, acuity, p, e)
}

/// [`coarseness_at`] with the pixel's true eccentricity `e_deg` already known.
fn coarseness_at_eccentricity(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    acuity: &AcuityModel,
    p: ScreenPoint,
    e_deg: f64,
) -> Option<Coarseness> {
    let s = mapping.forward(p)?;
    let here = display.eye_direction(p);
    // The neighbouring sample point one texel along (du, dv), the far side at the buffer's edge.
    let neighbour = |du: f64, dv: f64| -> Option<[f64; 3]> {
        let at = |k: f64| {
            mapping.inverse(SamplePoint {
                layer: s.layer,
                u: s.u + k * du,
                v: s.v + k * dv,
            })
        };
        Some(display.eye_direction(at(1.0).or_else(|| at(-1.0))?))
    };
    let (qu, qv) = (neighbour(1.0, 0.0)?, neighbour(0.0, 1.0)?);
    // Along v the step stays on its line of constant u (a polar buffer's ring). Across, the
    // spacing is the distance between neighbouring lines of constant u: the u-step's angle
    // times the sine of its angle to the v-step (polar buffers whose columns hold different
    // numbers of rows shift the angle from column to column; a tensor grid has no shear).
    let (a, b) = (sub3(qu, here), sub3(qv, here));
    let sin_shear = norm3(cross3(a, b)) / (norm3(a) * norm3(b));
    let nyquist_deg = acuity.mar_deg(e_deg) / 2.0;
    Some(Coarseness {
        eccentricity_deg: e_deg,
        u: angle_between_deg(here, qu) * sin_shear / nyquist_deg,
        v: angle_between_deg(here, qv) / nyquist_deg,
    })
}

/// The coarseness over one band of true eccentricity.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BandCoarseness {
    /// Band start, degrees (inclusive).
    pub lo_deg: f64,
    /// Band end, degrees (exclusive).
    pub hi_deg: f64,
    /// The share of the screen's pixels in the band.
    pub pixel_fraction: f64,
    /// The share of the band's pixels without a sample (or without a neighbouring texel).
    pub unsampled_fraction: f64,
    /// Median coarseness along `u` over the band's sampled pixels.
    pub u_median: f64,
    /// 90th percentile along `u`.
    pub u_p90: f64,
    /// Median coarseness along `v`.
    pub v_median: f64,
    /// 90th percentile along `v`.
    pub v_p90: f64,
}

/// Screen pixels visited per band summary: at most this many (the grid's stride grows to fit).
pub const MAX_GRID_POINTS: u64 = 1 << 20;

/// [`coarseness_at`] on a grid of pixel centres (every `stride_px`-th pixel, at least enough
/// for [`MAX_GRID_POINTS`]), summarised per band of true eccentricity. `edges_deg` are the
/// bands' edges, increasing (e.g. `[0, 5, 15, 30, 60, 180]`). Bands no pixel falls in are left
/// out.
pub fn coarseness_by_band(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    gaze: &Gaze,
    acuity: &AcuityModel,
    edges_deg: &[f64],
    stride_px: u32,
) -> Result<Vec<BandCoarseness>> {
    if edges_deg.len() < 2
        || edges_deg.iter().any(|e| !e.is_finite() || *e < 0.0)
        || edges_deg.windows(2).any(|w| w[0] >= w[1])
    {
        return Err(FoveaError::invalid(
            "bands",
            format!("{edges_deg:?}"),
            "at least two increasing, finite, non-negative eccentricities in degrees",
        ));
    }
    let (w, h) = (display.width_px as u64, display.height_px as u64);
    let fit = ((w * h) as f64 / MAX_GRID_POINTS as f64).sqrt().ceil() as u32;
    let stride = stride_px.max(fit).max(1) as usize;
    let n_bands = edges_deg.len() - 1;
    let mut us: Vec<Vec<f64>> = vec![Vec::new(); n_bands];
    let mut vs: Vec<Vec<f64>> = vec![Vec::new(); n_bands];
    let mut counts = vec![0u64; n_bands];
    let mut total = 0u64;
    for y in (0..h as usize).step_by(stride) {
        for x in (0..w as usize).step_by(stride) {
            let p = ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
            total += 1;
            let e = display.eccentricity_exact(p, gaze).0;
            let Some(b) = edges_deg.windows(2).position(|w| e >= w[0] && e < w[1]) else {
                continue;
            };
            counts[b] += 1;
            if let Some(c) = coarseness_at_eccentricity(mapping, display, acuity, p, e) {
                us[b].push(c.u);
                vs[b].push(c.v);
            }
        }
    }
    let quantile = |v: &mut Vec<f64>, q: f64| -> f64 {
        if v.is_empty() {
            return f64::NAN;
        }
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * q).round() as usize]
    };
    let mut out = Vec::new();
    for b in 0..n_bands {
        if counts[b] == 0 {
            continue;
        }
        let sampled = us[b].len() as u64;
        out.push(BandCoarseness {
            lo_deg: edges_deg[b],
            hi_deg: edges_deg[b + 1],
            pixel_fraction: counts[b] as f64 / total as f64,
            unsampled_fraction: (counts[b] - sampled) as f64 / counts[b] as f64,
            u_median: quantile(&mut us[b], 0.5),
            u_p90: quantile(&mut us[b], 0.9),
            v_median: quantile(&mut vs[b], 0.5),
            v_p90: quantile(&mut vs[b], 0.9),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::{build, MappingConfig, Method};

    fn vive() -> DisplayProfile {
        DisplayProfile::preset("vive-pro-eye").unwrap()
    }

    #[test]
    fn a_full_resolution_pixel_at_the_principal_point_spans_atan_one_over_f() {
        let d = vive();
        let g = d.centre_gaze();
        let acuity = AcuityModel::vafr_default();
        let full = build(Method::Full, &d, g, &MappingConfig::default()).unwrap();
        let c = coarseness_at(full.as_ref(), &d, &g, &acuity, g.point).unwrap();
        let nyquist = acuity.mar_deg(0.0) / 2.0;
        let expect_u = (1.0 / d.focal_x_px()).atan().to_degrees() / nyquist;
        let expect_v = (1.0 / d.focal_y_px()).atan().to_degrees() / nyquist;
        assert!(c.eccentricity_deg < 1e-9, "{c:?}");
        assert!((c.u - expect_u).abs() < 1e-9 * expect_u, "{c:?} {expect_u}");
        assert!((c.v - expect_v).abs() < 1e-9 * expect_v, "{c:?} {expect_v}");
    }

    /// VaFR at the centre gaze: Eq. 3 is exact there, so one texel along `u` is the acuity's
    /// Nyquist spacing, and Eq. 6's square texels are `1/cos e` coarser along `v`.
    #[test]
    fn vafr_at_the_centre_gaze_follows_its_acuity_radially_and_one_over_cos_e_tangentially() {
        let d = vive();
        let g = d.centre_gaze();
        let acuity = AcuityModel::vafr_default();
        let vafr = build(Method::Vafr, &d, g, &MappingConfig::default()).unwrap();
        for e_deg in [3.0f64, 12.0, 25.0, 45.0, 58.0] {
            for dir_deg in [0.0f64, 37.0, 90.0, 200.0] {
                let r = d.radius_px(crate::units::Degrees(e_deg));
                let (s, c) = dir_deg.to_radians().sin_cos();
                let p = ScreenPoint::new(g.point.x_px + r * c, g.point.y_px + r * s);
                let k = coarseness_at(vafr.as_ref(), &d, &g, &acuity, p).unwrap();
                assert!((k.eccentricity_deg - e_deg).abs() < 1e-9, "{k:?}");
                // One texel is a finite step: the MAR changes along it, so allow 2 %.
                assert!((k.u - 1.0).abs() < 0.02, "e {e_deg} dir {dir_deg}: {k:?}");
                let tangential = 1.0 / e_deg.to_radians().cos();
                assert!(
                    (k.v / tangential - 1.0).abs() < 0.02,
                    "e {e_deg} dir {dir_deg}: {k:?}, 1/cos e = {tangential}"
                );
            }
        }
    }

    #[test]
    fn bands_cover_the_screen_and_bad_edges_are_refused() {
        let d = vive();
        let acuity = AcuityModel::vafr_default();
        let g = d.gaze(100.0, 100.0).unwrap();
        let full = build(Method::Full, &d, g, &MappingConfig::default()).unwrap();
        let bands =
            coarseness_by_band(full.as_ref(), &d, &g, &acuity, &[0.0, 30.0, 180.0], 16).unwrap();
        let share: f64 = bands.iter().map(|b| b.pixel_fraction).sum();
        assert!((share - 1.0).abs() < 1e-12, "{bands:?}");
        assert!(bands.iter().all(|b| b.unsampled_fraction == 0.0));
        for bad in [&[0.0][..], &[0.0, 0.0], &[5.0, 1.0], &[0.0, f64::NAN]] {
            let e = coarseness_by_band(full.as_ref(), &d, &g, &acuity, bad, 16).unwrap_err();
            assert!(
                matches!(&e, FoveaError::InvalidParameter { name, .. } if name == "bands"),
                "{bad:?}: {e}"
            );
        }
    }
}
