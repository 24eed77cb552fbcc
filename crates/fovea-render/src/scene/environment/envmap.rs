//! Equirectangular (latitude-longitude) environment maps: radiance by direction with a
//! bilinear lookup, and importance sampling by luminance × solid angle through a 2D
//! piecewise-constant distribution (pbrt-v3, Pharr, Jakob and Humphreys 2016, Sec. 14.2.4
//! "Infinite area lights", whose weights are luminance × sin θ; the distribution is
//! `super::distribution`, pbrt-v4's `PiecewiseConstant2D`).
//!
//! **Orientation (Mitsuba's `envmap`, which is also OpenEXR's latitude-longitude layout).**
//! In the map's own frame +Y is up. A direction `d` has polar angle `θ = acos(d_y)` from +Y
//! and azimuth `φ = atan2(d_x, −d_z)`; the image coordinates are `u = φ / 2π` (wrapped to
//! `[0, 1)`, left to right) and `v = θ / π` (top to bottom), so
//! `d = (sin θ sin φ, cos θ, −sin θ cos φ)`: the top row is straight up, the bottom row
//! straight down, the left and right edges look along −Z, the image centre along +Z and
//! `u = 1/4` along +X. A `to_world` rotation ([`EnvMap::with_rotation`]) turns the map's
//! frame into the world's: `d_world = world_from_map · d_map`.
//!
//! **Lookup.** Pixel `(i, j)` holds the radiance at `uv = ((i + ½)/w, (j + ½)/h)`; between
//! centres the radiance is bilinear, wrapping around in `u` and clamped at the poles in `v`.
//!
//! **Sampling.** Pixel `(i, j)` covers `φ ∈ 2π [i, i+1)/w` and `θ ∈ π [j, j+1)/h`, the solid
//! angle `ΔΩ_j = (2π/w)(cos θ_j − cos θ_{j+1})` (∝ sin θ at the row's centre, pbrt-v3's
//! weight, but exact). It gets the weight `Y_max(i, j) · ΔΩ_j`, where `Y_max` is the largest
//! luminance (Rec. 709) of the 3 × 3 pixels around it: a bilinear lookup inside a pixel's
//! cell mixes its neighbours, so every direction with non-zero radiance keeps a non-zero
//! density. A sample `(x, y) ∈ [0, 1)²` of the 2D distribution picks the cell
//! `(⌊x w⌋, ⌊y h⌋)`; inside it `φ = 2π x` and `cos θ` is linear in `y` (uniform in solid
//! angle), so the density is constant per cell: `p(ω) = p(x, y) / (2π h (cos θ_j − cos
//! θ_{j+1}))` = `P(cell) / ΔΩ_cell`, with no singularity at the poles; a uniform map has
//! `p(ω) = 1/4π` exactly and `∫ p(ω) dω = 1` for every map. [`EnvMap::sample`],
//! [`EnvMap::pdf`] and [`EnvMap::invert`] agree on every direction.

use std::f32::consts::{PI, TAU};
use std::sync::Arc;

use glam::{Mat3, Vec2, Vec3};

use super::distribution::Distribution2D;
use super::EnvSample;
use crate::error::{RenderError, Result};

/// Most pixels an environment map may have: 8192 × 4096 (about 0.7 GB with its sampling
/// tables and the decoder's buffer).
pub const MAX_ENVMAP_PIXELS: u64 = 8192 * 4096;

/// Luminance of linear Rec. 709 RGB.
#[inline]
fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Image coordinates `(u, v) ∈ [0, 1)²` of a unit direction in the map's frame (see the module
/// header for the convention).
#[inline]
pub fn direction_to_uv(d: Vec3) -> Vec2 {
    let theta = d.y.clamp(-1.0, 1.0).acos();
    let phi = d.x.atan2(-d.z);
    let u = phi / TAU;
    let u = if u < 0.0 { u + 1.0 } else { u };
    Vec2::new(if u >= 1.0 { 0.0 } else { u }, theta / PI)
}

/// Unit direction in the map's frame of image coordinates `(u, v)`: `θ = π v`, `φ = 2π u`,
/// `d = (sin θ sin φ, cos θ, −sin θ cos φ)`.
#[inline]
pub fn uv_to_direction(uv: Vec2) -> Vec3 {
    let (st, ct) = (PI * uv.y).sin_cos();
    let (sp, cp) = (TAU * uv.x).sin_cos();
    Vec3::new(st * sp, ct, -st * cp)
}

