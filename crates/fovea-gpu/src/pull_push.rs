//! Weier et al. 2016's screen-aligned reconstruction on the GPU: the pull-push hole filling
//! of Gortler et al. 1996 ("The Lumigraph", Sec. 3.3) for colour and the nearest shaded pixel
//! for depth — the twin of `fovea_post::pull_push::pull_push` and
//! `fovea_post::inverse_map::nearest_fill_depth`, which the CPU's reconstruct stage runs for
//! [`Method::Weier`](fovea_core::mapping::Method::Weier).
//!
//! Split of the work:
//!
//! * **Rust, on the CPU**: which pixels are shaded (the caller's mask: for a frame,
//!   `fovea_post::inverse_map::mask_of` of the plan's mapping, the CPU path's own rule),
//!   packed to one bit per pixel; the pyramid's level sizes and offsets.
//! * **WGSL** (`shaders/pull_push.wgsl`): one `pull` dispatch per level (the 2×2 weighted
//!   average, weights capped at 1), one `push` dispatch per level coarsest first (the bilinear
//!   of the coarser level where a pixel's weight is below 1), and `fill_depth` (the first
//!   shaded pixel on square rings of radius 1 … [`DEPTH_FILL_RADIUS_PX`], in the CPU's order).
//!
//! Buffers: every level's colour in one buffer (3 f32 per pixel, level 0 = the screen, then
//! each coarser level of `ceil(w/2)×ceil(h/2)` down to 1×1, about 4/3 of the screen in all),
//! the weights of levels ≥ 1 in another (level 0's weight is the mask), the mask (1 bit per
//! pixel) and the depth (filled in place). Each must fit one storage binding; that is checked
//! before anything is allocated ([`GpuError::AdapterTooSmall`]), and [`GpuPullPush::fits`]
//! lets a caller that can fall back to the CPU ask first (the CLI's executor does).
//!
//! Agreement with the CPU: the same f32 operations in the same order; shaded pixels keep their
//! bits, depth is identical, and a filled colour can differ by an ulp or so where the device
//! fuses a multiply and an add (`tests/pull_push.rs` measures it).

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use fovea_core::Image;
use fovea_post::inverse_map::DEPTH_FILL_RADIUS_PX;
use fovea_post::Rgb;

use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};
use crate::timestamps::PassTimer;
use crate::transfer::{bind_group, read_buffers, stage, upload};

/// The module: entry points `pull`, `push` and `fill_depth`, [`PullPushUniform`] at binding 0.
pub const SHADER: ShaderSource = ShaderSource {
    file: "pull_push.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/pull_push.wgsl")
    ),
    entry_points: &["pull", "push", "fill_depth"],
    uniform: ("PullPushParams", std::mem::size_of::<PullPushUniform>()),
};

/// Bytes per pixel of the colour pyramid (r, g, b as f32).
pub(crate) const RGB_BYTES: u64 = 12;

/// The uniform block `PullPushParams` of `pull_push.wgsl` (same field order; see there). One
/// per dispatch.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PullPushUniform {
    /// The fine level's width, pixels.
    pub fine_w: u32,
    /// Its height, pixels.
    pub fine_h: u32,
    /// Its offset in the colour buffer, pixels.
    pub fine_off: u32,
    /// Its index (0: the screen).
    pub fine_level: u32,
    /// The coarse level's width, pixels.
    pub coarse_w: u32,
    /// Its height, pixels.
    pub coarse_h: u32,
    /// Its offset in the colour buffer, pixels.
    pub coarse_off: u32,
    /// Its offset in the weight buffer, pixels.
    pub coarse_wt_off: u32,
    /// The fine level's offset in the weight buffer (levels ≥ 1), pixels.
    pub fine_wt_off: u32,
    /// Invocations that do work.
    pub n: u32,
    /// The depth search's largest ring, pixels.
    pub max_radius: u32,
    /// `f32::INFINITY.to_bits()`.
    pub miss_depth_bits: u32,
}

/// Where the time of one GPU pull-push went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PullPushTimes {
    /// Packing the mask, creating buffers, uploading, recording and submitting, wall ms.
    pub upload_ms: f64,
    /// From submission until the output was read back into the images, wall ms (includes the
    /// GPU's work and the copy out).
    pub run_and_readback_ms: f64,
    /// The pull passes, from the device's timestamps (when it has `TIMESTAMP_QUERY`), ms.
    pub pull_ms: Option<f64>,
    /// The push passes, ms (timestamps).
    pub push_ms: Option<f64>,
    /// The depth fill, ms (timestamps).
    pub depth_ms: Option<f64>,
    /// All of the above, wall ms.
    pub total_ms: f64,
    /// Levels of the pyramid, the screen included.
    pub levels: u32,
}

