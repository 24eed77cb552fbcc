//! Scene, camera, eye and light options shared by `render` and `bench`.

use std::path::Path;

use anyhow::{anyhow, bail, Result};
use clap::Args;
use glam::Vec3;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_render::bvh::Backend;
use fovea_render::camera::{Eye, EyeCamera, HmdRig};
use fovea_render::lights::view_lights;
use fovea_render::scene::{builtin, CameraDesc, Light, Scene};
use fovea_render::world::World;

use crate::choices::{Bvh, EyeChoice, Headset};
use crate::common::DisplayArgs;

/// Where the scene and the viewer come from.
#[derive(Args, Debug, Clone, serde::Serialize)]
pub struct SceneArgs {
    /// Scene file (.gltf, .glb, .obj, .xml Mitsuba, .ply) or a built-in scene name
    /// (depth-range).
    #[arg(long, default_value = "depth-range")]
    pub scene: String,
    /// Metres per scene unit (default: the file's own; glTF and the Mitsuba classroom are in
    /// metres; e.g. 0.002 for the chess board).
    #[arg(long)]
    pub scene_scale: Option<f32>,
    /// Camera position X,Y,Z in metres (after --scene-scale); default: the file's camera.
    #[arg(long)]
    pub camera_pos: Option<String>,
    /// Point the camera looks at, X,Y,Z in metres (with --camera-pos; default 1 m ahead along −Z).
    #[arg(long)]
    pub look_at: Option<String>,
    /// Which of the file's cameras to use (0 = first).
    #[arg(long, default_value_t = 0)]
    pub camera_index: usize,
    /// Which eye to render: left, right or centre (the camera position is the head).
    #[arg(long, value_enum, ignore_case = true, default_value_t = EyeChoice::Centre)]
    pub eye: EyeChoice,
    /// Interpupillary distance in metres for --eye left/right.
    #[arg(long, default_value_t = 0.063)]
    pub ipd: f32,
    /// Replace the scene's lights by N generated point lights with shadows (the papers use 1,
    /// 12, 21, 31).
    #[arg(long)]
    pub lights: Option<u32>,
    /// Ray-casting backend: obvhs (default build) or embree (`--features embree`).
    #[arg(long, value_enum, ignore_case = true)]
    pub bvh: Option<Bvh>,
    /// Render even when the camera seems to be inside a closed mesh.
    #[arg(long)]
    pub allow_inside: bool,
    /// The command's `--max-memory` (bytes), which bounds what loading may decode (an
    /// environment map is reduced to fit): set with [`SceneArgs::within_memory`].
    #[arg(skip)]
    #[serde(skip)]
    pub max_memory_bytes: Option<u64>,
}

impl SceneArgs {
    /// These arguments with the command's memory limit for loading.
    pub fn within_memory(&self, max_memory_bytes: u64) -> Self {
        Self {
            max_memory_bytes: Some(max_memory_bytes),
            ..self.clone()
        }
    }
}

/// Parses `X,Y,Z`.
pub fn parse_vec3(name: &str, text: &str) -> Result<Vec3> {
    let bad =
        || anyhow!("invalid parameter `{name}` = {text}: expected X,Y,Z (three finite numbers)");
    let v: Vec<f32> = text
        .split(',')
        .map(|s| s.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| bad())?;
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        return Err(bad());
    }
    Ok(Vec3::new(v[0], v[1], v[2]))
}

/// Loads the scene (file or built-in) in metres.
pub fn load_scene(args: &SceneArgs) -> Result<Scene> {
    let path = Path::new(&args.scene);
    let looks_like_file = path.extension().is_some() || args.scene.contains('/');
    let mut scene = if looks_like_file {
        let limits = fovea_render::scene::LoadLimits {
            max_memory_bytes: args.max_memory_bytes.unwrap_or(u64::MAX),
            ..Default::default()
        };
        Scene::load_with_limits(path, &limits)?
    } else {
        builtin::by_name(&args.scene)?
    };
    scene.scale_to_metres(args.scene_scale)?;
    for w in &scene.warnings {
        match w.strip_prefix("note: ") {
            Some(note) => eprintln!("note: {note}"),
            None => eprintln!("warning: {w}"),
        }
    }
    Ok(scene)
}

