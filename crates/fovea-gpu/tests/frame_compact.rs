//! The resident frame's list of shaded texels (`fovea_gpu::frame::compact`, issue 37): the
//! kernels of a polar buffer run over a list of its shaded texels built on the device each
//! frame. Two checks per case, both eyes, a gaze at the centre and one off centre (the list
//! follows the gaze in the same buffers):
//!
//! * the list against the CPU mapping: every texel the plan shades listed once and nothing
//!   else. A texel is shaded, as the CPU's `trace_and_shade` decides it, where the mapping says
//!   so (`FoveationMapping::is_shaded`, asked texel by texel, not the runs the frame uploads)
//!   and its ray has a point on its column's ring (`Ring::polar` of `v = j + ½ + jitter`; the
//!   kernel compares `v` with the ring's period in f32, so the count here does too). And the
//!   host's bound of the count (the dispatch's size) is at least the count;
//! * the samples (colour and depth of every texel) bit for bit those of the same frame with
//!   the list off (`ResidentSamples::set_compaction(false)`: every texel walked, as before the
//!   list), with direct light and with the real-time preset's bounce of indirect light (whose
//!   kernels run over the list too), and with the denoiser's guides written and the denoiser
//!   run over them (so the guides the list's kernel writes for unshaded texels count as well;
//!   with the list on, the denoiser's passes after the first run over its own list of the
//!   texels that filter, dispatched by the frame list's bound: `GpuDenoiser::set_source_bound`).
//!
//! Cases: VaFR with the rings for any gaze (`VafrRings::Eq3AnyGaze`, the real-time preset's,
//! whose buffer reaches the screen's diagonal), VaFR's exact rings, KFR (a polar mapping that
//! does not list its runs). A small display (a fifth of the Vive Pro Eye's pixels, a third of its fields of view) keeps each
//! case to seconds on lavapipe. The fractions shaded are printed (what the list saves).
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;

use std::collections::BTreeSet;

use common::{gpu_or_skip, shout};
use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{Method, VafrRings};
use fovea_core::units::Degrees;
use fovea_gpu::frame::ResidentSamples;
use fovea_gpu::GpuContext;
use fovea_post::denoise::DenoiseParams;
use fovea_render::bvh::Backend;
use fovea_render::camera::{Eye, EyeCamera, HmdRig};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::FrameSettings;
use fovea_render::plan::FramePlan;
use fovea_render::quality::Quality;
use fovea_render::scene::builtin;
use fovea_render::shade::{EnvLight, FrameNoise, ShadingMode};
use fovea_render::world::World;

/// A fifth of the Vive Pro Eye per side (1440 × 1600), and a third of its fields of view
/// (VaFR's buffer follows the eccentricities the screen spans, not its pixels).
fn display() -> DisplayProfile {
    DisplayProfile::new("vive-small", 288, 320, Degrees(33.0), Degrees(37.0)).unwrap()
}

/// The built-in scene and both eyes' cameras (63 mm apart).
fn setup() -> (World, [EyeCamera; 2]) {
    let scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, 0.063).unwrap();
    let d = display();
    (
        world,
        [Eye::Left, Eye::Right].map(|e| rig.eye(e, &d).unwrap()),
    )
}

/// The texels `plan` shades, `j · width + i`, counted texel by texel (module header).
fn brute_force(plan: &FramePlan) -> BTreeSet<u32> {
    let mapping = plan.mapping();
    let size = plan.buffers[0];
    let (offsets, _) = plan.rays.pattern(1);
    let o = offsets[0];
    let jitter = plan.jitter_texels;
    let mut shaded = BTreeSet::new();
    for i in 0..size.width {
        let Some(ring) = mapping.ring(0, i as f64 + o[0] + jitter[0]) else {
            continue;
        };
        for j in 0..size.height {
            if !mapping.is_shaded(0, i, j) {
                continue;
            }
            let v = j as f32 + (o[1] + jitter[1]) as f32;
            let period = ring.period as f32;
            let on_ring = if period <= 0.0 {
                v == 0.0
            } else {
                v >= 0.0 && v <= period
            };
            if on_ring {
                shaded.insert(j * size.width + i);
            }
        }
    }
    shaded
}

/// One case: `method` (with `rings` for VaFR) shaded as `shading`, denoised or not.
struct Case {
    method: Method,
    rings: Option<VafrRings>,
    shading: ShadingMode,
    denoise: bool,
}

/// Gazes (screen pixels, left and right eye): the centre, then off centre towards a corner.
const GAZES: [[(f64, f64); 2]; 2] = [
    [(144.0, 160.0), (144.0, 160.0)],
    [(40.0, 50.0), (52.0, 48.0)],
];

