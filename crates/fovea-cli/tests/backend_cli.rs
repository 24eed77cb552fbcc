//! `fovea render --backend cpu|gpu|auto`: which executor ran which stage is in the stats, a
//! GPU that cannot run is a one-line error with exit status 2 (never a panic, never a silent
//! CPU run), and `auto` says why it took the CPU. With the `gpu` feature and an adapter
//! (lavapipe will do) the reconstruct stage of a VaFR frame runs on the GPU and its image
//! equals the CPU's within the tolerance of `fovea-gpu/tests/reconstruct.rs`.

use std::path::Path;

use assert_cmd::Command;

fn fovea() -> Command {
    let mut c = Command::cargo_bin("fovea").unwrap();
    // Mesa complains on stderr without a runtime directory.
    c.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    c
}

/// Direct shading (the default before issue 38): the frames compared here are the GPU's
/// stages against the CPU's, and the indirect light's bounces, cast on the CPU from each
/// backend's G-buffer, would add their own path noise wherever a record differs in its last
/// bits. `--staged`: these tests check the staged path stage by stage (the resident frame
/// would take most of these frames; its tests are `gpu_render_goes_resident_…` below).
const SMALL: [&str; 10] = [
    "render",
    "--res",
    "320x180",
    "--lights",
    "2",
    "--shading",
    "direct",
    "--staged",
    "-q",
    "--gaze",
];

fn render(dir: &Path, name: &str, extra: &[&str], env: &[(&str, &str)]) -> std::process::Output {
    let mut c = fovea();
    c.args(SMALL).arg("150,80").args(extra).arg("--out");
    c.arg(dir.join(format!("{name}.exr")));
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().unwrap()
}

fn stats(dir: &Path, name: &str) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join(format!("{name}.json"))).unwrap()).unwrap()
}

/// Whether a run that asked for the GPU succeeded. A run without any adapter is skipped with a
/// printed reason (returns false) unless `FOVEA_REQUIRE_GPU=1`; any other failure panics.
fn gpu_ran(out: &std::process::Output, test: &str) -> bool {
    if out.status.success() {
        return true;
    }
    let err = String::from_utf8_lossy(&out.stderr);
    if err.contains("no GPU adapter") && std::env::var("FOVEA_REQUIRE_GPU").as_deref() != Ok("1") {
        eprintln!("[fovea-cli] SKIPPED {test} (GPU): {err}");
        return false;
    }
    panic!("{err}");
}

/// A failed run: exit status 2, one `error:` line on stderr, no panic.
fn one_line_error(out: &std::process::Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].starts_with("error: "), "{err}");
    err
}

#[test]
fn cpu_backend_reports_every_stage_on_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let out = render(
        dir.path(),
        "cpu",
        &["--method", "vafr", "--backend", "cpu"],
        &[],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("backend: CPU (asked for)"), "{stdout}");
    let s = stats(dir.path(), "cpu");
    assert_eq!(s["backend"]["requested"], "cpu");
    assert_eq!(s["backend"]["adapter"], serde_json::Value::Null);
    assert_eq!(s["frame"]["reconstruct_backend"], "cpu");
    assert_eq!(s["frame"]["aa_backend"], "cpu");
    let stages = s["backend"]["stages"].as_object().unwrap();
    for k in ["plan", "trace", "shade", "aa", "reconstruct"] {
        assert_eq!(stages[k], "cpu", "{k}: {stages:?}");
    }
}

/// A screen-aligned method (Guenter's, reconstructed on the CPU) on the GPU: its primary rays
/// are generated and cast there, its shadow rays cast there, its reconstruction stays on the
/// CPU, and the stats say so.
#[cfg(feature = "gpu")]
#[test]
fn gpu_backend_casts_a_screen_aligned_methods_rays() {
    let dir = tempfile::tempdir().unwrap();
    let out = render(
        dir.path(),
        "g",
        &["--method", "guenter", "--backend", "gpu"],
        &[],
    );
    if !gpu_ran(&out, "gpu_backend_casts_a_screen_aligned_methods_rays") {
        return;
    }
    let s = stats(dir.path(), "g");
    assert_eq!(s["frame"]["trace_backend"], "gpu");
    // A screen-aligned buffer's rays are generated there too (from the CPU mapping's points).
    assert_eq!(s["frame"]["ray_generation_backend"], "gpu");
    assert_eq!(s["backend"]["rays"]["generation"], "gpu");
    // The surfaces at the hits are interpolated there: the built-in scene's textures (with
    // their mips) fit lavapipe's 128 MiB binding.
    assert_eq!(s["frame"]["surface_backend"], "gpu");
    assert_eq!(s["backend"]["surface"], "gpu");
    let up = &s["backend"]["gpu_surfaces"];
    assert!(up["textures"].as_u64().unwrap() >= 1, "{up}");
    assert!(up["mip_levels"].as_u64() > up["textures"].as_u64(), "{up}");
    assert_eq!(s["frame"]["shadow_backend"], "gpu");
    assert_eq!(s["frame"]["direct_light_backend"], "gpu");
    assert_eq!(s["frame"]["reconstruct_backend"], "cpu");
    assert_eq!(s["backend"]["rays"]["shadow"], "gpu");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains(
            "ray generation on the GPU, primary rays on the GPU, surfaces on the GPU, shadow \
             rays on the GPU, direct light on the GPU, environment light on the GPU, every \
             other stage"
        ),
        "{stdout}"
    );
}

/// The 8-bit output's tone map on the GPU (`--backend gpu`, a PNG): the stats and the
/// `backend:` line say so, and the bytes are the CPU's encoding of the same frame (its EXR,
/// rendered the same way) within one code in at most 1e-4 of the values (Reinhard's division
/// may round differently on the device; `fovea-gpu/tests/tonemap.rs`). An EXR has no tone map.
#[cfg(feature = "gpu")]
#[test]
fn gpu_backend_tone_maps_the_8_bit_output() {
    use fovea_post::tonemap::{to_srgb8, ToneCurve};
    let dir = tempfile::tempdir().unwrap();
    let args = ["--method", "vafr", "--backend", "gpu", "--exposure", "1.5"];
    let mut c = fovea();
    c.args(SMALL).arg("150,80").args(args).arg("--out");
    let out = c.arg(dir.path().join("g.png")).output().unwrap();
    if !gpu_ran(&out, "gpu_backend_tone_maps_the_8_bit_output") {
        return;
    }
    let s = stats(dir.path(), "g");
    assert_eq!(s["backend"]["tone_map"], "gpu");
    assert_eq!(s["backend"]["gpu_tone_map"]["calls"], 1);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("tone map on the GPU"), "{stdout}");
    assert!(render(dir.path(), "g", &args, &[]).status.success());
    assert_eq!(stats(dir.path(), "g")["backend"]["tone_map"], "cpu");
    let exr = image::open(dir.path().join("g.exr")).unwrap().into_rgb32f();
    let (w, h) = exr.dimensions();
    let px: Vec<[f32; 3]> = exr.as_raw().chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
    let img = fovea_core::Image::from_vec(w, h, px).unwrap();
    let want = to_srgb8(&img, 1.5, ToneCurve::Reinhard);
    let got = image::open(dir.path().join("g.png")).unwrap().into_rgb8();
    assert_eq!(got.as_raw().len(), want.len());
    let (mut off1, mut worse) = (0usize, 0usize);
    for (a, b) in got.as_raw().iter().zip(&want) {
        match a.abs_diff(*b) {
            0 => {}
            1 => off1 += 1,
            _ => worse += 1,
        }
    }
    eprintln!(
        "[fovea-cli] GPU tone map vs CPU: {off1} of {} values one code off, {worse} more",
        want.len()
    );
    assert_eq!(worse, 0);
    assert!(off1 as f64 <= 1e-4 * want.len() as f64, "{off1}");
}

