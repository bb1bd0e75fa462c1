//! `shadenet render`: a scene file in, a multi-layer EXR (and a PNG preview) out.
//!
//! The facade's part of rendering is what the tracer must not do: it links each material's
//! network (applying the scene's parameter overrides to node inputs first) and picks the
//! back end. Everything else — BVH, passes, specialization per component mask, film — is
//! `shadenet_tracer`'s.
//!
//! With no scene file, [`default_scene`] is the scene embedded in the binary
//! (`examples/scenes/default.toml` and the network files it names), so `shadenet render`
//! works from any directory.

use shadenet_gpu::{GpuBackend, GpuOptions};
use shadenet_graph::ir::Program;
use shadenet_graph::lower::{LowerOptions, lower_with};
use shadenet_graph::network::Network;
use shadenet_graph::{LightStrategy, NodeLibrary, error_chain, link};
use shadenet_runtime::input::{self, FileKind, InputError};
use shadenet_tracer::passes::PassDef;
use shadenet_tracer::scene::{self, MaterialRef, MaterialSource, Scene, SceneError};
use shadenet_tracer::shader::{BatchedBackend, InterpBackend, RuntimeBackend, ShaderBackend};
use shadenet_tracer::{RenderError, Renderer};
use std::collections::BTreeSet;
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

/// The embedded default scene's path (as it is named in messages).
pub const DEFAULT_SCENE_PATH: &str = "examples/scenes/default.toml";

/// The embedded files: the default scene and every network file it names.
const EMBEDDED: &[(&str, &str)] = &[
    (
        "examples/scenes/default.toml",
        include_str!("../examples/scenes/default.toml"),
    ),
    (
        "examples/scenes/materials/plastic.json",
        include_str!("../examples/scenes/materials/plastic.json"),
    ),
    (
        "examples/scenes/materials/satin.json",
        include_str!("../examples/scenes/materials/satin.json"),
    ),
    (
        "examples/scenes/materials/checker_floor.json",
        include_str!("../examples/scenes/materials/checker_floor.json"),
    ),
    (
        "examples/scenes/materials/ramp.json",
        include_str!("../examples/scenes/materials/ramp.json"),
    ),
    (
        "examples/networks/marble.json",
        include_str!("../examples/networks/marble.json"),
    ),
    (
        "examples/scenes/materials/bumpy.json",
        include_str!("../examples/scenes/materials/bumpy.json"),
    ),
    (
        "examples/scenes/materials/mirror.json",
        include_str!("../examples/scenes/materials/mirror.json"),
    ),
    (
        "examples/scenes/materials/glass.json",
        include_str!("../examples/scenes/materials/glass.json"),
    ),
];

/// Which back end runs the materials.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendKind {
    /// The interpreter (f32).
    Interp,
    /// The Cranelift JIT.
    Jit,
    /// The GPU (wgpu), with the JIT as its scalar companion (secondary hits); camera hits
    /// are shaded deferred, in batches. Default [`GpuOptions`]: see [`gpu_backend`].
    Gpu,
}

/// Command-line overrides of a scene's settings.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderOptions {
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Passes by standard name (replace the scene's).
    pub passes: Option<Vec<String>>,
    /// Resolution.
    pub res: Option<(u32, u32)>,
    /// How closures gather area lights and the environment (replaces the scene's
    /// `render.light_strategy`).
    pub light_strategy: Option<LightStrategy>,
}

/// Anything that stops a render before the first pixel.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// The scene file is invalid.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A material's network could not be read or linked.
    #[error("material `{material}` ({source_name}): {message}")]
    Material {
        /// The material's key.
        material: String,
        /// Its network file, or "inline".
        source_name: String,
        /// What is wrong.
        message: String,
    },
    /// An option is invalid.
    #[error("{0}")]
    Option(String),
    /// The back end is not available.
    #[error("{0}")]
    Backend(String),
    /// A light shader of the scene could not be compiled or used as a light.
    #[error(transparent)]
    Light(#[from] crate::scene_lights::ShaderLightError),
    /// The tracer refused the scene.
    #[error(transparent)]
    Render(#[from] RenderError),
}

/// Where network files are read from: the disk, or the embedded default scene's files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Files {
    /// The file system.
    Disk,
    /// The files embedded in the binary.
    Embedded,
}

impl Files {
    fn read(self, path: &Path) -> Result<String, InputError> {
        match self {
            Files::Disk => input::read_to_string(path, FileKind::Text, "network"),
            Files::Embedded => {
                let want = normalize(path);
                EMBEDDED
                    .iter()
                    .find(|(p, _)| normalize(Path::new(p)) == want)
                    .map(|(_, text)| text.to_string())
                    .ok_or_else(|| InputError::Io {
                        role: "network",
                        path: path.to_path_buf(),
                        source: std::io::Error::new(
                            std::io::ErrorKind::NotFound,
                            "not among the embedded files",
                        ),
                    })
            }
        }
    }
}

