//! `shadenet bench`: the benchmark suites of DESIGN §9, printed and written as CSV, SVG and
//! a markdown summary.

use super::{parse_res, print_out};
use anyhow::{Context, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub(crate) struct BenchArgs {
    /// Small sizes and few repetitions (under two minutes on two cores).
    #[arg(long)]
    quick: bool,
    /// Suites to run, comma-separated (b1 tree, b2 threads, b3 scenes, b4 preprocessing,
    /// b5 passes, b6 light-transport strategies: speed against error on pbr.toml, b7 peers:
    /// OSL's figures beside, b8 texture filtering: speed against error on
    /// texture_plane.toml).
    #[arg(long, value_delimiter = ',', default_value = "b1,b2,b3,b4,b5,b6,b7,b8")]
    suite: Vec<String>,
    /// Output directory of the CSV, SVG and summary files (and of B8's cached reference).
    #[arg(long, default_value = "bench-out")]
    out: PathBuf,
    /// Frame size of shading and tree renders, WxH (default 640x480; 160x120 with --quick;
    /// B6: 240x135, 96x54 with --quick; B8: 320x180, 96x54 with --quick).
    #[arg(long, value_parser = parse_res)]
    size: Option<(u32, u32)>,
    /// Tree levels of B1, comma-separated (default 1–10; 1,4,7,10 with --quick).
    #[arg(long, value_delimiter = ',')]
    levels: Option<Vec<u32>>,
    /// Directory of the example scenes (B3, B5, B6, B8).
    #[arg(long, default_value = "examples/scenes")]
    scenes: PathBuf,
}

/// Runs `shadenet bench`.
pub(crate) fn run(args: BenchArgs) -> Result<()> {
    use shadenet::bench::{self, BenchOptions, SUITES};
    for s in &args.suite {
        if !SUITES.contains(&s.to_lowercase().as_str()) {
            anyhow::bail!(
                "--suite: unknown suite `{s}` (known: {})",
                SUITES.join(", ")
            );
        }
    }
    if let Some(l) = &args.levels
        && l.iter().any(|l| !(1..=10).contains(l))
    {
        anyhow::bail!("--levels: levels are 1 to 10 (the native reference's range)");
    }
    let wants_scenes = args
        .suite
        .iter()
        .any(|s| matches!(s.to_lowercase().as_str(), "b3" | "b5" | "b6" | "b8"));
    if wants_scenes && !args.scenes.join("cornell.toml").is_file() {
        anyhow::bail!(
            "--scenes: {} holds no example scenes (B3, B5, B6 and B8 render examples/scenes/*.toml): \
             run from the repository root or pass --scenes DIR",
            args.scenes.display()
        );
    }
    let opts = BenchOptions {
        quick: args.quick,
        suites: args.suite.clone(),
        size: args.size,
        levels: args.levels.clone(),
        scenes: args.scenes.clone(),
        out: Some(args.out.clone()),
    };
    let start = std::time::Instant::now();
    let results = bench::run(&opts, |r| {
        print_out(&format!(
            "\n## {} — {}\n\n{}{}",
            r.name,
            r.title,
            bench::report::markdown(&r.rows),
            r.extra
        ));
    });
    let elapsed = start.elapsed().as_secs_f64();
    bench::write(&args.out, &results, &opts, elapsed)
        .with_context(|| format!("writing {}", args.out.display()))?;
    eprintln!(
        "bench: {elapsed:.1} s; wrote {}/{{{}}}.csv, .svg and summary.md",
        args.out.display(),
        results
            .iter()
            .map(|r| r.name.to_lowercase())
            .collect::<Vec<_>>()
            .join(",")
    );
    Ok(())
}
