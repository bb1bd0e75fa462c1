//! The meaning of every IR op, defined once (DESIGN §4, §7).
//!
//! The interpreter evaluates programs with these functions and the constant folder folds with
//! them; the JIT and GPU back ends are tested against them, never the other way round. All
//! functions are generic over [`Real`] (f32 for shading, f64 for the accuracy reference).
//!
//! Transcendentals are [`math`]'s, ours in f32 and f64, never the platform's libm.
//!
//! Every op is **total**: `x/0 = 0`, `sqrt(x<0) = 0`, `normalize(0) = 0`,
//! `pow(neg, non-integer) = 0`, `asin`/`acos` clamp their argument, `log(x<=0) =
//! log(f32::MIN_POSITIVE)`, `mod(x, 0) = 0`, integer arithmetic wraps and integer division
//! or modulo by zero gives 0. `min(a, b)` is `a < b ? a : b` and `max(a, b)` is
//! `a > b ? a : b` exactly (so a NaN in `a` yields `b`, as x86 `minss`/`maxss` do).
//! Non-finite values that still arise (overflow, a NaN from a stream) are left to the
//! material output guard, which replaces them with 0 and counts them.

pub mod cell_hsv_x4;
pub mod dielectric_albedo;
pub mod ggx_albedo;
pub mod math;
pub mod math_x4;
pub mod noise;
pub mod noise_x4;
pub mod osl_noise;
pub mod osl_noise_x4;
pub mod osl_simplex;
pub mod printf;
pub mod sheen_albedo;
pub mod simd;

use crate::ir::{BinOp, Intrinsic, UnOp, XformKind};
use crate::types::{ConstValue, Type};
use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// The floating-point types ops are evaluated in: `f32` and `f64`.
pub trait Real:
    Copy
    + Debug
    + PartialOrd
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Rounds an f64 to this type.
    fn from_f64(x: f64) -> Self;
    /// Widens to f64 (exact).
    fn to_f64(self) -> f64;
    /// Square root (IEEE).
    fn sqrt(self) -> Self;
    // The transcendentals below are [`math`]'s (ours, never the platform's libm).
    /// `e^x`.
    fn exp(self) -> Self;
    /// Natural logarithm.
    fn ln(self) -> Self;
    /// Sine.
    fn sin(self) -> Self;
    /// Cosine.
    fn cos(self) -> Self;
    /// Tangent.
    fn tan(self) -> Self;
    /// Arc sine.
    fn asin(self) -> Self;
    /// Arc cosine.
    fn acos(self) -> Self;
    /// `atan2(self, x)`.
    fn atan2(self, x: Self) -> Self;
    /// `self^e`.
    fn powf(self, e: Self) -> Self;
    /// Floor.
    fn floor(self) -> Self;
    /// Ceiling.
    fn ceil(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Rounds toward zero.
    fn trunc(self) -> Self;
    /// Neither infinite nor NaN.
    fn is_finite(self) -> bool;
    /// NaN.
    fn is_nan(self) -> bool;
    /// Conversion to i32: truncation toward zero, saturating, NaN → 0 (Rust `as`).
    fn to_i32(self) -> i32;
    /// Conversion from i32 (rounded to nearest).
    fn from_i32(i: i32) -> Self;
    /// The bits of this value as an f32: an f32's own bits untouched (a signalling NaN
    /// stays one), an f64 rounded to f32 first.
    fn f32_bits(self) -> u32;
}

/// The math library at one precision, by the names [`Real`] uses.
mod at {
    /// f32: [`super::math`]'s `_f32` functions.
    pub mod single {
        pub use super::super::math::{
            acos_f32 as acos, asin_f32 as asin, atan2_f32 as atan2, cos_f32 as cos, exp_f32 as exp,
            log_f32 as log, pow_f32 as pow, sin_f32 as sin, tan_f32 as tan,
        };
    }
    /// f64: [`super::math`] itself.
    pub mod double {
        pub use super::super::math::{acos, asin, atan2, cos, exp, log, pow, sin, tan};
    }
}

macro_rules! impl_real {
    ($t:ty, $m:ident) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            #[inline]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline]
            fn exp(self) -> Self {
                at::$m::exp(self)
            }
            #[inline]
            fn ln(self) -> Self {
                at::$m::log(self)
            }
            #[inline]
            fn sin(self) -> Self {
                at::$m::sin(self)
            }
            #[inline]
            fn cos(self) -> Self {
                at::$m::cos(self)
            }
            #[inline]
            fn tan(self) -> Self {
                at::$m::tan(self)
            }
            #[inline]
            fn asin(self) -> Self {
                at::$m::asin(self)
            }
            #[inline]
            fn acos(self) -> Self {
                at::$m::acos(self)
            }
            #[inline]
            fn atan2(self, x: Self) -> Self {
                at::$m::atan2(self, x)
            }
            #[inline]
            fn powf(self, e: Self) -> Self {
                at::$m::pow(self, e)
            }
            #[inline]
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
            #[inline]
            fn ceil(self) -> Self {
                <$t>::ceil(self)
            }
            #[inline]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline]
            fn trunc(self) -> Self {
                <$t>::trunc(self)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
            #[inline]
            fn to_i32(self) -> i32 {
                self as i32
            }
            #[inline]
            fn from_i32(i: i32) -> Self {
                i as $t
            }
            #[inline]
            #[allow(clippy::unnecessary_cast)]
            fn f32_bits(self) -> u32 {
                (self as f32).to_bits()
            }
        }
    };
}
impl_real!(f32, single);
impl_real!(f64, double);

