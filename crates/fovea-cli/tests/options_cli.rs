//! Options end to end: `--pixel-samples` and `--inset-smoothing` reach the frame, names from a
//! fixed set are checked by clap with a one-line error that lists the valid names, aliases
//! still work, and `-q` is accepted by every command.

use std::path::Path;

use assert_cmd::Command;

fn fovea() -> Command {
    Command::cargo_bin("fovea").unwrap()
}

/// `fovea render ARGS --res 64x72 --lights 1 -q --out OUT`: stdout and the stats JSON.
fn render(out: &Path, args: &[&str]) -> (String, serde_json::Value) {
    let o = fovea()
        .arg("render")
        .args(args)
        .args(["--res", "64x72", "--lights", "1", "-q", "--out"])
        .arg(out)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let json = serde_json::from_slice(&std::fs::read(out.with_extension("json")).unwrap())
        .unwrap_or_else(|e| panic!("{args:?}: {e}"));
    (String::from_utf8_lossy(&o.stdout).into_owned(), json)
}

#[test]
fn pixel_samples_trace_that_many_primary_rays_per_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let (text, json) = render(
        &dir.path().join("full4.png"),
        &["--method", "full", "--pixel-samples", "4"],
    );
    assert_eq!(json["frame"]["rays_primary"], 4 * 64 * 72, "{json}");
    assert_eq!(json["frame"]["samples"], 64 * 72);
    assert_eq!(json["pixel_samples"], 4);
    assert!(text.contains("4,608 samples × 4 rays"), "{text}");
    let (_, one) = render(&dir.path().join("full1.png"), &["--method", "full"]);
    assert_eq!(one["frame"]["rays_primary"], 64 * 72);
    assert_eq!(one["pixel_samples"], 1);
    assert_ne!(
        std::fs::read(dir.path().join("full4.png")).unwrap(),
        std::fs::read(dir.path().join("full1.png")).unwrap(),
        "supersampling changes the edges"
    );
}

#[test]
fn inset_smoothing_is_applied_named_and_printed() {
    let dir = tempfile::tempdir().unwrap();
    let smoothed = dir.path().join("smoothed.png");
    let hard = dir.path().join("hard.png");
    let gauss = dir.path().join("gauss.png");
    let (text, json) = render(&smoothed, &["--method", "inset"]);
    assert_eq!(json["frame"]["inset_smoothing"], "alpha-blend", "{json}");
    assert_eq!(json["inset_smoothing"], "alpha-blend");
    assert!(
        text.lines()
            .next()
            .unwrap()
            .contains("inset (boundary smoothing alpha-blend) |"),
        "{text}"
    );
    let (text, json) = render(&hard, &["--method", "inset", "--inset-smoothing", "none"]);
    assert_eq!(json["inset_smoothing"], "none", "{json}");
    assert!(json["frame"]["inset_smoothing"].is_null(), "{json}");
    assert!(text.contains("inset (boundary smoothing none) |"), "{text}");
    let (_, json) = render(
        &gauss,
        &["--method", "inset", "--inset-smoothing", "Gaussian-2D"],
    );
    assert_eq!(json["frame"]["inset_smoothing"], "gaussian-2d", "{json}");
    let bytes = |p: &Path| std::fs::read(p).unwrap();
    assert_ne!(bytes(&smoothed), bytes(&hard), "smoothing moved no pixel");
    assert_ne!(bytes(&smoothed), bytes(&gauss));
    // Other methods ignore it and say nothing about it.
    let (text, json) = render(
        &dir.path().join("vafr.png"),
        &["--method", "vafr", "--inset-smoothing", "none"],
    );
    assert!(json["inset_smoothing"].is_null() && json["frame"]["inset_smoothing"].is_null());
    assert!(!text.contains("smoothing"), "{text}");
}

#[test]
fn aliases_and_any_case_are_still_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let (_, json) = render(
        &dir.path().join("a.png"),
        &[
            "--method",
            "LMFR",
            "--aa",
            "gauss",
            "--eye",
            "center",
            "--bvh",
            "obvhs",
            "--lod",
            "no",
            "--tonemap",
            "Clamp",
            "--shading",
            "direct",
            "--eyes",
            "1",
        ],
    );
    assert_eq!(json["frame"]["method"], "kfr");
    assert_eq!(json["frame"]["aa"], "gaussian");
}

/// `fovea ARGS` exits with 2 and one line on stderr that holds every needle.
fn usage_error(args: &[&str], needles: &[&str]) {
    let o = fovea().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: no `{n}` in {err}");
    }
    assert!(err.trim_end().ends_with("(see fovea --help)"), "{err}");
}

