//! Peripheral temporal flicker of foveation methods, with and without temporal accumulation,
//! against the full-resolution sequence (the metric is [`crate::flicker`]).
//!
//! Peripheral vision is most sensitive to temporal change, so the artifact of sparse or
//! log-polar sampling in motion is shimmer the scene does not make; temporal accumulation
//! (Weier et al. 2018, Sec. 4: reprojection TAA; the same history in VaFR's log-polar buffer)
//! is the remedy measured here.
//!
//! One planned [`Sequence`] — a gaze trajectory (synthesised saccades and pursuit,
//! [`super::scenario`], or an eye-tracker CSV) and a moving camera — is rendered frame by frame
//! through [`SequenceDriver`]: one [`Track`] per method × accumulation mode, each with its own
//! temporal history and buffers, and beside them the full-resolution pinhole reference with
//! `reference_spp` stratified samples per pixel. Per eccentricity band the result gives
//! the RMS of the temporal change the reference does not make (`flicker`), and the mean luma
//! PSNR of the frames against the reference (where accumulation ghosted, this would drop).

use std::path::PathBuf;

use serde::Serialize;

use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_render::pipeline::FrameSettings;
use fovea_render::sequence::{Sequence, SequenceDriver, Track};
use fovea_render::shade::ShadingMode;
use fovea_render::temporal::TemporalSettings;
use fovea_render::thin_lens::{render_window, Window};
use fovea_render::world::World;

use crate::bands::check_edges;
use crate::error::{EvalError, Result};
use crate::flicker::{FlickerMeter, FlickerReport, DEFAULT_BANDS_DEG, PERIPHERY_DEG};
use crate::metrics::{luma_psnr, Region};

use super::{create_dir, finite_mean, write_png};

/// Most frames of one flicker sequence.
pub const MAX_FRAMES: usize = 10_000;

/// Largest reference samples per pixel.
pub const MAX_REFERENCE_SPP: u32 = 256;

/// Which accumulation modes each method is rendered with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Accumulation {
    /// Without temporal accumulation.
    Off,
    /// With temporal accumulation.
    On,
    /// Both: each method twice, without first.
    Both,
}

impl Accumulation {
    /// Parses `off`, `on` or `both`.
    pub fn parse(text: &str) -> Result<Self> {
        match text.trim().to_ascii_lowercase().as_str() {
            "on" => Ok(Self::On),
            "off" => Ok(Self::Off),
            "both" => Ok(Self::Both),
            _ => Err(EvalError::invalid("temporal", text, "on, off or both")),
        }
    }

    /// The modes in render order (`true`: accumulation on).
    pub fn modes(self) -> &'static [bool] {
        match self {
            Self::Off => &[false],
            Self::On => &[true],
            Self::Both => &[false, true],
        }
    }
}

/// Parameters of a flicker measurement.
#[derive(Clone, Debug, Serialize)]
pub struct FlickerParams {
    /// Foveation methods to compare (not `full`: that is the reference). Default: VaFR, KFR,
    /// visual-polar, inset, Weier.
    pub methods: Vec<Method>,
    /// Accumulation modes per method. Default: both.
    pub accumulation: Accumulation,
    /// Temporal accumulation settings of the tracks with accumulation on. Default:
    /// [`TemporalSettings::default`].
    pub temporal: TemporalSettings,
    /// Band edges, degrees of eccentricity, ascending from 0 (the last band is open). Default:
    /// [`DEFAULT_BANDS_DEG`].
    pub bands_deg: Vec<f64>,
    /// Eccentricity where the periphery starts, degrees. Default: [`PERIPHERY_DEG`] (20°).
    pub periphery_deg: f64,
    /// Pixel samples of the full-resolution reference (stratified over the pixel area), 1 to
    /// [`MAX_REFERENCE_SPP`]: a one-sample reference aliases and flickers itself. Default: 4.
    pub reference_spp: u32,
    /// What every track renders with besides its method: mapping parameters, shading (the
    /// reference's too), AA, peripheral contrast (`contrast`), memory limit. Its `method` is
    /// replaced per track; it must have no depth of field. Default: `FrameSettings::new(vafr)`
    /// with `ShadingMode::NOISE_FREE` (flicker of the method, not of Monte Carlo noise).
    pub frame: FrameSettings,
    /// Also write every frame as PNG into this folder: `reference/` and one folder per variant
    /// (`METHOD-on`, `METHOD-off`), `frame_00000.png` …. Default: none.
    pub save_frames: Option<PathBuf>,
}

