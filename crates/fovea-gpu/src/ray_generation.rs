//! Primary rays of a polar buffer generated on the GPU (`shaders/ray_generation.wgsl`, part of
//! the trace module): each ray goes up as the polar coordinates of its screen point around the
//! mapping's centre — 8 bytes instead of a 32-byte ray — and the shader places the point
//! (VaFR Eq. 11), builds the pinhole camera's ray through it and traces it, returning the hit
//! and the direction it cast.
//!
//! The radii and angles are the CPU mapping's (`fovea_core::mapping::Ring::polar`, f64, once
//! per column of the buffer); the camera's vectors, focal lengths, the centre relative to the
//! principal point and 2π are uploaded in [`RayGenCamera`], so the shader derives nothing.

use bytemuck::{Pod, Zeroable};

use crate::error::{GpuError, Result};
use crate::trace::{
    DirectLightModel, GpuHit, GpuTracer, HitGpu, ScenePass, TraceTimes, TraceUniform, MISS,
};
use crate::transfer::batch_len;

/// The camera block of `ray_generation.wgsl` (`RayGenCamera`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct RayGenCamera {
    /// Eye position, world space.
    pub origin: [f32; 3],
    /// Focal length along x, pixels.
    pub fx: f32,
    /// Unit viewing direction.
    pub forward: [f32; 3],
    /// Focal length along y, pixels.
    pub fy: f32,
    /// Unit right vector (screen +x).
    pub right: [f32; 3],
    /// 2π.
    pub rad_per_turn: f32,
    /// Unit up vector (screen −y).
    pub up: [f32; 3],
    _pad0: f32,
    /// The rings' centre minus the principal point, pixels.
    pub centre: [f32; 2],
    _pad1: [f32; 2],
}

impl RayGenCamera {
    /// The block of a pinhole camera at `origin` with unit `forward`, `right`, `up`, focal
    /// lengths `focal_px`, principal point `principal_px` and the rings around `centre_px`
    /// (screen pixels; subtracted here in f64).
    pub fn new(
        origin: [f32; 3],
        [forward, right, up]: [[f32; 3]; 3],
        focal_px: (f32, f32),
        principal_px: (f32, f32),
        centre_px: [f64; 2],
    ) -> Self {
        Self {
            origin,
            fx: focal_px.0,
            forward,
            fy: focal_px.1,
            right,
            rad_per_turn: std::f32::consts::TAU,
            up,
            _pad0: 0.0,
            centre: [
                (centre_px[0] - principal_px.0 as f64) as f32,
                (centre_px[1] - principal_px.1 as f64) as f32,
            ],
            _pad1: [0.0; 2],
        }
    }

    fn is_finite(&self) -> bool {
        bytemuck::cast_slice::<_, f32>(std::slice::from_ref(self))
            .iter()
            .all(|v| v.is_finite())
            && self.fx != 0.0
            && self.fy != 0.0
    }
}

/// A primary ray as `ray_generation.wgsl` reads it: its screen point's distance from the
/// centre (pixels) and angle (turns, from +x towards +y).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPolarRay {
    /// Distance from the centre, pixels.
    pub r_px: f32,
    /// Angle, turns.
    pub turn: f32,
}

/// A generated ray's unit direction and its closest hit (`None`: a miss).
pub type PolarHit = ([f32; 3], Option<GpuHit>);

/// What the shader writes per ray (`PolarHit`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
struct PolarHitGpu {
    hit: HitGpu,
    dir: [f32; 3],
    _pad: f32,
}

/// The WGSL name and the Rust size of the per-ray output record (`tests/shaders.rs` compares
/// them with naga).
pub const POLAR_HIT_STRUCT: (&str, usize) = ("PolarHit", std::mem::size_of::<PolarHitGpu>());

const IN_BYTES: u64 = std::mem::size_of::<GpuPolarRay>() as u64;
const OUT_BYTES: u64 = std::mem::size_of::<PolarHitGpu>() as u64;

impl GpuTracer {
    /// Generates the primary ray of each of `rays` through `camera` and traces it: the unit
    /// direction it was cast along and its closest hit (`None`: a miss), and where the time
    /// went. A non-finite camera or ray is an input error naming it, before any work.
    pub fn closest_hits_polar_timed(
        &self,
        camera: &RayGenCamera,
        rays: &[GpuPolarRay],
    ) -> Result<(Vec<PolarHit>, TraceTimes)> {
        let t = std::time::Instant::now();
        let mut times = TraceTimes::default();
        if !camera.is_finite() {
            return Err(GpuError::Input(format!(
                "the ray-generation camera has a non-finite or zero field: {camera:?}"
            )));
        }
        if let Some(k) = rays
            .iter()
            .position(|r| !(r.r_px.is_finite() && r.turn.is_finite() && r.r_px >= 0.0))
        {
            return Err(GpuError::Input(format!(
                "polar ray {k} is not a finite point ({:?})",
                rays[k]
            )));
        }
        let Some(scene) = &self.scene else {
            // No triangles: every ray misses; the directions still come from the camera.
            times.total_ms = t.elapsed().as_secs_f64() * 1e3;
            return Ok((
                rays.iter().map(|r| (direction(camera, r), None)).collect(),
                times,
            ));
        };
        let ctx = &self.ctx;
        let batch = batch_len(ctx, IN_BYTES.max(OUT_BYTES));
        let mut out = Vec::with_capacity(rays.len());
        for chunk in rays.chunks(batch) {
            let what = format!("generating and tracing {} primary rays", chunk.len());
            ctx.check_storage_binding(&what, chunk.len() as u64 * OUT_BYTES)?;
            let block = TraceUniform::new(chunk.len(), 0, DirectLightModel::zeroed());
            let (raw, ms) = self.run_scene_pass(
                scene,
                &scene.polar,
                ScenePass {
                    what: &what,
                    block,
                    inputs: &[
                        (6, bytemuck::bytes_of(camera), wgpu::BufferUsages::UNIFORM),
                        (7, bytemuck::cast_slice(chunk), wgpu::BufferUsages::STORAGE),
                    ],
                    resident: &[],
                    items: chunk.len(),
                    out_bytes: OUT_BYTES,
                },
            )?;
            times.add_batch(ms);
            out.extend(
                bytemuck::cast_slice::<u8, PolarHitGpu>(&raw)
                    .iter()
                    .take(chunk.len())
                    .map(|h| {
                        let hit = (h.hit.prim != MISS).then_some(GpuHit {
                            t: h.hit.t,
                            tri: h.hit.prim,
                            bary: [h.hit.u, h.hit.v],
                        });
                        (h.dir, hit)
                    }),
            );
        }
        times.total_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok((out, times))
    }
}

/// The shader's direction of `ray` through `camera`, on the CPU (f32 `cos`/`sin`, for a
/// scene without triangles, where nothing is dispatched).
fn direction(camera: &RayGenCamera, ray: &GpuPolarRay) -> [f32; 3] {
    let (s, c) = (ray.turn * camera.rad_per_turn).sin_cos();
    let (x, y) = (
        camera.centre[0] + ray.r_px * c,
        camera.centre[1] + ray.r_px * s,
    );
    let (a, b) = (x / camera.fx, y / camera.fy);
    let d: [f32; 3] =
        std::array::from_fn(|k| camera.forward[k] + a * camera.right[k] - b * camera.up[k]);
    let len = d.iter().map(|v| v * v).sum::<f32>().sqrt();
    d.map(|v| v / len)
}
