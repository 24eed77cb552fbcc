//! Temporal accumulation inside the resident frame (issue 37, item 4): the GPU twin of the
//! CPU's sample-space accumulation (`fovea_render::temporal::sample_space`, the running
//! estimate after Weier et al. 2018, Sec. 3.1; VaFR's stated limitation, flicker, is Zhang et
//! al. Sec. 8). Every shaded texel of this frame's sample layer takes its centre through the
//! inverse mapping to the screen, back into the world with its depth, into the previous camera
//! and through the previous frame's forward map, reads the previous *accumulated* layer there
//! (bilinear, or Catmull-Rom where all 16 taps agree in depth; each tap weighted by its depth
//! agreement), scales the trust by the sample densities' ratio, clamps the history to the
//! fresh 3×3 neighbourhood and folds it in with the weight
//! `α = 1 − (1 − max(α_min, 1/(n + 1)))·v` (`shaders/frame_temporal.wgsl` has the steps).
//!
//! **What stays on the device.** Per eye two histories (colour + depth, 16 B a texel, the
//! age, 4 B a texel, and — where the plan denoises with `TemporalSettings::variance` on — the
//! temporal moments, [`MOMENT_BYTES`] = 16 B a texel; 20 or 36 B a texel each, 40 or 72 B a
//! texel for the pair), ping-ponged: this frame reads one and writes the other, which the next
//! frame reads. They are sized from the eye's sample buffers (which the sample side sizes for
//! the largest gaze), made with the eye's first accumulated frame and again only when the
//! sample side's buffers are replaced (which resets the history). The pass is one compute
//! pass per eye recorded after the shading and before the screen side, in the frame's one
//! encoder; the accumulated colour is then copied over the frame's samples on the device
//! (`copy_buffer_to_buffer`), so the screen side (and a denoiser after this pass) reads it.
//!
//! **What goes up per frame.** The uniform block (272 B: both frames' cameras, gazes, layers,
//! the blend's settings) and this frame's column table — per polar column the ring's radius
//! and rows per turn at `u = i + ½` (the CPU mapping's `FoveationMapping::ring`, f64 rounded
//! to f32), the layout's rows and period (what `Grid` steps with) — plus the spacing table
//! (`SpacingLut` every 0.1° of eccentricity): 16 B a column and 4 B an entry, into the half of
//! a double table the previous frame does not read, so the previous frame's table stays for
//! its forward map. Whether a texel is shaded this frame is read from the sample side's own
//! run table; in the previous frame, from the history's age (0 where it did not shade).
//!
//! **Only when they change.** Each half remembers what it holds. The column records depend on
//! the method, its buffers and parameters and the display, and on the pole only where the
//! layout follows the gaze (`FoveationMapping::layout_is_gaze_free` is false): a half whose
//! key matches is read as it is, so with VaFR's `eq3-any-gaze` rings (the real-time
//! preset's) the columns go up once per display and method however the gaze moves. The
//! spacing table (its entries do not depend on the gaze for such a layout, its length
//! does: out to the gaze's farthest corner) is built every frame (a few microseconds) and
//! compared bit for bit with what the halves hold: a half that agrees is read as it is, and
//! only the entries past its end go up where this frame's table reaches farther (the previous
//! frame reads none of them).
//!
//! **Against the CPU.** The forward map of the previous frame is its columns' exact radii
//! interpolated linearly between column centres (the CPU evaluates the mapping's own
//! `forward`); the rest is the CPU's arithmetic in f32.
//!
//! **With the denoiser.** The CPU denoises the accumulated colour's Monte Carlo part
//! (`pipeline::sample_post::complement_part` before and after its blend): the fresh frame's
//! exact part `colour − part` is set aside and the accumulated colour less it is what is
//! filtered. The pass does the same in place on the guides' part (binding 9) wherever it blends
//! a history. With `TemporalSettings::variance` it also keeps SVGF's temporal moments of that
//! part's demodulated luminance (Schied et al. 2017, Sec. 4.2; the CPU's
//! `temporal::fold_moments` with `[m₁, m₂, Σw²]`) beside the age: the fresh luminance is the
//! part over the guides' albedo (binding 12, floored as `fovea_post::denoise::demodulate`),
//! the history's moments are the bilinear ones of the colour's taps, folded with the colour's
//! weight; a rejected history or a non-finite luminance starts over (`[y, y², 1]`). Where the
//! new age reaches `VARIANCE_MIN_AGE` (4) the pass writes `moments_variance` into the part's w
//! lane, which the device's denoiser reads as `denoise_with_variance` reads the CPU's
//! variance; elsewhere the lane keeps the sample side's −1 (the spatial estimate). With
//! `variance` off no moments are kept (16-byte stand-ins at bindings 10–12) and the w lane is
//! left as the sample side wrote it.