/// The camera pose: command line, else the file's camera, else one framing the scene.
fn camera_desc(args: &SceneArgs, scene: &Scene) -> Result<CameraDesc> {
    if let Some(p) = &args.camera_pos {
        let pos = parse_vec3("camera-pos", p)?;
        let target = match &args.look_at {
            Some(t) => parse_vec3("look-at", t)?,
            None => pos - Vec3::Z,
        };
        return Ok(CameraDesc::look_at("command line", pos, target, None)?);
    }
    if args.look_at.is_some() {
        bail!("invalid parameter `look-at`: needs --camera-pos too");
    }
    if !scene.cameras.is_empty() {
        return scene
            .cameras
            .get(args.camera_index)
            .cloned()
            .ok_or_else(|| {
                anyhow!(
                    "invalid parameter `camera-index` = {}: the scene has {} camera(s)",
                    args.camera_index,
                    scene.cameras.len()
                )
            });
    }
    if args.camera_index != 0 {
        bail!(
            "invalid parameter `camera-index` = {}: the scene has no cameras (its view is \
             framed automatically; use --camera-pos/--look-at to place one)",
            args.camera_index
        );
    }
    let b = scene
        .bounds()
        .ok_or_else(|| anyhow!("the scene is empty"))?;
    let c = b.centre();
    let ext = b.extent();
    Ok(CameraDesc::look_at(
        "framing",
        framing_position(c, ext),
        c,
        None,
    )?)
}

/// Where the automatic framing puts the camera (looking at the centre `c` of a scene with
/// bounding-box extent `ext`): in front and a little above, or, for a flat scene (its
/// smallest extent under 1 % of its largest: a ground plane, a single quad), along its thin
/// axis — from above a ground plane, in front of a wall — where an edge-on view would be
/// empty. [`CameraDesc::look_at`] picks an up vector that is not parallel to the view.
fn framing_position(c: Vec3, ext: Vec3) -> Vec3 {
    let max = ext.max_element();
    let (min, thin) = [(ext.x, Vec3::X), (ext.y, Vec3::Y), (ext.z, Vec3::Z)]
        .into_iter()
        .fold(
            (f32::INFINITY, Vec3::Z),
            |a, b| if b.0 < a.0 { b } else { a },
        );
    if max > 0.0 && min < 0.01 * max {
        c + thin * (1.2 * max)
    } else {
        c + Vec3::new(0.0, 0.25 * ext.y, 1.2 * max)
    }
}

/// Scene + world + eye camera, ready to render `display`.
pub struct Prepared {
    /// The BVH and lights.
    pub world: World,
    /// The eye's camera.
    pub camera: EyeCamera,
    /// The head with both eyes (`--ipd`).
    pub rig: HmdRig,
}

/// A loaded scene with its BVH and head rig: viewable on any display through
/// [`Loaded::view`], so `bench` loads and builds once for all its resolutions.
pub struct Loaded {
    /// The BVH and lights (the lights of the last [`Loaded::view`]).
    pub world: World,
    rig: HmdRig,
    eye: Eye,
    /// The scene's own lights.
    scene_lights: Vec<Light>,
    /// The vertical field of view of the file's camera when the view is that camera's.
    file_vfov_deg: Option<f32>,
}

