//! The GGX (Trowbridge–Reitz) anisotropic microfacet pieces the specular lobes share: the
//! roughness clamp, the distribution `D`, Smith masking `G1` and the height-correlated
//! `G2`, visible-normal sampling, the reflection/refraction geometry, the directional
//! albedo (a table of our own integration), and [`Microfacet`], a rough reflector/refractor parameterized by its
//! Fresnel function that the dielectric, conductor and generalized-Schlick lobes build on.
//! It owns no MaterialX node and no Fresnel formula (each lobe file brings its own).
//!
//! Conventions (local frame, `z` the shading normal towards the viewer):
//! - `α = clamp(roughness, ALPHA_MIN, 1)` per axis; MaterialX's `roughness` inputs are
//!   already `α` (its `roughness_anisotropy` squares them upstream).
//! - `D(h) = 1 / (π αx αy (hx²/αx² + hy²/αy² + hz²)²)` for `hz > 0`, else 0.
//! - With `L(w) = √(wz² + αx² wx² + αy² wy²)`: `Λ(w) = (L/|wz| − 1)/2`,
//!   `G1(w) = 2|wz| / (|wz| + L(w))` and the height-correlated
//!   `G2(wo, wi) = 1/(1 + Λ(wo) + Λ(wi)) = 2|co||ci| / (L(wo)|ci| + L(wi)|co|)`, written
//!   without a division by a cosine so grazing directions stay finite.
//! - Visible normals are drawn with Dupuy and Benyoub's spherical caps (2023), density
//!   `Dv(h) = G1(wo) D(h) max(0, wo·h) / wo.z`.
//! - Transmission follows Walter et al. 2007 with pbrt-v4's radiance convention: `etap` is
//!   the index of the far side over the viewer's side, the generalized half vector is
//!   `normalize(wo + etap wi)` turned to `+z`, and the transmitted `f` is divided by
//!   `etap²` (radiance, not importance, is transported: `L/η²` is what is conserved).

use super::math::{
    comp, div_pdf, f, gray, gt, lt, one_minus, pos, safe_sqrt, saturate, scale, sq, vec3,
};
use super::{Eval, Sample, ScatterMode};
use crate::ir::{BinOp, Builder, Intrinsic, UnOp, Value};
use crate::types::Type;
use std::f64::consts::PI;

/// The smallest `α` a GGX lobe uses. At `α = 1e-4` the peak of `D` is `1/(π α²) ≈ 3.2e7`
/// and `(hx/αx)²` of a horizontal half vector is `1e8`, whose square `1e16` is far from
/// `f32::MAX`, so every term stays finite in f32; the lobe is then a very sharp (but not
/// delta) mirror. Roughness 0 becomes this value; there is no delta special case.
pub const ALPHA_MIN: f64 = 1e-4;

/// The smallest `(wi·h + wo·h/etap)²` a refraction density divides by: at `etap = 1` the
/// transmitted direction is `−wo` whatever `h`, a delta the density can only approximate;
/// clamping keeps it finite (huge) while the sample weight stays exact.
const DENOM_MIN: f64 = 1e-12;

/// A GGX roughness pair (floats).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alpha {
    /// `αx`, along the frame's tangent.
    pub x: Value,
    /// `αy`, along the bitangent.
    pub y: Value,
}

impl Alpha {
    /// `clamp(roughness, ALPHA_MIN, 1)` per component of a vec2 `roughness` (NaN gives
    /// `ALPHA_MIN`).
    pub fn new(b: &mut Builder, roughness: Value) -> Alpha {
        let (lo, hi) = (f(b, ALPHA_MIN), f(b, 1.0));
        let rx = b.extract(roughness, 0);
        let ry = b.extract(roughness, 1);
        let x = b.max(rx, lo);
        let x = b.min(x, hi);
        let y = b.max(ry, lo);
        let y = b.min(y, hi);
        Alpha { x, y }
    }

    /// MaterialX's average roughness `√(αx αy)`, used by the albedo table (an approximation
    /// for anisotropic lobes: at normal incidence α = (0.2, 0.5) reflects 0.802 of white
    /// light, the isotropic α = 0.316 reflects 0.864).
    pub fn average(&self, b: &mut Builder) -> Value {
        let p = b.mul(self.x, self.y);
        b.unary(UnOp::Sqrt, p)
    }

