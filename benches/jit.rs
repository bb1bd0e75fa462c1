//! Benchmark B1 (DESIGN §9): the multiplication tree of Larsson 2005 (§5.1.1), shading only,
//! 640×480 fragments, CSE off, on one thread; and B4: preprocessing (link + optimize + JIT)
//! against network size.
//!
//! Back ends: the interpreter, the JIT's scalar entry (one call per fragment), the JIT's
//! batch entry (one call per packet of four) and the native reference (the same trees
//! written out as Rust by `build.rs` and compiled by rustc with optimizations: the ceiling).
//!
//! The workloads are `shadenet::bench::workloads` (shared with `shadenet bench`, no copy).
//! The fragments lie on the face z = 1 of the box [1, 2]³, which fills the frame:
//! `P = (1 + u, 1 + v, 1)`. Products of numbers ≥ 1 never become denormal (they overflow to
//! +inf, which the guard zeroes and counts), so the timings measure per-node work, not the
//! microcode assists denormal operands cost on x86.
//!
//! `cargo bench --bench jit` prints the README's table (levels 1–10; each time the best of a
//! few runs, all in one process), then runs criterion on level 10.
//! `SHADENET_B1_LEVELS=8,10` restricts the table's levels; `SHADENET_B1_TABLE_ONLY=1` skips
//! criterion.

use criterion::{Criterion, criterion_group};
use shadenet::bench::workloads::{
    self, packets, shade_packets, shade_scalar, tree_fragments, tree_program, tree_spec,
};
use shadenet::graph::ir::Space;
use shadenet::graph::opt::Specialization;
use shadenet::graph::{NodeLibrary, compile_json};
use shadenet::runtime::{
    Backend, Fragment, FragmentX4, InterpBackend, LANES, Material, ShadeCtx, ShadeEnv,
};
use shadenet_jit::JitBackend;
use std::hint::black_box;
use std::sync::Arc;
use std::time::{Duration, Instant};

const W: u32 = shadenet::bench::workloads::B1_SIZE.0;
const H: u32 = shadenet::bench::workloads::B1_SIZE.1;

fn fragments() -> Vec<Fragment> {
    tree_fragments(W, H)
}

fn spec() -> Specialization {
    tree_spec(false)
}

struct Level {
    level: u32,
    interp: Arc<dyn Material>,
    jit: Arc<dyn Material>,
}

fn prepare(level: u32) -> Level {
    let program = tree_program(level, Space::World);
    let interp = InterpBackend.compile(&program, &spec()).expect("interp");
    let jit = JitBackend::new().compile(&program, &spec()).expect("jit");
    assert!(jit.info().fallback.is_none());
    Level { level, interp, jit }
}

fn shade_batch(m: &dyn Material, env: &ShadeEnv, packets: &[FragmentX4], out: &mut [f32]) -> u64 {
    shade_packets(m, env, packets, out)
}

fn shade_native(level: u32, packets: &[FragmentX4], out: &mut [f32]) -> u64 {
    workloads::shade_native(level, packets, out).unwrap_or(0)
}

/// The best of at least `reps` runs of `f` (at least one), in seconds; fast runs repeat
/// until about a second has passed (at most 50 runs), so that the best is a quiet one on a
/// machine shared with other work.
fn best(reps: usize, mut f: impl FnMut() -> u64) -> (f64, u64) {
    let mut t = f64::INFINITY;
    let mut r = 0;
    let start = Instant::now();
    let mut n = 0;
    while n < reps.max(1) || (start.elapsed().as_secs_f64() < 1.0 && n < 50) {
        let s = Instant::now();
        r = black_box(f());
        t = t.min(s.elapsed().as_secs_f64());
        n += 1;
    }
    (t, r)
}

/// Preprocessing of one level: link (parse + link + lower), then optimize + JIT; the best
/// of `reps` runs, with the JIT's phases of that run.
fn preprocess(level: u32, reps: usize) -> (Duration, Duration, shadenet::runtime::CompileStats) {
    let net = shadenet::generate::mult_tree(level, Space::World)
        .expect("levels")
        .to_string();
    let lib = NodeLibrary::standard();
    let mut best: Option<(Duration, Duration, shadenet::runtime::CompileStats)> = None;
    for _ in 0..reps {
        let t = Instant::now();
        let c = compile_json(&net, &lib).expect("tree links");
        let link = t.elapsed();
        let m = JitBackend::new().compile(&c.program, &spec()).expect("jit");
        let total = t.elapsed();
        if best.as_ref().is_none_or(|b| total < b.1) {
            best = Some((link, total, m.info().stats));
        }
    }
    best.expect("one run")
}

fn levels() -> Vec<u32> {
    std::env::var("SHADENET_B1_LEVELS")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or_else(|| (1..=10).collect())
}

