//! Depth-of-field options shared by `fovea render`, `fovea bench --dof` and `fovea
//! dof-compare`: focus, pupil, CoC model, LCA and culling.

use anyhow::{bail, Result};
use clap::Args;

use fovea_core::optics::{pupil_de_groot_gebhard, pupil_liu_linear, EyeModel};
use fovea_core::units::{CandelasPerSquareMetre, Lux, Millimetres};
use fovea_post::dof::coc::CocModel;
use fovea_post::dof::FilterKind;
use fovea_render::dof::{DofSettings, FocusMode};

use crate::choices::{DofFilter, Switch};

/// The eye and focus.
#[derive(Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct EyeArgs {
    /// Focus distance: metres, `inf`, or `auto` (estimated from the depth around the gaze).
    #[arg(long, default_value = "auto")]
    pub focus: String,
    /// Pupil diameter in mm, 0 to 12 (0 = pinhole, everything sharp). Default: from --lux or
    /// --luminance, else 4.49 mm (Liu's HMD value).
    #[arg(long, conflicts_with_all = ["lux", "luminance"])]
    pub pupil: Option<f64>,
    /// Ambient illuminance in lux: pupil from Liu's linear fit.
    #[arg(long, conflicts_with = "luminance")]
    pub lux: Option<f64>,
    /// Display luminance in cd/m²: pupil from de Groot & Gebhard (1952).
    #[arg(long)]
    pub luminance: Option<f64>,
    /// CoC model: thin-lens (Liu Eq. 12's physical form), stabilised (Liu Eq. 13) or
    /// tracking-aware[:t] (Weier Eq. 3, t metres of gaze-depth uncertainty, default 0.2).
    #[arg(long, default_value = "thin-lens")]
    pub coc_model: String,
    /// Largest CoC diameter in pixels.
    #[arg(long, default_value_t = 64.0)]
    pub max_coc: f64,
}

impl EyeArgs {
    /// The focus mode.
    pub fn focus(&self) -> Result<FocusMode> {
        parse_focus(&self.focus)
    }

    /// The eye: the standard thin-lens eye with the pupil from the options.
    pub fn eye(&self) -> Result<EyeModel> {
        let pupil = match (self.pupil, self.lux, self.luminance) {
            (Some(p), _, _) => {
                if !(p.is_finite() && (0.0..=12.0).contains(&p)) {
                    bail!("invalid parameter `pupil` = {p}: expected 0 to 12 mm");
                }
                Millimetres(p)
            }
            (_, Some(lx), _) => pupil_liu_linear(Lux(lx))?,
            (_, _, Some(l)) => pupil_de_groot_gebhard(CandelasPerSquareMetre(l))?,
            _ => EyeModel::default().pupil,
        };
        // A zero pupil is a pinhole: `EyeModel::new` refuses it, so set the field.
        let mut eye = EyeModel::default();
        if pupil.0 > 0.0 {
            eye = eye.with_pupil(pupil)?;
        } else {
            eye.pupil = Millimetres(0.0);
        }
        Ok(eye)
    }

    /// The CoC model.
    pub fn coc_model(&self) -> Result<CocModel> {
        Ok(CocModel::parse(&self.coc_model)?)
    }

    /// DOF settings with `filter`, these eye options and no culling.
    pub fn settings(&self, filter: Option<FilterKind>) -> Result<DofSettings> {
        if !(self.max_coc.is_finite() && (0.0..=256.0).contains(&self.max_coc)) {
            bail!(
                "invalid parameter `max-coc` = {}: expected 0 to 256 pixels",
                self.max_coc
            );
        }
        let mut s = DofSettings::new(filter, self.focus()?);
        s.eye = self.eye()?;
        s.coc_model = self.coc_model()?;
        s.max_coc_px = self.max_coc;
        Ok(s)
    }
}

/// Parses `auto`, `inf`/`infinity` or a distance in metres (> 0).
pub fn parse_focus(text: &str) -> Result<FocusMode> {
    let t = text.trim().to_ascii_lowercase();
    match t.as_str() {
        "auto" => Ok(FocusMode::Auto),
        "inf" | "infinity" => Ok(FocusMode::Fixed(f64::INFINITY)),
        _ => match t.parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(FocusMode::Fixed(v)),
            _ => bail!(
                "invalid parameter `focus` = {text}: expected a distance in metres > 0, inf or auto"
            ),
        },
    }
}

/// The options of `fovea render` for depth of field.
#[derive(Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct DofArgs {
    /// Depth-of-field filter: none, bokeh, bokeh-lca, physical-lca, layered, adaptive-coc,
    /// bilateral, recursive, gather. `liu-hybrid` as the method defaults to bokeh-lca.
    #[arg(long, value_enum, ignore_case = true)]
    pub dof: Option<DofFilter>,
    #[command(flatten)]
    pub eye: EyeArgs,
    /// Longitudinal chromatic aberration with the bokeh filter: on (Liu's chromatic rows,
    /// = bokeh-lca) or off (= bokeh). physical-lca is the physically based alternative.
    #[arg(long, value_enum, ignore_case = true)]
    pub lca: Option<Switch>,
    /// DOF-aware culling: shade samples by Liu's Russian roulette on the DOF weight
    /// (Eq. 10–11); culled samples skip their shadow rays and are rebuilt from their
    /// neighbours' light visibility before the blur (docs/dof.md).
    #[arg(long)]
    pub cull: bool,
    /// Seed of the culling roulette.
    #[arg(long, default_value_t = 1)]
    pub cull_seed: u64,
    /// CoC diameter in pixels under which the blur cannot hide a culled sample: each surface
    /// keeps at least (this / |CoC|)² of its samples. 0 leaves Liu's weight alone.
    #[arg(long, default_value_t = 0.0)]
    pub cull_hidden_coc: f64,
}

impl DofArgs {
    /// The DOF settings, or `None` when no DOF was asked for. `liu_hybrid` turns on Liu's
    /// whole method: bokeh with LCA (unless `--dof`/`--lca` say otherwise) and culling.
    pub fn settings(&self, liu_hybrid: bool) -> Result<Option<DofSettings>> {
        let lca = self.lca.map(Switch::is_on);
        let filter = match self.dof {
            Some(d) => d.kind(),
            None if liu_hybrid => Some(FilterKind::BokehLca),
            None if self.cull || lca.is_some() => {
                bail!("--cull and --lca need --dof <filter> (or --method liu-hybrid)")
            }
            None => return Ok(None),
        };
        let filter = match (filter, lca) {
            (Some(FilterKind::Bokeh | FilterKind::BokehLca), Some(true)) => {
                Some(FilterKind::BokehLca)
            }
            (Some(FilterKind::Bokeh | FilterKind::BokehLca), Some(false)) => {
                Some(FilterKind::Bokeh)
            }
            (Some(k), Some(true)) if k != FilterKind::PhysicalLca => bail!(
                "invalid parameter `lca` = on with --dof {}: LCA comes with bokeh (Liu's chromatic rows) or physical-lca",
                k.name()
            ),
            (f, _) => f,
        };
        let mut s = self.eye.settings(filter)?;
        s.cull = self.cull || liu_hybrid;
        s.seed = self.cull_seed;
        if !(self.cull_hidden_coc.is_finite() && (0.0..=256.0).contains(&self.cull_hidden_coc)) {
            bail!(
                "invalid parameter `cull-hidden-coc` = {}: expected 0 to 256 pixels",
                self.cull_hidden_coc
            );
        }
        s.cull_hidden_coc_px = self.cull_hidden_coc;
        Ok(Some(s))
    }
}
