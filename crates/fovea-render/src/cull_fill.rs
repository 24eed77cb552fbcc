//! Rebuilding the samples that DOF-aware culling skipped (`crate::dof`), in the sample buffer,
//! before anti-aliasing, reconstruction and blur.
//!
//! A culled sample was traced: its position, normal and material are known; only its shadow
//! rays (or paths) were skipped. What needs no rays is kept per sample as `offset` and `basis`
//! ([`crate::shade::culled_basis`]): in direct shading `offset` = emission + ambient and
//! `basis` = the unshadowed direct light, so a shaded sample's ratio
//! `r = (L − offset)/basis` is the lights' visibility (the ratio estimator of Heitz et al.
//! 2018); in path tracing the basis is the albedo. A culled sample gets
//! `offset + basis · r̃`, with `r̃` taken from shaded samples of the same surface:
//!
//! 1. the depth-weighted mean of the shaded samples within [`NEIGHBOUR_RADIUS`] buffer pixels
//!    whose depth is within [`SAME_SURFACE`] (relative) of its own — so visibility is not
//!    borrowed across a silhouette from another object;
//! 2. where there is none, the pull-push fill of all shaded ratios (Gortler et al. 1996).
//!
//! In direct shading with at most 64 lights it goes one step further: each shaded sample
//! records which lights reached it, each culled sample keeps its unshadowed contribution from
//! every light (no rays), and a culled sample gets `offset + Σ_l U_l · v̄_l`, with `v̄_l` the
//! weighted share of its same-surface neighbours that light `l` reached. A scalar ratio mixes
//! the lights, which is wrong on glossy surfaces where one light's highlight dominates and
//! another light is occluded; per light it is not. The occluded environment light is one more
//! term with a fractional visibility: a shaded sample records the ratio (per channel) of its
//! environment light to the no-ray estimate `E_u` (`crate::shade::culled_env_basis`), and a
//! culled sample adds `E_u · ē`, with `ē` its same-surface neighbours' weighted mean ratio.
//!
//! Texture and shading detail therefore survive culling; only shadow edges are interpolated.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use fovea_core::Image;
use fovea_post::pull_push::pull_push;
use fovea_post::Rgb;

use crate::error::Result;
use crate::shade::{
    culled_basis, culled_env_basis, direct_per_light, direct_with_visibility, environment_light,
    shade, EnvLight, RayCounts, ShadingMode,
};
use crate::trace::GSample;
use crate::world::World;

/// What culling keeps of one sample to rebuild it or its neighbours.
#[derive(Clone, Debug, Default)]
pub struct SampleCull {
    /// Radiance without shading (`shade::culled_basis`).
    pub offset: Vec3,
    /// What the ratio multiplies (`shade::culled_basis`).
    pub basis: Vec3,
    /// Shaded samples: the lights that reached it (bit per light, direct shading).
    pub visible: u64,
    /// Culled samples: each light's unshadowed contribution (direct shading, ≤ 64 lights).
    pub lights: Option<Vec<(u32, Vec3)>>,
    /// Direct shading, ≤ 64 lights, occluded environment light: for a shaded sample its
    /// environment light over the no-ray estimate (per channel), for a culled sample the
    /// no-ray estimate itself.
    pub env: Vec3,
}

/// Shades `g` (when `keep`) or records what rebuilds it later; returns the radiance of a
/// shaded sample. Direct shading with at most 64 lights records per-light visibility.
pub fn shade_or_cull(
    world: &World,
    g: &GSample,
    mode: ShadingMode,
    keep: bool,
    key: u64,
    counts: &mut RayCounts,
) -> (Option<Vec3>, SampleCull) {
    let (offset, basis) = culled_basis(world, g, mode);
    let per_light = mode.is_direct() && world.lights.len() <= 64;
    let env_basis = culled_env_basis(world, g, mode);
    let info = |visible, lights, env| SampleCull {
        offset,
        basis,
        visible,
        lights,
        env,
    };
    if !keep {
        return (
            None,
            info(0, per_light.then(|| direct_per_light(world, g)), env_basis),
        );
    }
    if per_light {
        let (direct, visible) = direct_with_visibility(world, g, counts);
        // The unshadowed ambient term is part of `offset` already.
        let env = match mode {
            ShadingMode::Direct {
                env_light: l @ EnvLight::Occluded { .. },
            } => environment_light(world, g, l, key, counts),
            _ => Vec3::ZERO,
        };
        let ratio = Vec3::from_array([0, 1, 2].map(|ch| {
            if env_basis[ch] > 0.0 {
                env[ch] / env_basis[ch].max(MIN_BASIS)
            } else {
                0.0
            }
        }));
        return (Some(offset + direct + env), info(visible, None, ratio));
    }
    (
        Some(shade(world, g, mode, key, counts)),
        info(0, None, Vec3::ZERO),
    )
}

