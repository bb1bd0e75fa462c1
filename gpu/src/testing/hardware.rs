//! The hardware accuracy contract ([`crate::Accuracy::Hardware`]) as code: what the tests
//! accept from a hardware GPU where a software rasterizer must match the CPU bit for bit.
//!
//! WGSL lets a driver flush subnormal inputs and results to zero, compute `sqrt` and `x / y`
//! within a few ulps (division only for |y| in [2⁻¹²⁶, 2¹²⁶]), contract `a * b + c` into a
//! fused multiply-add, and assume that no infinity or NaN occurs. An NVIDIA H100 does all of
//! these (`docs/gpu.md`, "Accuracy"). The contract, one op at a time ([`close`]):
//!
//! - the result may be the CPU's for the operands with subnormals flushed to ±0 (the caller
//!   evaluates the CPU on [`ftz_variants`]), and a subnormal result may be flushed;
//!   zeros of either sign are equal ([`ftz_equal`]);
//! - operands that are infinite, NaN or of magnitude ≥ 2¹²⁶ ([`free_operand`]) leave the
//!   result free, as WGSL does;
//! - otherwise the result is within [`OpClass::ulps`] ulps of the CPU's, or that many ulps
//!   of the operation's scale (a cancellation after a fused multiply-add is exact where
//!   the CPU rounded the product: its error is an ulp of the product, not of the result).
//!
//! Whole programs ([`check_outputs`]) go through many ops and through branches, floors and
//! noise lattices, where a 1-ulp difference moves a result by a whole step: every output
//! within [`PROGRAM_ULPS`] ulps or [`PROGRAM_ABS`] (relative to max(1, |CPU's|)), except at
//! most [`PROGRAM_OUTLIERS`] of the outputs compared; fragments with an input outside the
//! domain ([`fragment_in_domain`]) are not compared.

use super::{Bound, Transcendental, same, ulps};
use shadenet_graph::ir::{Op, Program, Stream};
use shadenet_runtime::Fragment;

/// 2¹²⁶: operands at or above it leave a result free (WGSL's division bound stops there,
/// and the reciprocal of such a divisor is subnormal, flushed to 0).
pub const HUGE: f32 = 8.507_059e37;

/// The largest |input| of a fragment still compared by [`check_outputs`]: the device's
/// `sin` and `cos` err by about 2⁻²²·|x| (`documented in docs/gpu.md`), 2⁻⁸ at 2¹⁴.
pub const FRAGMENT_MAX: f32 = 16384.0;

/// Programs: the ulps an output may be off by ...
pub const PROGRAM_ULPS: u64 = 64;
/// ... or the difference relative to max(1, |CPU's output|) ...
pub const PROGRAM_ABS: f32 = 1e-5;
/// ... and the share of the compared outputs allowed beyond both (a few ulps moved across a
/// comparison, `floor`, a noise lattice, a branch or a lobe choice). Measured on an H100
/// over the compared fragments: a mirror's sampled lobes 5.6 %, a conductor's 5.2 %, a
/// random program 2.9 %; the mutations the contract must catch put 20–80 % beyond.
pub const PROGRAM_OUTLIERS: f64 = 0.10;

/// `x` with a subnormal flushed to the zero of its sign.
pub fn flush(x: f32) -> f32 {
    if x.is_subnormal() {
        0.0f32.copysign(x)
    } else {
        x
    }
}

/// The operand vectors whose CPU results a flushing device may give: every subnormal
/// operand kept or flushed to +0 or to -0, each independently (WGSL does not say which
/// zero; an H100 gives π for the atan2 of 1e-45 and 1e-45, the CPU's for +0 and -0). One
/// vector when no operand is subnormal.
pub fn ftz_variants(args: &[f32]) -> Vec<Vec<f32>> {
    let mut v = vec![args.to_vec()];
    // Each subnormal operand kept, or flushed to +0 or to -0, independently (the H100 flushed
    // the operands of one atan2 to zeros of different signs): 3^k vectors for k subnormal
    // operands, k at most a handful.
    for (i, x) in args.iter().enumerate() {
        if !x.is_subnormal() {
            continue;
        }
        let mut more = Vec::new();
        for base in &v {
            for zero in [0.0f32, -0.0] {
                let mut w: Vec<f32> = base.clone();
                w[i] = zero;
                more.push(w);
            }
        }
        v.extend(more);
    }
    v
}

