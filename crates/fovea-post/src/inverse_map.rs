//! Inverse mapping: sample buffers back to screen pixels (VaFR Sec. 3.4 / Eq. 10–11, the
//! "reconstruct" stage of DESIGN.md).
//!
//! Every screen pixel centre is sent through the mapping's forward map and the buffer is read
//! there with a filtered lookup:
//!
//! * **Polar buffers** (VaFR, KFR, LaFR, visual-polar): the column comes from a lookup table of
//!   `u(r)` (sampled from the mapping's own forward map every ⅛ pixel of radius and
//!   interpolated linearly), the angle from `atan2`. Colour is bilinear across the two nearest
//!   columns, each read at its own angle (`v = θ/360°·period[i]`) with rows wrapping, so there is
//!   no seam at the angular wrap; pixels nearer the gaze than the first column's centre read
//!   column 0 around the full circle, so there is no hole at the gaze point; pixels beyond the
//!   last column (past the mapping's maximum eccentricity) take the outermost ring.
//! * **Screen-aligned layers** (Guenter, insets): the pixel's layer from the forward map,
//!   bilinear inside that layer, clamped to the layer's shaded rectangle.
//! * **Sparse screen masks** (Weier): see [`crate::pull_push`].
//! * **Full resolution**: the buffer is the screen.
//!
//! Depth is read with nearest-sample lookups (interpolating depth across an object boundary
//! would invent surfaces).

use rayon::prelude::*;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{FoveationMapping, Method, SamplePoint};
use fovea_core::units::ScreenPoint;
use fovea_core::{FoveaError, Image, Result};

use crate::pull_push::pull_push;
use crate::{lerp3, Rgb};

/// Radius step of the `u(r)` lookup table, pixels.
const LUT_STEP_PX: f64 = 0.125;

/// Shaded sample buffers of one frame: colour and depth per layer, as the mapping's
/// `buffers()` lists them. Unshaded pixels may hold anything.
#[derive(Clone, Debug)]
pub struct SampleBuffers {
    /// Linear RGB per layer.
    pub color: Vec<Image<Rgb>>,
    /// Depth (metres along the view axis; `f32::INFINITY` for misses) per layer.
    pub depth: Vec<Image<f32>>,
}

/// The reconstructed screen image and depth.
#[derive(Clone, Debug)]
pub struct ScreenFrame {
    /// Linear RGB, display resolution.
    pub color: Image<Rgb>,
    /// Depth per pixel, metres.
    pub depth: Image<f32>,
}

/// Maps `buffers` back to the screen of `display` through `mapping`.
pub fn reconstruct(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    buffers: SampleBuffers,
) -> Result<ScreenFrame> {
    let (w, h) = (display.width_px, display.height_px);
    let sizes = mapping.buffers();
    if sizes.len() != buffers.color.len()
        || sizes.len() != buffers.depth.len()
        || sizes
            .iter()
            .zip(&buffers.color)
            .any(|(s, b)| s.width != b.width() || s.height != b.height())
    {
        return Err(FoveaError::invalid(
            "sample buffers",
            format!("{} colour layers", buffers.color.len()),
            format!("the mapping's {} buffer(s) {:?}", sizes.len(), sizes),
        ));
    }
    let method = mapping.method();
    if method == Method::Full {
        let mut b = buffers;
        return Ok(ScreenFrame {
            color: b.color.swap_remove(0),
            depth: b.depth.swap_remove(0),
        });
    }
    if method == Method::Weier {
        let mask = mask_of(mapping, w, h);
        let color = pull_push(&buffers.color[0], &mask)?;
        let depth = nearest_fill_depth(&buffers.depth[0], &mask)?;
        return Ok(ScreenFrame { color, depth });
    }
    if let Some(layout) = mapping.polar_layout() {
        return polar(mapping, display, &layout, &buffers);
    }
    layered(mapping, display, &buffers)
}

/// Which screen pixels a sparse screen-space mapping shades.
pub fn mask_of(mapping: &dyn FoveationMapping, w: u32, h: u32) -> Image<bool> {
    let data: Vec<bool> = (0..h)
        .into_par_iter()
        .flat_map_iter(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| mapping.is_shaded(0, i, j))
        .collect();
    Image::from_vec(w, h, data).expect("size matches")
}

