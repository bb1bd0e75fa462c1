//! Four lanes at once of the f32 transcendental ops — [`super::exp`], [`super::log`],
//! [`super::pow`], [`super::sin`], [`super::cos`], [`super::tan`], [`super::asin`],
//! [`super::acos`], [`super::atan2`] at `f32`, totality rules included — for the JIT's batch
//! entry (issue 23): structure of arrays in and out, and every lane has the scalar op's bits.
//!
//! # How the bits stay the scalar ones
//!
//! The scalar ops are [`super::math`]'s f64 functions on the widened argument, rounded once.
//! Here the common path of each is the same f64 operations in the same order, written over
//! four lanes ([`D4`]: every `+ - * /` a loop over `[f64; 4]` that the compiler turns into one
//! AVX2 instruction or two SSE ones; Rust never contracts into FMA): the same Horner loops,
//! the same magic-number rounding, and the scalar code's branches as selects by lane mask
//! (both sides computed, one kept, so a lane sees exactly the operations its branch would
//! run). The rare lanes — NaN, infinities, zeros where the scalar code special-cases them,
//! `sin`/`cos`/`tan` arguments that need Payne–Hanek reduction (`|x| ≥ 2²⁰·π/2`, or a
//! Cody–Waite remainder under 2⁻²⁰) — are found by a mask and recomputed by the scalar op
//! for just those lanes, so their bits are the scalar ones by construction. `pow`'s
//! integer exponents up to 64 run the squaring loop over lanes (seven masked steps).
//!
//! [`table`] gives the functions of one copy ([`Path`], shared with [`super::noise_x4`]):
//! compiled for AVX2, SSE4.1 or the baseline (SSE2), or the scalar op once per lane
//! ([`Path::Lanes`], to measure against); [`chosen`] is the process's copy. Owns no
//! semantics: a change to [`super::math`] or to an op's totality rule is mirrored here, and
//! the tests hold the two equal bit for bit on every path.

use super::math::{
    ATAN_C, COS_C, INV_FACT, LN2_HI, LN2_LO, LOG_C, PIO2_1, PIO2_2, PIO2_3, PIO2_HI, PIO2_LO, SIN_C,
};
pub use super::simd::Path;
use std::f64::consts::{FRAC_2_PI, FRAC_PI_2, FRAC_PI_4, LOG2_E, SQRT_2};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Four f32 values, one per lane.
pub type X4 = [f32; 4];

/// `2^e` for a normal exponent (as `math`'s).
const fn pow2(e: i32) -> f64 {
    f64::from_bits(((1023 + e) as u64) << 52)
}

/// Four f64 lanes; every operation is per lane, in the scalar code's order.
#[derive(Clone, Copy)]
struct D4([f64; 4]);

/// A lane mask: all ones (true) or zero per lane.
#[derive(Clone, Copy)]
struct M4([u64; 4]);

#[inline(always)]
fn d4(f: impl Fn(usize) -> f64) -> D4 {
    D4([f(0), f(1), f(2), f(3)])
}

#[inline(always)]
fn m4(f: impl Fn(usize) -> bool) -> M4 {
    M4([f(0), f(1), f(2), f(3)].map(|b| (b as u64).wrapping_neg()))
}

#[inline(always)]
fn splat(x: f64) -> D4 {
    D4([x; 4])
}

macro_rules! binop {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for D4 {
            type Output = D4;
            #[inline(always)]
            fn $f(self, o: D4) -> D4 {
                d4(|l| self.0[l] $op o.0[l])
            }
        }
        impl $tr<f64> for D4 {
            type Output = D4;
            #[inline(always)]
            fn $f(self, o: f64) -> D4 {
                d4(|l| self.0[l] $op o)
            }
        }
        impl $tr<D4> for f64 {
            type Output = D4;
            #[inline(always)]
            fn $f(self, o: D4) -> D4 {
                d4(|l| self $op o.0[l])
            }
        }
    };
}
binop!(Add, add, +);
binop!(Sub, sub, -);
binop!(Mul, mul, *);
binop!(Div, div, /);

