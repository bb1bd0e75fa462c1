//! Filtered noise: noise and fractal sums whose octaves fade to their average as they get
//! finer than the footprint (the approach of pbrt's `FBm` and RenderMan's filtered `fBm`),
//! so a far surface shows the noise's average instead of aliasing.
//!
//! The footprint width of the noise's input point `q` is `w = max(|∂q/∂x|, |∂q/∂y|)` times
//! the node's filter scale, from the shared screen-space derivatives ([`Builder::derivs`]).
//! An octave of lattice frequency `f` keeps the weight `1 − smoothstep(0.1, 2.2, f·w)` and
//! its average (0: every noise here is signed) takes the rest. The band is not pbrt's (which
//! drops an octave once `f·w` passes 0.5, where a box over the footprint still keeps 87 % of
//! it): it is the attenuation of our Perlin noise under a box of width `w`, measured
//! (`tests/filtered_noise.rs`: 0.98 at `w = 0.2`, 0.87 at 0.5, 0.60 at 1, 0.34 at 1.5, 0.18
//! at 2, 0.06 at 3) and fitted by that smoothstep within 0.12, so that a filtered value is
//! close to the box average a supersampled pixel sees. A fractal sum keeps its whole octaves
//! (`f·w ≤ 0.1`) through the same intrinsic with fewer octaves and adds the fading ones one
//! by one, each in its own region (a batch whose lanes all skip it skips it); the octaves
//! past the band are not computed. Where no octave fades (a fine footprint, no
//! derivatives, NaN) the result is the unfiltered one bit for bit, and a constant scale ≤ 0
//! folds every added op away. This module lowers onto ordinary IR ops; it owns the fade
//! formulas, not the nodes.

use crate::ir::{BinOp, Builder, Intrinsic, UnOp, Value};
use crate::types::Type;

/// The fade band of an octave, in `f·w` (frequency × footprint width): whole below,
/// gone above.
pub const FADE: [f64; 2] = [0.1, 2.2];

/// The most fading octaves a fractal computes past its whole ones: `⌈log₂(2.2 / 0.1)⌉`, the
/// band's span at lacunarity 2. Lacunarities below `22^(1/5) ≈ 1.86` put more octaves in
/// the band; the ones past these are dropped.
pub const FADING: usize = 5;

/// The footprint width of a noise's input point `q` (a float or vector):
/// `max(|∂q/∂x|, |∂q/∂y|)·scale`; `None` where `q` has no derivatives (a constant across
/// the pixel), so nothing is built.
pub fn point_width(b: &mut Builder, q: Value, scale: Value) -> Option<Value> {
    let [dx, dy] = b.derivs(q)?;
    let len = |b: &mut Builder, d: Value| {
        if b.ty(d).is_vector() {
            b.unary(UnOp::Length, d)
        } else {
            b.unary(UnOp::Abs, d)
        }
    };
    let (lx, ly) = (len(b, dx), len(b, dy));
    let m = b.max(lx, ly);
    Some(b.mul(m, scale))
}

/// The weight of an octave at `x = f·w`: `1 − smoothstep(FADE[0], FADE[1], x)`, exactly 1
/// below the band and 0 above it.
fn weight(b: &mut Builder, x: Value) -> Value {
    let (lo, hi) = (b.float(FADE[0]), b.float(FADE[1]));
    let s = super::math::smoothstep_scalar(b, &[lo, hi, x]);
    let one = b.float(1.0);
    b.sub(one, s)
}

/// `select(scale > 0, filtered, hard)`: a constant scale folds it, and the filtered arm's
/// derivative ops die with it where the scale is ≤ 0.
fn switch(b: &mut Builder, scale: Value, filtered: Value, hard: Value) -> Value {
    let z = b.float(0.0);
    let on = b.binary(BinOp::Gt, scale, z);
    b.select(on, filtered, hard)
}

