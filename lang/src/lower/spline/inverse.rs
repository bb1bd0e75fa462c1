//! OSL's `splineinverse(basis, y, knots…)`: the x in [0, 1] where `spline(basis, x, knots…)`
//! is `y`, by OSL's own search (`Spline::inverse` in `splineimpl.h`, `OIIO::invert` in
//! OpenImageIO's `fmath.h`), lowered to IR so every back end runs it:
//!
//! - `y` at or beyond the first or last knot the curve passes (the second and next-to-last
//!   for bases of step 1) is 0 or 1, in the direction of the knots (`knots[1] <
//!   knots[n − 2]`);
//! - otherwise each segment in turn, `[s/nsegs, (s+1)/nsegs]`, is searched if its ends
//!   bracket `y`: regula falsi (`t = (y − v0)/(v1 − v0)`, bisection where `t` leaves (0, 1))
//!   for 24 iterations, then bisection, at most 32 in all, until the interval or the value
//!   is within 10⁻⁶; the first bracketing segment's x is the result;
//! - no segment brackets `y` (a curve that is not monotonic): the last segment's edge on
//!   `y`'s side, as OSL returns.
//!
//! Each segment's search is one IR loop whose condition includes "this segment brackets
//! `y` and no earlier one did", so a fragment iterates in one segment only. Owns the
//! search; the spline's value is [`super::evaluate`].

use super::{Basis, evaluate};
use crate::lower::Ty;
use shadenet_graph::ir::{BinOp, Builder, UnOp, Value};

/// OSL's `Spline::inverse` of float knots `ks` at `y`.
pub(super) fn inverse(b: &mut Builder, basis: &'static Basis, y: Value, ks: &[Value]) -> Value {
    let (_, step, _) = *basis;
    let n = ks.len();
    let (lo, hi) = if step == 1 { (1, n - 2) } else { (0, n - 1) };
    let increasing = b.binary(BinOp::Lt, ks[1], ks[n - 2]);
    // Out of range: clamped to the knots the curve passes.
    let le_lo = b.binary(BinOp::Le, y, ks[lo]);
    let ge_lo = b.binary(BinOp::Ge, y, ks[lo]);
    let ge_hi = b.binary(BinOp::Ge, y, ks[hi]);
    let le_hi = b.binary(BinOp::Le, y, ks[hi]);
    let at0 = b.select(increasing, le_lo, ge_lo);
    let at1 = b.select(increasing, ge_hi, le_hi);
    // The search, segment by segment.
    let nsegs = (n - 4) / step + 1;
    let one = b.float(1.0);
    let count = b.float(nsegs as f64);
    let nseginv = b.div(one, count);
    let spline = |b: &mut Builder, x: Value| evaluate(b, basis, x, ks, Ty::Float);
    // Each segment's end is the next one's start: its value is evaluated once.
    let mut r0 = b.float(0.0);
    let mut v0 = spline(b, r0);
    let mut x = b.float(0.0);
    let mut found = b.boolean(false);
    for s in 0..nsegs {
        let next = b.float((s + 1) as f64);
        let r1 = b.mul(nseginv, next);
        let v1 = spline(b, r1);
        let (sx, bracketed) = invert(b, &spline, y, [(r0, v0), (r1, v1)], found);
        x = b.select(found, x, sx);
        found = b.binary(BinOp::Or, found, bracketed);
        (r0, v0) = (r1, v1);
    }
    let zero = b.float(0.0);
    let x = b.select(at1, one, x);
    b.select(at0, zero, x)
}