impl Neg for D4 {
    type Output = D4;
    #[inline(always)]
    fn neg(self) -> D4 {
        d4(|l| -self.0[l])
    }
}

impl D4 {
    #[inline(always)]
    fn abs(self) -> D4 {
        d4(|l| self.0[l].abs())
    }
    #[inline(always)]
    fn lt(self, c: f64) -> M4 {
        m4(|l| self.0[l] < c)
    }
    #[inline(always)]
    fn le(self, c: f64) -> M4 {
        m4(|l| self.0[l] <= c)
    }
    #[inline(always)]
    fn gt(self, c: f64) -> M4 {
        m4(|l| self.0[l] > c)
    }
    #[inline(always)]
    fn ge(self, c: f64) -> M4 {
        m4(|l| self.0[l] >= c)
    }
    #[inline(always)]
    fn eq(self, o: D4) -> M4 {
        m4(|l| self.0[l] == o.0[l])
    }
    /// The sign bit (`is_sign_negative`).
    #[inline(always)]
    fn negative(self) -> M4 {
        M4(self.0.map(|x| ((x.to_bits() as i64) >> 63) as u64))
    }
}

impl M4 {
    #[inline(always)]
    fn and(self, o: M4) -> M4 {
        M4([0, 1, 2, 3].map(|l| self.0[l] & o.0[l]))
    }
    #[inline(always)]
    fn or(self, o: M4) -> M4 {
        M4([0, 1, 2, 3].map(|l| self.0[l] | o.0[l]))
    }
    #[inline(always)]
    fn not(self) -> M4 {
        M4(self.0.map(|m| !m))
    }
    #[inline(always)]
    fn any(self) -> bool {
        (self.0[0] | self.0[1] | self.0[2] | self.0[3]) != 0
    }
    #[inline(always)]
    fn all(self) -> bool {
        (self.0[0] & self.0[1] & self.0[2] & self.0[3]) == !0
    }
    #[inline(always)]
    fn lane(self, l: usize) -> bool {
        self.0[l] != 0
    }
}

/// `m ? a : b` per lane, by bits (both sides are computed for every lane).
#[inline(always)]
fn select(m: M4, a: D4, b: D4) -> D4 {
    d4(|l| f64::from_bits((a.0[l].to_bits() & m.0[l]) | (b.0[l].to_bits() & !m.0[l])))
}

/// [`select`] with the mask through `black_box`, for a choice between two costly sides (the
/// trigonometric quadrant's `sin r` or `cos r`): a mask the optimizer can see may become a
/// branch per lane around one side (seen in the AVX2 `sin`: a branch on each of two lanes'
/// quadrant); opaque, both sides are computed and blended.
#[inline(always)]
fn select_opaque(m: M4, a: D4, b: D4) -> D4 {
    select(M4(std::hint::black_box(m.0)), a, b)
}

#[inline(always)]
fn widen(x: X4) -> D4 {
    d4(|l| x[l] as f64)
}

#[inline(always)]
fn narrow(x: D4) -> X4 {
    x.0.map(|x| x as f32)
}

const MAGIC: f64 = 6755399441055744.0; // 1.5·2⁵²

/// `d`, through `black_box`: an optimization barrier that bounds the expression trees the
/// vectorizer sees. Without it the trigonometric kernels (reduction, then two Horner chains
/// of nine steps, then the quadrant's choice) came out two lanes in SIMD and two scalar;
/// with the Horner sums fenced every Horner step is one AVX2 instruction, at the cost of a
/// store and a load. (The rest of those kernels is still partly two lanes + two scalar: the
/// auto-vectorizer's choice, see the README's figures.)
#[inline(always)]
fn fence(d: D4) -> D4 {
    D4(std::hint::black_box(d.0))
}

