//! `burley_diffuse_bsdf`: Burley's diffuse reflection (Disney BRDF, SIGGRAPH 2012) as
//! MaterialX 1.39 defines it, sampled by the cosine-weighted hemisphere.
//!
//! With `c = cos θo`, `l = cos θi`, `h = normalize(wo + wi)` and `r` the roughness:
//! `f = color/π · F(l) F(c)`, `F(x) = 1 + (F90 − 1)(1 − x)⁵`, `F90 = ½ + 2 r (wi·h)²`, and 0
//! unless `c > 0` and `l > 0`. The model is not energy conserving: at roughness 1 and
//! grazing views its retro-reflection reflects more than it receives (a white lobe's
//! directional albedo reaches about 1.5 at `c → 0`; the lobe suite bounds it).
//!
//! The directional albedo is Stephen Hill's fit that MaterialX uses,
//! `mix(0.97619 − 0.488095 (1 − c)⁵, 1.55754 + (−2.02221 + (2.56283 − 1.06244 c) c) c, r)`,
//! times `color` (the lobe suite checks it against a Monte Carlo estimate).

use super::math::{cosine_hemisphere, div_pdf, f, gt, one_minus, scale, sq};
use super::{Eval, Sample};
use crate::ir::{BinOp, Builder, Value};
use crate::types::Type;
use std::f64::consts::PI;

/// `x⁵`.
fn pow5(b: &mut Builder, x: Value) -> Value {
    let x2 = sq(b, x);
    let x4 = sq(b, x2);
    b.mul(x4, x)
}

/// Schlick's `1 + (f90 − 1)(1 − x)⁵`.
fn schlick(b: &mut Builder, x: Value, f90: Value) -> Value {
    let om = one_minus(b, x);
    let p = pow5(b, om);
    let one = f(b, 1.0);
    let k = b.sub(f90, one);
    let t = b.mul(k, p);
    b.add(one, t)
}

/// `f · cos θi` and the cosine-hemisphere pdf.
pub fn eval(b: &mut Builder, color: Value, roughness: Value, wo: Value, wi: Value) -> Eval {
    let c = b.extract(wo, 2);
    let l = b.extract(wi, 2);
    let zero = f(b, 0.0);
    let up_o = gt(b, c, zero);
    let up_i = gt(b, l, zero);
    let up = b.binary(BinOp::And, up_o, up_i);
    let h = b.add(wo, wi);
    let h = b.normalize(h);
    let lh = b.dot(wi, h);
    let lh2 = sq(b, lh);
    let two = f(b, 2.0);
    let k = b.mul(two, roughness);
    let k = b.mul(k, lh2);
    let half = f(b, 0.5);
    let f90 = b.add(half, k);
    let fl = schlick(b, l, f90);
    let fv = schlick(b, c, f90);
    let inv_pi = f(b, 1.0 / PI);
    let s = b.mul(fl, fv);
    let s = b.mul(s, l);
    let s = b.mul(s, inv_pi);
    let value = scale(b, color, s);
    let black = b.zero(Type::Color);
    let value = b.select(up, value, black);
    let pdf = b.mul(l, inv_pi);
    let pdf = b.select(up, pdf, zero);
    Eval { value, pdf }
}

/// A cosine-weighted direction and its weight `f cos θi / pdf`.
pub fn sample(b: &mut Builder, color: Value, roughness: Value, wo: Value, u: Value) -> Sample {
    let (u1, u2) = (b.extract(u, 0), b.extract(u, 1));
    let (wi, _) = cosine_hemisphere(b, u1, u2);
    let e = eval(b, color, roughness, wo, wi);
    let weight = div_pdf(b, e.value, e.pdf);
    Sample {
        wi,
        weight,
        pdf: e.pdf,
    }
}

/// Hill's directional albedo fit times `color`, 0 for `cos θo ≤ 0`.
pub fn albedo(b: &mut Builder, color: Value, roughness: Value, wo: Value) -> Value {
    let c = b.extract(wo, 2);
    let om = one_minus(b, c);
    let p = pow5(b, om);
    let (k0, k1) = (f(b, 0.97619), f(b, 0.488095));
    let t = b.mul(k1, p);
    let fit0 = b.sub(k0, t);
    // 1.55754 + (−2.02221 + (2.56283 − 1.06244 c) c) c
    let (a0, a1, a2, a3) = (f(b, 1.55754), f(b, -2.02221), f(b, 2.56283), f(b, 1.06244));
    let t = b.mul(a3, c);
    let t = b.sub(a2, t);
    let t = b.mul(t, c);
    let t = b.add(a1, t);
    let t = b.mul(t, c);
    let fit1 = b.add(a0, t);
    let e = b.mix(fit0, fit1, roughness);
    let a = scale(b, color, e);
    let zero = f(b, 0.0);
    let up = gt(b, c, zero);
    let black = b.zero(Type::Color);
    b.select(up, a, black)
}