/// The decoded image and its sampling tables (shared between clones).
#[derive(Debug)]
struct MapData {
    name: String,
    width: u32,
    height: u32,
    /// Linear radiance, row-major from the top row.
    pixels: Vec<Vec3>,
    distribution: Distribution2D,
    /// `cos(π j / h)` for `j = 0..=h`: the rows' edges.
    cos_edge: Vec<f32>,
    /// Solid-angle mean radiance, `(1/4π) Σ L_ij ΔΩ_ij`.
    mean: Vec3,
}

/// A latitude-longitude environment map in linear radiance (see the module header).
#[derive(Clone, Debug)]
pub struct EnvMap {
    data: Arc<MapData>,
    /// Multiplies every pixel (Mitsuba's `scale`).
    scale: f32,
    world_from_map: Mat3,
    map_from_world: Mat3,
}

impl EnvMap {
    /// A map from `width × height` linear radiance values, row-major from the top row
    /// (`v = 0`, straight up). Errors for a size that does not match, a side of 0, more than
    /// [`MAX_ENVMAP_PIXELS`] pixels, or a negative or non-finite value.
    pub fn new(name: &str, width: u32, height: u32, pixels: Vec<Vec3>) -> Result<Self> {
        let count = width as u64 * height as u64;
        if width == 0 || height == 0 || pixels.len() as u64 != count {
            return Err(RenderError::invalid(
                "environment map",
                format!("{name}: {width}x{height} with {} pixels", pixels.len()),
                "width · height pixels, both sides ≥ 1",
            ));
        }
        if count > MAX_ENVMAP_PIXELS {
            return Err(RenderError::ResourceLimit {
                what: format!("environment map {name}"),
                needed: format!("{width}x{height} pixels"),
                limit: format!("{MAX_ENVMAP_PIXELS} pixels (8192x4096)"),
            });
        }
        if let Some(k) = pixels
            .iter()
            .position(|p| !p.is_finite() || p.min_element() < 0.0)
        {
            return Err(RenderError::invalid(
                "environment map",
                format!(
                    "{name}: pixel ({}, {}) = {}",
                    k % width as usize,
                    k / width as usize,
                    pixels[k]
                ),
                "finite, non-negative radiance",
            ));
        }
        let (w, h) = (width as usize, height as usize);
        let lum: Vec<f32> = pixels.iter().map(|&p| luminance(p)).collect();
        let cos_edge: Vec<f32> = (0..=h)
            .map(|j| match j {
                0 => 1.0,
                j if j == h => -1.0,
                j => (PI * j as f32 / h as f32).cos(),
            })
            .collect();
        let mut func = vec![0.0f32; w * h];
        let mut mean = glam::DVec3::ZERO;
        for j in 0..h {
            // Solid angle of one pixel of this row (the common 2π/w left out of the weights).
            let dz = cos_edge[j] - cos_edge[j + 1];
            let d_omega = (TAU / w as f32) * dz;
            for i in 0..w {
                let mut y_max = 0.0f32;
                for dj in [-1i64, 0, 1] {
                    let jj = (j as i64 + dj).clamp(0, h as i64 - 1) as usize;
                    for di in [-1i64, 0, 1] {
                        let ii = (i as i64 + di).rem_euclid(w as i64) as usize;
                        y_max = y_max.max(lum[jj * w + ii]);
                    }
                }
                func[j * w + i] = y_max * dz;
                mean += pixels[j * w + i].as_dvec3() * d_omega as f64;
            }
        }
        let mean = (mean / (4.0 * std::f64::consts::PI)).as_vec3();
        Ok(Self {
            data: Arc::new(MapData {
                name: name.to_string(),
                width,
                height,
                pixels,
                distribution: Distribution2D::new(&func, w, h),
                cos_edge,
                mean,
            }),
            scale: 1.0,
            world_from_map: Mat3::IDENTITY,
            map_from_world: Mat3::IDENTITY,
        })
    }

