//! Filtered lookups in a mipmap pyramid: closest, bilinear, trilinear and anisotropic, with
//! the wrap modes periodic, clamp, mirror and black.
//!
//! Coordinates: `uv = (0, 0)` is the image's bottom-left corner, `(1, 1)` its top-right;
//! texel centres of a `w × h` level are at `((i + ½)/w, 1 − (j + ½)/h)` for row `j` from
//! the top. The **footprint** of a lookup is the parallelogram `uv + s·duv[0] + t·duv[1]`,
//! `s, t ∈ [−½, ½]`, where `duv[0]` and `duv[1]` are uv's screen-space derivatives
//! (∂uv/∂x, ∂uv/∂y).
//!
//! - **closest**: the level-0 texel holding `uv`.
//! - **bilinear**: bilinear interpolation between level-0 texel centres, whatever the
//!   footprint (with periodic wrap: bit for bit the lookup of the texture system before
//!   mipmaps).
//! - **trilinear**: bilinear in the two levels around `lod = log2(width)` blended by its
//!   fraction, `width` the footprint's longer axis in level-0 texels.
//! - **anisotropic**: trilinear probes spread along the footprint's major axis, each at the
//!   level of the footprint's width across it (its area over the major axis' length, at
//!   least 1/[`MAX_ANISOTROPY`] of the major axis: past that ratio the level rises instead).
//!   The major axis, measured in probe widths (`L ≤ 16`), is cut into unit cells centred on
//!   the integers `−8 … 8`; each cell's part inside `[−L/2, L/2]` gets one probe at its centre
//!   weighted by its length. Weights and positions are continuous in `L`, and a probe enters
//!   or leaves with weight 0, so the result is continuous in uv and the derivatives (no jump
//!   as the probe count changes) — what lets the GPU's port of this function agree with it.
//!
//! Only `+ − × ÷`, `floor`, `sqrt`, comparisons and [`log2`] (ours, below) are used, generic
//! over [`Real`], so the interpreter and the JIT (which both call this function) agree bit for
//! bit, and f32 and f64 runs differ only by rounding. Non-finite or huge derivatives are
//! clamped (NaN counts as 0, ±∞ as ±2²⁰ texels); non-finite uv reads a fixed texel (as
//! `(floor(x) as i32)` saturates and NaN converts to 0): never a panic, never an index out of
//! range.

use super::mip::Level;
use shadenet_graph::ir::{Filter, Sampling, Wrap};
use shadenet_graph::ops::Real;

/// The largest footprint aspect ratio filtered at the footprint's true width; beyond it the
/// probes are wider (the level rises) and blur across the major axis.
pub const MAX_ANISOTROPY: f64 = 16.0;

/// The cells along the major axis are centred on `−MAX_PROBE ..= MAX_PROBE`: `L ≤ 16`
/// touches at most 17 of them.
const MAX_PROBE: i32 = 8;

/// Derivative components (in level-0 texels) are clamped to ±this: far beyond the coarsest
/// level of the largest texture (2¹⁶ a side), and small enough that squares stay finite.
const MAX_TEXELS: f64 = (1u64 << 20) as f64;

/// `log2(1 + f)` on `[0, 1)`: a degree-5 least-squares fit with `p(0) = 0` and `p(1) = 1`
/// (the last coefficient is one minus the others), increasing, within 2.2e-5.
const LOG2_FIT: [f64; 5] = {
    let c = [
        1.441740302903869,
        -0.7077701801565556,
        0.41234421612858124,
        -0.19031902887652355,
    ];
    [c[0], c[1], c[2], c[3], 1.0 - c[0] - c[1] - c[2] - c[3]]
};

/// `log2 x` for `x ≥ 1`, continuous and increasing: the exponent of `x` plus [`LOG2_FIT`]
/// of its mantissa's fraction (so the pieces join at powers of two, where it is exact;
/// within 2.2e-5 of the true value elsewhere). Computed in f64 from the exact widening of
/// `x`, the polynomial by Estrin's scheme (short latency: the level of a lookup waits on
/// it); below 1 or NaN it is 0, `+∞` gives 1024.
pub fn log2<F: Real>(x: F) -> F {
    let x = x.to_f64();
    if x.is_nan() || x < 1.0 {
        return F::ZERO;
    }
    if !x.is_finite() {
        return F::from_f64(1024.0);
    }
    let bits = x.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i64 - 1023;
    let f = f64::from_bits((bits & ((1u64 << 52) - 1)) | (1023u64 << 52)) - 1.0;
    let c = LOG2_FIT;
    let f2 = f * f;
    let p = f * ((c[0] + c[1] * f) + f2 * ((c[2] + c[3] * f) + f2 * c[4]));
    F::from_f64(e as f64 + p)
}

