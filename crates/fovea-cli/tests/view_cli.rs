//! `fovea view` (built with `--features view`), headless: a window on a display server (Xvfb
//! in CI) drawn by any Vulkan device (lavapipe in CI). Its screenshot equals the offline
//! `fovea render` of the same view and gaze; its recording replays through `fovea sequence`
//! to the same frames; no display server is a one-line error with exit status 2.
//!
//! The window tests need `DISPLAY` (or `WAYLAND_DISPLAY`): without one they print why and
//! pass, unless `FOVEA_REQUIRE_DISPLAY=1` (CI runs them under `xvfb-run` with it set).
#![cfg(feature = "view")]

use std::path::Path;

use assert_cmd::Command;

fn fovea() -> Command {
    let mut c = Command::cargo_bin("fovea").unwrap();
    // Mesa complains on stderr without a runtime directory.
    c.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    c
}

/// Whether a display server is there; otherwise the reason the test is skipped (a failure
/// with `FOVEA_REQUIRE_DISPLAY=1`).
fn display_or_skip(test: &str) -> bool {
    let set = |k: &str| std::env::var_os(k).is_some_and(|v| !v.is_empty());
    if set("DISPLAY") || set("WAYLAND_DISPLAY") {
        return true;
    }
    assert!(
        std::env::var("FOVEA_REQUIRE_DISPLAY").as_deref() != Ok("1"),
        "FOVEA_REQUIRE_DISPLAY=1 but neither DISPLAY nor WAYLAND_DISPLAY is set"
    );
    eprintln!("skipping {test}: no DISPLAY or WAYLAND_DISPLAY (run under xvfb-run)");
    false
}

fn run_ok(c: &mut Command) -> std::process::Output {
    let out = c.output().unwrap();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn rgb(p: &Path) -> image::RgbImage {
    image::open(p)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
        .to_rgb8()
}

/// Luma PSNR of two 8-bit images (∞ when equal).
fn luma_psnr(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    assert_eq!(a.dimensions(), b.dimensions());
    let luma = |p: &image::Rgb<u8>| {
        0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
    };
    let mse = a
        .pixels()
        .zip(b.pixels())
        .map(|(p, q)| (luma(p) - luma(q)).powi(2))
        .sum::<f64>()
        / f64::from(a.width() * a.height());
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64.powi(2) / mse).log10()
    }
}

const VIEW: [&str; 7] = [
    "--res",
    "320x180",
    "--lights",
    "2",
    "--backend",
    "cpu",
    "-q",
];

/// An X server that never answers: the first connection is retried for 5 s, then one line
/// names the display, the attempts and the reason (issue 39), before the scene loads.
#[test]
fn an_absent_x_server_is_retried_then_one_line() {
    let t = std::time::Instant::now();
    let out = fovea()
        .args(["view", "--frames", "1", "--res", "64x72"])
        .env("DISPLAY", ":4917")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .unwrap();
    let secs = t.elapsed().as_secs_f64();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(
        lines[0].starts_with(
            "error: no display server: cannot connect to the X server DISPLAY=:4917 ("
        ),
        "{err}"
    );
    assert!(lines[0].contains("attempts over 5 s"), "{err}");
    assert!(secs >= 5.0, "gave up after {secs:.1} s");
}

#[test]
fn no_display_server_is_one_line_naming_the_variables() {
    let out = fovea()
        .args(["view", "--frames", "1"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].starts_with("error: no display server"), "{err}");
    assert!(
        err.contains("DISPLAY") && err.contains("WAYLAND_DISPLAY"),
        "{err}"
    );
}

