//! `shadenet gpu-info`: the GPU adapters, best first, and the one the GPU back end uses.

use super::print_out;
use anyhow::{Context, Result};
use shadenet_gpu::GpuContext;

/// Runs `shadenet gpu-info`.
pub(crate) fn run() -> Result<()> {
    let list = shadenet_gpu::context::adapters();
    if list.is_empty() {
        say!("adapters: none");
    } else {
        say!("adapters (best first):");
        for a in &list {
            say!(
                "  {} ({}, {}; driver: {})",
                a.name,
                a.backend,
                a.device_type,
                if a.driver.is_empty() {
                    "unknown"
                } else {
                    &a.driver
                }
            );
        }
    }
    let ctx = GpuContext::shared().context("the GPU back end has no device")?;
    say!("chosen:");
    print_out(&ctx.describe());
    Ok(())
}
