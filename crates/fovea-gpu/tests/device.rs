//! The device's failure modes: a one-line typed error, never a panic. The first test needs no
//! GPU; the others need an adapter (lavapipe will do) and say SKIPPED without one (a failure
//! under FOVEA_REQUIRE_GPU=1).

mod common;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{Vafr, VafrParams};
use fovea_gpu::{BackendChoice, GpuContext, GpuError, GpuMapping, GpuRequest, Resolved};

#[test]
fn no_adapter_is_a_one_line_error_that_names_the_fix() {
    // No backend that this binary was built with: no adapter can exist.
    let request = GpuRequest {
        backends: wgpu_backends_not_built(),
        ..GpuRequest::default()
    };
    if std::env::var("WGPU_BACKEND").is_ok() {
        common::shout("[fovea-gpu] SKIPPED no_adapter_…: WGPU_BACKEND overrides the request");
        return;
    }
    let e = GpuContext::new(&request).unwrap_err();
    assert!(matches!(e, GpuError::NoAdapter { .. }), "{e}");
    let text = e.to_string();
    assert!(!text.contains('\n'), "{text}");
    assert!(
        text.contains("mesa-vulkan-drivers") && text.contains("--backend cpu"),
        "{text}"
    );
    // `gpu` passes the error on; `auto` falls back to the CPU and says why.
    assert!(BackendChoice::Gpu.resolve(&request).is_err());
    let auto = BackendChoice::Auto.resolve(&request).unwrap();
    assert_eq!(auto.describe(), "CPU (auto: no GPU adapter)");
}

/// The GL backend: this crate builds wgpu without it.
fn wgpu_backends_not_built() -> fovea_gpu::device::Backends {
    fovea_gpu::device::Backends::GL
}

#[test]
fn an_adapter_too_small_is_refused_before_any_allocation() {
    let Some(ctx) = common::gpu_or_skip("an_adapter_too_small_is_refused_before_any_allocation")
    else {
        return;
    };
    let limit = ctx.limits().max_storage_buffer_binding_size;
    let request = GpuRequest {
        storage_binding_bytes: limit + 1,
        ..GpuRequest::default()
    };
    let e = GpuContext::new(&request).unwrap_err();
    let text = e.to_string();
    assert!(
        matches!(
            e,
            GpuError::AdapterTooSmall {
                limit_name: "max_storage_buffer_binding_size",
                ..
            }
        ),
        "{text}"
    );
    assert!(
        text.contains(&limit.to_string()) && !text.contains('\n'),
        "{text}"
    );
    // The same check guards an open context.
    assert!(ctx.check_storage_binding("a test buffer", limit).is_ok());
    assert!(ctx
        .check_storage_binding("a test buffer", limit + 1)
        .is_err());
}

#[test]
fn a_lost_device_is_an_error_not_a_panic() {
    let Some(ctx) = common::gpu_or_skip("a_lost_device_is_an_error_not_a_panic") else {
        return;
    };
    let d = DisplayProfile::preset("vive-pro-eye").unwrap();
    let v = Vafr::new(&d, d.centre_gaze(), VafrParams::eq3()).unwrap();
    let gpu = GpuMapping::vafr(&ctx, &v).unwrap();
    assert!(gpu.forward(&[[100.5, 200.5]]).unwrap()[0].is_some());
    ctx.device().destroy();
    let e = gpu.forward(&[[100.5, 200.5]]).unwrap_err();
    assert!(matches!(e, GpuError::DeviceLost { .. }), "{e}");
    assert!(!e.to_string().contains('\n'), "{e}");
}

#[test]
fn auto_says_which_backend_it_picked() {
    let Some(ctx) = common::gpu_or_skip("auto_says_which_backend_it_picked") else {
        return;
    };
    let auto = BackendChoice::Auto.resolve(&GpuRequest::default()).unwrap();
    common::shout(&format!(
        "[fovea-gpu] --backend auto here: {}",
        auto.describe()
    ));
    if ctx.adapter().is_software() {
        // The best adapter is a software one (lavapipe): auto takes the CPU path and says so.
        assert!(matches!(auto, Resolved::Cpu { .. }), "{}", auto.describe());
        assert!(
            auto.describe().contains("only a software GPU adapter")
                && auto.describe().contains(&ctx.adapter().name),
            "{}",
            auto.describe()
        );
        // `gpu` takes it anyway.
        let gpu = BackendChoice::Gpu.resolve(&GpuRequest::default()).unwrap();
        assert!(gpu.describe().starts_with("GPU: ") && gpu.describe().contains("CPU)"));
    } else {
        assert!(matches!(auto, Resolved::Gpu(_)), "{}", auto.describe());
        assert!(auto.describe().starts_with("GPU: "));
    }
}
