//! Replays the fuzzing corpus (`fuzz/corpus/<target>/`, minimised with `fuzz/minimise.py`)
//! and the seeds (`fuzz/seeds/<target>/`: `seed-*` from `fuzz/seeds.py`, and `regression-*`,
//! the inputs of crashes the fuzzer found) through the fuzz targets' own harness
//! (`fuzz/src/lib.rs`, included below), on stable and without libFuzzer: every file must load
//! or be refused with a one-line typed error, never panic. See docs/fuzzing.md.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

#[allow(dead_code)]
#[path = "../../../fuzz/src/lib.rs"]
mod harness;

use harness::Outcome;

/// A fuzz target's harness function.
type Target = fn(&[u8]) -> Outcome;

const TARGETS: [(&str, Target); 7] = [
    ("gltf", harness::gltf),
    ("glb", harness::glb),
    ("obj", harness::obj),
    ("ply", harness::ply),
    ("mitsuba", harness::mitsuba),
    ("gaze_csv", harness::gaze_csv),
    ("envmap", harness::envmap),
];

#[test]
fn fuzz_corpus_loads_or_fails_cleanly() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz");
    let mut failures = Vec::new();
    for (target, run) in TARGETS {
        let mut files = Vec::new();
        for dir in ["corpus", "seeds"] {
            let dir = root.join(dir).join(target);
            let entries =
                std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
            files.extend(entries.map(|e| e.unwrap().path()));
        }
        files.sort();
        assert!(files.len() >= 5, "{target}: only {} files", files.len());
        let (mut loaded, mut refused) = (0, 0);
        for path in &files {
            let data = std::fs::read(path).unwrap();
            let name = path.file_name().unwrap().to_string_lossy();
            match catch_unwind(AssertUnwindSafe(|| run(&data))) {
                Ok(Outcome::Loaded { .. }) => loaded += 1,
                Ok(Outcome::Refused(_)) => refused += 1,
                Err(_) => failures.push(format!("{target}/{name}: panic")),
            }
        }
        println!(
            "{target}: {} files, {loaded} loaded, {refused} refused",
            files.len()
        );
        // The corpus exercises both paths of every reader.
        assert!(
            loaded > 0 && refused > 0,
            "{target}: {loaded} loaded, {refused} refused"
        );
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn the_seeds_give_their_expected_outcomes() {
    let seed = |target: &str, name: &str| {
        let p = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../fuzz/seeds")
            .join(target)
            .join(format!("seed-{name}"));
        std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
    };
    let loads = |o: Outcome, what: &str| match o {
        Outcome::Loaded { items, .. } => assert!(items > 0, "{what}"),
        Outcome::Refused(e) => panic!("{what}: {e}"),
    };
    loads(harness::gltf(&seed("gltf", "rich.gltf")), "rich.gltf");
    loads(harness::glb(&seed("glb", "rich.glb")), "rich.glb");
    loads(harness::obj(&seed("obj", "quad-mtl.obj")), "quad-mtl.obj");
    for p in ["quad-ascii.ply", "quad-le.ply", "quad-be.ply"] {
        loads(harness::ply(&seed("ply", p)), p);
    }
    loads(
        harness::mitsuba(&seed("mitsuba", "scene-include.xml")),
        "scene-include.xml",
    );
    loads(
        harness::gaze_csv(&seed("gaze_csv", "pixels.csv")),
        "pixels.csv",
    );
    for p in ["rle.hdr", "flat.hdr", "old-rle.hdr", "sky.png"] {
        loads(harness::envmap(&seed("envmap", p)), p);
    }
    // Refused without reading the device.
    match harness::gltf(&seed("gltf", "dev-zero-buffer.gltf")) {
        Outcome::Refused(e) => assert!(e.contains("/dev/zero"), "{e}"),
        o => panic!("{o:?}"),
    }
}
