//! One IR value → one WGSL expression, and the WGSL library those expressions call.
//!
//! Every function here is pure text: [`op_expr`] writes the expression of a pure op over its
//! operands' expressions, [`literal`] writes constants exactly, [`store_columns`] /
//! [`load_columns`] / [`output_columns`] say how values sit in the `f32` buffers (docs/gpu.md),
//! and [`library`] / [`TEXTURE_LIBRARY`] hold the `sn_*` functions the expressions call.
//!
//! # Numeric rules
//!
//! The library mirrors `shadenet_graph::ops` (DESIGN §7) operation for operation: the total
//! rules (`x/0 = 0`, `sqrt(x<0) = 0`, `log(x<=0) = ln(f32::MIN_POSITIVE)`, `fmod(x,0) = 0`,
//! `normalize(0) = 0`, `pow(neg, non-integer) = 0`, `0^negative = 0`, clamped `asin`/`acos`),
//! `min`/`max` as `select` (a NaN in `a` yields `b`), dot products summed left to right from
//! `0 +` (never WGSL's `dot`/`length`, whose order is unspecified), the cross product and the
//! matrix products written out, wrapping integer arithmetic with division and modulo by zero
//! giving 0 and `rem_euclid` modulo, float → int as Rust's `as` (truncation, saturation, NaN →
//! 0, with explicit tests, never WGSL's out-of-range conversion), Perlin noise, fBm, cell noise,
//! OSL's noise and MaterialX's fractal and Worley noise (`ops::osl_noise`: u32 hashing, every
//! int → float conversion rounded once by hand) and the HSV conversions ported line by line.
//! NaN and infinity are tested on the bits.
//!
//! On a device that does IEEE f32 arithmetic with exact division and square root, without
//! contracting `a * b + c` into a fused multiply-add and without flushing subnormals (Mesa's
//! lavapipe, measured), everything except the transcendentals below is **bit-identical** to
//! the CPU: `+ - * /`, comparisons, `select`, `min`/`max`, `abs`, `neg`, `floor`/`ceil`/`fract`,
//! `sqrt`, `mod`, `dot`/`length`/`distance`/`normalize`/`cross`, matrix products, every
//! integer op and conversion, construct/extract/splat, noise, fBm, cell noise, HSV and texture
//! lookups (`gpu/tests/emit.rs` checks it on hard inputs). A driver that contracts into FMA or
//! flushes subnormals breaks that; the parity tests then show it.
//!
//! Found on the way and handled: lavapipe's `sqrt` gives +0 for -0 and for NaN (`sn_sqrt`
//! returns ±0 and NaN itself); naga writes WGSL's float `!=` as an *ordered* comparison, false
//! for NaN (`ne` and float → bool are written `!(a == b)`); Mesa drops a literal `0.0 +` (the
//! CPU's dot products start from `0 +`, which turns -0 into +0: `sn_plus_zero` does it on the
//! bits), and folds the constant z = 0 of `noise2 = noise3(x, y, 0)` into signed-zero changes
//! (`sn_noise2` evaluates the z terms by hand).
//!
//! # What the driver's compiler may not do: the key
//!
//! WGSL cannot ask for exact floating point and naga marks no SPIR-V op `NoContraction`, so
//! Mesa treats float arithmetic as real arithmetic where it sees a constant or one value
//! twice: `x + 0.0` → `x`, `x * 0.0` → `0`, `(x * 2.0) * 0.5` → `x`, `a - a` → `0`,
//! `a * b + a * c` → `a * (b + c)` (all measured on lavapipe; `gpu/tests/emit.rs` prints
//! them). The expressions of [`op_expr`] therefore read [`KEY`] (`sn_keep`, a uniform that
//! is 0 at run time): constants and the second operand of `sub`/`distance` pass through it
//! (`sn_o(x, sn_keep)`, an XOR the compiler cannot see through), as do the products that
//! `cross`, `mulpoint`, `mulvector`, `rgb_to_hsv`, `log` and `pow` sum. The op table runs every
//! binary op on one value twice and every vector op on splatted vectors to catch the rest.
//!
//! # Transcendentals
//!
//! `exp`, `log`, `asin`, `acos`, `atan2` and `pow` are ports of FreeBSD msun's float
//! functions (fdlibm) in `wgsl/lib.wgsl`: only `+ - * / sqrt` and bit operations, so every
//! device doing IEEE arithmetic gives the same bits; WGSL's built-ins are approximations of
//! unspecified accuracy (lavapipe's: `asin` 3 826 ulps (4e-4) off, `log` 6·10⁶ ulps near 1
//! and 15 off for subnormals, `exp` 53 ulps, `atan2` 4 366 ulps, `pow` thousands of ulps in
//! ordinary use). `sin`, `cos` and `tan` are the device's. Measured against the CPU
//! (`shadenet_graph::ops::math`, correctly rounded on every tested input) on lavapipe (Mesa 22.3.6, LLVM 15) by `gpu/tests/emit.rs`
//! (`op_table_on_the_device`: the hard inputs, 20 000 random ones and 4 000 aimed at each
//! function's hard region, on every type, plus `(a, a)` and splat variants), the bounds that
//! test enforces, and the worst measured:
//!
//! | op | domain | bound | worst measured |
//! |---|---|---|---|
//! | `exp` | finite x (normal, subnormal, overflowing or vanishing result) | 2 ulps | 1 ulp |
//! | `exp` | ±inf, NaN | exact | exact |
//! | `log` | x > 0 (subnormals included) | 2 ulps | 1 ulp |
//! | `log` | x ≤ 0, +inf, NaN | exact (x ≤ 0: `ln(f32::MIN_POSITIVE)`) | exact |
//! | `sin`, `cos` | \|x\| ≤ π | 2 ulps | 1 ulp |
//! | `sin`, `cos` | π < \|x\| ≤ 10⁴ | 2 ulps, or error ≤ 2⁻⁴⁶·\|x\|·(1 + r²) | cos 162, sin 139 ulps; 2⁻⁴⁹·³·\|x\| (near zeros) |
//! | `sin`, `cos` | \|x\| > 10⁴ finite | finite, \|r\| ≤ 1 (the device reduces with ~48 bits of π) | anything in [-1, 1] |
//! | `tan` | \|x\| ≤ π | 4 ulps | 2 ulps |
//! | `tan` | π < \|x\| ≤ 10⁴ | 4 ulps, or error ≤ 2⁻⁴⁶·\|x\|·(1 + r²) | 229 ulps; 2⁻⁴⁹·⁵·\|x\|·(1 + r²) |
//! | `tan` | \|x\| > 10⁴ finite | finite | anything |
//! | `sin`, `cos`, `tan` | ±inf, NaN | exact (NaN) | exact |
//! | `asin` | \|x\| < 1 | 4 ulps | 3 ulps |
//! | `acos` | \|x\| < 1 | 2 ulps | 1 ulp |
//! | `asin`, `acos` | \|x\| ≥ 1 (clamped), NaN | exact | exact |
//! | `atan2` | finite non-zero operands (subnormals included) | 4 ulps | 1 ulp |
//! | `atan2` | a zero, infinite or NaN operand | exact (C99 Annex F) | exact |
//! | `pow` | finite non-zero base ≠ ±1, finite exponent ≠ 0 (normal, subnormal, overflowing or vanishing result) | 2 ulps | 1 ulp |
//! | `pow` | base or exponent 0, ±1, ±inf, NaN (signaling NaN: NaN, as the CPU's `pow`); negative base with a non-integer exponent (0) | exact | exact |
//!
//! (r is the CPU's result; ulps count representable floats between the two results.) The
//! same bounds as code: [`crate::testing::documented_bound`], which the op table and the
//! parity suite (`tests/backends.rs`) apply.
//! Everything else — noise, fBm, cell noise, OSL/MaterialX noise, HSV, texture lookups
//! included — is exact.
//! A device that contracts into FMA, flushes subnormals or has other `sin`/`cos`/`tan`
//! needs its own measurement: run the op table there (`SHADENET_GPU_ADAPTER`).

