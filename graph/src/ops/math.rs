//! Our transcendental functions: `exp`, `log`, `pow`, `sin`, `cos`, `tan`, `asin`, `acos`,
//! `atan`, `atan2` (DESIGN §7). Every CPU back end calls these — the ops, the constant
//! folder, the interpreter in f32 and f64, and the JIT's helpers — never the platform's libm,
//! so an image's bits do not depend on the operating system or the C library.
//!
//! # One implementation per function
//!
//! Each function is written once, in f64, using only `+ - * /`, `sqrt` (IEEE) and bit
//! operations (no `mul_add`, no libm call; Rust never contracts into FMA). The f32 function
//! is the f64 one on the widened argument, rounded once to f32 (`sin_f32(x) = sin(x as f64)
//! as f32`): its error is the f64 function's error (2⁻⁵⁰ relative or less, far below an f32
//! ulp) plus the final rounding, so the f32 functions are correctly rounded except where the
//! exact result lies within about 2⁻²⁶ ulp of a rounding boundary.
//!
//! # Algorithms
//!
//! - Argument reduction for `sin`/`cos`/`tan`: `r = x − n·π/2` with `|r| ≤ π/4`; three-part
//!   Cody–Waite for `|x| < 2²⁰·π/2` when `r` keeps at least 2⁻²⁰, otherwise Payne–Hanek with
//!   192 bits of 2/π (exact for every finite f64).
//! - `exp`: `x = k·ln 2 + r`, `|r| ≤ ln 2 / 2`, Taylor series of `eʳ` to degree 13, scaled by
//!   `2ᵏ` in two exact steps (gradual underflow rounds once).
//! - `log`: `x = 2ᵏ·m`, `m ∈ [√½, √2)`, `ln m = 2·atanh(s)` with `s = (m−1)/(m+1)`, series to
//!   `s²³`.
//! - `atan`: `atan(t) = π/2 − atan(1/t)` for `t > 1`, `π/4 + atan((t−1)/(t+1))` for
//!   `t > tan(π/8)`, then the series to `t⁴³`; `atan2`, `asin` (`atan(x/√((1−x)(1+x)))`) and
//!   `acos` (`atan2(√((1−x)(1+x)), x)`) build on it.
//! - `pow`: integer exponents up to 64 by squaring (`1/x` for negative ones), otherwise
//!   `exp(y·ln|x|)`; the C99 Annex F special cases.
//!
//! The series coefficients are `1/n!` and `1/n`, computed here; the constants (π/2 and ln 2
//! in parts, the bits of 2/π) are computed at compile time from Machin's formula and
//! `ln 2 = 2·atanh(1/3)` in 1 312-bit fixed point ([`big`]), never pasted.
//!
//! # Accuracy
//!
//! Measured by this module's tests against std's f64 functions (glibc's, within an f64 ulp:
//! where glibc is not — its `cos` is 8 ulps off at Muller's worst case for reduction — the
//! test holds the 3 000-bit value) on every hard input (±0, subnormals, ±max, ±inf, NaN,
//! ±1 and its neighbours, f32 neighbours of k·π/2 up to 2⁴⁰·π/2, overflow and underflow
//! thresholds) and 200 000 random ones per function (uniform over bit patterns, and
//! uniform over the function's ordinary range):
//!
//! | function | f32 bound (measured), all finite inputs | f64 bound (measured) |
//! |---|---|---|
//! | `exp` | 0.5 + 2⁻²⁰ ulp (0.49999) | 2 ulps (1) |
//! | `log` | 0.5 + 2⁻²⁰ ulp (0.49999) | 2 ulps (2) |
//! | `sin`, `cos` | 0.5 + 2⁻²⁰ ulp (0.49999) | 2 ulps (1) |
//! | `tan` | 0.5 + 2⁻²⁰ ulp (0.49999) | 4 ulps (3) |
//! | `asin`, `acos`, `atan`, `atan2` | 0.5 + 2⁻²⁰ ulp (0.49999 / 0.5 for subnormal results) | 3 ulps (3) |
//! | `pow` | 0.5 + 2⁻²⁰ ulp (0.5) | integer \|y\| ≤ 64: 4 + 2·\|y\| ulps; otherwise 2 + 3·\|y·ln x\| ulps (809 at \|y·ln x\| ≈ 700): `y·ln x` is rounded, no extra precision |
//!
//! (f32: the error against the exact value in f32 ulps, so 0.5 is correct rounding.)
//!
//! Special values follow C99 Annex F (NaN in, NaN out; `exp(-inf) = 0`; `log(0) = -inf`;
//! `pow(x, 0) = pow(1, y) = 1` for a quiet NaN, NaN for a signaling one, as glibc; `atan2` of zeros and infinities; signed zeros kept). The
//! totality rules of DESIGN §7 (`log(x ≤ 0)`, clamping `asin`/`acos`, `pow` of a negative
//! base) are the ops' wrappers in [`crate::ops`], not these functions.
//!
//! [`super::math_x4`] computes the f32 ops four lanes at once with these functions' exact
//! operations (its constants are this module's): a change here is mirrored there, and its
//! tests hold the two equal bit for bit.

