//! Foveation mappings: where a method puts its primary samples.
//!
//! Every mapping is a triple (DESIGN.md): a forward map from screen pixels to its sample space,
//! the inverse back to the screen, and its radial and tangential shading rate in cycles per
//! degree as a function of eccentricity. Each also knows its buffer(s) and the exact number of
//! samples it shades, and can say whether a given buffer pixel is shaded.
//!
//! Conventions shared by all mappings:
//! * Screen points follow [`ScreenPoint`]: x right, y down, pixel `(i, j)` has its centre at
//!   `(i + 0.5, j + 0.5)`. Sample points likewise: buffer pixel `(i, j)` of a layer has its
//!   centre at `(u, v) = (i + 0.5, j + 0.5)`.
//! * Eccentricity is VaFR Eq. 3 (`e = atan(c_r · r)`, see [`crate::display`]).
//! * Shading rate (VaFR Eq. 13): a cycle is two samples. The radial rate is
//!   `½ · d(samples along the radius)/de`. The tangential rate follows VaFR Eq. 20: the number
//!   of samples on the circle of eccentricity `e`, over `2 · 360 · sin e · cos e` (the circle's
//!   length in screen pixels measured in degrees of radial eccentricity, `2π·r·de/dr`). With
//!   this convention the full-resolution screen has equal radial and tangential rates.

use serde::{Deserialize, Serialize};

use crate::display::{eccentricity_deg, DisplayProfile, Gaze};
use crate::units::{Degrees, ScreenPoint};

pub mod footprint;
pub mod full;
pub mod guenter;
pub mod inset;
pub mod kfr;
pub mod lafr;
mod layered;
mod log_polar;
mod screen_arcs;
pub mod vafr;
mod vafr_rings;
pub mod visual_polar;
pub mod weier;

pub use full::FullResolution;
pub use guenter::{GuenterLayers, GuenterParams};
pub use inset::{Inset, InsetParams};
pub use kfr::{Kfr, KfrParams};
pub use lafr::{Lafr, LafrKernelConstants, LafrParams};
pub use layered::ScreenLayer;
pub use log_polar::LogPolarGeometry;
pub use vafr::{Vafr, VafrParams, VafrRings};
pub use vafr_rings::RingTable;
pub use visual_polar::{VisualPolar, VisualPolarInverse, VisualPolarParams};
pub use weier::{RadialDensity, WeierParams, WeierSparse};

/// A position in a mapping's sample space: continuous buffer coordinates `(u, v)` in `layer`.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct SamplePoint {
    /// Which buffer (0 for single-buffer mappings; layer index for layered ones).
    pub layer: u32,
    /// Horizontal buffer coordinate in buffer pixels (LP methods: the log-radius axis).
    pub u: f64,
    /// Vertical buffer coordinate in buffer pixels (LP methods: the angle axis).
    pub v: f64,
}

impl SamplePoint {
    /// A point in layer 0.
    pub const fn new(u: f64, v: f64) -> Self {
        Self { layer: 0, u, v }
    }
}

/// Size of one sample buffer in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BufferSize {
    /// Width in buffer pixels.
    pub width: u32,
    /// Height in buffer pixels.
    pub height: u32,
}

impl BufferSize {
    /// Number of pixels.
    pub fn pixels(self) -> u64 {
        self.width as u64 * self.height as u64
    }
}

/// The foveation methods the crate implements.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Full resolution, every pixel: the ground truth.
    Full,
    /// VaFR: acuity-consistent log-polar mapping (Zhang et al.).
    Vafr,
    /// KFR / LMFR: kernel log-polar mapping (Meng et al.), as VaFR Eq. 1 and 14.
    Kfr,
    /// LaFR: locomotion-aware kernel log-polar mapping (Shi et al.), as VaFR Eq. 15.
    Lafr,
    /// Visual-polar sampling of Liu et al. (Eq. 1–3).
    VisualPolar,
    /// Guenter-style nested layers.
    Guenter,
    /// Fixed or gaze-following high-resolution inset over a low-resolution periphery.
    Inset,
    /// Weier et al.'s sparse foveated sampling (S_in / S_out tables).
    Weier,
}

impl Method {
    /// Every method, in table order.
    pub const ALL: [Method; 8] = [
        Method::Full,
        Method::Vafr,
        Method::Kfr,
        Method::Lafr,
        Method::VisualPolar,
        Method::Guenter,
        Method::Inset,
        Method::Weier,
    ];