use shadenet_graph::ir::{BinOp, Intrinsic, UnOp};
use shadenet_graph::ir::{Op, Program, Value};
use shadenet_graph::types::{ConstValue, Type};

/// `wgsl/lib.wgsl` as written: [`library`] fills in the noise permutation.
const LIBRARY_SOURCE: &str = include_str!("wgsl/lib.wgsl");

/// The WGSL intrinsic library: every `sn_*` function the expressions of [`op_expr`] call
/// (each kernel includes the declarations it uses). `wgsl/lib.wgsl` with the noise's
/// permutation table taken from the CPU's (`shadenet_graph::ops::noise::PERM`), so the two
/// cannot drift apart. The albedo tables are not in the text: their lookups read the
/// storage buffer `sn_tables` ([`albedo_tables`]), which a kernel whose library reads it
/// binds ([`TABLES_BINDING`]).
pub fn library() -> &'static str {
    static LIBRARY: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
        let rows: Vec<String> = shadenet_graph::ops::noise::PERM
            .chunks(16)
            .map(|row| {
                let row: Vec<String> = row.iter().map(u8::to_string).collect();
                format!("    {},", row.join(", "))
            })
            .collect();
        let entries = format!("(\n{}\n)", rows.join("\n"));
        LIBRARY_SOURCE
            .replacen("(SN_PERM_ENTRIES)", &entries, 1)
            .replacen(
                "SN_SHEEN_ROOT_MIN",
                &format!("{:?}f", shadenet_graph::ops::sheen_albedo::ROOT_MIN),
                1,
            )
            .replacen(
                "SN_SHEEN_INV_SPAN",
                &format!("{:?}f", shadenet_graph::ops::sheen_albedo::INV_SPAN),
                1,
            )
    });
    &LIBRARY
}