#[test]
fn impossible_options_are_refused_before_a_window_opens() {
    for (args, what) in [
        (&["--scale", "2"][..], "scale"),
        (&["--fps", "0"][..], "fps"),
        (&["--frames", "0"][..], "frames"),
        (&["--screenshot", "a.png"][..], "--screenshot"),
        (&["--speed", "NaN"][..], "speed"),
    ] {
        let out = fovea().arg("view").args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(what), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// The headless viewer's screenshot is the offline render of the same view and gaze: the same
/// plan and stages, the same exposure and tone curve (issue 19: luma PSNR ≥ 40 dB).
#[test]
fn the_screenshot_equals_the_offline_render() {
    if !display_or_skip("the_screenshot_equals_the_offline_render") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let csv = d.join("gaze.csv");
    std::fs::write(&csv, "t,x,y\n0,210,70\n1,210,70\n").unwrap();
    let shot = d.join("shot.png");
    let out = run_ok(
        fovea()
            .arg("view")
            .args(VIEW)
            .args(["--method", "vafr", "--frames", "2", "--gaze-csv"])
            .arg(&csv)
            .arg("--screenshot")
            .arg(&shot),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("2 frames in"), "{stdout}");
    let offline = d.join("render.png");
    run_ok(
        fovea()
            .arg("render")
            .args(VIEW)
            // The viewer's default preset.
            .args(["--quality", "realtime"])
            .args(["--method", "vafr", "--gaze", "210,70", "--out"])
            .arg(&offline),
    );
    let psnr = luma_psnr(&rgb(&shot), &rgb(&offline));
    println!("screenshot against fovea render: luma PSNR {psnr:.2} dB");
    assert!(psnr >= 40.0, "{psnr} dB");
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(shot.with_extension("json")).unwrap()).unwrap();
    assert_eq!(stats["method"], "vafr");
    assert_eq!(stats["gaze"][0], 210.0);
    assert!(stats["frames"][0]["rays_primary"].as_u64().unwrap() > 0);
}

/// No Vulkan device at all (the loader pointed at no driver): the frames render on the CPU
/// and the window is drawn by the CPU, each with a notice; the screenshot is still the
/// offline render.
#[test]
fn no_vulkan_device_falls_back_to_the_cpu_with_a_notice() {
    if !display_or_skip("no_vulkan_device_falls_back_to_the_cpu_with_a_notice") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let csv = d.join("gaze.csv");
    std::fs::write(&csv, "t,x,y\n0,100,120\n1,100,120\n").unwrap();
    let shot = d.join("shot.png");
    let out = run_ok(
        fovea()
            .env("VK_ICD_FILENAMES", d.join("no-driver.json"))
            .args([
                "view",
                "--res",
                "320x180",
                "--lights",
                "2",
                "--backend",
                "auto",
            ])
            .args(["--frames", "1", "--gaze-csv"])
            .arg(&csv)
            .arg("--screenshot")
            .arg(&shot),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("note: rendering on the CPU"), "{err}");
    assert!(err.contains("drawn by the CPU"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let offline = d.join("render.png");
    run_ok(
        fovea()
            .arg("render")
            .args(VIEW)
            // The viewer's default preset.
            .args(["--quality", "realtime"])
            .args(["--gaze", "100,120", "--out"])
            .arg(&offline),
    );
    let psnr = luma_psnr(&rgb(&shot), &rgb(&offline));
    println!("software-presented screenshot against fovea render: luma PSNR {psnr:.2} dB");
    assert!(psnr >= 40.0, "{psnr} dB");
}

/// A viewing recorded with a moving gaze and camera replays through `fovea sequence` to the
/// same frames.
#[test]
fn a_recorded_viewing_replays_through_sequence_to_the_same_frames() {
    if !display_or_skip("a_recorded_viewing_replays_through_sequence_to_the_same_frames") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let gaze = d.join("in-gaze.csv");
    std::fs::write(&gaze, "t,x,y\n0,60,40\n0.05,250,150\n").unwrap();
    let path = d.join("in-camera.csv");
    std::fs::write(
        &path,
        "t,x,y,z,look_x,look_y,look_z\n0,0,1.5,6,0,1,0\n0.05,0.6,1.4,5.5,0,1,0\n",
    )
    .unwrap();
    let rec = d.join("rec");
    let frames = d.join("view-frames");
    let n = "4";
    run_ok(
        fovea()
            .arg("view")
            .args(VIEW)
            .args([
                "--method",
                "kfr",
                "--frames",
                n,
                "--fps",
                "60",
                "--gaze-csv",
            ])
            .arg(&gaze)
            .arg("--camera-path")
            .arg(&path)
            .arg("--record")
            .arg(&rec)
            .arg("--frames-out")
            .arg(&frames),
    );
    let recorded = std::fs::read_to_string(rec.join("gaze.csv")).unwrap();
    assert_eq!(recorded.lines().count(), 5, "{recorded}");
    let seq = d.join("seq");
    run_ok(
        fovea()
            .arg("sequence")
            .args(VIEW)
            .args(["--quality", "realtime"])
            .args([
                "--method", "kfr", "--frames", n, "--fps", "60", "--video", "off",
            ])
            .arg("--gaze-csv")
            .arg(rec.join("gaze.csv"))
            .arg("--camera-path")
            .arg(rec.join("camera.csv"))
            .arg("--out")
            .arg(&seq),
    );
    let mut moved = 0.0f64;
    for i in 0..4 {
        let name = format!("frame_{i:05}.png");
        let v = rgb(&frames.join(&name));
        let s = rgb(&seq.join(&name));
        let psnr = luma_psnr(&v, &s);
        println!("frame {i}: viewer against sequence, luma PSNR {psnr:.2} dB");
        assert!(psnr >= 40.0, "frame {i}: {psnr} dB");
        if i > 0 {
            moved = moved.max(-luma_psnr(&v, &rgb(&frames.join("frame_00000.png"))));
        }
    }
    // The frames differ from one another (the camera and gaze moved).
    assert!(moved > -40.0, "the recorded frames did not change");
}

/// `fovea view --backend gpu --eyes both` (issue 18): both eyes' frames run on the GPU's
/// executors (the right eye borrows the left's: primary rays, AA, reconstruction) and are
/// encoded there; the screenshot is the CPU viewer's within luma PSNR 40 dB. Needs a Vulkan
/// device (lavapipe will do): without one it says why and passes, unless
/// `FOVEA_REQUIRE_GPU=1`.
#[test]
fn gpu_view_runs_both_eyes_on_the_gpu() {
    if !display_or_skip("gpu_view_runs_both_eyes_on_the_gpu") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let csv = d.join("gaze.csv");
    std::fs::write(&csv, "t,x,y\n0,150,80\n1,150,80\n").unwrap();
    let view = |backend: &str| {
        let shot = d.join(format!("{backend}.png"));
        let out = fovea()
            .args(["view", "--res", "320x180", "--lights", "2", "-q"])
            .args(["--method", "vafr", "--eyes", "both", "--frames", "1"])
            // Two rays a pixel: a view the resident frame does not serve, so this test keeps
            // the staged path's lockstep covered (`resident_view_presents_from_the_render_
            // device` covers the resident one).
            .args(["--pixel-samples", "2"])
            .args(["--backend", backend, "--lockstep", "on", "--gaze-csv"])
            .arg(&csv)
            .arg("--screenshot")
            .arg(&shot)
            .output()
            .unwrap();
        (out, shot)
    };
    let (out, gpu) = view("gpu");
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        if err.contains("no GPU adapter")
            && std::env::var("FOVEA_REQUIRE_GPU").as_deref() != Ok("1")
        {
            eprintln!("skipping gpu_view_runs_both_eyes_on_the_gpu: {err}");
            return;
        }
        panic!("{err}");
    }
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(gpu.with_extension("json")).unwrap()).unwrap();
    assert_eq!(stats["eyes"], "both");
    // On the GPU both eyes render at the same time (`--lockstep on`).
    assert_eq!(stats["lockstep"], true, "{stats}");
    for k in 0..2 {
        let f = &stats["frames"][k];
        assert_eq!(f["trace_backend"], "gpu", "eye {k}: {f}");
        assert_eq!(f["aa_backend"], "gpu", "eye {k}: {f}");
        assert_eq!(f["reconstruct_backend"], "gpu", "eye {k}: {f}");
    }
    let (out, cpu) = view("cpu");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let psnr = luma_psnr(&rgb(&gpu), &rgb(&cpu));
    println!("GPU viewer's screenshot (both eyes) against the CPU's: luma PSNR {psnr:.2} dB");
    assert!(psnr >= 40.0, "{psnr} dB");
}

/// `fovea view --backend gpu --eyes both` presents from the render device (issue 37, item
/// 6): with a replayed moving gaze the frames render as the resident GPU frame — both eyes'
/// every pass in one submission — and the window is drawn with that same device, from the
/// frame's own textures. Counted over the frames by `fovea_gpu`'s instrumentation: one
/// submission a frame, no blocking wait, nothing read back but the timestamps (16 B a pass
/// a timed frame) until the screenshot asks for the image (one readback per eye). The
/// HUD's lines carry fps, GPU ms per pass, host ms and bytes; the screenshot is `fovea
/// render --eyes both --stereo dup` of the same view and gaze (luma PSNR ≥ 40 dB). Needs a Vulkan device
/// (lavapipe will do): without one it says why and passes, unless `FOVEA_REQUIRE_GPU=1`.
#[test]
fn resident_view_presents_from_the_render_device() {
    if !display_or_skip("resident_view_presents_from_the_render_device") {
        return;
    }
    const FRAMES: u64 = 6;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let csv = d.join("gaze.csv");
    // Frame i at i/90 s: the gaze moves 24–40 px a frame, then holds for the last two (the
    // screenshot's gaze is then the render's, whatever the tracker's filter).
    let gaze = [
        (100, 60),
        (140, 80),
        (180, 70),
        (150, 110),
        (210, 70),
        (210, 70),
    ];
    let mut text = String::from("t,x,y\n");
    for (i, (x, y)) in gaze.iter().enumerate() {
        text += &format!("{},{x},{y}\n", i as f64 / 90.0);
    }
    std::fs::write(&csv, text).unwrap();
    let shot = d.join("resident.png");
    let out = fovea()
        .args(["view", "--res", "320x180", "--lights", "2"])
        .args(["--method", "vafr", "--eyes", "both", "--denoise", "off"])
        .args(["--backend", "gpu", "--fps", "90", "--frames"])
        .arg(FRAMES.to_string())
        .arg("--gaze-csv")
        .arg(&csv)
        .arg("--screenshot")
        .arg(&shot)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        if err.contains("no GPU adapter")
            && std::env::var("FOVEA_REQUIRE_GPU").as_deref() != Ok("1")
        {
            eprintln!("skipping resident_view_presents_from_the_render_device: {err}");
            return;
        }
        panic!("{err}");
    }
    assert!(
        !err.contains("note: the resident GPU frame does not"),
        "{err}"
    );
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(shot.with_extension("json")).unwrap()).unwrap();
    println!(
        "{}",
        serde_json::to_string_pretty(&stats["resident"]).unwrap()
    );
    println!("HUD: {}", stats["hud"]);
    // One device: the window was drawn with the frames' own.
    assert_eq!(stats["window_on_frames_device"], true, "{stats}");
    let r = &stats["resident"];
    let totals = &r["totals"];
    let t = &totals["traffic"];
    assert_eq!(totals["frames"], FRAMES, "{r}");
    assert_eq!(t["submissions"], FRAMES, "{r}");
    assert_eq!(t["blocking_waits"], 0, "{r}");
    // The timestamps only: 16 passes (each eye's shade and 7 screen passes), 16 B each.
    let timestamps = FRAMES * 16 * 16;
    let back = t["bytes_read_back"].as_u64().unwrap();
    assert!(
        back <= timestamps,
        "{back} B read back over {FRAMES} frames: {r}"
    );
    // The screenshot's image, one readback per eye, and no other.
    assert_eq!(totals["images_read"], 2, "{r}");
    assert_eq!(totals["image_bytes"], 2 * 320 * 180 * 3, "{r}");
    // The last frame is a steady one: nothing created, one submission.
    let last = &r["traffic"];
    assert_eq!(last["submissions"], 1, "{r}");
    assert_eq!(last["buffers_created"], 0, "{r}");
    assert_eq!(last["bind_groups_created"], 0, "{r}");
    assert!(r["host_ms"].as_f64().unwrap() > 0.0, "{r}");
    let passes: Vec<&str> = r["gpu_ms"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|p| p[0].as_str())
        .collect();
    assert!(
        passes.contains(&"left shade") && passes.contains(&"right tonemap"),
        "GPU times per pass: {r}"
    );
    let hud = stats["hud"].to_string();
    for what in ["fps", "host", "GPU ms (frame", "left shade", "up ", "back "] {
        assert!(hud.contains(what), "the HUD lacks {what:?}: {hud}");
    }
    let offline = d.join("render.png");
    run_ok(
        fovea()
            .args(["render", "--res", "320x180", "--lights", "2", "-q"])
            .args([
                "--backend",
                "cpu",
                "--quality",
                "realtime",
                "--denoise",
                "off",
            ])
            // Both eyes rendered (the viewer's way), not the left eye reprojected.
            .args(["--method", "vafr", "--eyes", "both", "--stereo", "dup"])
            .args(["--gaze", "210,70", "--out"])
            .arg(&offline),
    );
    let psnr = luma_psnr(&rgb(&shot), &rgb(&offline));
    println!(
        "resident viewer's screenshot (both eyes) against fovea render: luma PSNR {psnr:.2} dB"
    );
    assert!(psnr >= 40.0, "{psnr} dB");
}
