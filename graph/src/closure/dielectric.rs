//! `dielectric_bsdf`: a rough dielectric interface (GGX, exact unpolarized Fresnel) that
//! reflects (`R`), transmits (`T`) or both (`RT`), as MaterialX 1.39 defines it, built on
//! [`ggx::Microfacet`]. It owns the dielectric Fresnel formula; the distribution, sampling
//! and transmission geometry are [`ggx`]'s.
//!
//! `etap = ior` when the viewer is outside and `1/ior` when [`super::Frame::inside`] says it
//! is inside (the indices swap). Fresnel (Lagarde's form of the exact unpolarized formula):
//! `g² = etap² + c² − 1`; `F = 1` where `g² < 0` (total internal reflection), else
//! `F = ½ ((g − c)/(g + c))² (1 + ((c(g + c) − 1)/(c(g − c) + 1))²)`, `c = wo·h`.
//! Reflection is `tint F D G2/(4 cos θo)` (times `cos θi`), transmission Walter et al.'s
//! with pbrt-v4's `1/etap²` radiance scaling (see [`ggx`]). In `RT` reflection is chosen
//! with probability `F(wo·h)` using `u.z`.
//!
//! Albedo: `R` is `tint` times the directional albedo of this lobe with its exact Fresnel,
//! a table of our own integration over `(cos θo, α, √F0)` (`ops::dielectric_albedo`, the
//! intrinsic `dielectric_albedo`, `ᾱ = √(αx αy)`; it replaced Schlick's split `F0 A + B` of
//! the GGX table, under which `layer` gave the base up to 3 % of light the top reflects).
//! The table is for a viewer outside; inside it is raised, for near-mirror lobes, to the
//! exact Fresnel at the view angle times the white albedo, `F(cos θo)(A + B) max(1 − 4ᾱ,
//! 0)` (total internal reflection).
//! `T` and `RT` give `tint`, the
//! energy (flux) the interface passes on when nothing is absorbed, ignoring the few
//! percent that single-scattering GGX loses at high roughness and, for `T`, the reflected
//! share. Note this is not `∫ f |cos θi|` for `T`/`RT`: the transmitted radiance carries
//! the `1/etap²` factor, so the sample weights of `RT` average `F̄ + (1 − F̄)/etap²`, not
//! `tint` (the lobe picker only needs a relative size; `layer` over a transmitting top is
//! not meaningful anyway).
//!
//! A thin film (`thinfilm_thickness` > 0) replaces `F` by [`thin_film::fresnel`]: outside,
//! film over an index `ior`; inside, seen from the base (outside index `ior`, base index 1).
//! `R`'s albedo is then [`thin_film::albedo`].

use super::ggx::{self, Alpha, Microfacet};
use super::math::{f, gray, lt, safe_sqrt, sq};
use super::{Eval, Sample, ScatterMode, ThinFilm, thin_film};
use crate::ir::{Builder, Intrinsic, Value};
use crate::types::Type;

/// The exact unpolarized Fresnel reflectance of a dielectric (float) at `c = cos` (≥ 0)
/// with relative index `etap`; 1 under total internal reflection.
pub fn fresnel(b: &mut Builder, c: Value, etap: Value) -> Value {
    let c2 = sq(b, c);
    let e2 = sq(b, etap);
    let one = f(b, 1.0);
    let g2 = b.add(e2, c2);
    let g2 = b.sub(g2, one);
    let zero = f(b, 0.0);
    let tir = lt(b, g2, zero);
    let g = safe_sqrt(b, g2);
    let gmc = b.sub(g, c);
    let gpc = b.add(g, c);
    let r1 = b.div(gmc, gpc);
    let r1 = sq(b, r1);
    let n = b.mul(c, gpc);
    let n = b.sub(n, one);
    let d = b.mul(c, gmc);
    let d = b.add(d, one);
    let r2 = b.div(n, d);
    let r2 = sq(b, r2);
    let r2 = b.add(one, r2);
    let half = f(b, 0.5);
    let fr = b.mul(half, r1);
    let fr = b.mul(fr, r2);
    b.select(tir, one, fr)
}

/// `etap`: `ior`, or `1/ior` when the viewer is inside (`inside` bool).
pub fn etap(b: &mut Builder, ior: Value, inside: Value) -> Value {
    let one = f(b, 1.0);
    let inv = b.div(one, ior);
    b.select(inside, inv, ior)
}

