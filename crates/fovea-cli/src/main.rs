//! The `fovea` command-line tool.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod backend;
mod bench;
mod choices;
mod common;
mod curves;
mod demo;
mod dof_args;
mod dof_compare;
mod exposure_args;
mod fidelity;
mod flicker;
mod inset_analysis;
mod optics;
mod output;
mod plot;
mod render;
mod report;
mod resident;
mod scene_args;
mod sequence;
mod table;
mod temporal_args;
mod view;

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
    /// How coarse each method's texels are against the acuity model at every pixel's true
    /// eccentricity, per band, at several gazes (1 = acuity-consistent).
    Fidelity(Box<fidelity::FidelityArgs>),
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
    /// Open a window on a scene where the mouse, a gaze CSV or an eye tracker's UDP stream is
    /// the gaze: switch methods, DOF and overlays live, A/B against full resolution, record
    /// the viewing for `fovea sequence` (builds with `--features view`).
    View(Box<view::ViewArgs>),
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

/// A clap usage error as one line: clap's first line, then what it would list below it (the
/// valid values of an enum option, a close spelling), then where the details are.
fn usage_error_line(e: &clap::Error) -> String {
    use clap::error::{ContextKind, ContextValue};
    let text = e.to_string();
    let mut line = text
        .lines()
        .next()
        .unwrap_or("error: invalid arguments")
        .to_string();
    let mut extra = Vec::new();
    if let Some(ContextValue::Strings(valid)) = e.get(ContextKind::ValidValue) {
        if !valid.is_empty() {
            extra.push(format!("expected: {}", valid.join(", ")));
        }
    }
    for kind in [ContextKind::SuggestedValue, ContextKind::SuggestedArg] {
        match e.get(kind) {
            Some(ContextValue::String(s)) => extra.push(format!("did you mean '{s}'?")),
            Some(ContextValue::Strings(v)) if !v.is_empty() => {
                extra.push(format!("did you mean '{}'?", v.join("' or '")))
            }
            _ => {}
        }
    }
    if !extra.is_empty() {
        line += &format!(" ({})", extra.join("; "));
    }
    line + " (see fovea --help)"
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
            eprintln!("{}", usage_error_line(&e));
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Demo(a) => demo::run(a),
        Command::Curves(a) => curves::run(a),
        Command::Table(a) => table::run(a),
        Command::Fidelity(a) => fidelity::run(*a),
        Command::Optics(a) => optics::run(a),
        Command::Render(a) => render::run(*a),
        Command::Bench(a) => bench::run(*a),
        Command::DofCompare(a) => dof_compare::run(*a),
        Command::Sequence(a) => sequence::run(*a),
        Command::InsetAnalysis(a) => inset_analysis::run(*a),
        Command::Flicker(a) => flicker::run(*a),
        Command::Report(a) => report::run(*a),
        Command::View(a) => view::run(*a),
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

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;
    use fovea_core::mapping::Method;
    use fovea_render::pipeline::FrameSettings;

    #[test]
    fn the_command_line_definition_is_consistent() {
        // Every default parses, no two options share a name, every `conflicts_with` exists.
        Cli::command().debug_assert();
    }

    #[test]
    fn frame_option_defaults_are_the_library_defaults() {
        let lib = FrameSettings::new(Method::Inset);
        for sub in ["render", "sequence", "bench"] {
            let cli = Cli::try_parse_from(["fovea", sub]).unwrap();
            let frame = match cli.command {
                Command::Render(a) => a.frame,
                Command::Sequence(a) => a.frame,
                Command::Bench(a) => a.frame,
                _ => unreachable!(),
            };
            let mut s = FrameSettings::new(Method::Inset);
            frame.apply(&mut s);
            assert_eq!(s.pixel_samples, lib.pixel_samples, "{sub}");
            assert_eq!(s.inset_smoothing, lib.inset_smoothing, "{sub}");
        }
    }

    #[test]
    fn a_bad_name_is_one_line_that_lists_the_valid_ones() {
        let e = Cli::try_parse_from(["fovea", "render", "--method", "vafrr"]).unwrap_err();
        let line = usage_error_line(&e);
        assert_eq!(line.lines().count(), 1, "{line}");
        assert!(
            line.starts_with("error: invalid value 'vafrr' for '--method <METHOD>'"),
            "{line}"
        );
        assert!(
            line.contains("(expected: full, vafr, kfr, lafr, visual-polar, guenter, inset, weier, liu-hybrid; did you mean 'vafr'?)"),
            "{line}"
        );
        assert!(line.ends_with("(see fovea --help)"), "{line}");
        // Aliases are accepted but not listed.
        assert!(!line.contains("lmfr"), "{line}");
        assert!(Cli::try_parse_from(["fovea", "render", "--method", "LMFR"]).is_ok());
    }
}
