//! Stage 5 of the frame (DESIGN.md "How a frame flows"): **sample-space post** — temporal
//! accumulation (the previous frame reprojected and folded into the fresh samples, see
//! `crate::temporal`), denoising (`fovea_post::denoise`, SVGF's edge-avoiding à-trous filter
//! over the polar buffer or the screen, [`denoise`]) and anti-aliasing inside the sample
//! buffers: FXAA for VaFR and
//! visual-polar (VaFR Sec. 3.4, with the polar seam wrapped), the 3×3 Gaussian for KFR and LaFR
//! (Meng et al.), none for the others unless asked.
//!
//! Another executor (the GPU's, `fovea-gpu`, plugged in by the CLI) can take over the AA
//! filter through [`AaExecutor`], and the denoiser through [`DenoiseExecutor`]; the frame's
//! stats say which one ran ([`super::FrameStats::aa_backend`],
//! [`super::FrameStats::denoise_backend`]). The minified columns are restored on the CPU either
//! way.

use fovea_core::Image;
use fovea_post::denoise::{DenoiseGuides, DenoiseParams, DenoiseScratch, DenoiseStats};
use fovea_post::fxaa::{fxaa, FxaaParams};
use fovea_post::gaussian_aa::gaussian_3x3;
use fovea_post::grid::Grid;
use fovea_post::inverse_map::{minified_columns, ReconstructFilter, SampleBuffers};
use fovea_post::Rgb;

use super::AaMode;
use crate::camera::EyeCamera;
use crate::error::{RenderError, Result};
use crate::plan::FramePlan;
use crate::temporal::{MonteCarloPart, TemporalAccumulator, TemporalStats};

/// Folds the previous frame held by `accumulator` into this frame's `samples` (before AA).
/// With the denoiser's `guides` (their `noisy` holding the fresh frame's *exact* part:
/// [`complement_part`] before), the accumulation also keeps the temporal moments of the Monte
/// Carlo part's luminance and writes their variance into `guides.variance` for the denoiser
/// (`crate::temporal::TemporalSettings::variance`; NaN where a texel's history is shorter than
/// `crate::temporal::VARIANCE_MIN_AGE` frames, emptied where it is not estimated).
pub fn accumulate(
    plan: &FramePlan,
    camera: &EyeCamera,
    accumulator: &mut TemporalAccumulator,
    samples: &mut SampleBuffers,
    guides: Option<&mut DenoiseGuides>,
) -> Result<TemporalStats> {
    let part = guides.map(|g| MonteCarloPart {
        exact: &g.noisy,
        albedo: &g.albedo,
        variance: &mut g.variance,
    });
    accumulator.accumulate(plan, camera, samples, part)
}

