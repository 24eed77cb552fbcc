//! The resident frame's sample side for both eyes (issue 37, items 1–2): per eye persistent
//! buffers — the sample buffers ([`DeviceSamples`]), the uniform blocks, the column and run
//! tables — and one bind group, built when an eye's plan first needs them and again only when
//! its buffers' sizes, its ray layout (polar or screen) or a table's capacity change. Per
//! frame only the uniforms and the tables the plan's gaze decides go up:
//!
//! | what | bytes | per |
//! |---|---:|---|
//! | `RayGenCamera` (camera, the rings' centre) | 80 | eye |
//! | `EnvParams` (the estimator's constants, the rays per sample) | 272 | eye |
//! | `FrameParams` (layer, jitter, frame and eye in the keys, ambient) | 128 | eye |
//! | columns: each polar column's ring (radius, rows per turn), cone, first run | 16 × (columns + 1) | eye |
//! | runs: each column's shaded rows (`FoveationMapping::is_shaded`) | 8 × runs | eye |
//! | lights | 64 × lights | only when they change |
//!
//! The rings are the CPU mapping's own (`FoveationMapping::ring`, f64, once per column: what
//! the CPU's `plan::RayRings` reads), so every texel's ray is the one the CPU's
//! `trace_and_shade` casts; the per-texel work — the point on the ring, the ray, everything
//! after — is the kernel's ([`super::shade`]).
//!
//! [`ResidentSamples::record_eyes`] records every eye's pass into a caller's command encoder
//! (the caller chains the screen side onto the same encoder); [`ResidentSamples::render_eyes`]
//! does that and submits once — one `queue.submit` per binocular frame, no wait, nothing read
//! back. Whether a plan can be rendered here is decided before anything is recorded
//! ([`super::shade::supports`]).

use fovea_core::mapping::footprint::spread_with_floor_rad;
use fovea_core::mapping::BufferSize;
use fovea_core::units::ScreenPoint;
use fovea_render::camera::EyeCamera;
use fovea_render::plan::FramePlan;
use fovea_render::shade::frame_noise::with_frame;
use fovea_render::shade::{texel_key, EnvLight};
use fovea_render::world::World;

use super::bounce::{plan_bounces, BounceKernels, EyeBounce};
use super::compact::{self, EyeList};
use super::layers::{self, LayerPass, ShadeLayerGpu};
use super::samples::DeviceSamples;
use super::shade::{
    supports, FrameColumnGpu, FrameLayerGpu, FrameUniform, RayLayout, ShadeScene,
    GBUFFER_TEXEL_BYTES, KIND_LAYERED, KIND_POLAR, KIND_SCREEN, KIND_SPARSE,
};
use super::weier_pattern::{self, DevicePattern};
use crate::denoise::{DeviceGuides, GpuDenoiser};
use crate::environment_light::EnvUniform;
use crate::error::{GpuError, Result};
use crate::ray_generation::RayGenCamera;
use crate::shaders::WORKGROUP_SIZE;
use fovea_post::grid::Grid;

/// The most workgroups a dispatch takes along one dimension (WebGPU's default limit).
const MAX_GROUPS: u32 = 65_535;

/// One eye's persistent buffers and bind group.
pub struct EyeShade {
    layout: RayLayout,
    sizes: Vec<BufferSize>,
    samples: DeviceSamples,
    /// Texels the sample buffers and the G-buffer hold room for.
    texel_capacity: u64,
    camera: wgpu::Buffer,
    env: wgpu::Buffer,
    frame: wgpu::Buffer,
    columns: wgpu::Buffer,
    columns_capacity: usize,
    runs: wgpu::Buffer,
    runs_capacity: usize,
    /// The G-buffer between the kernels: geometry and material records.
    gbuffer: [wgpu::Buffer; 2],
    /// The denoiser's guides the kernels write, with the samples' layers and capacity, when
    /// the plan denoises (issue 38); else three 16-byte stand-ins fill the bindings.
    guides: Option<DeviceGuides>,
    _no_guides: Option<[wgpu::Buffer; 3]>,
    bind_group: wgpu::BindGroup,
    groups: [u32; 2],
    /// The first layer's `FrameScreenLayer` (binding 30; a stand-in unless layered).
    layer_block: wgpu::Buffer,
    /// Layers past the first of a layered buffer, each dispatched with its own uniforms.
    more: Vec<LayerPass>,
    /// Weier's pattern in the runs buffer (a sparse layout's), written whole only when it
    /// changes.
    sparse: DevicePattern,
    /// The bounces of indirect light (`super::bounce`), made with the eye's first plan
    /// that has them.
    bounce: Option<EyeBounce>,
    /// The list of shaded texels the kernels run over (a polar buffer's; `super::compact`).
    list: EyeList,
    /// Whether this frame's kernels run over the list (`compact::lists` of the layout, unless
    /// [`ResidentSamples::set_compaction`] turned it off).
    listed: bool,
}

