//! The WGSL emitter and library (`shadenet_gpu::emit`) against `shadenet_graph::ops`.
//!
//! - naga validates the library, the texture library and a kernel for every op of the table
//!   (no device needed), and parses every literal back to the same bits;
//! - on the device, [`op_table_on_the_device`] runs every pure op on every type it is defined
//!   on over ordinary and hard inputs (0, -0, subnormals, ±inf, NaN, 1e30, tiny, integer
//!   extremes, random bit patterns) and compares with the ops evaluated in f32: the exact
//!   class bit for bit, the transcendental class within the bounds documented in
//!   `gpu/src/emit.rs` (the measured worst errors are printed);
//! - constants, output columns and texture lookups on the device.
//!
//! On a hardware GPU (or under `SHADENET_GPU_ACCURACY=hardware`) the device's results are
//! held to the hardware contract instead (`shadenet_gpu::testing::hardware`): each case
//! against the CPU's result for its operands as they are or with subnormals flushed, within
//! the row's `OpClass` bound ([`hw_class`]: exact, sqrt 1 ulp, division 3, contracted sums of
//! products 4, noise 16) or the hardware bound of its transcendental; bilinear lookups within
//! 2 ulps of max(1, r); the key test up to flushing.
//!
//! Device tests skip (printing why) without an adapter, unless `SHADENET_REQUIRE_GPU=1`.

use shadenet_gpu::emit::{
    self, columns, float_literal, literal, load_columns, op_expr, output_columns, store_columns,
    wgsl_type,
};
use shadenet_gpu::testing::hardware::{self, OpClass};
use shadenet_gpu::testing::{
    Bound, Transcendental as Trans, accuracy, device_or_skip, documented_bound, ulps, within,
};
use shadenet_gpu::{Accuracy, GpuContext};
use shadenet_graph::ir::{BinOp, Expr, Intrinsic, Op, Program, UnOp, Value};
use shadenet_graph::ir::{Filter, Sampling, Wrap};
use shadenet_graph::ops::{self, Val};
use shadenet_graph::types::{ConstValue, Type};
use shadenet_runtime::Texture;
use shadenet_runtime::texture::TextureSet;
use std::fmt::Write as _;
use wgpu::util::DeviceExt;

// ---- naga ----

fn validate(src: &str) -> Result<(), String> {
    let module = naga::front::wgsl::parse_str(src).map_err(|e| e.emit_to_string(src))?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| e.emit_to_string(src))?;
    Ok(())
}

/// The intrinsic library with the albedo tables' binding declared (`sn_tables`, which `run`
/// binds whenever a module declares it).
fn library() -> String {
    format!("{}{}", emit::library(), emit::TABLES_DECLARATION)
}

const TEXTURE_BINDINGS: &str = "
@group(0) @binding(5) var<storage, read> sn_texels: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> sn_tex_info: array<vec4<u32>>;
";

#[test]
fn the_libraries_validate() {
    validate(&library()).unwrap_or_else(|e| panic!("LIBRARY:\n{e}"));
    let src = format!("{}{TEXTURE_BINDINGS}{}", library(), emit::TEXTURE_LIBRARY);
    validate(&src).unwrap_or_else(|e| panic!("TEXTURE_LIBRARY:\n{e}"));
    // Every function of the library is named sn_*.
    for lib in [emit::library(), emit::TEXTURE_LIBRARY] {
        for line in lib.lines() {
            if let Some(rest) = line.strip_prefix("fn ") {
                assert!(rest.starts_with("sn_"), "{line}");
            }
        }
    }
}

/// naga folds constant expressions and rejects a fold that overflows (`1e30f * 1e30f`), and
/// its validator rejects an integer division by a `let` bound to zero, where the IR defines
/// both; constants from `op_expr` are never folded, even when the operands are written
/// inline.
#[test]
fn constant_expressions_are_not_folded_by_naga() {
    let mut p = Program::default();
    let push = |p: &mut Program, op: Op, ty: Type| {
        p.exprs.push(Expr { op, ty: Some(ty) });
        Value::new(p.exprs.len() - 1)
    };
    let big = push(&mut p, Op::Const(ConstValue::Float(1e30)), Type::Float);
    let zero = push(&mut p, Op::Const(ConstValue::Int(0)), Type::Int);
    let seven = push(&mut p, Op::Const(ConstValue::Int(7)), Type::Int);
    let sq = push(&mut p, Op::Binary(BinOp::Mul, big, big), Type::Float);
    let q = push(&mut p, Op::Binary(BinOp::Div, seven, zero), Type::Int);
    let r = push(&mut p, Op::Binary(BinOp::Mod, seven, zero), Type::Int);
    let e = push(&mut p, Op::Unary(UnOp::Exp, big), Type::Float);
    let c = push(&mut p, Op::Convert(big), Type::Int);
    // Operands as `let` variables, and written inline (the whole tree in one expression).
    fn inline(p: &Program, v: Value) -> String {
        op_expr(p, v, &mut |a| inline(p, a)).unwrap()
    }
    let mut body = String::new();
    for v in [big, zero, seven, sq, q, r, e, c] {
        let x = op_expr(&p, v, &mut |a| format!("v{}", a.index())).unwrap();
        writeln!(body, "    let v{} = {x};", v.index()).unwrap();
        writeln!(body, "    let w{} = {};", v.index(), inline(&p, v)).unwrap();
    }
    let src = format!(
        "{}\nfn f(sn_keep: u32) -> f32 {{\n{body}    return v{sq} + f32(v{q} + v{r} + v{c}) + v{e} + w{sq} + f32(w{q} + w{r} + w{c}) + w{e};\n}}\n",
        library(),
        sq = sq.index(),
        q = q.index(),
        r = r.index(),
        e = e.index(),
        c = c.index(),
    );
    validate(&src).unwrap_or_else(|e| panic!("{e}\n{body}"));
    // The premise: bare literals are folded and rejected.
    for bare in [
        "fn f() -> f32 {\n    return 1e30f * 1e30f;\n}\n",
        "fn f() -> f32 {\n    return exp(1e30f);\n}\n",
        "fn f() -> i32 {\n    let z = 0i;\n    return 7i / z;\n}\n",
    ] {
        assert!(validate(bare).is_err(), "naga accepts {bare}");
    }
}

/// The value naga gives a module-scope `const` written with a literal.
fn naga_const_f32(lit: &str) -> f32 {
    let src = format!("const C: f32 = {lit};\n");
    let module = naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{lit}: {e}"));
    let (_, c) = module.constants.iter().next().expect("a constant");
    match module.global_expressions[c.init] {
        naga::Expression::Literal(naga::Literal::F32(x)) => x,
        ref other => panic!("{lit}: {other:?}"),
    }
}

#[test]
fn float_literals_parse_back_to_the_same_bits_in_naga() {
    let mut rng = Rng(0x1234_5678);
    let mut xs: Vec<f32> = HARD.to_vec();
    xs.extend((0..3000).map(|_| f32::from_bits(rng.next() as u32)));
    xs.extend((0..3000).map(|_| rng.float()));
    let mut checked = 0;
    for x in xs {
        let lit = float_literal(x);
        if lit.starts_with("bitcast") {
            // Non-finite and subnormal: checked on the device (constants_are_exact_on_the_device).
            assert!(!x.is_finite() || x.is_subnormal(), "{x:?} → {lit}");
            continue;
        }
        let back = naga_const_f32(&lit);
        assert_eq!(back.to_bits(), x.to_bits(), "{x:?} → {lit} → {back:?}");
        checked += 1;
    }
    assert!(checked > 5000, "{checked}");
}