/// `math::round_int` per lane.
#[inline(always)]
fn round_int(t: D4) -> D4 {
    (t + MAGIC) - MAGIC
}

/// `round_int(t)` as an integer, two's complement in the low bits (`|t| < 2⁵¹`): the bits
/// of `t + MAGIC` less MAGIC's (no float-to-int conversion, which has no AVX2 form).
#[inline(always)]
fn int_bits(t_plus_magic: D4) -> [i64; 4] {
    t_plus_magic
        .0
        .map(|t| (t.to_bits() as i64).wrapping_sub(MAGIC.to_bits() as i64))
}

/// `math::horner` per lane (the same first step `0·z + c`).
#[inline(always)]
fn horner(z: D4, c: &[f64]) -> D4 {
    let mut acc = splat(0.0);
    for &k in c.iter().rev() {
        acc = acc * z + k;
    }
    acc
}

/// The lanes of `out` in `rare` replaced by `scalar(lane)`.
#[inline(always)]
fn patch(mut out: X4, rare: M4, scalar: impl Fn(usize) -> f32) -> X4 {
    if rare.any() {
        for (l, o) in out.iter_mut().enumerate() {
            if rare.lane(l) {
                *o = scalar(l);
            }
        }
    }
    out
}

// ---- the f64 kernels: `math`'s functions on their ordinary inputs ----

/// `math::exp` for a non-NaN `x`.
#[inline(always)]
fn exp_k(x: D4) -> D4 {
    // f64::clamp, as written there.
    let x = select(x.lt(-1100.0), splat(-1100.0), x);
    let x = select(x.gt(1100.0), splat(1100.0), x);
    let t = x * LOG2_E + MAGIC;
    let k = t - MAGIC;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let p = horner(r, &INV_FACT[..14]);
    // `k as i32`, `k / 2` and `pow2` on the integer lanes (|k| ≤ 1 587 here; NaN lanes are
    // recomputed by the caller).
    let k = int_bits(t);
    let half = k.map(|k| k / 2);
    let scale = |e: [i64; 4]| d4(|l| f64::from_bits((e[l].wrapping_add(1023) as u64) << 52));
    p * scale(half) * scale([0, 1, 2, 3].map(|l| k[l].wrapping_sub(half[l])))
}

/// `math::log` for a positive, finite, normal `x`.
#[inline(always)]
fn log_k(x: D4) -> D4 {
    let bits = x.0.map(f64::to_bits);
    // The exponent field as an f64 (exact): its bits under 2⁵²'s.
    let e = d4(|l| f64::from_bits((bits[l] >> 52) | 0x4330_0000_0000_0000)) - pow2(52);
    let k = e - 1023.0;
    let m = d4(|l| f64::from_bits((bits[l] & ((1 << 52) - 1)) | (1023 << 52)));
    let big = m.gt(SQRT_2);
    let m = select(big, m * 0.5, m);
    let k = select(big, k + 1.0, k);
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let series = s * z * horner(z, &LOG_C);
    let log_m = 2.0 * s + 2.0 * series;
    k * LN2_HI + (log_m + k * LN2_LO)
}

/// `math::rem_pio2` where it takes no Payne–Hanek reduction: `(n mod 4, r, rl)`, and the
/// lanes that would or whose `|x| < 2⁻²⁷` (`rare`).
#[inline(always)]
fn rem_pio2_k(x: D4) -> ([i64; 4], D4, D4, M4) {
    let ax = x.abs();
    let small = ax.le(FRAC_PI_4);
    let t = x * FRAC_2_PI + MAGIC;
    let n = t - MAGIC;
    let r2 = (x - n * PIO2_1) - n * PIO2_2;
    let w = n * PIO2_3;
    let r = r2 - w;
    let rl = (r2 - r) - w;
    let cody_waite = ax.lt(pow2(20) * FRAC_PI_2).and(r2.abs().ge(pow2(-20)));
    // Below 2⁻²⁷ `math::sin_kernel` takes its own branch: those lanes go to the scalar op too.
    let rare = small.or(cody_waite).not().or(ax.lt(pow2(-27)));
    // For |x| ≤ π/4 (`math` returns `(0, x, 0)` there) this computes n = 0, r = x, rl = +0
    // exactly, so no select is needed.
    let n_bits = int_bits(t);
    (n_bits.map(|n| n & 3), r, rl, rare)
}