    /// Lower-case name used on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Method::Full => "full",
            Method::Vafr => "vafr",
            Method::Kfr => "kfr",
            Method::Lafr => "lafr",
            Method::VisualPolar => "visual-polar",
            Method::Guenter => "guenter",
            Method::Inset => "inset",
            Method::Weier => "weier",
        }
    }

    /// Parses a method name (also accepts `lmfr` for KFR, `gt` for full).
    pub fn parse(text: &str) -> crate::Result<Self> {
        let t = text.trim().to_ascii_lowercase();
        let m = match t.as_str() {
            "full" | "gt" => Method::Full,
            "vafr" => Method::Vafr,
            "kfr" | "lmfr" => Method::Kfr,
            "lafr" => Method::Lafr,
            "visual-polar" | "vp" | "liu" => Method::VisualPolar,
            "guenter" => Method::Guenter,
            "inset" => Method::Inset,
            "weier" => Method::Weier,
            _ => {
                return Err(crate::FoveaError::invalid(
                    "method",
                    text,
                    format!("one of {}", Method::ALL.map(Method::name).join(", ")),
                ))
            }
        };
        Ok(m)
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One foveation mapping for one display and one gaze point.
pub trait FoveationMapping: Send + Sync {
    /// Which method this is.
    fn method(&self) -> Method;

    /// The method's parameters, for reports and JSON.
    fn params(&self) -> serde_json::Value;

    /// The sample buffers (one for most mappings, one per layer for layered ones).
    fn buffers(&self) -> Vec<BufferSize>;

    /// Exact number of samples shaded per frame.
    fn sample_count(&self) -> u64;

    /// Whether buffer pixel `(i, j)` of `layer` is shaded.
    fn is_shaded(&self, layer: u32, i: u32, j: u32) -> bool;

    /// Screen → sample space. `None` when the method shades nothing that covers `p` (outside
    /// its buffer, e.g. beyond VaFR's maximum eccentricity) or `p` is not finite.
    fn forward(&self, p: ScreenPoint) -> Option<SamplePoint>;

    /// Sample space → screen. `None` outside the shaded region of the buffer.
    fn inverse(&self, s: SamplePoint) -> Option<ScreenPoint>;

    /// Radial shading rate at eccentricity `e_deg`, cycles per degree (VaFR Eq. 13).
    fn radial_rate_cpd(&self, e_deg: f64) -> f64;

    /// Tangential shading rate at eccentricity `e_deg`, cycles per degree (VaFR Eq. 20).
    fn tangential_rate_cpd(&self, e_deg: f64) -> f64;

    /// For polar (log-polar, visual-polar) mappings: how the buffer's angle axis wraps, so
    /// that filters and the inverse mapping can treat each column as periodic. `None` for
    /// screen-aligned mappings.
    fn polar_layout(&self) -> Option<PolarLayout> {
        None
    }

    /// This mapping's method, parameters and display at another gaze, from what of this one
    /// does not depend on the gaze — bit for bit what [`build`] makes for `display` and `gaze`
    /// — where the mapping can (VaFR with `VafrRings::Eq3AnyGaze`: only its shaded runs are
    /// laid out again); `None` otherwise, or where `gaze` needs another layout. Call it
    /// through [`rebuild_at`], which counts it as a built mapping.
    fn at_gaze(
        &self,
        _display: &crate::display::DisplayProfile,
        _gaze: crate::display::Gaze,
    ) -> Option<Box<dyn FoveationMapping>> {
        None
    }

    /// For polar mappings: the ring that column coordinate `u` of `layer` maps to, so that
    /// `inverse(s)` is `ring(s.layer, s.u)` then [`Ring::point`]`(s.v)`, bit for bit (each
    /// polar mapping's inverse is that composition). The trace reads every column's ring
    /// once and its rays' points from it. `None` where `inverse` is `None` for every `v`,
    /// and for screen-aligned mappings.
    fn ring(&self, _layer: u32, _u: f64) -> Option<Ring> {
        None
    }

    /// The shaded texels of column `i` of `layer` as half-open runs of rows `[j0, j1)`,
    /// sorted and disjoint, appended to `out`: exactly the `j` for which
    /// [`Self::is_shaded`]`(layer, i, j)`, without asking row by row. `false` (and nothing
    /// appended) where the mapping does not list them; then ask [`Self::is_shaded`].
    fn append_shaded_runs(&self, _layer: u32, _i: u32, _out: &mut Vec<(u32, u32)>) -> bool {
        false
    }

    /// Whether the polar layout (rows and periods) and the forward map about the pole (`u`
    /// of the radius, `v` of the angle) depend on the gaze only through what
    /// [`Self::buffers`] and [`Self::params`] report: then tables built from them (the
    /// reconstruction's `u(r)` table, the sample-space AA's grid) hold at every gaze with
    /// equal buffers and parameters, only the pole moving. The shaded texels may still
    /// follow the gaze. `false` unless the mapping says so (VaFR with
    /// `VafrRings::Eq3AnyGaze`, or Eq. 3's rings at a fixed `e_max`).
    fn layout_is_gaze_free(&self) -> bool {
        false
    }

    /// For screen-aligned layered mappings (Guenter's layers, the inset): each layer's
    /// screen rectangle, resolution and region, finest first, exactly as
    /// [`Self::forward`] and [`Self::inverse`] read them (a screen point belongs to the first
    /// layer that [`ScreenLayer::contains`] it). Empty for every other mapping. What another
    /// executor needs to reconstruct the layers itself (the GPU's resident frame).
    fn screen_layers(&self) -> Vec<ScreenLayer> {
        Vec::new()
    }

    /// Weier's sparse screen pattern behind this mapping, for an executor that evaluates
    /// its tables itself (the resident GPU frame); `None` for every other mapping.
    fn weier_sparse(&self) -> Option<&WeierSparse> {
        None
    }
}

/// One column of a polar buffer: the circle of radius `r_px` around `centre`, turned once
/// over `period` rows ([`FoveationMapping::ring`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ring {
    /// The pole (the gaze point).
    pub centre: ScreenPoint,
    /// Radius, screen pixels.
    pub r_px: f64,
    /// Buffer rows per full turn (VaFR: `l(e)`; log-polar: `H/δ`).
    pub period: f64,
}

