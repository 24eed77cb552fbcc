//! Weier's reconstruction on the resident screen side (issue 37): the pull-push hole filling
//! of Gortler et al. 1996 (Sec. 3.3, as Weier et al. 2016/2018 reconstruct their sparse
//! samples) for colour and the nearest shaded pixel for depth, recorded into the frame's
//! encoder over the screen's own colour and depth buffers — the twin of the CPU's
//! `fovea_post::pull_push::pull_push` and `fovea_post::inverse_map::nearest_fill_depth` for
//! `Method::Weier`, with the staged path's kernels (`shaders/pull_push.wgsl`, unchanged).
//!
//! Per frame, one compute pass (timed as the screen side's `reconstruct`):
//!
//! 0. `planes_to_rgb` (`shaders/frame_screen_split.wgsl`): the split's colour planes into the
//!    pyramid's level 0;
//! 1. `weier_mask` (`shaders/frame_weier_mask.wgsl`): the mask of the frame's pattern, one
//!    bit per screen pixel, from the pattern's tables ([`super::weier_pattern`]) and the
//!    point of regard — `fovea_post::inverse_map::mask_of` of the plan's mapping, computed
//!    where it is used instead of going up (288 KB per eye at the Vive Pro Eye);
//! 2. `pull`, one dispatch per level, the screen's colour as level 0;
//! 3. `push`, one dispatch per level, coarsest first, ending in the screen's colour;
//! 4. `fill_depth` over the screen's depth, in place;
//! 5. `rgb_to_planes`: the push's level 0 back into the colour planes the DOF and the tone map
//!    read.
//!
//! The pyramid (level 0 first, then the coarser levels: 16 bytes a screen pixel) is this
//! pass's own buffer: the screen's colour is three planes of 4 bytes a pixel (so that an 8K
//! screen fits 128 MiB bindings), while the staged kernels pull and push interleaved RGB. A
//! screen whose pyramid does not fit one binding is refused, naming it. Every level's
//! uniform block and bind group is made once with the screen side; per frame only the
//! pattern's four words go up (16 bytes), and its tables with the first frame.

use fovea_core::mapping::FoveationMapping;

use super::weier_pattern::{words_len, DevicePattern};
use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::pull_push::{level_pair, pyramid, uniform_base, PullPushUniform, RGB_BYTES};
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};
use crate::transfer::{bind_group, empty};

/// The mask module: entry point `weier_mask`, [`MaskUniform`] at binding 0.
pub const MASK_SHADER: ShaderSource = ShaderSource {
    file: "frame_weier_mask.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/frame_sparse.wgsl"),
        include_str!("../../shaders/frame_weier_mask.wgsl")
    ),
    entry_points: &["weier_mask"],
    uniform: ("MaskParams", std::mem::size_of::<MaskUniform>()),
};

/// The uniform block `MaskParams` of `frame_weier_mask.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MaskUniform {
    /// Screen pixels.
    pub pixels: u32,
    /// Screen width, pixels.
    pub width: u32,
    /// Mask words, `⌈pixels / 32⌉`.
    pub words: u32,
    /// Padding.
    pub pad: u32,
}

/// The bytes of the pull-push pyramid of a `w`×`h` screen (level 0 the screen's colour).
pub fn colour_bytes(w: u32, h: u32) -> u64 {
    pyramid(w, h).1 * RGB_BYTES
}

/// One dispatch: its bindings and its workgroups in x and y.
type Dispatch = (wgpu::BindGroup, (u32, u32));