/// `math::sin_kernel` for `|r| ≥ 2⁻²⁷` (which [`rem_pio2_k`]'s ordinary lanes have).
#[inline(always)]
fn sin_k(r: D4, rl: D4) -> D4 {
    let z = r * r;
    let h = fence(horner(z, &SIN_C));
    r + (rl * (1.0 - 0.5 * z) + r * z * h)
}

/// `math::cos_kernel`.
#[inline(always)]
fn cos_k(r: D4, rl: D4) -> D4 {
    let z = r * r;
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    let lost = (1.0 - w) - hz;
    let h = fence(horner(z, &COS_C));
    w + ((z * z * h - r * rl) + lost)
}

/// `math::minus_dd`.
#[inline(always)]
fn minus_dd(c: f64, cl: f64, h: D4, l: D4) -> (D4, D4) {
    let s = c - h;
    (s, ((c - s) - h) + (cl - l))
}

/// `math::atan_dd` for `t ≥ 0` (`+inf` included).
#[inline(always)]
fn atan_dd_k(t: D4) -> (D4, D4) {
    let inv = t.gt(1.0);
    let t = select(inv, 1.0 / t, t);
    let tan_pi_8 = SQRT_2 - 1.0;
    let big = t.gt(tan_pi_8);
    let base_hi = select(big, splat(0.5 * PIO2_HI), splat(0.0));
    let base_lo = select(big, splat(0.5 * PIO2_LO), splat(0.0));
    let u = select(big, (t - 1.0) / (t + 1.0), t);
    let z = u * u;
    let a = u + u * z * horner(z, &ATAN_C);
    let s = base_hi + a;
    let (h, l) = (s, ((base_hi - s) + a) + base_lo);
    let (mh, ml) = minus_dd(PIO2_HI, PIO2_LO, h, l);
    (select(inv, mh, h), select(inv, ml, l))
}

/// `math::atan2` for finite, non-NaN `y` and `x`.
#[inline(always)]
fn atan2_k(y: D4, x: D4) -> D4 {
    let pi_hi = 2.0 * PIO2_HI;
    let pi_lo = 2.0 * PIO2_LO;
    let xneg = x.negative();
    let at_zero = select(xneg, splat(pi_hi + pi_lo), splat(0.0));
    let (th, tl) = atan_dd_k(y.abs() / x.abs());
    let (mh, ml) = minus_dd(pi_hi, pi_lo, th, tl);
    let a = select(xneg, mh, th) + select(xneg, ml, tl);
    let a = select(y.eq(splat(0.0)), at_zero, a);
    select(y.negative(), -a, a)
}

/// `math::cofactor`.
#[inline(always)]
fn cofactor(a: D4) -> D4 {
    d4(|l| ((1.0 - a.0[l]) * (1.0 + a.0[l])).sqrt())
}

/// `ops::asin`'s and `ops::acos`'s clamp, in f32 (`f32::clamp` is the same two compares,
/// NaN passes through).
#[inline(always)]
fn clamp_unit(x: X4) -> X4 {
    x.map(|x| x.clamp(-1.0, 1.0))
}

// ---- the ops, four lanes ----

#[inline(always)]
fn exp_body(x: X4) -> X4 {
    let out = narrow(exp_k(widen(x)));
    patch(out, m4(|l| x[l].is_nan()), |l| super::exp(x[l]))
}

