//! The harness of fovea's fuzz targets: one function per target, each feeding bytes to the
//! public entry point the `fovea` command uses for that input. The fuzz targets
//! (`fuzz/fuzz_targets/*.rs`) call these functions, and the corpus replay test
//! (`crates/fovea-render/tests/fuzz_corpus.rs`) includes this file, so both run the same
//! code: on stable, without libFuzzer.
//!
//! Every function returns an [`Outcome`] and panics only when the library breaks its
//! contract: a panic inside the loader, or an error message that is empty or longer than
//! one line (errors are printed as one `error:` line). The file-based loaders read from a
//! scratch folder of the thread (`$TMPDIR/fovea-fuzz-<pid>-<n>/`, removed when the thread
//! ends), rewritten on every call, so a run does not depend on the inputs before it.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use fovea_core::gaze::csv::{parse_csv, CsvOptions, GapPolicy};
use fovea_render::scene::environment::file::decode_within;
use fovea_render::scene::{gltf, Scene};

/// What a reader made of one input.
#[derive(Debug, PartialEq)]
pub enum Outcome {
    /// Loaded: triangles (scenes) or samples (gaze), and warnings (scenes).
    Loaded { items: usize, warnings: usize },
    /// Refused with this one-line error.
    Refused(String),
}

/// Separates the OBJ part of an `obj` input from the MTL file `m.mtl` beside it.
pub const MTL_MARKER: &[u8] = b"\n##mtl\n";
/// Separates the scene part of a `mitsuba` input from the file `inc.xml` beside it.
pub const INCLUDE_MARKER: &[u8] = b"\n<!--inc.xml-->\n";

/// A triangle, `mesh.obj` in the scratch folder (for Mitsuba `<shape type="obj">`).
const MESH_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n";
/// A triangle, `mesh.ply` in the scratch folder (for Mitsuba `<shape type="ply">`).
const MESH_PLY: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
                        property float y\nproperty float z\nelement face 1\n\
                        property list uchar int vertex_indices\nend_header\n\
                        0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";

/// A scratch folder with the fixed companion files, removed when its thread ends.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Self {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("fovea-fuzz-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch folder");
        std::fs::write(dir.join("mesh.obj"), MESH_OBJ).expect("mesh.obj");
        std::fs::write(dir.join("mesh.ply"), MESH_PLY).expect("mesh.ply");
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

thread_local! {
    // One per thread: the replay test's test functions run in parallel.
    static SCRATCH: Scratch = Scratch::new();
}

/// The scratch folder of this thread.
fn scratch() -> PathBuf {
    SCRATCH.with(|s| s.0.clone())
}

/// `data` before and after the first `marker` (empty after when there is none).
fn split<'a>(data: &'a [u8], marker: &[u8]) -> (&'a [u8], &'a [u8]) {
    match data.windows(marker.len()).position(|w| w == marker) {
        Some(i) => (&data[..i], &data[i + marker.len()..]),
        None => (data, &[]),
    }
}

/// Writes `files` (name, bytes) to the scratch folder; the path of the first.
fn write(files: &[(&str, &[u8])]) -> PathBuf {
    let dir = scratch();
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes).expect("scratch file");
    }
    dir.join(files[0].0)
}

/// Checks an error message: one non-empty line.
fn refused(e: impl std::fmt::Display) -> Outcome {
    let msg = e.to_string();
    assert!(
        !msg.trim().is_empty() && !msg.contains('\n') && !msg.contains('\r'),
        "an error message must be one non-empty line: {msg:?}"
    );
    Outcome::Refused(msg)
}

fn scene_outcome(r: fovea_render::error::Result<Scene>) -> Outcome {
    match r {
        Ok(s) => Outcome::Loaded {
            items: s.triangle_count(),
            warnings: s.warnings.len(),
        },
        Err(e) => refused(e),
    }
}

/// glTF JSON (`.gltf`) through `gltf::load_from_bytes` (default limits; relative URIs resolve
/// in the scratch folder) and `Scene::validate`, which `Scene::load` runs.
pub fn gltf(data: &[u8]) -> Outcome {
    gltf_named(data, "scene.gltf")
}

