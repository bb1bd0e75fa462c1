//! `shadenet bench`: the benchmarks of DESIGN §9 as a product feature — interpreter against
//! JIT against the rustc-compiled native reference, speed against error.
//!
//! - **B1** the multiplication tree (Larsson 2005, §5.1.1): shading only (one thread, CSE
//!   off and on, scalar and batch entries, the native reference, the GPU's batch entry),
//!   full renders of the tree scene (all threads, the renderer's specialization; the GPU
//!   deferred) and preprocessing, world and camera space; the thesis's Figures 7–9 printed
//!   beside.
//! - **B2** thread scaling of B1's shading, 1…N threads.
//! - **B3** the example scenes rendered with each back end (the GPU deferred, in batches).
//!
//! GPU rows appear where an adapter exists (a note says why they are missing otherwise);
//! their shading time is split into upload, kernels, host steps and readback
//! (`BatchTimes`), with the passes dispatched.
//! - **B4** preprocessing (link + optimize + compile) against network size.
//! - **B5** N passes in one render against N one-pass renders; specialized against
//!   unspecialized shading.
//! - **B6** speed against error of the light-transport strategies (`mis`, `light`,
//!   `bsdf`) on `pbr.toml`: error against a high-spp MIS reference vs render time, and each
//!   strategy's error at MIS's time.
//! - **B7** peers: the tree at levels 1 and 10 and an fBm node through `shadenet shade`'s
//!   batch path on 2 threads, beside OSL's `testshade` figures quoted in issue 23.
//! - **B8** speed against error of texture filtering (unfiltered, trilinear, anisotropic)
//!   on `texture_plane.toml` at 1, 4 and 16 spp: RMSE, relMSE and SSIM against an
//!   unfiltered high-spp reference (cached in the output folder) vs render time, and the
//!   target check of issue 16.
//!
//! Every time is the median of repeated runs in this process (min and max beside), every
//! ratio is against a row of the same run, and every error is measured against the f64
//! interpreter on the same work.

pub mod peer;
pub mod render;
pub mod report;
pub mod speed_error;
pub mod ssim;
pub mod textures;
pub mod transport;
pub mod workloads;

#[cfg(target_arch = "x86_64")]
pub mod native;

use report::{ErrorStats, Row, Timing, time};
use shadenet_gpu::{GpuBackend, GpuOptions};
use shadenet_graph::ir::{Program, Space};
use shadenet_graph::opt::{self, Specialization};
use shadenet_jit::{JitBackend, JitOptions};
use shadenet_runtime::{
    Backend, BatchTimes, InterpBackend, Interpreter, LANES, Material, ShadeCtx, ShadeEnv,
};
use shadenet_tracer::scene::{self, MaterialSource, Scene};
use shadenet_tracer::shader::ShaderBackend;
use shadenet_tracer::{RenderStats, Renderer};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};
use workloads::{Entry, packets, tree_fragments, tree_program, tree_spec};

/// The suites, in order.
pub const SUITES: [&str; 8] = ["b1", "b2", "b3", "b4", "b5", "b6", "b7", "b8"];

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Small sizes and few repetitions (the whole run well under two minutes on 2 cores).
    pub quick: bool,
    /// Suites to run (lower case, from [`SUITES`]).
    pub suites: Vec<String>,
    /// Frame size of shading and renders; `None`: 640×480 (160×120 with `quick`).
    pub size: Option<(u32, u32)>,
    /// Tree levels of B1/B2/B4; `None`: 1–10 (1, 4, 7, 10 with `quick`).
    pub levels: Option<Vec<u32>>,
    /// Directory of the example scenes (B3, B5, B6, B8).
    pub scenes: PathBuf,
    /// The output folder, where a suite caches what later runs reuse (B8's reference
    /// render); `None`: nothing is cached.
    pub out: Option<PathBuf>,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            quick: false,
            suites: SUITES.iter().map(|s| s.to_string()).collect(),
            size: None,
            levels: None,
            scenes: PathBuf::from("examples/scenes"),
            out: None,
        }
    }
}

impl BenchOptions {
    fn size(&self) -> (u32, u32) {
        self.size.unwrap_or(if self.quick {
            (160, 120)
        } else {
            workloads::B1_SIZE
        })
    }
    fn levels(&self) -> Vec<u32> {
        self.levels.clone().unwrap_or(if self.quick {
            vec![1, 4, 7, 10]
        } else {
            (1..=10).collect()
        })
    }
    fn reps(&self) -> (usize, f64) {
        if self.quick { (3, 0.0) } else { (5, 0.5) }
    }
}