/// The frame of `--backend gpu` against the frame of `--backend cpu`, as issue 18 asks: the
/// built-in scene and (where `../shared/scenes` is present) the classroom at 320×180, full
/// resolution, VaFR, KFR and Weier, without and with the gather DOF filter — luma PSNR ≥ 40 dB
/// and mean ꟻLIP ≤ 0.01 (`fovea_eval::metrics`, at the display's pixels per degree). The GPU
/// generates and casts every primary ray, casts every shadow ray, computes direct and
/// environment light, runs the AA filter, reconstructs the polar methods and Weier's
/// (pull-push) and runs the gather DOF; each is asserted from the frame's stats.
#[cfg(feature = "gpu")]
#[test]
fn gpu_frames_are_the_cpu_frames_method_by_method() {
    use fovea_eval::metrics::{flip_mean, luma_psnr, Region};
    let dir = tempfile::tempdir().unwrap();
    let classroom = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/scenes/japanese-classroom/scene.xml");
    let mut scenes = vec![("builtin", None)];
    if classroom.exists() {
        scenes.push(("classroom", Some(classroom.to_string_lossy().into_owned())));
    } else {
        println!("classroom skipped: ../shared/scenes is absent (a fresh clone); CI has it");
    }
    let read = |name: &str| {
        let img = image::open(dir.path().join(format!("{name}.exr")))
            .unwrap()
            .into_rgb32f();
        let (w, h) = img.dimensions();
        let data = img.pixels().map(|p| [p[0], p[1], p[2]]).collect();
        fovea_core::Image::from_vec(w, h, data).unwrap()
    };
    for (scene, path) in &scenes {
        for method in ["full", "vafr", "kfr", "weier"] {
            for dof in ["none", "gather"] {
                let name = format!("{scene}-{method}-{dof}");
                let mut args = vec!["--method", method, "--dof", dof];
                if let Some(p) = path {
                    args.extend(["--scene", p.as_str()]);
                }
                let run = |backend: &str| {
                    let out = render(
                        dir.path(),
                        &format!("{name}-{backend}"),
                        &[&args[..], &["--backend", backend]].concat(),
                        &[],
                    );
                    let err = String::from_utf8_lossy(&out.stderr);
                    assert!(backend == "gpu" || out.status.success(), "{name}: {err}");
                    out
                };
                if !gpu_ran(
                    &run("gpu"),
                    "gpu_frames_are_the_cpu_frames_method_by_method",
                ) {
                    return;
                }
                let cpu = run("cpu");
                let s = stats(dir.path(), &format!("{name}-gpu"));
                // Every method's primary rays are generated there, screen-aligned or polar.
                for stage in [
                    "ray_generation",
                    "trace",
                    "shadow",
                    "direct_light",
                    "environment_light",
                ] {
                    assert_eq!(s["frame"][format!("{stage}_backend")], "gpu", "{name}");
                }
                assert_eq!(s["backend"]["rays"]["generation"], "gpu", "{name}");
                // The reconstruct stage: the polar lookup (VaFR, KFR) and Weier's pull-push
                // on the GPU; full resolution's buffer is the screen (nothing to run).
                let reconstruct_on = if method == "full" { "cpu" } else { "gpu" };
                assert_eq!(s["frame"]["reconstruct_backend"], reconstruct_on, "{name}");
                if method == "weier" {
                    let t = &s["backend"]["gpu_reconstruct"];
                    assert!(t["run_and_readback_ms"].is_number(), "{name}: {t}");
                }
                // The gather DOF (the eye's CoC map and the filter) runs on the GPU too; a
                // frame without a filter has none on the GPU.
                let dof_on = if dof == "gather" { "gpu" } else { "cpu" };
                assert_eq!(s["frame"]["dof_backend"], dof_on, "{name}");
                assert_eq!(s["backend"]["dof"], dof_on, "{name}");
                if dof == "gather" {
                    assert_eq!(s["backend"]["stages"]["dof"], "gpu", "{name}");
                    assert!(s["backend"]["gpu_dof"]["total_ms"].is_number(), "{name}");
                    let cpu_stats = stats(dir.path(), &format!("{name}-cpu"));
                    assert_eq!(cpu_stats["frame"]["dof_backend"], "cpu", "{name}");
                } else {
                    let stage = s["backend"]["stages"].get("dof");
                    assert!(stage.is_none_or(|v| v == "cpu"), "{name}: {stage:?}");
                }
                // Stage 5's filter (FXAA for VaFR, the Gaussian for KFR) runs on the GPU too;
                // full resolution and Weier have none.
                let aa_on = if matches!(method, "vafr" | "kfr") {
                    "gpu"
                } else {
                    "cpu"
                };
                assert_eq!(s["frame"]["aa_backend"], aa_on, "{name}");
                if aa_on == "gpu" {
                    assert_eq!(s["backend"]["stages"]["aa"], "gpu", "{name}");
                    assert_eq!(s["backend"]["gpu_aa"]["layers"], 1, "{name}");
                }
                // The denoiser (on by default) runs on the GPU for every method (issue 38).
                assert_eq!(s["frame"]["denoise_backend"], "gpu", "{name}");
                // "display 320x180 …: 1.23 px/deg across, …"
                let stdout = String::from_utf8_lossy(&cpu.stdout);
                let ppd: f32 = stdout
                    .lines()
                    .filter(|l| l.starts_with("display "))
                    .find_map(|l| l.split(": ").nth(1)?.split(" px/deg").next()?.parse().ok())
                    .unwrap_or_else(|| panic!("no px/deg in {stdout}"));
                let (g, c) = (read(&format!("{name}-gpu")), read(&format!("{name}-cpu")));
                let all = Region {
                    x0: 0,
                    y0: 0,
                    x1: c.width(),
                    y1: c.height(),
                };
                let psnr = luma_psnr(&c, &g, all).unwrap();
                let flip = flip_mean(&c, &g, all, ppd).unwrap();
                eprintln!("[fovea-cli] GPU vs CPU {name}: luma PSNR {psnr:.1} dB, ꟻLIP {flip:.5}");
                assert!(psnr >= 40.0, "{name}: {psnr} dB");
                assert!(flip <= 0.01, "{name}: ꟻLIP {flip}");
            }
        }
    }
}

