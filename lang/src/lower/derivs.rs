//! OSL's derivative builtins: `Dx`, `Dy`, `filterwidth`, `area`, `calculatenormal` and
//! `aastep` (stdosl.h's box-filtered step), on the IR's screen-space derivatives
//! ([`shadenet_graph::ir::Builder::derivs`]: the chain rule from the ray differentials,
//! a noise's or a lookup's change over the footprint). A value with no derivatives (a
//! constant, a parameter, or no ray differentials at run time) has zero. It owns these
//! builtins' formulas; it must not know how derivatives are built.

use super::{Ty, Val};
use shadenet_graph::ir::{BinOp, Builder, Stream, UnOp, Value};
use shadenet_graph::nodes::filtered::filter_width;

/// `[∂x/∂x_screen, ∂x/∂y_screen]`, zeros of `x`'s type where it has none.
fn both(b: &mut Builder, x: Value) -> [Value; 2] {
    match b.derivs(x) {
        Some(d) => d,
        None => {
            let ty = b.ty(x);
            [b.zero(ty), b.zero(ty)]
        }
    }
}

/// stdosl.h's `aastep(edge, s, dedge, ds)`: the share of `[s − w/2, s + w/2]`, `w =
/// |dedge| + |ds|`, at or above `edge`; the plain step where `w` is 0.
fn aastep(b: &mut Builder, edge: Value, s: Value, dedge: Value, ds: Value) -> Value {
    let (ae, as_) = (b.unary(UnOp::Abs, dedge), b.unary(UnOp::Abs, ds));
    let w = b.add(ae, as_);
    let half = b.float(0.5);
    let hw = b.mul(w, half);
    let e1 = b.sub(edge, hw);
    let e2 = b.add(edge, hw);
    let (zero, one) = (b.float(0.0), b.float(1.0));
    let d = b.sub(s, e1);
    let ramp = b.div(d, w);
    let above = b.binary(BinOp::Ge, s, e2);
    let r = b.select(above, one, ramp);
    let below = b.binary(BinOp::Le, s, e1);
    b.select(below, zero, r)
}

/// The derivative builtin `name` of the numeric arguments `vs`, if it is one and they fit.
pub(crate) fn builtin(b: &mut Builder, name: &str, vs: &[(Value, Ty, bool)]) -> Option<Val> {
    let varying = vs.iter().any(|v| v.2);
    let out = |v: Value, ty: Ty| Some(Val::V { v, ty, varying });
    let num = |t: Ty| t == Ty::Float || t.is_triple();
    match (name, vs) {
        ("Dx" | "Dy", [(x, t, _)]) if num(*t) => {
            let d = both(b, *x);
            out(d[usize::from(name == "Dy")], *t)
        }
        ("filterwidth", [(x, t, _)]) if num(*t) => out(filter_width(b, *x), *t),
        ("area", [(p, t, _)]) if t.is_geometric() => {
            let [dx, dy] = both(b, *p);
            let c = b.binary(BinOp::Cross, dx, dy);
            out(b.unary(UnOp::Length, c), Ty::Float)
        }
        ("calculatenormal", [(p, t, _)]) if t.is_geometric() => {
            // OSL: Dx(p) × Dy(p), or Dy(p) × Dx(p) where the renderer's screen axes are
            // left-handed on the surface ("flipHandedness": as OSL's testrender decides it,
            // the surface's own dP/dx × dP/dy facing away from N), so that an undisplaced
            // surface's calculatenormal(P) faces as N does. Not normalized.
            let [dx, dy] = both(b, *p);
            let (sx, sy, n) = (
                b.stream(Stream::DPdx),
                b.stream(Stream::DPdy),
                b.stream(Stream::N),
            );
            let surface = b.binary(BinOp::Cross, sx, sy);
            let facing = b.dot(surface, n);
            let zero = b.float(0.0);
            let flip = b.binary(BinOp::Lt, facing, zero);
            let right = b.binary(BinOp::Cross, dx, dy);
            let left = b.binary(BinOp::Cross, dy, dx);
            let v = b.select(flip, left, right);
            Some(Val::V {
                v,
                ty: Ty::Vector,
                varying: true,
            })
        }
        ("aastep", args)
            if (2..=4).contains(&args.len()) && args.iter().all(|a| a.1 == Ty::Float) =>
        {
            let (edge, s) = (args[0].0, args[1].0);
            let dedge = match args.len() {
                4 => args[2].0,
                _ => filter_width(b, edge),
            };
            let ds = match args.len() {
                2 => filter_width(b, s),
                _ => args[args.len() - 1].0,
            };
            out(aastep(b, edge, s, dedge, ds), Ty::Float)
        }
        _ => None,
    }
}
