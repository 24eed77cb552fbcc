//! The HMD rig and per-eye pinhole cameras.
//!
//! A [`DisplayProfile`] fixes each eye's render target (resolution, fields of view, lens
//! centre); an [`EyeCamera`] places it in the world. Screen convention as in `fovea-core`:
//! pixel `(i, j)` has its centre at `(i + ½, j + ½)`, x right, y down; the ray through screen
//! point `(x, y)` is `forward + (x − c_x)/f_x · right − (y − c_y)/f_y · up` with `f` the focal
//! lengths in pixels and `c` the principal point.
//!
//! [`HmdRig`] derives both eyes from a head pose and the interpupillary distance (IPD): each eye
//! sits `±IPD/2` along the head's right vector and looks along the head's forward vector
//! (parallel optical axes, as HMD lenses are). Gaze is a screen point or a world direction,
//! converted with [`EyeCamera::screen_point_of`].

use glam::Vec3;

use fovea_core::display::DisplayProfile;
use fovea_core::units::ScreenPoint;

use crate::bvh::Ray;
use crate::error::{RenderError, Result};
use crate::scene::CameraDesc;

/// A pinhole camera rendering one eye's display.
#[derive(Clone, Debug)]
pub struct EyeCamera {
    /// Eye (pinhole) position, world space, metres.
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit right vector (screen +x).
    pub right: Vec3,
    /// Unit up vector (screen −y).
    pub up: Vec3,
    /// The display this camera renders.
    pub display: DisplayProfile,
    fx: f32,
    fy: f32,
    cx: f32,
    cy: f32,
}

impl EyeCamera {
    /// A camera at `position` looking along `forward` with `up` (need not be orthogonal).
    pub fn new(position: Vec3, forward: Vec3, up: Vec3, display: &DisplayProfile) -> Result<Self> {
        display.validate()?;
        let f = forward.normalize_or_zero();
        let r = f.cross(up).normalize_or_zero();
        if !position.is_finite() || f == Vec3::ZERO || r == Vec3::ZERO {
            return Err(RenderError::invalid(
                "camera",
                format!("position {position}, forward {forward}, up {up}"),
                "a finite position and non-parallel, non-zero forward and up vectors",
            ));
        }
        let pp = display.principal_point();
        Ok(Self {
            position,
            forward: f,
            right: r,
            up: r.cross(f),
            display: display.clone(),
            fx: display.focal_x_px() as f32,
            fy: display.focal_y_px() as f32,
            cx: pp.x_px as f32,
            cy: pp.y_px as f32,
        })
    }

    /// The camera of a scene's [`CameraDesc`] rendering `display`. The display's field of view
    /// wins over the file's (the HMD fixes it); the file gives the pose.
    pub fn from_desc(desc: &CameraDesc, display: &DisplayProfile) -> Result<Self> {
        Self::new(desc.position, desc.forward, desc.up, display)
    }

    /// Unit direction of the ray through screen point `(x_px, y_px)`.
    #[inline]
    pub fn direction(&self, x_px: f32, y_px: f32) -> Vec3 {
        let a = (x_px - self.cx) / self.fx;
        let b = (y_px - self.cy) / self.fy;
        (self.forward + a * self.right - b * self.up).normalize()
    }

