//! stdosl.h's geometric functions written in OSL itself, lowered to IR arithmetic in the
//! header's order of operations: `distance(a, b, q)` (from `q` to the segment `ab`),
//! `rotate(p, angle, axis)` and `rotate(p, angle, a, b)` (about the line through `a` and
//! `b`, right-handed), and `fresnel(I, N, eta, Kr, Kt [, R, T])` (the dielectric Fresnel
//! factors of RenderMan's and OSL's headers, with the reflected and refracted directions).
//! Owns these formulas and `reflect` and `refract`, which the builtins of both dialects
//! call.

use super::{Lower, Ty, Val};
use crate::ast::Expr;
use crate::source::Span;
use shadenet_graph::Type;
use shadenet_graph::ir::{BinOp, Builder, UnOp, Value};

/// `distance(a, b, q)` or `rotate(…)` on the numeric arguments `vs`, if they fit.
pub(crate) fn builtin(b: &mut Builder, name: &str, vs: &[(Value, Ty, bool)]) -> Option<Val> {
    let varying = vs.iter().any(|v| v.2);
    let geo = |t: &Ty| t.is_geometric();
    match (name, vs) {
        ("distance", [(a, ta, _), (bb, tb, _), (q, tq, _)]) if geo(ta) && geo(tb) && geo(tq) => {
            Some(Val::V {
                v: segment_distance(b, *a, *bb, *q),
                ty: Ty::Float,
                varying,
            })
        }
        ("rotate", [(p, tp, _), (angle, Ty::Float, _), (axis, ta, _)]) if geo(tp) && geo(ta) => {
            let origin = b.zero(Type::Vec3);
            Some(Val::V {
                v: rotate(b, *p, *angle, origin, *axis),
                ty: Ty::Point,
                varying,
            })
        }
        ("rotate", [(p, tp, _), (angle, Ty::Float, _), (a, ta, _), (bb, tb, _)])
            if geo(tp) && geo(ta) && geo(tb) =>
        {
            Some(Val::V {
                v: rotate(b, *p, *angle, *a, *bb),
                ty: Ty::Point,
                varying,
            })
        }
        _ => None,
    }
}

/// stdosl.h's `distance(a, b, q)`: `t = (q − a)·d / d·d` with `d = b − a`, clamped to
/// [0, 1], then `|q − (a + t d)|`. A degenerate segment (`d·d = 0`) is the point `a`: the
/// header's `if` is not needed, as the IR's division by 0 gives 0, so `t = 0`.
fn segment_distance(b: &mut Builder, a: Value, bb: Value, q: Value) -> Value {
    let d = b.sub(bb, a);
    let dd = b.dot(d, d);
    let qa = b.sub(q, a);
    let num = b.dot(qa, d);
    let t = b.div(num, dd);
    let (zero, one) = (b.float(0.0), b.float(1.0));
    let t = b.max(t, zero);
    let t = b.min(t, one);
    let ts = b.splat(Type::Vec3, t);
    let td = b.mul(ts, d);
    let closest = b.add(a, td);
    b.binary(BinOp::Distance, q, closest)
}

/// stdosl.h's `rotate(p, angle, a, b)`: the rotation matrix about the unit axis
/// `normalize(b − a)` applied to the vector `p − a` (OSL's row-vector `transform`, as
/// Imath's `multDirMatrix` sums it), plus `a`.
fn rotate(b: &mut Builder, p: Value, angle: Value, a: Value, bb: Value) -> Value {
    let d = b.sub(bb, a);
    let axis = b.normalize(d);
    let (sin, cos) = (b.unary(UnOp::Sin, angle), b.unary(UnOp::Cos, angle));
    let one = b.float(1.0);
    let cos1 = b.sub(one, cos);
    let [x, y, z] = [0, 1, 2].map(|k| b.extract(axis, k));
    // Diagonal: x² + (1 − x²) cos; off-diagonal: x y (1 − cos) ± z sin, …
    let diag = |b: &mut Builder, x: Value| {
        let xx = b.mul(x, x);
        let rest = b.sub(one, xx);
        let r = b.mul(rest, cos);
        b.add(xx, r)
    };
    let off = |b: &mut Builder, x: Value, y: Value, z: Value, plus: bool| {
        let xy = b.mul(x, y);
        let xyc = b.mul(xy, cos1);
        let zs = b.mul(z, sin);
        if plus { b.add(xyc, zs) } else { b.sub(xyc, zs) }
    };
    let m = [
        [diag(b, x), off(b, x, y, z, true), off(b, x, z, y, false)],
        [off(b, x, y, z, false), diag(b, y), off(b, y, z, x, true)],
        [off(b, x, z, y, true), off(b, y, z, x, false), diag(b, z)],
    ];
    let v = b.sub(p, a);
    let [vx, vy, vz] = [0, 1, 2].map(|k| b.extract(v, k));
    let cols: Vec<Value> = (0..3)
        .map(|j| {
            let s = b.mul(vx, m[0][j]);
            let t = b.mul(vy, m[1][j]);
            let s = b.add(s, t);
            let t = b.mul(vz, m[2][j]);
            b.add(s, t)
        })
        .collect();
    let r = b.construct(Type::Vec3, &cols);
    b.add(r, a)
}

