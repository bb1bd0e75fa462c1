//! Thin-film interference on a specular interface (MaterialX 1.39's `thinfilm_thickness`,
//! `thinfilm_ior` on `dielectric_bsdf`, `conductor_bsdf` and `generalized_schlick_bsdf`):
//! the Fresnel reflectance of a film over the lobe's own interface, after Belcour and Barla,
//! "A Practical Extension to Microfacet Theory for the Modeling of Varying Iridescence"
//! (SIGGRAPH 2017), in the form MaterialX's shader generators use. It owns the Airy
//! summation, the polarized Fresnel terms and phases it needs, and the spectral
//! sensitivity fit; the lobes own their base Fresnel and choose when a film applies.
//!
//! Three media: outside (index `η1`), the film (`η2`, thickness `d` in nanometres), the
//! base (`η3 + iκ3` per channel). With `c = cos θ1` and `cos θ2 = √(1 − (1 − c²)(η1/η2)²)`:
//! - `R12` per polarization (p, s) from the exact dielectric formula at the first interface
//!   (1 where the film totally reflects), `T121 = 1 − R12`; `R23` per polarization and
//!   channel at `cos θ2`: the exact conductor formula with `(η3 + iκ3)/η2` for dielectric
//!   and conductor bases (κ3 = 0 for a dielectric), the generalized Schlick value itself
//!   for a Schlick base (both polarizations);
//! - phases: `φ21 = (c < cos θB ? 0 : π, π)` with Brewster's `cos θB = η1/√(η1² + η2²)`;
//!   `φ23` the conductor phase shifts at `cos θ2` (Belcour and Barla's appendix), or π
//!   per channel where the Schlick base's index `(1 + √F0)/(1 − √F0)` (F0 clamped to [0.01,
//!   0.99]) is below `η2`;
//! - per polarization, the incoherent part `R12 + T121² R23/(1 − R12 R23)` plus the
//!   first two orders `m = 1, 2` of the coherent sum: `C_m = (R_dc − T121) r123^m`,
//!   `r123 = √(R12 R23)`, times `2 S(m·OPD, m(φ23 + φ21))` with the optical path
//!   difference `OPD = 2 η2 d cos θ2` and `S` the Gaussian fit of the CIE 1931 XYZ
//!   sensitivities (Belcour and Barla's values, normalized by 1.0685e-7);
//! - the mean of the two polarizations: the incoherent part as it is (per RGB channel),
//!   the coherent part from XYZ to CIE RGB for an equal-energy white (an XYZ of (1, 1, 1)
//!   is RGB 1); the sum clamped to [0, 1].
//!
//! **Where we differ from MaterialX's GLSL, and why.** (1) For a Schlick base MaterialX
//! sets each polarization's `R23` to half the Schlick value, so a film whose index equals
//! the outside's (no film at all) halves the base's reflectance; we give each polarization
//! the whole value, so that film returns the base's Fresnel exactly (a test holds this).
//! (2) MaterialX converts the whole sum from XYZ to RGB, the incoherent part too, although
//! that part is made of the base's RGB reflectances: a colored base (gold) under a film of
//! the outside's index comes back with another hue (gold's (0.9, 0.6, 0.2)-like `F` as
//! (1, 0.41, 0.20)); we convert only the coherent part, which is computed against the XYZ
//! sensitivities, so a vanishing film returns the base's own color (for a gray base, as every
//! dielectric is, the two agree to 1e-7). (3) The outside index `η1` is a parameter, not 1: a viewer inside a dielectric sees the
//! film from the base's side (`η1 = ior`, `η3 = 1`); total internal reflection then gives
//! exactly 1 through the same sum (`R23 = 1` makes every coherent term vanish). The film's
//! index is clamped to ≥ 1, as MaterialX clamps it to ≥ η1 = 1.

use super::math::{f, f0_to_ior, gray, one_minus, safe_sqrt, saturate, scale, sq};
use crate::ir::{BinOp, Builder, UnOp, Value};
use crate::types::Type;
use std::f64::consts::PI;

