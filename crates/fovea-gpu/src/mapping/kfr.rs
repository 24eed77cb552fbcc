//! The KFR / LMFR mapping (Meng et al., in VaFR's form: Eq. 1, 14) as the uniform block of
//! `shaders/kfr_mapping.wgsl`: every number the shader uses, computed here in f64 from the
//! `fovea_core` mapping's [`LogPolarGeometry`](fovea_core::mapping::LogPolarGeometry) and
//! rounded to f32 once.

use bytemuck::{Pod, Zeroable};
use fovea_core::mapping::Kfr;

use super::vafr::split_f64;
use crate::shaders::ShaderSource;

/// The module: forward and inverse entry points, [`KfrUniform`] at binding 0.
pub const SHADER: ShaderSource = ShaderSource {
    file: "kfr_mapping.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/kfr_mapping.wgsl")
    ),
    entry_points: &["forward", "inverse"],
    uniform: ("KfrParams", std::mem::size_of::<KfrUniform>()),
};

/// The uniform block `KfrParams` of `kfr_mapping.wgsl` (same field order; see there).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct KfrUniform {
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
    /// Kernel exponent α.
    pub alpha: f32,
    /// 1/α.
    pub inv_alpha: f32,
    /// 2π.
    pub rad_per_turn: f32,
    /// 1/(2π).
    pub turns_per_rad: f32,
    /// Padding to 16 bytes.
    pub pad: u32,
}

impl KfrUniform {
    /// The block for `kfr`.
    pub fn new(kfr: &Kfr) -> Self {
        let g = kfr.geometry();
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
            alpha: kfr.alpha() as f32,
            inv_alpha: (1.0 / kfr.alpha()) as f32,
            rad_per_turn: (2.0 * pi) as f32,
            turns_per_rad: (0.5 / pi) as f32,
            pad: 0,
        }
    }
}
