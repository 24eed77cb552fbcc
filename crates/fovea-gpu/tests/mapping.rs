//! The GPU mappings against the f64 Rust ones they mirror (issue 18's must-show): forward and
//! inverse of VaFR with Eq. 3's rings (default screen coverage, the paper's fixed 60°, an
//! anisotropic and headset-capped variant) and with exact rings (the same three), KFR, LaFR and
//! visual-polar (exact inverse, a fixed 70° buffer, the paper's fit), on the Vive Pro Eye and 8K
//! presets at several gazes, agree within 0.01 px at the hard points — zero eccentricity, the
//! acuity segment joins or table steps, the foveal boundary, the buffer edges, the polar seam
//! (θ = 0/360° and θ = ±180°), the screen corners — and on a random set.
//!
//! Inputs are f32 (what the GPU gets); the reference is evaluated in f64 on the same f32
//! values. Forward errors are in buffer pixels, the angle axis compared modulo its period
//! (the seam is one line: v = 0 and v = l(e) are the same samples); inverse errors are screen
//! pixels. Whether a point has a sample (`Some`/`None`) must agree, except within 1e-3 px (or
//! buffer px) of the edge where f32 and f64 may round to opposite sides; those are counted.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;

use fovea_core::acuity::{AcuityModel, TangentialFactor};
use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::visual_polar::{eq3, rho_fovea, FOVEA_DEG};
use fovea_core::mapping::{
    BufferSize, Coverage, FoveationMapping, Kfr, KfrParams, Lafr, LafrParams, SamplePoint, Vafr,
    VafrParams, VafrRings, VisualPolar, VisualPolarInverse, VisualPolarParams,
};
use fovea_core::units::{CyclesPerDegree, Degrees, ScreenPoint};
use fovea_gpu::GpuMapping;
use rand::{Rng, SeedableRng};

/// The bound.
const TOLERANCE_PX: f64 = 0.01;
/// Where f32 and f64 may disagree on the buffer's edge.
const EDGE_BAND: f64 = 1e-3;

/// The gazes of every preset: centre, a corner, an off-centre point f32 cannot hold, a point
/// just outside the screen (trackers report those near the border).
fn gazes(d: &DisplayProfile) -> Vec<Gaze> {
    let (w, h) = (d.width_px as f64, d.height_px as f64);
    [
        (w / 2.0, h / 2.0),
        (0.0, 0.0),
        (0.3 * w + 0.123_456_7, 0.7 * h + 0.987_654_3),
        (-0.04 * w, 0.45 * h + 0.333_333_3),
    ]
    .iter()
    .map(|&(x, y)| d.gaze(x, y).unwrap())
    .collect()
}

fn f32_point(x: f64, y: f64) -> [f32; 2] {
    [x as f32, y as f32]
}

/// A polar mapping's numbers the point sets need.
struct Polar<'a> {
    mapping: &'a dyn FoveationMapping,
    gaze: ScreenPoint,
    /// Screen radii where something changes (segment joins, the buffer's edge).
    radii_px: Vec<f64>,
    /// Buffer columns where something changes.
    columns: Vec<f64>,
    /// The buffer's continuous width.
    u_max: f64,
    /// Rows per full turn at column `u` (the angle axis's period).
    period: Box<dyn Fn(f64) -> f64 + 'a>,
    /// Where the forward map's slope `du/dr` is unbounded (LaFR's periphery at the buffer's
    /// outer edge, from acos's infinite slope at −1): the forward answers for screen points
    /// farther out than this radius are measured backward instead (below).
    unbounded_slope_beyond_px: Option<f64>,
}