/// One suite's results.
#[derive(Clone, Debug)]
pub struct SuiteResult {
    /// `B1` …
    pub name: &'static str,
    /// One line on what it measures.
    pub title: String,
    /// The rows.
    pub rows: Vec<Row>,
    /// Extra markdown printed after the table (B1: the thesis's figures beside ours).
    pub extra: String,
}

/// Runs the selected suites, calling `done` after each.
pub fn run(opts: &BenchOptions, mut done: impl FnMut(&SuiteResult)) -> Vec<SuiteResult> {
    let mut out = Vec::new();
    for s in SUITES {
        if !opts.suites.iter().any(|x| x.eq_ignore_ascii_case(s)) {
            continue;
        }
        let mut r = match s {
            "b1" => b1(opts),
            "b2" => b2(opts),
            "b3" => b3(opts),
            "b4" => b4(opts),
            "b5" => b5(opts),
            "b6" => transport::b6(opts),
            "b7" => peer::b7(opts),
            _ => textures::b8(opts),
        };
        report::fill_ratios(&mut r.rows);
        done(&r);
        out.push(r);
    }
    out
}

fn jit(batch: bool) -> JitBackend {
    JitBackend::with_options(JitOptions {
        scalar: !batch,
        batch,
        log_fallback: false,
        ..JitOptions::default()
    })
}

/// The back end that actually runs `m`, for a material compiled by `asked`.
fn actual(asked: &str, m: &dyn Material) -> String {
    match &m.info().fallback {
        Some(_) => format!("interp (fallback from {asked})"),
        None => asked.to_string(),
    }
}

/// The GPU back end of the GPU rows (default options, the JIT as scalar companion), or why
/// there is none.
fn gpu_backend() -> Result<GpuBackend, String> {
    GpuBackend::new(GpuOptions::default(), Arc::new(jit(false))).map_err(|e| e.to_string())
}

/// Why GPU rows are missing: (case, reason).
type Notes = Vec<(String, String)>;

/// The notes of a suite for [`notes_markdown`]: why every GPU row is missing, or none.
fn gpu_notes(gpu: &Result<GpuBackend, String>) -> Notes {
    gpu.as_ref()
        .err()
        .map(|e| ("every case".to_string(), e.clone()))
        .into_iter()
        .collect()
}

/// The notes printed after a suite's table: why GPU rows are missing, one line per reason.
fn notes_markdown(notes: &Notes) -> String {
    let mut reasons: Vec<(&str, Vec<&str>)> = Vec::new();
    for (case, why) in notes {
        match reasons.iter_mut().find(|r| r.0 == why) {
            Some(r) => {
                if !r.1.contains(&case.as_str()) {
                    r.1.push(case)
                }
            }
            None => reasons.push((why, vec![case])),
        }
    }
    let mut s = String::new();
    for (why, cases) in reasons {
        s.push_str(&format!(
            "\nNote: no GPU rows for {}: {why}\n",
            cases.join(", ")
        ));
    }
    s
}

/// The time split of the run whose wall time is the median of `runs`.
fn median_split(runs: &mut [(Duration, BatchTimes)]) -> Option<BatchTimes> {
    runs.sort_by_key(|r| r.0);
    runs.get(runs.len().checked_sub(1)? / 2).map(|r| r.1)
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
}

/// The f64 interpreter's output for every fragment of a frame (the linked program,
/// specialized with the defaults).
fn reference_frame(
    program: &Program,
    env: &ShadeEnv,
    frags: &[shadenet_runtime::Fragment],
) -> (Vec<f64>, usize) {
    let (p, _) = opt::run(program, &Specialization::default());
    let interp = Interpreter::<f64>::new(&p).expect("no textures");
    let stride: usize = interp.slots().iter().map(|s| s.ty.width().max(1)).sum();
    let mut scratch = Default::default();
    let mut out = shadenet_runtime::ShadeOut::default();
    let mut v = Vec::with_capacity(frags.len() * stride);
    for f in frags {
        interp.shade_with(&ShadeCtx::new(*f, env), &mut scratch, &mut out);
        v.extend(out.values.iter().copied());
    }
    (v, stride)
}

fn space_name(s: Space) -> &'static str {
    if s == Space::World { "world" } else { "camera" }
}

