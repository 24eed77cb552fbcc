//! Primary rays generated on the GPU (`shaders/ray_generation.wgsl`, part of the trace
//! module): each ray goes up as its screen point — 8 bytes instead of a 32-byte ray — the
//! shader builds the pinhole camera's ray through it and traces it, returning the hit and the
//! direction it cast.
//!
//! * A polar buffer's ray ([`GpuTracer::closest_hits_polar_timed`]) goes as the polar
//!   coordinates of its point around the mapping's centre, and the shader places the point
//!   (VaFR Eq. 11). The radii and angles are the CPU mapping's
//!   (`fovea_core::mapping::Ring::polar`, f64, once per column of the buffer).
//! * A screen-aligned buffer's ray (full resolution, Guenter's layers, the inset, Weier's
//!   sparse set: [`GpuTracer::closest_hits_screen_timed`]) goes as its screen point, the CPU
//!   mapping's `inverse` (f64) rounded to f32 — as `EyeCamera::ray` rounds it, so the shader
//!   starts from the CPU's own numbers. An f32 keeps 24 bits: at 11,520 px (the widest
//!   display preset's neighbourhood) its step is 2⁻¹⁰ ≈ 0.001 px.
//!
//! The camera's vectors, focal lengths, the coordinates' origin relative to the principal
//! point and 2π are uploaded in [`RayGenCamera`], so the shader derives nothing.
//!
//! Why the screen points are uploaded rather than generated on the device from the pixel grid
//! (which would spare the upload at full resolution): which rays exist — the texels the
//! mapping shades, those not `known` from reprojection, the plan's per-texel patterns and
//! per-column counts, the jitter, and which points map onto the screen — is decided once, by
//! the CPU's plan, for every method; a device-side grid would repeat those rules in WGSL for
//! one method, and its f32 sums `i + offset + jitter` would not be the CPU's f64 ones rounded.
//! The upload is 8 bytes a ray, a quarter of a traced ray's.

use bytemuck::{Pod, Zeroable};

use crate::error::{GpuError, Result};
use crate::trace::{
    DirectLightModel, GpuHit, GpuTracer, HitGpu, SceneBuffers, ScenePass, TraceTimes, TraceUniform,
    MISS,
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
    /// The origin of the rays' coordinates minus the principal point, pixels: the rings'
    /// centre for polar rays, the screen's `(0, 0)` for screen rays.
    pub centre: [f32; 2],
    _pad1: [f32; 2],
}

impl RayGenCamera {
    /// The block of a pinhole camera at `origin` with unit `forward`, `right`, `up`, focal
    /// lengths `focal_px`, principal point `principal_px` and the rays' coordinates around
    /// `centre_px` (screen pixels; subtracted here in f64): the rings' centre for
    /// [`GpuTracer::closest_hits_polar_timed`], `[0.0, 0.0]` for
    /// [`GpuTracer::closest_hits_screen_timed`].
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

impl GpuPolarRay {
    /// The ray at `r_px` pixels from the centre and `turn` turns, as the shader reads it.
    pub fn new(r_px: f64, turn: f64) -> Self {
        Self {
            r_px: r_px as f32,
            turn: turn as f32,
        }
    }
}

/// A primary ray as `closest_hit_screen` reads it: its screen point, pixels.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuScreenRay {
    /// Screen x, pixels.
    pub x_px: f32,
    /// Screen y, pixels (down).
    pub y_px: f32,
}

/// A generated ray's unit direction and its closest hit (`None`: a miss).
pub type GeneratedHit = ([f32; 3], Option<GpuHit>);

/// What the shader writes per ray (`GeneratedHit`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct GeneratedHitGpu {
    pub(crate) hit: HitGpu,
    pub(crate) dir: [f32; 3],
    _pad: f32,
}

/// The WGSL name and the Rust size of the per-ray output record (`tests/shaders.rs` compares
/// them with naga).
pub const GENERATED_HIT_STRUCT: (&str, usize) =
    ("GeneratedHit", std::mem::size_of::<GeneratedHitGpu>());

impl GpuTracer {
    /// Generates the primary ray of each of `rays` (polar coordinates around the camera
    /// block's centre) through `camera` and traces it: the unit direction it was cast along
    /// and its closest hit (`None`: a miss), and where the time went. A non-finite camera or
    /// ray is an input error naming it, before any work.
    pub fn closest_hits_polar_timed(
        &self,
        camera: &RayGenCamera,
        rays: &[GpuPolarRay],
    ) -> Result<(Vec<GeneratedHit>, TraceTimes)> {
        let bad = rays
            .iter()
            .position(|r| !(r.r_px.is_finite() && r.turn.is_finite() && r.r_px >= 0.0));
        if let Some(k) = bad {
            return Err(GpuError::Input(format!(
                "polar ray {k} is not a finite point ({:?})",
                rays[k]
            )));
        }
        self.generate(camera, rays, |s| &s.polar, |r| polar_offset(camera, r))
    }