/// `floor(x)`, exactly, without the platform's `floor` where `|x| < 2³¹` (baseline x86-64 has
/// no rounding instruction: `f32::floor` is a call there). Below 2³¹ the conversion to i32
/// truncates exactly and the truncated value converts back exactly (a float of magnitude
/// 2²⁴ or more is already an integer); elsewhere, and for NaN, the platform's.
#[inline(always)]
fn floor<F: Real>(x: F) -> F {
    floor_i(x).0
}

/// [`floor`] and the same value as an i32 (`floor(x).to_i32()`: saturating, NaN → 0).
#[inline(always)]
fn floor_i<F: Real>(x: F) -> (F, i32) {
    let limit = F::from_f64(2_147_483_648.0);
    if x < limit && x > -limit {
        let i = x.to_i32();
        let t = F::from_i32(i);
        // x > −2³¹, so i − 1 ≥ −2³¹.
        if t > x { (t - F::ONE, i - 1) } else { (t, i) }
    } else {
        let t = x.floor();
        (t, t.to_i32())
    }
}

#[inline(always)]
fn min<F: Real>(a: F, b: F) -> F {
    if b < a { b } else { a }
}

#[inline(always)]
fn max<F: Real>(a: F, b: F) -> F {
    if b > a { b } else { a }
}

/// `i` modulo `n` (`0 < n ≤ 2¹⁶`), without a division when `i` is already in `[0, n)` (the
/// common case: uv within the image).
#[inline(always)]
fn periodic(i: i64, n: i64) -> i64 {
    if (i as u64) < n as u64 {
        i
    } else {
        i.rem_euclid(n)
    }
}

/// `i` modulo `n` (`n > 0`) in i32: no division when `i` is in `[0, n)` already.
#[inline(always)]
fn periodic32(i: i32, n: i32) -> i32 {
    if (i as u32) < n as u32 {
        return i;
    }
    let r = i % n;
    if r < 0 { r + n } else { r }
}

/// A texel index along one axis of `n` texels under a wrap mode; `None` reads black.
#[inline(always)]
fn wrap1(i: i64, n: i64, wrap: Wrap) -> Option<usize> {
    match wrap {
        Wrap::Periodic => Some(periodic(i, n) as usize),
        Wrap::Clamp => Some(i.clamp(0, n - 1) as usize),
        Wrap::Mirror => {
            let r = periodic(i, 2 * n);
            Some(if r < n { r } else { 2 * n - 1 - r } as usize)
        }
        Wrap::Black => (0..n).contains(&i).then_some(i as usize),
    }
}

/// The indices of `i` and `i + 1`.
#[inline(always)]
fn wrap2(i: i64, n: i64, wrap: Wrap) -> (Option<usize>, Option<usize>) {
    if wrap == Wrap::Periodic {
        let a = periodic(i, n);
        let b = if a + 1 == n { 0 } else { a + 1 };
        return (Some(a as usize), Some(b as usize));
    }
    (wrap1(i, n, wrap), wrap1(i + 1, n, wrap))
}

#[inline(always)]
fn fetch<F: Real>(level: &Level, x: Option<usize>, y: Option<usize>) -> [F; 4] {
    match (x, y) {
        (Some(x), Some(y)) => level
            .texels
            .get(y * level.width as usize + x)
            .map_or([F::ZERO; 4], |t| t.map(|c| F::from_f64(c as f64))),
        _ => [F::ZERO; 4],
    }
}

/// The texel of `level` holding `uv`.
pub fn closest<F: Real>(level: &Level, uv: [F; 2], wrap: [Wrap; 2]) -> [F; 4] {
    let x = floor(uv[0] * F::from_f64(level.width as f64));
    let y = floor((F::ONE - uv[1]) * F::from_f64(level.height as f64));
    let xi = wrap1(x.to_i32() as i64, level.width as i64, wrap[0]);
    let yi = wrap1(y.to_i32() as i64, level.height as i64, wrap[1]);
    fetch(level, xi, yi)
}

