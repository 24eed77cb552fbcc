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

const SMALL: [&str; 7] = [
    "render", "--res", "320x180", "--lights", "2", "-q", "--gaze",
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
    let stages = s["backend"]["stages"].as_object().unwrap();
    for k in ["plan", "trace", "shade", "reconstruct"] {
        assert_eq!(stages[k], "cpu", "{k}: {stages:?}");
    }
}

#[test]
fn gpu_backend_refuses_frames_it_has_no_stage_for() {
    let dir = tempfile::tempdir().unwrap();
    let e = one_line_error(&render(
        dir.path(),
        "g",
        &["--method", "guenter", "--backend", "gpu"],
        &[],
    ));
    assert!(
        e.contains("polar methods only") && e.contains("--backend cpu"),
        "{e}"
    );
    // `auto` takes the CPU for them and says why.
    let out = render(
        dir.path(),
        "a",
        &["--method", "guenter", "--backend", "auto"],
        &[],
    );
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("backend: CPU (auto: "), "{stdout}");
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
    assert_eq!(s["frame"]["trace_backend"], "gpu");
    assert_eq!(s["backend"]["stages"]["trace"], "gpu");
    assert_eq!(s["backend"]["stages"]["shade"], "cpu");
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
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains(
            "primary rays on the GPU, reconstruct on the GPU, every other stage on the CPU"
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

/// The GPU's image `gpu.exr` against the CPU's `cpu.exr` in `dir`: within the GPU
/// reconstruction tests' worst-case bound per channel (relative above 1), and a mean far below
/// theirs (shaded content is smooth where random texels are not).
#[cfg(feature = "gpu")]
fn assert_gpu_image_is_the_cpus(dir: &Path, gpu: &str, cpu: &str) {
    let read = |name: &str| {
        image::open(dir.join(format!("{name}.exr")))
            .unwrap()
            .into_rgb32f()
    };
    let (g, c) = (read(gpu), read(cpu));
    assert_eq!(g.dimensions(), c.dimensions());
    let (mut max, mut sum, mut n) = (0.0f32, 0.0f64, 0usize);
    for (a, b) in g.pixels().zip(c.pixels()) {
        for k in 0..3 {
            let e = (a[k] - b[k]).abs();
            let scale = a[k].abs().max(b[k].abs()).max(1.0);
            max = max.max(e / scale);
            sum += e as f64;
            n += 1;
        }
    }
    let mean = sum / n as f64;
    eprintln!("[fovea-cli] GPU vs CPU {gpu}: max relative difference {max:.4}, mean {mean:.2e}");
    assert!(max <= 2.0 / 64.0 + 2e-3, "{max}");
    // Smooth shaded content (measured on lavapipe: max 6e-4, mean 1.6e-5); random texels
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

/// `fovea sequence --backend`: the folder records where its frames were made, and a sequence
/// on the GPU writes the CPU's frames within 8-bit rounding of the render test's bounds.
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
        assert!(r["gpu_pass_ms"].as_object().unwrap().is_empty(), "{r}");
        let fps = r["fps"].as_f64().unwrap();
        assert!(fps.is_finite() && fps > 0.0, "{r}");
    }
    // One eye only on the GPU, refused before any work in every build.
    let e = one_line_error(&bench(&["--backend", "gpu", "--eyes", "both"], &[]));
    assert!(e.contains("one eye") && e.contains("--backend cpu"), "{e}");
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

/// VaFR's primary rays and reconstruction on the GPU with their passes' own times from
/// timestamps, full resolution on the CPU in the same run; on lavapipe the figures are
/// labelled CPU-emulated. Presence, sign and finiteness only: no timing is compared.
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
    assert_eq!(full["stage_backends"]["trace"], "cpu", "{full}");
    assert!(
        full["gpu_pass_ms"].as_object().unwrap().is_empty(),
        "{full}"
    );
    let vafr = run("vafr");
    assert_eq!(vafr["stage_backends"]["trace"], "gpu", "{vafr}");
    assert_eq!(vafr["stage_backends"]["reconstruct"], "gpu", "{vafr}");
    for pass in ["trace", "reconstruct"] {
        let ms = vafr["gpu_pass_ms"][pass].as_f64().unwrap_or(f64::NAN);
        assert!(ms.is_finite() && ms > 0.0, "{pass}: {vafr}");
    }
    for r in [full, vafr] {
        let fps = r["fps"].as_f64().unwrap();
        assert!(fps.is_finite() && fps > 0.0, "{r}");
        assert!(r["rays_primary"].as_u64().unwrap() > 0, "{r}");
        let speedup = r["speedup_vs_full"].as_f64().unwrap();
        assert!(speedup.is_finite() && speedup > 0.0, "{r}");
    }
}

/// `fovea demo --backend`: stdout and the page say where the foveated frames were made, and
/// a GPU that cannot run is the same one-line error as `render`'s, before any frame.
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