/// What lies under the film.
#[derive(Clone, Copy, Debug)]
pub enum Base {
    /// A dielectric or conductor of index `eta` (color) and extinction `kappa` (color;
    /// zero for a dielectric).
    Exact {
        /// Index `η3` per channel.
        eta: Value,
        /// Extinction `κ3` per channel.
        kappa: Value,
    },
    /// A generalized Schlick interface: `fresnel(cos)` gives its reflectance (color) and
    /// `f0` (color, ≥ 0) its normal-incidence reflectance, which fixes its index.
    Schlick {
        /// Reflectance at normal incidence (color).
        f0: Value,
    },
}

/// A film over a base, as one lobe's Fresnel sees it.
#[derive(Clone, Copy, Debug)]
pub struct Film {
    /// Thickness in nanometres (float).
    pub thickness: Value,
    /// The film's index (float), clamped to ≥ 1.
    pub ior: Value,
    /// The index of the medium the viewer is in (float).
    pub outside: Value,
}

/// The Gaussian fits of the XYZ sensitivities: `(amplitude · √(2π var) / 1.0685e-7,
/// position, variance)` per channel; X has a second lobe ([`X_EXTRA`]).
const SENS: [(f64, f64, f64); 3] = [
    (5.4856e-13, 1.6810e+06, 4.3278e+09),
    (4.4201e-13, 1.7953e+06, 9.3046e+09),
    (5.2481e-13, 2.2084e+06, 6.6121e+09),
];

/// The second Gaussian of the X sensitivity: (amplitude, position, variance).
const X_EXTRA: (f64, f64, f64) = (9.7470e-14, 2.2399e+06, 4.5282e+09);

/// The normalization of [`SENS`].
const SENS_NORM: f64 = 1.0685e-7;

/// XYZ to CIE 1931 RGB (equal-energy white), rows.
const XYZ_TO_RGB: [[f64; 3]; 3] = [
    [2.3706743, -0.9000405, -0.4706338],
    [-0.5138850, 1.4253036, 0.0885814],
    [0.0052982, -0.0146949, 1.0093968],
];

/// Orders of the coherent sum (MaterialX's `AIRY_FRESNEL_ITERATIONS`).
const ORDERS: u32 = 2;

/// The exact Fresnel reflectances `(Rp, Rs)` at `c` (float, clamped to [0, 1]) for a
/// relative complex index `n + ik` (colors; `k = 0` for a dielectric, where total internal
/// reflection gives 1): Lagarde's form, the same operations as the conductor lobe's.
pub fn polarized(b: &mut Builder, c: Value, n: Value, k: Value) -> (Value, Value) {
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
    let zero = b.zero(Type::Color);
    let a = b.max(a, zero);
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
    (rp, rs)
}

/// The phase shifts `(φp, φs)` (colors) of reflection at `c = cos θ` (float) from a medium
/// of index `eta1` (float) off a base `eta2 + i kappa2` (colors): Belcour and Barla's
/// appendix, as MaterialX writes it.
fn conductor_phase(
    b: &mut Builder,
    c: Value,
    eta1: Value,
    eta2: Value,
    kappa2: Value,
) -> (Value, Value) {
    let one = gray_f(b, 1.0);
    let k2 = b.div(kappa2, eta2);
    let kk = b.mul(k2, k2);
    let c2 = sq(b, c);
    let s2 = f(b, 1.0);
    let s2 = b.sub(s2, c2);
    let e2 = b.mul(eta2, eta2);
    let e1sq = sq(b, eta1);
    let omk = b.sub(one, kk);
    let a = b.mul(e2, omk);
    let es = b.mul(e1sq, s2);
    let es = gray(b, es);
    let a = b.sub(a, es);
    let two = f(b, 2.0);
    let ek = b.mul(e2, k2);
    let ek = scale(b, ek, two);
    let ek = b.mul(ek, ek);
    let bb = b.mul(a, a);
    let bb = b.add(bb, ek);
    let bb = b.unary(UnOp::Sqrt, bb);
    let half = f(b, 0.5);
    let apb = b.add(a, bb);
    let apb = scale(b, apb, half);
    let u = safe_sqrt_color(b, apb);
    let bma = b.sub(bb, a);
    let bma = scale(b, bma, half);
    let v = safe_sqrt_color(b, bma);
    let uv = {
        let u2 = b.mul(u, u);
        let v2 = b.mul(v, v);
        b.add(u2, v2)
    };
    // φs = atan2(2 η1 V c, U² + V² − (η1 c)²)
    let e1c = b.mul(eta1, c);
    let two_e1c = b.mul(two, e1c);
    let ys = scale(b, v, two_e1c);
    let e1c2 = sq(b, e1c);
    let e1c2 = gray(b, e1c2);
    let xs = b.sub(uv, e1c2);
    let phi_s = b.binary(BinOp::Atan2, ys, xs);
    // φp = atan2(2 η1 η2² c (2 k2 U − (1 − k2²) V), (η2² (1 + k2²) c)² − η1² (U² + V²))
    let k2u = b.mul(k2, u);
    let k2u = scale(b, k2u, two);
    let omkv = b.mul(omk, v);
    let inner = b.sub(k2u, omkv);
    let yp = b.mul(e2, inner);
    let yp = scale(b, yp, two_e1c);
    let opk = b.add(one, kk);
    let xp = b.mul(e2, opk);
    let xp = scale(b, xp, c);
    let xp = b.mul(xp, xp);
    let e1uv = scale(b, uv, e1sq);
    let xp = b.sub(xp, e1uv);
    let phi_p = b.binary(BinOp::Atan2, yp, xp);
    (phi_p, phi_s)
}

