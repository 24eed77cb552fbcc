//! Coverage of the whole screen at every gaze (issue 17): every screen pixel is reconstructed
//! from samples within ~1.5 local sample spacings of it, for every method, at the Vive Pro
//! Eye, Pimax Crystal and 8K presets, on a 7×7 grid of gazes with the corners included.
//!
//! Two checks:
//! * **Mapping**: a pixel's nearest shaded sample (searched around where the forward map puts
//!   the pixel, brought back through the inverse map) lies within 1.5 spacings, the spacing
//!   being the mapping's own at the pixel's eccentricity ([`SpacingLut`], from its shading
//!   rates, at least one pixel). Every fourth border pixel (where coverage fails first: the
//!   farthest points from the gaze lie on it), the corners and an interior grid are checked.
//! * **Reconstruction**: sample buffers holding each texel's own screen position
//!   (`x, y, 1`) go through the real reconstruction; a pixel's colour is then the weighted
//!   mean of the positions it was made from, which must lie within 1.5 spacings of it, with
//!   weights summing to one. A ring stretched over the screen (the old behaviour past VaFR's
//!   60°) puts that mean far away; an uncovered pixel has weight zero.
//!
//! VaFR's exact rings and Eq. 3's rings in the buffer for any gaze (`VafrRings::Eq3AnyGaze`,
//! the resident GPU frame's layout) leave their off-screen texels unshaded; both are checked
//! on the same grid. The negative control, VaFR with the paper's fixed 60° buffer, fails both.

use rayon::prelude::*;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::footprint::SpacingLut;
use fovea_core::mapping::{
    build, Coverage, FoveationMapping, MappingConfig, Method, PolarLayout, SamplePoint, VafrParams,
    VafrRings,
};
use fovea_core::units::{Degrees, ScreenPoint};
use fovea_core::Image;
use fovea_post::inverse_map::{reconstruct, SampleBuffers};

/// Largest distance from a pixel to its nearest sample, in local sample spacings.
const MAX_SPACINGS: f64 = 1.5;

/// Border pixels between checked ones.
const BORDER_STEP: usize = 4;

/// The 7×7 gaze grid: the screen's corners, edges and five steps between.
fn gazes(d: &DisplayProfile) -> Vec<Gaze> {
    let (w, h) = (d.width_px as f64, d.height_px as f64);
    let mut g = Vec::new();
    for gy in 0..7 {
        for gx in 0..7 {
            g.push(d.gaze(w * gx as f64 / 6.0, h * gy as f64 / 6.0).unwrap());
        }
    }
    g
}

/// Border pixels every [`BORDER_STEP`] and the four corners, and an interior grid of about
/// `interior` pixels. (An uncovered or streaked region is thousands of pixels wide: the old
/// 60° limit leaves whole stretches of border uncovered.)
fn pixels(d: &DisplayProfile, interior: usize) -> Vec<ScreenPoint> {
    let (w, h) = (d.width_px, d.height_px);
    let mut p = vec![(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)];
    for x in (1..w - 1).step_by(BORDER_STEP) {
        p.push((x, 0));
        p.push((x, h - 1));
    }
    for y in (1..h - 1).step_by(BORDER_STEP) {
        p.push((0, y));
        p.push((w - 1, y));
    }
    let stride = ((w as f64 * h as f64 / interior as f64).sqrt().ceil() as u32).max(1);
    // An odd offset so the grid does not share rows and columns with the gaze grid.
    for y in (stride / 2 + 1..h - 1).step_by(stride as usize) {
        for x in (stride / 3 + 1..w - 1).step_by(stride as usize) {
            p.push((x, y));
        }
    }
    p.into_iter()
        .map(|(x, y)| ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5))
        .collect()
}

/// The screen position of texel `(i, j)` of `layer`, when it is shaded.
fn texel_point(m: &dyn FoveationMapping, layer: u32, i: i64, j: i64) -> Option<ScreenPoint> {
    if i < 0 || j < 0 || !m.is_shaded(layer, i as u32, j as u32) {
        return None;
    }
    m.inverse(SamplePoint {
        layer,
        u: i as f64 + 0.5,
        v: j as f64 + 0.5,
    })
}

