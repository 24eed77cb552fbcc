//! Fuzz target `gaze_csv`: see `fovea_fuzz::gaze_csv` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fovea_fuzz::gaze_csv(data);
});