/// Screen points: the gaze and points within a pixel of it, every radius of interest (and
/// 1e-3 px either side) in eight directions, the seams θ = 0 (dy = 0 and ±1e-3 px around it)
/// and θ = 180°, the screen's corners and edges, and `random` uniform points over the screen
/// and a 5 % margin around it.
fn screen_points(d: &DisplayProfile, p: &Polar, random: usize, seed: u64) -> Vec<[f32; 2]> {
    let g = p.gaze;
    let mut pts = vec![f32_point(g.x_px, g.y_px)];
    for (dx, dy) in [
        (1e-3, 0.0),
        (0.0, -1e-2),
        (0.3, 0.4),
        (-0.7, 0.2),
        (1.0, 0.0),
        (0.0, 1.5),
    ] {
        pts.push(f32_point(g.x_px + dx, g.y_px + dy));
    }
    for &r in &p.radii_px {
        for r in [r - EDGE_BAND, r, r + EDGE_BAND] {
            for k in 0..8 {
                let a = k as f64 * std::f64::consts::FRAC_PI_4 + 0.1;
                pts.push(f32_point(g.x_px + r * a.cos(), g.y_px + r * a.sin()));
            }
        }
    }
    // The seams at many radii: exactly on the +x axis (θ = 0), just above and below it, and on
    // the −x axis (θ = 180°, atan2's ±π).
    for k in 1..40 {
        let r = k as f64 * 0.025 * p.radii_px.last().copied().unwrap_or(1000.0);
        let y = g.y_px as f32;
        for (sx, dy) in [
            (1.0, 0.0),
            (1.0, 1e-3),
            (1.0, -1e-3),
            (-1.0, 0.0),
            (-1.0, 1e-3),
            (-1.0, -1e-3),
        ] {
            pts.push([(g.x_px + sx * r) as f32, y + dy as f32]);
        }
    }
    let (w, h) = (d.width_px as f64, d.height_px as f64);
    for (x, y) in [
        (0.0, 0.0),
        (w, 0.0),
        (0.0, h),
        (w, h),
        (0.5, 0.5),
        (w - 0.5, h - 0.5),
        (w / 2.0, 0.0),
        (0.0, h / 2.0),
    ] {
        pts.push(f32_point(x, y));
    }
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    for _ in 0..random {
        let x = rng.random_range(-0.05 * w..1.05 * w);
        let y = rng.random_range(-0.05 * h..1.05 * h);
        pts.push(f32_point(x, y));
    }
    pts
}

/// Buffer points: column 0, every column of interest (and 1e-3 either side), the last
/// texel column's centre, each at rows 0, the seam's far side v = period, half a turn, just
/// past the period; then texel centres of shaded texels and continuous random points.
fn buffer_points(p: &Polar, random: usize, seed: u64) -> Vec<[f32; 2]> {
    let mut pts = vec![[0.0, 0.0], [0.0, 1.0], [1e-3, 0.0]];
    let b = p.mapping.buffers()[0];
    let mut cols: Vec<f64> = vec![1e-3, 0.5, p.u_max, (b.width as f64 - 0.5).min(p.u_max)];
    for &c in &p.columns {
        cols.extend([c - EDGE_BAND, c, c + EDGE_BAND]);
    }
    for u in cols {
        let period = (p.period)(u);
        for v in [
            0.0,
            0.5,
            period / 2.0,
            period - 0.5,
            period,
            period + EDGE_BAND,
            period + 0.5,
        ] {
            pts.push([u as f32, v as f32]);
        }
    }
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    for _ in 0..random {
        let i = rng.random_range(0..b.width);
        let j = rng.random_range(0..b.height);
        if p.mapping.is_shaded(0, i, j) {
            pts.push([i as f32 + 0.5, j as f32 + 0.5]);
        }
        let u = rng.random_range(0.0..p.u_max * 1.02);
        let v = rng.random_range(0.0..b.height as f64 * 1.02);
        pts.push([u as f32, v as f32]);
    }
    pts
}

/// Largest errors of one comparison.
#[derive(Default, Debug)]
struct Tally {
    compared: usize,
    max_err: f64,
    worst: String,
    edge_disagreements: usize,
    /// Forward answers measured backward (see [`Polar::unbounded_slope_beyond_px`]), and the
    /// largest such error, screen pixels.
    backward: usize,
    max_backward_px: f64,
}