impl PullPushTimes {
    /// The three passes together (timestamps), or `None` when the device has none.
    pub fn gpu_passes_ms(&self) -> Option<f64> {
        Some(self.pull_ms? + self.push_ms? + self.depth_ms?)
    }
}

/// One dispatch: its bindings and its workgroups in x and y.
type Dispatch = (wgpu::BindGroup, (u32, u32));

/// One level of the pyramid: size and offsets (pixels) in the colour and weight buffers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Level {
    pub(crate) w: u32,
    pub(crate) h: u32,
    pub(crate) off: u64,
    pub(crate) wt_off: u64,
}

/// The uniform block's fields every dispatch shares: the depth fill's radius and the miss
/// depth's bits.
pub(crate) fn uniform_base() -> PullPushUniform {
    PullPushUniform {
        max_radius: DEPTH_FILL_RADIUS_PX,
        miss_depth_bits: f32::INFINITY.to_bits(),
        ..PullPushUniform::default()
    }
}

/// The uniform block of level `l` and `l + 1` of `levels` over `n` invocations: the pull from
/// `l` to `l + 1` and the push back read the same pair.
pub(crate) fn level_pair(levels: &[Level], l: usize, n: u64) -> PullPushUniform {
    PullPushUniform {
        fine_w: levels[l].w,
        fine_h: levels[l].h,
        fine_off: levels[l].off as u32,
        fine_level: l as u32,
        coarse_w: levels[l + 1].w,
        coarse_h: levels[l + 1].h,
        coarse_off: levels[l + 1].off as u32,
        coarse_wt_off: levels[l + 1].wt_off as u32,
        fine_wt_off: if l == 0 { 0 } else { levels[l].wt_off as u32 },
        n: n as u32,
        ..uniform_base()
    }
}

/// The pyramid of a `w`×`h` screen (the CPU's: halve, rounding up, down to 1×1), with the
/// colour buffer's and the weight buffer's lengths in pixels.
pub(crate) fn pyramid(w: u32, h: u32) -> (Vec<Level>, u64, u64) {
    let mut levels = vec![Level {
        w,
        h,
        off: 0,
        wt_off: 0,
    }];
    let (mut off, mut wt_off) = (u64::from(w) * u64::from(h), 0u64);
    while let Some(&l) = levels.last().filter(|l| l.w > 1 || l.h > 1) {
        let (nw, nh) = (l.w.div_ceil(2), l.h.div_ceil(2));
        levels.push(Level {
            w: nw,
            h: nh,
            off,
            wt_off,
        });
        off += u64::from(nw) * u64::from(nh);
        wt_off += u64::from(nw) * u64::from(nh);
    }
    (levels, off, wt_off)
}

/// The pull-push pipelines on one device; reuse it from frame to frame.
pub struct GpuPullPush {
    ctx: GpuContext,
    pull: wgpu::ComputePipeline,
    push: wgpu::ComputePipeline,
    fill_depth: wgpu::ComputePipeline,
}

