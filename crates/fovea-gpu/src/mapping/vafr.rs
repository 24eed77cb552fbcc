//! The VaFR mapping (Zhang, Gai, Li; Eq. 3, 5, 8–12, 19) as the uniform block of
//! `shaders/vafr_mapping.wgsl`: every number the shader uses, computed here in f64 from the
//! `fovea_core` mapping and rounded to f32 once.
//!
//! The MAR segments are read through the acuity model's public functions at each pivot
//! (`mar_deg`, `mar_slope`, `u_of_e`), so they are the reference's own numbers; the gaze is
//! split into an f32 pair `hi + lo` so its rounding does not enter the offsets.

use bytemuck::{Pod, Zeroable};
use fovea_core::mapping::Vafr;

use crate::error::{GpuError, Result};
use crate::shaders::ShaderSource;

/// The module: forward and inverse entry points, [`VafrUniform`] at binding 0.
pub const SHADER: ShaderSource = ShaderSource {
    file: "vafr_mapping.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/vafr_mapping.wgsl")
    ),
    entry_points: &["forward", "inverse"],
    uniform: ("VafrParams", std::mem::size_of::<VafrUniform>()),
};

/// Capacity of the segment and tangential-pivot arrays of the uniform block.
pub const MAX_PIECES: usize = 16;

/// The uniform block `VafrParams` of `vafr_mapping.wgsl` (same field order; see there).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct VafrUniform {
    /// Gaze, f32 high part, pixels.
    pub gaze_hi: [f32; 2],
    /// Gaze, f32 low part (`gaze − hi`), pixels.
    pub gaze_lo: [f32; 2],
    /// `c_r` of Eq. 3, per pixel.
    pub c_r: f32,
    /// `tan(e_max)/c_r`, pixels.
    pub r_max_px: f32,
    /// `u(e_max)`, buffer pixels.
    pub u_max: f32,
    /// 180/π.
    pub deg_per_rad: f32,
    /// π/180.
    pub rad_per_deg: f32,
    /// 360.
    pub deg_per_turn: f32,
    /// 2π.
    pub rad_per_turn: f32,
    /// 1/(2π).
    pub turns_per_rad: f32,
    /// Segments in use.
    pub n_segments: u32,
    /// Tangential pieces in use.
    pub n_tangential: u32,
    /// Padding to 16 bytes.
    pub pad: [u32; 2],
    /// `(e_i °, ω_i °/cycle, dω/de, u_i high part)` per MAR segment.
    pub segments: [[f32; 4]; MAX_PIECES],
    /// `(u_i low part, tan e_i, 0, 0)` per MAR segment.
    pub segments_ext: [[f32; 4]; MAX_PIECES],
    /// `(e_j °, Δ(e_j), dΔ/de per °, 0)` per piece of Δ.
    pub tangential: [[f32; 4]; MAX_PIECES],
}

/// `x` as `hi + lo`, both f32: `hi` the nearest f32, `lo` the nearest f32 to the remainder.
pub(crate) fn split_f64(x: f64) -> (f32, f32) {
    let hi = x as f32;
    (hi, (x - hi as f64) as f32)
}