#[inline(always)]
fn log_body(x: X4) -> X4 {
    let xd = widen(x);
    // ops::log: x ≤ 0 gives log(f32::MIN_POSITIVE), the same operations on that argument.
    let xd = select(xd.le(0.0), splat(f32::MIN_POSITIVE as f64), xd);
    let out = narrow(log_k(xd));
    patch(out, m4(|l| x[l].is_nan() || x[l] == f32::INFINITY), |l| {
        super::log(x[l])
    })
}

/// `math::pow` for finite, nonzero `x` and `y` with `|y| < 2⁵¹` or `y` an f32 (every f64 from
/// 2⁵¹ up is then an even integer), whether `y` is an integer (where `x < 0` and it is not,
/// the value is not `math::pow`'s NaN) and whether it is an odd one.
#[inline(always)]
fn pow_k(xd: D4, yd: D4) -> (D4, M4, M4) {
    let (ax, ay) = (xd.abs(), yd.abs());
    // math::integer_parity by arithmetic.
    let is_int = ay.ge(pow2(51)).or(round_int(yd).eq(yd));
    let h = yd * 0.5;
    let odd = is_int.and(ay.lt(pow2(51))).and(round_int(h).eq(h).not());
    let squaring = is_int.and(ay.le(64.0));
    // Integer exponents up to 64: math::pow's loop, each step masked per lane.
    let mut base = select(yd.lt(0.0), 1.0 / ax, ax);
    let ay_bits = int_bits(ay + MAGIC);
    let mut n = [0, 1, 2, 3].map(|l| ay_bits[l] & squaring.0[l] as i64);
    let mut acc = splat(1.0);
    for _ in 0..7 {
        acc = select(m4(|l| n[l] & 1 == 1), acc * base, acc);
        n = n.map(|n| n >> 1);
        base = select(m4(|l| n[l] > 0), base * base, base);
    }
    // exp(y·ln|x|) where a lane needs it (a packet of integer exponents skips it: its
    // lanes would discard the value anyway).
    let general = if squaring.all() {
        splat(0.0)
    } else {
        exp_k(yd * log_k(ax))
    };
    let r = select(squaring, acc, general);
    (select(odd.and(xd.lt(0.0)), -r, r), is_int, odd)
}

#[inline(always)]
fn pow_body(x: X4, y: X4) -> X4 {
    let xd = widen(x);
    let (r, is_int, odd) = pow_k(xd, widen(y));
    // A zero base (a clamped dot product's, common in shading): ops::pow gives 0 for y < 0,
    // math::pow ±0 for y > 0 (-0 for -0 and an odd y).
    let zero_base = xd.eq(splat(0.0));
    let at_zero = select(odd.and(xd.negative()), splat(-0.0), splat(0.0));
    let r = select(zero_base, at_zero, r);
    let out = narrow(r);
    // ops::pow: a negative base with a non-integer exponent gives 0, and so does 0^negative.
    let zero = xd
        .lt(0.0)
        .and(is_int.not())
        .or(zero_base.and(widen(y).lt(0.0)));
    let out = [0, 1, 2, 3].map(|l| if zero.lane(l) { 0.0 } else { out[l] });
    let rare = m4(|l| !(x[l].is_finite() && y[l].is_finite() && y[l] != 0.0));
    patch(out, rare, |l| super::pow(x[l], y[l]))
}

/// `math::sin`, `cos` or `tan` (`pick` combines `n mod 4`, `sin r` and `cos r`) of finite
/// `x`, and the lanes that need Payne–Hanek reduction (their values are not the scalar ones).
#[inline(always)]
fn trig_k(x: D4, pick: impl Fn(M4, M4, D4, D4) -> D4) -> (D4, M4) {
    let (q, r, rl, rare) = rem_pio2_k(x);
    let (s, c) = (sin_k(r, rl), cos_k(r, rl));
    let odd = m4(|l| q[l] & 1 != 0);
    let two = m4(|l| q[l] & 2 != 0);
    (pick(odd, two, s, c), rare)
}

