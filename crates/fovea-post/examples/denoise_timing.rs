//! Times the sample-space denoiser (`fovea_post::denoise`) on VaFR's polar buffer (or full
//! resolution's screen) at several displays, on a synthetic frame: a few planes at different
//! depths and orientations, a textured albedo, and noisy light (a sky term of 4 binary rays).
//! Best of five runs in CPU time (the process's threads' run time, from /proc: the machine may be shared), plus the split between the set-up passes (roles, gradient, variance,
//! firefly clamp and the remodulation: `iterations = 1` less one pass) and the à-trous passes.
//! Run single-threaded for CPU time per texel:
//! `RAYON_NUM_THREADS=1 cargo run --release -p fovea-post --example denoise_timing [-- vive-pro-eye,8k [vafr|full]]`.

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, MappingConfig, Method};
use fovea_core::units::Degrees;
use fovea_core::Image;
use fovea_post::denoise::{denoise, DenoiseParams, DenoiseScratch};
use fovea_post::grid::Grid;
use fovea_post::Rgb;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let list = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "vive-pro-eye,8k".into());
    let method = std::env::args()
        .nth(2)
        .map(|m| Method::parse(&m))
        .transpose()?
        .unwrap_or(Method::Vafr);
    for name in list.split(',') {
        // A preset, or `WxH` (a flat display, 90° vertically).
        let d = match name
            .split_once('x')
            .map(|(w, h)| (w.parse::<u32>(), h.parse::<u32>()))
        {
            Some((Ok(w), Ok(h))) => DisplayProfile::with_vertical_fov(name, w, h, Degrees(90.0))?,
            _ => DisplayProfile::preset(name)?,
        };
        let m = build(method, &d, d.centre_gaze(), &MappingConfig::default())?;
        let b = &m.buffers()[0];
        let (w, h) = (b.width, b.height);
        let grid = Grid::of_layer(m.polar_layout().as_ref(), w, h);
        let n = (w * h) as usize;
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed >> 12;
            seed ^= seed << 25;
            seed ^= seed >> 27;
            ((seed.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32) / (1u64 << 24) as f32
        };
        // Four surfaces in bands of columns/rows: depth, normal.
        let surface = |i: u32, j: u32| -> (f32, [f32; 3]) {
            match (i / 97 + j / 211) % 4 {
                0 => (2.0 + 0.001 * i as f32, [0.0, 0.0, 1.0]),
                1 => (3.5 + 0.002 * j as f32, [0.0, 0.6, 0.8]),
                2 => (1.2, [0.8, 0.0, 0.6]),
                _ => (6.0 + 0.0005 * (i + j) as f32, [0.0, 1.0, 0.0]),
            }
        };
        let mut depth = Image::new(w, h, f32::INFINITY)?;
        let mut normal = Image::new(w, h, [0.0f32; 3])?;
        let mut albedo = Image::new(w, h, [0.5f32; 3])?;
        let mut color = Image::new(w, h, [0.0f32; 3])?;
        let mut noisy = Image::new(w, h, [0.0f32; 3])?;
        for k in 0..n {
            let (i, j) = ((k % w as usize) as u32, (k / w as usize) as u32);
            if !grid.valid(i, j) || (i * 7 + j * 13) % 53 == 0 {
                continue; // sky, or outside the polar buffer
            }
            let (z, nv) = surface(i, j);
            let a: Rgb = [0.1 + 0.8 * (((i * 7 + j * 3) % 11) as f32 / 10.0), 0.5, 0.3];
            let hits = (0..4).filter(|_| next() < 0.4).count() as f32 / 4.0;
            let sky: Rgb = [hits * 0.8, hits * 0.9, hits];
            let exact = if (i / 40 + j / 40) % 2 == 0 { 2.0 } else { 0.1 };
            *depth.get_mut(i, j) = z;
            *normal.get_mut(i, j) = nv;
            *albedo.get_mut(i, j) = a;
            let mc: Rgb = std::array::from_fn(|c| sky[c] * a[c]);
            *noisy.get_mut(i, j) = mc;
            *color.get_mut(i, j) = std::array::from_fn(|c| mc[c] + exact * a[c]);
        }
        let mut scratch = DenoiseScratch::default();
        let mut time = |iterations: u32| -> Result<f64, Box<dyn std::error::Error>> {
            let p = DenoiseParams {
                iterations,
                ..DenoiseParams::default()
            };
            let mut best = f64::INFINITY;
            for _ in 0..5 {
                let mut c = color.clone();
                let t = cpu_ms();
                denoise(
                    &mut c,
                    &depth,
                    &albedo,
                    &normal,
                    Some(&noisy),
                    &grid,
                    &p,
                    &mut scratch,
                )?;
                best = best.min(cpu_ms() - t);
                std::hint::black_box(c);
            }
            Ok(best)
        };
        let (one, two, four) = (time(1)?, time(2)?, time(4)?);
        let pass = two - one;
        println!(
            "{method} {name}: buffer {w}x{h} ({:.2} M texels): denoise 3x3 x4 {four:.1} ms \
             ({:.1} ns/texel); set-up {:.1} ms, one pass {pass:.1} ms (x1 {one:.1}, x2 {two:.1})",
            n as f64 / 1e6,
            four * 1e6 / n as f64,
            one - pass,
        );
    }
    Ok(())
}

/// CPU time of this process (all threads, nanosecond clock), milliseconds: the sum of
/// `/proc/self/task/*/schedstat`'s run times (Linux; 0 elsewhere).
fn cpu_ms() -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .sum::<f64>()
        / 1e6
}