#[cfg(not(feature = "gpu"))]
#[test]
fn without_the_gpu_feature_gpu_says_how_to_rebuild_and_auto_is_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let e = one_line_error(&render(
        dir.path(),
        "g",
        &["--method", "vafr", "--backend", "gpu"],
        &[],
    ));
    assert!(e.contains("--features gpu"), "{e}");
    let out = render(dir.path(), "a", &["--method", "vafr"], &[]);
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("backend: CPU (auto: built without the gpu feature)"),
        "{stdout}"
    );
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_without_an_adapter_is_one_line_and_auto_falls_back() {
    let dir = tempfile::tempdir().unwrap();
    // Hides every Vulkan driver.
    let hide = [("VK_ICD_FILENAMES", "/nonexistent")];
    let e = one_line_error(&render(
        dir.path(),
        "g",
        &["--method", "vafr", "--backend", "gpu"],
        &hide,
    ));
    assert!(
        e.contains("no GPU adapter") && e.contains("mesa-vulkan-drivers"),
        "{e}"
    );
    let out = render(dir.path(), "a", &["--method", "vafr"], &hide);
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("backend: CPU (auto: no GPU adapter)"),
        "{stdout}"
    );
    assert_eq!(
        stats(dir.path(), "a")["frame"]["reconstruct_backend"],
        "cpu"
    );
}

/// The primary rays and the reconstruct stage on the GPU, the rest on the CPU; the image is
/// the CPU's within the GPU reconstruction tests' worst-case bound per channel (relative
/// above 1: the GPU's hits are the CPU's, `fovea-gpu/tests/trace.rs`), and the mean far below
/// theirs (shaded content is smooth where random texels are not).
#[cfg(feature = "gpu")]
#[test]
fn gpu_backend_traces_and_reconstructs_on_the_gpu() {
    let dir = tempfile::tempdir().unwrap();
    let out = render(
        dir.path(),
        "gpu",
        &["--method", "vafr", "--backend", "gpu"],
        &[],
    );
    if !gpu_ran(&out, "gpu_backend_traces_and_reconstructs_on_the_gpu") {
        return;
    }
    let s = stats(dir.path(), "gpu");
    assert_eq!(s["frame"]["reconstruct_backend"], "gpu");
    assert_eq!(s["backend"]["stages"]["reconstruct"], "gpu");
    assert_eq!(s["frame"]["aa_backend"], "gpu");
    assert_eq!(s["backend"]["stages"]["aa"], "gpu");
    assert_eq!(s["frame"]["trace_backend"], "gpu");
    assert_eq!(s["backend"]["stages"]["trace"], "gpu");
    assert_eq!(s["backend"]["stages"]["shade"], "cpu");
    // A polar buffer's rays are generated there too.
    assert_eq!(s["frame"]["ray_generation_backend"], "gpu");
    assert_eq!(s["backend"]["rays"]["generation"], "gpu");
    assert!(s["backend"]["gpu_bvh"]["nodes"].as_u64().unwrap() > 1);
    assert!(s["backend"]["adapter"].is_string());
    assert!(s["backend"]["gpu_reconstruct"]["bands"].as_u64().unwrap() >= 1);
    // The trace stage calls the tracer once per chunk of texels (at most
    // `plan::CHUNK_SAMPLES` = 2^18 samples of whole rows); the frame's figures are summed
    // over every call, not the last call's.
    let trace = &s["backend"]["gpu_trace"];
    let rays = s["frame"]["rays_primary"].as_u64().unwrap();
    let calls = trace["calls"].as_u64().unwrap();
    assert!(
        rays > 2 << 18 && calls >= 2,
        "{rays} rays in {calls} calls: {trace}"
    );
    assert!(trace["batches"].as_u64().unwrap() >= calls, "{trace}");
    let total = trace["total_ms"].as_f64().unwrap();
    if let Some(pass) = trace["gpu_pass_ms"].as_f64() {
        // The passes run inside the calls: their sum cannot exceed the calls' wall time.
        assert!(pass > 0.0 && pass <= total, "{trace}");
    }
    // The shade stage's shadow rays and direct light too (the frame is direct shading, one
    // ray per texel).
    assert_eq!(s["frame"]["shadow_backend"], "gpu");
    assert_eq!(s["frame"]["direct_light_backend"], "gpu");
    // The environment's rays are cast in its own pass: none is left for `occluded`.
    assert_eq!(s["frame"]["environment_light_backend"], "gpu");
    assert_eq!(s["backend"]["environment_light"], "gpu");
    for key in ["gpu_shadow", "gpu_direct_light", "gpu_environment_light"] {
        let t = &s["backend"][key];
        assert!(t["calls"].as_u64().unwrap() >= 1, "{key}: {t}");
        if let Some(pass) = t["gpu_pass_ms"].as_f64() {
            assert!(
                pass > 0.0 && pass <= t["total_ms"].as_f64().unwrap(),
                "{key}: {t}"
            );
        }
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains(
            "primary rays on the GPU, surfaces on the GPU, shadow rays on the GPU, direct \
             light on the GPU, environment light on the GPU, aa on the GPU, reconstruct on the \
             GPU, every other stage on the CPU"
        ),
        "{stdout}"
    );

    let out = render(
        dir.path(),
        "cpu",
        &["--method", "vafr", "--backend", "cpu"],
        &[],
    );
    assert!(out.status.success());
    assert_gpu_image_is_the_cpus(dir.path(), "gpu", "cpu");
}