/// `math::sin`'s choice by quadrant.
#[inline(always)]
fn pick_sin(odd: M4, two: M4, s: D4, c: D4) -> D4 {
    let v = select_opaque(odd, c, s);
    select_opaque(two, -v, v)
}

/// `math::cos`'s choice by quadrant.
#[inline(always)]
fn pick_cos(odd: M4, two: M4, s: D4, c: D4) -> D4 {
    let v = select_opaque(odd, s, c);
    // n = 1 or 2: negated.
    let neg = M4([0, 1, 2, 3].map(|l| odd.0[l] ^ two.0[l]));
    select_opaque(neg, -v, v)
}

/// `math::tan`'s choice by quadrant.
#[inline(always)]
fn pick_tan(odd: M4, _: M4, s: D4, c: D4) -> D4 {
    select_opaque(odd, -c / s, s / c)
}

/// The three trigonometric ops in f32.
#[inline(always)]
fn trig_body(x: X4, pick: impl Fn(M4, M4, D4, D4) -> D4, scalar: fn(f32) -> f32) -> X4 {
    let (v, rare) = trig_k(widen(x), pick);
    let rare = rare.or(m4(|l| !x[l].is_finite()));
    patch(narrow(v), rare, |l| scalar(x[l]))
}

#[inline(always)]
fn sin_body(x: X4) -> X4 {
    trig_body(x, pick_sin, super::sin)
}

#[inline(always)]
fn cos_body(x: X4) -> X4 {
    trig_body(x, pick_cos, super::cos)
}

#[inline(always)]
fn tan_body(x: X4) -> X4 {
    trig_body(x, pick_tan, super::tan)
}

/// `math::asin` for `|x| ≤ 1`.
#[inline(always)]
fn asin_k(x: D4) -> D4 {
    let ax = x.abs();
    let (h, l) = atan_dd_k(ax / cofactor(ax));
    let a = h + l;
    select(x.negative(), -a, a)
}

/// `math::acos` for `|x| ≤ 1`.
#[inline(always)]
fn acos_k(x: D4) -> D4 {
    atan2_k(cofactor(x.abs()), x)
}

#[inline(always)]
fn asin_body(x: X4) -> X4 {
    let out = narrow(asin_k(widen(clamp_unit(x))));
    patch(out, m4(|l| x[l].is_nan()), |l| super::asin(x[l]))
}

#[inline(always)]
fn acos_body(x: X4) -> X4 {
    let out = narrow(acos_k(widen(clamp_unit(x))));
    patch(out, m4(|l| x[l].is_nan()), |l| super::acos(x[l]))
}

#[inline(always)]
fn atan2_body(y: X4, x: X4) -> X4 {
    let out = narrow(atan2_k(widen(y), widen(x)));
    let rare = m4(|l| !(y[l].is_finite() && x[l].is_finite()));
    patch(out, rare, |l| super::atan2(y[l], x[l]))
}

// ---- the copies ----

/// A one-argument four-lane op.
pub type Unary = fn(X4) -> X4;
/// A two-argument four-lane op (`pow(a, b)`, `atan2(y, x)`).
pub type Binary = fn(X4, X4) -> X4;

/// The four-lane ops of one copy; each lane has the scalar op's bits (`ops::exp::<f32>`…).
pub struct Table {
    /// [`super::exp`].
    pub exp: Unary,
    /// [`super::log`] (`log(f32::MIN_POSITIVE)` for `x ≤ 0`).
    pub log: Unary,
    /// [`super::sin`].
    pub sin: Unary,
    /// [`super::cos`].
    pub cos: Unary,
    /// [`super::tan`].
    pub tan: Unary,
    /// [`super::asin`] (clamped argument).
    pub asin: Unary,
    /// [`super::acos`] (clamped argument).
    pub acos: Unary,
    /// [`super::pow`] (0 for a negative base with a non-integer exponent, `0^negative = 0`).
    pub pow: Binary,
    /// [`super::atan2`]`(y, x)`.
    pub atan2: Binary,
}

