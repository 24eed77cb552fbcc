//! Inset compositing and boundary smoothing (Liu, Fan, Yan & Yan, "Inset Boundary Smoothing
//! for Foveated Rendering in Virtual Reality", `liu-inset-boundary-smoothing.txt`).
//!
//! A high-resolution inset (full display resolution, covering a [`Rect`] of the screen) is
//! composited over a periphery rendered at reduced resolution and upsampled to the screen
//! (Sec. 2), and the discontinuity at the inset boundary is smoothed with one of the paper's
//! methods ([`Smoothing`]).
//!
//! Taken from the paper:
//! * periphery at 1/4 resolution, upsampled to the frame size (Sec. 2). The paper's "1/4
//!   resolution … upsampled by 4×" is ambiguous between 1/4 of the pixels and 1/4 per side;
//!   both are accepted: the per-side factor (2 or 4, equal in x and y) is inferred from the
//!   sizes of `periphery_low` and the screen;
//! * naive alpha blend over an inner strip of width `S = 8` with a linear kernel, the weight of
//!   the low-resolution pixel decaying away from the boundary (Sec. 3.1, Fig. 3a);
//! * Gaussian smoothing of a strip along the boundary including pixels on both sides:
//!   σ = 1, kernel size 9, strip width 16 (Sec. 3.2); 1-D kernel orthogonal to the boundary or
//!   2-D kernel;
//! * Gaussian + alpha: same parameters, then a linear blend from the Gaussian-smoothed image at
//!   the inset boundary to the unsmoothed image at the strip boundary (Sec. 3.3, Fig. 5a);
//! * Laplacian pyramid blending of the foveated and the low-resolution image with five levels
//!   ("five steps", Sec. 3.4).
//!
//! Chosen here (the paper does not say):
//! * upsampling is bilinear with pixel centres aligned (`u = (x + ½)/f − ½`, edges clamped),
//!   i.e. OpenCV's default `resize` (`INTER_LINEAR`), which the paper's pipeline most likely used;
//! * distances to the boundary are measured in whole pixels: inside, `d = 0` is the inset's
//!   border pixel; outside, `d = 0` is the first periphery pixel (Chebyshev distance to the
//!   rectangle minus one, so the strips are rectangular rings). Linear weights use pixel
//!   centres: the low-resolution weight of the naive blend is `1 − (d + ½)/S` for `d < S`
//!   (15/16 … 1/16 for S = 8); the Gaussian weight of Gaussian + alpha is `1 − (d + ½)/8`
//!   on both sides of the boundary;
//! * an inset edge lying on the screen edge is not a boundary (there is no periphery beyond it)
//!   and is neither smoothed nor counted in distances;
//! * the 1-D Gaussian runs horizontally next to the left/right edges and vertically next to the
//!   top/bottom edges; where both are equally near (the strip's diagonals) it is the mean of the
//!   two 1-D results. The Gaussian reads the hard composite, clamped at the screen edges;
//! * Laplacian pyramid (Burt & Adelson 1983): 5-tap binomial kernel `[1 4 6 4 1]/16`, REDUCE to
//!   `⌈n/2⌉`, EXPAND by zero insertion and 2× the kernel, indices clamped at the edges; the mask
//!   is 1 inside the inset and 0 outside, smoothed by its own Gaussian pyramid; the images are
//!   the hard composite and the upsampled periphery. Fewer levels are built when the image
//!   becomes 1 px wide or high.

use fovea_core::{FoveaError, Image, Result};

use crate::Rgb;

/// Strip width `S` of the naive alpha blend (Sec. 3.1).
pub const ALPHA_STRIP_PX: u32 = 8;
/// σ of the Gaussian smoothing in pixels (Sec. 3.2).
pub const GAUSS_SIGMA: f32 = 1.0;
/// Kernel size (taps) of the Gaussian smoothing (Sec. 3.2).
pub const GAUSS_TAPS: usize = 9;
/// Width of the Gaussian strip, both sides of the boundary together (Sec. 3.2).
pub const GAUSS_STRIP_PX: u32 = 16;
/// Levels of the Laplacian pyramid ("five steps", Sec. 3.4).
pub const LAPLACIAN_LEVELS: u32 = 5;

/// A screen rectangle: columns `x0 .. x0 + w`, rows `y0 .. y0 + h`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Rect {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// Width in pixels.
    pub w: u32,
    /// Height in pixels.
    pub h: u32,
}

