//! Indirect light in the resident frame (issues 37 and 38): the renderer's
//! [`fovea_render::shade::indirect`] — a path tracer (Kajiya 1986) from each texel's primary
//! hit with next-event estimation of every light and of the environment at each bounce
//! (Veach's thesis Sec. 9.2), Russian roulette from the second bounce on (Arvo and Kirk 1990)
//! — on the device, after the primary's lights and environment (`shaders/frame_bounce.wgsl`),
//! with the CPU's random numbers: the first bounce's hashed from the texel's key without its
//! frame and rotated by the frame's point of the (0, 2)-sequence, the later ones hashed from
//! the key with its frame and eye (`fovea_render::shade::frame_noise`).
//!
//! A path advances one bounce at a time, three kernels a bounce — the bounce traced and its
//! surface interpolated, that surface's lights, its environment — each walking the BVH from
//! one place as the primary's kernels do ([`super::shade`]), then one kernel adds each path's
//! light to its texel. They run in the eye's shading pass, after `frame_environment`, only for
//! plans with bounces ([`ShadingMode::Indirect`]): the direct frame records exactly what it
//! recorded before. Their module is separate from the direct kernels' (compiled when a plan
//! first asks for bounces), and so is their bind group: the direct kernels' bindings, but an
//! environment block with the bounce's ray count ([`bounce_env_light`]), plus
//! [`BounceUniform`] (binding 31) and the paths (bindings 32–34, [`PATH_TEXEL_BYTES`] a texel
//! in three buffers of at most 32 bytes a texel, as the G-buffer's two: a binding's size
//! bounds the texels, 4.19 M on lavapipe's 128 MiB).

use bytemuck::{Pod, Zeroable};
use fovea_render::plan::FramePlan;
use fovea_render::shade::frame_noise::UNIT_BITS;
use fovea_render::shade::{
    bounce_env_key_mask, bounce_env_light, EnvLight, ShadingMode, BOUNCE_LATER_SALT, BOUNCE_SALT,
    BOUNCE_SPREAD_RAD, ROULETTE_MAX,
};

use super::shade::{declared_pipelines, ShadeScene, BINDINGS};
use crate::environment_light::EnvUniform;
use crate::error::{GpuError, Result};
use crate::shaders::ShaderSource;

/// The module: the direct kernels' ([`super::shade::SHADER`]) with `frame_bounce.wgsl`
/// appended; the frame creates pipelines for [`ENTRY_POINTS`] only.
pub const SHADER: ShaderSource = ShaderSource {
    file: "frame_bounce.wgsl",
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
        include_str!("../../shaders/frame_compact.wgsl"),
        include_str!("../../shaders/frame_bounce.wgsl")
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
        "frame_bounce_trace",
        "frame_bounce_direct",
        "frame_bounce_environment",
        "frame_bounce_add",
    ],
    uniform: ("BounceParams", std::mem::size_of::<BounceUniform>()),
};

/// The bounce kernels: per bounce the first three in order, then the last once.
pub const ENTRY_POINTS: [&str; 4] = [
    "frame_bounce_trace",
    "frame_bounce_direct",
    "frame_bounce_environment",
    "frame_bounce_add",
];

/// Bytes per texel of each of the paths' three buffers (`frame_paths_a`, `_b`, `_c`: two, two
/// and one `vec4<u32>`: throughput and depth, position and the random stream's low word;
/// `to_eye` and its high word, the sum; the vertex's emission and lights).
pub const PATH_TEXEL_BYTES: [u64; 3] = [32, 32, 16];

/// Storage buffers the bounce kernels' layout binds in one stage: the direct kernels' and the
/// paths' three.
pub const STORAGE_BUFFERS: u32 = super::shade::STORAGE_BUFFERS + 3;

/// Most bounces of a plan ([`ShadingMode::validate`]'s range): the keys' table.
pub const MAX_BOUNCES: usize = 16;

/// The uniform block `BounceParams` of `frame_bounce.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct BounceUniform {
    /// Bounces of the plan.
    pub bounces: u32,
    /// Bits of a random number ([`UNIT_BITS`]).
    pub unit_bits: u32,
    /// Largest survival probability of the roulette ([`ROULETTE_MAX`]).
    pub roulette_max: f32,
    /// The bounce ray's cone, radians ([`BOUNCE_SPREAD_RAD`]).
    pub spread: f32,
    /// [`BOUNCE_SALT`], low and high word.
    pub first_salt: [u32; 2],
    /// [`BOUNCE_LATER_SALT`], low and high word.
    pub later_salt: [u32; 2],
    /// [`bounce_env_key_mask`] of each depth (x low, y high word; z, w zero).
    pub env_keys: [[u32; 4]; MAX_BOUNCES],
}