// ---- inputs ----

/// Ordinary and hard floats (the parity suite's list).
const HARD: &[f32] = shadenet_runtime::testing::HARD_FLOATS;

/// Ordinary and extreme ints (the parity suite's list).
const INTS: &[i32] = shadenet_runtime::testing::HARD_INTS;

/// A small deterministic generator (xorshift).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }

    /// A float from a mix: any bit pattern, uniform in [-1, 1], [-10, 10], [-1e4, 1e4],
    /// log-uniform over the whole range with either sign, or a hard value.
    fn float(&mut self) -> f32 {
        let s = |u: f32| 2.0 * u - 1.0;
        match self.below(6) {
            0 => f32::from_bits(self.next() as u32),
            1 => s(self.unit()),
            2 => 10.0 * s(self.unit()),
            3 => 1e4 * s(self.unit()),
            4 => {
                let e = -149.0 + 277.0 * self.unit();
                let m = 2f32.powf(e.fract()) * 2f32.powi(e.floor() as i32);
                if self.below(2) == 0 { m } else { -m }
            }
            _ => HARD[self.below(HARD.len() as u64) as usize],
        }
    }

    fn int(&mut self) -> i32 {
        match self.below(4) {
            0 => self.next() as i32,
            1 => self.below(81) as i32 - 40,
            2 => INTS[self.below(INTS.len() as u64) as usize],
            _ => (self.next() as i32) >> self.below(31),
        }
    }
}

/// Matrices the table cycles through: the parity suite's, the identity, one with hard
/// entries.
fn matrices() -> Vec<[f32; 16]> {
    vec![
        [
            2.0, -1.0, 0.5, 3.0, 0.0, 1e-30, -0.0, 1e30, 1.5, 2.5, -3.5, 0.25, 0.0, 0.0, 0.0, 1.0,
        ],
        [
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ],
        [
            f32::INFINITY,
            1e-45,
            -0.0,
            f32::NAN,
            0.1,
            -7.75,
            f32::MAX,
            3.0,
            -1e30,
            0.5,
            16777216.0,
            -3e-41,
            1.0,
            2.0,
            3.0,
            4.0,
        ],
    ]
}

// ---- the op table ----

/// How a row is compared.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Class {
    /// Bit for bit (NaN equals NaN).
    Exact,
    /// The device's transcendental function: within the documented bound of the op.
    Transcendental(Trans),
}

/// One row: an op over operands of the given types (operand `k` is value `k`, a
/// placeholder), its result type, its class.
struct Row {
    name: String,
    operands: Vec<Type>,
    op: Op,
    ty: Type,
    class: Class,
    /// Random cases beyond the systematic hard ones.
    random: usize,
    /// How the operands reach the op.
    variant: Variant,
}

/// How a row's operands reach the op: the shader compiler may rewrite an expression whose
/// operands are the same value (`a * b + a * c` → `a * (b + c)`, `a - a` → 0), so the table
/// also runs every binary op on one value twice, and every vector op on vectors whose
/// components are one value.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Variant {
    /// Each operand loaded from its own columns.
    Plain,
    /// A binary op on one operand twice (`op(a0, a0)`).
    Same,
    /// Every vector operand built from one scalar (`vec3(s, s, s)`).
    Splat,
}

impl Row {
    fn program(&self) -> (Program, Value) {
        let mut p = Program::default();
        for (k, t) in self.operands.iter().enumerate() {
            p.exprs.push(Expr {
                op: Op::Param(k as u32),
                ty: Some(*t),
            });
        }
        p.exprs.push(Expr {
            op: self.op.clone(),
            ty: Some(self.ty),
        });
        let v = Value::new(p.exprs.len() - 1);
        (p, v)
    }

    fn in_width(&self) -> usize {
        self.operands.iter().map(|t| columns(*t)).sum()
    }
}

const TYPES: [Type; 8] = [
    Type::Float,
    Type::Vec2,
    Type::Vec3,
    Type::Color,
    Type::Vec4,
    Type::Color4,
    Type::Int,
    Type::Bool,
];

fn v(k: usize) -> Value {
    Value::new(k)
}

/// Every pure op on every type it is defined on.
fn op_table() -> Vec<Row> {
    let mut rows = Vec::new();
    let mut row = |name: String, operands: Vec<Type>, op: Op, ty: Type, class: Class| {
        let random = match class {
            Class::Transcendental(_) if operands[0] == Type::Float => 20_000,
            _ => 2_000,
        };
        rows.push(Row {
            name,
            operands,
            op,
            ty,
            class,
            random,
            variant: Variant::Plain,
        });
    };
    for &op in UnOp::ALL {
        for ty in TYPES {
            if let Some(rt) = ops::unary_type(op, ty) {
                let class = Trans::of_unary(op).map_or(Class::Exact, Class::Transcendental);
                let name = format!("{} {}", op.name(), ty.name());
                row(name, vec![ty], Op::Unary(op, v(0)), rt, class);
            }
        }
    }
    for &op in BinOp::ALL {
        for ty in TYPES {
            if let Some(rt) = ops::binary_type(op, ty, ty) {
                let class = Trans::of_binary(op).map_or(Class::Exact, Class::Transcendental);
                let name = format!("{} {}", op.name(), ty.name());
                row(name, vec![ty, ty], Op::Binary(op, v(0), v(1)), rt, class);
            }
        }
    }
    for op in [BinOp::MulPoint, BinOp::MulVector] {
        let name = op.name().to_string();
        let operands = vec![Type::Matrix44, Type::Vec3];
        row(
            name,
            operands,
            Op::Binary(op, v(0), v(1)),
            Type::Vec3,
            Class::Exact,
        );
    }
    for ty in TYPES.into_iter().chain([Type::Matrix44]) {
        let sel = Op::Select {
            cond: v(0),
            a: v(1),
            b: v(2),
        };
        let operands = vec![Type::Bool, ty, ty];
        row(
            format!("select {}", ty.name()),
            operands,
            sel,
            ty,
            Class::Exact,
        );
        for to in [Type::Bool, Type::Int, Type::Float] {
            if ops::convert_ok(ty, to) {
                let name = format!("convert {} → {}", ty.name(), to.name());
                row(name, vec![ty], Op::Convert(v(0)), to, Class::Exact);
            }
        }
        if ty.is_vector() {
            for i in 0..ty.width() {
                let name = format!("extract {} {i}", ty.name());
                let op = Op::Extract(v(0), i as u8);
                row(name, vec![ty], op, Type::Float, Class::Exact);
            }
            let name = format!("splat {}", ty.name());
            row(name, vec![Type::Float], Op::Splat(v(0)), ty, Class::Exact);
            let args: Vec<Value> = (0..ty.width()).map(v).collect();
            let name = format!("construct {}", ty.name());
            let operands = vec![Type::Float; ty.width()];
            row(name, operands, Op::Construct(args), ty, Class::Exact);
        }
    }
    for &i in Intrinsic::ALL {
        let operands = match i {
            Intrinsic::Noise2 => vec![Type::Vec2],
            Intrinsic::Noise3 | Intrinsic::CellNoise3 => vec![Type::Vec3],
            Intrinsic::Fbm3 => vec![Type::Vec3, Type::Int, Type::Float, Type::Float],
            Intrinsic::RgbToHsv | Intrinsic::HsvToRgb => vec![Type::Color],
            Intrinsic::GgxAlbedo | Intrinsic::SheenAlbedo => vec![Type::Float, Type::Float],
            Intrinsic::DielectricAlbedo => vec![Type::Float; 3],
            osl => ops::osl_intrinsic_operands(osl)
                .expect("an OSL noise intrinsic")
                .to_vec(),
        };
        let rt = ops::intrinsic_type(i, &operands).expect("intrinsic type");
        let args: Vec<Value> = (0..operands.len()).map(v).collect();
        row(
            i.name().into(),
            operands,
            Op::Call(i, args),
            rt,
            Class::Exact,
        );
    }
    let mut variants = Vec::new();
    for r in &rows {
        let binary = matches!(r.op, Op::Binary(..)) && r.operands[0] == r.operands[1];
        let vector = r.operands.iter().any(|t| t.is_vector());
        for (ok, variant, label) in [
            (binary, Variant::Same, "(a, a)"),
            (vector, Variant::Splat, "(splat)"),
        ] {
            if ok {
                variants.push(Row {
                    name: format!("{} {label}", r.name),
                    operands: r.operands.clone(),
                    op: r.op.clone(),
                    ty: r.ty,
                    class: r.class,
                    random: r.random.min(2_000),
                    variant,
                });
            }
        }
    }
    rows.extend(variants);
    rows
}