impl Default for FlickerParams {
    fn default() -> Self {
        Self {
            methods: vec![
                Method::Vafr,
                Method::Kfr,
                Method::VisualPolar,
                Method::Inset,
                Method::Weier,
            ],
            accumulation: Accumulation::Both,
            temporal: TemporalSettings::default(),
            bands_deg: DEFAULT_BANDS_DEG.to_vec(),
            periphery_deg: PERIPHERY_DEG,
            reference_spp: 4,
            frame: FrameSettings {
                shading: ShadingMode::NOISE_FREE,
                ..FrameSettings::new(Method::Vafr)
            },
            save_frames: None,
        }
    }
}

impl FlickerParams {
    /// Checks every parameter: foveation methods only, the temporal settings, ascending band
    /// edges from 0, a periphery ≥ 0°, 1 to [`MAX_REFERENCE_SPP`] reference samples, and frame
    /// settings without depth of field.
    pub fn validate(&self) -> Result<()> {
        if self.methods.is_empty() || self.methods.contains(&Method::Full) {
            let names: Vec<&str> = self.methods.iter().map(|m| m.name()).collect();
            return Err(EvalError::invalid(
                "methods",
                names.join(","),
                "foveation methods (full is the reference)",
            ));
        }
        self.temporal.validate()?;
        check_edges(&self.bands_deg)?;
        if !(self.periphery_deg.is_finite() && self.periphery_deg >= 0.0) {
            return Err(EvalError::invalid(
                "periphery",
                self.periphery_deg,
                "an eccentricity ≥ 0 degrees",
            ));
        }
        if !(1..=MAX_REFERENCE_SPP).contains(&self.reference_spp) {
            return Err(EvalError::invalid(
                "reference-spp",
                self.reference_spp,
                format!("1 to {MAX_REFERENCE_SPP}"),
            ));
        }
        self.frame.validate()?;
        if self.frame.dof.is_some() {
            return Err(EvalError::invalid(
                "dof",
                "a depth-of-field setting",
                "none: the flicker measurement compares sharp frames",
            ));
        }
        Ok(())
    }
}

/// Checks the shape of a flicker sequence: 2 to [`MAX_FRAMES`] frames (flicker is a frame
/// difference) at 1 to 1000 frames per second.
pub fn check_sequence(frames: usize, fps: f64) -> Result<()> {
    if !(2..=MAX_FRAMES).contains(&frames) {
        return Err(EvalError::invalid(
            "frames",
            frames,
            format!("2 to {MAX_FRAMES}"),
        ));
    }
    if !(fps.is_finite() && (1.0..=1000.0).contains(&fps)) {
        return Err(EvalError::invalid("fps", fps, "1 to 1000"));
    }
    Ok(())
}

/// One method × accumulation mode.
#[derive(Clone, Debug, Serialize)]
pub struct VariantReport {
    /// The method's name.
    pub method: String,
    /// Whether temporal accumulation was on.
    pub temporal: bool,
    /// Flicker by band and in the periphery.
    pub flicker: FlickerReport,
    /// Mean luma PSNR against the reference over the frames, whole screen, dB.
    pub mean_psnr_db: f64,
    /// The same within 10° of the gaze (a square of that radius), dB.
    pub mean_central_psnr_db: f64,
    /// Mean over frames 1… of the reused fraction of samples (accumulation on).
    pub mean_reused: Option<f64>,
    /// Per-frame luma PSNR, dB.
    #[serde(skip)]
    pub psnr: Vec<f64>,
}

/// One row of the per-frame table (`flicker-frames.csv`).
#[derive(Clone, Debug, Serialize)]
pub struct FrameRow {
    /// The method's name.
    pub method: String,
    /// Whether temporal accumulation was on.
    pub temporal: bool,
    /// Frame index.
    pub frame: usize,
    /// Peripheral flicker `mean((ΔY − ΔR)²)` of the change into this frame (none for frame 0).
    pub peripheral_flicker: Option<f64>,
    /// Luma PSNR against the reference, dB.
    pub psnr_db: f64,
}

/// Where a measurement is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlickerProgress {
    /// The frame being measured.
    pub frame: usize,
    /// Frames of the sequence.
    pub frames: usize,
    /// Renders done (the reference and each variant count one per frame).
    pub renders_done: u64,
    /// Renders in all: frames × (1 + variants).
    pub renders_total: u64,
    /// Whether `frame` is complete.
    pub frame_done: bool,
}

