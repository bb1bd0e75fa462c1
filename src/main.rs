//! The `shadenet` command line: `render`, `shade`, `compile`, `check`, `nodes`, `gen`,
//! `bench`, `gpu-info`, `diff`.

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand, ValueEnum};
use shadenet::graph::NodeLibrary;
use shadenet::graph::ir::Space;
use shadenet::graph::nodes::{LightDesc, LightKind};
use shadenet::graph::opt::{self, Specialization};
use shadenet::output::{OutputError, write_atomic, write_exr, write_png};
use shadenet::runtime::{Backend, InterpBackend, Material};
use shadenet::shade::{grid_env, shade_grid, shade_grid_many, shade_grid_with};
use shadenet_gpu::{GpuBackend, GpuContext, GpuOptions, PassMode};
use shadenet_jit::{JitBackend, JitOptions};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// `println!` through [`print_out`]: a closed pipe ends the output quietly instead of
/// panicking.
macro_rules! say {
    ($($arg:tt)*) => {
        print_out(&format!("{}\n", format_args!($($arg)*)))
    };
}

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
        /// The network file (.json).
        network: PathBuf,
    },
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
}

#[derive(clap::Args)]
struct DiffArgs {
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

#[derive(clap::Args)]
struct BenchArgs {
    /// Small sizes and few repetitions (under two minutes on two cores).
    #[arg(long)]
    quick: bool,
    /// Suites to run, comma-separated (b1 tree, b2 threads, b3 scenes, b4 preprocessing,
    /// b5 passes).
    #[arg(long, value_delimiter = ',', default_value = "b1,b2,b3,b4,b5")]
    suite: Vec<String>,
    /// Output directory of the CSV, SVG and summary files.
    #[arg(long, default_value = "bench-out")]
    out: PathBuf,
    /// Frame size of shading and tree renders, WxH (default 640x480; 160x120 with --quick).
    #[arg(long, value_parser = parse_res)]
    size: Option<(u32, u32)>,
    /// Tree levels of B1, comma-separated (default 1–10; 1,4,7,10 with --quick).
    #[arg(long, value_delimiter = ',')]
    levels: Option<Vec<u32>>,
    /// Directory of the example scenes (B3, B5).
    #[arg(long, default_value = "examples/scenes")]
    scenes: PathBuf,
}

#[derive(Subcommand)]
enum GenCmd {
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

#[derive(Clone, Copy, ValueEnum)]
enum GenSpace {
    /// World space.
    World,
    /// Camera space.
    Camera,
}

#[derive(clap::Args)]
struct CompileArgs {
    /// The network file (.json).
    network: PathBuf,
    /// What to print: `ir` (the optimized program), `ir:after=PASS` (the program after every
    /// run of PASS: specialize, fold, dead_branch, cse, dce, hoist), `ir:before` (the
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
    /// GPU pass partitioning for `--emit wgsl`: `auto` (the cost model), `1` (one kernel
    /// between host steps) or a pass count.
    #[arg(long, value_name = "auto|1|N", value_parser = parse_gpu_passes)]
    gpu_passes: Option<PassMode>,
    #[command(flatten)]
    opt: OptArgs,
}

/// How a network is specialized and optimized (shared by `compile` and `shade`).
#[derive(clap::Args, Clone)]
struct OptArgs {
    /// Active render components, comma separated (default: all).
    #[arg(long, value_delimiter = ',')]
    components: Option<Vec<String>>,
    /// Ray types the material will see: camera, shadow, reflection, refraction, diffuse
    /// (default: all).
    #[arg(long, value_delimiter = ',')]
    raytypes: Option<Vec<String>>,
    /// Instance compilation: bake parameters into constants (the default).
    #[arg(long, conflicts_with = "class")]
    bake: bool,
    /// Class compilation: keep parameters uniform (they can change without recompiling).
    #[arg(long)]
    class: bool,
    /// Switch common-subexpression elimination off (to measure per-node cost).
    #[arg(long)]
    no_cse: bool,
    /// Switch passes off, comma separated: specialize, fold, dead_branch, cse, dce, hoist.
    #[arg(long, value_delimiter = ',')]
    disable: Vec<String>,
    /// Do not optimize at all.
    #[arg(long)]
    no_opt: bool,
}

impl OptArgs {
    fn spec(&self, program: &shadenet::graph::ir::Program) -> Result<Specialization> {
        use shadenet::graph::ir::{
            RAY_CAMERA, RAY_DIFFUSE, RAY_REFLECTION, RAY_REFRACTION, RAY_SHADOW,
        };
        let mut spec = Specialization::default();
        if let Some(c) = &self.components {
            spec.components = Specialization::mask_of(program, c)
                .map_err(|e| anyhow::anyhow!("--components: {e}"))?;
        }
        if let Some(r) = &self.raytypes {
            spec.ray_types = 0;
            for t in r {
                spec.ray_types |= match t.as_str() {
                    "camera" => RAY_CAMERA,
                    "shadow" => RAY_SHADOW,
                    "reflection" => RAY_REFLECTION,
                    "refraction" => RAY_REFRACTION,
                    "diffuse" => RAY_DIFFUSE,
                    other => bail!(
                        "--raytypes: `{other}` is not a ray type (camera, shadow, reflection, refraction, diffuse)"
                    ),
                } as u32;
            }
        }
        spec.bake = !self.class;
        if self.no_cse {
            spec.passes.cse = false;
        }
        for pass in &self.disable {
            let flag = match pass.as_str() {
                "specialize" => &mut spec.passes.specialize,
                "fold" => &mut spec.passes.fold,
                "dead_branch" => &mut spec.passes.dead_branch,
                "cse" => &mut spec.passes.cse,
                "dce" => &mut spec.passes.dce,
                "hoist" => &mut spec.passes.hoist,
                other => bail!(
                    "--disable: `{other}` is not a pass (specialize, fold, dead_branch, cse, dce, hoist)"
                ),
            };
            *flag = false;
        }
        Ok(spec)
    }
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum Precision {
    /// f32, the shading precision.
    F32,
    /// f64, the accuracy reference.
    F64,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Debug)]
enum BackendArg {
    /// The interpreter.
    Interp,
    /// The Cranelift JIT, scalar entry.
    Jit,
    /// The Cranelift JIT, 4-wide batch entry.
    JitBatch,
    /// The GPU (wgpu): the whole grid in one batch.
    Gpu,
}

#[derive(clap::Args)]
struct ShadeArgs {
    /// The network file (.json).
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
    /// Add a light: point:X,Y,Z:INTENSITY[:R,G,B], distant:DX,DY,DZ:INTENSITY[:R,G,B],
    /// spot:X,Y,Z:DX,DY,DZ:INTENSITY:CONE_DEG[:R,G,B], ambient:INTENSITY[:R,G,B].
    #[arg(long)]
    light: Vec<String>,
    /// Back end: `interp` (the interpreter), `jit` (Cranelift, one call per fragment),
    /// `jit-batch` (Cranelift, four fragments per call) or `gpu` (wgpu, the whole grid in one
    /// batch). Default: `jit`, or `interp` with `--precision f64`.
    #[arg(long, value_enum)]
    backend: Option<BackendArg>,
    /// GPU pass partitioning (with `--backend gpu`): `auto` (the cost model), `1` (one
    /// kernel between host steps) or a pass count.
    #[arg(long, value_name = "auto|1|N", value_parser = parse_gpu_passes)]
    gpu_passes: Option<PassMode>,
    /// Precision: f32 (shading) or f64 (the interpreter's accuracy reference).
    #[arg(long, value_enum, default_value_t = Precision::F32)]
    precision: Precision,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum RenderBackendArg {
    /// The interpreter.
    Interp,
    /// The Cranelift JIT (scalar entry, one call per hit).
    Jit,
    /// The GPU (wgpu): camera hits shaded deferred, in batches; the JIT shades secondary
    /// hits.
    Gpu,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum ShadingArg {
    /// The back end decides.
    Auto,
    /// Each camera hit as it is found.
    Immediate,
    /// Camera hits in batches.
    Deferred,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// The scene file (.toml); without one, the embedded default scene.
    scene: Option<PathBuf>,
    /// Output EXR (every pass as f32 layers). Default: render.exr, plus render.png when
    /// --png is not given either.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Also write a tone-mapped sRGB PNG preview of the beauty pass.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Back end that runs the materials.
    #[arg(long, value_enum, default_value_t = RenderBackendArg::Jit)]
    backend: RenderBackendArg,
    /// GPU pass partitioning (with `--backend gpu`): `auto` (the cost model), `1` (one
    /// kernel between host steps) or a pass count.
    #[arg(long, value_name = "auto|1|N", value_parser = parse_gpu_passes)]
    gpu_passes: Option<PassMode>,
    /// How camera hits are shaded: `auto` (deferred in batches for the GPU, immediately for
    /// the CPU back ends), `immediate` (each hit as it is found) or `deferred` (traced per
    /// group of tiles, then shaded in batches; the same image on the CPU back ends).
    #[arg(long, value_enum, default_value_t = ShadingArg::Auto)]
    shading: ShadingArg,
    /// Samples per pixel (overrides the scene).
    #[arg(long)]
    spp: Option<u32>,
    /// Passes, comma separated (replace the scene's): a component (diffuse, specular,
    /// indirect, emission, reflection, refraction, shadow) or an override (normal, depth,
    /// uv, occlusion).
    #[arg(long, value_delimiter = ',')]
    passes: Option<Vec<String>>,
    /// Resolution, WxH (overrides the scene).
    #[arg(long, value_parser = parse_res)]
    res: Option<(u32, u32)>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print nothing but errors (no progress bar, no summary).
    #[arg(short, long)]
    quiet: bool,
}

fn parse_res(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}` is not WxH"))?;
    let w: u32 = w.parse().map_err(|_| format!("bad width in `{s}`"))?;
    let h: u32 = h.parse().map_err(|_| format!("bad height in `{s}`"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!(
            "resolution `{s}` must be between 1x1 and 16384x16384"
        ));
    }
    Ok((w, h))
}

fn parse_gpu_passes(s: &str) -> Result<PassMode, String> {
    s.parse::<PassMode>()
}

/// The GPU back end's options from `--gpu-passes`.
fn gpu_options(passes: Option<PassMode>) -> GpuOptions {
    GpuOptions {
        passes: passes.unwrap_or_default(),
        ..GpuOptions::default()
    }
}

/// `--gpu-passes` only means something to the GPU back end.
fn check_gpu_passes(passes: Option<PassMode>, gpu: bool, what: &str) -> Result<()> {
    if passes.is_some() && !gpu {
        bail!("--gpu-passes applies to {what} only");
    }
    Ok(())
}

/// Milliseconds of a duration, for the summaries.
fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.cmd {
        Cmd::Render(args) => render(args),
        Cmd::Shade(args) => shade(args),
        Cmd::Compile(args) => compile(&args),
        Cmd::Check { network } => check(&network),
        Cmd::Nodes => {
            print_out(&NodeLibrary::standard().reference());
            Ok(())
        }
        Cmd::Gen { what } => generate(what),
        Cmd::Bench(args) => bench(args),
        Cmd::GpuInfo => gpu_info(),
        Cmd::Diff(args) => diff(&args),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// Writes to stdout; a closed pipe (`| head`) ends the output quietly.
fn print_out(text: &str) {
    use std::io::Write;
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}

fn load(path: &Path) -> Result<shadenet::Compiled> {
    let compiled = shadenet::load_network(path)?;
    shadenet::graph::ir::validate(&compiled.program)
        .map_err(|e| anyhow::anyhow!("{}: internal error: invalid IR: {e}", path.display()))?;
    Ok(compiled)
}

fn compile(args: &CompileArgs) -> Result<()> {
    let c = load(&args.network)?;
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
                "--emit `{e}`: expected ir, ir:before, ir:after=PASS (specialize, fold, dead_branch, cse, dce, hoist), clif, wgsl or none"
            ),
        },
    };
    check_gpu_passes(args.gpu_passes, emit == "wgsl", "--emit wgsl")?;
    if emit == "ir:before" {
        print_out(&c.program.to_string());
    }
    if args.opt.no_opt {
        if emit == "ir" {
            print_out(&c.program.to_string());
        }
        if emit == "wgsl" {
            gpu_outputs(&c.program, args.gpu_passes, args.stats)?;
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
        .map_err(|e| anyhow::anyhow!("internal error: the optimizer produced invalid IR: {e}"))?;
    if emit == "ir" {
        print_out(&program.to_string());
    }
    if args.stats {
        print_out(&report.to_string());
    }
    if emit == "wgsl" {
        gpu_outputs(&program, args.gpu_passes, args.stats)?;
    }
    jit_outputs(&program, emit == "clif", args.stats, spec.passes.cse)
}

/// `--emit wgsl`: the GPU kernels of an already optimized program's pass plan, each headed
/// by a comment naming its pass and items; with `stats`, the plan after them. Planned with
/// the device's limits when a device opens, else with `wgpu::Limits::default()`; the first
/// line says which.
fn gpu_outputs(
    program: &shadenet::graph::ir::Program,
    passes: Option<PassMode>,
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
            format!("wgpu::Limits::default() (no device: {e})"),
        ),
    };
    let plan = shadenet_gpu::plan(program, &gpu_options(passes), &limits)?;
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
                "jit: {e}; the interpreter would run this material\n"
            )),
        }
    }
    Ok(())
}

fn check(path: &Path) -> Result<()> {
    let c = load(path)?;
    say!(
        "ok: {} ops, outputs: {}, components: [{}], lights: {}",
        c.program.op_count(),
        c.program.output_names().join(", "),
        c.program.components.join(", "),
        c.lights.len()
    );
    Ok(())
}

fn generate(what: GenCmd) -> Result<()> {
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

fn parse_light(spec: &str, index: usize) -> Result<LightDesc> {
    let parts: Vec<&str> = spec.split(':').collect();
    let vec3 = |s: &str| -> Result<[f64; 3]> {
        let v: Vec<f64> = s
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .with_context(|| format!("--light {spec}: `{s}` is not X,Y,Z"))?;
        if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
            bail!("--light {spec}: `{s}` is not three finite numbers");
        }
        Ok([v[0], v[1], v[2]])
    };
    let num = |s: &str| -> Result<f64> {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .with_context(|| format!("--light {spec}: `{s}` is not a finite number"))
    };
    let power = |i: f64, color: Option<&&str>| -> Result<[f64; 3]> {
        let c = color.map(|c| vec3(c)).transpose()?.unwrap_or([1.0; 3]);
        Ok(c.map(|x| x * i))
    };
    let name = format!("light{index}");
    let (kind, pw) = match (parts[0], parts.len()) {
        ("point", 3 | 4) => (
            LightKind::Point {
                position: vec3(parts[1])?,
            },
            power(num(parts[2])?, parts.get(3))?,
        ),
        ("distant", 3 | 4) => (
            LightKind::Distant {
                direction: vec3(parts[1])?,
            },
            power(num(parts[2])?, parts.get(3))?,
        ),
        ("spot", 5 | 6) => (
            LightKind::Spot {
                position: vec3(parts[1])?,
                direction: vec3(parts[2])?,
                cone_angle: num(parts[4])?.to_radians(),
                penumbra_angle: 0.0,
                dropoff: 0.0,
            },
            power(num(parts[3])?, parts.get(5))?,
        ),
        ("ambient", 2 | 3) => (LightKind::Ambient, power(num(parts[1])?, parts.get(2))?),
        _ => bail!(
            "--light {spec}: expected point:X,Y,Z:I[:R,G,B], distant:DX,DY,DZ:I[:R,G,B], \
             spot:X,Y,Z:DX,DY,DZ:I:CONE_DEG[:R,G,B] or ambient:I[:R,G,B]"
        ),
    };
    LightDesc::new(name, kind, pw).map_err(|e| anyhow::anyhow!("--light {spec}: {e}"))
}

fn shade(args: ShadeArgs) -> Result<()> {
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
            .context("cannot set the thread count")?;
    }
    if args.output.is_empty() {
        bail!("no output image: give -o FILE.png and/or -o FILE.exr");
    }
    for o in &args.output {
        match o.extension().and_then(|e| e.to_str()) {
            Some("png" | "exr") => {}
            _ => bail!("{}: output must end in .png or .exr", o.display()),
        }
    }
    let t0 = Instant::now();
    let compiled = load(&args.network)?;
    let program = &compiled.program;
    let mut lights = compiled.lights.clone();
    for (i, spec) in args.light.iter().enumerate() {
        lights.push(parse_light(spec, i)?);
    }
    if lights.is_empty() {
        if !args.quiet {
            eprintln!(
                "note: no lights in the network or on the command line; using --light point:1,1,2:20"
            );
        }
        lights.push(parse_light("point:1,1,2:20", 0)?);
    }
    // Specialize and optimize for this run (unless --no-opt): only what the active
    // components need is computed, and textures on dead branches are never opened.
    let spec = args.opt.spec(&compiled.program)?;
    let mask = spec.components;
    let backend = match (args.backend, args.precision) {
        (None, Precision::F64) => BackendArg::Interp,
        (None, Precision::F32) => BackendArg::Jit,
        (Some(BackendArg::Interp), _) => BackendArg::Interp,
        (Some(b), Precision::F64) => bail!(
            "--precision f64 runs the interpreter (the accuracy reference); --backend {} is f32 only",
            match b {
                BackendArg::Jit => "jit",
                BackendArg::Gpu => "gpu",
                _ => "jit-batch",
            }
        ),
        (Some(b), Precision::F32) => b,
    };
    check_gpu_passes(args.gpu_passes, backend == BackendArg::Gpu, "--backend gpu")?;
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
    let env = grid_env(&lights);
    let (w, h) = args.res;
    let mut gpu_split = None;
    let (grid, load_time, shade_time, ops, stats) = match args.precision {
        Precision::F64 => {
            let optimized;
            let p = if args.opt.no_opt {
                program
            } else {
                optimized = opt::run(program, &spec).0;
                &optimized
            };
            let load_time = t0.elapsed();
            let t1 = Instant::now();
            let grid = shade_grid::<f64>(p, &env, w, h, mask)?;
            (grid, load_time, t1.elapsed(), p.op_count(), None)
        }
        Precision::F32 => {
            let jit = || {
                JitBackend::with_options(JitOptions {
                    log_fallback: !args.quiet,
                    ..JitOptions::default()
                })
            };
            let b: Box<dyn Backend> = match backend {
                BackendArg::Interp => Box::new(InterpBackend),
                BackendArg::Gpu => Box::new(
                    GpuBackend::new(gpu_options(args.gpu_passes), Arc::new(jit()))
                        .context("--backend gpu: the GPU back end cannot start")?,
                ),
                _ => Box::new(jit()),
            };
            let material: Arc<dyn Material> = if args.opt.no_opt {
                b.compile_program(program, std::time::Duration::ZERO)?
            } else {
                b.compile(program, &spec)?
            };
            let load_time = t0.elapsed();
            let t1 = Instant::now();
            let grid = if backend == BackendArg::Gpu {
                let (grid, r) = shade_grid_many(&*material, &env, w, h, mask);
                gpu_split = Some(r.times);
                grid
            } else {
                shade_grid_with(
                    &*material,
                    &env,
                    w,
                    h,
                    mask,
                    backend == BackendArg::JitBatch,
                )
            };
            let info = material.info();
            let ops = info.stats.ops;
            let which = match (backend, &info.fallback) {
                (_, Some(_)) => "interp (fallback)",
                (BackendArg::Interp, _) => "interp",
                (BackendArg::Jit, _) => "jit",
                (BackendArg::JitBatch, _) => "jit-batch",
                (BackendArg::Gpu, _) => "gpu",
            };
            (
                grid,
                load_time,
                t1.elapsed(),
                ops,
                Some((which, info.stats)),
            )
        }
    };

    // The output layout every back end writes.
    let slots: Vec<_> = shadenet::runtime::output_layout(program)
        .0
        .into_iter()
        .map(|s| (s.name, s.component, s.ty, s.offset))
        .collect();
    let n = (w * h) as usize;
    let channel = |pred: &dyn Fn(&str, Option<u8>) -> bool, c: usize| -> Vec<f32> {
        let mut out = vec![0.0f32; n];
        for (name, comp, ty, off) in &slots {
            if !pred(name, *comp) {
                continue;
            }
            let w = ty.width().max(1);
            let ci = c.min(w - 1);
            for (p, o) in out.iter_mut().enumerate() {
                *o += grid.values[p * grid.stride + off + ci] as f32;
            }
        }
        out
    };
    for path in &args.output {
        if path.extension().and_then(|e| e.to_str()) == Some("png") {
            let pick = |name: &str, comp: Option<u8>| {
                name == aov && (component.is_none() || comp == component)
            };
            let chans: Vec<Vec<f32>> = (0..3).map(|c| channel(&pick, c)).collect();
            let mut rgb = vec![0.0f32; n * 3];
            for p in 0..n {
                for c in 0..3 {
                    rgb[p * 3 + c] = chans[c][p];
                }
            }
            write_png(path, w, h, &rgb)?;
        } else {
            let mut chans = Vec::new();
            for name in &names {
                let ty = slots
                    .iter()
                    .find(|s| &s.0 == name)
                    .map(|s| s.2)
                    .expect("output");
                let suffixes: &[&str] = match ty.width() {
                    2 => &["X", "Y"],
                    3 => &["R", "G", "B"],
                    _ => &["Y"],
                };
                let mut layers: Vec<(String, Option<Option<u8>>)> = vec![(name.to_string(), None)];
                for (sn, comp, _, _) in &slots {
                    if sn == name && comp.is_some() {
                        layers.push((
                            format!("{name}.{}", program.components[comp.unwrap() as usize]),
                            Some(*comp),
                        ));
                    }
                }
                for (layer, only) in layers {
                    for (ci, suf) in suffixes.iter().enumerate() {
                        let pred =
                            |n: &str, c: Option<u8>| n == *name && only.is_none_or(|o| o == c);
                        chans.push((format!("{layer}.{suf}"), channel(&pred, ci)));
                    }
                }
            }
            write_exr(path, w, h, chans)?;
        }
    }
    if !args.quiet {
        let secs = shade_time.as_secs_f64();
        say!(
            "shaded {w}x{h} = {n} fragments in {:.3} s ({:.2} M fragments/s, {} threads, {}, {}); load+compile {:.1} ms; {} ops; {} non-finite values zeroed",
            secs,
            n as f64 / secs / 1e6,
            rayon::current_num_threads(),
            match args.precision {
                Precision::F32 => "f32",
                Precision::F64 => "f64",
            },
            stats.map_or("interp", |s| s.0),
            load_time.as_secs_f64() * 1e3,
            ops,
            grid.nonfinite
        );
        if let Some((_, s)) = stats {
            say!("compile: {s}");
        }
        if let Some(t) = gpu_split {
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
    Ok(())
}

fn render(args: RenderArgs) -> Result<()> {
    use shadenet::render::{self as r, BackendKind, Files, RenderOptions};
    use shadenet::tracer::{DeferredOptions, ShadingMode};
    use std::io::IsTerminal;
    let t0 = Instant::now();
    check_gpu_passes(
        args.gpu_passes,
        args.backend == RenderBackendArg::Gpu,
        "--backend gpu",
    )?;
    let backend = match args.backend {
        RenderBackendArg::Interp => r::backend(BackendKind::Interp)?,
        RenderBackendArg::Jit => r::backend(BackendKind::Jit)?,
        RenderBackendArg::Gpu => {
            r::gpu_backend(gpu_options(args.gpu_passes)).context("--backend gpu")?
        }
    };
    let (exr_path, png_path) = match (&args.output, &args.png) {
        (None, None) => (
            PathBuf::from("render.exr"),
            Some(PathBuf::from("render.png")),
        ),
        (o, p) => (
            o.clone().unwrap_or_else(|| PathBuf::from("render.exr")),
            p.clone(),
        ),
    };
    if exr_path.extension().and_then(|e| e.to_str()) != Some("exr") {
        bail!("{}: -o must name an .exr file", exr_path.display());
    }
    if let Some(p) = &png_path
        && p.extension().and_then(|e| e.to_str()) != Some("png")
    {
        bail!("{}: --png must name a .png file", p.display());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start the worker threads")?;

    let (mut scene, files, dir, name) = match &args.scene {
        Some(p) => (
            shadenet::tracer::scene::load(p)?,
            Files::Disk,
            p.parent().map(Path::to_path_buf).unwrap_or_default(),
            p.display().to_string(),
        ),
        None => (
            r::default_scene()?,
            Files::Embedded,
            PathBuf::from("examples/scenes"),
            format!("{} (embedded default scene)", r::DEFAULT_SCENE_PATH),
        ),
    };
    r::apply_options(
        &mut scene,
        &RenderOptions {
            spp: args.spp,
            passes: args.passes.clone(),
            res: args.res,
        },
    )?;
    let (mut renderer, compiled) = r::prepare(scene, files, &dir, backend.as_ref())?;
    match args.shading {
        ShadingArg::Auto => {}
        ShadingArg::Immediate => renderer.set_shading_mode(ShadingMode::Immediate),
        ShadingArg::Deferred => {
            renderer.set_shading_mode(ShadingMode::Deferred(DeferredOptions::default()))
        }
    }
    let setup_time = t0.elapsed();
    if !args.quiet {
        for (m, c) in renderer.scene().materials.iter().zip(&compiled) {
            if c.ignored_lights > 0 {
                eprintln!(
                    "note: material `{}` declares {} light node(s); renders use the scene's [[lights]]",
                    m.name, c.ignored_lights
                );
            }
        }
        for w in renderer.warnings() {
            eprintln!("warning: {w}");
        }
    }

    let show = !args.quiet && std::io::stderr().is_terminal();
    let bar = show.then(|| {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} rendering [{bar:40}] {pos}/{len} tiles, {elapsed} (eta {eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        b
    });
    let progress = |done: u64, total: u64| {
        if let Some(b) = &bar {
            b.set_length(total);
            b.set_position(done);
        }
    };
    let (film, stats) = pool.install(|| renderer.render(&progress));
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    film.write_exr(&exr_path)?;
    if let Some(p) = &png_path {
        film.write_png(p)?;
    }
    if !args.quiet {
        let s = &stats;
        let render_s = s.render_time.as_secs_f64();
        let load = setup_time.saturating_sub(s.bvh_time + s.compile_time);
        let layers: Vec<&str> = film.layers.iter().map(|l| l.name.as_str()).collect();
        say!(
            "rendered {name}: {}x{}, {} spp, {} threads, backend {}, {} shading",
            film.width,
            film.height,
            renderer.scene().settings.spp,
            pool.current_num_threads(),
            backend.name(),
            match renderer.shading_mode() {
                ShadingMode::Immediate => "immediate".to_string(),
                ShadingMode::Deferred(o) =>
                    format!("deferred (groups of ≥{} samples)", o.group_samples),
            }
        );
        say!(
            "time: load {:.3} s, compile {:.3} s (shaders: {}), BVH {:.3} s (triangles: {}), render {:.3} s",
            load.as_secs_f64(),
            s.compile_time.as_secs_f64(),
            s.shaders,
            s.bvh_time.as_secs_f64(),
            s.triangles,
            render_s
        );
        say!(
            "{} rays ({:.2} M rays/s), {} shading calls, {} non-finite values caught by the guard",
            s.rays,
            s.rays as f64 / render_s.max(1e-9) / 1e6,
            s.shading_calls,
            s.nonfinite
        );
        if s.batches > 0 {
            let t = &s.batch_times;
            say!(
                "deferred shading: {} batches, {} fragments (mean {:.0}, largest {}); {} shading calls from inside traced rays ran one by one",
                s.batches,
                s.batched_fragments,
                s.batched_fragments as f64 / s.batches as f64,
                s.largest_batch,
                s.shading_calls - s.batched_fragments
            );
            say!(
                "batch time (summed over threads): upload {:.3} s, kernels {:.3} s, host {:.3} s, readback {:.3} s; {} GPU passes dispatched",
                t.upload.as_secs_f64(),
                t.kernels.as_secs_f64(),
                t.host.as_secs_f64(),
                t.readback.as_secs_f64(),
                t.passes
            );
        }
        say!(
            "wrote {} (layers: {})",
            exr_path.display(),
            layers.join(", ")
        );
        if let Some(p) = &png_path {
            say!("wrote {}", p.display());
        }
    }
    Ok(())
}

fn bench(args: BenchArgs) -> Result<()> {
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
        .any(|s| matches!(s.to_lowercase().as_str(), "b3" | "b5"));
    if wants_scenes && !args.scenes.join("cornell.toml").is_file() {
        anyhow::bail!(
            "--scenes: {} holds no example scenes (B3 and B5 render examples/scenes/*.toml): \
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

fn diff(args: &DiffArgs) -> Result<()> {
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

fn gpu_info() -> Result<()> {
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
