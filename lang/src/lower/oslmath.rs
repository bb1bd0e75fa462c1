//! OSL's math builtins beyond C's that the IR has no op for, lowered to IR arithmetic on
//! floats and, per component, triples: `sinh`, `tanh` (from `expm1`), `cosh`, `expm1`
//! (Kahan's `(eˣ − 1)·x / ln eˣ`, accurate near 0), `cbrt` (`sign(x)·|x|^⅓`), `log(x, b)`
//! (`ln x / ln b`), `erf` (its Taylor series below |x| = ½, else `1 − erfc`) and `erfc`
//! (Numerical Recipes' Chebyshev fit, relative error below 1.2·10⁻⁷, for x ≥ ½; else
//! `1 − erf`) and `logb` (the exponent of `|x|` clamped to f32's normal range, exact: by
//! halving and doubling with powers of two). Owns these formulas; `sincos` (output
//! arguments) is the caller's.

use super::components::componentwise;
use super::{Ty, Val};
use shadenet_graph::ir::{BinOp, Builder, UnOp, Value};

/// The builtin `name` of the numeric arguments `vs`, if it is one of this module's and
/// they fit.
pub(crate) fn builtin(b: &mut Builder, name: &str, vs: &[(Value, Ty, bool)]) -> Option<Val> {
    let varying = vs.iter().any(|v| v.2);
    let num = |t: Ty| t == Ty::Float || t.is_triple();
    let f: fn(&mut Builder, Value) -> Value = match (name, vs) {
        ("log", [(x, tx, _), (base, Ty::Float, _)]) if num(*tx) => {
            let lb = b.unary(UnOp::Log, *base);
            let v = componentwise(b, *x, *tx, |b, x| {
                let lx = b.unary(UnOp::Log, x);
                b.div(lx, lb)
            });
            return Some(Val::V {
                v,
                ty: *tx,
                varying,
            });
        }
        ("sinh", [(_, t, _)]) if num(*t) => sinh,
        ("cosh", [(_, t, _)]) if num(*t) => cosh,
        ("tanh", [(_, t, _)]) if num(*t) => tanh,
        ("expm1", [(_, t, _)]) if num(*t) => expm1,
        ("cbrt", [(_, t, _)]) if num(*t) => cbrt,
        ("erf", [(_, t, _)]) if num(*t) => erf,
        ("erfc", [(_, t, _)]) if num(*t) => erfc,
        ("logb", [(_, t, _)]) if num(*t) => logb,
        _ => return None,
    };
    let (x, t, _) = vs[0];
    let v = componentwise(b, x, t, f);
    Some(Val::V { v, ty: t, varying })
}

/// `(eˣ, e⁻ˣ)`.
fn exps(b: &mut Builder, x: Value) -> (Value, Value) {
    let e = b.unary(UnOp::Exp, x);
    let nx = b.unary(UnOp::Neg, x);
    (e, b.unary(UnOp::Exp, nx))
}

/// `v` with the sign of `x` (`v ≥ 0`).
fn signed(b: &mut Builder, x: Value, v: Value) -> Value {
    let zero = b.float(0.0);
    let neg = b.binary(BinOp::Lt, x, zero);
    let nv = b.unary(UnOp::Neg, v);
    b.select(neg, nv, v)
}

/// `±(E + E/(E + 1))/2` with `E = expm1(|x|)` (no cancellation near 0), `±e^|x|/2` beyond
/// |x| = 20 (where `E/(E + 1)` would be ∞/∞).
fn sinh(b: &mut Builder, x: Value) -> Value {
    let ax = b.unary(UnOp::Abs, x);
    let e = expm1(b, ax);
    let one = b.float(1.0);
    let e1 = b.add(e, one);
    let q = b.div(e, e1);
    let s = b.add(e, q);
    let half = b.float(0.5);
    let s = b.mul(half, s);
    let big = b.unary(UnOp::Exp, ax);
    let big = b.mul(half, big);
    let lim = b.float(20.0);
    let far = b.binary(BinOp::Gt, ax, lim);
    let s = b.select(far, big, s);
    signed(b, x, s)
}

/// `(eˣ + e⁻ˣ) / 2`.
fn cosh(b: &mut Builder, x: Value) -> Value {
    let (e, ne) = exps(b, x);
    let s = b.add(e, ne);
    let half = b.float(0.5);
    b.mul(s, half)
}

/// `±E/(E + 2)` with `E = expm1(2|x|)` (no cancellation near 0), ±1 beyond |x| = 20
/// (within an ulp there).
fn tanh(b: &mut Builder, x: Value) -> Value {
    let ax = b.unary(UnOp::Abs, x);
    let two = b.float(2.0);
    let x2 = b.mul(two, ax);
    let e = expm1(b, x2);
    let e2 = b.add(e, two);
    let t = b.div(e, e2);
    let lim = b.float(20.0);
    let far = b.binary(BinOp::Gt, ax, lim);
    let one = b.float(1.0);
    let t = b.select(far, one, t);
    signed(b, x, t)
}

/// Kahan's `expm1`: `u = eˣ`; `x` where `u = 1`, `−1` where `u − 1 = −1`, else
/// `(u − 1)·x / ln u`.
fn expm1(b: &mut Builder, x: Value) -> Value {
    let u = b.unary(UnOp::Exp, x);
    let one = b.float(1.0);
    let um1 = b.sub(u, one);
    let lu = b.unary(UnOp::Log, u);
    let p = b.mul(um1, x);
    let r = b.div(p, lu);
    let m1 = b.float(-1.0);
    let at_m1 = b.binary(BinOp::Eq, um1, m1);
    let r = b.select(at_m1, m1, r);
    let at_1 = b.binary(BinOp::Eq, u, one);
    // u = ∞ (x large): (u − 1)·x / ln u is ∞/∞; ln u equals u only there.
    let inf = b.binary(BinOp::Eq, u, lu);
    let r = b.select(inf, u, r);
    b.select(at_1, x, r)
}

