//! `oren_nayar_diffuse_bsdf`: diffuse reflection with Oren–Nayar roughness, as MaterialX
//! 1.39 defines it, sampled by the cosine-weighted hemisphere.
//!
//! With `c = cos θo = wo.z`, `l = cos θi = wi.z`, `s = wo·wi − c l` and `σ` the roughness:
//! - plain (the "qualitative" model of Oren and Nayar, 1994):
//!   `f = color/π · (A + B · max(s, 0)/max(c, l))`, `A = 1 − σ²/(2(σ² + 0.33))`,
//!   `B = 0.45 σ²/(σ² + 0.09)`; directional albedo: MaterialX's rational fit
//!   `E(c) = (1 − 0.4297σ − 0.7632cσ + 1.4385σ²) / (1 − 0.6076σ − 0.4993cσ + 2.0315σ²)`,
//!   clamped to [0, 1], times `color`.
//! - `energy_compensation` (Fujii's energy-preserving model as OpenPBR uses it):
//!   `f = color/π · A_F (1 + σ s/t) + f_ms`, `A_F = 1/(1 + (1/2 − 2/(3π))σ)`, where
//!   `t = max(c, l)` for `s > 0` and `t = 1` otherwise (Fujii's definition, which his
//!   exact albedo `E_F` integrates: dividing a negative `s` too loses up to 20 % of a white
//!   lobe's light at grazing views, as the lobe suite's furnace showed), and the
//!   multiple-scattering lobe
//!   `f_ms = ρ_ms/π · (1 − E_F(c))(1 − E_F(l)) / (1 − Ē_F)` with `ρ_ms = color² Ē_F / (1 −
//!   color (1 − Ē_F))`, `E_F` Fujii's exact directional albedo and `Ē_F = A_F(1 + (2/3 −
//!   28/(15π))σ)` its average; the directional albedo is `mix(ρ_ms, color, E_F(c))`, so a
//!   white lobe reflects exactly what it receives.
//!
//! Both are 0 unless `c > 0` and `l > 0`. The roughness is used as given (MaterialX does
//! not clamp it); `σ = 0` is Lambert.

use super::math::{cosine_hemisphere, div_pdf, f, gray, one_minus, pos, saturate, scale, sq};
use super::{Eval, Sample};
use crate::ir::{BinOp, Builder, UnOp, Value};
use crate::types::Type;
use std::f64::consts::PI;

const FUJII_1: f64 = 0.5 - 2.0 / (3.0 * PI);
const FUJII_2: f64 = 2.0 / 3.0 - 28.0 / (15.0 * PI);

/// `f · cos θi` and the cosine-hemisphere pdf.
pub fn eval(
    b: &mut Builder,
    color: Value,
    roughness: Value,
    compensated: bool,
    wo: Value,
    wi: Value,
) -> Eval {
    let c = b.extract(wo, 2);
    let l = b.extract(wi, 2);
    let value = value(b, color, roughness, compensated, wo, wi);
    let zero = f(b, 0.0);
    let up_o = b.binary(BinOp::Gt, c, zero);
    let up_i = b.binary(BinOp::Gt, l, zero);
    let up = b.binary(BinOp::And, up_o, up_i);
    let inv_pi = f(b, 1.0 / PI);
    let pdf = b.mul(l, inv_pi);
    let pdf = b.select(up, pdf, zero);
    let black = b.zero(Type::Color);
    let value = b.select(up, value, black);
    Eval { value, pdf }
}

/// `f · cos θi` where both cosines are positive (the caller masks the rest).
fn value(
    b: &mut Builder,
    color: Value,
    sigma: Value,
    compensated: bool,
    wo: Value,
    wi: Value,
) -> Value {
    let c = b.extract(wo, 2);
    let l = b.extract(wi, 2);
    let dot = b.dot(wo, wi);
    let cl = b.mul(c, l);
    let s = b.sub(dot, cl);
    let m = b.max(c, l);
    let t = b.div(s, m);
    let inv_pi = f(b, 1.0 / PI);
    let l_pi = b.mul(l, inv_pi);
    if !compensated {
        let s2 = sq(b, sigma);
        let (k33, k09) = (f(b, 0.33), f(b, 0.09));
        let d1 = b.add(s2, k33);
        let q1 = b.div(s2, d1);
        let half = f(b, 0.5);
        let hq = b.mul(half, q1);
        let a = one_minus(b, hq);
        let k45 = f(b, 0.45);
        let n2 = b.mul(k45, s2);
        let d2 = b.add(s2, k09);
        let bb = b.div(n2, d2);
        let tp = pos(b, t);
        let bt = b.mul(bb, tp);
        let r = b.add(a, bt);
        let k = b.mul(r, l_pi);
        return scale(b, color, k);
    }
    // Fujii: s/max(c, l) for s > 0, s itself otherwise.
    let zero = f(b, 0.0);
    let s_pos = b.binary(BinOp::Gt, s, zero);
    let t = b.select(s_pos, t, s);
    let a = fujii_a(b, sigma);
    let st = b.mul(sigma, t);
    let one = f(b, 1.0);
    let r = b.add(one, st);
    let single = b.mul(a, r);
    let single = b.mul(single, l_pi);
    let single = scale(b, color, single);
    let ev = fujii_albedo(b, c, sigma);
    let el = fujii_albedo(b, l, sigma);
    let avg = fujii_avg(b, sigma);
    let ms = multi_color(b, color, avg);
    let eps = f(b, 1e-6);
    let (ov, ol, oa) = (one_minus(b, ev), one_minus(b, el), one_minus(b, avg));
    let (ov, ol, oa) = (b.max(ov, eps), b.max(ol, eps), b.max(oa, eps));
    let k = b.mul(ov, ol);
    let k = b.div(k, oa);
    let k = b.mul(k, l_pi);
    let multi = scale(b, ms, k);
    b.add(single, multi)
}

