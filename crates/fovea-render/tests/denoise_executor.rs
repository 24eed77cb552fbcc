//! The denoise stage through another executor ([`DenoiseExecutor`] in a [`FrameContext`],
//! issue 38's GPU twin plugs in here): used for the buffers it supports, the CPU otherwise,
//! never while the denoiser is off, its name in the frame's stats, and its error one line
//! naming the stage. The mock executor runs the CPU's own filter, so its frame is the CPU frame
//! bit for bit.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_post::denoise::{DenoiseGuides, DenoiseParams, DenoiseScratch, DenoiseStats};
use fovea_post::grid::Grid;
use fovea_post::inverse_map::SampleBuffers;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::error::RenderError;
use fovea_render::pipeline::{
    plan_frame, render_planned, DenoiseExecutor, Frame, FrameContext, FrameInputs, FrameSettings,
};
use fovea_render::scene::builtin;
use fovea_render::world::World;

/// Runs `fovea_post::denoise` layer by layer, counting its calls; `accept` says whether it
/// supports the buffers, `fail` errs.
struct Mock {
    calls: Arc<AtomicUsize>,
    accept: bool,
    fail: bool,
}

impl DenoiseExecutor for Mock {
    fn backend(&self) -> &str {
        "mock"
    }

    fn supports(&self, sizes: &[(u32, u32)]) -> bool {
        assert!(!sizes.is_empty());
        self.accept
    }

    fn denoise(
        &mut self,
        params: &DenoiseParams,
        grids: &[Grid],
        samples: &mut SampleBuffers,
        guides: &DenoiseGuides,
    ) -> Result<DenoiseStats, String> {
        self.calls.fetch_add(1, Ordering::SeqCst);
        if self.fail {
            return Err("the mock failed; use --backend cpu".into());
        }
        assert_eq!(grids.len(), samples.color.len());
        let mut scratch = DenoiseScratch::default();
        let mut stats = DenoiseStats::default();
        for (l, ((c, d), grid)) in samples
            .color
            .iter_mut()
            .zip(&samples.depth)
            .zip(grids)
            .enumerate()
        {
            stats += fovea_post::denoise::denoise(
                c,
                d,
                &guides.albedo[l],
                &guides.normal[l],
                guides.noisy.get(l),
                grid,
                params,
                &mut scratch,
            )
            .map_err(|e| e.to_string())?;
        }
        Ok(stats)
    }
}

fn setup() -> (World, EyeCamera) {
    let world = World::new(builtin::depth_range().unwrap(), Backend::Obvhs).unwrap();
    let d = DisplayProfile::new("t", 64, 72, Degrees(100.0), Degrees(110.0)).unwrap();
    let camera = EyeCamera::from_desc(&world.scene.cameras[0], &d).unwrap();
    (world, camera)
}

fn render(
    ctx: &mut FrameContext,
    world: &World,
    camera: &EyeCamera,
    s: &FrameSettings,
) -> fovea_render::error::Result<Frame> {
    let gaze = camera.display.gaze(30.0, 40.0).unwrap();
    let (plan, times) = plan_frame(world, camera, s, gaze, [0.0, 0.0])?;
    render_planned(
        ctx,
        world,
        camera,
        &plan,
        FrameInputs::default(),
        times,
        &|_, _| {},
    )
    .cloned()
}

fn mock(ctx: &mut FrameContext, accept: bool, fail: bool) -> Arc<AtomicUsize> {
    let calls = Arc::new(AtomicUsize::new(0));
    ctx.set_denoiser(Box::new(Mock {
        calls: calls.clone(),
        accept,
        fail,
    }));
    calls
}

#[test]
fn the_executor_denoises_where_it_supports_the_buffers() {
    let (world, camera) = setup();
    for method in [Method::Vafr, Method::Full, Method::Weier] {
        let mut s = FrameSettings::new(method);
        s.denoise = Some(DenoiseParams::default());
        let cpu = render(&mut FrameContext::new(), &world, &camera, &s).unwrap();
        assert_eq!(cpu.stats.denoise_backend, "cpu");
        let filtered = cpu.stats.denoise.expect("denoised").filtered;
        assert!(filtered > 0, "{method}");

        // Supported: the executor runs (once per frame, every layer at once), its name is in
        // the stats, and its frame is the CPU's.
        let mut ctx = FrameContext::new();
        let calls = mock(&mut ctx, true, false);
        let f = render(&mut ctx, &world, &camera, &s).unwrap();
        assert_eq!(calls.load(Ordering::SeqCst), 1, "{method}");
        assert_eq!(f.stats.denoise_backend, "mock");
        assert_eq!(f.stats.denoise, cpu.stats.denoise);
        assert_eq!(f.color.data(), cpu.color.data(), "{method}");

        // Not supported: the CPU runs, the executor is never asked to filter.
        let mut ctx = FrameContext::new();
        let calls = mock(&mut ctx, false, false);
        let f = render(&mut ctx, &world, &camera, &s).unwrap();
        assert_eq!(calls.load(Ordering::SeqCst), 0);
        assert_eq!(f.stats.denoise_backend, "cpu");
        assert_eq!(f.color.data(), cpu.color.data());

        // The denoiser off: nothing runs, the backend is the CPU's.
        let mut off = s.clone();
        off.denoise = None;
        let mut ctx = FrameContext::new();
        let calls = mock(&mut ctx, true, false);
        let f = render(&mut ctx, &world, &camera, &off).unwrap();
        assert_eq!(calls.load(Ordering::SeqCst), 0);
        assert_eq!(f.stats.denoise_backend, "cpu");
        assert!(f.stats.denoise.is_none());
    }
}

#[test]
fn an_executor_error_names_the_stage_and_the_backend() {
    let (world, camera) = setup();
    let mut s = FrameSettings::new(Method::Vafr);
    s.denoise = Some(DenoiseParams::default());
    let mut ctx = FrameContext::new();
    let calls = mock(&mut ctx, true, true);
    let e = render(&mut ctx, &world, &camera, &s).unwrap_err();
    assert_eq!(calls.load(Ordering::SeqCst), 1);
    assert!(
        matches!(&e, RenderError::Executor { stage: "denoise", backend, .. } if backend == "mock"),
        "{e:?}"
    );
    let text = e.to_string();
    assert!(
        text.contains("denoise on the mock backend") && !text.contains('\n'),
        "{text}"
    );
}