/// `--backend gpu --denoise on`: the sample-space denoiser runs on the GPU (issue 38's twin),
/// the stats say so, and the frame is the CPU's within 40 dB of luma PSNR — far closer than
/// the frame without denoising is to either.
#[cfg(feature = "gpu")]
#[test]
fn gpu_backend_denoises_on_the_gpu_and_matches_the_cpu() {
    use fovea_eval::metrics::{luma_psnr, Region};
    let dir = tempfile::tempdir().unwrap();
    let read = |name: &str| {
        let img = image::open(dir.path().join(format!("{name}.exr")))
            .unwrap()
            .into_rgb32f();
        let (w, h) = img.dimensions();
        let data = img.pixels().map(|p| [p[0], p[1], p[2]]).collect();
        fovea_core::Image::from_vec(w, h, data).unwrap()
    };
    for method in ["vafr", "full"] {
        let run = |backend: &str, denoise: &str| {
            render(
                dir.path(),
                &format!("dn-{method}-{backend}-{denoise}"),
                &[
                    "--method",
                    method,
                    "--denoise",
                    denoise,
                    "--backend",
                    backend,
                ],
                &[],
            )
        };
        if !gpu_ran(
            &run("gpu", "on"),
            "gpu_backend_denoises_on_the_gpu_and_matches_the_cpu",
        ) {
            return;
        }
        for denoise in ["on", "off"] {
            let out = run("cpu", denoise);
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        let s = stats(dir.path(), &format!("dn-{method}-gpu-on"));
        assert_eq!(s["frame"]["denoise_backend"], "gpu", "{method}");
        assert_eq!(s["backend"]["stages"]["denoise"], "gpu", "{method}");
        assert!(s["frame"]["denoise"]["filtered"].as_u64().unwrap() > 0);
        let c = stats(dir.path(), &format!("dn-{method}-cpu-on"));
        assert_eq!(c["frame"]["denoise_backend"], "cpu", "{method}");
        let (g, c, raw) = (
            read(&format!("dn-{method}-gpu-on")),
            read(&format!("dn-{method}-cpu-on")),
            read(&format!("dn-{method}-cpu-off")),
        );
        let all = Region {
            x0: 0,
            y0: 0,
            x1: c.width(),
            y1: c.height(),
        };
        let psnr = luma_psnr(&c, &g, all).unwrap();
        let undenoised = luma_psnr(&c, &raw, all).unwrap();
        eprintln!(
            "[fovea-cli] {method} --denoise on, GPU vs CPU: luma PSNR {psnr:.1} dB (the frame \
             without denoising: {undenoised:.1} dB)"
        );
        assert!(psnr >= 40.0, "{method}: {psnr} dB");
        assert!(
            undenoised < psnr - 5.0,
            "{method}: {undenoised} vs {psnr} dB"
        );
    }
}

/// The GPU's image `gpu.exr` against the CPU's `cpu.exr` in `dir`: within the GPU
/// reconstruction tests' worst-case bound per channel (relative above 1) at all but 0.05 % of
/// the pixels, and a mean far below theirs (shaded content is smooth where random texels are
/// not). The few pixels allowed past the bound are shadow rays that graze an edge: the GPU
/// answers them in its own f32 arithmetic, so one in tens of thousands can differ (measured on
/// lavapipe, VaFR at 320×180: 7 of 57,600 pixels past 1e-3, 2 past the bound, of 4 million
/// shadow rays).
#[cfg(feature = "gpu")]
fn assert_gpu_image_is_the_cpus(dir: &Path, gpu: &str, cpu: &str) {
    let read = |name: &str| {
        image::open(dir.join(format!("{name}.exr")))
            .unwrap()
            .into_rgb32f()
    };
    let (g, c) = (read(gpu), read(cpu));
    assert_eq!(g.dimensions(), c.dimensions());
    const BOUND: f32 = 2.0 / 64.0 + 2e-3;
    let (mut max, mut sum, mut n, mut past) = (0.0f32, 0.0f64, 0usize, 0usize);
    for (a, b) in g.pixels().zip(c.pixels()) {
        let mut worst = 0.0f32;
        for k in 0..3 {
            let e = (a[k] - b[k]).abs();
            let scale = a[k].abs().max(b[k].abs()).max(1.0);
            worst = worst.max(e / scale);
            sum += e as f64;
            n += 1;
        }
        max = max.max(worst);
        past += usize::from(worst > BOUND);
    }
    let mean = sum / n as f64;
    let pixels = n / 3;
    eprintln!(
        "[fovea-cli] GPU vs CPU {gpu}: max relative difference {max:.4} ({past} of {pixels} \
         pixels past {BOUND:.4}), mean {mean:.2e}"
    );
    assert!(
        past <= (pixels / 2000).max(1),
        "{past} of {pixels} pixels past {BOUND}"
    );
    // Smooth shaded content (measured on lavapipe: mean 1.6e-5 to 1.8e-5); random texels
    // reach 9e-4 in the mean.
    assert!(mean <= 2e-4, "{mean}");
}

/// Both eyes (`--eyes both`, VaFR_Dup and VaFR_Rep) on the GPU's executors: every eye's
/// primary rays and reconstruction run there, the tracer's times cover both eyes, and the
/// side-by-side image is the CPU's within the one-eye test's bounds.
#[cfg(feature = "gpu")]
#[test]
fn gpu_backend_renders_both_eyes() {
    let dir = tempfile::tempdir().unwrap();
    for mode in ["dup", "rep"] {
        let gpu = format!("{mode}-gpu");
        let cpu = format!("{mode}-cpu");
        let both = ["--method", "vafr", "--eyes", "both", "--stereo", mode];
        let out = render(
            dir.path(),
            &gpu,
            &[&both[..], &["--backend", "gpu"]].concat(),
            &[],
        );
        if !gpu_ran(&out, "gpu_backend_renders_both_eyes") {
            return;
        }
        let s = stats(dir.path(), &gpu);
        for eye in ["left", "right"] {
            assert_eq!(s[eye]["trace_backend"], "gpu", "{mode} {eye}");
            assert_eq!(s[eye]["reconstruct_backend"], "gpu", "{mode} {eye}");
        }
        assert_eq!(s["backend"]["stages"]["trace"], "gpu");
        let calls = s["backend"]["gpu_trace"]["calls"].as_u64().unwrap();
        assert!(calls >= 2, "{mode}: {calls} tracer calls for two eyes");
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains("backend: GPU: "), "{stdout}");
        let out = render(
            dir.path(),
            &cpu,
            &[&both[..], &["--backend", "cpu"]].concat(),
            &[],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert_gpu_image_is_the_cpus(dir.path(), &gpu, &cpu);
    }
}

/// `--eyes both --stereo dup --lockstep on` on the GPU renders the eyes in lockstep: every
/// submission while both eyes render carries both eyes' work, each pass is submitted once,
/// and the frames are those of the eyes rendered one after the other (`--lockstep off`),
/// byte for byte.
#[cfg(feature = "gpu")]
#[test]
fn gpu_lockstep_submits_both_eyes_together_and_changes_no_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let both = ["--method", "vafr", "--eyes", "both", "--stereo", "dup"];
    let mut counts = Vec::new();
    for lockstep in ["on", "off"] {
        let args = [&both[..], &["--backend", "gpu", "--lockstep", lockstep]].concat();
        let out = render(dir.path(), lockstep, &args, &[]);
        if !gpu_ran(&out, "gpu_lockstep_submits_both_eyes_together") {
            return;
        }
        let s = stats(dir.path(), lockstep);
        assert_eq!(s["lockstep"], lockstep == "on", "{s}");
        let n = &s["backend"]["gpu_submissions"];
        let get = |k: &str| n[k].as_u64().unwrap_or_else(|| panic!("{k}: {s}"));
        counts.push((get("submissions"), get("joint"), get("posted")));
    }
    let (on, off) = (counts[0], counts[1]);
    // One after the other: each pass its own submission.
    assert_eq!(off.0, off.2, "off: {off:?}");
    assert_eq!(off.1, 0, "off: {off:?}");
    // In lockstep: the same passes, every one submitted once; a joint submission carries two.
    assert_eq!(on.2, off.2, "the same passes: on {on:?}, off {off:?}");
    assert_eq!(on.0 + on.1, on.2, "each pass submitted once: {on:?}");
    // Both eyes' passes but the last few of the eye with more went together.
    assert!(
        on.1 >= 1 && on.1 * 2 + 8 >= on.2,
        "joint submissions: {on:?}"
    );
    let (a, b) = (
        std::fs::read(dir.path().join("on.exr")).unwrap(),
        std::fs::read(dir.path().join("off.exr")).unwrap(),
    );
    assert!(a == b, "the lockstep frame differs from the sequential one");
    // The default (auto): lockstep on a hardware GPU, not on a CPU-emulated one.
    let out = render(
        dir.path(),
        "auto",
        &[&both[..], &["--backend", "gpu"]].concat(),
        &[],
    );
    assert!(gpu_ran(&out, "gpu_lockstep_submits_both_eyes_together"));
    let s = stats(dir.path(), "auto");
    let emulated = s["backend"]["cpu_emulated"].as_bool().unwrap();
    assert_eq!(s["lockstep"], !emulated, "{s}");
}

