//! The LaFR mapping (Shi et al., in VaFR's form: Eq. 15 on KFR's kernel log-polar frame, Eq. 1)
//! as the uniform block of `shaders/lafr_mapping.wgsl`: every number the shader uses, computed
//! here in f64 from the `fovea_core` mapping's geometry and kernel constants and rounded to f32
//! once.

use bytemuck::{Pod, Zeroable};
use fovea_core::mapping::Lafr;

use super::vafr::split_f64;
use crate::shaders::ShaderSource;

/// The module: forward and inverse entry points, [`LafrUniform`] at binding 0.
pub const SHADER: ShaderSource = ShaderSource {
    file: "lafr_mapping.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/lafr_mapping.wgsl")
    ),
    entry_points: &["forward", "inverse"],
    uniform: ("LafrParams", std::mem::size_of::<LafrUniform>()),
};

/// The uniform block `LafrParams` of `lafr_mapping.wgsl` (same field order; see there).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct LafrUniform {
    /// Gaze, f32 high part, pixels.
    pub gaze_hi: [f32; 2],
    /// Gaze, f32 low part, pixels.
    pub gaze_lo: [f32; 2],
    /// `ln L`.
    pub ln_l: f32,
    /// Outer radius of the forward mapping, pixels.
    pub r_max_px: f32,
    /// `L = exp(ln L)`, pixels.
    pub l_px: f32,
    /// `W/δ`, buffer pixels.
    pub width: f32,
    /// `H/δ`, buffer pixels.
    pub height: f32,
    /// LaFR's exponent `F`.
    pub f: f32,
    /// `1/F`.
    pub inv_f: f32,
    /// `ln(1 − F)`.
    pub ln_one_minus_f: f32,
    /// `1/(1 − F)`.
    pub inv_one_minus_f: f32,
    /// `Z_ef`.
    pub z_ef: f32,
    /// `1 − Z_ef`.
    pub one_minus_z_ef: f32,
    /// `U_ef`.
    pub u_ef: f32,
    /// `1 − U_ef`.
    pub one_minus_u_ef: f32,
    /// The periphery's exponent `k = β/0.7`.
    pub k: f32,
    /// `1/k`.
    pub inv_k: f32,
    /// `4/π`.
    pub four_over_pi: f32,
    /// `1/8` of a turn (`π/4` per unit of `1 − q`).
    pub eighth_turn: f32,
    /// 2π.
    pub rad_per_turn: f32,
    /// 1/(2π).
    pub turns_per_rad: f32,
    /// Padding to 16 bytes.
    pub pad: u32,
}

impl LafrUniform {
    /// The block for `lafr`.
    pub fn new(lafr: &Lafr) -> Self {
        let g = lafr.geometry();
        let c = lafr.kernel_constants();
        let (gx_hi, gx_lo) = split_f64(g.gaze.x_px);
        let (gy_hi, gy_lo) = split_f64(g.gaze.y_px);
        let pi = std::f64::consts::PI;
        Self {
            gaze_hi: [gx_hi, gy_hi],
            gaze_lo: [gx_lo, gy_lo],
            ln_l: g.ln_l as f32,
            r_max_px: g.max_radius_px as f32,
            l_px: g.ln_l.exp() as f32,
            width: g.width as f32,
            height: g.height as f32,
            f: c.f as f32,
            inv_f: (1.0 / c.f) as f32,
            ln_one_minus_f: (1.0 - c.f).ln() as f32,
            inv_one_minus_f: (1.0 / (1.0 - c.f)) as f32,
            z_ef: c.z_ef as f32,
            one_minus_z_ef: (1.0 - c.z_ef) as f32,
            u_ef: c.u_ef as f32,
            one_minus_u_ef: (1.0 - c.u_ef) as f32,
            k: c.k as f32,
            inv_k: (1.0 / c.k) as f32,
            four_over_pi: (4.0 / pi) as f32,
            eighth_turn: 0.125,
            rad_per_turn: (2.0 * pi) as f32,
            turns_per_rad: (0.5 / pi) as f32,
            pad: 0,
        }
    }
}