/// One signed noise value `noise` of the point `q` (lattice frequency 1), faded towards its
/// average 0 as the footprint `w` of `q` (scaled by `scale`; ≤ 0 turns filtering off)
/// grows: `noise · (1 − smoothstep(0.1, 2.2, w))`. Exactly `noise` where `w ≤ 0.1`, where
/// `q` has no derivatives, and where the width is NaN.
pub fn noise(b: &mut Builder, noise: Value, q: Value, scale: Value) -> Value {
    let Some(w) = point_width(b, q, scale) else {
        return noise;
    };
    let lo = b.float(FADE[0]);
    let blur = b.binary(BinOp::Gt, w, lo);
    let s = weight(b, w);
    let one = b.float(1.0);
    let s = b.select(blur, s, one);
    let ty = b.ty(noise);
    let s = b.splat_to(ty, s);
    let faded = b.mul(noise, s);
    switch(b, scale, faded, noise)
}

/// A fractal sum intrinsic and the noise each of its octaves is: `sum(q, octaves,
/// lacunarity, gain) = Σ_{i<octaves} gainⁱ · octave(q · lacunarityⁱ)`, octaves clamped to
/// `[0, max_octaves]`.
#[derive(Clone, Copy, Debug)]
pub struct Fractal {
    /// The sum: `(q, octaves: int, lacunarity: float, gain: float)`.
    pub sum: Intrinsic,
    /// One octave: `(q)`, the same result type as `sum`.
    pub octave: Intrinsic,
    /// The sum's clamp on its octave count.
    pub max_octaves: i32,
}

/// The fractal `f` of `q` with its octaves faded over the footprint width `w` (see
/// [`point_width`]; `None`: no derivatives, the plain sum): octave `i` (frequency
/// `lacunarityⁱ`) weighted by `1 − smoothstep(0.1, 2.2, lacunarityⁱ·w)`. The whole octaves
/// (`lacunarityⁱ·w ≤ 0.1`: the first `k = ⌊log(0.1/w) / log(lacunarity)⌋ + 1`) are summed by
/// `f.sum` with `k` octaves, so their bits are the unfiltered ones; the next [`FADING`] are
/// added one by one where they lie inside the count and the band; the rest are dropped
/// (their average is 0). Where `k` reaches the octave count (a fine footprint), the
/// lacunarity is ≤ 1 (no octave is finer than the first), `w` is 0 or NaN, or `scale ≤ 0`:
/// the unfiltered sum, bit for bit.
pub fn fractal(
    b: &mut Builder,
    f: Fractal,
    q: Value,
    [octaves, lacunarity, gain]: [Value; 3],
    w: Option<Value>,
    scale: Value,
) -> Value {
    let Some(w) = w else {
        return b.call(f.sum, &[q, octaves, lacunarity, gain]);
    };
    let (zero, one) = (b.float(0.0), b.float(1.0));
    let ln_lac = b.unary(UnOp::Log, lacunarity);
    // Octaves 0..=n are whole: lacunarityⁿ·w ≤ FADE[0].
    let n = {
        let lo = b.float(FADE[0]);
        let r = b.div(lo, w);
        let l = b.unary(UnOp::Log, r);
        b.div(l, ln_lac)
    };
    // The octave count the sum clamps to, as a float.
    let count = {
        let o = b.convert(Type::Float, octaves);
        let m = b.float(f.max_octaves as f64);
        b.clamp(o, zero, m)
    };
    let kf = {
        let nf = b.unary(UnOp::Floor, n);
        let k = b.add(nf, one);
        b.max(k, zero)
    };
    // Filter where an octave fades (false for a NaN `n`), the lacunarity makes the octaves
    // finer, and the width is positive (the IR's division by 0 is 0).
    let fades = {
        let short = b.binary(BinOp::Lt, kf, count);
        let finer = b.binary(BinOp::Gt, lacunarity, one);
        let wide = b.binary(BinOp::Gt, w, zero);
        let a = b.binary(BinOp::And, short, finer);
        b.binary(BinOp::And, a, wide)
    };
    let k = b.convert(Type::Int, kf);
    let kept = b.select(fades, k, octaves);
    // A constant scale ≤ 0 folds the count back to `octaves`: the unfiltered call.
    let kept = switch(b, scale, kept, octaves);
    let sum = b.call(f.sum, &[q, kept, lacunarity, gain]);
    // Octave i lies inside the band where lacunarityⁱ·w < FADE[1], that is where
    // i < n + log(FADE[1]/FADE[0]) / log(lacunarity): no power computed outside the regions
    // (a constant lacunarity folds the bound's offset).
    let last = {
        let span = b.float((FADE[1] / FADE[0]).ln());
        let o = b.div(span, ln_lac);
        b.add(n, o)
    };
    // The first fading octave's frequency and amplitude (powers), in a region no lane of a
    // packet that keeps every octave enters; the next ones by products. The powers are
    // `exp(k·ln x)`: the logarithms of uniform parameters are hoisted, and the region pays
    // one `exp` each (a `pow` was a quarter of a filtered fBm's time).
    let first = b.if_(
        fades,
        |b| {
            let e = b.mul(kf, ln_lac);
            let freq = b.unary(UnOp::Exp, e);
            vec![freq, signed_power(b, gain, kf)]
        },
        |b| vec![b.float(1.0), b.float(1.0)],
    );
    let (mut freq, mut amp) = (first[0], first[1]);
    let mut acc = sum;
    for j in 0..FADING {
        let i = {
            let jf = b.float(j as f64);
            b.add(kf, jf)
        };
        let inside = b.binary(BinOp::Lt, i, count);
        let in_band = b.binary(BinOp::Lt, i, last);
        let c = b.binary(BinOp::And, fades, inside);
        let c = b.binary(BinOp::And, c, in_band);
        let before = acc;
        let (fr, am) = (freq, amp);
        acc = b.if_(
            c,
            |b| {
                let term = fading_octave(b, f.octave, q, w, fr, am);
                vec![b.add(before, term)]
            },
            |_| vec![before],
        )[0];
        if j + 1 < FADING {
            freq = b.mul(freq, lacunarity);
            amp = b.mul(amp, gain);
        }
    }
    switch(b, scale, acc, sum)
}