/// A runtime value. Matrices are not carried in registers (they would make every register
/// four times larger): a matrix-typed value is `Mat(i)`, an index into the evaluator's matrix
/// tables (constants and parameters, and the matrices the program constructs: see the
/// interpreter).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Val<F> {
    /// A bool.
    Bool(bool),
    /// An int.
    Int(i32),
    /// A float.
    Float(F),
    /// A vec2.
    Vec2([F; 2]),
    /// A vec3 or color.
    Vec3([F; 3]),
    /// A vec4 or color4.
    Vec4([F; 4]),
    /// A matrix, by index into the evaluator's matrix table.
    Mat(u32),
}

impl<F: Real> Val<F> {
    /// The zero of a type (matrices: `Mat(0)`).
    pub fn zero(ty: Type) -> Val<F> {
        match ty {
            Type::Bool => Val::Bool(false),
            Type::Int | Type::String | Type::Closure(_) => Val::Int(0),
            Type::Float => Val::Float(F::ZERO),
            Type::Vec2 => Val::Vec2([F::ZERO; 2]),
            Type::Vec3 | Type::Color => Val::Vec3([F::ZERO; 3]),
            Type::Vec4 | Type::Color4 => Val::Vec4([F::ZERO; 4]),
            Type::Matrix33 | Type::Matrix44 => Val::Mat(0),
        }
    }

    /// Converts a constant (floats rounded to `F`); matrices and strings become `Mat(0)` /
    /// `Int(0)`: the caller keeps matrices in its own table.
    pub fn from_const(c: &ConstValue) -> Val<F> {
        let f = F::from_f64;
        match c {
            ConstValue::Bool(b) => Val::Bool(*b),
            ConstValue::Int(i) => Val::Int(*i),
            ConstValue::Float(x) => Val::Float(f(*x)),
            ConstValue::Vec2(v) => Val::Vec2([f(v[0]), f(v[1])]),
            ConstValue::Vec3(v) | ConstValue::Color(v) => Val::Vec3([f(v[0]), f(v[1]), f(v[2])]),
            ConstValue::Vec4(v) | ConstValue::Color4(v) => Val::Vec4(v.map(f)),
            ConstValue::Matrix33(_) | ConstValue::Matrix44(_) => Val::Mat(0),
            ConstValue::String(_) => Val::Int(0),
        }
    }

    /// Converts back to a constant of type `ty` (the constant folder's direction).
    pub fn to_const(self, ty: Type) -> ConstValue {
        match self {
            Val::Bool(b) => ConstValue::Bool(b),
            Val::Int(i) => ConstValue::Int(i),
            Val::Float(x) => ConstValue::Float(x.to_f64()),
            Val::Vec2(v) => ConstValue::Vec2([v[0].to_f64(), v[1].to_f64()]),
            Val::Vec3(v) => {
                let v = [v[0].to_f64(), v[1].to_f64(), v[2].to_f64()];
                if ty == Type::Color {
                    ConstValue::Color(v)
                } else {
                    ConstValue::Vec3(v)
                }
            }
            Val::Vec4(v) => {
                let v = v.map(|x| x.to_f64());
                if ty == Type::Color4 {
                    ConstValue::Color4(v)
                } else {
                    ConstValue::Vec4(v)
                }
            }
            Val::Mat(_) => ConstValue::identity(),
        }
    }

    /// The float components (empty for bool, int and matrices).
    pub fn floats(&self) -> &[F] {
        match self {
            Val::Float(x) => std::slice::from_ref(x),
            Val::Vec2(v) => v,
            Val::Vec3(v) => v,
            Val::Vec4(v) => v,
            _ => &[],
        }
    }

    /// The value as a bool (false for non-bools).
    pub fn as_bool(self) -> bool {
        matches!(self, Val::Bool(true))
    }

    /// The value as an int (0 for non-ints).
    pub fn as_int(self) -> i32 {
        match self {
            Val::Int(i) => i,
            _ => 0,
        }
    }

    /// The value as a float (0 for non-floats).
    pub fn as_float(self) -> F {
        match self {
            Val::Float(x) => x,
            _ => F::ZERO,
        }
    }