/// Equal under flushing: the same bits, both NaN, or equal values once subnormals are
/// flushed (zeros of either sign are equal).
pub fn ftz_equal(got: f32, want: f32) -> bool {
    same(got, want)
        || flush(got) == flush(want)
        // The device flushes a result it finds tiny *before* rounding: the CPU's result
        // may have rounded up to the smallest normal (MIN_POSITIVE · 0.99999994 on an H100).
        || (got == 0.0 && want.abs() == f32::MIN_POSITIVE)
}

/// Whether an operand leaves the result free on hardware: infinite, NaN, |x| ≥ 2¹²⁶, or
/// 0 < |x| < 2⁻⁶⁰ (its products and quotients with ordinary values may be subnormal
/// intermediates, which the device flushes: `length(1e-20, 1e-38)` is 0 on an H100, and
/// `mod(1e-38, -2.5)` floors a flushed quotient).
pub fn free_operand(x: f32) -> bool {
    !x.is_finite() || x.abs() >= HUGE || (x != 0.0 && x.abs() < TINY)
}

/// The magnitude under which an operand is free ([`free_operand`]): 2⁻⁶⁰.
pub const TINY: f32 = 8.673_617e-19;

/// One ulp at the magnitude of `x` (the spacing of the floats of its binade; 2⁻¹⁴⁹ below
/// the normal range, infinity for a non-finite `x`).
pub fn ulp_at(x: f32) -> f32 {
    let a = x.abs();
    if !a.is_finite() {
        return f32::INFINITY;
    }
    if a < f32::MIN_POSITIVE {
        return f32::from_bits(1);
    }
    let exp = a.to_bits() & 0x7f80_0000;
    // 2^(e - 23): an exponent field 23 lower (at least 1: the smallest normal's ulp).
    let e = (exp >> 23) as i32 - 23;
    if e >= 1 {
        f32::from_bits((e as u32) << 23)
    } else {
        f32::from_bits(1 << (e + 22))
    }
}

/// What kind of computation an op is on hardware, and so its bound.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OpClass {
    /// One correctly rounded IEEE operation or no arithmetic at all (add, sub, mul, min,
    /// max, abs, floor, ceil, fract, comparisons, selects, conversions, moves): exact up
    /// to flushing.
    Exact,
    /// `x / y`: WGSL's 2.5 ulps from the exact quotient, 3 from the CPU's correctly rounded
    /// one.
    Div,
    /// `sqrt`: 1 ulp (measured on an H100; not correctly rounded there).
    Sqrt,
    /// Several products summed (dot, cross, length, distance, normalize, mod, matrix
    /// products, colour conversions), which the driver contracts into fused multiply-adds:
    /// 4 ulps of the result or of the scale.
    Contracted,
    /// Noise, cell and Worley noise: polynomials of the lattice offsets, contracted: 32
    /// ulps of max(1, result) (an H100: up to 22).
    Noise,
    /// Fractal sums of noise (`fbm3`, MaterialX `fractal`, `vfractal`): finite where the CPU's
    /// result is, not otherwise bounded. Each octave scales the coordinates by the
    /// lacunarity, and an ulp that contraction moves in a scaled coordinate moves the
    /// octave's lattice offsets by ulps of that magnitude: on an H100 ordinary parameters
    /// gave up to 4 % (fbm3 8.09 against 8.40) and large lacunarities unrelated values.
    Fractal,
    /// A bilinear texture lookup (three contracted lerps of texels): 2 ulps of
    /// max(1, result).
    Texture,
}

impl OpClass {
    /// The bound in ulps (of the result, or of [`close`]'s scale).
    pub fn ulps(self) -> u64 {
        match self {
            OpClass::Exact => 0,
            OpClass::Sqrt => 1,
            OpClass::Texture => 2,
            OpClass::Div => 3,
            OpClass::Contracted => 4,
            OpClass::Noise => 32,
            OpClass::Fractal => u64::MAX,
        }
    }
}

