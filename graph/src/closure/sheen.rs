//! `sheen_bsdf`, mode `conty_kulla` (MaterialX 1.39's default): the Imageworks sheen of
//! Conty and Kulla ("Production Friendly Microfacet Sheen BRDF", SIGGRAPH 2017), sampled
//! uniformly over the hemisphere.
//!
//! With `c = cos θo`, `l = cos θi`, `h = normalize(wo + wi)`, `s² = 1 − h.z²` and
//! `r = max(roughness, 0.005)`: the "Charlie" distribution `D = (2 + 1/r) s^(1/r) / (2π)`
//! over the smooth denominator of Neubelt and Pettineo instead of a shadowing term,
//! `f = color · D / (4 (l + c − l c))`, and 0 unless `c > 0` and `l > 0`. Fresnel and
//! shadowing are 1, as MaterialX has them.
//!
//! Uniform hemisphere sampling (pdf `1/(2π)`) rather than the cosine: the lobe's light
//! comes from grazing half-vectors, and `f cos θi / pdf = π D l / (2(l + c − lc)) ≤ π D/2`
//! stays bounded at grazing views, where the cosine density's weight grows as `1/c`.
//!
//! The model reflects more than it receives at grazing views of smooth roughness (no
//! shadowing term: a white lobe 5.3× at 89.9° and roughness 0, 1.3× at 0.1). The lobe here
//! is divided by `N(cos θo) N(cos θi)`, `N(x) = max(1, E(x))` with `E` the model's own
//! directional albedo: reciprocal, never above 1 in a white furnace, and exactly the model
//! wherever it reflects at most what it receives from both directions (every view at
//! roughness ≥ 0.3).
//!
//! `E` and the normalized lobe's albedo (what [`albedo`] gives, times `color`) come from one
//! table of our own integration (`ops::sheen_albedo`, the intrinsic
//! `sheen_albedo`); it replaced MaterialX's rational fit, which is up to 0.1 off the model
//! (0.157 at `c = 1`, `r = 1`, where the model's is 0.1414) and under which `layer` gave
//! standard_surface's sheen 8.4 % more than the light in a white furnace. MaterialX's
//! `zeltner` mode (an LTC sheen) is not built here: the node lowering must refuse it with
//! an error.

use super::math::{div_pdf, f, gt, one_minus, pos, safe_sqrt, scale, sq, vec3};
use super::{Eval, Sample};
use crate::ir::{BinOp, Builder, Intrinsic, UnOp, Value};
use crate::types::Type;
use std::f64::consts::PI;

/// `f · cos θi` and the uniform-hemisphere pdf.
pub fn eval(b: &mut Builder, color: Value, roughness: Value, wo: Value, wi: Value) -> Eval {
    let c = b.extract(wo, 2);
    let l = b.extract(wi, 2);
    let zero = f(b, 0.0);
    let up_o = gt(b, c, zero);
    let up_i = gt(b, l, zero);
    let up = b.binary(BinOp::And, up_o, up_i);
    let h = b.add(wo, wi);
    let h = b.normalize(h);
    let hz = b.extract(h, 2);
    let hz2 = sq(b, hz);
    let s2 = one_minus(b, hz2);
    let s2 = pos(b, s2);
    let rmin = f(b, 0.005);
    let r = b.max(roughness, rmin);
    let one = f(b, 1.0);
    let inv_r = b.div(one, r);
    let half = f(b, 0.5);
    let e = b.mul(inv_r, half);
    let p = b.binary(BinOp::Pow, s2, e);
    let two = f(b, 2.0);
    let k = b.add(two, inv_r);
    let d = b.mul(k, p);
    let inv_2pi = f(b, 0.5 / PI);
    let d = b.mul(d, inv_2pi);
    let cl = b.mul(c, l);
    let den = b.add(c, l);
    let den = b.sub(den, cl);
    let four = f(b, 4.0);
    let den = b.mul(four, den);
    let fr = b.div(d, den);
    let fr = b.mul(fr, l);
    let nc = normalization(b, c, roughness);
    let nl = normalization(b, l, roughness);
    let n = b.mul(nc, nl);
    let fr = b.div(fr, n);
    let value = scale(b, color, fr);
    let black = b.zero(Type::Color);
    let value = b.select(up, value, black);
    let pdf = b.select(up, inv_2pi, zero);
    Eval { value, pdf }
}

/// A uniform direction on the upper hemisphere (`cos θi = u.x`, `φ = 2π u.y`).
pub fn sample(b: &mut Builder, color: Value, roughness: Value, wo: Value, u: Value) -> Sample {
    let (u1, u2) = (b.extract(u, 0), b.extract(u, 1));
    let z = one_minus(b, u1);
    let zz = sq(b, z);
    let om = one_minus(b, zz);
    let s = safe_sqrt(b, om);
    let tau = f(b, 2.0 * PI);
    let phi = b.mul(tau, u2);
    let (cp, sp) = (b.unary(UnOp::Cos, phi), b.unary(UnOp::Sin, phi));
    let x = b.mul(s, cp);
    let y = b.mul(s, sp);
    let wi = vec3(b, x, y, z);
    let e = eval(b, color, roughness, wo, wi);
    let weight = div_pdf(b, e.value, e.pdf);
    Sample {
        wi,
        weight,
        pdf: e.pdf,
    }
}

/// `N(x) = max(1, E(x))`, `E` the raw lobe's albedo at `cos θo = x` (the table).
fn normalization(b: &mut Builder, x: Value, roughness: Value) -> Value {
    let e = b.call(Intrinsic::SheenAlbedo, &[x, roughness]);
    let e = b.extract(e, 0);
    let one = f(b, 1.0);
    b.max(e, one)
}

/// The normalized lobe's albedo `G / N(cos θo)` (the table's `(E, G)`, `N = max(1, E)`)
/// times `color`, 0 for `cos θo ≤ 0`.
pub fn albedo(b: &mut Builder, color: Value, roughness: Value, wo: Value) -> Value {
    let c = b.extract(wo, 2);
    let eg = b.call(Intrinsic::SheenAlbedo, &[c, roughness]);
    let (e, g) = (b.extract(eg, 0), b.extract(eg, 1));
    let one = f(b, 1.0);
    let n = b.max(e, one);
    let e = b.div(g, n);
    let a = scale(b, color, e);
    let zero = f(b, 0.0);
    let up = gt(b, c, zero);
    let black = b.zero(Type::Color);
    b.select(up, a, black)
}