/// The binding of `sn_tables: array<f32>`, the albedo tables ([`albedo_tables`]).
pub const TABLES_BINDING: u32 = 7;

/// The declaration of `sn_tables` at [`TABLES_BINDING`], which a kernel whose library reads
/// the tables carries (with [`library`] in full, so does any module that calls the lookups).
pub const TABLES_DECLARATION: &str =
    "@group(0) @binding(7) var<storage, read> sn_tables: array<f32>;\n";

/// The contents of `sn_tables`: the CPU's albedo tables end to end, as `wgsl/lib.wgsl`'s
/// lookups index them — `ops::ggx_albedo::table` ((A, B) pairs) at 0,
/// `ops::dielectric_albedo::table` at 2048, `ops::sheen_albedo::table` ((E, G) pairs) at
/// 5376. In a storage buffer rather than in the WGSL text: as `var<private>` arrays every
/// invocation held a copy, and lavapipe took minutes to compile a kernel that read them.
pub fn albedo_tables() -> &'static [f32] {
    static TABLES: std::sync::LazyLock<Vec<f32>> = std::sync::LazyLock::new(|| {
        let mut t: Vec<f32> = shadenet_graph::ops::ggx_albedo::table()
            .iter()
            .flatten()
            .copied()
            .collect();
        assert_eq!(t.len(), 2048, "the GGX table's offset in wgsl/lib.wgsl");
        t.extend_from_slice(shadenet_graph::ops::dielectric_albedo::table());
        assert_eq!(t.len(), 5376, "the sheen table's offset in wgsl/lib.wgsl");
        t.extend(shadenet_graph::ops::sheen_albedo::table().iter().flatten());
        t
    });
    &TABLES
}

/// Texture lookup (`sn_texture(tex: u32, uv: vec2<f32>) -> vec4<f32>`), which reads the
/// bindings `sn_texels: array<vec4<f32>>` and `sn_tex_info: array<vec4<u32>>` (base, width,
/// height, 0): included only by kernels of programs with textures, after those bindings.
pub const TEXTURE_LIBRARY: &str = include_str!("wgsl/texture.wgsl");

/// The WGSL name of the key the expressions of [`op_expr`] read: a `u32` that is 0 at run
/// time but unknown to the shader compiler (the kernel loads it from the uniforms), in scope
/// wherever an expression is placed. Passing an operand through it (`sn_o(x, sn_keep)`)
/// keeps the compiler from rewriting `a - a` to 0 or `a * b + a * c` to `a * (b + c)`,
/// which Mesa does where one value meets itself (see `wgsl/lib.wgsl`).
pub const KEY: &str = "sn_keep";

/// Why a value cannot be written as one WGSL expression.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EmitError {
    /// The op reads buffers or is a region (streams, params, lights, textures, trace, If,
    /// Illuminance, Proj, ComponentEnabled, Transform, Ambient): the kernel writer handles it.
    #[error("{0} is not a pure op")]
    NotPure(String),
    /// The type has no WGSL form (strings).
    #[error("type {0} has no WGSL form")]
    Type(String),
}

/// The WGSL type of an IR type: `bool`, `i32`, `f32`, `vec2<f32>`, `vec3<f32>` (vec3 and
/// color), `array<vec3<f32>, 3>` (matrix33, rows), `array<vec4<f32>, 4>` (matrix44, rows).
pub fn wgsl_type(ty: Type) -> Result<&'static str, EmitError> {
    Ok(match ty {
        Type::Bool => "bool",
        Type::Int => "i32",
        Type::Float => "f32",
        Type::Vec2 => "vec2<f32>",
        Type::Vec3 | Type::Color => "vec3<f32>",
        Type::Vec4 | Type::Color4 => "vec4<f32>",
        Type::Matrix33 => "array<vec3<f32>, 3>",
        Type::Matrix44 => "array<vec4<f32>, 4>",
        Type::String | Type::Closure(_) => return Err(EmitError::Type(ty.name().into())),
    })
}

/// An exact WGSL expression of an `f32`: the shortest decimal that parses back to the same
/// bits, with the `f` suffix (`1.0f`, `-0.0f`, `1e30f`, `3.4028235e38f`), or
/// `bitcast<f32>(0x…u)` for infinities, NaN (its payload kept) and subnormals (a literal a
/// driver might flush).
pub fn float_literal(x: f32) -> String {
    if !x.is_finite() || x.is_subnormal() {
        format!("bitcast<f32>({:#010x}u)", x.to_bits())
    } else {
        format!("{x:?}f")
    }
}