fn compare_forward(p: &Polar, gpu: &GpuMapping, pts: &[[f32; 2]], label: &str) -> Tally {
    let got = gpu.forward(pts).unwrap();
    let mut t = Tally::default();
    for (q, g) in pts.iter().zip(got) {
        let s = ScreenPoint::new(q[0] as f64, q[1] as f64);
        let want = p.mapping.forward(s);
        match (want, g) {
            (Some(w), Some(g)) => {
                let du = (g[0] as f64 - w.u).abs();
                let period = (p.period)(w.u);
                let mut dv = g[1] as f64 - w.v;
                if period > 0.0 {
                    dv -= period * (dv / period).round();
                }
                let mut err = du.max(dv.abs());
                t.compared += 1;
                // Where du/dr is unbounded an f32 radius's rounding (~1e-4 px) moves u by more
                // than the bound, so the answer is judged by its backward error: how far from
                // the point is the point the f64 mapping sends to the GPU's (u, v)? Within the
                // bound, the GPU answered for a point within 0.01 px of the one asked.
                let beyond = p
                    .unbounded_slope_beyond_px
                    .is_some_and(|r0| s.distance(p.gaze) > r0);
                if beyond {
                    // (u as f32 may round past the buffer's f64 width.)
                    let u = (g[0] as f64).min(p.u_max);
                    let back = p
                        .mapping
                        .inverse(SamplePoint::new(u, g[1] as f64))
                        .map_or(f64::INFINITY, |b| b.distance(s));
                    t.backward += 1;
                    t.max_backward_px = t.max_backward_px.max(back);
                    err = back;
                }
                if err > t.max_err {
                    t.max_err = err;
                    t.worst = format!(
                        "({}, {}) → CPU ({:.5}, {:.5}) GPU ({:.5}, {:.5})",
                        q[0], q[1], w.u, w.v, g[0], g[1]
                    );
                }
            }
            (None, None) => {}
            (w, g) => {
                let r = s.distance(p.gaze);
                let edge = p.radii_px.last().copied().unwrap();
                assert!(
                    (r - edge).abs() < EDGE_BAND,
                    "{label}: forward({}, {}) at r = {r} (edge {edge}): CPU {w:?}, GPU {g:?}",
                    q[0],
                    q[1]
                );
                t.edge_disagreements += 1;
            }
        }
    }
    t
}

fn compare_inverse(p: &Polar, gpu: &GpuMapping, pts: &[[f32; 2]], label: &str) -> Tally {
    let got = gpu.inverse(pts).unwrap();
    let mut t = Tally::default();
    for (q, g) in pts.iter().zip(got) {
        let s = SamplePoint::new(q[0] as f64, q[1] as f64);
        let want = p.mapping.inverse(s);
        match (want, g) {
            (Some(w), Some(g)) => {
                let err = w.distance(ScreenPoint::new(g[0] as f64, g[1] as f64));
                t.compared += 1;
                if err > t.max_err {
                    t.max_err = err;
                    t.worst = format!(
                        "({}, {}) → CPU ({:.5}, {:.5}) GPU ({:.5}, {:.5})",
                        q[0], q[1], w.x_px, w.y_px, g[0], g[1]
                    );
                }
            }
            (None, None) => {}
            (w, g) => {
                let period = (p.period)(s.u);
                let near = (s.u - p.u_max).abs() < EDGE_BAND || (s.v - period).abs() < EDGE_BAND;
                assert!(
                    near,
                    "{label}: inverse({}, {}) (u_max {}, period {period}): CPU {w:?}, GPU {g:?}",
                    q[0], q[1], p.u_max
                );
                t.edge_disagreements += 1;
            }
        }
    }
    t
}

