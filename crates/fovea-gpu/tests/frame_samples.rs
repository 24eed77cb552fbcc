//! The resident frame's sample buffers on the device (`fovea_gpu::frame::DeviceSamples`):
//! a polar mapping's buffers go up and come back bit for bit, with exactly their bytes counted
//! each way.
//!
//! Needs a GPU adapter (lavapipe will do); without one the test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{Kfr, KfrParams};
use fovea_gpu::frame::DeviceSamples;
use fovea_post::inverse_map::SampleBuffers;

#[test]
fn sample_buffers_round_trip_bit_for_bit() {
    let Some(ctx) = common::gpu_or_skip("sample_buffers_round_trip_bit_for_bit") else {
        return;
    };
    let display = DisplayProfile::preset("vive-pro-eye").unwrap();
    let kfr = Kfr::new(
        &display,
        display.gaze(700.0, 820.0).unwrap(),
        KfrParams::default(),
    )
    .unwrap();
    let mut buffers = SampleBuffers::random(&kfr, 7).unwrap();
    buffers.depth[0].data_mut()[3] = f32::INFINITY;
    let device = DeviceSamples::for_mapping(&ctx, &kfr).unwrap();
    assert!(device.fits(&fovea_core::mapping::FoveationMapping::buffers(&kfr)));
    let texels: u64 = buffers
        .color
        .iter()
        .map(|c| u64::from(c.width() * c.height()))
        .sum();
    assert_eq!(device.texels(), texels);

    let before = ctx.traffic();
    device.upload(&ctx, &buffers).unwrap();
    let back = device.read(&ctx).unwrap();
    let moved = ctx.traffic().since(&before);
    assert_eq!(moved.bytes_uploaded, 16 * texels, "{moved:?}");
    assert_eq!(moved.bytes_read_back, 16 * texels, "{moved:?}");
    for k in 0..buffers.color.len() {
        assert_eq!(
            back.color[k].data(),
            buffers.color[k].data(),
            "layer {k} colour"
        );
        let same_depth = back.depth[k]
            .data()
            .iter()
            .zip(buffers.depth[k].data())
            .all(|(a, b)| a.to_bits() == b.to_bits());
        assert!(same_depth, "layer {k} depth");
    }
}