use std::f64::consts::{FRAC_2_PI, FRAC_PI_2, LOG2_E};

/// Fixed-point bignum arithmetic at compile time, for the constants of this module.
mod big {
    /// u32 limbs, most significant first; limb 0 is the integer part, the other 41 the
    /// fraction (1 312 bits).
    pub const LIMBS: usize = 42;
    /// A non-negative fixed-point number.
    pub type Big = [u32; LIMBS];

    const fn div_small(a: &mut Big, d: u32) {
        let mut rem: u64 = 0;
        let mut i = 0;
        while i < LIMBS {
            let cur = (rem << 32) | a[i] as u64;
            a[i] = (cur / d as u64) as u32;
            rem = cur % d as u64;
            i += 1;
        }
    }

    const fn add(a: &mut Big, b: &Big) {
        let mut carry = 0u64;
        let mut i = LIMBS;
        while i > 0 {
            i -= 1;
            let s = a[i] as u64 + b[i] as u64 + carry;
            a[i] = s as u32;
            carry = s >> 32;
        }
    }

    const fn sub(a: &mut Big, b: &Big) {
        let mut borrow = 0i64;
        let mut i = LIMBS;
        while i > 0 {
            i -= 1;
            let mut s = a[i] as i64 - b[i] as i64 - borrow;
            borrow = 0;
            if s < 0 {
                s += 1 << 32;
                borrow = 1;
            }
            a[i] = s as u32;
        }
    }

    const fn mul_small(a: &mut Big, m: u32) {
        let mut carry = 0u64;
        let mut i = LIMBS;
        while i > 0 {
            i -= 1;
            let p = a[i] as u64 * m as u64 + carry;
            a[i] = p as u32;
            carry = p >> 32;
        }
    }

    const fn is_zero(a: &Big) -> bool {
        let mut i = 0;
        while i < LIMBS {
            if a[i] != 0 {
                return false;
            }
            i += 1;
        }
        true
    }

    const fn ge(a: &Big, b: &Big) -> bool {
        let mut i = 0;
        while i < LIMBS {
            if a[i] != b[i] {
                return a[i] > b[i];
            }
            i += 1;
        }
        true
    }

    /// `atan(1/q)` (`hyperbolic`: `atanh(1/q)`) by its series.
    const fn atan_inv(q: u32, hyperbolic: bool) -> Big {
        let mut power = [0u32; LIMBS];
        power[0] = 1;
        div_small(&mut power, q);
        let mut plus = [0u32; LIMBS];
        let mut minus = [0u32; LIMBS];
        let mut k: u32 = 0;
        while !is_zero(&power) {
            let mut term = power;
            div_small(&mut term, 2 * k + 1);
            if hyperbolic || k.is_multiple_of(2) {
                add(&mut plus, &term);
            } else {
                add(&mut minus, &term);
            }
            div_small(&mut power, q * q);
            k += 1;
        }
        sub(&mut plus, &minus);
        plus
    }

    /// π = 16·atan(1/5) − 4·atan(1/239) (Machin).
    pub const fn pi() -> Big {
        let mut a = atan_inv(5, false);
        mul_small(&mut a, 16);
        let mut b = atan_inv(239, false);
        mul_small(&mut b, 4);
        sub(&mut a, &b);
        a
    }