fn polar(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    layout: &fovea_core::mapping::PolarLayout,
    buffers: &SampleBuffers,
) -> Result<ScreenFrame> {
    let (w, h) = (display.width_px, display.height_px);
    let c = layout.centre;
    let last = match layout.rows.iter().rposition(|&r| r > 0) {
        Some(l) => l,
        None => {
            return Err(FoveaError::Unsupported(
                "a polar buffer without shaded samples".into(),
            ))
        }
    };
    // u(r) lookup table from the mapping's forward map.
    let corners = [
        (0.0, 0.0),
        (w as f64, 0.0),
        (0.0, h as f64),
        (w as f64, h as f64),
    ];
    let r_max = corners
        .iter()
        .map(|&(x, y)| (x - c.x_px).hypot(y - c.y_px))
        .fold(0.0, f64::max)
        + 2.0;
    let n = (r_max / LUT_STEP_PX).ceil() as usize + 2;
    let cols_end = (last + 1) as f32;
    let lut: Vec<f32> = (0..n)
        .into_par_iter()
        .map(|k| {
            let r = k as f64 * LUT_STEP_PX;
            match mapping.forward(ScreenPoint::new(c.x_px + r, c.y_px)) {
                Some(s) => s.u as f32,
                None => cols_end,
            }
        })
        .collect();
    let color = &buffers.color[0];
    let depth = &buffers.depth[0];
    let period: Vec<f32> = layout.period.iter().map(|&p| p as f32).collect();
    let rows = &layout.rows;
    let inv_step = (1.0 / LUT_STEP_PX) as f32;
    let (cx, cy) = (c.x_px as f32, c.y_px as f32);
    let inv_2pi = 1.0 / std::f32::consts::TAU;

    // Column k starts at `offset[k]` in the buffer's flat storage (row-major: pixel (k, j)
    // at j·bw + k); rows wrap at `rows[k]`.
    let bw = color.width() as usize;
    // Colour and depth interleaved, so one 16-byte load fetches both.
    let rgbd: Vec<[f32; 4]> = color
        .data()
        .par_iter()
        .zip(depth.data().par_iter())
        .map(|(c, &d)| [c[0], c[1], c[2], d])
        .collect();
    let wu = w as usize;
    let mut out_c = vec![[0.0f32; 3]; wu * h as usize];
    let mut out_d = vec![0.0f32; wu * h as usize];
    let lastf = last as f32;
    out_c
        .par_chunks_mut(wu)
        .zip(out_d.par_chunks_mut(wu))
        .enumerate()
        .for_each(|(y, (row_c, row_d))| {
            let dy = y as f32 + 0.5 - cy;
            for x in 0..wu {
                let dx = x as f32 + 0.5 - cx;
                let r = (dx * dx + dy * dy).sqrt();
                let t = r * inv_step;
                let k = (t as usize).min(n - 2);
                let f = (t - k as f32).min(1.0);
                let u = lut[k] + (lut[k + 1] - lut[k]) * f;
                let turn = fast_atan2(dy, dx) * inv_2pi;
                let turn = if turn < 0.0 { turn + 1.0 } else { turn };
                let uc = (u - 0.5).clamp(0.0, lastf);
                let i0 = uc as usize;
                let i1 = (i0 + 1).min(last);
                let fu = uc - i0 as f32;
                // Bilinear along the angle inside column i (v ≥ −½, so truncation after
                // adding 1 is a floor); nearest depth.
                let col = |i: usize| -> [f32; 4] {
                    let rws = rows[i] as usize;
                    if rws == 0 {
                        return [0.0, 0.0, 0.0, f32::INFINITY];
                    }
                    let v = turn * period[i] + 0.5;
                    let jf = v as usize;
                    let fv = v - jf as f32;
                    // Rows jf − 1 and jf, wrapped.
                    let mut jb = jf;
                    while jb >= rws {
                        jb -= rws;
                    }
                    let ja = if jb == 0 { rws - 1 } else { jb - 1 };
                    let a = rgbd[ja * bw + i];
                    let b = rgbd[jb * bw + i];
                    [
                        a[0] + (b[0] - a[0]) * fv,
                        a[1] + (b[1] - a[1]) * fv,
                        a[2] + (b[2] - a[2]) * fv,
                        if fv < 0.5 { a[3] } else { b[3] },
                    ]
                };
                let a = col(i0);
                if fu > 0.0 && i1 != i0 {
                    let b = col(i1);
                    row_c[x] = [
                        a[0] + (b[0] - a[0]) * fu,
                        a[1] + (b[1] - a[1]) * fu,
                        a[2] + (b[2] - a[2]) * fu,
                    ];
                    row_d[x] = if fu < 0.5 { a[3] } else { b[3] };
                } else {
                    row_c[x] = [a[0], a[1], a[2]];
                    row_d[x] = a[3];
                }
            }
        });
    Ok(ScreenFrame {
        color: Image::from_vec(w, h, out_c)?,
        depth: Image::from_vec(w, h, out_d)?,
    })
}

/// `atan2(y, x)` in radians with |error| < 1e-5 (octant reduction and a degree-11 odd
/// minimax polynomial for atan on [0, 1]); about 5× faster than the libm call, which matters
/// at tens of millions of pixels per frame.
#[inline]
pub fn fast_atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (mn, mx) = if ax < ay { (ax, ay) } else { (ay, ax) };
    if mx == 0.0 {
        return 0.0;
    }
    let a = mn / mx;
    let s = a * a;
    let mut r = ((((-0.011_719_12 * s + 0.052_653_32) * s - 0.116_432_87) * s + 0.193_543_46) * s
        - 0.332_623_47)
        * s
        * a
        + 0.999_977_26 * a;
    if ay > ax {
        r = std::f32::consts::FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = std::f32::consts::PI - r;
    }
    if y < 0.0 {
        -r
    } else {
        r
    }
}

