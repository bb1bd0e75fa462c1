//! Filtered procedurals: patterns averaged over the footprint of their coordinates, so a
//! far surface shows the pattern's mean instead of aliasing.
//!
//! The footprint comes from the screen-space derivatives of the pattern's coordinates
//! ([`Builder::derivs`]); where they are zero (no ray differentials, or a coordinate that
//! does not change across the pixel) the pattern is the unfiltered one, bit for bit. This
//! module lowers onto ordinary IR ops; it owns the filter formulas, not the nodes.

use crate::ir::{BinOp, Builder, UnOp, Value};
use crate::types::Type;

/// Footprints narrower than this (in cells) are not filtered: the box average differs from
/// the point value only within this distance of an edge, and f32 cannot resolve a narrower
/// difference of the integrals far from the origin.
const NARROW: f64 = 1e-3;

/// Probes along the footprint's major axis in [`checker_weight`]: the footprint
/// parallelogram is cut into this many slices across its major axis, each box-filtered
/// separably. A separable box over the whole parallelogram is wrong where the parallelogram
/// is sheared against the checks (a grazing view away from the image's centre line); over a
/// slice the error shrinks with the slice.
pub const CHECKER_PROBES: usize = 4;

/// The weight of the "even" checks (cells whose integer coordinates have an even sum) in
/// the average of a checkerboard of unit cells over the footprint of `s` (a float or vector
/// of cell coordinates): the parallelogram `s + a·∂s/∂x + b·∂s/∂y`, `a, b ∈ [−½, ½]`, scaled
/// by `scale` (a float; 0 turns filtering off). The parallelogram is cut into
/// [`CHECKER_PROBES`] slices along its longer axis; each slice contributes the analytic box
/// average `(1 + Π gₖ) / 2` over a box of its per-axis widths `√((majorₖ/N)² + minorₖ²)`
/// (`gₖ` the box average of the ±1 square wave along axis `k`). 1 or 0 where the whole
/// footprint is narrow; `even` is the unfiltered parity (a bool), used there and where
/// `scale ≤ 0`.
pub fn checker_weight(b: &mut Builder, s: Value, even: Value, scale: Value) -> Value {
    let (one, zero) = (b.float(1.0), b.float(0.0));
    let hard = b.select(even, one, zero);
    let Some([dx, dy]) = b.derivs(s) else {
        return hard;
    };
    let ty = b.ty(s);
    let n = ty.width();
    let comp = |b: &mut Builder, v: Value, k: usize| {
        if ty.is_vector() { b.extract(v, k) } else { v }
    };
    // The longer screen axis is the major one.
    let (lx, ly) = if ty.is_vector() {
        (b.dot(dx, dx), b.dot(dy, dy))
    } else {
        (b.mul(dx, dx), b.mul(dy, dy))
    };
    let x_major = b.binary(BinOp::Ge, lx, ly);
    let probes = b.float(CHECKER_PROBES as f64);
    let mut centre = Vec::new();
    let mut major = Vec::new();
    let mut slice_w = Vec::new();
    let mut all_narrow: Option<Value> = None;
    for k in 0..n {
        let x = comp(b, s, k);
        let (ax, ay) = (comp(b, dx, k), comp(b, dy, k));
        let maj = b.select(x_major, ax, ay);
        let min = b.select(x_major, ay, ax);
        let full = footprint_width(b, maj, min, scale);
        let narrow = {
            let eps = b.float(NARROW);
            // NaN widths count as narrow: the point value is always defined.
            let wide = b.binary(BinOp::Gt, full, eps);
            b.unary(UnOp::Not, wide)
        };
        all_narrow = Some(match all_narrow {
            Some(a) => b.binary(BinOp::And, a, narrow),
            None => narrow,
        });
        let part = b.div(maj, probes);
        slice_w.push(footprint_width(b, part, min, scale));
        major.push(b.mul(maj, scale));
        centre.push(x);
    }
    let Some(all_narrow) = all_narrow else {
        return hard;
    };
    let half = b.float(0.5);
    let mut sum: Option<Value> = None;
    for j in 0..CHECKER_PROBES {
        let offset = b.float((j as f64 + 0.5) / CHECKER_PROBES as f64 - 0.5);
        let mut product: Option<Value> = None;
        for k in 0..n {
            let shift = b.mul(major[k], offset);
            let x = b.add(centre[k], shift);
            let g = box_square_wave_or_point(b, x, slice_w[k]);
            product = Some(match product {
                Some(p) => b.mul(p, g),
                None => g,
            });
        }
        let product = product.expect("a checker has an axis");
        sum = Some(match sum {
            Some(t) => b.add(t, product),
            None => product,
        });
    }
    let mean = {
        let inv = b.float(1.0 / CHECKER_PROBES as f64);
        let t = sum.expect("probes");
        b.mul(t, inv)
    };
    let hp = b.mul(half, mean);
    let soft = b.add(half, hp);
    // Where every axis is narrow the parity is exact (and NaN-proof) as unfiltered.
    let filtered = b.select(all_narrow, hard, soft);
    // A scale ≤ 0 (or NaN) turns filtering off; a constant one folds this select, and the
    // derivative ops die with the filtered arm.
    let z = b.float(0.0);
    let on = b.binary(BinOp::Gt, scale, z);
    b.select(on, filtered, hard)
}