impl VafrUniform {
    /// The block for `vafr`. [`GpuError::Unsupported`] for the exact rings (they
    /// go through [`super::vafr_rings`]; [`GpuMapping::vafr`](crate::GpuMapping::vafr)
    /// picks the right one), or when the acuity model has more than
    /// [`MAX_PIECES`] pivots or the tangential factor more than [`MAX_PIECES`].
    pub fn new(vafr: &Vafr) -> Result<Self> {
        // Eq. 3's rings in the buffer for any gaze map as Eq. 3's: only its shaded texels
        // differ, which the mapping shader does not decide.
        if vafr.rings() == fovea_core::mapping::VafrRings::Exact {
            return Err(GpuError::Unsupported(format!(
                "VaFR with --vafr-rings {} in the Eq. 3 mapping shader (GpuMapping::vafr takes \
                 the exact rings through their table)",
                vafr.rings().name()
            )));
        }
        let acuity = &vafr.params().acuity;
        let pivots = acuity.pivots();
        if pivots.len() > MAX_PIECES {
            return Err(GpuError::Unsupported(format!(
                "a VaFR acuity model with {} pivots (the shader takes up to {MAX_PIECES})",
                pivots.len()
            )));
        }
        let tangential = vafr.params().tangential.pivots();
        if tangential.is_empty() || tangential.len() > MAX_PIECES {
            return Err(GpuError::Unsupported(format!(
                "a VaFR tangential factor with {} pivots (the shader takes 1 to {MAX_PIECES})",
                tangential.len()
            )));
        }
        let mut segments = [[0.0f32; 4]; MAX_PIECES];
        let mut segments_ext = [[0.0f32; 4]; MAX_PIECES];
        for (i, p) in pivots.iter().enumerate() {
            // Segment i starts at pivot i (the last one is flat and unbounded).
            let e = p.eccentricity_deg;
            let (u_hi, u_lo) = split_f64(acuity.u_of_e(e));
            segments[i] = [
                e as f32,
                acuity.mar_deg(e) as f32,
                acuity.mar_slope(e) as f32,
                u_hi,
            ];
            segments_ext[i] = [u_lo, e.to_radians().tan() as f32, 0.0, 0.0];
        }
        let mut pieces = [[0.0f32; 4]; MAX_PIECES];
        for (j, piece) in pieces.iter_mut().enumerate().take(tangential.len()) {
            let (e, ratio) = tangential[j];
            let slope = match tangential.get(j + 1) {
                Some(&(e1, r1)) => (r1 - ratio) / (e1 - e),
                None => 0.0,
            };
            *piece = [e as f32, ratio as f32, slope as f32, 0.0];
        }
        let gaze = vafr.gaze();
        let (gx_hi, gx_lo) = split_f64(gaze.x_px);
        let (gy_hi, gy_lo) = split_f64(gaze.y_px);
        let pi = std::f64::consts::PI;
        Ok(Self {
            gaze_hi: [gx_hi, gy_hi],
            gaze_lo: [gx_lo, gy_lo],
            c_r: vafr.c_r() as f32,
            r_max_px: vafr.max_radius_px() as f32,
            u_max: vafr.u_max() as f32,
            deg_per_rad: (180.0 / pi) as f32,
            rad_per_deg: (pi / 180.0) as f32,
            deg_per_turn: 360.0,
            rad_per_turn: (2.0 * pi) as f32,
            turns_per_rad: (0.5 / pi) as f32,
            n_segments: pivots.len() as u32,
            n_tangential: tangential.len() as u32,
            pad: [0; 2],
            segments,
            segments_ext,
            tangential: pieces,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_core::acuity::{AcuityModel, Pivot, TangentialFactor};
    use fovea_core::display::DisplayProfile;
    use fovea_core::mapping::VafrParams;

    #[test]
    fn the_block_holds_the_reference_numbers() {
        let d = DisplayProfile::preset("8k").unwrap();
        let g = d.gaze(1234.567, 3210.987).unwrap();
        let v = Vafr::new(&d, g, VafrParams::eq3()).unwrap();
        let b = VafrUniform::new(&v).unwrap();
        // The gaze survives the split to well below a millionth of a pixel.
        for (hi, lo, want) in [
            (b.gaze_hi[0], b.gaze_lo[0], 1234.567),
            (b.gaze_hi[1], b.gaze_lo[1], 3210.987),
        ] {
            assert!((hi as f64 + lo as f64 - want).abs() < 1e-9);
            assert!(
                (hi as f64 - want).abs() > 0.0,
                "the test needs a gaze f32 cannot hold"
            );
        }
        // VaFR's five default pivots; segment 1 starts at 10° with ω = 1/10 and u = u(10°).
        assert_eq!(b.n_segments, 5);
        assert_eq!(b.segments[1][0], 10.0);
        assert!((b.segments[1][1] - 0.1).abs() < 1e-8);
        let a = AcuityModel::vafr_default();
        assert!((b.segments[1][3] as f64 - a.u_of_e(10.0)).abs() < 1e-4);
        // The last segment is flat.
        assert_eq!(b.segments[4][2], 0.0);
        assert_eq!(b.n_tangential, 1);
        assert_eq!(b.tangential[0][1], 1.0);
        assert!((b.u_max as f64 - v.u_max()).abs() < 1e-3);
    }

    #[test]
    fn anisotropic_factor_is_uploaded_as_linear_pieces() {
        let d = DisplayProfile::preset("2k").unwrap();
        let p = VafrParams {
            tangential: TangentialFactor::radial_twice_at_30(),
            ..VafrParams::eq3()
        };
        let v = Vafr::new(&d, d.centre_gaze(), p).unwrap();
        let b = VafrUniform::new(&v).unwrap();
        assert_eq!(b.n_tangential, 2);
        // Δ(15°) from the first piece equals the reference's.
        let piece = b.tangential[0];
        let at15 = piece[1] + piece[2] * (15.0 - piece[0]);
        assert!((at15 as f64 - v.params().tangential.at(15.0)).abs() < 1e-6);
    }

    #[test]
    fn too_many_pivots_is_a_typed_refusal() {
        let pivots: Vec<Pivot> = (0..20)
            .map(|i| Pivot {
                eccentricity_deg: i as f64 * 4.0,
                cpd: 40.0 - i as f64,
            })
            .collect();
        let p = VafrParams {
            acuity: AcuityModel::segmented(&pivots).unwrap(),
            ..VafrParams::eq3()
        };
        let d = DisplayProfile::preset("2k").unwrap();
        let v = Vafr::new(&d, d.centre_gaze(), p).unwrap();
        let e = VafrUniform::new(&v).unwrap_err();
        assert!(matches!(e, GpuError::Unsupported(_)), "{e}");
        assert!(e.to_string().contains("20 pivots"), "{e}");
    }
}