    /// The value as a vec3 (zero for others).
    pub fn as_vec3(self) -> [F; 3] {
        match self {
            Val::Vec3(v) => v,
            _ => [F::ZERO; 3],
        }
    }

    fn map(self, f: impl Fn(F) -> F) -> Val<F> {
        match self {
            Val::Float(x) => Val::Float(f(x)),
            Val::Vec2(v) => Val::Vec2(v.map(f)),
            Val::Vec3(v) => Val::Vec3(v.map(f)),
            Val::Vec4(v) => Val::Vec4(v.map(f)),
            other => other,
        }
    }

    fn zip(self, b: Val<F>, f: impl Fn(F, F) -> F) -> Val<F> {
        match (self, b) {
            (Val::Float(x), Val::Float(y)) => Val::Float(f(x, y)),
            (Val::Vec2(x), Val::Vec2(y)) => Val::Vec2([f(x[0], y[0]), f(x[1], y[1])]),
            (Val::Vec3(x), Val::Vec3(y)) => {
                Val::Vec3([f(x[0], y[0]), f(x[1], y[1]), f(x[2], y[2])])
            }
            (Val::Vec4(x), Val::Vec4(y)) => Val::Vec4(std::array::from_fn(|i| f(x[i], y[i]))),
            (a, _) => a,
        }
    }
}

// ---- scalar semantics: every back end on the CPU calls these ----

/// `a / b`, 0 where `b == 0`.
#[inline]
pub fn div<F: Real>(a: F, b: F) -> F {
    if b == F::ZERO { F::ZERO } else { a / b }
}

/// `a - b * floor(a / b)`, 0 where `b == 0`.
#[inline]
pub fn fmod<F: Real>(a: F, b: F) -> F {
    if b == F::ZERO {
        F::ZERO
    } else {
        a - b * (a / b).floor()
    }
}

/// `a^b`; 0 for a negative base with a non-integer exponent; `0^negative = 0` (no infinity
/// from a zero base).
pub fn pow<F: Real>(a: F, b: F) -> F {
    if a < F::ZERO && b.trunc() != b {
        return F::ZERO;
    }
    if a == F::ZERO && b < F::ZERO {
        return F::ZERO;
    }
    a.powf(b)
}

/// `e^x` ([`math::exp`]).
pub fn exp<F: Real>(x: F) -> F {
    x.exp()
}

/// `sin x` ([`math::sin`]).
pub fn sin<F: Real>(x: F) -> F {
    x.sin()
}

/// `cos x` ([`math::cos`]).
pub fn cos<F: Real>(x: F) -> F {
    x.cos()
}

/// `tan x` ([`math::tan`]).
pub fn tan<F: Real>(x: F) -> F {
    x.tan()
}

/// `atan2(y, x)` ([`math::atan2`]).
pub fn atan2<F: Real>(y: F, x: F) -> F {
    y.atan2(x)
}

/// `sqrt(x)`, 0 for `x < 0`.
pub fn sqrt<F: Real>(x: F) -> F {
    if x < F::ZERO { F::ZERO } else { x.sqrt() }
}

/// `ln(x)`, `ln(f32::MIN_POSITIVE)` for `x <= 0`.
pub fn log<F: Real>(x: F) -> F {
    if x <= F::ZERO {
        F::from_f64(math::log(f32::MIN_POSITIVE as f64))
    } else {
        x.ln()
    }
}

fn clamp_unit<F: Real>(x: F) -> F {
    let lo = -F::ONE;
    if x < lo {
        lo
    } else if x > F::ONE {
        F::ONE
    } else {
        x
    }
}

/// `asin(clamp(x, -1, 1))`.
pub fn asin<F: Real>(x: F) -> F {
    clamp_unit(x).asin()
}

/// `acos(clamp(x, -1, 1))`.
pub fn acos<F: Real>(x: F) -> F {
    clamp_unit(x).acos()
}

/// `a < b ? a : b`.
#[inline]
pub fn min<F: Real>(a: F, b: F) -> F {
    if a < b { a } else { b }
}

/// `a > b ? a : b`.
#[inline]
pub fn max<F: Real>(a: F, b: F) -> F {
    if a > b { a } else { b }
}

/// `x - floor(x)`.
#[inline]
pub fn fract<F: Real>(x: F) -> F {
    x - x.floor()
}

/// Dot product, summed left to right.
pub fn dot<F: Real>(a: &[F], b: &[F]) -> F {
    let mut s = F::ZERO;
    for (x, y) in a.iter().zip(b) {
        s = s + *x * *y;
    }
    s
}

/// Euclidean length: `sqrt(dot(v, v))`.
pub fn length<F: Real>(v: &[F]) -> F {
    sqrt(dot(v, v))
}

