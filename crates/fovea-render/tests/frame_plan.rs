//! The frame plan and the frame context: one mapping per eye per frame, buffers reused from
//! frame to frame, the plan as data. One test function, because it reads a process-wide
//! counter of built mappings (`fovea_core::mapping::build_count`) that parallel tests would
//! disturb.

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::gaze::GazeSample;
use fovea_core::mapping::{build_count, Method};
use fovea_core::optics::AccommodationParams;
use fovea_core::units::Degrees;
use fovea_post::dof::FilterKind;
use fovea_render::bvh::Backend;
use fovea_render::camera::{Eye, EyeCamera, HmdRig};
use fovea_render::dof::{DofSettings, FocusMode};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::{
    render_frame, render_frame_temporal, render_planned, FrameContext, FrameInputs, FrameSettings,
    StageTimes,
};
use fovea_render::plan::FramePlan;
use fovea_render::scene::builtin;
use fovea_render::sequence::{Sequence, SequenceDriver, Track};
use fovea_render::stereo::{fixating_eyes, render_stereo, StereoMode};
use fovea_render::temporal::{TemporalAccumulator, TemporalSettings};
use fovea_render::world::World;

fn display() -> DisplayProfile {
    DisplayProfile::new("t", 160, 180, Degrees(100.0), Degrees(110.0)).unwrap()
}

/// Mappings built while `f` runs.
fn builds<T>(f: impl FnOnce() -> T) -> (u64, T) {
    let before = build_count();
    let out = f();
    (build_count() - before, out)
}

#[test]
fn frame_plans() {
    one_mapping_per_eye_per_frame_and_buffers_reused();
    the_plan_is_data();
}

fn one_mapping_per_eye_per_frame_and_buffers_reused() {
    let d = display();
    let scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, 0.063).unwrap();
    let camera = rig.eye(Eye::Centre, &d).unwrap();
    let gaze = d.gaze(60.0, 70.0).unwrap();
    let mut dof_settings = FrameSettings::new(Method::Vafr);
    let mut dof = DofSettings::new(Some(FilterKind::Gather), FocusMode::Auto);
    dof.cull = true;
    dof_settings.dof = Some(dof);
    dof_settings.contrast = Some(Default::default());

    // A single frame, every method, with and without DOF, culling and contrast: one mapping.
    for m in Method::ALL {
        let (n, _) = builds(|| {
            render_frame(&world, &camera, &FrameSettings::new(m), gaze, &|_, _| {}).unwrap()
        });
        assert_eq!(n, 1, "{m}");
    }
    let (n, _) = builds(|| render_frame(&world, &camera, &dof_settings, gaze, &|_, _| {}).unwrap());
    assert_eq!(n, 1, "VaFR with DOF, culling and contrast");

    // Temporal accumulation: one mapping per frame (the history keeps the previous one).
    for m in [Method::Vafr, Method::Weier, Method::Guenter] {
        let mut acc = TemporalAccumulator::new(TemporalSettings::default()).unwrap();
        for k in 0..3 {
            let g = d.gaze(60.0 + 5.0 * k as f64, 70.0).unwrap();
            let s = FrameSettings::new(m);
            let (n, _) =
                builds(|| render_frame_temporal(&world, &camera, &s, g, &mut acc, &|_, _| {}));
            assert_eq!(n, 1, "{m} temporal frame {k}");
        }
    }

    // Both eyes: one mapping per eye, in Dup and in Rep (whose warp reads both plans).
    let (_, [(lc, lg), (rc, rg)]) = fixating_eyes(&world, &rig, &d, &gaze).unwrap();
    for mode in [StereoMode::Dup, StereoMode::Rep] {
        let eyes = [EyeState::looking_at(lg), EyeState::looking_at(rg)];
        let s = FrameSettings::new(Method::Vafr);
        let (n, _) =
            builds(|| render_stereo(&world, &lc, &rc, &s, eyes, mode, &|_, _| {}).unwrap());
        assert_eq!(n, 2, "{mode:?}");
    }

    // A sequence of 4 frames with temporal accumulation and auto focus: 4 mappings, and after
    // the first frame no screen buffer is allocated again.
    let n_frames = 4;
    let gazes: Vec<GazeSample> = (0..n_frames)
        .map(|k| GazeSample::new(k as f64 / 90.0, 50.0 + 8.0 * k as f64, 80.0))
        .collect();
    let seq = Sequence::plan(
        &world,
        vec![camera.clone(); n_frames],
        gazes,
        dof_settings.dof.as_ref(),
        90.0,
        AccommodationParams::default(),
        None,
    )
    .unwrap();
    let track = Track::new(
        "vafr-on",
        dof_settings.clone(),
        Some(TemporalSettings::default()),
    )
    .unwrap();
    let mut driver = SequenceDriver::new(&world, &seq, vec![track]).unwrap();
    let mut allocations = Vec::new();
    let (n, counts) = builds(|| {
        driver
            .run::<fovea_render::RenderError>(
                &|_| false,
                &mut |e| {
                    allocations.push(e.tracks[0].screen_allocations());
                    Ok(())
                },
                &mut |_| {},
            )
            .unwrap()
    });
    assert_eq!(counts.rendered, n_frames);
    assert_eq!(n, n_frames as u64, "one mapping per frame of the sequence");
    assert!(allocations[0] >= 1, "{allocations:?}");
    assert!(
        allocations.windows(2).all(|w| w[0] == w[1]),
        "screen buffers allocated after the first frame: {allocations:?}"
    );

    // Pointer identity: repeated VaFR and full-resolution frames in one context write the
    // same screen buffers, and the frame is the same as a fresh render's.
    for m in [Method::Vafr, Method::Full, Method::Kfr] {
        let s = FrameSettings::new(m);
        let eye = EyeState::looking_at(gaze);
        let mut ctx = FrameContext::new();
        let mut ptrs = Vec::new();
        for _ in 0..3 {
            let plan = FramePlan::new(&world, &camera, &s, &eye, [0.0, 0.0]).unwrap();
            let f = render_planned(
                &mut ctx,
                &world,
                &camera,
                &plan,
                FrameInputs::default(),
                StageTimes::default(),
                &|_, _| {},
            )
            .unwrap();
            ptrs.push((f.color.data().as_ptr(), f.depth.data().as_ptr()));
        }
        assert_eq!(ctx.screen_allocations(), 2, "{m}: colour and depth, once");
        // Full resolution hands its sample buffer over as the screen and takes it back as the
        // next frame's samples: one pair of buffers too.
        assert!(ptrs.windows(2).all(|w| w[0] == w[1]), "{m}: {ptrs:?}");
        let fresh = render_frame(&world, &camera, &s, gaze, &|_, _| {}).unwrap();
        assert_eq!(
            ctx.frame().unwrap().color.data(),
            fresh.color.data(),
            "{m}: a reused context renders the same image"
        );
    }
}