/// The per-frame tables of one eye's plan: each column's record (and one past the last), the
/// runs, and the rays' centre.
struct Tables {
    columns: Vec<FrameColumnGpu>,
    runs: Vec<[u32; 2]>,
    centre: [f64; 2],
}

/// The column records and runs of columns `range` of `plan`'s polar buffer (`size`; rays at
/// texel offset `o`), the records' first runs counted from the part's own first.
fn column_tables(
    plan: &FramePlan,
    polar: &fovea_core::mapping::PolarLayout,
    size: BufferSize,
    o: [f64; 2],
    range: std::ops::Range<u32>,
) -> (Vec<FrameColumnGpu>, Vec<[u32; 2]>) {
    let mapping = plan.mapping();
    let jitter = plan.jitter_texels;
    let mut columns = Vec::with_capacity(range.len());
    let mut runs = Vec::with_capacity(2 * range.len());
    let mut listed = Vec::new();
    for i in range {
        let first = runs.len() as u32;
        let ring = mapping.ring(0, i as f64 + o[0] + jitter[0]);
        let Some(ring) = ring else {
            columns.push(FrameColumnGpu {
                runs: first,
                ..FrameColumnGpu::default()
            });
            continue;
        };
        let spread = plan.footprint.column_spread_rad(i).unwrap_or_else(|| {
            let p = ScreenPoint::new(ring.centre.x_px + ring.r_px, ring.centre.y_px);
            spread_with_floor_rad(
                mapping,
                &plan.display,
                &plan.eye.gaze,
                p,
                plan.footprint.floor_rad as f64,
            )
        });
        let rows = polar
            .rows
            .get(i as usize)
            .copied()
            .unwrap_or(0)
            .min(size.height);
        listed.clear();
        if mapping.append_shaded_runs(0, i, &mut listed) {
            // The mapping's own runs (VaFR's), clipped to the rows the buffer holds.
            runs.extend(
                listed
                    .iter()
                    .filter(|&&(a, _)| a < rows)
                    .map(|&(a, b)| [a, b.min(rows)]),
            );
        } else {
            let mut start = None;
            for j in 0..rows {
                match (mapping.is_shaded(0, i, j), start) {
                    (true, None) => start = Some(j),
                    (false, Some(a)) => {
                        runs.push([a, j]);
                        start = None;
                    }
                    _ => {}
                }
            }
            if let Some(a) = start {
                runs.push([a, rows]);
            }
        }
        columns.push(FrameColumnGpu {
            r_px: ring.r_px as f32,
            period: ring.period as f32,
            spread,
            runs: first,
        });
    }
    (columns, runs)
}