    /// ln 2 = 2·atanh(1/3).
    pub const fn ln2() -> Big {
        let mut a = atan_inv(3, true);
        mul_small(&mut a, 2);
        a
    }

    /// Bit `j` of `a` (bit 0: the integer limb's most significant bit, weight 2³¹).
    pub const fn bit(a: &Big, j: u32) -> u64 {
        ((a[(j / 32) as usize] >> (31 - j % 32)) & 1) as u64
    }

    /// `2^e` for a normal exponent.
    pub const fn pow2(e: i32) -> f64 {
        f64::from_bits(((1023 + e) as u64) << 52)
    }

    /// Bits `j0 .. j0 + n` of `a` (n ≤ 53) as an f64, scaled by `2^shift` (exact).
    pub const fn part(a: &Big, j0: u32, n: u32, shift: i32) -> f64 {
        let mut v: u64 = 0;
        let mut j = j0;
        while j < j0 + n {
            v = (v << 1) | bit(a, j);
            j += 1;
        }
        v as f64 * pow2(31 - (j0 + n - 1) as i32 + shift)
    }

    /// The binary digits of 2/π after the point, in u64 words (most significant bit first),
    /// preceded by one zero word: bit `i` after the point (weight 2⁻ⁱ, `i ≥ 1`) is global
    /// bit `i + 63`.
    pub const fn two_over_pi<const W: usize>() -> [u64; W] {
        let pi = pi();
        let mut r = [0u32; LIMBS];
        r[0] = 2;
        let mut out = [0u64; W];
        let mut i = 1;
        while i + 63 < W * 64 {
            mul_small(&mut r, 2);
            if ge(&r, &pi) {
                sub(&mut r, &pi);
                let g = i + 63;
                out[g / 64] |= 1 << (63 - g % 64);
            }
            i += 1;
        }
        out
    }
}

const PI_BIG: big::Big = big::pi();
const LN2_BIG: big::Big = big::ln2();
/// π/2 in three parts: 33 + 33 + 53 bits (π's bits 30.. shifted by one).
pub(super) const PIO2_1: f64 = big::part(&PI_BIG, 30, 33, -1);
pub(super) const PIO2_2: f64 = big::part(&PI_BIG, 63, 33, -1);
pub(super) const PIO2_3: f64 = big::part(&PI_BIG, 96, 53, -1);
/// π/2 as high (53 bits) + low parts, for the `atan` family.
pub(super) const PIO2_HI: f64 = big::part(&PI_BIG, 30, 53, -1);
pub(super) const PIO2_LO: f64 = big::part(&PI_BIG, 83, 53, -1);
/// ln 2 in two parts: 32 bits (so `k·LN2_HI` is exact for `|k| < 2²¹`) + 53 bits.
pub(super) const LN2_HI: f64 = big::part(&LN2_BIG, 32, 32, 0);
pub(super) const LN2_LO: f64 = big::part(&LN2_BIG, 64, 53, 0);
/// 2/π bits for Payne–Hanek: enough for the largest f64 exponent and a 192-bit window.
const TWO_OVER_PI: [u64; 21] = big::two_over_pi::<21>();

/// `1/n!` for `n` in `0..N`.
const fn inv_factorials<const N: usize>() -> [f64; N] {
    let mut out = [0.0; N];
    let mut f = 1.0f64;
    let mut n = 0;
    while n < N {
        if n > 0 {
            f *= n as f64;
        }
        out[n] = 1.0 / f;
        n += 1;
    }
    out
}
pub(super) const INV_FACT: [f64; 22] = inv_factorials::<22>();

