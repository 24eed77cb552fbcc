//! `fovea dof-compare`: every DOF filter against the thin-lens reference, focused near and
//! far — a table (luma PSNR, SSIM, ꟻLIP, ms per megapixel), a contact sheet of crops, JSON.
//! The comparison, its table and JSON are [`fovea_eval::experiments::dof_compare`]; this file
//! parses the options, draws the contact sheet and writes the files.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;

use fovea_eval::experiments::dof_compare::{
    fmt_db, run as run_dof_compare, DofCompareParams, DofComparison, FocusSpec,
};
use fovea_post::dof::FilterKind;

use crate::choices::{EnvLightChoice, Headset, Shading};
use crate::common::DisplayArgs;
use crate::dof_args::EyeArgs;
use crate::render::{shading, EnvLightArgs};
use crate::scene_args::{prepare, GazeArgs, SceneArgs};
use fovea_core::display::DisplayProfile;

/// Options of `fovea dof-compare`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct DofCompareArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub display: DisplayArgs,
    #[command(flatten)]
    pub gaze: GazeArgs,
    /// Focus cases, comma-separated: near and far (10th / 90th percentile of the window's
    /// depths, Konrad's protocol), auto, or metres.
    #[arg(long, default_value = "near,far")]
    pub cases: String,
    #[command(flatten)]
    pub eye: EyeArgs,
    /// Filters to compare, comma-separated, or `all`.
    #[arg(long, default_value = "all")]
    pub filters: String,
    /// Scored window WxH around the gaze, at the display's resolution, or `full`.
    #[arg(long, default_value = "384x384")]
    pub window: String,
    /// Rays per pixel of the pinhole frame (pixel-area sampling of both renders when above
    /// 1, so that scores measure the blur and not aliasing; 1 = pixel centres, as Konrad),
    /// and rays per texel of the --cull method's frames.
    #[arg(long, default_value_t = 16)]
    pub pixel_samples: u32,
    /// Extra pinhole pixels on each side of the window for the filters' context.
    #[arg(long, default_value_t = 32)]
    pub margin: u32,
    /// Lens samples per pixel of the thin-lens reference (Konrad used 55).
    #[arg(long, default_value_t = 128)]
    pub lens_samples: u32,
    /// Also measure DOF-aware culling: METHOD[+FILTER] (default filter gather) renders whole
    /// frames with and without culling and scores both in the window, e.g. `vafr+gather`.
    #[arg(long)]
    pub cull: Option<String>,
    /// With --cull: CoC diameter in pixels under which the blur cannot hide a culled sample
    /// (see `fovea render --help`).
    #[arg(long, default_value_t = 0.0)]
    pub cull_hidden_coc: f64,
    /// Shading: direct (the default: with the viewer's real-time environment light, one
    /// occluded ray per sample, so the pinhole frame and the reference carry its Monte Carlo
    /// noise and the tables print the reference's noise floor; `--env-light unshadowed` for
    /// the noise-free comparison of before issue 38) or path.
    #[arg(long, value_enum, ignore_case = true, default_value_t = Shading::Direct)]
    pub shading: Shading,
    #[command(flatten)]
    pub env: EnvLightArgs,
    /// Output folder: contact-sheet.png, dof-compare.md, dof-compare.json.
    #[arg(long, default_value = "fovea-out/dof-compare")]
    pub out: PathBuf,
    /// Print the JSON (`{"filters": [...], "cases": [...]}`) instead of the table.
    #[arg(long)]
    pub json: bool,
    /// No progress messages.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Parses `--window WxH` or `full` (the display's size).
fn parse_window(text: &str, w: u32, h: u32) -> Result<[u32; 2]> {
    if text.trim().eq_ignore_ascii_case("full") {
        return Ok([w, h]);
    }
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    let v: Option<Vec<u32>> = parts.iter().map(|p| p.trim().parse().ok()).collect();
    match v.as_deref() {
        Some([a, b]) => Ok([*a, *b]),
        _ => bail!(
            "invalid parameter `window` = {text}: expected WxH with sides 8 to 16384, or full"
        ),
    }
}

pub fn run(args: DofCompareArgs) -> Result<()> {
    // Checked before the scene loads: they depend on the display's size, which the file
    // camera's field of view (see `Loaded::display`) does not change.
    let params = params(&args, &args.display.display(Headset::VivePro)?)?;
    let prepared = prepare(&args.scene, &args.display, Headset::VivePro)?;
    let display = prepared.camera.display.clone();
    let g = args.gaze.resolve(&display, &prepared.camera)?;
    let quiet = args.quiet || args.json;
    let t0 = std::time::Instant::now();
    let result = run_dof_compare(&prepared.world, &prepared.camera, &g, &params, &|stage| {
        if !quiet {
            eprintln!("[{:>6.1} s] {stage}", t0.elapsed().as_secs_f64());
        }
    })?;
    let written = write_outputs(
        &result,
        &prepared.world.scene.name,
        &display.name,
        &args.out,
    )?;
    if args.json {
        print!("{}", written.json_text);
    } else {
        print!("{}", written.markdown);
        println!(
            "wrote {}, {} and {}",
            written.markdown_path.display(),
            written.json_path.display(),
            written.sheet_path.display()
        );
    }
    Ok(())
}