/// Binary glTF (`.glb`): the same entry point as [`gltf`] (the loader tells the container
/// by its magic), seeded with GLB files.
pub fn glb(data: &[u8]) -> Outcome {
    gltf_named(data, "scene.glb")
}

fn gltf_named(data: &[u8], name: &str) -> Outcome {
    let path = scratch().join(name);
    scene_outcome(gltf::load_from_bytes(&path, data).and_then(|mut s| {
        s.validate()?;
        Ok(s)
    }))
}

/// Wavefront OBJ through `Scene::load`: the part before [`MTL_MARKER`] is `scene.obj`, the
/// part after it `m.mtl` (empty when there is no marker).
pub fn obj(data: &[u8]) -> Outcome {
    let (obj, mtl) = split(data, MTL_MARKER);
    scene_outcome(Scene::load(&write(&[("scene.obj", obj), ("m.mtl", mtl)])))
}

/// PLY (ASCII or binary) through `Scene::load`.
pub fn ply(data: &[u8]) -> Outcome {
    scene_outcome(Scene::load(&write(&[("scene.ply", data)])))
}

/// Mitsuba XML through `Scene::load`: the part before [`INCLUDE_MARKER`] is `scene.xml`, the
/// part after it `inc.xml`; `mesh.obj` and `mesh.ply` (a triangle each) lie beside them.
pub fn mitsuba(data: &[u8]) -> Outcome {
    let (xml, inc) = split(data, INCLUDE_MARKER);
    scene_outcome(Scene::load(&write(&[("scene.xml", xml), ("inc.xml", inc)])))
}

/// An eye-tracker CSV through `parse_csv` on a 1440×1600 screen, with the default options
/// (what `fovea sequence --gaze-csv` uses) and again dropping gaps without rebasing time;
/// each trajectory is then resampled at 90 Hz (at most 10,000 frames). Bytes that are not
/// UTF-8 are replaced (the command refuses such a file before parsing).
pub fn gaze_csv(data: &[u8]) -> Outcome {
    let text = String::from_utf8_lossy(data);
    let drop = CsvOptions {
        gap_policy: GapPolicy::Drop,
        rebase_time: false,
        ..CsvOptions::default()
    };
    let mut first = None;
    for opts in [CsvOptions::default(), drop] {
        let outcome = match parse_csv(&text, 1440.0, 1600.0, &opts) {
            Ok((t, _report)) => {
                let n = t.frame_count(90.0).min(10_000);
                match t.resample(90.0, n) {
                    Ok(frames) => {
                        assert!(
                            frames
                                .iter()
                                .all(|g| g.x_px.is_finite() && g.y_px.is_finite()),
                            "a resampled gaze is not finite"
                        );
                        Outcome::Loaded {
                            items: t.len(),
                            warnings: 0,
                        }
                    }
                    Err(e) => refused(e),
                }
            }
            Err(e) => refused(e),
        };
        first.get_or_insert(outcome);
    }
    first.expect("two runs")
}

/// An environment map through `environment::file::decode_within` (what a Mitsuba `envmap`
/// runs), as `env.hdr` (the decoder is chosen by the content: Radiance RGBE by its `#?`
/// signature, else OpenEXR, PNG or JPEG by `image`'s detection), twice: within 64 MiB of
/// memory and within 1 MiB, where any map of more than about 16,000 pixels is reduced while
/// it decodes. The reduced map must hold finite, non-negative radiance.
pub fn envmap(data: &[u8]) -> Outcome {
    let path = std::path::Path::new("env.hdr");
    let mut first = None;
    for budget in [64u64 << 20, 1 << 20] {
        let outcome = match decode_within(path, data, budget) {
            Ok((map, note)) => {
                let m = map.mean();
                assert!(m.is_finite() && m.min_element() >= 0.0, "mean radiance {m}");
                if let Some(n) = &note {
                    assert!(!n.contains('\n'), "a note must be one line: {n:?}");
                }
                Outcome::Loaded {
                    items: (map.width() * map.height()) as usize,
                    warnings: note.is_some() as usize,
                }
            }
            Err(e) => refused(e),
        };
        first.get_or_insert(outcome);
    }
    first.expect("two runs")
}