/// Series coefficients: `c[i] = sign(i) / denom(i)` where `denom(i) = (2i + first)!` when
/// `factorial`, else `2i + first`; `sign(i)` alternates from `first_sign`.
const fn series<const N: usize>(
    first: usize,
    factorial: bool,
    first_sign: f64,
    alt: bool,
) -> [f64; N] {
    let mut out = [0.0; N];
    let mut i = 0;
    let mut sign = first_sign;
    while i < N {
        let n = 2 * i + first;
        let d = if factorial {
            INV_FACT[n]
        } else {
            1.0 / n as f64
        };
        out[i] = sign * d;
        if alt {
            sign = -sign;
        }
        i += 1;
    }
    out
}
/// `sin`: `−1/3!, 1/5!, …, 1/19!` (the coefficients of `r³ … r¹⁹`, divided by `r³`).
pub(super) const SIN_C: [f64; 9] = series::<9>(3, true, -1.0, true);
/// `cos`: `1/4!, −1/6!, …, 1/20!`.
pub(super) const COS_C: [f64; 9] = series::<9>(4, true, 1.0, true);
/// `atanh`: `1/3, 1/5, …, 1/23`.
pub(super) const LOG_C: [f64; 11] = series::<11>(3, false, 1.0, false);
/// `atan`: `−1/3, 1/5, …, 1/43`.
pub(super) const ATAN_C: [f64; 21] = series::<21>(3, false, -1.0, true);

/// Rounds to the nearest integer (ties to even) for `|t| < 2⁵¹`, by arithmetic alone.
fn round_int(t: f64) -> f64 {
    const MAGIC: f64 = 6755399441055744.0; // 1.5·2⁵²
    (t + MAGIC) - MAGIC
}

/// Evaluates `Σ c[i]·z^i` by Horner's rule.
fn horner(z: f64, c: &[f64]) -> f64 {
    let mut acc = 0.0;
    for &k in c.iter().rev() {
        acc = acc * z + k;
    }
    acc
}

// ---- exp and log ----

/// `eˣ`. Accuracy: see the module documentation.
pub fn exp(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    // Beyond ±1100 the result is 0 or inf; clamping keeps the scale factors normal.
    let x = x.clamp(-1100.0, 1100.0);
    let k = round_int(x * LOG2_E);
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let p = horner(r, &INV_FACT[..14]);
    let k = k as i32;
    let half = k / 2;
    p * big::pow2(half) * big::pow2(k - half)
}

/// `ln x` (NaN for `x < 0`, `-inf` for ±0).
pub fn log(x: f64) -> f64 {
    if x.is_nan() || x < 0.0 {
        return f64::NAN;
    }
    if x == 0.0 {
        return f64::NEG_INFINITY;
    }
    if x == f64::INFINITY {
        return x;
    }
    let (x, mut k) = if x < f64::MIN_POSITIVE {
        (x * big::pow2(54), -54)
    } else {
        (x, 0)
    };
    let bits = x.to_bits();
    k += ((bits >> 52) as i32) - 1023;
    let mut m = f64::from_bits((bits & ((1 << 52) - 1)) | (1023 << 52));
    if m > std::f64::consts::SQRT_2 {
        m *= 0.5;
        k += 1;
    }
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    // 2·atanh(s) = 2s·Σ z^i / (2i + 1).
    let series = s * z * horner(z, &LOG_C);
    let log_m = 2.0 * s + 2.0 * series;
    let k = k as f64;
    k * LN2_HI + (log_m + k * LN2_LO)
}

/// Whether a finite `y` is an integer, and whether it is odd (from its bits).
fn integer_parity(y: f64) -> (bool, bool) {
    let bits = y.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let mant = (bits & ((1 << 52) - 1)) | (1 << 52);
    if e < 0 {
        (y == 0.0, false)
    } else if e > 52 {
        (true, false)
    } else {
        let point = 52 - e as u32;
        let is_int = mant & ((1u64 << point) - 1) == 0;
        (is_int, is_int && (mant >> point) & 1 == 1)
    }
}

