//! `generalized_schlick_bsdf`: a GGX interface whose Fresnel is MaterialX 1.39's
//! generalized Schlick with the F82 tint (Hoffman 2023), reflecting, transmitting or both,
//! built on [`ggx::Microfacet`]. It owns that Fresnel formula.
//!
//! With `x = clamp(wo·h, 0, 1)` and colors clamped to ≥ 0:
//! `F(x) = mix(F0, F90, (1 − x)^p) − a x (1 − x)⁶`,
//! `a = mix(F0, F90, (6/7)^p) (1 − F82) / ((1/7)(6/7)⁶)`, `p` the exponent; `F82 = 1`
//! gives the plain generalized Schlick.
//!
//! Transmission (`T`, `RT`) is the dielectric's (see [`super::dielectric`]) with `F` from
//! the formula above and, as MaterialX does, the index `(1 + √F̄0)/(1 − √F̄0)` from the mean
//! `F̄0` of `color0` clamped to [0.01, 0.99] (inverted when the viewer is inside); where
//! that index forbids refraction `F = 1` (total internal reflection). `RT` reflects with
//! probability = the mean of `F`'s channels.
//!
//! A thin film (`thinfilm_thickness` > 0) replaces `F` by [`thin_film::fresnel`] over this
//! interface, seen from outside.
//!
//! Albedo: `R` is `color0 A + color90 B` of the GGX albedo table (F82 ignored, as MaterialX
//! does); `T` and `RT` give white (energy through, see the dielectric's note).

use super::ggx::{self, Alpha, Microfacet};
use super::math::{f, f0_to_ior, gray, lt, one_minus, saturate, scale, sq};
use super::{Eval, Sample, ScatterMode, ThinFilm, thin_film};
use crate::ir::{BinOp, Builder, Value};
use crate::types::Type;

/// `cos θ` where the F82 term peaks.
const COS_MAX: f64 = 1.0 / 7.0;

/// The generalized Schlick reflectance (color) at `x = cos` (float) for colors `f0`, `f82`,
/// `f90` (already ≥ 0) and exponent `p` (float).
pub fn fresnel(b: &mut Builder, x: Value, f0: Value, f82: Value, f90: Value, p: Value) -> Value {
    let x = saturate(b, x);
    let omx = one_minus(b, x);
    let t = b.binary(BinOp::Pow, omx, p);
    let base = b.mix(f0, f90, t);
    let k = f(b, 1.0 - COS_MAX);
    let tk = b.binary(BinOp::Pow, k, p);
    let at = b.mix(f0, f90, tk);
    let om82 = one_minus(b, f82);
    let a = b.mul(at, om82);
    let factor = f(b, 1.0 / (COS_MAX * (1.0 - COS_MAX).powi(6)));
    let a = scale(b, a, factor);
    let o2 = sq(b, omx);
    let o3 = b.mul(o2, omx);
    let o6 = sq(b, o3);
    let s = b.mul(x, o6);
    let corr = scale(b, a, s);
    b.sub(base, corr)
}

/// The lobe's parameters.
#[derive(Clone, Copy, Debug)]
pub struct Schlick {
    /// Reflectance at normal incidence (color).
    pub color0: Value,
    /// Reflectance tint at 82° (color).
    pub color82: Value,
    /// Reflectance at grazing incidence (color).
    pub color90: Value,
    /// Schlick exponent (float).
    pub exponent: Value,
    /// Roughness `(αx, αy)` (vec2).
    pub roughness: Value,
    /// Which sides scatter.
    pub mode: ScatterMode,
    /// Whether the viewer is inside (bool).
    pub inside: Value,
    /// A thin film on the interface (seen from outside).
    pub thin_film: Option<ThinFilm>,
}

impl Schlick {
    /// The three colors clamped to ≥ 0.
    fn colors(&self, b: &mut Builder) -> [Value; 3] {
        let zero = b.zero(Type::Color);
        [self.color0, self.color82, self.color90].map(|c| b.max(c, zero))
    }

    /// `etap` from the mean of `color0` (MaterialX's `mx_f0_to_ior`).
    fn etap(&self, b: &mut Builder, f0: Value) -> Value {
        let v = b.retype(Type::Vec3, f0);
        let third = b.vec3([1.0 / 3.0; 3]);
        let m = b.dot(v, third);
        let ior = f0_to_ior(b, m);
        super::dielectric::etap(b, ior, self.inside)
    }

    fn with<R>(&self, b: &mut Builder, body: impl FnOnce(&mut Builder, &Microfacet) -> R) -> R {
        let alpha = Alpha::new(b, self.roughness);
        let [f0, f82, f90] = self.colors(b);
        let p = self.exponent;
        let etap = self.etap(b, f0);
        let transmits = self.mode != ScatterMode::R;
        let film = self.thin_film;
        let fr = move |b: &mut Builder, c: Value| {
            let base = thin_film::Base::Schlick { f0 };
            let one = f(b, 1.0);
            let film = film.as_ref().map(|t| (t, one));
            let plain = |b: &mut Builder, c: Value| fresnel(b, c, f0, f82, f90, p);
            let fr = thin_film::or_plain(b, c, film, &base, &plain);
            if !transmits {
                return fr;
            }
            let c2 = sq(b, c);
            let s2 = one_minus(b, c2);
            let e2 = sq(b, etap);
            let st2 = b.div(s2, e2);
            let one = f(b, 1.0);
            let ok = lt(b, st2, one);
            let w = gray(b, one);
            b.select(ok, fr, w)
        };
        let tint = ggx::white(b);
        let m = Microfacet {
            alpha,
            mode: self.mode,
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

    /// The directional albedo (color).
    pub fn albedo(&self, b: &mut Builder, wo: Value) -> Value {
        if self.mode != ScatterMode::R {
            return ggx::white(b);
        }
        let alpha = Alpha::new(b, self.roughness);
        let [f0, f82, f90] = self.colors(b);
        let plain = ggx::albedo_f0_f90(b, alpha, wo, f0, f90);
        let p = self.exponent;
        let base = thin_film::Base::Schlick { f0 };
        let one = f(b, 1.0);
        let film = self.thin_film.as_ref().map(|t| (t, one));
        thin_film::albedo_or_plain(
            b,
            alpha,
            wo,
            film,
            &base,
            &|b, c| fresnel(b, c, f0, f82, f90, p),
            plain,
        )
    }
}