/// Weier's reconstruction on one eye's screen side (see the module).
pub struct ResidentPullPush {
    ctx: GpuContext,
    mask: wgpu::ComputePipeline,
    pull: wgpu::ComputePipeline,
    push: wgpu::ComputePipeline,
    fill_depth: wgpu::ComputePipeline,
    /// The pattern's words (without the cone table) and the mask pass's bindings, made with
    /// the first frame's pattern (their size is the pattern's) and again only for a larger one.
    pattern_buf: Option<(wgpu::Buffer, wgpu::BindGroup)>,
    pattern: DevicePattern,
    mask_uniform: wgpu::Buffer,
    mask_bits: wgpu::Buffer,
    mask_groups: (u32, u32),
    pulls: Vec<Dispatch>,
    pushes: Vec<Dispatch>,
    depth_dispatch: Dispatch,
    /// The copies between the screen's colour planes and the pyramid's level 0.
    to_pyramid: Dispatch,
    to_planes: Dispatch,
    planes_to_rgb: wgpu::ComputePipeline,
    rgb_to_planes: wgpu::ComputePipeline,
    /// Kept alive for the bind groups: uniforms, the mask, the weights.
    _buffers: Vec<wgpu::Buffer>,
    width: u32,
    height: u32,
    last_upload: u64,
}