/// Bilinear interpolation between the texel centres of `level` around `uv`.
#[inline(always)]
pub fn bilinear<F: Real>(level: &Level, uv: [F; 2], wrap: [Wrap; 2]) -> [F; 4] {
    let half = F::from_f64(0.5);
    let x = uv[0] * F::from_f64(level.width as f64) - half;
    let y = (F::ONE - uv[1]) * F::from_f64(level.height as f64) - half;
    let ((x0, xi), (y0, yi)) = (floor_i(x), floor_i(y));
    let (fx, fy) = (x - x0, y - y0);
    let (fx, fy) = (
        if fx.is_finite() { fx } else { F::ZERO },
        if fy.is_finite() { fy } else { F::ZERO },
    );
    let [t00, t10, t01, t11] = if wrap == [Wrap::Periodic; 2] {
        // The common case without options: `i` and `i + 1` modulo the size, in i32 (the
        // lattice coordinates come from `to_i32`; `i + 1` is never formed, so it cannot
        // overflow).
        let (w, h) = (level.width as i32, level.height as i32);
        let xa = periodic32(xi, w);
        let xb = if xa + 1 == w { 0 } else { xa + 1 };
        let ya = periodic32(yi, h);
        let yb = if ya + 1 == h { 0 } else { ya + 1 };
        let (ra, rb) = ((ya * w) as usize, (yb * w) as usize);
        let t = |i: usize| -> [F; 4] {
            level
                .texels
                .get(i)
                .map_or([F::ZERO; 4], |t| t.map(|c| F::from_f64(c as f64)))
        };
        [
            t(ra + xa as usize),
            t(ra + xb as usize),
            t(rb + xa as usize),
            t(rb + xb as usize),
        ]
    } else {
        let (xa, xb) = wrap2(xi as i64, level.width as i64, wrap[0]);
        let (ya, yb) = wrap2(yi as i64, level.height as i64, wrap[1]);
        [
            fetch::<F>(level, xa, ya),
            fetch::<F>(level, xb, ya),
            fetch::<F>(level, xa, yb),
            fetch::<F>(level, xb, yb),
        ]
    };
    let mut out = [F::ZERO; 4];
    for c in 0..4 {
        let top = t00[c] + fx * (t10[c] - t00[c]);
        let bottom = t01[c] + fx * (t11[c] - t01[c]);
        out[c] = top + fy * (bottom - top);
    }
    out
}

/// A level of detail resolved: the finer level and the weight of the next one.
#[derive(Clone, Copy)]
struct Lod<F> {
    level: usize,
    /// In `[0, 1)`; 0 reads the finer level alone.
    t: F,
}

impl<F: Real> Lod<F> {
    /// `lod` in `[0, levels − 1]`.
    #[inline]
    fn new(lod: F, levels: usize) -> Lod<F> {
        let l0 = floor(lod);
        let level = (l0.to_i32().max(0) as usize).min(levels - 1);
        let t = if level + 1 < levels {
            lod - l0
        } else {
            F::ZERO
        };
        Lod { level, t }
    }
}

/// Bilinear in the levels of `lod`, blended by its weight.
#[inline(always)]
fn trilinear<F: Real>(levels: &[Level], uv: [F; 2], lod: Lod<F>, wrap: [Wrap; 2]) -> [F; 4] {
    let a = bilinear(&levels[lod.level], uv, wrap);
    if lod.t <= F::ZERO {
        return a;
    }
    let b = bilinear(&levels[lod.level + 1], uv, wrap);
    let mut out = a;
    for c in 0..4 {
        out[c] = a[c] + lod.t * (b[c] - a[c]);
    }
    out
}

/// The level for a footprint `width` level-0 texels wide: `log2(width)` within
/// `[0, levels − 1]` (0 below one texel).
#[inline(always)]
fn lod_of<F: Real>(width: F, levels: usize) -> F {
    min(log2(width), F::from_f64((levels - 1) as f64))
}