/// Cross product.
pub fn cross<F: Real>(a: [F; 3], b: [F; 3]) -> [F; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `v / length(v)` component-wise (with the total division: zero stays zero).
pub fn normalize<F: Real, const N: usize>(v: [F; N]) -> [F; N] {
    let l = length(&v);
    v.map(|x| div(x, l))
}

/// `M * (p, 1)` for a row-major matrix (the w row is ignored: affine transforms).
pub fn mul_point<F: Real>(m: &[F; 16], p: [F; 3]) -> [F; 3] {
    std::array::from_fn(|r| {
        m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3]
    })
}

/// `M * (v, 0)`.
pub fn mul_vector<F: Real>(m: &[F; 16], v: [F; 3]) -> [F; 3] {
    std::array::from_fn(|r| m[r * 4] * v[0] + m[r * 4 + 1] * v[1] + m[r * 4 + 2] * v[2])
}

/// Transforms a vec3 as `kind` by the matrix `m`; `m_inv` is its inverse, used for normals
/// (multiplied by the transpose of the inverse).
pub fn transform<F: Real>(kind: XformKind, m: &[F; 16], m_inv: &[F; 16], v: [F; 3]) -> [F; 3] {
    match kind {
        XformKind::Point => mul_point(m, v),
        XformKind::Vector => mul_vector(m, v),
        XformKind::Normal => {
            std::array::from_fn(|c| m_inv[c] * v[0] + m_inv[4 + c] * v[1] + m_inv[8 + c] * v[2])
        }
    }
}

// ---- typing ----

/// The result type of a unary op on an operand of type `a`, or `None` if not defined.
pub fn unary_type(op: UnOp, a: Type) -> Option<Type> {
    use UnOp::*;
    match op {
        Not => (a == Type::Bool).then_some(Type::Bool),
        BitNot => (a == Type::Int).then_some(Type::Int),
        Neg | Abs => (a == Type::Int || a.is_float_based()).then_some(a),
        Length => a.is_vector().then_some(Type::Float),
        Normalize => a.is_vector().then_some(a),
        _ => a.is_float_based().then_some(a),
    }
}

/// The result type of a binary op on operands of types `a` and `b`, or `None`.
pub fn binary_type(op: BinOp, a: Type, b: Type) -> Option<Type> {
    use BinOp::*;
    match op {
        MulPoint | MulVector => (a == Type::Matrix44 && b == Type::Vec3).then_some(Type::Vec3),
        _ if a != b => None,
        Add | Sub | Mul | Div | Mod | Min | Max => {
            (a == Type::Int || a.is_float_based()).then_some(a)
        }
        Pow | Atan2 => a.is_float_based().then_some(a),
        Dot | Distance => a.is_vector().then_some(Type::Float),
        Cross => (a == Type::Vec3 || a == Type::Color).then_some(a),
        Lt | Le | Gt | Ge => matches!(a, Type::Int | Type::Float).then_some(Type::Bool),
        Eq | Ne => matches!(a, Type::Int | Type::Float | Type::Bool).then_some(Type::Bool),
        And | Or => (a == Type::Bool).then_some(Type::Bool),
        BitAnd | BitOr | BitXor | Shl | Shr => (a == Type::Int).then_some(Type::Int),
    }
}

/// The result type of an intrinsic call, or `None` if the operand types do not fit.
pub fn intrinsic_type(i: Intrinsic, args: &[Type]) -> Option<Type> {
    use Intrinsic::*;
    let ok = match i {
        Noise2 => args == [Type::Vec2],
        Noise3 | CellNoise3 => args == [Type::Vec3],
        Fbm3 => args == [Type::Vec3, Type::Int, Type::Float, Type::Float],
        RgbToHsv | HsvToRgb => args == [Type::Color],
        GgxAlbedo | SheenAlbedo => args == [Type::Float, Type::Float],
        DielectricAlbedo => args == [Type::Float, Type::Float, Type::Float],
        _ => return osl_intrinsic_type(i, args),
    };
    ok.then_some(match i {
        RgbToHsv | HsvToRgb => Type::Color,
        GgxAlbedo | SheenAlbedo => Type::Vec2,
        _ => Type::Float,
    })
}