/// A `u64` as (low, high) words.
fn words(x: u64) -> [u32; 2] {
    [x as u32, (x >> 32) as u32]
}

impl BounceUniform {
    /// The block of a plan with `bounces` bounces (at most [`MAX_BOUNCES`]).
    pub fn new(bounces: u32) -> Self {
        let mut env_keys = [[0u32; 4]; MAX_BOUNCES];
        for (depth, k) in env_keys.iter_mut().enumerate() {
            let [lo, hi] = words(bounce_env_key_mask(depth as u32));
            *k = [lo, hi, 0, 0];
        }
        Self {
            bounces: bounces.min(MAX_BOUNCES as u32),
            unit_bits: UNIT_BITS,
            roulette_max: ROULETTE_MAX,
            spread: BOUNCE_SPREAD_RAD,
            first_salt: words(BOUNCE_SALT),
            later_salt: words(BOUNCE_LATER_SALT),
            env_keys,
        }
    }
}

/// Bounces of indirect light `plan` asks for (0: direct shading).
pub fn plan_bounces(plan: &FramePlan) -> u32 {
    match plan.settings.shading {
        ShadingMode::Indirect { bounces, .. } => bounces,
        _ => 0,
    }
}

/// Environment rays at a bounce's surface of a plan whose primary hit takes `env_light`
/// ([`bounce_env_light`]; 0 also for the unshadowed ambient term, which the kernel adds
/// without rays).
pub fn bounce_env_samples(env_light: EnvLight) -> u32 {
    match bounce_env_light(env_light) {
        EnvLight::Occluded { samples } => samples,
        EnvLight::Unshadowed => 0,
    }
}

/// The bounce kernels' bindings: the direct kernels' ([`BINDINGS`]), the block and the paths.
fn bindings() -> Vec<(u32, bool, bool)> {
    let mut b = BINDINGS.to_vec();
    b.extend([
        (31, true, true),
        (32, false, false),
        (33, false, false),
        (34, false, false),
    ]);
    b
}

/// The bounce kernels' pipelines ([`ENTRY_POINTS`], one layout), built once per scene when a
/// plan first asks for bounces.
pub struct BounceKernels {
    pipelines: [wgpu::ComputePipeline; 4],
}

impl BounceKernels {
    /// Compiles the module and builds the pipelines on `scene`'s device.
    /// Refused ([`GpuError::Unsupported`]) on a device with fewer than [`STORAGE_BUFFERS`]
    /// storage buffers per stage.
    pub fn new(scene: &ShadeScene) -> Result<Self> {
        let ctx = scene.context();
        let per_stage = ctx.limits().max_storage_buffers_per_shader_stage;
        if per_stage < STORAGE_BUFFERS {
            return Err(GpuError::Unsupported(format!(
                "indirect light in the resident frame binds {STORAGE_BUFFERS} storage buffers \
                 in one stage, the device {per_stage}"
            )));
        }
        let pipelines = ctx.scoped("building the resident frame's bounce kernels", || {
            declared_pipelines(
                ctx.device(),
                "resident frame bounces",
                &bindings(),
                &SHADER,
                ENTRY_POINTS,
            )
        })?;
        Ok(Self { pipelines })
    }
}

/// One eye's bounce buffers and bind group: the bounce's environment block, [`BounceUniform`],
/// the paths (room for the eye's texel capacity).
pub struct EyeBounce {
    env: wgpu::Buffer,
    params: wgpu::Buffer,
    _paths: [wgpu::Buffer; 3],
    bind_group: wgpu::BindGroup,
    pipelines: [wgpu::ComputePipeline; 4],
    /// Bounces of the plan last written.
    bounces: u32,
}

