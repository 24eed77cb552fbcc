//! The environment: radiance arriving from infinitely far away, by direction. Rays that
//! escape the scene see it (the background of primary rays, the escaped bounces of the path
//! tracer), and direct shading gathers it through shadow rays (`crate::shade`, "Environment
//! light").
//!
//! * [`Environment::Constant`]: the same radiance from every direction (Mitsuba `constant`,
//!   `sky`/`sunsky`, the default of glTF/OBJ/PLY scenes).
//! * [`Environment::Map`]: an equirectangular image ([`EnvMap`], module `envmap`: Mitsuba's
//!   lat-long orientation, bilinear lookup, importance sampling by luminance × solid angle),
//!   read from OpenEXR, Radiance HDR (module `rgbe`, one scanline at a time), PNG or JPEG
//!   (module `file`), reduced to fit the memory limit (module `shrink`).
//!
//! Every variant offers the same four queries: [`Environment::radiance`] by direction,
//! [`Environment::mean`] over the sphere, [`Environment::sample`] (a direction with its
//! radiance and solid-angle density) and [`Environment::pdf`], which agrees with `sample`.
//! A constant environment samples the sphere uniformly (`p = 1/4π`); shading samples it by
//! the cosine instead, which is exact for a constant.

use std::f32::consts::{PI, TAU};

use glam::Vec3;

pub mod distribution;
pub mod envmap;
pub mod file;
pub mod rgbe;
pub mod shrink;

pub use envmap::{EnvMap, MAX_ENVMAP_PIXELS};

/// One direction drawn from an environment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvSample {
    /// Unit direction towards the environment (world space).
    pub direction: Vec3,
    /// Radiance arriving from `direction`, linear RGB.
    pub radiance: Vec3,
    /// Density of `direction`, per steradian.
    pub pdf_per_sr: f32,
}

/// Radiance from infinitely far away, by direction (see the module header).
#[derive(Clone, Debug)]
pub enum Environment {
    /// The same radiance (linear RGB) from every direction.
    Constant(Vec3),
    /// A latitude-longitude map.
    Map(EnvMap),
}

impl Default for Environment {
    /// Black.
    fn default() -> Self {
        Environment::Constant(Vec3::ZERO)
    }
}

impl From<Vec3> for Environment {
    fn from(v: Vec3) -> Self {
        Environment::Constant(v)
    }
}

impl std::ops::MulAssign<f32> for Environment {
    /// Multiplies the radiance (a map's density is unchanged).
    fn mul_assign(&mut self, factor: f32) {
        match self {
            Environment::Constant(v) => *v *= factor,
            Environment::Map(m) => m.scale_by(factor),
        }
    }
}

impl Environment {
    /// Radiance arriving from the world direction `dir` (unit length).
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        match self {
            Environment::Constant(v) => *v,
            Environment::Map(m) => m.radiance(dir),
        }
    }

    /// Mean radiance over the sphere of directions, `(1/4π) ∫ L dω`.
    pub fn mean(&self) -> Vec3 {
        match self {
            Environment::Constant(v) => *v,
            Environment::Map(m) => m.mean(),
        }
    }

    /// Whether no direction carries radiance (a black constant; a map counts as lit).
    pub fn is_black(&self) -> bool {
        match self {
            Environment::Constant(v) => v.max_element() <= 0.0,
            Environment::Map(m) => m.mean().max_element() <= 0.0,
        }
    }

    /// A direction from `u ∈ [0, 1)²`: uniform over the sphere for a constant (`p = 1/4π`),
    /// by the map's weights for a map. `None` when the map cannot produce one.
    pub fn sample(&self, u: [f32; 2]) -> Option<EnvSample> {
        match self {
            Environment::Constant(v) => {
                // Archimedes: z uniform in [−1, 1], φ uniform.
                let z = 1.0 - 2.0 * u[0];
                let r = (1.0 - z * z).max(0.0).sqrt();
                let (s, c) = (TAU * u[1]).sin_cos();
                Some(EnvSample {
                    direction: Vec3::new(r * c, z, r * s),
                    radiance: *v,
                    pdf_per_sr: 1.0 / (4.0 * PI),
                })
            }
            Environment::Map(m) => m.sample(u),
        }
    }

    /// Solid-angle density of [`Self::sample`] at the world direction `dir` (unit length).
    pub fn pdf(&self, dir: Vec3) -> f32 {
        match self {
            Environment::Constant(_) => 1.0 / (4.0 * PI),
            Environment::Map(m) => m.pdf(dir),
        }
    }

    /// The constant, if it is one.
    pub fn as_constant(&self) -> Option<Vec3> {
        match self {
            Environment::Constant(v) => Some(*v),
            Environment::Map(_) => None,
        }
    }

    /// The map, if it is one.
    pub fn as_map(&self) -> Option<&EnvMap> {
        match self {
            Environment::Constant(_) => None,
            Environment::Map(m) => Some(m),
        }
    }

    /// Whether the radiance is finite and non-negative everywhere (maps are checked when
    /// built; a constant here).
    pub fn is_valid(&self) -> bool {
        match self {
            Environment::Constant(v) => v.is_finite() && v.min_element() >= 0.0,
            Environment::Map(m) => m.mean().is_finite() && m.mean().min_element() >= 0.0,
        }
    }

    /// A one-line description for messages and statistics: `constant [r, g, b]` or
    /// `map NAME WxH (mean [r, g, b])`.
    pub fn describe(&self) -> String {
        let v3 = |v: Vec3| format!("[{:.3}, {:.3}, {:.3}]", v.x, v.y, v.z);
        match self {
            Environment::Constant(v) => format!("constant {}", v3(*v)),
            Environment::Map(m) => format!(
                "map {} {}x{} (mean {})",
                m.name(),
                m.width(),
                m.height(),
                v3(m.mean())
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_samples_the_sphere_uniformly() {
        let env = Environment::Constant(Vec3::new(1.0, 2.0, 3.0));
        let mut mean_dir = Vec3::ZERO;
        let n = 64;
        for i in 0..n {
            for j in 0..n {
                let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
                let s = env.sample(u).unwrap();
                assert!((s.direction.length() - 1.0).abs() < 1e-5);
                assert_eq!(s.pdf_per_sr, env.pdf(s.direction));
                assert_eq!(s.radiance, env.radiance(s.direction));
                mean_dir += s.direction / (n * n) as f32;
            }
        }
        assert!(mean_dir.length() < 1e-3, "{mean_dir}");
        assert_eq!(env.mean(), Vec3::new(1.0, 2.0, 3.0));
        let mut e = env.clone();
        e *= 2.0;
        assert_eq!(e.mean(), Vec3::new(2.0, 4.0, 6.0));
        assert!(!e.is_black() && Environment::default().is_black());
        assert!(!Environment::Constant(Vec3::splat(f32::NAN)).is_valid());
    }
}