/// `fovea sequence --backend`: the folder records where its frames were made, and a sequence
/// on the GPU's staged path (`--staged`; the resident frame's test is
/// `gpu_sequence_goes_resident_…` below) writes the CPU's frames within 8-bit rounding of the
/// render test's bounds.
fn sequence(dir: &Path, name: &str, backend: &str) -> std::process::Output {
    fovea()
        .args([
            "sequence", "--method", "vafr", "--res", "160x180", "--lights", "1",
        ])
        .args([
            "--frames",
            "2",
            "--video",
            "off",
            "-q",
            "--staged",
            "--backend",
            backend,
            "--out",
        ])
        .arg(dir.join(name))
        .env("XDG_RUNTIME_DIR", dir)
        .output()
        .unwrap()
}

#[test]
fn sequence_records_its_backend() {
    let dir = tempfile::tempdir().unwrap();
    let out = sequence(dir.path(), "cpu", "cpu");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("cpu/sequence.json")).unwrap())
            .unwrap();
    assert_eq!(m["backend"], "cpu");
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_sequence_frames_equal_the_cpu_ones() {
    let dir = tempfile::tempdir().unwrap();
    let out = sequence(dir.path(), "gpu", "gpu");
    if !gpu_ran(&out, "gpu_sequence_frames_equal_the_cpu_ones") {
        return;
    }
    assert!(sequence(dir.path(), "cpu", "cpu").status.success());
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("gpu/sequence.json")).unwrap())
            .unwrap();
    assert_eq!(m["backend"], "gpu");
    for i in 0..2 {
        let read = |name: &str| {
            image::open(dir.path().join(format!("{name}/frame_{i:05}.png")))
                .unwrap()
                .into_rgb8()
        };
        let (g, c) = (read("gpu"), read("cpu"));
        let diffs: Vec<i32> = g
            .as_raw()
            .iter()
            .zip(c.as_raw())
            .map(|(&a, &b)| (i32::from(a) - i32::from(b)).abs())
            .collect();
        let max = diffs.iter().max().copied().unwrap_or(0);
        let mean = diffs.iter().map(|&d| f64::from(d)).sum::<f64>() / diffs.len() as f64;
        eprintln!("[fovea-cli] GPU vs CPU sequence frame {i}: max {max} codes, mean {mean:.4}");
        // The render test's bound (2/64 + 2e-3 relative) is at most 9 codes after the sRGB
        // curve's steepest part; the mean stays far below one code.
        assert!(max <= 9, "{max}");
        assert!(mean <= 0.05, "{mean}");
    }
}

/// Luma PSNR (dB, peak 255; Rec. 709 weights on the 8-bit codes) of two PNGs of the same size.
#[cfg(feature = "gpu")]
fn png_luma_psnr_db(a: &Path, b: &Path) -> f64 {
    let (a, b) = (
        image::open(a).unwrap().into_rgb8(),
        image::open(b).unwrap().into_rgb8(),
    );
    assert_eq!(a.dimensions(), b.dimensions());
    let luma = |p: &image::Rgb<u8>| {
        0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
    };
    let se: f64 = a
        .pixels()
        .zip(b.pixels())
        .map(|(x, y)| (luma(x) - luma(y)).powi(2))
        .sum();
    let mse = se / f64::from(a.width() * a.height());
    10.0 * (255.0f64 * 255.0 / mse.max(1e-12)).log10()
}