/// The lobe's parameters.
#[derive(Clone, Copy, Debug)]
pub struct Dielectric {
    /// Tint (color).
    pub tint: Value,
    /// Index of refraction (float).
    pub ior: Value,
    /// Roughness `(αx, αy)` (vec2).
    pub roughness: Value,
    /// Which sides scatter.
    pub mode: ScatterMode,
    /// Whether the viewer is inside (bool, [`super::Frame::inside`]).
    pub inside: Value,
    /// A thin film on the interface.
    pub thin_film: Option<ThinFilm>,
}

impl Dielectric {
    fn with<R>(&self, b: &mut Builder, body: impl FnOnce(&mut Builder, &Microfacet) -> R) -> R {
        let alpha = Alpha::new(b, self.roughness);
        let etap = etap(b, self.ior, self.inside);
        let film = self.film(b);
        let fr = move |b: &mut Builder, c: Value| {
            let plain = |b: &mut Builder, c: Value| {
                let x = fresnel(b, c, etap);
                gray(b, x)
            };
            match &film {
                None => plain(b, c),
                Some((tf, outside, base)) => {
                    thin_film::or_plain(b, c, Some((tf, *outside)), base, &plain)
                }
            }
        };
        let m = Microfacet {
            alpha,
            mode: self.mode,
            etap,
            fresnel: &fr,
            tint: self.tint,
        };
        body(b, &m)
    }

    /// The film, the viewer's medium's index and the base under the film (ior outside,
    /// 1 inside).
    fn film(&self, b: &mut Builder) -> Option<(ThinFilm, Value, thin_film::Base)> {
        let tf = self.thin_film?;
        let one = f(b, 1.0);
        let outside = b.select(self.inside, self.ior, one);
        let eta = b.select(self.inside, one, self.ior);
        let eta = gray(b, eta);
        let kappa = b.zero(Type::Color);
        Some((tf, outside, thin_film::Base::Exact { eta, kappa }))
    }

    /// `f · |cos θi|` and the pdf.
    pub fn eval(&self, b: &mut Builder, wo: Value, wi: Value) -> Eval {
        self.with(b, |b, m| m.eval(b, wo, wi))
    }

    /// A sampled direction.
    pub fn sample(&self, b: &mut Builder, wo: Value, u: Value) -> Sample {
        self.with(b, |b, m| m.sample(b, wo, u))
    }

    /// The directional albedo (color): the table for `R`, `tint` for `T`/`RT`.
    pub fn albedo(&self, b: &mut Builder, wo: Value) -> Value {
        if self.mode != ScatterMode::R {
            return self.tint;
        }
        let alpha = Alpha::new(b, self.roughness);
        let etap = etap(b, self.ior, self.inside);
        let one = f(b, 1.0);
        let w = gray(b, one);
        let co = super::math::comp(b, wo, 2);
        let zero = f(b, 0.0);
        let up = super::math::gt(b, co, zero);
        let co = b.max(co, zero);
        let avg = alpha.average(b);
        let e = b.call(Intrinsic::DielectricAlbedo, &[co, avg, etap]);
        let e = b.select(up, e, zero);
        let e = gray(b, e);
        // The table is for a viewer outside (`η ≥ 1`); inside, it reads the node of `1/η`
        // and misses total internal reflection. A near-mirror lobe's albedo is the exact
        // Fresnel at `wo` times the white albedo; rough lobes average the Fresnel over
        // tilted microfacets, so that bound fades out linearly by α = 0.25. (Outside it is
        // below the table's value up to the table's error.)
        let white = ggx::albedo_f0_f90(b, alpha, wo, w, w);
        let fr = fresnel(b, co, etap);
        let k = f(b, 4.0);
        let fade = b.mul(avg, k);
        let fade = b.sub(one, fade);
        let fade = b.max(fade, zero);
        let fr = b.mul(fr, fade);
        let exact = super::math::scale(b, white, fr);
        let e = b.max(e, exact);
        let film = self.film(b);
        let e = match &film {
            None => e,
            Some((tf, outside, base)) => thin_film::albedo_or_plain(
                b,
                alpha,
                wo,
                Some((tf, *outside)),
                base,
                &|b, c| {
                    let x = fresnel(b, c, etap);
                    gray(b, x)
                },
                e,
            ),
        };
        b.mul(self.tint, e)
    }
}