use bytemuck::{Pod, Zeroable};
use fovea_core::mapping::{BufferSize, Method, PolarLayout};
use fovea_render::camera::EyeCamera;
use fovea_render::plan::FramePlan;
use fovea_render::temporal::TemporalSettings;

use super::context::EyeShade;
use super::samples::TEXEL_BYTES;
use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};

/// The temporal module: entry point `temporal_blend`, [`TemporalUniform`] at binding 0.
pub const SHADER: ShaderSource = ShaderSource {
    file: "frame_temporal.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/frame_temporal.wgsl")
    ),
    entry_points: &["temporal_blend"],
    uniform: ("TemporalParams", std::mem::size_of::<TemporalUniform>()),
};

/// `TemporalView::kind` of a polar layer.
const KIND_POLAR: u32 = 0;
/// `TemporalView::kind` of a screen-aligned (full-resolution) layer.
const KIND_SCREEN: u32 = 1;
/// The spacing table's step, degrees of eccentricity (`SpacingLut`'s).
const SPACING_STEP_DEG: f64 = 0.1;
/// Room for the spacing table: 0.1° steps to 91°, the most any display's corner needs.
const SPACING_CAPACITY: usize = 912;
/// The most workgroups a dispatch takes along one dimension.
const MAX_GROUPS: u32 = 65_535;
/// Bytes per texel of one moments history: `[m₁, m₂, s]` and a spare lane, `vec4<f32>`.
pub const MOMENT_BYTES: u64 = 16;

/// A camera as the pass reads it (`TemporalCamera`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TemporalCameraGpu {
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
    /// Principal point x, pixels.
    pub cx: f32,
    /// Unit up vector (screen −y).
    pub up: [f32; 3],
    /// Principal point y, pixels.
    pub cy: f32,
}

impl TemporalCameraGpu {
    fn of(camera: &EyeCamera) -> Self {
        let (fx, fy) = camera.focal_px();
        let (cx, cy) = camera.principal_point_px();
        Self {
            origin: camera.position.into(),
            fx,
            forward: camera.forward.into(),
            fy,
            right: camera.right.into(),
            cx,
            up: camera.up.into(),
            cy,
        }
    }
}

/// One frame's view of its sample layer (`TemporalView`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TemporalViewGpu {
    /// The camera.
    pub camera: TemporalCameraGpu,
    /// The gaze point (a polar buffer's pole) minus the principal point, pixels (f32 of the
    /// f64 difference).
    pub gaze: [f32; 2],
    /// The layer's first texel in the sample buffer.
    pub offset: u32,
    /// Width, texels.
    pub width: u32,
    /// Height, texels.
    pub height: u32,
    /// Polar (0) or screen-aligned (1).
    pub kind: u32,
    /// Column records in the table.
    pub columns: u32,
    /// The first column record's index in the tables (floats).
    pub table: u32,
    /// The spacing table's index in the tables (floats).
    pub spacing: u32,
    /// Entries of the spacing table.
    pub spacing_len: u32,
    /// Entries per degree of eccentricity.
    pub steps_per_deg: f32,
    /// Padding.
    pub _pad0: u32,
}

