//! The `fovea` command-line tool.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod bench;
mod common;
mod curves;
mod demo;
mod dof_args;
mod dof_compare;
mod flicker;
mod inset_analysis;
mod optics;
mod output;
mod plot;
mod render;
mod report;
mod scene_args;
mod sequence;
mod table;
mod temporal_args;

/// Perception-driven foveated rendering and depth of field for head-mounted displays.
#[derive(Parser, Debug)]
#[command(name = "fovea", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The first thing to run: the built-in scene on a headset along a short gaze path, VaFR
    /// with auto-focus depth of field; frames, the full-resolution reference, a side-by-side,
    /// a sample-density overlay and index.html in ./fovea-out/demo/.
    Demo(demo::DemoArgs),
    /// Plot radial and tangential shading rate against eccentricity for every mapping
    /// (PNG + CSV), with the acuity curve (VaFR Figs. 5, 8, 9, 10, 21).
    Curves(curves::CurvesArgs),
    /// Print samples per eye of every method at 2K…retinal (VaFR Table 1).
    Table(table::TableArgs),
    /// Print the eye's depth-of-field limits and circles of confusion for a focus distance.
    Optics(optics::OpticsArgs),
    /// Ray-trace one frame of a scene through a foveation method (PNG/EXR, depth and
    /// sample-density views, per-stage timings as JSON).
    Render(Box<render::RenderArgs>),
    /// Time full resolution against foveated methods at several resolutions (rays, per-stage
    /// milliseconds, speedup) and the BVH backends' primary-ray throughput.
    Bench(Box<bench::BenchArgs>),
    /// Render a thin-lens depth-of-field reference and score every DOF filter against it,
    /// focused near and far (luma PSNR, SSIM, ꟻLIP, ms per megapixel; contact sheet, JSON).
    DofCompare(Box<dof_compare::DofCompareArgs>),
    /// Render N frames along a gaze trajectory (eye-tracker CSV or synthesised saccades and
    /// pursuit) with auto focus through the accommodation filter: numbered PNGs (and MP4 with
    /// ffmpeg); an interrupted run resumes.
    Sequence(Box<sequence::SequenceArgs>),
    /// The inset paper's gradient-intensity table: full-resolution inset over a rendered
    /// 1/4-resolution periphery, every boundary smoothing, against the full frame.
    InsetAnalysis(Box<inset_analysis::InsetAnalysisArgs>),
    /// Peripheral flicker of foveation methods over a sequence with saccades, pursuit and a
    /// moving camera, with and without temporal accumulation, against full resolution.
    Flicker(Box<flicker::FlickerArgs>),
    /// One page (HTML, Markdown, JSON) reproducing the papers' tables and figures for a scene:
    /// VaFR Table 1 and shading-rate figures, speed per stage, DOF filters, inset gradients,
    /// flicker, and every method's quality against full resolution by eccentricity band.
    Report(Box<report::ReportArgs>),
}

/// Ends quietly, as other command-line tools do, when stdout is a pipe whose reader has gone
/// (`fovea bench --json | head`), instead of panicking in `println!`.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in `main`, before any thread starts; setting SIGPIPE back
    // to its default disposition installs no handler code.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

fn main() -> ExitCode {
    restore_default_sigpipe();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                e.exit();
            }
            // Usage errors in one line too; --help has the details.
            let text = e.to_string();
            let first = text.lines().next().unwrap_or("invalid arguments");
            eprintln!("{first} (see fovea --help)");
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Demo(a) => demo::run(a),
        Command::Curves(a) => curves::run(a),
        Command::Table(a) => table::run(a),
        Command::Optics(a) => optics::run(a),
        Command::Render(a) => render::run(*a),
        Command::Bench(a) => bench::run(*a),
        Command::DofCompare(a) => dof_compare::run(*a),
        Command::Sequence(a) => sequence::run(*a),
        Command::InsetAnalysis(a) => inset_analysis::run(*a),
        Command::Flicker(a) => flicker::run(*a),
        Command::Report(a) => report::run(*a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One actionable line.
            eprintln!("error: {}", format!("{e:#}").replace('\n', " "));
            ExitCode::from(2)
        }
    }
}
