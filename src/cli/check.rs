//! `shadenet check`: link a network and report every error, or `ok` with a summary.

use super::{SourceArgs, load_source, print_out};
use anyhow::Result;
use std::path::Path;

/// Runs `shadenet check`.
pub(crate) fn run(path: &Path, mtlx: &SourceArgs) -> Result<()> {
    let c = load_source(path, mtlx, true)?;
    say!(
        "ok: {} ops, outputs: {}, components: [{}], lights: {}",
        c.program.op_count(),
        c.program.output_names().join(", "),
        c.program.components.join(", "),
        c.lights.len()
    );
    Ok(())
}