/// The operand types of an OSL/MaterialX noise intrinsic ([`osl_noise`]), or `None` for
/// the others.
pub fn osl_intrinsic_operands(i: Intrinsic) -> Option<&'static [Type]> {
    use Intrinsic::*;
    const V2: &[Type] = &[Type::Vec2];
    const V3: &[Type] = &[Type::Vec3];
    const F1: &[Type] = &[Type::Float];
    const V3F: &[Type] = &[Type::Vec3, Type::Float];
    const F2: &[Type] = &[Type::Float, Type::Float];
    const V2V2: &[Type] = &[Type::Vec2, Type::Vec2];
    const V3V3: &[Type] = &[Type::Vec3, Type::Vec3];
    const V3FV3F: &[Type] = &[Type::Vec3, Type::Float, Type::Vec3, Type::Float];
    const FRACTAL2: &[Type] = &[Type::Vec2, Type::Int, Type::Float, Type::Float];
    const FRACTAL3: &[Type] = &[Type::Vec3, Type::Int, Type::Float, Type::Float];
    const WORLEY2: &[Type] = &[Type::Vec2, Type::Float, Type::Int, Type::Int];
    const WORLEY3: &[Type] = &[Type::Vec3, Type::Float, Type::Int, Type::Int];
    Some(match i {
        OslPerlin2 | OslVPerlin2 | OslCell2 | OslVCell2 | OslHash2 | OslVHash2 | OslSimplex2
        | OslVSimplex2 => V2,
        OslPerlin3 | OslVPerlin3 | OslCell3 | OslVCell3 | OslHash3 | OslVHash3 | OslSimplex3
        | OslVSimplex3 => V3,
        OslCell1 | OslVCell1 | OslPerlin1 | OslVPerlin1 | OslHash1 | OslVHash1 | OslSimplex1
        | OslVSimplex1 => F1,
        OslCell4 | OslVCell4 | OslPerlin4 | OslVPerlin4 | OslHash4 | OslVHash4 | OslSimplex4
        | OslVSimplex4 => V3F,
        OslPPerlin1 | OslVPPerlin1 => F2,
        OslPPerlin2 | OslVPPerlin2 => V2V2,
        OslPPerlin3 | OslVPPerlin3 => V3V3,
        OslPPerlin4 | OslVPPerlin4 => V3FV3F,
        MxFractal2 | MxVFractal2 => FRACTAL2,
        MxFractal3 | MxVFractal3 => FRACTAL3,
        MxWorley2 | MxWorley2V2 | MxWorley2V3 => WORLEY2,
        MxWorley3 | MxWorley3V2 | MxWorley3V3 => WORLEY3,
        _ => return None,
    })
}

/// The result type of an OSL/MaterialX noise intrinsic on `args`, or `None`.
fn osl_intrinsic_type(i: Intrinsic, args: &[Type]) -> Option<Type> {
    use Intrinsic::*;
    if osl_intrinsic_operands(i)? != args {
        return None;
    }
    Some(match i {
        OslVPerlin1 | OslVPerlin2 | OslVPerlin3 | OslVPerlin4 | OslVCell1 | OslVCell2
        | OslVCell3 | OslVCell4 | OslVHash1 | OslVHash2 | OslVHash3 | OslVHash4 | OslVPPerlin1
        | OslVPPerlin2 | OslVPPerlin3 | OslVPPerlin4 | OslVSimplex1 | OslVSimplex2
        | OslVSimplex3 | OslVSimplex4 | MxVFractal2 | MxVFractal3 | MxWorley2V3 | MxWorley3V3 => {
            Type::Vec3
        }
        MxWorley2V2 | MxWorley3V2 => Type::Vec2,
        _ => Type::Float,
    })
}

/// Whether `Convert` from `from` to `to` is defined (between bool, int and float).
pub fn convert_ok(from: Type, to: Type) -> bool {
    let scalar = |t: Type| matches!(t, Type::Bool | Type::Int | Type::Float);
    scalar(from) && scalar(to)
}

// ---- evaluation ----

/// Evaluates a unary op.
pub fn unary<F: Real>(op: UnOp, a: Val<F>) -> Val<F> {
    use UnOp::*;
    match (op, a) {
        (Not, Val::Bool(b)) => Val::Bool(!b),
        (Neg, Val::Int(i)) => Val::Int(i.wrapping_neg()),
        (Abs, Val::Int(i)) => Val::Int(i.wrapping_abs()),
        (BitNot, Val::Int(i)) => Val::Int(!i),
        (Length, v) => Val::Float(length(v.floats())),
        (Normalize, Val::Vec2(v)) => Val::Vec2(normalize(v)),
        (Normalize, Val::Vec3(v)) => Val::Vec3(normalize(v)),
        (Normalize, Val::Vec4(v)) => Val::Vec4(normalize(v)),
        (Neg, v) => v.map(|x| -x),
        (Abs, v) => v.map(F::abs),
        (Floor, v) => v.map(F::floor),
        (Ceil, v) => v.map(F::ceil),
        (Fract, v) => v.map(fract),
        (Sqrt, v) => v.map(sqrt),
        (Exp, v) => v.map(exp),
        (Log, v) => v.map(log),
        (Sin, v) => v.map(sin),
        (Cos, v) => v.map(cos),
        (Tan, v) => v.map(tan),
        (Asin, v) => v.map(asin),
        (Acos, v) => v.map(acos),
        (Not | Normalize | BitNot, v) => v,
    }
}

