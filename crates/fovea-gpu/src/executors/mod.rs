//! The GPU executors of the frame pipeline (docs/gpu.md "What runs where"): the adapters that
//! make this crate's passes the render traits' implementations, one file per executor, and
//! [`GpuExecutors::new`], which hands out a world's set of them on one device with the
//! readers of their times ([`GpuReport`], the pipeline's `ExecutorDevice`).
//!
//! | stage | trait | executor |
//! |---|---|---|
//! | trace, surfaces, shadow rays, direct and environment light | `fovea_render::pipeline::TraceExecutor` | [`GpuTraceExecutor`] |
//! | sample-space AA | `fovea_render::pipeline::AaExecutor` | [`GpuAaExecutor`] |
//! | reconstruct | `fovea_render::pipeline::ReconstructExecutor` | [`GpuReconstructExecutor`] |
//! | depth of field (gather) | `fovea_render::pipeline::DofExecutor` | [`GpuDofExecutor`] |
//! | sample-space denoiser | `fovea_render::pipeline::DenoiseExecutor` | [`GpuDenoiseExecutor`] |
//! | tone map, 8-bit output | `fovea_post::tonemap::ToneMapExecutor` | [`GpuToneExecutor`] |
//!
//! Callers (the CLI, the viewer through it, the bench) only choose a device and plug the
//! executors into their frame contexts; which stage then runs where is decided by the
//! pipeline from what each executor supports.

use std::collections::BTreeMap;
use std::sync::Arc;

use serde_json::{json, Map, Value};

use fovea_post::tonemap::ToneMapExecutor;
use fovea_render::pipeline::{ExecutorDevice, Executors, Lockstep, DEVICE_REPORT_KEYS};
use fovea_render::world::World;

use crate::error::{GpuError, Result};
use crate::{
    GpuContext, GpuDof, GpuEnvironment, GpuReconstructor, GpuRequest, GpuSampleAa, GpuSurfaces,
    GpuToneMap, GpuTracer,
};

mod aa;
pub mod denoise;
mod dof;
mod reconstruct;
pub mod times;
mod tone_map;
mod trace;

pub use aa::GpuAaExecutor;
pub use denoise::GpuDenoiseExecutor;
pub use dof::GpuDofExecutor;
pub use reconstruct::GpuReconstructExecutor;
pub use times::PassTimes;
pub use tone_map::GpuToneExecutor;
pub use trace::GpuTraceExecutor;

/// What a device must offer every frame of `world`: its largest binding, the triangles.
pub fn request_for(world: &World) -> GpuRequest {
    let bytes = world.tris.len() as u64 * crate::trace::TRIANGLE_BYTES;
    GpuRequest {
        storage_binding_bytes: bytes,
        buffer_bytes: bytes,
        ..GpuRequest::default()
    }
}

/// A world's GPU executors on one device.
pub struct GpuExecutors {
    /// The executors of a frame's context (the left eye's, or the only eye's).
    pub first: Executors,
    /// The right eye's executors for a binocular frame rendered in lockstep with the left's:
    /// second handles to the same device objects (its own AA filter, whose tables follow its
    /// own gaze).
    pub second: Executors,
    /// The 8-bit output's tone curve and encoding.
    pub tone_map: Box<dyn ToneMapExecutor>,
    /// The device and the executors' times.
    pub report: GpuReport,
}

