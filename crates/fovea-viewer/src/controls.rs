//! The viewer's live settings: what the panel and the keys change, and the frame settings a
//! frame is rendered with ([`ViewSettings::frame_settings`]). Nothing here needs a window:
//! the keys are [`Action`]s, the panel is a function of an [`egui::Ui`], and both are tested
//! through an `egui::Context` without one.

use fovea_core::mapping::Method;
use fovea_core::optics::{pupil_liu_linear, EyeModel};
use fovea_core::units::{Lux, Millimetres};
use fovea_post::dof::FilterKind;
use fovea_render::dof::{DofSettings, FocusMode};
use fovea_render::pipeline::FrameSettings;

use crate::error::{Result, ViewerError};

/// A method of the viewer's menu: a foveation method, or Liu et al.'s whole hybrid method
/// (visual-polar sampling, DOF-aware culling, bokeh with LCA), as `fovea render --method`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewMethod {
    /// One of the foveation methods.
    Method(Method),
    /// Liu et al.'s hybrid method.
    LiuHybrid,
}

impl ViewMethod {
    /// The menu, in the order of the number keys 1–9.
    pub const ALL: [ViewMethod; 9] = [
        ViewMethod::Method(Method::Full),
        ViewMethod::Method(Method::Vafr),
        ViewMethod::Method(Method::Kfr),
        ViewMethod::Method(Method::Lafr),
        ViewMethod::Method(Method::VisualPolar),
        ViewMethod::Method(Method::Guenter),
        ViewMethod::Method(Method::Inset),
        ViewMethod::Method(Method::Weier),
        ViewMethod::LiuHybrid,
    ];

    /// The name `fovea render --method` takes.
    pub fn name(self) -> &'static str {
        match self {
            ViewMethod::Method(m) => m.name(),
            ViewMethod::LiuHybrid => "liu-hybrid",
        }
    }

    /// The method that samples the frame.
    pub fn method(self) -> Method {
        match self {
            ViewMethod::Method(m) => m,
            ViewMethod::LiuHybrid => Method::VisualPolar,
        }
    }

    /// Parses a `--method` name.
    pub fn parse(text: &str) -> Result<Self> {
        if text.eq_ignore_ascii_case("liu-hybrid") {
            return Ok(ViewMethod::LiuHybrid);
        }
        Method::parse(text)
            .map(ViewMethod::Method)
            .map_err(|e| ViewerError::Input(e.to_string()))
    }
}

/// The focus of depth of field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FocusChoice {
    /// At the gaze, through the accommodation filter.
    Auto,
    /// Fixed, metres.
    FixedM(f64),
}

/// Where the pupil diameter comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PupilChoice {
    /// A diameter, millimetres (0: pinhole).
    Mm(f64),
    /// The ambient light level, lux (Liu's linear fit).
    Lux(f64),
}

/// Which lights shade the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightsChoice {
    /// The first light only.
    One,
    /// Every light of the scene.
    All,
}

/// Both eyes side by side, or the one eye of `--eye`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EyesChoice {
    /// One eye.
    One,
    /// Left | right, each eye with its own gaze at the fixated point.
    Both,
}

/// Overlays drawn over the frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Overlays {
    /// The sample density (samples per pixel, false colour) blended over the frame.
    pub density: bool,
    /// Eccentricity rings around the gaze (5°, 10°, 20°, 30°, 45°, 60°).
    pub rings: bool,
    /// The circle-of-confusion map (|CoC| in pixels, false colour) in place of the frame
    /// (needs a DOF filter).
    pub coc: bool,
}