/// Smallest basis value (per channel) a shaded sample's radiance is divided by.
pub const MIN_BASIS: f32 = 0.02;
/// Buffer pixels searched around a culled sample for shaded samples of its surface.
pub const NEIGHBOUR_RADIUS: i32 = 2;
/// Relative depth difference under which two samples count as the same surface.
pub const SAME_SURFACE: f32 = 0.02;

/// The buffers of one layer that rebuild culled samples.
pub struct CullBuffers {
    /// 1: shaded surface sample; 2: culled surface sample; 0: neither (a miss, or no sample).
    pub state: Image<u8>,
    /// The radiance every surface sample gets without shading.
    pub offset: Image<Rgb>,
    /// What the smooth ratio multiplies.
    pub basis: Image<Rgb>,
    /// Per shaded sample, the lights that reached it.
    pub visible: Image<u64>,
    /// Per culled sample (by index in the buffer), each light's unshadowed contribution.
    pub lights: HashMap<usize, Vec<(u32, Vec3)>>,
    /// Per sample, the environment term of [`SampleCull::env`].
    pub env: Image<Rgb>,
}

impl CullBuffers {
    /// Empty buffers for a `w × h` layer.
    pub fn new(w: u32, h: u32) -> Result<Self> {
        Ok(Self {
            state: Image::new(w, h, 0u8)?,
            offset: Image::new(w, h, [0.0f32; 3])?,
            basis: Image::new(w, h, [0.0f32; 3])?,
            visible: Image::new(w, h, 0u64)?,
            lights: HashMap::new(),
            env: Image::new(w, h, [0.0f32; 3])?,
        })
    }

    /// Records sample `index` (1 shaded, 2 culled, 0 neither).
    pub fn record(&mut self, index: usize, state: u8, info: SampleCull) {
        self.state.data_mut()[index] = state;
        self.offset.data_mut()[index] = info.offset.to_array();
        self.basis.data_mut()[index] = info.basis.to_array();
        self.visible.data_mut()[index] = info.visible;
        self.env.data_mut()[index] = info.env.to_array();
        if let Some(l) = info.lights {
            self.lights.insert(index, l);
        }
    }
}

/// Fills the culled samples of a layer's `color` (see the module header); `depth` is the
/// layer's view depth.
pub fn fill_culled(color: &Image<Rgb>, depth: &Image<f32>, cb: &CullBuffers) -> Result<Image<Rgb>> {
    let (w, h) = (color.width(), color.height());
    let ratio: Vec<Rgb> = color
        .data()
        .par_iter()
        .zip(cb.offset.data().par_iter().zip(cb.basis.data().par_iter()))
        .map(|(&c, (&o, &b))| [0, 1, 2].map(|ch| (c[ch] - o[ch]) / b[ch].max(MIN_BASIS)))
        .collect();
    let usable: Vec<bool> = cb
        .state
        .data()
        .iter()
        .zip(cb.basis.data())
        .map(|(&s, b)| s == 1 && b.iter().any(|&v| v >= MIN_BASIS))
        .collect();
    let ratio = Image::from_vec(w, h, ratio)?;
    let usable = Image::from_vec(w, h, usable)?;
    let filled = pull_push(&ratio, &usable)?;
    let mut out = color.clone();
    out.data_mut()
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            let y = y as u32;
            for (x, o) in row.iter_mut().enumerate() {
                let x = x as u32;
                if *cb.state.get(x, y) != 2 {
                    continue;
                }
                let d = *depth.get(x, y);
                let off = cb.offset.get(x, y);
                let index = y as usize * w as usize + x as usize;
                if let Some(lights) = cb.lights.get(&index) {
                    if let Some((v, env)) = per_light_visibility(cb, depth, x, y, d, lights) {
                        *o = *off;
                        for ((_, u), v) in lights.iter().zip(v) {
                            for ch in 0..3 {
                                o[ch] += u[ch] * v;
                            }
                        }
                        let env_basis = cb.env.get(x, y);
                        for ch in 0..3 {
                            o[ch] += env_basis[ch] * env[ch];
                        }
                        continue;
                    }
                }
                let r = same_surface_ratio(&ratio, &usable, depth, x, y, d)
                    .unwrap_or(*filled.get(x, y));
                let b = cb.basis.get(x, y);
                *o = [0, 1, 2].map(|ch| off[ch] + r[ch].max(0.0) * b[ch]);
            }
        });
    Ok(out)
}