/// Shaded rectangle `[i0, i1] × [j0, j1]` of a screen-aligned layer.
fn shaded_rect(
    mapping: &dyn FoveationMapping,
    layer: u32,
    bw: u32,
    bh: u32,
) -> (u32, u32, u32, u32) {
    let mid_j = bh / 2;
    let mid_i = bw / 2;
    let i0 = (0..bw)
        .find(|&i| mapping.is_shaded(layer, i, mid_j))
        .unwrap_or(0);
    let i1 = (0..bw)
        .rev()
        .find(|&i| mapping.is_shaded(layer, i, mid_j))
        .unwrap_or(bw - 1);
    let j0 = (0..bh)
        .find(|&j| mapping.is_shaded(layer, mid_i, j))
        .unwrap_or(0);
    let j1 = (0..bh)
        .rev()
        .find(|&j| mapping.is_shaded(layer, mid_i, j))
        .unwrap_or(bh - 1);
    (i0, i1.max(i0), j0, j1.max(j0))
}

fn layered(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    buffers: &SampleBuffers,
) -> Result<ScreenFrame> {
    let (w, h) = (display.width_px, display.height_px);
    let rects: Vec<_> = buffers
        .color
        .iter()
        .enumerate()
        .map(|(k, b)| shaded_rect(mapping, k as u32, b.width(), b.height()))
        .collect();
    let mut out_c = Image::new(w, h, [0.0f32; 3])?;
    let mut out_d = Image::new(w, h, f32::INFINITY)?;
    out_c
        .data_mut()
        .par_chunks_mut(w as usize)
        .zip(out_d.data_mut().par_chunks_mut(w as usize))
        .enumerate()
        .for_each(|(y, (row_c, row_d))| {
            for x in 0..w as usize {
                let p = ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
                let Some(SamplePoint { layer, u, v }) = mapping.forward(p) else {
                    continue;
                };
                let k = layer as usize;
                let (i0, i1, j0, j1) = rects[k];
                let img = &buffers.color[k];
                let fx = ((u - 0.5) as f32).clamp(i0 as f32, i1 as f32);
                let fy = ((v - 0.5) as f32).clamp(j0 as f32, j1 as f32);
                let (xa, ya) = (fx.floor() as u32, fy.floor() as u32);
                let (xb, yb) = ((xa + 1).min(i1), (ya + 1).min(j1));
                let (tx, ty) = (fx - xa as f32, fy - ya as f32);
                let top = lerp3(*img.get(xa, ya), *img.get(xb, ya), tx);
                let bot = lerp3(*img.get(xa, yb), *img.get(xb, yb), tx);
                row_c[x] = lerp3(top, bot, ty);
                let (nx, ny) = (fx.round() as u32, fy.round() as u32);
                row_d[x] = *buffers.depth[k].get(nx.min(i1), ny.min(j1));
            }
        });
    Ok(ScreenFrame {
        color: out_c,
        depth: out_d,
    })
}

/// Fills unshaded depth pixels with the nearest shaded one found by a growing square search
/// (bounded at 64 px; beyond, infinity).
fn nearest_fill_depth(depth: &Image<f32>, mask: &Image<bool>) -> Result<Image<f32>> {
    let (w, h) = (depth.width(), depth.height());
    let mut out = depth.clone();
    out.data_mut()
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, d) in row.iter_mut().enumerate() {
                if *mask.get(x as u32, y as u32) {
                    continue;
                }
                *d = f32::INFINITY;
                'search: for rad in 1i64..=64 {
                    for dy in -rad..=rad {
                        for dx in -rad..=rad {
                            if dx.abs() != rad && dy.abs() != rad {
                                continue;
                            }
                            let (sx, sy) = (x as i64 + dx, y as i64 + dy);
                            if sx < 0 || sy < 0 || sx >= w as i64 || sy >= h as i64 {
                                continue;
                            }
                            if *mask.get(sx as u32, sy as u32) {
                                *d = *depth.get(sx as u32, sy as u32);
                                break 'search;
                            }
                        }
                    }
                }
            }
        });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_atan2_matches_libm() {
        let mut worst = 0.0f32;
        for k in 0..20_000 {
            let a = k as f32 * 0.000_314_159_27 * 2.0;
            for r in [1e-3f32, 0.7, 123.0] {
                let (y, x) = (r * a.sin(), r * a.cos());
                worst = worst.max((fast_atan2(y, x) - y.atan2(x)).abs());
            }
        }
        assert!(worst < 2e-5, "{worst}");
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
    }
}
