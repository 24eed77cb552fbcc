//! Pupil diameter from the light level.
//!
//! * Liu et al. Sec. 3.2: a straight line through (150 lx, 5.22 mm) and (350 lx, 4.24 mm),
//!   read from Moon–Spencer's table; 300 lx gives 4.49 mm. Outside 150–350 lx the line is
//!   extrapolated and clamped to the physiological range 2–8 mm.
//! * de Groot & Gebhard (1952), as collected by Watson & Yellott (2012, "A unified formula for
//!   light-adapted pupil size"): `D = 7.175·exp(−0.00092·(7.597 + log₁₀ L)³)` mm for luminance
//!   `L` in cd/m², valid over many log units (about 10⁻⁴ to 10⁴ cd/m²).

use crate::error::{check_range_open_lo, Result};
use crate::units::{CandelasPerSquareMetre, Lux, Millimetres};

/// Smallest and largest pupil the models return, mm.
pub const PUPIL_RANGE_MM: (f64, f64) = (2.0, 8.0);

/// Liu's linear fit between (150 lx, 5.22 mm) and (350 lx, 4.24 mm).
pub fn pupil_liu_linear(illuminance: Lux) -> Result<Millimetres> {
    check_range_open_lo("lux", illuminance.0, 0.0, 1e6)?;
    let d = 5.22 + (illuminance.0 - 150.0) * (4.24 - 5.22) / (350.0 - 150.0);
    Ok(Millimetres(d.clamp(PUPIL_RANGE_MM.0, PUPIL_RANGE_MM.1)))
}

/// de Groot & Gebhard's formula for luminance in cd/m².
pub fn pupil_de_groot_gebhard(luminance: CandelasPerSquareMetre) -> Result<Millimetres> {
    check_range_open_lo("luminance", luminance.0, 0.0, 1e7)?;
    let x = 7.597 + luminance.0.log10();
    let d = 7.175 * (-0.00092 * x * x * x).exp();
    Ok(Millimetres(d.clamp(PUPIL_RANGE_MM.0, PUPIL_RANGE_MM.1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn liu_points() {
        assert!((pupil_liu_linear(Lux(150.0)).unwrap().0 - 5.22).abs() < 1e-12);
        assert!((pupil_liu_linear(Lux(350.0)).unwrap().0 - 4.24).abs() < 1e-12);
        assert!((pupil_liu_linear(Lux(300.0)).unwrap().0 - 4.485).abs() < 1e-12);
        assert!(pupil_liu_linear(Lux(-3.0)).is_err());
    }

    #[test]
    fn de_groot_gebhard_is_monotone_and_plausible() {
        let mut prev = 10.0;
        for k in -4..=4 {
            let d = pupil_de_groot_gebhard(CandelasPerSquareMetre(10f64.powi(k)))
                .unwrap()
                .0;
            assert!(d < prev);
            prev = d;
        }
        // About 4.8 mm at 1 cd/m² and 3.2 mm at 100 cd/m².
        let d1 = pupil_de_groot_gebhard(CandelasPerSquareMetre(1.0))
            .unwrap()
            .0;
        let d100 = pupil_de_groot_gebhard(CandelasPerSquareMetre(100.0))
            .unwrap()
            .0;
        assert!(
            (d1 - 4.79).abs() < 0.02 && (d100 - 3.19).abs() < 0.02,
            "{d1} {d100}"
        );
    }
}
