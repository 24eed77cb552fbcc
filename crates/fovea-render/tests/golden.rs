//! Golden images: small frames of the built-in scene through every method (the sample-space
//! denoiser off, as `FrameSettings::new` has it, but in one VaFR case), a few depth-of-field
//! filters, Liu's hybrid, peripheral contrast, path tracing, binocular reprojection (Rep) and
//! temporal accumulation after several frames, compared with images stored in
//! `tests/golden/` (16-bit PNG of the tone-mapped, sRGB-encoded colour, the encoding of
//! `fovea render`'s PNGs with 256× the precision).
//!
//! Every other oracle of the test suite is computed at test time, so a change that moves a
//! method and its reference together (the BRDF, the BVH, texture LOD) passes them unseen; these
//! images pin what the renderer produced when they were captured.
//!
//! **Metric.** Per image, PSNR over the three encoded channels (peak 1) and the largest code
//! difference (of 65,535). An image passes when it is bit-identical or its PSNR reaches its
//! case's tolerance (60 dB unless a case says otherwise: a 1 % change of the shading scores
//! about 55 dB, see `a_one_percent_shading_change_fails`).
//!
//! **On mismatch** the actual image and an amplified difference image (|Δ| × 64, 8-bit) are
//! written under `target/tmp/golden/` and their paths printed.
//!
//! **Regenerating on purpose** (and saying why in the commit):
//! `FOVEA_GOLDEN=update cargo test -p fovea-render --test golden` rewrites every stored image.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_core::Image;
use fovea_post::contrast::PeripheralContrast;
use fovea_post::dof::FilterKind;
use fovea_post::Rgb;
use fovea_render::bvh::Backend;
use fovea_render::camera::{Eye, EyeCamera, HmdRig};
use fovea_render::dof::{DofSettings, FocusMode};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::{render_frame, render_frame_temporal, FrameSettings};
use fovea_render::scene::{builtin, Light};
use fovea_render::shade::ShadingMode;
use fovea_render::stereo::{fixating_eyes, render_stereo, StereoMode};
use fovea_render::temporal::{TemporalAccumulator, TemporalSettings};
use fovea_render::world::World;

/// Frame size of every golden image (the Vive Pro Eye's field of view, 1/9 of its pixels).
const WIDTH: u32 = 160;
const HEIGHT: u32 = 180;
/// Default tolerance: PSNR of the encoded colour, dB.
const DEFAULT_MIN_PSNR_DB: f64 = 60.0;
/// Frames of a temporal case before the one compared.
const TEMPORAL_FRAMES: usize = 6;

fn display() -> DisplayProfile {
    DisplayProfile::new("golden", WIDTH, HEIGHT, Degrees(100.0), Degrees(110.0)).unwrap()
}

/// The built-in scene as `fovea render` sets it up: its first camera (centre eye of a rig with
/// a 63 mm IPD) and its own lights.
struct Setup {
    world: World,
    rig: HmdRig,
    camera: EyeCamera,
}

fn setup_with_light_scale(scale: f32) -> Setup {
    let scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    let mut world = World::new(scene, Backend::Obvhs).unwrap();
    for l in &mut world.lights {
        match l {
            Light::Point { intensity, .. } | Light::Spot { intensity, .. } => *intensity *= scale,
            Light::Directional { irradiance, .. } => *irradiance *= scale,
        }
    }
    world.scene.environment *= scale;
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, 0.063).unwrap();
    let camera = rig.eye(Eye::Centre, &display()).unwrap();
    Setup { world, rig, camera }
}

fn setup() -> &'static Setup {
    static S: OnceLock<Setup> = OnceLock::new();
    S.get_or_init(|| setup_with_light_scale(1.0))
}

fn gaze(x: f64, y: f64) -> Gaze {
    display().gaze(x, y).unwrap()
}

/// The off-centre gaze most cases use (up and left of the centre, ~17° out).
fn off_centre() -> Gaze {
    gaze(52.0, 64.0)
}

fn frame(s: &Setup, settings: &FrameSettings, gaze: Gaze) -> Image<Rgb> {
    render_frame(&s.world, &s.camera, settings, gaze, &|_, _| {})
        .unwrap()
        .color
}

fn method(s: &Setup, m: Method, g: Gaze) -> Image<Rgb> {
    frame(s, &FrameSettings::new(m), g)
}

fn with_dof(m: Method, filter: FilterKind, focus: FocusMode) -> FrameSettings {
    let mut f = FrameSettings::new(m);
    f.dof = Some(DofSettings::new(Some(filter), focus));
    f
}

