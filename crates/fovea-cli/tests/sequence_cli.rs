//! `fovea sequence`: numbered frames, the eye-state table, resuming an interrupted run,
//! refusing a folder of other settings, gaze CSV input and bad gaze files.

use std::path::Path;

use assert_cmd::Command;

mod common;

fn fovea() -> Command {
    Command::cargo_bin("fovea").unwrap()
}

fn run(out: &Path, extra: &[&str]) -> std::process::Output {
    fovea()
        .args([
            "sequence", "--res", "120x90", "--lights", "1", "--frames", "4",
        ])
        .args(["--dof", "gather", "--video", "off", "-q", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn frames_resume_and_settings_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("seq");
    let first = ok(&run(&out, &[]));
    assert!(first.contains("4 rendered, 0 already there"), "{first}");
    for i in 0..4 {
        assert!(out.join(format!("frame_{i:05}.png")).is_file());
    }
    // The eye state of every frame: gaze and the accommodated focus.
    let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
    for line in csv.lines().skip(1) {
        let focus: f64 = line.rsplit(',').next().unwrap().parse().unwrap();
        assert!(focus > 0.0 && focus.is_finite(), "{line}");
    }
    // Nothing to do the second time; one lost frame is rendered again, alone.
    let again = ok(&run(&out, &[]));
    assert!(again.contains("0 rendered, 4 already there"), "{again}");
    let kept = std::fs::read(out.join("frame_00001.png")).unwrap();
    std::fs::remove_file(out.join("frame_00002.png")).unwrap();
    // A half-written frame (as a killed run would leave under its temporary name) is ignored.
    std::fs::write(out.join("frame_00003.png.tmp"), b"partial").unwrap();
    let resumed = ok(&run(&out, &[]));
    assert!(resumed.contains("1 rendered, 3 already there"), "{resumed}");
    assert_eq!(std::fs::read(out.join("frame_00001.png")).unwrap(), kept);
    // Other settings: refused, unless --overwrite.
    let other = run(&out, &["--method", "kfr"]);
    assert!(!other.status.success());
    let err = String::from_utf8_lossy(&other.stderr);
    assert!(
        err.contains("--overwrite") && !err.contains("panicked"),
        "{err}"
    );
    let fresh = ok(&run(&out, &["--method", "kfr", "--overwrite"]));
    assert!(fresh.contains("4 rendered"), "{fresh}");
    // The environment light is a setting of the sequence like any other: another one is
    // refused in the same folder; out-of-range rays are a one-line error.
    let env = run(&out, &["--method", "kfr", "--env-light", "unshadowed"]);
    assert!(!env.status.success());
    assert!(String::from_utf8_lossy(&env.stderr).contains("--overwrite"));
    let bad = run(&dir.path().join("bad"), &["--env-samples", "999"]);
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("env-samples") && err.trim_end().lines().count() == 1,
        "{err}"
    );
}

#[test]
fn gaze_csv_with_blinks_and_bad_files() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("gaze.csv");
    std::fs::write(
        &good,
        "timestamp_ms,x_norm,y_norm,confidence\n0,0.5,0.5,0.9\n10,0.52,0.5,0.9\n20,NaN,0.5,0.9\n30,0.55,0.52,0.95\n40,0.6,0.52,0.2\n",
    )
    .unwrap();
    let o = ok(&run(
        &dir.path().join("a"),
        &["--gaze-csv", good.to_str().unwrap()],
    ));
    assert!(o.contains("4 rendered"), "{o}");
    let csv = std::fs::read_to_string(dir.path().join("a/frames.csv")).unwrap();
    // The blink at 20 ms holds the last valid gaze and is marked invalid.
    assert!(csv.lines().nth(3).unwrap().contains(",false,"), "{csv}");
    for (name, text) in [
        ("missing.csv", "timestamp_ms,x_norm\n0,0.5\n"),
        ("order.csv", "t,x,y\n0,10,10\n0.02,11,10\n0.01,12,10\n"),
        ("empty.csv", ""),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        let o = run(&dir.path().join(name), &["--gaze-csv", p.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{name}");
        assert!(
            err.contains("error") && !err.contains("panicked"),
            "{name}: {err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{name}: {err}");
    }
    // A camera path: a dolly towards the scene; bad paths are one-line errors.
    let path = dir.path().join("path.csv");
    std::fs::write(
        &path,
        "t,x,y,z,look_x,look_y,look_z\n0,0,1.6,0,0,1.4,-10\n0.05,0,1.6,-1,0,1.4,-11\n",
    )
    .unwrap();
    let o = ok(&run(
        &dir.path().join("d"),
        &["--camera-path", path.to_str().unwrap()],
    ));
    assert!(o.contains("4 rendered"), "{o}");
    let a = std::fs::read(dir.path().join("d/frame_00000.png")).unwrap();
    let b = std::fs::read(dir.path().join("d/frame_00003.png")).unwrap();
    assert_ne!(a, b, "the camera moved");
    std::fs::write(&path, "t,x,y,z,look_x,look_y,look_z\n0,0,1.6,0,0,1.6,0\n").unwrap();
    let o = run(
        &dir.path().join("e"),
        &["--camera-path", path.to_str().unwrap()],
    );
    assert!(!o.status.success());
    assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
    let o = run(&dir.path().join("b"), &["--frames", "0"]);
    assert!(!o.status.success());
    let o = run(&dir.path().join("c"), &["--scenario", "dance"]);
    assert!(!o.status.success());
}

#[test]
fn inset_analysis_reports_every_smoothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = fovea()
        .args([
            "inset-analysis",
            "--res",
            "160x120",
            "--lights",
            "1",
            // The smoothing rows as before issue 38's viewer shading (which adds the noise
            // floor's row and lets Area1 move with the noise); inset_cli covers that mode.
            "--shading",
            "noise-free",
            "--json",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    let names: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    assert_eq!(
        names,
        [
            "full",
            "none",
            "alpha-blend",
            "gaussian-1d",
            "gaussian-2d",
            "gaussian-1d-alpha",
            "gaussian-2d-alpha",
            "laplacian"
        ]
    );
    for r in rows {
        let a1 = r["report"]["areas"][0]["mean_x"].as_f64().unwrap();
        assert!(a1.is_finite() && a1 >= 0.0, "{r}");
        assert!(
            r["area1_change"].as_f64().unwrap().abs() < 0.05,
            "Area1 is the inset: {r}"
        );
    }
    let bad = fovea()
        .args(["inset-analysis", "--res", "161x120", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(!String::from_utf8_lossy(&bad.stderr).contains("panicked"));
}

#[test]
fn temporal_sequence_resumes_with_the_same_frames() {
    // With accumulation a frame depends on the ones before it: a resumed run rebuilds the
    // history from the frames before the first missing one, so it writes the same images.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("seq");
    let extra = [
        "--temporal",
        "on",
        "--method",
        "weier",
        "--peripheral-contrast",
        "0.5",
    ];
    let first = ok(&run(&out, &extra));
    assert!(first.contains("4 rendered, 0 already there"), "{first}");
    let before: Vec<Vec<u8>> = (2..4)
        .map(|i| std::fs::read(out.join(format!("frame_{i:05}.png"))).unwrap())
        .collect();
    for i in 2..4 {
        std::fs::remove_file(out.join(format!("frame_{i:05}.png"))).unwrap();
    }
    let resumed = ok(&run(&out, &extra));
    assert!(resumed.contains("2 rendered, 2 already there"), "{resumed}");
    for (k, i) in (2..4).enumerate() {
        let now = std::fs::read(out.join(format!("frame_{i:05}.png"))).unwrap();
        assert!(now == before[k], "frame {i} differs after resuming");
    }
    // Bad temporal options: one-line errors.
    for bad in [
        ["--temporal", "maybe"],
        ["--alpha-min", "0"],
        ["--peripheral-contrast", "-1"],
    ] {
        let o = run(&out, &bad);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && !err.contains("panicked"),
            "{bad:?}: {err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{bad:?}: {err}");
    }
}

#[test]
fn flicker_runs_and_rejects_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("flicker");
    let o = fovea()
        .args([
            "flicker",
            "--res",
            "96x80",
            "--lights",
            "1",
            "--frames",
            "4",
            "--methods",
            "vafr,weier",
            "-q",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let text = ok(&o);
    assert!(
        text.contains("| vafr | on |") && text.contains("| weier | off |"),
        "{text}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("flicker.json")).unwrap()).unwrap();
    let variants = json["variants"].as_array().unwrap();
    assert_eq!(variants.len(), 4);
    for v in variants {
        assert_eq!(v["flicker"]["frames"].as_array().unwrap().len(), 3);
    }
    let csv = std::fs::read_to_string(out.join("flicker-frames.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 4 * 4, "{csv}");
    for bad in [
        vec!["flicker", "--frames", "1"],
        vec!["flicker", "--methods", "full"],
        vec!["flicker", "--methods", "vafr,nope"],
        vec!["flicker", "--bands", "5,1"],
        vec!["flicker", "--temporal", "sometimes"],
        vec!["flicker", "--reference-spp", "0"],
        vec!["flicker", "--camera-move", "1,nan,0"],
        vec!["flicker", "--shading", "sometimes"],
        vec!["flicker", "--shading", "indirect", "--bounces", "0"],
    ] {
        let o = fovea().args(&bad).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && !err.contains("panicked"),
            "{bad:?}: {err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{bad:?}: {err}");
    }
}

#[test]
fn flicker_scores_the_noisy_shading_when_asked() {
    // Issue 38: with --shading the frames carry the viewer's Monte Carlo noise (and the
    // denoiser), so the same sequence flickers differently from the noise-free one.
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str], name: &str| {
        let out = dir.path().join(name);
        let o = fovea()
            .args([
                "flicker",
                "--res",
                "96x80",
                "--lights",
                "1",
                "--frames",
                "3",
                "--methods",
                "vafr",
                "--temporal",
                "on",
                "-q",
                "--out",
            ])
            .arg(&out)
            .args(extra)
            .output()
            .unwrap();
        ok(&o);
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("flicker.json")).unwrap())
                .unwrap();
        json["variants"][0]["flicker"]["frames"].clone()
    };
    let clean = run(&[], "clean");
    let noisy = run(
        &[
            "--shading",
            "direct",
            "--env-samples",
            "1",
            "--denoise",
            "off",
        ],
        "noisy",
    );
    assert_eq!(clean.as_array().unwrap().len(), 2);
    assert_ne!(clean, noisy);
}

#[test]
fn a_gaze_csv_vergence_depth_drives_the_focus() {
    let dir = tempfile::tempdir().unwrap();
    // The same gaze, first without a depth column (focus from the depth buffer), then with a
    // vergence depth of 0.45 m the scene has nowhere near the gaze.
    let rows: String = (0..10).map(|k| format!("{},0.5,0.5\n", k * 100)).collect();
    let plain = dir.path().join("plain.csv");
    std::fs::write(&plain, format!("timestamp_ms,x_norm,y_norm\n{rows}")).unwrap();
    let rows: String = (0..10)
        .map(|k| format!("{},0.5,0.5,0.45\n", k * 100))
        .collect();
    let verged = dir.path().join("verged.csv");
    std::fs::write(
        &verged,
        format!("timestamp_ms,x_norm,y_norm,depth_m\n{rows}"),
    )
    .unwrap();
    let last_row = |out: &str, csv: &Path| -> (String, f64) {
        let o = fovea()
            .args([
                "sequence", "--res", "120x90", "--lights", "1", "--frames", "10",
            ])
            .args([
                "--fps", "10", "--dof", "gather", "--focus", "auto", "--video", "off",
            ])
            .args(["-q", "--gaze-csv", csv.to_str().unwrap(), "--out"])
            .arg(dir.path().join(out))
            .output()
            .unwrap();
        ok(&o);
        let text = std::fs::read_to_string(dir.path().join(out).join("frames.csv")).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let last: Vec<String> = text
            .lines()
            .last()
            .unwrap()
            .split(',')
            .map(str::to_string)
            .collect();
        let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
        (
            last[col("focus_source")].clone(),
            last[col("focus_m")].parse().unwrap(),
        )
    };
    let (source, buffer_m) = last_row("plain", &plain);
    assert_eq!(source, "depth-buffer");
    let (source, focus_m) = last_row("verged", &verged);
    assert_eq!(source, "tracker-depth");
    // The gaze is at the screen centre, so the depth along the view axis is the vergence.
    assert!((focus_m - 0.45).abs() < 0.01, "{focus_m}");
    assert!((buffer_m - 0.45).abs() > 0.2, "depth buffer {buffer_m} m");
}

#[test]
fn a_photometric_sequence_is_exposed_once_for_all_its_frames() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::photometric_ground(dir.path(), 6830.0);
    let out = dir.path().join("seq");
    let run = || {
        fovea()
            .args([
                "sequence", "--res", "64x48", "--method", "full", "--frames", "3",
            ])
            .args(["--video", "off", "-q", "--scene"])
            .arg(&scene)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap()
    };
    let o = run();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("exposed automatically"), "{err}");
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("sequence.json")).unwrap()).unwrap();
    let stops = manifest["exposure_stops"].as_f64().unwrap();
    assert!(stops < -8.0, "{stops}");
    // Every frame is a picture, not white: the metered exposure applied to all of them.
    for i in 0..3 {
        let img = image::open(out.join(format!("frame_{i:05}.png")))
            .unwrap()
            .to_rgb8();
        let white = img.pixels().filter(|p| p.0 == [255; 3]).count();
        assert!(
            white * 100 < img.pixels().count(),
            "frame {i}: {white} white pixels"
        );
    }
    // Metering again on resume gives the same exposure, so the folder resumes.
    let o = run();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 rendered, 3 already there"));
}
