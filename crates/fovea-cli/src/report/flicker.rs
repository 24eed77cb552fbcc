//! The flicker table of `fovea flicker`: peripheral temporal flicker of foveation methods over
//! a sequence with saccades, pursuit and a moving camera, with and without temporal
//! accumulation, against the full-resolution sequence.

use anyhow::Result;

use fovea_core::mapping::Method;
use fovea_core::optics::AccommodationParams;
use fovea_eval::experiments::flicker::{accumulation_lines, check_sequence, FlickerParams};
use fovea_eval::experiments::scenario::{camera_slide, GazeScenario};
use fovea_render::sequence::Sequence;

use crate::flicker::{measure, write_outputs, DEFAULT_CAMERA_MOVE};
use crate::sequence::{gaze_trajectory, path_cameras, read_camera_path, read_gaze_csv};

use super::doc::{Cell, Section, Table};
use super::Ctx;

/// Frames per second of the sequence.
const FPS: f64 = 90.0;

/// The gaze scenario.
const SCENARIO: GazeScenario = GazeScenario::SaccadePursuit;

pub fn run(ctx: &mut Ctx, sec: &mut Section) -> Result<()> {
    let args = ctx.args;
    let frames = args
        .flicker_frames
        .unwrap_or(if args.quick { 6 } else { 120 });
    check_sequence(frames as usize, FPS)?;
    let mut params = FlickerParams::default();
    if args.quick {
        params.methods = vec![Method::Vafr, Method::Weier];
    }
    params.validate()?;
    // The default camera slide is over 120 frames; a shorter sequence moves as far per frame.
    let slide = crate::scene_args::parse_vec3("camera-move", DEFAULT_CAMERA_MOVE)?;
    let share = (frames as f32 / 120.0).min(1.0);
    let m = slide * share;
    let camera_move = format!("{},{},{}", m.x, m.y, m.z);
    // The gaze and camera of a recording (`fovea view --record`) when given, else the
    // synthesised scenario and the camera slide.
    let gaze_text = read_gaze_csv(args.gaze_csv.as_deref())?;
    let gazes = gaze_trajectory(
        args.gaze_csv.as_deref().zip(gaze_text.as_deref()),
        SCENARIO,
        args.seed,
        args.quiet,
        &ctx.display,
        frames as f64 / FPS,
    )?
    .resample(FPS, frames as usize)?;
    let cameras = match &args.camera_path {
        Some(p) => path_cameras(&read_camera_path(p)?.0, frames as usize, FPS, &ctx.display)?,
        None => camera_slide(&ctx.camera, m.to_array(), frames as usize)?,
    };
    let world = &ctx.loaded.world;
    let seq = Sequence::plan(
        world,
        cameras,
        gazes,
        None,
        FPS,
        AccommodationParams::default(),
        None,
    )?;
    let out = ctx.dir("flicker")?;
    let result = measure(world, &seq, &params, args.quiet)?;
    let written = write_outputs(
        &result,
        &ctx.display,
        args.gaze_csv.is_none().then_some(SCENARIO.name()),
        args.camera_path.is_none().then_some(camera_move.as_str()),
        &out,
    )?;
    let gaze_words = match &args.gaze_csv {
        Some(p) => format!("the gaze of {}", p.display()),
        None => format!(
            "the `{}` gaze scenario (seed {})",
            SCENARIO.name(),
            args.seed
        ),
    };
    let camera_words = match &args.camera_path {
        Some(p) => format!("the camera following {}", p.display()),
        None => format!("the camera sliding {camera_move} m (right, up, back)"),
    };
    sec.text(format!(
        "{} frames at {} fps of {gaze_words}, {camera_words}; the reference is full resolution with {} samples per pixel. Flicker = RMS of the frame-to-frame change the reference does not make, % of the display range.",
        frames, FPS, params.reference_spp
    ));
    let first = result
        .variants
        .first()
        .ok_or_else(|| anyhow::anyhow!("no variant was measured"))?;
    let mut cols = vec!["method".to_string(), "accumulation".to_string()];
    cols.extend(first.flicker.bands.iter().map(|b| match b.hi_deg {
        Some(hi) => format!("{}–{hi}° (%)", b.lo_deg),
        None => format!("≥ {}° (%)", b.lo_deg),
    }));
    cols.extend([
        format!("periphery ≥ {}° (%)", first.flicker.periphery_deg),
        "periphery energy / reference".into(),
        "PSNR ≤ 10° (dB)".into(),
        "PSNR (dB)".into(),
        "reused (%)".into(),
    ]);
    let col_refs: Vec<&str> = cols.iter().map(String::as_str).collect();
    let mut t = Table::new(
        "flicker",
        "Flicker by eccentricity band, mean PSNR against the reference",
        &col_refs,
    );
    let pct = |v: f64| {
        if v.is_finite() {
            Cell::Num(v, 3)
        } else {
            Cell::text("— (no pixels)")
        }
    };
    for r in &result.variants {
        let p = &r.flicker.periphery;
        let mut cells = vec![
            Cell::text(r.method.clone()),
            Cell::text(if r.temporal { "on" } else { "off" }),
        ];
        cells.extend(r.flicker.bands.iter().map(|b| pct(b.flicker_rms_pct)));
        cells.extend([
            pct(p.flicker_rms_pct),
            Cell::Num(p.temporal_energy / p.reference_energy, 2),
            Cell::Psnr(r.mean_central_psnr_db),
            Cell::Psnr(r.mean_psnr_db),
            r.mean_reused
                .map_or(Cell::text("—"), |u| Cell::Num(100.0 * u, 0)),
        ]);
        t.row(cells);
    }
    sec.table(t);
    for line in accumulation_lines(&result.variants) {
        sec.text(line);
    }
    let method_names: Vec<&str> = params.methods.iter().map(|m| m.name()).collect();
    let mut motion = match &args.camera_path {
        Some(p) => format!(" --camera-path {}", p.display()),
        None => format!(" --camera-move={camera_move}"),
    };
    if let Some(p) = &args.gaze_csv {
        motion += &format!(" --gaze-csv {}", p.display());
    }
    sec.text(format!(
        "Reproduce: fovea flicker {}{} --frames {}{motion} --methods {} --seed {}; per-frame values in {}.",
        super::scene_flags(&args.scene),
        super::display_flags(&args.display),
        frames,
        method_names.join(","),
        args.seed,
        ctx.link(&out.join("flicker-frames.csv"))
    ));
    sec.data = written.json;
    Ok(())
}
