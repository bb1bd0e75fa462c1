//! OSL builtins that `stdosl.h` defines in OSL itself or the specification adds to C's
//! math, lowered to IR arithmetic in the header's order of operations: `smooth_linearstep`
//! (a linear ramp with quadratic corners of half-width `eps`; a step where the edges
//! coincide), `select(a, b, cond)` (`cond ? b : a`, per component for a triple condition)
//! and `hypot(x, y, z)`; the geometric ones are [`super::geometry`]'s. Owns these builtins'
//! formulas.

use super::components::componentwise_n;
use super::{Ty, Val, nonzero};
use shadenet_graph::Type;
use shadenet_graph::ir::{BinOp, Builder, UnOp, Value};

/// The builtin `name` of the numeric arguments `vs` (value, type, varying), if it is one
/// of this module's and they fit.
pub(crate) fn builtin(b: &mut Builder, name: &str, vs: &[(Value, Ty, bool)]) -> Option<Val> {
    let varying = vs.iter().any(|v| v.2);
    let out = |v: Value, ty: Ty| Some(Val::V { v, ty, varying });
    match (name, vs) {
        ("hypot", [(x, Ty::Float, _), (y, Ty::Float, _), (z, Ty::Float, _)]) => {
            let v = b.construct(Type::Vec3, &[*x, *y, *z]);
            out(b.unary(UnOp::Length, v), Ty::Float)
        }
        ("smooth_linearstep", [(e0, t0, _), (e1, t1, _), (x, tx, _), (eps, te, _)])
            if [*t1, *tx, *te].iter().all(|t| t == t0) && (*t0 == Ty::Float || t0.is_triple()) =>
        {
            let v = componentwise_n(b, &[*e0, *e1, *x, *eps], *t0, |b, a| {
                smooth_linearstep(b, [a[0], a[1], a[2], a[3]])
            });
            out(v, *t0)
        }
        ("select", [(a, ta, _), (bb, tb, _), (c, tc, _)]) => {
            let (a, bb, t) = super::same(b, (*a, *ta), (*bb, *tb))?;
            if t == Ty::Matrix {
                return None;
            }
            let v = if tc.is_triple() && t.is_triple() {
                componentwise_n(b, &[a, bb, *c], t, |b, v| {
                    let on = nonzero(b, v[2], Ty::Float);
                    b.select(on, v[1], v[0])
                })
            } else if matches!(tc, Ty::Float | Ty::Int | Ty::Bool) {
                let on = nonzero(b, *c, *tc);
                b.select(on, bb, a)
            } else {
                return None;
            };
            out(v, t)
        }
        _ => super::geometry::builtin(b, name, vs),
    }
}

/// stdosl.h's `smooth_linearstep(edge0, edge1, x, eps)` on floats.
fn smooth_linearstep(b: &mut Builder, [e0, e1, x_, eps_]: [Value; 4]) -> Value {
    let (zero, one, half, two) = (b.float(0.0), b.float(1.0), b.float(0.5), b.float(2.0));
    let w = b.sub(e1, e0);
    let width_inv = b.div(one, w);
    let eps = b.mul(eps_, width_inv);
    let d = b.sub(x_, e0);
    let x = b.mul(d, width_inv);
    // rampup(x, r) = 0.5 / r · x · x, with r = 2·eps.
    let r = b.mul(two, eps);
    let k = b.div(half, r);
    let rampup = |b: &mut Builder, x: Value| {
        let kx = b.mul(k, x);
        b.mul(kx, x)
    };
    let xe = b.add(x, eps);
    let low = rampup(b, xe);
    let top = b.add(one, eps);
    let from_top = b.sub(top, x);
    let ramp_hi = rampup(b, from_top);
    let high = b.sub(one, ramp_hi);
    // The header's if-chain, last case first.
    let below_eps = b.binary(BinOp::Lt, x, eps);
    let mut r = b.select(below_eps, low, high);
    let past = b.binary(BinOp::Ge, x, top);
    r = b.select(past, one, r);
    let ge_eps = b.binary(BinOp::Ge, x, eps);
    let one_minus = b.sub(one, eps);
    let le_hi = b.binary(BinOp::Le, x, one_minus);
    let middle = b.binary(BinOp::And, ge_eps, le_hi);
    r = b.select(middle, x, r);
    let neg_eps = b.unary(UnOp::Neg, eps);
    let before = b.binary(BinOp::Le, x, neg_eps);
    r = b.select(before, zero, r);
    // Coinciding edges: step(edge0, x).
    let same = b.binary(BinOp::Eq, e0, e1);
    let lt = b.binary(BinOp::Lt, x_, e0);
    let step = b.select(lt, zero, one);
    b.select(same, step, r)
}