/// Denoises every layer of `samples` with `params`, guided by `guides` (recorded by the
/// trace for this frame) and each layer's depth, over the layer's topology: a polar buffer
/// (VaFR, KFR/LMFR, LaFR, visual-polar) wraps around the angle axis and reads across the
/// fovea half a turn on; a screen-aligned one (full resolution, Weier's sparse screen grid,
/// Guenter's layers, the inset) is a rectangle. Texels with no surface record (sky, unshaded,
/// Weier's unsampled pixels, prefilled) are left as they are and never read. On `executor`
/// (e.g. the GPU's) where it [supports](DenoiseExecutor::supports) the buffers, else on the
/// CPU; returns what the filter did and the backend that ran it (`cpu` or the executor's
/// name).
///
/// After temporal accumulation, `guides.noisy` must hold the accumulated colour's Monte Carlo
/// part ([`complement_part`] before and after it), and `guides.variance` (where present) the
/// temporal variance [`accumulate`] wrote; without accumulation it must be empty (the spatial
/// estimate).
pub fn denoise(
    plan: &FramePlan,
    params: &DenoiseParams,
    samples: &mut SampleBuffers,
    guides: &DenoiseGuides,
    scratch: &mut DenoiseScratch,
    executor: Option<&mut (dyn DenoiseExecutor + 'static)>,
) -> Result<DenoiseStats> {
    if guides.albedo.len() != samples.color.len() || guides.normal.len() != samples.color.len() {
        return Err(RenderError::invalid(
            "denoise guides",
            format!("{} layers", guides.albedo.len()),
            format!("one per sample buffer ({})", samples.depth.len()),
        ));
    }
    let polar = plan.mapping().polar_layout();
    let grids: Vec<Grid> = samples
        .color
        .iter()
        .map(|c| Grid::of_layer(polar.as_ref(), c.width(), c.height()))
        .collect();
    // `executor` is the one the frame's `StageBackends` placed the stage on (it supports
    // these buffers' sizes), or none: the CPU.
    if let Some(ex) = executor {
        let stats = ex
            .denoise(params, &grids, samples, guides)
            .map_err(|message| RenderError::Executor {
                stage: "denoise",
                backend: ex.backend().to_string(),
                message,
            })?;
        return Ok(stats);
    }
    let mut stats = DenoiseStats::default();
    for (l, ((c, d), grid)) in samples
        .color
        .iter_mut()
        .zip(samples.depth.iter())
        .zip(&grids)
        .enumerate()
    {
        let (albedo, normal) = (&guides.albedo[l], &guides.normal[l]);
        let noisy = guides.noisy.get(l);
        let variance = guides.variance.get(l);
        stats += fovea_post::denoise::denoise_with_variance(
            c, d, albedo, normal, noisy, variance, grid, params, scratch,
        )?;
    }
    Ok(stats)
}

/// Another executor of the sample-space denoiser (e.g. the GPU's), kept in a
/// [`super::FrameContext`] from frame to frame. For the buffers it
/// [`supports`](Self::supports) it replaces `fovea_post::denoise::denoise` over every layer
/// and must return what it returns (within the executor's documented agreement: the GPU's is
/// ≥ 40 dB in luma), the colours filtered in place and the depths untouched.
pub trait DenoiseExecutor: Send {
    /// The backend's short name in stats and JSON, e.g. `gpu`.
    fn backend(&self) -> &str;
    /// Whether it denoises sample buffers of these layer sizes (width, height).
    fn supports(&self, sizes: &[(u32, u32)]) -> bool;
    /// Denoises every layer of `samples` in place with `params` over `grids` (one per layer),
    /// guided by `guides` and the depths. An error is one line saying what to do.
    fn denoise(
        &mut self,
        params: &DenoiseParams,
        grids: &[Grid],
        samples: &mut SampleBuffers,
        guides: &DenoiseGuides,
    ) -> std::result::Result<DenoiseStats, String>;
}

/// Replaces each texel's part in `guides.noisy` by its colour less that part (NaN, unknown,
/// stays NaN; layers of another size are left alone). Called twice around temporal
/// accumulation so the denoiser's Monte Carlo part follows the colour through the blend:
/// before it, the fresh frame's Monte Carlo part becomes the exact part of its colour (the
/// lights' shadow rays, the emission); after it, the accumulated colour less that exact part
/// is the accumulated Monte Carlo part. Where the view is still the history's exact light is
/// the frame's, so that difference is the averaged estimate the denoiser filters while the
/// exact light (the point lights' highlights and shadow edges) is kept; where the history
/// moved or was rejected, what it changed is filtered with it.
pub fn complement_part(samples: &SampleBuffers, guides: &mut DenoiseGuides) {
    for (c, n) in samples.color.iter().zip(guides.noisy.iter_mut()) {
        if c.width() != n.width() || c.height() != n.height() {
            continue;
        }
        for (n, c) in n.data_mut().iter_mut().zip(c.data()) {
            *n = [c[0] - n[0], c[1] - n[1], c[2] - n[2]];
        }
    }
}

/// Another executor of the AA filter (e.g. the GPU's), kept in a [`super::FrameContext`] from
/// frame to frame. For the modes and grids it [`supports`](Self::supports) it replaces
/// `fovea_post::fxaa::fxaa` / `fovea_post::gaussian_aa::gaussian_3x3` and must return what
/// they return (every texel: the grid's valid ones filtered, the others as they were); the
/// restoring of minified columns and every other stage stay on the CPU.
pub trait AaExecutor: Send {
    /// The backend's short name in stats and JSON, e.g. `gpu`.
    fn backend(&self) -> &str;
    /// Whether it runs `mode` ([`AaMode::Fxaa`] or [`AaMode::Gaussian`]) on `grid`.
    fn supports(&self, mode: AaMode, grid: &Grid) -> bool;
    /// `color` filtered with `mode` (FXAA with `params`) on `grid`. An error is one line
    /// saying what to do.
    fn anti_alias(
        &mut self,
        mode: AaMode,
        params: &FxaaParams,
        grid: &Grid,
        color: &Image<Rgb>,
    ) -> std::result::Result<Image<Rgb>, String>;
}

/// Anti-aliases every layer of `color` with the plan's resolved AA mode, on `executor` when
/// given (the frame's [`super::StageBackends`] put the stage there) and on the CPU otherwise. With the footprint
/// reconstruction (the default), the columns of a polar buffer whose texels are smaller than a
/// screen pixel both ways ([`minified_columns`]: VaFR's and visual-polar's fovea) are left as
/// they are: the reconstruction averages every sample a pixel holds there, so an edge is
/// already anti-aliased and FXAA or the Gaussian would only blur it further (issue 17; the
/// measurements are in docs/rendering.md, "Anti-aliasing the fovea and the periphery").
pub fn anti_alias(
    plan: &FramePlan,
    color: &mut [Image<Rgb>],
    mut executor: Option<&mut (dyn AaExecutor + 'static)>,
) -> Result<()> {
    if plan.aa == AaMode::None {
        return Ok(());
    }
    let params = FxaaParams::default();
    let polar = plan.mapping().polar_layout();
    let keep = match plan.settings.reconstruct_filter {
        ReconstructFilter::Footprint => minified_columns(plan.mapping()),
        ReconstructFilter::Bilinear => None,
    };
    for c in color.iter_mut() {
        let grid = Grid::of_layer(polar.as_ref(), c.width(), c.height());
        if matches!(plan.aa, AaMode::None | AaMode::Auto) {
            // `FramePlan` resolves `Auto`; `None` returned above.
            return Ok(());
        }
        let mut out = match executor.as_deref_mut() {
            Some(ex) => {
                let out = ex
                    .anti_alias(plan.aa, &params, &grid, c)
                    .map_err(|message| RenderError::Executor {
                        stage: "aa",
                        backend: ex.backend().to_string(),
                        message,
                    })?;
                if (out.width(), out.height()) != (c.width(), c.height()) {
                    return Err(RenderError::Executor {
                        stage: "aa",
                        backend: ex.backend().to_string(),
                        message: format!(
                            "returned a {}x{} buffer for a {}x{} one",
                            out.width(),
                            out.height(),
                            c.width(),
                            c.height()
                        ),
                    });
                }
                out
            }
            None if plan.aa == AaMode::Fxaa => fxaa(c, &grid, &params),
            None => gaussian_3x3(c, &grid),
        };
        if let Some(keep) = &keep {
            restore_columns(&mut out, c, keep);
        }
        *c = out;
    }
    Ok(())
}

/// The name of the CPU backend in stats.
pub const CPU: &str = "cpu";

/// Copies the columns `i` of `original` with `keep[i]` back into `out` (same size; a polar
/// buffer's x is its column `u`, so `keep` applies along every image row).
fn restore_columns(out: &mut Image<Rgb>, original: &Image<Rgb>, keep: &[bool]) {
    let w = out.width() as usize;
    if w == 0 {
        return;
    }
    for (dst, src) in out.data_mut().chunks_mut(w).zip(original.data().chunks(w)) {
        for ((d, s), _) in dst.iter_mut().zip(src).zip(keep).filter(|(_, &k)| k) {
            *d = *s;
        }
    }
}