/// Loads the scene, builds its BVH and places the head.
pub fn load(args: &SceneArgs) -> Result<Loaded> {
    let scene = load_scene(args)?;
    let backend = args.bvh.map_or_else(Backend::best_available, Backend::from);
    let desc = camera_desc(args, &scene)?;
    let world = World::new(scene, backend)?;
    if world.duplicate_triangles > 0 {
        if let Some(w) = world.scene.warnings.last() {
            eprintln!("warning: {w}");
        }
    }
    let eye = Eye::from(args.eye);
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, args.ipd)?;
    if args.lights.is_none() && world.lights.is_empty() {
        eprintln!(
            "warning: the scene has no lights; using 4 generated point lights (set the number with --lights N)"
        );
    }
    Ok(Loaded {
        scene_lights: world.lights.clone(),
        world,
        rig,
        eye,
        file_vfov_deg: desc.yfov_deg,
    })
}

impl Loaded {
    /// The display of `args` for this view: with `--res` and no `--vfov`, the field of view
    /// of the file's camera when the view is that camera's (a `note:` says so).
    pub fn display(&self, args: &DisplayArgs, default: Headset) -> Result<DisplayProfile> {
        let d = args.display_for_view(default, self.file_vfov_deg)?;
        if let (Some(_), None, Some(f)) = (&args.res, args.vfov, self.file_vfov_deg) {
            eprintln!("note: vertical field of view {f:.1}° from the scene file's camera (--vfov sets another)");
        }
        Ok(d)
    }

    /// The head rig (both eyes).
    pub fn rig(&self) -> &HmdRig {
        &self.rig
    }

    /// The eye's camera for `display`, with the world's lights set for it: the scene's own,
    /// or generated around the view (`--lights N`, or 4 when the scene has none).
    pub fn view(&mut self, args: &SceneArgs, display: &DisplayProfile) -> Result<EyeCamera> {
        let camera = self.rig.eye(self.eye, display)?;
        if !args.allow_inside {
            if let Some(mesh) = self.world.enclosing_mesh(camera.position) {
                bail!(
                    "the camera at {} is inside mesh `{mesh}` (almost every ray from it hits a back face); move it with --camera-pos, or pass --allow-inside",
                    camera.position
                );
            }
        }
        self.world.lights = match args.lights {
            Some(n) => view_lights(&self.world, &camera, n)?,
            None if self.scene_lights.is_empty() => view_lights(&self.world, &camera, 4)?,
            None => self.scene_lights.clone(),
        };
        Ok(camera)
    }
}

/// Builds the world and the camera for the display of `display` (`default` when it names
/// none; see [`Loaded::display`]); the display is `camera.display`.
pub fn prepare(args: &SceneArgs, display: &DisplayArgs, default: Headset) -> Result<Prepared> {
    let mut loaded = load(args)?;
    let display = loaded.display(display, default)?;
    let camera = loaded.view(args, &display)?;
    Ok(Prepared {
        rig: loaded.rig.clone(),
        world: loaded.world,
        camera,
    })
}

/// Where the eye looks: a screen point or a world point.
#[derive(Args, Debug, Clone, Default)]
pub struct GazeArgs {
    /// Gaze point X,Y in screen pixels (default: the screen centre; negative values allowed,
    /// e.g. --gaze -10,20, within the screen's margin).
    #[arg(long, conflicts_with = "gaze_at", allow_hyphen_values = true)]
    pub gaze: Option<String>,
    /// Gaze at a world point X,Y,Z (metres) instead of a screen point.
    #[arg(long)]
    pub gaze_at: Option<String>,
}

impl GazeArgs {
    /// The gaze on `display` seen from `camera`: `--gaze-at` projected, else `--gaze`, else
    /// the screen centre.
    pub fn resolve(&self, display: &DisplayProfile, camera: &EyeCamera) -> Result<Gaze> {
        if let Some(t) = &self.gaze_at {
            let p = parse_vec3("gaze-at", t)?;
            let s = camera.screen_point_of(p - camera.position).ok_or_else(|| {
                anyhow!("invalid parameter `gaze-at` = {t}: the point is behind the eye")
            })?;
            return Ok(display.gaze(s.x_px, s.y_px)?);
        }
        crate::common::parse_gaze(display, self.gaze.as_deref())
    }
}