/// `x^y` with the C99 Annex F special cases (NaN for a negative finite base with a
/// non-integer exponent).
pub fn pow(x: f64, y: f64) -> f64 {
    let signaling = |v: f64| v.is_nan() && v.to_bits() & (1 << 51) == 0;
    if signaling(x) || signaling(y) {
        return f64::NAN; // as glibc: a signaling NaN is not the NaN of pow(NaN, 0) = 1
    }
    if y == 0.0 || x == 1.0 {
        return 1.0;
    }
    if x.is_nan() || y.is_nan() {
        return f64::NAN;
    }
    if y.is_infinite() {
        let ax = x.abs();
        return if ax == 1.0 {
            1.0
        } else if (ax > 1.0) == (y > 0.0) {
            f64::INFINITY
        } else {
            0.0
        };
    }
    let (integer, odd) = integer_parity(y);
    if x == 0.0 || x.is_infinite() {
        // 0^y and inf^y: the magnitude is 0 or inf; an odd exponent keeps the base's sign.
        let big_result = (x == 0.0) == (y < 0.0);
        let mag = if big_result { f64::INFINITY } else { 0.0 };
        return if odd && x.is_sign_negative() {
            -mag
        } else {
            mag
        };
    }
    if x < 0.0 && !integer {
        return f64::NAN;
    }
    let r = if integer && y.abs() <= 64.0 {
        // Small integer exponents by squaring: exact where the result is representable
        // (pow(-2, 3) = -8), within 2⁻⁴⁷ relative otherwise.
        let mut base = if y < 0.0 { 1.0 / x.abs() } else { x.abs() };
        let mut n = y.abs() as u32;
        let mut acc = 1.0;
        while n > 0 {
            if n & 1 == 1 {
                acc *= base;
            }
            n >>= 1;
            if n > 0 {
                base *= base;
            }
        }
        acc
    } else {
        exp(y * log(x.abs()))
    };
    if x < 0.0 && odd { -r } else { r }
}

// ---- sin, cos, tan ----

/// `x = n·π/2 + r` with `|r| ≤ π/4` (about): `(n mod 4, r, rl)`, the remainder as an
/// unevaluated sum `r + rl` (`|rl| ≤ ulp(r)`); `x` finite.
fn rem_pio2(x: f64) -> (u32, f64, f64) {
    let ax = x.abs();
    if ax <= std::f64::consts::FRAC_PI_4 {
        return (0, x, 0.0);
    }
    if ax < big::pow2(20) * FRAC_PI_2 {
        let n = round_int(x * FRAC_2_PI);
        let r2 = (x - n * PIO2_1) - n * PIO2_2;
        if r2.abs() >= big::pow2(-20) {
            let w = n * PIO2_3;
            let r = r2 - w;
            return ((n as i64 & 3) as u32, r, (r2 - r) - w);
        }
    }
    let (n, r, rl) = payne_hanek(ax);
    if x < 0.0 {
        ((4 - n) & 3, -r, -rl)
    } else {
        (n, r, rl)
    }
}

/// Splits `a` into two halves of 26 bits (Veltkamp), for exact products.
fn split(a: f64) -> (f64, f64) {
    let c = 134217729.0 * a; // 2²⁷ + 1
    let hi = c - (c - a);
    (hi, a - hi)
}

/// `a·b` exactly, as `p + e` (Dekker; `a·b` finite and not tiny).
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    let e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    (p, e)
}

/// Payne–Hanek reduction of a finite `x ≥ π/4`: `(n mod 4, r, rl)` with
/// `x·2/π = n + (r + rl)·2/π`, `|r| ≤ π/4`.
fn payne_hanek(x: f64) -> (u32, f64, f64) {
    let bits = x.to_bits();
    let m = (bits & ((1 << 52) - 1)) | (1 << 52);
    // x = m·2^e; bits of 2/π with weight 2^-i for i ≤ e − 2 give multiples of 4: skip them.
    let e = ((bits >> 52) as i32) - 1075;
    let g = (e + 62) as usize; // global index of bit i = e − 1
    let (k, sh) = (g / 64, (g % 64) as u32);
    let word = |i: usize| -> u64 {
        let hi = TWO_OVER_PI[k + i] << sh;
        if sh == 0 {
            hi
        } else {
            hi | (TWO_OVER_PI[k + i + 1] >> (64 - sh))
        }
    };
    let (w0, w1, w2) = (word(0), word(1), word(2));
    // m·w (53 × 192 bits) in four words; x·2/π mod 4 = m·w·2⁻¹⁹⁰.
    let t = m as u128 * w2 as u128;
    let r3 = t as u64;
    let t = m as u128 * w1 as u128 + (t >> 64);
    let r2 = t as u64;
    let t = m as u128 * w0 as u128 + (t >> 64);
    let r1 = t as u64;
    let mut n = ((r1 >> 62) & 3) as u32;
    // The fraction: 62 bits of r1, then r2, r3; take it as a signed value in [-½, ½).
    let mut frac = (((r1 & ((1 << 62) - 1)) as u128) << 64) | r2 as u128;
    let mut lo = r3;
    let negative = frac >> 125 == 1;
    if negative {
        n = (n + 1) & 3;
        // 2^190 − frac: negate the 190-bit number (frac, lo).
        let (nlo, borrow) = 0u64.overflowing_sub(lo);
        lo = nlo;
        frac = (1u128 << 126) - frac - borrow as u128;
    }
    // The magnitude as hi + tail (the tail: what hi's rounding left, and the low word).
    let hi = frac as f64;
    let rest = frac as i128 - hi as u128 as i128;
    let tail = rest as f64 + lo as f64 * big::pow2(-64);
    let (mh, ml) = (hi * big::pow2(-126), tail * big::pow2(-126));
    // (mh + ml)·(PIO2_HI + PIO2_LO), in double-double.
    let (p, pe) = two_prod(mh, PIO2_HI);
    let pe = pe + (mh * PIO2_LO + ml * PIO2_HI);
    let r = p + pe;
    let rl = pe - (r - p);
    if negative { (n, -r, -rl) } else { (n, r, rl) }
}