/// `fovea sequence --backend gpu` through the resident frame (issue 37, item 7): full
/// resolution at 160×180, the real-time preset (its denoiser included), temporal accumulation
/// with the accumulator's sub-texel jitter on a still gaze, three frames. `stats.json` says
/// every frame went resident — 1 submission, no blocking wait and nothing read back for the
/// frame, then its one image read back for the file (3·w·h bytes, one wait), no pass of the
/// right eye recorded (the sequence's one eye is the frame's left side) — the manifest
/// records the route, and each frame is the CPU's (`--backend cpu`, the same settings) within
/// a luma PSNR of 40 dB (the jitter of each frame included). A deleted frame is rendered
/// again after the one warm-up frame its history needs, to the same bytes. `--staged` and
/// settings the resident frame refuses (Weier's accumulation) go staged, the reason in the
/// stats.
#[cfg(feature = "gpu")]
#[test]
fn gpu_sequence_goes_resident_with_temporal_accumulation() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, frames: &str, extra: &[&str]| {
        fovea()
            .args(["sequence", "--res", "160x180", "--lights", "1"])
            .args([
                "--scenario",
                "fixation",
                "--temporal",
                "on",
                "--frames",
                frames,
            ])
            .args(["--quality", "realtime", "--jitter", "on"])
            .args(["--video", "off", "-q"])
            .args(extra)
            .arg("--out")
            .arg(dir.path().join(name))
            .env("XDG_RUNTIME_DIR", dir.path())
            .output()
            .unwrap()
    };
    let json = |name: &str, file: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(dir.path().join(name).join(file)).unwrap()).unwrap()
    };
    // The real-time preset's denoiser after the accumulation, resident too (the pass
    // rewrites the accumulated colour's Monte Carlo part for it, as the CPU does).
    let full = ["--method", "full", "--backend"];
    let out = run("gpu", "3", &[&full[..], &["gpu"]].concat());
    if !gpu_ran(
        &out,
        "gpu_sequence_goes_resident_with_temporal_accumulation",
    ) {
        return;
    }
    assert_eq!(json("gpu", "sequence.json")["route"], "resident");
    let b = json("gpu", "stats.json")["backend"].clone();
    assert_eq!(b["route"], "resident", "{b}");
    assert!(b["staged_because"].is_null(), "{b}");
    assert_eq!(b["resident_frames"], 3, "{b}");
    assert_eq!(b["staged_frames"], 0, "{b}");
    let frames = b["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3, "{b}");
    for f in frames {
        assert_eq!(f["route"], "resident", "{f}");
        assert_eq!(f["counts"]["submissions"], 1, "{f}");
        assert_eq!(f["counts"]["blocking_waits"], 0, "{f}");
        assert_eq!(f["counts"]["bytes_read_back"], 0, "{f}");
        assert_eq!(f["warmup_frames"], 0, "{f}");
        let image = &f["image_readback"];
        assert_eq!(image["bytes_read_back"], 3 * 160 * 180, "{f}");
        assert_eq!(image["blocking_waits"], 1, "{f}");
    }
    // One eye: the binocular frame's left side only (`set_eyes(1)`), no right pass timed.
    let passes = b["resident_gpu_pass_ms"].as_object().unwrap();
    assert!(passes.keys().all(|k| !k.starts_with("right")), "{b}");
    eprintln!("[fovea-cli] resident sequence GPU passes (ms): {passes:?}");
    // After the first frame nothing is created and only the uniforms go up.
    for f in &frames[1..] {
        assert_eq!(f["counts"]["buffers_created"], 0, "{f}");
        assert!(
            f["counts"]["bytes_uploaded"].as_u64().unwrap() <= 256 * 1024,
            "{f}"
        );
    }
    let out = run("cpu", "3", &[&full[..], &["cpu"]].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!dir.path().join("cpu/stats.json").exists());
    for i in 0..3 {
        let frame = |name: &str| dir.path().join(format!("{name}/frame_{i:05}.png"));
        let db = png_luma_psnr_db(&frame("gpu"), &frame("cpu"));
        eprintln!("[fovea-cli] resident sequence frame {i} against the CPU: luma PSNR {db:.1} dB");
        assert!(db >= 40.0, "frame {i}: {db} dB");
    }
    // Resumed: frame 1 deleted is rendered again after frame 0 (its history), unwritten.
    let frame1 = dir.path().join("gpu/frame_00001.png");
    let before = std::fs::read(&frame1).unwrap();
    std::fs::remove_file(&frame1).unwrap();
    let out = run("gpu", "3", &[&full[..], &["gpu"]].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(std::fs::read(&frame1).unwrap(), before);
    let b = json("gpu", "stats.json")["backend"].clone();
    assert_eq!(
        (b["rendered"].as_u64(), b["skipped"].as_u64()),
        (Some(1), Some(2)),
        "{b}"
    );
    let f = &b["frames"][0];
    assert_eq!(
        (f["frame"].as_u64(), f["route"].as_str()),
        (Some(1), Some("resident")),
        "{f}"
    );
    assert_eq!(f["warmup_frames"], 1, "{f}");
    assert_eq!(f["warmup"]["submissions"], 1, "{f}");
    // Staged: asked for, and refused by the resident frame (Weier accumulates in screen space
    // on the CPU), each with its reason.
    for (name, extra, why) in [
        (
            "staged",
            &[&full[..], &["gpu", "--staged"]].concat()[..],
            "--staged",
        ),
        (
            "weier",
            &["--method", "weier", "--denoise", "off", "--backend", "gpu"][..],
            "temporal accumulation of the weier method",
        ),
    ] {
        let out = run(name, "1", extra);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(json(name, "sequence.json")["route"], "staged");
        let b = json(name, "stats.json")["backend"].clone();
        assert_eq!(b["route"], "staged", "{b}");
        let because = b["staged_because"].as_str().unwrap();
        assert!(
            because.contains(why) && !because.contains('\n'),
            "{because}"
        );
        assert_eq!(b["frames"][0]["route"], "staged", "{b}");
        assert_eq!(b["resident_frames"], 0, "{b}");
    }
}

/// `fovea bench --backend`: a small bench (one 160x180 display, full resolution against VaFR,
/// no BVH throughput test) as JSON.
fn bench(extra: &[&str], env: &[(&str, &str)]) -> std::process::Output {
    let mut c = fovea();
    c.args([
        "bench",
        "--res",
        "160x180",
        "--methods",
        "vafr",
        "--lights",
        "1",
    ])
    .args(["--bvh-rays", "0", "--json", "-q"])
    .args(extra);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().unwrap()
}

fn bench_json(out: &std::process::Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn cpu_bench_reports_every_stage_on_the_cpu_and_no_gpu_passes() {
    let j = bench_json(&bench(&["--backend", "cpu"], &[]));
    assert_eq!(j["backend"]["requested"], "cpu");
    assert_eq!(j["backend"]["cpu_emulated"], false);
    let runs = j["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 2);
    for r in runs {
        assert_eq!(r["stage_backends"]["trace"], "cpu", "{r}");
        assert_eq!(r["stage_backends"]["reconstruct"], "cpu", "{r}");
        assert_eq!(r["stage_backends"]["aa"], "cpu", "{r}");
        assert!(r["gpu_pass_ms"].as_object().unwrap().is_empty(), "{r}");
        assert!(
            r["gpu_traffic_per_frame"].as_object().unwrap().is_empty(),
            "{r}"
        );
        let fps = r["fps"].as_f64().unwrap();
        assert!(fps.is_finite() && fps > 0.0, "{r}");
    }
}

/// `fovea bench --eyes both --backend gpu`: both eyes of the binocular frames (Dup and Rep) run
/// on the GPU's executors, and each mode's GPU passes (both eyes summed) are reported. Presence
/// and sign only: no timing is compared.
#[cfg(feature = "gpu")]
#[test]
fn bench_gpu_times_both_eyes_on_the_gpu() {
    let out = bench(
        &[
            "--backend",
            "gpu",
            "--eyes",
            "both",
            "--stereo-reps",
            "1",
            "--lockstep",
            "on",
        ],
        &[],
    );
    if !gpu_ran(&out, "bench_gpu_times_both_eyes_on_the_gpu") {
        return;
    }
    let j = bench_json(&out);
    let rows = j["binocular"].as_array().unwrap();
    assert_eq!(rows.len(), 1, "{j}");
    let row = &rows[0];
    assert_eq!(row["trace_backend"], "gpu", "{row}");
    assert_eq!(row["dup_lockstep"], true, "{row}");
    for mode in ["dup_device_pass_ms", "rep_device_pass_ms"] {
        for pass in ["trace", "direct_light", "reconstruct"] {
            let ms = row[mode][pass].as_f64().unwrap_or(f64::NAN);
            assert!(ms.is_finite() && ms > 0.0, "{mode} {pass}: {row}");
        }
    }
    assert!(row["rep_rays_primary"].as_u64().unwrap() < row["dup_rays_primary"].as_u64().unwrap());
    // The pair's traffic, counted in fovea-gpu: both eyes' passes in shared submissions, each
    // eye waiting for its readbacks (today's path: a wait per submission and eye).
    for mode in ["dup_device_traffic", "rep_device_traffic"] {
        let t = &row[mode];
        let get = |k: &str| t[k].as_u64().unwrap_or_else(|| panic!("{mode}.{k}: {row}"));
        assert!(
            get("bytes_uploaded") > 0 && get("bytes_read_back") > 0,
            "{mode}: {row}"
        );
        assert!(get("submissions") > 0 && get("blocking_waits") >= get("submissions") / 2);
    }
    let dup = &row["dup_device_traffic"];
    assert!(
        dup["blocking_waits"].as_u64() > dup["submissions"].as_u64(),
        "in lockstep a submission carries both eyes' passes, each eye waits: {row}"
    );
}

#[cfg(not(feature = "gpu"))]
#[test]
fn without_the_gpu_feature_bench_gpu_says_how_to_rebuild() {
    let e = one_line_error(&bench(&["--backend", "gpu"], &[]));
    assert!(e.contains("--features gpu"), "{e}");
    let j = bench_json(&bench(&["--backend", "auto"], &[]));
    assert_eq!(
        j["backend"]["resolved"],
        "CPU (auto: built without the gpu feature)"
    );
}

#[cfg(feature = "gpu")]
#[test]
fn bench_gpu_without_an_adapter_is_one_line() {
    let hide = [("VK_ICD_FILENAMES", "/nonexistent")];
    let e = one_line_error(&bench(&["--backend", "gpu"], &hide));
    assert!(
        e.contains("no GPU adapter") && e.contains("mesa-vulkan-drivers"),
        "{e}"
    );
}

/// VaFR's primary and shadow rays and its reconstruction on the GPU with their passes' own
/// times from timestamps, and full resolution's rays on the GPU in the same run (the
/// speedup's reference); on lavapipe the figures are labelled CPU-emulated. Presence, sign and
/// finiteness only: no timing is compared.
#[cfg(feature = "gpu")]
#[test]
fn bench_gpu_reports_pass_times_fps_and_speedup() {
    let out = bench(&["--backend", "gpu"], &[]);
    if !gpu_ran(&out, "bench_gpu_reports_pass_times_fps_and_speedup") {
        return;
    }
    let j = bench_json(&out);
    assert_eq!(j["backend"]["requested"], "gpu");
    let adapter = j["backend"]["adapter"].as_str().unwrap();
    let emulated = j["backend"]["cpu_emulated"].as_bool().unwrap();
    if adapter.contains("llvmpipe") {
        assert!(emulated, "{adapter}");
    }
    let runs = j["runs"].as_array().unwrap();
    let run = |m: &str| {
        runs.iter()
            .find(|r| r["method"].as_str().unwrap().eq_ignore_ascii_case(m))
            .unwrap_or_else(|| panic!("no {m} run: {j}"))
    };
    let full = run("full");
    assert_eq!(full["stage_backends"]["trace"], "gpu", "{full}");
    assert_eq!(full["stage_backends"]["shadow_rays"], "gpu", "{full}");
    assert_eq!(full["stage_backends"]["direct_light"], "gpu", "{full}");
    assert_eq!(full["stage_backends"]["environment_light"], "gpu", "{full}");
    assert_eq!(full["stage_backends"]["reconstruct"], "cpu", "{full}");
    for pass in ["trace", "direct_light", "environment_light"] {
        let ms = full["gpu_pass_ms"][pass].as_f64().unwrap_or(f64::NAN);
        assert!(ms.is_finite() && ms > 0.0, "{pass}: {full}");
    }
    let vafr = run("vafr");
    assert_eq!(vafr["stage_backends"]["trace"], "gpu", "{vafr}");
    assert_eq!(vafr["stage_backends"]["shadow_rays"], "gpu", "{vafr}");
    assert_eq!(vafr["stage_backends"]["reconstruct"], "gpu", "{vafr}");
    assert_eq!(vafr["stage_backends"]["aa"], "gpu", "{vafr}");
    for pass in [
        "trace",
        "direct_light",
        "environment_light",
        "aa",
        "reconstruct",
    ] {
        let ms = vafr["gpu_pass_ms"][pass].as_f64().unwrap_or(f64::NAN);
        assert!(ms.is_finite() && ms > 0.0, "{pass}: {vafr}");
    }
    for r in [full, vafr] {
        let fps = r["fps"].as_f64().unwrap();
        assert!(fps.is_finite() && fps > 0.0, "{r}");
        // The median frame's traffic, counted in fovea-gpu: at least the frame's own
        // readback (today every stage's records come back).
        let t = &r["gpu_traffic_per_frame"];
        let screen_bytes = r["width"].as_u64().unwrap() * r["height"].as_u64().unwrap() * 12;
        assert!(
            t["bytes_read_back"].as_u64().unwrap() >= screen_bytes,
            "{r}"
        );
        assert!(t["submissions"].as_u64().unwrap() > 0, "{r}");
        assert!(r["rays_primary"].as_u64().unwrap() > 0, "{r}");
        let speedup = r["speedup_vs_full"].as_f64().unwrap();
        assert!(speedup.is_finite() && speedup > 0.0, "{r}");
    }
}

/// `fovea demo --backend`: stdout and the page say where the foveated frames were made, and
/// a GPU that cannot run is the same one-line error as `render`'s, before any frame.
/// PSNR (dB, peak 255) of two 8-bit PNGs of the same size, over every channel.
#[cfg(feature = "gpu")]
fn png_psnr_db(a: &Path, b: &Path) -> f64 {
    let (a, b) = (
        image::open(a).unwrap().into_rgb8(),
        image::open(b).unwrap().into_rgb8(),
    );
    assert_eq!(a.dimensions(), b.dimensions());
    let se: f64 = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(&x, &y)| (x as f64 - y as f64).powi(2))
        .sum();
    let mse = se / a.as_raw().len() as f64;
    10.0 * (255.0f64 * 255.0 / mse.max(1e-12)).log10()
}

/// `fovea render --backend gpu` through the resident frame (issue 37): a frame it serves
/// (`--quality realtime`, one eye and both eyes with `--stereo dup`) goes resident — the
/// JSON's `backend.route` says so, the frame is one submission, no blocking wait, nothing
/// read back, the image read back only for `--out` (3 bytes a pixel and eye) — and its PNG is
/// the CPU's within 40 dB; a frame it does not serve (path tracing, `--stereo rep`) is
/// staged, and the JSON says why in one line.
#[cfg(feature = "gpu")]
#[test]
fn gpu_render_goes_resident_when_served_and_says_why_not() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let mut c = fovea();
        c.args([
            "render", "--res", "320x180", "--lights", "1", "-q", "--gaze", "150,80",
        ])
        .args(extra)
        .arg("--out")
        .arg(dir.path().join(format!("{name}.png")));
        c.output().unwrap()
    };
    // `--quality realtime` turns the denoiser on, which the resident frame does not run yet.
    let realtime = ["--quality", "realtime", "--denoise", "off"];
    for (name, eyes, width) in [
        // Full resolution: VaFR at 320×180 shades 20× the pixels (its buffer is sized for
        // acuity), slow on lavapipe; VaFR's resident images are `fovea-gpu`'s golden test.
        ("one", &["--method", "full", "--eyes", "one"][..], 320u64),
        (
            "dup",
            &["--method", "full", "--eyes", "both", "--stereo", "dup"][..],
            640,
        ),
    ] {
        let out = run(name, &[&realtime[..], eyes, &["--backend", "gpu"]].concat());
        if !gpu_ran(
            &out,
            "gpu_render_goes_resident_when_served_and_says_why_not",
        ) {
            return;
        }
        let s = stats(dir.path(), name);
        let b = &s["backend"];
        assert_eq!(b["route"], "resident", "{s}");
        let f = &b["resident_frame"];
        assert_eq!(f["submissions"], 1, "{s}");
        assert_eq!(f["blocking_waits"], 0, "{s}");
        assert_eq!(f["bytes_read_back"], 0, "{s}");
        let image = b["image_readback"]["bytes_read_back"].as_u64().unwrap();
        assert_eq!(image, 3 * width * 180, "{s}");
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            stdout.contains("backend: resident frame: 1 submission"),
            "{stdout}"
        );
        let cpu = format!("{name}-cpu");
        let out = run(&cpu, &[&realtime[..], eyes, &["--backend", "cpu"]].concat());
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let db = png_psnr_db(
            &dir.path().join(format!("{name}.png")),
            &dir.path().join(format!("{cpu}.png")),
        );
        eprintln!("[fovea-cli] resident {name} against the CPU: PSNR {db:.1} dB");
        assert!(db >= 40.0, "{name}: {db} dB");
    }
    for (name, extra, why) in [
        (
            "path",
            &["--method", "full", "--shading", "path"][..],
            "path tracing",
        ),
        (
            "rep",
            &[&realtime[..], &["--eyes", "both", "--stereo", "rep"]].concat()[..],
            "reprojection",
        ),
    ] {
        let out = run(name, &[extra, &["--backend", "gpu"]].concat());
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let s = stats(dir.path(), name);
        assert_eq!(s["backend"]["route"], "staged", "{s}");
        let because = s["backend"]["staged_because"].as_str().unwrap();
        assert!(
            because.contains(why) && !because.contains('\n'),
            "{because}"
        );
    }
}