/// Liu et al.'s hybrid as `--method liu-hybrid`: visual-polar sampling, bokeh with LCA, DOF-
/// aware culling, focus at the gaze.
fn liu_hybrid(s: &Setup) -> Image<Rgb> {
    let mut f = FrameSettings::new(Method::VisualPolar);
    let mut d = DofSettings::new(Some(FilterKind::BokehLca), FocusMode::Auto);
    d.cull = true;
    f.dof = Some(d);
    frame(s, &f, off_centre())
}

/// Both eyes fixating the off-centre gaze's surface point, the right eye reprojected from the
/// left (VaFR_Rep).
fn stereo_rep(s: &Setup, right: bool) -> Image<Rgb> {
    let d = display();
    let (_, [(lc, lg), (rc, rg)]) = fixating_eyes(&s.world, &s.rig, &d, &off_centre()).unwrap();
    let st = render_stereo(
        &s.world,
        &lc,
        &rc,
        &FrameSettings::new(Method::Vafr),
        [EyeState::looking_at(lg), EyeState::looking_at(rg)],
        StereoMode::Rep,
        &|_, _| {},
    )
    .unwrap();
    if right {
        st.right.color
    } else {
        st.left.color
    }
}

/// The last of `TEMPORAL_FRAMES + 1` frames with accumulation, the gaze sliding right by 4 px
/// per frame (about 2.7°), the camera still.
fn temporal(s: &Setup, m: Method) -> Image<Rgb> {
    let mut acc = TemporalAccumulator::new(TemporalSettings::default()).unwrap();
    let mut last = None;
    for k in 0..=TEMPORAL_FRAMES {
        let g = gaze(60.0 + 4.0 * k as f64, 96.0);
        let f = render_frame_temporal(
            &s.world,
            &s.camera,
            &FrameSettings::new(m),
            g,
            &mut acc,
            &|_, _| {},
        )
        .unwrap();
        last = Some(f.color);
    }
    last.unwrap()
}

/// One golden image: its name (file stem), what it renders and its tolerance.
struct Case {
    name: &'static str,
    render: fn(&Setup) -> Image<Rgb>,
    min_psnr_db: f64,
}

const fn case(name: &'static str, render: fn(&Setup) -> Image<Rgb>) -> Case {
    Case {
        name,
        render,
        min_psnr_db: DEFAULT_MIN_PSNR_DB,
    }
}