/// An exact WGSL expression of an `i32` (`i32::MIN`, whose magnitude is no `i32` literal, as
/// `bitcast<i32>(0x80000000u)`).
pub fn int_literal(i: i32) -> String {
    if i == i32::MIN {
        "bitcast<i32>(0x80000000u)".into()
    } else {
        format!("{i}i")
    }
}

fn floats_literal(ty: &str, v: impl IntoIterator<Item = f64>) -> String {
    let parts: Vec<String> = v.into_iter().map(|x| float_literal(x as f32)).collect();
    format!("{ty}({})", parts.join(", "))
}

/// An exact WGSL literal of a constant (floats round-trip bit for bit; non-finite and
/// subnormal floats as `bitcast<f32>(0x…u)`). Floats are held as f64 in [`ConstValue`] and
/// rounded to f32 first, as the f32 interpreter does. The result is a valid expression
/// anywhere in a function body; one with a `bitcast` is not a WGSL const-expression (naga
/// does not evaluate `bitcast` at compile time), so it cannot initialize a module-scope
/// `const`.
pub fn literal(c: &ConstValue) -> Result<String, EmitError> {
    Ok(match c {
        ConstValue::Bool(b) => b.to_string(),
        ConstValue::Int(i) => int_literal(*i),
        ConstValue::Float(x) => float_literal(*x as f32),
        ConstValue::Vec2(v) => floats_literal("vec2<f32>", *v),
        ConstValue::Vec3(v) | ConstValue::Color(v) => floats_literal("vec3<f32>", *v),
        ConstValue::Vec4(v) | ConstValue::Color4(v) => floats_literal("vec4<f32>", *v),
        ConstValue::Matrix33(_) | ConstValue::Matrix44(_) => {
            matrix_literal(c.ty(), c.floats(), &|r| r)
        }
        ConstValue::String(_) => return Err(EmitError::Type(Type::String.name().into())),
    })
}

/// A matrix of type `ty` (its row-major elements `m`) as an array of row vectors, each row
/// literal passed through `wrap`.
fn matrix_literal(ty: Type, m: &[f64], wrap: &dyn Fn(String) -> String) -> String {
    let k = ty.matrix_size();
    let row = format!("vec{k}<f32>");
    let rows: Vec<String> = m
        .chunks(k)
        .map(|r| wrap(floats_literal(&row, r.iter().copied())))
        .collect();
    format!("array<{row}, {k}>({})", rows.join(", "))
}

/// A matrix of type `ty` from the WGSL expressions of its row-major elements.
fn matrix_of(ty: Type, elems: &[String]) -> String {
    let k = ty.matrix_size();
    let rows: Vec<String> = elems
        .chunks(k)
        .map(|r| format!("vec{k}<f32>({})", r.join(", ")))
        .collect();
    format!("array<vec{k}<f32>, {k}>({})", rows.join(", "))
}

/// The WGSL expressions of the row-major elements of the matrix `e` of type `ty`.
fn matrix_elems(ty: Type, e: &str) -> Vec<String> {
    let k = ty.matrix_size();
    let a = atom(e);
    (0..k * k)
        .map(|i| format!("{a}[{}].{}", i / k, COMPONENTS[i % k]))
        .collect()
}

/// `e` where it can take a postfix (`.x`, `[0]`) or a unary prefix: an identifier or a
/// call as it is, anything else in parentheses.
fn atom(e: &str) -> String {
    let ident = !e.is_empty()
        && e.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !e.starts_with(|c: char| c.is_ascii_digit());
    if ident {
        e.to_string()
    } else {
        format!("({e})")
    }
}

const COMPONENTS: [&str; 4] = ["x", "y", "z", "w"];

/// The float components of an expression of a float-based type.
fn components(ty: Type, e: &str) -> Vec<String> {
    match ty {
        Type::Float => vec![e.to_string()],
        _ => {
            let a = atom(e);
            COMPONENTS[..ty.width()]
                .iter()
                .map(|c| format!("{a}.{c}"))
                .collect()
        }
    }
}

/// `f` applied to every component of a float-based value.
fn map1(ty: Type, f: &str, x: &str) -> Result<String, EmitError> {
    let parts: Vec<String> = components(ty, x)
        .iter()
        .map(|c| format!("{f}({c})"))
        .collect();
    gather(ty, parts)
}

/// `f` applied component-wise to two float-based values of the same type.
fn map2(ty: Type, f: &str, x: &str, y: &str) -> Result<String, EmitError> {
    let parts: Vec<String> = components(ty, x)
        .iter()
        .zip(components(ty, y))
        .map(|(a, b)| format!("{f}({a}, {b})"))
        .collect();
    gather(ty, parts)
}

