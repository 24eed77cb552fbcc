//! The buffers of a frame, kept from frame to frame: a sequence, the bench's repeated frames
//! or a real-time loop allocates its sample and screen buffers once and reuses them while the
//! plan's sizes stay the same. At 8K a fresh screen buffer costs more than the reconstruction
//! that fills it: the kernel zeroes every new page on first touch (about 20 % of an 8K VaFR
//! frame's CPU time before this context existed).

use rayon::prelude::*;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::Image;
use fovea_post::denoise::{DenoiseGuides, DenoiseScratch};
use fovea_post::inverse_map::SampleBuffers;
use fovea_post::Rgb;

use super::reconstruct::ReconstructExecutor;
use super::sample_post::{AaExecutor, DenoiseExecutor};
use super::screen_post::DofExecutor;
use super::trace_shade::TraceExecutor;
use super::{Frame, Prefill};
use crate::error::{RenderError, Result};
use crate::plan::FramePlan;

/// Rows of this many values per parallel task when filling or copying buffers.
const PAR_CHUNK: usize = 1 << 16;

/// `dst[i] = v` on every thread (first touches of fresh pages are spread too).
fn par_fill<T: Copy + Send + Sync>(dst: &mut [T], v: T) {
    dst.par_chunks_mut(PAR_CHUNK).for_each(|c| c.fill(v));
}

/// `dst = src` on every thread.
fn par_copy<T: Copy + Send + Sync>(dst: &mut [T], src: &[T]) {
    dst.par_chunks_mut(PAR_CHUNK)
        .zip(src.par_chunks(PAR_CHUNK))
        .for_each(|(d, s)| d.copy_from_slice(s));
}

/// Buffers reused across frames. Create one per eye and keep it for the whole sequence.
#[derive(Default)]
pub struct FrameContext {
    /// Sample buffers (colour, depth per layer).
    samples: Option<SampleBuffers>,
    /// The last frame: its colour and depth are the next frame's screen buffers.
    frame: Option<Frame>,
    /// A screen-sized colour image freed by the screen post (the reconstruction's output when
    /// contrast or DOF produced a new image), reused by the next reconstruction.
    spare_color: Option<Image<Rgb>>,
    /// Screen buffers allocated so far (colour and depth count one each).
    screen_allocations: u64,
    /// The other executors the stages run on, where one is plugged in.
    executors: Executors,
    /// The denoiser's guides (written by the trace) and working buffers, when it is on.
    denoise: (DenoiseGuides, DenoiseScratch),
}

/// The executors other than the CPU's (e.g. the GPU's) that a [`FrameContext`] runs stages
/// on; each `None` stage runs on the CPU. They move between contexts as a whole
/// ([`FrameContext::take_executors`], [`FrameContext::set_executors`]): e.g. a viewer's two
/// eyes, each with its own buffers, take turns on one GPU's executors.
#[derive(Default)]
pub struct Executors {
    /// The trace stage's ray casting (see [`FrameContext::set_tracer`]).
    pub tracer: Option<Box<dyn TraceExecutor>>,
    /// The reconstruct stage (see [`FrameContext::set_reconstructor`]).
    pub reconstructor: Option<Box<dyn ReconstructExecutor>>,
    /// The depth-of-field stage (see [`FrameContext::set_dof_executor`]).
    pub dof: Option<Box<dyn DofExecutor>>,
    /// The sample-space AA filter (see [`FrameContext::set_anti_aliaser`]).
    pub anti_aliaser: Option<Box<dyn AaExecutor>>,
    /// The sample-space denoiser (see [`FrameContext::set_denoiser`]).
    pub denoiser: Option<Box<dyn DenoiseExecutor>>,
}

impl Executors {
    /// Whether every stage runs on the CPU.
    pub fn is_empty(&self) -> bool {
        self.tracer.is_none()
            && self.reconstructor.is_none()
            && self.dof.is_none()
            && self.anti_aliaser.is_none()
            && self.denoiser.is_none()
    }
}

impl FrameContext {
    /// An empty context; the first frame allocates.
    pub fn new() -> Self {
        Self::default()
    }

    /// The last frame rendered with this context.
    pub fn frame(&self) -> Option<&Frame> {
        self.frame.as_ref()
    }

    /// The last frame, taken out (the next frame allocates its screen buffers again).
    pub fn take_frame(&mut self) -> Option<Frame> {
        self.frame.take()
    }

    /// How many screen-sized buffers this context has allocated.
    pub fn screen_allocations(&self) -> u64 {
        self.screen_allocations
    }