fn cases() -> Vec<Case> {
    vec![
        case("full-centre", |s| {
            method(s, Method::Full, display().centre_gaze())
        }),
        case("vafr-centre", |s| {
            method(s, Method::Vafr, display().centre_gaze())
        }),
        case("full", |s| method(s, Method::Full, off_centre())),
        case("vafr", |s| method(s, Method::Vafr, off_centre())),
        case("kfr", |s| method(s, Method::Kfr, off_centre())),
        case("lafr", |s| method(s, Method::Lafr, off_centre())),
        case("visual-polar", |s| {
            method(s, Method::VisualPolar, off_centre())
        }),
        case("guenter", |s| method(s, Method::Guenter, off_centre())),
        case("inset", |s| method(s, Method::Inset, off_centre())),
        case("inset-hard", |s| {
            let mut f = FrameSettings::new(Method::Inset);
            f.inset_smoothing = fovea_post::inset_smoothing::Smoothing::None;
            frame(s, &f, off_centre())
        }),
        case("weier", |s| method(s, Method::Weier, off_centre())),
        // The sample-space denoiser (issue 38), off in every other case.
        case("vafr-denoise", |s| {
            let mut f = FrameSettings::new(Method::Vafr);
            f.denoise = Some(fovea_post::denoise::DenoiseParams::default());
            frame(s, &f, off_centre())
        }),
        // The DOF cases focus at 10 cm (the near point of a young eye), so the room beyond
        // blurs by ~2.7 px at 160×180 (see `realtime-dof-gather-full-10cm`). Focused at 1 m,
        // at the gaze (auto) or at infinity, as they were until issue 38's round, the eye's
        // CoC of the room stays under 0.3 px and `dof-gather-full-1m`, `-bokeh-lca-vafr-auto`
        // and `-layered-weier-inf` equalled `full`, `vafr` and `weier` bit for bit
        // (`VARIANTS` now keeps them apart). Auto focus is tested in fovea-post's DOF tests.
        case("dof-gather-full-10cm", |s| {
            let f = with_dof(Method::Full, FilterKind::Gather, FocusMode::Fixed(0.1));
            frame(s, &f, off_centre())
        }),
        case("dof-bokeh-lca-vafr-10cm", |s| {
            let f = with_dof(Method::Vafr, FilterKind::BokehLca, FocusMode::Fixed(0.1));
            frame(s, &f, off_centre())
        }),
        case("dof-recursive-full-5m", |s| {
            let f = with_dof(Method::Full, FilterKind::Recursive, FocusMode::Fixed(5.0));
            frame(s, &f, off_centre())
        }),
        case("dof-layered-weier-10cm", |s| {
            let f = with_dof(Method::Weier, FilterKind::Layered, FocusMode::Fixed(0.1));
            frame(s, &f, off_centre())
        }),
        case("liu-hybrid", liu_hybrid),
        case("contrast-vafr", |s| {
            let mut f = FrameSettings::new(Method::Vafr);
            f.contrast = Some(PeripheralContrast::default());
            frame(s, &f, off_centre())
        }),
        case("path-full", |s| {
            let mut f = FrameSettings::new(Method::Full);
            f.shading = ShadingMode::Path {
                bounces: 1,
                spp: 2,
                seed: 7,
            };
            frame(s, &f, off_centre())
        }),
        case("stereo-rep-left", |s| stereo_rep(s, false)),
        case("stereo-rep-right", |s| stereo_rep(s, true)),
        case("temporal-vafr", |s| temporal(s, Method::Vafr)),
        case("temporal-weier", |s| temporal(s, Method::Weier)),
        // The real-time preset (issue 37): what the resident GPU frame serves.
        // `fovea-gpu/tests/frame_golden.rs` renders these through it and compares them with
        // the same files; keep the two lists in step.
        case("realtime-full-centre", |s| {
            frame(s, &realtime(Method::Full), display().centre_gaze())
        }),
        case("realtime-vafr-centre", |s| {
            frame(s, &realtime(Method::Vafr), display().centre_gaze())
        }),
        case("realtime-full", |s| {
            frame(s, &realtime(Method::Full), off_centre())
        }),
        case("realtime-vafr", |s| {
            frame(s, &realtime(Method::Vafr), off_centre())
        }),
        case("realtime-kfr", |s| {
            frame(s, &realtime(Method::Kfr), off_centre())
        }),
        case("realtime-lafr", |s| {
            frame(s, &realtime(Method::Lafr), off_centre())
        }),
        case("realtime-visual-polar", |s| {
            frame(s, &realtime(Method::VisualPolar), off_centre())
        }),
        // Weier's sparse pattern and pull-push (issue 37: resident on the GPU).
        case("realtime-weier", |s| {
            frame(s, &realtime(Method::Weier), off_centre())
        }),
        // FXAA with the paper's bilinear lookup, and without it: with the footprint
        // reconstruction (the default) every column of VaFR at 160×180 is denser than the
        // screen, FXAA's output is restored there, and an AA-less frame would equal
        // `realtime-vafr` bit for bit (it did, as `realtime-vafr-no-aa`, until issue 37's
        // polish; `VARIANTS` below keeps the pair apart).
        case("realtime-vafr-bilinear", |s| {
            frame(s, &realtime_vafr_bilinear(), off_centre())
        }),
        case("realtime-vafr-bilinear-no-aa", |s| {
            let mut f = realtime_vafr_bilinear();
            f.aa = fovea_render::pipeline::AaMode::None;
            frame(s, &f, off_centre())
        }),
        // Focused at 10 cm (the near point of a young eye): the eye's CoC of the room beyond
        // is 4.49 mm × 9.5 D ≈ 2.4° ≈ 2.7 px at 160×180. Focused at 1 m (the case's focus
        // until issue 37's polish) it stays under 0.3 px and the frame equalled
        // `realtime-full` bit for bit.
        case("realtime-dof-gather-full-10cm", |s| {
            let mut f = with_dof(Method::Full, FilterKind::Gather, FocusMode::Fixed(0.1));
            fovea_render::quality::Quality::Realtime.apply(&mut f);
            frame(s, &f, off_centre())
        }),
        // The layered methods with the preset's direct light only: their resident frame runs
        // no bounce (`--quality realtime --shading direct`).
        case("realtime-guenter", |s| {
            frame(s, &realtime_direct(Method::Guenter), off_centre())
        }),
        case("realtime-inset", |s| {
            frame(s, &realtime_direct(Method::Inset), off_centre())
        }),
    ]
}