/// [`map1`] of a library function that also takes the key.
fn map1k(ty: Type, f: &str, x: &str) -> Result<String, EmitError> {
    let parts: Vec<String> = components(ty, x)
        .iter()
        .map(|c| format!("{f}({c}, {KEY})"))
        .collect();
    gather(ty, parts)
}

/// [`map2`] of a library function that also takes the key.
fn map2k(ty: Type, f: &str, x: &str, y: &str) -> Result<String, EmitError> {
    let parts: Vec<String> = components(ty, x)
        .iter()
        .zip(components(ty, y))
        .map(|(a, b)| format!("{f}({a}, {b}, {KEY})"))
        .collect();
    gather(ty, parts)
}

fn gather(ty: Type, parts: Vec<String>) -> Result<String, EmitError> {
    if ty == Type::Float {
        Ok(parts.into_iter().next().unwrap_or_default())
    } else {
        Ok(format!("{}({})", wgsl_type(ty)?, parts.join(", ")))
    }
}

fn ill_typed(what: &str, ty: Type) -> EmitError {
    EmitError::Type(format!("{ty} (operand of {what})"))
}

/// The WGSL expression computing `v` from its operands, for the pure ops (`Const`, `Unary`,
/// `Binary` incl. `mulpoint`/`mulvector`, `Select`, `Construct`, `Extract`, `Splat`,
/// `Convert`, `Call`). `arg` names an operand's WGSL expression (a variable the kernel
/// writer declared; any expression works, it is parenthesized where needed, and may be
/// repeated in the result).
///
/// Expressions may read the key [`KEY`]. A float constant is its [`literal`] passed through
/// the key (`sn_o(1.5f, sn_keep)`; bools and ints stay bare), so that neither naga (which
/// folds constant expressions and rejects `1e30f * 1e30f`) nor the driver's compiler (which
/// folds `x * 0.0` to 0 and `(x * 2.0) * 0.5` to `x`) rewrites arithmetic over it.
pub fn op_expr(
    program: &Program,
    v: Value,
    arg: &mut dyn FnMut(Value) -> String,
) -> Result<String, EmitError> {
    let expr = program.expr(v);
    let not_pure = || EmitError::NotPure(format!("{v:?} ({})", expr.op.short_name()));
    let ty = expr.ty.ok_or_else(not_pure)?;
    match &expr.op {
        Op::Const(c) => {
            let lit = literal(c)?;
            let keyed = |f: &str, e: &str| format!("{f}({e}, {KEY})");
            Ok(match c {
                ConstValue::Bool(_) | ConstValue::Int(_) => lit,
                ConstValue::Float(_) => keyed("sn_o", &lit),
                ConstValue::Vec2(_) => keyed("sn_o2", &lit),
                ConstValue::Vec3(_) | ConstValue::Color(_) => keyed("sn_o3", &lit),
                ConstValue::Vec4(_) | ConstValue::Color4(_) => keyed("sn_o4", &lit),
                ConstValue::Matrix33(m) => {
                    matrix_literal(Type::Matrix33, m, &|r| keyed("sn_o3", &r))
                }
                ConstValue::Matrix44(m) => {
                    matrix_literal(Type::Matrix44, m, &|r| keyed("sn_o4", &r))
                }
                ConstValue::String(_) => {
                    return Err(EmitError::Type(Type::String.name().into()));
                }
            })
        }
        Op::Unary(op, a) => unary(*op, program.ty(*a), &arg(*a)),
        Op::Binary(op, a, b) => {
            let (x, y) = (arg(*a), arg(*b));
            binary(*op, program.ty(*a), &x, &y)
        }
        Op::Select { cond, a, b } => {
            let (c, x, y) = (arg(*cond), arg(*a), arg(*b));
            if ty.is_matrix() {
                let k = ty.matrix_size();
                let (x, y) = (atom(&x), atom(&y));
                let rows: Vec<String> = (0..k)
                    .map(|r| format!("select({y}[{r}], {x}[{r}], {c})"))
                    .collect();
                Ok(format!("array<vec{k}<f32>, {k}>({})", rows.join(", ")))
            } else {
                wgsl_type(ty)?;
                Ok(format!("select({y}, {x}, {c})"))
            }
        }
        Op::Construct(args) if ty.is_matrix() && args.len() == ty.width() => {
            let parts: Vec<String> = args.iter().map(|a| arg(*a)).collect();
            Ok(matrix_of(ty, &parts))
        }
        Op::Construct(args) => {
            if !ty.is_vector() {
                return Err(ill_typed("construct", ty));
            }
            let parts: Vec<String> = args.iter().map(|a| arg(*a)).collect();
            Ok(format!("{}({})", wgsl_type(ty)?, parts.join(", ")))
        }
        Op::Extract(a, i) if program.ty(*a).is_matrix() => {
            let t = program.ty(*a);
            let k = t.matrix_size();
            let i = *i as usize;
            if i >= t.width() {
                return Err(ill_typed("extract", t));
            }
            Ok(format!(
                "{}[{}].{}",
                atom(&arg(*a)),
                i / k,
                COMPONENTS[i % k]
            ))
        }
        Op::Extract(a, i) => {
            let t = program.ty(*a);
            if !t.is_vector() || *i as usize >= t.width() {
                return Err(ill_typed("extract", t));
            }
            Ok(format!("{}.{}", atom(&arg(*a)), COMPONENTS[*i as usize]))
        }
        Op::Splat(a) => {
            if !ty.is_vector() {
                return Err(ill_typed("splat", ty));
            }
            Ok(format!("{}({})", wgsl_type(ty)?, arg(*a)))
        }
        Op::Convert(a) => convert(program.ty(*a), ty, &arg(*a)),
        Op::Call(i, args) => {
            let mut parts: Vec<String> = args.iter().map(|a| arg(*a)).collect();
            // rgb_to_hsv, the Worley and the simplex noises take the key.
            use Intrinsic as I;
            if matches!(
                i,
                I::RgbToHsv
                    | I::OslSimplex1
                    | I::OslSimplex2
                    | I::OslSimplex3
                    | I::OslSimplex4
                    | I::OslVSimplex1
                    | I::OslVSimplex2
                    | I::OslVSimplex3
                    | I::OslVSimplex4
                    | I::MxWorley2
                    | I::MxWorley2V2
                    | I::MxWorley2V3
                    | I::MxWorley3
                    | I::MxWorley3V2
                    | I::MxWorley3V3
            ) {
                parts.push(KEY.into());
            }
            let f = match i {
                Intrinsic::Noise2 => "sn_noise2",
                Intrinsic::Noise3 => "sn_noise3",
                Intrinsic::Fbm3 => "sn_fbm3",
                Intrinsic::CellNoise3 => "sn_cellnoise3",
                Intrinsic::RgbToHsv => "sn_rgb_to_hsv",
                Intrinsic::HsvToRgb => "sn_hsv_to_rgb",
                // The OSL/MaterialX noise: `sn_` and the IR name (`sn_osl_perlin3`, …).
                osl => return Ok(format!("sn_{}({})", osl.name(), parts.join(", "))),
            };
            Ok(format!("{f}({})", parts.join(", ")))
        }
        _ => Err(not_pure()),
    }
}