/// The spectral sensitivity fit `S(opd, shift)` (an XYZ color) for an optical path
/// difference `opd` (float, metres) and a phase `shift` per channel (color).
fn sensitivity(b: &mut Builder, opd: Value, shift: Value) -> Value {
    let tau = f(b, 2.0 * PI);
    let phase = b.mul(tau, opd);
    let phase2 = sq(b, phase);
    let amp = b.color(SENS.map(|(v, _, var)| v * (2.0 * PI * var).sqrt() / SENS_NORM));
    let pos = b.color(SENS.map(|(_, p, _)| p));
    let var = b.color(SENS.map(|(_, _, var)| -var));
    let arg = scale(b, pos, phase);
    let arg = b.add(arg, shift);
    let cos = b.unary(UnOp::Cos, arg);
    let e = scale(b, var, phase2);
    let e = b.unary(UnOp::Exp, e);
    let xyz = b.mul(amp, cos);
    let xyz = b.mul(xyz, e);
    // X's second lobe.
    let (xa, xp, xv) = X_EXTRA;
    let xa = f(b, xa * (2.0 * PI * xv).sqrt() / SENS_NORM);
    let xp = f(b, xp);
    let arg = b.mul(xp, phase);
    let sx = b.extract(shift, 0);
    let arg = b.add(arg, sx);
    let cos = b.unary(UnOp::Cos, arg);
    let nxv = f(b, -xv);
    let e = b.mul(nxv, phase2);
    let e = b.unary(UnOp::Exp, e);
    let extra = b.mul(xa, cos);
    let extra = b.mul(extra, e);
    let z = f(b, 0.0);
    let extra = b.construct(Type::Color, &[extra, z, z]);
    b.add(xyz, extra)
}