    /// `(αx wx, αy wy, wz)`: `w` in the stretched (unit-roughness) configuration.
    fn stretch(&self, b: &mut Builder, w: Value) -> Value {
        let (x, y, z) = (comp(b, w, 0), comp(b, w, 1), comp(b, w, 2));
        let x = b.mul(x, self.x);
        let y = b.mul(y, self.y);
        vec3(b, x, y, z)
    }

    /// `L(w) = √(wz² + αx² wx² + αy² wy²)`.
    fn proj_len(&self, b: &mut Builder, w: Value) -> Value {
        let s = self.stretch(b, w);
        b.unary(UnOp::Length, s)
    }
}

/// The GGX distribution `D(h)` (0 for `h.z ≤ 0`).
pub fn d(b: &mut Builder, a: Alpha, h: Value) -> Value {
    let (hx, hy, hz) = (comp(b, h, 0), comp(b, h, 1), comp(b, h, 2));
    let ex = b.div(hx, a.x);
    let ey = b.div(hy, a.y);
    let (ex2, ey2, hz2) = (sq(b, ex), sq(b, ey), sq(b, hz));
    let s = b.add(ex2, ey2);
    let s = b.add(s, hz2);
    let s2 = sq(b, s);
    let axy = b.mul(a.x, a.y);
    let k = f(b, PI);
    let den = b.mul(axy, s2);
    let den = b.mul(den, k);
    let one = f(b, 1.0);
    let dv = b.div(one, den);
    let zero = f(b, 0.0);
    let up = gt(b, hz, zero);
    b.select(up, dv, zero)
}

/// Smith's `G1(w) = 2|wz| / (|wz| + L(w))`.
pub fn g1(b: &mut Builder, a: Alpha, w: Value) -> Value {
    let z = comp(b, w, 2);
    let z = b.unary(UnOp::Abs, z);
    let l = a.proj_len(b, w);
    let two = f(b, 2.0);
    let n = b.mul(two, z);
    let den = b.add(z, l);
    b.div(n, den)
}

/// The height-correlated `G2(wo, wi) = 2|co||ci| / (L(wo)|ci| + L(wi)|co|)`.
pub fn g2(b: &mut Builder, a: Alpha, wo: Value, wi: Value) -> Value {
    let co = comp(b, wo, 2);
    let co = b.unary(UnOp::Abs, co);
    let ci = comp(b, wi, 2);
    let ci = b.unary(UnOp::Abs, ci);
    let lo = a.proj_len(b, wo);
    let li = a.proj_len(b, wi);
    let two = f(b, 2.0);
    let n = b.mul(co, ci);
    let n = b.mul(two, n);
    let t1 = b.mul(lo, ci);
    let t2 = b.mul(li, co);
    let den = b.add(t1, t2);
    b.div(n, den)
}

/// A visible normal for `wo` (`wo.z ≥ 0`) from two uniform numbers: Dupuy and Benyoub's
/// spherical-cap sampling in the stretched configuration.
pub fn sample_vndf(b: &mut Builder, a: Alpha, wo: Value, u1: Value, u2: Value) -> Value {
    let v = a.stretch(b, wo);
    let v = b.normalize(v);
    let vz = comp(b, v, 2);
    let tau = f(b, 2.0 * PI);
    let phi = b.mul(tau, u1);
    let om = one_minus(b, u2);
    let one = f(b, 1.0);
    let opz = b.add(one, vz);
    let z = b.mul(om, opz);
    let z = b.sub(z, vz);
    let z2 = sq(b, z);
    let s2 = one_minus(b, z2);
    let s = safe_sqrt(b, s2);
    let (c, sn) = (b.unary(UnOp::Cos, phi), b.unary(UnOp::Sin, phi));
    let x = b.mul(s, c);
    let y = b.mul(s, sn);
    let cap = vec3(b, x, y, z);
    let h = b.add(cap, v);
    let (hx, hy, hz) = (comp(b, h, 0), comp(b, h, 1), comp(b, h, 2));
    let hx = b.mul(hx, a.x);
    let hy = b.mul(hy, a.y);
    let hz = pos(b, hz);
    let h = vec3(b, hx, hy, hz);
    b.normalize(h)
}

