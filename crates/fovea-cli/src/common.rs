//! Argument parsing shared by the subcommands: displays, gazes, methods.

use std::path::Path;

use anyhow::{Context, Result};
use clap::Args;
use fovea_core::acuity::AcuityModel;
use fovea_core::display::{parse_resolution, DisplayProfile, Gaze};
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;

use fovea_render::pipeline::FrameSettings;
use fovea_render::settings::{DEFAULT_PERIPHERY_RAYS, MAX_PERIPHERY_RAYS, MAX_PIXEL_SAMPLES};

use crate::choices::{
    self, DenoiseChoice, DenoiseKernelChoice, Headset, InsetPlacement, InsetSmoothing,
    ReconstructFilterChoice, VafrRingsChoice, VpInverse,
};

/// Which display to use: a preset or a resolution with a field of view.
#[derive(Args, Debug, Clone)]
pub struct DisplayArgs {
    /// Headset or test-resolution preset: vive-pro-eye, pimax-crystal, varjo-xr4, 2k, 4k, 6k,
    /// 8k, retinal.
    #[arg(long, conflicts_with = "res", value_enum, ignore_case = true)]
    pub headset: Option<Headset>,
    /// Custom per-eye resolution WxH (square pixels), e.g. 1920x1080, or a preset name.
    #[arg(long)]
    pub res: Option<String>,
    /// Vertical field of view in degrees for --res (default: the scene file's camera's when
    /// the view is that camera's, else 90).
    #[arg(long)]
    pub vfov: Option<f64>,
}

/// The vertical field of view of `--res` when neither `--vfov` nor the file's camera sets one.
pub const DEFAULT_VFOV_DEG: f64 = 90.0;

impl DisplayArgs {
    /// The chosen display; `default` when neither --headset nor --res is given.
    pub fn display(&self, default: Headset) -> Result<DisplayProfile> {
        self.display_for_view(default, None)
    }

    /// The `--vfov` in effect without a file camera: the flag's, else 90°.
    pub fn vfov_deg(&self) -> f64 {
        self.vfov.unwrap_or(DEFAULT_VFOV_DEG)
    }

    /// The chosen display for a view whose camera came from the scene file with vertical field
    /// of view `file_vfov_deg` (glTF `yfov`, Mitsuba `fov`): a `--res` display takes that field
    /// of view unless `--vfov` is given; a headset preset keeps its own (the headset's optics
    /// decide what the eye sees).
    pub fn display_for_view(
        &self,
        default: Headset,
        file_vfov_deg: Option<f32>,
    ) -> Result<DisplayProfile> {
        if let Some(r) = &self.res {
            let vfov = match (self.vfov, file_vfov_deg) {
                (Some(v), _) => v,
                (None, Some(f)) => f64::from(f),
                (None, None) => DEFAULT_VFOV_DEG,
            };
            display_of(r, vfov)
        } else {
            preset(self.headset.unwrap_or(default))
        }
    }
}

/// The display of a `--headset` preset.
pub fn preset(headset: Headset) -> Result<DisplayProfile> {
    Ok(DisplayProfile::preset(&choices::name(&headset))?)
}