/// Whether the hardware's `got` is within `class`'s bound of the CPU's `want` (both
/// already for the same operands, flushed or not): [`ftz_equal`], or at most
/// `class.ulps()` ulps apart, or at most that many ulps of `scale` apart (the magnitude of
/// the largest product the op sums; 1 for noise and textures, whose values are O(1)).
pub fn close(class: OpClass, got: f32, want: f32, scale: f32) -> bool {
    if ftz_equal(got, want) {
        return true;
    }
    let (g, w) = (flush(got), flush(want));
    if !g.is_finite() || !w.is_finite() {
        return false;
    }
    let n = class.ulps();
    let scale = match class {
        OpClass::Noise | OpClass::Texture => scale.abs().max(1.0),
        _ => scale.abs(),
    };
    ulps(g, w) <= n || (g as f64 - w as f64).abs() <= n as f64 * ulp_at(scale) as f64
}

/// The bound of a transcendental on hardware: the documented one
/// ([`super::documented_bound`]), except `sin`, `cos` and `tan` of |x| ≤ 10⁴, which the
/// device computes with an absolute error: [`Bound::DeviceTrig`] (measured on an H100:
/// 2⁻²²·³ of max(1, |x|) at worst).
pub fn transcendental_bound(t: Transcendental, x: f32, y: f32, cpu: f32) -> (&'static str, Bound) {
    let (domain, bound) = super::documented_bound(t, x, y, cpu);
    match (t, bound) {
        // Far from the origin the device's reduction may land tan on a pole (an H100 gives
        // -inf for tan(2^24)): any value passes (the bound is |x| radians of angle).
        (Transcendental::Tan, Bound::FiniteIffFinite { .. }) => (
            domain,
            Bound::DeviceTrig {
                log2_per_x: 0,
                tan: true,
            },
        ),
        (
            Transcendental::Sin | Transcendental::Cos | Transcendental::Tan,
            Bound::Ulps(_) | Bound::Reduced { .. },
        ) => (
            domain,
            Bound::DeviceTrig {
                log2_per_x: 21,
                tan: t == Transcendental::Tan,
            },
        ),
        _ => (domain, bound),
    }
}

/// [`super::within`] on hardware: [`ftz_equal`], or `bound` on the flushed values.
pub fn within(bound: Bound, x: f32, got: f32, want: f32) -> bool {
    ftz_equal(got, want) || super::within(bound, x, flush(got), flush(want))
}

/// The streams a program reads (its fragment inputs).
pub fn streams_read(program: &Program) -> Vec<Stream> {
    let mut v: Vec<Stream> = Vec::new();
    for e in &program.exprs {
        if let Op::Stream(s) = e.op
            && !v.contains(&s)
        {
            v.push(s);
        }
    }
    v
}

/// The floats of stream `s` of a fragment (none for the int streams).
fn stream_floats(f: &Fragment, s: Stream) -> &[f32] {
    match s {
        Stream::P => &f.p,
        Stream::N => &f.n,
        Stream::Ng => &f.ng,
        Stream::I => &f.i,
        Stream::Uv => &f.uv,
        Stream::DPdu => &f.dpdu,
        Stream::DPdv => &f.dpdv,
        Stream::DPdx => &f.dpdx,
        Stream::DPdy => &f.dpdy,
        Stream::Time => std::slice::from_ref(&f.time),
        Stream::Rand => &f.rand,
        Stream::RayType | Stream::RayDepth => &[],
    }
}

/// Whether every float a fragment gives the `streams` ([`streams_read`]) is in the domain
/// [`check_outputs`] compares: finite, zero or normal, and of magnitude at most
/// [`FRAGMENT_MAX`].
pub fn fragment_in_domain(f: &Fragment, streams: &[Stream]) -> bool {
    streams.iter().all(|s| {
        stream_floats(f, *s)
            .iter()
            .all(|x| x.is_finite() && !x.is_subnormal() && x.abs() <= FRAGMENT_MAX)
    })
}

/// Whether a float a fragment gives the `streams` leaves results free
/// ([`free_operand`]: infinite, NaN or of magnitude ≥ 2¹²⁶).
pub fn fragment_free(f: &Fragment, streams: &[Stream]) -> bool {
    streams
        .iter()
        .any(|s| stream_floats(f, *s).iter().any(|x| free_operand(*x)))
}

