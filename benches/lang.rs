//! Shading-language benchmarks: issue 21's figure — front end (preprocess, parse, check,
//! lower) + optimize + JIT of `benches/shaders/big.sl`, a 550-line RSL surface shader of our
//! own, on one thread; the target is ≤ 20 ms — and issue 22's: B1's multiplication tree at
//! level 10 as an OSL shader group of 2047 layers (`shadenet gen mult-tree -o
//! tree.oslgroup`), loaded from OSL's serialized text, lowered, optimized and JIT-compiled
//! (OSL's own optimizer and LLVM JIT take 60–120 ms for it, as issue 22 quotes).
//!
//! `cargo bench --bench lang` prints each step's best of ten runs (as the renderer compiles:
//! the scalar entry, the batch entry left for the first batch call; and with both entries),
//! then runs criterion on the first; `cargo test --benches` runs a quick check instead (the shader compiles).

use criterion::{Criterion, criterion_group};
use shadenet::graph::opt::{self, Specialization};
use shadenet::lang::{Options, SourceMap, lower, parse_file};
use shadenet::runtime::Backend;
use shadenet_jit::JitBackend;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn shader() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/shaders/big.sl")
}

/// Every step once: (parse, lower, optimize, JIT) times and (ops before, ops after). The
/// JIT compiles as the renderer asks it to (the scalar entry now, the batch entry on the
/// first batch call) or, with `both`, also makes one batch call, which compiles the batch
/// entry.
fn steps(path: &Path, both: bool) -> ([Duration; 4], (usize, usize)) {
    let t0 = Instant::now();
    let mut sources = SourceMap::new();
    let parsed = parse_file(&mut sources, path, &Options::default()).expect("big.sl parses");
    let t1 = Instant::now();
    let program =
        lower::compile(&parsed, None).unwrap_or_else(|d| panic!("{}", d.render(&sources)));
    let t2 = Instant::now();
    let spec = Specialization::default();
    let (optimized, _) = opt::run(&program, &spec);
    let t3 = Instant::now();
    // The JIT optimizes again inside `compile` (its own copy); the step here is the rest.
    let material = JitBackend::new()
        .compile(&program, &spec)
        .expect("the JIT compiles big.sl");
    if both {
        let env = shadenet::runtime::ShadeEnv::default();
        let frags = shadenet::runtime::FragmentX4::default();
        let mut out = vec![0.0f32; material.width() * 4];
        material.shade_x4(&env, u32::MAX, &frags, 1, &mut out);
    }
    let t4 = Instant::now();
    black_box(material);
    (
        [t1 - t0, t2 - t1, t3 - t2, t4 - t3],
        (program.exprs.len(), optimized.exprs.len()),
    )
}

/// Writes the level-10 tree group and its two shaders into a folder under the build
/// directory; returns the group file.
fn tree_group() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("lang_bench_tree");
    std::fs::create_dir_all(&dir).expect("a bench folder");
    for (name, source) in shadenet::generate::MULT_TREE_SHADERS {
        std::fs::write(dir.join(name), source).expect("a tree shader");
    }
    let group = dir.join("tree.oslgroup");
    let text = shadenet::generate::mult_tree_group(10).expect("level 10");
    std::fs::write(&group, text).expect("the tree group");
    group
}

/// The group's steps once: (load: group text and shader sources parsed, lower, optimize,
/// JIT compile — which optimizes its own copy again, so the pipeline is load + lower + JIT)
/// and (ops lowered, ops after optimization).
fn group_steps(path: &Path) -> ([Duration; 4], (usize, usize)) {
    let t0 = Instant::now();
    let mut sources = SourceMap::new();
    let loaded = shadenet::lang::group::load(&mut sources, path, &Options::default())
        .unwrap_or_else(|d| panic!("{}", d.render(&sources)));
    let t1 = Instant::now();
    let program =
        lower::compile_group(&loaded).unwrap_or_else(|d| panic!("{}", d.render(&sources)));
    let t2 = Instant::now();
    let spec = Specialization::default();
    let (optimized, _) = opt::run(&program, &spec);
    let t3 = Instant::now();
    let material = JitBackend::new()
        .compile(&program, &spec)
        .expect("the JIT compiles the tree");
    let t4 = Instant::now();
    black_box(material);
    (
        [t1 - t0, t2 - t1, t3 - t2, t4 - t3],
        (program.op_count(), optimized.op_count()),
    )
}