/// The GPU of a suite's rows: the back end, or why there is none (said once per suite).
type Gpu<'a> = Option<&'a Result<GpuBackend, String>>;

#[allow(clippy::too_many_arguments)]
fn shading_rows(
    opts: &BenchOptions,
    suite: &'static str,
    level: u32,
    space: Space,
    threads: &[usize],
    configs: &[(&str, bool, Entry)],
    with_native: bool,
    gpu: Gpu,
    notes: &mut Notes,
) -> Vec<Row> {
    let (w, h) = opts.size();
    let n = (w * h) as usize;
    let frags = tree_fragments(w, h);
    let packs = packets(&frags);
    let env = crate::shade::grid_env(&[]);
    let program = tree_program(level, space);
    let (reference, _) = reference_frame(&program, &env, &frags);
    let (reps, budget) = opts.reps();
    let mut rows = Vec::new();
    let mut out = vec![0.0f32; packs.len() * LANES * 3];
    for &t in threads {
        let pool = pool(t);
        let case = format!("L{level} {} shade", space_name(space));
        for &(name, cse, entry) in configs {
            let backend: Box<dyn Backend> = match name {
                "interp" => Box::new(InterpBackend),
                _ => Box::new(jit(entry == Entry::Batch)),
            };
            let m = workloads::compile(&*backend, &program, &tree_spec(cse));
            let timing = pool.install(|| {
                time(reps, budget, || {
                    workloads::shade_frame(&*m, &env, &packs, n, entry, &mut out);
                })
            });
            rows.push(Row {
                suite,
                case: case.clone(),
                backend: actual(name, &*m),
                config: format!(
                    "CSE {}, {}, {t} thr",
                    if cse { "on" } else { "off" },
                    if entry == Entry::Batch {
                        "batch"
                    } else {
                        "scalar"
                    }
                ),
                work: n as u64,
                unit: "frag",
                time: timing,
                error: Some(ErrorStats::measure(&out[..n * 3], &reference, 3)),
                ..Row::default()
            });
        }
        if with_native && space == Space::World {
            let mut ok = true;
            let timing = pool.install(|| {
                time(reps, budget, || {
                    ok &= workloads::native_frame(level, &packs, n, &mut out).is_some();
                })
            });
            if ok {
                rows.push(Row {
                    suite,
                    case: case.clone(),
                    backend: "native (rustc)".into(),
                    config: format!("CSE off, batch, {t} thr"),
                    work: n as u64,
                    unit: "frag",
                    time: timing,
                    error: Some(ErrorStats::measure(&out[..n * 3], &reference, 3)),
                    ..Row::default()
                });
            }
        }
    }
    if let Some(Ok(gpu)) = gpu {
        let case = format!("L{level} {} shade", space_name(space));
        for cse in [false, true] {
            let m = match gpu.compile(&program, &tree_spec(cse)) {
                Ok(m) => m,
                Err(e) => {
                    notes.push((case.clone(), e.to_string()));
                    continue;
                }
            };
            let packed = shadenet_runtime::Fragments::from_slice(&frags);
            let mut gout = vec![0.0f32; shadenet_runtime::packed_len(m.width(), n)];
            let mut runs = Vec::new();
            let timing = time(reps, budget, || {
                let t = Instant::now();
                let r = m.shade_many(&env, u32::MAX, None, &packed, &mut gout);
                runs.push((t.elapsed(), r.times));
            });
            rows.push(Row {
                suite,
                case: case.clone(),
                backend: actual("gpu", &*m),
                config: format!(
                    "CSE {}, shade_many (1 batch)",
                    if cse { "on" } else { "off" }
                ),
                work: n as u64,
                unit: "frag",
                time: timing,
                error: Some(ErrorStats::measure(
                    &shadenet_runtime::unpacked(m.width(), n, &gout),
                    &reference,
                    3,
                )),
                split: median_split(&mut runs),
                ..Row::default()
            });
        }
    }
    rows
}

const TREE_SCENE: &str = include_str!("../../examples/scenes/mult_tree.toml");

/// A timed render: timing, preparation seconds, the beauty layer of the last run and its
/// floats per pixel, and the statistics of the median run.
type Rendered = (Timing, f64, Vec<f32>, usize, RenderStats);

