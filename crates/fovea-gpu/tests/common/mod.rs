//! Shared by the GPU tests: open the device or skip loudly.

use std::io::Write;

use fovea_gpu::{GpuContext, GpuRequest};

/// The environment variable that turns a skip (no GPU adapter) into a failure. CI sets it.
pub const REQUIRE_GPU: &str = "FOVEA_REQUIRE_GPU";

/// Writes to the process's stderr directly: the test harness captures `eprintln!` of passing
/// tests, and a skip must be seen.
pub fn shout(text: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{text}");
}

/// A device on any adapter (lavapipe included), or `None` after a message nobody can miss.
/// Panics instead when `FOVEA_REQUIRE_GPU=1`.
pub fn gpu_or_skip(test: &str) -> Option<GpuContext> {
    match GpuContext::new(&GpuRequest::default()) {
        Ok(ctx) => {
            shout(&format!(
                "[fovea-gpu] {test}: on {} — {}",
                ctx.adapter(),
                ctx.adapter().driver
            ));
            Some(ctx)
        }
        Err(e) => {
            if std::env::var(REQUIRE_GPU).is_ok_and(|v| v == "1") {
                panic!("{REQUIRE_GPU}=1 and no GPU device: {e}");
            }
            shout(&format!(
                "\n[fovea-gpu] SKIPPED {test}: {e}\n[fovea-gpu] (nothing was checked; set \
                 {REQUIRE_GPU}=1 to make this a failure)\n"
            ));
            None
        }
    }
}
