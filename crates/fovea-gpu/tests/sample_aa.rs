//! The GPU's sample-space AA (`fovea_gpu::GpuSampleAa`) against the CPU's
//! (`fovea_post::fxaa::fxaa`, `fovea_post::gaussian_aa::gaussian_3x3`), texel by texel, on rect
//! buffers (random texels, a staircase edge) and on real polar layouts (VaFR and KFR for the
//! Vive Pro Eye with an off-centre gaze: rows wrapping at the seam, columns of different
//! lengths aligned by angle), with random texels and a polar staircase that crosses the seam.
//!
//! Both sides read identical neighbours (the GPU gets `Grid::step`'s rows from the Rust side)
//! and do the same f32 operations in the same order; what may differ is the GPU compiler's
//! freedom to fuse a multiply and an add (WGSL allows it), i.e. the last bit of a sum. Bound
//! per channel: **max |GPU − CPU| ≤ 1e-5** on colours in [0, 1]. A last-bit difference in a
//! luma could also flip one of FXAA's threshold tests at an exact tie; none occurs on these
//! inputs (the test prints the worst difference and how many texels differ at all, run with
//! `--nocapture`). Measured on lavapipe (Mesa 22.3.6): bit-identical, 0 texels differ in
//! every case (VaFR 1184×2603 and KFR 800×889 buffers included).
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, FoveationMapping, MappingConfig, Method};
use fovea_core::Image;
use fovea_gpu::{GpuError, GpuSampleAa, SampleFilter};
use fovea_post::fxaa::{fxaa, FxaaParams};
use fovea_post::gaussian_aa::gaussian_3x3;
use fovea_post::grid::Grid;
use fovea_post::inverse_map::SampleBuffers;
use fovea_post::Rgb;

/// Largest per-channel difference allowed.
const MAX_DIFF: f32 = 1e-5;

/// Worst per-channel difference and the number of texels that differ at all.
fn compare(case: &str, gpu: &Image<Rgb>, cpu: &Image<Rgb>, input: &Image<Rgb>) -> f32 {
    assert_eq!((gpu.width(), gpu.height()), (cpu.width(), cpu.height()));
    let mut worst = 0.0f32;
    let (mut differ, mut changed) = (0usize, 0usize);
    for ((g, c), i) in gpu.data().iter().zip(cpu.data()).zip(input.data()) {
        let d = (0..3).map(|k| (g[k] - c[k]).abs()).fold(0.0, f32::max);
        worst = worst.max(d);
        differ += usize::from(g != c);
        changed += usize::from(c != i);
    }
    common::shout(&format!(
        "[fovea-gpu] {case}: {}x{} texels, {changed} changed by the CPU filter; GPU vs CPU worst \
         |diff| {worst:.3e}, {differ} texels differ at all",
        gpu.width(),
        gpu.height()
    ));
    assert!(
        worst <= MAX_DIFF,
        "{case}: worst difference {worst} > {MAX_DIFF}"
    );
    assert!(
        changed > 0,
        "{case}: the input is left alone, nothing was tested"
    );
    worst
}

fn random_image(w: u32, h: u32, seed: u64) -> Image<Rgb> {
    let mut state = 0x9e37_79b9_7f4a_7c15u64 ^ seed.wrapping_mul(0x2545_f491_4f6c_dd1d);
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    Image::from_vec(w, h, (0..w * h).map(|_| [next(), next(), next()]).collect()).unwrap()
}

/// A slightly slanted edge (as the CPU test's), in colour.
fn staircase(w: u32, h: u32) -> Image<Rgb> {
    let mut img = Image::new(w, h, [0.05, 0.1, 0.0]).unwrap();
    for y in 0..h {
        for x in 0..w {
            if (y as f32) < x as f32 / 8.0 + h as f32 / 4.0 {
                *img.get_mut(x, y) = [0.9, 0.8, 1.0];
            }
        }
    }
    img
}

fn both(gpu: &GpuSampleAa, case: &str, img: &Image<Rgb>, grid: &Grid) -> [f32; 2] {
    let params = FxaaParams::default();
    let (g, _) = gpu.run(img, grid, SampleFilter::Fxaa(params)).unwrap();
    let f = compare(&format!("FXAA, {case}"), &g, &fxaa(img, grid, &params), img);
    let (g, t) = gpu.run(img, grid, SampleFilter::Gaussian).unwrap();
    let s = compare(
        &format!("Gaussian, {case}"),
        &g,
        &gaussian_3x3(img, grid),
        img,
    );
    assert!(t.total_ms >= t.run_and_readback_ms);
    [f, s]
}

#[test]
fn rect_buffers_match_the_cpu() {
    let Some(ctx) = common::gpu_or_skip("rect_buffers_match_the_cpu") else {
        return;
    };
    let gpu = GpuSampleAa::new(&ctx).unwrap();
    for (case, img) in [
        ("random 97x61", random_image(97, 61, 1)),
        ("random 1x5", random_image(1, 5, 2)),
        ("staircase 64x32", staircase(64, 32)),
    ] {
        let grid = Grid::Rect {
            width: img.width(),
            height: img.height(),
        };
        both(&gpu, case, &img, &grid);
    }
    // Other FXAA settings travel too.
    let img = random_image(40, 30, 3);
    let grid = Grid::Rect {
        width: 40,
        height: 30,
    };
    let params = FxaaParams {
        edge_threshold: 0.063,
        edge_threshold_min: 0.0312,
        subpix: 1.0,
        search_steps: 3,
    };
    let (g, _) = gpu.run(&img, &grid, SampleFilter::Fxaa(params)).unwrap();
    compare(
        "FXAA (other settings), random 40x30",
        &g,
        &fxaa(&img, &grid, &params),
        &img,
    );
}

