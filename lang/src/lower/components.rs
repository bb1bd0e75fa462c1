//! Lowering a scalar operation on floats or, component by component, on triples: the
//! helpers OSL's per-component builtins (`sign`, `fmod`, `erf`, `smooth_linearstep`…) share.
//! It owns only the splitting and rebuilding; the operations are the callers'.

use super::Ty;
use shadenet_graph::ir::{Builder, Value};

/// `f` on each component of `x` (a float or a triple of type `t`).
pub(crate) fn componentwise(
    b: &mut Builder,
    x: Value,
    t: Ty,
    f: impl Fn(&mut Builder, Value) -> Value,
) -> Value {
    componentwise_n(b, &[x], t, |b, v| f(b, v[0]))
}

/// `f` on each pair of components of `x` and `y` (both of type `t`).
pub(crate) fn componentwise2(
    b: &mut Builder,
    x: Value,
    y: Value,
    t: Ty,
    f: impl Fn(&mut Builder, Value, Value) -> Value,
) -> Value {
    componentwise_n(b, &[x, y], t, |b, v| f(b, v[0], v[1]))
}

/// `f` on the operands `xs` (all of type `t`) where `t` is a float, else on each
/// component `k` of them, the results making a `t`.
pub(crate) fn componentwise_n(
    b: &mut Builder,
    xs: &[Value],
    t: Ty,
    f: impl Fn(&mut Builder, &[Value]) -> Value,
) -> Value {
    if t == Ty::Float {
        return f(b, xs);
    }
    let c: Vec<Value> = (0..3)
        .map(|k| {
            let xk: Vec<Value> = xs.iter().map(|x| b.extract(*x, k)).collect();
            f(b, &xk)
        })
        .collect();
    b.construct(t.ir(), &c)
}