impl GpuExecutors {
    /// Uploads `world` (BVH, surfaces, environment) to `ctx`'s device and builds every
    /// executor's pipelines. Scene surfaces the device cannot hold (a texture larger than a
    /// binding) stay on the CPU, as the report's `gpu_surfaces` says.
    pub fn new(ctx: &GpuContext, world: &World) -> Result<Self> {
        let tracer = GpuTracer::new(ctx, &world.tris.vertex_arrays())?;
        let s = tracer.stats();
        let bvh = json!({
            "triangles": s.triangles,
            "nodes": s.nodes,
            "depth": s.depth,
            "build_ms": s.build_ms,
        });
        let (surfaces, surfaces_json) = match GpuSurfaces::new(&tracer, world) {
            Ok(surfaces) => {
                let s = surfaces.stats();
                let json = json!({
                    "triangles": s.triangles,
                    "vertices": s.vertices,
                    "materials": s.materials,
                    "textures": s.textures,
                    "mip_levels": s.mip_levels,
                    "bytes": s.bytes,
                    "texel_bytes": s.texel_bytes,
                    "upload_ms": s.upload_ms,
                });
                (Ok(Arc::new(surfaces)), json)
            }
            Err(e @ (GpuError::AdapterTooSmall { .. } | GpuError::Unsupported(_))) => {
                let why = format!("no surfaces on the device: {e}");
                (Err(why), json!({ "on_cpu_because": e.to_string() }))
            }
            Err(e) => return Err(e),
        };
        let times = PassTimes::default();
        let tracer = GpuTraceExecutor {
            gpu: Arc::new(tracer),
            no_surfaces: surfaces.as_ref().err().cloned(),
            surfaces: surfaces.ok(),
            fingerprint: world.tris_fingerprint,
            environment: Arc::new(GpuEnvironment::new(ctx, &world.scene.environment)?),
            times: times.trace.clone(),
            shadow_times: times.shadow.clone(),
            direct_times: times.direct_light.clone(),
            environment_times: times.environment_light.clone(),
        };
        let reconstructor = GpuReconstructExecutor {
            gpu: Arc::new(GpuReconstructor::new(ctx)?),
            times: times.reconstruct.clone(),
        };
        let dof = GpuDofExecutor {
            gpu: Arc::new(GpuDof::new(ctx)?),
            times: times.dof.clone(),
        };
        let aa = || -> Result<GpuAaExecutor> {
            Ok(GpuAaExecutor {
                gpu: Arc::new(GpuSampleAa::new(ctx)?),
                times: times.aa.clone(),
            })
        };
        let second = Executors {
            tracer: Some(Box::new(tracer.clone())),
            reconstructor: Some(Box::new(reconstructor.clone())),
            dof: Some(Box::new(dof.clone())),
            anti_aliaser: Some(Box::new(aa()?)),
            denoiser: Some(Box::new(GpuDenoiseExecutor::new(ctx)?)),
        };
        let first = Executors {
            tracer: Some(Box::new(tracer)),
            reconstructor: Some(Box::new(reconstructor)),
            dof: Some(Box::new(dof)),
            anti_aliaser: Some(Box::new(aa()?)),
            denoiser: Some(Box::new(GpuDenoiseExecutor::new(ctx)?)),
        };
        let tone_map = Box::new(GpuToneExecutor {
            gpu: GpuToneMap::new(ctx)?,
            times: times.tone_map.clone(),
        });
        Ok(Self {
            first,
            second,
            tone_map,
            report: GpuReport {
                ctx: ctx.clone(),
                times,
                bvh,
                surfaces: surfaces_json,
            },
        })
    }
}

/// The device of a set of GPU executors and the readers of their times.
#[derive(Clone)]
pub struct GpuReport {
    ctx: GpuContext,
    /// The executors' slots.
    pub times: PassTimes,
    bvh: Value,
    surfaces: Value,
}

impl GpuReport {
    /// The device.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }
}

impl ExecutorDevice for GpuReport {
    fn lockstep(&self) -> Arc<dyn Lockstep + Send + Sync> {
        Arc::new(self.ctx.clone())
    }

    fn traffic(&self) -> BTreeMap<String, u64> {
        self.ctx
            .traffic()
            .named()
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect()
    }

    fn take_pass_ms(&self) -> Vec<(&'static str, f64)> {
        self.times.take_pass_ms()
    }

    fn tone_mapped(&self) -> bool {
        self.times.tone_mapped()
    }

    fn report(&self) -> Map<String, Value> {
        use times::peek;
        let t = &self.times;
        let c = self.ctx.submission_counts();
        let values = [
            json!(peek(&t.reconstruct)),
            json!(peek(&t.dof)),
            json!(peek(&t.aa)),
            json!(peek(&t.trace)),
            json!(peek(&t.shadow)),
            json!(peek(&t.direct_light)),
            json!(peek(&t.environment_light)),
            json!(peek(&t.tone_map)),
            self.bvh.clone(),
            self.surfaces.clone(),
            json!({
                "submissions": c.submissions,
                "joint": c.joint,
                "posted": c.posted,
                "timed_out": c.timed_out,
            }),
            json!(self.traffic()),
        ];
        DEVICE_REPORT_KEYS
            .iter()
            .map(|k| k.to_string())
            .zip(values)
            .collect()
    }
}
