//! `shadenet.render`: a scene (or the embedded default) rendered to layers, set up exactly
//! as `shadenet render` sets it up (`shadenet::render::load`: the scene file or the default
//! scene, the options; then `shadenet::render::prepare`), with the GIL released while it
//! renders.

use crate::boundary::{Layers, detached, f32_bytes, shadenet_error, shadenet_msg, value_error};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shadenet::render::{self as r, BackendKind, RenderOptions, SetupError};
use shadenet::tracer::{Film, RenderStats, Renderer};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How many worker threads `threads=` may ask for per core (the CLI's `--threads` rule).
const MAX_THREADS_PER_CORE: usize = 8;

/// A rendered film and what the render reports.
type Rendered<'py> = (u32, u32, Layers<'py, String>, Bound<'py, PyDict>);

/// Renders `scene` (a `.toml` path; `None`: the embedded default scene) with the CLI's
/// overrides. Returns `(width, height, layers, stats)`, each layer `(name, channels,
/// bytes)` with `height × width × channels` f32, rows top to bottom.
#[pyfunction]
#[pyo3(signature = (scene=None, spp=None, res=None, passes=None, backend="jit", threads=None, mtlx_libraries=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn render<'py>(
    py: Python<'py>,
    scene: Option<PathBuf>,
    spp: Option<u32>,
    res: Option<(u32, u32)>,
    passes: Option<Vec<String>>,
    backend: &str,
    threads: Option<usize>,
    mtlx_libraries: Option<PathBuf>,
) -> PyResult<Rendered<'py>> {
    let t0 = Instant::now();
    let kind = match backend {
        "interp" => BackendKind::Interp,
        "jit" => BackendKind::Jit,
        "gpu" => BackendKind::Gpu,
        "jit-batch" => {
            return Err(value_error(
                "backend \"jit-batch\": not available to render yet (the renderer calls the \
                 JIT's scalar entry per hit; use backend=\"jit\")",
            ));
        }
        other => {
            return Err(value_error(format!(
                "unknown backend \"{other}\": expected interp, jit or gpu"
            )));
        }
    };
    let pool = thread_pool(threads)?;
    // The crop window (issue 17 §1) joins these options when the library has it.
    let opts = RenderOptions {
        spp,
        passes,
        res,
        ..RenderOptions::default()
    };
    let (film, stats, info) = detached(py, move || {
        let backend = r::backend(kind).map_err(|e| shadenet_error(&e))?;
        let renderer = setup(scene.as_deref(), &opts, backend.as_ref(), mtlx_libraries)?;
        let setup_time = t0.elapsed();
        let (film, stats) = pool.install(|| renderer.render(&|_, _| {}));
        let info = Info {
            spp: renderer.scene().settings.spp,
            threads: pool.current_num_threads(),
            backend: backend.name().to_string(),
            setup_s: setup_time.as_secs_f64(),
            warnings: renderer.warnings().to_vec(),
        };
        Ok((film, stats, info))
    })?;
    let d = stats_dict(py, &stats, &info)?;
    let layers = film_layers(py, &film);
    Ok((film.width, film.height, layers, d))
}

/// What the summary reports besides the film and the statistics.
struct Info {
    /// Samples per pixel rendered.
    spp: u32,
    /// Worker threads.
    threads: usize,
    /// The back end's name.
    backend: String,
    /// Seconds from the call to the first pixel (loading, compiling, BVH).
    setup_s: f64,
    /// The renderer's warnings about the scene.
    warnings: Vec<String>,
}

/// The thread pool of `threads` workers (1 to 8 × the cores; `None`: all cores).
fn thread_pool(threads: Option<usize>) -> PyResult<rayon::ThreadPool> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max = MAX_THREADS_PER_CORE * cores;
    if let Some(n) = threads
        && (n == 0 || n > max)
    {
        return Err(value_error(format!(
            "threads={n}: expected 1 to {max} ({MAX_THREADS_PER_CORE} × the {cores} cores of this machine)"
        )));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| shadenet_msg(format!("cannot start the worker threads: {e}")))
}

/// Loads the scene (or the embedded default), applies the options and compiles the
/// materials, as `shadenet render` does (`shadenet::render::load`, then `prepare`). An
/// option out of range is a `ValueError`; anything else a `ShadenetError`.
fn setup(
    scene: Option<&Path>,
    opts: &RenderOptions,
    backend: &dyn shadenet::tracer::shader::ShaderBackend,
    mtlx_libraries: Option<PathBuf>,
) -> PyResult<Renderer> {
    let (scene, files, dir) = r::load(scene, opts).map_err(|e| match e {
        SetupError::Option(m) => value_error(m),
        e => shadenet_error(&e),
    })?;
    let (renderer, _) = r::prepare(scene, files, &dir, backend, mtlx_libraries.as_deref())
        .map_err(|e| shadenet_error(&e))?;
    Ok(renderer)
}

/// The film's layers as `(name, channels, bytes)`.
fn film_layers<'py>(py: Python<'py>, film: &Film) -> Layers<'py, String> {
    film.layers
        .iter()
        .map(|l| (l.name.clone(), l.channels.clone(), f32_bytes(py, &l.data)))
        .collect()
}

/// The render's statistics as a dict (the numbers `shadenet render` prints).
fn stats_dict<'py>(py: Python<'py>, s: &RenderStats, info: &Info) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("spp", info.spp)?;
    d.set_item("threads", info.threads)?;
    d.set_item("backend", &info.backend)?;
    d.set_item("setup_s", info.setup_s)?;
    d.set_item("compile_s", s.compile_time.as_secs_f64())?;
    d.set_item("bvh_s", s.bvh_time.as_secs_f64())?;
    d.set_item("render_s", s.render_time.as_secs_f64())?;
    d.set_item("shaders", s.shaders)?;
    d.set_item("triangles", s.triangles)?;
    d.set_item("rays", s.rays)?;
    d.set_item("camera_rays", s.camera_rays)?;
    d.set_item("shadow_rays", s.shadow_rays)?;
    d.set_item("secondary_rays", s.secondary_rays)?;
    d.set_item("shading_calls", s.shading_calls)?;
    d.set_item("nonfinite", s.nonfinite)?;
    d.set_item("batches", s.batches)?;
    d.set_item("batched_fragments", s.batched_fragments)?;
    d.set_item("warnings", info.warnings.clone())?;
    Ok(d)
}
