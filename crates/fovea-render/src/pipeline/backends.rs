//! Where each stage of a frame runs, and why (issue 37, item 8): decided once, before the
//! first pass, from the frame's executors and its plan ([`StageBackends::decide`]), instead
//! of each stage asking its executor per call. The stages read the decision; the frame's
//! stats carry it ([`super::FrameStats::stage_backends`], and the `*_backend` names copied
//! from it).
//!
//! A stage runs on another executor (e.g. the GPU's) when the frame's context holds one
//! and it takes what the plan asks for: the trace executor serves the world's triangles;
//! rays are generated and surfaces interpolated where it can; the shade stage's rays and
//! lights go to it for direct shading of one ray per texel without DOF culling; the AA
//! executor takes the mode and every layer's grid (a buffer within its bindings); the
//! reconstruct executor takes the mapping (its buffers within its bindings); the DOF
//! executor takes the filter and CoC model and the screen's size. Otherwise the CPU runs
//! it, and where an executor was there the record says why.

use serde::Serialize;

use fovea_post::grid::Grid;

use super::context::Executors;
use super::timing::Stage;
use crate::plan::FramePlan;
use crate::settings::AaMode;
use crate::shade::EnvLight;
use crate::world::World;

/// The name of the CPU in the record.
pub const CPU: &str = "cpu";

/// Where one stage runs.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Placement {
    /// `cpu`, or the executor's name (`gpu`).
    pub backend: String,
    /// Why the CPU runs it although the frame's context holds an executor for the stage
    /// (`None` when it runs on the executor, or there is none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub on_cpu_because: Option<String>,
}

impl Placement {
    /// On the CPU, with no executor for the stage.
    pub fn cpu() -> Self {
        Self {
            backend: CPU.to_string(),
            on_cpu_because: None,
        }
    }

    /// On the CPU although there is an executor, because `why`.
    fn cpu_because(why: impl Into<String>) -> Self {
        Self {
            backend: CPU.to_string(),
            on_cpu_because: Some(why.into()),
        }
    }

    /// On the executor named `name`.
    fn on(name: &str) -> Self {
        Self {
            backend: name.to_string(),
            on_cpu_because: None,
        }
    }

    /// Whether another executor than the CPU runs the stage.
    pub fn on_executor(&self) -> bool {
        self.backend != CPU
    }

    /// `self` if it runs on an executor, else `otherwise` (the CPU, with a reason when the
    /// stage it depends on ran on the executor).
    fn and_then(&self, then: impl FnOnce(&str) -> Placement) -> Placement {
        if self.on_executor() {
            then(&self.backend)
        } else {
            Placement::cpu()
        }
    }
}

/// Where every stage of a frame runs that an executor can take.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct StageBackends {
    /// The primary rays' generation (their screen points and directions).
    pub ray_generation: Placement,
    /// The primary rays' closest hits (the trace stage).
    pub trace: Placement,
    /// The surface at each primary hit (the G-buffer record).
    pub surface: Placement,
    /// The shade stage's shadow rays.
    pub shadow: Placement,
    /// The lights' part of direct shading.
    pub direct_light: Placement,
    /// The environment's part of direct shading.
    pub environment_light: Placement,
    /// The sample-space AA filter.
    pub aa: Placement,
    /// The reconstruct stage's lookup.
    pub reconstruct: Placement,
    /// The depth-of-field stage (CoC map and filter).
    pub dof: Placement,
    /// The sample-space denoiser.
    pub denoise: Placement,
}

impl Default for StageBackends {
    /// Every stage on the CPU.
    fn default() -> Self {
        Self {
            ray_generation: Placement::cpu(),
            trace: Placement::cpu(),
            surface: Placement::cpu(),
            shadow: Placement::cpu(),
            direct_light: Placement::cpu(),
            environment_light: Placement::cpu(),
            aa: Placement::cpu(),
            reconstruct: Placement::cpu(),
            dof: Placement::cpu(),
            denoise: Placement::cpu(),
        }
    }
}