/// Whether one program output is close: [`ftz_equal`], within [`PROGRAM_ULPS`] ulps, or
/// within [`PROGRAM_ABS`] · max(1, |want|).
pub fn output_close(got: f32, want: f32) -> bool {
    if ftz_equal(got, want) {
        return true;
    }
    let (g, w) = (flush(got), flush(want));
    g.is_finite()
        && w.is_finite()
        && (ulps(g, w) <= PROGRAM_ULPS || (g - w).abs() <= PROGRAM_ABS * w.abs().max(1.0))
}

/// The hardware contract of a whole program's outputs (`width` floats per fragment,
/// fragment after fragment): the outputs of the fragments `compared` accepts are compared;
/// at most [`PROGRAM_OUTLIERS`] of them (rounded down) may be not [`output_close`]. `Ok`
/// with a one-line summary, or `Err` naming the first outlier and the counts.
pub fn check_outputs(
    got: &[f32],
    want: &[f32],
    width: usize,
    compared: &dyn Fn(usize) -> bool,
) -> Result<String, String> {
    assert_eq!(got.len(), want.len(), "output lengths");
    let w = width.max(1);
    let frags = got.len() / w;
    let (mut n, mut outliers, mut first) = (0usize, 0usize, None);
    let mut differ = 0usize;
    for f in (0..frags).filter(|f| compared(*f)) {
        for c in 0..w {
            let (g, x) = (got[f * w + c], want[f * w + c]);
            n += 1;
            differ += usize::from(!same(g, x));
            if !output_close(g, x) {
                outliers += 1;
                first.get_or_insert((f, c, g, x));
            }
        }
    }
    let allowed = (PROGRAM_OUTLIERS * n as f64).floor() as usize;
    let summary = format!(
        "{n} outputs of {} compared, {differ} not bit-identical, {outliers} beyond \
         {PROGRAM_ULPS} ulps and {PROGRAM_ABS} (at most {allowed} may be)",
        got.len()
    );
    match first {
        Some((f, c, g, x)) if outliers > allowed => Err(format!(
            "{summary}; first at fragment {f} output float {c}: got {g:?} ({:#010x}), want \
             {x:?} ({:#010x})",
            g.to_bits(),
            x.to_bits()
        )),
        _ => Ok(summary),
    }
}

/// Images (renders): a pixel value is close within this, relative to max(1, |CPU's|) ...
pub const IMAGE_CLOSE: f64 = 1e-3;
/// ... at most this share of the values may be beyond it (a path that took another branch
/// after a few-ulp difference: a lobe choice, Russian roulette, a grazing hit) ...
pub const IMAGE_OUTLIERS: f64 = 0.10;
/// ... and the mean difference must be within this many standard errors of zero (paths
/// that diverged are independent unbiased samples of the same pixel, so their differences
/// average to zero; a wrong lobe, a missing light or a misplaced result does not).
pub const IMAGE_SIGMAS: f64 = 5.0;

