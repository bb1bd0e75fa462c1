//! `shadenet gen`: generated networks for the benchmarks.

use anyhow::{Context, Result};
use clap::{Subcommand, ValueEnum};
use shadenet::graph::ir::Space;
use shadenet::output::{OutputError, write_atomic};
use std::path::PathBuf;

/// What `shadenet gen` writes.
#[derive(Subcommand)]
pub(crate) enum GenCmd {
    /// The multiplication tree of benchmark B1 (Larsson 2005, §5.1.1): 2^N − 1 multiply nodes
    /// over 2^N samplerInfo leaves whose P feeds the bottom row; the root is output `color`.
    MultTree {
        /// Tree levels N, 1 to 16.
        #[arg(long)]
        levels: u32,
        /// The space the leaves read P in.
        #[arg(long, value_enum, default_value_t = GenSpace::World)]
        space: GenSpace,
        /// The network file to write (.json).
        #[arg(short, long)]
        output: PathBuf,
    },
}

/// The space the tree's leaves read P in.
#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum GenSpace {
    /// World space.
    World,
    /// Camera space.
    Camera,
}

/// Runs `shadenet gen`.
pub(crate) fn run(what: GenCmd) -> Result<()> {
    match what {
        GenCmd::MultTree {
            levels,
            space,
            output,
        } => {
            let space = match space {
                GenSpace::World => Space::World,
                GenSpace::Camera => Space::Camera,
            };
            let net = shadenet::generate::mult_tree(levels, space).context("--levels")?;
            let mut text = serde_json::to_string_pretty(&net)?;
            text.push('\n');
            write_atomic(&output, |tmp| {
                std::fs::write(tmp, &text).map_err(|e| OutputError::Write {
                    path: output.clone(),
                    message: e.to_string(),
                })
            })?;
            Ok(())
        }
    }
}
