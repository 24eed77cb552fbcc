//! The resident frame's sample side (issue 37): per texel, kernels of `shaders/frame_shade.wgsl`
//! — the ray placed and traced and the surface at its hit interpolated (`frame_surface`), each
//! light's contribution behind its shadow ray (`frame_direct`), the environment's MIS estimate
//! behind its shadow rays (`frame_environment`), emission first — writing colour and depth into
//! the frame's [`DeviceSamples`](super::DeviceSamples), which never come back to the host; the
//! G-buffer between the kernels stays on the device.
//!
//! The arithmetic is the staged passes' own WGSL (`trace.wgsl`, `ray_generation.wgsl`,
//! `surface.wgsl`, `direct_light.wgsl`, `environment_light.wgsl`: the renderer's
//! `fovea_render::trace::surface`, `shade::direct`, `shade::environment_light` step for step),
//! concatenated and called from three entry points, so the resident samples are the staged
//! path's and the CPU's `trace_and_shade` for direct shading of one ray per texel
//! (`tests/frame_shade.rs`). Each kernel walks the BVH from one place, as each staged pass does
//! (lavapipe corrupts memory running kernels that inline the traversal more than once; see
//! docs/gpu.md). What the kernels serve, and the typed refusal of everything else before
//! anything is recorded, is [`supports`].
//!
//! [`ShadeScene`] holds what one world puts on the device once — the BVH
//! ([`GpuTracer`]), the surfaces ([`GpuSurfaces`]), the environment ([`GpuEnvironment`]), the
//! lights and the pipelines; [`super::context`] holds each eye's buffers.

use bytemuck::{Pod, Zeroable};
use fovea_core::mapping::Method;
use fovea_render::plan::FramePlan;
use fovea_render::shade::{EnvLight, ShadingMode, MAX_ENV_SAMPLES};
use fovea_render::world::World;

use crate::device::GpuContext;
use crate::direct_light::GpuLight;
use crate::environment_light::GpuEnvironment;
use crate::error::{GpuError, Result};
use crate::shaders::ShaderSource;
use crate::surface::GpuSurfaces;
use crate::trace::{DirectLightModel, GpuTracer, TraceUniform, MAX_DISTANCE};

/// The module: the staged passes' files with `frame_shade.wgsl` appended (and the list of
/// shaded texels' `frame_compact.wgsl`, [`super::compact`]); the frame creates pipelines for
/// [`ENTRY_POINTS`] and [`super::compact::ENTRY_POINT`] only, not for the ten the other files
/// bring along.
pub const SHADER: ShaderSource = ShaderSource {
    file: "frame_shade.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/trace.wgsl"),
        include_str!("../../shaders/direct_light.wgsl"),
        include_str!("../../shaders/ray_generation.wgsl"),
        include_str!("../../shaders/surface.wgsl"),
        include_str!("../../shaders/environment_light.wgsl"),
        include_str!("../../shaders/frame_shade_layers.wgsl"),
        include_str!("../../shaders/frame_shade.wgsl"),
        include_str!("../../shaders/frame_sparse.wgsl"),
        include_str!("../../shaders/frame_compact.wgsl")
    ),
    entry_points: &[
        "closest_hit",
        "any_hit",
        "direct_light",
        "closest_hit_polar",
        "closest_hit_screen",
        "surface_polar",
        "surface_screen",
        "environment_light",
        "mix64_check",
        "polar_point_check",
        "frame_surface",
        "frame_direct",
        "frame_environment",
        "frame_compact",
    ],
    uniform: ("FrameParams", std::mem::size_of::<FrameUniform>()),
};

/// The resident kernels' entry points, in the order they run: the surface at each texel's
/// primary hit, then its lights, then the environment's light.
pub const ENTRY_POINTS: [&str; 3] = ["frame_surface", "frame_direct", "frame_environment"];

/// Storage buffers the kernels' layout binds in one stage: the BVH's three, the surfaces'
/// five, the lights, the environment map's two, the columns, the runs, the samples, the
/// G-buffer's two, the denoiser's three guides and the list of shaded texels' two
/// ([`super::compact`]).
pub const STORAGE_BUFFERS: u32 = 21;

/// Bytes per texel of each of the two G-buffer records the kernels keep on the device
/// (`frame_geometry`, `frame_material`: two `vec4<f32>` each).
pub const GBUFFER_TEXEL_BYTES: u64 = 32;

/// `FrameParams.kind` of a polar buffer.
pub const KIND_POLAR: u32 = 0;
/// `FrameParams.kind` of a screen-aligned (full-resolution) buffer.
pub const KIND_SCREEN: u32 = 1;
/// `FrameParams.kind` of a layer of a screen-aligned layered buffer (Guenter's layers;
/// `super::layers`).
pub const KIND_LAYERED: u32 = 2;
/// `FrameParams.kind` of Weier's sparse screen pattern: a screen-aligned buffer shaded where
/// the pattern's tables in the runs binding say (`frame_sparse.wgsl`).
pub const KIND_SPARSE: u32 = 3;