/// `sign(x)·|x|^⅓`.
fn cbrt(b: &mut Builder, x: Value) -> Value {
    let ax = b.unary(UnOp::Abs, x);
    let third = b.float(1.0 / 3.0);
    let r = b.binary(BinOp::Pow, ax, third);
    signed(b, x, r)
}

/// `a` where `|x| < limit`, else `v`.
fn small(b: &mut Builder, x: Value, limit: f64, a: Value, v: Value) -> Value {
    let ax = b.unary(UnOp::Abs, x);
    let l = b.float(limit);
    let lt = b.binary(BinOp::Lt, ax, l);
    b.select(lt, a, v)
}

/// `erf(x)` by its Taylor series `2/√π · (x − x³/3 + x⁵/10 − x⁷/42 + x⁹/216 − x¹¹/1320)`
/// for `|x| < ½` (truncation below 2·10⁻⁸ relative), `±(1 − erfc(|x|))` beyond.
fn erf(b: &mut Builder, x: Value) -> Value {
    let x2 = b.mul(x, x);
    // Horner in x²: x · (1 + x²·(−1/3 + x²·(1/10 + x²·(−1/42 + x²·(1/216 − x²/1320))))).
    let coeffs = [
        -1.0 / 1320.0,
        1.0 / 216.0,
        -1.0 / 42.0,
        1.0 / 10.0,
        -1.0 / 3.0,
        1.0,
    ];
    let mut s = b.float(coeffs[0]);
    for c in &coeffs[1..] {
        let m = b.mul(s, x2);
        let c = b.float(*c);
        s = b.add(m, c);
    }
    let k = b.float(std::f64::consts::FRAC_2_SQRT_PI);
    let sx = b.mul(s, x);
    let series = b.mul(k, sx);
    let ax = b.unary(UnOp::Abs, x);
    let tail = erfc_fit(b, ax);
    let one = b.float(1.0);
    let pos = b.sub(one, tail);
    let far = signed(b, x, pos);
    small(b, x, 0.5, series, far)
}

/// `erfc(x)`: the fit for `x ≥ ½`, `1 − erf(x)` below.
fn erfc(b: &mut Builder, x: Value) -> Value {
    let fit = erfc_fit(b, x);
    let e = erf(b, x);
    let one = b.float(1.0);
    let near = b.sub(one, e);
    let half = b.float(0.5);
    let ge = b.binary(BinOp::Ge, x, half);
    b.select(ge, fit, near)
}

/// Numerical Recipes' `erfcc` for `z ≥ 0`: `t·exp(−z² + P(t))`, `t = 1/(1 + z/2)`.
fn erfc_fit(b: &mut Builder, z: Value) -> Value {
    const P: [f64; 10] = [
        -1.26551223,
        1.00002368,
        0.37409196,
        0.09678418,
        -0.18628806,
        0.27886807,
        -1.13520398,
        1.48851587,
        -0.82215223,
        0.17087277,
    ];
    let (one, half) = (b.float(1.0), b.float(0.5));
    let hz = b.mul(half, z);
    let d = b.add(one, hz);
    let t = b.div(one, d);
    let mut p = b.float(P[9]);
    for c in P[..9].iter().rev() {
        let m = b.mul(t, p);
        let c = b.float(*c);
        p = b.add(c, m);
    }
    let z2 = b.mul(z, z);
    let nz2 = b.unary(UnOp::Neg, z2);
    let a = b.add(nz2, p);
    let e = b.unary(UnOp::Exp, a);
    b.mul(t, e)
}

/// `logb(x)`: the binary exponent of `|x|` as a float, `⌊log₂ |x|⌋` exactly — found by
/// scaling with powers of two (exact products) rather than from a logarithm, which rounds
/// next to powers of two. `|x|` is first clamped to f32's normal range, as OpenImageIO's
/// `fast_logb` that OSL's runtime calls does: 0 and subnormals give −126, infinities 127,
/// in f32 and f64 alike.
fn logb(b: &mut Builder, x: Value) -> Value {
    let ax = b.unary(UnOp::Abs, x);
    let (lo, hi) = (
        b.float(f64::from(f32::MIN_POSITIVE)),
        b.float(f64::from(f32::MAX)),
    );
    let y = b.max(ax, lo);
    let mut y = b.min(y, hi);
    let mut e = b.float(0.0);
    // Down to [1, 2) from above: at most 127 halvings, in steps of 64, 32, …, 1.
    for k in [64, 32, 16, 8, 4, 2, 1] {
        let big = b.float(2f64.powi(k));
        let c = b.binary(BinOp::Ge, y, big);
        let scale = b.float(2f64.powi(-k));
        let scaled = b.mul(y, scale);
        y = b.select(c, scaled, y);
        let kf = b.float(f64::from(k));
        let up = b.add(e, kf);
        e = b.select(c, up, e);
    }
    // Up to [1, 2) from below: at most 126 doublings.
    for k in [64, 32, 16, 8, 4, 2, 1] {
        let small = b.float(2f64.powi(1 - k));
        let c = b.binary(BinOp::Lt, y, small);
        let scale = b.float(2f64.powi(k));
        let scaled = b.mul(y, scale);
        y = b.select(c, scaled, y);
        let kf = b.float(f64::from(k));
        let down = b.sub(e, kf);
        e = b.select(c, down, e);
    }
    e
}