/// The operands of one case, as the columns the kernel loads (floats, ints as bits, bools
/// as 0/1, matrices row-major).
fn cases(row: &Row) -> Vec<Vec<f32>> {
    let h = HARD;
    let n = h.len();
    let mats = matrices();
    let mut out = Vec::new();
    // Systematic: every pair (i, j) of hard values; operand 0 follows i, operand 1 follows j,
    // the other components mix them.
    for i in 0..n {
        for j in 0..n {
            let mut case = Vec::new();
            for (k, t) in row.operands.iter().enumerate() {
                let pick = |c: usize| match (k + c) % 3 {
                    0 => h[i],
                    1 => h[j],
                    _ => h[(i * 7 + j * 3 + k + c) % n],
                };
                match t {
                    Type::Bool => case.push(if (i >> k) & 1 == j & 1 { 1.0 } else { 0.0 }),
                    Type::Int => {
                        let x = INTS[if k % 2 == 0 { i } else { j } % INTS.len()];
                        // fbm3's octave count: also the interesting small ones.
                        let x = if row.operands.len() == 4 {
                            (x % 20) - 1
                        } else {
                            x
                        };
                        case.push(f32::from_bits(x as u32))
                    }
                    Type::Matrix44 => case.extend(mats[(i + j) % mats.len()]),
                    t => case.extend((0..t.width()).map(pick)),
                }
            }
            out.push(case);
        }
    }
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ (row.name.len() as u64 * 0x1000_0001));
    for _ in 0..row.random {
        let mut case = Vec::new();
        for t in &row.operands {
            match t {
                Type::Bool => case.push(rng.below(2) as f32),
                Type::Int => case.push(f32::from_bits(rng.int() as u32)),
                Type::Matrix44 => case.extend((0..16).map(|_| rng.float())),
                t => case.extend((0..t.width()).map(|_| rng.float())),
            }
        }
        out.push(case);
    }
    if row.class == Class::Transcendental(Trans::Pow)
        && row.operands[0] == Type::Float
        && row.variant == Variant::Plain
    {
        // Negative bases with integer exponents, and ordinary positive bases.
        for k in 0..row.random {
            let base = if k % 2 == 0 {
                rng.float()
            } else {
                4.0 * rng.unit()
            };
            let e = if k % 3 == 0 {
                rng.below(81) as f32 - 40.0
            } else {
                120.0 * rng.unit() - 60.0
            };
            out.push(vec![base, e]);
        }
    }
    if let (Class::Transcendental(t), Variant::Plain) = (row.class, row.variant)
        && row.operands[0] == Type::Float
    {
        // Where the functions are hardest: subnormal and overflowing exponentials, logs
        // near 1, sines near their zeros and extrema, arcsines near ±1, atan2 near the
        // diagonals and at extreme ratios.
        let u = |rng: &mut Rng, lo: f32, hi: f32| lo + (hi - lo) * rng.unit();
        for _ in 0..4000 {
            let x = match t {
                Trans::Exp => match rng.below(2) {
                    0 => u(&mut rng, -104.0, -86.0),
                    _ => u(&mut rng, 87.0, 89.0),
                },
                Trans::Log => match rng.below(2) {
                    0 => u(&mut rng, 0.9, 1.1),
                    _ => 1.0 + u(&mut rng, -1e-3, 1e-3),
                },
                Trans::Sin | Trans::Cos | Trans::Tan => {
                    let k = rng.below(6000) as f64;
                    let x = k * std::f64::consts::FRAC_PI_2 + (u(&mut rng, -1e-3, 1e-3) as f64);
                    x as f32
                }
                Trans::Asin | Trans::Acos => {
                    let a = 1.0 - 2f32.powf(-u(&mut rng, 1.0, 24.0));
                    if rng.below(2) == 0 { a } else { -a }
                }
                Trans::Atan2 | Trans::Pow => 0.0,
            };
            match t {
                Trans::Atan2 => {
                    let y = rng.float();
                    let x = match rng.below(3) {
                        0 => y * u(&mut rng, 0.9, 1.1),
                        1 => -y * u(&mut rng, 0.9, 1.1),
                        _ => y * 2f32.powf(u(&mut rng, -40.0, 40.0)),
                    };
                    out.push(vec![y, x]);
                }
                Trans::Pow => {}
                _ => out.push(vec![x]),
            }
        }
    }
    for case in &mut out {
        match row.variant {
            Variant::Plain => {}
            Variant::Same => {
                let w = columns(row.operands[0]);
                let (a, b) = case.split_at_mut(w);
                b[..w].copy_from_slice(a);
            }
            Variant::Splat => {
                let mut at = 0;
                for t in &row.operands {
                    let w = columns(*t);
                    if t.is_vector() {
                        let first = case[at];
                        case[at..at + w].fill(first);
                    }
                    at += w;
                }
            }
        }
    }
    out
}

/// An operand as the interpreter holds it (and its matrix, for matrix operands).
fn to_val(ty: Type, cols: &[f32]) -> (Val<f32>, [f32; 16]) {
    let mut m = [0.0; 16];
    let v = match ty {
        Type::Bool => Val::Bool(cols[0] != 0.0),
        Type::Int => Val::Int(cols[0].to_bits() as i32),
        Type::Float => Val::Float(cols[0]),
        Type::Vec2 => Val::Vec2([cols[0], cols[1]]),
        Type::Vec3 | Type::Color => Val::Vec3([cols[0], cols[1], cols[2]]),
        Type::Vec4 | Type::Color4 => Val::Vec4([cols[0], cols[1], cols[2], cols[3]]),
        Type::Matrix33 | Type::Matrix44 => {
            let n = ty.width();
            m[..n].copy_from_slice(&cols[..n]);
            Val::Mat(0)
        }
        Type::String | Type::Closure(_) => Val::Int(0),
    };
    (v, m)
}