/// A display from `WxH` (square pixels, `vfov_deg` vertical field of view) or a preset name.
pub fn display_of(text: &str, vfov_deg: f64) -> Result<DisplayProfile> {
    let text = text.trim();
    if text.starts_with(|c: char| c.is_ascii_digit()) && text.contains(['x', 'X']) {
        let (w, h) = parse_resolution(text)?;
        Ok(DisplayProfile::with_vertical_fov(
            text,
            w,
            h,
            Degrees(vfov_deg),
        )?)
    } else {
        Ok(DisplayProfile::preset(text)?)
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

/// Largest text input file (gaze CSV, camera path) the commands read: 1 GiB (10 million gaze
/// rows of ~100 bytes).
pub const MAX_TEXT_INPUT_BYTES: u64 = 1 << 30;

/// Reads a text input file (`what` names it in errors) as the scene loaders read theirs: a
/// regular file only (a FIFO, `/dev/zero` or another device, a socket or a directory is
/// refused before it is opened, so nothing waits for a writer or reads without end), at most
/// [`MAX_TEXT_INPUT_BYTES`], UTF-8.
pub fn read_text_input(p: &Path, what: &str) -> Result<String> {
    use std::io::Read;
    let meta =
        std::fs::metadata(p).with_context(|| format!("cannot read {what} {}", p.display()))?;
    if !meta.is_file() {
        let kind = if meta.is_dir() {
            "a directory"
        } else {
            "not a regular file (a FIFO, device or socket)"
        };
        anyhow::bail!(
            "cannot read {what} {}: it is {kind}; only regular files are read",
            p.display()
        );
    }
    if meta.len() > MAX_TEXT_INPUT_BYTES {
        anyhow::bail!(
            "cannot read {what} {}: {} bytes is more than the {MAX_TEXT_INPUT_BYTES} bytes accepted",
            p.display(),
            meta.len()
        );
    }
    let file =
        std::fs::File::open(p).with_context(|| format!("cannot read {what} {}", p.display()))?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(MAX_TEXT_INPUT_BYTES)
        .read_to_end(&mut bytes)
        .with_context(|| format!("cannot read {what} {}", p.display()))?;
    String::from_utf8(bytes).map_err(|e| {
        anyhow::anyhow!(
            "cannot read {what} {}: not UTF-8 text (invalid byte at offset {}); save it as UTF-8",
            p.display(),
            e.utf8_error().valid_up_to()
        )
    })
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

/// Method parameters that can be set from the command line (each method's documented default
/// otherwise).
#[derive(Args, Debug, Clone, Default)]
pub struct MethodOptions {
    /// Reduction ratio δ ≥ 1 of KFR/LMFR and LaFR (buffer W/δ × H/δ).
    #[arg(long)]
    pub delta: Option<f64>,
    /// KFR kernel exponent α (u = z^α·W/δ).
    #[arg(long)]
    pub kfr_alpha: Option<f64>,
    /// Tangential factor Δ(e) of VaFR: isotropic, radial2x30, or ECC:RATIO pairs.
    #[arg(long)]
    pub tangential: Option<String>,
    /// VaFR's acuity pivots, ECC:CPD pairs (eccentricity in degrees, the acuity in cycles per
    /// degree there, piecewise-linear in MAR between them, as the paper's Fig. 5). Default:
    /// the paper's 0:40,10:10,20:6,30:5,60:4. Higher values sample more densely.
    #[arg(long)]
    pub vafr_pivots: Option<String>,
    /// VaFR's largest covered eccentricity in degrees. Default: out to the farthest screen
    /// corner from the gaze, so every pixel has samples. The paper's 60 leaves the pixels
    /// beyond it without samples: they render black.
    #[arg(long)]
    pub vafr_emax: Option<f64>,
    /// How VaFR sizes its rings: exact (the offline default: each ring at the true
    /// eccentricity of the screen points it crosses, texels off the screen unshaded;
    /// acuity-consistent at every gaze) or eq3 (the paper's Eq. 3, the gaze taken as the optical axis: the same buffer at
    /// every gaze, up to 4x too coarse far from a corner gaze; equal to exact at the centre)
    /// or eq3-any-gaze (Eq. 3's rings in one buffer reaching the screen's diagonal, texels off
    /// the screen unshaded: the same layout at every gaze, which the resident GPU frame builds
    /// its tables from once; the default of --quality realtime and of view).
    #[arg(long, value_enum, ignore_case = true)]
    pub vafr_rings: Option<VafrRingsChoice>,
    /// Visual-polar inverse CDF: exact (Lambert W) or paper-fit (Liu Eq. 3).
    #[arg(long, value_enum, ignore_case = true)]
    pub vp_inverse: Option<VpInverse>,
    /// Inset placement: dynamic (follows the gaze) or fixed (screen centre).
    #[arg(long, value_enum, ignore_case = true)]
    pub inset: Option<InsetPlacement>,
    /// Weier's r0,r1 in degrees and p_min, e.g. 10,20,0.2.
    #[arg(long)]
    pub weier: Option<String>,
}

impl MethodOptions {
    /// One warning per option set here that none of `methods` uses (`--weier` without
    /// weier, `--delta` without kfr/lafr, …): the option is ignored, not an error.
    pub fn inapplicable(&self, methods: &[Method]) -> Vec<String> {
        let uses = |wanted: &[Method]| methods.iter().any(|m| wanted.contains(m));
        let checks: [(&str, bool, &[Method], &str); 9] = [
            (
                "delta",
                self.delta.is_some(),
                &[Method::Kfr, Method::Lafr],
                "kfr or lafr",
            ),
            ("kfr-alpha", self.kfr_alpha.is_some(), &[Method::Kfr], "kfr"),
            (
                "tangential",
                self.tangential.is_some(),
                &[Method::Vafr],
                "vafr",
            ),
            (
                "vafr-pivots",
                self.vafr_pivots.is_some(),
                &[Method::Vafr],
                "vafr",
            ),
            (
                "vafr-emax",
                self.vafr_emax.is_some(),
                &[Method::Vafr],
                "vafr",
            ),
            (
                "vafr-rings",
                self.vafr_rings.is_some(),
                &[Method::Vafr],
                "vafr",
            ),
            (
                "vp-inverse",
                self.vp_inverse.is_some(),
                &[Method::VisualPolar],
                "visual-polar",
            ),
            ("inset", self.inset.is_some(), &[Method::Inset], "inset"),
            ("weier", self.weier.is_some(), &[Method::Weier], "weier"),
        ];
        checks
            .iter()
            .filter(|(_, set, wanted, _)| *set && !uses(wanted))
            .map(|(flag, _, _, names)| {
                format!("warning: --{flag} applies to --method {names} only; ignored")
            })
            .collect()
    }

    /// Prints [`Self::inapplicable`]'s warnings on stderr.
    pub fn warn_inapplicable(&self, methods: &[Method]) {
        for w in self.inapplicable(methods) {
            eprintln!("{w}");
        }
    }

    /// The mapping configuration of one frame: the defaults with `quality`'s VaFR rings
    /// ([`fovea_render::quality::Quality::vafr_rings`]), then these options, `--delta`
    /// setting both KFR's and LaFR's ratio (`table` and `curves` instead add rows per δ).
    pub fn frame_config(
        &self,
        quality: fovea_render::quality::Quality,
    ) -> Result<fovea_core::mapping::MappingConfig> {
        let mut config = fovea_core::mapping::MappingConfig::default();
        config.vafr.rings = quality.vafr_rings();
        self.apply(&mut config)?;
        if let Some(d) = self.delta {
            config.kfr.delta = d;
            config.lafr.delta = d;
        }
        Ok(config)
    }

    /// Applies every option but `delta` to `config` (δ also names the KFR/LaFR entries, so
    /// callers build those with [`fovea_core::analysis::MethodEntry::kfr`] / `lafr`).
    pub fn apply(&self, config: &mut fovea_core::mapping::MappingConfig) -> Result<()> {
        use fovea_core::acuity::TangentialFactor;
        if let Some(a) = self.kfr_alpha {
            config.kfr.alpha = a;
        }
        if let Some(t) = &self.tangential {
            config.vafr.tangential = TangentialFactor::parse(t)?;
        }
        if let Some(p) = &self.vafr_pivots {
            config.vafr.acuity = AcuityModel::parse_pivots(p).context("reading --vafr-pivots")?;
        }
        if let Some(e) = self.vafr_emax {
            config.vafr.max_eccentricity = fovea_core::mapping::Coverage::Fixed(Degrees(e));
        }
        if let Some(r) = self.vafr_rings {
            config.vafr.rings = r.into();
        }
        if let Some(v) = self.vp_inverse {
            config.visual_polar.inverse = v.into();
        }
        if let Some(i) = self.inset {
            config.inset.dynamic = i == InsetPlacement::Dynamic;
        }
        if let Some(w) = &self.weier {
            let bad = || {
                anyhow::anyhow!(
                    "invalid parameter `weier` = {w}: expected R0,R1,PMIN, e.g. 10,20,0.2"
                )
            };
            let v: Vec<f64> = w
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| bad())?;
            if v.len() != 3 {
                return Err(bad());
            }
            config.weier.r0 = Degrees(v[0]);
            config.weier.r1 = Degrees(v[1]);
            config.weier.p_min = v[2];
        }
        Ok(())
    }
}

/// Sampling and reconstruction options of a rendered frame, shared by `render`, `sequence`
/// and `bench`.
#[derive(Args, Debug, Clone)]
pub struct FrameOptions {
    /// Primary rays per sample, 1 to 1024, stratified over the sample's texel and averaged (1:
    /// one ray through its centre). At full resolution, a supersampled reference.
    #[arg(long, default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_PIXEL_SAMPLES)))]
    pub pixel_samples: u32,
    /// How VaFR's and the other polar buffers are read back at each pixel: `footprint` boxes
    /// every texel a pixel covers where the buffer is denser than the screen (the fovea);
    /// `bilinear` is the paper's lookup at the pixel centre.
    #[arg(long, value_enum, ignore_case = true, default_value_t = ReconstructFilterChoice::Footprint)]
    pub reconstruct_filter: ReconstructFilterChoice,
    /// With one ray per sample, the most primary rays a texel of VaFR, KFR, LaFR or
    /// visual-polar casts where it covers several screen pixels (one per pixel it covers, up
    /// to this; 1 to 64; 1, the default: one ray per texel, as the paper). Steadier edges
    /// under gaze motion at about twice VaFR's rays (docs/rendering.md).
    #[arg(long, default_value_t = DEFAULT_PERIPHERY_RAYS,
          value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_PERIPHERY_RAYS)))]
    pub periphery_rays: u32,
    #[command(flatten)]
    pub inset: InsetSmoothingArgs,
    #[command(flatten)]
    pub denoise: DenoiseArgs,
    /// Quality preset: offline (direct light plus three bounces of indirect light, four
    /// environment rays per sample, VaFR's exact rings; the default of render, sequence and
    /// bench) or realtime (direct light, one environment ray per sample and one bounce of
    /// indirect light, left to temporal accumulation and the denoiser, VaFR's rings for any
    /// gaze; the default of view, and what the resident GPU frame runs). --shading,
    /// --bounces, --env-samples and --vafr-rings override it (docs/rendering.md, "Quality
    /// presets").
    #[arg(long, value_enum, ignore_case = true)]
    pub quality: Option<crate::choices::QualityChoice>,
}

