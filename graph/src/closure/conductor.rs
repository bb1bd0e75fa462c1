//! `conductor_bsdf`: a rough metal (GGX reflection with the exact conductor Fresnel per
//! channel), as MaterialX 1.39 defines it, built on [`ggx::Microfacet`] in `R` mode. It owns
//! the conductor Fresnel formula.
//!
//! Fresnel (Lagarde's form of the exact unpolarized formula for a complex index
//! `n + ik` per channel, `c = wo·h`): `t0 = n² − k² − s²` (`s² = 1 − c²`),
//! `a²+b² = √(t0² + 4n²k²)`, `a = √(½(a²+b² + t0))`, `Rs = (a²+b² + c² − 2ac)/(a²+b² + c² +
//! 2ac)`, `Rp = Rs (c²(a²+b²) + s⁴ − 2ac s²)/(c²(a²+b²) + s⁴ + 2ac s²)`, `F = (Rs + Rp)/2`.
//! `f · cos θi = F D G2 / (4 cos θo)`.
//!
//! Albedo: MaterialX's approximation, the fit `F0 A + B` with `F0` the Fresnel at normal
//! incidence (the Schlick split with `F90 = 1`); its error against the exact conductor
//! Fresnel is largest for strongly colored metals at grazing angles.

use super::ggx::{self, Alpha, Microfacet};
use super::math::{f, gray, one_minus, saturate, scale, sq};
use super::{Eval, Sample, ScatterMode};
use crate::ir::{Builder, UnOp, Value};

/// The exact conductor Fresnel reflectance (color) at `c = cos` (float, clamped to [0, 1])
/// for index `n` and extinction `k` (colors).
pub fn fresnel(b: &mut Builder, c: Value, n: Value, k: Value) -> Value {
    let c = saturate(b, c);
    let c2 = sq(b, c);
    let s2 = one_minus(b, c2);
    let (n2, k2) = (b.mul(n, n), b.mul(k, k));
    let s2c = gray(b, s2);
    let c2c = gray(b, c2);
    let t0 = b.sub(n2, k2);
    let t0 = b.sub(t0, s2c);
    let t0sq = b.mul(t0, t0);
    let nk = b.mul(n2, k2);
    let four = f(b, 4.0);
    let nk4 = scale(b, nk, four);
    let ab = b.add(t0sq, nk4);
    let ab = b.unary(UnOp::Sqrt, ab);
    let t1 = b.add(ab, c2c);
    let a = b.add(ab, t0);
    let half = f(b, 0.5);
    let a = scale(b, a, half);
    let a = pos_color(b, a);
    let a = b.unary(UnOp::Sqrt, a);
    let two_c = b.add(c, c);
    let t2 = scale(b, a, two_c);
    let num = b.sub(t1, t2);
    let den = b.add(t1, t2);
    let rs = b.div(num, den);
    let t3 = scale(b, ab, c2);
    let s4 = sq(b, s2);
    let s4c = gray(b, s4);
    let t3 = b.add(t3, s4c);
    let t4 = scale(b, t2, s2);
    let num = b.sub(t3, t4);
    let den = b.add(t3, t4);
    let rp = b.div(num, den);
    let rp = b.mul(rs, rp);
    let s = b.add(rs, rp);
    scale(b, s, half)
}

/// `max(x, 0)` per channel of a color.
fn pos_color(b: &mut Builder, x: Value) -> Value {
    let zero = b.zero(crate::types::Type::Color);
    b.max(x, zero)
}

/// The lobe's parameters.
#[derive(Clone, Copy, Debug)]
pub struct Conductor {
    /// Index of refraction `n` (color).
    pub ior: Value,
    /// Extinction `k` (color).
    pub extinction: Value,
    /// Roughness `(αx, αy)` (vec2).
    pub roughness: Value,
}

impl Conductor {
    fn with<R>(&self, b: &mut Builder, body: impl FnOnce(&mut Builder, &Microfacet) -> R) -> R {
        let alpha = Alpha::new(b, self.roughness);
        let (n, k) = (self.ior, self.extinction);
        let fr = move |b: &mut Builder, c: Value| fresnel(b, c, n, k);
        let etap = f(b, 1.0);
        let tint = ggx::white(b);
        let m = Microfacet {
            alpha,
            mode: ScatterMode::R,
            etap,
            fresnel: &fr,
            tint,
        };
        body(b, &m)
    }

    /// `f · |cos θi|` and the pdf.
    pub fn eval(&self, b: &mut Builder, wo: Value, wi: Value) -> Eval {
        self.with(b, |b, m| m.eval(b, wo, wi))
    }

    /// A sampled direction.
    pub fn sample(&self, b: &mut Builder, wo: Value, u: Value) -> Sample {
        self.with(b, |b, m| m.sample(b, wo, u))
    }

    /// The directional albedo (color): `F(1) A + B` from MaterialX's fit.
    pub fn albedo(&self, b: &mut Builder, wo: Value) -> Value {
        let alpha = Alpha::new(b, self.roughness);
        let one = f(b, 1.0);
        let f0 = fresnel(b, one, self.ior, self.extinction);
        let w = ggx::white(b);
        ggx::albedo_f0_f90(b, alpha, wo, f0, w)
    }
}
