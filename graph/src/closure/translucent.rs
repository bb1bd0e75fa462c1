//! `translucent_bsdf`: Lambertian transmission of `color` to the side opposite the viewer,
//! as MaterialX 1.39 defines it, sampled by the cosine-weighted lower hemisphere.
//!
//! `f · |cos θi| = color · |l|/π` for `l = cos θi < 0` (and `cos θo > 0`), 0 otherwise; the
//! pdf is `|l|/π` there, so every sample's weight is `color` and the directional albedo is
//! `color` (0 for `cos θo ≤ 0`, as every lobe gives for a degenerate frame).

use super::math::{cosine_hemisphere, div_pdf, f, gt, lt, scale, vec3};
use super::{Eval, Sample};
use crate::ir::{BinOp, Builder, UnOp, Value};
use crate::types::Type;
use std::f64::consts::PI;

/// `color |cos θi| / π` below the surface and its pdf.
pub fn eval(b: &mut Builder, color: Value, wo: Value, wi: Value) -> Eval {
    let c = b.extract(wo, 2);
    let l = b.extract(wi, 2);
    let zero = f(b, 0.0);
    let up_o = gt(b, c, zero);
    let down = lt(b, l, zero);
    let ok = b.binary(BinOp::And, up_o, down);
    let al = b.unary(UnOp::Neg, l);
    let inv_pi = f(b, 1.0 / PI);
    let pdf = b.mul(al, inv_pi);
    let pdf = b.select(ok, pdf, zero);
    let value = scale(b, color, pdf);
    Eval { value, pdf }
}

/// A cosine-weighted direction below the surface; its weight is `color`.
pub fn sample(b: &mut Builder, color: Value, wo: Value, u: Value) -> Sample {
    let (u1, u2) = (b.extract(u, 0), b.extract(u, 1));
    let (w, _) = cosine_hemisphere(b, u1, u2);
    let (x, y, z) = (b.extract(w, 0), b.extract(w, 1), b.extract(w, 2));
    let z = b.unary(UnOp::Neg, z);
    let wi = vec3(b, x, y, z);
    let e = eval(b, color, wo, wi);
    let weight = div_pdf(b, e.value, e.pdf);
    Sample {
        wi,
        weight,
        pdf: e.pdf,
    }
}

/// `color`, 0 for `cos θo ≤ 0`.
pub fn albedo(b: &mut Builder, color: Value, wo: Value) -> Value {
    let c = b.extract(wo, 2);
    let zero = f(b, 0.0);
    let up = gt(b, c, zero);
    let black = b.zero(Type::Color);
    b.select(up, color, black)
}
