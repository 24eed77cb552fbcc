//! The options whose value is one name from a fixed set, as `clap::ValueEnum`s: clap checks
//! the name while parsing, and its one-line error lists the valid names (`main.rs`). Each enum
//! maps to the library's type; the accepted names and aliases are those the library's
//! `parse` functions accept (the tests below hold the two together).
//!
//! Options that take numbers, lists or a name-or-value (`--focus 1.5|inf|auto`,
//! `--methods vafr,kfr`, `--coc-model tracking-aware:0.3`, `--res 1920x1080|2k`) stay strings
//! parsed by the subcommand, whose error names the option and what it expects.
//!
//! Every enum is matched case-insensitively (`ignore_case` on each option), as the library's
//! parsers were. Variants carry no `///` docs on purpose: clap would turn them into a
//! per-value list in `--help`, and each option's help already says what its values mean.

use clap::ValueEnum;
use serde::Serialize;

use fovea_core::mapping::{Method, VisualPolarInverse};
use fovea_eval::experiments::flicker::Accumulation;
use fovea_eval::experiments::scenario::GazeScenario;
use fovea_post::dof::FilterKind;
use fovea_post::inset_smoothing::{GaussianKernel, Smoothing};
use fovea_post::tonemap::ToneCurve;
use fovea_render::bvh::Backend;
use fovea_render::camera::Eye;
use fovea_render::pipeline::AaMode;
use fovea_render::stereo::StereoMode;

/// The name a value is given on the command line (its first, canonical name).
pub fn name<T: ValueEnum>(value: &T) -> String {
    value
        .to_possible_value()
        .map_or_else(String::new, |p| p.get_name().to_string())
}

/// `--headset`: a display preset (`fovea_core::display::PRESET_NAMES`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Headset {
    #[value(name = "vive-pro-eye", alias = "vive")]
    VivePro,
    #[value(name = "pimax-crystal", alias = "pimax")]
    PimaxCrystal,
    #[value(name = "varjo-xr4", aliases = ["varjo-xr-4", "xr4"])]
    VarjoXr4,
    #[value(name = "2k")]
    K2,
    #[value(name = "4k")]
    K4,
    #[value(name = "6k")]
    K6,
    #[value(name = "8k")]
    K8,
    Retinal,
}

/// `--method` of `render` and `sequence`: a foveation method, or Liu et al.'s whole hybrid
/// method (visual-polar sampling with DOF-aware culling and bokeh with LCA).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodChoice {
    #[value(alias = "gt")]
    Full,
    Vafr,
    #[value(alias = "lmfr")]
    Kfr,
    Lafr,
    #[value(aliases = ["vp", "liu"])]
    VisualPolar,
    Guenter,
    Inset,
    Weier,
    LiuHybrid,
}

impl MethodChoice {
    /// The foveation method that samples the frame (visual-polar for liu-hybrid).
    pub fn method(self) -> Method {
        match self {
            MethodChoice::Full => Method::Full,
            MethodChoice::Vafr => Method::Vafr,
            MethodChoice::Kfr => Method::Kfr,
            MethodChoice::Lafr => Method::Lafr,
            MethodChoice::VisualPolar | MethodChoice::LiuHybrid => Method::VisualPolar,
            MethodChoice::Guenter => Method::Guenter,
            MethodChoice::Inset => Method::Inset,
            MethodChoice::Weier => Method::Weier,
        }
    }

    /// Whether this is Liu et al.'s whole method.
    pub fn is_liu_hybrid(self) -> bool {
        self == MethodChoice::LiuHybrid
    }
}

/// `--aa`: sample-space anti-aliasing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Aa {
    Auto,
    #[value(alias = "off")]
    None,
    Fxaa,
    #[value(alias = "gauss")]
    Gaussian,
}

impl From<Aa> for AaMode {
    fn from(a: Aa) -> Self {
        match a {
            Aa::Auto => AaMode::Auto,
            Aa::None => AaMode::None,
            Aa::Fxaa => AaMode::Fxaa,
            Aa::Gaussian => AaMode::Gaussian,
        }
    }
}

/// `--reconstruct-filter`: how polar buffers are read back at each pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ReconstructFilterChoice {
    Footprint,
    Bilinear,
}

impl From<ReconstructFilterChoice> for fovea_post::inverse_map::ReconstructFilter {
    fn from(f: ReconstructFilterChoice) -> Self {
        match f {
            ReconstructFilterChoice::Footprint => Self::Footprint,
            ReconstructFilterChoice::Bilinear => Self::Bilinear,
        }
    }
}

/// `--denoise`: the sample-space denoiser off, or on (spatial: SVGF's à-trous filter with a
/// spatial variance estimate).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DenoiseChoice {
    Off,
    #[value(alias = "spatial")]
    On,
}