fn unary(op: UnOp, t: Type, x: &str) -> Result<String, EmitError> {
    use UnOp::*;
    let a = atom(x);
    if t == Type::Int {
        return match op {
            Neg => Ok(format!("sn_ineg({x})")),
            Abs => Ok(format!("sn_iabs({x})")),
            BitNot => Ok(format!("(~{a})")),
            _ => Err(ill_typed(op.name(), t)),
        };
    }
    if t == Type::Bool {
        return match op {
            Not => Ok(format!("(!{a})")),
            _ => Err(ill_typed(op.name(), t)),
        };
    }
    if !t.is_float_based() {
        return Err(ill_typed(op.name(), t));
    }
    let vector = |f2: &str, f3: &str, f4: &str| -> Result<String, EmitError> {
        match t {
            Type::Vec2 => Ok(format!("{f2}({x})")),
            Type::Vec3 | Type::Color => Ok(format!("{f3}({x})")),
            Type::Vec4 | Type::Color4 => Ok(format!("{f4}({x})")),
            _ => Err(ill_typed(op.name(), t)),
        }
    };
    match op {
        Neg => Ok(format!("(-{a})")),
        Abs => Ok(format!("abs({x})")),
        Floor => Ok(format!("floor({x})")),
        Ceil => Ok(format!("ceil({x})")),
        Fract => map1(t, "sn_fract", x),
        Sqrt => map1(t, "sn_sqrt", x),
        Exp => map1(t, "sn_exp", x),
        Log => map1k(t, "sn_log", x),
        Sin => Ok(format!("sin({x})")),
        Cos => Ok(format!("cos({x})")),
        Tan => Ok(format!("tan({x})")),
        Asin => map1(t, "sn_asin", x),
        Acos => map1(t, "sn_acos", x),
        Length => vector("sn_length2", "sn_length3", "sn_length4"),
        Normalize => vector("sn_normalize2", "sn_normalize3", "sn_normalize4"),
        Not | BitNot => Err(ill_typed(op.name(), t)),
    }
}