/// The pass's uniform block (`TemporalParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TemporalUniform {
    /// This frame.
    pub cur: TemporalViewGpu,
    /// The previous frame.
    pub prev: TemporalViewGpu,
    /// The display, pixels.
    pub screen: [f32; 2],
    /// `TemporalSettings::alpha_min`.
    pub alpha_min: f32,
    /// `TemporalSettings::depth_tolerance`.
    pub tau: f32,
    /// The display's `c_r` (VaFR Eq. 3).
    pub c_r: f32,
    /// `TemporalSettings::clamp`.
    pub clamp: u32,
    /// 1 where the previous frame is held, 0 for a first frame.
    pub history: u32,
    /// Invocations per row of the dispatch's grid.
    pub row_invocations: u32,
    /// +∞ as bits.
    pub inf_bits: u32,
    /// 1 where binding 9 holds the denoiser's guides (the accumulated colour's Monte Carlo
    /// part is rewritten there), 0 for its stand-in.
    pub guides: u32,
    /// 1 where the temporal moments are kept (bindings 10–12 are the moment histories and the
    /// guides' albedo) and their variance written into binding 9's w lane, 0 for stand-ins.
    pub moments: u32,
    /// `fovea_post::denoise::ALBEDO_FLOOR` (the demodulation's floor).
    pub albedo_floor: f32,
}

/// Checks `settings` for the resident frame: the CPU's ranges (`TemporalSettings::validate`).
/// Every sample-space option is served (jitter moves the rays, which the sample side casts;
/// the history is read at the texel centres as on the CPU).
pub fn supports(settings: &TemporalSettings) -> Result<()> {
    settings
        .validate()
        .map_err(|e| GpuError::Input(format!("temporal accumulation: {e}")))
}

/// What the previous frame left for this one.
#[derive(Clone, Copy)]
struct Previous {
    view: TemporalViewGpu,
    method: Method,
    display: (u32, u32),
}

/// One eye's histories, tables, uniform and bind groups.
struct EyeTemporal {
    color: [wgpu::Buffer; 2],
    /// The ages and the moments (16-byte stand-ins where not kept), bound in the bind groups
    /// only.
    _ages: [wgpu::Buffer; 2],
    _moments: [wgpu::Buffer; 2],
    /// Whether the moments are kept (the guides are bound and `TemporalSettings::variance`).
    moments: bool,
    /// Two halves of `half` floats each, each with a column and a spacing table; a frame's
    /// view names the ones it reads, which stay as they are while the next frame reads them
    /// as its previous.
    tables: wgpu::Buffer,
    half: usize,
    /// What the columns each half holds were made for.
    held_columns: [Option<ColumnsKey>; 2],
    /// The spacing entries each half holds.
    held_spacing: [Vec<f32>; 2],
    columns_capacity: usize,
    uniform: wgpu::Buffer,
    /// Index = the history written (the other is read).
    bind_groups: [wgpu::BindGroup; 2],
    /// The sample side's buffers the bind groups name: samples, columns, runs, and the
    /// guides' Monte Carlo part and albedo (or 16-byte stand-ins when the plan does not
    /// denoise).
    bound: [wgpu::Buffer; 5],
    texel_capacity: u64,
    /// The history this frame writes.
    next: usize,
    previous: Option<Previous>,
    groups: [u32; 2],
    /// The layer's texels (offset, count) to copy back after the pass; `None` on a first
    /// frame (the samples are already the result).
    copy: Option<(u64, u64)>,
}

/// Temporal accumulation for both eyes of the resident frame (see the module).
pub struct ResidentTemporal {
    ctx: GpuContext,
    settings: TemporalSettings,
    pipeline: wgpu::ComputePipeline,
    eyes: [Option<EyeTemporal>; 2],
}

