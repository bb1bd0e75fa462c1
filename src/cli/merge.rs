//! `shadenet merge`: region renders (`render --crop`) assembled into the full frame's EXR.

use super::print_out;
use anyhow::{Result, bail};
use shadenet::output::{read_exr, write_exr_window};
use shadenet::tracer::Window;
use shadenet::tracer::merge::merge;
use std::path::PathBuf;

/// `shadenet merge`'s arguments.
#[derive(clap::Args)]
pub(crate) struct MergeArgs {
    /// The parts (.exr), each a region render of the same frame.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// The full frame's EXR (written atomically: an error leaves an existing file as it was).
    #[arg(short, long)]
    output: PathBuf,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

/// Runs `shadenet merge`: reads every part, checks that they tile one frame exactly and
/// writes the frame.
pub(crate) fn run(args: &MergeArgs) -> Result<()> {
    super::check_extension(&args.output, &["exr"], "-o")?;
    if args.parts.iter().any(|p| p == &args.output) {
        bail!(
            "-o {}: the output is also one of the parts",
            args.output.display()
        );
    }
    let mut parts = Vec::with_capacity(args.parts.len());
    for p in &args.parts {
        parts.push((p.clone(), read_exr(p)?));
    }
    let full = merge(&parts).map_err(anyhow::Error::msg)?;
    write_exr_window(
        &args.output,
        Window::full(full.width, full.height),
        full.frame,
        full.channels,
    )?;
    if !args.quiet {
        say!(
            "merged {} parts into {} ({}×{})",
            args.parts.len(),
            args.output.display(),
            full.width,
            full.height
        );
    }
    Ok(())
}