/// The density of [`sample_vndf`]'s normals, `Dv(h) = G1(wo) D(h) max(0, wo·h) / wo.z`
/// (0 for `wo.z ≤ 0`).
pub fn vndf_pdf(b: &mut Builder, a: Alpha, wo: Value, h: Value) -> Value {
    let g = g1(b, a, wo);
    let dh = d(b, a, h);
    let c = b.dot(wo, h);
    let c = pos(b, c);
    let co = comp(b, wo, 2);
    let p = b.mul(g, dh);
    let p = b.mul(p, c);
    let p = b.div(p, co);
    let zero = f(b, 0.0);
    let up = gt(b, co, zero);
    b.select(up, p, zero)
}

/// The mirror direction `2 (wo·h) h − wo`.
pub fn reflect(b: &mut Builder, wo: Value, h: Value) -> Value {
    let c = b.dot(wo, h);
    let two = f(b, 2.0);
    let c2 = b.mul(two, c);
    let hh = scale(b, h, c2);
    b.sub(hh, wo)
}

/// The refracted direction of `wo` through the microfacet `h` (`wo·h ≥ 0`) with
/// `etap` = far index / viewer index, and whether it exists (false under total internal
/// reflection): `wt = −wo/etap + (c/etap − √(1 − (1 − c²)/etap²)) h`, `c = wo·h`.
pub fn refract(b: &mut Builder, wo: Value, h: Value, etap: Value) -> (Value, Value) {
    let c = b.dot(wo, h);
    let c2 = sq(b, c);
    let s2 = one_minus(b, c2);
    let e2 = sq(b, etap);
    let st2 = b.div(s2, e2);
    let one = f(b, 1.0);
    let ok = lt(b, st2, one);
    let ct2 = one_minus(b, st2);
    let ct = safe_sqrt(b, ct2);
    let inv = b.div(one, etap);
    let a = b.unary(UnOp::Neg, inv);
    let t1 = scale(b, wo, a);
    let k = b.mul(c, inv);
    let k = b.sub(k, ct);
    let t2 = scale(b, h, k);
    let wt = b.add(t1, t2);
    let wt = b.normalize(wt);
    (wt, ok)
}

/// The GGX directional albedo `(A, B)`: a lobe with Schlick Fresnel `F0 + (F90 −
/// F0)(1 − wo·h)⁵` reflects `F0 A + F90 B` of the light from `wo` (`cos = wo.z`, `alpha`
/// the average roughness) — the IR intrinsic `ggx_albedo`, a table of our own numerical
/// integration ([`crate::ops::ggx_albedo`]; it replaced MaterialX's rational fit, which is
/// off by up to 0.11 at grazing views of smooth lobes).
pub fn dir_albedo(b: &mut Builder, cos: Value, alpha: Value) -> (Value, Value) {
    let ab = b.call(Intrinsic::GgxAlbedo, &[cos, alpha]);
    (b.extract(ab, 0), b.extract(ab, 1))
}

/// A Fresnel function: the reflectance (color) at `cos = wo·h` (≥ 0); it must give 1
/// where `etap` makes refraction impossible (total internal reflection).
pub type Fresnel<'a> = &'a dyn Fn(&mut Builder, Value) -> Value;

/// A rough GGX interface: reflection `tint F D G2 / (4 co)` and transmission
/// `tint (1 − F) D G2 |wi·h| |wo·h| / (co (wi·h + wo·h/etap)² etap²)` (both already times
/// `|cos θi|`), sampled by visible normals; `RT` reflects with probability `P` = the mean of
/// `F`'s channels (clamped to [0, 1]) using `u.z`.
pub struct Microfacet<'a> {
    /// The roughness.
    pub alpha: Alpha,
    /// Which sides scatter.
    pub mode: ScatterMode,
    /// Far-side index over viewer-side index (float; unused by `R`).
    pub etap: Value,
    /// The Fresnel reflectance.
    pub fresnel: Fresnel<'a>,
    /// A color factor on both sides.
    pub tint: Value,
}

