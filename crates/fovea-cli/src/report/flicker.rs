//! The flicker table of `fovea flicker`: peripheral temporal flicker of foveation methods over
//! a sequence with saccades, pursuit and a moving camera, with and without temporal
//! accumulation, against the full-resolution sequence.

use anyhow::Result;

use crate::common::defaults;
use crate::flicker::{measure, plan, FlickerArgs};

use super::doc::{Cell, Section, Table};
use super::Ctx;

pub fn run(ctx: &mut Ctx, sec: &mut Section) -> Result<()> {
    let args = ctx.args;
    let mut f: FlickerArgs = defaults();
    f.scene = args.scene.clone();
    f.display = args.display.clone();
    f.seed = args.seed;
    f.frames = args
        .flicker_frames
        .unwrap_or(if args.quick { 6 } else { f.frames });
    if args.quick {
        f.methods = "vafr,weier".into();
    }
    // The default camera slide is over 120 frames; a shorter sequence moves as far per frame.
    let slide = crate::scene_args::parse_vec3("camera-move", &f.camera_move)?;
    let share = (f.frames as f32 / 120.0).min(1.0);
    let m = slide * share;
    f.camera_move = format!("{},{},{}", m.x, m.y, m.z);
    f.out = ctx.dir("flicker")?;
    f.quiet = args.quiet;
    let p = plan(&f)?;
    let outcome = measure(&f, &p, &ctx.loaded.world, &ctx.camera)?;
    sec.text(format!(
        "{} frames at {} fps of the `{}` gaze scenario (seed {}), the camera sliding {} m (right, up, back); the reference is full resolution with {} samples per pixel. Flicker = RMS of the frame-to-frame change the reference does not make, % of the display range.",
        f.frames, f.fps, f.scenario, f.seed, f.camera_move, f.reference_spp
    ));
    let first = outcome
        .reports
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
    for r in &outcome.reports {
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
    for line in crate::flicker::accumulation_lines(&outcome.reports) {
        sec.text(line);
    }
    sec.text(format!(
        "Reproduce: fovea flicker {}{} --frames {} --camera-move={} --methods {} --seed {}; per-frame values in {}.",
        super::scene_flags(&args.scene),
        super::display_flags(&args.display),
        f.frames,
        f.camera_move,
        f.methods,
        f.seed,
        ctx.link(&f.out.join("flicker-frames.csv"))
    ));
    sec.data = outcome.json;
    Ok(())
}