    /// The primary ray through screen point `p`.
    #[inline]
    pub fn ray(&self, p: ScreenPoint) -> Ray {
        Ray {
            origin: self.position,
            dir: self.direction(p.x_px as f32, p.y_px as f32),
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    /// Where a world direction from the eye meets the screen (`None` when it points backwards).
    pub fn screen_point_of(&self, dir: Vec3) -> Option<ScreenPoint> {
        let z = dir.dot(self.forward);
        if z.is_nan() || z <= 1e-6 || !dir.is_finite() {
            return None;
        }
        let x = self.cx + self.fx * dir.dot(self.right) / z;
        let y = self.cy - self.fy * dir.dot(self.up) / z;
        Some(ScreenPoint::new(x as f64, y as f64))
    }

    /// Depth along the view axis of a point at distance `t` along the unit direction `dir`.
    #[inline]
    pub fn view_depth(&self, dir: Vec3, t: f32) -> f32 {
        t * dir.dot(self.forward)
    }

    /// Focal lengths in pixels `(f_x, f_y)`.
    pub fn focal_px(&self) -> (f32, f32) {
        (self.fx, self.fy)
    }

    /// The principal point `(c_x, c_y)`, screen pixels: where the view axis meets the screen.
    pub fn principal_point_px(&self) -> (f32, f32) {
        (self.cx, self.cy)
    }
}

/// Which eye.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Eye {
    /// Left eye (−IPD/2 along the head's right vector).
    Left,
    /// Right eye (+IPD/2).
    Right,
    /// Cyclopean eye at the head position.
    Centre,
}

/// A head pose and the IPD, from which both eye cameras follow.
#[derive(Clone, Debug)]
pub struct HmdRig {
    /// Midpoint between the eyes, world space, metres.
    pub head: Vec3,
    /// Unit forward of the head.
    pub forward: Vec3,
    /// Unit up of the head.
    pub up: Vec3,
    /// Interpupillary distance in metres (adult mean 0.063; accepted 0.04–0.09).
    pub ipd_m: f32,
}

impl HmdRig {
    /// A rig with validated IPD.
    pub fn new(head: Vec3, forward: Vec3, up: Vec3, ipd_m: f32) -> Result<Self> {
        if !(ipd_m.is_finite() && (0.04..=0.09).contains(&ipd_m)) {
            return Err(RenderError::invalid(
                "ipd",
                ipd_m,
                "metres in [0.04, 0.09] (adult range)",
            ));
        }
        Ok(Self {
            head,
            forward,
            up,
            ipd_m,
        })
    }

    /// The camera of one eye.
    pub fn eye(&self, eye: Eye, display: &DisplayProfile) -> Result<EyeCamera> {
        let c = EyeCamera::new(self.head, self.forward, self.up, display)?;
        let offset = match eye {
            Eye::Left => -0.5 * self.ipd_m,
            Eye::Right => 0.5 * self.ipd_m,
            Eye::Centre => 0.0,
        };
        EyeCamera::new(self.head + offset * c.right, self.forward, self.up, display)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn screen_points_and_rays_are_inverse() {
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        let cam = EyeCamera::new(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(0.3, -0.1, -1.0),
            Vec3::Y,
            &d,
        )
        .unwrap();
        for (x, y) in [(0.5, 0.5), (720.0, 800.0), (1439.5, 3.0)] {
            let dir = cam.direction(x, y);
            let p = cam.screen_point_of(dir).unwrap();
            assert!((p.x_px - x as f64).abs() < 1e-2 && (p.y_px - y as f64).abs() < 1e-2);
        }
        // The top edge of the screen is vfov/2 above the axis.
        let top = cam.direction(cam.cx, 0.0);
        let angle = top.angle_between(cam.forward).to_degrees();
        assert!((angle - 55.0).abs() < 0.01, "{angle}");
        assert!(cam.direction(0.0, 800.0).dot(cam.right) < 0.0);
    }

    #[test]
    fn eyes_sit_half_the_ipd_apart() {
        let d = DisplayProfile::preset("2k").unwrap();
        let rig = HmdRig::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 0.064).unwrap();
        let l = rig.eye(Eye::Left, &d).unwrap();
        let r = rig.eye(Eye::Right, &d).unwrap();
        assert!((l.position.x + 0.032).abs() < 1e-6 && (r.position.x - 0.032).abs() < 1e-6);
        assert!(HmdRig::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, f32::NAN).is_err());
        assert!(EyeCamera::new(Vec3::ZERO, Vec3::Y, Vec3::Y, &d).is_err());
    }
}
