//! Acceptance test of gaze-contingent auto-focus (Weier et al. 2018, Sec. 3.2): a near box at
//! 0.6 m fills the left half of the view, a wall at 4 m the right half. The viewer fixates the
//! box 0.75° inside its edge while the eye tracker reports the gaze with up to 1° of error
//! (deterministic pseudo-random, 300 frames at 90 Hz on a 20 pixels-per-degree display).
//!
//! The naive estimate (the depth of the pixel under the measured gaze) jumps to the wall
//! whenever the error crosses the edge. The robust pipeline (ring pattern, clusters in
//! dioptres, hysteresis towards the accommodation filter's current focus, then the filter)
//! must keep the focus on the box in every frame. Each trajectory starts with a 1/3 s lead-in
//! fixating 2.5° inside the box (the gaze lands on the object before it drifts to the edge), so
//! the filter starts on the box; statistics cover the 300 frames after it. Run with
//! `--nocapture` for the numbers.

use fovea_core::optics::gaze_depth::{single_pixel_depth, GazeDepth};
use fovea_core::optics::{
    estimate_gaze_depth, estimate_gaze_depth_with_prior, AccommodationFilter, AccommodationParams,
    EyeModel, GazeDepthParams,
};
use fovea_core::units::{Metres, ScreenPoint};
use fovea_core::Image;

const PPD: f64 = 20.0;
const W: u32 = 800;
const H: u32 = 600;
const EDGE_X_PX: f64 = 400.0;
const NEAR_M: f64 = 0.6;
const FAR_M: f64 = 4.0;
const DT_S: f64 = 1.0 / 90.0;
const FRAMES: usize = 300;
/// Frames (1/3 s) of fixation 2° deeper inside the box before the measured trajectory.
const LEAD_IN_FRAMES: usize = 30;

fn scene() -> Image<f32> {
    let data = (0..W * H)
        .map(|i| {
            if ((i % W) as f64) < EDGE_X_PX {
                NEAR_M as f32
            } else {
                FAR_M as f32
            }
        })
        .collect();
    Image::from_vec(W, H, data).unwrap()
}

/// SplitMix64: a tiny deterministic generator, uniform in [0, 1).
struct Rng(u64);

impl Rng {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in the disc of radius `r`.
    fn in_disc(&mut self, r: f64) -> (f64, f64) {
        let (u, v) = (self.next_f64(), self.next_f64());
        let (rr, a) = (r * u.sqrt(), std::f64::consts::TAU * v);
        (rr * a.cos(), rr * a.sin())
    }
}

/// Measured gaze, lead-in first: the true PoR plus an error in the 1° disc. With
/// `correlation_s` = 0 the error is independent per frame (uniform in the disc); otherwise it
/// is a drifting bias (first-order autoregressive with that correlation time, clamped to the
/// disc).
fn gaze_trajectory(true_por: ScreenPoint, seed: u64, correlation_s: f64) -> Vec<ScreenPoint> {
    let mut rng = Rng(seed);
    let (mut bx, mut by) = (0.0, 0.0);
    (0..LEAD_IN_FRAMES + FRAMES)
        .map(|i| {
            let lead_px = if i < LEAD_IN_FRAMES { -2.0 * PPD } else { 0.0 };
            let (ex, ey) = if correlation_s > 0.0 {
                let a = (-DT_S / correlation_s).exp();
                let (nx, ny) = rng.in_disc(1.0);
                bx = a * bx + (1.0 - a * a).sqrt() * nx;
                by = a * by + (1.0 - a * a).sqrt() * ny;
                let r = bx.hypot(by);
                if r > 1.0 {
                    (bx / r, by / r)
                } else {
                    (bx, by)
                }
            } else {
                rng.in_disc(1.0)
            };
            ScreenPoint::new(true_por.x_px + lead_px + ex * PPD, true_por.y_px + ey * PPD)
        })
        .collect()
}

/// Number of frames whose value differs from the previous frame's by more than 0.1 D.
fn switches(focus_m: &[f64]) -> usize {
    focus_m
        .windows(2)
        .filter(|w| (1.0 / w[1] - 1.0 / w[0]).abs() > 0.1)
        .count()
}

/// Statistics of a focus sequence (metres) against the object at `object_m`.
#[derive(Debug)]
struct Stats {
    switches: usize,
    /// Fraction of frames within 0.1 D of the object.
    within_0p1_d: f64,
    /// Fraction of frames whose depth of field (Liu's eye, 4.49 mm pupil) contains the object.
    within_dof: f64,
    max_excursion_d: f64,
}

