//! `PlanCache` (issue 37): a plan made from the cache is the plan `FramePlan::new` makes — its
//! data and its mapping, compared point by point and texel by texel at gazes in the middle, at
//! the corners and off the screen — and the cache forgets its tables when the display, the
//! method, the mapping's parameters or the ray settings change.

use std::sync::Arc;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::{FoveationMapping, Method, SamplePoint, VafrRings};
use fovea_core::units::{Degrees, ScreenPoint};
use fovea_render::bvh::Backend;
use fovea_render::camera::{Eye, EyeCamera, HmdRig};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::FrameSettings;
use fovea_render::plan::{FramePlan, PlanCache, PLAN_CACHE_GAZES};
use fovea_render::scene::builtin;
use fovea_render::world::World;

fn setup(d: &DisplayProfile) -> (World, EyeCamera) {
    let scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, 0.063).unwrap();
    let camera = rig.eye(Eye::Left, d).unwrap();
    (world, camera)
}

/// The two mappings answer alike: forward at a grid of screen points (and a few off it),
/// inverse and shading at every texel of every buffer, the rates at every 0.5°.
fn same_mapping(a: &dyn FoveationMapping, b: &dyn FoveationMapping, d: &DisplayProfile) {
    assert_eq!(a.method(), b.method());
    assert_eq!(a.buffers(), b.buffers());
    assert_eq!(a.sample_count(), b.sample_count());
    assert_eq!(a.polar_layout(), b.polar_layout());
    let (w, h) = (d.width_px as f64, d.height_px as f64);
    for y in -2..=40 {
        for x in -2..=40 {
            let p = ScreenPoint::new(x as f64 * w / 38.0 + 0.25, y as f64 * h / 38.0 + 0.75);
            assert_eq!(a.forward(p), b.forward(p), "{p:?}");
        }
    }
    for (layer, size) in a.buffers().iter().enumerate() {
        let layer = layer as u32;
        for j in 0..size.height {
            for i in 0..size.width {
                assert_eq!(a.is_shaded(layer, i, j), b.is_shaded(layer, i, j));
                let s = SamplePoint {
                    layer,
                    u: i as f64 + 0.5,
                    v: j as f64 + 0.5,
                };
                assert_eq!(a.inverse(s), b.inverse(s), "{s:?}");
            }
        }
    }
    for k in 0..180 {
        let e = k as f64 * 0.5;
        assert_eq!(
            a.radial_rate_cpd(e).to_bits(),
            b.radial_rate_cpd(e).to_bits()
        );
        assert_eq!(
            a.tangential_rate_cpd(e).to_bits(),
            b.tangential_rate_cpd(e).to_bits()
        );
    }
}

#[test]
fn cached_plans_equal_uncached_ones_at_every_gaze() {
    let d = DisplayProfile::new("t", 200, 180, Degrees(100.0), Degrees(95.0)).unwrap();
    let (world, camera) = setup(&d);
    let (w, h) = (d.width_px as f64, d.height_px as f64);
    let gazes: Vec<Gaze> = [
        (0.5, 0.5),
        (0.0, 0.0),
        (1.0, 0.0),
        (0.0, 1.0),
        (1.0, 1.0),
        (0.37, 0.81),
        (-0.04, 0.5),
        (0.5, 1.04),
    ]
    .iter()
    .map(|&(x, y)| d.gaze(x * w, y * h).unwrap())
    .collect();
    // VaFR's rings for any gaze: each miss moves the last mapping (`rebuild_at`) where the
    // gaze keeps its layout, builds it where not (the gazes off the screen).
    for (m, any_gaze) in [
        (Method::Vafr, false),
        (Method::Vafr, true),
        (Method::Kfr, false),
        (Method::VisualPolar, false),
        (Method::Weier, false),
    ] {
        let mut settings = FrameSettings::new(m);
        settings.periphery_rays = 4;
        if any_gaze {
            settings.mapping.vafr.rings = VafrRings::Eq3AnyGaze;
        }
        let mut cache = PlanCache::new();
        for (k, &g) in gazes.iter().enumerate() {
            let eye = EyeState::looking_at(g);
            let jitter = [0.125 * (k % 3) as f64, -0.25];
            let want = FramePlan::new(&world, &camera, &settings, &eye, jitter).unwrap();
            let got =
                FramePlan::cached(&world, &camera, &settings, &eye, jitter, &mut cache).unwrap();
            assert_eq!(got.to_json().unwrap(), want.to_json().unwrap(), "{m} {g:?}");
            same_mapping(got.mapping(), want.mapping(), &d);
            // Again: from the cache, the same mapping shared.
            let again =
                FramePlan::cached(&world, &camera, &settings, &eye, [0.0; 2], &mut cache).unwrap();
            assert!(Arc::ptr_eq(&again.shared_mapping(), &got.shared_mapping()));
            assert_eq!(again.rays.per_column, want.rays.per_column);
        }
        assert_eq!(cache.misses(), gazes.len() as u64, "{m}");
        assert_eq!(cache.hits(), gazes.len() as u64, "{m}");
        assert_eq!(cache.len(), PLAN_CACHE_GAZES);
        // Gazes forgotten: a gaze planned before is planned afresh, the same plan.
        cache.forget_gazes();
        assert!(cache.is_empty());
        let eye = EyeState::looking_at(gazes[5]);
        let want = FramePlan::new(&world, &camera, &settings, &eye, [0.0; 2]).unwrap();
        let got =
            FramePlan::cached(&world, &camera, &settings, &eye, [0.0; 2], &mut cache).unwrap();
        assert_eq!(
            got.to_json().unwrap(),
            want.to_json().unwrap(),
            "{m} forgotten"
        );
        same_mapping(got.mapping(), want.mapping(), &d);
        assert_eq!(cache.misses(), gazes.len() as u64 + 1, "{m}");
    }
}