/// `--denoise-kernel`: the denoiser's à-trous kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DenoiseKernelChoice {
    #[value(name = "3x3")]
    Linear3x3,
    #[value(name = "5x5")]
    B3Spline5x5,
}

impl From<DenoiseKernelChoice> for fovea_post::denoise::Kernel {
    fn from(k: DenoiseKernelChoice) -> Self {
        match k {
            DenoiseKernelChoice::Linear3x3 => Self::Linear3x3,
            DenoiseKernelChoice::B3Spline5x5 => Self::B3Spline5x5,
        }
    }
}

/// `--quality`: a preset of the shading (`fovea_render::quality`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum QualityChoice {
    Offline,
    Realtime,
}

impl From<QualityChoice> for fovea_render::quality::Quality {
    fn from(q: QualityChoice) -> Self {
        match q {
            QualityChoice::Offline => Self::Offline,
            QualityChoice::Realtime => Self::Realtime,
        }
    }
}

/// `--shading`: direct lighting plus indirect light (the default), direct lighting alone, or
/// path tracing (the numbers are separate options).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Shading {
    Indirect,
    Direct,
    Path,
}

/// `--shading` of the measurements (`report`, `dof-compare`, `inset-analysis`): what a viewer
/// gets (`fovea_eval::reference::MeasuredShading::Viewer`, the default) or the noise-free
/// shading of the tables before issue 38.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MeasuredShadingChoice {
    Viewer,
    NoiseFree,
}

impl From<MeasuredShadingChoice> for fovea_eval::reference::MeasuredShading {
    fn from(c: MeasuredShadingChoice) -> Self {
        match c {
            MeasuredShadingChoice::Viewer => Self::Viewer,
            MeasuredShadingChoice::NoiseFree => Self::NoiseFree,
        }
    }
}

/// `--env-light`: how direct shading lights surfaces with the environment (the ray count is
/// `--env-samples`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EnvLightChoice {
    Occluded,
    Unshadowed,
}

/// `--tonemap`: the tone curve of PNG output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Tonemap {
    Clamp,
    Reinhard,
}

impl From<Tonemap> for ToneCurve {
    fn from(t: Tonemap) -> Self {
        match t {
            Tonemap::Clamp => ToneCurve::Clamp,
            Tonemap::Reinhard => ToneCurve::Reinhard,
        }
    }
}

/// `--eyes`: one eye or both.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Eyes {
    #[value(alias = "1")]
    One,
    #[value(alias = "2")]
    Both,
}

/// An on/off option (`--lod`, `--lca`, `--jitter`, `--history-clamp`, `sequence --temporal`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Switch {
    #[value(aliases = ["true", "yes", "1"])]
    On,
    #[value(aliases = ["false", "no", "0"])]
    Off,
}

impl Switch {
    /// `true` for on.
    pub fn is_on(self) -> bool {
        self == Switch::On
    }
}

/// `--backend`: which executor runs the stages the GPU can run (`fovea_gpu::BackendChoice`;
/// see `backend.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BackendArg {
    Cpu,
    Gpu,
    Auto,
}

/// `--lockstep`: whether both eyes of a Dup pair render at the same time on a GPU, their
/// passes in shared submissions (`fovea_render::pipeline::lockstep`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LockstepArg {
    /// On a hardware GPU; off on a CPU-emulated device (lavapipe), whose "device" is the
    /// cores that run the eyes' CPU work, where it measured slower (docs/gpu-measurements.md).
    Auto,
    On,
    Off,
}

/// `--stereo`: how the second eye is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Stereo {
    Dup,
    Rep,
}

impl From<Stereo> for StereoMode {
    fn from(s: Stereo) -> Self {
        match s {
            Stereo::Dup => StereoMode::Dup,
            Stereo::Rep => StereoMode::Rep,
        }
    }
}

/// `--dof` of `render` and `sequence`: a depth-of-field filter, or none.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DofFilter {
    #[value(alias = "off")]
    None,
    Bokeh,
    BokehLca,
    PhysicalLca,
    Layered,
    AdaptiveCoc,
    Bilateral,
    Recursive,
    Gather,
}

impl DofFilter {
    /// The filter (`None` for none).
    pub fn kind(self) -> Option<FilterKind> {
        match self {
            DofFilter::None => None,
            DofFilter::Bokeh => Some(FilterKind::Bokeh),
            DofFilter::BokehLca => Some(FilterKind::BokehLca),
            DofFilter::PhysicalLca => Some(FilterKind::PhysicalLca),
            DofFilter::Layered => Some(FilterKind::Layered),
            DofFilter::AdaptiveCoc => Some(FilterKind::AdaptiveCoc),
            DofFilter::Bilateral => Some(FilterKind::Bilateral),
            DofFilter::Recursive => Some(FilterKind::Recursive),
            DofFilter::Gather => Some(FilterKind::Gather),
        }
    }
}