fn stats(focus_m: &[f64], object_m: f64) -> Stats {
    let eye = EyeModel::default();
    let target_d = 1.0 / object_m;
    let n = focus_m.len() as f64;
    let exc: Vec<f64> = focus_m.iter().map(|m| (1.0 / m - target_d).abs()).collect();
    Stats {
        switches: switches(focus_m),
        within_0p1_d: exc.iter().filter(|&&e| e <= 0.1).count() as f64 / n,
        within_dof: focus_m
            .iter()
            .filter(|&&m| {
                eye.dof_limits(Metres(m))
                    .unwrap()
                    .contains(Metres(object_m))
            })
            .count() as f64
            / n,
        max_excursion_d: exc.iter().fold(0.0, |a: f64, &b| a.max(b)),
    }
}

fn filtered(raw_m: &[f64]) -> Vec<f64> {
    let mut f = AccommodationFilter::new(AccommodationParams::default()).unwrap();
    raw_m.iter().map(|&m| f.update(m, DT_S).unwrap()).collect()
}

/// The robust pipeline: each frame's estimate uses the accommodation filter's current focus
/// as its prior (hysteresis at silhouettes), then feeds the filter. Returns (raw, filtered).
fn robust_pipeline(depth: &Image<f32>, gazes: &[ScreenPoint]) -> (Vec<f64>, Vec<f64>) {
    let params = GazeDepthParams::default();
    let mut filter = AccommodationFilter::new(AccommodationParams::default()).unwrap();
    gazes
        .iter()
        .map(|&g| {
            let prior = filter.current_m().unwrap_or(f64::NAN);
            let est: GazeDepth =
                estimate_gaze_depth_with_prior(depth, g, PPD, &params, prior).unwrap();
            (est.focus_m, filter.update(est.focus_m, DT_S).unwrap())
        })
        .unzip()
}

/// All five sequences of one trajectory, lead-in removed.
struct Case {
    crossed: usize,
    naive: Stats,
    robust_no_prior: Stats,
    robust_raw: Stats,
    naive_filtered: Stats,
    robust_filtered: Stats,
}

fn run_case(inside_deg: f64, correlation_s: f64, seed: u64) -> Case {
    let depth = scene();
    let true_por = ScreenPoint::new(EDGE_X_PX - inside_deg * PPD, H as f64 / 2.0);
    let gazes = gaze_trajectory(true_por, seed, correlation_s);
    let naive: Vec<f64> = gazes
        .iter()
        .map(|&g| single_pixel_depth(&depth, g).unwrap())
        .collect();
    let no_prior: Vec<f64> = gazes
        .iter()
        .map(|&g| {
            estimate_gaze_depth(&depth, g, PPD, &GazeDepthParams::default())
                .unwrap()
                .focus_m
        })
        .collect();
    let (robust, robust_f) = robust_pipeline(&depth, &gazes);
    let naive_f = filtered(&naive);
    let l = LEAD_IN_FRAMES;
    Case {
        crossed: gazes[l..].iter().filter(|g| g.x_px >= EDGE_X_PX).count(),
        naive: stats(&naive[l..], NEAR_M),
        robust_no_prior: stats(&no_prior[l..], NEAR_M),
        robust_raw: stats(&robust[l..], NEAR_M),
        naive_filtered: stats(&naive_f[l..], NEAR_M),
        robust_filtered: stats(&robust_f[l..], NEAR_M),
    }
}

fn print_case(name: &str, inside_deg: f64, c: &Case) {
    println!(
        "== {name}: {FRAMES} frames at 90 Hz, {PPD} ppd, box {NEAR_M} m | wall {FAR_M} m, \
         true PoR {inside_deg}° inside the edge, error ≤ 1°; measured PoR beyond the edge in \
         {} frames",
        c.crossed
    );
    for (label, s) in [
        ("naive single pixel", &c.naive),
        ("robust, no prior", &c.robust_no_prior),
        ("robust + prior (raw)", &c.robust_raw),
        ("naive → accommodation", &c.naive_filtered),
        ("robust → accommodation", &c.robust_filtered),
    ] {
        println!(
            "   {label:24}: {:3} switches, within 0.1 D {:5.1} %, box in DOF {:5.1} %, \
             max excursion {:.3} D",
            s.switches,
            100.0 * s.within_0p1_d,
            100.0 * s.within_dof,
            s.max_excursion_d
        );
    }
}