/// `FrameLayer` of `frame_shade.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct FrameLayerGpu {
    /// First texel of the layer in the sample buffer.
    pub offset: u32,
    /// Width, texels.
    pub width: u32,
    /// Height, texels.
    pub height: u32,
    /// The high word of the layer's shading keys (layer, eye, frame).
    pub key_hi: u32,
}

/// The uniform block `FrameParams` of `frame_shade.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct FrameUniform {
    /// Texels of the layer.
    pub texels: u32,
    /// [`KIND_POLAR`] or [`KIND_SCREEN`].
    pub kind: u32,
    /// `f32::INFINITY.to_bits()`.
    pub inf_bits: u32,
    /// 1: the environment as the unshadowed ambient term; 0: occluded.
    pub unshadowed: u32,
    /// The layer.
    pub layer: FrameLayerGpu,
    /// The ray's offset in its texel plus the jitter, buffer texels.
    pub offset: [f32; 2],
    /// A screen-aligned texel's ray cone, radians.
    pub pixel_spread: f32,
    /// Invocations per row of the dispatch's grid.
    pub row_invocations: u32,
    /// The environment's mean radiance (xyz).
    pub ambient: [f32; 4],
    /// `rank[j % 4][i % 4]`: a texel's rank in its 4×4 tile.
    pub rank: [[u32; 4]; 4],
    /// 1: the kernels write the denoiser's guides (bindings 27–29); 0: they do not.
    pub guides: u32,
    /// 1: the kernels run over the list of shaded texels ([`super::compact`]); 0: over every
    /// texel, tile by tile.
    pub listed: u32,
    /// Padding.
    pub pad: [u32; 2],
}

/// `FrameColumn` of `frame_shade.wgsl`: a polar column's ring, cone and first run.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FrameColumnGpu {
    /// The ring's radius, pixels.
    pub r_px: f32,
    /// Rows per turn (≤ 0: the pole only).
    pub period: f32,
    /// The cone of the column's rays, radians.
    pub spread: f32,
    /// Its first shaded run in the runs buffer.
    pub runs: u32,
}

/// The WGSL names and Rust sizes of the kernel's records (`tests/shaders.rs` compares them
/// with naga).
pub const RECORD_STRUCTS: [(&str, usize); 3] = [
    ("FrameParams", std::mem::size_of::<FrameUniform>()),
    ("FrameLayer", std::mem::size_of::<FrameLayerGpu>()),
    ("FrameColumn", std::mem::size_of::<FrameColumnGpu>()),
];

/// How a supported plan's texels place their rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayLayout {
    /// On their column's ring (a polar buffer of one layer).
    Polar,
    /// Through the screen point of the texel (full resolution).
    Screen,
    /// Through the screen point of the texel in its layer, one dispatch per layer
    /// (Guenter's layers; [`super::layers`]).
    Layered,
    /// Through the screen point of the texel where Weier's sparse pattern casts a ray
    /// ([`super::weier_pattern`]).
    Sparse,
}

/// Whether the resident kernel renders `plan`'s samples exactly as the CPU's
/// `trace_and_shade` would, and how; [`GpuError::Unsupported`] naming what it lacks otherwise.
/// Decided before anything is recorded.
pub fn supports(plan: &FramePlan) -> Result<RayLayout> {
    let unsupported = |what: String| Err(GpuError::Unsupported(what));
    let env_light = match plan.settings.shading {
        // Indirect light: the bounce kernels after the direct ones (`super::bounce`).
        ShadingMode::Direct { env_light } | ShadingMode::Indirect { env_light, .. } => env_light,
        ShadingMode::Path { .. } => {
            return unsupported("path tracing in the resident frame (use --shading direct)".into())
        }
    };
    if let EnvLight::Occluded { samples } = env_light {
        if samples > MAX_ENV_SAMPLES {
            return unsupported(format!("{samples} environment rays per sample"));
        }
    }
    if !plan.rays.per_column.is_empty() || plan.rays.uniform != 1 {
        return unsupported(format!(
            "{} rays per texel (periphery rays or pixel samples) in the resident frame",
            plan.rays.most()
        ));
    }
    if plan.culling.is_some() {
        return unsupported("DOF-aware culling in the resident frame".into());
    }
    let mapping = plan.mapping();
    if !mapping.screen_layers().is_empty() {
        if let ShadingMode::Indirect { bounces, .. } = plan.settings.shading {
            // The bounce kernels read the G-buffer of one layer; a layered buffer reuses it
            // layer after layer.
            return unsupported(format!(
                "indirect light ({bounces} bounces) on {}'s layers in the resident frame (use \
                 --shading direct)",
                plan.method()
            ));
        }
        super::layers::supports(plan)?;
        return Ok(RayLayout::Layered);
    }
    if plan.buffers.len() != 1 {
        return unsupported(format!(
            "{} sample layers ({}) in the resident frame",
            plan.buffers.len(),
            plan.method()
        ));
    }
    if mapping.polar_layout().is_some() {
        return Ok(RayLayout::Polar);
    }
    if plan.method() == Method::Full {
        return Ok(RayLayout::Screen);
    }
    if plan.method() == Method::Weier && mapping.weier_sparse().is_some() {
        return Ok(RayLayout::Sparse);
    }
    unsupported(format!(
        "the {} mapping's screen-aligned samples in the resident frame",
        plan.method()
    ))
}