/// Evaluates a binary op (not `MulPoint`/`MulVector`, which need the matrix table: see
/// [`mul_point`], [`mul_vector`]).
pub fn binary<F: Real>(op: BinOp, a: Val<F>, b: Val<F>) -> Val<F> {
    use BinOp::*;
    if let (Val::Int(x), Val::Int(y)) = (a, b) {
        return match op {
            Add => Val::Int(x.wrapping_add(y)),
            Sub => Val::Int(x.wrapping_sub(y)),
            Mul => Val::Int(x.wrapping_mul(y)),
            Div => Val::Int(if y == 0 { 0 } else { x.wrapping_div(y) }),
            Mod => Val::Int(if y == 0 { 0 } else { x.wrapping_rem_euclid(y) }),
            Min => Val::Int(x.min(y)),
            Max => Val::Int(x.max(y)),
            Lt => Val::Bool(x < y),
            Le => Val::Bool(x <= y),
            Gt => Val::Bool(x > y),
            Ge => Val::Bool(x >= y),
            Eq => Val::Bool(x == y),
            Ne => Val::Bool(x != y),
            BitAnd => Val::Int(x & y),
            BitOr => Val::Int(x | y),
            BitXor => Val::Int(x ^ y),
            // `wrapping_sh*` take the count's low five bits, as documented on the op.
            Shl => Val::Int(x.wrapping_shl(y as u32)),
            Shr => Val::Int(x.wrapping_shr(y as u32)),
            _ => Val::Int(0),
        };
    }
    if let (Val::Bool(x), Val::Bool(y)) = (a, b) {
        return Val::Bool(match op {
            And => x && y,
            Or => x || y,
            Eq => x == y,
            Ne => x != y,
            _ => false,
        });
    }
    match op {
        Add => a.zip(b, |x, y| x + y),
        Sub => a.zip(b, |x, y| x - y),
        Mul => a.zip(b, |x, y| x * y),
        Div => a.zip(b, div),
        Mod => a.zip(b, fmod),
        Pow => a.zip(b, pow),
        Min => a.zip(b, min),
        Max => a.zip(b, max),
        Atan2 => a.zip(b, atan2),
        Dot => Val::Float(dot(a.floats(), b.floats())),
        Distance => {
            let d = a.zip(b, |x, y| x - y);
            Val::Float(length(d.floats()))
        }
        Cross => Val::Vec3(cross(a.as_vec3(), b.as_vec3())),
        Lt => Val::Bool(a.as_float() < b.as_float()),
        Le => Val::Bool(a.as_float() <= b.as_float()),
        Gt => Val::Bool(a.as_float() > b.as_float()),
        Ge => Val::Bool(a.as_float() >= b.as_float()),
        Eq => Val::Bool(a.as_float() == b.as_float()),
        Ne => Val::Bool(a.as_float() != b.as_float()),
        And | Or | MulPoint | MulVector | BitAnd | BitOr | BitXor | Shl | Shr => Val::Bool(false),
    }
}

/// `cond ? a : b`.
pub fn select<F: Real>(cond: Val<F>, a: Val<F>, b: Val<F>) -> Val<F> {
    if cond.as_bool() { a } else { b }
}

/// Builds a vector of type `ty` from float scalars.
pub fn construct<F: Real>(ty: Type, args: &[Val<F>]) -> Val<F> {
    let c = |i: usize| args.get(i).map_or(F::ZERO, |v| v.as_float());
    match ty {
        Type::Vec2 => Val::Vec2([c(0), c(1)]),
        Type::Vec3 | Type::Color => Val::Vec3([c(0), c(1), c(2)]),
        Type::Vec4 | Type::Color4 => Val::Vec4([c(0), c(1), c(2), c(3)]),
        _ => Val::Float(c(0)),
    }
}

/// Component `i` of a vector.
pub fn extract<F: Real>(v: Val<F>, i: u8) -> Val<F> {
    Val::Float(v.floats().get(i as usize).copied().unwrap_or(F::ZERO))
}

/// A float broadcast to a vector type.
pub fn splat<F: Real>(ty: Type, x: Val<F>) -> Val<F> {
    let x = x.as_float();
    match ty {
        Type::Vec2 => Val::Vec2([x; 2]),
        Type::Vec3 | Type::Color => Val::Vec3([x; 3]),
        Type::Vec4 | Type::Color4 => Val::Vec4([x; 4]),
        _ => Val::Float(x),
    }
}

/// Scalar conversion to `to` (see [`crate::ir::Op::Convert`]).
pub fn convert<F: Real>(to: Type, v: Val<F>) -> Val<F> {
    let as_f = match v {
        Val::Bool(b) => {
            if b {
                F::ONE
            } else {
                F::ZERO
            }
        }
        Val::Int(i) => F::from_i32(i),
        Val::Float(x) => x,
        _ => F::ZERO,
    };
    match (to, v) {
        (Type::Bool, Val::Bool(b)) => Val::Bool(b),
        (Type::Bool, Val::Int(i)) => Val::Bool(i != 0),
        (Type::Bool, _) => Val::Bool(as_f != F::ZERO),
        (Type::Int, Val::Int(i)) => Val::Int(i),
        (Type::Int, Val::Bool(b)) => Val::Int(b as i32),
        (Type::Int, _) => Val::Int(as_f.to_i32()),
        _ => Val::Float(as_f),
    }
}

