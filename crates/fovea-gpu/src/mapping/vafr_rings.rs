//! VaFR with exact rings (`VafrRings::Exact`, the default; Zhang, Gai, Li, Eq. 3–9 and 19 with
//! every ring sized by the worst point of its on-screen arc, `fovea_core`'s `vafr_rings.rs`)
//! as a table of `shaders/polar_table_mapping.wgsl` ([`super::polar_table`]).
//!
//! The reference's own table ([`Vafr::ring_table`]) is uploaded as it is: one segment per step
//! `[k·step, (k+1)·step]` of radius, `u` the cubic Hermite through the two entries' `u` and
//! `du/dr·step` (the reference's `u_of_r`), the rows per turn linear between the entries
//! (`period_of_r`). The shader's inverse solves the same cubic the reference solves by
//! safeguarded Newton (`r_of_u`).

use fovea_core::mapping::{Vafr, VafrRings};

use super::polar_table::{Knot, PolarTable};
use crate::error::{GpuError, Result};

/// The table of `vafr`'s exact rings. [`GpuError::Unsupported`] for Eq. 3's rings (those
/// have their own shader, [`super::vafr`]).
pub fn table(vafr: &Vafr) -> Result<PolarTable> {
    let Some(rings) = vafr.ring_table() else {
        return Err(GpuError::Unsupported(format!(
            "VaFR with --vafr-rings {} in the exact rings' table shader (Eq. 3's rings have \
             their own, `GpuMapping::vafr` picks it)",
            vafr.rings().name()
        )));
    };
    debug_assert_eq!(vafr.rings(), VafrRings::Exact);
    let step = rings.step_px();
    let (u, du_dr, period) = (rings.u(), rings.du_dr(), rings.period());
    // Entries up to the first one at or beyond r_max: the steps the mapping reads.
    let last = ((rings.r_max_px() / step).ceil() as usize + 1).min(u.len());
    let knots: Vec<Knot> = (0..last)
        .map(|k| Knot {
            r: k as f64 * step,
            u: u[k],
            du_dr: du_dr[k],
            period: period[k],
        })
        .collect();
    // No sample beyond the forward map's edge r_max, or beyond u(r_max) backwards.
    PolarTable::new(vafr.gaze(), &knots, rings.r_max_px(), vafr.u_max())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_core::display::DisplayProfile;
    use fovea_core::mapping::VafrParams;

    #[test]
    fn the_table_is_the_references_steps() {
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        let g = d.gaze(101.25, 1300.5).unwrap();
        let v = Vafr::new(&d, g, VafrParams::default()).unwrap();
        let rings = v.ring_table().unwrap();
        let t = table(&v).unwrap();
        let step = rings.step_px();
        // Every step out to the one holding r_max, none beyond.
        let n = t.segments.len();
        assert!((n as f64 - 1.0) * step <= rings.r_max_px() && n as f64 * step >= rings.r_max_px());
        // Segment k starts at k·step with u_k and period_k (as f32 pairs) and rises to u_{k+1}.
        for k in [0, 1, n / 2, n - 1] {
            let s = &t.segments[k];
            assert!((s.r[0] as f64 + s.r[1] as f64 - k as f64 * step).abs() < 1e-9);
            assert!((s.u[0] as f64 + s.u[1] as f64 - rings.u()[k]).abs() < 1e-9);
            let rise = s.u[2] as f64 + s.u[3] as f64 + s.ext[0] as f64;
            let want = rings.u()[k + 1] - rings.u()[k];
            assert!((rise - want).abs() < 1e-6 * want.max(1.0), "{rise} {want}");
            assert!((s.ext[1] as f64 + s.ext[2] as f64 - rings.period()[k]).abs() < 1e-9);
        }
        // The trapezoid rule's steps are quadratics: c₃ vanishes (to f64 rounding).
        let c3 = t
            .segments
            .iter()
            .map(|s| s.ext[0].abs())
            .fold(0.0, f32::max);
        assert!(c3 < 1e-9, "{c3}");
        assert_eq!(t.uniform.u_max[0], v.u_max() as f32);
    }

    #[test]
    fn eq3_rings_are_refused_with_a_pointer() {
        let d = DisplayProfile::preset("2k").unwrap();
        let v = Vafr::new(&d, d.centre_gaze(), VafrParams::eq3()).unwrap();
        let e = table(&v).unwrap_err();
        assert!(matches!(e, GpuError::Unsupported(_)), "{e}");
        assert!(e.to_string().contains("eq3"), "{e}");
    }
}