/// The film's reflectance (color, in [0, 1]) at `c = cos θ` (float, ≥ 0) in the outside
/// medium; `base_fresnel(cos)` is the base's own reflectance (color) at the film-side
/// cosine, used for a [`Base::Schlick`] base.
pub fn fresnel(
    b: &mut Builder,
    c: Value,
    film: &Film,
    base: &Base,
    base_fresnel: &dyn Fn(&mut Builder, Value) -> Value,
) -> Value {
    let one = f(b, 1.0);
    let eta1 = film.outside;
    let eta2 = b.max(film.ior, one);
    let c = saturate(b, c);
    // The film-side cosine; the film totally reflects where it has none.
    let c2 = sq(b, c);
    let s2 = b.sub(one, c2);
    let r = b.div(eta1, eta2);
    let r2 = sq(b, r);
    let st2 = b.mul(s2, r2);
    let ct2 = b.sub(one, st2);
    let zero = f(b, 0.0);
    let tir = b.binary(BinOp::Le, ct2, zero);
    let ct = safe_sqrt(b, ct2);
    let n12 = b.div(eta2, eta1);
    let n12 = gray(b, n12);
    let k0 = b.zero(Type::Color);
    let (r12p, r12s) = polarized(b, c, n12, k0);
    let white = gray(b, one);
    let r12p = b.select(tir, white, r12p);
    let r12s = b.select(tir, white, r12s);
    // Second interface and its phases.
    let (r23p, r23s, phi23p, phi23s) = match *base {
        Base::Exact { eta, kappa } => {
            let e2c = gray(b, eta2);
            let n = b.div(eta, e2c);
            let k = b.div(kappa, e2c);
            let (rp, rs) = polarized(b, ct, n, k);
            let (pp, ps) = conductor_phase(b, ct, eta2, eta, kappa);
            (rp, rs, pp, ps)
        }
        Base::Schlick { f0 } => {
            let fr = base_fresnel(b, ct);
            let phi = schlick_phase(b, f0, eta2);
            (fr, fr, phi, phi)
        }
    };
    // Brewster's angle at the first interface decides the p phase there.
    let e1sq = sq(b, eta1);
    let e2sq = sq(b, eta2);
    let hyp = b.add(e1sq, e2sq);
    let hyp = b.unary(UnOp::Sqrt, hyp);
    let cos_b = b.div(eta1, hyp);
    let below = b.binary(BinOp::Lt, c, cos_b);
    let pi = f(b, PI);
    let phi21p = b.select(below, zero, pi);
    let phi21s = pi;
    // Optical path difference, metres.
    let nm = f(b, 1e-9);
    let d = b.mul(film.thickness, nm);
    let two = f(b, 2.0);
    let opd = b.mul(two, eta2);
    let opd = b.mul(opd, ct);
    let opd = b.mul(opd, d);
    let (dc_p, osc_p) = airy_polarization(b, r12p, r23p, phi23p, phi21p, opd);
    let (dc_s, osc_s) = airy_polarization(b, r12s, r23s, phi23s, phi21s, opd);
    let half = f(b, 0.5);
    let dc = b.add(dc_p, dc_s);
    let dc = scale(b, dc, half);
    let osc = b.add(osc_p, osc_s);
    let osc = scale(b, osc, half);
    let osc = xyz_to_rgb(b, osc);
    let rgb = b.add(dc, osc);
    let black = b.zero(Type::Color);
    let rgb = b.max(rgb, black);
    b.min(rgb, white)
}

/// One polarization's sum: the incoherent part (per RGB channel) and [`ORDERS`] coherent
/// orders (XYZ).
fn airy_polarization(
    b: &mut Builder,
    r12: Value,
    r23: Value,
    phi23: Value,
    phi21: Value,
    opd: Value,
) -> (Value, Value) {
    let t121 = one_minus(b, r12);
    let tt = b.mul(t121, t121);
    let num = b.mul(tt, r23);
    let rr = b.mul(r12, r23);
    let den = one_minus(b, rr);
    let rdc = b.div(num, den);
    let dc = b.add(r12, rdc);
    let black = b.zero(Type::Color);
    let mut i = black;
    let rr = b.max(rr, black);
    let r123 = b.unary(UnOp::Sqrt, rr);
    let mut cm = b.sub(rdc, t121);
    let phi21 = gray(b, phi21);
    let shift = b.add(phi23, phi21);
    for m in 1..=ORDERS {
        cm = b.mul(cm, r123);
        let mf = f(b, m as f64);
        let mopd = b.mul(mf, opd);
        let mshift = scale(b, shift, mf);
        let s = sensitivity(b, mopd, mshift);
        let two = f(b, 2.0);
        let s = scale(b, s, two);
        let term = b.mul(cm, s);
        i = b.add(i, term);
    }
    (dc, i)
}

/// A Schlick base's phase per channel: π where its index `(1 + √F0)/(1 − √F0)` is below
/// the film's `eta2` (float), else 0.
fn schlick_phase(b: &mut Builder, f0: Value, eta2: Value) -> Value {
    let eta3 = f0_to_ior(b, f0);
    let (zero, pi) = (f(b, 0.0), f(b, PI));
    let ch: Vec<Value> = (0..3)
        .map(|i| {
            let e = b.extract(eta3, i);
            let lt = b.binary(BinOp::Lt, e, eta2);
            b.select(lt, pi, zero)
        })
        .collect();
    b.construct(Type::Color, &ch)
}

