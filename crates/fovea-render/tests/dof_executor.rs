//! Stage 7's depth of field through another executor ([`DofExecutor`], the seam the GPU's
//! gather plugs into): used for the filters and CoC models it supports, with the CoC
//! parameters and focus the CPU path uses, named in the frame's stats; the CPU keeps the
//! others; an executor's error is the frame's one-line error.

use std::sync::{Arc, Mutex};

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::{Degrees, Metres};
use fovea_core::Image;
use fovea_post::dof::coc::{coc_map, CocModel, CocParams};
use fovea_post::dof::{DofInput, FilterKind};
use fovea_post::Rgb;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::dof::{DofSettings, FocusMode};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::{
    render_planned, DofExecutor, FrameContext, FrameInputs, FrameSettings, StageTimes,
};
use fovea_render::plan::FramePlan;
use fovea_render::scene::builtin;
use fovea_render::world::World;

/// Runs the CPU's own functions (so the frame must equal the CPU frame) and records calls.
struct Mock {
    calls: Arc<Mutex<Vec<(FilterKind, f64)>>>,
    fail: bool,
    /// The largest image it takes, pixels (a device's binding limit).
    max_pixels: u64,
}

impl DofExecutor for Mock {
    fn backend(&self) -> &str {
        "mock"
    }

    fn supports(&self, filter: FilterKind, coc_model: &CocModel) -> bool {
        filter == FilterKind::Gather && *coc_model == CocModel::ThinLens
    }

    fn fits(&self, width_px: u32, height_px: u32) -> bool {
        u64::from(width_px) * u64::from(height_px) <= self.max_pixels
    }

    fn depth_of_field(
        &mut self,
        filter: FilterKind,
        coc: &CocParams,
        focus_m: f64,
        color: &Image<Rgb>,
        depth_m: &Image<f32>,
    ) -> Result<(Image<Rgb>, Image<f32>), String> {
        self.calls.lock().unwrap().push((filter, focus_m));
        if self.fail {
            return Err("the mock failed; use --backend cpu".into());
        }
        let map = coc_map(coc, Metres(focus_m), depth_m).map_err(|e| e.to_string())?;
        let out = filter
            .build()
            .apply(&DofInput {
                color,
                depth_m,
                coc_px: &map,
                focus_m: focus_m as f32,
                px_per_dioptre: coc.px_per_dioptre() as f32,
                gaze_px: [0.0, 0.0],
                px_per_degree: 1.0,
            })
            .map_err(|e| e.to_string())?;
        Ok((out, map))
    }
}

#[test]
fn the_dof_executor_runs_what_it_supports_and_says_so() {
    let d = DisplayProfile::new("t", 96, 80, Degrees(100.0), Degrees(110.0)).unwrap();
    let scene = builtin::depth_range().unwrap();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let camera = EyeCamera::from_desc(&world.scene.cameras[0], &d).unwrap();
    let gaze = d.gaze(40.0, 40.0).unwrap();
    let frame = |filter: FilterKind, model: CocModel, executor: Option<Mock>| {
        let mut s = FrameSettings::new(Method::Full);
        let mut dof = DofSettings::new(Some(filter), FocusMode::Fixed(0.7));
        dof.coc_model = model;
        let eye = EyeState::fixating(&world, &camera, gaze, Some(&dof)).unwrap();
        s.dof = Some(dof);
        let plan = FramePlan::new(&world, &camera, &s, &eye, [0.0, 0.0]).unwrap();
        let mut ctx = FrameContext::new();
        if let Some(ex) = executor {
            ctx.set_dof_executor(Box::new(ex));
        }
        render_planned(
            &mut ctx,
            &world,
            &camera,
            &plan,
            FrameInputs::default(),
            StageTimes::default(),
            &|_, _| {},
        )
        .map(|f| {
            // The stage's placement was decided before the first pass, and the name in the
            // stats is the decision's.
            let placed = &f.stats.stage_backends.dof;
            assert_eq!(placed.backend, f.stats.dof_backend);
            let why = placed.on_cpu_because.clone().unwrap_or_default();
            (
                f.color.clone(),
                f.coc.clone(),
                f.stats.dof_backend.clone(),
                why,
            )
        })
    };
    let calls = Arc::new(Mutex::new(Vec::new()));
    let mock = |fail| Mock {
        calls: calls.clone(),
        fail,
        max_pixels: u64::MAX,
    };
    // Gather with the thin lens: the executor, with the CPU path's focus; the same frame.
    let (c_cpu, coc_cpu, b_cpu, why) = frame(FilterKind::Gather, CocModel::ThinLens, None).unwrap();
    assert_eq!(b_cpu, "cpu");
    assert_eq!(why, "", "no executor, no reason");
    let (c, coc, b, _) = frame(FilterKind::Gather, CocModel::ThinLens, Some(mock(false))).unwrap();
    assert_eq!(b, "mock");
    assert_eq!(
        calls.lock().unwrap().as_slice(),
        &[(FilterKind::Gather, 0.7)]
    );
    assert_eq!(c.data(), c_cpu.data());
    assert_eq!(coc.unwrap().data(), coc_cpu.unwrap().data());
    // Another filter or CoC model: the CPU.
    for (filter, model) in [
        (FilterKind::Bokeh, CocModel::ThinLens),
        (FilterKind::Gather, CocModel::Stabilised),
    ] {
        let (_, _, b, why) = frame(filter, model, Some(mock(false))).unwrap();
        assert_eq!(b, "cpu", "{filter:?} {model:?}");
        assert!(why.contains("does not take"), "{why}");
    }
    assert_eq!(calls.lock().unwrap().len(), 1);
    // An executor that takes one pixel fewer than the frame's 96×80: the CPU filters it (the
    // CPU's frame); one that takes exactly 96×80: the executor.
    for (max_pixels, backend) in [(96 * 80 - 1, "cpu"), (96 * 80, "mock")] {
        let small = Mock {
            max_pixels,
            ..mock(false)
        };
        let (c, _, b, why) = frame(FilterKind::Gather, CocModel::ThinLens, Some(small)).unwrap();
        assert_eq!(b, backend, "{max_pixels}");
        assert_eq!(
            why.contains("96×80 frame is past"),
            backend == "cpu",
            "{why}"
        );
        assert_eq!(c.data(), c_cpu.data());
    }
    assert_eq!(calls.lock().unwrap().len(), 2);
    // The executor's error is the frame's, on one line, naming the stage and backend.
    let e = frame(FilterKind::Gather, CocModel::ThinLens, Some(mock(true)))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("dof") && e.contains("mock") && !e.contains('\n'),
        "{e}"
    );
}