#[test]
fn the_cache_forgets_its_tables_when_what_they_depend_on_changes() {
    let d = DisplayProfile::new("t", 160, 120, Degrees(100.0), Degrees(85.0)).unwrap();
    let (world, camera) = setup(&d);
    let gaze = d.gaze(30.0, 100.0).unwrap();
    let eye = EyeState::looking_at(gaze);
    let base = FrameSettings::new(Method::Vafr);
    let mut cache = PlanCache::new();
    let plan = |s: &FrameSettings, cam: &EyeCamera, cache: &mut PlanCache| {
        let got = FramePlan::cached(&world, cam, s, &eye, [0.0; 2], cache).unwrap();
        let want = FramePlan::new(&world, cam, s, &eye, [0.0; 2]).unwrap();
        assert_eq!(got.to_json().unwrap(), want.to_json().unwrap());
        same_mapping(got.mapping(), want.mapping(), &cam.display);
        got
    };
    let first = plan(&base, &camera, &mut cache);
    assert_eq!((cache.hits(), cache.misses()), (0, 1));
    plan(&base, &camera, &mut cache);
    assert_eq!((cache.hits(), cache.misses()), (1, 1));

    // Every change below builds anew, and empties the cache first.
    let mut eq3 = base.clone();
    eq3.mapping.vafr.rings = VafrRings::Eq3;
    let mut kfr = base.clone();
    kfr.method = Method::Kfr;
    let mut rays = base.clone();
    rays.periphery_rays = 9;
    let mut filter = base.clone();
    filter.reconstruct_filter = fovea_post::inverse_map::ReconstructFilter::Bilinear;
    let mut misses = 1;
    for s in [&eq3, &kfr, &rays, &filter] {
        let p = plan(s, &camera, &mut cache);
        misses += 1;
        assert_eq!(cache.misses(), misses);
        assert_eq!(cache.len(), 1);
        assert!(!Arc::ptr_eq(&p.shared_mapping(), &first.shared_mapping()));
    }
    // Another display (the same pixels, another field of view).
    let other = DisplayProfile::new("t", 160, 120, Degrees(90.0), Degrees(75.0)).unwrap();
    let (_, other_cam) = setup(&other);
    let p = plan(&base, &other_cam, &mut cache);
    assert_eq!(cache.misses(), misses + 1);
    assert_eq!(cache.len(), 1);
    assert_ne!(p.buffers, first.buffers);
    // And back: built again (the first display's tables were dropped).
    plan(&base, &camera, &mut cache);
    assert_eq!(cache.misses(), misses + 2);

    // Settings the tables do not depend on share them.
    let mut aa = base.clone();
    aa.aa = fovea_render::pipeline::AaMode::None;
    let hits = cache.hits();
    plan(&aa, &camera, &mut cache);
    assert_eq!(cache.hits(), hits + 1);

    // More gazes than it holds: the oldest is built again.
    for k in 0..PLAN_CACHE_GAZES {
        let g = d.gaze(10.0 + 20.0 * k as f64, 50.0).unwrap();
        FramePlan::cached(
            &world,
            &camera,
            &base,
            &EyeState::looking_at(g),
            [0.0; 2],
            &mut cache,
        )
        .unwrap();
    }
    let misses = cache.misses();
    plan(&base, &camera, &mut cache);
    assert_eq!(cache.misses(), misses + 1);
}
