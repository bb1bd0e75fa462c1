//! The JIT batch entry's math helpers (issue 23): each transcendental op over 2²⁰ inputs
//! (ordinary shading ranges; `pow_int`: integer exponents 1–64), four lanes at a time — per lane through the scalar op (what
//! the batch entry did before `ops::math_x4`), and through `ops::math_x4` on each SIMD path
//! the CPU has. One thread. `cargo bench --bench math`; `cargo test --benches` runs a quick
//! check that the paths agree instead.

use criterion::{Criterion, criterion_group};
use shadenet::graph::ops::{
    self,
    math_x4::{self, Binary, Path, Table, Unary},
};
use std::hint::black_box;

const N: usize = 1 << 20;

/// One op: its name, the four-lane form in a table, the scalar op, and the inputs' range.
enum Op {
    Un(&'static str, fn(&Table) -> Unary, fn(f32) -> f32, f32, f32),
    Bin(
        &'static str,
        fn(&Table) -> Binary,
        fn(f32, f32) -> f32,
        [f32; 4],
    ),
}

fn ops() -> Vec<Op> {
    vec![
        Op::Un("exp", |t| t.exp, ops::exp, -10.0, 10.0),
        Op::Un("log", |t| t.log, ops::log, 1e-3, 100.0),
        Op::Un("sin", |t| t.sin, ops::sin, -100.0, 100.0),
        Op::Un("cos", |t| t.cos, ops::cos, -100.0, 100.0),
        Op::Un("tan", |t| t.tan, ops::tan, -100.0, 100.0),
        Op::Un("asin", |t| t.asin, ops::asin, -1.0, 1.0),
        Op::Un("acos", |t| t.acos, ops::acos, -1.0, 1.0),
        Op::Bin("pow", |t| t.pow, ops::pow, [0.0, 4.0, 0.1, 40.0]),
        Op::Bin("atan2", |t| t.atan2, ops::atan2, [-5.0, 5.0, -5.0, 5.0]),
        // Integer exponents (a Phong or Blinn lobe's): the squaring loop.
        Op::Bin("pow_int", |t| t.pow, ops::pow, [0.0, 1.0, 1.0, 65.0]),
    ]
}

/// `n` values uniform in `[lo, hi)` (a fixed xorshift sequence).
fn uniform(n: usize, lo: f32, hi: f32, seed: u64) -> Vec<f32> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            lo + (s >> 40) as f32 / (1u64 << 24) as f32 * (hi - lo)
        })
        .collect()
}

/// The second operand of `op`: `pow_int`'s exponents are whole numbers.
fn second(name: &str, n: usize, lo: f32, hi: f32, seed: u64) -> Vec<f32> {
    let v = uniform(n, lo, hi, seed);
    if name == "pow_int" {
        v.into_iter().map(f32::floor).collect()
    } else {
        v
    }
}

fn packets(v: &[f32]) -> Vec<[f32; 4]> {
    v.chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect()
}

fn per_lane_un(f: fn(f32) -> f32, a: &[[f32; 4]]) -> f32 {
    let mut acc = 0.0;
    for p in a {
        for x in p {
            acc += f(*x);
        }
    }
    acc
}

fn x4_un(f: Unary, a: &[[f32; 4]]) -> f32 {
    let mut acc = 0.0;
    for p in a {
        for x in f(*p) {
            acc += x;
        }
    }
    acc
}

fn per_lane_bin(f: fn(f32, f32) -> f32, a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    let mut acc = 0.0;
    for (p, q) in a.iter().zip(b) {
        for l in 0..4 {
            acc += f(p[l], q[l]);
        }
    }
    acc
}

fn x4_bin(f: Binary, a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    let mut acc = 0.0;
    for (p, q) in a.iter().zip(b) {
        for x in f(*p, *q) {
            acc += x;
        }
    }
    acc
}

/// The paths this CPU can run, the scalar-per-lane one first.
fn paths() -> Vec<Path> {
    Path::ALL.into_iter().filter(|p| p.available()).collect()
}

fn bench(c: &mut Criterion) {
    for op in ops() {
        let mut g;
        match op {
            Op::Un(name, pick, scalar, lo, hi) => {
                let a = packets(&uniform(N, lo, hi, 0x9E37_79B9));
                g = c.benchmark_group(format!("{name}_1M"));
                g.sample_size(10);
                g.bench_function("per_lane_scalar", |b| {
                    b.iter(|| black_box(per_lane_un(scalar, &a)))
                });
                for path in paths() {
                    let f = pick(math_x4::table(path));
                    g.bench_function(format!("x4_{path:?}"), |b| {
                        b.iter(|| black_box(x4_un(f, &a)))
                    });
                }
            }
            Op::Bin(name, pick, scalar, r) => {
                let a = packets(&uniform(N, r[0], r[1], 0x9E37_79B9));
                let bb = packets(&second(name, N, r[2], r[3], 0x2545_F491));
                g = c.benchmark_group(format!("{name}_1M"));
                g.sample_size(10);
                g.bench_function("per_lane_scalar", |b| {
                    b.iter(|| black_box(per_lane_bin(scalar, &a, &bb)))
                });
                for path in paths() {
                    let f = pick(math_x4::table(path));
                    g.bench_function(format!("x4_{path:?}"), |b| {
                        b.iter(|| black_box(x4_bin(f, &a, &bb)))
                    });
                }
            }
        }
        g.finish();
    }
}

criterion_group!(benches, bench);

fn main() {
    if !std::env::args().any(|a| a == "--bench") {
        for op in ops() {
            match op {
                Op::Un(name, pick, scalar, lo, hi) => {
                    let a = packets(&uniform(4096, lo, hi, 7));
                    let want = per_lane_un(scalar, &a);
                    for path in paths() {
                        let got = x4_un(pick(math_x4::table(path)), &a);
                        assert_eq!(got.to_bits(), want.to_bits(), "{name} on {path:?}");
                    }
                }
                Op::Bin(name, pick, scalar, r) => {
                    let a = packets(&uniform(4096, r[0], r[1], 7));
                    let b = packets(&second(name, 4096, r[2], r[3], 8));
                    let want = per_lane_bin(scalar, &a, &b);
                    for path in paths() {
                        let got = x4_bin(pick(math_x4::table(path)), &a, &b);
                        assert_eq!(got.to_bits(), want.to_bits(), "{name} on {path:?}");
                    }
                }
            }
        }
        println!("math bench smoke check: ok (run `cargo bench --bench math`)");
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