/// Evaluates an intrinsic.
pub fn intrinsic<F: Real>(i: Intrinsic, args: &[Val<F>]) -> Val<F> {
    let arg = |k: usize| args.get(k).copied().unwrap_or(Val::Int(0));
    match i {
        Intrinsic::Noise2 => {
            let p = arg(0);
            let p = p.floats();
            Val::Float(noise::noise2(p[0], p[1]))
        }
        Intrinsic::Noise3 => Val::Float(noise::noise3(arg(0).as_vec3())),
        Intrinsic::Fbm3 => Val::Float(noise::fbm3(
            arg(0).as_vec3(),
            arg(1).as_int(),
            arg(2).as_float(),
            arg(3).as_float(),
        )),
        Intrinsic::CellNoise3 => Val::Float(noise::cellnoise3(arg(0).as_vec3())),
        Intrinsic::RgbToHsv => Val::Vec3(rgb_to_hsv(arg(0).as_vec3())),
        Intrinsic::HsvToRgb => Val::Vec3(hsv_to_rgb(arg(0).as_vec3())),
        Intrinsic::GgxAlbedo => {
            Val::Vec2(ggx_albedo::ggx_albedo(arg(0).as_float(), arg(1).as_float()))
        }
        Intrinsic::DielectricAlbedo => Val::Float(dielectric_albedo::dielectric_albedo(
            arg(0).as_float(),
            arg(1).as_float(),
            arg(2).as_float(),
        )),
        Intrinsic::SheenAlbedo => Val::Vec2(sheen_albedo::sheen_albedo(
            arg(0).as_float(),
            arg(1).as_float(),
        )),
        _ => osl_intrinsic(i, args),
    }
}

