//! Each experiment end to end on the built-in scene at a tiny resolution: the library
//! functions `fovea bench`, `fovea flicker`, `fovea inset-analysis`, `fovea dof-compare` and
//! `fovea report` call.

use std::sync::atomic::{AtomicUsize, Ordering};

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::optics::AccommodationParams;
use fovea_core::units::Degrees;
use fovea_eval::experiments::bench::{self, BenchEvent, BenchParams, FixedScene};
use fovea_eval::experiments::dof_compare::{self, DofCompareParams, FocusSpec};
use fovea_eval::experiments::flicker::{self, Accumulation, FlickerParams};
use fovea_eval::experiments::inset::{self, smoothings, InsetParams};
use fovea_eval::experiments::scenario::{camera_slide, GazeScenario};
use fovea_post::dof::FilterKind;
use fovea_render::bvh::Backend;
use fovea_render::camera::{Eye, EyeCamera, HmdRig};
use fovea_render::scene::builtin;
use fovea_render::sequence::Sequence;
use fovea_render::world::World;

fn display(w: u32, h: u32) -> DisplayProfile {
    DisplayProfile::with_vertical_fov(format!("{w}x{h}"), w, h, Degrees(90.0)).unwrap()
}

/// The depth-range scene, its BVH and its camera on `d`.
fn scene(d: &DisplayProfile) -> (World, EyeCamera, HmdRig) {
    let scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    let camera = EyeCamera::from_desc(&desc, d).unwrap();
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, 0.063).unwrap();
    (World::new(scene, Backend::Obvhs).unwrap(), camera, rig)
}

