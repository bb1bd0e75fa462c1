//! `shadenet.compile` and the compiled material: loading a network (a `.json`, `.mtlx` or `.sl`
//! file, or either as text) as the CLI's `load` does, its optimized IR and statistics as
//! `compile --emit ir --stats` reports them, and shading fragments with a chosen back end.

use crate::boundary::{Layers, detached, f32_bytes, shadenet_error, shadenet_msg, value_error};
use crate::fragments::fragments;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shadenet::graph::ir::Program;
use shadenet::graph::nodes::LightDesc;
use shadenet::graph::opt::{self, Report, Specialization, StopReason};
use shadenet::runtime::{Backend, InterpBackend, Material};
use shadenet::shade::{BatchMode, grid_env, output_layers, output_slots, shade_fragments};
use shadenet::{Compiled, MtlxOptions};
use shadenet_gpu::{GpuBackend, GpuOptions};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

/// The back ends `Material.shade` accepts, as the CLI's `shade --backend` names them.
const BACKENDS: &str = "interp, jit, jit-batch or gpu";

/// What `compile` reads: a file, or network text in one of the two formats.
enum Source<'a> {
    /// A `.json` network, `.mtlx` document or `.sl` shader on disk.
    Path(&'a Path),
    /// The JSON text of a network.
    Json(&'a str),
    /// The XML text of a MaterialX document.
    Mtlx(&'a str),
}

/// The options of `compile` besides the source.
struct Options {
    /// The MaterialX `libraries` folder (else the environment's).
    mtlx_libraries: Option<PathBuf>,
    /// The material of a MaterialX document to compile.
    material: Option<String>,
    /// The output of a MaterialX document to compile.
    output: Option<String>,
}

impl Options {
    /// The MaterialX options of the library.
    fn mtlx(&self) -> MtlxOptions {
        MtlxOptions {
            libraries: self.mtlx_libraries.clone(),
            selection: shadenet::graph::mtlx::Selection {
                material: self.material.clone(),
                output: self.output.clone(),
                ..Default::default()
            },
        }
    }
}

/// Loads and validates a network as the CLI's `load` (src/cli/mod.rs) does; text sources
/// have their relative texture paths resolved against the current directory.
fn load(source: &Source, opts: &Options) -> PyResult<Compiled> {
    let mtlx_only = opts.material.is_some() || opts.output.is_some();
    let (compiled, place) = match source {
        Source::Path(path) => {
            let is_mtlx = path.extension().is_some_and(|e| e == "mtlx");
            if !is_mtlx && mtlx_only {
                return Err(value_error(
                    "material= and output= apply to MaterialX documents only",
                ));
            }
            let is_shader = path.extension().is_some_and(|e| e == "sl" || e == "osl");
            let c = if is_mtlx {
                shadenet::compile_mtlx(path, &opts.mtlx()).map_err(|e| shadenet_error(&e))?
            } else if is_shader {
                shadenet::shader::load(path, &[], &[]).map_err(|e| shadenet_error(&e))?
            } else {
                shadenet::load_network(path).map_err(|e| shadenet_error(&e))?
            };
            (c, path.display().to_string())
        }
        Source::Json(text) => {
            if mtlx_only {
                return Err(value_error(
                    "material= and output= apply to MaterialX documents only",
                ));
            }
            let mut c = shadenet::compile_json(text, &shadenet::NodeLibrary::standard())
                .map_err(|e| shadenet_msg(format!("<network text>: {}", chain(&e))))?;
            c.program.resolve_textures(&current_dir());
            (c, "<network text>".to_string())
        }
        Source::Mtlx(text) => {
            let o = opts.mtlx();
            let lib = shadenet::mtlx::locate(o.libraries.as_deref())
                .and_then(|dir| shadenet::mtlx::library(&dir))
                .map_err(|e| shadenet_error(&e))?;
            let mut c = shadenet::graph::mtlx::compile("<MaterialX text>", text, lib, &o.selection)
                .map_err(|e| shadenet_error(&e))?;
            c.program.resolve_textures(&current_dir());
            (c, "<MaterialX text>".to_string())
        }
    };
    shadenet::graph::ir::validate(&compiled.program).map_err(|e| {
        shadenet_msg(format!(
            "{place}: internal error: invalid IR: {}",
            chain(&e)
        ))
    })?;
    Ok(compiled)
}

/// An error and its causes, outermost first, joined by `: `.
fn chain(e: &dyn std::error::Error) -> String {
    shadenet::graph::error_chain(e)
}

/// The directory relative texture paths of network text are resolved against.
fn current_dir() -> PathBuf {
    std::env::current_dir().unwrap_or_default()
}

/// A compiled material (`shadenet.Material` wraps it): the linked program, its optimized
/// form for the default specialization, and the back ends' compiled materials, made on
/// first use per (back end, component mask).
#[pyclass(frozen, module = "shadenet._native")]
pub(crate) struct NativeMaterial {
    /// The linked, unoptimized program.
    program: Program,
    /// The network's light nodes.
    lights: Vec<LightDesc>,
    /// The program optimized for the default specialization (every component and ray type,
    /// parameters baked): what `compile --emit ir` prints.
    optimized: Program,
    /// What the optimizer did.
    report: Report,
    /// `Some(path)` for a `.mtlx` file (its lobe statistics are read from it).
    mtlx_path: Option<(PathBuf, MtlxOptions)>,
    /// The JIT's compile statistics line (`compile --stats`), made on first use.
    jit_stats: OnceLock<String>,
    /// Compiled materials by (back end, mask).
    cache: Mutex<HashMap<(String, u32), Arc<dyn Material>>>,
}

/// Compiles a network. `kind` says what `source` is: `"path"`, `"json"` (network text) or
/// `"mtlx"` (MaterialX text); the GIL is released while it compiles.
#[pyfunction]
#[pyo3(signature = (source, kind, name=None, mtlx_libraries=None, material=None, output=None))]
pub(crate) fn compile(
    py: Python<'_>,
    source: String,
    kind: &str,
    name: Option<String>,
    mtlx_libraries: Option<PathBuf>,
    material: Option<String>,
    output: Option<String>,
) -> PyResult<NativeMaterial> {
    let opts = Options {
        mtlx_libraries,
        material,
        output,
    };
    let path = PathBuf::from(&source);
    let src = match kind {
        "path" => Source::Path(&path),
        "json" => Source::Json(&source),
        "mtlx" => Source::Mtlx(&source),
        other => {
            return Err(value_error(format!(
                "source kind `{other}`: expected path, json or mtlx"
            )));
        }
    };
    let mtlx_path = match &src {
        Source::Path(p) if p.extension().is_some_and(|e| e == "mtlx") => {
            Some((p.to_path_buf(), opts.mtlx()))
        }
        _ => None,
    };
    detached(py, move || {
        let mut compiled = load(&src, &opts)?;
        if let Some(n) = name {
            compiled.program.name = n;
        }
        let (optimized, report) = opt::run(&compiled.program, &Specialization::default());
        shadenet::graph::ir::validate(&optimized).map_err(|e| {
            shadenet_msg(format!(
                "internal error: the optimizer produced invalid IR: {}",
                chain(&e)
            ))
        })?;
        Ok(NativeMaterial {
            program: compiled.program,
            lights: compiled.lights,
            optimized,
            report,
            mtlx_path,
            jit_stats: OnceLock::new(),
            cache: Mutex::new(HashMap::new()),
        })
    })
}

#[pymethods]
impl NativeMaterial {
    /// The material's name (the file's stem unless the network names it, or `name=`).
    #[getter]
    fn name(&self) -> &str {
        &self.program.name
    }

    /// The optimized program's text form, as `shadenet compile --emit ir` prints it.
    #[getter]
    fn ir(&self) -> String {
        self.optimized.to_string()
    }

    /// The unoptimized program's text form (`compile --emit ir:before`).
    #[getter]
    fn ir_before(&self) -> String {
        self.program.to_string()
    }

    /// What `shadenet compile --stats` reports, as a dict (see docs/python.md).
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let r = &self.report;
        let d = PyDict::new(py);
        d.set_item("ops_before", r.ops_before)?;
        d.set_item("ops_after", r.ops_after)?;
        d.set_item("rounds", r.rounds)?;
        d.set_item(
            "stop",
            match r.stop {
                StopReason::FixedPoint => "fixed point",
                StopReason::Budget => "budget exhausted",
            },
        )?;
        d.set_item("optimize_s", r.time.as_secs_f64())?;
        let passes = pyo3::types::PyList::empty(py);
        for s in &r.passes {
            let p = PyDict::new(py);
            p.set_item("pass", s.pass)?;
            p.set_item("ops_before", s.ops_before)?;
            p.set_item("ops_after", s.ops_after)?;
            p.set_item("changes", s.changes)?;
            p.set_item("runs", s.runs)?;
            p.set_item("time_s", s.time.as_secs_f64())?;
            passes.append(p)?;
        }
        d.set_item("passes", passes)?;
        d.set_item("needs", r.needs.to_string().trim_end())?;
        d.set_item("report", r.to_string())?;
        // Computed with the GIL released and outside the `OnceLock`: a thread that waited
        // on the lock while holding the GIL would deadlock with one that computes without it.
        let jit = match self.jit_stats.get() {
            Some(s) => s.clone(),
            None => {
                let optimized = &self.optimized;
                let s = py.detach(|| jit_stats(optimized));
                self.jit_stats.get_or_init(|| s).clone()
            }
        };
        d.set_item("jit", jit)?;
        if let Some((path, opts)) = &self.mtlx_path {
            let lobes = py
                .detach(|| shadenet::mtlx::mtlx_lobes(path, opts, &Specialization::default()))
                .map_err(|e| shadenet_error(&e))?;
            let list = pyo3::types::PyList::empty(py);
            for l in lobes {
                let ld = PyDict::new(py);
                ld.set_item("output", l.material)?;
                ld.set_item("kind", l.kind)?;
                ld.set_item("component", l.component)?;
                ld.set_item("live", l.live)?;
                list.append(ld)?;
            }
            d.set_item("lobes", list)?;
        }
        Ok(d)
    }

    /// The outputs: `(name, type, components, channels)` per output, in order; the
    /// components are the render components it has parts for.
    fn outputs(&self) -> Vec<(String, String, Vec<String>, Vec<&'static str>)> {
        let slots = output_slots(&self.program);
        let mut out: Vec<(String, String, Vec<String>, Vec<&'static str>)> = Vec::new();
        for name in self.program.output_names() {
            let Some((_, _, ty, _)) = slots.iter().find(|s| s.0 == name) else {
                continue;
            };
            let components = slots
                .iter()
                .filter(|s| s.0 == name)
                .filter_map(|s| s.1)
                .map(|k| self.program.components[k as usize].to_string())
                .collect();
            let channels = shadenet::shade::channel_names(*ty).to_vec();
            out.push((name.to_string(), ty.to_string(), components, channels));
        }
        out
    }

    /// The render components the program declares.
    fn components(&self) -> Vec<String> {
        self.program
            .components
            .iter()
            .map(|c| c.to_string())
            .collect()
    }

    /// Shades `n` fragments given as a dict of field bytes (see [`fragments`]). Returns the
    /// layers as `(name, channels, bytes)`, `bytes` holding `n × channels` f32, row after
    /// row. The GIL is released while compiling and shading.
    #[pyo3(signature = (n, fields, lights=None, backend="jit", mask=None))]
    fn shade<'py>(
        &self,
        py: Python<'py>,
        n: usize,
        fields: &Bound<'py, PyDict>,
        lights: Option<Vec<String>>,
        backend: &str,
        mask: Option<Vec<String>>,
    ) -> PyResult<Layers<'py, &'static str>> {
        let frags = fragments(n, fields)?;
        let mut all_lights = self.lights.clone();
        for (i, spec) in lights.iter().flatten().enumerate() {
            let l = shadenet::lights::parse_light(spec, i)
                .map_err(|e| value_error(format!("lights[{i}] \"{spec}\": {}", chain(&e))))?;
            all_lights.push(l);
        }
        if all_lights.is_empty() {
            all_lights.push(
                shadenet::lights::parse_light(shadenet::lights::DEFAULT_LIGHT, 0)
                    .map_err(|e| shadenet_error(&e))?,
            );
        }
        let mut spec = Specialization::default();
        if let Some(names) = &mask {
            spec.components = Specialization::mask_of(&self.program, names)
                .map_err(|e| value_error(format!("mask: {e}")))?;
        }
        let key = (backend.to_string(), spec.components);
        let program = &self.program;
        let cache = &self.cache;
        // Everything that waits on a lock (the GPU device, the cache) runs without the GIL.
        let layers = detached(py, move || {
            let (back, mode) = backend_for(backend)?;
            let cached = cache
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .get(&key)
                .cloned();
            let material = match cached {
                Some(m) => m,
                None => {
                    let m = back
                        .compile(program, &spec)
                        .map_err(|e| shadenet_error(&e))?;
                    cache
                        .lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .insert(key, m.clone());
                    m
                }
            };
            let env = grid_env(&all_lights);
            let mode = if frags.is_empty() {
                BatchMode::Single
            } else {
                mode
            };
            let grid = shade_fragments(&*material, &env, &frags, spec.components, mode);
            Ok(output_layers(program, &grid))
        })?;
        Ok(layers
            .into_iter()
            .map(|l| {
                let width = l.channels.len();
                let mut rows = vec![0.0f32; n * width];
                for (c, data) in l.data.iter().enumerate() {
                    for (i, v) in data.iter().enumerate() {
                        rows[i * width + c] = *v;
                    }
                }
                (l.name, l.channels, f32_bytes(py, &rows))
            })
            .collect())
    }
}

/// The JIT as `shade` runs it (no fallback message on standard error: the material's
/// statistics say which back end ran).
fn jit() -> shadenet::jit::JitBackend {
    shadenet::jit::JitBackend::with_options(shadenet::jit::JitOptions {
        log_fallback: false,
        ..shadenet::jit::JitOptions::default()
    })
}

/// A back end by name (the CLI's `shade --backend` names) and how `shade_fragments` calls
/// it. The GPU back end is started once per process (opening a device is slow) and shared.
fn backend_for(name: &str) -> PyResult<(Arc<dyn Backend>, BatchMode)> {
    static GPU: OnceLock<Result<Arc<dyn Backend>, String>> = OnceLock::new();
    Ok(match name {
        "interp" => (Arc::new(InterpBackend), BatchMode::Single),
        "jit" => (Arc::new(jit()), BatchMode::Single),
        "jit-batch" => (Arc::new(jit()), BatchMode::Batches),
        "gpu" => {
            let gpu = GPU.get_or_init(|| {
                GpuBackend::new(GpuOptions::default(), Arc::new(jit()))
                    .map(|g| Arc::new(g) as Arc<dyn Backend>)
                    .map_err(|e| {
                        format!(
                            "backend \"gpu\": the GPU back end cannot start: {}",
                            chain(&e)
                        )
                    })
            });
            match gpu {
                Ok(b) => (b.clone(), BatchMode::All),
                Err(e) => return Err(shadenet_msg(e.clone())),
            }
        }
        other => {
            return Err(value_error(format!(
                "unknown backend \"{other}\": expected {BACKENDS}"
            )));
        }
    })
}

/// The JIT half of `compile --stats`: its compile statistics, or why it would fall back.
fn jit_stats(program: &Program) -> String {
    // As `compile --stats` with the default specialization (CSE on: Cranelift's `speed`).
    let backend = shadenet::jit::JitBackend::with_options(shadenet::jit::JitOptions {
        fallback: false,
        opt: shadenet::jit::OptLevel::Speed,
        ..shadenet::jit::JitOptions::default()
    });
    match backend.compile_program(program, std::time::Duration::ZERO) {
        Ok(m) => m.info().stats.to_string(),
        Err(e) => format!("{}; the interpreter would run this material", chain(&e)),
    }
}