/// `a/b/../c` → `a/c` (lexically; the embedded files have no links).
fn normalize(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// The embedded default scene.
pub fn default_scene() -> Result<Scene, SetupError> {
    let text = EMBEDDED[0].1;
    Ok(scene::parse(text, Path::new(DEFAULT_SCENE_PATH))?)
}

/// Applies command-line overrides to a scene.
pub fn apply_options(scene: &mut Scene, opts: &RenderOptions) -> Result<(), SetupError> {
    // The scene file's ranges (`scene::MAX_SPP`, `scene::MAX_RESOLUTION`), named by option.
    if let Some(spp) = opts.spp {
        if spp == 0 || spp > scene::MAX_SPP {
            return Err(SetupError::Option(format!(
                "--spp must be 1 to {}",
                scene::MAX_SPP
            )));
        }
        scene.settings.spp = spp;
    }
    if let Some((w, h)) = opts.res {
        let max = scene::MAX_RESOLUTION;
        if w == 0 || h == 0 || w > max || h > max {
            return Err(SetupError::Option(format!(
                "--res must be between 1x1 and {max}x{max}"
            )));
        }
        scene.camera.width = w;
        scene.camera.height = h;
    }
    if let Some(names) = &opts.passes {
        let passes = names
            .iter()
            .filter(|n| !n.is_empty())
            .map(|n| PassDef::standard(n).map_err(|e| SetupError::Option(format!("--passes: {e}"))))
            .collect::<Result<Vec<_>, _>>()?;
        shadenet_tracer::passes::check_pass_names(&passes)
            .map_err(|e| SetupError::Option(format!("--passes: {e}")))?;
        scene.settings.passes = passes;
    }
    if let Some(s) = opts.light_strategy {
        scene.settings.light_strategy = s;
    }
    Ok(())
}

/// A compiled material and what it declared that the renderer ignores.
#[derive(Clone, Debug)]
pub struct CompiledMaterial {
    /// The program.
    pub program: Program,
    /// Light nodes in its network (the scene's `[[lights]]` are used instead).
    pub ignored_lights: usize,
    /// The uniform geometric properties its MaterialX document's string-valued
    /// `geompropvalueuniform` nodes read (empty for other sources): the renderer compiles
    /// it once per distinct set of their values ([`crate::specialize`]).
    pub geomprops: BTreeSet<String>,
}

/// Reads, overrides, links and lowers one material's network, its closures lit by
/// `strategy` (the scene's `render.light_strategy`, which the renderer weights BSDF-sampled
/// rays with). A MaterialX material finds the data libraries in `mtlx_libraries`, else as
/// [`crate::mtlx::locate`] says.
pub fn compile_material(
    m: &MaterialRef,
    files: Files,
    scene_dir: &Path,
    mtlx_libraries: Option<&Path>,
    strategy: LightStrategy,
) -> Result<CompiledMaterial, SetupError> {
    let (source_name, dir) = match &m.source {
        MaterialSource::File(p) | MaterialSource::Mtlx { file: p, .. } => (
            p.display().to_string(),
            p.parent().map(Path::to_path_buf).unwrap_or_default(),
        ),
        MaterialSource::Inline(_) => ("inline".to_string(), scene_dir.to_path_buf()),
    };
    let fail = |message: String| SetupError::Material {
        material: m.name.clone(),
        source_name: source_name.clone(),
        message,
    };
    if let MaterialSource::File(p) = &m.source
        && p.extension()
            .is_some_and(|e| e == "sl" || e == "osl" || e == crate::shader::GROUP_EXTENSION)
    {
        return shader_material(m, p, files).map_err(fail);
    }
    if m.displacement.is_some() {
        return Err(fail(
            "`displacement` applies to a shader-source material (network = \"….osl\" or \"….sl\"): this one is a network or a MaterialX document".into(),
        ));
    }
    let standard;
    let mut geomprops = BTreeSet::new();
    let (mut network, lib): (Network, &NodeLibrary) = match &m.source {
        MaterialSource::File(p) => {
            let text = files.read(p).map_err(|e| fail(error_chain(&e)))?;
            standard = NodeLibrary::standard();
            let net =
                Network::from_json(&text).map_err(|e| fail(format!("malformed network: {e}")))?;
            (net, &standard)
        }
        MaterialSource::Inline(v) => {
            standard = NodeLibrary::standard();
            let net = serde_json::from_value(v.clone())
                .map_err(|e| fail(format!("malformed inline network: {e}")))?;
            (net, &standard)
        }
        MaterialSource::Mtlx {
            file,
            material,
            output,
        } => {
            let selection = shadenet_graph::mtlx::Selection {
                material: material.clone(),
                output: output.clone(),
                geomprops: m.geomprops.clone(),
            };
            let (net, lib, read) = crate::mtlx::mtlx_network(file, mtlx_libraries, &selection)
                .map_err(|e| fail(error_chain(&e)))?;
            geomprops = read;
            (net, lib.atoms())
        }
    };
    for (node, input, value) in &m.overrides {
        set_input(&mut network, node, input, value).map_err(&fail)?;
    }
    let linked = link(&network, lib).map_err(|e| fail(e.to_string()))?;
    let opts = LowerOptions {
        strategy,
        ..LowerOptions::default()
    };
    let mut program = lower_with(&linked, lib, opts).map_err(|e| fail(e.to_string()))?;
    shadenet_graph::ir::validate(&program)
        .map_err(|e| fail(format!("internal error: invalid IR: {e}")))?;
    program.name = m.name.clone();
    program.resolve_textures(&dir);
    Ok(CompiledMaterial {
        program,
        ignored_lights: linked.lights.len(),
        geomprops,
    })
}

/// A material that is a shader source (`network = "plastic.sl"`, an RSL surface, or an
/// OSL `surface`/`shader`, `network = "glossy.osl"`): compiled by the
/// shading-language front end, its `set` overrides (`"shader.param" = value`, the shader
/// named as in the file) changing its parameters' values.
fn shader_material(m: &MaterialRef, path: &Path, files: Files) -> Result<CompiledMaterial, String> {
    if files == Files::Embedded {
        return Err("shader sources are read from disk only".into());
    }
    let compiled = match &m.displacement {
        Some(d) => crate::shader::load_displaced(path, d, &[], &[]),
        None => crate::shader::load(path, &[], &[]),
    }
    .map_err(|e| e.to_string())?;
    let mut program = compiled.program;
    crate::shader::set_overrides(&mut program, &m.overrides)?;
    shadenet_graph::ir::validate(&program)
        .map_err(|e| format!("internal error: invalid IR: {e}"))?;
    program.name = m.name.clone();
    Ok(CompiledMaterial {
        program,
        ignored_lights: 0,
        geomprops: BTreeSet::new(),
    })
}

/// Applies one `set` override: `node.input` on a node of the network, or
/// `graph/node.input` on a node inside a nodegraph (a compound the network instantiates as
/// the node `graph`: how MaterialX documents arrive); `graph.input` sets a nodegraph's
/// interface input.
fn set_input(
    network: &mut Network,
    node: &str,
    input: &str,
    value: &serde_json::Value,
) -> Result<(), String> {
    let names = |nodes: &[shadenet_graph::network::NodeSpec]| {
        nodes
            .iter()
            .map(|n| n.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let (outer, inner) = match node.split_once('/') {
        Some((g, n)) => (g, Some(n)),
        None => (node, None),
    };
    let Some(spec) = network.nodes.iter_mut().find(|n| n.name == outer) else {
        return Err(format!(
            "set \"{node}.{input}\": the network has no node `{outer}` (its nodes: {})",
            names(&network.nodes)
        ));
    };
    let Some(inner) = inner else {
        spec.inputs.insert(input.to_string(), value.clone());
        return Ok(());
    };
    let ty = spec.ty.clone();
    let Some(compound) = network.compounds.iter_mut().find(|c| c.name == ty) else {
        return Err(format!(
            "set \"{node}.{input}\": `{outer}` is a `{ty}` node, not a nodegraph"
        ));
    };
    let known = names(&compound.nodes);
    let Some(spec) = compound.nodes.iter_mut().find(|n| n.name == inner) else {
        return Err(format!(
            "set \"{node}.{input}\": the nodegraph `{outer}` has no node `{inner}` (its nodes: {known})"
        ));
    };
    spec.inputs.insert(input.to_string(), value.clone());
    Ok(())
}

/// How many worker threads a render or shade may ask for per core: enough to oversubscribe,
/// not enough to exhaust the machine (`--threads 100000` used to run for minutes).
pub const MAX_THREADS_PER_CORE: usize = 8;

/// Checks a worker-thread count against 1 to [`MAX_THREADS_PER_CORE`] × this machine's
/// cores; the error starts with the count, for the caller to prefix with its option's name
/// (`--threads`, `threads=`).
pub fn check_threads(n: usize) -> Result<usize, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max = MAX_THREADS_PER_CORE * cores;
    if n == 0 || n > max {
        return Err(format!(
            "{n}: expected 1 to {max} ({MAX_THREADS_PER_CORE} × the {cores} cores of this machine)"
        ));
    }
    Ok(n)
}

/// The back end for a kind.
pub fn backend(kind: BackendKind) -> Result<Box<dyn ShaderBackend>, SetupError> {
    match kind {
        BackendKind::Interp => Ok(Box::new(InterpBackend)),
        BackendKind::Jit => Ok(Box::new(RuntimeBackend(Arc::new(
            shadenet_jit::JitBackend::new(),
        )))),
        BackendKind::Gpu => gpu_backend(GpuOptions::default()),
    }
}

/// The GPU back end with these options and the JIT as its scalar companion (it shades the
/// single hits: secondary rays shaded from inside `trace`), as a shader back end that
/// prefers batches (the renderer shades camera hits deferred). Fails, naming the cause,
/// when no adapter exists or no device opens on it.
pub fn gpu_backend(options: GpuOptions) -> Result<Box<dyn ShaderBackend>, SetupError> {
    let gpu = GpuBackend::new(options, Arc::new(shadenet_jit::JitBackend::new())).map_err(|e| {
        SetupError::Backend(format!(
            "the GPU back end cannot start: {}",
            error_chain(&e)
        ))
    })?;
    Ok(Box::new(BatchedBackend(Arc::new(gpu))))
}

/// Compiles every material of a scene and prepares the renderer (`mtlx_libraries`: where
/// MaterialX materials find the data libraries, see [`compile_material`]).
pub fn prepare(
    scene: Scene,
    files: Files,
    scene_dir: &Path,
    backend: &dyn ShaderBackend,
    mtlx_libraries: Option<&Path>,
) -> Result<(Renderer, Vec<CompiledMaterial>), SetupError> {
    let mut scene = scene;
    let strategy = scene.settings.light_strategy;
    let compile = |m: &MaterialRef| compile_material(m, files, scene_dir, mtlx_libraries, strategy);
    let base = scene
        .materials
        .iter()
        .map(compile)
        .collect::<Result<Vec<_>, _>>()?;
    // Materials whose documents read uniform geometric properties: one compile per
    // distinct set of values among their instances; the compiles above (made without
    // values) serve the materials and sets that give none.
    let read: Vec<BTreeSet<String>> = base.iter().map(|c| c.geomprops.clone()).collect();
    let from = crate::specialize::by_geomprops(&mut scene, &read);
    let mut compiled = Vec::with_capacity(from.len());
    for (m, from) in scene.materials.iter().zip(from) {
        let mut c = match from {
            Some(k) => base[k].clone(),
            None => compile(m)?,
        };
        c.program.name.clone_from(&m.name);
        compiled.push(c);
    }
    let programs = compiled.iter().map(|c| c.program.clone()).collect();
    // Light programs run on the interpreter for renders on the interpreter, else compiled by
    // the JIT (the GPU back end's host steps sample lights on the CPU).
    let jit = backend.name() != "interp";
    crate::scene_lights::compile(&mut scene, files == Files::Disk, jit)?;
    let renderer = Renderer::new(scene, programs, backend)?;
    Ok((renderer, compiled))
}

/// Loads a scene file (or the embedded default with `None`), applies the options and
/// prepares the renderer with the interpreter: the whole setup in one call, for tests and
/// embedding.
pub fn setup(path: Option<&Path>, opts: &RenderOptions) -> Result<Renderer, SetupError> {
    setup_with(path, opts, &InterpBackend)
}

/// [`setup`] with a chosen back end (see [`backend`]).
pub fn setup_with(
    path: Option<&Path>,
    opts: &RenderOptions,
    backend: &dyn ShaderBackend,
) -> Result<Renderer, SetupError> {
    let (scene, files, dir) = load(path, opts)?;
    Ok(prepare(scene, files, &dir, backend, None)?.0)
}

/// Loads a scene file (or the embedded default scene with `None`) and applies the options:
/// the scene, where its files come from and the folder its relative paths start from. The
/// CLI, [`setup_with`] and the Python package all start a render here.
pub fn load(
    path: Option<&Path>,
    opts: &RenderOptions,
) -> Result<(Scene, Files, PathBuf), SetupError> {
    let (mut scene, files, dir) = match path {
        Some(p) => (
            scene::load(p)?,
            Files::Disk,
            p.parent().map(Path::to_path_buf).unwrap_or_default(),
        ),
        None => (
            default_scene()?,
            Files::Embedded,
            PathBuf::from("examples/scenes"),
        ),
    };
    apply_options(&mut scene, opts)?;
    Ok((scene, files, dir))
}