/// Renders `scene` with `backend` `reps` times (panics if the scene cannot be prepared:
/// the example scenes can).
fn render_timed(
    scene: &Scene,
    programs: &[Program],
    backend: &dyn ShaderBackend,
    reps: (usize, f64),
) -> Rendered {
    try_render_timed(scene, programs, backend, reps).expect("the scene prepares")
}

/// [`render_timed`], or why the back end cannot prepare the scene.
fn try_render_timed(
    scene: &Scene,
    programs: &[Program],
    backend: &dyn ShaderBackend,
    reps: (usize, f64),
) -> Result<Rendered, String> {
    let t = Instant::now();
    let r = Renderer::new(scene.clone(), programs.to_vec(), backend).map_err(|e| e.to_string())?;
    let prep = t.elapsed().as_secs_f64();
    let mut film = None;
    let mut runs = Vec::new();
    let timing = time(reps.0, reps.1, || {
        let (f, st) = r.render(&|_, _| {});
        film = Some(f);
        runs.push(st);
    });
    runs.sort_by_key(|st| st.render_time);
    let stats = runs.get(runs.len() / 2).cloned().unwrap_or_default();
    let film = film.ok_or("no render ran")?;
    let beauty = film
        .layers
        .into_iter()
        .next()
        .ok_or("the film has no beauty layer")?;
    let stride = beauty.channels.len();
    Ok((timing, prep, beauty.data, stride, stats))
}

/// Renders a scene with the interpreter, the JIT (through the runtime traits, reporting a
/// fallback), the GPU where `gpu` has one (deferred, in batches) and the f64 reference; one
/// row per back end.
fn render_rows(
    suite: &'static str,
    case: &str,
    scene: &Scene,
    programs: &[Program],
    reps: (usize, f64),
    gpu: Gpu,
    notes: &mut Notes,
) -> Vec<Row> {
    let threads = rayon::current_num_threads();
    let pixels = (scene.camera.width * scene.camera.height) as u64;
    let (_, _, reference, stride, _) = render_timed(scene, programs, &render::F64Shaders, (1, 0.0));
    let reference: Vec<f64> = reference.iter().map(|v| *v as f64).collect();
    let mut rows = Vec::new();
    let backends: Vec<(&str, Box<dyn Backend>)> = vec![
        ("interp", Box::new(InterpBackend)),
        ("jit", Box::new(jit(false))),
    ];
    for (name, b) in backends {
        let shaders = render::RuntimeShaders::new(b);
        let (timing, _, beauty, _, _) = render_timed(scene, programs, &shaders, reps);
        let used = shaders.actual();
        rows.push(Row {
            suite,
            case: case.to_string(),
            backend: if used == name { name.to_string() } else { used },
            config: format!("renderer spec (CSE on), scalar, {threads} thr"),
            work: pixels * scene.settings.spp as u64,
            unit: "sample",
            time: timing,
            error: Some(ErrorStats::measure(&beauty, &reference, stride)),
            ..Row::default()
        });
    }
    if let Some(Ok(_)) = gpu {
        let Ok(b) = gpu_backend() else {
            return rows;
        };
        let shaders = render::RuntimeShaders::batched(Box::new(b));
        match try_render_timed(scene, programs, &shaders, reps) {
            Ok((timing, _, beauty, _, st)) => {
                let used = shaders.actual();
                rows.push(Row {
                    suite,
                    case: case.to_string(),
                    backend: if used == "gpu" { used } else { used + " (gpu)" },
                    config: format!(
                        "renderer spec, deferred: {} batches (largest {}), secondary hits on the JIT, {threads} thr; split summed over batches and threads",
                        st.batches, st.largest_batch
                    ),
                    work: pixels * scene.settings.spp as u64,
                    unit: "sample",
                    time: timing,
                    error: Some(ErrorStats::measure(&beauty, &reference, stride)),
                    split: Some(st.batch_times),
                    ..Row::default()
                });
            }
            Err(e) => notes.push((case.to_string(), e)),
        }
    }
    rows
}

fn tree_scene(level: u32, space: Space, size: (u32, u32)) -> (Scene, Vec<Program>) {
    let mut s = scene::parse(TREE_SCENE, Path::new("examples/scenes/mult_tree.toml"))
        .expect("the tree scene parses");
    s.camera.width = size.0;
    s.camera.height = size.1;
    let net = crate::generate::mult_tree(level, space).expect("levels 1–16");
    s.materials[0].source = MaterialSource::Inline(net);
    let programs = compile_scene(&s, Path::new("examples/scenes"));
    (s, programs)
}

