//! `--exposure` and `--ev100`: how a PNG frame is exposed, and the warnings when the exposed
//! frame mostly clips to white or mostly misses the scene. The choice and the measurements
//! are `fovea_post::exposure`'s; this file parses, chooses the default and prints.

use anyhow::{bail, Result};
use clap::Args;
use fovea_core::Image;
use fovea_post::exposure::{stops_to_ev100, Exposure, FrameExposure, MAX_STOPS};
use fovea_post::tonemap::ToneCurve;
use fovea_post::Rgb;
use fovea_render::scene::LightUnits;

/// The EV100 range `--ev100` accepts: a moonless night (−6) to beyond direct sunlight.
const EV100_RANGE: (f32, f32) = (-10.0, 30.0);

/// A warning when more than this share of the pixels encode to white.
const CLIP_WARNING_FRACTION: f32 = 0.5;

/// A warning when more than this share of the pixels see no geometry.
const BACKGROUND_WARNING_FRACTION: f32 = 0.95;

/// How PNG output is exposed.
#[derive(Args, Debug, Clone, Default)]
pub struct ExposureArgs {
    /// Exposure for PNG output: stops from -20 to 20, or `auto` (middle grey at the
    /// log-average luminance of what the frame sees). Default: auto for scenes whose lights
    /// are photometric (glTF: candela, lux), else 0.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "ev100")]
    pub exposure: Option<String>,
    /// Exposure as a camera's exposure value at ISO 100 (e.g. 15 in sunlight, 7 indoors),
    /// the frame read as luminance in cd/m² (a glTF scene's unit); -10 to 30.
    #[arg(long, allow_hyphen_values = true)]
    pub ev100: Option<f32>,
}

impl ExposureArgs {
    /// The exposure asked for on the command line; `None` when neither flag is given.
    /// Errors name the flag and its range (checked before any work).
    pub fn asked(&self) -> Result<Option<Exposure>> {
        if let Some(ev) = self.ev100 {
            let (lo, hi) = EV100_RANGE;
            if !(ev.is_finite() && (lo..=hi).contains(&ev)) {
                bail!(
                    "invalid parameter `ev100` = {ev}: expected a finite EV100 from {lo} to {hi}"
                );
            }
            return Ok(Some(Exposure::Ev100(ev)));
        }
        let Some(text) = &self.exposure else {
            return Ok(None);
        };
        let t = text.trim();
        if t.eq_ignore_ascii_case("auto") {
            return Ok(Some(Exposure::Auto));
        }
        match t.parse::<f32>() {
            Ok(s) if s.is_finite() && s.abs() <= MAX_STOPS => Ok(Some(Exposure::Stops(s))),
            _ => bail!(
                "invalid parameter `exposure` = {text}: expected `auto` or a finite number of \
                 stops from -{MAX_STOPS} to {MAX_STOPS}"
            ),
        }
    }

    /// The exposure for a scene whose lights are in `units`: the one asked for, else auto
    /// for photometric lights and 0 stops otherwise. The flag says whether it was the
    /// photometric default.
    pub fn choose(&self, units: LightUnits) -> Result<(Exposure, bool)> {
        Ok(match (self.asked()?, units) {
            (Some(e), _) => (e, false),
            (None, LightUnits::Photometric) => (Exposure::Auto, true),
            (None, LightUnits::Relative) => (Exposure::Stops(0.0), false),
        })
    }
}