/// The baseline copy (x86-64: SSE2).
const BASE: Table = Table {
    exp: exp_body,
    log: log_body,
    sin: sin_body,
    cos: cos_body,
    tan: tan_body,
    asin: asin_body,
    acos: acos_body,
    pow: pow_body,
    atan2: atan2_body,
};

/// The scalar op once per lane.
const LANES: Table = Table {
    exp: |x| x.map(super::exp),
    log: |x| x.map(super::log),
    sin: |x| x.map(super::sin),
    cos: |x| x.map(super::cos),
    tan: |x| x.map(super::tan),
    asin: |x| x.map(super::asin),
    acos: |x| x.map(super::acos),
    pow: |a, b| [0, 1, 2, 3].map(|l| super::pow(a[l], b[l])),
    atan2: |y, x| [0, 1, 2, 3].map(|l| super::atan2(y[l], x[l])),
};

/// A copy of every body compiled for a target feature, and its table.
macro_rules! feature_copy {
    ($m:ident, $feature:literal) => {
        #[cfg(target_arch = "x86_64")]
        mod $m {
            use super::*;
            #[target_feature(enable = $feature)]
            fn exp(x: X4) -> X4 {
                exp_body(x)
            }
            #[target_feature(enable = $feature)]
            fn log(x: X4) -> X4 {
                log_body(x)
            }
            #[target_feature(enable = $feature)]
            fn sin(x: X4) -> X4 {
                sin_body(x)
            }
            #[target_feature(enable = $feature)]
            fn cos(x: X4) -> X4 {
                cos_body(x)
            }
            #[target_feature(enable = $feature)]
            fn tan(x: X4) -> X4 {
                tan_body(x)
            }
            #[target_feature(enable = $feature)]
            fn asin(x: X4) -> X4 {
                asin_body(x)
            }
            #[target_feature(enable = $feature)]
            fn acos(x: X4) -> X4 {
                acos_body(x)
            }
            #[target_feature(enable = $feature)]
            fn pow(a: X4, b: X4) -> X4 {
                pow_body(a, b)
            }
            #[target_feature(enable = $feature)]
            fn atan2(y: X4, x: X4) -> X4 {
                atan2_body(y, x)
            }
            // SAFETY (every entry): `table` hands this table out only where
            // `Path::available` found the feature.
            pub(super) const TABLE: Table = Table {
                exp: |x| unsafe { exp(x) },
                log: |x| unsafe { log(x) },
                sin: |x| unsafe { sin(x) },
                cos: |x| unsafe { cos(x) },
                tan: |x| unsafe { tan(x) },
                asin: |x| unsafe { asin(x) },
                acos: |x| unsafe { acos(x) },
                pow: |a, b| unsafe { pow(a, b) },
                atan2: |y, x| unsafe { atan2(y, x) },
            };
        }
    };
}
feature_copy!(avx2, "avx2");
feature_copy!(sse41, "sse4.1");

/// The ops of the copy `path`. Panics if the CPU cannot run it ([`Path::available`]).
pub fn table(path: Path) -> &'static Table {
    assert!(path.available(), "{path:?} is not available on this CPU");
    match path {
        Path::Lanes => &LANES,
        #[cfg(target_arch = "x86_64")]
        Path::Avx2 => &avx2::TABLE,
        #[cfg(target_arch = "x86_64")]
        Path::Sse41 => &sse41::TABLE,
        _ => &BASE,
    }
}

/// The ops of [`Path::chosen`], the process's copy.
pub fn chosen() -> &'static Table {
    static CHOSEN: std::sync::OnceLock<&'static Table> = std::sync::OnceLock::new();
    CHOSEN.get_or_init(|| table(Path::chosen()))
}

#[cfg(test)]
mod tests;