/// What one world puts on the device for the resident kernel, once: the BVH, the surfaces,
/// the environment, the lights, the shading model's block and the pipeline.
pub struct ShadeScene {
    pub(crate) ctx: GpuContext,
    pub(crate) tracer: GpuTracer,
    pub(crate) surfaces: GpuSurfaces,
    pub(crate) environment: GpuEnvironment,
    /// The world's lights as uploaded (rewritten when the world's change).
    pub(crate) lights: Vec<GpuLight>,
    pub(crate) lights_buffer: wgpu::Buffer,
    /// `TraceParams`: the light count and the shading model.
    pub(crate) trace_params: wgpu::Buffer,
    /// `frame_surface`, `frame_direct`, `frame_environment`.
    pub(crate) pipelines: [wgpu::ComputePipeline; 3],
    /// `frame_compact`: the list of shaded texels ([`super::compact`]).
    pub(crate) compact: wgpu::ComputePipeline,
    fingerprint: u64,
}

/// Whether every field of `l` is finite.
fn light_is_finite(l: &GpuLight) -> bool {
    [l.position, l.direction, l.intensity]
        .iter()
        .flatten()
        .chain([&l.cos_inner, &l.cos_outer, &l.range])
        .all(|v| v.is_finite())
}

/// The kernel's bindings in group 0: `(binding, uniform, read-only)` (uniform blocks, then
/// storage buffers), declared rather than derived from what the entry point reads, so the
/// layout does not change with the code.
pub const BINDINGS: [(u32, bool, bool); 27] = [
    (0, true, true),    // TraceParams
    (1, false, true),   // BVH nodes
    (2, false, true),   // triangles
    (3, false, true),   // triangle ids
    (6, true, true),    // RayGenCamera
    (7, false, true),   // lights
    (9, false, true),   // surface triangles
    (10, false, true),  // vertices
    (11, false, true),  // materials
    (12, false, true),  // mip levels
    (13, false, true),  // texels
    (14, true, true),   // SurfaceModel
    (16, true, true),   // EnvParams
    (17, false, true),  // environment pixels
    (18, false, true),  // environment tables
    (21, true, true),   // FrameParams
    (22, false, true),  // columns
    (23, false, true),  // runs
    (24, false, false), // the sample buffers
    (25, false, false), // the G-buffer's geometry
    (26, false, false), // the G-buffer's material
    (27, false, false), // the denoiser's albedo guide
    (28, false, false), // the denoiser's normal guide
    (29, false, false), // the denoiser's Monte Carlo part
    (30, true, true),   // FrameScreenLayer (a layered buffer's layer)
    // 31–34: the bounce kernels' (`super::bounce`).
    (35, false, false), // the list of shaded texels (`super::compact::BINDINGS`)
    (36, false, false), // its count
];

/// The kernels' pipelines with their declared layout ([`BINDINGS`]), in the order of
/// [`ENTRY_POINTS`], and the list's ([`super::compact::ENTRY_POINT`]). Call inside an error
/// scope.
fn pipelines(device: &wgpu::Device) -> ([wgpu::ComputePipeline; 3], wgpu::ComputePipeline) {
    let [surface, direct, environment, compact] = declared_pipelines(
        device,
        "resident frame",
        &BINDINGS,
        &SHADER,
        [
            ENTRY_POINTS[0],
            ENTRY_POINTS[1],
            ENTRY_POINTS[2],
            super::compact::ENTRY_POINT,
        ],
    );
    ([surface, direct, environment], compact)
}

