//! Liu et al.'s DOF sampling weight (Eq. 10) and Russian roulette (Eq. 11).
//!
//! `w_d = 1` inside the DOF limits, `D/D_N` in front of them and `(D_M − D)/(D_M − D_F)`
//! behind them, with `D_M` the scene's maximum depth (1000 m when the scene is unbounded).
//! A sample is shaded when a uniform `ε ∈ [0, 1]` satisfies `ε ≤ w_d` (Eq. 11).

use super::thin_lens::DofLimits;
use crate::units::Metres;

/// `D_M` for scenes with infinite depth (Liu Sec. 3.2).
pub const DEFAULT_MAX_DEPTH_M: f64 = 1000.0;

/// Eq. 10. `max_depth` is `D_M`; depths beyond it get weight 0. Non-finite or non-positive
/// depths (no hit) count as `D_M`.
pub fn dof_weight(depth: Metres, limits: &DofLimits, max_depth: Metres) -> f64 {
    let d = if depth.0.is_finite() && depth.0 > 0.0 {
        depth.0
    } else {
        max_depth.0
    };
    if d < limits.near.0 {
        (d / limits.near.0).clamp(0.0, 1.0)
    } else if d <= limits.far.0 {
        1.0
    } else {
        let span = max_depth.0 - limits.far.0;
        if span <= 0.0 {
            0.0
        } else {
            ((max_depth.0 - d) / span).clamp(0.0, 1.0)
        }
    }
}

/// Eq. 11: keep (shade) the sample when `epsilon ≤ weight`.
pub fn russian_roulette(weight: f64, epsilon: f64) -> bool {
    epsilon <= weight
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weight_pieces() {
        let lim = DofLimits {
            near: Metres(1.0),
            far: Metres(2.0),
        };
        let dm = Metres(1000.0);
        assert_eq!(dof_weight(Metres(1.5), &lim, dm), 1.0);
        assert!((dof_weight(Metres(0.5), &lim, dm) - 0.5).abs() < 1e-12);
        assert!((dof_weight(Metres(501.0), &lim, dm) - 0.5).abs() < 1e-12);
        assert_eq!(dof_weight(Metres(f64::NAN), &lim, dm), 0.0);
        assert!(russian_roulette(0.5, 0.3) && !russian_roulette(0.5, 0.7));
    }
}