impl Rect {
    /// Errors unless the rectangle is non-empty and lies inside a `screen_w × screen_h` screen.
    pub fn validate(&self, screen_w: u32, screen_h: u32) -> Result<()> {
        if self.w == 0 || self.h == 0 {
            return Err(FoveaError::invalid(
                "inset_rect",
                format!("{}×{}", self.w, self.h),
                "a non-empty rectangle",
            ));
        }
        if self.x0 as u64 + self.w as u64 > screen_w as u64
            || self.y0 as u64 + self.h as u64 > screen_h as u64
        {
            return Err(FoveaError::invalid(
                "inset_rect",
                format!("({}, {}) + {}×{}", self.x0, self.y0, self.w, self.h),
                format!("a rectangle inside the {screen_w}×{screen_h} screen"),
            ));
        }
        Ok(())
    }

    /// Whether pixel `(x, y)` lies in the rectangle.
    pub fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && y >= self.y0 && (x - self.x0) < self.w && (y - self.y0) < self.h
    }
}

/// Which way a strip pixel's nearest boundary edge runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Across {
    /// Nearest edge is a left/right (vertical) edge: smooth horizontally.
    Horizontal,
    /// Nearest edge is a top/bottom (horizontal) edge: smooth vertically.
    Vertical,
    /// Equally near to both (diagonal of a corner).
    Both,
}

/// A pixel's position relative to the inset boundary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoundaryDistance {
    /// Whether the pixel lies in the inset.
    pub inside: bool,
    /// Whole-pixel distance to the boundary: 0 for the inset's border pixel (inside) or the
    /// first periphery pixel (outside); `u32::MAX` when the inset has no boundary inside the
    /// screen (it covers the screen).
    pub d: u32,
    /// Orientation of the nearest boundary edge.
    pub across: Across,
}

/// Distance of pixel `(x, y)` to the boundary of `rect` on a `screen_w × screen_h` screen
/// (see the module header). `rect` must have been validated.
pub fn boundary_distance(
    rect: Rect,
    screen_w: u32,
    screen_h: u32,
    x: u32,
    y: u32,
) -> BoundaryDistance {
    let (x, y) = (x as i64, y as i64);
    let (x0, y0) = (rect.x0 as i64, rect.y0 as i64);
    let (x1, y1) = (x0 + rect.w as i64 - 1, y0 + rect.h as i64 - 1);
    let pick = |dv: i64, dh: i64| {
        if dv < dh {
            Across::Horizontal
        } else if dh < dv {
            Across::Vertical
        } else {
            Across::Both
        }
    };
    if rect.contains(x as u32, y as u32) {
        let inf = i64::MAX;
        let left = if x0 > 0 { x - x0 } else { inf };
        let right = if x1 < screen_w as i64 - 1 {
            x1 - x
        } else {
            inf
        };
        let top = if y0 > 0 { y - y0 } else { inf };
        let bottom = if y1 < screen_h as i64 - 1 {
            y1 - y
        } else {
            inf
        };
        let dv = left.min(right);
        let dh = top.min(bottom);
        let d = dv.min(dh);
        BoundaryDistance {
            inside: true,
            d: if d == inf { u32::MAX } else { d as u32 },
            across: pick(dv, dh),
        }
    } else {
        let ox = (x0 - x).max(x - x1).max(0);
        let oy = (y0 - y).max(y - y1).max(0);
        BoundaryDistance {
            inside: false,
            d: (ox.max(oy) - 1) as u32,
            // Larger offset = farther past that edge pair = that pair is the nearest edge.
            across: pick(-ox, -oy),
        }
    }
}

/// 1-D or 2-D Gaussian kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum GaussianKernel {
    /// 1-D kernel orthogonal to the boundary.
    OneD,
    /// 2-D (separable) kernel.
    TwoD,
}

/// Boundary-smoothing method (Sec. 3).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Smoothing {
    /// Hard composite: inset inside the rectangle, upsampled periphery outside.
    None,
    /// Naive alpha blend over an inner strip of `strip_px` pixels (Sec. 3.1; the paper uses 8).
    AlphaBlend {
        /// Strip width `S` in pixels (≥ 1).
        strip_px: u32,
    },
    /// 1-D Gaussian orthogonal to the boundary over the 16-px strip (Sec. 3.2).
    Gaussian1d,
    /// 2-D Gaussian over the 16-px strip (Sec. 3.2).
    Gaussian2d,
    /// Gaussian followed by a linear blend back to the unsmoothed image (Sec. 3.3).
    GaussianAlpha {
        /// Which Gaussian.
        kernel: GaussianKernel,
    },
    /// Laplacian pyramid blending (Sec. 3.4; the paper uses 5 levels).
    LaplacianPyramid {
        /// Pyramid levels (1 ..= 16).
        levels: u32,
    },
}