/// A polar buffer of `method` for the Vive Pro Eye with an off-centre gaze.
fn polar(method: Method) -> (Box<dyn FoveationMapping>, Grid) {
    let d = DisplayProfile::preset("vive-pro-eye").unwrap();
    let gaze = d
        .gaze(0.31 * d.width_px as f64, 0.62 * d.height_px as f64)
        .unwrap();
    let m = build(method, &d, gaze, &MappingConfig::default()).unwrap();
    let grid = Grid::polar(&m.polar_layout().unwrap());
    (m, grid)
}

/// Light and dark wedges whose boundary turns with the radius: edges in every direction,
/// across the angular seam.
fn polar_staircase(img: &Image<Rgb>, grid: &Grid) -> Image<Rgb> {
    let Grid::Polar { period, .. } = grid else {
        unreachable!()
    };
    let mut out = img.clone();
    for j in 0..img.height() {
        for i in 0..img.width() {
            let p = period.get(i as usize).copied().unwrap_or(1.0).max(1.0);
            let turn = (j as f64 + 0.5) / p + i as f64 / 200.0;
            let light = (turn * 7.0).rem_euclid(1.0) < 0.5;
            *out.get_mut(i, j) = if light {
                [0.85, 0.9, 0.7]
            } else {
                [0.02, 0.05, 0.1]
            };
        }
    }
    out
}

#[test]
fn polar_buffers_match_the_cpu() {
    let Some(ctx) = common::gpu_or_skip("polar_buffers_match_the_cpu") else {
        return;
    };
    let gpu = GpuSampleAa::new(&ctx).unwrap();
    for method in [Method::Vafr, Method::Kfr] {
        let (m, grid) = polar(method);
        let random = SampleBuffers::random(m.as_ref(), 7)
            .unwrap()
            .color
            .remove(0);
        let wedges = polar_staircase(&random, &grid);
        let name = method.name();
        both(&gpu, &format!("{name} random"), &random, &grid);
        both(&gpu, &format!("{name} wedges"), &wedges, &grid);
    }
}

#[test]
fn the_seam_is_crossed_as_on_the_cpu() {
    // The CPU test's case: an edge exactly at the seam of two columns of 8 rows.
    let Some(ctx) = common::gpu_or_skip("the_seam_is_crossed_as_on_the_cpu") else {
        return;
    };
    let gpu = GpuSampleAa::new(&ctx).unwrap();
    let mut img = Image::new(3, 8, [0.0; 3]).unwrap();
    for i in 0..2 {
        for j in 1..7 {
            *img.get_mut(i, j) = [1.0; 3];
        }
    }
    // Column 2 is empty (no rows): left as it is, never a neighbour.
    *img.get_mut(2, 3) = [0.5; 3];
    let grid = Grid::Polar {
        rows: vec![8, 8, 0],
        period: vec![8.0, 8.0, 0.0],
    };
    both(&gpu, "two columns of 8 rows", &img, &grid);
}

#[test]
fn inconsistent_grids_are_errors() {
    let Some(ctx) = common::gpu_or_skip("inconsistent_grids_are_errors") else {
        return;
    };
    let gpu = GpuSampleAa::new(&ctx).unwrap();
    let img = random_image(4, 4, 5);
    for grid in [
        Grid::Rect {
            width: 5,
            height: 4,
        },
        Grid::Polar {
            rows: vec![4, 5],
            period: vec![4.0, 5.0],
        },
        Grid::Polar {
            rows: vec![4; 5],
            period: vec![4.0; 5],
        },
    ] {
        let e = gpu.run(&img, &grid, SampleFilter::Gaussian).unwrap_err();
        assert!(matches!(e, GpuError::Input(_)), "{e}");
        assert!(!e.to_string().contains('\n'));
    }
    // An edge search the shader's loop could not finish is refused, not run.
    let endless = fovea_post::fxaa::FxaaParams {
        search_steps: u32::MAX,
        ..Default::default()
    };
    let grid = Grid::Rect {
        width: img.width(),
        height: img.height(),
    };
    let e = gpu
        .run(&img, &grid, SampleFilter::Fxaa(endless))
        .unwrap_err();
    assert!(matches!(e, GpuError::Input(_)), "{e}");
    assert!(!e.to_string().contains('\n'));
    // What a caller asks before it hands a buffer over: small grids fit, one of 40 G texels
    // does not (the CPU filters it).
    assert!(gpu.fits(&Grid::Rect {
        width: 4,
        height: 4
    }));
    assert!(!gpu.fits(&Grid::Rect {
        width: 200_000,
        height: 200_000
    }));
    let (_, grid) = polar(Method::Vafr);
    assert!(gpu.fits(&grid));
}