fn table() {
    let frags = fragments();
    let packs = packets(&frags);
    let env = ShadeEnv::default();
    let mut out = vec![0.0f32; 3 * LANES];
    println!("\nB1 — multiplication tree, shading only, {W}×{H} fragments, CSE off, 1 thread");
    println!(
        "| level | products | interp (ms) | JIT scalar (ms) | JIT batch (ms) | native (ms) | batch vs interp | batch vs native |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for level in levels() {
        let l = prepare(level);
        let reps_interp = if level >= 8 { 1 } else { 3 };
        let (ti, bi) = best(reps_interp, || {
            shade_scalar(&*l.interp, &env, &frags, &mut out)
        });
        let (ts, bs) = best(5, || shade_scalar(&*l.jit, &env, &frags, &mut out));
        let (tb, bb) = best(5, || shade_batch(&*l.jit, &env, &packs, &mut out));
        let (tn, bn) = best(5, || shade_native(l.level, &packs, &mut out));
        assert_eq!(
            bi, bs,
            "scalar JIT and interpreter count the same non-finite values"
        );
        assert_eq!(
            bi, bb,
            "batch JIT and interpreter count the same non-finite values"
        );
        if cfg!(target_arch = "x86_64") {
            assert_eq!(
                bi, bn,
                "native and interpreter count the same non-finite values"
            );
        }
        println!(
            "| {level} | {} | {:.1} | {:.2} | {:.2} | {:.2} | {:.1}× | {:.2}× |",
            (1u32 << level) - 1,
            ti * 1e3,
            ts * 1e3,
            tb * 1e3,
            tn * 1e3,
            ti / tb,
            tn / tb
        );
    }
    println!(
        "\nB4 — preprocessing: link (parse, link, lower) + optimize + JIT (both entries), best of 5"
    );
    println!(
        "| level | nodes | ops | link (ms) | optimize (ms) | lower (ms) | Cranelift (ms) | JIT link (ms) | total (ms) | CLIF insts | code (bytes) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for level in levels() {
        let (link, total, s) = preprocess(level, 5);
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        println!(
            "| {level} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {} |",
            (1u32 << (level + 1)) - 1,
            s.ops,
            ms(link),
            ms(s.optimize),
            ms(s.lower),
            ms(s.codegen),
            ms(s.link),
            ms(total),
            s.ir_insts,
            s.code_bytes
        );
    }
    println!();
}

fn b1(c: &mut Criterion) {
    table();
    if std::env::var_os("SHADENET_B1_TABLE_ONLY").is_some() {
        return;
    }
    let frags = fragments();
    let packs = packets(&frags);
    let env = ShadeEnv::default();
    let mut out = vec![0.0f32; 3 * LANES];
    let l = prepare(10);
    let mut g = c.benchmark_group("b1_level10");
    g.sample_size(10);
    g.bench_function("jit_batch", |b| {
        b.iter(|| shade_batch(&*l.jit, &env, &packs, &mut out))
    });
    g.bench_function("native", |b| b.iter(|| shade_native(10, &packs, &mut out)));
    g.bench_function("jit_scalar", |b| {
        b.iter(|| shade_scalar(&*l.jit, &env, &frags, &mut out))
    });
    g.bench_function("interp", |b| {
        b.iter(|| shade_scalar(&*l.interp, &env, &frags, &mut out))
    });
    g.finish();
    let mut g = c.benchmark_group("b4_preprocess");
    g.sample_size(20);
    let lib = NodeLibrary::standard();
    let net = shadenet::generate::mult_tree(10, Space::World)
        .expect("levels")
        .to_string();
    g.bench_function("level10", |b| {
        b.iter(|| {
            let c = compile_json(&net, &lib).expect("tree links");
            JitBackend::new().compile(&c.program, &spec()).expect("jit")
        })
    });
    g.finish();
}

criterion_group!(benches, b1);

/// `cargo test --benches` (no `--bench` argument) runs a quick check instead: every back end
/// and the native reference agree at levels 1–4 on a small frame.
fn smoke() {
    let frags: Vec<Fragment> = fragments().into_iter().step_by(997).collect();
    let packs = packets(&frags);
    let env = ShadeEnv::default();
    for level in 1..=4 {
        let l = prepare(level);
        let mut outs: Vec<Vec<u32>> = Vec::new();
        for run in 0..4 {
            let mut all = Vec::new();
            let mut out = vec![0.0f32; 3 * LANES];
            for (i, p) in packs.iter().enumerate() {
                let n = (frags.len() - i * LANES).min(LANES);
                match run {
                    0 => {
                        l.interp.shade_x4(&env, u32::MAX, p, n, &mut out);
                    }
                    1 => {
                        l.jit.shade_x4(&env, u32::MAX, p, n, &mut out);
                    }
                    2 => {
                        for lane in 0..n {
                            let ctx = ShadeCtx::new(p.lane(lane), &env);
                            let mut one = [0.0f32; 3];
                            l.jit.shade(&ctx, &mut one);
                            for k in 0..3 {
                                out[k * LANES + lane] = one[k];
                            }
                        }
                    }
                    _ => {
                        if cfg!(not(target_arch = "x86_64")) {
                            continue;
                        }
                        shade_native(level, std::slice::from_ref(p), &mut out);
                    }
                }
                for lane in 0..n {
                    for k in 0..3 {
                        all.push(out[k * LANES + lane].to_bits());
                    }
                }
            }
            outs.push(all);
        }
        for (i, o) in outs.iter().enumerate().skip(1) {
            assert!(
                o.is_empty() || *o == outs[0],
                "level {level}: run {i} differs"
            );
        }
    }
    println!("jit bench smoke check: ok (run `cargo bench --bench jit` to measure)");
}

fn main() {
    if !std::env::args().any(|a| a == "--bench") {
        smoke();
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
