//! Fold and dead-branch keep results bit-identical in the f32 interpreter.
//!
//! - Every example network, optimized with only fold, dead_branch and DCE (parameters baked),
//!   shades a grid to exactly the same f32 bits as the unoptimized program, with fewer ops.
//! - Every fold and dead_branch filetest input gives the same bits before and after its pass.
//! - Random programs over hard constants (±0, ±inf, NaN, denormals, `i32` extremes), streams,
//!   selects, mixes and ifs give the same bits after each pass alone and after the pipeline;
//!   a pass that reports no change leaves the program exactly as it was.

use shadenet::shade::{grid_env, shade_grid};
use shadenet_graph::ir::{
    BinOp, Builder, Intrinsic, Program, Stream, UnOp, Value, parse, validate,
};
use shadenet_graph::nodes::{LightDesc, LightKind};
use shadenet_graph::opt::{self, Passes, Specialization, StopReason, dead_branch, fold};
use shadenet_graph::types::{ConstValue, Type};
use shadenet_graph::{NodeLibrary, compile_json};
use std::path::{Path, PathBuf};

fn only_fold_dead_branch_dce() -> Specialization {
    Specialization {
        passes: Passes {
            fold: true,
            dead_branch: true,
            dce: true,
            ..Passes::NONE
        },
        ..Specialization::default()
    }
}

fn lights() -> Vec<LightDesc> {
    vec![LightDesc {
        name: "key".into(),
        kind: LightKind::Point {
            position: [1.0, 1.0, 2.0],
        },
        power: [20.0; 3],
    }]
}

/// The f32 bits of every output of every pixel of a `w × h` grid (and the guard's count).
fn shade_bits(p: &Program, lights: &[LightDesc], w: u32, h: u32) -> (Vec<u32>, u64) {
    let env = grid_env(lights);
    let g = shade_grid::<f32>(p, &env, w, h, u32::MAX).expect("no textures to load");
    // The grid widens f32 to f64 exactly: narrowing back gives the shaded bits.
    let bits = g
        .pixel_values()
        .iter()
        .map(|x| (*x as f32).to_bits())
        .collect();
    (bits, g.nonfinite)
}

fn assert_same_bits(what: &str, before: &Program, after: &Program, lights: &[LightDesc]) {
    let (a, na) = shade_bits(before, lights, 16, 16);
    let (b, nb) = shade_bits(after, lights, 16, 16);
    assert_eq!(a.len(), b.len(), "{what}: output layout changed");
    if let Some(i) = (0..a.len()).find(|&i| a[i] != b[i]) {
        panic!(
            "{what}: value {i} differs: {} ({:#x}) before, {} ({:#x}) after\n--- before\n{before}\n--- after\n{after}",
            f32::from_bits(a[i]),
            a[i],
            f32::from_bits(b[i]),
            b[i]
        );
    }
    assert_eq!(na, nb, "{what}: non-finite counts differ");
}

fn files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

#[test]
fn examples_shade_bit_identically_after_fold_and_dead_branch() {
    let lib = NodeLibrary::standard();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/networks");
    let examples = files(&dir, "json");
    assert!(examples.len() >= 5, "expected the bundled examples");
    let spec = only_fold_dead_branch_dce();
    for path in examples {
        let what = path.display().to_string();
        let c = compile_json(&std::fs::read_to_string(&path).unwrap(), &lib)
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        let (opt, report) = opt::run(&c.program, &spec);
        validate(&opt).unwrap_or_else(|e| panic!("{what}: {e}\n{opt}"));
        assert_eq!(report.stop, StopReason::FixedPoint, "{what}\n{report}");
        assert!(
            opt.op_count() < c.program.op_count(),
            "{what}: {} ops before, {} after",
            c.program.op_count(),
            opt.op_count()
        );
        println!("{what}: {} → {} ops", c.program.op_count(), opt.op_count());
        let lights = if c.lights.is_empty() {
            lights()
        } else {
            c.lights.clone()
        };
        assert_same_bits(&what, &c.program, &opt, &lights);

        // At the fixed point both passes find nothing more and change nothing.
        let mut again = opt.clone();
        assert_eq!(
            fold::run(&mut again, &spec),
            0,
            "{what}: fold after fixed point"
        );
        assert_eq!(
            dead_branch::run(&mut again, &spec),
            0,
            "{what}: dead_branch"
        );
        assert_eq!(
            format!("{again:?}"),
            format!("{opt:?}"),
            "{what}: a pass reporting 0 changed the program"
        );
    }
}