/// The row's op evaluated by `shadenet_graph::ops` in f32, as stored columns.
fn eval_cpu(row: &Row, case: &[f32]) -> Vec<f32> {
    let mut args = Vec::new();
    let mut at = 0;
    for t in &row.operands {
        args.push(to_val(*t, &case[at..at + columns(*t)]));
        at += columns(*t);
    }
    let a = |k: usize| args[k].0;
    let vals: Vec<Val<f32>> = args.iter().map(|x| x.0).collect();
    let r = match &row.op {
        Op::Unary(op, _) => ops::unary(*op, a(0)),
        Op::Binary(BinOp::MulPoint, ..) => Val::Vec3(ops::mul_point(&args[0].1, a(1).as_vec3())),
        Op::Binary(BinOp::MulVector, ..) => Val::Vec3(ops::mul_vector(&args[0].1, a(1).as_vec3())),
        Op::Binary(op, ..) => ops::binary(*op, a(0), a(1)),
        Op::Select { .. } if row.ty == Type::Matrix44 => {
            let pick = if a(0).as_bool() { 1 } else { 2 };
            return args[pick].1.to_vec();
        }
        Op::Select { .. } => ops::select(a(0), a(1), a(2)),
        Op::Construct(_) => ops::construct(row.ty, &vals),
        Op::Extract(_, i) => ops::extract(a(0), *i),
        Op::Splat(_) => ops::splat(row.ty, a(0)),
        Op::Convert(_) => ops::convert(row.ty, a(0)),
        Op::Call(i, _) => ops::intrinsic(*i, &vals),
        other => panic!("{}: not in the table: {other:?}", row.name),
    };
    match r {
        Val::Bool(b) => vec![if b { 1.0 } else { 0.0 }],
        Val::Int(i) => vec![f32::from_bits(i as u32)],
        v => v.floats().to_vec(),
    }
}

/// The kernel of a row: invocation `i` loads case `i`, computes the op, stores the result.
fn row_kernel(row: &Row, n: usize) -> String {
    let (p, value) = row.program();
    let in_w = row.in_width();
    let out_w = columns(row.ty);
    let mut s = String::new();
    s.push_str("@group(0) @binding(0) var<storage, read> sn_in: array<f32>;\n");
    s.push_str("@group(0) @binding(1) var<storage, read_write> sn_res: array<f32>;\n");
    s.push_str(&library());
    s.push_str("\n@compute @workgroup_size(64)\n");
    s.push_str("fn main(@builtin(global_invocation_id) gid: vec3<u32>) {\n");
    writeln!(
        s,
        "    let i = gid.x;\n    if (i >= {n}u) {{\n        return;\n    }}"
    )
    .unwrap();
    // The key: word 0 of the input, a zero.
    writeln!(s, "    let sn_keep = bitcast<u32>(sn_in[0]);").unwrap();
    let mut col = 0;
    for (k, t) in row.operands.iter().enumerate() {
        let splat = row.variant == Variant::Splat && t.is_vector();
        let cols: Vec<String> = (0..columns(*t))
            .map(|c| {
                format!(
                    "sn_in[1u + i * {in_w}u + {}u]",
                    col + if splat { 0 } else { c }
                )
            })
            .collect();
        let ty = wgsl_type(*t).unwrap();
        if splat {
            // One scalar, every component (the compiler sees one value).
            writeln!(s, "    let s{k}: f32 = {};", cols[0]).unwrap();
            let cols = vec![format!("s{k}"); columns(*t)];
            writeln!(s, "    let a{k}: {ty} = {};", load_columns(*t, &cols)).unwrap();
        } else {
            writeln!(s, "    let a{k}: {ty} = {};", load_columns(*t, &cols)).unwrap();
        }
        col += columns(*t);
    }
    let same = row.variant == Variant::Same;
    let e = op_expr(&p, value, &mut |a| {
        format!("a{}", if same { 0 } else { a.index() })
    })
    .unwrap_or_else(|e| panic!("{}: {e}", row.name));
    writeln!(s, "    let r: {} = {e};", wgsl_type(row.ty).unwrap()).unwrap();
    for (c, x) in store_columns(row.ty, "r").iter().enumerate() {
        writeln!(s, "    sn_res[i * {out_w}u + {c}u] = {x};").unwrap();
    }
    s.push_str("}\n");
    s
}

#[test]
fn every_row_kernel_validates() {
    let rows = op_table();
    assert!(rows.len() > 120, "{} rows", rows.len());
    for row in &rows {
        let src = row_kernel(row, 1);
        validate(&src).unwrap_or_else(|e| panic!("{}:\n{e}", row.name));
    }
}

// ---- the device ----

/// Runs `main` of `src` over `n` invocations: `input` at binding 0, `extra` read-only
/// buffers at their bindings, an output of `out_len` words at binding 1; returns the output.
fn run(
    ctx: &GpuContext,
    src: &str,
    input: &[f32],
    extra: &[(u32, &[u8])],
    out_len: usize,
    n: usize,
) -> Vec<u32> {
    if let Err(e) = validate(src) {
        panic!("{e}");
    }
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: None,
        source: wgpu::ShaderSource::Wgsl(src.into()),
    });
    let storage = |contents: &[u8]| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents,
            usage: wgpu::BufferUsages::STORAGE,
        })
    };
    let input = if input.is_empty() {
        &[0.0f32][..]
    } else {
        input
    };
    let inbuf = storage(bytemuck::cast_slice(input));
    let extra_bufs: Vec<(u32, wgpu::Buffer)> =
        extra.iter().map(|(b, c)| (*b, storage(c))).collect();
    let size = (out_len.max(1) * 4) as u64;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    // The albedo tables where the module declares them (the whole library does).
    let mut extra_bufs = extra_bufs;
    if src.contains(emit::TABLES_DECLARATION) {
        extra_bufs.push((
            emit::TABLES_BINDING,
            storage(bytemuck::cast_slice(emit::albedo_tables())),
        ));
    }
    // An explicit layout: a binding the entry point does not reach may stay in it.
    let entry = |binding: u32, read_only: bool| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let mut layout_entries = vec![entry(0, true), entry(1, false)];
    layout_entries.extend(extra_bufs.iter().map(|(b, _)| entry(*b, true)));
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &layout_entries,
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let t_compile = std::time::Instant::now();
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let mut entries = vec![
        wgpu::BindGroupEntry {
            binding: 0,
            resource: inbuf.as_entire_binding(),
        },
        wgpu::BindGroupEntry {
            binding: 1,
            resource: out.as_entire_binding(),
        },
    ];
    for (b, buf) in &extra_bufs {
        entries.push(wgpu::BindGroupEntry {
            binding: *b,
            resource: buf.as_entire_binding(),
        });
    }
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &layout,
        entries: &entries,
    });
    if std::env::var("SN_ROW").is_ok() {
        eprintln!("compiled in {:?}", t_compile.elapsed());
    }
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((n as u32).div_ceil(64).max(1), 1, 1);
    }
    enc.copy_buffer_to_buffer(&out, 0, &readback, 0, size);
    ctx.queue.submit([enc.finish()]);
    readback
        .slice(..)
        .map_async(wgpu::MapMode::Read, |r| r.unwrap());
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("device poll");
    let words =
        bytemuck::cast_slice::<u8, u32>(&readback.slice(..).get_mapped_range().unwrap()).to_vec();
    readback.unmap();
    words[..out_len].to_vec()
}

