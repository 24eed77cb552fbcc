//! Hostile and careless command lines (issue 21): every case exits 0 with a documented
//! fallback (a `warning:` or `note:` line) or 2 with one `error:` line, never a panic.

use std::path::Path;

use assert_cmd::Command;

fn fovea() -> Command {
    Command::cargo_bin("fovea").unwrap()
}

/// `fovea render ARGS --res 64x72 --lights 1 -q --out DIR/r.png`.
fn render(dir: &Path, args: &[&str]) -> std::process::Output {
    fovea()
        .arg("render")
        .args(["--res", "64x72", "--lights", "1", "-q", "--out"])
        .arg(dir.join("r.png"))
        .args(args)
        .output()
        .unwrap()
}

/// The one-line error of a refused command, checked for exit code 2 and no panic.
fn refused(o: &std::process::Output, args: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    assert!(
        err.starts_with("error: ") && !err.contains("panicked"),
        "{args:?}: {err}"
    );
    err
}

/// The stderr of a command that succeeded.
fn accepted(o: &std::process::Output, args: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{args:?}: {err}");
    err
}

/// A unit cube as OBJ: a scene with no camera and a single object.
fn cube_obj(dir: &Path) -> std::path::PathBuf {
    let p = dir.join("cube.obj");
    let mut s = String::new();
    for z in [-0.5, 0.5] {
        for y in [-0.5, 0.5] {
            for x in [-0.5, 0.5] {
                s += &format!("v {x} {y} {z}\n");
            }
        }
    }
    // Vertices 1..8: index = 1 + x + 2y + 4z.
    for f in [
        "1 3 4 2", "5 6 8 7", "1 2 6 5", "3 7 8 4", "1 5 7 3", "2 4 8 6",
    ] {
        s += &format!("f {f}\n");
    }
    std::fs::write(&p, s).unwrap();
    p
}

#[test]
fn exposures_that_are_not_finite_or_sane_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for e in ["nan", "inf", "-inf", "-1e9", "21", "-20.5"] {
        let args = ["--exposure", e];
        let err = refused(&render(dir.path(), &args), &args);
        assert!(
            err.contains("`exposure`") && err.contains("-20 to 20"),
            "{err}"
        );
    }
    for e in ["-3", "2.5", "20"] {
        let args = ["--exposure", e, "--method", "full"];
        accepted(&render(dir.path(), &args), &args);
    }
}

#[test]
fn options_of_another_method_are_ignored_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["--method", "kfr", "--weier", "10,20,0.2"];
    let err = accepted(&render(dir.path(), &args), &args);
    assert!(
        err.contains("warning: --weier applies to --method weier only; ignored"),
        "{err}"
    );
    let args = [
        "--method",
        "full",
        "--vafr-emax",
        "60",
        "--vafr-pivots",
        "0:40,60:4",
        "--tangential",
        "isotropic",
        "--delta",
        "2",
        "--kfr-alpha",
        "0.5",
        "--inset",
        "fixed",
    ];
    let err = accepted(&render(dir.path(), &args), &args);
    for flag in [
        "vafr-emax",
        "vafr-pivots",
        "tangential",
        "delta",
        "kfr-alpha",
        "inset",
    ] {
        assert!(
            err.contains(&format!("warning: --{flag} applies to --method ")),
            "{flag}: {err}"
        );
    }
    // The method's own options: no warning.
    for args in [
        ["--method", "weier", "--weier", "10,20,0.2"],
        ["--method", "lafr", "--delta", "2"],
        ["--method", "vafr", "--vafr-emax", "60"],
    ] {
        let err = accepted(&render(dir.path(), &args), &args);
        assert!(!err.contains("warning:"), "{args:?}: {err}");
    }
}

#[test]
fn a_camera_index_on_a_scene_without_cameras_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cube = cube_obj(dir.path());
    let scene = cube.to_str().unwrap();
    let args = ["--scene", scene, "--camera-index", "99"];
    let err = refused(&render(dir.path(), &args), &args);
    assert!(
        err.contains("`camera-index` = 99") && err.contains("no cameras"),
        "{err}"
    );
    // Index 0 (the default) still frames the scene.
    let args = ["--scene", scene, "--method", "full"];
    accepted(&render(dir.path(), &args), &args);
}