impl Smoothing {
    /// The naive alpha blend with the paper's `S = 8`.
    pub const ALPHA_BLEND: Smoothing = Smoothing::AlphaBlend {
        strip_px: ALPHA_STRIP_PX,
    };
    /// Laplacian blending with the paper's five levels.
    pub const LAPLACIAN: Smoothing = Smoothing::LaplacianPyramid {
        levels: LAPLACIAN_LEVELS,
    };

    /// Every method with the paper's parameters, with its name, in the paper's order.
    pub const ALL: [(&'static str, Smoothing); 7] = [
        ("none", Smoothing::None),
        ("alpha-blend", Smoothing::ALPHA_BLEND),
        ("gaussian-1d", Smoothing::Gaussian1d),
        ("gaussian-2d", Smoothing::Gaussian2d),
        (
            "gaussian-1d-alpha",
            Smoothing::GaussianAlpha {
                kernel: GaussianKernel::OneD,
            },
        ),
        (
            "gaussian-2d-alpha",
            Smoothing::GaussianAlpha {
                kernel: GaussianKernel::TwoD,
            },
        ),
        ("laplacian", Smoothing::LAPLACIAN),
    ];

    /// The name of a method of [`ALL`](Self::ALL) (`custom` for other parameters).
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(_, m)| *m == self)
            .map_or("custom", |(n, _)| n)
    }

    /// Parses a name of [`ALL`](Self::ALL).
    pub fn parse(text: &str) -> Result<Self> {
        let t = text.trim().to_ascii_lowercase();
        Self::ALL
            .iter()
            .find(|(n, _)| *n == t)
            .map(|(_, m)| *m)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|(n, _)| *n).collect();
                FoveaError::invalid("inset-smoothing", text, names.join(", "))
            })
    }
}

/// Bilinear upsampling by an integer `factor` with pixel centres aligned, edges clamped.
pub fn upsample_bilinear(low: &Image<Rgb>, factor: u32) -> Result<Image<Rgb>> {
    if factor == 0 {
        return Err(FoveaError::invalid("factor", factor, "≥ 1"));
    }
    let (lw, lh) = (low.width(), low.height());
    let (w, h) = (
        lw.checked_mul(factor)
            .ok_or_else(|| FoveaError::invalid("factor", factor, "an upsampled width < 2³²"))?,
        lh.checked_mul(factor)
            .ok_or_else(|| FoveaError::invalid("factor", factor, "an upsampled height < 2³²"))?,
    );
    let taps = |x: u32, n: u32| {
        let u = ((x as f32 + 0.5) / factor as f32 - 0.5).clamp(0.0, (n - 1) as f32);
        let i0 = u.floor() as u32;
        let i1 = (i0 + 1).min(n - 1);
        (i0, i1, u - i0 as f32)
    };
    let xs: Vec<_> = (0..w).map(|x| taps(x, lw)).collect();
    let mut data = Vec::with_capacity(w as usize * h as usize);
    for y in 0..h {
        let (j0, j1, ty) = taps(y, lh);
        let (r0, r1) = (low.row(j0), low.row(j1));
        for &(i0, i1, tx) in &xs {
            let mut c = [0.0f32; 3];
            for k in 0..3 {
                let a = r0[i0 as usize][k] + (r0[i1 as usize][k] - r0[i0 as usize][k]) * tx;
                let b = r1[i0 as usize][k] + (r1[i1 as usize][k] - r1[i0 as usize][k]) * tx;
                c[k] = a + (b - a) * ty;
            }
            data.push(c);
        }
    }
    Image::from_vec(w, h, data)
}