/// The tables of `plan` (module header). Polar: each column's ring at `u = i + ½ + jitter`
/// (`FoveationMapping::ring`), its cone (the plan's per-column footprint, or the mapping's
/// spread at the ring's radius where the column's centre is off the screen — the CPU's
/// per-sample fallback, which depends on the radius alone), and the runs of rows the mapping
/// shades. Screen: none.
fn tables(plan: &FramePlan, layout: RayLayout) -> Tables {
    let (offsets, _) = plan.rays.pattern(1);
    let o = offsets[0];
    let polar = match (layout, plan.mapping().polar_layout()) {
        (RayLayout::Polar, Some(p)) => p,
        _ => {
            return Tables {
                columns: vec![FrameColumnGpu::default(); 2],
                runs: vec![[0, 0]],
                centre: [0.0, 0.0],
            }
        }
    };
    let size = plan.buffers[0];
    // The columns in as many contiguous parts as the machine has threads where the run scan
    // asks `is_shaded` for every row, then joined, each part's runs offset by those before;
    // in one part where the mapping lists its runs (a few arithmetic operations a column:
    // cheaper than starting a thread).
    let lists_runs = plan
        .mapping()
        .append_shaded_runs(0, 0, &mut Vec::with_capacity(4));
    let threads = if lists_runs {
        1
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    };
    let per = (size.width as usize).div_ceil(threads).max(1) as u32;
    let parts: Vec<(Vec<FrameColumnGpu>, Vec<[u32; 2]>)> = if threads == 1 {
        vec![column_tables(plan, &polar, size, o, 0..size.width)]
    } else {
        std::thread::scope(|scope| {
            let handles: Vec<_> = (0..size.width)
                .step_by(per as usize)
                .map(|i0| {
                    let i1 = (i0 + per).min(size.width);
                    let polar = &polar;
                    scope.spawn(move || column_tables(plan, polar, size, o, i0..i1))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        })
    };
    let mut columns = Vec::with_capacity(size.width as usize + 1);
    let mut runs = Vec::with_capacity(2 * size.width as usize);
    for (part_columns, part_runs) in parts {
        let base = runs.len() as u32;
        columns.extend(part_columns.into_iter().map(|c| FrameColumnGpu {
            runs: c.runs + base,
            ..c
        }));
        runs.extend(part_runs);
    }
    columns.push(FrameColumnGpu {
        runs: runs.len() as u32,
        ..FrameColumnGpu::default()
    });
    if runs.is_empty() {
        runs.push([0, 0]);
    }
    Tables {
        columns,
        runs,
        centre: [polar.centre.x_px, polar.centre.y_px],
    }
}

/// Run records (two words each) Weier's pattern takes in the runs buffer, with its cone table
/// (1 for another mapping).
fn sparse_pairs(plan: &FramePlan) -> usize {
    plan.mapping()
        .weier_sparse()
        .map_or(1, |m| weier_pattern::words_len(m, true).div_ceil(2))
}

/// The largest buffer (texels) and the most columns of `plan`'s mapping over gazes at the
/// screen's corners and centre (built here, once per eye's buffers).
pub(crate) fn worst_case(plan: &FramePlan) -> (u64, usize) {
    let d = &plan.display;
    let (w, h) = (d.width_px as f64, d.height_px as f64);
    let mut most = (0u64, 0usize);
    for (x, y) in [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h), (0.5 * w, 0.5 * h)] {
        let Ok(gaze) = d.gaze(x, y) else {
            continue;
        };
        let Ok(m) = fovea_core::mapping::build(plan.method(), d, gaze, &plan.settings.mapping)
        else {
            continue;
        };
        let b = m.buffers();
        let texels = b.iter().map(|s| s.pixels()).sum();
        let columns = b.first().map_or(0, |s| s.width as usize);
        most = (most.0.max(texels), most.1.max(columns));
    }
    most
}

/// The dispatch grid of the layers `sizes`: one workgroup per 8×8 tile of texels
/// (`frame_texel` in the shader), as `[x, y]` workgroups, x at most [`MAX_GROUPS`].
fn dispatch(sizes: &[BufferSize]) -> Result<[u32; 2]> {
    let tiles: u64 = sizes
        .iter()
        .map(|s| u64::from(s.width.div_ceil(8)) * u64::from(s.height.div_ceil(8)))
        .sum();
    let texels: u64 = sizes.iter().map(|s| s.pixels()).sum();
    debug_assert_eq!(WORKGROUP_SIZE, 64);
    let groups = tiles.max(1);
    let gx = groups.min(u64::from(MAX_GROUPS));
    let gy = groups.div_ceil(gx);
    if gy > u64::from(MAX_GROUPS) {
        return Err(GpuError::Unsupported(format!(
            "{texels} texels in one dispatch of the resident frame"
        )));
    }
    Ok([gx as u32, gy as u32])
}

/// A buffer of `bytes` (at least 4) with `usage | COPY_DST`, counted.
fn buffer(
    scene: &ShadeScene,
    label: &str,
    bytes: usize,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    scene.ctx.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(16) as u64,
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

impl EyeShade {
    /// Allocates an eye's buffers for `plan` (its layout and sizes), with room for
    /// `columns` column records and `runs` runs, and binds them with the scene's.
    fn new(
        scene: &ShadeScene,
        plan: &FramePlan,
        layout: RayLayout,
        (columns, runs, capacity): (usize, usize, u64),
    ) -> Result<Self> {
        let ctx = &scene.ctx;
        let sizes = plan.buffers.clone();
        let texels: u64 = sizes.iter().map(|s| s.pixels()).sum();
        let capacity = capacity.max(texels);
        // One dispatch per layer (a layered buffer's; every other buffer has one).
        let layer_groups = sizes
            .iter()
            .map(|s| dispatch(std::slice::from_ref(s)))
            .collect::<Result<Vec<_>>>()?;
        let groups = layer_groups.first().copied().unwrap_or([1, 1]);
        let column_bytes = columns * std::mem::size_of::<FrameColumnGpu>();
        let run_bytes = runs * std::mem::size_of::<[u32; 2]>();
        ctx.check_storage_binding("the frame's column table", column_bytes as u64)?;
        ctx.check_storage_binding("the frame's runs of shaded rows", run_bytes as u64)?;
        let gbuffer_bytes = capacity.max(1) * GBUFFER_TEXEL_BYTES;
        ctx.check_storage_binding("the frame's G-buffer (geometry)", gbuffer_bytes)?;
        ctx.check_storage_binding("the frame's G-buffer (material)", gbuffer_bytes)?;
        // Room for a list of shaded texels where the layout has one (`super::compact`).
        let list_capacity = if compact::lists(layout) { capacity } else { 0 };
        EyeList::check(ctx, list_capacity)?;
        let samples = DeviceSamples::with_capacity(ctx, &sizes, capacity)?;
        let guides = match plan.settings.denoise {
            Some(_) => Some(DeviceGuides::with_capacity(ctx, &sizes, capacity)?),
            None => None,
        };
        let scene_buffers = scene.tracer.scene.as_ref().ok_or_else(|| {
            GpuError::Unsupported("a scene without triangles in the resident frame".into())
        })?;
        let uniform = wgpu::BufferUsages::UNIFORM;
        let storage = wgpu::BufferUsages::STORAGE;
        let built = ctx.scoped("allocating an eye of the resident frame", || {
            let camera = buffer(
                scene,
                "frame camera",
                std::mem::size_of::<RayGenCamera>(),
                uniform,
            );
            let env = buffer(
                scene,
                "frame environment",
                std::mem::size_of::<EnvUniform>(),
                uniform,
            );
            let frame = buffer(
                scene,
                "frame parameters",
                std::mem::size_of::<FrameUniform>(),
                uniform,
            );
            let layer_block = buffer(
                scene,
                "frame layer rays",
                std::mem::size_of::<ShadeLayerGpu>(),
                uniform,
            );
            let columns_buf = buffer(scene, "frame columns", column_bytes, storage);
            let runs_buf = buffer(scene, "frame runs", run_bytes, storage);
            let gbuffer = ["frame G-buffer geometry", "frame G-buffer material"]
                .map(|label| buffer(scene, label, gbuffer_bytes as usize, storage));
            let no_guides = guides.is_none().then(|| {
                [
                    "frame no albedo guide",
                    "frame no normal guide",
                    "frame no noisy part",
                ]
                .map(|label| buffer(scene, label, 16, storage))
            });
            let guide_buffers: [&wgpu::Buffer; 3] = match (&guides, &no_guides) {
                (Some(g), _) => [g.albedo(), g.normal(), g.noisy()],
                (None, Some(n)) => [&n[0], &n[1], &n[2]],
                (None, None) => unreachable!("stand-ins are made without guides"),
            };
            let list = EyeList::new(ctx, list_capacity);
            let s = &scene.surfaces.buffers;
            let mut entries: Vec<(u32, &wgpu::Buffer)> = vec![
                (0, &scene.trace_params),
                (1, &scene_buffers.nodes),
                (2, &scene_buffers.tris),
                (3, &scene_buffers.prim_ids),
                (6, &camera),
                (7, &scene.lights_buffer),
                (9, &s[0]),
                (10, &s[1]),
                (11, &s[2]),
                (12, &s[3]),
                (13, &s[4]),
                (14, &s[5]),
                (16, &env),
                (17, &scene.environment.pixels),
                (18, &scene.environment.tables),
                (21, &frame),
                (22, &columns_buf),
                (23, &runs_buf),
                (24, samples.buffer()),
                (25, &gbuffer[0]),
                (26, &gbuffer[1]),
                (27, guide_buffers[0]),
                (28, guide_buffers[1]),
                (29, guide_buffers[2]),
                (30, &layer_block),
            ];
            entries.extend(list.bindings());
            let bind_group =
                crate::transfer::bind_group(ctx, "resident frame", &scene.pipelines[0], &entries);
            let more = layers::more_passes(ctx, &scene.pipelines[0], &entries, &layer_groups);
            (
                camera,
                env,
                frame,
                columns_buf,
                runs_buf,
                gbuffer,
                no_guides,
                bind_group,
                (layer_block, more, list),
            )
        })?;
        let (camera, env, frame, columns_buf, runs_buf, gbuffer, no_guides, bind_group, layered) =
            built;
        let (layer_block, more, list) = layered;
        Ok(Self {
            layout,
            sizes,
            samples,
            texel_capacity: capacity,
            camera,
            env,
            frame,
            columns: columns_buf,
            columns_capacity: columns,
            runs: runs_buf,
            runs_capacity: runs,
            gbuffer,
            guides,
            _no_guides: no_guides,
            bind_group,
            groups,
            layer_block,
            more,
            sparse: DevicePattern::default(),
            bounce: None,
            list,
            listed: compact::lists(layout),
        })
    }

    /// Readies the bounces of indirect light for `plan` (`super::bounce`): their buffers and
    /// bind group made when the plan first has bounces (`kernels` built by then), their blocks
    /// written; a plan without bounces records none.
    fn prepare_bounce(
        &mut self,
        scene: &ShadeScene,
        kernels: Option<&BounceKernels>,
        plan: &FramePlan,
    ) -> Result<()> {
        if let (None, Some(kernels), true) = (&self.bounce, kernels, plan_bounces(plan) > 0) {
            let scene_buffers = scene.tracer.scene.as_ref().ok_or_else(|| {
                GpuError::Unsupported("a scene without triangles in the resident frame".into())
            })?;
            let guides: [&wgpu::Buffer; 3] = match (&self.guides, &self._no_guides) {
                (Some(g), _) => [g.albedo(), g.normal(), g.noisy()],
                (None, Some(n)) => [&n[0], &n[1], &n[2]],
                (None, None) => unreachable!("stand-ins are made without guides"),
            };
            let s = &scene.surfaces.buffers;
            // The direct kernels' bindings but the environment block (16), which the bounces
            // have their own of.
            let mut shared: Vec<(u32, &wgpu::Buffer)> = vec![
                (0, &scene.trace_params),
                (1, &scene_buffers.nodes),
                (2, &scene_buffers.tris),
                (3, &scene_buffers.prim_ids),
                (6, &self.camera),
                (7, &scene.lights_buffer),
                (9, &s[0]),
                (10, &s[1]),
                (11, &s[2]),
                (12, &s[3]),
                (13, &s[4]),
                (14, &s[5]),
                (17, &scene.environment.pixels),
                (18, &scene.environment.tables),
                (21, &self.frame),
                (22, &self.columns),
                (23, &self.runs),
                (24, self.samples.buffer()),
                (25, &self.gbuffer[0]),
                (26, &self.gbuffer[1]),
                (27, guides[0]),
                (28, guides[1]),
                (29, guides[2]),
                // The layer block (a stand-in: bounces never run on layers).
                (30, &self.layer_block),
            ];
            shared.extend(self.list.bindings());
            self.bounce = Some(EyeBounce::new(
                scene,
                kernels,
                &shared,
                self.texel_capacity,
            )?);
        }
        if let Some(b) = &mut self.bounce {
            b.write(scene, plan);
        }
        Ok(())
    }

    /// Takes `plan`'s buffers and tables over when they fit these buffers (no allocation;
    /// the sample buffers relaid out where the plan's sizes changed); `false` otherwise.
    fn take(&mut self, plan: &FramePlan, layout: RayLayout, tables: &Tables) -> bool {
        let texels: u64 = plan.buffers.iter().map(|s| s.pixels()).sum();
        let fits = self.layout == layout
            && self.guides.is_some() == plan.settings.denoise.is_some()
            && texels <= self.texel_capacity
            && tables.columns.len() <= self.columns_capacity
            && tables.runs.len() <= self.runs_capacity
            && (plan.buffers.len() == 1 || self.sizes == plan.buffers)
            && (layout != RayLayout::Sparse || sparse_pairs(plan) <= self.runs_capacity);
        if !fits {
            return false;
        }
        if self.sizes != plan.buffers {
            let Ok(groups) = dispatch(&plan.buffers) else {
                return false;
            };
            if !self.samples.relayout(&plan.buffers) {
                return false;
            }
            if let Some(g) = &mut self.guides {
                if !g.relayout(&plan.buffers) {
                    return false;
                }
            }
            self.sizes = plan.buffers.clone();
            self.groups = groups;
        }
        true
    }

    /// Writes the frame's uniform blocks and tables (the only per-frame uploads).
    fn write(
        &self,
        scene: &ShadeScene,
        world: &World,
        camera: &EyeCamera,
        plan: &FramePlan,
        tables: &Tables,
        layered: &[ShadeLayerGpu],
    ) {
        let ctx = &scene.ctx;
        let cam = RayGenCamera::new(
            camera.position.into(),
            [camera.forward.into(), camera.right.into(), camera.up.into()],
            camera.focal_px(),
            camera.principal_point_px(),
            tables.centre,
        );
        // The primary hit's environment light, with or without bounces.
        let env_light = plan
            .settings
            .shading
            .direct_env_light()
            .unwrap_or(EnvLight::Occluded { samples: 0 });
        let env = scene.environment.uniform(match env_light {
            EnvLight::Occluded { samples } => samples,
            EnvLight::Unshadowed => 0,
        });
        let (offsets, _) = plan.rays.pattern(1);
        let o = offsets[0];
        let size = self.sizes[0];
        let mut rank = [[0u32; 4]; 4];
        for (j, row) in rank.iter_mut().enumerate() {
            for (i, r) in row.iter_mut().enumerate() {
                *r = (texel_key(0, i as u32, j as u32) & 15) as u32;
            }
        }
        let mean = world.scene.environment.mean();
        let frame = FrameUniform {
            texels: size.width * size.height,
            kind: match self.layout {
                RayLayout::Polar => KIND_POLAR,
                RayLayout::Screen => KIND_SCREEN,
                RayLayout::Layered => KIND_LAYERED,
                RayLayout::Sparse => KIND_SPARSE,
            },
            inf_bits: f32::INFINITY.to_bits(),
            unshadowed: u32::from(env_light == EnvLight::Unshadowed),
            layer: FrameLayerGpu {
                offset: 0,
                width: size.width,
                height: size.height,
                key_hi: (with_frame(texel_key(0, 0, 0), plan.noise) >> 32) as u32,
            },
            offset: [
                (o[0] + plan.jitter_texels[0]) as f32,
                (o[1] + plan.jitter_texels[1]) as f32,
            ],
            pixel_spread: plan.footprint.pixel_rad,
            row_invocations: self.groups[0] * WORKGROUP_SIZE,
            ambient: [mean.x, mean.y, mean.z, 0.0],
            rank,
            guides: u32::from(self.guides.is_some()),
            listed: u32::from(self.listed),
            pad: [0; 2],
        };
        ctx.write_buffer(&self.camera, 0, bytemuck::bytes_of(&cam));
        ctx.write_buffer(&self.env, 0, bytemuck::bytes_of(&env));
        ctx.write_buffer(&self.frame, 0, bytemuck::bytes_of(&frame));
        layers::write_layers(
            ctx,
            plan,
            &frame,
            &self.layer_block,
            &self.more,
            &self.samples,
            layered,
        );
        if self.layout == RayLayout::Polar {
            ctx.write_buffer(&self.columns, 0, bytemuck::cast_slice(&tables.columns));
            ctx.write_buffer(&self.runs, 0, bytemuck::cast_slice(&tables.runs));
            self.list
                .set_bound(compact::shaded_bound(&tables.runs, size.pixels()));
        }
        if let (RayLayout::Sparse, Some(m)) = (self.layout, plan.mapping().weier_sparse()) {
            // Weier's pattern where the runs would be: its four per-frame words, or every
            // word (tables and cones) with the eye's first frame.
            let gaze = plan.eye.gaze;
            let spread = weier_pattern::Spread {
                mapping: plan.mapping(),
                display: &plan.display,
                gaze,
                floor_rad: plan.footprint.floor_rad,
            };
            let at = [gaze.point.x_px, gaze.point.y_px];
            self.sparse.write(ctx, &self.runs, m, at, Some(&spread));
        }
    }

    /// Records this eye's pass into `encoder`: one compute pass, the surface kernel's dispatch,
    /// then the lights', then the environment's (a polar buffer's first the list of its shaded
    /// texels, then each over the list: `super::compact`).
    pub fn record(&self, scene: &ShadeScene, encoder: &mut wgpu::CommandEncoder) {
        self.record_timed(scene, encoder, None);
    }

    /// [`Self::record`] with the pass's timestamps written where `timestamp_writes` says (a
    /// [`super::FrameTimer`]'s slot).
    pub fn record_timed(
        &self,
        scene: &ShadeScene,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let listed = self.listed;
        if listed {
            self.list.clear(encoder);
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("resident frame: trace and shade"),
            timestamp_writes,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        // The kernels' grid: over the list of shaded texels where the layout has one, else
        // over every texel; none where nothing can be shaded.
        let groups = match listed {
            true => self.list.record(&mut pass, &scene.compact, self.groups),
            false => Some(self.groups),
        };
        if let Some(groups) = groups {
            for pipeline in &scene.pipelines {
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(groups[0], groups[1], 1);
            }
            // Indirect light, after the primary's (`super::bounce`; never with layers, which
            // `super::shade::supports` refuses with it).
            if let Some(b) = &self.bounce {
                b.record(&mut pass, groups);
            }
        }
        // A layered buffer's other layers, each with its own uniforms (the G-buffer between
        // the kernels is the layer's).
        for layer in &self.more {
            pass.set_bind_group(0, &layer.bind_group, &[]);
            for pipeline in &scene.pipelines {
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(layer.groups[0], layer.groups[1], 1);
            }
        }
    }

    /// The G-buffer records between the kernels (geometry, material; 32 bytes per texel
    /// each: shading normal and t, geometric normal and metallic; albedo and roughness, specular
    /// and the texel's state), for a pass that reads them (the denoiser's guides).
    pub fn gbuffer(&self) -> &[wgpu::Buffer; 2] {
        &self.gbuffer
    }

    /// The list of shaded texels the eye's kernels ran over (a polar buffer's;
    /// `super::compact`).
    pub fn list(&self) -> &EyeList {
        &self.list
    }

    /// An upper bound of the texels the denoiser filters this frame (those with a surface
    /// record, all of them listed): the list's bound where the kernels run over a list and the
    /// samples are its one layer; `None` otherwise.
    pub(crate) fn denoise_bound(&self) -> Option<u32> {
        (self.listed && self.samples.layers().len() == 1).then(|| self.list.bound())
    }

    /// The eye's sample buffers on the device.
    pub fn samples(&self) -> &DeviceSamples {
        &self.samples
    }

    /// This frame's column records (`FrameColumn`) and runs of shaded rows, for a pass that
    /// asks which texels the mapping shades (the temporal accumulation).
    pub(crate) fn tables(&self) -> (&wgpu::Buffer, &wgpu::Buffer) {
        (&self.columns, &self.runs)
    }

    /// The denoiser's guides the kernels write (the samples' layers), when the eye's plan
    /// denoises.
    pub fn guides(&self) -> Option<&DeviceGuides> {
        self.guides.as_ref()
    }

    /// Room the buffers hold: texels, and polar column records (one past the last included).
    pub fn capacity(&self) -> (u64, usize) {
        (self.texel_capacity, self.columns_capacity)
    }
}

/// Where the host's time of one [`ResidentSamples::render_eyes`] went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RecordTimes {
    /// Preparing (tables, uniforms) and recording every eye, wall ms: the host's own work on
    /// the frame, without the submission.
    pub host_ms: f64,
    /// Of that, the per-column tables (rings, cones, the runs of shaded rows scanned from
    /// `FoveationMapping::is_shaded`), wall ms.
    pub tables_ms: f64,
    /// The `queue.submit` call, wall ms.
    pub submit_ms: f64,
}

/// The resident frame's sample side for up to two eyes: the scene on the device and each
/// eye's buffers (module header).
pub struct ResidentSamples {
    scene: ShadeScene,
    eyes: [Option<EyeShade>; 2],
    /// Each eye's sample-space denoiser (its working buffers sized as the eye's samples),
    /// made with the eye's first denoised plan and kept (one per eye: the parameters are a
    /// uniform written per call).
    denoisers: [Option<GpuDenoiser>; 2],
    /// The tables' wall ms since the last [`Self::render_eyes`].
    tables_ms: f64,
    /// The bounce kernels, built with the first plan that has bounces of indirect light.
    bounce_kernels: Option<BounceKernels>,
    /// Whether a polar buffer's kernels run over its list of shaded texels
    /// ([`Self::set_compaction`]).
    compaction: bool,
}

impl ResidentSamples {
    /// The scene of `world` on `ctx` (see [`ShadeScene::new`]); no eye's buffers yet.
    pub fn new(ctx: &crate::GpuContext, world: &World) -> Result<Self> {
        Ok(Self {
            scene: ShadeScene::new(ctx, world)?,
            eyes: [None, None],
            denoisers: [None, None],
            tables_ms: 0.0,
            bounce_kernels: None,
            compaction: true,
        })
    }

    /// Whether a polar buffer's kernels run over the list of its shaded texels (`on`, the
    /// default; `super::compact`) or over every texel as the other layouts do, from the next
    /// [`Self::prepare_eye`] on. The samples are the same bits either way
    /// (`tests/frame_compact.rs`); off is for that test and for measuring what the list saves.
    pub fn set_compaction(&mut self, on: bool) {
        self.compaction = on;
    }

    /// Wall ms spent on the per-column tables by [`Self::prepare_eye`] since the last
    /// [`Self::render_eyes`] (which resets it).
    pub fn tables_ms(&self) -> f64 {
        self.tables_ms
    }

    /// The scene on the device.
    pub fn scene(&self) -> &ShadeScene {
        &self.scene
    }

    /// Eye `eye`'s (0 left, 1 right) buffers, once a frame was prepared for it.
    pub fn eye(&self, eye: usize) -> Option<&EyeShade> {
        self.eyes.get(eye)?.as_ref()
    }

    /// Eye `eye`'s denoiser, once a denoised frame was prepared for it.
    pub fn denoiser(&self, eye: usize) -> Option<&GpuDenoiser> {
        self.denoisers.get(eye)?.as_ref()
    }

    /// Eye `eye`'s sample buffers, once a frame was prepared for it.
    pub fn samples(&self, eye: usize) -> Option<&DeviceSamples> {
        self.eye(eye).map(EyeShade::samples)
    }

    /// Readies eye `eye` (0 or 1) for `plan` seen by `camera`: checks that the kernel serves
    /// the plan and the world ([`GpuError::Unsupported`] / [`GpuError::Input`], before
    /// anything is written), (re)builds the eye's buffers where the plan's sizes or tables
    /// outgrow them, and writes its uniforms and tables.
    pub fn prepare_eye(
        &mut self,
        eye: usize,
        world: &World,
        camera: &EyeCamera,
        plan: &FramePlan,
    ) -> Result<()> {
        if eye > 1 {
            return Err(GpuError::Input(format!("eye {eye} (0 left, 1 right)")));
        }
        let layout = supports(plan)?;
        if !self.scene.serves(world) {
            return Err(GpuError::Input(
                "the resident frame's scene was built from another world's triangles".into(),
            ));
        }
        if (camera.display.width_px, camera.display.height_px)
            != (plan.display.width_px, plan.display.height_px)
        {
            return Err(GpuError::Input(
                "the camera's display is not the plan's".into(),
            ));
        }
        self.scene.update_lights(world)?;
        let layered = match layout {
            RayLayout::Layered => layers::shade_blocks(plan, camera)?,
            _ => Vec::new(),
        };
        let t = std::time::Instant::now();
        let tables = tables(plan, layout);
        self.tables_ms += t.elapsed().as_secs_f64() * 1e3;
        let fits = self.eyes[eye]
            .as_mut()
            .is_some_and(|e| e.take(plan, layout, &tables));
        if !fits {
            // A polar buffer's size follows the gaze: room for the largest of the screen's
            // corners and centre (as far as a binding allows), so that a moving gaze does not
            // outgrow the buffers.
            let texels: u64 = plan.buffers.iter().map(|s| s.pixels()).sum();
            let (columns, runs, capacity) = match layout {
                RayLayout::Polar => {
                    let most = self.scene.ctx.max_binding_bytes() / GBUFFER_TEXEL_BYTES;
                    let (worst_texels, worst_columns) = worst_case(plan);
                    let columns = tables.columns.len().max(worst_columns + 1);
                    (
                        columns,
                        (tables.runs.len() + tables.runs.len() / 2 + 64).max(4 * columns),
                        texels.max(worst_texels).min(most),
                    )
                }
                RayLayout::Screen | RayLayout::Layered => {
                    (tables.columns.len(), tables.runs.len(), texels)
                }
                RayLayout::Sparse => (tables.columns.len(), sparse_pairs(plan), texels),
            };
            self.eyes[eye] = Some(EyeShade::new(
                &self.scene,
                plan,
                layout,
                (columns, runs, capacity),
            )?);
        }
        if plan_bounces(plan) > 0 && self.bounce_kernels.is_none() {
            self.bounce_kernels = Some(BounceKernels::new(&self.scene)?);
        }
        if let Some(e) = &mut self.eyes[eye] {
            e.prepare_bounce(&self.scene, self.bounce_kernels.as_ref(), plan)?;
            e.listed = compact::lists(e.layout) && self.compaction;
        }
        if let Some(e) = &self.eyes[eye] {
            e.write(&self.scene, world, camera, plan, &tables, &layered);
            if plan.settings.denoise.is_some() {
                let (texels, columns) = e.capacity();
                let denoiser = match &mut self.denoisers[eye] {
                    Some(d) => d,
                    slot => slot.insert(GpuDenoiser::new(&self.scene.ctx)?),
                };
                denoiser.reserve(texels, columns as u64);
            }
        }
        Ok(())
    }

    /// Records eye `eye`'s sample-space denoiser (issue 38; `fovea_gpu::denoise`, the GPU twin
    /// of `fovea_post::denoise`) into `encoder`, its one compute pass timed where
    /// `timestamp_writes` says: over the eye's samples in place, guided by the albedo, normal
    /// and Monte Carlo part its kernels wrote, with `plan`'s parameters (the plan the eye was
    /// prepared with). Record it after the eye's shading (and any temporal accumulation),
    /// before the screen side. `Ok(false)`, nothing recorded, when `plan` does not denoise.
    pub fn record_denoise(
        &mut self,
        eye: usize,
        plan: &FramePlan,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<bool> {
        let Some(params) = plan.settings.denoise else {
            return Ok(false);
        };
        let not_ready = || GpuError::Input(format!("eye {eye} was not prepared to denoise"));
        let e = self
            .eyes
            .get(eye)
            .and_then(Option::as_ref)
            .ok_or_else(not_ready)?;
        let guides = e.guides().ok_or_else(not_ready)?;
        let denoiser = self
            .denoisers
            .get_mut(eye)
            .and_then(Option::as_mut)
            .ok_or_else(not_ready)?;
        let polar = plan.mapping().polar_layout();
        let grids: Vec<Grid> = e
            .samples()
            .layers()
            .iter()
            .map(|l| Grid::of_layer(polar.as_ref(), l.width, l.height))
            .collect();
        // Over the shaded texels only (lavapipe runs a passive texel's lanes in full).
        denoiser.set_source_bound(e.denoise_bound());
        denoiser.record_timed(
            encoder,
            e.samples(),
            guides,
            &grids,
            &params,
            timestamp_writes,
        )?;
        Ok(true)
    }

    /// Records eye `eye`'s pass into `encoder` (after [`Self::prepare_eye`]).
    pub fn record_eye(&self, eye: usize, encoder: &mut wgpu::CommandEncoder) -> Result<()> {
        let e = self.eye(eye).ok_or_else(|| {
            GpuError::Input(format!("eye {eye} of the resident frame was not prepared"))
        })?;
        e.record(&self.scene, encoder);
        Ok(())
    }

    /// Prepares every eye of `eyes` (index = eye) and, once all are ready, records their
    /// passes into `encoder`; nothing is recorded when any eye is refused.
    pub fn record_eyes(
        &mut self,
        world: &World,
        eyes: &[(&EyeCamera, &FramePlan)],
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<()> {
        if eyes.len() > 2 {
            return Err(GpuError::Input(format!("{} eyes (at most 2)", eyes.len())));
        }
        for (k, (camera, plan)) in eyes.iter().enumerate() {
            self.prepare_eye(k, world, camera, plan)?;
        }
        for k in 0..eyes.len() {
            self.record_eye(k, encoder)?;
        }
        Ok(())
    }

    /// [`Self::record_eyes`] into a new encoder, submitted once (`GpuContext::submit`): one
    /// submission per binocular frame, no wait, nothing read back.
    pub fn render_eyes(
        &mut self,
        world: &World,
        eyes: &[(&EyeCamera, &FramePlan)],
    ) -> Result<RecordTimes> {
        let t = std::time::Instant::now();
        self.tables_ms = 0.0;
        let ctx = self.scene.ctx.clone();
        let mut encoder = ctx
            .device()
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("resident frame"),
            });
        ctx.scoped("recording the resident frame", || {
            self.record_eyes(world, eyes, &mut encoder)
        })??;
        let host_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = std::time::Instant::now();
        ctx.scoped("submitting the resident frame", || {
            ctx.submit([encoder.finish()])
        })?;
        Ok(RecordTimes {
            host_ms,
            tables_ms: self.tables_ms,
            submit_ms: t.elapsed().as_secs_f64() * 1e3,
        })
    }
}