impl FrameOptions {
    /// `--quality`, or the command's `default`.
    pub fn quality(
        &self,
        default: fovea_render::quality::Quality,
    ) -> fovea_render::quality::Quality {
        self.quality.map_or(default, Into::into)
    }

    /// Sets these options in `settings`.
    pub fn apply(&self, settings: &mut FrameSettings) {
        settings.pixel_samples = self.pixel_samples;
        settings.reconstruct_filter = self.reconstruct_filter.into();
        settings.periphery_rays = self.periphery_rays;
        self.inset.apply(settings);
        self.denoise.apply(settings);
    }
}

/// `--denoise`, `--denoise-iterations` (`render`, `sequence`, `bench`, `view`, `demo`).
#[derive(Args, Debug, Clone)]
pub struct DenoiseArgs {
    /// The sample-space denoiser (SVGF's edge-avoiding à-trous filter over the polar buffer or
    /// the screen, before the reconstruction; docs/denoise.md): `on` (spatial variance) or
    /// `off`.
    #[arg(long, value_enum, ignore_case = true, default_value_t = DenoiseChoice::On)]
    pub denoise: DenoiseChoice,
    /// À-trous iterations of the denoiser (step 2^i texels), 1 to 6.
    #[arg(long, default_value_t = fovea_post::denoise::DenoiseParams::default().iterations,
          value_parser = clap::value_parser!(u32)
              .range(1..=i64::from(fovea_post::denoise::MAX_ITERATIONS)))]
    pub denoise_iterations: u32,
    /// The denoiser's à-trous kernel: 3x3 (linear B spline, the default: 2.2x cheaper) or
    /// 5x5 (SVGF's B3 spline).
    #[arg(long, value_enum, default_value_t = DenoiseKernelChoice::Linear3x3)]
    pub denoise_kernel: DenoiseKernelChoice,
}

