//! `shadenet.Renderer` and `shadenet.render`: a scene (or the embedded default) rendered to
//! layers, whole or a pixel window at a time, set up exactly
//! as `shadenet render` sets it up (`shadenet::render::load`: the scene file or the default
//! scene, the options; then `shadenet::render::prepare`), with the GIL released while it
//! renders.

use crate::boundary::{Layers, detached, f32_bytes, shadenet_error, shadenet_msg, value_error};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shadenet::render::{self as r, BackendKind, RenderOptions, SetupError};
use shadenet::tracer::{Film, RenderStats, Renderer, Window};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A rendered film and what the render reports: the window's size, its layers, the
/// statistics, the window `(x0, y0, x1, y1)` and the full frame's size.
type Rendered<'py> = (
    u32,
    u32,
    Layers<'py, String>,
    Bound<'py, PyDict>,
    (u32, u32, u32, u32),
    (u32, u32),
);

/// A scene loaded and compiled once, rendered any number of times, whole or a pixel window
/// at a time (`shadenet.Renderer`; `shadenet.distributed` keeps one per worker process).
#[pyclass(frozen, name = "Renderer", module = "shadenet._native")]
pub(crate) struct NativeRenderer {
    renderer: Renderer,
    pool: rayon::ThreadPool,
    info: Info,
}

#[pymethods]
impl NativeRenderer {
    /// Loads `scene` (a `.toml` path; `None`: the embedded default scene), applies the
    /// CLI's overrides and compiles its materials, with the GIL released.
    #[new]
    #[pyo3(signature = (scene=None, spp=None, res=None, passes=None, backend="jit", threads=None, mtlx_libraries=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        scene: Option<PathBuf>,
        spp: Option<u32>,
        res: Option<(u32, u32)>,
        passes: Option<Vec<String>>,
        backend: &str,
        threads: Option<usize>,
        mtlx_libraries: Option<PathBuf>,
    ) -> PyResult<NativeRenderer> {
        let t0 = Instant::now();
        let kind = backend_kind(backend)?;
        let pool = thread_pool(threads)?;
        let opts = RenderOptions {
            spp,
            passes,
            res,
            ..RenderOptions::default()
        };
        let threads = pool.current_num_threads();
        let (renderer, name) = detached(py, move || {
            let backend = r::backend(kind).map_err(|e| shadenet_error(&e))?;
            let renderer = setup(scene.as_deref(), &opts, backend.as_ref(), mtlx_libraries)?;
            Ok((renderer, backend.name().to_string()))
        })?;
        let info = Info {
            spp: renderer.scene().settings.spp,
            threads,
            backend: name,
            setup_s: t0.elapsed().as_secs_f64(),
            warnings: renderer.warnings().to_vec(),
        };
        Ok(NativeRenderer {
            renderer,
            pool,
            info,
        })
    }

    /// The full frame's size `(width, height)`.
    #[getter]
    fn frame(&self) -> (u32, u32) {
        let c = &self.renderer.scene().camera;
        (c.width, c.height)
    }

    /// Samples per pixel.
    #[getter]
    fn spp(&self) -> u32 {
        self.info.spp
    }

    /// Renders the frame, or only the pixel window `crop = (x0, y0, x1, y1)` (ends
    /// exclusive), whose pixels get exactly the bits of a full render. Returns `(width,
    /// height, layers, stats, window, frame)`.
    #[pyo3(signature = (crop=None))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        crop: Option<(u32, u32, u32, u32)>,
    ) -> PyResult<Rendered<'py>> {
        let (fw, fh) = self.frame();
        let window = match crop {
            Some((x0, y0, x1, y1)) => Window::new([x0, y0, x1, y1], (fw, fh))
                .map_err(|e| value_error(format!("crop: {e}")))?,
            None => Window::full(fw, fh),
        };
        let (film, stats) = detached(py, || {
            Ok(self
                .pool
                .install(|| self.renderer.render_window(window, &|_, _| {})))
        })?;
        let d = stats_dict(py, &stats, &self.info)?;
        let layers = film_layers(py, &film);
        let w = film.window;
        Ok((
            film.width,
            film.height,
            layers,
            d,
            (w.x0, w.y0, w.x1, w.y1),
            film.frame,
        ))
    }
}

/// The frame size `(width, height)` of `scene` (`None`: the embedded default scene) with the
/// `res` override: the scene loaded and checked, nothing compiled.
#[pyfunction]
#[pyo3(signature = (scene=None, res=None))]
pub(crate) fn frame_size(
    py: Python<'_>,
    scene: Option<PathBuf>,
    res: Option<(u32, u32)>,
) -> PyResult<(u32, u32)> {
    let opts = RenderOptions {
        res,
        ..RenderOptions::default()
    };
    detached(py, move || {
        let (scene, _, _) = r::load(scene.as_deref(), &opts).map_err(load_error)?;
        Ok((scene.camera.width, scene.camera.height))
    })
}

/// The back end named `name`, or a `ValueError` listing the ones a render can use.
fn backend_kind(name: &str) -> PyResult<BackendKind> {
    match name {
        "interp" => Ok(BackendKind::Interp),
        "jit" => Ok(BackendKind::Jit),
        "gpu" => Ok(BackendKind::Gpu),
        "jit-batch" => Err(value_error(
            "backend \"jit-batch\": not available to render yet (the renderer calls the \
             JIT's scalar entry per hit; use backend=\"jit\")",
        )),
        other => Err(value_error(format!(
            "unknown backend \"{other}\": expected interp, jit or gpu"
        ))),
    }
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
    if let Some(n) = threads {
        r::check_threads(n).map_err(|e| value_error(format!("threads={e}")))?;
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
    let (scene, files, dir) = r::load(scene, opts).map_err(load_error)?;
    let (renderer, _) = r::prepare(scene, files, &dir, backend, mtlx_libraries.as_deref())
        .map_err(|e| shadenet_error(&e))?;
    Ok(renderer)
}

/// An option out of range is a `ValueError`; anything else a `ShadenetError`.
fn load_error(e: SetupError) -> PyErr {
    match e {
        SetupError::Option(m) => value_error(m),
        e => shadenet_error(&e),
    }
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