/// What a polar layout's column records depend on: the method, its buffers and parameters,
/// the display — and the pole, unless the layout is the same at every gaze
/// (`FoveationMapping::layout_is_gaze_free`: VaFR's `eq3-any-gaze` rings, Eq. 3's rings at a
/// fixed `e_max`), whose columns a moving gaze leaves as they are.
#[derive(Clone, Debug, PartialEq)]
struct ColumnsKey {
    method: Method,
    /// The pole's bits, where the layout follows the gaze.
    pole: Option<(u64, u64)>,
    buffers: Vec<BufferSize>,
    params: serde_json::Value,
    display: (u32, u32),
    c_r_bits: u64,
    /// The column count written.
    columns: usize,
}

impl ColumnsKey {
    fn of(plan: &FramePlan, polar: &PolarLayout, columns: usize) -> Self {
        let mapping = plan.mapping();
        let pole = (!mapping.layout_is_gaze_free())
            .then(|| (polar.centre.x_px.to_bits(), polar.centre.y_px.to_bits()));
        Self {
            method: mapping.method(),
            pole,
            buffers: plan.buffers.clone(),
            params: mapping.params(),
            display: (plan.display.width_px, plan.display.height_px),
            c_r_bits: plan.display.c_r().to_bits(),
            columns,
        }
    }
}

/// The column records of `plan`'s polar layout `polar` (ring radius, ring rows per turn, the
/// layout's rows and period per column: 4 floats a column).
fn column_table(plan: &FramePlan, polar: &PolarLayout, n: usize) -> Vec<f32> {
    let mapping = plan.mapping();
    let mut columns = Vec::with_capacity(4 * n);
    let mut radii: Vec<f64> = Vec::with_capacity(n);
    for i in 0..n {
        let (r, period) = match mapping.ring(0, i as f64 + 0.5) {
            Some(ring) => (ring.r_px, ring.period),
            // Past the buffer's edge: the radius continued outwards (the forward map
            // searches the radii), no ring (the texel's centre maps nowhere).
            None => {
                let r = match i {
                    0 => 0.0,
                    1 => 3.0 * radii[0],
                    _ => 2.0 * radii[i - 1] - radii[i - 2],
                };
                (r, -1.0)
            }
        };
        radii.push(r);
        columns.extend_from_slice(&[
            r as f32,
            period as f32,
            polar.rows[i] as f32,
            polar.period[i] as f32,
        ]);
    }
    columns
}

/// The spacing table of `plan` (`SpacingLut::at` every 0.1° out to 1° beyond the gaze's
/// farthest screen corner). A few microseconds: built every frame and compared with what the
/// device holds.
fn spacing_table(plan: &FramePlan) -> Vec<f32> {
    let e_max = plan.display.farthest_corner_eccentricity(&plan.eye.gaze).0 + 1.0;
    let len = ((e_max / SPACING_STEP_DEG).ceil() as usize + 2).clamp(2, SPACING_CAPACITY);
    (0..len)
        .map(|k| plan.spacing.at(k as f64 * SPACING_STEP_DEG))
        .collect()
}