/// Evaluates an OSL/MaterialX noise intrinsic ([`osl_noise`]).
fn osl_intrinsic<F: Real>(i: Intrinsic, args: &[Val<F>]) -> Val<F> {
    use osl_noise as o;
    use osl_simplex as s;
    let arg = |k: usize| args.get(k).copied().unwrap_or(Val::Int(0));
    let vec2 = |k: usize| {
        let p = arg(k);
        let f = p.floats();
        [0, 1].map(|c| f.get(c).copied().unwrap_or(F::ZERO))
    };
    let v2 = || vec2(0);
    let v3 = || arg(0).as_vec3();
    let (n, f1, i2, i3) = (
        arg(1).as_int(),
        arg(1).as_float(),
        arg(2).as_int(),
        arg(3).as_int(),
    );
    let (f2, f3) = (arg(2).as_float(), arg(3).as_float());
    match i {
        Intrinsic::OslPerlin2 => Val::Float(o::perlin2(v2())),
        Intrinsic::OslPerlin3 => Val::Float(o::perlin3(v3())),
        Intrinsic::OslVPerlin2 => Val::Vec3(o::vperlin2(v2())),
        Intrinsic::OslVPerlin3 => Val::Vec3(o::vperlin3(v3())),
        Intrinsic::OslCell2 => Val::Float(o::cell2(v2())),
        Intrinsic::OslCell3 => Val::Float(o::cell3(v3())),
        Intrinsic::OslVCell2 => Val::Vec3(o::vcell2(v2())),
        Intrinsic::OslVCell3 => Val::Vec3(o::vcell3(v3())),
        Intrinsic::OslCell1 => Val::Float(o::cell1(arg(0).as_float())),
        Intrinsic::OslCell4 => Val::Float(o::cell4(v3(), f1)),
        Intrinsic::OslVCell1 => Val::Vec3(o::vcell1(arg(0).as_float())),
        Intrinsic::OslVCell4 => Val::Vec3(o::vcell4(v3(), f1)),
        Intrinsic::OslPerlin1 => Val::Float(o::perlin1(arg(0).as_float())),
        Intrinsic::OslPerlin4 => Val::Float(o::perlin4(v3(), f1)),
        Intrinsic::OslVPerlin1 => Val::Vec3(o::vperlin1(arg(0).as_float())),
        Intrinsic::OslVPerlin4 => Val::Vec3(o::vperlin4(v3(), f1)),
        Intrinsic::OslHash1 => Val::Float(o::hash1(arg(0).as_float())),
        Intrinsic::OslHash2 => Val::Float(o::hash2(v2())),
        Intrinsic::OslHash3 => Val::Float(o::hash3(v3())),
        Intrinsic::OslHash4 => Val::Float(o::hash4(v3(), f1)),
        Intrinsic::OslVHash1 => Val::Vec3(o::vhash1(arg(0).as_float())),
        Intrinsic::OslVHash2 => Val::Vec3(o::vhash2(v2())),
        Intrinsic::OslVHash3 => Val::Vec3(o::vhash3(v3())),
        Intrinsic::OslVHash4 => Val::Vec3(o::vhash4(v3(), f1)),
        Intrinsic::OslPPerlin1 => Val::Float(o::pperlin1(arg(0).as_float(), f1)),
        Intrinsic::OslPPerlin2 => Val::Float(o::pperlin2(v2(), vec2(1))),
        Intrinsic::OslPPerlin3 => Val::Float(o::pperlin3(v3(), arg(1).as_vec3())),
        Intrinsic::OslPPerlin4 => Val::Float(o::pperlin4(v3(), f1, arg(2).as_vec3(), f3)),
        Intrinsic::OslVPPerlin1 => Val::Vec3(o::vpperlin1(arg(0).as_float(), f1)),
        Intrinsic::OslVPPerlin2 => Val::Vec3(o::vpperlin2(v2(), vec2(1))),
        Intrinsic::OslVPPerlin3 => Val::Vec3(o::vpperlin3(v3(), arg(1).as_vec3())),
        Intrinsic::OslVPPerlin4 => Val::Vec3(o::vpperlin4(v3(), f1, arg(2).as_vec3(), f3)),
        Intrinsic::OslSimplex1 => Val::Float(s::simplex1(arg(0).as_float(), 0)),
        Intrinsic::OslSimplex2 => Val::Float(s::simplex2(v2(), 0)),
        Intrinsic::OslSimplex3 => Val::Float(s::simplex3(v3(), 0)),
        Intrinsic::OslSimplex4 => Val::Float(s::simplex4(v3(), f1, 0)),
        Intrinsic::OslVSimplex1 => Val::Vec3(s::vsimplex1(arg(0).as_float())),
        Intrinsic::OslVSimplex2 => Val::Vec3(s::vsimplex2(v2())),
        Intrinsic::OslVSimplex3 => Val::Vec3(s::vsimplex3(v3())),
        Intrinsic::OslVSimplex4 => Val::Vec3(s::vsimplex4(v3(), f1)),
        Intrinsic::MxFractal2 => Val::Float(o::fractal2(v2(), n, f2, f3)),
        Intrinsic::MxFractal3 => Val::Float(o::fractal3(v3(), n, f2, f3)),
        Intrinsic::MxVFractal2 => Val::Vec3(o::vfractal2(v2(), n, f2, f3)),
        Intrinsic::MxVFractal3 => Val::Vec3(o::vfractal3(v3(), n, f2, f3)),
        Intrinsic::MxWorley2 => Val::Float(o::worley2(v2(), f1, i2, i3)),
        Intrinsic::MxWorley2V2 => Val::Vec2(o::worley2_v2(v2(), f1, i2, i3)),
        Intrinsic::MxWorley2V3 => Val::Vec3(o::worley2_v3(v2(), f1, i2, i3)),
        Intrinsic::MxWorley3 => Val::Float(o::worley3(v3(), f1, i2, i3)),
        Intrinsic::MxWorley3V2 => Val::Vec2(o::worley3_v2(v3(), f1, i2, i3)),
        Intrinsic::MxWorley3V3 => Val::Vec3(o::worley3_v3(v3(), f1, i2, i3)),
        _ => Val::Int(0),
    }
}

/// RGB → HSV: hue in [0, 1) (0 for greys), saturation `(max-min)/max` (0 for black), value
/// `max`.
#[inline]
pub fn rgb_to_hsv<F: Real>(c: [F; 3]) -> [F; 3] {
    let [r, g, b] = c;
    let mx = max(r, max(g, b));
    let mn = min(r, min(g, b));
    let d = mx - mn;
    let six = F::from_f64(6.0);
    let h = if d == F::ZERO {
        F::ZERO
    } else if mx == r {
        fmod(div(g - b, d), six)
    } else if mx == g {
        div(b - r, d) + F::from_f64(2.0)
    } else {
        div(r - g, d) + F::from_f64(4.0)
    };
    [div(h, six), div(d, mx), mx]
}

/// HSV → RGB (hue wraps modulo 1, saturation used as given).
#[inline]
pub fn hsv_to_rgb<F: Real>(c: [F; 3]) -> [F; 3] {
    let [h, s, v] = c;
    let six = F::from_f64(6.0);
    let h6 = fract(h) * six;
    let sector = h6.floor();
    let f = h6 - sector;
    let p = v * (F::ONE - s);
    let q = v * (F::ONE - s * f);
    let t = v * (F::ONE - s * (F::ONE - f));
    match sector.to_i32() {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}
