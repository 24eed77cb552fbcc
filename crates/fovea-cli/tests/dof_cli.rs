//! Depth of field end to end: `fovea render --dof`, `--method liu-hybrid`, `fovea dof-compare`
//! on the built-in scene and (where `../shared/scenes` is present) on two real scenes with
//! Konrad's protocol, and bad DOF input that must end in a one-line error.

use std::path::{Path, PathBuf};

use assert_cmd::Command;

fn fovea() -> Command {
    Command::cargo_bin("fovea").unwrap()
}

fn shared_scenes() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    if p.is_dir() {
        Some(p)
    } else {
        println!("skipped: ../shared/scenes is absent (a fresh clone); CI has it");
        None
    }
}

fn fails(args: &[&str]) -> String {
    let out = fovea().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} succeeded:\n{err}");
    assert!(!err.contains("panicked"), "{args:?} panicked:\n{err}");
    assert!(err.contains("error"), "{args:?}: no error line:\n{err}");
    assert_eq!(
        err.trim().lines().count(),
        1,
        "{args:?}: not one line:\n{err}"
    );
    err
}

fn run_json(args: &[&str]) -> serde_json::Value {
    let out = fovea().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn render_with_dof_writes_coc_and_reports_focus() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("f.png");
    let coc = dir.path().join("coc.exr");
    let out = fovea()
        .args([
            "render", "--res", "320x240", "--method", "full", "--lights", "2",
        ])
        .args(["--dof", "gather", "--focus", "auto", "-q", "--out"])
        .arg(&png)
        .arg("--coc-out")
        .arg(&coc)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::metadata(&coc).unwrap().len() > 100);
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("f.json")).unwrap()).unwrap();
    let f = &stats["frame"];
    assert_eq!(f["dof_filter"], "gather");
    let focus = f["focus_m"].as_f64().unwrap();
    assert!(focus > 0.0 && focus.is_finite(), "{focus}");
    assert!(f["stages_ms"]["dof"].as_f64().unwrap() >= 0.0);
}

#[test]
fn liu_hybrid_culls_shading_and_blurs() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("liu.png");
    let out = fovea()
        .args([
            "render",
            "--res",
            "480x270",
            "--method",
            "liu-hybrid",
            "--lights",
            "2",
        ])
        .args(["--focus", "0.5", "-q", "--out"])
        .arg(&png)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("liu.json")).unwrap()).unwrap();
    let f = &stats["frame"];
    assert_eq!(f["method"], "visual-polar");
    assert_eq!(f["dof_filter"], "bokeh-lca");
    let culled = f["samples_culled"].as_u64().unwrap();
    let shaded = f["samples_shaded"].as_u64().unwrap();
    assert!(culled > 0 && shaded > 0, "culled {culled}, shaded {shaded}");
}