fn binary(op: BinOp, t: Type, x: &str, y: &str) -> Result<String, EmitError> {
    use BinOp::*;
    let infix = |o: &str| Ok(format!("({x} {o} {y})"));
    if matches!(op, MulPoint | MulVector) {
        if t != Type::Matrix44 {
            return Err(ill_typed(op.name(), t));
        }
        let f = if op == MulPoint {
            "sn_mul_point"
        } else {
            "sn_mul_vector"
        };
        return Ok(format!("{f}({x}, {y}, {KEY})"));
    }
    match t {
        Type::Int => match op {
            Add => infix("+"),
            Sub => infix("-"),
            Mul => infix("*"),
            Div => Ok(format!("sn_idiv({x}, {y})")),
            Mod => Ok(format!("sn_imod({x}, {y})")),
            Min => Ok(format!("min({x}, {y})")),
            Max => Ok(format!("max({x}, {y})")),
            Lt => infix("<"),
            Le => infix("<="),
            Gt => infix(">"),
            Ge => infix(">="),
            Eq => infix("=="),
            Ne => infix("!="),
            BitAnd => infix("&"),
            BitOr => infix("|"),
            BitXor => infix("^"),
            // The count's low five bits, as the CPU's (WGSL wants a u32 count).
            Shl => Ok(format!("({x} << (bitcast<u32>({y}) & 31u))")),
            Shr => Ok(format!("({x} >> (bitcast<u32>({y}) & 31u))")),
            _ => Err(ill_typed(op.name(), t)),
        },
        Type::Bool => match op {
            And => infix("&&"),
            Or => infix("||"),
            Eq => infix("=="),
            Ne => infix("!="),
            _ => Err(ill_typed(op.name(), t)),
        },
        _ if t.is_float_based() => {
            let vector = |f2: &str, f3: &str, f4: &str| match t {
                Type::Vec2 => Ok(format!("{f2}({x}, {y})")),
                Type::Vec3 | Type::Color => Ok(format!("{f3}({x}, {y})")),
                Type::Vec4 | Type::Color4 => Ok(format!("{f4}({x}, {y})")),
                _ => Err(ill_typed(op.name(), t)),
            };
            // y through the key: x and y may be one value (`x - x` is NaN for an infinite x).
            let keyed = |e: &str| match t {
                Type::Vec2 => format!("sn_o2({e}, {KEY})"),
                Type::Vec3 | Type::Color => format!("sn_o3({e}, {KEY})"),
                Type::Vec4 | Type::Color4 => format!("sn_o4({e}, {KEY})"),
                _ => format!("sn_o({e}, {KEY})"),
            };
            match op {
                Add => infix("+"),
                Sub => Ok(format!("({x} - {})", keyed(y))),
                Mul => infix("*"),
                Div => map2(t, "sn_div", x, y),
                Mod => map2(t, "sn_mod", x, y),
                Pow => map2k(t, "sn_pow", x, y),
                Atan2 => map2(t, "sn_atan2", x, y),
                // a < b ? a : b, component-wise (a NaN in a yields b).
                Min => Ok(format!("select({y}, {x}, {x} < {y})")),
                Max => Ok(format!("select({y}, {x}, {x} > {y})")),
                Dot => vector("sn_dot2", "sn_dot3", "sn_dot4"),
                Distance => match t {
                    Type::Vec2 => Ok(format!("sn_length2({x} - {})", keyed(y))),
                    Type::Vec3 | Type::Color => Ok(format!("sn_length3({x} - {})", keyed(y))),
                    Type::Vec4 | Type::Color4 => Ok(format!("sn_length4({x} - {})", keyed(y))),
                    _ => Err(ill_typed(op.name(), t)),
                },
                Cross if matches!(t, Type::Vec3 | Type::Color) => {
                    Ok(format!("sn_cross({x}, {y}, {KEY})"))
                }
                // naga writes WGSL's float `!=` as an ordered comparison (false for NaN):
                // the CPU's unordered `!=` is `!(a == b)`.
                Ne if t == Type::Float => Ok(format!("(!({x} == {y}))")),
                Lt | Le | Gt | Ge | Eq if t == Type::Float => infix(match op {
                    Lt => "<",
                    Le => "<=",
                    Gt => ">",
                    Ge => ">=",
                    _ => "==",
                }),
                _ => Err(ill_typed(op.name(), t)),
            }
        }
        _ => Err(ill_typed(op.name(), t)),
    }
}

fn convert(from: Type, to: Type, x: &str) -> Result<String, EmitError> {
    Ok(match (from, to) {
        (Type::Bool, Type::Bool) | (Type::Int, Type::Int) | (Type::Float, Type::Float) => {
            x.to_string()
        }
        (Type::Bool, Type::Int) => format!("select(0i, 1i, {x})"),
        (Type::Bool, Type::Float) => format!("select(0.0f, 1.0f, {x})"),
        (Type::Int, Type::Bool) => format!("({x} != 0i)"),
        (Type::Int, Type::Float) => format!("f32({x})"),
        // NaN → true, as on the CPU (`!=` would be ordered: see `binary`).
        (Type::Float, Type::Bool) => format!("(!({x} == 0.0f))"),
        (Type::Float, Type::Int) => format!("sn_f2i({x})"),
        _ => return Err(ill_typed("convert", from)),
    })
}