    /// Sample buffers sized for `plan`, reset (colour 0, depth ∞) or copied from `prefill`.
    pub(crate) fn samples_for(
        &mut self,
        plan: &FramePlan,
        prefill: Option<&Prefill>,
    ) -> Result<&mut SampleBuffers> {
        let sizes = &plan.buffers;
        if let Some(p) = prefill {
            let ok = |n: usize, dims: &mut dyn Iterator<Item = (u32, u32)>| {
                n == sizes.len() && dims.zip(sizes).all(|(d, b)| d == (b.width, b.height))
            };
            if !(ok(
                p.color.len(),
                &mut p.color.iter().map(|i| (i.width(), i.height())),
            ) && ok(
                p.depth.len(),
                &mut p.depth.iter().map(|i| (i.width(), i.height())),
            ) && ok(
                p.known.len(),
                &mut p.known.iter().map(|i| (i.width(), i.height())),
            )) {
                return Err(RenderError::invalid(
                    "prefill",
                    format!("{} layers", p.color.len()),
                    format!("buffers of the mapping's sizes {sizes:?}"),
                ));
            }
        }
        // Full resolution: the last frame's screen images are this frame's sample buffers (the
        // reconstruction hands the sample buffer over as the screen), so one pair of
        // screen-sized buffers serves every frame.
        let full = plan.method() == Method::Full;
        if full {
            let screen = (plan.display.width_px, plan.display.height_px);
            let last = self.frame.take_if(|f| {
                (f.color.width(), f.color.height()) == screen
                    && (f.depth.width(), f.depth.height()) == screen
            });
            if let Some(f) = last {
                self.samples = Some(SampleBuffers {
                    color: vec![f.color],
                    depth: vec![f.depth],
                });
            }
        }
        let fits = self.samples.as_ref().is_some_and(|s| {
            s.color.len() == sizes.len()
                && s.color
                    .iter()
                    .zip(sizes)
                    .all(|(i, b)| (i.width(), i.height()) == (b.width, b.height))
        });
        if !fits {
            if full {
                // Colour and depth of the screen.
                self.screen_allocations += 2;
            }
            let mut color = Vec::with_capacity(sizes.len());
            let mut depth = Vec::with_capacity(sizes.len());
            for b in sizes {
                color.push(Image::new(b.width, b.height, [0.0f32; 3])?);
                depth.push(Image::new(b.width, b.height, f32::INFINITY)?);
            }
            self.samples = Some(SampleBuffers { color, depth });
        }
        // At full resolution without culling or jitter the trace and shade write every
        // texel (colour and depth), so reused buffers need no reset.
        let all_written = plan.method() == Method::Full
            && plan.culling.is_none()
            && plan.jitter_texels == [0.0, 0.0];
        let s = self.samples.as_mut().expect("set above");
        for (l, (c, d)) in s.color.iter_mut().zip(s.depth.iter_mut()).enumerate() {
            match prefill {
                Some(p) => {
                    par_copy(c.data_mut(), p.color[l].data());
                    par_copy(d.data_mut(), p.depth[l].data());
                }
                None if fits && !all_written => {
                    par_fill(c.data_mut(), [0.0; 3]);
                    par_fill(d.data_mut(), f32::INFINITY);
                }
                None => {}
            }
        }
        Ok(s)
    }

