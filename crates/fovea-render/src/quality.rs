//! Quality presets (issue 37, item 10): the shading a frame gets when the user names a use
//! rather than every option.
//!
//! * [`Quality::Offline`] — `render`, `sequence` and `bench`'s default: direct light plus
//!   [`DEFAULT_BOUNCES`] bounces of indirect light with next-event estimation
//!   ([`ShadingMode::Indirect`], issue 38), [`DEFAULT_ENV_SAMPLES`] environment rays per
//!   sample.
//! * [`Quality::Realtime`] — `view`'s default, what a headset would run: direct light with
//!   **one** environment ray per sample plus [`REALTIME_BOUNCES`] bounce of indirect light
//!   ([`ShadingMode::Indirect`]), left to temporal accumulation and the sample-space denoiser
//!   (both on wherever frames follow each other) to average over frames. The resident GPU
//!   frame (`fovea_gpu::frame`) serves it, so the viewer's usual settings stay on the device.
//!   The bounce is what lights a window-lit interior beyond its sunlit patches; what it costs
//!   and gains, and what the preset gives up against the offline one, is measured in
//!   docs/rendering.md ("Quality presets").
//!
//! The presets also pick VaFR's ring layout ([`Quality::vafr_rings`]): the offline preset the
//! exact rings ([`VafrRings::Exact`], acuity-consistent at every gaze, rebuilt per gaze), the
//! real-time one Eq. 3's rings in one buffer for any gaze ([`VafrRings::Eq3AnyGaze`]), whose
//! tables the resident frame builds once per display: with the exact rings a moving gaze
//! costs the render thread ~250 ms of table building per frame at the Vive Pro Eye, against
//! issue 37's 2 ms. What the coarser far rings of an off-centre gaze cost is measured in
//! docs/rendering.md ("Quality presets").
//!
//! Explicit options (`--shading`, `--env-samples`, `--bounces`, `--vafr-rings`) override a
//! preset's choice.

use serde::Serialize;

use fovea_core::mapping::VafrRings;

use crate::settings::FrameSettings;
use crate::shade::{EnvLight, ShadingMode, DEFAULT_BOUNCES, DEFAULT_ENV_SAMPLES};

/// Environment rays per sample of the real-time preset.
pub const REALTIME_ENV_SAMPLES: u32 = 1;
/// Bounces of indirect light of the real-time preset (docs/rendering.md, "Quality presets",
/// has the measurement that chose it).
pub const REALTIME_BOUNCES: u32 = 1;

/// A quality preset.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Quality {
    /// Converging, noisy-but-unbiased shading with indirect light (the default of single
    /// frames and sequences).
    #[default]
    Offline,
    /// Direct light, one environment ray per sample and one bounce of indirect light, for
    /// frames that follow each other at a headset's rate.
    Realtime,
}

/// The kinds of shading a preset or an option picks (the numbers are separate).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadingKind {
    /// [`ShadingMode::Indirect`].
    Indirect,
    /// [`ShadingMode::Direct`].
    Direct,
}

impl Quality {
    /// The name of the preset, as the CLI spells it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Offline => "offline",
            Self::Realtime => "realtime",
        }
    }

    /// The preset's kind of shading.
    pub fn shading_kind(self) -> ShadingKind {
        match self {
            Self::Offline | Self::Realtime => ShadingKind::Indirect,
        }
    }

    /// The preset's bounces of indirect light (with [`ShadingKind::Indirect`]).
    pub fn bounces(self) -> u32 {
        match self {
            Self::Offline => DEFAULT_BOUNCES,
            Self::Realtime => REALTIME_BOUNCES,
        }
    }

    /// The preset's environment rays per sample (with occluded environment light).
    pub fn env_samples(self) -> u32 {
        match self {
            Self::Offline => DEFAULT_ENV_SAMPLES,
            Self::Realtime => REALTIME_ENV_SAMPLES,
        }
    }

    /// The preset's VaFR ring layout: [`VafrRings::Exact`] offline, [`VafrRings::Eq3AnyGaze`]
    /// in real time (the same tables at every gaze, so a moving gaze rebuilds nothing).
    pub fn vafr_rings(self) -> VafrRings {
        match self {
            Self::Offline => VafrRings::Exact,
            Self::Realtime => VafrRings::Eq3AnyGaze,
        }
    }

    /// Sets the preset's choices in `settings`: its shading ([`Self::shading`]) and VaFR's
    /// rings ([`Self::vafr_rings`]).
    pub fn apply(self, settings: &mut FrameSettings) {
        settings.shading = self.shading();
        settings.mapping.vafr.rings = self.vafr_rings();
    }

    /// The preset's shading with occluded environment light.
    pub fn shading(self) -> ShadingMode {
        let env_light = EnvLight::Occluded {
            samples: self.env_samples(),
        };
        match self.shading_kind() {
            ShadingKind::Indirect => ShadingMode::Indirect {
                env_light,
                bounces: self.bounces(),
            },
            ShadingKind::Direct => ShadingMode::Direct { env_light },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_name_their_shading() {
        assert_eq!(
            Quality::Offline.shading(),
            ShadingMode::Indirect {
                env_light: EnvLight::Occluded { samples: 4 },
                bounces: DEFAULT_BOUNCES,
            }
        );
        assert_eq!(
            Quality::Realtime.shading(),
            ShadingMode::Indirect {
                env_light: EnvLight::Occluded { samples: 1 },
                bounces: 1,
            }
        );
        for q in [Quality::Offline, Quality::Realtime] {
            assert!(q.shading().validate().is_ok(), "{}", q.name());
        }
        assert_eq!(Quality::default(), Quality::Offline);
        // Offline keeps the mapping's default rings; real time the gaze-independent layout.
        assert_eq!(
            Quality::Offline.vafr_rings(),
            fovea_core::mapping::VafrParams::default().rings
        );
        assert_eq!(Quality::Realtime.vafr_rings(), VafrRings::Eq3AnyGaze);
    }
}
