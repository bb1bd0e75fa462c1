//! `shadenet shade`: a network shaded over a grid of fragments on a unit plane, written as
//! PNG and/or multi-layer EXR, with a summary of the speed.

use super::print_out;
use super::{BackendArg, GpuPassesArg, OptArgs, ThreadsArg, check_extension, load, ms, parse_res};
use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use shadenet::bench::report::Timing;
use shadenet::graph::ir::Program;
use shadenet::graph::nodes::LightDesc;
use shadenet::graph::opt::{self, Specialization};
use shadenet::lights::{DEFAULT_LIGHT, parse_light};
use shadenet::output::{write_exr, write_png};
use shadenet::runtime::{Backend, BatchTimes, CompileStats, InterpBackend, Material};
use shadenet::shade::{
    Grid, GridValues, channel, exr_channels, grid_env, output_slots, shade_grid, shade_grid_into,
    shade_grid_many, shade_grid_with,
};
use shadenet_gpu::GpuBackend;
use shadenet_jit::{JitBackend, JitOptions};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The arithmetic `shade` runs in.
#[derive(Clone, Copy, ValueEnum, PartialEq)]
pub(crate) enum Precision {
    /// f32, the shading precision.
    F32,
    /// f64, the accuracy reference.
    F64,
}

/// `shadenet shade`'s arguments.
#[derive(clap::Args)]
pub(crate) struct ShadeArgs {
    /// The network file (.json), MaterialX document (.mtlx) or shader source (.sl, .osl).
    network: PathBuf,
    /// Output image: .png (sRGB preview) or .exr (every output and component as f32 layers).
    #[arg(short, long)]
    output: Vec<PathBuf>,
    /// Grid size, WxH.
    #[arg(long, default_value = "256x256", value_parser = parse_res)]
    res: (u32, u32),
    /// Material output written to PNG (default: the first declared).
    #[arg(long)]
    aov: Option<String>,
    /// Write only this render component of the PNG's output (default: the total).
    #[arg(long)]
    component: Option<String>,
    #[command(flatten)]
    opt: OptArgs,
    #[command(flatten)]
    mtlx: super::SourceArgs,
    /// Add a light: point:X,Y,Z:INTENSITY[:R,G,B], distant:DX,DY,DZ:INTENSITY[:R,G,B],
    /// spot:X,Y,Z:DX,DY,DZ:INTENSITY:CONE_DEG[:R,G,B], ambient:INTENSITY[:R,G,B].
    #[arg(long)]
    light: Vec<String>,
    /// Back end: `interp` (the interpreter), `jit` (Cranelift, one call per fragment),
    /// `jit-batch` (Cranelift, four-lane packets, a row per call) or `gpu` (wgpu, the whole
    /// grid in one batch). Default: `jit`, or `interp` with `--precision f64`.
    #[arg(long, value_enum)]
    backend: Option<BackendArg>,
    #[command(flatten)]
    gpu: GpuPassesArg,
    /// Precision: f32 (shading) or f64 (the interpreter's accuracy reference).
    #[arg(long, value_enum, default_value_t = Precision::F32)]
    precision: Precision,
    #[command(flatten)]
    threads: ThreadsArg,
    /// Shade the grid this many times (1 to 1000) and report the first frame and the median
    /// of the others, as OSL's testshade `--iters` does: a compiled back end reuses its
    /// output buffer from frame to frame, so later frames pay no allocation.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

/// What one run shades: the checked arguments and the network, before any back end.
struct Job {
    program: Program,
    spec: Specialization,
    lights: Vec<LightDesc>,
    backend: BackendArg,
    aov: String,
    component: Option<u8>,
    load_start: Instant,
}

/// A shaded grid and how it was made.
struct Shaded {
    grid: Grid,
    load_time: Duration,
    shade_time: Duration,
    /// Frames 2.. (`--frames`): each frame's time.
    later: Vec<Duration>,
    ops: usize,
    /// The back end that ran and its compile statistics (`None`: the f64 interpreter).
    stats: Option<(&'static str, CompileStats)>,
    gpu_split: Option<BatchTimes>,
}

/// Runs `shadenet shade`.
pub(crate) fn run(args: ShadeArgs) -> Result<()> {
    if let Some(n) = args.threads.count()? {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("cannot set the thread count")?;
    }
    if args.output.is_empty() {
        bail!("no output image: give -o FILE.png and/or -o FILE.exr");
    }
    for o in &args.output {
        check_extension(o, &["png", "exr"], "-o")?;
    }
    let job = prepare(&args)?;
    let shaded = shade(&args, &job)?;
    super::print_messages(&shaded.grid.messages);
    write_outputs(&args, &job, &shaded.grid)?;
    if !args.quiet {
        summary(&args, &shaded);
    }
    Ok(())
}

/// Loads the network, adds the lights, picks the back end and checks the output choice.
fn prepare(args: &ShadeArgs) -> Result<Job> {
    let load_start = Instant::now();
    let compiled = load(&args.network, &args.mtlx)?;
    let program = compiled.program;
    let mut lights = compiled.lights;
    for (i, spec) in args.light.iter().enumerate() {
        lights.push(parse_light(spec, i).with_context(|| format!("--light {spec}"))?);
    }
    if lights.is_empty() {
        if !args.quiet {
            eprintln!(
                "note: no lights in the network or on the command line; using --light {DEFAULT_LIGHT}"
            );
        }
        lights.push(parse_light(DEFAULT_LIGHT, 0)?);
    }
    // Specialize and optimize for this run (unless --no-opt): only what the active
    // components need is computed, and textures on dead branches are never opened.
    let spec = args.opt.spec(&program)?;
    let backend = match (args.backend, args.precision) {
        (None, Precision::F64) => BackendArg::Interp,
        (None, Precision::F32) => BackendArg::Jit,
        (Some(BackendArg::Interp), _) => BackendArg::Interp,
        (Some(b), Precision::F64) => bail!(
            "--precision f64 runs the interpreter (the accuracy reference); --backend {} is f32 only",
            b.name()
        ),
        (Some(b), Precision::F32) => b,
    };
    args.gpu
        .check(backend == BackendArg::Gpu, "--backend gpu")?;
    let names = program.output_names();
    let aov = args.aov.clone().unwrap_or_else(|| names[0].to_string());
    if !names.contains(&aov.as_str()) {
        bail!(
            "--aov: the material has no output `{aov}` (it has: {})",
            names.join(", ")
        );
    }
    let component =
        match &args.component {
            None => None,
            Some(c) => Some(program.component_index(c).with_context(|| {
                format!("--component: `{c}` is not a component of this material")
            })?),
        };
    Ok(Job {
        program,
        spec,
        lights,
        backend,
        aov,
        component,
        load_start,
    })
}

/// Compiles the material on the chosen back end and shades the grid.
fn shade(args: &ShadeArgs, job: &Job) -> Result<Shaded> {
    let env = grid_env(&job.lights);
    let (w, h) = args.res;
    let mask = job.spec.components;
    let program = &job.program;
    if args.precision == Precision::F64 {
        let optimized;
        let p = if args.opt.no_opt {
            program
        } else {
            optimized = opt::run(program, &job.spec).0;
            &optimized
        };
        let load_time = job.load_start.elapsed();
        let t1 = Instant::now();
        let grid = shade_grid::<f64>(p, &env, w, h, mask)?;
        let shade_time = t1.elapsed();
        let mut later = Vec::new();
        for _ in 1..args.frames {
            let t = Instant::now();
            shade_grid::<f64>(p, &env, w, h, mask)?;
            later.push(t.elapsed());
        }
        return Ok(Shaded {
            grid,
            load_time,
            shade_time,
            later,
            ops: p.op_count(),
            stats: None,
            gpu_split: None,
        });
    }
    let jit = || {
        JitBackend::with_options(JitOptions {
            log_fallback: !args.quiet,
            ..JitOptions::default()
        })
    };
    let b: Box<dyn Backend> = match job.backend {
        BackendArg::Interp => Box::new(InterpBackend),
        BackendArg::Gpu => Box::new(
            GpuBackend::new(args.gpu.options(), Arc::new(jit()))
                .context("--backend gpu: the GPU back end cannot start")?,
        ),
        _ => Box::new(jit()),
    };
    let material: Arc<dyn Material> = if args.opt.no_opt {
        b.compile_program(program, Duration::ZERO)?
    } else {
        b.compile(program, &job.spec)?
    };
    let load_time = job.load_start.elapsed();
    let mut gpu_split = None;
    let (grid, shade_time, later) = if job.backend == BackendArg::Gpu {
        let (mut grid, mut first, mut later) = (None, Duration::ZERO, Vec::new());
        for f in 0..args.frames {
            let t = Instant::now();
            let (g, r) = shade_grid_many(&*material, &env, w, h, mask);
            let took = t.elapsed();
            if f == 0 {
                (first, gpu_split) = (took, Some(r.times));
            } else {
                later.push(took);
            }
            grid = Some(g);
        }
        (grid.expect("at least one frame"), first, later)
    } else {
        let batch = job.backend == BackendArg::JitBatch;
        let t = Instant::now();
        let mut grid = shade_grid_with(&*material, &env, w, h, mask, batch);
        let first = t.elapsed();
        let mut later = Vec::new();
        if let GridValues::Packed { data, .. } = &mut grid.values {
            for _ in 1..args.frames {
                let t = Instant::now();
                shade_grid_into(&*material, &env, (w, h), mask, batch, data);
                later.push(t.elapsed());
            }
        }
        (grid, first, later)
    };
    let info = material.info();
    let which = match &info.fallback {
        Some(_) => "interp (fallback)",
        None => job.backend.name(),
    };
    Ok(Shaded {
        grid,
        load_time,
        shade_time,
        later,
        ops: info.stats.ops,
        stats: Some((which, info.stats)),
        gpu_split,
    })
}

/// Writes every `-o` image: a PNG of the chosen output (and component), or an EXR of every
/// output and component.
fn write_outputs(args: &ShadeArgs, job: &Job, grid: &Grid) -> Result<()> {
    let slots = output_slots(&job.program);
    let (w, h) = args.res;
    for path in &args.output {
        if path.extension().and_then(|e| e.to_str()) == Some("png") {
            let pick = |name: &str, comp: Option<u8>| {
                name == job.aov && (job.component.is_none() || comp == job.component)
            };
            let chans: Vec<Vec<f32>> = (0..3).map(|c| channel(grid, &slots, &pick, c)).collect();
            let n = (w * h) as usize;
            let mut rgb = vec![0.0f32; n * 3];
            for p in 0..n {
                for c in 0..3 {
                    rgb[p * 3 + c] = chans[c][p];
                }
            }
            write_png(path, w, h, &rgb)?;
        } else {
            write_exr(path, w, h, exr_channels(&job.program, grid))?;
        }
    }
    Ok(())
}

/// The summary line, the compile statistics and the GPU time split.
fn summary(args: &ShadeArgs, s: &Shaded) {
    let (w, h) = args.res;
    let n = w as u64 * h as u64;
    let secs = s.shade_time.as_secs_f64();
    say!(
        "shaded {w}x{h} = {n} fragments in {:.3} s ({:.2} M fragments/s, {} threads, {}, {}); load+compile {:.1} ms; {} ops; {} non-finite values zeroed",
        secs,
        n as f64 / secs / 1e6,
        rayon::current_num_threads(),
        match args.precision {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        },
        s.stats.as_ref().map_or("interp", |s| s.0),
        s.load_time.as_secs_f64() * 1e3,
        s.ops,
        s.grid.nonfinite
    );
    if let Some(t) = Timing::of(s.later.iter().map(|d| d.as_secs_f64()).collect()) {
        say!(
            "frames 2..{}: median {:.3} ms per frame ({:.3}–{:.3}), {:.2} M fragments/s",
            t.runs + 1,
            t.median * 1e3,
            t.min * 1e3,
            t.max * 1e3,
            n as f64 / t.median / 1e6
        );
    }
    if let Some(line) = super::messages_line(&s.grid.messages) {
        say!("{line}");
    }
    if let Some((_, st)) = &s.stats {
        say!("compile: {st}");
    }
    if let Some(t) = &s.gpu_split {
        say!(
            "gpu: upload {:.3} ms, kernels {:.3} ms, host {:.3} ms, readback {:.3} ms; {} passes dispatched",
            ms(t.upload),
            ms(t.kernels),
            ms(t.host),
            ms(t.readback),
            t.passes
        );
    }
    for p in &args.output {
        say!("wrote {}", p.display());
    }
}