impl Ring {
    /// The screen point at row coordinate `v`, `360° · v / period` around the ring (VaFR
    /// Eq. 11); `None` for `v` outside `[0, period]` or not finite. A ring without rows
    /// (`period ≤ 0`) has only the pole, at `v = 0`.
    #[inline]
    pub fn point(&self, v: f64) -> Option<ScreenPoint> {
        let (r_px, turn) = self.polar(v)?;
        Some(if self.period <= 0.0 {
            self.centre
        } else {
            from_polar_deg(r_px, turn * 360.0, self.centre)
        })
    }

    /// The polar coordinates of [`point`](Self::point)`(v)` around the centre: its radius,
    /// pixels, and its angle in turns (`v / period`; the pole, a ring without rows, is
    /// `(0, 0)`). `None` where `point` is `None`. What another executor needs to place the
    /// point itself (the GPU's ray generation).
    #[inline]
    pub fn polar(&self, v: f64) -> Option<(f64, f64)> {
        if self.period <= 0.0 {
            return (v == 0.0).then_some((0.0, 0.0));
        }
        if !(v >= 0.0 && v <= self.period) {
            return None;
        }
        Some((self.r_px, v / self.period))
    }
}

/// The angle axis of a polar sample buffer. Column `i` (a ring around `centre`) holds
/// `rows[i]` samples at `v = j + ½`, and `v` advances by `period[i]` over a full turn, i.e.
/// sample `j` of column `i` lies at the angle `360° · (j + ½) / period[i]`. The column of a
/// screen point depends only on its distance to `centre` (read it through `forward`).
#[derive(Clone, Debug, PartialEq)]
pub struct PolarLayout {
    /// The pole (the gaze point).
    pub centre: ScreenPoint,
    /// Buffer rows per full turn for every column (continuous; VaFR: `l(e)`, KFR: `H/δ`).
    pub period: Vec<f64>,
    /// Rows of every column: all shaded, but where a mapping leaves the texels off the screen
    /// unshaded (VaFR's exact rings; ask [`FoveationMapping::is_shaded`]).
    pub rows: Vec<u32>,
}

/// Polar coordinates of `p` around `centre`: (radius in pixels, angle in degrees in [0, 360)),
/// the angle measured from +x towards +y (screen down), as VaFR Eq. 1.
#[inline]
pub(crate) fn polar_deg(p: ScreenPoint, centre: ScreenPoint) -> (f64, f64) {
    let (dx, dy) = (p.x_px - centre.x_px, p.y_px - centre.y_px);
    let mut theta = dy.atan2(dx).to_degrees();
    if theta < 0.0 {
        theta += 360.0;
    }
    if theta >= 360.0 {
        theta -= 360.0;
    }
    (dx.hypot(dy), theta)
}

/// The point at `r_px`, `theta_deg` around `centre`.
#[inline]
pub(crate) fn from_polar_deg(r_px: f64, theta_deg: f64, centre: ScreenPoint) -> ScreenPoint {
    let (s, c) = theta_deg.to_radians().sin_cos();
    ScreenPoint::new(centre.x_px + r_px * c, centre.y_px + r_px * s)
}