/// Both eyes' samples (colour, depth as bits, per eye) of each gaze's frame, with the list on
/// or off; with it on, each eye's list checked against the brute-force count.
fn frames(ctx: &GpuContext, case: &Case, on: bool) -> Vec<Vec<u32>> {
    let (world, cams) = setup();
    let mut s = FrameSettings::new(case.method);
    s.shading = case.shading;
    s.periphery_rays = 1;
    if let Some(r) = case.rings {
        s.mapping.vafr.rings = r;
    }
    if case.denoise {
        s.denoise = Some(DenoiseParams::default());
    }
    let name = format!("{} {:?} {:?}", case.method, case.rings, case.shading);
    let mut resident = ResidentSamples::new(ctx, &world).unwrap();
    resident.set_compaction(on);
    let mut out = Vec::new();
    for (f, gazes) in GAZES.iter().enumerate() {
        let plans: Vec<FramePlan> = (0..2)
            .map(|e| {
                let g = cams[e].display.gaze(gazes[e].0, gazes[e].1).unwrap();
                FramePlan::new(&world, &cams[e], &s, &EyeState::looking_at(g), [0.0, 0.0])
                    .unwrap()
                    .with_noise(FrameNoise::new(f as u64, e as u32))
            })
            .collect();
        let eyes = [(&cams[0], &plans[0]), (&cams[1], &plans[1])];
        resident.render_eyes(&world, &eyes).unwrap();
        if case.denoise {
            let mut encoder = ctx
                .device()
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            for (e, plan) in plans.iter().enumerate() {
                assert!(resident
                    .record_denoise(e, plan, &mut encoder, None)
                    .unwrap());
            }
            ctx.submit([encoder.finish()]);
            for e in 0..2 {
                // With the list, the denoiser's later passes ran over its own list: every
                // texel it filtered listed, within the frame list's bound; without, none.
                let [filtered, _, listed] = resident
                    .denoiser(e)
                    .unwrap()
                    .read_counts()
                    .unwrap()
                    .unwrap();
                let bound = resident.eye(e).unwrap().list().bound();
                shout(&format!(
                    "[fovea-gpu] compact {name} frame {f} eye {e}: denoiser filtered \
                     {filtered}, listed {listed} (list {}, bound {bound})",
                    if on { "on" } else { "off" }
                ));
                if on {
                    assert_eq!(
                        listed, filtered,
                        "{name} frame {f} eye {e}: denoiser's list"
                    );
                    assert!(
                        filtered > 0 && listed <= bound,
                        "{name} frame {f} eye {e}: denoiser listed {listed}, bound {bound}"
                    );
                } else {
                    assert_eq!(
                        listed, 0,
                        "{name} frame {f} eye {e}: listed without a bound"
                    );
                }
            }
        }
        for (e, plan) in plans.iter().enumerate() {
            let eye = resident.eye(e).unwrap();
            let samples = eye.samples().read(ctx).unwrap();
            let mut bits = Vec::new();
            for (c, d) in samples.color.iter().zip(&samples.depth) {
                bits.extend(c.data().iter().flatten().map(|v| v.to_bits()));
                bits.extend(d.data().iter().map(|v| v.to_bits()));
            }
            out.push(bits);
            if !on {
                continue;
            }
            let size = plan.buffers[0];
            let listed = eye.list().read(ctx).unwrap();
            let set: BTreeSet<u32> = listed.iter().copied().collect();
            assert_eq!(
                set.len(),
                listed.len(),
                "{name} frame {f} eye {e}: listed twice"
            );
            let expected = brute_force(plan);
            let missing = expected.difference(&set).count();
            let extra = set.difference(&expected).count();
            shout(&format!(
                "[fovea-gpu] compact {name} frame {f} eye {e} gaze {:?}: buffer {}x{}, {} of {} \
                 texels shaded ({:.1} %), listed {} ({missing} missing, {extra} extra), bound {}",
                gazes[e],
                size.width,
                size.height,
                expected.len(),
                size.pixels(),
                100.0 * expected.len() as f64 / size.pixels() as f64,
                listed.len(),
                eye.list().bound(),
            ));
            assert_eq!(
                missing, 0,
                "{name} frame {f} eye {e}: shaded texels not listed"
            );
            assert_eq!(extra, 0, "{name} frame {f} eye {e}: unshaded texels listed");
            assert!(
                !expected.is_empty(),
                "{name} frame {f} eye {e}: nothing shaded"
            );
            assert!(
                eye.list().bound() as usize >= listed.len(),
                "{name} frame {f} eye {e}: the dispatch's bound {} under the count {}",
                eye.list().bound(),
                listed.len()
            );
        }
    }
    out
}

/// The case's frames with the list and without are the same bits (and the list is right).
fn same_bits_with_and_without_the_list(test: &str, case: Case) {
    let Some(ctx) = gpu_or_skip(test) else {
        return;
    };
    let with = frames(&ctx, &case, true);
    let without = frames(&ctx, &case, false);
    assert_eq!(with.len(), without.len());
    for (k, (a, b)) in with.iter().zip(&without).enumerate() {
        assert_eq!(
            a.len(),
            b.len(),
            "{test}: frame {} eye {}: sizes",
            k / 2,
            k % 2
        );
        let differ = a.iter().zip(b).filter(|(x, y)| x != y).count();
        assert_eq!(
            differ,
            0,
            "{test}: frame {} eye {}: {differ} of {} words differ with the list",
            k / 2,
            k % 2,
            a.len()
        );
    }
}

#[test]
fn vafr_any_gaze_realtime_list_is_exact_and_changes_no_bit() {
    same_bits_with_and_without_the_list(
        "vafr_any_gaze_realtime_list_is_exact_and_changes_no_bit",
        Case {
            method: Method::Vafr,
            rings: Some(VafrRings::Eq3AnyGaze),
            shading: Quality::Realtime.shading(),
            denoise: true,
        },
    );
}

#[test]
fn vafr_exact_direct_list_is_exact_and_changes_no_bit() {
    same_bits_with_and_without_the_list(
        "vafr_exact_direct_list_is_exact_and_changes_no_bit",
        Case {
            method: Method::Vafr,
            rings: Some(VafrRings::Exact),
            shading: ShadingMode::Direct {
                env_light: EnvLight::Occluded { samples: 2 },
            },
            denoise: false,
        },
    );
}

#[test]
fn kfr_list_is_exact_and_changes_no_bit() {
    same_bits_with_and_without_the_list(
        "kfr_list_is_exact_and_changes_no_bit",
        Case {
            method: Method::Kfr,
            rings: None,
            shading: ShadingMode::DIRECT,
            denoise: false,
        },
    );
}