/// Everything the panel and the keys change.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewSettings {
    /// The method.
    pub method: ViewMethod,
    /// Index into the headset presets ([`fovea_core::display::PRESET_NAMES`]), or `None`
    /// for the display the viewer was opened with.
    pub headset: Option<usize>,
    /// One eye or both.
    pub eyes: EyesChoice,
    /// The depth-of-field filter (`None`: sharp).
    pub dof: Option<FilterKind>,
    /// The focus.
    pub focus: FocusChoice,
    /// The pupil.
    pub pupil: PupilChoice,
    /// Temporal accumulation (reprojection of the previous frames).
    pub temporal: bool,
    /// Gaze-contingent level of detail (Liu Eq. 14).
    pub lod: bool,
    /// One light or all.
    pub lights: LightsChoice,
    /// Overlays.
    pub overlays: Overlays,
    /// A/B: show full resolution instead of the method (same gaze, camera and settings).
    pub compare_full: bool,
    /// Render scale of the display (1: every pixel; the CPU path starts lower and refines
    /// when the view is still).
    pub scale: f32,
    /// Exposure, stops.
    pub exposure_stops: f32,
    /// Whether the side panel is shown.
    pub panel: bool,
}

impl ViewSettings {
    /// The settings the viewer opens with: `method`, DOF filter `dof` (focus auto, the
    /// default eye), everything else off.
    pub fn new(method: ViewMethod, dof: Option<FilterKind>, scale: f32) -> Self {
        Self {
            method,
            headset: None,
            eyes: EyesChoice::One,
            dof,
            focus: FocusChoice::Auto,
            pupil: PupilChoice::Mm(EyeModel::default().pupil.0),
            temporal: true,
            lod: false,
            lights: LightsChoice::All,
            overlays: Overlays::default(),
            compare_full: false,
            scale,
            exposure_stops: 0.0,
            panel: true,
        }
    }

    /// The method the frame is rendered with: full resolution while A/B shows it.
    pub fn effective_method(&self) -> ViewMethod {
        if self.compare_full {
            ViewMethod::Method(Method::Full)
        } else {
            self.method
        }
    }

    /// The DOF filter the frame gets: liu-hybrid brings bokeh with LCA when none is chosen.
    pub fn effective_dof(&self) -> Option<FilterKind> {
        match (self.dof, self.effective_method()) {
            (None, ViewMethod::LiuHybrid) => Some(FilterKind::BokehLca),
            (d, _) => d,
        }
    }

    /// The eye model of the pupil choice.
    pub fn eye_model(&self) -> Result<EyeModel> {
        let mm = match self.pupil {
            PupilChoice::Mm(p) => {
                if !(p.is_finite() && (0.0..=12.0).contains(&p)) {
                    return Err(ViewerError::Input(format!(
                        "invalid parameter `pupil` = {p}: expected 0 to 12 mm"
                    )));
                }
                Millimetres(p)
            }
            PupilChoice::Lux(lx) => {
                pupil_liu_linear(Lux(lx)).map_err(|e| ViewerError::Input(e.to_string()))?
            }
        };
        let mut eye = EyeModel::default();
        if mm.0 > 0.0 {
            eye = eye
                .with_pupil(mm)
                .map_err(|e| ViewerError::Input(e.to_string()))?;
        } else {
            eye.pupil = Millimetres(0.0);
        }
        Ok(eye)
    }

    /// The frame settings of these view settings over `base` (the command line's: mapping
    /// parameters, shading, AA, memory limit, and the DOF options the panel does not show,
    /// such as the CoC model). Validated.
    pub fn frame_settings(&self, base: &FrameSettings) -> Result<FrameSettings> {
        let mut s = base.clone();
        let method = self.effective_method();
        s.method = method.method();
        s.density_view = self.overlays.density;
        s.dof = match self.effective_dof() {
            None => None,
            Some(filter) => {
                let focus = match self.focus {
                    FocusChoice::Auto => FocusMode::Auto,
                    FocusChoice::FixedM(m) => {
                        if !(m.is_finite() && m > 0.0) {
                            return Err(ViewerError::Input(format!(
                                "invalid parameter `focus` = {m}: expected metres > 0"
                            )));
                        }
                        FocusMode::Fixed(m)
                    }
                };
                let mut d = base
                    .dof
                    .clone()
                    .unwrap_or_else(|| DofSettings::new(Some(filter), focus));
                d.filter = Some(filter);
                d.focus = focus;
                d.eye = self.eye_model()?;
                // Liu's whole method culls by the DOF weight (Eq. 10–11), as `fovea render`.
                d.cull = d.cull || method == ViewMethod::LiuHybrid;
                Some(d)
            }
        };
        s.validate()
            .map_err(|e| ViewerError::Input(format!("frame settings: {e}")))?;
        Ok(s)
    }

