//! Fuzz target `glb`: see `fovea_fuzz::glb` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fovea_fuzz::glb(data);
});
