//! A corpus of small malformed scene files (`tests/corpus/{obj,ply,mitsuba}`): every file
//! must load to an error or to a scene with at least one warning, and never panic. Files
//! named `ok_*` must load (they exercise tolerated oddities).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use fovea_render::scene::Scene;

#[test]
fn corpus_files_fail_cleanly_or_warn() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus");
    let mut checked = 0;
    let mut failures = Vec::new();
    for sub in ["obj", "ply", "mitsuba"] {
        let mut entries: Vec<_> = std::fs::read_dir(root.join(sub))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for path in entries {
            let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
            if !matches!(ext, "obj" | "ply" | "xml") {
                continue; // MTL files are read through their OBJ
            }
            let size = std::fs::metadata(&path).unwrap().len();
            assert!(size < 4096, "{} is {size} bytes", path.display());
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            checked += 1;
            match catch_unwind(AssertUnwindSafe(|| Scene::load(&path))) {
                Err(_) => failures.push(format!("{name}: PANIC")),
                Ok(Ok(s)) if name.starts_with("ok_") => {
                    println!("{name}: ok ({} triangles)", s.triangle_count())
                }
                Ok(Err(e)) if name.starts_with("ok_") => {
                    failures.push(format!("{name}: expected to load, got {e}"))
                }
                Ok(Ok(s)) if s.warnings.is_empty() => {
                    failures.push(format!("{name}: loaded without any warning"))
                }
                Ok(Ok(s)) => println!("{name}: ok with warnings {:?}", s.warnings),
                Ok(Err(e)) => println!("{name}: error: {e}"),
            }
        }
    }
    assert!(checked >= 30, "only {checked} corpus files");
    assert!(failures.is_empty(), "{failures:#?}");
}