#[test]
fn a_bad_name_is_one_line_listing_the_valid_names() {
    let smoothings = "(expected: none, alpha-blend, gaussian-1d, gaussian-2d, gaussian-1d-alpha, gaussian-2d-alpha, laplacian";
    for (args, needles) in [
        (
            &["render", "--method", "nope"][..],
            &[
                "error: invalid value 'nope' for '--method <METHOD>'",
                "(expected: full, vafr, kfr, lafr, visual-polar, guenter, inset, weier, liu-hybrid)",
            ][..],
        ),
        (
            &["render", "--aa", "fxaaa"][..],
            &[
                "'--aa <AA>'",
                "expected: auto, none, fxaa, gaussian",
                "did you mean 'fxaa'?",
            ][..],
        ),
        (&["render", "--inset-smoothing", "blur"][..], &[smoothings][..]),
        (&["sequence", "--inset-smoothing", "blur"][..], &[smoothings][..]),
        (&["bench", "--inset-smoothing", "blur"][..], &[smoothings][..]),
        (&["flicker", "--inset-smoothing", "blur"][..], &[smoothings][..]),
        (
            &["render", "--pixel-samples", "0"][..],
            &["'--pixel-samples <PIXEL_SAMPLES>'", "0 is not in 1..=1024"][..],
        ),
        (
            &["sequence", "--pixel-samples", "1025"][..],
            &["1025 is not in 1..=1024"][..],
        ),
        (
            &["render", "--periphery-rays", "65"][..],
            &["65 is not in 1..=64"][..],
        ),
        (&["bench", "--pixel-samples", "many"][..], &["--pixel-samples"][..]),
        (
            &["report", "--reference-pixel-samples", "0"][..],
            &["0 is not in 1..=1024"][..],
        ),
        (
            &["render", "--headset", "oculus"][..],
            &["expected: vive-pro-eye, pimax-crystal, varjo-xr4, 2k, 4k, 6k, 8k, retinal"][..],
        ),
        (&["demo", "--headset", "oculus"][..], &["vive-pro-eye"][..]),
        (
            &["render", "--eye", "up"][..],
            &["expected: left, right, centre"][..],
        ),
        (
            &["render", "--bvh", "octree"][..],
            &["expected: obvhs, embree, brute-force"][..],
        ),
        (
            &["render", "--dof", "gauss"][..],
            &["'--dof <DOF>'", "bokeh-lca", "gather"][..],
        ),
        (&["render", "--lca", "maybe"][..], &["expected: on, off"][..]),
        (&["render", "--lod", "maybe"][..], &["expected: on, off"][..]),
        (
            &["render", "--eyes", "three"][..],
            &["expected: one, both"][..],
        ),
        (
            &["render", "--stereo", "triple"][..],
            &["expected: dup, rep"][..],
        ),
        (
            &["render", "--tonemap", "aces"][..],
            &["expected: clamp, reinhard"][..],
        ),
        (
            &["dof-compare", "--shading", "raster"][..],
            &["expected: indirect, direct, path"][..],
        ),
        (
            &["curves", "--vp-inverse", "approx"][..],
            &["expected: exact, paper-fit"][..],
        ),
        (
            &["table", "--inset", "sideways"][..],
            &["expected: dynamic, fixed"][..],
        ),
        (
            &["sequence", "--scenario", "dance"][..],
            &["expected: demo, saccade-pursuit, random-walk, fixation"][..],
        ),
        (
            &["sequence", "--video", "sometimes"][..],
            &["expected: auto, on, off"][..],
        ),
        (
            &["sequence", "--temporal", "maybe"][..],
            &["expected: on, off"][..],
        ),
        (
            &["flicker", "--temporal", "sometimes"][..],
            &["expected: off, on, both"][..],
        ),
        (
            &["flicker", "--jitter", "sometimes"][..],
            &["expected: on, off"][..],
        ),
        (
            &["flicker", "--history-clamp", "x"][..],
            &["expected: on, off"][..],
        ),
    ] {
        usage_error(args, needles);
    }
}

#[test]
fn every_command_takes_quiet() {
    let dir = tempfile::tempdir().unwrap();
    // curves: the files, no list of them.
    let o = fovea()
        .args(["curves", "--samples", "20", "-q", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(dir.path().join("curves.csv").exists());
    // table: the table, without the notes on the paper.
    let loud = fovea().args(["table"]).output().unwrap();
    let quiet = fovea().args(["table", "--quiet"]).output().unwrap();
    let (loud, quiet) = (
        String::from_utf8_lossy(&loud.stdout),
        String::from_utf8_lossy(&quiet.stdout),
    );
    assert!(loud.contains("VaFR Table 1 prints") && !quiet.contains("VaFR Table 1 prints"));
    assert!(
        quiet.contains("vafr") && loud.starts_with(&*quiet),
        "{quiet}"
    );
    // --json output is the same with -q.
    let json = |q: bool| {
        let mut c = fovea();
        c.args(["table", "--json", "--headsets", "2k"]);
        if q {
            c.arg("-q");
        }
        c.output().unwrap().stdout
    };
    assert_eq!(json(true), json(false));
    // fidelity: the table, without the paragraph that explains it.
    let fidelity = |q: bool| {
        let mut c = fovea();
        c.args([
            "fidelity",
            "--res",
            "160x180",
            "--methods",
            "vafr",
            "--stride",
            "8",
        ]);
        if q {
            c.arg("-q");
        }
        let o = c.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let (loud, quiet) = (fidelity(false), fidelity(true));
    assert!(
        loud.starts_with("Texel spacing") && quiet.starts_with("| method |"),
        "{quiet}"
    );
    assert!(loud.ends_with(&*quiet), "{quiet}");
    // optics: every line is what was asked for.
    let o = fovea().args(["optics", "-q"]).output().unwrap();
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("depth m"));
    // inset-analysis: the table, not where the files went.
    let out = dir.path().join("inset");
    let o = fovea()
        .args([
            "inset-analysis",
            "--res",
            "160x120",
            "--lights",
            "1",
            "-q",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("| alpha-blend |") && !text.contains("wrote"),
        "{text}"
    );
    assert!(out.join("inset-analysis.json").exists());
}
