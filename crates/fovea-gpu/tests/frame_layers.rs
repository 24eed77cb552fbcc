//! The layered mappings' ray cones as the resident kernels compute them
//! (`shaders/frame_shade_layers.wgsl`: `scale(r) · c_r / (1 + (c_r r)²)` clamped to
//! [floor, 10°], with the steps of `fovea_gpu::frame::layers::spread_steps`) against the
//! CPU's `SampleFootprint::spread_rad` — the cone `trace_and_shade` gives each texel — for
//! Guenter's layers and the inset at gazes in the centre, off-centre and in a corner of the
//! Vive Pro Eye, at every 3rd texel centre of every layer: relative difference ≤ 1e-6 (the
//! CPU's cone is an f32; the kernel's own f32 arithmetic adds its rounding), except within
//! 1e-6 px of a step, where the two may take either side. No GPU needed. The time to find the steps (once per
//! eye and frame) is printed, never asserted.

use std::time::Instant;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::footprint::{SampleFootprint, MAX_SPREAD_DEG};
use fovea_core::mapping::{build, MappingConfig, Method, SamplePoint};
use fovea_gpu::frame::layers::spread_steps;

#[test]
fn layered_cones_in_closed_form_are_the_cpus() {
    let d = DisplayProfile::preset("vive-pro-eye").unwrap();
    let c_r = d.c_r();
    for method in [Method::Guenter, Method::Inset] {
        for (gx, gy) in [(720.0, 800.0), (500.0, 1000.0), (60.0, 1550.0)] {
            let gaze = d.gaze(gx, gy).unwrap();
            let m = build(method, &d, gaze, &MappingConfig::default()).unwrap();
            let footprint = SampleFootprint::new(m.as_ref(), &d, &gaze);
            let t = Instant::now();
            let r_end = d.farthest_corner_px(&gaze) + 2.0 * 4.0 + 2.0;
            let steps = spread_steps(m.as_ref(), c_r, r_end).unwrap();
            let ms = t.elapsed().as_secs_f64() * 1e3;
            eprintln!("[frame_layers] {method} gaze ({gx}, {gy}): {steps:?} in {ms:.3} ms");
            assert!(!steps.is_empty() && steps[0][0] == 0.0);
            let closed = |r: f64| {
                let scale = steps.iter().rev().find(|s| r >= s[0]).map_or(0.0, |s| s[1]);
                (scale * c_r / (1.0 + (c_r * r) * (c_r * r)))
                    .min(MAX_SPREAD_DEG.to_radians())
                    .max(footprint.floor_rad as f64)
            };
            let mut checked = 0;
            for (k, b) in m.buffers().iter().enumerate() {
                for j in (0..b.height).step_by(3) {
                    for i in (0..b.width).step_by(3) {
                        let Some(p) = m.inverse(SamplePoint {
                            layer: k as u32,
                            u: i as f64 + 0.5,
                            v: j as f64 + 0.5,
                        }) else {
                            continue;
                        };
                        let r = p.distance(gaze.point);
                        if steps.iter().any(|s| (r - s[0]).abs() < 1e-6) {
                            continue;
                        }
                        let cpu = footprint.spread_rad(m.as_ref(), &d, &gaze, i, p) as f64;
                        let gpu = closed(r);
                        assert!(
                            (gpu - cpu).abs() <= 1e-6 * cpu,
                            "{method} layer {k} texel ({i}, {j}) r {r}: {gpu} against {cpu}"
                        );
                        checked += 1;
                    }
                }
            }
            assert!(checked > 1000, "{method}: {checked}");
        }
    }
}