/// MaterialX's `genosl` implementations that compile (issue 22's figure: all of them
/// through the front end, the optimizer and the JIT in ≤ 1 s on one thread), when the
/// MaterialX libraries are found: (the module's source, the shaders' names, the folder,
/// the implementations).
type GenOslModule = (String, Vec<String>, PathBuf, Vec<shadenet::genosl::GenOsl>);

/// [`GenOslModule`] of the libraries found, if any.
fn genosl_module() -> Option<GenOslModule> {
    let dir = shadenet::mtlx::locate(None).ok()?;
    let lib = shadenet::mtlx::library(&dir).ok()?;
    let impls = shadenet::genosl::compiling(&dir, lib).ok()?;
    let (src, names) = shadenet::genosl::module_source(&impls, lib);
    Some((src, names.into_iter().map(|(_, s)| s).collect(), dir, impls))
}

/// Compiles every shader of the module: (parse, lower all, JIT all — which optimizes).
fn genosl_steps((src, names, dir, impls): &GenOslModule) -> [Duration; 3] {
    let t0 = Instant::now();
    let mut sources = SourceMap::new();
    let parsed =
        shadenet::genosl::parse_module(dir, impls, src, &mut sources).expect("the module parses");
    let t1 = Instant::now();
    let programs: Vec<_> = names
        .iter()
        .map(|n| lower::compile(&parsed, Some(n)).expect("a shader that compiled alone"))
        .collect();
    let t2 = Instant::now();
    let jit = JitBackend::new();
    let spec = Specialization::default();
    for p in &programs {
        black_box(jit.compile(p, &spec).expect("the JIT compiles it"));
    }
    [t1 - t0, t2 - t1, t2.elapsed()]
}

fn bench(c: &mut Criterion) {
    let path = shader();
    c.bench_function("lang/big_sl_front_end_optimize_jit", |b| {
        b.iter(|| black_box(steps(&path, false)))
    });
    let group = tree_group();
    c.bench_function("lang/b1_tree_group_level10_load_lower_optimize_jit", |b| {
        b.iter(|| black_box(group_steps(&group)))
    });
}

criterion_group!(benches, bench);

fn main() {
    let path = shader();
    let lines = std::fs::read_to_string(&path)
        .expect("big.sl")
        .lines()
        .count();
    if !std::env::args().any(|a| a == "--bench") {
        assert!(lines >= 500, "big.sl has {lines} lines, not ≥ 500");
        steps(&path, false);
        group_steps(&tree_group());
        println!(
            "lang bench smoke check: big.sl ({lines} lines) compiles (run `cargo bench --bench lang`)"
        );
        return;
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .ok();
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    for (what, both) in [
        (
            "the JIT's scalar entry; the batch entry on first use",
            false,
        ),
        ("both JIT entries", true),
    ] {
        let best = (0..10)
            .map(|_| steps(&path, both))
            .min_by_key(|r| r.0.iter().sum::<Duration>())
            .unwrap();
        let (t, (before, after)) = best;
        println!(
            "big.sl ({lines} lines; {before} IR values lowered, {after} after optimization; {what}): front end {:.2} ms, lower {:.2} ms, optimize {:.2} ms, JIT {:.2} ms, total {:.2} ms (best of 10, one thread)",
            ms(t[0]),
            ms(t[1]),
            ms(t[2]),
            ms(t[3]),
            ms(t.iter().sum())
        );
    }
    let group = tree_group();
    let (t, (before, after)) = (0..10)
        .map(|_| group_steps(&group))
        .min_by_key(|r| r.0.iter().sum::<Duration>())
        .unwrap();
    println!(
        "B1 tree, level 10, as an OSL group of 2047 layers ({before} ops lowered, {after} after optimization): load {:.2} ms, lower {:.2} ms, JIT compile {:.2} ms (of which optimize ≈ {:.2} ms), total {:.2} ms (best of 10, one thread)",
        ms(t[0]),
        ms(t[1]),
        ms(t[3]),
        ms(t[2]),
        ms(t[0] + t[1] + t[3])
    );
    match genosl_module() {
        Some(m) => {
            let t = genosl_steps(&m);
            println!(
                "MaterialX genosl: {} implementations: parse (headers and files once) {:.1} ms, lower all {:.1} ms, JIT all (optimize + codegen) {:.1} ms, total {:.1} ms (one thread; target 1 s)",
                m.1.len(),
                ms(t[0]),
                ms(t[1]),
                ms(t[2]),
                ms(t[0] + t[1] + t[2])
            );
        }
        None => println!("MaterialX genosl: skipped (no MaterialX libraries found)"),
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