/// What a measurement found.
#[derive(Clone, Debug, Serialize)]
pub struct FlickerResult {
    /// Scene name.
    pub scene: String,
    /// Display name.
    pub display: String,
    /// Frames of the sequence.
    pub frames: usize,
    /// Frames per second.
    pub fps: f64,
    /// The parameters.
    pub params: FlickerParams,
    /// Per method and accumulation mode, in render order.
    pub variants: Vec<VariantReport>,
    /// Per variant and frame.
    pub per_frame: Vec<FrameRow>,
}

/// A track's metrics, beside it.
struct Variant {
    method: Method,
    temporal: bool,
    /// `METHOD-on` or `METHOD-off`: the track's name and the folder of its frames.
    dir: String,
    psnr: Vec<f64>,
    meter: FlickerMeter,
    central_sum: f64,
    central_n: u64,
    reused_sum: f64,
}

/// Renders `seq` in `world` through every method and accumulation mode of `params`, beside
/// the full-resolution reference, and measures each frame. `progress` is told after each
/// render.
pub fn run(
    world: &World,
    seq: &Sequence,
    params: &FlickerParams,
    progress: &mut dyn FnMut(FlickerProgress),
) -> Result<FlickerResult> {
    params.validate()?;
    check_sequence(seq.len(), seq.fps)?;
    let display = seq.cameras[0].display.clone();

    // One track per method and accumulation mode, each with its own history and buffers;
    // the metrics of each track beside it.
    let mut tracks = Vec::new();
    let mut variants = Vec::new();
    for &method in &params.methods {
        for &on in params.accumulation.modes() {
            let mut s = params.frame.clone();
            s.method = method;
            let dir = format!("{}-{}", method.name(), if on { "on" } else { "off" });
            tracks.push(Track::new(dir.clone(), s, on.then_some(params.temporal))?);
            variants.push(Variant {
                method,
                temporal: on,
                dir,
                psnr: Vec::new(),
                meter: FlickerMeter::new(&display, &params.bands_deg, params.periphery_deg)?,
                central_sum: 0.0,
                central_n: 0,
                reused_sum: 0.0,
            });
        }
    }
    if let Some(dir) = &params.save_frames {
        let dirs = std::iter::once("reference").chain(variants.iter().map(|v| v.dir.as_str()));
        for d in dirs {
            create_dir(&dir.join(d))?;
        }
    }
    let save = |dir: &str, i: usize, img: &fovea_core::Image<fovea_post::Rgb>| -> Result<()> {
        match &params.save_frames {
            Some(root) => write_png(&root.join(dir).join(format!("frame_{i:05}.png")), img),
            None => Ok(()),
        }
    };
    let full_region = Region::full(display.width_px, display.height_px);
    let r10 = display.radius_px(Degrees(10.0));
    let n_frames = seq.len();
    let renders_total = n_frames as u64 * (1 + variants.len() as u64);
    let mut renders_done = 0u64;
    let mut driver = SequenceDriver::new(world, seq, tracks)?;
    driver.run(
        &|_| false,
        &mut |e| {
            let i = e.index;
            let gaze = e.eye.gaze;
            let mut tell = |done: u64, frame_done: bool| {
                progress(FlickerProgress {
                    frame: i,
                    frames: n_frames,
                    renders_done: done,
                    renders_total,
                    frame_done,
                })
            };
            let reference = render_window(
                world,
                e.camera,
                Window::full(display.width_px, display.height_px),
                None,
                params.reference_spp,
                params.frame.shading,
                &|_, _| {},
            )?;
            save("reference", i, &reference.color)?;
            renders_done += 1;
            tell(renders_done, false);
            let central = Region::around(
                gaze.point.x_px,
                gaze.point.y_px,
                r10,
                display.width_px,
                display.height_px,
            );
            let n = variants.len();
            for (k, ((v, frame), track)) in
                variants.iter_mut().zip(&e.frames).zip(e.tracks).enumerate()
            {
                if let (Some(acc), true) = (track.accumulator(), i > 0) {
                    let t = acc.last_stats();
                    v.reused_sum += t.reused as f64 / (t.reused + t.fresh).max(1) as f64;
                }
                save(&v.dir, i, &frame.color)?;
                v.meter.push(&frame.color, &reference.color, &gaze)?;
                if let Some(p) = luma_psnr(&reference.color, &frame.color, central) {
                    if p.is_finite() {
                        v.central_sum += p;
                        v.central_n += 1;
                    }
                }
                if let Some(p) = luma_psnr(&reference.color, &frame.color, full_region) {
                    v.psnr.push(p);
                }
                renders_done += 1;
                tell(renders_done, k + 1 == n);
            }
            Ok::<(), EvalError>(())
        },
        &mut |_| {},
    )?;

    let variants: Vec<VariantReport> = variants
        .into_iter()
        .map(|v| VariantReport {
            method: v.method.name().to_string(),
            temporal: v.temporal,
            flicker: v.meter.report(),
            mean_psnr_db: finite_mean(&v.psnr),
            mean_central_psnr_db: v.central_sum / v.central_n.max(1) as f64,
            mean_reused: v.temporal.then(|| v.reused_sum / (n_frames - 1) as f64),
            psnr: v.psnr,
        })
        .collect();
    let per_frame = variants
        .iter()
        .flat_map(|r| {
            r.psnr.iter().enumerate().map(move |(i, &p)| FrameRow {
                method: r.method.clone(),
                temporal: r.temporal,
                frame: i,
                peripheral_flicker: r
                    .flicker
                    .frames
                    .iter()
                    .find(|f| f.frame == i as u64)
                    .map(|f| f.peripheral),
                psnr_db: p,
            })
        })
        .collect();
    Ok(FlickerResult {
        scene: world.scene.name.clone(),
        display: display.name.clone(),
        frames: n_frames,
        fps: seq.fps,
        params: params.clone(),
        variants,
        per_frame,
    })
}