#[test]
fn negative_gazes_parse_and_off_screen_ones_get_the_range_error() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["--gaze", "-100,-100"];
    let err = refused(&render(dir.path(), &args), &args);
    assert!(
        err.contains("invalid parameter `gaze` = -100,-100") && err.contains("x in ["),
        "{err}"
    );
    // A gaze a pixel left of the screen is within the margin.
    let args = ["--gaze", "-1,36", "--method", "full"];
    accepted(&render(dir.path(), &args), &args);
    // `curves` reads the same way.
    let o = fovea()
        .args(["curves", "--res", "64x72", "--gaze", "-100,-100", "--out"])
        .arg(dir.path().join("curves"))
        .output()
        .unwrap();
    let err = refused(&o, &["curves"]);
    assert!(err.contains("`gaze` = -100,-100"), "{err}");
}

#[test]
fn vafr_shading_more_samples_than_pixels_is_noted() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["--method", "vafr"];
    let err = accepted(&render(dir.path(), &args), &args);
    let notes: Vec<&str> = err.lines().filter(|l| l.starts_with("note:")).collect();
    assert_eq!(notes.len(), 1, "{err}");
    assert!(
        notes[0].contains("64×72 display's 4,608 pixels")
            && notes[0].contains("× the")
            && notes[0].contains("acuity"),
        "{err}"
    );
    let args = ["--method", "full"];
    let err = accepted(&render(dir.path(), &args), &args);
    assert!(!err.contains("note:"), "{err}");
}

#[test]
fn a_truncated_frame_is_rendered_again_on_resume() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("seq");
    let run = || {
        fovea()
            .args([
                "sequence", "--res", "120x90", "--lights", "1", "--frames", "3",
            ])
            .args(["--video", "off", "-q", "--out"])
            .arg(&out)
            .output()
            .unwrap()
    };
    let first = run();
    accepted(&first, &["first"]);
    let frame = out.join("frame_00001.png");
    let good = std::fs::read(&frame).unwrap();
    // Header intact, data cut short (as a full disk would leave it).
    std::fs::write(&frame, &good[..good.len() / 2]).unwrap();
    assert!(image::image_dimensions(&frame).is_ok());
    let again = run();
    accepted(&again, &["again"]);
    let text = String::from_utf8_lossy(&again.stdout);
    assert!(text.contains("1 rendered, 2 already there"), "{text}");
    assert_eq!(std::fs::read(&frame).unwrap(), good);
}

