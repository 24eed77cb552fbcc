//! Fuzz target `ply`: see `fovea_fuzz::ply` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fovea_fuzz::ply(data);
});