#[test]
fn filetest_inputs_shade_bit_identically() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/filetests");
    let spec = Specialization::default();
    let mut count = 0;
    for (pass, run) in [
        ("fold", fold::run as opt::PassFn),
        ("dead_branch", dead_branch::run),
    ] {
        for path in files(&root.join(pass), "ir") {
            let text = std::fs::read_to_string(&path).unwrap();
            let input: String = text
                .lines()
                .filter(|l| !l.starts_with("; check:"))
                .map(|l| format!("{l}\n"))
                .collect();
            let before = parse(&input).unwrap();
            if !before.textures.is_empty() {
                continue; // its texture files are not there to load
            }
            let mut after = before.clone();
            run(&mut after, &spec);
            validate(&after).unwrap();
            assert_same_bits(&path.display().to_string(), &before, &after, &lights());
            count += 1;
        }
    }
    assert!(count >= 10, "only {count} filetests shaded");
}

// ---- random programs ----

/// xorshift64*: deterministic, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn pick<T: Copy>(&mut self, v: &[T]) -> T {
        v[self.below(v.len())]
    }
}

const FLOATS: &[f64] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    2.0,
    0.1,
    3.7,
    -2.5,
    1e30,
    -1e-40,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NAN,
];
const INTS: &[i32] = &[0, 1, -1, 7, -3, i32::MAX, i32::MIN];

/// Values built so far, by type.
#[derive(Clone, Default)]
struct Pool {
    f: Vec<Value>,
    v: Vec<Value>,
    i: Vec<Value>,
    b: Vec<Value>,
}

fn random_float_const(r: &mut Rng, b: &mut Builder) -> Value {
    let x = r.pick(FLOATS);
    b.float(x)
}

fn seed_pool(r: &mut Rng, b: &mut Builder, pool: &mut Pool) {
    let t = b.stream(Stream::Time);
    let uv = b.stream(Stream::Uv);
    let u = b.extract(uv, 0);
    let p = b.stream(Stream::P);
    let n = b.stream(Stream::N);
    let d = b.stream(Stream::RayDepth);
    pool.f.extend([t, u]);
    pool.v.extend([p, n]);
    pool.i.push(d);
    for _ in 0..4 {
        let c = random_float_const(r, b);
        pool.f.push(c);
    }
    for _ in 0..2 {
        let c = [r.pick(FLOATS), r.pick(FLOATS), r.pick(FLOATS)];
        let c = b.vec3(c);
        pool.v.push(c);
        let ones = b.vec3([1.0; 3]);
        let nz = b.vec3([-0.0; 3]);
        pool.v.extend([ones, nz]);
    }
    for _ in 0..3 {
        let k = r.pick(INTS);
        let c = b.int(k);
        pool.i.push(c);
    }
    let half = b.float(0.5);
    let lt = b.binary(BinOp::Lt, u, half);
    let tr = b.boolean(true);
    let fa = b.boolean(false);
    pool.b.extend([lt, tr, fa]);
}

