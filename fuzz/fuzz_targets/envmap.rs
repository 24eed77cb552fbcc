//! Fuzz target `envmap`: see `fovea_fuzz::envmap` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fovea_fuzz::envmap(data);
});
