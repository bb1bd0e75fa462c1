//! The subcommands of the `shadenet` command line, one file each, and the option groups
//! they share (specialization flags, back-end choice, GPU pass partitioning, threads).
//!
//! This module owns argument checking and what the commands print; the work itself is the
//! library's (`shadenet::render`, `shadenet::shade`, `shadenet::bench`…). It must not hold
//! rendering or shading logic of its own.

/// `println!` through [`print_out`]: a closed pipe ends the output quietly instead of
/// panicking.
macro_rules! say {
    ($($arg:tt)*) => {
        print_out(&format!("{}\n", format_args!($($arg)*)))
    };
}

pub mod bench;
pub mod check;
pub mod compile;
pub mod diff;
pub mod generate;
pub mod gpu_info;
pub mod merge;
pub mod mtlx_coverage;
pub mod render;
pub mod shade;

use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use shadenet::graph::opt::Specialization;
use shadenet_gpu::{GpuOptions, PassMode};
use std::path::Path;

/// The back end that runs a material (`--backend`), shared by `shade` and `render`.
#[derive(Clone, Copy, ValueEnum, PartialEq, Debug)]
pub(crate) enum BackendArg {
    /// The interpreter.
    Interp,
    /// The Cranelift JIT, scalar entry (one call per fragment or hit).
    Jit,
    /// The Cranelift JIT, its batch entry: four-lane packets, a row per call (`shade` only).
    JitBatch,
    /// The GPU (wgpu): `shade` runs the whole grid in one batch; `render` shades camera hits
    /// deferred in batches and the JIT shades secondary hits.
    Gpu,
}

impl BackendArg {
    /// The name as written on the command line.
    pub(crate) fn name(self) -> &'static str {
        match self {
            BackendArg::Interp => "interp",
            BackendArg::Jit => "jit",
            BackendArg::JitBatch => "jit-batch",
            BackendArg::Gpu => "gpu",
        }
    }
}

/// `--gpu-passes`, shared by `shade`, `render` and `compile --emit wgsl`.
#[derive(clap::Args, Clone, Copy)]
pub(crate) struct GpuPassesArg {
    /// GPU pass partitioning (with `--backend gpu` or `--emit wgsl`): `auto` (the cost
    /// model), `1` (one kernel between host steps) or a pass count.
    #[arg(long, value_name = "auto|1|N", value_parser = parse_gpu_passes)]
    pub(crate) gpu_passes: Option<PassMode>,
}

fn parse_gpu_passes(s: &str) -> Result<PassMode, String> {
    s.parse::<PassMode>()
}

impl GpuPassesArg {
    /// The GPU back end's options.
    pub(crate) fn options(&self) -> GpuOptions {
        GpuOptions {
            passes: self.gpu_passes.unwrap_or_default(),
            ..GpuOptions::default()
        }
    }

    /// `--gpu-passes` only means something to the GPU back end (`what` names it).
    pub(crate) fn check(&self, gpu: bool, what: &str) -> Result<()> {
        if self.gpu_passes.is_some() && !gpu {
            bail!("--gpu-passes applies to {what} only");
        }
        Ok(())
    }
}

/// `--threads`, shared by `shade` and `render`.
#[derive(clap::Args, Clone, Copy)]
pub(crate) struct ThreadsArg {
    /// Worker threads, 1 to 8 × the cores (default: all cores).
    #[arg(long)]
    pub(crate) threads: Option<usize>,
}

impl ThreadsArg {
    /// The checked count (`None`: all cores), or an error naming the range.
    pub(crate) fn count(&self) -> Result<Option<usize>> {
        self.threads
            .map(|n| {
                shadenet::render::check_threads(n).map_err(|e| anyhow::anyhow!("--threads {e}"))
            })
            .transpose()
    }

    /// A thread pool of the checked size.
    pub(crate) fn pool(&self) -> Result<rayon::ThreadPool> {
        rayon::ThreadPoolBuilder::new()
            .num_threads(self.count()?.unwrap_or(0))
            .build()
            .context("cannot start the worker threads")
    }
}

/// Checks that an output path ends in one of `exts`; `what` names the option.
pub(crate) fn check_extension(path: &Path, exts: &[&str], what: &str) -> Result<()> {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if exts.contains(&e) => Ok(()),
        _ => bail!(
            "{}: {what} must name a {} file",
            path.display(),
            exts.iter()
                .map(|e| format!(".{e}"))
                .collect::<Vec<_>>()
                .join(" or ")
        ),
    }
}