/// Whether `a` and `b` agree bit for bit where both have entries.
fn agree(a: &[f32], b: &[f32]) -> bool {
    a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

impl EyeTemporal {
    fn new(
        ctx: &GpuContext,
        pipeline: &wgpu::ComputePipeline,
        shade: &EyeShade,
        columns_capacity: usize,
        variance: bool,
    ) -> Result<Self> {
        let samples = shade.samples().buffer();
        let (shade_columns, shade_runs) = shade.tables();
        let texel_capacity = (samples.size() / TEXEL_BYTES).max(1);
        let color_bytes = texel_capacity * TEXEL_BYTES;
        let age_bytes = texel_capacity * 4;
        let moments = variance && shade.guides().is_some();
        let moment_bytes = if moments {
            texel_capacity * MOMENT_BYTES
        } else {
            16
        };
        ctx.check_storage_binding("the temporal history (colour)", color_bytes)?;
        ctx.check_storage_binding("the temporal history (moments)", moment_bytes)?;
        let half = 4 * columns_capacity + SPACING_CAPACITY;
        let table_bytes = (2 * half * 4) as u64;
        ctx.check_storage_binding("the temporal tables", table_bytes)?;
        ctx.scoped("allocating the resident frame's temporal history", || {
            let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
                ctx.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: size.max(16),
                    usage: usage | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            };
            let storage = wgpu::BufferUsages::STORAGE;
            let color = ["temporal history A", "temporal history B"]
                .map(|l| buffer(l, color_bytes, storage | wgpu::BufferUsages::COPY_SRC));
            let age = ["temporal ages A", "temporal ages B"].map(|l| buffer(l, age_bytes, storage));
            let tables = buffer("temporal tables", table_bytes, storage);
            let moment = ["temporal moments A", "temporal moments B"]
                .map(|l| buffer(l, moment_bytes, storage));
            let (noisy, albedo) = match shade.guides() {
                Some(g) => (g.noisy().clone(), g.albedo().clone()),
                None => (
                    buffer("temporal no noisy part", 16, storage),
                    buffer("temporal no albedo", 16, storage),
                ),
            };
            let uniform = buffer(
                "temporal parameters",
                std::mem::size_of::<TemporalUniform>() as u64,
                wgpu::BufferUsages::UNIFORM,
            );
            let bind_groups = [0usize, 1].map(|next| {
                let prev = 1 - next;
                crate::transfer::bind_group(
                    ctx,
                    "resident frame temporal",
                    pipeline,
                    &[
                        (0, &uniform),
                        (1, samples),
                        (2, &color[prev]),
                        (3, &age[prev]),
                        (4, &color[next]),
                        (5, &age[next]),
                        (6, &tables),
                        (7, shade_columns),
                        (8, shade_runs),
                        (9, &noisy),
                        (10, &moment[prev]),
                        (11, &moment[next]),
                        (12, &albedo),
                    ],
                )
            });
            Self {
                color,
                _ages: age,
                _moments: moment,
                moments,
                tables,
                half,
                held_columns: [None, None],
                held_spacing: [Vec::new(), Vec::new()],
                columns_capacity,
                uniform,
                bind_groups,
                bound: [
                    samples.clone(),
                    shade_columns.clone(),
                    shade_runs.clone(),
                    noisy,
                    albedo,
                ],
                texel_capacity,
                next: 0,
                previous: None,
                groups: [1, 1],
                copy: None,
            }
        })
    }

    /// Whether the bind groups name `shade`'s buffers.
    fn binds(&self, shade: &EyeShade) -> bool {
        let (c, r) = shade.tables();
        let guides = match shade.guides() {
            Some(g) => self.bound[3] == *g.noisy() && self.bound[4] == *g.albedo(),
            None => self.bound[3].size() == 16,
        };
        self.bound[0] == *shade.samples().buffer()
            && self.bound[1] == *c
            && self.bound[2] == *r
            && guides
    }
}

impl ResidentTemporal {
    /// The pass's pipeline on `ctx` for `settings` (checked by [`supports`]); each eye's
    /// histories are made with its first frame.
    pub fn new(ctx: &GpuContext, settings: TemporalSettings) -> Result<Self> {
        supports(&settings)?;
        let pipeline = ctx
            .scoped("building the temporal pipeline", || {
                SHADER.pipelines(ctx.device()).pop()
            })?
            .ok_or_else(|| GpuError::Input("the temporal module has no entry point".into()))?;
        Ok(Self {
            ctx: ctx.clone(),
            settings,
            pipeline,
            eyes: [None, None],
        })
    }

    /// The settings.
    pub fn settings(&self) -> &TemporalSettings {
        &self.settings
    }

    /// Forgets both eyes' history (a cut): the next frame starts afresh.
    pub fn reset(&mut self) {
        for e in self.eyes.iter_mut().flatten() {
            e.previous = None;
        }
    }