/// Runs both directions, prints the numbers, checks the bound; returns the worst errors.
fn check(p: &Polar, gpu: &GpuMapping, d: &DisplayProfile, label: &str, seed: u64) -> (f64, f64) {
    let fwd_pts = screen_points(d, p, 4000, seed);
    let inv_pts = buffer_points(p, 4000, seed + 1);
    let f = compare_forward(p, gpu, &fwd_pts, label);
    let i = compare_inverse(p, gpu, &inv_pts, label);
    common::shout(&format!(
        "[fovea-gpu] {label}: forward {} pts, max {:.2e} buffer px ({} measured backward, max \
         {:.2e} px); inverse {} pts, max {:.2e} px; edge disagreements {}/{}",
        f.compared,
        f.max_err,
        f.backward,
        f.max_backward_px,
        i.compared,
        i.max_err,
        f.edge_disagreements,
        i.edge_disagreements
    ));
    // Nothing vacuous: a good share of the points have samples on both sides.
    assert!(
        f.compared > fwd_pts.len() / 4,
        "{label}: forward compared only {}",
        f.compared
    );
    assert!(
        i.compared > inv_pts.len() / 4,
        "{label}: inverse compared only {}",
        i.compared
    );
    assert!(
        f.max_err <= TOLERANCE_PX,
        "{label}: forward off by {:.4} buffer px at {}",
        f.max_err,
        f.worst
    );
    assert!(
        i.max_err <= TOLERANCE_PX,
        "{label}: inverse off by {:.4} px at {}",
        i.max_err,
        i.worst
    );
    (f.max_err, i.max_err)
}

fn vafr_polar(v: &Vafr) -> Polar<'_> {
    let acuity = &v.params().acuity;
    let e_max = v.max_eccentricity_deg();
    let joins: Vec<f64> = acuity
        .pivots()
        .iter()
        .map(|p| p.eccentricity_deg)
        .filter(|&e| e > 0.0 && e < e_max)
        .collect();
    let mut radii_px: Vec<f64> = joins
        .iter()
        .map(|e| e.to_radians().tan() / v.c_r())
        .collect();
    radii_px.push(v.max_radius_px());
    let mut columns: Vec<f64> = joins.iter().map(|&e| acuity.u_of_e(e)).collect();
    columns.push(v.u_max());
    Polar {
        mapping: v,
        gaze: v.gaze(),
        radii_px,
        columns,
        u_max: v.u_max(),
        period: Box::new(move |u| v.shading_height(acuity.e_of_u(u))),
        unbounded_slope_beyond_px: None,
    }
}

/// Which joins of a table of `n` steps are hard points: the first 40 (around the pole, where
/// the profile bends most) and every 37th after.
fn sampled_joins(n: usize) -> impl Iterator<Item = usize> {
    (1..n).filter(|&k| k <= 40 || k % 37 == 0)
}

/// VaFR's exact rings: the table's steps (radius `k·step`, column `u_k`) are the joins.
fn vafr_exact_polar(v: &Vafr) -> Polar<'_> {
    let t = v.ring_table().expect("exact rings");
    let (step, r_max, u_max) = (t.step_px(), t.r_max_px(), v.u_max());
    let joins: Vec<usize> = sampled_joins(t.u().len())
        .filter(|&k| (k as f64) * step < r_max)
        .collect();
    let mut radii_px: Vec<f64> = joins.iter().map(|&k| k as f64 * step).collect();
    radii_px.push(r_max);
    let mut columns: Vec<f64> = joins.iter().map(|&k| t.u()[k]).collect();
    columns.push(u_max);
    Polar {
        mapping: v,
        gaze: v.gaze(),
        radii_px,
        columns,
        u_max,
        period: Box::new(move |u| v.period_at_u(u.clamp(0.0, u_max))),
        unbounded_slope_beyond_px: None,
    }
}