/// Whether the device flushes subnormal results to zero (lavapipe does not).
fn flushes_subnormals(ctx: &GpuContext) -> bool {
    let src = "@group(0) @binding(0) var<storage, read> sn_in: array<f32>;
@group(0) @binding(1) var<storage, read_write> sn_res: array<f32>;
@compute @workgroup_size(1)
fn main() {
    sn_res[0] = sn_in[0] * sn_in[1];
}
";
    let r = run(ctx, src, &[1e-40, 1.5], &[], 1, 1);
    f32::from_bits(r[0]) != 1e-40 * 1.5
}

/// Exact comparison of one column: the same bits, or both NaN (floats only), or — on a
/// device that flushes subnormals — a subnormal CPU result against a zero.
fn exact_eq(ty: Type, got: u32, want: f32, flush: bool) -> bool {
    let g = f32::from_bits(got);
    got == want.to_bits()
        || (ty != Type::Int && g.is_nan() && want.is_nan())
        || (flush && want.is_subnormal() && g == 0.0)
}

#[test]
fn op_table_on_the_device() {
    let Some(ctx) = device_or_skip("op_table_on_the_device") else {
        return;
    };
    let flush = flushes_subnormals(&ctx);
    let hw = accuracy(&ctx) == Accuracy::Hardware;
    eprintln!(
        "device: {} (flushes subnormals: {flush}; {})",
        ctx.info.name,
        ctx.accuracy.describe()
    );
    let mut failures = Failures::default();
    let mut measured: Vec<(Trans, Stats)> = Vec::new();
    let mut exact_rows = 0;
    let mut compared = 0usize;
    let mut slow = Vec::new();
    for row in op_table() {
        let t0 = std::time::Instant::now();
        if std::env::var("SN_ROW").is_ok_and(|r| !row.name.contains(&r)) {
            continue;
        }
        let cases = cases(&row);
        let n = cases.len();
        let input: Vec<f32> = std::iter::once(0.0)
            .chain(cases.iter().flatten().copied())
            .collect();
        let out_w = columns(row.ty);
        let got = run(&ctx, &row_kernel(&row, n), &input, &[], n * out_w, n);
        for (k, case) in cases.iter().enumerate() {
            let got = &got[k * out_w..(k + 1) * out_w];
            compared += out_w;
            if hw {
                if let Err(e) = hw_check(&row, case, got, &mut measured) {
                    failures.add(&row.name, || e);
                }
                continue;
            }
            let want = eval_cpu(&row, case);
            match row.class {
                Class::Exact => {
                    for c in 0..out_w {
                        if !exact_eq(row.ty, got[c], want[c], flush) {
                            failures.add(&row.name, || {
                                format!(
                                    "{}: inputs {:?} ({:08x?}): column {c}: got {:?} ({:#010x}), \
                                 want {:?} ({:#010x})",
                                    row.name,
                                    case,
                                    case.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                                    f32::from_bits(got[c]),
                                    got[c],
                                    want[c],
                                    want[c].to_bits()
                                )
                            });
                        }
                    }
                }
                Class::Transcendental(t) => {
                    let stats = match measured.iter_mut().find(|(x, _)| *x == t) {
                        Some((_, s)) => s,
                        None => {
                            measured.push((t, Stats::default()));
                            &mut measured.last_mut().unwrap().1
                        }
                    };
                    let w = row.ty.width();
                    for c in 0..out_w {
                        // Component-wise ops: component c of every operand.
                        let x = case[c];
                        let y = if row.operands.len() > 1 {
                            case[w + c]
                        } else {
                            0.0
                        };
                        let g = f32::from_bits(got[c]);
                        if let Err(why) = stats.record(t, (x, y), g, want[c], false) {
                            failures.add(&row.name, || {
                                format!(
                                    "{}: inputs ({x:?}, {y:?}) ({:#010x}, {:#010x}): got {g:?} \
                                 ({:#010x}), want {:?} ({:#010x}): {why}",
                                    row.name,
                                    x.to_bits(),
                                    y.to_bits(),
                                    got[c],
                                    want[c],
                                    want[c].to_bits()
                                )
                            });
                        }
                    }
                }
            }
        }
        if row.class == Class::Exact {
            exact_rows += 1;
        }
        slow.push((t0.elapsed(), row.name.clone()));
    }
    slow.sort();
    eprintln!("slowest rows: {:?}", &slow[slow.len().saturating_sub(8)..]);
    eprintln!(
        "total {:?}",
        slow.iter().map(|x| x.0).sum::<std::time::Duration>()
    );
    measured.sort_by_key(|(t, _)| *t);
    for (t, s) in &measured {
        eprintln!("{t:?}:\n{s}");
    }
    eprintln!("{exact_rows} exact rows, {compared} columns compared");
    assert!(
        failures.count == 0,
        "{} differences from the CPU in {} rows:\n{}",
        failures.count,
        failures.rows.len(),
        failures.report()
    );
}

/// Which of a row's operand columns are floats (an int operand's column holds its bits).
fn float_columns(row: &Row) -> Vec<bool> {
    row.operands
        .iter()
        .flat_map(|t| std::iter::repeat_n(*t != Type::Int, columns(*t)))
        .collect()
}

/// What bounds a row's op on hardware (see `shadenet_gpu::testing::hardware`).
fn hw_class(row: &Row) -> OpClass {
    use BinOp as B;
    match &row.op {
        Op::Unary(UnOp::Sqrt, _) => OpClass::Sqrt,
        Op::Unary(UnOp::Length | UnOp::Normalize, _) => OpClass::Contracted,
        Op::Binary(B::Div, ..) => OpClass::Div,
        Op::Binary(B::Mod | B::Dot | B::Cross | B::Distance | B::MulPoint | B::MulVector, ..) => {
            OpClass::Contracted
        }
        Op::Call(Intrinsic::RgbToHsv | Intrinsic::HsvToRgb, _) => OpClass::Contracted,
        Op::Call(
            Intrinsic::Fbm3
            | Intrinsic::MxFractal2
            | Intrinsic::MxFractal3
            | Intrinsic::MxVFractal2
            | Intrinsic::MxVFractal3,
            _,
        ) => OpClass::Fractal,
        Op::Call(..) => OpClass::Noise,
        _ => OpClass::Exact,
    }
}