    /// The sample buffers [`samples_for`](Self::samples_for) prepared, and the executor of
    /// the AA filter, if one is plugged in.
    pub(crate) fn samples_and_anti_aliaser(
        &mut self,
    ) -> (&mut SampleBuffers, Option<&mut (dyn AaExecutor + 'static)>) {
        let samples = self
            .samples
            .as_mut()
            .expect("samples_for runs before the AA");
        (samples, self.executors.anti_aliaser.as_deref_mut())
    }

    /// The sample buffers [`samples_for`](Self::samples_for) prepared, and the executor of
    /// the reconstruct stage, if one is plugged in.
    pub(crate) fn samples_and_executor(
        &mut self,
    ) -> (
        &mut SampleBuffers,
        Option<&mut (dyn ReconstructExecutor + 'static)>,
    ) {
        let samples = self
            .samples
            .as_mut()
            .expect("samples_for runs before the reconstruction");
        (samples, self.executors.reconstructor.as_deref_mut())
    }

    /// The sample buffers for `plan` ([`samples_for`](Self::samples_for)), the executor
    /// of the trace stage, if one is plugged in, and the denoiser's guides sized for `plan`
    /// when it denoises.
    #[allow(clippy::type_complexity)]
    pub(crate) fn samples_and_tracer(
        &mut self,
        plan: &FramePlan,
        prefill: Option<&Prefill>,
    ) -> Result<(
        &mut SampleBuffers,
        Option<&mut (dyn TraceExecutor + 'static)>,
        Option<&mut DenoiseGuides>,
    )> {
        self.samples_for(plan, prefill)?;
        let samples = self
            .samples
            .as_mut()
            .expect("samples_for keeps the buffers it prepares");
        let guides = match plan.settings.denoise {
            Some(_) => {
                let sizes: Vec<(u32, u32)> =
                    plan.buffers.iter().map(|b| (b.width, b.height)).collect();
                self.denoise.0.fit(&sizes)?;
                Some(&mut self.denoise.0)
            }
            None => None,
        };
        Ok((samples, self.executors.tracer.as_deref_mut(), guides))
    }

    /// The sample buffers [`samples_for`](Self::samples_for) prepared, with the denoiser's
    /// guides (as the trace wrote them) and working buffers, and the executor of the
    /// denoiser, if one is plugged in.
    #[allow(clippy::type_complexity)]
    pub(crate) fn samples_and_denoiser(
        &mut self,
    ) -> (
        &mut SampleBuffers,
        &DenoiseGuides,
        &mut DenoiseScratch,
        Option<&mut (dyn DenoiseExecutor + 'static)>,
    ) {
        let samples = self
            .samples
            .as_mut()
            .expect("samples_for runs before the denoiser");
        let (guides, scratch) = &mut self.denoise;
        (
            samples,
            &*guides,
            scratch,
            self.executors.denoiser.as_deref_mut(),
        )
    }

    /// Casts the trace stage's primary rays on `executor` (e.g. the GPU's) in every frame
    /// rendered with this context, for the world it was built for.
    pub fn set_tracer(&mut self, executor: Box<dyn TraceExecutor>) {
        self.executors.tracer = Some(executor);
    }

    /// Runs the reconstruct stage's lookup on `executor` (e.g. the GPU's) for the mappings it
    /// supports, in every frame rendered with this context.
    pub fn set_reconstructor(&mut self, executor: Box<dyn ReconstructExecutor>) {
        self.executors.reconstructor = Some(executor);
    }

    /// Runs the depth-of-field stage (CoC map and filter) on `executor` (e.g. the GPU's) for
    /// the filters it supports, in every frame rendered with this context.
    pub fn set_dof_executor(&mut self, executor: Box<dyn DofExecutor>) {
        self.executors.dof = Some(executor);
    }

    /// The executor of the depth-of-field stage, if one is plugged in.
    pub(crate) fn dof_executor(&mut self) -> Option<&mut (dyn DofExecutor + 'static)> {
        self.executors.dof.as_deref_mut()
    }

    /// Runs the sample-space AA filter (FXAA, the 3×3 Gaussian) on `executor` (e.g. the GPU's)
    /// for the modes and grids it supports, in every frame rendered with this context.
    pub fn set_anti_aliaser(&mut self, executor: Box<dyn AaExecutor>) {
        self.executors.anti_aliaser = Some(executor);
    }

    /// Runs the sample-space denoiser on `executor` (e.g. the GPU's) for the buffers it
    /// supports, in every frame rendered with this context.
    pub fn set_denoiser(&mut self, executor: Box<dyn DenoiseExecutor>) {
        self.executors.denoiser = Some(executor);
    }

    /// Plugs in `executors`, replacing every executor the context had.
    pub fn set_executors(&mut self, executors: Executors) {
        self.executors = executors;
    }

    /// Takes the context's executors out (its stages then run on the CPU until
    /// [`Self::set_executors`]).
    pub fn take_executors(&mut self) -> Executors {
        std::mem::take(&mut self.executors)
    }

    /// Screen-sized colour and depth buffers for `plan`'s display: the last frame's when they
    /// fit, otherwise new (zeroed pages, faulted in where the reconstruction writes them).
    pub(crate) fn screen_buffers(&mut self, plan: &FramePlan) -> Result<(Image<Rgb>, Image<f32>)> {
        let display: &DisplayProfile = &plan.display;
        if plan.method() == Method::Full {
            // The sample buffer is the screen: the reconstruction hands it over as it is
            // (`samples_for` took the last frame's images as this frame's samples).
            return Ok((Image::new(1, 1, [0.0; 3])?, Image::new(1, 1, 0.0)?));
        }
        let (w, h) = (display.width_px, display.height_px);
        let fits = |wh: (u32, u32)| wh == (w, h);
        let last = self.frame.take();
        let (mut color, mut depth) = (None, None);
        if let Some(f) = last {
            if fits((f.depth.width(), f.depth.height())) {
                depth = Some(f.depth);
            }
            // Any screen-sized image will do: the reconstruction writes every pixel.
            if fits((f.color.width(), f.color.height())) {
                color = Some(f.color);
            }
        }
        if color.is_none() {
            color = self
                .spare_color
                .take()
                .filter(|c| fits((c.width(), c.height())));
        }
        let n = w as usize * h as usize;
        let color = match color {
            Some(c) => c,
            None => {
                self.screen_allocations += 1;
                Image::from_vec(w, h, fovea_post::alloc::zeroed::<[f32; 3]>(n))?
            }
        };
        let depth = match depth {
            Some(d) => d,
            None => {
                self.screen_allocations += 1;
                Image::from_vec(w, h, fovea_post::alloc::zeroed::<f32>(n))?
            }
        };
        Ok((color, depth))
    }

    /// Keeps a screen colour image the screen post replaced, for the next frame.
    pub(crate) fn keep_spare(&mut self, color: Image<Rgb>) {
        self.spare_color = Some(color);
    }

    /// Stores the finished frame.
    pub(crate) fn store(&mut self, frame: Frame) -> &Frame {
        self.frame.insert(frame)
    }
}