    /// The map turned by `world_from_map` (a `to_world` transform's 3 × 3 part). Uniform scale
    /// is removed; a rotation, optionally mirrored, is accepted; shear or non-uniform scale is
    /// an error (it would change the density's Jacobian).
    pub fn with_rotation(mut self, world_from_map: Mat3) -> Result<Self> {
        let cols = [
            world_from_map.x_axis,
            world_from_map.y_axis,
            world_from_map.z_axis,
        ];
        let lens = cols.map(|c| c.length());
        let ok = cols.iter().all(|c| c.is_finite())
            && lens.iter().all(|&l| l > 1e-12)
            && (lens[0] - lens[1]).abs() < 1e-3 * lens[0]
            && (lens[0] - lens[2]).abs() < 1e-3 * lens[0];
        let n = [cols[0] / lens[0], cols[1] / lens[1], cols[2] / lens[2]];
        if !ok || n[0].dot(n[1]).abs() > 1e-3 || n[0].dot(n[2]).abs() > 1e-3 || {
            n[1].dot(n[2]).abs() > 1e-3
        } {
            return Err(RenderError::invalid(
                "environment map to_world",
                format!("{world_from_map}"),
                "a rotation (uniform scale and mirroring allowed; no shear or non-uniform scale)",
            ));
        }
        self.world_from_map = Mat3::from_cols(n[0], n[1], n[2]);
        self.map_from_world = self.world_from_map.transpose();
        Ok(self)
    }

    /// The map with every pixel multiplied by `factor` (finite, ≥ 0).
    pub fn scaled(mut self, factor: f32) -> Result<Self> {
        if !(factor.is_finite() && factor >= 0.0) {
            return Err(RenderError::invalid(
                "environment map scale",
                factor,
                "a finite number ≥ 0",
            ));
        }
        self.scale *= factor;
        Ok(self)
    }

    /// Multiplies every pixel by `factor` (no check: see [`Self::scaled`]).
    pub(crate) fn scale_by(&mut self, factor: f32) {
        self.scale *= factor;
    }

    /// Name (the file's name, or the one given to [`Self::new`]).
    pub fn name(&self) -> &str {
        &self.data.name
    }

    /// Width, pixels.
    pub fn width(&self) -> u32 {
        self.data.width
    }

    /// Height, pixels.
    pub fn height(&self) -> u32 {
        self.data.height
    }

    /// The map-to-world rotation.
    pub fn world_from_map(&self) -> Mat3 {
        self.world_from_map
    }

    /// The world-to-map rotation (the transpose of [`Self::world_from_map`]).
    pub fn map_from_world(&self) -> Mat3 {
        self.map_from_world
    }

    /// The factor every pixel is multiplied by on lookup.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The pixels, linear radiance before [`Self::scale`], row-major from the top row.
    pub fn pixels(&self) -> &[Vec3] {
        &self.data.pixels
    }

    /// The sampling distribution over image coordinates (module header).
    pub fn distribution(&self) -> &Distribution2D {
        &self.data.distribution
    }

    /// `cos(π j / h)` for `j = 0..=h`: the rows' edges (exactly 1 and −1 at the poles).
    pub fn cos_edges(&self) -> &[f32] {
        &self.data.cos_edge
    }

    /// Bilinear radiance at image coordinates `uv` (wraps in `u`, clamps in `v`).
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        let d = &*self.data;
        let (w, h) = (d.width as i64, d.height as i64);
        let x = uv.x * d.width as f32 - 0.5;
        let y = (uv.y * d.height as f32 - 0.5).clamp(0.0, (h - 1) as f32);
        if !(x.is_finite() && y.is_finite()) {
            return Vec3::ZERO;
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (xa, ya) = (x0 as i64, y0 as i64);
        let xa_w = xa.rem_euclid(w) as usize;
        let xb_w = (xa + 1).rem_euclid(w) as usize;
        let yb = (ya + 1).min(h - 1) as usize;
        let ya = ya as usize;
        let p = |x: usize, y: usize| d.pixels[y * d.width as usize + x];
        let top = p(xa_w, ya).lerp(p(xb_w, ya), fx);
        let bot = p(xa_w, yb).lerp(p(xb_w, yb), fx);
        top.lerp(bot, fy) * self.scale
    }