/// Fujii's `A = 1/(1 + (1/2 − 2/(3π))σ)`.
fn fujii_a(b: &mut Builder, sigma: Value) -> Value {
    let (one, k1) = (f(b, 1.0), f(b, FUJII_1));
    let d = b.mul(k1, sigma);
    let d = b.add(one, d);
    b.div(one, d)
}

/// Fujii's exact directional albedo of his model at `cos θ = c` (`c > 0`):
/// `A + σA/π · (S(θ − S c) + 2/3 ((S/c)(1 − S³) − S))`, `S = sin θ`.
fn fujii_albedo(b: &mut Builder, c: Value, sigma: Value) -> Value {
    let a = fujii_a(b, sigma);
    let bb = b.mul(sigma, a);
    let cc = sq(b, c);
    let s2 = one_minus(b, cc);
    let s = super::math::safe_sqrt(b, s2);
    let (m1, one) = (f(b, -1.0), f(b, 1.0));
    let cl = b.clamp(c, m1, one);
    let theta = b.unary(UnOp::Acos, cl);
    let sc = b.mul(s, c);
    let g1 = b.sub(theta, sc);
    let g1 = b.mul(s, g1);
    let s3 = b.mul(s2, s);
    let om = one_minus(b, s3);
    let so = b.div(s, c);
    let g2 = b.mul(so, om);
    let g2 = b.sub(g2, s);
    let k = f(b, 2.0 / 3.0);
    let g2 = b.mul(k, g2);
    let g = b.add(g1, g2);
    let inv_pi = f(b, 1.0 / PI);
    let t = b.mul(bb, g);
    let t = b.mul(t, inv_pi);
    b.add(a, t)
}

/// Fujii's average albedo `Ē = A(1 + (2/3 − 28/(15π))σ)`.
fn fujii_avg(b: &mut Builder, sigma: Value) -> Value {
    let a = fujii_a(b, sigma);
    let (one, k2) = (f(b, 1.0), f(b, FUJII_2));
    let t = b.mul(k2, sigma);
    let t = b.add(one, t);
    b.mul(a, t)
}

/// The multiple-scattering color `color² Ē / (1 − color (1 − Ē))`.
fn multi_color(b: &mut Builder, color: Value, avg: Value) -> Value {
    let c2 = b.mul(color, color);
    let n = scale(b, c2, avg);
    let oa = one_minus(b, avg);
    let oa = pos(b, oa);
    let d = scale(b, color, oa);
    let d = one_minus(b, d);
    b.div(n, d)
}

/// A cosine-weighted direction and its weight `f cos θi / pdf`.
pub fn sample(
    b: &mut Builder,
    color: Value,
    roughness: Value,
    compensated: bool,
    wo: Value,
    u: Value,
) -> Sample {
    let (u1, u2) = (b.extract(u, 0), b.extract(u, 1));
    let (wi, _) = cosine_hemisphere(b, u1, u2);
    let e = eval(b, color, roughness, compensated, wo, wi);
    let weight = div_pdf(b, e.value, e.pdf);
    Sample {
        wi,
        weight,
        pdf: e.pdf,
    }
}

/// The directional albedo (color), 0 for `cos θo ≤ 0`.
pub fn albedo(b: &mut Builder, color: Value, sigma: Value, compensated: bool, wo: Value) -> Value {
    let c = b.extract(wo, 2);
    let a = if compensated {
        let e = fujii_albedo(b, c, sigma);
        let e = saturate(b, e);
        let avg = fujii_avg(b, sigma);
        let ms = multi_color(b, color, avg);
        b.mix(ms, color, e)
    } else {
        let s2 = sq(b, sigma);
        let cs = b.mul(c, sigma);
        let num = poly(b, sigma, cs, s2, [-0.4297, -0.7632, 1.4385]);
        let den = poly(b, sigma, cs, s2, [-0.6076, -0.4993, 2.0315]);
        let e = b.div(num, den);
        let e = saturate(b, e);
        let g = gray(b, e);
        b.mul(color, g)
    };
    let zero = f(b, 0.0);
    let up = b.binary(BinOp::Gt, c, zero);
    let black = b.zero(Type::Color);
    b.select(up, a, black)
}

/// `1 + k0 σ + k1 cσ + k2 σ²`.
fn poly(b: &mut Builder, sigma: Value, cs: Value, s2: Value, k: [f64; 3]) -> Value {
    let one = f(b, 1.0);
    let k = k.map(|x| f(b, x));
    let t0 = b.mul(k[0], sigma);
    let t1 = b.mul(k[1], cs);
    let t2 = b.mul(k[2], s2);
    let s = b.add(one, t0);
    let s = b.add(s, t1);
    b.add(s, t2)
}