/// Exposes `color` (with its `depth`) as `exposure` asks under `curve`, printing a `note:`
/// when the exposure was the photometric default and a `warning:` when most of the frame
/// clips to white or sees no geometry. Returns what was measured, for the frame's JSON.
pub fn expose(
    color: &Image<Rgb>,
    depth: &Image<f32>,
    (exposure, photometric_default): (Exposure, bool),
    curve: ToneCurve,
) -> FrameExposure {
    let e = FrameExposure::measure(color, depth, exposure, curve);
    if photometric_default {
        eprintln!(
            "note: the scene's lights are photometric (candela, lux); exposed automatically at \
             {:+.1} stops (EV100 {:.1}); --exposure or --ev100 sets it",
            e.stops,
            stops_to_ev100(e.stops)
        );
    }
    if e.clipped_fraction > CLIP_WARNING_FRACTION {
        eprintln!(
            "warning: {:.0} % of the pixels clip to white at {:+.1} stops; lower --exposure or \
             pass --exposure auto",
            100.0 * e.clipped_fraction,
            e.stops
        );
    }
    if e.background_fraction > BACKGROUND_WARNING_FRACTION {
        eprintln!(
            "warning: {:.0} % of the pixels see no geometry: the view may miss the scene \
             (place the camera with --camera-pos and --look-at)",
            100.0 * e.background_fraction
        );
    }
    e
}

/// The exposure as the frame's JSON records it.
pub fn exposure_json(exposure: Exposure, e: &FrameExposure) -> serde_json::Value {
    let mode = match exposure {
        Exposure::Stops(_) => "stops",
        Exposure::Ev100(_) => "ev100",
        Exposure::Auto => "auto",
    };
    serde_json::json!({
        "mode": mode,
        "stops": e.stops,
        "ev100": stops_to_ev100(e.stops),
        "clipped_fraction": e.clipped_fraction,
        "background_fraction": e.background_fraction,
    })
}

/// The one exposure of frames shown or written in a row (a per-frame auto exposure would
/// flicker): the stops asked for, or, for `auto` (the default for photometric lights), the
/// auto exposure of a full-resolution frame of `camera` with `settings`' shading, metered
/// before anything else is rendered.
pub fn metered_stops(
    exposure: &ExposureArgs,
    world: &fovea_render::world::World,
    camera: &fovea_render::camera::EyeCamera,
    settings: &fovea_render::pipeline::FrameSettings,
) -> Result<f32> {
    use fovea_render::pipeline::{render_frame, FrameSettings};
    let chosen = exposure.choose(world.scene.light_units)?;
    if let Some(stops) = chosen.0.fixed_stops() {
        return Ok(stops);
    }
    let mut meter = FrameSettings::new(fovea_core::mapping::Method::Full);
    meter.shading = settings.shading;
    meter.memory_limit_bytes = settings.memory_limit_bytes;
    let frame = render_frame(
        world,
        camera,
        &meter,
        camera.display.centre_gaze(),
        &|_, _| {},
    )?;
    Ok(expose(&frame.color, &frame.depth, chosen, ToneCurve::Reinhard).stops)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(exposure: Option<&str>, ev100: Option<f32>) -> ExposureArgs {
        ExposureArgs {
            exposure: exposure.map(str::to_string),
            ev100,
        }
    }

    #[test]
    fn defaults_follow_the_scene_light_units() {
        let a = args(None, None);
        assert_eq!(
            a.choose(LightUnits::Photometric).unwrap(),
            (Exposure::Auto, true)
        );
        assert_eq!(
            a.choose(LightUnits::Relative).unwrap(),
            (Exposure::Stops(0.0), false)
        );
        let a = args(Some("-2.5"), None);
        assert_eq!(
            a.choose(LightUnits::Photometric).unwrap(),
            (Exposure::Stops(-2.5), false)
        );
        let a = args(Some("AUTO"), None);
        assert_eq!(
            a.choose(LightUnits::Relative).unwrap(),
            (Exposure::Auto, false)
        );
        let a = args(None, Some(12.0));
        assert_eq!(
            a.choose(LightUnits::Relative).unwrap(),
            (Exposure::Ev100(12.0), false)
        );
    }

    #[test]
    fn bad_values_name_the_flag() {
        for e in ["nan", "inf", "-1e9", "21", "bright"] {
            let err = args(Some(e), None).asked().unwrap_err().to_string();
            assert!(
                err.contains("`exposure`") && err.contains("-20 to 20"),
                "{err}"
            );
        }
        for ev in [f32::NAN, 31.0, -11.0] {
            let err = args(None, Some(ev)).asked().unwrap_err().to_string();
            assert!(err.contains("`ev100`"), "{err}");
        }
    }
}