impl EyeBounce {
    /// Allocates the buffers for `capacity` texels and binds them with `shared` (the eye's
    /// bindings of the direct kernels but the environment block, binding 16).
    pub(crate) fn new(
        scene: &ShadeScene,
        kernels: &BounceKernels,
        shared: &[(u32, &wgpu::Buffer)],
        capacity: u64,
    ) -> Result<Self> {
        let ctx = scene.context();
        let path_bytes = PATH_TEXEL_BYTES.map(|b| capacity.max(1) * b);
        for bytes in path_bytes {
            ctx.check_storage_binding("the resident frame's paths (indirect light)", bytes)?;
        }
        ctx.scoped("allocating an eye's bounces of the resident frame", || {
            let buffer = |label: &str, bytes: u64, usage: wgpu::BufferUsages| {
                ctx.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes.max(16),
                    usage: usage | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            };
            let uniform = wgpu::BufferUsages::UNIFORM;
            let env = buffer(
                "frame bounce environment",
                std::mem::size_of::<EnvUniform>() as u64,
                uniform,
            );
            let params = buffer(
                "frame bounce parameters",
                std::mem::size_of::<BounceUniform>() as u64,
                uniform,
            );
            let paths =
                path_bytes.map(|bytes| buffer("frame paths", bytes, wgpu::BufferUsages::STORAGE));
            let mut entries: Vec<(u32, &wgpu::Buffer)> =
                shared.iter().copied().filter(|&(b, _)| b != 16).collect();
            entries.extend([
                (16, &env),
                (31, &params),
                (32, &paths[0]),
                (33, &paths[1]),
                (34, &paths[2]),
            ]);
            let bind_group = crate::transfer::bind_group(
                ctx,
                "resident frame bounces",
                &kernels.pipelines[0],
                &entries,
            );
            Self {
                env,
                params,
                _paths: paths,
                bind_group,
                pipelines: kernels.pipelines.clone(),
                bounces: 0,
            }
        })
    }

    /// Writes the blocks of `plan` (its bounces and the bounce's environment rays).
    pub(crate) fn write(&mut self, scene: &ShadeScene, plan: &FramePlan) {
        let ctx = scene.context();
        let bounces = plan_bounces(plan);
        let env_light = plan
            .settings
            .shading
            .direct_env_light()
            .unwrap_or(EnvLight::Occluded { samples: 0 });
        let env = scene.environment.uniform(bounce_env_samples(env_light));
        ctx.write_buffer(&self.env, 0, bytemuck::bytes_of(&env));
        ctx.write_buffer(
            &self.params,
            0,
            bytemuck::bytes_of(&BounceUniform::new(bounces)),
        );
        self.bounces = bounces;
    }

    /// Bounces of the plan last written.
    pub fn bounces(&self) -> u32 {
        self.bounces
    }

    /// Records the bounces into `pass` (after the direct kernels): per bounce the trace, the
    /// lights and the environment, then the sum added; over `groups` workgroups each. Nothing
    /// for a plan without bounces.
    pub(crate) fn record(&self, pass: &mut wgpu::ComputePass<'_>, groups: [u32; 2]) {
        if self.bounces == 0 {
            return;
        }
        pass.set_bind_group(0, &self.bind_group, &[]);
        for _ in 0..self.bounces {
            for pipeline in &self.pipelines[..3] {
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(groups[0], groups[1], 1);
            }
        }
        pass.set_pipeline(&self.pipelines[3]);
        pass.dispatch_workgroups(groups[0], groups[1], 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_block_carries_the_renderers_constants() {
        let b = BounceUniform::new(3);
        assert_eq!(b.bounces, 3);
        let join = |w: [u32; 2]| u64::from(w[0]) | (u64::from(w[1]) << 32);
        assert_eq!(join(b.first_salt), BOUNCE_SALT);
        assert_eq!(join(b.later_salt), BOUNCE_SALT.rotate_left(17));
        for (d, k) in b.env_keys.iter().enumerate() {
            assert_eq!(join([k[0], k[1]]), bounce_env_key_mask(d as u32));
        }
        assert_eq!(BounceUniform::new(99).bounces, MAX_BOUNCES as u32);
    }

    #[test]
    fn the_bounces_environment_follows_the_primarys() {
        assert_eq!(bounce_env_samples(EnvLight::Occluded { samples: 4 }), 1);
        assert_eq!(bounce_env_samples(EnvLight::Occluded { samples: 0 }), 0);
        assert_eq!(bounce_env_samples(EnvLight::Unshadowed), 0);
    }
}
