//! Shading-language benchmark (issue 21's performance figure): front end (preprocess, parse,
//! check, lower) + optimize + JIT of `benches/shaders/big.sl`, a 550-line RSL surface shader
//! of our own, on one thread; the target is ≤ 20 ms.
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

fn bench(c: &mut Criterion) {
    let path = shader();
    c.bench_function("lang/big_sl_front_end_optimize_jit", |b| {
        b.iter(|| black_box(steps(&path, false)))
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
    benches();
    Criterion::default().configure_from_args().final_summary();
}
