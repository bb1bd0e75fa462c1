//! `conductor_bsdf`: a rough metal (GGX reflection with the exact conductor Fresnel per
//! channel), as MaterialX 1.39 defines it, built on [`ggx::Microfacet`] in `R` mode. Its Fresnel
//! is the mean of the two polarizations of [`thin_film::polarized`] (the film needs them
//! apart).
//!
//! Fresnel (Lagarde's form of the exact unpolarized formula for a complex index
//! `n + ik` per channel, `c = wo·h`): `t0 = n² − k² − s²` (`s² = 1 − c²`),
//! `a²+b² = √(t0² + 4n²k²)`, `a = √(½(a²+b² + t0))`, `Rs = (a²+b² + c² − 2ac)/(a²+b² + c² +
//! 2ac)`, `Rp = Rs (c²(a²+b²) + s⁴ − 2ac s²)/(c²(a²+b²) + s⁴ + 2ac s²)`, `F = (Rs + Rp)/2`.
//! `f · cos θi = F D G2 / (4 cos θo)`.
//!
//! A thin film (`thinfilm_thickness` > 0) replaces `F` by [`thin_film::fresnel`] over this
//! metal.
//!
//! Albedo: MaterialX's approximation `F0 A + B` (our GGX albedo table, `ops::ggx_albedo`) with `F0` the Fresnel at normal
//! incidence (the Schlick split with `F90 = 1`); its error against the exact conductor
//! Fresnel is largest for strongly colored metals at grazing angles.

use super::ggx::{self, Alpha, Microfacet};
use super::math::{f, scale};
use super::{Eval, Sample, ScatterMode, ThinFilm, thin_film};
use crate::ir::{Builder, Value};

/// The exact conductor Fresnel reflectance (color) at `c = cos` (float, clamped to [0, 1])
/// for index `n` and extinction `k` (colors).
pub fn fresnel(b: &mut Builder, c: Value, n: Value, k: Value) -> Value {
    let (rp, rs) = thin_film::polarized(b, c, n, k);
    let s = b.add(rs, rp);
    let half = f(b, 0.5);
    scale(b, s, half)
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
    /// A thin film over the metal.
    pub thin_film: Option<ThinFilm>,
}

impl Conductor {
    fn with<R>(&self, b: &mut Builder, body: impl FnOnce(&mut Builder, &Microfacet) -> R) -> R {
        let alpha = Alpha::new(b, self.roughness);
        let (n, k) = (self.ior, self.extinction);
        let film = self.thin_film;
        let fr = move |b: &mut Builder, c: Value| {
            let base = thin_film::Base::Exact { eta: n, kappa: k };
            let one = f(b, 1.0);
            let film = film.as_ref().map(|t| (t, one));
            thin_film::or_plain(b, c, film, &base, &|b, c| fresnel(b, c, n, k))
        };
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

    /// The directional albedo (color): `F(1) A + B` from the GGX albedo table; with a film,
    /// [`thin_film::albedo`] where its thickness is > 0.
    pub fn albedo(&self, b: &mut Builder, wo: Value) -> Value {
        let alpha = Alpha::new(b, self.roughness);
        let one = f(b, 1.0);
        let f0 = fresnel(b, one, self.ior, self.extinction);
        let w = ggx::white(b);
        let plain = ggx::albedo_f0_f90(b, alpha, wo, f0, w);
        let (n, k) = (self.ior, self.extinction);
        let base = thin_film::Base::Exact { eta: n, kappa: k };
        let film = self.thin_film.as_ref().map(|t| (t, one));
        thin_film::albedo_or_plain(
            b,
            alpha,
            wo,
            film,
            &base,
            &|b, c| fresnel(b, c, n, k),
            plain,
        )
    }
}