    /// Applies an action; returns whether the view settings changed.
    pub fn apply(&mut self, action: Action, presets: usize) -> bool {
        let before = self.clone();
        match action {
            Action::SetMethod(m) => self.method = m,
            Action::CycleDof => {
                // none → each filter in table order → none.
                let all = FilterKind::ALL;
                self.dof = match self.dof {
                    None => Some(all[0]),
                    Some(k) => all
                        .iter()
                        .position(|&f| f == k)
                        .and_then(|i| all.get(i + 1).copied()),
                };
            }
            Action::ToggleFocus => {
                self.focus = match self.focus {
                    FocusChoice::Auto => FocusChoice::FixedM(1.0),
                    FocusChoice::FixedM(_) => FocusChoice::Auto,
                }
            }
            Action::ToggleTemporal => self.temporal = !self.temporal,
            Action::ToggleLod => self.lod = !self.lod,
            Action::ToggleLights => {
                self.lights = match self.lights {
                    LightsChoice::One => LightsChoice::All,
                    LightsChoice::All => LightsChoice::One,
                }
            }
            Action::ToggleDensity => self.overlays.density = !self.overlays.density,
            Action::ToggleRings => self.overlays.rings = !self.overlays.rings,
            Action::ToggleCoc => self.overlays.coc = !self.overlays.coc,
            Action::ToggleCompare => self.compare_full = !self.compare_full,
            Action::ToggleEyes => {
                self.eyes = match self.eyes {
                    EyesChoice::One => EyesChoice::Both,
                    EyesChoice::Both => EyesChoice::One,
                }
            }
            Action::NextHeadset if presets > 0 => {
                self.headset = Some(self.headset.map_or(0, |i| (i + 1) % presets));
            }
            Action::NextHeadset => {}
            Action::ExposureUp => self.exposure_stops += 0.5,
            Action::ExposureDown => self.exposure_stops -= 0.5,
            Action::TogglePanel => self.panel = !self.panel,
            Action::Screenshot | Action::StepGaze | Action::Quit => {}
        }
        *self != before
    }
}

/// What a key does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Keys 1–9: the methods of [`ViewMethod::ALL`].
    SetMethod(ViewMethod),
    /// F: the next DOF filter (none, then each filter, then none).
    CycleDof,
    /// G: focus auto ↔ fixed.
    ToggleFocus,
    /// T: temporal accumulation.
    ToggleTemporal,
    /// L: level of detail.
    ToggleLod,
    /// K: one light ↔ all.
    ToggleLights,
    /// Y: sample-density overlay.
    ToggleDensity,
    /// R: eccentricity rings.
    ToggleRings,
    /// C: CoC map.
    ToggleCoc,
    /// B: A/B against full resolution.
    ToggleCompare,
    /// V: one eye ↔ both.
    ToggleEyes,
    /// H: the next headset preset.
    NextHeadset,
    /// + / −: exposure ±½ stop.
    ExposureUp,
    /// See [`Action::ExposureUp`].
    ExposureDown,
    /// Tab: show or hide the panel.
    TogglePanel,
    /// P or F12: screenshot (PNG + the frame's JSON).
    Screenshot,
    /// N: the next sample of a stepped gaze replay.
    StepGaze,
    /// Escape: quit.
    Quit,
}

/// The key bindings, as the README lists them (WASD, Q/E and the right mouse button move the
/// camera; they are not actions).
pub const KEYS: &[(&str, &str)] = &[
    ("1–9", "method: full, vafr, kfr, lafr, visual-polar, guenter, inset, weier, liu-hybrid"),
    ("F", "next DOF filter (none, bokeh, bokeh-lca, physical-lca, layered, adaptive-coc, bilateral, recursive, gather)"),
    ("G", "focus: auto at the gaze ↔ fixed"),
    ("T", "temporal accumulation on/off"),
    ("L", "level of detail on/off"),
    ("K", "one light ↔ all lights"),
    ("Y / R / C", "overlays: sample density / eccentricity rings / CoC map"),
    ("B", "A/B: full resolution ↔ the method"),
    ("V", "one eye ↔ both eyes side by side"),
    ("H", "next headset preset"),
    ("+ / −", "exposure ±½ stop"),
    ("N", "next gaze sample of a stepped replay"),
    ("P or F12", "screenshot: PNG + the frame's JSON"),
    ("Tab", "hide or show the panel"),
    ("W A S D, Q E", "move the camera; right mouse button held: look around"),
    ("Esc", "quit"),
];

