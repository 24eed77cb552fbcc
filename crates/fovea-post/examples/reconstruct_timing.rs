//! Times the reconstruct stage (inverse mapping to the screen) of VaFR at several display
//! resolutions on a synthetic sample buffer, best of five runs:
//! `cargo run --release -p fovea-post --example reconstruct_timing [-- 2k,8k,retinal]`.

use std::time::Instant;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, MappingConfig, Method};
use fovea_core::Image;
use fovea_post::inverse_map::{reconstruct, SampleBuffers};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let list = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "2k,8k,retinal".into());
    let method = std::env::args()
        .nth(2)
        .map(|m| Method::parse(&m))
        .transpose()?
        .unwrap_or(Method::Vafr);
    for name in list.split(',') {
        let d = DisplayProfile::preset(name)?;
        let m = build(method, &d, d.centre_gaze(), &MappingConfig::default())?;
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let mut color = Vec::new();
            let mut depth = Vec::new();
            for b in m.buffers() {
                let mut c = Image::new(b.width, b.height, [0.0f32; 3])?;
                for (k, v) in c.data_mut().iter_mut().enumerate() {
                    let s = ((k * 2_654_435_761) % 1000) as f32 / 1000.0;
                    *v = [s, 1.0 - s, 0.5 * s];
                }
                color.push(c);
                depth.push(Image::new(b.width, b.height, 1.0f32)?);
            }
            let t = Instant::now();
            let out = reconstruct(m.as_ref(), &d, SampleBuffers { color, depth })?;
            best = best.min(t.elapsed().as_secs_f64() * 1e3);
            std::hint::black_box(out);
        }
        println!(
            "{method} {name} {}x{}: reconstruct {best:.1} ms ({:.2} ns/pixel)",
            d.width_px,
            d.height_px,
            best * 1e6 / d.pixel_count() as f64
        );
    }
    Ok(())
}
