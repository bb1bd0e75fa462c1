//! The value atoms of MaterialX's pbrlib (no closures): the roughness parameterizations,
//! the artistic conductor IOR and the blackbody color, each the formula of the MaterialX
//! 1.39 reference implementation written with existing IR ops.
//!
//! This module owns those formulas; it must not build lobes (the closure atoms do).

use crate::closure::math::{f, gt, lt, one_minus, safe_sqrt};
use crate::ir::{BinOp, Builder, UnOp, Value};
use crate::nodes::{LowVal, NodeInputs};
use crate::types::Type;

type Out = Result<Vec<LowVal>, String>;

/// Smallest squared roughness (MaterialX's `M_FLOAT_EPS`).
const EPS: f64 = 1e-8;

/// `clamp(r², ε, 1)`.
fn alpha(b: &mut Builder, r: Value) -> Value {
    let r2 = b.mul(r, r);
    let (lo, hi) = (f(b, EPS), f(b, 1.0));
    b.clamp(r2, lo, hi)
}

/// `roughness_anisotropy`: `α = clamp(roughness², ε, 1)`; for `anisotropy > 0`, with
/// `a = √(1 − clamp(anisotropy, 0, 0.98))`: `(min(α/a, 1), α·a)`, else `(α, α)`.
pub fn roughness_anisotropy(b: &mut Builder, inp: &NodeInputs) -> Out {
    let al = alpha(b, inp.get("roughness"));
    let an = inp.get("anisotropy");
    let (zero, top, one) = (f(b, 0.0), f(b, 0.98), f(b, 1.0));
    let c = b.clamp(an, zero, top);
    let c = one_minus(b, c);
    let aspect = safe_sqrt(b, c);
    let x = b.div(al, aspect);
    let x = b.min(x, one);
    let y = b.mul(al, aspect);
    let aniso = b.construct(Type::Vec2, &[x, y]);
    let iso = b.construct(Type::Vec2, &[al, al]);
    let has = gt(b, an, zero);
    Ok(vec![LowVal::plain(b.select(has, aniso, iso))])
}

/// `roughness_dual`: `y < 0` takes `x`; each squared and clamped to [ε, 1].
pub fn roughness_dual(b: &mut Builder, inp: &NodeInputs) -> Out {
    let r = inp.get("roughness");
    let (x, y) = (b.extract(r, 0), b.extract(r, 1));
    let zero = f(b, 0.0);
    let neg = lt(b, y, zero);
    let y = b.select(neg, x, y);
    let (ax, ay) = (alpha(b, x), alpha(b, y));
    Ok(vec![LowVal::plain(b.construct(Type::Vec2, &[ax, ay]))])
}

/// `artistic_ior` (Gulbrandsen 2014): `r = clamp(reflectivity, 0, 0.99)`,
/// `n = mix((1 + √r)/(1 − √r), (1 − r)/(1 + r), edge_color)`,
/// `k = √max(((n + 1)² r − (n − 1)²)/(1 − r), 0)`; outputs `ior = n`, `extinction = k`.
pub fn artistic_ior(b: &mut Builder, inp: &NodeInputs) -> Out {
    let refl = inp.get("reflectivity");
    let edge = inp.get("edge_color");
    let k = f(b, 0.99);
    let (lo, hi) = (b.zero(Type::Color), b.splat_to(Type::Color, k));
    let r = b.clamp(refl, lo, hi);
    let one = f(b, 1.0);
    let one = b.splat_to(Type::Color, one);
    let rs = b.unary(UnOp::Sqrt, r);
    let n_min = {
        let a = b.sub(one, r);
        let c = b.add(one, r);
        b.div(a, c)
    };
    let n_max = {
        let a = b.add(one, rs);
        let c = b.sub(one, rs);
        b.div(a, c)
    };
    let n = b.mix(n_max, n_min, edge);
    let np1 = b.add(n, one);
    let nm1 = b.sub(n, one);
    let a = b.mul(np1, np1);
    let a = b.mul(a, r);
    let c = b.mul(nm1, nm1);
    let k2 = b.sub(a, c);
    let d = b.sub(one, r);
    let k2 = b.div(k2, d);
    let k2 = b.max(k2, lo);
    let k = b.unary(UnOp::Sqrt, k2);
    Ok(vec![LowVal::plain(n), LowVal::plain(k)])
}

/// `c3 t³ + c2 t² + c1 t + c0`.
fn cubic(b: &mut Builder, t: Value, c: [f64; 4]) -> Value {
    let mut acc = f(b, c[0]);
    for k in &c[1..] {
        acc = b.mul(acc, t);
        let kk = f(b, *k);
        acc = b.add(acc, kk);
    }
    acc
}

/// `blackbody`: the Planckian locus chromaticity (Kang et al. 2002 cubic fits) at
/// `clamp(temperature, 800, 25000)` K turned into Rec. 709 with luminance `Y = 1`, negative
/// channels clamped to 0; white where the fit's `y ≤ 0`.
pub fn blackbody(b: &mut Builder, inp: &NodeInputs) -> Out {
    let temp = inp.get("temperature");
    let (lo, hi) = (f(b, 800.0), f(b, 25000.0));
    let tk = b.clamp(temp, lo, hi);
    let k1000 = f(b, 1000.0);
    let t = b.div(k1000, tk);
    let (k2222, k4000) = (f(b, 2222.0), f(b, 4000.0));
    let cool = lt(b, tk, k4000);
    let xa = cubic(b, t, [-0.2661239, -0.2343580, 0.8776956, 0.179910]);
    let xb = cubic(b, t, [-3.0258469, 2.1070379, 0.2226347, 0.240390]);
    let xc = b.select(cool, xa, xb);
    let ya = cubic(b, xc, [-1.1063814, -1.34811020, 2.18555832, -0.20219683]);
    let yb = cubic(b, xc, [-0.9549476, -1.37418593, 2.09137015, -0.16748867]);
    let yc3 = cubic(b, xc, [3.0817580, -5.87338670, 3.75112997, -0.37001483]);
    let very = lt(b, tk, k2222);
    let y_warm = b.select(very, ya, yb);
    let yc = b.select(cool, y_warm, yc3);
    let one = f(b, 1.0);
    let xx = b.div(xc, yc);
    let zz = b.sub(one, xc);
    let zz = b.sub(zz, yc);
    let zz = b.div(zz, yc);
    let rows = [
        [3.2406, -1.5372, -0.4986],
        [-0.9689, 1.8758, 0.0415],
        [0.0557, -0.2040, 1.0570],
    ];
    let rgb: Vec<Value> = rows
        .iter()
        .map(|r| {
            let a = f(b, r[0]);
            let a = b.mul(a, xx);
            let c = f(b, r[1]);
            let a = b.add(a, c);
            let d = f(b, r[2]);
            let d = b.mul(d, zz);
            let s = b.add(a, d);
            let zero = f(b, 0.0);
            b.max(s, zero)
        })
        .collect();
    let c = b.construct(Type::Color, &rgb);
    let zero = f(b, 0.0);
    let ok = b.binary(BinOp::Gt, yc, zero);
    let white = b.splat_to(Type::Color, one);
    Ok(vec![LowVal::plain(b.select(ok, c, white))])
}
