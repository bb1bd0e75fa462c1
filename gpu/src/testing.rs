//! Test helpers for the GPU back end: the device, or a skip that says why.
//!
//! Every test that needs a device starts with [`device_or_skip`]. Without an adapter the test
//! prints `SKIPPED: <test>: <why>` to stderr and returns (it passes: a machine without any
//! Vulkan or GL driver cannot run it); with `SHADENET_REQUIRE_GPU=1` in the environment (CI,
//! which installs Mesa's lavapipe) a missing device fails the test instead.

use crate::GpuContext;
use std::sync::Arc;

/// The environment variable that turns a skip into a failure when set to `1`.
pub const REQUIRE_GPU: &str = "SHADENET_REQUIRE_GPU";

/// The shared device ([`GpuContext::shared`]); `None` after printing
/// `SKIPPED: <test>: <error>` to stderr when there is none. Panics instead (naming the test
/// and the error) when `SHADENET_REQUIRE_GPU=1`.
pub fn device_or_skip(test: &str) -> Option<Arc<GpuContext>> {
    match GpuContext::shared() {
        Ok(ctx) => Some(ctx),
        Err(e) => {
            if std::env::var(REQUIRE_GPU).is_ok_and(|v| v == "1") {
                panic!("{test}: {REQUIRE_GPU}=1 but the GPU back end cannot run: {e}");
            }
            eprintln!("SKIPPED: {test}: {e}");
            None
        }
    }
}