/// The hardware contract on one case of a row: free where a float operand is
/// ([`hardware::free_operand`]); otherwise the device's result must be within the row's
/// bound of the CPU's for the operands as they are or flushed ([`hardware::ftz_variants`]),
/// one variant for the whole case. Transcendental rows also record their worst errors.
fn hw_check(
    row: &Row,
    case: &[f32],
    got: &[u32],
    measured: &mut Vec<(Trans, Stats)>,
) -> Result<(), String> {
    let is_float = float_columns(row);
    let floats: Vec<f32> = case
        .iter()
        .zip(&is_float)
        .filter(|(_, f)| **f)
        .map(|(x, _)| *x)
        .collect();
    if floats.iter().any(|x| hardware::free_operand(*x)) {
        return Ok(());
    }
    let variants: Vec<Vec<f32>> = hardware::ftz_variants(&floats)
        .into_iter()
        .map(|v| {
            let mut it = v.into_iter();
            case.iter()
                .zip(&is_float)
                .map(|(x, f)| if *f { it.next().unwrap() } else { *x })
                .collect()
        })
        .collect();
    let wants: Vec<Vec<f32>> = variants.iter().map(|v| eval_cpu(row, v)).collect();
    let m = floats.iter().fold(0.0f32, |a, x| a.max(x.abs()));
    let class = hw_class(row);
    let col_ok = |c: usize, v: usize| {
        let (g, want) = (f32::from_bits(got[c]), wants[v][c]);
        match row.class {
            _ if row.ty == Type::Int => got[c] == want.to_bits(),
            // A result the CPU overflows on finite operands is free (WGSL).
            _ if !want.is_finite() => true,
            Class::Transcendental(t) => {
                let (x, y) = hw_args(row, &variants[v], c);
                let (_, bound) = hardware::transcendental_bound(t, x, y, want);
                hardware::within(bound, x, g, want)
            }
            Class::Exact => {
                let scale = match class {
                    OpClass::Noise | OpClass::Texture => want.abs(),
                    _ => (m * m.max(1.0)).max(want.abs()),
                };
                hardware::close(class, g, want, scale)
            }
        }
    };
    let out_w = got.len();
    if let Class::Transcendental(t) = row.class {
        let stats = match measured.iter_mut().position(|(x, _)| *x == t) {
            Some(i) => &mut measured[i].1,
            None => {
                measured.push((t, Stats::default()));
                &mut measured.last_mut().unwrap().1
            }
        };
        for c in 0..out_w {
            let v = (0..variants.len()).find(|&v| col_ok(c, v)).unwrap_or(0);
            let g = f32::from_bits(got[c]);
            let args = hw_args(row, &variants[v], c);
            if wants[v][c].is_finite() {
                stats.record(t, args, g, wants[v][c], true).map_err(|why| {
                    format!(
                        "{}: operands {args:?}: got {g:?} ({:#010x}), want {:?}: {why}",
                        row.name, got[c], wants[v][c]
                    )
                })?;
            }
        }
        return Ok(());
    }
    if (0..variants.len()).any(|v| (0..out_w).all(|c| col_ok(c, v))) {
        return Ok(());
    }
    let c = (0..out_w).find(|&c| !col_ok(c, 0)).unwrap_or(0);
    Err(format!(
        "{}: inputs {:?} ({:08x?}): column {c}: got {:?} ({:#010x}), want {:?} ({:#010x}) \
         (or the same for the operands flushed), hardware bound {class:?}",
        row.name,
        case,
        case.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
        f32::from_bits(got[c]),
        got[c],
        wants[0][c],
        wants[0][c].to_bits()
    ))
}

/// The arguments of component `c` of a component-wise transcendental row.
fn hw_args(row: &Row, case: &[f32], c: usize) -> (f32, f32) {
    let w = row.ty.width();
    let y = if row.operands.len() > 1 {
        case[w + c]
    } else {
        0.0
    };
    (case[c], y)
}

/// Differences found, per row: how many, and the first few in words.
#[derive(Default)]
struct Failures {
    count: usize,
    rows: Vec<(String, usize, Vec<String>)>,
}

impl Failures {
    fn add(&mut self, row: &str, what: impl FnOnce() -> String) {
        self.count += 1;
        if self.rows.last().is_none_or(|r| r.0 != row) {
            self.rows.push((row.to_string(), 0, Vec::new()));
        }
        let r = self.rows.last_mut().unwrap();
        r.1 += 1;
        if r.2.len() < 3 {
            r.2.push(what());
        }
    }

    fn report(&self) -> String {
        let mut s = String::new();
        for (row, n, first) in &self.rows {
            writeln!(s, "{row}: {n} differences, e.g.").unwrap();
            for f in first {
                writeln!(s, "    {f}").unwrap();
            }
        }
        s
    }
}

// ---- transcendental bounds ----

/// Worst errors of one op, per input domain.
#[derive(Default)]
struct Stats {
    domains: Vec<(&'static str, Worst)>,
}

#[derive(Default, Clone, Copy)]
struct Worst {
    count: usize,
    bound: Option<Bound>,
    ulps: u64,
    ulps_at: (f32, f32),
    /// The worst error / (|x| (1 + want²)) beyond the ulps bound (`Bound::Reduced`).
    reduced: f64,
}

impl std::fmt::Display for Stats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (d, w) in &self.domains {
            writeln!(
                f,
                "  {d:<45} {:>6} values: worst {:>10} ulps at {:?}; bound {:?}",
                w.count,
                w.ulps,
                w.ulps_at,
                w.bound.unwrap_or(Bound::Exact)
            )?;
            if w.reduced > 0.0 {
                writeln!(
                    f,
                    "  {:<45} beyond the ulps: worst error / (|x| (1 + want²)) = 2^{:.1}",
                    "",
                    w.reduced.log2()
                )?;
            }
        }
        Ok(())
    }
}

impl Stats {
    /// Records one comparison; `Err` when it breaks the op's documented bound.
    /// On hardware (`hw`) the bound is [`hardware::transcendental_bound`], checked on the
    /// flushed values.
    fn record(
        &mut self,
        t: Trans,
        (x, y): (f32, f32),
        got: f32,
        want: f32,
        hw: bool,
    ) -> Result<(), String> {
        let (d, bound) = if hw {
            hardware::transcendental_bound(t, x, y, want)
        } else {
            documented_bound(t, x, y, want)
        };
        let (got, want) = if hw {
            (hardware::flush(got), hardware::flush(want))
        } else {
            (got, want)
        };
        let w = match self.domains.iter_mut().find(|(n, _)| *n == d) {
            Some((_, w)) => w,
            None => {
                self.domains.push((d, Worst::default()));
                &mut self.domains.last_mut().unwrap().1
            }
        };
        w.count += 1;
        w.bound = Some(bound);
        let u = if got.is_nan() && want.is_nan() {
            0
        } else {
            ulps(got, want)
        };
        if u > w.ulps {
            w.ulps = u;
            w.ulps_at = (x, y);
        }
        // The error in units of |x| (1 + want²) where the ulps bound does not hold.
        if let Bound::Reduced { ulps: n, .. } = bound
            && ulps(got, want) > n
        {
            let e =
                (got as f64 - want as f64).abs() / (x.abs() as f64 * (1.0 + (want as f64).powi(2)));
            w.reduced = w.reduced.max(e);
        }
        let ok = if hw {
            hardware::within(bound, x, got, want)
        } else {
            within(bound, x, got, want)
        };
        if ok {
            Ok(())
        } else {
            Err(format!("outside the bound {bound:?}"))
        }
    }
}

// ---- constants, outputs, textures ----

