//! `shadenet diff`: two EXR images compared layer by layer.

use super::print_out;
use anyhow::{Result, bail};
use std::path::PathBuf;

#[derive(clap::Args)]
pub(crate) struct DiffArgs {
    /// The reference image (.exr).
    a: PathBuf,
    /// The image to compare with it (.exr): same size, same channels.
    b: PathBuf,
    /// Fail when a layer's largest absolute difference is above this.
    #[arg(long)]
    max_abs: Option<f64>,
    /// Fail when a layer's root mean square difference is above this.
    #[arg(long)]
    rmse: Option<f64>,
}

/// Runs `shadenet diff`.
pub(crate) fn run(args: &DiffArgs) -> Result<()> {
    for (name, bound) in [("--max-abs", args.max_abs), ("--rmse", args.rmse)] {
        if let Some(x) = bound
            && !(x.is_finite() && x >= 0.0)
        {
            bail!("{name} {x}: expected a finite bound ≥ 0");
        }
    }
    let a = shadenet::output::read_exr(&args.a)?;
    let b = shadenet::output::read_exr(&args.b)?;
    let layers = shadenet::output::compare(&a, &b)
        .map_err(|e| anyhow::anyhow!("{} and {}: {e}", args.a.display(), args.b.display()))?;
    say!(
        "{} vs {} ({}×{}, {} channels)",
        args.a.display(),
        args.b.display(),
        a.width,
        a.height,
        a.channels.len()
    );
    say!(
        "{:<24} {:>12} {:>12} {:>18}  worst (x, y, channel)",
        "layer",
        "max abs",
        "RMSE",
        "differing"
    );
    let mut over = Vec::new();
    for d in &layers {
        let worst = if d.differing == 0 {
            "—".to_string()
        } else {
            format!("({}, {}, {})", d.worst.0, d.worst.1, d.worst.2)
        };
        say!(
            "{:<24} {:>12.3e} {:>12.3e} {:>18}  {worst}",
            d.layer,
            d.max_abs,
            d.rmse,
            format!("{}/{}", d.differing, d.samples),
        );
        let bad = |v: f64, bound: Option<f64>| bound.is_some_and(|b| v.is_nan() || v > b);
        if bad(d.max_abs, args.max_abs) || bad(d.rmse, args.rmse) {
            over.push(d.layer.as_str());
        }
    }
    if !over.is_empty() {
        bail!(
            "{} beyond the bound (--max-abs {}, --rmse {}): {}",
            if over.len() == 1 {
                "a layer is"
            } else {
                "layers are"
            },
            args.max_abs.map_or("none".into(), |x| format!("{x:e}")),
            args.rmse.map_or("none".into(), |x| format!("{x:e}")),
            over.join(", ")
        );
    }
    Ok(())
}