/// `fovea bench --backend gpu --eyes both` times the binocular frame resident against staged
/// with the gaze moving a saccade-sized step every frame, counted by fovea-gpu: per steady
/// frame one submission, no blocking wait, nothing read back, the bytes up and the host time
/// reported; the staged path's submissions and the ratio beside it. Presence and counts only:
/// no timing is compared. (`--quality realtime` turns the denoiser on for the bench's frames,
/// which the resident frame refuses: `--denoise off`.)
#[cfg(feature = "gpu")]
#[test]
fn bench_gpu_compares_the_resident_frame_with_the_staged_path() {
    let common = [
        "--backend",
        "gpu",
        "--eyes",
        "both",
        "--stereo-reps",
        "1",
        "--frames",
        "1",
        "--gaze-path",
        "saccade",
        "--quality",
        "realtime",
    ];
    let out = bench(&[&common[..], &["--denoise", "off"]].concat(), &[]);
    if !gpu_ran(
        &out,
        "bench_gpu_compares_the_resident_frame_with_the_staged_path",
    ) {
        return;
    }
    let j = bench_json(&out);
    let rows = j["resident_binocular"].as_array().unwrap();
    assert_eq!(rows.len(), 1, "{j}");
    let row = &rows[0];
    assert_eq!(row["route"], "resident", "{row}");
    assert_eq!(row["gaze_path"], "saccade", "{row}");
    let r = &row["resident"];
    assert_eq!(r["submissions_max"], 1, "{row}");
    assert_eq!(r["blocking_waits_max"], 0, "{row}");
    assert_eq!(r["bytes_read_back_max"], 0, "{row}");
    assert!(r["bytes_uploaded_max"].as_u64().unwrap() > 0, "{row}");
    for k in ["wall_ms", "cpu_ms", "host_ms", "plan_ms", "record_ms"] {
        let v = r[k].as_f64().unwrap_or(f64::NAN);
        assert!(v.is_finite() && v > 0.0, "{k}: {row}");
    }
    assert!(r["submissions_max"].as_u64() < row["staged"]["submissions_max"].as_u64());
    let ratio = row["staged_over_resident_wall"].as_f64().unwrap();
    assert!(ratio.is_finite() && ratio > 0.0, "{row}");
    let frames = row["per_frame"].as_array().unwrap();
    assert_eq!(frames.len(), 1, "{row}");
    // Frame 1 (after the warmup frame at the centre) is one step to the right of it.
    let x = frames[0]["gaze_px"][0].as_f64().unwrap();
    assert!(x > 80.0 + 1.0, "{row}");
}