/// How a value of type `ty` is stored in `f32` buffer columns (`sn_tmp`): one expression per
/// column, from the WGSL expression `e` of the value (floats as they are, ints as
/// `bitcast<f32>`, bools as 0/1, a matrix row after row; a string, which never reaches a
/// kernel, as one 0).
///
/// An int stored as its bits may be a NaN or subnormal pattern as an f32: a device that
/// copies storage words as they are (every one we know) keeps it; the op table in
/// `gpu/tests/emit.rs` stores every result this way.
pub fn store_columns(ty: Type, e: &str) -> Vec<String> {
    match ty {
        Type::Bool => vec![format!("select(0.0f, 1.0f, {e})")],
        Type::Int => vec![format!("bitcast<f32>({e})")],
        Type::Float | Type::Vec2 | Type::Vec3 | Type::Color | Type::Vec4 | Type::Color4 => {
            components(ty, e)
        }
        Type::Matrix33 | Type::Matrix44 => matrix_elems(ty, e),
        Type::String | Type::Closure(_) => vec!["0.0f".into()],
    }
}

/// The inverse of [`store_columns`]: the value of type `ty` from the WGSL expressions of its
/// columns (a bool is any non-zero column).
pub fn load_columns(ty: Type, cols: &[String]) -> String {
    let col = |k: usize| cols.get(k).cloned().unwrap_or_else(|| "0.0f".into());
    match ty {
        Type::Bool => format!("({} != 0.0f)", col(0)),
        Type::Int => format!("bitcast<i32>({})", col(0)),
        Type::Float | Type::String | Type::Closure(_) => col(0),
        Type::Vec2 => format!("vec2<f32>({}, {})", col(0), col(1)),
        Type::Vec3 | Type::Color => format!("vec3<f32>({}, {}, {})", col(0), col(1), col(2)),
        Type::Vec4 | Type::Color4 => {
            format!("vec4<f32>({}, {}, {}, {})", col(0), col(1), col(2), col(3))
        }
        Type::Matrix33 | Type::Matrix44 => {
            let elems: Vec<String> = (0..ty.width()).map(col).collect();
            matrix_of(ty, &elems)
        }
    }
}

/// How an output of type `ty` is written to `sn_out`: one expression per column (floats as
/// they are, ints as `f32(i)`, bools as 0/1: the interpreter's output layout). A matrix
/// output is its elements, row-major; a string one zero, as the interpreter writes them.
pub fn output_columns(ty: Type, e: &str) -> Vec<String> {
    match ty {
        Type::Bool => vec![format!("select(0.0f, 1.0f, {e})")],
        Type::Int => vec![format!("f32({e})")],
        Type::Float | Type::Vec2 | Type::Vec3 | Type::Color | Type::Vec4 | Type::Color4 => {
            components(ty, e)
        }
        Type::Matrix33 | Type::Matrix44 => matrix_elems(ty, e),
        Type::String | Type::Closure(_) => vec!["0.0f".into()],
    }
}

/// Columns a value of type `ty` takes (matrix33: 9, matrix44: 16; string: 1).
pub fn columns(ty: Type) -> usize {
    ty.width().max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_round_trip_through_rust_parsing() {
        for x in [
            0.0f32,
            1.0,
            -1.5,
            0.1,
            1e30,
            -1e-30,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
            16777217.0,
            std::f32::consts::PI,
        ] {
            let s = float_literal(x);
            let back: f32 = s.trim_end_matches('f').parse().unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{s}");
        }
        assert_eq!(float_literal(-0.0), "-0.0f");
        assert_eq!(float_literal(f32::INFINITY), "bitcast<f32>(0x7f800000u)");
        assert_eq!(float_literal(1e-45), "bitcast<f32>(0x00000001u)");
        assert_eq!(int_literal(i32::MIN), "bitcast<i32>(0x80000000u)");
        assert_eq!(int_literal(-7), "-7i");
        assert_eq!(
            literal(&ConstValue::Vec2([0.5, f64::NAN])).unwrap(),
            "vec2<f32>(0.5f, bitcast<f32>(0x7fc00000u))"
        );
        assert!(literal(&ConstValue::String("x".into())).is_err());
    }

    #[test]
    fn atoms() {
        assert_eq!(atom("v12"), "v12");
        assert_eq!(atom("a + b"), "(a + b)");
        assert_eq!(atom("sn_tmp[3]"), "(sn_tmp[3])");
        assert_eq!(atom("1.0f"), "(1.0f)");
    }

    #[test]
    fn columns_are_consistent() {
        for ty in Type::ALL {
            assert_eq!(store_columns(ty, "v").len(), columns(ty), "{ty}");
            assert_eq!(output_columns(ty, "v").len(), columns(ty), "{ty}");
        }
    }
}
