//! `shadenet mtlx-coverage`: every nodedef of a MaterialX library folder with its status and
//! the total.

use super::print_out;
use anyhow::Result;
use shadenet::graph::mtlx::coverage;
use std::path::PathBuf;

/// `shadenet mtlx-coverage`'s arguments.
#[derive(clap::Args)]
pub(crate) struct CoverageArgs {
    /// The MaterialX `libraries` folder (default: SHADENET_MTLX_LIBRARIES, then
    /// MATERIALX_SEARCH_PATH).
    #[arg(long, value_name = "DIR")]
    mtlx_libraries: Option<PathBuf>,
    /// The library folder to report on.
    #[arg(long, default_value = "stdlib")]
    folder: String,
}

/// Runs `shadenet mtlx-coverage`.
pub(crate) fn run(args: &CoverageArgs) -> Result<()> {
    let lib = shadenet::mtlx::library(&shadenet::mtlx::locate(args.mtlx_libraries.as_deref())?)?;
    let rows = coverage::check(lib, &args.folder);
    print_out(&coverage::report(&rows));
    Ok(())
}