/// Runs a scenario for 20 seeds, prints the first, and asserts the robust pipeline keeps the
/// box in focus in every frame of every seed while the naive estimate jumps.
fn assert_scenario(name: &str, inside_deg: f64, correlation_s: f64) {
    let mut naive_switches = 0;
    let mut naive_filtered_worst: f64 = 1.0;
    for seed in 0..20u64 {
        let c = run_case(inside_deg, correlation_s, 0xF0CA_0000 + seed);
        if seed == 0 {
            print_case(name, inside_deg, &c);
        }
        naive_switches += c.naive.switches;
        naive_filtered_worst = naive_filtered_worst.min(c.naive_filtered.within_0p1_d);
        let r = &c.robust_filtered;
        assert_eq!(r.within_0p1_d, 1.0, "seed {seed}: {r:?}");
        assert_eq!(r.within_dof, 1.0, "seed {seed}: {r:?}");
        assert!(r.max_excursion_d < 0.1, "seed {seed}: {r:?}");
        assert_eq!(r.switches, 0, "seed {seed}: {r:?}");
        assert!(c.robust_raw.switches <= c.naive.switches, "seed {seed}");
    }
    println!(
        "   over 20 seeds: naive switches {:.1}/run; naive → accommodation worst run {:.1} % \
         within 0.1 D; robust → accommodation 100 % in every run",
        naive_switches as f64 / 20.0,
        100.0 * naive_filtered_worst
    );
    assert!(naive_switches >= 20 * 8, "{naive_switches}");
}

#[test]
fn focus_stays_on_the_box_under_independent_tracker_noise() {
    assert_scenario("independent error per frame", 0.75, 0.0);
    assert_scenario("independent error per frame", 0.5, 0.0);
}

#[test]
fn focus_stays_on_the_box_under_drifting_tracker_bias() {
    assert_scenario("drifting bias, 0.2 s correlation", 0.75, 0.2);
}

/// A bias that stays up to 0.5° past the edge for a few hundred milliseconds is the same signal
/// as a real fixation on the wall: no estimator can tell them apart, and the robust pipeline
/// sometimes follows it. Reported, with only a comparative assertion.
#[test]
fn sustained_bias_past_the_edge_is_ambiguous() {
    let (mut naive_f, mut robust_f) = (0.0, 0.0);
    let mut all_on_box = 0;
    for seed in 0..20u64 {
        let c = run_case(0.5, 0.3, 0xF0CA_0000 + seed);
        if seed == 0 {
            print_case("drifting bias, 0.3 s correlation", 0.5, &c);
        }
        naive_f += c.naive_filtered.within_0p1_d / 20.0;
        robust_f += c.robust_filtered.within_0p1_d / 20.0;
        all_on_box += usize::from(c.robust_filtered.within_0p1_d == 1.0);
    }
    println!(
        "   over 20 seeds: within 0.1 D naive → accommodation {:.1} %, robust → accommodation \
         {:.1} % (100 % in {all_on_box} of 20 runs)",
        100.0 * naive_f,
        100.0 * robust_f
    );
    assert!(robust_f > naive_f, "{robust_f} {naive_f}");
}

/// The hysteresis must not freeze the focus: a real saccade from the box to the wall 5° to the
/// right of the edge moves the focus to the wall, and back.
#[test]
fn a_real_gaze_shift_moves_the_focus() {
    let depth = scene();
    let on_box = ScreenPoint::new(EDGE_X_PX - 0.75 * PPD, H as f64 / 2.0);
    let on_wall = ScreenPoint::new(EDGE_X_PX + 5.0 * PPD, H as f64 / 2.0);
    let mut gazes = gaze_trajectory(on_box, 7, 0.0);
    let wall = gaze_trajectory(on_wall, 8, 0.0);
    let (a, b) = (LEAD_IN_FRAMES + 100, LEAD_IN_FRAMES + 200);
    gazes[a..b].copy_from_slice(&wall[a..b]);
    let (robust, focus) = robust_pipeline(&depth, &gazes);
    let reach = (a..b)
        .find(|&i| (1.0 / focus[i] - 1.0 / FAR_M).abs() <= 0.1)
        .map(|i| (i - a) as f64 * DT_S);
    let back = (b..gazes.len())
        .find(|&i| (1.0 / focus[i] - 1.0 / NEAR_M).abs() <= 0.1)
        .map(|i| (i - b) as f64 * DT_S);
    println!(
        "saccade box → wall: focus within 0.1 D of the wall after {reach:.3?} s; \
         wall → box after {back:.3?} s"
    );
    assert!(robust[a..b].iter().all(|&m| (m - FAR_M).abs() < 1e-6));
    let reach = reach.expect("focus never reached the wall");
    let back = back.expect("focus never came back to the box");
    // 1.42 D at ≤ 10 D/s takes ≥ 0.14 s; with τ = 0.25 s and the 0.1 s median ≈ 0.7 s.
    assert!((0.14..1.0).contains(&reach), "{reach}");
    assert!((0.14..1.0).contains(&back), "{back}");
    // Settled on the wall before the saccade back, within the release band.
    assert!((1.0 / focus[b - 1] - 1.0 / FAR_M).abs() <= 0.02);
}