impl ResidentPullPush {
    /// The passes over `planes` (the screen's colour, red, green and blue planes of f32) and
    /// `depth` (the screen's depth as u32 bits) of a `w`×`h` screen, with the pyramid
    /// ([`colour_bytes`]) of their own. Sizes are checked against the adapter before anything
    /// is allocated.
    pub fn new(
        ctx: &GpuContext,
        w: u32,
        h: u32,
        planes: [&wgpu::Buffer; 3],
        depth: &wgpu::Buffer,
    ) -> Result<Self> {
        let (levels, colour_px, weight_px) = pyramid(w, h);
        let screen_px = u64::from(w) * u64::from(h);
        let mask_words = screen_px.div_ceil(32);
        ctx.check_storage_binding("the pull-push colour pyramid", colour_px * RGB_BYTES)?;
        ctx.check_storage_binding("the pull-push weights", weight_px.max(1) * 4)?;
        let plane_bytes = screen_px * 4;
        if let Some(p) = planes.iter().find(|p| p.size() < plane_bytes) {
            return Err(GpuError::Input(format!(
                "a {} byte colour plane for a {w}x{h} screen ({plane_bytes} bytes)",
                p.size()
            )));
        }
        let max = ctx.limits().max_compute_workgroups_per_dimension;
        let groups = |n: u64| -> Result<(u32, u32)> {
            let g = n.div_ceil(u64::from(WORKGROUP_SIZE)).max(1);
            let gx = g.min(u64::from(max));
            let gy = g.div_ceil(gx);
            if gy > u64::from(max) {
                return Err(GpuError::Unsupported(format!(
                    "a {w}x{h} screen in one dispatch of the pull-push"
                )));
            }
            Ok((gx as u32, gy as u32))
        };
        let what = format!("building the resident pull-push at {w}x{h}");
        let device = ctx.device();
        let mut modules = ctx.scoped(&what, || {
            let mut p = MASK_SHADER.pipelines(device);
            p.extend(crate::pull_push::SHADER.pipelines(device));
            p.extend(
                super::screen::SPLIT_SHADER
                    .pipelines_of(device, &["planes_to_rgb", "rgb_to_planes"]),
            );
            p
        })?;
        if modules.len() != 6 {
            return Err(GpuError::Input(
                "the pull-push modules lack an entry point".into(),
            ));
        }
        let rgb_to_planes = modules.remove(5);
        let planes_to_rgb = modules.remove(4);
        let fill_depth = modules.remove(3);
        let push = modules.remove(2);
        let pull = modules.remove(1);
        let mask = modules.remove(0);
        let storage = wgpu::BufferUsages::STORAGE;
        let uniform_usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let base = uniform_base();
        let pair = |l: usize, n: u64| level_pair(&levels, l, n);
        let coarsest = levels.len() - 1;
        let pull_groups: Vec<(u32, u32)> = (0..coarsest)
            .map(|l| groups(u64::from(levels[l + 1].w) * u64::from(levels[l + 1].h)))
            .collect::<Result<_>>()?;
        let push_groups: Vec<(u32, u32)> = (0..coarsest)
            .rev()
            .map(|l| groups(u64::from(levels[l].w) * u64::from(levels[l].h)))
            .collect::<Result<_>>()?;
        let screen_groups = groups(screen_px)?;
        let mask_groups = groups(mask_words)?;
        let built = ctx.scoped(&what, || {
            let mut kept = Vec::new();
            let uniform = |kept: &mut Vec<wgpu::Buffer>, bytes: &[u8]| {
                let b = empty(
                    ctx,
                    "pull-push parameters",
                    bytes.len() as u64,
                    uniform_usage,
                );
                ctx.write_buffer(&b, 0, bytes);
                kept.push(b.clone());
                b
            };
            let mask_bits = empty(ctx, "Weier mask", mask_words * 4, storage);
            let pyramid_buf = empty(ctx, "pull-push pyramid", colour_px * RGB_BYTES, storage);
            let color = &pyramid_buf;
            let copy_u = uniform(
                &mut kept,
                bytemuck::bytes_of(&super::screen::SplitUniform {
                    offset: 0,
                    width: w,
                    height: h,
                    pad: 0,
                }),
            );
            let copies = [&planes_to_rgb, &rgb_to_planes].map(|pipeline| {
                bind_group(
                    ctx,
                    "resident pull-push copy",
                    pipeline,
                    &[
                        (0, &copy_u),
                        (2, color),
                        (4, planes[0]),
                        (5, planes[1]),
                        (6, planes[2]),
                    ],
                )
            });
            let weights = empty(ctx, "pull-push weights", weight_px.max(1) * 4, storage);
            let mask_u = uniform(
                &mut kept,
                bytemuck::bytes_of(&MaskUniform {
                    pixels: screen_px as u32,
                    width: w,
                    words: mask_words as u32,
                    pad: 0,
                }),
            );
            let mut pulls = Vec::with_capacity(coarsest);
            for (l, g) in (0..coarsest).zip(&pull_groups) {
                let n = u64::from(levels[l + 1].w) * u64::from(levels[l + 1].h);
                let u = uniform(&mut kept, bytemuck::bytes_of(&pair(l, n)));
                let bind = bind_group(
                    ctx,
                    "resident pull",
                    &pull,
                    &[(0, &u), (1, &mask_bits), (2, color), (3, &weights)],
                );
                pulls.push((bind, *g));
            }
            let mut pushes = Vec::with_capacity(coarsest);
            for (l, g) in (0..coarsest).rev().zip(&push_groups) {
                let n = u64::from(levels[l].w) * u64::from(levels[l].h);
                let u = uniform(&mut kept, bytemuck::bytes_of(&pair(l, n)));
                let bind = bind_group(
                    ctx,
                    "resident push",
                    &push,
                    &[(0, &u), (1, &mask_bits), (2, color), (3, &weights)],
                );
                pushes.push((bind, *g));
            }
            let depth_u = uniform(
                &mut kept,
                bytemuck::bytes_of(&PullPushUniform {
                    fine_w: w,
                    fine_h: h,
                    n: screen_px as u32,
                    ..base
                }),
            );
            let depth_bind = bind_group(
                ctx,
                "resident depth fill",
                &fill_depth,
                &[(0, &depth_u), (1, &mask_bits), (4, depth)],
            );
            kept.push(weights);
            kept.push(pyramid_buf.clone());
            (mask_u, mask_bits, pulls, pushes, depth_bind, copies, kept)
        })?;
        let (mask_uniform, mask_bits, pulls, pushes, depth_bind, copies, kept) = built;
        let [to_pyramid, to_planes] = copies;
        let copy_groups = (w.div_ceil(WORKGROUP_SIZE), h);
        Ok(Self {
            ctx: ctx.clone(),
            mask,
            pull,
            push,
            fill_depth,
            pattern_buf: None,
            pattern: DevicePattern::default(),
            mask_uniform,
            mask_bits,
            mask_groups,
            pulls,
            pushes,
            depth_dispatch: (depth_bind, screen_groups),
            to_pyramid: (to_pyramid, copy_groups),
            to_planes: (to_planes, copy_groups),
            planes_to_rgb,
            rgb_to_planes,
            _buffers: kept,
            width: w,
            height: h,
            last_upload: 0,
        })
    }