#[test]
fn constants_are_exact_on_the_device() {
    let Some(ctx) = device_or_skip("constants_are_exact_on_the_device") else {
        return;
    };
    let mut rng = Rng(77);
    let mut consts: Vec<ConstValue> = Vec::new();
    let mut floats: Vec<f32> = HARD.to_vec();
    floats.extend((0..200).map(|_| f32::from_bits(rng.next() as u32)));
    floats.extend((0..200).map(|_| rng.float()));
    consts.extend(floats.iter().map(|x| ConstValue::Float(*x as f64)));
    consts.extend(INTS.iter().map(|i| ConstValue::Int(*i)));
    consts.extend([ConstValue::Bool(true), ConstValue::Bool(false)]);
    consts.push(ConstValue::Vec2([-0.0, 1e-45]));
    consts.push(ConstValue::Vec3([f64::INFINITY, 0.1, -3e-41]));
    consts.push(ConstValue::Color([0.25, f64::NAN, 1e30]));
    consts.push(ConstValue::Matrix44(matrices()[2].map(|x| x as f64)));
    // A float constant written in f64 is rounded to f32 as the interpreter does.
    consts.push(ConstValue::Float(0.1));
    consts.push(ConstValue::Float(1e-300));
    consts.push(ConstValue::Float(-1e300));
    let mut p = Program::default();
    let mut body = String::new();
    let mut want: Vec<(Type, f32)> = Vec::new();
    for c in &consts {
        p.exprs.push(Expr {
            op: Op::Const(c.clone()),
            ty: Some(c.ty()),
        });
        let v = Value::new(p.exprs.len() - 1);
        let e = op_expr(&p, v, &mut |_| unreachable!()).unwrap();
        writeln!(body, "    let c{} = {e};", v.index()).unwrap();
        let cols: Vec<f32> = match c {
            ConstValue::Bool(b) => vec![*b as u32 as f32],
            ConstValue::Int(i) => vec![f32::from_bits(*i as u32)],
            c => c.floats().iter().map(|x| *x as f32).collect(),
        };
        let stored = store_columns(c.ty(), &format!("c{}", v.index()));
        assert_eq!(stored.len(), cols.len());
        for (x, w) in stored.iter().zip(cols) {
            writeln!(body, "    sn_res[{}] = {x};", want.len()).unwrap();
            want.push((c.ty(), w));
        }
        // Also the bare literal (no identity around it).
        let lit = literal(c).unwrap();
        writeln!(body, "    let l{} = {lit};", v.index()).unwrap();
    }
    let src = format!(
        "@group(0) @binding(0) var<storage, read> sn_in: array<f32>;
@group(0) @binding(1) var<storage, read_write> sn_res: array<f32>;
{}
@compute @workgroup_size(1)
fn main() {{
    let sn_keep = bitcast<u32>(sn_in[0]);
{body}}}
",
        library()
    );
    let got = run(&ctx, &src, &[0.0], &[], want.len(), 1);
    for (k, ((ty, w), g)) in want.iter().zip(&got).enumerate() {
        let same = *g == w.to_bits();
        assert!(
            same,
            "column {k} ({ty}): got {:?} ({g:#010x}), want {w:?} ({:#010x})",
            f32::from_bits(*g),
            w.to_bits()
        );
    }
}

#[test]
fn output_columns_follow_the_interpreter_layout() {
    let Some(ctx) = device_or_skip("output_columns_follow_the_interpreter_layout") else {
        return;
    };
    // ints as f32(i) (rounded to nearest), bools as 0/1, floats as they are
    let ints: Vec<i32> = INTS
        .iter()
        .copied()
        .chain([
            16777217,
            -16777217,
            16777219,
            2147483520,
            2147483584,
            -2147483585,
        ])
        .collect();
    let mut body = String::new();
    let mut want: Vec<f32> = Vec::new();
    for (k, i) in ints.iter().enumerate() {
        let e = format!("bitcast<i32>(sn_in[{k}])");
        for x in output_columns(Type::Int, &e) {
            writeln!(body, "    sn_res[{}] = {x};", want.len()).unwrap();
            want.push(*i as f32);
        }
    }
    for b in [true, false] {
        for x in output_columns(Type::Bool, &b.to_string()) {
            writeln!(body, "    sn_res[{}] = {x};", want.len()).unwrap();
            want.push(if b { 1.0 } else { 0.0 });
        }
    }
    for x in output_columns(Type::Matrix44, "m") {
        writeln!(body, "    sn_res[{}] = {x};", want.len()).unwrap();
        want.push(0.0);
    }
    let e = "vec3<f32>(sn_in[0], -0.0f, 1.5f)";
    for (k, x) in output_columns(Type::Color, e).iter().enumerate() {
        writeln!(body, "    sn_res[{}] = {x};", want.len()).unwrap();
        want.push([0.0, -0.0, 1.5][k]);
    }
    let src = format!(
        "@group(0) @binding(0) var<storage, read> sn_in: array<f32>;
@group(0) @binding(1) var<storage, read_write> sn_res: array<f32>;
@compute @workgroup_size(1)
fn main() {{
    let m = array<vec4<f32>, 4>();
{body}}}
"
    );
    let input: Vec<f32> = ints.iter().map(|i| f32::from_bits(*i as u32)).collect();
    let got = run(&ctx, &src, &input, &[], want.len(), 1);
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(
            *g,
            w.to_bits(),
            "column {k}: got {:?}, want {w:?}",
            f32::from_bits(*g)
        );
    }
}