impl Microfacet<'_> {
    fn has_r(&self) -> bool {
        self.mode != ScatterMode::T
    }

    fn has_t(&self) -> bool {
        self.mode != ScatterMode::R
    }

    /// The probability of choosing reflection given `F` (1 for `R`, 0 for `T`).
    fn p_reflect(&self, b: &mut Builder, fr: Value) -> Value {
        match self.mode {
            ScatterMode::R => f(b, 1.0),
            ScatterMode::T => f(b, 0.0),
            ScatterMode::RT => {
                let v = b.retype(Type::Vec3, fr);
                let third = b.vec3([1.0 / 3.0; 3]);
                let m = b.dot(v, third);
                saturate(b, m)
            }
        }
    }

    /// `tint F`.
    fn r_color(&self, b: &mut Builder, fr: Value) -> Value {
        b.mul(self.tint, fr)
    }

    /// `tint (1 − F) / etap²`.
    fn t_color(&self, b: &mut Builder, fr: Value) -> Value {
        let omf = one_minus(b, fr);
        let black = b.zero(Type::Color);
        let omf = b.max(omf, black);
        let c = b.mul(self.tint, omf);
        let e2 = sq(b, self.etap);
        let one = f(b, 1.0);
        let inv = b.div(one, e2);
        scale(b, c, inv)
    }

    /// `(f · |cos θi|, pdf)` of the interface.
    pub fn eval(&self, b: &mut Builder, wo: Value, wi: Value) -> Eval {
        let co = comp(b, wo, 2);
        let ci = comp(b, wi, 2);
        let zero = f(b, 0.0);
        let up_o = gt(b, co, zero);
        let mut value = b.zero(Type::Color);
        let mut pdf = zero;
        let g = g2(b, self.alpha, wo, wi);
        if self.has_r() {
            let h = b.add(wo, wi);
            let h = b.normalize(h);
            let c = b.dot(wo, h);
            let c = saturate(b, c);
            let fr = (self.fresnel)(b, c);
            let p = self.p_reflect(b, fr);
            let dh = d(b, self.alpha, h);
            let four = f(b, 4.0);
            let co4 = b.mul(four, co);
            let k = b.mul(dh, g);
            let k = b.div(k, co4);
            let col = self.r_color(b, fr);
            let v = scale(b, col, k);
            let g1o = g1(b, self.alpha, wo);
            let pr = b.mul(dh, g1o);
            let pr = b.div(pr, co4);
            let pr = b.mul(pr, p);
            let up_i = gt(b, ci, zero);
            let ok = b.binary(BinOp::And, up_o, up_i);
            let black = b.zero(Type::Color);
            value = b.select(ok, v, black);
            pdf = b.select(ok, pr, zero);
        }
        if self.has_t() {
            let (v, pt) = self.eval_t(b, wo, wi, g);
            value = b.add(value, v);
            pdf = b.add(pdf, pt);
        }
        Eval { value, pdf }
    }

    /// The transmitted part of [`Microfacet::eval`], given `G2(wo, wi)`.
    fn eval_t(&self, b: &mut Builder, wo: Value, wi: Value, g: Value) -> (Value, Value) {
        let co = comp(b, wo, 2);
        let ci = comp(b, wi, 2);
        let zero = f(b, 0.0);
        let ew = scale(b, wi, self.etap);
        let h = b.add(wo, ew);
        let h = b.normalize(h);
        let hz = comp(b, h, 2);
        let neg = lt(b, hz, zero);
        let hn = b.unary(UnOp::Neg, h);
        let h = b.select(neg, hn, h);
        let oh = b.dot(wo, h);
        let ih = b.dot(wi, h);
        let fr = (self.fresnel)(b, oh);
        let p = self.p_reflect(b, fr);
        let one = f(b, 1.0);
        let pt = b.sub(one, p);
        let dh = d(b, self.alpha, h);
        let den = b.div(oh, self.etap);
        let den = b.add(ih, den);
        let den = sq(b, den);
        let dmin = f(b, DENOM_MIN);
        let den = b.max(den, dmin);
        let aih = b.unary(UnOp::Abs, ih);
        let k = b.mul(dh, g);
        let k = b.mul(k, aih);
        let k = b.mul(k, oh);
        let cd = b.mul(co, den);
        let k = b.div(k, cd);
        let col = self.t_color(b, fr);
        let v = scale(b, col, k);
        let g1o = g1(b, self.alpha, wo);
        let dv = b.mul(g1o, dh);
        let dv = b.mul(dv, oh);
        let dv = b.div(dv, co);
        let pdf = b.mul(dv, aih);
        let pdf = b.div(pdf, den);
        let pdf = b.mul(pdf, pt);
        let up_o = gt(b, co, zero);
        let down_i = lt(b, ci, zero);
        let front = gt(b, oh, zero);
        let back = lt(b, ih, zero);
        let ok = b.binary(BinOp::And, up_o, down_i);
        let ok2 = b.binary(BinOp::And, front, back);
        let ok = b.binary(BinOp::And, ok, ok2);
        let black = b.zero(Type::Color);
        (b.select(ok, v, black), b.select(ok, pdf, zero))
    }

    /// A direction from a visible normal: reflected or refracted (by `u.z` in `RT`), its
    /// weight `tint F G2/G1(wo) / P` (reflection) or `tint (1 − F) G2/G1(wo) / ((1 − P)
    /// etap²)` (transmission) in closed form, and its density.
    pub fn sample(&self, b: &mut Builder, wo: Value, u: Value) -> Sample {
        let (u1, u2, u3) = (comp(b, u, 0), comp(b, u, 1), comp(b, u, 2));
        let a = self.alpha;
        let h = sample_vndf(b, a, wo, u1, u2);
        let c = b.dot(wo, h);
        let c = saturate(b, c);
        let fr = (self.fresnel)(b, c);
        let p = self.p_reflect(b, fr);
        let dv = vndf_pdf(b, a, wo, h);
        let g1o = g1(b, a, wo);
        let zero = f(b, 0.0);
        let one = f(b, 1.0);
        // Reflection.
        let wr = reflect(b, wo, h);
        let gr = g2(b, a, wo, wr);
        let kr = b.div(gr, g1o);
        let colr = self.r_color(b, fr);
        let wgt_r = scale(b, colr, kr);
        let wgt_r = div_pdf(b, wgt_r, p);
        let four = f(b, 4.0);
        let c4 = b.mul(four, c);
        let pdf_r = b.div(dv, c4);
        let pdf_r = b.mul(pdf_r, p);
        let wrz = comp(b, wr, 2);
        let ok_r = gt(b, wrz, zero);
        // Transmission.
        let (wt, tir_free) = refract(b, wo, h, self.etap);
        let gt_ = g2(b, a, wo, wt);
        let kt = b.div(gt_, g1o);
        let colt = self.t_color(b, fr);
        let wgt_t = scale(b, colt, kt);
        let pt = b.sub(one, p);
        let wgt_t = div_pdf(b, wgt_t, pt);
        let ih = b.dot(wt, h);
        let den = b.div(c, self.etap);
        let den = b.add(ih, den);
        let den = sq(b, den);
        let dmin = f(b, DENOM_MIN);
        let den = b.max(den, dmin);
        let aih = b.unary(UnOp::Abs, ih);
        let pdf_t = b.mul(dv, aih);
        let pdf_t = b.div(pdf_t, den);
        let pdf_t = b.mul(pdf_t, pt);
        let wtz = comp(b, wt, 2);
        let below = lt(b, wtz, zero);
        let ok_t = b.binary(BinOp::And, tir_free, below);
        let pick_r = match self.mode {
            ScatterMode::R => b.boolean(true),
            ScatterMode::T => b.boolean(false),
            ScatterMode::RT => lt(b, u3, p),
        };
        let wi = b.select(pick_r, wr, wt);
        let weight = b.select(pick_r, wgt_r, wgt_t);
        let pdf = b.select(pick_r, pdf_r, pdf_t);
        let ok = b.select(pick_r, ok_r, ok_t);
        let has = gt(b, pdf, zero);
        let ok = b.binary(BinOp::And, ok, has);
        let black = b.zero(Type::Color);
        let weight = b.select(ok, weight, black);
        let pdf = b.select(ok, pdf, zero);
        Sample { wi, weight, pdf }
    }
}

/// `(F0 A + F90 B)` of [`dir_albedo`] at `wo` (0 for `wo.z ≤ 0`), colors `f0`, `f90`.
pub fn albedo_f0_f90(b: &mut Builder, a: Alpha, wo: Value, f0: Value, f90: Value) -> Value {
    let co = comp(b, wo, 2);
    let avg = a.average(b);
    let (ea, eb) = dir_albedo(b, co, avg);
    let x = scale(b, f0, ea);
    let y = scale(b, f90, eb);
    let e = b.add(x, y);
    let zero = f(b, 0.0);
    let up = gt(b, co, zero);
    let black = b.zero(Type::Color);
    b.select(up, e, black)
}

/// A gray color.
pub fn white(b: &mut Builder) -> Value {
    let one = f(b, 1.0);
    gray(b, one)
}