fn compile_scene(s: &Scene, dir: &Path) -> Vec<Program> {
    s.materials
        .iter()
        .map(|m| {
            crate::render::compile_material(
                m,
                crate::render::Files::Disk,
                dir,
                None,
                s.settings.light_strategy,
            )
            .expect("the material compiles")
            .program
        })
        .collect()
}

/// Preprocessing rows: link (parse + link + lower) + optimize + compile, per back end.
fn preprocess_rows(suite: &'static str, level: u32, space: Space, reps: (usize, f64)) -> Vec<Row> {
    let net = crate::generate::mult_tree(level, space)
        .expect("levels")
        .to_string();
    let lib = shadenet_graph::NodeLibrary::standard();
    let nodes = (1u64 << (level + 1)) - 1;
    let mut rows = Vec::new();
    // The JIT compiles the scalar entry and leaves the batch entry to the first batch call;
    // the `both entries` row makes that call (the definition B4 had before the batch entry
    // became lazy).
    let backends: Vec<(&str, Box<dyn Backend>, bool, &str)> = vec![
        ("interp", Box::new(InterpBackend), false, "link+opt+compile"),
        (
            "jit",
            Box::new(JitBackend::new()),
            false,
            "link+opt+compile (scalar entry)",
        ),
        (
            "jit",
            Box::new(JitBackend::new()),
            true,
            "link+opt+compile (both entries)",
        ),
    ];
    for (name, b, both, what) in backends {
        let mut used = name.to_string();
        let timing = time(reps.0, reps.1, || {
            let c = shadenet_graph::compile_json(&net, &lib).expect("links");
            let m = b.compile(&c.program, &tree_spec(false)).expect("compiles");
            if both {
                let env = shadenet_runtime::ShadeEnv::default();
                let mut out = vec![0.0f32; m.width() * shadenet_runtime::LANES];
                let frags = shadenet_runtime::FragmentX4::default();
                m.shade_x4(&env, u32::MAX, &frags, 1, &mut out);
            }
            used = actual(name, &*m);
        });
        rows.push(Row {
            suite,
            case: format!("L{level} {} preprocess", space_name(space)),
            backend: used,
            config: format!("CSE off, {what}, 1 thr"),
            work: nodes,
            unit: "node",
            time: timing,
            error: None,
            ..Row::default()
        });
    }
    rows
}

fn b1(opts: &BenchOptions) -> SuiteResult {
    let (w, h) = opts.size();
    let reps = opts.reps();
    let mut rows = Vec::new();
    let configs = [
        ("interp", false, Entry::Scalar),
        ("jit", false, Entry::Scalar),
        ("jit", false, Entry::Batch),
        ("jit", true, Entry::Batch),
    ];
    let render_levels: Vec<u32> = if opts.quick {
        vec![4, 10]
    } else {
        opts.levels()
    };
    let gpu = gpu_backend();
    let mut notes = gpu_notes(&gpu);
    for space in [Space::World, Space::Camera] {
        for level in opts.levels() {
            rows.extend(shading_rows(
                opts,
                "B1",
                level,
                space,
                &[1],
                &configs,
                true,
                Some(&gpu),
                &mut notes,
            ));
            rows.extend(preprocess_rows("B1", level, space, reps));
            if render_levels.contains(&level) {
                let (s, p) = tree_scene(level, space, (w, h));
                rows.extend(render_rows(
                    "B1",
                    &format!("L{level} {} render", space_name(space)),
                    &s,
                    &p,
                    reps,
                    Some(&gpu),
                    &mut notes,
                ));
            }
        }
    }
    let extra = notes_markdown(&notes) + &thesis_beside(&rows, opts);
    SuiteResult {
        name: "B1",
        title: format!(
            "multiplication tree, {w}×{h}, 1 spp: shading only (1 thread), full render (all threads, CSE on as the renderer specializes), preprocessing"
        ),
        rows,
        extra,
    }
}