/// [`realtime`] with direct light only (`--quality realtime --shading direct`).
fn realtime_direct(m: Method) -> FrameSettings {
    let mut f = realtime(m);
    f.shading = fovea_render::shade::ShadingMode::Direct {
        env_light: fovea_render::shade::EnvLight::Occluded {
            samples: fovea_render::quality::REALTIME_ENV_SAMPLES,
        },
    };
    f
}

/// `--quality realtime`'s settings (`Quality::apply`: direct light, one occluded environment
/// ray per sample, one bounce of indirect light, VaFR's rings in one buffer for any gaze).
fn realtime(m: Method) -> FrameSettings {
    let mut f = FrameSettings::new(m);
    fovea_render::quality::Quality::Realtime.apply(&mut f);
    f
}

/// The real-time VaFR frame with the paper's bilinear lookup instead of the pixel footprint.
fn realtime_vafr_bilinear() -> FrameSettings {
    let mut f = realtime(Method::Vafr);
    f.reconstruct_filter = fovea_post::inverse_map::ReconstructFilter::Bilinear;
    f
}

/// Cases that vary one setting of another case, with the most PSNR (dB, the metric of
/// [`Comparison`]) their stored images may have against their base's: a variant whose setting
/// stops changing the frame (as `realtime-vafr-no-aa` and `realtime-dof-gather-full-1m` did,
/// bit for bit) fails here instead of pinning its base twice. The bounds sit several dB above
/// what the stored images score (printed).
const VARIANTS: [(&str, &str, f64); 5] = [
    (
        "realtime-vafr-bilinear-no-aa",
        "realtime-vafr-bilinear",
        50.0,
    ),
    ("realtime-dof-gather-full-10cm", "realtime-full", 35.0),
    ("dof-gather-full-10cm", "full", 35.0),
    ("dof-bokeh-lca-vafr-10cm", "vafr", 35.0),
    ("dof-layered-weier-10cm", "weier", 45.0),
];

/// Reinhard + sRGB, 16 bits per channel.
fn encode(img: &Image<Rgb>) -> Vec<u16> {
    img.data()
        .iter()
        .flatten()
        .map(|&v| {
            let x = if v.is_finite() { v.max(0.0) } else { 0.0 };
            let e = fovea_post::tonemap::linear_to_srgb(x / (1.0 + x));
            (e * 65535.0).round() as u16
        })
        .collect()
}

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

fn out_dir() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("golden")
}

fn write_png16(path: &Path, codes: &[u16]) {
    let img =
        image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(WIDTH, HEIGHT, codes.to_vec())
            .expect("image size");
    img.save_with_format(path, image::ImageFormat::Png)
        .unwrap_or_else(|e| panic!("cannot write {}: {e}", path.display()));
}