/// The full-resolution screen's own radial rate at eccentricity `e_deg` for a display with
/// constant `c_r`: `½ · dr/de = ½ · (π/180) / (c_r cos² e)` cycles per degree.
#[inline]
pub(crate) fn screen_rate_cpd(c_r: f64, e_deg: f64) -> f64 {
    let c = e_deg.to_radians().cos();
    0.5 * std::f64::consts::PI / 180.0 / (c_r * c * c)
}

/// VaFR Eq. 20's denominator: `2 · 360 · sin e · cos e` (twice the length, in degrees of radial
/// eccentricity, of the circle at eccentricity `e`).
#[inline]
pub(crate) fn tangential_denominator(e_deg: f64) -> f64 {
    360.0 * (2.0 * e_deg).to_radians().sin()
}

/// How far out a polar mapping's buffer reaches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Coverage {
    /// Out to the farthest screen corner from the gaze (VaFR Eq. 3), at most
    /// [`MAX_COVERAGE_DEG`]: every screen pixel has samples at every gaze.
    #[default]
    Screen,
    /// Out to this eccentricity and no farther, whatever the gaze.
    Fixed(Degrees),
}

/// Largest eccentricity a polar buffer may reach: the log-polar mappings divide by
/// `cos e`, which vanishes at 90°.
pub const MAX_COVERAGE_DEG: f64 = 89.0;

impl Coverage {
    /// The eccentricity the buffer reaches for `display` and `gaze`, degrees: for
    /// [`Coverage::Screen`] the farthest corner's plus one pixel of radius, so the last
    /// column's texels reach past the corner pixel's centre.
    pub fn resolve(self, display: &DisplayProfile, gaze: &Gaze) -> f64 {
        match self {
            Coverage::Fixed(e) => e.0,
            Coverage::Screen => {
                let r = display.farthest_corner_px(gaze) + 1.0;
                eccentricity_deg(display.c_r(), r).min(MAX_COVERAGE_DEG)
            }
        }
    }
}

impl std::fmt::Display for Coverage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Coverage::Screen => f.write_str("screen"),
            Coverage::Fixed(e) => write!(f, "{}°", e.0),
        }
    }
}

/// Parameters of every method, with each method's documented defaults.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MappingConfig {
    /// VaFR.
    pub vafr: VafrParams,
    /// KFR / LMFR.
    pub kfr: KfrParams,
    /// LaFR.
    pub lafr: LafrParams,
    /// Visual-polar.
    pub visual_polar: VisualPolarParams,
    /// Guenter layers.
    pub guenter: GuenterParams,
    /// Inset.
    pub inset: InsetParams,
    /// Weier's sparse sampling.
    pub weier: WeierParams,
}

/// Mappings built by [`build`] in this process so far. A frame plan builds its mapping once
/// and every stage reads it from the plan; tests read this counter to check that nothing
/// rebuilds one.
static BUILDS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// How many mappings [`build`] has built in this process.
pub fn build_count() -> u64 {
    BUILDS.load(std::sync::atomic::Ordering::Relaxed)
}

/// `mapping` at `gaze` on `display` from its gaze-free layout
/// ([`FoveationMapping::at_gaze`]), counted as a build ([`build_count`]); `None` where it
/// cannot, then [`build`] it.
pub fn rebuild_at(
    mapping: &dyn FoveationMapping,
    display: &crate::display::DisplayProfile,
    gaze: crate::display::Gaze,
) -> Option<Box<dyn FoveationMapping>> {
    let m = mapping.at_gaze(display, gaze)?;
    BUILDS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    Some(m)
}

/// Builds the mapping of `method` for `display` and `gaze`.
pub fn build(
    method: Method,
    display: &crate::display::DisplayProfile,
    gaze: crate::display::Gaze,
    config: &MappingConfig,
) -> crate::Result<Box<dyn FoveationMapping>> {
    BUILDS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    Ok(match method {
        Method::Full => Box::new(FullResolution::new(display)?),
        Method::Vafr => Box::new(Vafr::new(display, gaze, config.vafr.clone())?),
        Method::Kfr => Box::new(Kfr::new(display, gaze, config.kfr)?),
        Method::Lafr => Box::new(Lafr::new(display, gaze, config.lafr)?),
        Method::VisualPolar => Box::new(VisualPolar::new(display, gaze, config.visual_polar)?),
        Method::Guenter => Box::new(GuenterLayers::new(display, gaze, config.guenter.clone())?),
        Method::Inset => Box::new(Inset::new(display, gaze, config.inset)?),
        Method::Weier => Box::new(WeierSparse::new(display, gaze, config.weier)?),
    })
}