/// Larsson 2005, Figures 7 and 8 (seconds; Maya, Mental Ray, Turtle dual, Turtle single)
/// and Figure 9 (Turtle single: preprocessing, render), levels 1–10.
const FIG7: [[f64; 4]; 10] = [
    [1., 3., 1., 2.],
    [1., 4., 1., 2.],
    [1., 5., 1., 2.],
    [2., 8., 2., 2.],
    [2., 15., 2., 3.],
    [3., 26., 3., 4.],
    [5., 54., 4., 8.],
    [10., 105., 9., 17.],
    [18., 215., 19., 34.],
    [36., 500., 44., 73.],
];
const FIG8: [[f64; 4]; 10] = [
    [1., 3., 1., 2.],
    [1., 4., 1., 2.],
    [1., 5., 2., 2.],
    [2., 8., 2., 3.],
    [2., 15., 2., 3.],
    [3., 26., 3., 5.],
    [5., 52., 5., 9.],
    [9., 105., 11., 18.],
    [18., 215., 21., 43.],
    [35., 525., 51., 81.],
];
const FIG9: [(u32, f64, f64); 4] = [
    (7, 0.38, 6.65),
    (8, 0.89, 15.53),
    (9, 2.36, 30.83),
    (10, 10.21, 61.62),
];

fn thesis_beside(rows: &[Row], opts: &BenchOptions) -> String {
    let (w, h) = opts.size();
    let find = |case: &str, b: &str, cfg: &str| {
        rows.iter()
            .find(|r| r.case == case && r.backend == b && r.config.contains(cfg))
            .map(|r| format!("{:.3}", r.time.median))
            .unwrap_or_else(|| "—".into())
    };
    let mut s = format!(
        "\nOurs beside Larsson 2005 (Figures 7–9). Thesis: seconds for a 640×480 render on a dual Opteron 1.6 GHz, 2 GB, Windows XP, Maya 7 (2005 hardware). Ours: seconds, this machine, {w}×{h}{}.\n\n\
         | level | space | ours: interp shade 1 thr | ours: JIT batch shade 1 thr | ours: native shade 1 thr | ours: JIT render | ours: JIT preprocess | thesis: Maya | Mental Ray | Turtle dual | Turtle single | Turtle S preproc (Fig 9) | Turtle S render (Fig 9) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        if (w, h) != (640, 480) {
            " (quick size: scale by the pixel count to compare)"
        } else {
            ""
        }
    );
    for space in [Space::World, Space::Camera] {
        let sp = space_name(space);
        for level in opts.levels() {
            if !(1..=10).contains(&level) {
                continue;
            }
            let f = if space == Space::World { FIG7 } else { FIG8 }[level as usize - 1];
            let f9 = FIG9
                .iter()
                .find(|x| x.0 == level && space == Space::World)
                .map(|x| (format!("{}", x.1), format!("{}", x.2)))
                .unwrap_or(("—".into(), "—".into()));
            let shade = format!("L{level} {sp} shade");
            s.push_str(&format!(
                "| {level} | {sp} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                find(&shade, "interp", "CSE off"),
                find(&shade, "jit", "CSE off, batch"),
                find(&shade, "native (rustc)", ""),
                find(&format!("L{level} {sp} render"), "jit", ""),
                find(&format!("L{level} {sp} preprocess"), "jit", ""),
                f[0],
                f[1],
                f[2],
                f[3],
                f9.0,
                f9.1
            ));
        }
    }
    s
}

fn b2(opts: &BenchOptions) -> SuiteResult {
    let level = if opts.quick { 7 } else { 10 };
    let max = std::thread::available_parallelism().map_or(2, |n| n.get());
    let threads: Vec<usize> = (1..=max).collect();
    let configs = [
        ("interp", false, Entry::Scalar),
        ("jit", false, Entry::Batch),
    ];
    let rows = shading_rows(
        opts,
        "B2",
        level,
        Space::World,
        &threads,
        &configs,
        true,
        None,
        &mut Vec::new(),
    );
    let mut rows = rows;
    // Ratios within a thread count, and the speed-up over 1 thread in the case name.
    for r in &mut rows {
        let t = r.config.rsplit(", ").next().unwrap_or("").to_string();
        r.case = format!("{} {t}", r.case);
    }
    SuiteResult {
        name: "B2",
        title: format!(
            "thread scaling (Figure 10 analogue): level {level} world shading, CSE off, 1…{max} threads"
        ),
        rows,
        extra: String::new(),
    }
}

fn example_scenes(opts: &BenchOptions) -> Vec<(String, Scene, Vec<Program>)> {
    let mut v = Vec::new();
    let names = ["default", "cornell", "cornell_glass", "showcase"];
    let (w, h) = if opts.quick { (80, 60) } else { (320, 240) };
    for name in names {
        let path = opts.scenes.join(format!("{name}.toml"));
        let Ok(mut s) = scene::load(&path) else {
            continue;
        };
        if crate::scene_lights::compile(&mut s, true, true).is_err() {
            continue;
        }
        s.camera.width = w;
        s.camera.height = h;
        s.settings.spp = 1;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let programs = compile_scene(&s, &dir);
        v.push((name.to_string(), s, programs));
    }
    v
}