/// The hardware contract of a render against the CPU's, one layer's floats: at most
/// [`IMAGE_OUTLIERS`] of the values beyond [`IMAGE_CLOSE`], and a mean difference within
/// [`IMAGE_SIGMAS`] standard errors of zero (plus [`IMAGE_CLOSE`] of the mean magnitude,
/// for the continuous part). `Ok` with the measured figures in a line, `Err` with them and
/// the bound broken.
pub fn check_image(got: &[f32], want: &[f32]) -> Result<String, String> {
    assert_eq!(got.len(), want.len(), "image sizes");
    let n = got.len().max(1) as f64;
    let (mut outliers, mut sum, mut sum2, mut mag) = (0usize, 0.0f64, 0.0f64, 0.0f64);
    for (g, w) in got.iter().zip(want) {
        let (g, w) = (*g as f64, *w as f64);
        if !(g.is_finite() && w.is_finite()) {
            if !(g.is_nan() && w.is_nan()) && g != w {
                outliers += 1;
            }
            continue;
        }
        let d = g - w;
        if d.abs() > IMAGE_CLOSE * w.abs().max(1.0) {
            outliers += 1;
        }
        sum += d;
        sum2 += d * d;
        mag += w.abs();
    }
    let mean = sum / n;
    let sd = (sum2 / n - mean * mean).max(0.0).sqrt();
    let se = sd / n.sqrt();
    let share = outliers as f64 / n;
    let allowed_mean = IMAGE_SIGMAS * se + IMAGE_CLOSE * mag / n;
    let line = format!(
        "{outliers} of {n} values beyond {IMAGE_CLOSE} ({:.3}%, at most {}%), mean \
         difference {mean:.3e} (at most {allowed_mean:.3e}: {IMAGE_SIGMAS} standard errors \
         of {se:.3e})",
        100.0 * share,
        100.0 * IMAGE_OUTLIERS
    );
    if share > IMAGE_OUTLIERS || mean.abs() > allowed_mean {
        Err(line)
    } else {
        Ok(line)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ulps_flushing_and_closeness() {
        assert_eq!(ulp_at(1.0), f32::EPSILON);
        assert_eq!(ulp_at(-2.0), 2.0 * f32::EPSILON);
        assert_eq!(ulp_at(0.0), f32::from_bits(1));
        assert_eq!(ulp_at(f32::MIN_POSITIVE), f32::from_bits(1));
        assert_eq!(ulp_at(f32::INFINITY), f32::INFINITY);
        assert!(ftz_equal(1e-45, 0.0) && ftz_equal(-3e-41, 0.0) && ftz_equal(-0.0, 0.0));
        assert!(ftz_equal(f32::NAN, f32::NAN) && !ftz_equal(1e-30, 0.0));
        assert_eq!(ftz_variants(&[1.0, 2.0]).len(), 1);
        let v = ftz_variants(&[1e-45, 2.0]);
        assert_eq!(v.len(), 3);
        assert!(v[1][0] == 0.0 && v[1][0].is_sign_positive() && v[2][0].is_sign_negative());
        // Two subnormal operands flush independently: (+0, -0) is one of the nine.
        let v = ftz_variants(&[1e-45, 1e-45]);
        assert_eq!(v.len(), 9);
        assert!(
            v.iter()
                .any(|w| w[0].is_sign_positive() && w[0] == 0.0 && w[1].is_sign_negative())
        );
        let up = |x: f32, k: u32| f32::from_bits(x.to_bits() + k);
        assert!(close(OpClass::Sqrt, up(1.5, 1), 1.5, 0.0));
        assert!(!close(OpClass::Sqrt, up(1.5, 2), 1.5, 0.0));
        assert!(!close(OpClass::Exact, up(1.5, 1), 1.5, 0.0));
        // A cancellation after a fused multiply-add: an ulp of the product, not of the result.
        assert!(close(OpClass::Contracted, -1.49e-8, 0.0, 1.0));
        assert!(!close(OpClass::Contracted, 1e-6, 0.0, 1.0));
        assert!(free_operand(HUGE) && free_operand(f32::NAN) && !free_operand(1e37));
    }

    #[test]
    fn program_outliers_are_counted_against_the_share() {
        let want: Vec<f32> = (0..1000).map(|i| i as f32 * 0.01).collect();
        let moved = |k: usize| {
            let mut g = want.clone();
            for x in g.iter_mut().step_by(1000 / k) {
                *x += 1.0;
            }
            g
        };
        let all = |_: usize| true;
        assert!(check_outputs(&moved(90), &want, 2, &all).is_ok());
        assert!(check_outputs(&moved(120), &want, 2, &all).is_err());
        // Fragments left out are not counted.
        let none = |_: usize| false;
        assert!(check_outputs(&moved(500), &want, 2, &none).is_ok());
    }

    #[test]
    fn images_allow_diverged_paths_but_not_a_bias() {
        let want: Vec<f32> = (0..10_000).map(|i| 0.25 + (i % 7) as f32 * 0.1).collect();
        // 2 % of the samples took another path: ±0.5, averaging to zero.
        let mut noisy = want.clone();
        for (k, x) in noisy.iter_mut().step_by(50).enumerate() {
            *x += if k % 2 == 0 { 0.5 } else { -0.5 };
        }
        assert!(check_image(&noisy, &want).is_ok());
        // 5 % of the samples brighter (a wrong lobe): few enough, but a bias.
        let mut biased = want.clone();
        for x in biased.iter_mut().step_by(20) {
            *x += 0.5;
        }
        assert!(check_image(&biased, &want).is_err());
        // Everything 1 % brighter: every sample beyond.
        let scaled: Vec<f32> = want.iter().map(|x| x * 1.01).collect();
        assert!(check_image(&scaled, &want).is_err());
        assert!(check_image(&want, &want).is_ok());
    }
}