    /// Radiance arriving from the world direction `dir` (unit length; travelling along
    /// `−dir`).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let local = (self.map_from_world * dir).normalize_or_zero();
        if local == Vec3::ZERO {
            return Vec3::ZERO;
        }
        self.lookup(direction_to_uv(local))
    }

    /// Solid-angle mean radiance over the sphere, `(1/4π) ∫ L dω` (per pixel, exact cell solid
    /// angles).
    pub fn mean(&self) -> Vec3 {
        self.data.mean * self.scale
    }

    /// Row of the polar angle whose cosine is `z`, and where `z` lies in it (`0` at the row's
    /// top edge, `1` at its bottom edge).
    fn row_of(&self, z: f32) -> (usize, f32) {
        let d = &*self.data;
        let h = d.height as usize;
        let theta = z.clamp(-1.0, 1.0).acos();
        let j = ((theta / PI * h as f32) as usize).min(h - 1);
        let dz = d.cos_edge[j] - d.cos_edge[j + 1];
        let t = if dz > 0.0 {
            ((d.cos_edge[j] - z) / dz).clamp(0.0, 1.0)
        } else {
            0.5
        };
        (j, t)
    }

    /// A direction drawn with density proportional to the sampling weights (module header)
    /// from `u ∈ [0, 1)²`; `None` only for a degenerate (zero solid angle) row.
    pub fn sample(&self, u: [f32; 2]) -> Option<EnvSample> {
        let d = &*self.data;
        let h = d.height as usize;
        let (xy, pdf_xy) = d.distribution.sample(u);
        let y = xy[1] * h as f32;
        let j = (y as usize).min(h - 1);
        let t = (y - j as f32).clamp(0.0, 1.0);
        let dz = d.cos_edge[j] - d.cos_edge[j + 1];
        if !(pdf_xy > 0.0 && dz > 0.0) {
            return None;
        }
        let z = d.cos_edge[j] - t * dz;
        let st = (1.0 - z * z).max(0.0).sqrt();
        let (sp, cp) = (TAU * xy[0]).sin_cos();
        let local = Vec3::new(st * sp, z, -st * cp);
        Some(EnvSample {
            direction: (self.world_from_map * local).normalize(),
            radiance: self.lookup(direction_to_uv(local)),
            pdf_per_sr: pdf_xy / (TAU * h as f32 * dz),
        })
    }

    /// Solid-angle density of [`Self::sample`] at the world direction `dir` (unit length).
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let d = &*self.data;
        let local = (self.map_from_world * dir).normalize_or_zero();
        if local == Vec3::ZERO {
            return 0.0;
        }
        let h = d.height as usize;
        let (j, _) = self.row_of(local.y);
        let dz = d.cos_edge[j] - d.cos_edge[j + 1];
        if dz <= 0.0 {
            return 0.0;
        }
        // The density is constant per cell: look it up at the row's centre.
        let x = direction_to_uv(local).x;
        let y = (j as f32 + 0.5) / h as f32;
        d.distribution.pdf([x, y]) / (TAU * h as f32 * dz)
    }

    /// The `u ∈ [0, 1)²` that [`Self::sample`] maps to the world direction `dir`; `None` where
    /// the density is 0.
    pub fn invert(&self, dir: Vec3) -> Option<[f32; 2]> {
        let local = (self.map_from_world * dir).normalize_or_zero();
        if local == Vec3::ZERO {
            return None;
        }
        let h = self.data.height as f32;
        let (j, t) = self.row_of(local.y);
        let x = direction_to_uv(local).x;
        let y = ((j as f32 + t) / h).min(1.0 - f32::EPSILON);
        self.data.distribution.invert([x, y])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 32 × 16 map: a dim blue sky gradient, a dark ground and a small bright "sun".
    fn test_map() -> EnvMap {
        let (w, h) = (32u32, 16u32);
        let pixels = (0..w * h)
            .map(|k| {
                let (i, j) = (k % w, k / w);
                if (i, j) == (9, 4) {
                    Vec3::new(200.0, 180.0, 150.0)
                } else if j < h / 2 {
                    Vec3::new(0.3, 0.4, 0.8) * (1.0 - j as f32 / h as f32)
                } else {
                    Vec3::splat(0.05)
                }
            })
            .collect();
        EnvMap::new("test", w, h, pixels).unwrap()
    }

    fn sphere_grid(n: usize) -> impl Iterator<Item = (Vec3, f32)> {
        // Midpoint rule in (cos θ, φ): every point stands for 4π / n² steradians.
        (0..n * n).map(move |k| {
            let (i, j) = (k % n, k / n);
            let ct = 1.0 - 2.0 * (j as f32 + 0.5) / n as f32;
            let phi = TAU * (i as f32 + 0.5) / n as f32;
            let st = (1.0 - ct * ct).sqrt();
            (
                Vec3::new(st * phi.cos(), ct, st * phi.sin()),
                4.0 * PI / (n * n) as f32,
            )
        })
    }

    /// A midpoint rule aligned with the map's pixel cells (`m × m` points per cell, uniform in
    /// `φ` and `cos θ`), in the map's frame: the density is constant per cell, so it integrates
    /// exactly up to rounding.
    fn cell_grid(w: u32, h: u32, m: u32) -> Vec<(Vec3, f32)> {
        let mut out = Vec::new();
        for j in 0..h {
            let z0 = (PI * j as f32 / h as f32).cos();
            let z1 = (PI * (j + 1) as f32 / h as f32).cos();
            for a in 0..m {
                let z = z0 + (z1 - z0) * (a as f32 + 0.5) / m as f32;
                let st = (1.0 - z * z).max(0.0).sqrt();
                for b in 0..w * m {
                    let phi = TAU * (b as f32 + 0.5) / (w * m) as f32;
                    let dw = (z0 - z1) / m as f32 * TAU / (w * m) as f32;
                    out.push((Vec3::new(st * phi.sin(), z, -st * phi.cos()), dw));
                }
            }
        }
        out
    }

    #[test]
    fn directions_and_image_coordinates_round_trip_in_mitsubas_orientation() {
        // The convention's landmarks.
        let close = |a: Vec2, b: Vec2| (a - b).abs().max_element() < 1e-6;
        assert!(close(direction_to_uv(Vec3::NEG_Z), Vec2::new(0.0, 0.5)));
        assert!(close(direction_to_uv(Vec3::X), Vec2::new(0.25, 0.5)));
        assert!(close(direction_to_uv(Vec3::Z), Vec2::new(0.5, 0.5)));
        assert!(close(direction_to_uv(Vec3::NEG_X), Vec2::new(0.75, 0.5)));
        assert!(direction_to_uv(Vec3::Y).y.abs() < 1e-6);
        assert!((direction_to_uv(Vec3::NEG_Y).y - 1.0).abs() < 1e-6);
        for (d, _) in sphere_grid(64) {
            let uv = direction_to_uv(d);
            assert!((0.0..1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y));
            let back = uv_to_direction(uv);
            assert!((back - d).length() < 1e-5, "{d} → {uv} → {back}");
        }
    }

    #[test]
    fn sample_and_pdf_agree_and_the_density_integrates_to_one() {
        let r = Mat3::from_rotation_x(0.4) * Mat3::from_rotation_y(1.1);
        let turned = test_map().with_rotation(r).unwrap();
        for (map, world_from_map) in [(test_map(), Mat3::IDENTITY), (turned, r)] {
            // ∫ p dω over the map's cells (exact for a per-cell constant density).
            let grid = cell_grid(32, 16, 3);
            let integral: f64 = grid
                .iter()
                .map(|&(d, dw)| (map.pdf(world_from_map * d) * dw) as f64)
                .sum();
            assert!((integral - 1.0).abs() < 1e-4, "∫p = {integral}");
            // And over a grid that ignores the cells (discontinuities cost ~0.5 %).
            let integral: f32 = sphere_grid(1024).map(|(d, dw)| map.pdf(d) * dw).sum();
            assert!((integral - 1.0).abs() < 1e-2, "∫p = {integral}");
            for k in 0..4096 {
                let u = [
                    ((k % 64) as f32 + 0.37) / 64.0,
                    ((k / 64) as f32 + 0.61) / 64.0,
                ];
                let s = map.sample(u).unwrap();
                assert!((s.direction.length() - 1.0).abs() < 1e-5);
                let p = map.pdf(s.direction);
                assert!(
                    (p - s.pdf_per_sr).abs() <= 2e-3 * p.max(1e-3),
                    "u {u:?}: sample pdf {} vs pdf {p}",
                    s.pdf_per_sr
                );
                assert!((s.radiance - map.radiance(s.direction)).abs().max_element() < 1e-2);
                let back = map.invert(s.direction).unwrap();
                assert!((back[0] - u[0]).abs() < 2e-3 && (back[1] - u[1]).abs() < 2e-3);
            }
        }
    }

    #[test]
    fn samples_follow_the_pdf_in_a_histogram() {
        // 8 × 4 solid-angle bins in (φ, cos θ); expected share = ∫_bin p dω.
        let map = test_map();
        let (bx, by) = (8usize, 4usize);
        let bin_of = |d: Vec3| {
            let phi = d.z.atan2(d.x).rem_euclid(TAU);
            let i = ((phi / TAU) * bx as f32) as usize;
            let j = (((1.0 - d.y) / 2.0) * by as f32) as usize;
            i.min(bx - 1) + bx * j.min(by - 1)
        };
        let mut expected = vec![0.0f64; bx * by];
        for (d, dw) in sphere_grid(1024) {
            expected[bin_of(d)] += (map.pdf(d) * dw) as f64;
        }
        let n = 400usize;
        let mut hist = vec![0u32; bx * by];
        let mut rng = 12345u64;
        for _ in 0..n * n {
            let mut next = || {
                rng = fovea_core::math::mix64(rng);
                (rng >> 40) as f32 / (1u64 << 24) as f32
            };
            let s = map.sample([next(), next()]).unwrap();
            hist[bin_of(s.direction)] += 1;
        }
        for k in 0..bx * by {
            let got = hist[k] as f64 / (n * n) as f64;
            // 4σ of a binomial share plus the grid's quadrature error.
            let sigma = (expected[k] * (1.0 - expected[k]) / (n * n) as f64).sqrt();
            assert!(
                (got - expected[k]).abs() < 4.0 * sigma + 2e-3,
                "bin {k}: {got} vs {}",
                expected[k]
            );
        }
    }

    #[test]
    fn a_uniform_map_samples_the_sphere_uniformly_and_its_mean_is_its_value() {
        let l = Vec3::new(0.5, 1.0, 2.0);
        let map = EnvMap::new("uniform", 16, 8, vec![l; 128]).unwrap();
        assert!((map.mean() - l).abs().max_element() < 1e-5);
        for k in 0..256 {
            let u = [
                ((k % 16) as f32 + 0.5) / 16.0,
                ((k / 16) as f32 + 0.5) / 16.0,
            ];
            let s = map.sample(u).unwrap();
            let uniform = 1.0 / (4.0 * PI);
            assert!(
                (s.pdf_per_sr - uniform).abs() < 1e-4 * uniform,
                "{} vs {uniform}",
                s.pdf_per_sr
            );
            assert!((map.pdf(s.direction) - uniform).abs() < 1e-4 * uniform);
            assert!((s.radiance - l).abs().max_element() < 1e-5);
        }
        // The poles too.
        assert!((map.pdf(Vec3::Y) - 1.0 / (4.0 * PI)).abs() < 1e-6);
        // Integrated over the sphere the density is 1/(4π) on average.
        let integral: f32 = sphere_grid(512).map(|(d, dw)| map.pdf(d) * dw).sum();
        assert!((integral - 1.0).abs() < 1e-4, "{integral}");
        // Scaling multiplies the radiance, not the density.
        let twice = map.clone().scaled(2.0).unwrap();
        assert!((twice.radiance(Vec3::X) - 2.0 * l).abs().max_element() < 1e-5);
        assert_eq!(twice.pdf(Vec3::X), map.pdf(Vec3::X));
        assert!(map.clone().scaled(f32::NAN).is_err());
    }

    #[test]
    fn bad_maps_and_transforms_are_refused() {
        assert!(EnvMap::new("a", 2, 2, vec![Vec3::ONE; 3]).is_err());
        assert!(EnvMap::new("a", 0, 2, vec![]).is_err());
        let mut px = vec![Vec3::ONE; 4];
        px[1] = Vec3::new(f32::NAN, 0.0, 0.0);
        let e = EnvMap::new("a", 2, 2, px).unwrap_err().to_string();
        assert!(e.contains("(1, 0)"), "{e}");
        assert!(EnvMap::new("a", 2, 2, vec![-Vec3::ONE; 4]).is_err());
        let m = EnvMap::new("a", 2, 2, vec![Vec3::ONE; 4]).unwrap();
        assert!(m
            .clone()
            .with_rotation(Mat3::from_diagonal(Vec3::new(1.0, 2.0, 1.0)))
            .is_err());
        assert!(m.clone().with_rotation(Mat3::ZERO).is_err());
        assert!(m
            .with_rotation(Mat3::from_diagonal(Vec3::splat(3.0)))
            .is_ok());
    }

    #[test]
    fn a_rotation_turns_the_lookup() {
        let map = test_map();
        let r = Mat3::from_rotation_y(0.7);
        let turned = map.clone().with_rotation(r).unwrap();
        for (d, _) in sphere_grid(16) {
            let a = turned.radiance(r * d);
            let b = map.radiance(d);
            assert!((a - b).abs().max_element() < 1e-3 * b.max_element().max(1.0));
        }
    }
}