/// Composites `inset` (covering `inset_rect`) over `periphery_low` upsampled to
/// `screen_w × screen_h`, smoothing the boundary with `smoothing`.
pub fn composite(
    inset: &Image<Rgb>,
    inset_rect: Rect,
    periphery_low: &Image<Rgb>,
    screen_w: u32,
    screen_h: u32,
    smoothing: Smoothing,
) -> Result<Image<Rgb>> {
    if screen_w == 0 || screen_h == 0 {
        return Err(FoveaError::invalid(
            "screen",
            format!("{screen_w}×{screen_h}"),
            "a non-empty screen",
        ));
    }
    let (lw, lh) = (periphery_low.width(), periphery_low.height());
    let factor = screen_w / lw.max(1);
    if lw == 0
        || !(factor == 2 || factor == 4)
        || lw as u64 * factor as u64 != screen_w as u64
        || lh as u64 * factor as u64 != screen_h as u64
    {
        return Err(FoveaError::invalid(
            "periphery_low",
            format!("{lw}×{lh}"),
            format!("the {screen_w}×{screen_h} screen divided by 2 or by 4 on each side"),
        ));
    }
    inset_rect.validate(screen_w, screen_h)?;
    if inset.width() != inset_rect.w || inset.height() != inset_rect.h {
        return Err(FoveaError::invalid(
            "inset",
            format!("{}×{}", inset.width(), inset.height()),
            format!(
                "the inset rectangle's size {}×{}",
                inset_rect.w, inset_rect.h
            ),
        ));
    }
    match smoothing {
        Smoothing::AlphaBlend { strip_px } if strip_px == 0 => {
            return Err(FoveaError::invalid("strip_px", strip_px, "≥ 1"));
        }
        Smoothing::LaplacianPyramid { levels } if !(1..=16).contains(&levels) => {
            return Err(FoveaError::invalid("levels", levels, "1 ..= 16"));
        }
        _ => {}
    }

    let periphery = upsample_bilinear(periphery_low, factor)?;
    let mut hard = periphery.clone();
    for j in 0..inset_rect.h {
        let src = inset.row(j);
        let y = inset_rect.y0 + j;
        for (i, c) in src.iter().enumerate() {
            *hard.get_mut(inset_rect.x0 + i as u32, y) = *c;
        }
    }
    let dist = |x, y| boundary_distance(inset_rect, screen_w, screen_h, x, y);

    match smoothing {
        Smoothing::None => Ok(hard),
        Smoothing::AlphaBlend { strip_px } => {
            let mut out = hard;
            for y in inset_rect.y0..inset_rect.y0 + inset_rect.h {
                for x in inset_rect.x0..inset_rect.x0 + inset_rect.w {
                    let bd = dist(x, y);
                    if bd.d < strip_px {
                        let a_low = 1.0 - (bd.d as f32 + 0.5) / strip_px as f32;
                        let hi = *out.get(x, y);
                        *out.get_mut(x, y) = crate::lerp3(hi, *periphery.get(x, y), a_low);
                    }
                }
            }
            Ok(out)
        }
        Smoothing::Gaussian1d => Ok(gaussian_strip(&hard, &dist, GaussianKernel::OneD, false)),
        Smoothing::Gaussian2d => Ok(gaussian_strip(&hard, &dist, GaussianKernel::TwoD, false)),
        Smoothing::GaussianAlpha { kernel } => Ok(gaussian_strip(&hard, &dist, kernel, true)),
        Smoothing::LaplacianPyramid { levels } => {
            let mask = Image::from_vec(
                screen_w,
                screen_h,
                (0..screen_h)
                    .flat_map(|y| (0..screen_w).map(move |x| (x, y)))
                    .map(|(x, y)| {
                        let m = if inset_rect.contains(x, y) { 1.0 } else { 0.0 };
                        [m; 3]
                    })
                    .collect(),
            )?;
            laplacian_blend(&hard, &periphery, &mask, levels)
        }
    }
}

/// Normalised 9-tap Gaussian, σ = 1.
fn gauss_weights() -> [f32; GAUSS_TAPS] {
    let r = (GAUSS_TAPS / 2) as i32;
    let mut w = [0.0f32; GAUSS_TAPS];
    for (i, wi) in w.iter_mut().enumerate() {
        let t = (i as i32 - r) as f32;
        *wi = (-t * t / (2.0 * GAUSS_SIGMA * GAUSS_SIGMA)).exp();
    }
    let s: f32 = w.iter().sum();
    w.iter_mut().for_each(|v| *v /= s);
    w
}

/// Separable convolution along x (`horizontal`) or y, edges clamped.
fn convolve(img: &Image<Rgb>, weights: &[f32], horizontal: bool) -> Image<Rgb> {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let r = (weights.len() / 2) as i64;
    let mut out = img.clone();
    for y in 0..h {
        for x in 0..w {
            let mut c = [0.0f32; 3];
            for (i, wt) in weights.iter().enumerate() {
                let o = i as i64 - r;
                let (sx, sy) = if horizontal {
                    ((x + o).clamp(0, w - 1), y)
                } else {
                    (x, (y + o).clamp(0, h - 1))
                };
                let s = img.get(sx as u32, sy as u32);
                for k in 0..3 {
                    c[k] += wt * s[k];
                }
            }
            *out.get_mut(x as u32, y as u32) = c;
        }
    }
    out
}

fn gaussian_strip(
    hard: &Image<Rgb>,
    dist: &dyn Fn(u32, u32) -> BoundaryDistance,
    kernel: GaussianKernel,
    alpha: bool,
) -> Image<Rgb> {
    let wts = gauss_weights();
    let bx = convolve(hard, &wts, true);
    let by = convolve(hard, &wts, false);
    let bxy = match kernel {
        GaussianKernel::TwoD => Some(convolve(&bx, &wts, false)),
        GaussianKernel::OneD => None,
    };
    let half = GAUSS_STRIP_PX / 2;
    let mut out = hard.clone();
    for y in 0..hard.height() {
        for x in 0..hard.width() {
            let bd = dist(x, y);
            if bd.d >= half {
                continue;
            }
            let g = match &bxy {
                Some(b2) => *b2.get(x, y),
                None => match bd.across {
                    Across::Horizontal => *bx.get(x, y),
                    Across::Vertical => *by.get(x, y),
                    Across::Both => crate::lerp3(*bx.get(x, y), *by.get(x, y), 0.5),
                },
            };
            *out.get_mut(x, y) = if alpha {
                let wg = 1.0 - (bd.d as f32 + 0.5) / half as f32;
                crate::lerp3(*hard.get(x, y), g, wg)
            } else {
                g
            };
        }
    }
    out
}