#[test]
fn demo_says_which_backend_made_its_frames() {
    let dir = tempfile::tempdir().unwrap();
    let demo = |backend: &str, env: &[(&str, &str)]| {
        let mut c = fovea();
        c.args(["demo", "--frames", "1", "--backend", backend, "--out"])
            .arg(dir.path());
        for (k, v) in env {
            c.env(k, v);
        }
        c.output().unwrap()
    };
    let page = || std::fs::read_to_string(dir.path().join("demo/index.html")).unwrap();
    // Hides every Vulkan driver: `auto` takes the CPU and says so.
    let out = demo("auto", &[("VK_ICD_FILENAMES", "/nonexistent")]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("backend: CPU (auto: "), "{stdout}");
    assert!(
        page().contains("Foveated frames rendered on: CPU (auto: "),
        "{}",
        page()
    );
    let out = demo("gpu", &[]);
    if cfg!(not(feature = "gpu")) {
        let e = one_line_error(&out);
        assert!(e.contains("--features gpu"), "{e}");
        return;
    }
    if !gpu_ran(&out, "demo_says_which_backend_made_its_frames") {
        return;
    }
    assert!(
        page().contains("Foveated frames rendered on: GPU: "),
        "{}",
        page()
    );
}

/// `fovea report --backend`: the speed section's frames on the GPU say where their rays and
/// reconstruction ran and give the GPU passes' times, and its reproduce line carries the
/// backend; `gpu` without the feature (or an adapter) is a one-line error before any work.
#[test]
fn report_speed_section_says_which_backend_ran() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("report");
    let report = |backend: &str, env: &[(&str, &str)]| {
        let mut c = fovea();
        c.args([
            "report",
            "--quick",
            "--sections",
            "speed",
            "--bench-res",
            "160x90",
        ])
        .args(["-q", "--backend", backend, "--out"])
        .arg(&out_dir);
        for (k, v) in env {
            c.env(k, v);
        }
        c.output().unwrap()
    };
    let hide = [("VK_ICD_FILENAMES", "/nonexistent")];
    let e = one_line_error(&report("gpu", &hide));
    if cfg!(feature = "gpu") {
        assert!(e.contains("no GPU adapter"), "{e}");
    } else {
        assert!(e.contains("--features gpu"), "{e}");
    }
    assert!(
        !out_dir.exists(),
        "the failed report wrote {}",
        out_dir.display()
    );
    let out = report("gpu", &[]);
    if cfg!(not(feature = "gpu")) || !gpu_ran(&out, "report_speed_section_says_which_backend_ran") {
        return;
    }
    let md = std::fs::read_to_string(out_dir.join("report.md")).unwrap();
    assert!(md.contains("Backend: GPU ("), "{md}");
    assert!(md.contains("--backend gpu."), "{md}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out_dir.join("report.json")).unwrap()).unwrap();
    let text = json.to_string();
    for want in [
        "GPU trace pass (ms)",
        "GPU direct_light pass (ms)",
        "GPU environment_light pass (ms)",
        "rays on",
    ] {
        assert!(text.contains(want), "no {want} in {text}");
    }
    let v = fovea()
        .args(["report", "--verify"])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stdout));
}
