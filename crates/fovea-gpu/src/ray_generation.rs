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
    /// Pixels per unit of a polar ray's fixed-point offset (`1 / GpuPolarRay::Q_PER_PX`).
    pub px_per_q: f32,
    /// The origin of the rays' coordinates minus the principal point, pixels: the rings'
    /// centre for polar rays, the screen's `(0, 0)` for screen rays (`f32` of the f64
    /// difference).
    pub centre: [f32; 2],
    /// The f64 difference minus `floor(centre)`, pixels (within ~3e-8 px): polar rays add
    /// their offset to the centre as `(floor(centre) + whole pixels) + (centre_lo + fraction)`,
    /// integers first, so no sum needs its rounding error kept.
    pub centre_lo: [f32; 2],
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
        let split = |d: f64| {
            let hi = d as f32;
            (hi, (d - hi.floor() as f64) as f32)
        };
        let (cx_hi, cx_lo) = split(centre_px[0] - principal_px.0 as f64);
        let (cy_hi, cy_lo) = split(centre_px[1] - principal_px.1 as f64);
        Self {
            origin,
            fx: focal_px.0,
            forward,
            fy: focal_px.1,
            right,
            rad_per_turn: std::f32::consts::TAU,
            up,
            px_per_q: (1.0 / GpuPolarRay::Q_PER_PX) as f32,
            centre: [cx_hi, cy_hi],
            centre_lo: [cx_lo, cy_lo],
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

/// A polar buffer's primary ray as `ray_generation.wgsl` reads it: its screen point's offset
/// from the rings' centre, in fixed point (`Q_PER_PX` units a pixel), computed on the CPU
/// from the mapping's f64 polar coordinates `(r_px, turn)`.
///
/// Why not the polar coordinates themselves, as before: f32 `r_px` and `turn` (and f32
/// `cos`/`sin` on the device) put the point up to ~1.7e-3 px off at 8K, where a radius
/// reaches 5,000 px, against the mappings' 0.01 px bound; f32 `cos`/`sin` alone cost
/// `r · 6e-8` ≈ 3e-4 px there. The fixed-point offset is exact to `0.5 / Q_PER_PX` ≈ 7.6e-6 px
/// anywhere within ±32,768 px, and splits on the device into two f32s that hold it exactly
/// (`polar_point`: whole pixels and the fraction), still 8 bytes a ray. The device
/// compiler may rearrange float sums (Mesa does), so the shader keeps no rounding error
/// (no two-sum): the integers add exactly, the fractions are small.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPolarRay {
    /// `(x, y)` offset from the centre, `1 / Q_PER_PX` px units (screen +y down).
    pub offset_q: [i32; 2],
}

impl GpuPolarRay {
    /// Fixed-point units per pixel of [`Self::offset_q`] (2¹⁶: ±32,768 px, 1.5e-5 px steps).
    pub const Q_PER_PX: f64 = 65536.0;

    /// The ray at `r_px` pixels from the centre and `turn` turns (from +x towards +y), its
    /// offset computed in f64. Errors: a non-finite or negative radius, a non-finite angle,
    /// or an offset beyond ±32,767 px.
    pub fn new(r_px: f64, turn: f64) -> Result<Self> {
        if !(r_px.is_finite() && r_px >= 0.0 && turn.is_finite()) {
            return Err(GpuError::Input(format!(
                "polar ray (r = {r_px} px, {turn} turns) is not a finite point"
            )));
        }
        let (s, c) = (turn * std::f64::consts::TAU).sin_cos();
        let q = |d: f64| {
            let q = (d * Self::Q_PER_PX).round();
            (q.abs() < i32::MAX as f64).then_some(q as i32)
        };
        match (q(r_px * c), q(r_px * s)) {
            (Some(x), Some(y)) => Ok(Self { offset_q: [x, y] }),
            _ => Err(GpuError::Input(format!(
                "polar ray at {r_px} px from its centre: beyond the ±32,767 px a ray can reach"
            ))),
        }
    }

    /// The offset as the shader splits it: whole pixels and the fraction, both exact in f32.
    pub fn offset_parts(&self) -> [[f32; 2]; 2] {
        let part = |q: i32| {
            let whole = q >> 16;
            [
                whole as f32,
                (q - (whole << 16)) as f32 / Self::Q_PER_PX as f32,
            ]
        };
        let (x, y) = (part(self.offset_q[0]), part(self.offset_q[1]));
        [[x[0], y[0]], [x[1], y[1]]]
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

    /// The screen point of each of `rays` relative to the principal point as the device
    /// reconstructs it for [`closest_hits_polar_timed`](Self::closest_hits_polar_timed)
    /// (`polar_point` in `ray_generation.wgsl`), the f64 sum of the shader's f32 pair
    /// `hi + lo`: a probe of the frame's own function, for the tests of its precision. The
    /// scene needs a triangle (the pass binds the BVH).
    pub fn polar_points(
        &self,
        camera: &RayGenCamera,
        rays: &[GpuPolarRay],
    ) -> Result<Vec<[f64; 2]>> {
        if self.scene.is_none() {
            return Err(GpuError::Input(
                "the polar-point probe needs a scene with a triangle".into(),
            ));
        }
        let probe = match self.polar_probe.get() {
            Some(p) => p,
            None => {
                let built = self.ctx.scoped("building the polar-point probe", || {
                    crate::trace::SHADER
                        .pipelines_of(self.ctx.device(), &["polar_point_check"])
                        .pop()
                })?;
                let Some(p) = built else {
                    return Err(GpuError::Input(
                        "the trace module lacks its polar_point_check entry point".into(),
                    ));
                };
                self.polar_probe.get_or_init(|| p)
            }
        };
        let (out, _) = self.generated(
            camera,
            rays,
            |_| Some((probe, Vec::new())),
            |_, _| [f64::NAN; 2],
            |p: &[f32; 4]| [p[0] as f64 + p[2] as f64, p[1] as f64 + p[3] as f64],
        )?;
        Ok(out)
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

/// The shader's point of `ray` relative to the principal point, on the CPU (as
/// `polar_point` adds it up).
pub(crate) fn polar_offset(camera: &RayGenCamera, ray: &GpuPolarRay) -> [f32; 2] {
    let [whole, frac] = ray.offset_parts();
    let at = |k: usize| {
        let exact =
            camera.centre[k] as f64 + camera.centre_lo[k] as f64 + whole[k] as f64 + frac[k] as f64;
        exact as f32
    };
    [at(0), at(1)]
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