impl FlickerResult {
    /// The per-frame table as CSV: `method,temporal,frame,peripheral_flicker,psnr_db`.
    pub fn frames_csv(&self) -> String {
        let mut csv = String::from("method,temporal,frame,peripheral_flicker,psnr_db\n");
        for r in &self.per_frame {
            let flicker = r
                .peripheral_flicker
                .map_or(String::new(), |f| format!("{f:.6e}"));
            csv += &format!(
                "{},{},{},{flicker},{:.3}\n",
                r.method,
                if r.temporal { "on" } else { "off" },
                r.frame,
                r.psnr_db
            );
        }
        csv
    }

    /// The table as Markdown (`flicker.md`): flicker by band, periphery, energy over the
    /// reference's, PSNR, reused share, and the [`accumulation_lines`].
    pub fn markdown(&self) -> String {
        let (edges, periphery) = (&self.params.bands_deg, self.params.periphery_deg);
        let reports = &self.variants;
        let frames = reports
            .first()
            .map_or(0, |r| r.flicker.periphery.frames + 1);
        let mut s = format!(
            "{}, {}, {frames} frames: flicker = RMS of the temporal change the full-resolution sequence does not make, % of the display range, by eccentricity band; energy = mean squared frame-to-frame change over the reference's\n\n",
            self.scene, self.display
        );
        let bands: Vec<String> = edges
            .iter()
            .enumerate()
            .map(|(k, lo)| match edges.get(k + 1) {
                Some(hi) => format!("{lo}–{hi}°"),
                None => format!("≥ {lo}°"),
            })
            .collect();
        s += &format!(
            "| method | accumulation | {} | periphery ≥ {periphery}° | periphery energy / reference | PSNR ≤ 10° (dB) | PSNR (dB) | reused |\n",
            bands.join(" | ")
        );
        s += &format!(
            "|---|---|{}---|---|---|---|---|\n",
            "---|".repeat(bands.len())
        );
        for r in reports {
            let cells: Vec<String> = r
                .flicker
                .bands
                .iter()
                .map(|b| format!("{:.3}", b.flicker_rms_pct))
                .collect();
            let p = &r.flicker.periphery;
            s += &format!(
                "| {} | {} | {} | {:.3} | {:.2} | {:.2} | {:.2} | {} |\n",
                r.method,
                if r.temporal { "on" } else { "off" },
                cells.join(" | "),
                p.flicker_rms_pct,
                p.temporal_energy / p.reference_energy,
                r.mean_central_psnr_db,
                r.mean_psnr_db,
                r.mean_reused
                    .map_or("—".to_string(), |f| format!("{:.0} %", 100.0 * f))
            );
        }
        let lines: Vec<String> = accumulation_lines(reports)
            .into_iter()
            .map(|l| format!("- {l}"))
            .collect();
        if !lines.is_empty() {
            s += "\n";
            s += &lines.join("\n");
            s += "\n";
        }
        s
    }
}