/// `sin r` for `|r| ≤ π/4`: the series to `r¹⁹`.
/// `rl`: the tail of the reduced argument (`sin(r + rl) ≈ sin r + rl·cos r`).
fn sin_kernel(r: f64, rl: f64) -> f64 {
    if r.abs() < big::pow2(-27) {
        return if rl == 0.0 { r } else { r + rl }; // r − r³/6 rounds to r; −0 stays −0
    }
    let z = r * r;
    r + (rl * (1.0 - 0.5 * z) + r * z * horner(z, &SIN_C))
}

/// `cos r` for `|r| ≤ π/4`: the series to `r²⁰`; `rl` as for [`sin_kernel`].
fn cos_kernel(r: f64, rl: f64) -> f64 {
    let z = r * r;
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    // 1 − z/2 as w plus what its rounding lost, then the series and the tail's term.
    let lost = (1.0 - w) - hz;
    w + ((z * z * horner(z, &COS_C) - r * rl) + lost)
}

/// `sin x`.
pub fn sin(x: f64) -> f64 {
    if !x.is_finite() {
        return f64::NAN;
    }
    let (n, r, rl) = rem_pio2(x);
    match n {
        0 => sin_kernel(r, rl),
        1 => cos_kernel(r, rl),
        2 => -sin_kernel(r, rl),
        _ => -cos_kernel(r, rl),
    }
}

/// `cos x`.
pub fn cos(x: f64) -> f64 {
    if !x.is_finite() {
        return f64::NAN;
    }
    let (n, r, rl) = rem_pio2(x);
    match n {
        0 => cos_kernel(r, rl),
        1 => -sin_kernel(r, rl),
        2 => -cos_kernel(r, rl),
        _ => sin_kernel(r, rl),
    }
}

/// `tan x`.
pub fn tan(x: f64) -> f64 {
    if !x.is_finite() {
        return f64::NAN;
    }
    let (n, r, rl) = rem_pio2(x);
    let (s, c) = (sin_kernel(r, rl), cos_kernel(r, rl));
    if n & 1 == 0 { s / c } else { -c / s }
}

// ---- the atan family ----

/// `c − (h + l)` for `|c| ≥ |h|`, as a rounded sum and its tail (`cl`: `c`'s tail).
fn minus_dd(c: f64, cl: f64, (h, l): (f64, f64)) -> (f64, f64) {
    let s = c - h;
    (s, ((c - s) - h) + (cl - l))
}

/// `atan t` for `t ≥ 0` (`t` may be +inf), as a rounded value and its tail.
fn atan_dd(t: f64) -> (f64, f64) {
    if t > 1.0 {
        return minus_dd(PIO2_HI, PIO2_LO, atan_dd(1.0 / t));
    }
    let tan_pi_8 = std::f64::consts::SQRT_2 - 1.0;
    let (base_hi, base_lo, u) = if t > tan_pi_8 {
        (0.5 * PIO2_HI, 0.5 * PIO2_LO, (t - 1.0) / (t + 1.0))
    } else {
        (0.0, 0.0, t)
    };
    let z = u * u;
    let a = u + u * z * horner(z, &ATAN_C);
    let s = base_hi + a;
    (s, ((base_hi - s) + a) + base_lo)
}

