//! Fuzz target `obj`: see `fovea_fuzz::obj` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fovea_fuzz::obj(data);
});