/// How `after` compares with `before` as a factor above 1: "×1.12 lower" for a fall,
/// "×1.12 higher" for a rise, "unchanged" when equal.
fn ratio_change(before: f64, after: f64) -> String {
    if before == after {
        "unchanged".into()
    } else if after < before {
        format!("×{:.2} lower", before / after)
    } else {
        format!("×{:.2} higher", after / before)
    }
}

/// One sentence per method measured both ways: what accumulation did to its peripheral
/// flicker, temporal energy and PSNR.
pub fn accumulation_lines(reports: &[VariantReport]) -> Vec<String> {
    let mut lines = Vec::new();
    for r in reports.iter().filter(|r| !r.temporal) {
        if let Some(on) = reports.iter().find(|o| o.temporal && o.method == r.method) {
            let (a, b) = (
                r.flicker.periphery.flicker_rms_pct,
                on.flicker.periphery.flicker_rms_pct,
            );
            let (ea, eb) = (
                r.flicker.periphery.temporal_energy,
                on.flicker.periphery.temporal_energy,
            );
            lines.push(format!(
                "{}: accumulation changes peripheral flicker RMS {a:.3} → {b:.3} % ({}), peripheral temporal energy {}, PSNR ≤ 10° {:.2} → {:.2} dB, whole frame {:.2} → {:.2} dB",
                r.method,
                ratio_change(a, b),
                ratio_change(ea, eb),
                r.mean_central_psnr_db,
                on.mean_central_psnr_db,
                r.mean_psnr_db,
                on.mean_psnr_db
            ));
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_changes_read_as_rises_or_falls() {
        assert_eq!(ratio_change(1.0, 1.12), "×1.12 higher");
        assert_eq!(ratio_change(1.12, 1.0), "×1.12 lower");
        assert_eq!(ratio_change(0.5, 0.5), "unchanged");
    }
    use fovea_render::dof::{DofSettings, FocusMode};

    use crate::experiments::invalid_parameter as invalid;

    #[test]
    fn default_params_are_valid() {
        FlickerParams::default().validate().unwrap();
        check_sequence(120, 90.0).unwrap();
    }

    #[test]
    fn bad_params_give_typed_errors() {
        let bad = |f: &dyn Fn(&mut FlickerParams)| {
            let mut p = FlickerParams::default();
            f(&mut p);
            p.validate()
        };
        assert_eq!(invalid(bad(&|p| p.methods.clear())), "methods");
        assert_eq!(invalid(bad(&|p| p.methods.push(Method::Full))), "methods");
        assert_eq!(invalid(bad(&|p| p.reference_spp = 0)), "reference-spp");
        assert_eq!(
            invalid(bad(&|p| p.reference_spp = MAX_REFERENCE_SPP + 1)),
            "reference-spp"
        );
        assert_eq!(invalid(bad(&|p| p.periphery_deg = f64::NAN)), "periphery");
        assert_eq!(invalid(bad(&|p| p.periphery_deg = -1.0)), "periphery");
        assert_eq!(
            invalid(bad(
                &|p| p.frame.dof = Some(DofSettings::new(None, FocusMode::Auto))
            )),
            "dof"
        );
        // Errors from the metric and the renderer keep their own types.
        assert!(matches!(
            bad(&|p| p.bands_deg = vec![5.0, 1.0]),
            Err(EvalError::Core(fovea_core::FoveaError::InvalidParameter { ref name, .. }))
                if name == "bands"
        ));
        assert!(matches!(
            bad(&|p| p.temporal.alpha_min = 0.0),
            Err(EvalError::Render(fovea_render::RenderError::InvalidParameter { ref name, .. }))
                if name == "alpha-min"
        ));
        assert_eq!(
            bad(&|p| p.frame.memory_limit_bytes = 0)
                .unwrap_err()
                .parameter(),
            Some("max-memory")
        );
        assert_eq!(invalid(check_sequence(1, 90.0)), "frames");
        assert_eq!(invalid(check_sequence(MAX_FRAMES + 1, 90.0)), "frames");
        assert_eq!(invalid(check_sequence(10, 0.5)), "fps");
        assert_eq!(invalid(check_sequence(10, f64::NAN)), "fps");
    }

    #[test]
    fn accumulation_modes() {
        assert_eq!(Accumulation::parse("both").unwrap().modes(), &[false, true]);
        assert_eq!(Accumulation::parse(" ON ").unwrap().modes(), &[true]);
        assert_eq!(
            Accumulation::parse("sometimes").unwrap_err().parameter(),
            Some("temporal")
        );
    }
}