#[test]
fn report_verify_passes_a_single_object_scene() {
    let dir = tempfile::tempdir().unwrap();
    let cube = cube_obj(dir.path());
    let out = dir.path().join("report");
    let o = fovea()
        .args([
            "report", "--quick", "--res", "160x180", "--vfov", "100", "-q",
        ])
        .args(["--sections", "quality", "--scene"])
        .arg(&cube)
        // The cube covers the gaze's surroundings; beyond 30° there is only background.
        .args([
            "--camera-pos",
            "0,0,3",
            "--look-at",
            "0.2,0.1,0",
            "--lights",
            "1",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    accepted(&o, &["report"]);
    let o = fovea()
        .args(["report", "--verify"])
        .arg(&out)
        .output()
        .unwrap();
    let err = accepted(&o, &["verify"]);
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    let check = json["sections"][0]["checks"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["claim"].as_str().unwrap().starts_with("Quality falls"))
        .unwrap_or_else(|| panic!("{err}\n{json}"));
    assert_eq!(check["pass"], true, "{check}");
    let detail = check["detail"].as_str().unwrap();
    assert!(
        detail.contains("skipped > 30°") && detail.contains("background only"),
        "{detail}"
    );
}

/// The fraction of pixels of PNG `a` that differ from those of PNG `b` (same size).
fn fraction_differing(a: &Path, b: &Path) -> f64 {
    let a = image::open(a).unwrap().to_rgb8();
    let b = image::open(b).unwrap().to_rgb8();
    assert_eq!(a.dimensions(), b.dimensions());
    let n = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
    n as f64 / (a.width() * a.height()) as f64
}

#[test]
fn flat_scenes_are_framed_face_on_not_edge_on() {
    let dir = tempfile::tempdir().unwrap();
    // A ground quad in XZ (seen from above) and a wall quad in XY (seen from the front).
    let quads = [
        (
            "ground.obj",
            "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 4 3 2 1\n",
        ),
        (
            "wall.obj",
            "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n",
        ),
    ];
    for (name, obj) in quads {
        let scene = dir.path().join(name);
        std::fs::write(&scene, obj).unwrap();
        let scene = scene.to_str().unwrap();
        let args = ["--scene", scene, "--method", "full"];
        accepted(&render(dir.path(), &args), &args);
        let framed = dir.path().join(format!("{name}.png"));
        std::fs::rename(dir.path().join("r.png"), &framed).unwrap();
        // The environment alone: a camera looking away from the quad.
        let away = [
            "--scene",
            scene,
            "--method",
            "full",
            "--camera-pos",
            "0,5,5",
            "--look-at",
            "0,10,10",
        ];
        accepted(&render(dir.path(), &away), &away);
        let f = fraction_differing(&framed, &dir.path().join("r.png"));
        // From 1.2× its width the quad spans ±22.6° of the 90° × 83° view: about 20 % of
        // the pixels (edge-on, as before issue 21: none).
        assert!(
            f > 0.15,
            "{name}: {:.1} % of the pixels show the quad",
            f * 100.0
        );
    }
}

#[test]
fn environment_light_options_are_range_checked_and_warned_where_they_do_not_apply() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["--env-samples", "257"];
    let err = refused(&render(dir.path(), &args), &args);
    assert!(
        err.contains("`env-samples`") && err.contains("0 to 256"),
        "{err}"
    );
    let args = ["--env-light", "sometimes"];
    let err = refused(&render(dir.path(), &args), &args);
    assert!(
        err.contains("occluded") && err.contains("unshadowed"),
        "{err}"
    );
    for args in [
        ["--shading", "path", "--env-samples", "8"],
        ["--env-light", "unshadowed", "--env-samples", "8"],
    ] {
        let mut a = args.to_vec();
        a.extend(["--method", "full"]);
        let err = accepted(&render(dir.path(), &a), &a);
        assert!(err.contains("warning: --env-samples applies to"), "{err}");
    }
    // Environment rays are counted apart, and the unshadowed term casts none.
    let rays = |args: &[&str]| {
        accepted(&render(dir.path(), args), args);
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("r.json")).unwrap()).unwrap();
        json["frame"]["rays_environment"].as_u64().unwrap()
    };
    assert!(rays(&["--method", "full"]) > 0);
    assert_eq!(rays(&["--method", "full", "--env-light", "unshadowed"]), 0);
    assert_eq!(rays(&["--method", "full", "--env-samples", "0"]), 0);
}

#[test]
#[cfg(unix)]
fn gaze_csv_and_camera_path_must_be_regular_files() {
    // Read to the end, /dev/zero would exhaust memory, and a FIFO would wait for a writer.
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("gaze.fifo");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success());
    let mut inputs = vec![("--gaze-csv", Path::new("/dev/zero"))];
    if made {
        inputs.push(("--gaze-csv", fifo.as_path()));
    }
    inputs.push(("--camera-path", Path::new("/dev/zero")));
    inputs.push(("--gaze-csv", dir.path()));
    for (flag, path) in inputs {
        let o = fovea()
            .args([
                "sequence", "--res", "64x72", "--frames", "2", "--video", "off",
            ])
            .args(["-q", flag])
            .arg(path)
            .arg("--out")
            .arg(dir.path().join("seq"))
            .timeout(std::time::Duration::from_secs(120))
            .output()
            .unwrap();
        let err = refused(&o, &[flag]);
        assert!(
            err.contains(&path.display().to_string()) && err.contains("only regular files"),
            "{err}"
        );
    }
    // A gaze CSV that is not UTF-8 names the offset.
    let latin1 = dir.path().join("latin1.csv");
    std::fs::write(&latin1, b"t,x,y\n0,1,1\n# caf\xe9\n").unwrap();
    let o = fovea()
        .args([
            "sequence", "--res", "64x72", "--frames", "2", "--video", "off",
        ])
        .arg("-q")
        .arg("--gaze-csv")
        .arg(&latin1)
        .arg("--out")
        .arg(dir.path().join("seq"))
        .output()
        .unwrap();
    let err = refused(&o, &["latin1"]);
    assert!(
        err.contains("not UTF-8") && err.contains("offset 17"),
        "{err}"
    );
}