/// The action of a key press, if it has one.
pub fn key_action(key: egui::Key) -> Option<Action> {
    use egui::Key;
    let method = |i: usize| Some(Action::SetMethod(ViewMethod::ALL[i]));
    match key {
        Key::Num1 => method(0),
        Key::Num2 => method(1),
        Key::Num3 => method(2),
        Key::Num4 => method(3),
        Key::Num5 => method(4),
        Key::Num6 => method(5),
        Key::Num7 => method(6),
        Key::Num8 => method(7),
        Key::Num9 => method(8),
        Key::F => Some(Action::CycleDof),
        Key::G => Some(Action::ToggleFocus),
        Key::T => Some(Action::ToggleTemporal),
        Key::L => Some(Action::ToggleLod),
        Key::K => Some(Action::ToggleLights),
        Key::Y => Some(Action::ToggleDensity),
        Key::R => Some(Action::ToggleRings),
        Key::C => Some(Action::ToggleCoc),
        Key::B => Some(Action::ToggleCompare),
        Key::V => Some(Action::ToggleEyes),
        Key::H => Some(Action::NextHeadset),
        Key::Plus | Key::Equals => Some(Action::ExposureUp),
        Key::Minus => Some(Action::ExposureDown),
        Key::Tab => Some(Action::TogglePanel),
        Key::P | Key::F12 => Some(Action::Screenshot),
        Key::N => Some(Action::StepGaze),
        Key::Escape => Some(Action::Quit),
        _ => None,
    }
}

/// The actions of the key presses in `input` (while no text field has the focus).
pub fn key_actions(ctx: &egui::Context) -> Vec<Action> {
    if ctx.egui_wants_keyboard_input() {
        return Vec::new();
    }
    ctx.input(|i| {
        i.events
            .iter()
            .filter_map(|e| match e {
                egui::Event::Key {
                    key,
                    pressed: true,
                    repeat: false,
                    ..
                } => key_action(*key),
                _ => None,
            })
            .collect()
    })
}