/// How a network is specialized and optimized (shared by `compile` and `shade`).
#[derive(clap::Args, Clone)]
pub(crate) struct OptArgs {
    /// Active render components, comma separated (default: all).
    #[arg(long, value_delimiter = ',')]
    pub(crate) components: Option<Vec<String>>,
    /// Ray types the material will see: camera, shadow, reflection, refraction, diffuse
    /// (default: all).
    #[arg(long, value_delimiter = ',')]
    pub(crate) raytypes: Option<Vec<String>>,
    /// Instance compilation: bake parameters into constants (the default).
    #[arg(long, conflicts_with = "class")]
    pub(crate) bake: bool,
    /// Class compilation: keep parameters uniform (they can change without recompiling).
    #[arg(long)]
    pub(crate) class: bool,
    /// Switch common-subexpression elimination off (to measure per-node cost).
    #[arg(long)]
    pub(crate) no_cse: bool,
    /// Switch passes off, comma separated: specialize, fold, dead_branch, unroll, cse, dce, hoist.
    #[arg(long, value_delimiter = ',')]
    pub(crate) disable: Vec<String>,
    /// Do not optimize at all.
    #[arg(long)]
    pub(crate) no_opt: bool,
}

impl OptArgs {
    pub(crate) fn spec(&self, program: &shadenet::graph::ir::Program) -> Result<Specialization> {
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
                "unroll" => &mut spec.passes.unroll,
                other => bail!(
                    "--disable: `{other}` is not a pass (specialize, fold, dead_branch, unroll, cse, dce, hoist)"
                ),
            };
            *flag = false;
        }
        Ok(spec)
    }
}

pub(crate) fn parse_res(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}` is not WxH"))?;
    let w: u32 = w.parse().map_err(|_| format!("bad width in `{s}`"))?;
    let h: u32 = h.parse().map_err(|_| format!("bad height in `{s}`"))?;
    let max = shadenet::tracer::scene::MAX_RESOLUTION;
    if w == 0 || h == 0 || w > max || h > max {
        return Err(format!(
            "resolution `{s}` must be between 1x1 and {max}x{max}"
        ));
    }
    Ok((w, h))
}

/// Milliseconds of a duration, for the summaries.
pub(crate) fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Writes to stdout; a closed pipe (`| head`) ends the output quietly.
pub(crate) fn print_out(text: &str) {
    use std::io::Write;
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}

/// The summary line of what shaders printed (`None` when they printed nothing).
pub(crate) fn messages_line(m: &shadenet::runtime::messages::Messages) -> Option<String> {
    use shadenet::graph::ir::Severity;
    (!m.is_empty()).then(|| {
        let dropped = if m.dropped > 0 {
            format!(", {} dropped", m.dropped)
        } else {
            String::new()
        };
        format!(
            "shader messages: {} printf, {} warnings, {} errors{dropped}",
            m.count(Severity::Printf),
            m.count(Severity::Warning),
            m.errors()
        )
    })
}

/// Writes what shaders printed, in the order given: `printf` output to standard output as
/// it is (a shader ends its own lines), warnings and errors to standard error as `WARNING:`
/// and `ERROR:` lines (OSL's error handler's form), then how many the log dropped.
pub(crate) fn print_messages(m: &shadenet::runtime::messages::Messages) {
    use shadenet::graph::ir::Severity;
    for msg in &m.list {
        match msg.severity {
            Severity::Printf => print_out(&msg.text),
            s => {
                let tag = if s == Severity::Error {
                    "ERROR"
                } else {
                    "WARNING"
                };
                eprintln!("{tag}: {}", msg.text.trim_end_matches('\n'));
            }
        }
    }
    if m.dropped > 0 {
        eprintln!(
            "warning: {} shader messages dropped (a thread's log holds at most {} MiB)",
            m.dropped,
            shadenet::runtime::messages::LOG_LIMIT >> 20
        );
    }
}

/// The source options of `check`, `compile` and `shade`: MaterialX (`.mtlx` files) and the
/// shader preprocessor (`.sl`, `.osl`).
#[derive(clap::Args, Clone, Default)]
pub(crate) struct SourceArgs {
    /// A folder `#include` searches in shader sources (.sl, .osl), after the including
    /// file's own; repeatable.
    #[arg(short = 'I', value_name = "DIR")]
    pub(crate) include: Vec<std::path::PathBuf>,
    /// The file is an OSL shader group in OSL's serialized text (`param`, `shader`,
    /// `connect` statements; the default for `.oslgroup` files): each shader's source is
    /// `NAME.osl` beside the group file or in an -I folder.
    #[arg(long)]
    pub(crate) group: bool,
    /// A preprocessor macro for shader sources: NAME or NAME=VALUE; repeatable.
    #[arg(short = 'D', value_name = "NAME[=VALUE]")]
    pub(crate) define: Vec<String>,
    /// Sets a material parameter's value before compiling: NAME=X for a float or int,
    /// NAME=R,G,B (or one number) for a color or vector; a shader's parameters are named as
    /// in its source, a network's `node.input`; repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub(crate) param: Vec<String>,
    /// The MaterialX `libraries` folder (default: SHADENET_MTLX_LIBRARIES, then each
    /// MATERIALX_SEARCH_PATH entry's `libraries/`).
    #[arg(long, value_name = "DIR")]
    pub(crate) mtlx_libraries: Option<std::path::PathBuf>,
    /// Shade this material of a .mtlx document (closures: not built yet, issue 15).
    #[arg(long, value_name = "NAME", conflicts_with = "mtlx_output")]
    pub(crate) material: Option<String>,
    /// Shade this output of a .mtlx document: a top-level <output>, a nodegraph (all its
    /// outputs) or `nodegraph/output` (default: every output).
    #[arg(long, value_name = "NAME")]
    pub(crate) mtlx_output: Option<String>,
    /// A uniform geometric property of the shaded geometry, NAME=VALUE, which a .mtlx
    /// document's string-valued `geompropvalueuniform` nodes read (a scene gives them per
    /// instance: `geomprops = { NAME = "VALUE" }`); repeatable.
    #[arg(long = "geomprop", value_name = "NAME=VALUE", value_parser = geomprop)]
    pub(crate) geomprops: Vec<(String, String)>,
}