    /// Writes the frame's pattern (its four per-frame words, or every word when the tables
    /// changed) for `mapping` (Weier's, on this screen). [`GpuError::Unsupported`] for another
    /// mapping, [`GpuError::Input`] for one of another screen or larger tables.
    pub fn prepare(&mut self, mapping: &dyn FoveationMapping) -> Result<()> {
        let m = mapping.weier_sparse().ok_or_else(|| {
            GpuError::Unsupported(format!(
                "the {} mapping in the resident pull-push (Weier's sparse pattern)",
                mapping.method()
            ))
        })?;
        if m.screen_px() != (self.width, self.height) {
            return Err(GpuError::Input(format!(
                "a Weier pattern of {:?} on a {}x{} screen side",
                m.screen_px(),
                self.width,
                self.height
            )));
        }
        let bytes = words_len(m, false) as u64 * 4;
        if self
            .pattern_buf
            .as_ref()
            .is_none_or(|(b, _)| b.size() < bytes)
        {
            let ctx = &self.ctx;
            ctx.check_storage_binding("the Weier pattern's tables", bytes)?;
            let made = ctx.scoped("allocating the Weier pattern's tables", || {
                let b = empty(
                    ctx,
                    "Weier pattern (screen side)",
                    bytes,
                    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                );
                let bind = bind_group(
                    ctx,
                    "Weier mask",
                    &self.mask,
                    &[(0, &self.mask_uniform), (1, &b), (2, &self.mask_bits)],
                );
                (b, bind)
            })?;
            self.pattern.forget();
            self.pattern_buf = Some(made);
        }
        let Some((buffer, _)) = &self.pattern_buf else {
            return Err(GpuError::Input("the Weier pattern has no buffer".into()));
        };
        // Only the anchor is read here (the cone table is the sample side's).
        self.last_upload = self.pattern.write(&self.ctx, buffer, m, [0.0, 0.0], None);
        Ok(())
    }

    /// Bytes the last [`Self::prepare`] sent up.
    pub fn last_upload(&self) -> u64 {
        self.last_upload
    }

    /// Records the frame's pass (mask, pull, push, depth fill) into `encoder`, timed where
    /// `timestamp_writes` says. Record it after the screen's colour and depth hold the
    /// samples (the split pass) and after [`Self::prepare`] ([`GpuError::Input`] before it).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<()> {
        let Some((_, mask_bind)) = &self.pattern_buf else {
            return Err(GpuError::Input(
                "the resident pull-push was not prepared".into(),
            ));
        };
        let mask_dispatch = (mask_bind.clone(), self.mask_groups);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("pull-push"),
            timestamp_writes,
        });
        let mut run = |pipeline: &wgpu::ComputePipeline, dispatches: &[&Dispatch]| {
            pass.set_pipeline(pipeline);
            for (bind, (gx, gy)) in dispatches.iter().map(|d| (&d.0, d.1)) {
                pass.set_bind_group(0, bind, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            }
        };
        run(&self.planes_to_rgb, &[&self.to_pyramid]);
        run(&self.mask, &[&mask_dispatch]);
        run(&self.pull, &self.pulls.iter().collect::<Vec<_>>());
        run(&self.push, &self.pushes.iter().collect::<Vec<_>>());
        run(&self.fill_depth, &[&self.depth_dispatch]);
        run(&self.rgb_to_planes, &[&self.to_planes]);
        Ok(())
    }
}