fn b3(opts: &BenchOptions) -> SuiteResult {
    let mut rows = Vec::new();
    let mut size = (0, 0);
    let gpu = gpu_backend();
    let mut notes = gpu_notes(&gpu);
    for (name, s, programs) in example_scenes(opts) {
        size = (s.camera.width, s.camera.height);
        rows.extend(render_rows(
            "B3",
            &format!("{name} render"),
            &s,
            &programs,
            opts.reps(),
            Some(&gpu),
            &mut notes,
        ));
    }
    SuiteResult {
        name: "B3",
        title: format!(
            "example scenes ({}×{}, 1 spp, all passes of the scene), per back end; error against the f64 interpreter render",
            size.0, size.1
        ),
        rows,
        extra: notes_markdown(&notes),
    }
}

fn b4(opts: &BenchOptions) -> SuiteResult {
    let mut rows = Vec::new();
    let levels: Vec<u32> = if opts.quick {
        vec![1, 4, 7, 10]
    } else {
        (1..=12).collect()
    };
    for level in levels {
        rows.extend(preprocess_rows("B4", level, Space::World, opts.reps()));
    }
    SuiteResult {
        name: "B4",
        title: "preprocessing (parse + link + lower + optimize + compile) against network size; throughput in nodes/s should stay flat (linear growth)".into(),
        rows,
        extra: String::new(),
    }
}

fn b5(opts: &BenchOptions) -> SuiteResult {
    let mut rows = Vec::new();
    let reps = opts.reps();
    let threads = rayon::current_num_threads();
    // Renders: N passes in one render against N renders of one pass.
    if let Some((name, s, programs)) = example_scenes(opts).into_iter().find(|x| x.0 == "cornell") {
        let passes = s.settings.passes.clone();
        let n = passes.len();
        let pixels = (s.camera.width * s.camera.height) as u64;
        for (bname, b) in [
            ("interp", Box::new(InterpBackend) as Box<dyn Backend>),
            ("jit", Box::new(jit(false))),
        ] {
            let shaders = render::RuntimeShaders::new(b);
            let (one, prep, _, _, _) = render_timed(&s, &programs, &shaders, reps);
            let used = shaders.actual();
            let mut sum = Timing::default();
            let mut sum_prep = 0.0;
            for p in &passes {
                let mut s1 = s.clone();
                s1.settings.passes = vec![p.clone()];
                let (t, pr, _, _, _) = render_timed(&s1, &programs, &shaders, reps);
                sum.median += t.median;
                sum.min += t.min;
                sum.max += t.max;
                sum.runs = t.runs;
                sum_prep += pr;
            }
            let base = format!("{name} {n} passes");
            for (how, t) in [
                ("1 render, N passes", one),
                ("N renders, 1 pass each (sum)", sum),
            ] {
                rows.push(Row {
                    suite: "B5",
                    case: format!("{base}: {how}"),
                    backend: if used == bname {
                        bname.into()
                    } else {
                        used.clone()
                    },
                    config: format!("renderer spec, scalar, {threads} thr"),
                    work: pixels,
                    unit: "pixel",
                    time: t,
                    ..Row::default()
                });
            }
            rows.push(Row {
                suite: "B5",
                case: format!("{base}: preprocessing, 1 render vs N (sum)"),
                backend: used.clone(),
                config: format!("{:.2} ms vs {:.2} ms", prep * 1e3, sum_prep * 1e3),
                work: pixels,
                unit: "pixel",
                time: Timing {
                    median: prep,
                    min: prep,
                    max: sum_prep,
                    runs: 1,
                },
                ..Row::default()
            });
        }
    }
    // Shading: specialized to one component against unspecialized (all components computed,
    // the component masked at run time).
    let net_path = opts.scenes.join("materials/plastic.json");
    if let Ok(c) = crate::load_network(&net_path) {
        let (w, h) = opts.size();
        let n = (w * h) as usize;
        let frags: Vec<_> = (0..h)
            .flat_map(|y| (0..w).map(move |x| crate::shade::grid_fragment(x, y, w, h)))
            .collect();
        let packs = packets(&frags);
        let lights = [shadenet_graph::nodes::LightDesc {
            name: "key".into(),
            kind: shadenet_graph::nodes::LightKind::Point {
                position: [1.0, 1.0, 2.0],
            },
            power: [4.0; 3],
        }];
        let env = crate::shade::grid_env(&lights);
        let comps = c.program.components.clone();
        for (ci, comp) in comps.iter().enumerate() {
            let mask = 1u32 << ci;
            let reference = {
                let g = crate::shade::shade_grid::<f64>(&c.program, &env, w, h, mask)
                    .expect("no textures");
                g.pixel_values()
            };
            let spec = Specialization {
                components: mask,
                ..Specialization::default()
            };
            for label in [
                "specialized",
                "unspecialized (linked program, mask at run time)",
            ] {
                let m = if label == "specialized" {
                    jit(true).compile(&c.program, &spec)
                } else {
                    jit(true).compile_program(&c.program, std::time::Duration::ZERO)
                }
                .expect("compiles");
                let width = m.width();
                let mut out = vec![0.0f32; packs.len() * LANES * width];
                let timing = time(reps.0, reps.1, || {
                    workloads_masked(&*m, &env, &packs, n, mask, &mut out);
                });
                rows.push(Row {
                    suite: "B5",
                    case: format!("plastic `{comp}` shade"),
                    backend: actual("jit", &*m),
                    config: format!("{label}, batch, {threads} thr"),
                    work: n as u64,
                    unit: "frag",
                    time: timing,
                    error: Some(ErrorStats::measure(&out[..n * width], &reference, width)),
                    ..Row::default()
                });
            }
        }
    }
    SuiteResult {
        name: "B5",
        title: "passes: N passes in one render vs N one-pass renders (the renderer always specializes per pass); specialized vs unspecialized shading of one component".into(),
        rows,
        extra: String::new(),
    }
}