/// Every filter and wrap mode of `sn_texture` against the texture system's `lookup`, over
/// textures of several sizes (mip pyramids of one to five levels), hard and random uv, and
/// footprints from none to huge, anisotropic and non-finite: closest and bilinear bit for
/// bit, trilinear and anisotropic within 1e-4 (the level of detail takes WGSL's log2, the
/// CPU its own series).
#[test]
fn texture_lookups_match_the_cpu() {
    let Some(ctx) = device_or_skip("texture_lookups_match_the_cpu") else {
        return;
    };
    let mut rng = Rng(4242);
    let textures: Vec<Texture> = [(3u32, 2u32), (1, 1), (5, 7), (16, 9)]
        .iter()
        .map(|&(width, height)| {
            let texels = (0..width * height)
                .map(|_| [rng.unit(), rng.unit(), 2.0 * rng.unit() - 0.5, rng.unit()])
                .collect();
            Texture::from_texels(width, height, texels)
        })
        .collect();
    let set = TextureSet::from_textures(textures);
    let nt = 4usize;
    let (texels, info) = shadenet_gpu::textures::texture_buffers(nt, &set).unwrap();
    let samplings: Vec<Sampling> = Filter::ALL
        .iter()
        .flat_map(|&filter| {
            [
                [Wrap::Periodic, Wrap::Periodic],
                [Wrap::Clamp, Wrap::Mirror],
                [Wrap::Mirror, Wrap::Black],
                [Wrap::Black, Wrap::Clamp],
            ]
            .map(|wrap| Sampling { filter, wrap })
        })
        .collect();
    // Each case: uv, ∂uv/∂x, ∂uv/∂y.
    let mut cases: Vec<[f32; 6]> = Vec::new();
    for a in HARD {
        for b in HARD {
            cases.push([*a, *b, 0.0, 0.0, 0.0, 0.0]);
        }
    }
    for k in 0..1500 {
        let uv = [3.0 * rng.unit() - 1.0, 3.0 * rng.unit() - 1.0];
        let scale = [0.0, 1e-3, 0.03, 0.2, 1.5][k % 5];
        let d: [f32; 4] = std::array::from_fn(|_| scale * (2.0 * rng.unit() - 1.0));
        // Every third footprint is stretched 10:1 along x.
        let d = if k % 3 == 0 {
            [d[0] * 10.0, d[1], d[2], d[3] * 0.1]
        } else {
            d
        };
        cases.push([uv[0], uv[1], d[0], d[1], d[2], d[3]]);
    }
    for bad in [f32::NAN, f32::INFINITY, -f32::INFINITY, 3e38] {
        cases.push([0.3, 0.6, bad, 0.01, 0.02, bad]);
    }
    let n = cases.len();
    let ns = samplings.len();
    let bits: Vec<String> = samplings.iter().map(|s| format!("{}u", s.bits())).collect();
    let src = format!(
        "@group(0) @binding(0) var<storage, read> sn_in: array<f32>;
@group(0) @binding(1) var<storage, read_write> sn_res: array<f32>;
{TEXTURE_BINDINGS}
{}
{}
const SAMPLINGS = array<u32, {ns}>({});
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let i = gid.x;
    if (i >= {n}u) {{
        return;
    }}
    let uv = vec2<f32>(sn_in[6u * i], sn_in[6u * i + 1u]);
    let dx = vec2<f32>(sn_in[6u * i + 2u], sn_in[6u * i + 3u]);
    let dy = vec2<f32>(sn_in[6u * i + 4u], sn_in[6u * i + 5u]);
    for (var s = 0u; s < {ns}u; s++) {{
        for (var t = 0u; t < {nt}u; t++) {{
            let c = sn_texture(t, SAMPLINGS[s], uv, dx, dy);
            for (var k = 0u; k < 4u; k++) {{
                sn_res[((i * {ns}u + s) * {nt}u + t) * 4u + k] = c[k];
            }}
        }}
    }}
}}
",
        library(),
        emit::TEXTURE_LIBRARY,
        bits.join(", "),
    );
    let input: Vec<f32> = cases.iter().flatten().copied().collect();
    let out_len = n * ns * nt * 4;
    let hw = accuracy(&ctx) == Accuracy::Hardware;
    let got = run(
        &ctx,
        &src,
        &input,
        &[
            (5, bytemuck::cast_slice(&texels)),
            (6, bytemuck::cast_slice(&info)),
        ],
        out_len,
        n,
    );
    let mut bad = Vec::new();
    for (i, c) in cases.iter().enumerate() {
        let (uv, duv) = ([c[0], c[1]], [[c[2], c[3]], [c[4], c[5]]]);
        for (s, sampling) in samplings.iter().enumerate() {
            for t in 0..nt {
                let tex = set.get(t as u32).unwrap();
                let want = tex.lookup::<f32>(uv, duv, *sampling);
                // Hardware: a subnormal coordinate may be flushed to either zero first.
                let flushed: Vec<[f32; 4]> = match hw {
                    true => hardware::ftz_variants(&c[..])
                        .iter()
                        .map(|v| {
                            tex.lookup::<f32>([v[0], v[1]], [[v[2], v[3]], [v[4], v[5]]], *sampling)
                        })
                        .collect(),
                    false => vec![want],
                };
                for k in 0..4 {
                    let g = got[((i * ns + s) * nt + t) * 4 + k];
                    let ok = match sampling.filter {
                        // Hardware: the driver contracts `u * width - 0.5` and the lerps
                        // `t00 + fx * (t10 - t00)` into fmas: the weights move by ulps of
                        // the scaled coordinate, as much as the filtered ones' 1e-4.
                        Filter::Bilinear if hw => flushed
                            .iter()
                            .any(|w| (f32::from_bits(g) - w[k]).abs() <= 1e-4),
                        Filter::Closest if hw => flushed
                            .iter()
                            .any(|w| exact_eq(Type::Float, g, w[k], false)),
                        Filter::Closest | Filter::Bilinear => {
                            exact_eq(Type::Float, g, want[k], false)
                        }
                        _ => (f32::from_bits(g) - want[k]).abs() <= 1e-4,
                    };
                    if !ok {
                        bad.push(format!(
                            "texture {t} {sampling:?} at {uv:?} d {duv:?}: channel {k}: got {:?}, want {:?}",
                            f32::from_bits(g),
                            want[k]
                        ));
                    }
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "{} differences:\n{}",
        bad.len(),
        bad[..bad.len().min(20)].join("\n")
    );
}

/// The driver's compiler rewrites float arithmetic where it sees a constant or one value
/// twice (Mesa: `x + 0.0` → `x`, `x * 0.0` → `0`, `x - x` → `0`, `(x * 2) * 0.5` → `x`);
/// through the key the same expressions keep their IEEE results. (The bare forms are
/// printed, not asserted: another driver may not rewrite them.)
#[test]
fn the_key_keeps_the_compiler_from_rewriting() {
    let Some(ctx) = device_or_skip("the_key_keeps_the_compiler_from_rewriting") else {
        return;
    };
    let k = |e: &str| format!("sn_o({e}, sn_keep)");
    type Case = (String, String, fn(f32) -> f32);
    let cases: Vec<Case> = vec![
        ("x + 0.0f".into(), format!("x + {}", k("0.0f")), |x| x + 0.0),
        ("x * 0.0f".into(), format!("x * {}", k("0.0f")), |x| x * 0.0),
        ("x - x".into(), format!("x - {}", k("x")), |x| x - x),
        (
            "(x * 2.0f) * 0.5f".into(),
            format!("(x * {}) * {}", k("2.0f"), k("0.5f")),
            |x| (x * 2.0) * 0.5,
        ),
    ];
    let xs = [-0.0f32, 0.0, f32::INFINITY, f32::NAN, 1.0, 3e38, -1e-45];
    let mut body = String::new();
    for (j, (bare, keyed, _)) in cases.iter().enumerate() {
        writeln!(
            body,
            "    sn_res[i * {w}u + {a}u] = {bare};\n    sn_res[i * {w}u + {b}u] = {keyed};",
            w = 2 * cases.len(),
            a = 2 * j,
            b = 2 * j + 1
        )
        .unwrap();
    }
    let src = format!(
        "@group(0) @binding(0) var<storage, read> sn_in: array<f32>;
@group(0) @binding(1) var<storage, read_write> sn_res: array<f32>;
{}
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let i = gid.x;
    if (i >= {n}u) {{
        return;
    }}
    let sn_keep = bitcast<u32>(sn_in[{n}u]);
    let x = sn_in[i];
{body}}}
",
        library(),
        n = xs.len()
    );
    let input: Vec<f32> = xs.iter().copied().chain([0.0]).collect();
    let w = 2 * cases.len();
    let hw = accuracy(&ctx) == Accuracy::Hardware;
    let got = run(&ctx, &src, &input, &[], xs.len() * w, xs.len());
    for (j, (bare, keyed, f)) in cases.iter().enumerate() {
        let mut folded = Vec::new();
        for (i, x) in xs.iter().enumerate() {
            let want = f(*x);
            let b = f32::from_bits(got[i * w + 2 * j]);
            let g = got[i * w + 2 * j + 1];
            // Hardware: the subnormal operand may be flushed first, the result after.
            let flushed = hw && hardware::ftz_equal(f32::from_bits(g), f(hardware::flush(*x)));
            assert!(
                exact_eq(Type::Float, g, want, false) || flushed,
                "{keyed} at {x:?}: got {:?}, want {want:?}",
                f32::from_bits(g)
            );
            if !exact_eq(Type::Float, b.to_bits(), want, false) {
                folded.push(format!("{x:?} → {b:?} (IEEE {want:?})"));
            }
        }
        if !folded.is_empty() {
            eprintln!("the compiler rewrites `{bare}`: {}", folded.join(", "));
        }
    }
}
