//! `subsurface_bsdf`: an approximation. Until shadenet has volumes and a random walk, the
//! lobe is **Lambertian reflection of `color`** (`f · cos θi = color · cos θi / π` where
//! both cosines are positive, albedo `color`, cosine-hemisphere sampling): light that
//! enters and leaves the surface at the same point. `radius` (the mean free path) and
//! `anisotropy` (the phase function's) are accepted and ignored, so the blur and the
//! translucency of real subsurface scattering are missing. MaterialX's own GLSL does
//! something close (a diffusion profile integrated over the local curvature for direct
//! light, plain diffuse for indirect light); this is what MaterialX does for indirect light
//! everywhere.

use super::math::{cosine_hemisphere, div_pdf, f, gt, scale};
use super::{Eval, Sample};
use crate::ir::{BinOp, Builder, Value};
use crate::types::Type;
use std::f64::consts::PI;

/// `color cos θi / π` above the surface and its pdf.
pub fn eval(b: &mut Builder, color: Value, wo: Value, wi: Value) -> Eval {
    let c = b.extract(wo, 2);
    let l = b.extract(wi, 2);
    let zero = f(b, 0.0);
    let up_o = gt(b, c, zero);
    let up_i = gt(b, l, zero);
    let ok = b.binary(BinOp::And, up_o, up_i);
    let inv_pi = f(b, 1.0 / PI);
    let pdf = b.mul(l, inv_pi);
    let pdf = b.select(ok, pdf, zero);
    let value = scale(b, color, pdf);
    Eval { value, pdf }
}

/// A cosine-weighted direction; its weight is `color`.
pub fn sample(b: &mut Builder, color: Value, wo: Value, u: Value) -> Sample {
    let (u1, u2) = (b.extract(u, 0), b.extract(u, 1));
    let (wi, _) = cosine_hemisphere(b, u1, u2);
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
