//! Unit newtypes used at API boundaries. Inside hot loops the crate uses plain `f64` with a unit
//! suffix on the name (`eccentricity_deg`, `r_px`); conversion happens once, at the edge.

use serde::{Deserialize, Serialize};

macro_rules! unit {
    ($(#[$doc:meta])* $name:ident, $suffix:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, PartialOrd, Default, Serialize, Deserialize)]
        #[serde(transparent)]
        pub struct $name(pub f64);

        impl $name {
            /// The bare number in this unit.
            #[inline]
            pub fn value(self) -> f64 {
                self.0
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                if let Some(p) = f.precision() {
                    write!(f, "{:.*} {}", p, self.0, $suffix)
                } else {
                    write!(f, "{} {}", self.0, $suffix)
                }
            }
        }
    };
}

unit!(
    /// An angle in degrees (eccentricity, field of view). The papers state every angle in degrees.
    Degrees,
    "°"
);
unit!(
    /// A length in millimetres (eye focal length, pupil diameter, retinal circle of confusion).
    Millimetres,
    "mm"
);
unit!(
    /// A distance in metres (focus distance, scene depth).
    Metres,
    "m"
);
unit!(
    /// Spatial frequency in cycles per degree of visual angle; one cycle is two pixels/samples.
    CyclesPerDegree,
    "cpd"
);
unit!(
    /// Illuminance in lux (Liu et al. state the ambient light of an HMD in lux).
    Lux,
    "lx"
);
unit!(
    /// Luminance in candelas per square metre (nits).
    CandelasPerSquareMetre,
    "cd/m²"
);
unit!(
    /// A length in screen pixels.
    Pixels,
    "px"
);

impl Degrees {
    /// The angle in radians.
    #[inline]
    pub fn to_radians(self) -> f64 {
        self.0.to_radians()
    }
}

impl Metres {
    /// The distance in millimetres.
    #[inline]
    pub fn to_mm(self) -> Millimetres {
        Millimetres(self.0 * 1000.0)
    }
}

impl Millimetres {
    /// The length in metres.
    #[inline]
    pub fn to_metres(self) -> Metres {
        Metres(self.0 / 1000.0)
    }
}

/// A point on the screen in pixel coordinates: x to the right, y down, (0, 0) at the top-left
/// corner of the top-left pixel (so the centre of pixel (i, j) is (i + 0.5, j + 0.5)).
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct ScreenPoint {
    /// Horizontal position in pixels.
    pub x_px: f64,
    /// Vertical position in pixels (down).
    pub y_px: f64,
}

impl ScreenPoint {
    /// A point at (x, y) pixels.
    pub const fn new(x_px: f64, y_px: f64) -> Self {
        Self { x_px, y_px }
    }

    /// Euclidean distance to `other` in pixels.
    pub fn distance(self, other: ScreenPoint) -> f64 {
        (self.x_px - other.x_px).hypot(self.y_px - other.y_px)
    }
}