const BINOMIAL: [f32; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];

/// Blur with `[1 4 6 4 1]/16` and keep every second pixel (size `⌈n/2⌉`).
fn reduce(img: &Image<Rgb>) -> Image<Rgb> {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let (w2, h2) = ((w + 1) / 2, (h + 1) / 2);
    let mut tmp = Vec::with_capacity((w2 * h) as usize);
    for y in 0..h {
        for x2 in 0..w2 {
            let mut c = [0.0f32; 3];
            for (i, wt) in BINOMIAL.iter().enumerate() {
                let sx = (2 * x2 + i as i64 - 2).clamp(0, w - 1);
                let s = img.get(sx as u32, y as u32);
                for k in 0..3 {
                    c[k] += wt * s[k];
                }
            }
            tmp.push(c);
        }
    }
    let mut data = Vec::with_capacity((w2 * h2) as usize);
    for y2 in 0..h2 {
        for x2 in 0..w2 {
            let mut c = [0.0f32; 3];
            for (i, wt) in BINOMIAL.iter().enumerate() {
                let sy = (2 * y2 + i as i64 - 2).clamp(0, h - 1);
                let s = tmp[(sy * w2 + x2) as usize];
                for k in 0..3 {
                    c[k] += wt * s[k];
                }
            }
            data.push(c);
        }
    }
    Image::from_vec(w2 as u32, h2 as u32, data).expect("reduced size is consistent")
}

/// Burt–Adelson EXPAND of `img` to `tw × th`: zero insertion, then 2× the binomial kernel.
fn expand(img: &Image<Rgb>, tw: u32, th: u32) -> Image<Rgb> {
    let (w, h) = (img.width() as i64, img.height() as i64);
    // Output index `x` reads source `(x − m)/2` for even `x − m`, `m ∈ −2..=2`.
    let taps = |x: i64, n: i64| {
        let mut t = Vec::with_capacity(3);
        for (i, wt) in BINOMIAL.iter().enumerate() {
            let m = i as i64 - 2;
            if (x - m).rem_euclid(2) == 0 {
                t.push((((x - m).div_euclid(2)).clamp(0, n - 1), 2.0 * wt));
            }
        }
        t
    };
    let (tw, th) = (tw as i64, th as i64);
    let mut tmp = Vec::with_capacity((tw * h) as usize);
    let xt: Vec<_> = (0..tw).map(|x| taps(x, w)).collect();
    for y in 0..h {
        for t in &xt {
            let mut c = [0.0f32; 3];
            for &(sx, wt) in t {
                let s = img.get(sx as u32, y as u32);
                for k in 0..3 {
                    c[k] += wt * s[k];
                }
            }
            tmp.push(c);
        }
    }
    let mut data = Vec::with_capacity((tw * th) as usize);
    for y in 0..th {
        let t = taps(y, h);
        for x in 0..tw {
            let mut c = [0.0f32; 3];
            for &(sy, wt) in &t {
                let s = tmp[(sy * tw + x) as usize];
                for k in 0..3 {
                    c[k] += wt * s[k];
                }
            }
            data.push(c);
        }
    }
    Image::from_vec(tw as u32, th as u32, data).expect("expanded size is consistent")
}

fn gaussian_pyramid(img: &Image<Rgb>, levels: u32) -> Vec<Image<Rgb>> {
    let mut p = vec![img.clone()];
    while (p.len() as u32) < levels {
        let last = p.last().expect("non-empty");
        if last.width() <= 1 || last.height() <= 1 {
            break;
        }
        p.push(reduce(last));
    }
    p
}

fn sub(a: &Image<Rgb>, b: &Image<Rgb>) -> Image<Rgb> {
    let data = a
        .data()
        .iter()
        .zip(b.data())
        .map(|(p, q)| [p[0] - q[0], p[1] - q[1], p[2] - q[2]])
        .collect();
    Image::from_vec(a.width(), a.height(), data).expect("same size")
}