/// `--eye`: which eye of the head renders. Serialised by its name (`sequence.json`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EyeChoice {
    Left,
    Right,
    #[value(aliases = ["center", "mono"])]
    Centre,
}

impl From<EyeChoice> for Eye {
    fn from(e: EyeChoice) -> Self {
        match e {
            EyeChoice::Left => Eye::Left,
            EyeChoice::Right => Eye::Right,
            EyeChoice::Centre => Eye::Centre,
        }
    }
}

/// `--bvh`: the ray-casting backend. Serialised by its name (`sequence.json`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Bvh {
    Obvhs,
    Embree,
    #[value(alias = "brute")]
    BruteForce,
}

impl From<Bvh> for Backend {
    fn from(b: Bvh) -> Self {
        match b {
            Bvh::Obvhs => Backend::Obvhs,
            Bvh::Embree => Backend::Embree,
            Bvh::BruteForce => Backend::BruteForce,
        }
    }
}

/// `--vp-inverse`: the visual-polar inverse CDF.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum VpInverse {
    Exact,
    #[value(alias = "fit")]
    PaperFit,
}

impl From<VpInverse> for VisualPolarInverse {
    fn from(v: VpInverse) -> Self {
        match v {
            VpInverse::Exact => VisualPolarInverse::Exact,
            VpInverse::PaperFit => VisualPolarInverse::PaperFit,
        }
    }
}

/// `--vafr-rings`: how VaFR sizes its rings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum VafrRingsChoice {
    /// At the true eccentricity of every screen point a ring crosses (default).
    Exact,
    /// The paper's Eq. 3 (the gaze as the optical axis).
    Eq3,
    /// Eq. 3's rings in one buffer for every gaze, off-screen texels unshaded (the resident
    /// GPU frame builds its tables once for it).
    #[value(name = "eq3-any-gaze")]
    Eq3AnyGaze,
}

impl From<VafrRingsChoice> for fovea_core::mapping::VafrRings {
    fn from(v: VafrRingsChoice) -> Self {
        match v {
            VafrRingsChoice::Eq3 => Self::Eq3,
            VafrRingsChoice::Exact => Self::Exact,
            VafrRingsChoice::Eq3AnyGaze => Self::Eq3AnyGaze,
        }
    }
}

/// `--inset`: where the inset sits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum InsetPlacement {
    Dynamic,
    Fixed,
}

/// `--scenario`: a synthesised gaze trajectory.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Scenario {
    Demo,
    SaccadePursuit,
    RandomWalk,
    Fixation,
}

impl From<Scenario> for GazeScenario {
    fn from(s: Scenario) -> Self {
        match s {
            Scenario::Demo => GazeScenario::Demo,
            Scenario::SaccadePursuit => GazeScenario::SaccadePursuit,
            Scenario::RandomWalk => GazeScenario::RandomWalk,
            Scenario::Fixation => GazeScenario::Fixation,
        }
    }
}

/// `--video` of `sequence`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Video {
    Auto,
    On,
    Off,
}

/// `--temporal` of `flicker`: which accumulation modes each method runs in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AccumulationChoice {
    Off,
    On,
    Both,
}

impl From<AccumulationChoice> for Accumulation {
    fn from(a: AccumulationChoice) -> Self {
        match a {
            AccumulationChoice::Off => Accumulation::Off,
            AccumulationChoice::On => Accumulation::On,
            AccumulationChoice::Both => Accumulation::Both,
        }
    }
}

/// `--inset-smoothing`: the inset's boundary smoothing (`Smoothing::ALL`, the paper's
/// parameters).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum InsetSmoothing {
    None,
    AlphaBlend,
    #[value(name = "gaussian-1d")]
    Gaussian1d,
    #[value(name = "gaussian-2d")]
    Gaussian2d,
    #[value(name = "gaussian-1d-alpha")]
    Gaussian1dAlpha,
    #[value(name = "gaussian-2d-alpha")]
    Gaussian2dAlpha,
    Laplacian,
}

