//! The device's transfer counters (`fovea_gpu::traffic`, `GpuContext::traffic`) against a
//! pass whose traffic is known from its definition: the tone map of a W×H image uploads its
//! 16-byte uniform, the 3·W·H linear values and the 255 sRGB thresholds (4 bytes each),
//! creates those three buffers and its output and readback buffers (⌈3·W·H/4⌉ words each),
//! one bind group, submits once, waits once and maps and reads back the output's words.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;

use fovea_core::Image;
use fovea_gpu::{GpuToneMap, TrafficCounts};
use fovea_post::tonemap::{srgb8_thresholds, ToneCurve};

#[test]
fn a_tone_map_moves_exactly_its_buffers() {
    let Some(ctx) = common::gpu_or_skip("a_tone_map_moves_exactly_its_buffers") else {
        return;
    };
    let gpu = GpuToneMap::new(&ctx).unwrap();
    for (w, h) in [(7u32, 5u32), (64, 33)] {
        let img = Image::from_vec(w, h, vec![[0.25f32, 0.5, 1.5]; (w * h) as usize]).unwrap();
        let values = 3 * u64::from(w * h);
        assert!(values <= gpu.band_values(), "one band");
        let words = values.div_ceil(4);
        let thresholds = srgb8_thresholds().len() as u64;
        let before = ctx.traffic();
        let bytes = gpu.to_srgb8(&img, 0.0, ToneCurve::Clamp).unwrap();
        let mut moved = ctx.traffic().since(&before);
        assert_eq!(bytes.len() as u64, values);
        // The time blocked is measured, not derived: positive, then left out of the match.
        assert!(moved.blocked_ns > 0, "{moved:?}");
        moved.blocked_ns = 0;
        let uploaded = 16 + 4 * values + 4 * thresholds;
        assert_eq!(
            moved,
            TrafficCounts {
                bytes_uploaded: uploaded,
                bytes_read_back: 4 * words,
                buffers_created: 5,
                buffer_bytes_created: uploaded + 2 * 4 * words,
                bind_groups_created: 1,
                buffer_maps: 1,
                blocking_waits: 1,
                blocked_ns: 0,
                submissions: 1,
            },
            "{w}x{h}"
        );
    }
}

#[test]
fn since_is_the_difference_of_two_snapshots() {
    let a = TrafficCounts {
        bytes_uploaded: 10,
        bytes_read_back: 20,
        buffers_created: 3,
        buffer_bytes_created: 40,
        bind_groups_created: 2,
        buffer_maps: 1,
        blocking_waits: 1,
        blocked_ns: 1_000,
        submissions: 4,
    };
    let b = TrafficCounts {
        bytes_uploaded: 15,
        bytes_read_back: 20,
        buffers_created: 7,
        buffer_bytes_created: 100,
        bind_groups_created: 2,
        buffer_maps: 3,
        blocking_waits: 2,
        blocked_ns: 3_500,
        submissions: 9,
    };
    let d = b.since(&a);
    assert_eq!(
        (
            d.bytes_uploaded,
            d.bytes_read_back,
            d.buffers_created,
            d.buffer_bytes_created
        ),
        (5, 0, 4, 60)
    );
    assert_eq!(
        (
            d.bind_groups_created,
            d.buffer_maps,
            d.blocking_waits,
            d.submissions
        ),
        (0, 2, 1, 5)
    );
    assert_eq!(d.blocked_ns, 2_500);
    let names: Vec<&str> = d.named().iter().map(|&(k, _)| k).collect();
    assert_eq!(names.len(), 9);
    assert!(d.named().contains(&("blocked_ns", 2_500)), "{names:?}");
    // Snapshots in the wrong order saturate instead of wrapping.
    assert_eq!(a.since(&b).bytes_uploaded, 0);
}