/// `entry_points` of `shader`, one pipeline each, over one bind group laid out as `bindings`
/// declares (`(binding, uniform, read-only)`; see [`BINDINGS`]) rather than as the entry
/// points happen to read: the resident kernels' and the bounce kernels' shared layout rule.
/// Call inside an error scope.
pub(crate) fn declared_pipelines<const N: usize>(
    device: &wgpu::Device,
    label: &str,
    bindings: &[(u32, bool, bool)],
    shader: &ShaderSource,
    entry_points: [&str; N],
) -> [wgpu::ComputePipeline; N] {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = bindings
        .iter()
        .map(
            |&(binding, uniform, read_only)| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: if uniform {
                        wgpu::BufferBindingType::Uniform
                    } else {
                        wgpu::BufferBindingType::Storage { read_only }
                    },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
        )
        .collect();
    let group = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(&group)],
        immediate_size: 0,
    });
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(shader.file),
        source: wgpu::ShaderSource::Wgsl(shader.source.into()),
    });
    entry_points.map(|entry| {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        })
    })
}

/// A light as uploaded: its range made finite (WGSL may assume no infinities).
fn gpu_lights(world: &World) -> Vec<GpuLight> {
    world
        .lights
        .iter()
        .map(|l| {
            let g = GpuLight::of(l);
            GpuLight {
                range: g.range.min(MAX_DISTANCE),
                ..g
            }
        })
        .collect()
}

impl ShadeScene {
    /// Uploads `world` (BVH, surfaces, environment, lights) and builds the kernel's pipeline.
    /// Errors before any allocation where the device cannot run the kernel (fewer than
    /// [`STORAGE_BUFFERS`] storage buffers per stage: [`GpuError::Unsupported`]; textures
    /// larger than a binding: [`GpuError::AdapterTooSmall`]), and for a scene without
    /// triangles.
    pub fn new(ctx: &GpuContext, world: &World) -> Result<Self> {
        let per_stage = ctx.limits().max_storage_buffers_per_shader_stage;
        if per_stage < STORAGE_BUFFERS {
            return Err(GpuError::Unsupported(format!(
                "the resident frame binds {STORAGE_BUFFERS} storage buffers in one stage, the \
                 device {per_stage}"
            )));
        }
        if world.tris.is_empty() {
            return Err(GpuError::Unsupported(
                "a scene without triangles in the resident frame".into(),
            ));
        }
        let lights = gpu_lights(world);
        if let Some(k) = lights.iter().position(|l| !light_is_finite(l)) {
            return Err(GpuError::Input(format!("light {k} has a non-finite field")));
        }
        let tracer = GpuTracer::new(ctx, &world.tris.vertex_arrays())?;
        let surfaces = GpuSurfaces::new(&tracer, world)?;
        let environment = GpuEnvironment::new(ctx, &world.scene.environment)?;
        let lights_bytes = (lights.len().max(1) * std::mem::size_of::<GpuLight>()) as u64;
        ctx.check_storage_binding("the lights", lights_bytes)?;
        let block = TraceUniform::new(0, lights.len(), DirectLightModel::RENDERER);
        let (lights_buffer, trace_params, (pipelines, compact)) =
            ctx.scoped("building the resident frame's kernel", || {
                let lights_buffer = ctx.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("frame lights"),
                    size: lights_bytes,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                if !lights.is_empty() {
                    ctx.write_buffer(&lights_buffer, 0, bytemuck::cast_slice(&lights));
                }
                let trace_params = crate::transfer::upload(
                    ctx,
                    "frame trace parameters",
                    bytemuck::bytes_of(&block),
                    wgpu::BufferUsages::UNIFORM,
                );
                let pipelines = pipelines(ctx.device());
                (lights_buffer, trace_params, pipelines)
            })?;
        Ok(Self {
            ctx: ctx.clone(),
            tracer,
            surfaces,
            environment,
            lights,
            lights_buffer,
            trace_params,
            pipelines,
            compact,
            fingerprint: world.tris_fingerprint,
        })
    }

    /// Whether this scene was built from `world`'s triangles.
    pub fn serves(&self, world: &World) -> bool {
        world.tris_fingerprint == self.fingerprint
    }

    /// Rewrites the lights where `world`'s differ from those uploaded (same count: a light
    /// moved or changed); another count needs a new scene ([`GpuError::Input`]).
    pub(crate) fn update_lights(&mut self, world: &World) -> Result<()> {
        let lights = gpu_lights(world);
        if lights == self.lights {
            return Ok(());
        }
        if lights.len() != self.lights.len() {
            return Err(GpuError::Input(format!(
                "the world has {} lights, the resident frame's scene {}: build a new scene",
                lights.len(),
                self.lights.len()
            )));
        }
        if let Some(k) = lights.iter().position(|l| !light_is_finite(l)) {
            return Err(GpuError::Input(format!("light {k} has a non-finite field")));
        }
        self.ctx
            .write_buffer(&self.lights_buffer, 0, bytemuck::cast_slice(&lights));
        self.lights = lights;
        Ok(())
    }

    /// The device.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The tracer (the BVH on the device).
    pub fn tracer(&self) -> &GpuTracer {
        &self.tracer
    }
}