    /// Generates the primary ray through each screen point of `rays` (pixels; the camera
    /// block's centre is the screen's origin, `RayGenCamera::new(…, [0.0, 0.0])`) and traces
    /// it, as [`closest_hits_polar_timed`](Self::closest_hits_polar_timed).
    pub fn closest_hits_screen_timed(
        &self,
        camera: &RayGenCamera,
        rays: &[GpuScreenRay],
    ) -> Result<(Vec<GeneratedHit>, TraceTimes)> {
        if let Some(k) = rays
            .iter()
            .position(|r| !(r.x_px.is_finite() && r.y_px.is_finite()))
        {
            return Err(GpuError::Input(format!(
                "screen ray {k} is not a finite point ({:?})",
                rays[k]
            )));
        }
        self.generate(
            camera,
            rays,
            |s| &s.screen,
            |r| [camera.centre[0] + r.x_px, camera.centre[1] + r.y_px],
        )
    }

    /// Runs `rays` (checked finite) through the ray-generation entry point `pipeline` of the
    /// scene in batches; `offset` is the shader's point relative to the principal point, for
    /// a scene without triangles (every ray misses without a dispatch).
    fn generate<R: Pod>(
        &self,
        camera: &RayGenCamera,
        rays: &[R],
        pipeline: impl Fn(&SceneBuffers) -> &wgpu::ComputePipeline,
        offset: impl Fn(&R) -> [f32; 2],
    ) -> Result<(Vec<GeneratedHit>, TraceTimes)> {
        self.generated(
            camera,
            rays,
            |scene| Some((pipeline(scene), Vec::new())),
            |r, _| (direction(camera, offset(r)), None),
            |h: &GeneratedHitGpu| {
                let hit = (h.hit.prim != MISS).then_some(GpuHit {
                    t: h.hit.t,
                    tri: h.hit.prim,
                    bary: [h.hit.u, h.hit.v],
                });
                (h.dir, hit)
            },
        )
    }

    /// Runs `rays` (checked finite) through a ray-generation entry point in batches that fit
    /// the device: `pass` gives the pipeline and the buffers already on the device for the
    /// scene (`None`: no pass, as for a scene without triangles), `missed` the answer to a
    /// ray without a pass (with its index), `answer` each ray's answer from the shader's
    /// record `O` (at binding 8; the rays at 7, the camera at 6).
    pub(crate) fn generated<'s, R: Pod, O: Pod, A>(
        &'s self,
        camera: &RayGenCamera,
        rays: &[R],
        pass: impl FnOnce(
            &'s SceneBuffers,
        ) -> Option<(&'s wgpu::ComputePipeline, Vec<(u32, &'s wgpu::Buffer)>)>,
        missed: impl Fn(&R, usize) -> A,
        answer: impl Fn(&O) -> A,
    ) -> Result<(Vec<A>, TraceTimes)> {
        let t = std::time::Instant::now();
        let mut times = TraceTimes::default();
        if !camera.is_finite() {
            return Err(GpuError::Input(format!(
                "the ray-generation camera has a non-finite or zero field: {camera:?}"
            )));
        }
        let Some((scene, (pipeline, resident))) = self
            .scene
            .as_ref()
            .and_then(|scene| pass(scene).map(|p| (scene, p)))
        else {
            // No triangles: every ray misses; the directions still come from the camera.
            times.total_ms = t.elapsed().as_secs_f64() * 1e3;
            return Ok((
                rays.iter().enumerate().map(|(i, r)| missed(r, i)).collect(),
                times,
            ));
        };
        let ctx = &self.ctx;
        let in_bytes = std::mem::size_of::<R>() as u64;
        let out_bytes = std::mem::size_of::<O>() as u64;
        let batch = batch_len(ctx, in_bytes.max(out_bytes));
        let mut out = Vec::with_capacity(rays.len());
        for chunk in rays.chunks(batch) {
            let what = format!("generating and tracing {} primary rays", chunk.len());
            ctx.check_storage_binding(&what, chunk.len() as u64 * out_bytes)?;
            let block = TraceUniform::new(chunk.len(), 0, DirectLightModel::zeroed());
            let (raw, ms) = self.run_scene_pass(
                scene,
                pipeline,
                ScenePass {
                    what: &what,
                    block,
                    inputs: &[
                        (6, bytemuck::bytes_of(camera), wgpu::BufferUsages::UNIFORM),
                        (7, bytemuck::cast_slice(chunk), wgpu::BufferUsages::STORAGE),
                    ],
                    resident: &resident,
                    items: chunk.len(),
                    out_bytes,
                },
            )?;
            times.add_batch(ms);
            out.extend(
                bytemuck::cast_slice::<u32, O>(&raw)
                    .iter()
                    .take(chunk.len())
                    .map(&answer),
            );
        }
        times.total_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok((out, times))
    }
}

/// The shader's point of `ray` relative to the principal point, on the CPU (f32 `cos`/`sin`).
pub(crate) fn polar_offset(camera: &RayGenCamera, ray: &GpuPolarRay) -> [f32; 2] {
    let (s, c) = (ray.turn * camera.rad_per_turn).sin_cos();
    [
        camera.centre[0] + ray.r_px * c,
        camera.centre[1] + ray.r_px * s,
    ]
}

/// The shader's direction through the point `[x, y]` pixels from the principal point, on the
/// CPU (for a scene without triangles, where nothing is dispatched).
pub(crate) fn direction(camera: &RayGenCamera, [x, y]: [f32; 2]) -> [f32; 3] {
    let (a, b) = (x / camera.fx, y / camera.fy);
    let d: [f32; 3] =
        std::array::from_fn(|k| camera.forward[k] + a * camera.right[k] - b * camera.up[k]);
    let len = d.iter().map(|v| v * v).sum::<f32>().sqrt();
    d.map(|v| v / len)
}