#[test]
fn dof_compare_json_has_every_filter_with_finite_scores() {
    let dir = tempfile::tempdir().unwrap();
    let v = run_json(&[
        "dof-compare",
        "--res",
        "640x640",
        "--vfov",
        "30",
        "--lights",
        "2",
        "--window",
        "48x48",
        "--margin",
        "16",
        "--lens-samples",
        "16",
        "--json",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    let filters = v["filters"].as_array().unwrap();
    assert_eq!(filters.len(), 9, "pinhole + 8 filters");
    for f in filters {
        for k in ["psnr_y_db", "ssim", "flip", "ms_per_megapixel"] {
            assert!(f[k].as_f64().is_some_and(f64::is_finite), "{k} of {f}");
        }
        assert!(f["name"].is_string());
    }
    assert_eq!(v["cases"].as_array().unwrap().len(), 2);
    for name in ["contact-sheet.png", "dof-compare.md", "dof-compare.json"] {
        assert!(std::fs::metadata(dir.path().join(name)).unwrap().len() > 100);
    }
}

/// `dof-compare --cull` renders the method's frames with the pinhole frame's rays per pixel
/// (per texel), and reports the gap to the same filter on the full-resolution frame.
#[test]
fn dof_compare_culling_frames_are_sampled_like_the_pinhole_frame() {
    let run = |pixel_samples: &str| {
        let dir = tempfile::tempdir().unwrap();
        let v = run_json(&[
            "dof-compare",
            "--res",
            "160x160",
            "--lights",
            "1",
            "--window",
            "48x48",
            "--margin",
            "8",
            "--lens-samples",
            "4",
            "--pixel-samples",
            pixel_samples,
            "--filters",
            "gather",
            "--cases",
            "near",
            "--cull",
            "vafr+gather",
            "--json",
            "--out",
            dir.path().to_str().unwrap(),
        ]);
        v["cases"][0].clone()
    };
    let (one, four) = (run("1"), run("4"));
    let rays = |c: &serde_json::Value, i: usize| c["culling"]["primary_rays"][i].as_u64().unwrap();
    assert_eq!(one["culling"]["rays_per_texel"], 1);
    assert_eq!(four["culling"]["rays_per_texel"], 4);
    // One ray per texel (--periphery-rays is 1 by default) against four: 4x the rays, less
    // the few stratified rays of edge texels that leave the screen (0.1 % here), with and
    // without culling (culling drops shading, not primary rays).
    for i in 0..2 {
        assert!(rays(&one, i) > 1000, "{one}");
        let ratio = rays(&four, i) as f64 / rays(&one, i) as f64;
        assert!((3.99..=4.0).contains(&ratio), "{ratio}\n{one}\n{four}");
    }
    for c in [&one, &four] {
        let gather = c["filters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["name"] == "gather")
            .unwrap()["psnr_y_db"]
            .as_f64()
            .unwrap();
        let k = &c["culling"];
        assert_eq!(k["full_frame_db"].as_f64().unwrap(), gather, "{c}");
        let gap = k["psnr_with_db"].as_f64().unwrap() - gather;
        assert!((k["gap_db"].as_f64().unwrap() - gap).abs() < 1e-12, "{c}");
    }
}

#[test]
fn bad_dof_input_is_one_line() {
    // `--dof` is checked by clap, whose line names the option and lists the filters.
    let e = fails(&["render", "--res", "64x64", "--dof", "gauss"]);
    assert!(
        e.contains("'--dof <DOF>'") && e.contains("bokeh-lca"),
        "{e}"
    );
    fails(&[
        "render", "--res", "64x64", "--dof", "gather", "--focus", "nan",
    ]);
    fails(&[
        "render", "--res", "64x64", "--dof", "gather", "--focus", "-2",
    ]);
    fails(&[
        "render", "--res", "64x64", "--dof", "gather", "--pupil", "40",
    ]);
    fails(&["render", "--res", "64x64", "--dof", "gather", "--lca", "on"]);
    fails(&["render", "--res", "64x64", "--cull"]);
    fails(&[
        "render",
        "--res",
        "64x64",
        "--dof",
        "gather",
        "--coc-model",
        "x",
    ]);
    fails(&["dof-compare", "--res", "64x64", "--lens-samples", "0"]);
    fails(&["dof-compare", "--res", "64x64", "--window", "3x3"]);
    fails(&["dof-compare", "--res", "64x64", "--cases", "middle"]);
}

#[test]
fn zero_pupil_and_infinite_focus_render() {
    let dir = tempfile::tempdir().unwrap();
    for (i, extra) in [
        ["--pupil", "0", "--focus", "1"],
        ["--pupil", "4", "--focus", "inf"],
        ["--pupil", "4", "--focus", "0.01"],
    ]
    .iter()
    .enumerate()
    {
        let png = dir.path().join(format!("z{i}.png"));
        let out = fovea()
            .args([
                "render", "--res", "160x120", "--method", "vafr", "--lights", "1",
            ])
            .args(["--dof", "gather", "--cull", "-q"])
            .args(extra)
            .arg("--out")
            .arg(&png)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{extra:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// Konrad's protocol on two real scenes: focus on the near and on the far object; the best
/// filter must reach 33 dB luma PSNR against the thin-lens reference in every case. The view:
/// an 8K display (90° vertical field, 38 px/deg at the centre) so that the eye's 4.49 mm pupil
/// blurs by up to about 10 px; the chess board scaled to a 0.55 m board and seen from 0.45 m,
/// the classroom from a seat behind a chair.
#[test]
fn best_filter_reaches_33_db_on_real_scenes() {
    let Some(scenes) = shared_scenes() else {
        return;
    };
    let chess = scenes.join("chess-board/chess-board.plain.glb");
    let classroom = scenes.join("japanese-classroom/scene.xml");
    let cases: [(&Path, &[&str]); 2] = [
        (
            &chess,
            &[
                "--scene-scale",
                "0.002",
                "--camera-pos",
                "0,0.25,0.36",
                "--look-at",
                "0,0.03,0.0",
                "--gaze",
                "3400,2520",
            ],
        ),
        (
            &classroom,
            &[
                "--camera-pos=-1.4,1.05,4.0",
                "--look-at=-1.0,0.7,0.0",
                "--gaze",
                "4200,2280",
            ],
        ),
    ];
    for (scene, extra) in cases {
        let dir = tempfile::tempdir().unwrap();
        let mut args = vec![
            "dof-compare",
            "--scene",
            scene.to_str().unwrap(),
            "--res",
            "8k",
            "--lights",
            "4",
            "--window",
            "256x256",
            "--lens-samples",
            "128",
            // The filters against the thin lens, without the environment light's Monte Carlo
            // noise (the default since issue 38 puts the reference's floor near 32 dB, below
            // the bar this test holds the filters to).
            "--env-light",
            "unshadowed",
            "--json",
            "--out",
            dir.path().to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let v = run_json(&args);
        for case in v["cases"].as_array().unwrap() {
            let score = |f: &serde_json::Value| f["psnr_y_db"].as_f64().unwrap();
            let filters = case["filters"].as_array().unwrap();
            let best = filters
                .iter()
                .filter(|f| f["name"] != "pinhole")
                .max_by(|a, b| score(a).total_cmp(&score(b)))
                .unwrap();
            let pinhole = filters.iter().find(|f| f["name"] == "pinhole").unwrap();
            println!(
                "{} focus {} ({:.3} m, largest CoC {:.1} px, reference floor {:.1} dB): best {} {:.2} dB, pinhole {:.2} dB",
                scene.display(),
                case["focus"],
                case["focus_m"].as_f64().unwrap(),
                case["max_coc_px"].as_f64().unwrap(),
                case["reference_noise_floor_db"].as_f64().unwrap(),
                best["name"],
                score(best),
                score(pinhole)
            );
            for f in filters {
                println!("    {:>13} {:.2} dB", f["name"].as_str().unwrap(), score(f));
            }
            // The view really is out of focus somewhere, and blurring it matters: the best
            // filter beats the sharp frame by a clear margin.
            assert!(case["max_coc_px"].as_f64().unwrap() > 3.0, "{case}");
            assert!(score(best) >= score(pinhole) + 3.0, "{case}");
            assert!(score(best) >= 33.0, "{case}");
        }
    }
}
