//! Nested rectangular layers at decreasing resolution, the structure shared by Guenter-style
//! foveated rendering and inset foveation. Layer 0 is the finest; a screen point belongs to the
//! first layer whose region contains it. The last layer covers the whole screen.
//!
//! Layer `k` renders the screen rectangle `[x₀, x₀ + w) × [y₀, y₀ + h)` at `1/s_k` resolution
//! per axis: buffer pixel `(i, j)` covers screen `x₀ + [i, i+1)·s_k`. A pixel is shaded when its
//! centre is on the screen (layers that stick out past the border are clipped).

use super::{screen_rate_cpd, BufferSize, SamplePoint};
use crate::display::DisplayProfile;
use crate::units::ScreenPoint;

/// Which screen points a layer owns (besides lying in its rectangle).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Region {
    /// Points within `radius_px` of `centre` (Guenter's eccentricity layers).
    Disc { centre: ScreenPoint, radius_px: f64 },
    /// Every point of the layer rectangle (insets, the outer layer).
    Rect,
}

/// One layer of a screen-aligned layered mapping as [`super::FoveationMapping::screen_layers`]
/// reports it: the screen rectangle `[x₀, x₀ + w) × [y₀, y₀ + h)` rendered at `1/scale`
/// (buffer texel `(i, j)` covers screen `x₀ + [i, i+1)·scale`), owning the points of the
/// rectangle that also lie in `disc` (centre, radius in pixels) where it has one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenLayer {
    /// The rectangle's top-left corner, screen pixels.
    pub origin: ScreenPoint,
    /// The rectangle's width, screen pixels.
    pub width_px: f64,
    /// The rectangle's height, screen pixels.
    pub height_px: f64,
    /// Screen pixels per layer texel along each axis (≥ 1).
    pub scale: f64,
    /// Guenter's eccentricity disc (centre, radius in pixels); `None`: the whole rectangle.
    pub disc: Option<(ScreenPoint, f64)>,
}

impl ScreenLayer {
    /// Whether the layer owns `p` (its rectangle, and its disc where it has one).
    pub fn contains(&self, p: ScreenPoint) -> bool {
        Layer::from(*self).contains(p)
    }
}

impl From<ScreenLayer> for Layer {
    fn from(l: ScreenLayer) -> Self {
        Self {
            origin: l.origin,
            width_px: l.width_px,
            height_px: l.height_px,
            scale: l.scale,
            region: match l.disc {
                Some((centre, radius_px)) => Region::Disc { centre, radius_px },
                None => Region::Rect,
            },
        }
    }
}