/// Distance from `p` to the nearest shaded sample around where the forward map puts it;
/// `None` when the mapping has no sample there at all.
fn nearest_sample_px(
    m: &dyn FoveationMapping,
    layout: Option<&PolarLayout>,
    p: ScreenPoint,
    search: i64,
) -> Option<f64> {
    // Weier's buffer is the screen, and its forward map answers only for shaded pixels.
    let s = match m.method() {
        Method::Weier => SamplePoint::new(p.x_px, p.y_px),
        _ => m.forward(p)?,
    };
    let mut best = f64::INFINITY;
    let mut consider = |q: Option<ScreenPoint>| {
        if let Some(q) = q {
            best = best.min(q.distance(p));
        }
    };
    if let Some(layout) = layout {
        // Each column is read at its own angle (rows per turn differ between columns).
        let (dx, dy) = (p.x_px - layout.centre.x_px, p.y_px - layout.centre.y_px);
        let turn = dy.atan2(dx).rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU;
        let i0 = s.u.floor() as i64;
        for i in i0 - 1..=i0 + 1 {
            let Some(&rows) = (i >= 0).then(|| layout.rows.get(i as usize)).flatten() else {
                continue;
            };
            if rows == 0 {
                continue;
            }
            let v = turn * layout.period[i as usize];
            let j0 = v.floor() as i64;
            for j in j0 - 1..=j0 + 1 {
                consider(texel_point(m, 0, i, j.rem_euclid(rows as i64)));
            }
        }
    } else {
        let (i0, j0) = (s.u.floor() as i64, s.v.floor() as i64);
        for j in j0 - search..=j0 + search {
            for i in i0 - search..=i0 + search {
                consider(texel_point(m, s.layer, i, j));
            }
        }
    }
    best.is_finite().then_some(best)
}

/// The local sample spacing at `p`, pixels: the larger of the mapping's density spacing at
/// its eccentricity ([`SpacingLut`], from the shading rates; what spaces Weier's sparse
/// samples) and the screen distance between the neighbouring texel centres around where the
/// forward map puts `p`, along either buffer axis (what spaces the anisotropic rings of
/// LaFR); inside a polar buffer's first ring, the ring's radius (KFR's first ring lies 3.4 px
/// from the gaze at the Vive Pro Eye: the pixels inside read it around the full circle). At
/// least one pixel.
fn local_spacing_px(
    m: &dyn FoveationMapping,
    d: &DisplayProfile,
    g: &Gaze,
    lut: &SpacingLut,
    first_ring_px: Option<f64>,
    p: ScreenPoint,
) -> f64 {
    let mut spacing = (lut.at(d.eccentricity(p, g).0) as f64).max(1.0);
    if let Some(s) = m.forward(p) {
        // Inside a polar buffer's first ring (the pole): the ring's radius is the gap.
        if let (Some(r), true) = (first_ring_px, s.u < 0.5) {
            spacing = spacing.max(r);
        }
        let at = |u: f64, v: f64| {
            m.inverse(SamplePoint {
                layer: s.layer,
                u,
                v,
            })
        };
        // Texel-centre neighbours bracketing `s` (shifted inward at the buffer's edges).
        let (i, j) = (s.u - 0.5, s.v - 0.5);
        let (i0, j0) = (i.floor().max(0.0) + 0.5, j.floor().max(0.0) + 0.5);
        for (a, b) in [
            (at(i0, s.v), at(i0 + 1.0, s.v)),
            (at(i0 - 1.0, s.v), at(i0, s.v)),
            (at(s.u, j0), at(s.u, j0 + 1.0)),
            (at(s.u, j0 - 1.0), at(s.u, j0)),
        ] {
            if let (Some(a), Some(b)) = (a, b) {
                spacing = spacing.max(a.distance(b));
                break;
            }
        }
        for (a, b) in [
            (at(s.u, j0), at(s.u, j0 + 1.0)),
            (at(s.u, j0 - 1.0), at(s.u, j0)),
        ] {
            if let (Some(a), Some(b)) = (a, b) {
                spacing = spacing.max(a.distance(b));
                break;
            }
        }
    }
    spacing
}

/// The radius of a polar buffer's first ring (its column 0's centre), pixels.
fn first_ring_px(m: &dyn FoveationMapping, layout: Option<&PolarLayout>) -> Option<f64> {
    let centre = layout?.centre;
    Some(m.inverse(SamplePoint::new(0.5, 0.5))?.distance(centre))
}

/// Pixels of `d` at gaze `g` whose nearest sample lies farther than [`MAX_SPACINGS`] local
/// spacings, with the worst one (pixel, distance, spacing).
fn mapping_failures(
    d: &DisplayProfile,
    g: Gaze,
    m: &dyn FoveationMapping,
    pixels: &[ScreenPoint],
) -> (usize, Option<(ScreenPoint, f64, f64)>) {
    let lut = SpacingLut::new(m, d, g);
    let layout = m.polar_layout();
    let ring = first_ring_px(m, layout.as_ref());
    let bad: Vec<(ScreenPoint, f64, f64)> = pixels
        .par_iter()
        .filter_map(|&p| {
            // The density spacing first: the local spacing is never smaller, so a pixel
            // within 1.5 of it passes without the texel-neighbour search.
            let density = (lut.at(d.eccentricity(p, &g).0) as f64).max(1.0);
            // Weier's sparse samples are screen pixels up to a few spacings apart.
            let search = if m.method() == Method::Weier {
                (MAX_SPACINGS * density).ceil() as i64 + 1
            } else {
                1
            };
            let dist = nearest_sample_px(m, layout.as_ref(), p, search).unwrap_or(f64::INFINITY);
            if dist <= MAX_SPACINGS * density + 1e-6 {
                return None;
            }
            let spacing = local_spacing_px(m, d, &g, &lut, ring, p);
            (dist > MAX_SPACINGS * spacing + 1e-6).then_some((p, dist, spacing))
        })
        .collect();
    let worst = bad
        .iter()
        .copied()
        .max_by(|a, b| (a.1 / a.2).total_cmp(&(b.1 / b.2)));
    (bad.len(), worst)
}

