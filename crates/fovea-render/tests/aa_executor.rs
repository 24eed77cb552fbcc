//! Stage 5's AA through another executor ([`AaExecutor`] in a [`FrameContext`]): used for the
//! modes and grids it supports, the CPU otherwise, its name in the frame's stats, and its
//! error one line naming the stage. The mock executor runs the CPU's own filters, so its frame
//! is the CPU frame bit for bit (the minified columns restored as on the CPU).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_core::Image;
use fovea_post::fxaa::{fxaa, FxaaParams};
use fovea_post::gaussian_aa::gaussian_3x3;
use fovea_post::grid::Grid;
use fovea_post::Rgb;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::eye::EyeState;
use fovea_render::pipeline::{
    render_planned, AaExecutor, AaMode, FrameContext, FrameInputs, FrameSettings, StageTimes,
};
use fovea_render::plan::FramePlan;
use fovea_render::scene::builtin;
use fovea_render::world::World;

/// Runs the CPU filters, counting its calls; `accept` says what it supports, `fail` errs.
struct Mock {
    calls: Arc<AtomicUsize>,
    accept: bool,
    fail: bool,
}

impl AaExecutor for Mock {
    fn backend(&self) -> &str {
        "mock"
    }

    fn supports(&self, mode: AaMode, _grid: &Grid) -> bool {
        self.accept && matches!(mode, AaMode::Fxaa | AaMode::Gaussian)
    }

    fn anti_alias(
        &mut self,
        mode: AaMode,
        params: &FxaaParams,
        grid: &Grid,
        color: &Image<Rgb>,
    ) -> Result<Image<Rgb>, String> {
        self.calls.fetch_add(1, Ordering::SeqCst);
        if self.fail {
            return Err("the mock failed; use --backend cpu".into());
        }
        Ok(match mode {
            AaMode::Fxaa => fxaa(color, grid, params),
            _ => gaussian_3x3(color, grid),
        })
    }
}

#[test]
fn an_aa_executor_runs_stage_5_where_it_can() {
    let d = DisplayProfile::new("t", 160, 180, Degrees(100.0), Degrees(110.0)).unwrap();
    let world = World::new(builtin::depth_range().unwrap(), Backend::Obvhs).unwrap();
    let camera = EyeCamera::from_desc(&world.scene.cameras[0], &d).unwrap();
    let eye = EyeState::looking_at(d.gaze(60.0, 70.0).unwrap());
    let frame = |m: Method, mock: Option<Mock>| {
        let plan =
            FramePlan::new(&world, &camera, &FrameSettings::new(m), &eye, [0.0, 0.0]).unwrap();
        let mut ctx = FrameContext::new();
        if let Some(mock) = mock {
            ctx.set_anti_aliaser(Box::new(mock));
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
        .map(|f| (f.color.clone(), f.stats.aa_backend.clone(), f.stats.aa))
    };
    for (m, aa) in [
        (Method::Vafr, AaMode::Fxaa),
        (Method::Kfr, AaMode::Gaussian),
        (Method::Full, AaMode::None),
    ] {
        let calls = Arc::new(AtomicUsize::new(0));
        let mock = |accept, fail| Mock {
            calls: calls.clone(),
            accept,
            fail,
        };
        let (cpu, cpu_backend, cpu_aa) = frame(m, None).unwrap();
        assert_eq!((cpu_backend.as_str(), cpu_aa), ("cpu", aa), "{m}");
        let (on_mock, backend, _) = frame(m, Some(mock(true, false))).unwrap();
        let filtered = aa != AaMode::None;
        assert_eq!(
            calls.swap(0, Ordering::SeqCst),
            usize::from(filtered),
            "{m}"
        );
        assert_eq!(backend, if filtered { "mock" } else { "cpu" }, "{m}");
        assert_eq!(on_mock.data(), cpu.data(), "{m}: the executor's frame");
        // Declined: the CPU filters.
        let (declined, backend, _) = frame(m, Some(mock(false, false))).unwrap();
        assert_eq!(calls.swap(0, Ordering::SeqCst), 0, "{m}");
        assert_eq!(backend, "cpu", "{m}");
        assert_eq!(declined.data(), cpu.data(), "{m}");
        if filtered {
            let e = frame(m, Some(mock(true, true))).unwrap_err().to_string();
            assert!(e.contains("aa") && e.contains("mock") && e.contains("the mock failed"));
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
