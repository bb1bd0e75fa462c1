//! Small IR-emitting helpers the lobe files share (scalar algebra on [`Value`]s, local-frame
//! vectors, cosine-weighted hemisphere sampling). It owns no lobe and reads no stream.

use crate::ir::{BinOp, Builder, UnOp, Value};
use crate::types::Type;
use std::f64::consts::PI;

/// A float constant.
pub fn f(b: &mut Builder, x: f64) -> Value {
    b.float(x)
}

/// `x²`.
pub fn sq(b: &mut Builder, x: Value) -> Value {
    b.mul(x, x)
}

/// `clamp(x, 0, 1)`, with a NaN `x` giving 0.
pub fn saturate(b: &mut Builder, x: Value) -> Value {
    let (zero, one) = (b.float(0.0), b.float(1.0));
    let x = b.max(x, zero);
    b.min(x, one)
}

/// `max(x, 0)` (a NaN `x` gives 0).
pub fn pos(b: &mut Builder, x: Value) -> Value {
    let zero = b.float(0.0);
    b.max(x, zero)
}

/// `√max(x, 0)`.
pub fn safe_sqrt(b: &mut Builder, x: Value) -> Value {
    let x = pos(b, x);
    b.unary(UnOp::Sqrt, x)
}

/// `1 − x`.
pub fn one_minus(b: &mut Builder, x: Value) -> Value {
    let ty = b.ty(x);
    let one = b.float(1.0);
    let one = b.splat_to(ty, one);
    b.sub(one, x)
}

/// `a < c` (bool).
pub fn lt(b: &mut Builder, a: Value, c: Value) -> Value {
    b.binary(BinOp::Lt, a, c)
}

/// `a > c` (bool).
pub fn gt(b: &mut Builder, a: Value, c: Value) -> Value {
    b.binary(BinOp::Gt, a, c)
}

/// Component `i` of a vector.
pub fn comp(b: &mut Builder, v: Value, i: usize) -> Value {
    b.extract(v, i)
}

/// A vec3 from three floats.
pub fn vec3(b: &mut Builder, x: Value, y: Value, z: Value) -> Value {
    b.construct(Type::Vec3, &[x, y, z])
}

/// A color `c` times a float `s`.
pub fn scale(b: &mut Builder, c: Value, s: Value) -> Value {
    let ty = b.ty(c);
    let s = b.splat(ty, s);
    b.mul(c, s)
}

/// A color with three equal channels.
pub fn gray(b: &mut Builder, s: Value) -> Value {
    b.splat(Type::Color, s)
}

/// `cos θ` of a local-frame direction: its `z`.
pub fn cos_theta(b: &mut Builder, w: Value) -> Value {
    b.extract(w, 2)
}

/// The luminance of a linear Rec. 709 color (float), used to pick lobes.
pub fn luminance(b: &mut Builder, c: Value) -> Value {
    let w = b.vec3([0.2126, 0.7152, 0.0722]);
    let c = b.retype(Type::Vec3, c);
    b.dot(c, w)
}

/// A cosine-weighted direction on the `+z` hemisphere from two uniform numbers (Malley's
/// method: a uniform point on the unit disk lifted to the hemisphere) and its density
/// `cos θ / π`.
pub fn cosine_hemisphere(b: &mut Builder, u1: Value, u2: Value) -> (Value, Value) {
    let r = safe_sqrt(b, u1);
    let tau = b.float(2.0 * PI);
    let phi = b.mul(tau, u2);
    let (c, s) = (b.unary(UnOp::Cos, phi), b.unary(UnOp::Sin, phi));
    let x = b.mul(r, c);
    let y = b.mul(r, s);
    let om = one_minus(b, u1);
    let z = safe_sqrt(b, om);
    let w = vec3(b, x, y, z);
    let inv_pi = b.float(1.0 / PI);
    let pdf = b.mul(z, inv_pi);
    (w, pdf)
}

/// `a / c` where `c > 0`, else 0 (a color or float `a`, a float `c`): what a sampled
/// weight is where its density vanishes.
pub fn div_pdf(b: &mut Builder, a: Value, c: Value) -> Value {
    let zero = b.float(0.0);
    let ok = gt(b, c, zero);
    let ty = b.ty(a);
    let cs = b.splat_to(ty, c);
    let q = b.div(a, cs);
    let z = b.zero(ty);
    b.select(ok, q, z)
}

/// MaterialX's `mx_f0_to_ior`: the real index `(1 + √F0)/(1 − √F0)` of a normal-incidence
/// reflectance `f0` (float or color, per channel) clamped to [0.01, 0.99].
pub fn f0_to_ior(b: &mut Builder, f0: Value) -> Value {
    let ty = b.ty(f0);
    let (lo, hi) = (b.float(0.01), b.float(0.99));
    let (lo, hi) = (b.splat_to(ty, lo), b.splat_to(ty, hi));
    let f0 = b.clamp(f0, lo, hi);
    let s = b.unary(UnOp::Sqrt, f0);
    let one = b.float(1.0);
    let one = b.splat_to(ty, one);
    let n = b.add(one, s);
    let d = b.sub(one, s);
    b.div(n, d)
}