/// Appends one random well-typed op to the builder's current block.
fn step(r: &mut Rng, b: &mut Builder, pool: &mut Pool, depth: u32) {
    use BinOp::*;
    use UnOp::*;
    let f = |r: &mut Rng, pool: &Pool| r.pick(&pool.f);
    let v = |r: &mut Rng, pool: &Pool| r.pick(&pool.v);
    let i = |r: &mut Rng, pool: &Pool| r.pick(&pool.i);
    let c = |r: &mut Rng, pool: &Pool| r.pick(&pool.b);
    match r.below(16) {
        0 => {
            let op = r.pick(&[Add, Sub, Mul, Div, Mod, Pow, Min, Max, Atan2]);
            let (x, y) = (f(r, pool), f(r, pool));
            let z = b.binary(op, x, y);
            pool.f.push(z);
        }
        1 => {
            let op = r.pick(&[
                Neg, Abs, Floor, Ceil, Fract, Sqrt, Exp, Log, Sin, Cos, Tan, Asin, Acos,
            ]);
            let x = f(r, pool);
            let z = b.unary(op, x);
            pool.f.push(z);
        }
        2 => {
            let op = r.pick(&[Add, Sub, Mul, Div, Min, Max, Cross]);
            let (x, y) = (v(r, pool), v(r, pool));
            let z = b.binary(op, x, y);
            pool.v.push(z);
        }
        3 => {
            let x = v(r, pool);
            let z = match r.below(4) {
                0 => b.unary(Neg, x),
                1 => b.unary(Normalize, x),
                2 => {
                    let k = r.below(3);
                    let e = b.extract(x, k);
                    pool.f.push(e);
                    return;
                }
                _ => {
                    let s = f(r, pool);
                    b.splat(Type::Vec3, s)
                }
            };
            pool.v.push(z);
        }
        4 => {
            let (x, y) = (v(r, pool), v(r, pool));
            let z = match r.below(3) {
                0 => b.dot(x, y),
                1 => b.binary(Distance, x, y),
                _ => b.unary(Length, x),
            };
            pool.f.push(z);
        }
        5 => {
            let args = [f(r, pool), f(r, pool), f(r, pool)];
            let z = b.construct(Type::Vec3, &args);
            pool.v.push(z);
        }
        6 => {
            let op = r.pick(&[Add, Sub, Mul, Div, Mod, Min, Max]);
            let (x, y) = (i(r, pool), i(r, pool));
            let z = b.binary(op, x, y);
            pool.i.push(z);
        }
        7 => match r.below(4) {
            0 => {
                let x = f(r, pool);
                let z = b.convert(Type::Int, x);
                pool.i.push(z);
            }
            1 => {
                let x = i(r, pool);
                let z = b.convert(Type::Float, x);
                pool.f.push(z);
            }
            2 => {
                let x = c(r, pool);
                let z = b.convert(Type::Int, x);
                pool.i.push(z);
            }
            _ => {
                let x = i(r, pool);
                let z = b.unary(r.pick(&[Neg, Abs]), x);
                pool.i.push(z);
            }
        },
        8 => {
            let op = r.pick(&[Lt, Le, Gt, Ge, Eq, Ne]);
            let z = if r.below(2) == 0 {
                let (x, y) = (f(r, pool), f(r, pool));
                b.binary(op, x, y)
            } else {
                let (x, y) = (i(r, pool), i(r, pool));
                b.binary(op, x, y)
            };
            pool.b.push(z);
        }
        9 => {
            let (x, y) = (c(r, pool), c(r, pool));
            let z = match r.below(3) {
                0 => b.binary(And, x, y),
                1 => b.binary(Or, x, y),
                _ => b.unary(Not, x),
            };
            pool.b.push(z);
        }
        10 => {
            let k = c(r, pool);
            match r.below(3) {
                0 => {
                    let (x, y) = (f(r, pool), f(r, pool));
                    let z = b.select(k, x, y);
                    pool.f.push(z);
                }
                1 => {
                    let (x, y) = (v(r, pool), v(r, pool));
                    let z = b.select(k, x, y);
                    pool.v.push(z);
                }
                _ => {
                    let x = i(r, pool);
                    let z = b.select(k, x, x);
                    pool.i.push(z);
                }
            }
        }
        11 => {
            // mix, with a weight that is often exactly 0 or 1.
            let t = match r.below(3) {
                0 => b.float(0.0),
                1 => b.float(1.0),
                _ => f(r, pool),
            };
            let (x, y) = (v(r, pool), v(r, pool));
            let z = b.mix(x, y, t);
            pool.v.push(z);
        }
        12 => {
            let x = v(r, pool);
            let z = if r.below(2) == 0 {
                b.call(Intrinsic::Noise3, &[x])
            } else {
                b.call(Intrinsic::CellNoise3, &[x])
            };
            pool.f.push(z);
        }
        13 if depth < 2 => {
            // An if yielding a float and a vec3, each arm a few ops deep.
            let cond = c(r, pool);
            let seed = r.next();
            let arm = |b: &mut Builder, salt: u64, pool: &Pool| {
                let mut r = Rng((seed ^ salt) | 1);
                let mut inner = pool.clone();
                for _ in 0..r.below(4) {
                    step(&mut r, b, &mut inner, depth + 1);
                }
                let fy = *inner.f.last().expect("seeded");
                let vy = *inner.v.last().expect("seeded");
                vec![fy, vy]
            };
            let snapshot = pool.clone();
            let res = b.if_(
                cond,
                |b| arm(b, 0x9e37_79b9, &snapshot),
                |b| arm(b, 0x85eb_ca6b, &snapshot),
            );
            pool.f.push(res[0]);
            pool.v.push(res[1]);
        }
        _ => {
            // Identity fodder: x*1, x-0, x+(-0), neg neg, min(x, x).
            let x = f(r, pool);
            let z = match r.below(5) {
                0 => {
                    let one = b.float(1.0);
                    b.mul(x, one)
                }
                1 => {
                    let zero = b.float(0.0);
                    b.sub(x, zero)
                }
                2 => {
                    let nz = b.float(-0.0);
                    b.add(nz, x)
                }
                3 => {
                    let n = b.unary(Neg, x);
                    b.unary(Neg, n)
                }
                _ => b.min(x, x),
            };
            pool.f.push(z);
        }
    }
}