/// What [`write_outputs`] wrote.
pub struct Written {
    /// `dof-compare.json`'s text.
    pub json_text: String,
    /// The JSON.
    pub json: serde_json::Value,
    /// `dof-compare.md`'s text.
    pub markdown: String,
    /// Paths of the Markdown, the JSON and the contact sheet.
    pub markdown_path: PathBuf,
    pub json_path: PathBuf,
    pub sheet_path: PathBuf,
}

/// The comparison's parameters from the options, checked.
pub fn params(args: &DofCompareArgs, display: &DisplayProfile) -> Result<DofCompareParams> {
    let window = parse_window(&args.window, display.width_px, display.height_px)?;
    let filters: Vec<FilterKind> = if args.filters.trim() == "all" {
        FilterKind::ALL.to_vec()
    } else {
        args.filters
            .split(',')
            .map(FilterKind::parse)
            .collect::<Result<_, _>>()?
    };
    let focus: Vec<FocusSpec> = args
        .cases
        .split(',')
        .map(FocusSpec::parse)
        .collect::<Result<_, _>>()?;
    let culling = match args.cull.as_deref() {
        None => None,
        Some(text) => {
            let (m, f) = text.split_once('+').unwrap_or((text, "gather"));
            Some((
                fovea_core::mapping::Method::parse(m)?,
                FilterKind::parse(f)?,
            ))
        }
    };
    let params = DofCompareParams {
        culling,
        cull_hidden_coc_px: args.cull_hidden_coc,
        window,
        margin_px: args.margin,
        lens_samples: args.lens_samples,
        pixel_samples: args.pixel_samples,
        // No bounce count of its own: the mode's default (path tracing's 2, indirect's 3).
        shading: shading(
            Some(args.shading),
            // The viewer's shading by default (issue 38): the real-time preset's one
            // occluded environment ray per sample; `--env-light unshadowed` is the noise-free
            // comparison of before.
            fovea_render::quality::Quality::Realtime,
            None,
            4,
            1,
            &args.env,
            EnvLightChoice::Occluded,
        )?,
        eye: args.eye.eye()?,
        coc_model: args.eye.coc_model()?,
        max_coc_px: args.eye.settings(None)?.max_coc_px,
        filters,
        focus,
    };
    params.validate()?;
    Ok(params)
}

/// Writes `dof-compare.json`, `dof-compare.md` and `contact-sheet.png` into `out`.
pub fn write_outputs(
    result: &DofComparison,
    scene: &str,
    display: &str,
    out: &std::path::Path,
) -> Result<Written> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create directory {}", out.display()))?;
    let json = result.to_json(scene, display);
    let json_text = serde_json::to_string_pretty(&json)? + "\n";
    let json_path = out.join("dof-compare.json");
    crate::output::write_file(&json_path, json_text.as_bytes())?;
    let md = result.markdown(scene, display);
    let md_path = out.join("dof-compare.md");
    crate::output::write_file(&md_path, md.as_bytes())?;
    let sheet_path = out.join("contact-sheet.png");
    contact_sheet(result, &sheet_path)?;
    Ok(Written {
        json_text,
        json,
        markdown: md,
        markdown_path: md_path,
        json_path,
        sheet_path,
    })
}

/// A grid of crops: one row per focus case; the reference, the pinhole frame and each filter,
/// with their names and PSNR drawn above each tile.
fn contact_sheet(r: &DofComparison, path: &std::path::Path) -> Result<()> {
    use plotters::prelude::*;
    let (tw, th) = (r.window.width, r.window.height);
    let label_h = 22u32;
    let cols = 1 + r.cases.first().map_or(0, |c| c.images.len()) as u32;
    let rows = r.cases.len() as u32;
    let (w, h) = (cols * tw, rows * (th + label_h));
    if w as u64 * h as u64 > 1 << 28 {
        bail!("contact sheet of {w}x{h} pixels is too large; use a smaller --window");
    }
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let blit = |buf: &mut [u8], img: &fovea_core::Image<fovea_post::Rgb>, cx: u32, cy: u32| {
        let rgb = fovea_eval::metrics::display_srgb8(img);
        for y in 0..th {
            let src = &rgb[(y * tw * 3) as usize..((y + 1) * tw * 3) as usize];
            let o = (((cy + label_h + y) * w + cx) * 3) as usize;
            buf[o..o + src.len()].copy_from_slice(src);
        }
    };
    for (ri, c) in r.cases.iter().enumerate() {
        let y = ri as u32 * (th + label_h);
        blit(&mut buf, &c.reference, 0, y);
        for (k, img) in c.images.iter().enumerate() {
            blit(&mut buf, img, (k as u32 + 1) * tw, y);
        }
    }
    {
        crate::plot::register_font();
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let style = ("sans-serif", 15).into_font().color(&BLACK);
        for (ri, c) in r.cases.iter().enumerate() {
            let y = (ri as u32 * (th + label_h)) as i32 + 3;
            root.draw_text(&format!("reference ({})", c.focus), &style, (4, y))
                .map_err(|e| anyhow::anyhow!("contact sheet: {e}"))?;
            for (k, f) in c.filters.iter().enumerate() {
                root.draw_text(
                    &format!("{} {} dB", f.name, fmt_db(f.psnr_y_db)),
                    &style,
                    (((k as u32 + 1) * tw) as i32 + 4, y),
                )
                .map_err(|e| anyhow::anyhow!("contact sheet: {e}"))?;
            }
        }
        root.present()
            .map_err(|e| anyhow::anyhow!("contact sheet: {e}"))?;
    }
    let png = crate::output::png_bytes(path, w, h, buf)?;
    crate::output::write_file(path, &png)
}