impl<'a> Lower<'a> {
    /// `fresnel(I, N, eta, output Kr, output Kt [, output R, output T])`, stdosl.h's: with
    /// `c = |I·N|` and `g² = 1/eta² − 1 + c²`, `Kr = ½ (1 + F²) (β / (g + c))²` where `β = g −
    /// c` and `F = (c (g + c) − 1) / (c β + 1)`, `Kt = (1 − Kr) eta²`, `R = reflect(I, N)`,
    /// `T = refract(I, N, eta)`; under total internal reflection (`g² < 0`) `Kr = 1`, `Kt =
    /// 0` and `T` the zero vector.
    pub(crate) fn fresnel(
        &mut self,
        b: &mut Builder,
        vals: &[(Val, Span)],
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let void = Self::void;
        let fits = super::numbers(b, &vals[..vals.len().min(3)]).filter(|vs| {
            matches!(vs.as_slice(), [(_, ti, _), (_, tn, _), (_, Ty::Float, _)]
                if ti.is_geometric() && tn.is_geometric())
        });
        let (Some(vs), 5 | 7) = (fits, vals.len()) else {
            self.error(
                "`fresnel` takes (vector I, normal N, float eta, output float Kr, output float Kt[, output vector R, output vector T])",
                span,
                "fresnel",
            );
            return void(b);
        };
        let varying = vs.iter().any(|v| v.2);
        let (i, n, eta) = (vs[0].0, vs[1].0, vs[2].0);
        let outs = fresnel_terms(b, i, n, eta);
        let tys = [Ty::Float, Ty::Float, Ty::Vector, Ty::Vector];
        for (k, (v, ty)) in outs.into_iter().zip(tys).enumerate().take(vals.len() - 3) {
            let val = Val::V { v, ty, varying };
            self.store_output_arg(b, &args[3 + k], val, (4 + k, "fresnel"));
        }
        void(b)
    }
}

/// `[Kr, Kt, R, T]` of [`Lower::fresnel`].
fn fresnel_terms(b: &mut Builder, i: Value, n: Value, eta: Value) -> [Value; 4] {
    let (zero, one, half) = (b.float(0.0), b.float(1.0), b.float(0.5));
    let c = b.dot(i, n);
    let neg = b.binary(BinOp::Lt, c, zero);
    let minus = b.unary(UnOp::Neg, c);
    let c = b.select(neg, minus, c);
    let r = reflect(b, i, n);
    let ee = b.mul(eta, eta);
    let inv = b.div(one, ee);
    let g2 = b.sub(inv, one);
    let cc = b.mul(c, c);
    let g2 = b.add(g2, cc);
    let g = b.unary(UnOp::Sqrt, g2);
    let beta = b.sub(g, c);
    let gc = b.add(g, c);
    let num = b.mul(c, gc);
    let num = b.sub(num, one);
    let den = b.mul(c, beta);
    let den = b.add(den, one);
    let f = b.div(num, den);
    let ff = b.mul(f, f);
    let f = b.add(one, ff);
    let f = b.mul(half, f);
    let q = b.div(beta, gc);
    let qq = b.mul(q, q);
    let kr = b.mul(f, qq);
    let kt = b.sub(one, kr);
    let kt = b.mul(kt, ee);
    let t = refract(b, i, n, eta);
    let ok = b.binary(BinOp::Ge, g2, zero);
    let z = b.zero(Type::Vec3);
    [
        b.select(ok, kr, one),
        b.select(ok, kt, zero),
        r,
        b.select(ok, t, z),
    ]
}

/// `reflect(I, N) = I − 2 (N·I) N`.
pub(crate) fn reflect(b: &mut Builder, i: Value, n: Value) -> Value {
    let d = b.dot(n, i);
    let two = b.float(2.0);
    let k = b.mul(two, d);
    let k = b.splat(Type::Vec3, k);
    let kn = b.mul(k, n);
    b.sub(i, kn)
}

/// `refract(I, N, eta)` (unit `I`, `N`): `eta I − (eta (N·I) + √k) N` with `k = 1 − eta²
/// (1 − (N·I)²)`; the zero vector under total internal reflection (`k < 0`).
pub(crate) fn refract(b: &mut Builder, i: Value, n: Value, eta: Value) -> Value {
    let d = b.dot(n, i);
    let one = b.float(1.0);
    let dd = b.mul(d, d);
    let s = b.sub(one, dd);
    let ee = b.mul(eta, eta);
    let es = b.mul(ee, s);
    let k = b.sub(one, es);
    let zero = b.float(0.0);
    let kc = b.max(k, zero);
    let sk = b.unary(UnOp::Sqrt, kc);
    let ed = b.mul(eta, d);
    let m = b.add(ed, sk);
    let ei = b.splat(Type::Vec3, eta);
    let ei = b.mul(ei, i);
    let mn = b.splat(Type::Vec3, m);
    let mn = b.mul(mn, n);
    let r = b.sub(ei, mn);
    let tir = b.binary(BinOp::Lt, k, zero);
    let z = b.zero(Type::Vec3);
    b.select(tir, z, r)
}
