//! `shadenet compile`: link, lower and optimize a network; print its IR, the Cranelift IR,
//! the GPU kernels and what each pass did.

use super::{GpuPassesArg, OptArgs, load_source, print_out};
use anyhow::{Context, Result, bail};
use shadenet::graph::opt;
use shadenet::runtime::Backend;
use shadenet_gpu::GpuContext;
use shadenet_jit::{JitBackend, JitOptions};
use std::path::PathBuf;

#[derive(clap::Args)]
pub(crate) struct CompileArgs {
    /// The network file (.json), MaterialX document (.mtlx) or shader source (.sl, .osl).
    network: PathBuf,
    /// What to print: `ir` (the optimized program), `ir:after=PASS` (the program after every
    /// run of PASS: specialize, fold, dead_branch, unroll, cse, dce, hoist), `ir:before` (the
    /// unoptimized program), `clif` (the Cranelift IR the JIT compiles: prelude, scalar and
    /// batch entries), `wgsl` (the GPU kernels of the program's pass plan, each headed by a
    /// comment naming its pass and items; with --stats also the plan) or `none`. Default:
    /// `ir`, or `none` with --stats.
    #[arg(long)]
    emit: Option<String>,
    /// Print, per pass, ops before/after, changes and time, then the program's needs and the
    /// JIT's compile statistics (lowering, Cranelift and linking time, code size).
    #[arg(long)]
    stats: bool,
    #[command(flatten)]
    gpu: GpuPassesArg,
    #[command(flatten)]
    opt: OptArgs,
    #[command(flatten)]
    mtlx: super::SourceArgs,
}

/// Runs `shadenet compile`.
pub(crate) fn run(args: &CompileArgs) -> Result<()> {
    let c = load_source(&args.network, &args.mtlx, true)?;
    let emit = args.emit.clone().unwrap_or_else(|| {
        if args.stats {
            "none".into()
        } else {
            "ir".into()
        }
    });
    let after = match emit.as_str() {
        "ir" | "none" | "ir:before" | "clif" | "wgsl" => None,
        e => match e.strip_prefix("ir:after=") {
            Some(pass) if opt::pass(pass).is_some() => Some(pass.to_string()),
            _ => bail!(
                "--emit `{e}`: expected ir, ir:before, ir:after=PASS (specialize, fold, dead_branch, unroll, cse, dce, hoist), clif, wgsl or none"
            ),
        },
    };
    args.gpu.check(emit == "wgsl", "--emit wgsl")?;
    if emit == "ir:before" {
        print_out(&c.program.to_string());
    }
    if args.opt.no_opt {
        if emit == "ir" {
            print_out(&c.program.to_string());
        }
        if emit == "wgsl" {
            gpu_outputs(&c.program, &args.gpu, args.stats)?;
        }
        return jit_outputs(&c.program, emit == "clif", args.stats, true);
    }
    let spec = args.opt.spec(&c.program)?;
    let mut runs = 0;
    let (program, report) = opt::run_observed(&c.program, &spec, &mut |pass, p| {
        if after.as_deref() == Some(pass) {
            runs += 1;
            print_out(&format!("; after {pass} (run {runs})\n{p}"));
        }
    });
    shadenet::graph::ir::validate(&program)
        .context("internal error: the optimizer produced invalid IR")?;
    if emit == "ir" {
        print_out(&program.to_string());
    }
    if args.stats {
        print_out(&report.to_string());
        if args.network.extension().is_some_and(|e| e == "mtlx") {
            lobe_stats(&args.network, &args.mtlx, &spec)?;
        }
    }
    if emit == "wgsl" {
        gpu_outputs(&program, &args.gpu, args.stats)?;
    }
    jit_outputs(&program, emit == "clif", args.stats, spec.passes.cse)
}

