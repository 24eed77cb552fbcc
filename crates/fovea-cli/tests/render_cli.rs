//! `fovea render` and `fovea bench` end to end: outputs, JSON shapes, and bad input that must
//! end in a one-line error (never a panic) before any large allocation.

use std::path::{Path, PathBuf};

use assert_cmd::Command;

mod common;
use common::photometric_ground;

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

/// Runs `fovea args…`, expects failure, and returns stderr after checking it is a clean error.
fn fails(args: &[&str]) -> String {
    let out = fovea().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} succeeded:\n{err}");
    assert!(!err.contains("panicked"), "{args:?} panicked:\n{err}");
    assert!(err.contains("error"), "{args:?}: no error line:\n{err}");
    err
}

#[test]
fn render_writes_image_stats_depth_and_density() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("f.png");
    let depth = dir.path().join("d.exr");
    let density = dir.path().join("s.png");
    let out = fovea()
        .args([
            "render", "--res", "480x270", "--method", "vafr", "--gaze", "200,100",
        ])
        .args(["--lights", "3", "-q", "--out"])
        .arg(&png)
        .arg("--depth-out")
        .arg(&depth)
        .arg("--density-out")
        .arg(&density)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for p in [&png, &depth, &density] {
        assert!(std::fs::metadata(p).unwrap().len() > 100, "{}", p.display());
    }
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("f.json")).unwrap()).unwrap();
    let f = &stats["frame"];
    assert_eq!(f["method"], "vafr");
    assert_eq!(f["width"], 480);
    assert!(f["rays_primary"].as_u64().unwrap() > 0);
    assert_eq!(
        f["rays"].as_u64().unwrap(),
        f["rays_primary"].as_u64().unwrap()
            + f["rays_shadow"].as_u64().unwrap()
            + f["rays_environment"].as_u64().unwrap()
            + f["rays_bounce"].as_u64().unwrap()
    );
    // The sample-space denoiser is on by default (issue 38).
    for stage in ["plan", "trace", "shade", "denoise", "aa", "reconstruct"] {
        assert!(f["stages_ms"][stage].as_f64().is_some(), "{stage}");
    }
    assert!(f["denoise"]["filtered"].as_u64().unwrap() > 0);
    assert_eq!(stats["denoise"]["iterations"], 4);
}

#[test]
fn denoise_off_leaves_out_its_stage_and_bad_choices_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("f.png");
    let out = fovea()
        .args([
            "render",
            "--res",
            "160x90",
            "--method",
            "vafr",
            "--denoise",
            "off",
        ])
        .args(["-q", "--out"])
        .arg(&png)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("f.json")).unwrap()).unwrap();
    assert!(stats["frame"]["stages_ms"]["denoise"].is_null());
    assert!(stats["frame"]["denoise"].is_null());
    assert!(stats["denoise"].is_null());
    let err = fails(&["render", "--res", "160x90", "--denoise", "maybe", "-q"]);
    assert!(err.contains("--denoise"), "{err}");
    let err = fails(&[
        "render",
        "--res",
        "160x90",
        "--denoise-iterations",
        "9",
        "-q",
    ]);
    assert!(err.contains("--denoise-iterations"), "{err}");
}