impl StageBackends {
    /// Where each stage of the frame `plan` of `world` runs with `executors`.
    pub fn decide(executors: &Executors, world: &World, plan: &FramePlan) -> Self {
        let trace = match executors.tracer.as_deref() {
            None => Placement::cpu(),
            Some(t) if !t.serves(world) => {
                Placement::cpu_because("the trace executor holds another world's triangles")
            }
            Some(t) => Placement::on(t.backend()),
        };
        let tracer = executors.tracer.as_deref();
        let can = |f: &dyn Fn(&dyn super::TraceExecutor) -> bool| tracer.is_some_and(f);
        let ray_generation = trace.and_then(|name| match can(&|t| t.generates_rays()) {
            true => Placement::on(name),
            false => Placement::cpu_because("the trace executor does not generate rays"),
        });
        let surface = ray_generation.and_then(|name| match can(&|t| t.interpolates_surfaces()) {
            true => Placement::on(name),
            false => Placement::cpu_because(
                tracer
                    .and_then(|t| t.why_no_surfaces())
                    .unwrap_or_else(|| "the trace executor does not interpolate surfaces".into()),
            ),
        });
        // The shade stage's rays go to the executor for direct shading of one ray per texel
        // without DOF culling (`trace_shade::shade_chunk`).
        let shading = plan.settings.shading;
        let shade_why = if shading.direct_env_light().is_none() {
            Some("path tracing shades on the CPU")
        } else if plan.culling.is_some() {
            Some("DOF culling shades on the CPU")
        } else if !(plan.rays.per_column.is_empty() && plan.rays.uniform == 1) {
            Some("several rays per texel shade on the CPU")
        } else {
            None
        };
        let shadow = trace.and_then(|name| match shade_why {
            None => Placement::on(name),
            Some(why) => Placement::cpu_because(why),
        });
        let direct_light = shadow.and_then(|name| match can(&|t| t.shades_direct_light()) {
            true => Placement::on(name),
            false => Placement::cpu_because("the trace executor does not compute direct light"),
        });
        let env_rays = matches!(
            shading.direct_env_light(),
            Some(EnvLight::Occluded { samples }) if samples > 0
        );
        let environment_light =
            shadow.and_then(|name| match (env_rays, can(&|t| t.shades_environment())) {
                (false, _) => Placement::cpu_because("no environment rays"),
                (true, true) => Placement::on(name),
                (true, false) => {
                    Placement::cpu_because("the trace executor does not compute environment light")
                }
            });
        Self {
            ray_generation,
            trace,
            surface,
            shadow,
            direct_light,
            environment_light,
            aa: aa(executors, plan),
            reconstruct: reconstruct(executors, plan),
            dof: dof(executors, plan),
            denoise: denoise(executors, plan),
        }
    }

    /// The backend of a stage of [`Stage`]'s list: the trace, AA, reconstruct and DOF
    /// stages as decided, every other stage `cpu`.
    pub fn of(&self, stage: Stage) -> &str {
        match stage {
            Stage::Trace => &self.trace.backend,
            Stage::Aa => &self.aa.backend,
            Stage::Reconstruct => &self.reconstruct.backend,
            Stage::Dof => &self.dof.backend,
            Stage::Denoise => &self.denoise.backend,
            _ => CPU,
        }
    }
}

/// The denoiser: on the executor when the plan denoises and it takes every layer's size.
fn denoise(executors: &Executors, plan: &FramePlan) -> Placement {
    let Some(ex) = executors.denoiser.as_deref() else {
        return Placement::cpu();
    };
    if plan.settings.denoise.is_none() {
        return Placement::cpu_because("the plan does not denoise");
    }
    let sizes: Vec<(u32, u32)> = plan.buffers.iter().map(|b| (b.width, b.height)).collect();
    match ex.supports(&sizes) {
        true => Placement::on(ex.backend()),
        false => Placement::cpu_because(format!(
            "the denoise executor does not take {} buffers here (past its bindings)",
            plan.method()
        )),
    }
}

/// The AA filter: on the executor when it takes the plan's mode on every layer's grid.
fn aa(executors: &Executors, plan: &FramePlan) -> Placement {
    let Some(ex) = executors.anti_aliaser.as_deref() else {
        return Placement::cpu();
    };
    if matches!(plan.aa, AaMode::None | AaMode::Auto) {
        return Placement::cpu();
    }
    let polar = plan.mapping().polar_layout();
    let fits = plan
        .buffers
        .iter()
        .all(|b| ex.supports(plan.aa, &Grid::of_layer(polar.as_ref(), b.width, b.height)));
    match fits {
        true => Placement::on(ex.backend()),
        false => Placement::cpu_because(format!(
            "the AA executor does not take {:?} on these buffers (a mode it lacks, or a \
             buffer past its bindings)",
            plan.aa
        )),
    }
}

/// The reconstruction: on the executor when it takes the plan's mapping (full resolution
/// has none: its buffer is the screen).
fn reconstruct(executors: &Executors, plan: &FramePlan) -> Placement {
    let Some(ex) = executors.reconstructor.as_deref() else {
        return Placement::cpu();
    };
    if plan.method() == fovea_core::mapping::Method::Full {
        return Placement::cpu();
    }
    match ex.supports(plan.mapping()) {
        true => Placement::on(ex.backend()),
        false => Placement::cpu_because(format!(
            "the reconstruct executor does not take {} here (a mapping it lacks, or buffers \
             past its bindings)",
            plan.method()
        )),
    }
}

/// The depth of field: on the executor when it takes the plan's filter and CoC model at the
/// screen's size.
fn dof(executors: &Executors, plan: &FramePlan) -> Placement {
    let Some(ex) = executors.dof.as_deref() else {
        return Placement::cpu();
    };
    let (Some(d), Some(_)) = (&plan.settings.dof, plan.focus_m()) else {
        return Placement::cpu();
    };
    let Some(kind) = d.filter else {
        return Placement::cpu();
    };
    let (w, h) = (plan.display.width_px, plan.display.height_px);
    if !ex.supports(kind, &d.coc_model) {
        Placement::cpu_because(format!(
            "the DOF executor does not take the {} filter with this CoC model",
            kind.name()
        ))
    } else if !ex.fits(w, h) {
        Placement::cpu_because(format!(
            "a {w}×{h} frame is past the DOF executor's bindings"
        ))
    } else {
        Placement::on(ex.backend())
    }
}