/// The `--stats` line of a MaterialX material's lobes: those specialization leaves and the
/// number it removed (nothing for documents without closures).
fn lobe_stats(
    path: &std::path::Path,
    mtlx: &super::SourceArgs,
    spec: &opt::Specialization,
) -> Result<()> {
    let lobes = shadenet::mtlx::mtlx_lobes(path, &mtlx.options(), spec)?;
    if lobes.is_empty() {
        return Ok(());
    }

    let live: Vec<String> = lobes
        .iter()
        .filter(|l| l.live)
        .map(|l| format!("{} ({})", l.kind, l.component))
        .collect();
    print_out(&format!(
        "lobes: {} of {} left: {}\n",
        live.len(),
        lobes.len(),
        if live.is_empty() {
            "none".to_string()
        } else {
            live.join(", ")
        }
    ));
    Ok(())
}

/// `--emit wgsl`: the GPU kernels of an already optimized program's pass plan, each headed
/// by a comment naming its pass and items; with `stats`, the plan after them. Planned with
/// the device's limits when a device opens, else with `wgpu::Limits::default()`; the first
/// line says which.
fn gpu_outputs(
    program: &shadenet::graph::ir::Program,
    passes: &GpuPassesArg,
    stats: bool,
) -> Result<()> {
    use shadenet_gpu::plan::{ItemKind, Step};
    let (limits, whose) = match GpuContext::shared() {
        Ok(ctx) => (
            ctx.limits.clone(),
            format!(
                "the limits of adapter `{}` ({})",
                ctx.info.name, ctx.info.backend
            ),
        ),
        Err(e) => (
            wgpu::Limits::default(),
            format!(
                "wgpu::Limits::default() (no device: {})",
                shadenet::graph::error_chain(&e)
            ),
        ),
    };
    let plan = shadenet_gpu::plan(program, &passes.options(), &limits)?;
    let total = plan.passes();
    let mut text = format!(
        "// material `{}`: GPU passes: {total}, host steps: {}; planned with {whose}\n",
        plan.material,
        plan.host_steps()
    );
    let mut pass = 0;
    for (step, st) in plan.steps.iter().enumerate() {
        let Step::Pass(ps) = st else {
            continue;
        };
        text.push_str(&format!(
            "\n// ---- pass {pass} of {total} (step {step}): {} items, {} ops ----\n",
            ps.items.len(),
            ps.cost
        ));
        let names: Vec<String> = ps
            .items
            .iter()
            .map(|it| match &it.kind {
                ItemKind::Value(v) => plan.name(*v),
                ItemKind::Merge(v) => format!("merge({})", plan.name(*v)),
                ItemKind::Illuminance { region, .. } => {
                    format!("illuminance({})", plan.name(*region))
                }
                ItemKind::Loop { region } => format!("loop({})", plan.name(*region)),
            })
            .collect();
        let mut line = String::from("// items:");
        for n in names {
            if line.len() + n.len() + 1 > 96 {
                text.push_str(&line);
                text.push('\n');
                line = String::from("//       ");
            }
            line.push(' ');
            line.push_str(&n);
        }
        text.push_str(&line);
        text.push('\n');
        text.push_str(&ps.wgsl);
        if !ps.wgsl.ends_with('\n') {
            text.push('\n');
        }
        pass += 1;
    }
    print_out(&text);
    if stats {
        print_out(&format!("{plan}"));
    }
    Ok(())
}

/// `--emit clif` and the JIT half of `--stats` for an already optimized program; `speed`:
/// Cranelift's optimization level as the JIT picks it (`speed` unless CSE is off).
fn jit_outputs(
    program: &shadenet::graph::ir::Program,
    clif: bool,
    stats: bool,
    speed: bool,
) -> Result<()> {
    if clif {
        print_out(&shadenet_jit::emit_clif(
            program,
            &JitOptions::default(),
            speed,
        )?);
    }
    if stats {
        let backend = JitBackend::with_options(JitOptions {
            fallback: false,
            opt: if speed {
                shadenet_jit::OptLevel::Speed
            } else {
                shadenet_jit::OptLevel::None
            },
            ..JitOptions::default()
        });
        match backend.compile_program(program, std::time::Duration::ZERO) {
            Ok(m) => print_out(&format!("jit: {}\n", m.info().stats)),
            Err(e) => print_out(&format!(
                "jit: {}; the interpreter would run this material\n",
                shadenet::graph::error_chain(&e)
            )),
        }
    }
    Ok(())
}