/// A derivative component clamped to ±[`MAX_TEXELS`] (NaN → 0).
#[inline(always)]
fn clamp_texels<F: Real>(x: F) -> F {
    let m = F::from_f64(MAX_TEXELS);
    if x > m {
        m
    } else if x < -m {
        -m
    } else if x.is_nan() {
        F::ZERO
    } else {
        x
    }
}

/// A lookup in the pyramid `levels` (finest first, non-empty): see the module's doc.
pub fn lookup<F: Real>(
    levels: &[Level],
    uv: [F; 2],
    duv: [[F; 2]; 2],
    sampling: Sampling,
) -> [F; 4] {
    let Some(base) = levels.first() else {
        return [F::ZERO; 4];
    };
    let wrap = sampling.wrap;
    if sampling.filter == Filter::Closest {
        return closest(base, uv, wrap);
    }
    if sampling.filter == Filter::Bilinear {
        return bilinear(base, uv, wrap);
    }
    // The derivatives in level-0 texels.
    let (w, h) = (
        F::from_f64(base.width as f64),
        F::from_f64(base.height as f64),
    );
    let a = [clamp_texels(duv[0][0] * w), clamp_texels(duv[0][1] * h)];
    let b = [clamp_texels(duv[1][0] * w), clamp_texels(duv[1][1] * h)];
    let (la2, lb2) = (a[0] * a[0] + a[1] * a[1], b[0] * b[0] + b[1] * b[1]);
    let (major, lmaj2) = if la2 >= lb2 { (a, la2) } else { (b, lb2) };
    if sampling.filter == Filter::Trilinear {
        // log2 of the length is half the log2 of its square: no square root on the way to
        // the level.
        let lod = F::from_f64(0.5) * log2(lmaj2);
        let lod = Lod::new(
            min(lod, F::from_f64((levels.len() - 1) as f64)),
            levels.len(),
        );
        return trilinear(levels, uv, lod, wrap);
    }
    let lmaj = lmaj2.sqrt();
    // Anisotropic: the width across the major axis is the parallelogram's area over it.
    let area = (a[0] * b[1] - a[1] * b[0]).abs();
    let lmin = if lmaj > F::ZERO { area / lmaj } else { F::ZERO };
    let probe = max(max(lmin, lmaj / F::from_f64(MAX_ANISOTROPY)), F::ONE);
    let lod = Lod::new(lod_of(probe, levels.len()), levels.len());
    let len = lmaj / probe;
    let half = len * F::from_f64(0.5);
    let kmax = floor(half + F::from_f64(0.5)).to_i32().clamp(0, MAX_PROBE);
    if kmax == 0 {
        return trilinear(levels, uv, lod, wrap);
    }
    // One probe width along the major axis, in uv.
    let step = [major[0] / w / len, major[1] / h / len];
    let mut acc = [F::ZERO; 4];
    let mut total = F::ZERO;
    for k in -kmax..=kmax {
        let kf = F::from_i32(k);
        let lo = max(kf - F::from_f64(0.5), -half);
        let hi = min(kf + F::from_f64(0.5), half);
        if hi <= lo {
            continue;
        }
        let weight = hi - lo;
        let at = (lo + hi) * F::from_f64(0.5);
        let p = [uv[0] + step[0] * at, uv[1] + step[1] * at];
        let t = trilinear(levels, p, lod, wrap);
        for c in 0..4 {
            acc[c] = acc[c] + weight * t[c];
        }
        total = total + weight;
    }
    acc.map(|c| c / total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::mip::Pyramid;

    fn sampling(filter: Filter, wrap: Wrap) -> Sampling {
        Sampling {
            filter,
            wrap: [wrap; 2],
        }
    }

    /// The bilinear lookup of the texture system before mipmaps (periodic), verbatim.
    fn old_sample<F: Real>(l: &Level, uv: [F; 2]) -> [F; 4] {
        let texel = |x: i64, y: i64| -> [F; 4] {
            let x = x.rem_euclid(l.width as i64) as usize;
            let y = y.rem_euclid(l.height as i64) as usize;
            l.texels[y * l.width as usize + x].map(|c| F::from_f64(c as f64))
        };
        let half = F::from_f64(0.5);
        let x = uv[0] * F::from_f64(l.width as f64) - half;
        let y = (F::ONE - uv[1]) * F::from_f64(l.height as f64) - half;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (fx, fy) = (
            if fx.is_finite() { fx } else { F::ZERO },
            if fy.is_finite() { fy } else { F::ZERO },
        );
        let (xi, yi) = (x0.to_i32() as i64, y0.to_i32() as i64);
        let t00 = texel(xi, yi);
        let t10 = texel(xi + 1, yi);
        let t01 = texel(xi, yi + 1);
        let t11 = texel(xi + 1, yi + 1);
        std::array::from_fn(|c| {
            let top = t00[c] + fx * (t10[c] - t00[c]);
            let bottom = t01[c] + fx * (t11[c] - t01[c]);
            top + fy * (bottom - top)
        })
    }

    /// A small image with distinct texels.
    fn distinct(w: u32, h: u32) -> Pyramid {
        Pyramid::build(
            w,
            h,
            (0..w * h)
                .map(|i| {
                    [
                        i as f32,
                        (i * 7 % 5) as f32 * 0.25,
                        0.5,
                        1.0 - i as f32 * 0.01,
                    ]
                })
                .collect(),
        )
    }

    /// A generator of numbers in [0, 1) (xorshift), deterministic.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    const ODD_UVS: [[f64; 2]; 8] = [
        [f64::NAN, 0.3],
        [0.2, f64::INFINITY],
        [f64::NEG_INFINITY, f64::NAN],
        [1e30, -1e30],
        [3e9, 0.5],
        [-0.0, 1.0],
        [1.0, 0.0],
        [-7.25, 13.5],
    ];

    #[test]
    fn bilinear_is_the_old_lookup_bit_for_bit() {
        let p = distinct(5, 3);
        let l = &p.levels()[0];
        let mut rng = Rng(7);
        let mut uvs: Vec<[f64; 2]> = (0..2000)
            .map(|_| [rng.next() * 6.0 - 3.0, rng.next() * 6.0 - 3.0])
            .collect();
        uvs.extend(ODD_UVS);
        let s = sampling(Filter::Bilinear, Wrap::Periodic);
        for uv in uvs {
            for duv in [[[0.0; 2]; 2], [[0.3, 0.0], [0.0, 9.0]], [[f64::NAN; 2]; 2]] {
                let a = lookup(p.levels(), uv, duv, s);
                let b = old_sample(l, uv);
                assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "{uv:?}");
                let uv32 = uv.map(|x| x as f32);
                let duv32 = duv.map(|d| d.map(|x| x as f32));
                let a = lookup(p.levels(), uv32, duv32, s);
                let b = old_sample(l, uv32);
                assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "{uv:?}");
            }
        }
    }

    /// The texel index `i` reads along an axis of 4 texels under `wrap` (the definitions,
    /// spelled out case by case).
    fn expected(i: i64, wrap: Wrap) -> Option<i64> {
        // Indices −8 … 11.
        const PERIODIC: [i64; 20] = [0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3];
        const MIRROR: [i64; 20] = [0, 1, 2, 3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0, 1, 2, 3];
        let k = (i + 8) as usize;
        match wrap {
            Wrap::Periodic => Some(PERIODIC[k]),
            Wrap::Mirror => Some(MIRROR[k]),
            Wrap::Clamp => Some(i.clamp(0, 3)),
            Wrap::Black => (0..4).contains(&i).then_some(i),
        }
    }

    #[test]
    fn wrap_modes_are_exact() {
        // 4 × 4 distinct texels (a power of two: texel centres' uv are exact).
        let p = distinct(4, 4);
        let l = &p.levels()[0];
        for wrap in [Wrap::Periodic, Wrap::Clamp, Wrap::Mirror, Wrap::Black] {
            for i in -8i64..=11 {
                for j in -8i64..=11 {
                    // uv of texel (i, j)'s centre (j counted from the top).
                    let uv = [(i as f64 + 0.5) / 4.0, 1.0 - (j as f64 + 0.5) / 4.0];
                    let want = match (expected(i, wrap), expected(j, wrap)) {
                        (Some(x), Some(y)) => l.texels[(y * 4 + x) as usize].map(f64::from),
                        _ => [0.0; 4],
                    };
                    for filter in [Filter::Closest, Filter::Bilinear] {
                        let got = lookup(p.levels(), uv, [[0.0; 2]; 2], sampling(filter, wrap));
                        assert_eq!(got, want, "{wrap:?} {filter:?} texel ({i}, {j})");
                    }
                }
            }
            // Half way between texels 3 and 4 of the top row: the mean of what both read.
            let uv = [1.0, 1.0 - 0.5 / 4.0];
            let got = lookup(
                p.levels(),
                uv,
                [[0.0; 2]; 2],
                sampling(Filter::Bilinear, wrap),
            );
            let read = |i: i64| expected(i, wrap).map_or(0.0, |x| l.texels[x as usize][0] as f64);
            assert_eq!(got[0], (read(3) + read(4)) / 2.0, "{wrap:?}");
        }
    }

    #[test]
    fn closest_reads_the_texel_under_uv() {
        let p = distinct(4, 3);
        let l = &p.levels()[0];
        for j in 0..3 {
            for i in 0..4 {
                let want = l.texels[j * 4 + i].map(f64::from);
                // Anywhere inside the texel, derivatives ignored.
                for (fx, fy) in [(0.01, 0.01), (0.5, 0.5), (0.99, 0.99), (0.0, 0.999)] {
                    let uv = [(i as f64 + fx) / 4.0, 1.0 - (j as f64 + fy) / 3.0];
                    let got = lookup(
                        p.levels(),
                        uv,
                        [[5.0, 1.0], [0.0, 3.0]],
                        sampling(Filter::Closest, Wrap::Clamp),
                    );
                    assert_eq!(got, want, "texel ({i}, {j}) at {uv:?}");
                }
            }
        }
    }

    #[test]
    fn non_finite_and_huge_inputs_give_finite_fixed_results() {
        let p = distinct(6, 5);
        let duvs = [
            [[f64::NAN; 2]; 2],
            [[f64::INFINITY, 0.0], [0.0, f64::NEG_INFINITY]],
            [[1e30, -1e30], [1e-30, 1e30]],
            [[1e300, 0.0], [0.0, 1e-300]],
            [[0.0; 2]; 2],
        ];
        for filter in [
            Filter::Closest,
            Filter::Bilinear,
            Filter::Trilinear,
            Filter::Anisotropic,
        ] {
            for wrap in [Wrap::Periodic, Wrap::Clamp, Wrap::Mirror, Wrap::Black] {
                for uv in ODD_UVS.iter().chain(&[[0.3, 0.6]]) {
                    for duv in duvs {
                        let s = sampling(filter, wrap);
                        let a = lookup(p.levels(), *uv, duv, s);
                        assert!(
                            a.iter().all(|c| c.is_finite()),
                            "{filter:?} {wrap:?} {uv:?} {duv:?}: {a:?}"
                        );
                        assert_eq!(a, lookup(p.levels(), *uv, duv, s));
                        let uv32 = uv.map(|x| x as f32);
                        let duv32 = duv.map(|d| d.map(|x| x as f32));
                        let b = lookup(p.levels(), uv32, duv32, s);
                        assert!(
                            b.iter().all(|c| c.is_finite()),
                            "{filter:?} {wrap:?} {uv:?} {duv:?}: {b:?}"
                        );
                    }
                }
            }
        }
        // NaN derivatives are zero derivatives: level 0.
        let s = sampling(Filter::Anisotropic, Wrap::Periodic);
        assert_eq!(
            lookup(p.levels(), [0.3, 0.6], [[f64::NAN; 2]; 2], s),
            lookup(p.levels(), [0.3, 0.6], [[0.0; 2]; 2], s)
        );
    }

    #[test]
    fn our_log2_is_close_continuous_and_exact_at_powers_of_two() {
        for k in 0..60 {
            assert_eq!(log2((1u64 << k) as f64), k as f64);
        }
        let mut prev = 0.0f64;
        let mut x = 1.0f64;
        while x < 1e6 {
            let l = log2(x);
            assert!((l - x.log2()).abs() < 2.5e-5, "{x}: {l}");
            assert!(l >= prev, "not increasing at {x}");
            prev = l;
            x *= 1.0007;
        }
        assert_eq!(log2(0.5f32), 0.0);
        assert_eq!(log2(f32::NAN), 0.0);
        assert_eq!(log2(f64::INFINITY), 1024.0);
    }
}