/// `OIIO::invert(S, y, xmin, xmax, 32, 1e-6, &brack)` given `S(xmin) = v0` and `S(xmax) =
/// v1`: the x and whether `[xmin, xmax]` brackets `y`; the loop runs only where it does
/// and `skip` is false.
fn invert(
    b: &mut Builder,
    spline: &dyn Fn(&mut Builder, Value) -> Value,
    y: Value,
    [(xmin, v0), (xmax, v1)]: [(Value, Value); 2],
    skip: Value,
) -> (Value, Value) {
    let eps = b.float(1.0e-6);
    let increasing = b.binary(BinOp::Lt, v0, v1);
    let vmin = b.select(increasing, v0, v1);
    let vmax = b.select(increasing, v1, v0);
    let ge = b.binary(BinOp::Ge, y, vmin);
    let le = b.binary(BinOp::Le, y, vmax);
    let bracketed = b.binary(BinOp::And, ge, le);
    // Not bracketed: the edge on y's side.
    let below = b.binary(BinOp::Lt, y, vmin);
    let above = b.unary(UnOp::Not, below);
    let low_side = b.select(increasing, below, above);
    let edge = b.select(low_side, xmin, xmax);
    // Already close enough: xmin.
    let d = b.sub(v0, v1);
    let d = b.unary(UnOp::Abs, d);
    let close = b.binary(BinOp::Lt, d, eps);
    let far = b.unary(UnOp::Not, close);
    let search = b.binary(BinOp::And, bracketed, far);
    let not_skip = b.unary(UnOp::Not, skip);
    let active = b.binary(BinOp::And, search, not_skip);
    let it = b.int(0);
    let init = [it, xmin, xmax, v0, v1, xmin, active];
    let out = b.loop_(
        &init,
        |b, s| {
            let limit = b.int(32);
            let more = b.binary(BinOp::Lt, s[0], limit);
            b.binary(BinOp::And, s[6], more)
        },
        |b, s| step(b, spline, y, increasing, s),
    );
    let x = out.get(5).copied().unwrap_or(xmin);
    (b.select(bracketed, x, edge), bracketed)
}

/// One iteration of `OIIO::invert` on the carried `[iters, xmin, xmax, v0, v1, x, active]`.
fn step(
    b: &mut Builder,
    spline: &dyn Fn(&mut Builder, Value) -> Value,
    y: Value,
    increasing: Value,
    s: &[Value],
) -> Vec<Value> {
    let [it, xmin, xmax, v0, v1] = [s[0], s[1], s[2], s[3], s[4]];
    let (zero, one, half) = (b.float(0.0), b.float(1.0), b.float(0.5));
    // Regula falsi for the first 3/4 of 32 iterations, bisection where it leaves (0, 1)
    // and after.
    let num = b.sub(y, v0);
    let den = b.sub(v1, v0);
    let t = b.div(num, den);
    let le0 = b.binary(BinOp::Le, t, zero);
    let ge1 = b.binary(BinOp::Ge, t, one);
    let out = b.binary(BinOp::Or, le0, ge1);
    let t = b.select(out, half, t);
    let rf_iters = b.int(24);
    let rf = b.binary(BinOp::Lt, it, rf_iters);
    let t = b.select(rf, t, half);
    // OIIO::lerp: xmin (1 − t) + xmax t.
    let u = b.sub(one, t);
    let a = b.mul(xmin, u);
    let c = b.mul(xmax, t);
    let x = b.add(a, c);
    let v = spline(b, x);
    let below = b.binary(BinOp::Lt, v, y);
    let above = b.unary(UnOp::Not, below);
    let low = b.select(increasing, below, above);
    let xmin = b.select(low, x, xmin);
    let v0 = b.select(low, v, v0);
    let xmax = b.select(low, xmax, x);
    let v1 = b.select(low, v1, v);
    let eps = b.float(1.0e-6);
    let w = b.sub(xmax, xmin);
    let w = b.unary(UnOp::Abs, w);
    let narrow = b.binary(BinOp::Lt, w, eps);
    let e = b.sub(v, y);
    let e = b.unary(UnOp::Abs, e);
    let near = b.binary(BinOp::Lt, e, eps);
    let done = b.binary(BinOp::Or, narrow, near);
    let active = b.unary(UnOp::Not, done);
    let one_i = b.int(1);
    let it = b.add(it, one_i);
    vec![it, xmin, xmax, v0, v1, x, active]
}