    /// Readies eye `eye`'s pass for `plan` seen by `camera`, after the sample side prepared
    /// the eye (`shade`): (re)builds the eye's histories where the sample side's buffers were
    /// replaced or the columns outgrow the table, and writes the uniform block and, where no
    /// half of the table holds them already, this frame's columns and spacing. The history is
    /// forgotten where the method or the display changed (as the CPU's accumulator does) or
    /// the buffers were rebuilt.
    pub fn prepare(
        &mut self,
        eye: usize,
        plan: &FramePlan,
        camera: &EyeCamera,
        shade: &EyeShade,
    ) -> Result<()> {
        if eye > 1 {
            return Err(GpuError::Input(format!("eye {eye} (0 left, 1 right)")));
        }
        if plan.buffers.len() != 1 {
            return Err(GpuError::Unsupported(format!(
                "temporal accumulation of {} sample layers ({}) in the resident frame",
                plan.buffers.len(),
                plan.method()
            )));
        }
        let polar = plan.mapping().polar_layout();
        let n_columns = polar
            .as_ref()
            .map_or(0, |p| p.rows.len().min(plan.buffers[0].width as usize));
        let size = plan.buffers[0];
        let texels = u64::from(size.width) * u64::from(size.height);
        let keep = self.eyes[eye].as_ref().is_some_and(|e| {
            e.binds(shade) && n_columns < e.columns_capacity && texels <= e.texel_capacity
        });
        if !keep {
            let (_, worst_columns) = super::context::worst_case(plan);
            let capacity = n_columns.max(worst_columns) + 1;
            self.eyes[eye] = Some(EyeTemporal::new(
                &self.ctx,
                &self.pipeline,
                shade,
                capacity,
                self.settings.variance,
            )?);
        }
        let Some(e) = self.eyes[eye].as_mut() else {
            return Err(GpuError::Input(format!(
                "eye {eye} has no temporal history"
            )));
        };
        let layer = shade
            .samples()
            .layers()
            .first()
            .copied()
            .ok_or_else(|| GpuError::Input("a sample buffer without layers".into()))?;
        let (cx, cy) = camera.principal_point_px();
        let centre = polar.as_ref().map_or(plan.eye.gaze.point, |p| p.centre);
        let display = (plan.display.width_px, plan.display.height_px);
        let previous = e
            .previous
            .filter(|p| p.method == plan.method() && p.display == display);
        // The halves the previous frame's view reads (this frame reads them as its previous).
        let prev_half = previous.map(|p| {
            (
                p.view.table as usize / e.half,
                p.view.spacing as usize / e.half,
            )
        });
        let ctx = &self.ctx;
        // The columns: a half that holds this layout's already, or the one the previous frame
        // does not read, written anew.
        let column_half = match &polar {
            None => 0,
            Some(polar) => {
                let key = ColumnsKey::of(plan, polar, n_columns);
                let held = (0..2).find(|&h| e.held_columns[h].as_ref() == Some(&key));
                match held {
                    Some(h) => h,
                    None => {
                        let h = prev_half.map_or(0, |p| 1 - p.0);
                        let columns = column_table(plan, polar, n_columns);
                        if !columns.is_empty() {
                            ctx.write_buffer(
                                &e.tables,
                                (h * e.half * 4) as u64,
                                bytemuck::cast_slice(&columns),
                            );
                        }
                        e.held_columns[h] = Some(key);
                        h
                    }
                }
            }
        };
        // The spacing table: a half whose entries agree with this frame's, extended where
        // this frame's reach farther (entries past the previous frame's length are not read
        // by it), else the one the previous frame does not read, written anew.
        let spacing = spacing_table(plan);
        let spacing_len = spacing.len();
        let (half, columns_capacity) = (e.half, e.columns_capacity);
        let spacing_at = |h: usize| ((h * half + 4 * columns_capacity) * 4) as u64;
        let agreeing = (0..2)
            .filter(|&h| agree(&e.held_spacing[h], &spacing))
            .max_by_key(|&h| e.held_spacing[h].len().min(spacing.len()));
        let spacing_half = match agreeing.filter(|&h| !e.held_spacing[h].is_empty()) {
            Some(h) => {
                let held = e.held_spacing[h].len();
                if spacing.len() > held {
                    ctx.write_buffer(
                        &e.tables,
                        spacing_at(h) + (held * 4) as u64,
                        bytemuck::cast_slice(&spacing[held..]),
                    );
                    e.held_spacing[h].extend_from_slice(&spacing[held..]);
                }
                h
            }
            None => {
                let h = prev_half.map_or(0, |p| 1 - p.1);
                ctx.write_buffer(&e.tables, spacing_at(h), bytemuck::cast_slice(&spacing));
                e.held_spacing[h] = spacing;
                h
            }
        };
        let view = TemporalViewGpu {
            camera: TemporalCameraGpu::of(camera),
            gaze: [
                (centre.x_px - cx as f64) as f32,
                (centre.y_px - cy as f64) as f32,
            ],
            offset: layer.offset,
            width: layer.width,
            height: layer.height,
            kind: if polar.is_some() {
                KIND_POLAR
            } else {
                KIND_SCREEN
            },
            columns: n_columns as u32,
            table: (column_half * e.half) as u32,
            spacing: (spacing_half * e.half + 4 * e.columns_capacity) as u32,
            spacing_len: spacing_len as u32,
            steps_per_deg: (1.0 / SPACING_STEP_DEG) as f32,
            _pad0: 0,
        };
        let groups_total = texels.div_ceil(u64::from(WORKGROUP_SIZE)).max(1);
        let gx = groups_total.min(u64::from(MAX_GROUPS));
        let gy = groups_total.div_ceil(gx);
        if gy > u64::from(MAX_GROUPS) {
            return Err(GpuError::Unsupported(format!(
                "{texels} texels in one temporal dispatch"
            )));
        }
        e.groups = [gx as u32, gy as u32];
        let uniform = TemporalUniform {
            cur: view,
            prev: previous.map_or(view, |p| p.view),
            screen: [display.0 as f32, display.1 as f32],
            alpha_min: self.settings.alpha_min,
            tau: self.settings.depth_tolerance,
            c_r: plan.display.c_r() as f32,
            clamp: u32::from(self.settings.clamp),
            history: u32::from(previous.is_some()),
            row_invocations: e.groups[0] * WORKGROUP_SIZE,
            inf_bits: f32::INFINITY.to_bits(),
            guides: u32::from(shade.guides().is_some()),
            moments: u32::from(e.moments),
            albedo_floor: fovea_post::denoise::ALBEDO_FLOOR,
        };
        ctx.write_buffer(&e.uniform, 0, bytemuck::bytes_of(&uniform));
        e.copy = previous.map(|_| (u64::from(layer.offset), texels));
        e.previous = Some(Previous {
            view,
            method: plan.method(),
            display,
        });
        Ok(())
    }

    /// Records eye `eye`'s pass (after [`Self::prepare`]) into `encoder`: the blend, then the
    /// accumulated colour copied over the eye's samples (`samples`, the buffer the sample side
    /// wrote). The next frame reads what this one wrote.
    pub fn record(
        &mut self,
        eye: usize,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<()> {
        let Some(e) = self.eyes.get_mut(eye).and_then(Option::as_mut) else {
            return Err(GpuError::Input(format!(
                "eye {eye}'s temporal pass was not prepared"
            )));
        };
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("resident frame: temporal accumulation"),
                timestamp_writes,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &e.bind_groups[e.next], &[]);
            pass.dispatch_workgroups(e.groups[0], e.groups[1], 1);
        }
        if let Some((offset, texels)) = e.copy.take() {
            encoder.copy_buffer_to_buffer(
                &e.color[e.next],
                offset * TEXEL_BYTES,
                &e.bound[0],
                offset * TEXEL_BYTES,
                texels * TEXEL_BYTES,
            );
        }
        e.next = 1 - e.next;
        Ok(())
    }
}