fn read_png16(path: &Path) -> Result<Vec<u16>, String> {
    let img = image::open(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    if (img.width(), img.height()) != (WIDTH, HEIGHT) {
        return Err(format!(
            "{} is {}x{}, expected {WIDTH}x{HEIGHT}",
            path.display(),
            img.width(),
            img.height()
        ));
    }
    Ok(img.into_rgb16().into_raw())
}

/// The comparison of one image with its golden copy.
#[derive(Debug)]
struct Comparison {
    psnr_db: f64,
    max_code_diff: u16,
}

impl Comparison {
    fn of(expected: &[u16], actual: &[u16]) -> Self {
        let mut se = 0.0f64;
        let mut max = 0u16;
        for (&a, &b) in expected.iter().zip(actual) {
            let d = a.abs_diff(b);
            max = max.max(d);
            let e = d as f64 / 65535.0;
            se += e * e;
        }
        let mse = se / expected.len().max(1) as f64;
        let psnr_db = if mse == 0.0 {
            f64::INFINITY
        } else {
            -10.0 * mse.log10()
        };
        Self {
            psnr_db,
            max_code_diff: max,
        }
    }

    fn passes(&self, min_psnr_db: f64) -> bool {
        self.max_code_diff == 0 || self.psnr_db >= min_psnr_db
    }
}

/// |Δ| × 64 per channel, 8-bit.
fn write_diff(path: &Path, expected: &[u16], actual: &[u16]) {
    let bytes: Vec<u8> = expected
        .iter()
        .zip(actual)
        .map(|(&a, &b)| ((a.abs_diff(b) as u32 * 64) >> 8).min(255) as u8)
        .collect();
    let img = image::RgbImage::from_raw(WIDTH, HEIGHT, bytes).expect("image size");
    img.save_with_format(path, image::ImageFormat::Png)
        .unwrap_or_else(|e| panic!("cannot write {}: {e}", path.display()));
}

fn updating() -> bool {
    std::env::var("FOVEA_GOLDEN").is_ok_and(|v| v == "update")
}

#[test]
fn every_golden_image_is_reproduced() {
    let s = setup();
    let cases = cases();
    if updating() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        for c in &cases {
            let path = golden_dir().join(format!("{}.png", c.name));
            write_png16(&path, &encode(&(c.render)(s)));
            println!("golden: wrote {}", path.display());
        }
        return;
    }
    let mut failures = Vec::new();
    std::fs::create_dir_all(out_dir()).unwrap();
    for c in &cases {
        let img = (c.render)(s);
        assert_eq!((img.width(), img.height()), (WIDTH, HEIGHT), "{}", c.name);
        let actual = encode(&img);
        let golden = golden_dir().join(format!("{}.png", c.name));
        let expected = match read_png16(&golden) {
            Ok(e) => e,
            Err(e) => {
                failures.push(format!("{}: {e}", c.name));
                continue;
            }
        };
        let cmp = Comparison::of(&expected, &actual);
        let verdict = if cmp.max_code_diff == 0 {
            "identical".to_string()
        } else {
            format!(
                "PSNR {:.2} dB (≥ {} dB), max Δ {} of 65535",
                cmp.psnr_db, c.min_psnr_db, cmp.max_code_diff
            )
        };
        println!("golden {:<26} {verdict}", c.name);
        if !cmp.passes(c.min_psnr_db) {
            let a = out_dir().join(format!("{}.actual.png", c.name));
            let d = out_dir().join(format!("{}.diff.png", c.name));
            write_png16(&a, &actual);
            write_diff(&d, &expected, &actual);
            failures.push(format!(
                "{}: {verdict}\n  expected {}\n  actual   {}\n  diff     {} (|Δ|×64)",
                c.name,
                golden.display(),
                a.display(),
                d.display()
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} golden images differ (regenerate on purpose with FOVEA_GOLDEN=update):\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// Negative control: the same frames with every light and the environment 1 % brighter (a 1 %
/// change of the shading) fail the comparison, so the tolerance can see such a change.
#[test]
fn a_one_percent_shading_change_fails() {
    if updating() {
        return;
    }
    let brighter = setup_with_light_scale(1.01);
    for c in cases()
        .iter()
        .filter(|c| ["full", "vafr", "weier"].contains(&c.name))
    {
        let expected = read_png16(&golden_dir().join(format!("{}.png", c.name))).unwrap();
        let cmp = Comparison::of(&expected, &encode(&(c.render)(&brighter)));
        println!(
            "1 % brighter {:<8} PSNR {:.2} dB, max Δ {}",
            c.name, cmp.psnr_db, cmp.max_code_diff
        );
        assert!(
            !cmp.passes(c.min_psnr_db),
            "{}: a 1 % shading change passed ({cmp:?})",
            c.name
        );
    }
}

#[test]
fn variants_differ_from_their_base() {
    if updating() {
        return;
    }
    let read = |name: &str| read_png16(&golden_dir().join(format!("{name}.png"))).unwrap();
    let names: Vec<&str> = cases().iter().map(|c| c.name).collect();
    for (variant, base, max_psnr_db) in VARIANTS {
        assert!(
            names.contains(&variant) && names.contains(&base),
            "{variant}, {base}"
        );
        let cmp = Comparison::of(&read(base), &read(variant));
        println!(
            "variant {variant:<30} against {base:<24} PSNR {:.2} dB (≤ {max_psnr_db} dB), max Δ {}",
            cmp.psnr_db, cmp.max_code_diff
        );
        assert!(
            cmp.psnr_db <= max_psnr_db,
            "{variant} is too close to {base} ({cmp:?}): its setting no longer changes the frame"
        );
    }
}

#[test]
fn the_metric_scores_identical_and_shifted_images() {
    let a = vec![1000u16; 300];
    assert!(Comparison::of(&a, &a).psnr_db.is_infinite());
    let b: Vec<u16> = a.iter().map(|v| v + 655).collect(); // Δ = 1 % of the range
    let c = Comparison::of(&a, &b);
    assert!((c.psnr_db - 40.0).abs() < 0.01, "{c:?}");
    assert_eq!(c.max_code_diff, 655);
}
