//! Fuzz target `mitsuba`: see `fovea_fuzz::mitsuba` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fovea_fuzz::mitsuba(data);
});