/// `gainⁱ` for a float `i ≥ 0` holding an integer: `|gain|ⁱ = exp(i·ln|gain|)` with the
/// sign of `gain` where `i` is odd; exactly 1 for `i = 0` and, for a zero gain, 0 after.
fn signed_power(b: &mut Builder, gain: Value, i: Value) -> Value {
    let g = b.unary(UnOp::Abs, gain);
    let lg = b.unary(UnOp::Log, g);
    let e = b.mul(i, lg);
    let a = b.unary(UnOp::Exp, e);
    let zero = b.float(0.0);
    let (one, none) = (b.float(1.0), b.binary(BinOp::Eq, g, zero));
    let a = b.select(none, zero, a);
    // `x⁰ = 1` for every x (an infinite or NaN gain too, as `pow` says).
    let first = b.binary(BinOp::Eq, i, zero);
    let a = b.select(first, one, a);
    let neg = b.binary(BinOp::Lt, gain, zero);
    let half = b.float(0.5);
    let h = b.mul(i, half);
    let fl = b.unary(UnOp::Floor, h);
    let odd = b.binary(BinOp::Ne, fl, h);
    let flip = b.binary(BinOp::And, neg, odd);
    let na = b.unary(UnOp::Neg, a);
    b.select(flip, na, a)
}

/// One fading octave of noise `octave` at `q` for the footprint width `w`, of frequency
/// `freq` and amplitude `amp`: `amp · weight(freq·w) · octave(q · freq)`.
fn fading_octave(
    b: &mut Builder,
    octave: Intrinsic,
    q: Value,
    w: Value,
    freq: Value,
    amp: Value,
) -> Value {
    let x = b.mul(freq, w);
    let qty = b.ty(q);
    let fs = b.splat_to(qty, freq);
    let qk = b.mul(q, fs);
    let v = b.call(octave, &[qk]);
    let s = weight(b, x);
    let s = b.mul(s, amp);
    let ty = b.ty(v);
    let s = b.splat_to(ty, s);
    b.mul(v, s)
}