/// `M · xyz` with [`XYZ_TO_RGB`].
fn xyz_to_rgb(b: &mut Builder, xyz: Value) -> Value {
    let v = b.retype(Type::Vec3, xyz);
    let ch: Vec<Value> = XYZ_TO_RGB
        .iter()
        .map(|row| {
            let r = b.vec3(*row);
            b.dot(v, r)
        })
        .collect();
    b.construct(Type::Color, &ch)
}

/// A gray color constant.
fn gray_f(b: &mut Builder, x: f64) -> Value {
    b.color([x; 3])
}

/// `√max(x, 0)` per channel of a color.
fn safe_sqrt_color(b: &mut Builder, x: Value) -> Value {
    let zero = b.zero(Type::Color);
    let x = b.max(x, zero);
    b.unary(UnOp::Sqrt, x)
}

/// Directional albedo of a filmed GGX reflector (MaterialX's approximation): a blend, by
/// `√ᾱ`, of the film's reflectance at `wo` (the mirror limit) and the fit with `F0` the
/// film's reflectance at normal incidence and `F90 = 1`.
fn albedo(
    b: &mut Builder,
    alpha: super::ggx::Alpha,
    wo: Value,
    film_fresnel: &dyn Fn(&mut Builder, Value) -> Value,
) -> Value {
    let co = b.extract(wo, 2);
    let mirror = film_fresnel(b, co);
    let zero = f(b, 0.0);
    let up = b.binary(BinOp::Gt, co, zero);
    let black = b.zero(Type::Color);
    let mirror = b.select(up, mirror, black);
    let one = f(b, 1.0);
    let f0 = film_fresnel(b, one);
    let w = super::ggx::white(b);
    let rough = super::ggx::albedo_f0_f90(b, alpha, wo, f0, w);
    let avg = alpha.average(b);
    let t = safe_sqrt(b, avg);
    b.mix(mirror, rough, t)
}

/// The film of `tf` seen from a medium of index `outside`, and whether it is on (its
/// thickness > 0; bool).
fn film_on(b: &mut Builder, tf: &super::ThinFilm, outside: Value) -> (Film, Value) {
    let film = Film {
        thickness: tf.thickness,
        ior: tf.ior,
        outside,
    };
    let zero = f(b, 0.0);
    let on = b.binary(BinOp::Gt, tf.thickness, zero);
    (film, on)
}

/// A lobe's Fresnel with an optional film (`(film, outside index)`): `plain(c)` without one;
/// with one, the film's reflectance where its thickness is > 0 and `plain(c)` elsewhere (a
/// constant thickness folds the choice away).
pub fn or_plain(
    b: &mut Builder,
    c: Value,
    film: Option<(&super::ThinFilm, Value)>,
    base: &Base,
    plain: &dyn Fn(&mut Builder, Value) -> Value,
) -> Value {
    let p = plain(b, c);
    let Some((tf, outside)) = film else {
        return p;
    };
    let (film, on) = film_on(b, tf, outside);
    let filmed = fresnel(b, c, &film, base, plain);
    b.select(on, filmed, p)
}

/// A GGX reflector's directional albedo with an optional film, as [`or_plain`] chooses its
/// Fresnel: `plain` without one; with one, [`albedo`] of the filmed Fresnel where the
/// thickness is > 0. `plain_fresnel` is the base's own reflectance (a Schlick base's).
pub fn albedo_or_plain(
    b: &mut Builder,
    alpha: super::ggx::Alpha,
    wo: Value,
    film: Option<(&super::ThinFilm, Value)>,
    base: &Base,
    plain_fresnel: &dyn Fn(&mut Builder, Value) -> Value,
    plain: Value,
) -> Value {
    let Some((tf, outside)) = film else {
        return plain;
    };
    let (film, on) = film_on(b, tf, outside);
    let filmed = albedo(b, alpha, wo, &|b, c| {
        fresnel(b, c, &film, base, plain_fresnel)
    });
    b.select(on, filmed, plain)
}