/// Visual-polar: the foveal boundary (and, with the paper's fit, where the fit is flat: from
/// α_F to Eq. 3(ρ_F) and from Eq. 3(1) to 80°) as radii and columns, and the uploaded table's
/// joins.
fn visual_polar_polar(m: &VisualPolar) -> Polar<'_> {
    let b = m.buffers()[0];
    let (w, h) = (b.width as f64, b.height as f64);
    let r_of = |alpha: f64| alpha.to_radians().tan() / m.c_r();
    let mut radii_px = vec![1.0, r_of(FOVEA_DEG)];
    if m.params().inverse == VisualPolarInverse::PaperFit {
        radii_px.extend([r_of(eq3(rho_fovea())), r_of(eq3(1.0))]);
    }
    let table = fovea_gpu::mapping::visual_polar::table(m).unwrap();
    radii_px.extend(
        sampled_joins(table.segments.len())
            .map(|k| table.segments[k].r[0] as f64 + table.segments[k].r[1] as f64),
    );
    let r_max = r_of(m.max_eccentricity_deg());
    radii_px.retain(|&r| r < r_max);
    radii_px.sort_by(f64::total_cmp);
    let g = m.gaze();
    let mut columns: Vec<f64> = radii_px
        .iter()
        .map(|&r| m.forward(ScreenPoint::new(g.x_px + r, g.y_px)).unwrap().u)
        .collect();
    columns.push(w);
    radii_px.push(r_max);
    Polar {
        mapping: m,
        gaze: g,
        radii_px,
        columns,
        u_max: w,
        period: Box::new(move |_| h),
        unbounded_slope_beyond_px: None,
    }
}

fn kfr_polar(k: &Kfr) -> Polar<'_> {
    let g = k.geometry();
    Polar {
        mapping: k,
        gaze: g.gaze,
        radii_px: vec![1.0, g.max_radius_px],
        columns: vec![g.width],
        u_max: g.width,
        period: Box::new(move |_| g.height),
        unbounded_slope_beyond_px: None,
    }
}

/// LaFR's hard points besides KFR's: the foveal boundary `Z_ef` (where the kernel changes
/// form) as a radius and as a column.
fn lafr_polar(m: &Lafr) -> Polar<'_> {
    let g = m.geometry();
    let c = m.kernel_constants();
    Polar {
        mapping: m,
        gaze: g.gaze,
        radii_px: vec![1.0, (c.z_ef * g.ln_l).exp(), g.max_radius_px],
        columns: vec![c.u_ef * g.width, g.width],
        u_max: g.width,
        period: Box::new(move |_| g.height),
        // 1 − U ∝ √(1 − z) within the outermost 1 % of ln r.
        unbounded_slope_beyond_px: Some((0.99 * g.ln_l).exp()),
    }
}

fn vafr_variants(d: &DisplayProfile) -> Vec<(&'static str, VafrParams)> {
    vec![
        ("vafr", VafrParams::eq3()),
        ("vafr-paper-60deg", VafrParams::paper()),
        (
            "vafr-capped-anisotropic",
            VafrParams {
                acuity: AcuityModel::vafr_default()
                    .headset_capped(CyclesPerDegree(d.nyquist_cpd()))
                    .unwrap(),
                tangential: TangentialFactor::radial_twice_at_30(),
                max_eccentricity: Coverage::Fixed(Degrees(75.0)),
                rings: VafrRings::Eq3,
            },
        ),
    ]
}

/// Checks `variants` variants of a mapping on the Vive Pro Eye and 8K presets at every gaze of
/// [`gazes`]: `one(display, preset, gaze, variant, seed)` builds variant `variant` there and
/// returns [`check`]'s worst errors (the seed is `seed0 + 100 · gaze index + runs so far`);
/// prints the worst over all of them under `name`.
fn check_presets_and_gazes(
    name: &str,
    seed0: u64,
    variants: usize,
    mut one: impl FnMut(&DisplayProfile, &str, Gaze, usize, u64) -> (f64, f64),
) {
    let mut worst = (0.0f64, 0.0f64);
    let mut runs = 0;
    for preset in ["vive-pro-eye", "8k"] {
        let d = DisplayProfile::preset(preset).unwrap();
        for (k, g) in gazes(&d).into_iter().enumerate() {
            for v in 0..variants {
                let (f, i) = one(&d, preset, g, v, seed0 + 100 * k as u64 + runs);
                worst = (worst.0.max(f), worst.1.max(i));
                runs += 1;
            }
        }
    }
    common::shout(&format!(
        "[fovea-gpu] {name} over {runs} mappings: forward max {:.2e} buffer px, inverse max {:.2e} px (bound {TOLERANCE_PX})",
        worst.0, worst.1
    ));
}