/// `atan t` for `t ≥ 0`.
fn atan_pos(t: f64) -> f64 {
    let (h, l) = atan_dd(t);
    h + l
}

/// `atan x`.
pub fn atan(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    let a = atan_pos(x.abs());
    if x.is_sign_negative() { -a } else { a }
}

/// `atan2(y, x)`: the angle of `(x, y)`, with the C99 Annex F special cases.
pub fn atan2(y: f64, x: f64) -> f64 {
    if x.is_nan() || y.is_nan() {
        return f64::NAN;
    }
    let pi_hi = 2.0 * PIO2_HI;
    let pi_lo = 2.0 * PIO2_LO;
    let a = if y == 0.0 {
        if x.is_sign_negative() {
            pi_hi + pi_lo
        } else {
            0.0
        }
    } else {
        // Two infinities: the angle of (±1, ±1).
        let t = if x.is_infinite() && y.is_infinite() {
            atan_dd(1.0)
        } else {
            atan_dd(y.abs() / x.abs())
        };
        let (h, l) = if x.is_sign_negative() {
            minus_dd(pi_hi, pi_lo, t)
        } else {
            t
        };
        h + l
    };
    if y.is_sign_negative() { -a } else { a }
}

/// `√((1 − a)(1 + a))` for `0 ≤ a ≤ 1`.
fn cofactor(a: f64) -> f64 {
    ((1.0 - a) * (1.0 + a)).sqrt()
}

/// `asin x` (NaN for `|x| > 1`).
pub fn asin(x: f64) -> f64 {
    if x.is_nan() || x.abs() > 1.0 {
        return f64::NAN;
    }
    let a = atan_pos(x.abs() / cofactor(x.abs()));
    if x.is_sign_negative() { -a } else { a }
}

/// `acos x` (NaN for `|x| > 1`).
pub fn acos(x: f64) -> f64 {
    if x.is_nan() || x.abs() > 1.0 {
        return f64::NAN;
    }
    atan2(cofactor(x.abs()), x)
}

// ---- f32: the f64 functions, rounded once ----

/// `eˣ` in f32: [`exp`] rounded.
pub fn exp_f32(x: f32) -> f32 {
    exp(x as f64) as f32
}
/// `ln x` in f32: [`log`] rounded.
pub fn log_f32(x: f32) -> f32 {
    log(x as f64) as f32
}
/// `x^y` in f32: [`pow`] rounded.
pub fn pow_f32(x: f32, y: f32) -> f32 {
    // Widening may quiet a signaling NaN: look at the f32 bits.
    let signaling = |v: f32| v.is_nan() && v.to_bits() & (1 << 22) == 0;
    if signaling(x) || signaling(y) {
        return f32::NAN;
    }
    pow(x as f64, y as f64) as f32
}
/// `sin x` in f32: [`sin`] rounded.
pub fn sin_f32(x: f32) -> f32 {
    sin(x as f64) as f32
}
/// `cos x` in f32: [`cos`] rounded.
pub fn cos_f32(x: f32) -> f32 {
    cos(x as f64) as f32
}
/// `tan x` in f32: [`tan`] rounded.
pub fn tan_f32(x: f32) -> f32 {
    tan(x as f64) as f32
}
/// `asin x` in f32: [`asin`] rounded.
pub fn asin_f32(x: f32) -> f32 {
    asin(x as f64) as f32
}
/// `acos x` in f32: [`acos`] rounded.
pub fn acos_f32(x: f32) -> f32 {
    acos(x as f64) as f32
}
/// `atan x` in f32: [`atan`] rounded.
pub fn atan_f32(x: f32) -> f32 {
    atan(x as f64) as f32
}
/// `atan2(y, x)` in f32: [`atan2`] rounded.
pub fn atan2_f32(y: f32, x: f32) -> f32 {
    atan2(y as f64, x as f64) as f32
}

#[cfg(test)]
mod tests;
