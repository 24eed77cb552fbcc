//! The DOF comparison of `fovea dof-compare`: every filter against the thin-lens reference,
//! focused near and far, in a window around the gaze; its tables and contact sheet.

use anyhow::Result;

use fovea_eval::experiments::dof_compare::{
    focus_label, run as run_dof_compare, DofCompareParams, FilterScore,
};

use crate::dof_compare::write_outputs;

use super::doc::{Cell, Section, Table};
use super::Ctx;

fn table(id: String, title: String, rows: &[FilterScore]) -> Table {
    let mut t = Table::new(
        &id,
        title,
        &["filter", "luma PSNR (dB)", "SSIM", "ꟻLIP", "ms / megapixel"],
    );
    for f in rows {
        t.row(vec![
            Cell::text(f.name.clone()),
            Cell::Psnr(f.psnr_y_db),
            Cell::Num(f.ssim, 4),
            Cell::Num(f.flip, 4),
            Cell::Num(f.ms_per_megapixel, 1),
        ]);
    }
    t
}

pub fn run(ctx: &mut Ctx, sec: &mut Section) -> Result<()> {
    let args = ctx.args;
    let p = if args.quick {
        DofCompareParams {
            window: [128, 128],
            lens_samples: 32,
            pixel_samples: 4,
            ..DofCompareParams::default()
        }
    } else {
        DofCompareParams::default()
    };
    let shading = fovea_eval::reference::MeasuredShading::from(args.shading);
    let p = DofCompareParams {
        shading: shading.shading(),
        ..p
    };
    p.validate()?;
    let quiet = args.quiet;
    let t0 = std::time::Instant::now();
    let result = run_dof_compare(&ctx.loaded.world, &ctx.camera, &ctx.gaze, &p, &|stage| {
        if !quiet {
            eprintln!(
                "           dof [{:>6.1} s] {stage}",
                t0.elapsed().as_secs_f64()
            );
        }
    })?;
    let dir = ctx.dir("dof")?;
    let written = write_outputs(
        &result,
        &ctx.loaded.world.scene.name,
        &ctx.display.name,
        &dir,
    )?;
    sec.text(format!(
        "Window {}×{} around the gaze at {:.1} px/deg, pupil {:.2} mm, thin-lens reference with {} lens samples, {} pixel samples, CoC model {}, {}. Focus cases as Konrad et al.: the 10th (near) and 90th (far) percentile of the window's depths.",
        result.window.width,
        result.window.height,
        result.pixels_per_degree,
        result.params.eye.pupil.0,
        result.params.lens_samples,
        result.params.pixel_samples,
        result.params.coc_model.name(),
        if shading.is_noisy() {
            "the viewer's shading (one occluded environment ray per ray: the pinhole frame carries the noise of its pixel samples, not denoised, and the reference's own noise floor is in each case's title)"
        } else {
            "noise-free shading"
        }
    ));
    sec.table(table(
        "dof-mean".into(),
        "Mean over the focus cases (PSNR averaged in dB)".into(),
        &result.mean_scores(),
    ));
    for c in &result.cases {
        let focus = focus_label(c.focus_m);
        sec.table(table(
            format!("dof-{}", c.focus),
            format!(
                "Focus {} ({focus}): largest CoC {:.1} px, the reference's own noise floor {:.1} dB",
                c.focus, c.max_coc_px, c.reference_noise_floor_db
            ),
            &c.filters,
        ));
    }
    sec.image(
        ctx.link(&written.sheet_path),
        "Contact sheet: per focus case, the thin-lens reference, then each filter with its PSNR",
    );
    sec.text(format!(
        "Reproduce: fovea dof-compare {}{} --gaze {:.0},{:.0} --window {}x{} --lens-samples {} --pixel-samples {}{}.",
        super::scene_flags(&args.scene),
        super::display_flags(&args.display),
        ctx.gaze.point.x_px,
        ctx.gaze.point.y_px,
        p.window[0],
        p.window[1],
        p.lens_samples,
        p.pixel_samples,
        if shading.is_noisy() {
            ""
        } else {
            " --env-light unshadowed"
        }
    ));
    sec.data = written.json;
    Ok(())
}