impl DenoiseArgs {
    /// Sets the denoiser in `settings`.
    pub fn apply(&self, settings: &mut FrameSettings) {
        settings.denoise = match self.denoise {
            DenoiseChoice::Off => None,
            DenoiseChoice::On => Some(fovea_post::denoise::DenoiseParams {
                iterations: self.denoise_iterations,
                kernel: self.denoise_kernel.into(),
                ..Default::default()
            }),
        };
    }
}

/// `--inset-smoothing` (`render`, `sequence`, `bench`, `flicker`).
#[derive(Args, Debug, Clone)]
pub struct InsetSmoothingArgs {
    /// Boundary smoothing of the inset method, with the parameters of Liu et al.'s inset paper
    /// (alpha blend over 8 px, 9-tap Gaussians over a 16-px strip, a 5-level Laplacian
    /// pyramid); other methods ignore it.
    #[arg(long, value_enum, ignore_case = true, default_value_t = InsetSmoothing::AlphaBlend)]
    pub inset_smoothing: InsetSmoothing,
}

impl InsetSmoothingArgs {
    /// Sets the smoothing in `settings`.
    pub fn apply(&self, settings: &mut FrameSettings) {
        settings.inset_smoothing = self.inset_smoothing.into();
    }
}

/// A sampling method of a list option (`--methods` of bench, table, curves, flicker):
/// [`Method::parse`], with `liu-hybrid` — a render/sequence `--method` that is visual-polar
/// sampling plus the eye's depth of field — pointed at the name these lists take.
pub fn parse_list_method(name: &str) -> Result<fovea_core::mapping::Method> {
    if name.trim().eq_ignore_ascii_case("liu-hybrid") {
        anyhow::bail!(
            "invalid parameter `method` = liu-hybrid: here methods are sampling methods only \
             (full, vafr, kfr, lafr, visual-polar, guenter, inset, weier); liu-hybrid samples \
             as visual-polar, so name that"
        );
    }
    Ok(fovea_core::mapping::Method::parse(name)?)
}