/// The side panel's controls over `s` (`presets`: the headset names; `opened`: the display the
/// viewer was opened with). Returns the actions of its buttons (screenshot).
pub fn panel(
    ui: &mut egui::Ui,
    s: &mut ViewSettings,
    presets: &[&str],
    opened: &str,
) -> Vec<Action> {
    let mut actions = Vec::new();
    ui.heading("fovea view");
    egui::ComboBox::from_label("method")
        .selected_text(s.method.name())
        .show_ui(ui, |ui| {
            for m in ViewMethod::ALL {
                ui.selectable_value(&mut s.method, m, m.name());
            }
        });
    ui.checkbox(&mut s.compare_full, "A/B: full resolution (B)");
    let headset = s
        .headset
        .and_then(|i| presets.get(i))
        .copied()
        .unwrap_or(opened);
    egui::ComboBox::from_label("display")
        .selected_text(headset)
        .show_ui(ui, |ui| {
            ui.selectable_value(&mut s.headset, None, opened);
            for (i, p) in presets.iter().enumerate() {
                ui.selectable_value(&mut s.headset, Some(i), *p);
            }
        });
    ui.horizontal(|ui| {
        ui.radio_value(&mut s.eyes, EyesChoice::One, "one eye");
        ui.radio_value(&mut s.eyes, EyesChoice::Both, "both eyes");
    });
    ui.add(egui::Slider::new(&mut s.scale, 0.125..=1.0).text("render scale"));
    ui.separator();
    egui::ComboBox::from_label("depth of field")
        .selected_text(s.dof.map_or("none", FilterKind::name))
        .show_ui(ui, |ui| {
            ui.selectable_value(&mut s.dof, None, "none");
            for k in FilterKind::ALL {
                ui.selectable_value(&mut s.dof, Some(k), k.name());
            }
        });
    let mut auto = s.focus == FocusChoice::Auto;
    ui.horizontal(|ui| {
        ui.checkbox(&mut auto, "auto focus at the gaze");
        if let FocusChoice::FixedM(m) = &mut s.focus {
            ui.add(
                egui::DragValue::new(m)
                    .range(0.1..=100.0)
                    .speed(0.02)
                    .suffix(" m"),
            );
        }
    });
    if auto != (s.focus == FocusChoice::Auto) {
        s.focus = if auto {
            FocusChoice::Auto
        } else {
            FocusChoice::FixedM(1.0)
        };
    }
    let mut from_light = matches!(s.pupil, PupilChoice::Lux(_));
    ui.checkbox(&mut from_light, "pupil from the light level");
    if from_light != matches!(s.pupil, PupilChoice::Lux(_)) {
        s.pupil = if from_light {
            PupilChoice::Lux(300.0)
        } else {
            PupilChoice::Mm(4.49)
        };
    }
    match &mut s.pupil {
        PupilChoice::Mm(p) => {
            ui.add(egui::Slider::new(p, 0.0..=8.0).text("pupil (mm)"));
        }
        PupilChoice::Lux(l) => {
            ui.add(
                egui::Slider::new(l, 0.1..=10_000.0)
                    .logarithmic(true)
                    .text("lux"),
            );
        }
    }
    ui.separator();
    ui.checkbox(&mut s.temporal, "temporal accumulation (T)");
    ui.checkbox(&mut s.lod, "level of detail (L)");
    ui.horizontal(|ui| {
        ui.radio_value(&mut s.lights, LightsChoice::One, "1 light");
        ui.radio_value(&mut s.lights, LightsChoice::All, "all lights (K)");
    });
    ui.add(egui::Slider::new(&mut s.exposure_stops, -20.0..=10.0).text("exposure (stops)"));
    ui.separator();
    ui.label("overlays");
    ui.checkbox(&mut s.overlays.density, "sample density (Y)");
    ui.checkbox(&mut s.overlays.rings, "eccentricity rings (R)");
    ui.checkbox(&mut s.overlays.coc, "CoC map (C)");
    if ui.button("screenshot (P)").clicked() {
        actions.push(Action::Screenshot);
    }
    actions
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> FrameSettings {
        FrameSettings::new(Method::Vafr)
    }

    #[test]
    fn every_number_key_selects_its_method() {
        let keys = [
            egui::Key::Num1,
            egui::Key::Num2,
            egui::Key::Num3,
            egui::Key::Num4,
            egui::Key::Num5,
            egui::Key::Num6,
            egui::Key::Num7,
            egui::Key::Num8,
            egui::Key::Num9,
        ];
        for (k, m) in keys.into_iter().zip(ViewMethod::ALL) {
            let mut s = ViewSettings::new(ViewMethod::Method(Method::Vafr), None, 1.0);
            s.apply(key_action(k).unwrap(), 0);
            assert_eq!(s.method, m);
            assert_eq!(s.frame_settings(&base()).unwrap().method, m.method());
        }
    }

    #[test]
    fn liu_hybrid_brings_bokeh_lca_and_culling() {
        let mut s = ViewSettings::new(ViewMethod::LiuHybrid, None, 1.0);
        let f = s.frame_settings(&base()).unwrap();
        assert_eq!(f.method, Method::VisualPolar);
        let d = f.dof.unwrap();
        assert_eq!(d.filter, Some(FilterKind::BokehLca));
        assert!(d.cull);
        // A/B shows full resolution without Liu's DOF.
        s.apply(Action::ToggleCompare, 0);
        let f = s.frame_settings(&base()).unwrap();
        assert_eq!(f.method, Method::Full);
        assert!(f.dof.is_none());
    }

    #[test]
    fn dof_cycles_through_every_filter_and_back_to_none() {
        let mut s = ViewSettings::new(ViewMethod::Method(Method::Vafr), None, 1.0);
        let mut seen = Vec::new();
        for _ in 0..=FilterKind::ALL.len() {
            assert!(s.apply(Action::CycleDof, 0));
            seen.push(
                s.frame_settings(&base())
                    .unwrap()
                    .dof
                    .and_then(|d| d.filter),
            );
        }
        let mut want: Vec<_> = FilterKind::ALL.iter().map(|&k| Some(k)).collect();
        want.push(None);
        assert_eq!(seen, want);
    }

    #[test]
    fn focus_pupil_and_overlays_reach_the_frame_settings() {
        let mut s = ViewSettings::new(
            ViewMethod::Method(Method::Vafr),
            Some(FilterKind::Gather),
            1.0,
        );
        let d = s.frame_settings(&base()).unwrap().dof.unwrap();
        assert_eq!(d.focus, FocusMode::Auto);
        s.apply(Action::ToggleFocus, 0);
        s.pupil = PupilChoice::Mm(6.0);
        let d = s.frame_settings(&base()).unwrap().dof.unwrap();
        assert_eq!(d.focus, FocusMode::Fixed(1.0));
        assert_eq!(d.eye.pupil.0, 6.0);
        // Liu's linear fit: brighter light, smaller pupil.
        s.pupil = PupilChoice::Lux(10.0);
        let dim = s.frame_settings(&base()).unwrap().dof.unwrap().eye.pupil.0;
        s.pupil = PupilChoice::Lux(1000.0);
        let bright = s.frame_settings(&base()).unwrap().dof.unwrap().eye.pupil.0;
        assert!(bright < dim, "{bright} < {dim}");
        assert!(!s.frame_settings(&base()).unwrap().density_view);
        s.apply(Action::ToggleDensity, 0);
        assert!(s.frame_settings(&base()).unwrap().density_view);
        s.pupil = PupilChoice::Mm(f64::NAN);
        assert!(s.frame_settings(&base()).is_err());
    }

    #[test]
    fn headsets_cycle_and_unbound_keys_do_nothing() {
        let mut s = ViewSettings::new(ViewMethod::Method(Method::Vafr), None, 1.0);
        assert!(s.apply(Action::NextHeadset, 3));
        assert_eq!(s.headset, Some(0));
        s.apply(Action::NextHeadset, 3);
        s.apply(Action::NextHeadset, 3);
        s.apply(Action::NextHeadset, 3);
        assert_eq!(s.headset, Some(0));
        assert!(!s.apply(Action::NextHeadset, 0));
        assert!(!s.apply(Action::Screenshot, 3));
        assert_eq!(key_action(egui::Key::Z), None);
    }

    /// Key presses fed to an `egui::Context` (no window) come out as actions that change the
    /// frame settings; the panel lays out over the same settings.
    #[test]
    fn keys_through_egui_change_the_frame_settings() {
        let ctx = egui::Context::default();
        let mut s = ViewSettings::new(ViewMethod::Method(Method::Vafr), None, 1.0);
        let press = |key| egui::Event::Key {
            key,
            physical_key: None,
            pressed: true,
            repeat: false,
            modifiers: egui::Modifiers::NONE,
        };
        let input = egui::RawInput {
            events: vec![
                press(egui::Key::Num3),
                press(egui::Key::F),
                press(egui::Key::R),
            ],
            ..Default::default()
        };
        let mut actions = Vec::new();
        let _ = ctx.run_ui(input, |ui| {
            actions = key_actions(ui.ctx());
            egui::Panel::left("controls").show(ui, |ui| {
                panel(ui, &mut s, &["vive-pro-eye"], "640x360");
            });
        });
        assert_eq!(
            actions,
            vec![
                Action::SetMethod(ViewMethod::Method(Method::Kfr)),
                Action::CycleDof,
                Action::ToggleRings
            ]
        );
        for a in actions {
            s.apply(a, 1);
        }
        let f = s.frame_settings(&base()).unwrap();
        assert_eq!(f.method, Method::Kfr);
        assert_eq!(f.dof.unwrap().filter, Some(FilterKind::ALL[0]));
        assert!(s.overlays.rings);
    }
}
