//! Fuzz target `gltf`: see `fovea_fuzz::gltf` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fovea_fuzz::gltf(data);
});
