//! Sun position for the `sun` and `sunsky` emitters: the PSA algorithm (Blanco-Muriel et al.
//! 2001, "Computing the solar vector", Solar Energy 70(5)), as in Mitsuba's sunsky, from the
//! date, time, time zone and place, in Mitsuba's sky frame (+y up, north = −z, east = +x).

use glam::Vec3;

/// Date, time and place of a sun position (Mitsuba's `sun` parameters).
pub(super) struct SunTime {
    pub(super) year: f32,
    pub(super) month: f32,
    pub(super) day: f32,
    pub(super) hour: f32,
    pub(super) minute: f32,
    pub(super) second: f32,
    pub(super) latitude: f32,
    pub(super) longitude: f32,
    pub(super) timezone: f32,
}

/// Direction towards the sun in Mitsuba's sky frame (+y up, north −z, east +x).
pub(super) fn sun_position(t: &SunTime) -> Vec3 {
    let (year, month, day) = (t.year as i64, t.month as i64, t.day as i64);
    let dec_hours =
        t.hour as f64 - t.timezone as f64 + (t.minute as f64 + t.second as f64 / 60.0) / 60.0;
    let aux1 = (month - 14) / 12;
    let aux2 = (1461 * (year + 4800 + aux1)) / 4 + (367 * (month - 2 - 12 * aux1)) / 12
        - (3 * ((year + 4900 + aux1) / 100)) / 4
        + day
        - 32075;
    let julian = aux2 as f64 - 0.5 + dec_hours / 24.0;
    let n = julian - 2_451_545.0;

    let omega = 2.1429 - 0.001_039_459_4 * n;
    let mean_longitude = 4.895_063_0 + 0.017_202_791_698 * n;
    let anomaly = 6.240_060_0 + 0.017_201_969_9 * n;
    let ecl_longitude =
        mean_longitude + 0.033_416_07 * anomaly.sin() + 0.000_348_94 * (2.0 * anomaly).sin()
            - 0.000_113_4
            - 0.000_020_3 * omega.sin();
    let ecl_obliquity = 0.409_092_8 - 6.214e-9 * n + 0.000_039_6 * omega.cos();

    let sin_el = ecl_longitude.sin();
    let mut ra = (ecl_obliquity.cos() * sin_el).atan2(ecl_longitude.cos());
    if ra < 0.0 {
        ra += std::f64::consts::TAU;
    }
    let declination = (ecl_obliquity.sin() * sin_el).asin();

    let gmst = 6.697_424_324_2 + 0.065_709_828_3 * n + dec_hours;
    let lmst = (gmst * 15.0 + t.longitude as f64).to_radians();
    let lat = (t.latitude as f64).to_radians();
    let hour_angle = lmst - ra;
    let mut zenith = (lat.cos() * hour_angle.cos() * declination.cos()
        + declination.sin() * lat.sin())
    .clamp(-1.0, 1.0)
    .acos();
    let mut azimuth =
        (-hour_angle.sin()).atan2(declination.tan() * lat.cos() - lat.sin() * hour_angle.cos());
    if azimuth < 0.0 {
        azimuth += std::f64::consts::TAU;
    }
    zenith += (6371.01 / 149_597_890.0) * zenith.sin();

    let (st, ct) = zenith.sin_cos();
    let (sp, cp) = azimuth.sin_cos();
    Vec3::new((sp * st) as f32, ct as f32, (-cp * st) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sun_is_up_in_a_tokyo_summer_afternoon() {
        let d = sun_position(&SunTime {
            year: 2010.0,
            month: 7.0,
            day: 10.0,
            hour: 15.0,
            minute: 0.0,
            second: 0.0,
            latitude: 35.6894,
            longitude: 139.6917,
            timezone: 9.0,
        });
        assert!((d.length() - 1.0).abs() < 1e-4);
        // Mid-afternoon in July: elevation ≈ 45°, sun in the west (−x in this frame is west).
        let elevation = d.y.asin().to_degrees();
        assert!(elevation > 30.0 && elevation < 60.0, "{elevation}");
        assert!(d.x < 0.0, "{d}");
    }
}