impl From<&Layer> for ScreenLayer {
    fn from(l: &Layer) -> Self {
        Self {
            origin: l.origin,
            width_px: l.width_px,
            height_px: l.height_px,
            scale: l.scale,
            disc: match l.region {
                Region::Disc { centre, radius_px } => Some((centre, radius_px)),
                Region::Rect => None,
            },
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Layer {
    pub origin: ScreenPoint,
    pub width_px: f64,
    pub height_px: f64,
    /// Screen pixels per layer pixel along each axis (≥ 1).
    pub scale: f64,
    pub region: Region,
}

impl Layer {
    fn buffer(&self) -> BufferSize {
        BufferSize {
            width: (self.width_px / self.scale).ceil() as u32,
            height: (self.height_px / self.scale).ceil() as u32,
        }
    }

    fn contains(&self, p: ScreenPoint) -> bool {
        let in_rect = p.x_px >= self.origin.x_px
            && p.x_px < self.origin.x_px + self.width_px
            && p.y_px >= self.origin.y_px
            && p.y_px < self.origin.y_px + self.height_px;
        in_rect
            && match self.region {
                Region::Disc { centre, radius_px } => p.distance(centre) <= radius_px,
                Region::Rect => true,
            }
    }

    /// Number of buffer pixels along one axis whose centres fall in `[0, extent)`.
    fn on_screen(origin: f64, n: u32, scale: f64, extent: f64) -> u64 {
        (0..n)
            .filter(|&i| {
                let c = origin + (i as f64 + 0.5) * scale;
                (0.0..extent).contains(&c)
            })
            .count() as u64
    }
}

#[derive(Clone, Debug)]
pub(crate) struct Layers {
    pub layers: Vec<Layer>,
    pub screen_w: f64,
    pub screen_h: f64,
    pub c_r: f64,
    pub gaze: ScreenPoint,
}

impl Layers {
    pub fn new(display: &DisplayProfile, gaze: ScreenPoint, layers: Vec<Layer>) -> Self {
        Self {
            layers,
            screen_w: display.width_px as f64,
            screen_h: display.height_px as f64,
            c_r: display.c_r(),
            gaze,
        }
    }

    pub fn buffers(&self) -> Vec<BufferSize> {
        self.layers.iter().map(Layer::buffer).collect()
    }

    pub fn sample_count(&self) -> u64 {
        self.layers
            .iter()
            .map(|l| {
                let b = l.buffer();
                Layer::on_screen(l.origin.x_px, b.width, l.scale, self.screen_w)
                    * Layer::on_screen(l.origin.y_px, b.height, l.scale, self.screen_h)
            })
            .sum()
    }

    pub fn is_shaded(&self, layer: u32, i: u32, j: u32) -> bool {
        let Some(l) = self.layers.get(layer as usize) else {
            return false;
        };
        let b = l.buffer();
        if i >= b.width || j >= b.height {
            return false;
        }
        let x = l.origin.x_px + (i as f64 + 0.5) * l.scale;
        let y = l.origin.y_px + (j as f64 + 0.5) * l.scale;
        (0.0..self.screen_w).contains(&x) && (0.0..self.screen_h).contains(&y)
    }

    /// Index of the finest layer owning `p`.
    pub fn layer_of(&self, p: ScreenPoint) -> Option<usize> {
        self.layers.iter().position(|l| l.contains(p))
    }

    pub fn forward(&self, p: ScreenPoint) -> Option<SamplePoint> {
        if !(p.x_px.is_finite() && p.y_px.is_finite()) {
            return None;
        }
        let k = self.layer_of(p)?;
        let l = &self.layers[k];
        Some(SamplePoint {
            layer: k as u32,
            u: (p.x_px - l.origin.x_px) / l.scale,
            v: (p.y_px - l.origin.y_px) / l.scale,
        })
    }

    pub fn inverse(&self, s: SamplePoint) -> Option<ScreenPoint> {
        let l = self.layers.get(s.layer as usize)?;
        let b = l.buffer();
        if !(s.u >= 0.0 && s.u <= b.width as f64 && s.v >= 0.0 && s.v <= b.height as f64) {
            return None;
        }
        Some(ScreenPoint::new(
            l.origin.x_px + s.u * l.scale,
            l.origin.y_px + s.v * l.scale,
        ))
    }

    /// Rate of the layer that owns the point at eccentricity `e_deg` along `direction`
    /// (a unit vector) from the gaze point: the screen's own rate divided by the layer scale.
    pub fn rate_along(&self, e_deg: f64, direction: (f64, f64)) -> f64 {
        let r = e_deg.to_radians().tan() / self.c_r;
        let p = ScreenPoint::new(
            self.gaze.x_px + r * direction.0,
            self.gaze.y_px + r * direction.1,
        );
        match self.layer_of(p) {
            Some(k) => screen_rate_cpd(self.c_r, e_deg) / self.layers[k].scale,
            None => 0.0,
        }
    }

    /// The unit direction from the gaze towards the farthest screen corner (rates are reported
    /// along it, so a curve reaches the largest eccentricity on screen).
    pub fn probe_direction(&self) -> (f64, f64) {
        let corners = [
            (0.0, 0.0),
            (self.screen_w, 0.0),
            (0.0, self.screen_h),
            (self.screen_w, self.screen_h),
        ];
        let (dx, dy) = corners
            .iter()
            .map(|&(x, y)| (x - self.gaze.x_px, y - self.gaze.y_px))
            .fold((0.0, 0.0), |best: (f64, f64), d| {
                if d.0.hypot(d.1) > best.0.hypot(best.1) {
                    d
                } else {
                    best
                }
            });
        let n = dx.hypot(dy).max(1e-12);
        (dx / n, dy / n)
    }
}

/// Implements the geometric part of [`super::FoveationMapping`] for a type with a field
/// `layers: Layers`. Forward maps only on-screen points; rates are reported towards the
/// farthest corner, the same in every direction (square pixels).
macro_rules! delegate_to_layers {
    () => {
        fn buffers(&self) -> Vec<BufferSize> {
            self.layers.buffers()
        }
        fn sample_count(&self) -> u64 {
            self.layers.sample_count()
        }
        fn is_shaded(&self, layer: u32, i: u32, j: u32) -> bool {
            self.layers.is_shaded(layer, i, j)
        }
        fn forward(&self, p: ScreenPoint) -> Option<SamplePoint> {
            if !(0.0..self.layers.screen_w).contains(&p.x_px)
                || !(0.0..self.layers.screen_h).contains(&p.y_px)
            {
                return None;
            }
            self.layers.forward(p)
        }
        fn inverse(&self, s: SamplePoint) -> Option<ScreenPoint> {
            self.layers.inverse(s)
        }
        fn radial_rate_cpd(&self, e_deg: f64) -> f64 {
            self.layers.rate_along(e_deg, self.layers.probe_direction())
        }
        fn tangential_rate_cpd(&self, e_deg: f64) -> f64 {
            self.radial_rate_cpd(e_deg)
        }
        fn screen_layers(&self) -> Vec<super::ScreenLayer> {
            self.layers.layers.iter().map(Into::into).collect()
        }
    };
}
pub(crate) use delegate_to_layers;

#[cfg(test)]
mod tests {
    use crate::display::DisplayProfile;
    use crate::mapping::{
        FoveationMapping, GuenterLayers, GuenterParams, Inset, InsetParams, SamplePoint,
    };
    use crate::units::ScreenPoint;

    /// `screen_layers` is what `forward` and `inverse` read: the first layer containing a
    /// point is `forward`'s layer, and `forward`'s coordinates are `(p − origin) / scale`.
    #[test]
    fn screen_layers_are_what_forward_and_inverse_read() {
        let d = DisplayProfile::preset("2k").unwrap();
        for (gx, gy) in [(1280.0, 720.0), (100.0, 1300.0), (2500.0, 30.0)] {
            let g = d.gaze(gx, gy).unwrap();
            let maps: [Box<dyn FoveationMapping>; 2] = [
                Box::new(GuenterLayers::new(&d, g, GuenterParams::default()).unwrap()),
                Box::new(Inset::new(&d, g, InsetParams::default()).unwrap()),
            ];
            for m in &maps {
                let layers = m.screen_layers();
                assert_eq!(layers.len(), m.buffers().len());
                for y in (0..d.height_px).step_by(7) {
                    for x in (0..d.width_px).step_by(5) {
                        let p = ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
                        let s = m.forward(p).unwrap();
                        let k = layers.iter().position(|l| l.contains(p)).unwrap();
                        assert_eq!(s.layer as usize, k, "{p:?}");
                        let l = &layers[k];
                        assert_eq!(s.u, (p.x_px - l.origin.x_px) / l.scale);
                        assert_eq!(s.v, (p.y_px - l.origin.y_px) / l.scale);
                    }
                }
                for (k, l) in layers.iter().enumerate() {
                    let q = m
                        .inverse(SamplePoint {
                            layer: k as u32,
                            u: 1.5,
                            v: 2.5,
                        })
                        .unwrap();
                    assert_eq!(q.x_px, l.origin.x_px + 1.5 * l.scale);
                    assert_eq!(q.y_px, l.origin.y_px + 2.5 * l.scale);
                }
            }
        }
    }
}