/// For each of `lights`, the weighted share of the shaded same-surface samples near `(x, y)`
/// that it reached, and their weighted mean environment ratio (weights `1/(1 + distance²)`);
/// `None` when there is no such sample.
fn per_light_visibility(
    cb: &CullBuffers,
    depth: &Image<f32>,
    x: u32,
    y: u32,
    d: f32,
    lights: &[(u32, Vec3)],
) -> Option<(Vec<f32>, Rgb)> {
    let (w, h) = (cb.state.width() as i32, cb.state.height() as i32);
    let mut acc = vec![0.0f32; lights.len()];
    let mut env = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for dy in -NEIGHBOUR_RADIUS..=NEIGHBOUR_RADIUS {
        for dx in -NEIGHBOUR_RADIUS..=NEIGHBOUR_RADIUS {
            let (nx, ny) = (x as i32 + dx, y as i32 + dy);
            if nx < 0 || ny < 0 || nx >= w || ny >= h {
                continue;
            }
            let (nx, ny) = (nx as u32, ny as u32);
            if *cb.state.get(nx, ny) != 1 || (depth.get(nx, ny) - d).abs() > SAME_SURFACE * d {
                continue;
            }
            let wt = 1.0 / (1.0 + (dx * dx + dy * dy) as f32);
            let mask = *cb.visible.get(nx, ny);
            for (a, (l, _)) in acc.iter_mut().zip(lights) {
                if mask & (1 << l) != 0 {
                    *a += wt;
                }
            }
            let r = cb.env.get(nx, ny);
            for ch in 0..3 {
                env[ch] += wt * r[ch];
            }
            wsum += wt;
        }
    }
    (wsum > 0.0).then(|| {
        (
            acc.into_iter().map(|a| a / wsum).collect(),
            env.map(|e| e / wsum),
        )
    })
}

/// The mean ratio of the usable samples near `(x, y)` whose depth is within
/// [`SAME_SURFACE`] of `d`, weighted by `1/(1 + distance²)`; `None` when there is none.
fn same_surface_ratio(
    ratio: &Image<Rgb>,
    usable: &Image<bool>,
    depth: &Image<f32>,
    x: u32,
    y: u32,
    d: f32,
) -> Option<Rgb> {
    let (w, h) = (ratio.width() as i32, ratio.height() as i32);
    let mut acc = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for dy in -NEIGHBOUR_RADIUS..=NEIGHBOUR_RADIUS {
        for dx in -NEIGHBOUR_RADIUS..=NEIGHBOUR_RADIUS {
            let (nx, ny) = (x as i32 + dx, y as i32 + dy);
            if nx < 0 || ny < 0 || nx >= w || ny >= h {
                continue;
            }
            let (nx, ny) = (nx as u32, ny as u32);
            if !*usable.get(nx, ny) || (depth.get(nx, ny) - d).abs() > SAME_SURFACE * d {
                continue;
            }
            let wt = 1.0 / (1.0 + (dx * dx + dy * dy) as f32);
            let r = ratio.get(nx, ny);
            for ch in 0..3 {
                acc[ch] += wt * r[ch];
            }
            wsum += wt;
        }
    }
    (wsum > 0.0).then(|| acc.map(|a| a / wsum))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two surfaces side by side, lit differently; a culled sample on each takes its own
    /// surface's visibility, and texture (basis) detail is kept.
    #[test]
    fn culled_samples_take_their_own_surfaces_visibility() {
        let (w, h) = (8u32, 4u32);
        let left = |x: u32| x < 4;
        let depth = Image::from_vec(
            w,
            h,
            (0..w * h)
                .map(|k| if left(k % w) { 1.0 } else { 3.0 })
                .collect(),
        )
        .unwrap();
        // Visibility 1 on the left surface, 0.25 on the right; the basis varies per sample.
        let basis: Vec<Rgb> = (0..w * h)
            .map(|k| [0.5 + 0.05 * (k % 5) as f32; 3])
            .collect();
        let vis = |k: u32| if left(k % w) { 1.0 } else { 0.25 };
        let color: Vec<Rgb> = (0..w * h)
            .map(|k| basis[k as usize].map(|b| 0.1 + b * vis(k)))
            .collect();
        let mut state = vec![1u8; (w * h) as usize];
        // Cull one sample either side of the silhouette.
        state[(w + 3) as usize] = 2;
        state[(w + 4) as usize] = 2;
        let cb = CullBuffers {
            state: Image::from_vec(w, h, state).unwrap(),
            offset: Image::new(w, h, [0.1f32; 3]).unwrap(),
            basis: Image::from_vec(w, h, basis).unwrap(),
            ..CullBuffers::new(w, h).unwrap()
        };
        let truth = Image::from_vec(w, h, color.clone()).unwrap();
        let mut culled = color;
        culled[(w + 3) as usize] = [0.0; 3];
        culled[(w + 4) as usize] = [0.0; 3];
        let out = fill_culled(&Image::from_vec(w, h, culled).unwrap(), &depth, &cb).unwrap();
        for k in [w + 3, w + 4] {
            let (x, y) = (k % w, k / w);
            for ch in 0..3 {
                assert!(
                    (out.get(x, y)[ch] - truth.get(x, y)[ch]).abs() < 1e-5,
                    "{k}: {:?} vs {:?}",
                    out.get(x, y),
                    truth.get(x, y)
                );
            }
        }
        // Shaded samples are untouched.
        assert_eq!(out.get(0, 0), truth.get(0, 0));
    }
}