/// The label of one checked mapping: what it is, the preset and the gaze.
fn label(what: &str, preset: &str, g: Gaze) -> String {
    format!(
        "{what} {preset} gaze ({:.3}, {:.3})",
        g.point.x_px, g.point.y_px
    )
}

#[test]
fn vafr_on_the_gpu_equals_the_rust_mapping() {
    let Some(ctx) = common::gpu_or_skip("vafr_on_the_gpu_equals_the_rust_mapping") else {
        return;
    };
    check_presets_and_gazes("VaFR", 0, 3, |d, preset, g, v, seed| {
        let (name, params) = vafr_variants(d).swap_remove(v);
        let m = Vafr::new(d, g, params).unwrap();
        let gpu = GpuMapping::vafr(&ctx, &m).unwrap();
        let polar = vafr_polar(&m);
        check(&polar, &gpu, d, &label(name, preset, g), seed)
    });
}

/// VaFR with exact rings (the default): the screen-covering default, the paper's fixed 60°,
/// and headset-capped pivots with the anisotropic Δ.
fn vafr_exact_variants(d: &DisplayProfile) -> Vec<(&'static str, VafrParams)> {
    vec![
        ("vafr-exact", VafrParams::default()),
        (
            "vafr-exact-60deg",
            VafrParams {
                max_eccentricity: Coverage::Fixed(Degrees(60.0)),
                ..VafrParams::default()
            },
        ),
        (
            "vafr-exact-capped-anisotropic",
            VafrParams {
                acuity: AcuityModel::vafr_default()
                    .headset_capped(CyclesPerDegree(d.nyquist_cpd()))
                    .unwrap(),
                tangential: TangentialFactor::radial_twice_at_30(),
                ..VafrParams::default()
            },
        ),
    ]
}

#[test]
fn vafr_exact_rings_on_the_gpu_equal_the_rust_mapping() {
    let Some(ctx) = common::gpu_or_skip("vafr_exact_rings_on_the_gpu_equal_the_rust_mapping")
    else {
        return;
    };
    check_presets_and_gazes("VaFR exact rings", 19, 3, |d, preset, g, v, seed| {
        let (name, params) = vafr_exact_variants(d).swap_remove(v);
        let m = Vafr::new(d, g, params).unwrap();
        assert_eq!(m.rings(), VafrRings::Exact);
        let gpu = GpuMapping::vafr(&ctx, &m).unwrap();
        let polar = vafr_exact_polar(&m);
        check(&polar, &gpu, d, &label(name, preset, g), seed)
    });
}

#[test]
fn visual_polar_on_the_gpu_equals_the_rust_mapping() {
    let Some(ctx) = common::gpu_or_skip("visual_polar_on_the_gpu_equals_the_rust_mapping") else {
        return;
    };
    // The exact inverse covering the screen (Liu's buffer of the display's size), the exact
    // inverse at a fixed 70° in a 900×1800 buffer, the paper's Eq. 3 fit (80°).
    let variants = [
        ("visual-polar", VisualPolarParams::default()),
        (
            "visual-polar-70deg-900x1800",
            VisualPolarParams {
                buffer: Some(BufferSize {
                    width: 900,
                    height: 1800,
                }),
                max_eccentricity: Coverage::Fixed(Degrees(70.0)),
                inverse: VisualPolarInverse::Exact,
            },
        ),
        (
            "visual-polar-paper-fit",
            VisualPolarParams {
                inverse: VisualPolarInverse::PaperFit,
                ..VisualPolarParams::default()
            },
        ),
    ];
    check_presets_and_gazes(
        "visual-polar",
        23,
        variants.len(),
        |d, preset, g, v, seed| {
            let (name, params) = variants[v];
            let m = VisualPolar::new(d, g, params).unwrap();
            let gpu = GpuMapping::visual_polar(&ctx, &m).unwrap();
            let polar = visual_polar_polar(&m);
            check(&polar, &gpu, d, &label(name, preset, g), seed)
        },
    );
}

