//! The `shadenet` command line: `render`, `shade`, `compile`, `check`, `nodes`, `gen`,
//! `bench`, `gpu-info`, `diff`, `merge`, `mtlx-coverage`.
//!
//! This file only parses arguments and dispatches; each subcommand is a file of [`cli`], and
//! an error is printed once here, its causes outermost first.

mod cli;

use clap::{Parser, Subcommand};
use cli::bench::BenchArgs;
use cli::compile::CompileArgs;
use cli::diff::DiffArgs;
use cli::generate::GenCmd;
use cli::merge::MergeArgs;
use cli::render::RenderArgs;
use cli::shade::ShadeArgs;
use shadenet::graph::NodeLibrary;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "shadenet",
    version,
    about = "Shading networks, partially evaluated and compiled"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Render a scene (or, with no scene file, the embedded default scene) to a multi-layer
    /// EXR and a PNG preview.
    Render(RenderArgs),
    /// Shade a network over a grid of fragments on a unit plane and write images.
    Shade(ShadeArgs),
    /// Link, lower and optimize a network; print its IR and/or what the optimizer did.
    Compile(CompileArgs),
    /// Link a network and report every error, or `ok` with a summary.
    Check {
        /// The network file (.json), MaterialX document (.mtlx) or shader source (.sl, .osl).
        network: PathBuf,
        #[command(flatten)]
        mtlx: cli::SourceArgs,
    },
    /// Print every MaterialX stdlib nodedef with its status (native, via nodegraph, or
    /// unsupported with the reason) and the total.
    MtlxCoverage(cli::mtlx_coverage::CoverageArgs),
    /// Print the node reference (Markdown; docs/nodes.md is this output).
    Nodes,
    /// Write a generated network (for benchmarks).
    Gen {
        #[command(subcommand)]
        what: GenCmd,
    },
    /// Run the benchmarks (DESIGN §9): tables per suite, CSV + SVG per suite and a markdown
    /// summary in the output directory.
    Bench(BenchArgs),
    /// List the GPU adapters (best first) and describe the one the GPU back end uses; exit 1
    /// when there is none.
    GpuInfo,
    /// Compare two EXR images layer by layer (max abs difference, RMSE, worst pixel, samples
    /// that differ); exit 1 when a bound given is exceeded.
    Diff(DiffArgs),
    /// Assemble region renders (`render --crop`) into the full frame's EXR; the parts must
    /// tile the frame exactly.
    Merge(MergeArgs),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.cmd {
        Cmd::Render(args) => cli::render::run(args),
        Cmd::Shade(args) => cli::shade::run(args),
        Cmd::Compile(args) => cli::compile::run(&args),
        Cmd::Check { network, mtlx } => cli::check::run(&network, &mtlx),
        Cmd::MtlxCoverage(args) => cli::mtlx_coverage::run(&args),
        Cmd::Nodes => {
            cli::print_out(&NodeLibrary::standard().reference());
            Ok(())
        }
        Cmd::Gen { what } => cli::generate::run(what),
        Cmd::Bench(args) => cli::bench::run(args),
        Cmd::GpuInfo => cli::gpu_info::run(),
        Cmd::Diff(args) => cli::diff::run(&args),
        Cmd::Merge(args) => cli::merge::run(&args),
    };
    if let Err(e) = result {
        // Each level of an error says its own part only: `{:#}` prints the chain once,
        // outermost first, joined by ": ".
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