fn random_program(seed: u64) -> Program {
    let mut r = Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
    let mut b = Builder::new("random");
    let mut pool = Pool::default();
    seed_pool(&mut r, &mut b, &mut pool);
    for _ in 0..40 {
        step(&mut r, &mut b, &mut pool, 0);
    }
    for (k, x) in pool.f.iter().rev().take(4).enumerate() {
        b.output(&format!("f{k}"), None, *x);
    }
    for (k, x) in pool.v.iter().rev().take(4).enumerate() {
        b.output(&format!("v{k}"), None, *x);
    }
    for (k, x) in pool.i.iter().rev().take(2).enumerate() {
        b.output(&format!("i{k}"), None, *x);
    }
    for (k, x) in pool.b.iter().rev().take(2).enumerate() {
        b.output(&format!("b{k}"), None, *x);
    }
    b.finish().expect("random programs are well typed")
}

#[test]
fn random_programs_shade_bit_identically() {
    let spec = only_fold_dead_branch_dce();
    let no_lights: Vec<LightDesc> = Vec::new();
    let mut folded = 0;
    let mut branches = 0;
    for s in 0..300 {
        let p = random_program(s);
        validate(&p).unwrap_or_else(|e| panic!("seed {s}: generator: {e}\n{p}"));
        for (name, pass) in [
            ("fold", fold::run as opt::PassFn),
            ("dead_branch", dead_branch::run),
        ] {
            let mut q = p.clone();
            let n = pass(&mut q, &spec);
            validate(&q).unwrap_or_else(|e| panic!("seed {s}: {name}: {e}\n{q}"));
            if n == 0 {
                // Compared through Debug: NaN constants are not `==` to themselves.
                assert_eq!(
                    format!("{q:?}"),
                    format!("{p:?}"),
                    "seed {s}: {name} reported 0 changes but changed the program"
                );
            }
            match name {
                "fold" => folded += n,
                _ => branches += n,
            }
            assert_same_bits(&format!("seed {s}, {name}"), &p, &q, &no_lights);
        }
        let (q, report) = opt::run(&p, &spec);
        assert_eq!(report.stop, StopReason::FixedPoint, "seed {s}\n{report}");
        assert_same_bits(&format!("seed {s}, pipeline"), &p, &q, &no_lights);
    }
    println!("fold changes: {folded}, dead_branch changes: {branches}");
    // The generator does exercise both passes.
    assert!(
        folded > 300 && branches > 30,
        "fold {folded}, dead_branch {branches}"
    );
}

#[test]
fn constants_are_stored_as_f32_results() {
    // 0.1 + 0.2 in f32, widened: not the f64 sum.
    let p = parse(
        r#"program "t" {
  %0 = const 0.1 : float
  %1 = const 0.2 : float
  %2 = add %0, %1 : float
  output o %2
}
"#,
    )
    .unwrap();
    let mut q = p.clone();
    assert_eq!(fold::run(&mut q, &Specialization::default()), 1);
    let want = (0.1f32 + 0.2f32) as f64;
    assert_eq!(
        q.exprs[2].op,
        shadenet_graph::ir::Op::Const(ConstValue::Float(want))
    );
    assert_ne!(want, 0.1 + 0.2);
    assert_eq!(fold::run(&mut q, &Specialization::default()), 0);
}