fn laplacian_pyramid(img: &Image<Rgb>, levels: u32) -> Vec<Image<Rgb>> {
    let g = gaussian_pyramid(img, levels);
    let mut l = Vec::with_capacity(g.len());
    for k in 0..g.len() - 1 {
        l.push(sub(&g[k], &expand(&g[k + 1], g[k].width(), g[k].height())));
    }
    l.push(g[g.len() - 1].clone());
    l
}

/// Burt–Adelson multiresolution blend: `mask · a + (1 − mask) · b` band by band, the mask
/// (per channel, in [0, 1]) smoothed by its Gaussian pyramid. All three images must have the
/// same size; `levels` ≥ 1 (fewer are used once a level is 1 px wide or high).
pub fn laplacian_blend(
    a: &Image<Rgb>,
    b: &Image<Rgb>,
    mask: &Image<Rgb>,
    levels: u32,
) -> Result<Image<Rgb>> {
    let size = |i: &Image<Rgb>| (i.width(), i.height());
    if size(a) != size(b) || size(a) != size(mask) {
        return Err(FoveaError::invalid(
            "laplacian_blend sizes",
            format!("{:?}, {:?}, {:?}", size(a), size(b), size(mask)),
            "three images of the same size",
        ));
    }
    if levels == 0 {
        return Err(FoveaError::invalid("levels", levels, "≥ 1"));
    }
    let la = laplacian_pyramid(a, levels);
    let lb = laplacian_pyramid(b, levels);
    let gm = gaussian_pyramid(mask, levels);
    let blended: Vec<Image<Rgb>> = (0..la.len())
        .map(|k| {
            let data = la[k]
                .data()
                .iter()
                .zip(lb[k].data())
                .zip(gm[k].data())
                .map(|((p, q), m)| {
                    let mut c = [0.0f32; 3];
                    for ch in 0..3 {
                        c[ch] = m[ch] * p[ch] + (1.0 - m[ch]) * q[ch];
                    }
                    c
                })
                .collect();
            Image::from_vec(la[k].width(), la[k].height(), data).expect("same size")
        })
        .collect();
    let mut r = blended[blended.len() - 1].clone();
    for k in (0..blended.len() - 1).rev() {
        let e = expand(&r, blended[k].width(), blended[k].height());
        let data = blended[k]
            .data()
            .iter()
            .zip(e.data())
            .map(|(p, q)| [p[0] + q[0], p[1] + q[1], p[2] + q[2]])
            .collect();
        r = Image::from_vec(e.width(), e.height(), data)?;
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    const W: u32 = 128;
    const H: u32 = 96;
    const RECT: Rect = Rect {
        x0: 40,
        y0: 24,
        w: 48,
        h: 48,
    };

    fn all_methods() -> Vec<Smoothing> {
        vec![
            Smoothing::None,
            Smoothing::ALPHA_BLEND,
            Smoothing::Gaussian1d,
            Smoothing::Gaussian2d,
            Smoothing::GaussianAlpha {
                kernel: GaussianKernel::OneD,
            },
            Smoothing::GaussianAlpha {
                kernel: GaussianKernel::TwoD,
            },
            Smoothing::LAPLACIAN,
        ]
    }

    fn pattern(w: u32, h: u32, seed: u32) -> Image<Rgb> {
        let data = (0..w * h)
            .map(|i| {
                let v = (i.wrapping_mul(2_654_435_761).wrapping_add(seed) >> 8) % 1000;
                let v = v as f32 / 1000.0;
                [v, 1.0 - v, 0.5 * v]
            })
            .collect();
        Image::from_vec(w, h, data).unwrap()
    }

    #[test]
    fn constant_stays_constant() {
        let c = [0.3f32, 0.6, 0.9];
        for f in [2, 4] {
            let inset = Image::new(RECT.w, RECT.h, c).unwrap();
            let low = Image::new(W / f, H / f, c).unwrap();
            for m in all_methods() {
                let out = composite(&inset, RECT, &low, W, H, m).unwrap();
                for p in out.data() {
                    for k in 0..3 {
                        assert!((p[k] - c[k]).abs() < 1e-5, "{m:?}: {p:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn inset_kept_far_inside_and_periphery_kept_far_outside() {
        let inset = pattern(RECT.w, RECT.h, 1);
        let low = pattern(W / 4, H / 4, 7);
        let up = upsample_bilinear(&low, 4).unwrap();
        for m in all_methods() {
            if matches!(m, Smoothing::LaplacianPyramid { .. }) {
                continue; // see laplacian_keeps_inset_centre_of_a_large_inset
            }
            let out = composite(&inset, RECT, &low, W, H, m).unwrap();
            assert_kept(&out, &inset, RECT, &up, 8, 8, 0.0, m);
        }
    }

    /// Checks that inside pixels at distance ≥ `reach_in` equal the inset and outside pixels at
    /// distance ≥ `reach_out` equal the upsampled periphery, within `tol`.
    #[allow(clippy::too_many_arguments)]
    fn assert_kept(
        out: &Image<Rgb>,
        inset: &Image<Rgb>,
        rect: Rect,
        up: &Image<Rgb>,
        reach_in: u32,
        reach_out: u32,
        tol: f32,
        m: Smoothing,
    ) {
        let (w, h) = (out.width(), out.height());
        let mut checked = 0;
        for y in 0..h {
            for x in 0..w {
                let bd = boundary_distance(rect, w, h, x, y);
                let (want, far) = if bd.inside {
                    (*inset.get(x - rect.x0, y - rect.y0), bd.d >= reach_in)
                } else {
                    (*up.get(x, y), bd.d >= reach_out)
                };
                if far {
                    checked += 1;
                    let got = *out.get(x, y);
                    for k in 0..3 {
                        assert!(
                            (got[k] - want[k]).abs() <= tol,
                            "{m:?} at ({x},{y}) d={} inside={}: {got:?} vs {want:?}",
                            bd.d,
                            bd.inside
                        );
                    }
                }
            }
        }
        assert!(checked > 0);
    }

    /// The pyramid's coarsest band (1/16 scale, kernel reach ≈ ±4 coarse px) mixes inset and
    /// periphery up to ≈ 64 px from the boundary, so exactness is checked on a large inset
    /// (the paper's inset is 1/4 of the frame per side) well away from the boundary.
    #[test]
    fn laplacian_keeps_inset_centre_of_a_large_inset() {
        let (w, h) = (512, 384);
        let rect = Rect {
            x0: 128,
            y0: 96,
            w: 256,
            h: 192,
        };
        let inset = pattern(rect.w, rect.h, 1);
        let low = pattern(w / 4, h / 4, 7);
        let up = upsample_bilinear(&low, 4).unwrap();
        let out = composite(&inset, rect, &low, w, h, Smoothing::LAPLACIAN).unwrap();
        assert_kept(&out, &inset, rect, &up, 80, 80, 1e-4, Smoothing::LAPLACIAN);
    }

    #[test]
    fn strip_outside_boundary_untouched_by_alpha_blend_and_none() {
        let inset = pattern(RECT.w, RECT.h, 3);
        let low = pattern(W / 2, H / 2, 5);
        let up = upsample_bilinear(&low, 2).unwrap();
        for m in [Smoothing::None, Smoothing::ALPHA_BLEND] {
            let out = composite(&inset, RECT, &low, W, H, m).unwrap();
            for y in 0..H {
                for x in 0..W {
                    if !RECT.contains(x, y) {
                        assert_eq!(out.get(x, y), up.get(x, y));
                    }
                }
            }
        }
    }

    /// Inset white, periphery black: along a row through the left edge the result must rise
    /// monotonically from 0 to 1 for the alpha and Gaussian methods; the naive ramp is exact.
    #[test]
    fn alpha_ramps_are_monotone() {
        let inset = Image::new(RECT.w, RECT.h, [1.0f32; 3]).unwrap();
        let low = Image::new(W / 4, H / 4, [0.0f32; 3]).unwrap();
        let y = RECT.y0 + RECT.h / 2;
        // Not the Laplacian blend: its finest band keeps the step and its coarse bands ring
        // (the undershoot inside the inset the paper describes in Sec. 3.4).
        for m in all_methods()
            .into_iter()
            .filter(|m| !matches!(m, Smoothing::LaplacianPyramid { .. }))
        {
            let out = composite(&inset, RECT, &low, W, H, m).unwrap();
            let row: Vec<f32> = (0..RECT.x0 + RECT.w / 2)
                .map(|x| out.get(x, y)[0])
                .collect();
            for w in row.windows(2) {
                assert!(w[1] >= w[0] - 1e-6, "{m:?}: {row:?}");
            }
        }
        let out = composite(&inset, RECT, &low, W, H, Smoothing::ALPHA_BLEND).unwrap();
        for d in 0..ALPHA_STRIP_PX {
            let v = out.get(RECT.x0 + d, y)[0];
            let want = (d as f32 + 0.5) / ALPHA_STRIP_PX as f32;
            assert!((v - want).abs() < 1e-6, "d={d}: {v} vs {want}");
        }
        assert_eq!(out.get(RECT.x0 - 1, y)[0], 0.0);
        assert_eq!(out.get(RECT.x0 + ALPHA_STRIP_PX, y)[0], 1.0);
        // Gaussian + alpha: strictly between 0 and 1 on both sides next to the boundary.
        let ga = composite(
            &inset,
            RECT,
            &low,
            W,
            H,
            Smoothing::GaussianAlpha {
                kernel: GaussianKernel::TwoD,
            },
        )
        .unwrap();
        let (a, b) = (ga.get(RECT.x0 - 1, y)[0], ga.get(RECT.x0, y)[0]);
        assert!(0.0 < a && a < b && b < 1.0, "{a} {b}");
    }

    #[test]
    fn laplacian_blend_of_identical_images_is_identity() {
        let img = pattern(37, 29, 11);
        let mask = pattern(37, 29, 13);
        for levels in [1, 3, 5, 16] {
            let out = laplacian_blend(&img, &img, &mask, levels).unwrap();
            for (p, q) in out.data().iter().zip(img.data()) {
                for k in 0..3 {
                    assert!((p[k] - q[k]).abs() < 1e-5, "{p:?} {q:?}");
                }
            }
        }
    }

    #[test]
    fn bad_inputs_are_errors() {
        let inset = Image::new(RECT.w, RECT.h, [0.0f32; 3]).unwrap();
        let low = Image::new(W / 4, H / 4, [0.0f32; 3]).unwrap();
        let m = Smoothing::None;
        let bad_rects = [
            Rect {
                x0: 0,
                y0: 0,
                w: 0,
                h: 4,
            },
            Rect {
                x0: W - 10,
                y0: 0,
                w: RECT.w,
                h: RECT.h,
            },
            Rect {
                x0: u32::MAX,
                y0: 0,
                w: RECT.w,
                h: RECT.h,
            },
            Rect {
                x0: 0,
                y0: u32::MAX - 1,
                w: RECT.w,
                h: RECT.h,
            },
        ];
        for r in bad_rects {
            assert!(composite(&inset, r, &low, W, H, m).is_err(), "{r:?}");
        }
        // Inset size differs from the rectangle.
        let r2 = Rect {
            w: RECT.w + 1,
            ..RECT
        };
        assert!(composite(&inset, r2, &low, W, H, m).is_err());
        // Periphery not W/2 or W/4, or not matching in y.
        for (lw, lh) in [
            (W / 3, H / 3),
            (W, H),
            (W / 4, H / 2),
            (W / 8, H / 8),
            (W / 4 + 1, H / 4),
        ] {
            let l = Image::new(lw, lh, [0.0f32; 3]).unwrap();
            assert!(composite(&inset, RECT, &l, W, H, m).is_err(), "{lw}×{lh}");
        }
        assert!(composite(&inset, RECT, &low, 0, H, m).is_err());
        assert!(composite(
            &inset,
            RECT,
            &low,
            W,
            H,
            Smoothing::AlphaBlend { strip_px: 0 }
        )
        .is_err());
        assert!(composite(
            &inset,
            RECT,
            &low,
            W,
            H,
            Smoothing::LaplacianPyramid { levels: 0 }
        )
        .is_err());
        assert!(upsample_bilinear(&low, 0).is_err());
        let other = Image::new(3, 3, [0.0f32; 3]).unwrap();
        assert!(laplacian_blend(&low, &other, &low, 5).is_err());
    }

    #[test]
    fn inset_on_screen_edge_has_no_boundary_there() {
        let r = Rect {
            x0: 0,
            y0: 0,
            w: 32,
            h: H,
        };
        assert_eq!(boundary_distance(r, W, H, 0, 40).d, 31);
        let full = Rect {
            x0: 0,
            y0: 0,
            w: W,
            h: H,
        };
        assert_eq!(boundary_distance(full, W, H, 5, 5).d, u32::MAX);
        let inset = pattern(W, H, 2);
        let low = pattern(W / 4, H / 4, 9);
        for m in all_methods() {
            let out = composite(&inset, full, &low, W, H, m).unwrap();
            let tol = if matches!(m, Smoothing::LaplacianPyramid { .. }) {
                1e-4
            } else {
                0.0
            };
            for (p, q) in out.data().iter().zip(inset.data()) {
                for k in 0..3 {
                    assert!((p[k] - q[k]).abs() <= tol, "{m:?}");
                }
            }
        }
    }

    #[test]
    fn distances_outside() {
        // First periphery pixel left of the inset and at the diagonal corner.
        let bd = boundary_distance(RECT, W, H, RECT.x0 - 1, RECT.y0 + 3);
        assert_eq!((bd.inside, bd.d, bd.across), (false, 0, Across::Horizontal));
        let bd = boundary_distance(RECT, W, H, RECT.x0 - 3, RECT.y0 - 3);
        assert_eq!((bd.inside, bd.d, bd.across), (false, 2, Across::Both));
        let bd = boundary_distance(RECT, W, H, RECT.x0 + 5, RECT.y0 + 1);
        assert_eq!((bd.inside, bd.d, bd.across), (true, 1, Across::Vertical));
    }
}