#[test]
fn flicker_accumulation_reuses_samples() {
    let d = display(64, 72);
    let (world, camera, _) = scene(&d);
    let (frames, fps) = (4, 90.0);
    let gazes = GazeScenario::SaccadePursuit
        .trajectory(&d, 1, frames as f64 / fps)
        .unwrap()
        .resample(fps, frames)
        .unwrap();
    let cameras = camera_slide(&camera, [0.04, 0.01, 0.0], frames).unwrap();
    assert_eq!(cameras.len(), frames);
    let seq = Sequence::plan(
        &world,
        cameras,
        gazes,
        None,
        fps,
        AccommodationParams::default(),
        None,
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let params = FlickerParams {
        methods: vec![Method::Vafr],
        accumulation: Accumulation::Both,
        reference_spp: 1,
        save_frames: Some(dir.path().join("frames")),
        ..FlickerParams::default()
    };
    let mut last = None;
    let r = flicker::run(&world, &seq, &params, &mut |p| last = Some(p)).unwrap();
    let last = last.unwrap();
    assert_eq!((last.renders_done, last.renders_total), (12, 12));
    assert!(last.frame_done && last.frame == frames - 1);

    assert_eq!(r.variants.len(), 2);
    let (off, on) = (&r.variants[0], &r.variants[1]);
    assert!(!off.temporal && on.temporal);
    assert_eq!(off.mean_reused, None);
    let reused = on.mean_reused.unwrap();
    assert!(reused > 0.0 && reused <= 1.0, "{reused}");
    for v in &r.variants {
        assert_eq!(v.psnr.len(), frames);
        assert_eq!(v.flicker.periphery.frames, frames as u64 - 1);
        assert!(
            v.mean_psnr_db.is_finite() && v.mean_psnr_db > 10.0,
            "{}",
            v.mean_psnr_db
        );
    }
    assert_eq!(r.per_frame.len(), 2 * frames);
    assert!(r.per_frame[0].peripheral_flicker.is_none());
    assert!(r.per_frame[1].peripheral_flicker.is_some());
    let csv = r.frames_csv();
    assert_eq!(csv.lines().count(), 1 + 2 * frames);
    assert!(
        csv.lines().nth(5).unwrap().starts_with("vafr,on,0,"),
        "{csv}"
    );
    let md = r.markdown();
    assert!(
        md.contains("| vafr | off |") && md.contains("| vafr | on |"),
        "{md}"
    );
    assert_eq!(flicker::accumulation_lines(&r.variants).len(), 1);
    for sub in ["reference", "vafr-off", "vafr-on"] {
        let p = dir.path().join("frames").join(sub).join("frame_00003.png");
        assert!(p.is_file(), "{}", p.display());
    }
}

#[test]
fn bench_counts_rays_and_speedups() {
    let d = display(96, 96);
    let (world, _, rig) = scene(&d);
    let mut view = FixedScene {
        world: &world,
        rig,
        eye: Eye::Centre,
    };
    let params = BenchParams {
        displays: vec![d.clone()],
        methods: vec![Method::Vafr],
        bvh_rays: 4096,
        dof_filters: vec![FilterKind::Gather],
        dof_reps: 1,
        stereo: true,
        stereo_reps: 1,
        ..BenchParams::default()
    };
    let (started, runs, samples) = (
        AtomicUsize::new(0),
        AtomicUsize::new(0),
        AtomicUsize::new(0),
    );
    let r = bench::run(&mut view, &params, &|e| match e {
        BenchEvent::Started { .. } => {
            started.fetch_add(1, Ordering::Relaxed);
        }
        BenchEvent::Run(_) => {
            runs.fetch_add(1, Ordering::Relaxed);
        }
        BenchEvent::Samples { done, total } => {
            assert!(done <= total);
            samples.fetch_add(1, Ordering::Relaxed);
        }
        _ => {}
    })
    .unwrap();
    assert_eq!(started.into_inner(), 2);
    assert_eq!(runs.into_inner(), 2);
    assert!(samples.into_inner() > 0);

    assert_eq!(r.runs.len(), 2);
    let (full, vafr) = (&r.runs[0].stats, &r.runs[1]);
    assert_eq!(full.method, "full");
    assert_eq!(full.samples, 96 * 96);
    assert_eq!(full.rays_primary, full.samples);
    assert_eq!(r.runs[0].speedup, 1.0);
    assert_eq!(vafr.stats.method, "vafr");
    assert!(vafr.stats.rays_primary > 0 && vafr.stats.rays_primary <= vafr.stats.samples);
    assert!(
        vafr.speedup > 0.0 && vafr.speedup.is_finite(),
        "{}",
        vafr.speedup
    );
    assert_eq!(
        vafr.screen_allocations, 0,
        "the timed frame reuses the warm-up's buffers"
    );

    assert_eq!(r.dof.len(), 1);
    assert_eq!(r.dof[0].filters.len(), 1);
    assert_eq!(r.dof[0].filters[0].relative_to_fastest, 1.0);
    assert_eq!(r.binocular.len(), 1);
    let b = &r.binocular[0];
    assert_eq!(b.method, "vafr");
    assert!(b.rep_rays_primary <= b.dup_rays_primary);
    let obvhs = r
        .bvh_throughput
        .iter()
        .find(|b| b.backend == "obvhs")
        .unwrap();
    assert!(obvhs.available && obvhs.chosen);
    assert!(obvhs.primary_mrays_per_s.unwrap() > 0.0);

    let json = r.to_json();
    assert_eq!(json["scene"], world.scene.name.as_str());
    assert_eq!(json["runs"].as_array().unwrap().len(), 2);
    assert_eq!(json["runs"][1]["rays_primary"], vafr.stats.rays_primary);
    assert!(json["runs"][1]["stages_ms"]["trace"].as_f64().is_some());
    assert_eq!(json["binocular"][0]["method"], "vafr");
}

#[test]
fn inset_table_has_one_row_per_smoothing() {
    let d = display(128, 128);
    let (world, camera, _) = scene(&d);
    let dir = tempfile::tempdir().unwrap();
    // Noise-free: the inset is then the reference's own pixels (checked below).
    let params = InsetParams {
        band_px: 8,
        images: Some(dir.path().to_path_buf()),
        shading: fovea_eval::reference::MeasuredShading::NoiseFree,
        ..InsetParams::default()
    };
    let a = inset::run(&world, &camera, &d.centre_gaze(), &params).unwrap();
    assert_eq!((a.inset.w, a.inset.h), (32, 32));
    assert_eq!(a.periphery_px, [32, 32]);
    let names: Vec<&str> = a.rows.iter().map(|r| r.method.as_str()).collect();
    let mut expected = vec!["full"];
    expected.extend(smoothings().iter().map(|s| s.0));
    assert_eq!(names, expected);
    assert_eq!(a.rows[0].area1_change, 0.0);
    // The inset is the full frame's pixels: Area1 (well inside) of the hard composite is
    // the full frame's.
    assert!(
        a.rows[1].area1_change.abs() < 1e-9,
        "{}",
        a.rows[1].area1_change
    );
    for name in &expected {
        assert!(dir.path().join(format!("{name}.png")).is_file(), "{name}");
    }
    let json = a.to_json();
    assert_eq!(json["rows"].as_array().unwrap().len(), 8);
    assert_eq!(json["band_px"], 8);
    assert_eq!(json["periphery_factor"], 4);
}

#[test]
fn dof_compare_scores_a_filter_against_the_reference() {
    let d = display(96, 96);
    let (world, camera, _) = scene(&d);
    let params = DofCompareParams {
        window: [32, 32],
        margin_px: 8,
        lens_samples: 8,
        pixel_samples: 2,
        filters: vec![FilterKind::Gather],
        focus: vec![FocusSpec::Near, FocusSpec::Metres(2.0)],
        ..DofCompareParams::default()
    };
    let steps = AtomicUsize::new(0);
    let r = dof_compare::run(&world, &camera, &d.centre_gaze(), &params, &|_| {
        steps.fetch_add(1, Ordering::Relaxed);
    })
    .unwrap();
    assert!(steps.into_inner() >= 3);
    assert_eq!((r.window.width, r.window.height), (32, 32));
    assert_eq!(r.cases.len(), 2);
    assert_eq!(r.cases[1].focus_m, 2.0);
    for c in &r.cases {
        let names: Vec<&str> = c.filters.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["pinhole", "gather"]);
        assert_eq!(c.images.len(), 2);
        assert!(
            c.filters.iter().all(|f| f.psnr_y_db > 0.0),
            "{:?}",
            c.filters
        );
    }
    let md = r.markdown("depth-range", &d.name);
    assert!(md.contains("| gather |") && md.contains("## Mean over the focus cases"));
    let json = r.to_json("depth-range", &d.name);
    assert_eq!(json["filters"].as_array().unwrap().len(), 2);
    assert_eq!(json["cases"].as_array().unwrap().len(), 2);

    let mut bad = params.clone();
    bad.window = [4, 4];
    let e = dof_compare::run(&world, &camera, &d.centre_gaze(), &bad, &|_| {}).unwrap_err();
    assert_eq!(e.parameter(), Some("window"));
}