impl GpuPullPush {
    /// Compiles the passes on `ctx`.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        let device = ctx.device();
        let mut pipelines = ctx
            .scoped("building the pull-push pipelines", || {
                SHADER.pipelines(device)
            })?
            .into_iter();
        let mut next = || {
            pipelines
                .next()
                .ok_or_else(|| GpuError::Input("the pull-push module lacks an entry point".into()))
        };
        Ok(Self {
            pull: next()?,
            push: next()?,
            fill_depth: next()?,
            ctx: ctx.clone(),
        })
    }

    /// The device.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The bytes of the largest binding a `w`×`h` screen needs: the colour pyramid (12 bytes
    /// per pixel of every level, about 16 per screen pixel).
    pub fn pyramid_bytes(w: u32, h: u32) -> u64 {
        pyramid(w, h).1 * RGB_BYTES
    }

    /// Whether a `w`×`h` screen fits the device: every buffer in one storage binding and
    /// every level within one dispatch. A caller that can fall back to the CPU asks this
    /// first; [`Self::fill_into`] checks the same and fails with
    /// [`GpuError::AdapterTooSmall`] or [`GpuError::Unsupported`].
    pub fn fits(&self, w: u32, h: u32) -> bool {
        self.check(w, h).is_ok()
    }

    fn check(&self, w: u32, h: u32) -> Result<()> {
        let (_, colour_px, weight_px) = pyramid(w, h);
        let screen_px = u64::from(w) * u64::from(h);
        self.ctx
            .check_storage_binding("the pull-push colour pyramid", colour_px * RGB_BYTES)?;
        self.ctx
            .check_storage_binding("the pull-push weights", weight_px.max(1) * 4)?;
        self.ctx
            .check_storage_binding("the screen's depth", screen_px * 4)?;
        let limits = self.ctx.limits();
        let max = u64::from(limits.max_compute_workgroups_per_dimension);
        let groups = screen_px.div_ceil(u64::from(WORKGROUP_SIZE));
        if groups.div_ceil(max) > max {
            return Err(GpuError::Unsupported(format!(
                "a {w}x{h} screen in one dispatch (more than {max}² workgroups of \
                 {WORKGROUP_SIZE})"
            )));
        }
        Ok(())
    }

    /// [`Self::fill_into`] into new images.
    pub fn fill(
        &self,
        color: &Image<Rgb>,
        depth: &Image<f32>,
        mask: &Image<bool>,
    ) -> Result<(Image<Rgb>, Image<f32>, PullPushTimes)> {
        let image_err = |e: fovea_core::FoveaError| GpuError::Input(e.to_string());
        let (w, h) = (color.width(), color.height());
        let mut out_c = Image::new(w, h, [0.0f32; 3]).map_err(image_err)?;
        let mut out_d = Image::new(w, h, 0.0f32).map_err(image_err)?;
        let times = self.fill_into(color, depth, mask, &mut out_c, &mut out_d)?;
        Ok((out_c, out_d, times))
    }

    /// Fills the pixels of `color` and `depth` where `mask` is false, writing every pixel of
    /// `out_color` and `out_depth`, as `fovea_post::pull_push::pull_push` and
    /// `fovea_post::inverse_map::nearest_fill_depth` do on the CPU: colour by pull-push, depth
    /// from the nearest shaded pixel within [`DEPTH_FILL_RADIUS_PX`] (+∞ beyond). All five
    /// images have one size.
    pub fn fill_into(
        &self,
        color: &Image<Rgb>,
        depth: &Image<f32>,
        mask: &Image<bool>,
        out_color: &mut Image<Rgb>,
        out_depth: &mut Image<f32>,
    ) -> Result<PullPushTimes> {
        let t_start = Instant::now();
        let (w, h) = (color.width(), color.height());
        for (name, size) in [
            ("depth", (depth.width(), depth.height())),
            ("mask", (mask.width(), mask.height())),
            ("output colour", (out_color.width(), out_color.height())),
            ("output depth", (out_depth.width(), out_depth.height())),
        ] {
            if size != (w, h) {
                return Err(GpuError::Input(format!(
                    "pull-push {name} is {}x{}, the colour {w}x{h}",
                    size.0, size.1
                )));
            }
        }
        if w == 0 || h == 0 {
            return Err(GpuError::Input(format!(
                "pull-push of an empty {w}x{h} image"
            )));
        }
        self.check(w, h)?;
        let (levels, colour_px, weight_px) = pyramid(w, h);
        let screen_px = u64::from(w) * u64::from(h);
        let mut bits = vec![0u32; screen_px.div_ceil(32) as usize];
        for (k, _) in mask.data().iter().enumerate().filter(|(_, &m)| m) {
            bits[k / 32] |= 1 << (k % 32);
        }
        let limits = self.ctx.limits();
        let max_groups = limits.max_compute_workgroups_per_dimension;
        // (gx, gy) workgroups for n invocations (rows of gx; `check` bounded gy).
        let groups = |n: u64| {
            let g = n.div_ceil(u64::from(WORKGROUP_SIZE)).max(1);
            let gx = g.min(u64::from(max_groups));
            (gx as u32, g.div_ceil(gx) as u32)
        };
        let uniform_base = uniform_base();
        let pair = |l: usize, n: u64| level_pair(&levels, l, n);
        let what = format!("the pull-push reconstruction at {w}x{h}");
        let device = self.ctx.device();
        let (colour_read, depth_read, timers) = self.ctx.scoped(&what, || {
            let storage = wgpu::BufferUsages::STORAGE;
            let mask_buf = upload(
                &self.ctx,
                "pull-push mask",
                bytemuck::cast_slice(&bits),
                storage,
            );
            let colour_buf = self.ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pull-push colour pyramid"),
                size: colour_px * RGB_BYTES,
                usage: storage | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let screen: &[f32] = bytemuck::cast_slice(color.data());
            self.ctx
                .write_buffer(&colour_buf, 0, bytemuck::cast_slice(screen));
            let weight_buf = self.ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pull-push weights"),
                size: weight_px.max(1) * 4,
                usage: storage,
                mapped_at_creation: false,
            });
            let depth_buf = upload(
                &self.ctx,
                "pull-push depth",
                bytemuck::cast_slice(depth.data()),
                storage | wgpu::BufferUsages::COPY_SRC,
            );
            let uniform = |u: &PullPushUniform| {
                upload(
                    &self.ctx,
                    "pull-push parameters",
                    bytemuck::bytes_of(u),
                    wgpu::BufferUsages::UNIFORM,
                )
            };
            let pyramid_binds = |pipeline: &wgpu::ComputePipeline, u: &wgpu::Buffer| {
                bind_group(
                    &self.ctx,
                    "pull-push bindings",
                    pipeline,
                    &[(0, u), (1, &mask_buf), (2, &colour_buf), (3, &weight_buf)],
                )
            };
            let coarsest = levels.len() - 1;
            let pulls: Vec<Dispatch> = (0..coarsest)
                .map(|l| {
                    let n = u64::from(levels[l + 1].w) * u64::from(levels[l + 1].h);
                    (pyramid_binds(&self.pull, &uniform(&pair(l, n))), groups(n))
                })
                .collect();
            let pushes: Vec<Dispatch> = (0..coarsest)
                .rev()
                .map(|l| {
                    let n = u64::from(levels[l].w) * u64::from(levels[l].h);
                    (pyramid_binds(&self.push, &uniform(&pair(l, n))), groups(n))
                })
                .collect();
            let depth_uniform = uniform(&PullPushUniform {
                fine_w: w,
                fine_h: h,
                n: screen_px as u32,
                ..uniform_base
            });
            let depth_bind = bind_group(
                &self.ctx,
                "pull-push depth bindings",
                &self.fill_depth,
                &[(0, &depth_uniform), (1, &mask_buf), (4, &depth_buf)],
            );
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("pull-push"),
            });
            let timers = [
                PassTimer::new(&self.ctx, "pull timestamps"),
                PassTimer::new(&self.ctx, "push timestamps"),
                PassTimer::new(&self.ctx, "depth fill timestamps"),
            ];
            let depths: Vec<Dispatch> = vec![(depth_bind, groups(screen_px))];
            let passes = [
                ("pull", &self.pull, &pulls),
                ("push", &self.push, &pushes),
                ("depth fill", &self.fill_depth, &depths),
            ];
            for ((label, pipeline, dispatches), timer) in passes.iter().zip(&timers) {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(label),
                    timestamp_writes: timer.as_ref().map(PassTimer::writes),
                });
                pass.set_pipeline(pipeline);
                for (bind, (gx, gy)) in dispatches.iter() {
                    pass.set_bind_group(0, bind, &[]);
                    pass.dispatch_workgroups(*gx, *gy, 1);
                }
            }
            let [colour_read, depth_read]: [wgpu::Buffer; 2] = stage(
                &self.ctx,
                &mut encoder,
                &[
                    (&colour_buf, screen_px * RGB_BYTES),
                    (&depth_buf, screen_px * 4),
                ],
                "pull-push readback",
            )
            .try_into()
            .expect("two sources, two staging buffers");
            for timer in timers.iter().flatten() {
                timer.resolve(&mut encoder);
            }
            self.ctx.submit([encoder.finish()]);
            (colour_read, depth_read, timers)
        })?;
        let upload_ms = ms_since(t_start);

        let t_run = Instant::now();
        let mut all = vec![&colour_read, &depth_read];
        all.extend(timers.iter().flatten().map(PassTimer::readback));
        let mut stamps = Vec::with_capacity(3);
        read_buffers(&self.ctx, &all, &what, |k, bytes| match k {
            // Same bits as the shader's u32s.
            0 => {
                let px: &[[f32; 3]] = bytemuck::cast_slice(bytes);
                out_color.data_mut().copy_from_slice(px);
            }
            1 => out_depth
                .data_mut()
                .copy_from_slice(bytemuck::cast_slice(bytes)),
            _ => stamps.push(PassTimer::ms(&self.ctx, bytes)),
        })?;
        let stamp = |k: usize| stamps.get(k).copied();
        Ok(PullPushTimes {
            upload_ms,
            run_and_readback_ms: ms_since(t_run),
            pull_ms: stamp(0),
            push_ms: stamp(1),
            depth_ms: stamp(2),
            total_ms: ms_since(t_start),
            levels: levels.len() as u32,
        })
    }
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pyramid_halves_down_to_one_pixel_with_packed_offsets() {
        let (levels, colour, weight) = pyramid(5, 3);
        let sizes: Vec<(u32, u32)> = levels.iter().map(|l| (l.w, l.h)).collect();
        assert_eq!(sizes, [(5, 3), (3, 2), (2, 1), (1, 1)]);
        let offs: Vec<u64> = levels.iter().map(|l| l.off).collect();
        assert_eq!(offs, [0, 15, 21, 23]);
        assert_eq!(colour, 24);
        let wt: Vec<u64> = levels.iter().skip(1).map(|l| l.wt_off).collect();
        assert_eq!(wt, [0, 6, 8]);
        assert_eq!(weight, 9);
        let (one, colour, weight) = pyramid(1, 1);
        assert_eq!((one.len(), colour, weight), (1, 1, 0));
        let column: Vec<(u32, u32)> = pyramid(1, 7).0.iter().map(|l| (l.w, l.h)).collect();
        assert_eq!(column, [(1, 7), (1, 4), (1, 2), (1, 1)]);
    }
}