impl From<InsetSmoothing> for Smoothing {
    fn from(s: InsetSmoothing) -> Self {
        match s {
            InsetSmoothing::None => Smoothing::None,
            InsetSmoothing::AlphaBlend => Smoothing::ALPHA_BLEND,
            InsetSmoothing::Gaussian1d => Smoothing::Gaussian1d,
            InsetSmoothing::Gaussian2d => Smoothing::Gaussian2d,
            InsetSmoothing::Gaussian1dAlpha => Smoothing::GaussianAlpha {
                kernel: GaussianKernel::OneD,
            },
            InsetSmoothing::Gaussian2dAlpha => Smoothing::GaussianAlpha {
                kernel: GaussianKernel::TwoD,
            },
            InsetSmoothing::Laplacian => Smoothing::LAPLACIAN,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_core::display::{DisplayProfile, PRESET_NAMES};
    use fovea_render::pipeline::FrameSettings;

    /// Every name and alias of every variant.
    fn spellings<T: ValueEnum>() -> Vec<(T, String)> {
        T::value_variants()
            .iter()
            .flat_map(|v| {
                let p = v.to_possible_value().expect("no skipped variant");
                p.get_name_and_aliases()
                    .map(|s| (v.clone(), s.to_string()))
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    fn names<T: ValueEnum>() -> Vec<String> {
        T::value_variants().iter().map(name).collect()
    }

    #[test]
    fn headsets_are_the_library_presets_with_its_aliases() {
        assert_eq!(names::<Headset>(), PRESET_NAMES);
        for (v, s) in spellings::<Headset>() {
            let canonical = DisplayProfile::preset(&name(&v)).unwrap();
            let spelled = DisplayProfile::preset(&s).unwrap();
            assert_eq!(spelled.name, canonical.name, "{s}");
            assert_eq!(spelled.width_px, canonical.width_px, "{s}");
        }
    }

    #[test]
    fn methods_are_the_library_methods_and_liu_hybrid() {
        let mut expected: Vec<String> = Method::ALL.map(|m| m.name().to_string()).to_vec();
        expected.push("liu-hybrid".into());
        assert_eq!(names::<MethodChoice>(), expected);
        for (v, s) in spellings::<MethodChoice>() {
            if !v.is_liu_hybrid() {
                assert_eq!(Method::parse(&s).unwrap(), v.method(), "{s}");
            }
        }
    }

    #[test]
    fn each_choice_means_what_the_library_parser_says() {
        for (v, s) in spellings::<Aa>() {
            assert_eq!(AaMode::parse(&s).unwrap(), AaMode::from(v), "{s}");
        }
        for (v, s) in spellings::<Stereo>() {
            assert_eq!(StereoMode::parse(&s).unwrap(), StereoMode::from(v), "{s}");
        }
        for (v, s) in spellings::<Bvh>() {
            assert_eq!(Backend::parse(&s).unwrap(), Backend::from(v), "{s}");
        }
        for (v, s) in spellings::<Scenario>() {
            assert_eq!(
                GazeScenario::parse(&s).unwrap(),
                GazeScenario::from(v),
                "{s}"
            );
        }
        assert_eq!(
            names::<Scenario>(),
            GazeScenario::ALL.map(|s| s.name().to_string())
        );
        for (v, s) in spellings::<AccumulationChoice>() {
            assert_eq!(
                Accumulation::parse(&s).unwrap(),
                Accumulation::from(v),
                "{s}"
            );
        }
        for (v, s) in spellings::<DofFilter>() {
            match v.kind() {
                Some(k) => assert_eq!(FilterKind::parse(&s).unwrap(), k, "{s}"),
                None => assert!(s == "none" || s == "off"),
            }
        }
        let filters: Vec<String> = FilterKind::ALL.map(|k| k.name().to_string()).to_vec();
        let mut listed = names::<DofFilter>();
        listed.remove(0);
        listed.sort();
        let mut sorted = filters.clone();
        sorted.sort();
        assert_eq!(listed, sorted, "every filter, and only those");
    }

    #[test]
    fn smoothings_are_the_library_list_in_its_order() {
        let lib: Vec<&str> = Smoothing::ALL.iter().map(|(n, _)| *n).collect();
        assert_eq!(names::<InsetSmoothing>(), lib);
        for (v, s) in spellings::<InsetSmoothing>() {
            assert_eq!(Smoothing::parse(&s).unwrap(), Smoothing::from(v), "{s}");
            assert_eq!(Smoothing::from(v).name(), s);
        }
        // The CLI's default is the library's.
        assert_eq!(
            Smoothing::from(crate::choices::InsetSmoothing::AlphaBlend),
            FrameSettings::new(Method::Inset).inset_smoothing
        );
    }

    #[test]
    fn names_are_matched_ignoring_case() {
        assert_eq!(
            MethodChoice::from_str("VaFR", true).unwrap(),
            MethodChoice::Vafr
        );
        assert_eq!(Switch::from_str("Yes", true).unwrap(), Switch::On);
        assert!(Switch::from_str("maybe", true).is_err());
    }
}
