//! `shadenet render`: a scene (or the embedded default) rendered to a multi-layer EXR and a
//! PNG preview, with progress on a terminal and a summary of where the time went.

use super::{BackendArg, GpuPassesArg, ThreadsArg, check_extension, parse_res, print_out};
use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use shadenet::render::{self as r, BackendKind, CompiledMaterial, RenderOptions};
use shadenet::tracer::render::StageTimes;
use shadenet::tracer::shader::ShaderBackend;
use shadenet::tracer::{DeferredOptions, Film, RenderStats, Renderer, ShadingMode, Window};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// `--shading`: how camera hits are shaded.
#[derive(Clone, Copy, ValueEnum, PartialEq)]
pub(crate) enum ShadingArg {
    /// The back end decides.
    Auto,
    /// Each camera hit as it is found.
    Immediate,
    /// Camera hits in batches.
    Deferred,
}

/// `shadenet render`'s arguments.
#[derive(clap::Args)]
pub(crate) struct RenderArgs {
    /// The scene file (.toml); without one, the embedded default scene.
    scene: Option<PathBuf>,
    /// Output EXR (every pass as f32 layers). Default: render.exr, plus render.png when
    /// --png is not given either.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Also write a tone-mapped sRGB PNG preview of the beauty pass.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Back end that runs the materials: `interp`, `jit` (scalar entry, one call per hit)
    /// or `gpu` (camera hits shaded deferred, in batches; the JIT shades secondary hits).
    #[arg(long, value_enum, default_value_t = BackendArg::Jit)]
    backend: BackendArg,
    #[command(flatten)]
    gpu: GpuPassesArg,
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
    /// Render only this pixel window of the frame: columns X0..X1 and rows Y0..Y1 from the
    /// top left, ends exclusive. Its pixels get exactly the bits a full render gives them;
    /// the EXR's data window is the crop inside the full frame (`shadenet merge` assembles
    /// the parts).
    #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = parse_crop)]
    crop: Option<[u32; 4]>,
    /// How closures gather area lights and the environment (overrides the scene's
    /// `render.light_strategy`): `mis` (light sampling and BSDF sampling, power heuristic),
    /// `light` (light sampling only) or `bsdf` (BSDF sampling only; point, spot and distant
    /// lights stay light-sampled).
    #[arg(long, value_parser = parse_strategy)]
    light_strategy: Option<shadenet::graph::LightStrategy>,
    #[command(flatten)]
    threads: ThreadsArg,
    /// The MaterialX `libraries` folder for materials given as `mtlx = "…"` (default:
    /// SHADENET_MTLX_LIBRARIES, then each MATERIALX_SEARCH_PATH entry's `libraries/`).
    #[arg(long, value_name = "DIR")]
    mtlx_libraries: Option<PathBuf>,
    /// Print nothing but errors (no progress bar, no summary).
    #[arg(short, long)]
    quiet: bool,
}

/// `--crop X0,Y0,X1,Y1`: four whole numbers (checked against the frame after the scene is
/// loaded).
fn parse_crop(s: &str) -> Result<[u32; 4], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let nums: Vec<u32> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    match <[u32; 4]>::try_from(nums) {
        Ok(c) if parts.len() == 4 => Ok(c),
        _ => Err(format!(
            "`{s}`: expected X0,Y0,X1,Y1, four whole numbers ≥ 0 (ends exclusive)"
        )),
    }
}

fn parse_strategy(s: &str) -> Result<shadenet::graph::LightStrategy, String> {
    s.parse()
}