#[test]
fn kfr_on_the_gpu_equals_the_rust_mapping() {
    let Some(ctx) = common::gpu_or_skip("kfr_on_the_gpu_equals_the_rust_mapping") else {
        return;
    };
    let variants = [
        KfrParams::default(),
        KfrParams {
            delta: 2.2,
            alpha: 2.5,
        },
    ];
    check_presets_and_gazes("KFR", 7, variants.len(), |d, preset, g, v, seed| {
        let params = variants[v];
        let m = Kfr::new(d, g, params).unwrap();
        let gpu = GpuMapping::kfr(&ctx, &m).unwrap();
        let what = format!("kfr δ={} α={}", params.delta, params.alpha);
        let polar = kfr_polar(&m);
        check(&polar, &gpu, d, &label(&what, preset, g), seed)
    });
}

#[test]
fn lafr_on_the_gpu_equals_the_rust_mapping() {
    let Some(ctx) = common::gpu_or_skip("lafr_on_the_gpu_equals_the_rust_mapping") else {
        return;
    };
    // The paper's LaFR and the retinal tuning (VaFR Sec. 4.5).
    let variants = [
        LafrParams::default(),
        LafrParams {
            delta: 2.2,
            alpha: 0.78,
            beta: 0.9,
            ..LafrParams::default()
        },
    ];
    check_presets_and_gazes("LaFR", 13, variants.len(), |d, preset, g, v, seed| {
        let params = variants[v];
        let m = Lafr::new(d, g, params).unwrap();
        let gpu = GpuMapping::lafr(&ctx, &m).unwrap();
        let what = format!(
            "lafr δ={} α={} β={}",
            params.delta, params.alpha, params.beta
        );
        let polar = lafr_polar(&m);
        check(&polar, &gpu, d, &label(&what, preset, g), seed)
    });
}

#[test]
fn non_finite_and_empty_inputs_have_no_sample() {
    let Some(ctx) = common::gpu_or_skip("non_finite_and_empty_inputs_have_no_sample") else {
        return;
    };
    let d = DisplayProfile::preset("vive-pro-eye").unwrap();
    let v = Vafr::new(&d, d.centre_gaze(), VafrParams::eq3()).unwrap();
    let gpu = GpuMapping::vafr(&ctx, &v).unwrap();
    assert!(gpu.forward(&[]).unwrap().is_empty());
    let got = gpu
        .forward(&[[f32::NAN, 3.0], [f32::INFINITY, 0.0], [720.0, 800.0]])
        .unwrap();
    assert_eq!(got[0], None);
    assert_eq!(got[1], None);
    assert_eq!(
        got[2],
        Some([0.0, 0.0]),
        "the gaze maps to the buffer's origin"
    );
    let back = gpu
        .inverse(&[[0.0, 0.0], [f32::NAN, 1.0], [-1.0, 0.0]])
        .unwrap();
    assert_eq!(back, vec![Some([720.0, 800.0]), None, None]);
    // The table mappings likewise: the gaze and back, NaN, left of column 0; at u = 0 the exact
    // rings have only v = 0 (the pole), visual-polar every row of the first column.
    let exact = Vafr::new(&d, d.centre_gaze(), VafrParams::default()).unwrap();
    let vp = VisualPolar::new(&d, d.centre_gaze(), VisualPolarParams::default()).unwrap();
    for (gpu, v_at_pole) in [
        (GpuMapping::vafr(&ctx, &exact).unwrap(), None),
        (
            GpuMapping::visual_polar(&ctx, &vp).unwrap(),
            Some([720.0, 800.0]),
        ),
    ] {
        assert!(gpu.forward(&[]).unwrap().is_empty());
        let got = gpu.forward(&[[f32::NAN, 3.0], [720.0, 800.0]]).unwrap();
        assert_eq!(got, vec![None, Some([0.0, 0.0])]);
        let back = gpu
            .inverse(&[[0.0, 0.0], [f32::INFINITY, 1.0], [-1.0, 0.0], [0.0, 5.0]])
            .unwrap();
        assert_eq!(back, vec![Some([720.0, 800.0]), None, None, v_at_pole]);
    }
}