fn the_plan_is_data() {
    let d = display();
    let scene = builtin::depth_range().unwrap();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let camera = EyeCamera::from_desc(&world.scene.cameras[0], &d).unwrap();
    let gaze: Gaze = d.gaze(40.0, 100.0).unwrap();
    let mut s = FrameSettings::new(Method::Vafr);
    s.dof = Some(DofSettings::new(Some(FilterKind::Gather), FocusMode::Auto));
    let eye = EyeState::fixating(&world, &camera, gaze, s.dof.as_ref()).unwrap();
    let plan = FramePlan::new(&world, &camera, &s, &eye, [0.0, 0.0]).unwrap();
    let json = plan.to_json().unwrap();
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    // The eye state, the mapping's buffers and tables, the resolved AA: all there.
    assert_eq!(v["eye"]["gaze"]["point"]["x_px"].as_f64(), Some(40.0));
    assert!(v["eye"]["focus"]["metres"].as_f64().unwrap() > 0.0);
    assert_eq!(v["settings"]["method"], "vafr");
    assert_eq!(v["aa"], "fxaa");
    assert_eq!(
        v["sample_count"].as_u64().unwrap(),
        plan.mapping().sample_count()
    );
    let cols = v["footprint"]["column_rad"].as_array().unwrap();
    assert_eq!(cols.len(), plan.buffers[0].width as usize);
    // The same inputs give the same plan, byte for byte; another gaze another plan.
    let again = FramePlan::new(&world, &camera, &s, &eye, [0.0, 0.0]).unwrap();
    assert_eq!(again.to_json().unwrap(), json);
    let other_eye = EyeState {
        gaze: d.gaze(120.0, 100.0).unwrap(),
        ..eye
    };
    let other = FramePlan::new(&world, &camera, &s, &other_eye, [0.0, 0.0]).unwrap();
    assert_ne!(other.to_json().unwrap(), json);
    // A DOF frame without a focus, a bad jitter, a bad setting: typed errors, no work done.
    let unfocused = EyeState::looking_at(gaze);
    assert!(FramePlan::new(&world, &camera, &s, &unfocused, [0.0, 0.0]).is_err());
    assert!(FramePlan::new(&world, &camera, &s, &eye, [f64::NAN, 0.0]).is_err());
    let mut bad = s.clone();
    bad.dof.as_mut().unwrap().max_coc_px = -1.0;
    let e = FramePlan::new(&world, &camera, &bad, &eye, [0.0, 0.0]).unwrap_err();
    assert!(e.to_string().contains("max-coc"), "{e}");
    let mut tiny = s.clone();
    tiny.memory_limit_bytes = 1000;
    let e = FramePlan::new(&world, &camera, &tiny, &eye, [0.0, 0.0]).unwrap_err();
    assert!(e.to_string().contains("--max-memory"), "{e}");
}