/// Runs `shadenet render`.
pub(crate) fn run(args: RenderArgs) -> Result<()> {
    let t0 = Instant::now();
    args.gpu
        .check(args.backend == BackendArg::Gpu, "--backend gpu")?;
    let backend = match args.backend {
        BackendArg::Interp => r::backend(BackendKind::Interp)?,
        BackendArg::Jit => r::backend(BackendKind::Jit)?,
        BackendArg::Gpu => r::gpu_backend(args.gpu.options()).context("--backend gpu")?,
        BackendArg::JitBatch => bail!(
            "--backend jit-batch: not available to render yet (the renderer calls the JIT's \
             scalar entry per hit; use --backend jit)"
        ),
    };
    let (exr_path, png_path) = output_paths(&args)?;
    let pool = args.threads.pool()?;
    let (mut renderer, compiled, name) = setup(&args, backend.as_ref())?;
    match args.shading {
        ShadingArg::Auto => {}
        ShadingArg::Immediate => renderer.set_shading_mode(ShadingMode::Immediate),
        ShadingArg::Deferred => {
            renderer.set_shading_mode(ShadingMode::Deferred(DeferredOptions::default()))
        }
    }
    let frame = (
        renderer.scene().camera.width,
        renderer.scene().camera.height,
    );
    let window = match args.crop {
        Some(c) => Window::new(c, frame).map_err(|e| anyhow::anyhow!("--crop: {e}"))?,
        None => Window::full(frame.0, frame.1),
    };
    let setup_time = t0.elapsed();
    if !args.quiet {
        notes(&renderer, &compiled);
    }
    let (film, stats) = pool.install(|| render_with_progress(&renderer, window, args.quiet));
    // What shaders printed (printf, warning, error), gathered from every thread's log: in
    // the order each thread shaded, threads one after another (a render's hits are not in
    // pixel order; `shade` prints in fragment order).
    let mut messages = shadenet::runtime::messages::take();
    for m in pool.broadcast(|_| shadenet::runtime::messages::take()) {
        messages.append(m);
    }
    super::print_messages(&messages);
    if let Some(line) = super::messages_line(&messages).filter(|_| !args.quiet) {
        say!("{line}");
    }
    // Each file is written to a temporary name and renamed: an error leaves any existing
    // output untouched.
    film.write_exr(&exr_path)?;
    if let Some(p) = &png_path {
        film.write_png(p)?;
    }
    if !args.quiet {
        let run = Run {
            name: &name,
            renderer: &renderer,
            backend: backend.as_ref(),
            threads: pool.current_num_threads(),
            setup_time,
        };
        summary(&run, &film, &stats);
        say!(
            "wrote {} (layers: {})",
            exr_path.display(),
            film.layers
                .iter()
                .map(|l| l.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
        if let Some(p) = &png_path {
            say!("wrote {}", p.display());
        }
    }
    Ok(())
}

/// The EXR and optional PNG paths: `render.exr` and `render.png` when neither is given.
fn output_paths(args: &RenderArgs) -> Result<(PathBuf, Option<PathBuf>)> {
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
    check_extension(&exr_path, &["exr"], "-o")?;
    if let Some(p) = &png_path {
        check_extension(p, &["png"], "--png")?;
    }
    Ok((exr_path, png_path))
}

/// Loads the scene (or the embedded default), applies the options and compiles the
/// materials; also returns the scene's name for the summary.
fn setup(
    args: &RenderArgs,
    backend: &dyn ShaderBackend,
) -> Result<(Renderer, Vec<CompiledMaterial>, String)> {
    let name = match &args.scene {
        Some(p) => p.display().to_string(),
        None => format!("{} (embedded default scene)", r::DEFAULT_SCENE_PATH),
    };
    let (scene, files, dir) = r::load(
        args.scene.as_deref(),
        &RenderOptions {
            spp: args.spp,
            passes: args.passes.clone(),
            res: args.res,
            light_strategy: args.light_strategy,
        },
    )?;
    let (renderer, compiled) =
        r::prepare(scene, files, &dir, backend, args.mtlx_libraries.as_deref())?;
    Ok((renderer, compiled, name))
}

/// Notes on light nodes the render ignores, and the renderer's warnings.
fn notes(renderer: &Renderer, compiled: &[CompiledMaterial]) {
    for (m, c) in renderer.scene().materials.iter().zip(compiled) {
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

/// Renders, with a progress bar when stderr is a terminal and `quiet` is off.
fn render_with_progress(renderer: &Renderer, window: Window, quiet: bool) -> (Film, RenderStats) {
    use std::io::IsTerminal;
    let show = !quiet && std::io::stderr().is_terminal();
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
    let result = renderer.render_window(window, &progress);
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    result
}

/// What the summary reports besides the film and the statistics.
struct Run<'a> {
    name: &'a str,
    renderer: &'a Renderer,
    backend: &'a dyn ShaderBackend,
    threads: usize,
    setup_time: Duration,
}

/// The summary: size, samples, threads, back end and mode; the time split; rays and shading
/// calls; the texture cache; the deferred batches.
fn summary(run: &Run, film: &Film, s: &RenderStats) {
    let render_s = s.render_time.as_secs_f64();
    let load = run.setup_time.saturating_sub(s.bvh_time + s.compile_time);
    let size = if film.window == Window::full(film.frame.0, film.frame.1) {
        format!("{}x{}", film.width, film.height)
    } else {
        format!(
            "region {} ({}x{}) of {}x{}",
            film.window, film.width, film.height, film.frame.0, film.frame.1
        )
    };
    say!(
        "rendered {}: {size}, {} spp, {} threads, backend {}, {} shading",
        run.name,
        run.renderer.scene().settings.spp,
        run.threads,
        run.backend.name(),
        match run.renderer.shading_mode() {
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
    if s.loop_limits > 0 {
        say!(
            "{} loop executions stopped at the iteration limit ({} iterations): a shader loop that does not end",
            s.loop_limits,
            shadenet::graph::ir::LOOP_ITERATION_LIMIT
        );
    }
    // The texture cache's files, hits, evictions and resident bytes (when any were opened).
    let textures = shadenet_runtime::texture::stats();
    if textures.files_opened + textures.cache_hits > 0 {
        say!("{textures}");
    }
    let rate = |n: u64| n as f64 / render_s.max(1e-9) / 1e6;
    say!(
        "rays by kind: camera {} ({:.2} M/s), shadow {} ({:.2} M/s), secondary {} ({:.2} M/s)",
        s.camera_rays,
        rate(s.camera_rays),
        s.shadow_rays,
        rate(s.shadow_rays),
        s.secondary_rays,
        rate(s.secondary_rays)
    );
    say!("{}", stage_split(&s.stages));
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
}

/// The time split by stage (summed over threads), with each stage's share; the traversal
/// of shadow and secondary rays is a sampled estimate inside shading.
fn stage_split(t: &StageTimes) -> String {
    let total = (t.sample + t.trace + t.shade + t.film)
        .as_secs_f64()
        .max(1e-9);
    let part = |name: &str, d: Duration| {
        format!(
            "{name} {:.3} s ({:.0} %)",
            d.as_secs_f64(),
            100.0 * d.as_secs_f64() / total
        )
    };
    let nested = t.shadow_trace + t.secondary_trace;
    format!(
        "stages (thread time): {}, {}, {} [of which shadow-ray traversal ≈ {:.3} s, secondary-ray traversal ≈ {:.3} s], {}; shading without nested traversal ≈ {:.3} s",
        part("sample", t.sample),
        part("trace camera rays", t.trace),
        part("shade", t.shade),
        t.shadow_trace.as_secs_f64(),
        t.secondary_trace.as_secs_f64(),
        part("film", t.film),
        t.shade.saturating_sub(nested).as_secs_f64()
    )
}