#[test]
fn bench_json_has_the_documented_shape() {
    let out = fovea()
        .args(["bench", "--res", "320x180,400x300", "--methods", "vafr,kfr"])
        .args(["--lights", "2", "--bvh-rays", "20000", "--json", "-q"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let runs = v["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 6, "full + 2 methods at 2 resolutions");
    for r in runs {
        for key in ["method", "width", "height", "rays", "total_ms", "stages_ms"] {
            assert!(r.get(key).is_some(), "missing {key}: {r}");
        }
        let s = r["speedup_vs_full"].as_f64().unwrap();
        assert!(s.is_finite() && s > 0.0);
        if r["method"] == "full" {
            assert_eq!(s, 1.0);
        }
    }
    assert_eq!(runs[3]["width"], 400);
    let bvh = v["bvh_throughput"].as_array().unwrap();
    assert!(bvh
        .iter()
        .any(|b| b["backend"] == "obvhs" && b["primary_mrays_per_s"].as_f64().unwrap() > 0.0));
}

#[test]
fn impossible_requests_are_refused_before_allocating() {
    // 40000 pixels wide: beyond any display.
    let e = fails(&["render", "--res", "40000x40000", "-q"]);
    assert!(e.contains("res"), "{e}");
    // A retinal full frame under a 64 MiB budget.
    let e = fails(&[
        "render",
        "--headset",
        "retinal",
        "--method",
        "full",
        "--max-memory",
        "64M",
        "-q",
    ]);
    assert!(e.contains("GiB") && e.contains("--max-memory"), "{e}");
    let e = fails(&["bench", "--res", "retinal", "--max-memory", "64M", "-q"]);
    assert!(e.contains("--max-memory"), "{e}");
}

#[test]
fn bad_parameters_give_one_clear_error() {
    for (args, needle) in [
        (&["render", "--gaze", "NaN,3", "-q"][..], "gaze"),
        (
            &["render", "--gaze", "5000,3", "--res", "640x360", "-q"][..],
            "gaze",
        ),
        (&["render", "--lights", "0", "-q"][..], "lights"),
        (&["render", "--method", "sparkle", "-q"][..], "method"),
        (&["render", "--res", "0x10", "-q"][..], "res"),
        (
            &["render", "--scene", "no/such/file.glb", "-q"][..],
            "no/such/file.glb",
        ),
        (&["render", "--scene", "x.fbx", "-q"][..], "fbx"),
        (
            &["render", "--out", "frame.tiff", "--res", "64x64", "-q"][..],
            "tiff",
        ),
        (&["bench", "--res", "2k,banana", "-q"][..], "banana"),
    ] {
        let e = fails(args);
        assert!(e.contains(needle), "{args:?}: {e}");
        assert!(e.trim().lines().count() <= 3, "{args:?}: {e}");
    }
}

#[test]
fn camera_inside_a_closed_mesh_is_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("box.obj");
    // A closed cube of side 2 around the origin.
    let mut text = String::new();
    for z in [-1, 1] {
        for y in [-1, 1] {
            for x in [-1, 1] {
                text += &format!("v {x} {y} {z}\n");
            }
        }
    }
    for f in [
        "1 3 4 2", "5 6 8 7", "1 2 6 5", "3 7 8 4", "1 5 7 3", "2 4 8 6",
    ] {
        text += &format!("f {f}\n");
    }
    std::fs::write(&obj, text).unwrap();
    let scene = obj.to_str().unwrap();
    let base = [
        "render",
        "--scene",
        scene,
        "--camera-pos",
        "0,0,0",
        "--res",
        "64x64",
    ];
    let e = fails(&[&base[..], &["-q"]].concat());
    assert!(e.contains("inside") && e.contains("--allow-inside"), "{e}");
    let png = dir.path().join("in.png");
    let out = fovea()
        .args(base)
        .args(["--allow-inside", "-q", "--out"])
        .arg(&png)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The mesh has no lights: a warning and generated lights, not an error.
    assert!(String::from_utf8_lossy(&out.stderr).contains("no lights"));
}

#[test]
fn draco_compressed_chess_board_names_the_extension() {
    let Some(scenes) = shared_scenes() else {
        return;
    };
    let board = scenes.join("chess-board/chess-board.glb");
    let e = fails(&[
        "render",
        "--scene",
        board.to_str().unwrap(),
        "--res",
        "64x64",
        "-q",
    ]);
    assert!(e.contains("KHR_draco_mesh_compression"), "{e}");
}

#[test]
fn binocular_render_and_bench() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("stereo.png");
    let o = Command::cargo_bin("fovea")
        .unwrap()
        .args([
            "render", "--eyes", "both", "--stereo", "rep", "--res", "160x180", "--lights", "1",
            "-q", "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Side by side: twice the width.
    assert_eq!(image::image_dimensions(&out).unwrap(), (320, 180));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.with_extension("json")).unwrap())
            .unwrap();
    let st = &json["stereo"];
    assert_eq!(st["mode"], "rep");
    assert!(st["rays_primary_right"].as_u64().unwrap() < st["rays_primary_left"].as_u64().unwrap());
    let b = Command::cargo_bin("fovea")
        .unwrap()
        .args([
            "bench",
            "--res",
            "160x180",
            "--eyes",
            "both",
            "--stereo-reps",
            "1",
            "--bvh-rays",
            "0",
            "--lights",
            "1",
            "--json",
            "-q",
        ])
        .output()
        .unwrap();
    assert!(b.status.success(), "{}", String::from_utf8_lossy(&b.stderr));
    let bj: serde_json::Value = serde_json::from_slice(&b.stdout).unwrap();
    let row = &bj["binocular"][0];
    assert_eq!(row["method"], "vafr");
    assert!(row["rep_over_dup_rays"].as_f64().unwrap() < 0.6);
    for bad in [
        vec!["render", "--eyes", "three"],
        vec!["render", "--eyes", "both", "--stereo", "triple"],
        vec!["render", "--eyes", "both", "--depth-out", "d.png"],
        vec!["bench", "--eyes", "both", "--stereo-reps", "0"],
    ] {
        one_line_error(&bad);
    }
}

#[test]
fn demo_writes_frames_reference_overlay_and_index() {
    let dir = tempfile::tempdir().unwrap();
    let o = Command::cargo_bin("fovea")
        .unwrap()
        .args(["demo", "--frames", "2", "-q", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let d = dir.path().join("demo");
    for f in [
        "frame_00000.png",
        "frame_00001.png",
        "reference.png",
        "side-by-side.png",
        "density-overlay.png",
        "crop-gaze.png",
        "crop-periphery.png",
        "difference.png",
    ] {
        assert!(image::image_dimensions(d.join(f)).is_ok(), "{f}");
    }
    // Two zoomed 133×133 crops side by side, ×2 (1600/12 px, 360/133).
    assert_eq!(
        image::image_dimensions(d.join("crop-gaze.png")).unwrap(),
        (532, 266)
    );
    assert_eq!(
        image::image_dimensions(d.join("side-by-side.png")).unwrap(),
        (2880, 1600)
    );
    let html = std::fs::read_to_string(d.join("index.html")).unwrap();
    assert!(html.contains("side-by-side.png") && html.contains("VaFR"));
    // The default `--backend auto` says where the frames were made (the CPU without a
    // hardware GPU or without the `gpu` feature).
    assert!(html.contains("Foveated frames rendered on: "), "{html}");
    for part in [
        "crop-gaze.png",
        "crop-periphery.png",
        "difference.png",
        "ring marks",
    ] {
        assert!(html.contains(part), "{part}");
    }
    assert!(String::from_utf8_lossy(&o.stdout).contains("index.html"));
    for bad in [
        vec!["demo", "--frames", "0"],
        vec!["demo", "--headset", "nope"],
    ] {
        one_line_error(&bad);
    }
}

/// `fovea ARGS` fails with one line on stderr and no panic.
fn one_line_error(args: &[&str]) {
    let o = Command::cargo_bin("fovea")
        .unwrap()
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && !err.contains("panicked"),
        "{args:?}: {err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
}

/// Renders `scene` at 64×48 with `extra` flags; returns (PNG bytes decoded, stats, stderr).
fn render_small(
    dir: &Path,
    scene: &Path,
    name: &str,
    extra: &[&str],
) -> (Vec<u8>, serde_json::Value, String) {
    let png = dir.join(format!("{name}.png"));
    let out = fovea()
        .args([
            "render", "--res", "64x48", "--method", "full", "-q", "--scene",
        ])
        .arg(scene)
        .args(extra)
        .arg("--out")
        .arg(&png)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{extra:?}: {err}");
    let img = image::open(&png).unwrap().to_rgb8().into_raw();
    let stats =
        serde_json::from_slice(&std::fs::read(png.with_extension("json")).unwrap()).unwrap();
    (img, stats, err)
}

#[test]
fn a_photometric_sun_is_exposed_automatically_and_clipping_is_warned() {
    let dir = tempfile::tempdir().unwrap();
    let scene = photometric_ground(dir.path(), 6830.0);
    let white = |img: &[u8]| {
        img.chunks(3)
            .filter(|c| c.iter().all(|&v| v == 255))
            .count() as f64
            / (img.len() / 3) as f64
    };
    let mean = |img: &[u8]| img.iter().map(|&v| f64::from(v)).sum::<f64>() / img.len() as f64;

    // Default: auto exposure for photometric lights, said in a note; a visible picture.
    let (img, stats, err) = render_small(dir.path(), &scene, "auto", &[]);
    assert!(
        err.contains("note: the scene's lights are photometric"),
        "{err}"
    );
    assert_eq!(stats["exposure"]["mode"], "auto");
    let stops = stats["exposure"]["stops"].as_f64().unwrap();
    println!(
        "auto: {stops:+.2} stops (EV100 {:.2}), {:.1} % white pixels, mean code {:.0}",
        stats["exposure"]["ev100"].as_f64().unwrap(),
        100.0 * white(&img),
        mean(&img)
    );
    assert!(stops < -8.0, "a 6,830 lx sun needs a strong cut: {stops}");
    assert!(white(&img) < 0.01, "{}", white(&img));
    assert!((40.0..220.0).contains(&mean(&img)), "{}", mean(&img));

    // The raw values clip: the frame is white below the horizon, and a warning says so.
    let (img, stats, err) = render_small(dir.path(), &scene, "raw", &["--exposure", "0"]);
    assert!(
        err.contains("warning:") && err.contains("clip to white"),
        "{err}"
    );
    println!(
        "--exposure 0: {:.1} % white pixels, clipped fraction {:.3}",
        100.0 * white(&img),
        stats["exposure"]["clipped_fraction"].as_f64().unwrap()
    );
    assert!(white(&img) > 0.5, "{}", white(&img));
    assert!(stats["exposure"]["clipped_fraction"].as_f64().unwrap() > 0.5);

    // A camera's EV100 is recorded as given.
    let (_, stats, _) = render_small(dir.path(), &scene, "ev", &["--ev100", "12"]);
    assert_eq!(stats["exposure"]["mode"], "ev100");
    assert!((stats["exposure"]["ev100"].as_f64().unwrap() - 12.0).abs() < 1e-4);
}

#[test]
fn the_file_camera_field_of_view_sets_a_custom_resolution() {
    let dir = tempfile::tempdir().unwrap();
    let scene = photometric_ground(dir.path(), 10.0);
    let fov = 0.7f64.to_degrees().to_string();
    let (file, _, err) = render_small(dir.path(), &scene, "file", &["--exposure", "0"]);
    assert!(
        err.contains("note: vertical field of view 40.1° from the scene file's camera"),
        "{err}"
    );
    let (same, _, _) = render_small(
        dir.path(),
        &scene,
        "same",
        &["--exposure", "0", "--vfov", &fov],
    );
    let (wide, _, _) = render_small(
        dir.path(),
        &scene,
        "wide",
        &["--exposure", "0", "--vfov", "90"],
    );
    assert_eq!(
        file, same,
        "the file's yfov and --vfov with the same value differ"
    );
    assert_ne!(file, wide, "the file's 40° and --vfov 90 render alike");
}