/// Parses `--geomprop NAME=VALUE`.
fn geomprop(s: &str) -> std::result::Result<(String, String), String> {
    match s.split_once('=') {
        Some((n, v)) if !n.is_empty() => Ok((n.to_string(), v.to_string())),
        _ => Err(format!("`{s}`: expected NAME=VALUE")),
    }
}

impl SourceArgs {
    fn options(&self) -> shadenet::MtlxOptions {
        shadenet::MtlxOptions {
            libraries: self.mtlx_libraries.clone(),
            selection: shadenet::graph::mtlx::Selection {
                material: self.material.clone(),
                output: self.mtlx_output.clone(),
                geomprops: self.geomprops.iter().cloned().collect(),
            },
        }
    }
}

/// Applies `--param NAME=VALUE` options to a program's parameters.
fn set_params(program: &mut shadenet::graph::ir::Program, params: &[String]) -> Result<()> {
    for p in params {
        let Some((name, value)) = p.split_once('=') else {
            bail!("--param {p}: expected NAME=VALUE");
        };
        let values: Option<Vec<f64>> = value.split(',').map(|x| x.trim().parse().ok()).collect();
        let Some(values) = values else {
            bail!("--param {p}: `{value}` is not a number or comma-separated numbers");
        };
        shadenet::shader::set_param(program, name.trim(), &values)
            .map_err(|e| anyhow::anyhow!("--param {p}: {e}"))?;
    }
    Ok(())
}

/// Reads, links and lowers a network file (`.json`, or `.mtlx` with `mtlx`'s options) and
/// validates its IR; a shader source must be a surface shader.
pub(crate) fn load(path: &Path, mtlx: &SourceArgs) -> Result<shadenet::Compiled> {
    load_source(path, mtlx, false)
}

/// [`load`], also taking a light shader when `lights_too` (`check` and `compile` show its
/// light program).
pub(crate) fn load_source(
    path: &Path,
    mtlx: &SourceArgs,
    lights_too: bool,
) -> Result<shadenet::Compiled> {
    let is_mtlx = path.extension().is_some_and(|e| e == "mtlx");
    let is_shader = mtlx.group
        || path
            .extension()
            .is_some_and(|e| e == "sl" || e == "osl" || e == shadenet::shader::GROUP_EXTENSION);
    let preprocessor = !(mtlx.include.is_empty() && mtlx.define.is_empty());
    if preprocessor && !is_shader {
        bail!("-I and -D apply to shader sources (.sl, .osl, .oslgroup) only");
    }
    if is_shader {
        let mut compiled = if mtlx.group {
            shadenet::shader::load_group(path, &mtlx.include, &mtlx.define)?
        } else if lights_too {
            shadenet::shader::load_any(path, &mtlx.include, &mtlx.define)?.0
        } else {
            shadenet::shader::load(path, &mtlx.include, &mtlx.define)?
        };
        set_params(&mut compiled.program, &mtlx.param)?;
        shadenet::graph::ir::validate(&compiled.program)
            .with_context(|| format!("{}: internal error: invalid IR", path.display()))?;
        return Ok(compiled);
    }
    if !is_mtlx && (mtlx.material.is_some() || mtlx.mtlx_output.is_some()) {
        bail!("--material and --mtlx-output apply to .mtlx documents only");
    }
    let mut compiled = if is_mtlx {
        shadenet::compile_mtlx(path, &mtlx.options())?
    } else {
        shadenet::load_network(path)?
    };
    set_params(&mut compiled.program, &mtlx.param)?;
    shadenet::graph::ir::validate(&compiled.program)
        .with_context(|| format!("{}: internal error: invalid IR", path.display()))?;
    Ok(compiled)
}