fn presets() -> Vec<(DisplayProfile, usize)> {
    // Interior points per gaze: the failures start at the border, which is checked in full.
    [
        ("vive-pro-eye", 2_500),
        ("pimax-crystal", 2_500),
        ("8k", 2_500),
    ]
    .iter()
    .map(|&(n, k)| (DisplayProfile::preset(n).unwrap(), k))
    .collect()
}

#[test]
fn every_method_covers_the_screen_at_every_gaze() {
    let config = MappingConfig::default();
    let mut report = Vec::new();
    for (d, interior) in presets() {
        let px = pixels(&d, interior);
        for method in Method::ALL {
            for g in gazes(&d) {
                let m = build(method, &d, g, &config).unwrap();
                let (n, worst) = mapping_failures(&d, g, m.as_ref(), &px);
                if n > 0 {
                    report.push(format!(
                        "{} {method} gaze ({:.0},{:.0}): {n} of {} pixels uncovered, worst {:?}",
                        d.name,
                        g.point.x_px,
                        g.point.y_px,
                        px.len(),
                        worst
                    ));
                }
            }
        }
        // VaFR with its rings at the true eccentricity, and Eq. 3's in the buffer for any
        // gaze (the resident GPU frame's), whose off-screen texels are unshaded.
        for (name, config) in [("exact", exact_rings()), ("eq3-any-gaze", any_gaze_rings())] {
            for g in gazes(&d) {
                let m = build(Method::Vafr, &d, g, &config).unwrap();
                let (n, worst) = mapping_failures(&d, g, m.as_ref(), &px);
                if n > 0 {
                    report.push(format!(
                        "{} vafr --vafr-rings {name} gaze ({:.0},{:.0}): {n} uncovered, worst \
                         {worst:?}",
                        d.name, g.point.x_px, g.point.y_px,
                    ));
                }
            }
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}

fn exact_rings() -> MappingConfig {
    MappingConfig {
        vafr: VafrParams {
            rings: VafrRings::Exact,
            ..Default::default()
        },
        ..Default::default()
    }
}

fn any_gaze_rings() -> MappingConfig {
    MappingConfig {
        vafr: VafrParams {
            rings: VafrRings::Eq3AnyGaze,
            ..Default::default()
        },
        ..Default::default()
    }
}

#[test]
fn the_papers_fixed_60_degrees_fails_the_coverage_check() {
    let config = MappingConfig {
        vafr: VafrParams::paper(),
        ..Default::default()
    };
    for (d, interior) in presets() {
        let px = pixels(&d, interior);
        let mut failing = 0;
        for g in gazes(&d) {
            let m = build(Method::Vafr, &d, g, &config).unwrap();
            let (n, _) = mapping_failures(&d, g, m.as_ref(), &px);
            failing += (n > 0) as usize;
        }
        // Every corner gaze at least; at 8K even the centre (corners at 63.9°).
        assert!(failing >= 4, "{}: {failing} of 49 gazes fail", d.name);
        let centre = d.centre_gaze();
        let m = build(Method::Vafr, &d, centre, &config).unwrap();
        let (n, _) = mapping_failures(&d, centre, m.as_ref(), &px);
        assert!(
            n > 0,
            "{}: the centre gaze's corners lie beyond 60°",
            d.name
        );
    }
}

/// Sample buffers whose texels hold their own screen position `(x, y, 1)` (unshaded: 0).
fn position_buffers(m: &dyn FoveationMapping) -> SampleBuffers {
    let mut color = Vec::new();
    let mut depth = Vec::new();
    for (layer, size) in m.buffers().into_iter().enumerate() {
        let data: Vec<[f32; 3]> = (0..size.height as i64)
            .into_par_iter()
            .flat_map_iter(|j| (0..size.width as i64).map(move |i| (i, j)))
            .map(|(i, j)| match texel_point(m, layer as u32, i, j) {
                Some(q) => [q.x_px as f32, q.y_px as f32, 1.0],
                None => [0.0; 3],
            })
            .collect();
        color.push(Image::from_vec(size.width, size.height, data).unwrap());
        depth.push(Image::new(size.width, size.height, 1.0f32).unwrap());
    }
    SampleBuffers { color, depth }
}

/// Pixels whose reconstruction is not made from samples near them: weights not summing to
/// one (uncovered), or the weighted mean of the source positions farther than
/// [`MAX_SPACINGS`] spacings.
fn reconstruction_failures(d: &DisplayProfile, g: Gaze, config: &MappingConfig, m: Method) -> u64 {
    let m = build(m, d, g, config).unwrap();
    let frame = reconstruct(m.as_ref(), d, position_buffers(m.as_ref())).unwrap();
    let lut = SpacingLut::new(m.as_ref(), d, g);
    let ring = first_ring_px(m.as_ref(), m.polar_layout().as_ref());
    let w = d.width_px as usize;
    frame
        .color
        .data()
        .par_iter()
        .enumerate()
        .filter(|(k, c)| {
            let p = ScreenPoint::new((k % w) as f64 + 0.5, (k / w) as f64 + 0.5);
            let weight = c[2] as f64;
            if (weight - 1.0).abs() > 1e-3 {
                return true;
            }
            let mean = ScreenPoint::new(c[0] as f64 / weight, c[1] as f64 / weight);
            let far = |spacing: f64| mean.distance(p) > MAX_SPACINGS * spacing + 0.01;
            // The density spacing first (the local spacing is never smaller).
            far((lut.at(d.eccentricity(p, &g).0) as f64).max(1.0))
                && far(local_spacing_px(m.as_ref(), d, &g, &lut, ring, p))
        })
        .count() as u64
}

#[test]
fn the_reconstruction_never_stretches_a_ring_over_the_screen() {
    // The full reconstruction of every pixel, at the Vive Pro Eye, at the centre, a corner and
    // the off-centre gaze of issue 17 (1100, 1200), for every method.
    let d = DisplayProfile::preset("vive-pro-eye").unwrap();
    let config = MappingConfig::default();
    let mut report = Vec::new();
    for (gx, gy) in [(720.0, 800.0), (0.0, 0.0), (1100.0, 1200.0)] {
        let g = d.gaze(gx, gy).unwrap();
        for method in Method::ALL {
            let n = reconstruction_failures(&d, g, &config, method);
            if n > 0 {
                report.push(format!("{method} at ({gx},{gy}): {n} pixels"));
            }
        }
        // Every pixel reads shaded texels only, though off-screen ones are skipped.
        for (name, config) in [("exact", exact_rings()), ("eq3-any-gaze", any_gaze_rings())] {
            let n = reconstruction_failures(&d, g, &config, Method::Vafr);
            if n > 0 {
                report.push(format!(
                    "vafr --vafr-rings {name} at ({gx},{gy}): {n} pixels"
                ));
            }
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
    // Negative control: the paper's 60° buffer at the off-centre gaze leaves a large part of
    // the screen without samples.
    let paper = MappingConfig {
        vafr: VafrParams {
            max_eccentricity: Coverage::Fixed(Degrees(60.0)),
            ..VafrParams::eq3()
        },
        ..Default::default()
    };
    let g = d.gaze(1100.0, 1200.0).unwrap();
    let n = reconstruction_failures(&d, g, &paper, Method::Vafr);
    assert!(n > 10_000, "{n}");
}

#[test]
fn uncovered_pixels_are_black_not_the_outermost_ring() {
    let d = DisplayProfile::preset("vive-pro-eye").unwrap();
    let g = d.gaze(1100.0, 1200.0).unwrap();
    let m = build(
        Method::Vafr,
        &d,
        g,
        &MappingConfig {
            vafr: VafrParams::paper(),
            ..Default::default()
        },
    )
    .unwrap();
    let mut buffers = position_buffers(m.as_ref());
    for c in buffers.color[0].data_mut() {
        *c = [1.0, 1.0, 1.0];
    }
    let frame = reconstruct(m.as_ref(), &d, buffers).unwrap();
    for (x, y) in [(0.5, 0.5), (1439.5, 0.5), (0.5, 1599.5), (1100.5, 1200.5)] {
        let p = ScreenPoint::new(x, y);
        let c = *frame.color.get(x as u32, y as u32);
        let d_ = *frame.depth.get(x as u32, y as u32);
        if m.forward(p).is_some() {
            assert_eq!(c, [1.0; 3], "{x},{y}");
        } else {
            assert_eq!((c, d_), ([0.0; 3], f32::INFINITY), "{x},{y}");
        }
    }
    assert!(m.forward(ScreenPoint::new(0.5, 0.5)).is_none());
}