/// The box average of the ±1 square wave over `[x − w/2, x + w/2]` ([`box_square_wave`]),
/// or its point value where `w` is narrow (or NaN).
fn box_square_wave_or_point(b: &mut Builder, x: Value, w: Value) -> Value {
    let eps = b.float(NARROW);
    let wide = b.binary(BinOp::Gt, w, eps);
    let g = box_square_wave(b, x, w);
    let sq = {
        let f = b.unary(UnOp::Floor, x);
        let i = b.convert(Type::Int, f);
        let two = b.int(2);
        let parity = b.binary(BinOp::Mod, i, two);
        let z = b.int(0);
        let ev = b.binary(BinOp::Eq, parity, z);
        let (one, m) = (b.float(1.0), b.float(-1.0));
        b.select(ev, one, m)
    };
    b.select(wide, g, sq)
}

/// The width of the footprint along one coordinate, `√(∂x² + ∂y²)·scale` (OSL's
/// `filterwidth`).
fn footprint_width(b: &mut Builder, ax: Value, ay: Value, scale: Value) -> Value {
    let (xx, yy) = (b.mul(ax, ax), b.mul(ay, ay));
    let sum = b.add(xx, yy);
    let w = b.unary(UnOp::Sqrt, sum);
    b.mul(w, scale)
}

/// The box average over `[x − w/2, x + w/2]` of the square wave that is +1 on `[0, 1)` and
/// −1 on `[1, 2)` (period 2), clamped to [−1, 1] against rounding: `(I(x + w/2) − I(x −
/// w/2)) / w` with its integral `I(t) = 1 − |t mod 2 − 1|`.
fn box_square_wave(b: &mut Builder, x: Value, w: Value) -> Value {
    let half = b.float(0.5);
    let hw = b.mul(w, half);
    let hi = b.add(x, hw);
    let lo = b.sub(x, hw);
    let (ih, il) = (square_wave_integral(b, hi), square_wave_integral(b, lo));
    let d = b.sub(ih, il);
    let g = b.div(d, w);
    let (m, p) = (b.float(-1.0), b.float(1.0));
    b.clamp(g, m, p)
}

/// `I(t) = 1 − |t − 2·floor(t/2) − 1|`, the integral from 0 of the period-2 square wave.
fn square_wave_integral(b: &mut Builder, t: Value) -> Value {
    let (half, two, one) = (b.float(0.5), b.float(2.0), b.float(1.0));
    let h = b.mul(t, half);
    let f = b.unary(UnOp::Floor, h);
    let f2 = b.mul(f, two);
    let m = b.sub(t, f2);
    let c = b.sub(m, one);
    let a = b.unary(UnOp::Abs, c);
    b.sub(one, a)
}

/// OSL's `filterwidth(x)` of a float (or, per component, of a vector or colour):
/// `√(∂x/∂x_screen² + ∂x/∂y_screen²)`, 0 where `x` has no derivatives (a constant, or no
/// ray differentials).
pub fn filter_width(b: &mut Builder, x: Value) -> Value {
    match b.derivs(x) {
        Some([dx, dy]) => {
            let (xx, yy) = (b.mul(dx, dx), b.mul(dy, dy));
            let sum = b.add(xx, yy);
            b.unary(UnOp::Sqrt, sum)
        }
        None => {
            let ty = b.ty(x);
            b.zero(ty)
        }
    }
}

/// A box-filtered step: the share of `[x − w/2, x + w/2]` at or above `edge`, `w` the filter
/// width of `x` times `scale`, that is `clamp((x + w/2 − edge) / w, 0, 1)`; where `w` is
/// below 1e-9 (or NaN, or `scale ≤ 0`) the unfiltered step, 1 for `x ≥ edge`, else 0.
pub fn filter_step(b: &mut Builder, edge: Value, x: Value, scale: Value) -> Value {
    let (one, zero) = (b.float(1.0), b.float(0.0));
    let at_or_above = b.binary(BinOp::Ge, x, edge);
    let hard = b.select(at_or_above, one, zero);
    let Some([dx, dy]) = b.derivs(x) else {
        return hard;
    };
    let w = footprint_width(b, dx, dy, scale);
    let half = b.float(0.5);
    let hw = b.mul(w, half);
    let top = b.add(x, hw);
    let above = b.sub(top, edge);
    let share = b.div(above, w);
    let soft = b.clamp(share, zero, one);
    let eps = b.float(1e-9);
    let wide = b.binary(BinOp::Gt, w, eps);
    let filtered = b.select(wide, soft, hard);
    // As the checker's: a constant scale ≤ 0 folds the filtered arm and its derivatives away.
    let on = b.binary(BinOp::Gt, scale, zero);
    b.select(on, filtered, hard)
}