fn workloads_masked(
    m: &dyn Material,
    env: &ShadeEnv,
    packets: &[shadenet_runtime::FragmentX4],
    n: usize,
    mask: u32,
    out: &mut [f32],
) {
    use rayon::prelude::*;
    let w = m.width();
    out.par_chunks_mut(LANES * w)
        .zip(packets.par_iter())
        .enumerate()
        .for_each(|(i, (dst, p))| {
            let active = n.saturating_sub(i * LANES).min(LANES);
            let mut soa = vec![0.0f32; w * LANES];
            m.shade_x4(env, mask, p, active, &mut soa);
            for lane in 0..active {
                for k in 0..w {
                    dst[lane * w + k] = soa[k * LANES + lane];
                }
            }
        });
}

/// Writes every suite's CSV and SVG and the markdown summary into `dir`; returns the
/// summary.
pub fn write(
    dir: &Path,
    results: &[SuiteResult],
    opts: &BenchOptions,
    elapsed: f64,
) -> std::io::Result<String> {
    std::fs::create_dir_all(dir)?;
    let mut md = format!(
        "# shadenet bench{}\n\n{} threads available; times are medians of repeated runs (min–max beside) in one process on a machine that may be shared, so expect noise; ratios compare rows of this run. Error: against the f64 interpreter (reference rounded to f32, non-finite → 0); a pixel differs when some float differs by more than 2⁻¹⁰·max(1, |ref|). Whole run: {elapsed:.1} s.\n",
        if opts.quick { " --quick" } else { "" },
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    for r in results {
        let stem = r.name.to_lowercase();
        write_file(&dir.join(format!("{stem}.csv")), report::csv(&r.rows))?;
        write_file(
            &dir.join(format!("{stem}.svg")),
            if r.name == "B6" || r.name == "B8" {
                speed_error::svg(&format!("{} — {}", r.name, r.title), &r.rows)
            } else {
                report::svg(&format!("{} — {}", r.name, r.title), &r.rows)
            },
        )?;
        md.push_str(&format!(
            "\n## {} — {}\n\n{}{}",
            r.name,
            r.title,
            report::markdown(&r.rows),
            r.extra
        ));
    }
    write_file(&dir.join("summary.md"), &md)?;
    Ok(md)
}

/// Writes `contents` to a temporary file beside `path` and renames it over `path`, so an
/// interrupted or failed run never leaves a half-written result where an old one was.
fn write_file(path: &Path, contents: impl AsRef<[u8]>) -> std::io::Result<()> {
    let name = path
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let result = std::fs::write(&tmp, contents).and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
