//! `fovea report` end to end: every section's tables present with finite numbers (checked by
//! `--verify`), one failing section reported in place while the rest is written, and bad
//! options refused before anything runs.

use std::path::Path;

use assert_cmd::Command;

fn fovea() -> Command {
    Command::cargo_bin("fovea").unwrap()
}

fn json(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

fn section<'a>(j: &'a serde_json::Value, id: &str) -> &'a serde_json::Value {
    j["sections"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["id"] == id)
        .unwrap_or_else(|| panic!("no section {id}"))
}

#[test]
fn quick_report_of_the_builtin_scene_has_every_table_and_passes_verify() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let run = fovea()
        .args([
            "report", "--quick", "--res", "320x360", "--vfov", "100", "-q",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    for f in ["report.html", "report.md", "report.json"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let v = fovea()
        .args(["report", "--verify"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stdout));
    let j = json(&out);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for s in j["sections"].as_array().unwrap() {
        assert_eq!(s["status"], "ok", "{s}");
        for t in s["tables"].as_array().unwrap() {
            let id = t["id"].as_str().unwrap();
            assert!(html.contains(&format!("<table id=\"{id}\">")), "{id}");
        }
    }
    // The numbers are the measurements: Table 1's VaFR(60°) row is the constant 1,061,630 samples,
    // and the quality table holds one whole-frame row per foveation method.
    let t1 = &section(&j, "samples")["tables"][0];
    let vafr = t1["rows"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r[0] == "vafr(60°)")
        .unwrap();
    assert!(vafr.as_array().unwrap()[1..].iter().all(|c| c == 1_061_630));
    let q = section(&j, "quality");
    // The viewer's shading by default (issue 38): the reference is supersampled (32 rays per
    // pixel with --quick) and its twin of another seed is scored first (the noise floor),
    // then the one-ray full frame and the seven methods.
    assert_eq!(q["data"]["shading"], "viewer");
    assert_eq!(q["data"]["reference_pixel_samples"], 32);
    assert!(q["data"]["noise_floor"]["psnr_db"].as_f64().unwrap() > 0.0);
    assert_eq!(q["tables"][0]["rows"].as_array().unwrap().len(), 9);
    assert_eq!(
        q["tables"][0]["rows"][0][0],
        "reference, seed 1 (noise floor)"
    );
    assert_eq!(q["tables"][0]["rows"][1][0], "full");
    assert_eq!(q["tables"][1]["rows"].as_array().unwrap().len(), 36);
    // Reproducibility: command, revision and seed are on the page.
    let keys: Vec<&str> = j["provenance"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["key"].as_str().unwrap())
        .collect();
    for k in ["command", "git revision", "seed", "CPU"] {
        assert!(keys.contains(&k), "{k}");
    }
}

#[test]
fn a_failing_section_is_reported_in_place_and_the_rest_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    // 322 px is not divisible by the inset periphery's factor 4: only that section fails.
    let run = fovea()
        .args([
            "report",
            "--quick",
            "--res",
            "322x360",
            "--sections",
            "quality,inset,samples",
            "-q",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains("1 of 3 sections failed (inset: invalid parameter `display`"),
        "{err}"
    );
    let j = json(&out);
    assert_eq!(section(&j, "inset")["status"], "failed");
    assert!(section(&j, "inset")["error"]
        .as_str()
        .unwrap()
        .contains("periphery factor 4"));
    for ok in ["samples", "quality"] {
        assert_eq!(section(&j, ok)["status"], "ok");
    }
    // Sections run in page order whatever the order asked.
    let ids: Vec<&str> = j["sections"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["samples", "inset", "quality"]);
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("**This section failed:** invalid parameter `display`"));
    let v = fovea()
        .args(["report", "--verify"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!v.status.success());
    let listed = String::from_utf8_lossy(&v.stdout);
    assert!(listed.contains("section `inset` failed"), "{listed}");
    assert!(
        listed.contains("table `inset-gradient` is missing"),
        "{listed}"
    );
}

/// The flicker section follows a recorded viewing (`fovea view --record`: gaze.csv,
/// camera.csv) when given one, and says so in its text and its reproduce line.
#[test]
fn the_flicker_section_follows_a_recorded_viewing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("gaze.csv"),
        "t_s,x_px,y_px,depth_m,confidence\n0,100,80,,1\n0.011111,150,90,,1\n0.022222,160,100,,0\n",
    )
    .unwrap();
    std::fs::write(
        d.join("camera.csv"),
        "t,x,y,z,look_x,look_y,look_z,up_x,up_y,up_z\n0,0,1.5,6,0,1.4,5,0,1,0\n0.05,0.3,1.5,6,0.3,1.4,5,0,1,0\n",
    )
    .unwrap();
    let out = d.join("report");
    let run = fovea()
        .args([
            "report",
            "--quick",
            "--sections",
            "flicker",
            "--flicker-frames",
            "3",
        ])
        .args(["--res", "320x180", "-q", "--gaze-csv"])
        .arg(d.join("gaze.csv"))
        .arg("--camera-path")
        .arg(d.join("camera.csv"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(section(&json(&out), "flicker")["status"], "ok");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("the gaze of ") && md.contains("gaze.csv"),
        "{md}"
    );
    assert!(md.contains("the camera following "), "{md}");
    assert!(
        md.contains("--camera-path ") && md.contains("--gaze-csv "),
        "{md}"
    );
    let v = fovea()
        .args(["report", "--verify"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stdout));
}

#[test]
fn bad_options_are_refused_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    for (args, needle) in [
        (
            vec!["--sections", "samples,teapot"],
            "unknown section `teapot`",
        ),
        (vec!["--flicker-frames", "1"], "flicker-frames"),
        (vec!["--bench-res", "0x0"], "0x0"),
        (vec!["--gaze", "nan,3"], "gaze"),
        (vec!["--scene", "/nonexistent/scene.glb"], "nonexistent"),
    ] {
        let out = dir.path().join("r");
        let run = fovea()
            .args(["report", "-q"])
            .args(&args)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{args:?}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(!out.join("report.json").exists(), "{args:?}");
    }
    let missing = fovea()
        .args(["report", "--verify"])
        .arg(dir.path().join("nothing"))
        .output()
        .unwrap();
    assert!(!missing.status.success());
    assert!(String::from_utf8_lossy(&missing.stderr).contains("cannot read"));
}
