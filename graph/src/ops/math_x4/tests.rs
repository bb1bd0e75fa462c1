//! Every four-lane op ≡ the scalar op (`ops::exp::<f32>`…) bit for bit, on every copy this
//! CPU can run, on hard inputs and random ones, with rare and ordinary lanes mixed in packets.

use super::*;
use crate::ops::{self, math};

/// Zeros, subnormals, the normal range's ends, infinities, NaNs (quiet, with payloads,
/// signaling), ±1 and neighbours, thresholds of `exp` and `pow`.
fn hard() -> Vec<f32> {
    let mut v = vec![
        0.0,
        1e-45,
        1e-40,
        f32::MIN_POSITIVE / 2.0,
        f32::MIN_POSITIVE,
        1.1754945e-38,
        1e-30,
        1e-10,
        1e-8,
        3.0e-5,
        0.1,
        0.25,
        0.4142135,
        0.41421357,
        0.5,
        0.7,
        0.99999994,
        1.0,
        1.0000001,
        1.5,
        2.0,
        2.4142137,
        3.0,
        10.0,
        88.72,
        88.73,
        89.0,
        103.9,
        104.0,
        150.0,
        709.0,
        1e10,
        1e30,
        f32::MAX,
        f32::INFINITY,
    ];
    let neg: Vec<f32> = v.iter().map(|x| -x).collect();
    v.extend(neg);
    v.extend(
        [
            0x7fc0_0000u32,
            0xffc0_0000,
            0x7fc0_0001,
            0x7fff_ffff,
            0x7f80_0001,
            0xff80_0001,
            0x7fa0_0000,
            0x7fbf_ffff,
        ]
        .map(f32::from_bits),
    );
    v
}

/// The f32 neighbours (±1, ±2 ulps) of `k·π/2`, and arguments around and beyond 2²⁰·π/2
/// (Payne–Hanek).
fn near_pi_2() -> Vec<f32> {
    let mut v = Vec::new();
    // π/4 (where `math::rem_pio2` stops returning its argument) and its neighbours.
    let q = std::f32::consts::FRAC_PI_4.to_bits();
    v.extend((q - 2..=q + 2).map(f32::from_bits));
    let mut ks: Vec<i64> = (0..=64).collect();
    ks.extend([
        100,
        355,
        1000,
        12345,
        102_944,
        1 << 19,
        (1 << 20) - 1,
        1 << 20,
    ]);
    ks.extend([(1 << 20) + 1, 1 << 21, 1 << 24, 1 << 30, 1 << 40, 1 << 60]);
    for k in ks {
        for sign in [1.0, -1.0] {
            let x = (sign * k as f64 * std::f64::consts::FRAC_PI_2) as f32;
            let b = x.to_bits();
            for d in [-2i32, -1, 0, 1, 2] {
                v.push(f32::from_bits(b.wrapping_add_signed(d)));
            }
        }
    }
    v.extend([1.6e6, 1.7e6, -1.7e6, 1e7, 3e9, 1e20, -1e38]);
    v
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    /// Uniform in `[-r, r)`.
    fn uniform(&mut self, r: f32) -> f32 {
        ((self.next() >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0) * r
    }
    /// Any magnitude from subnormal to huge, either sign.
    fn any_magnitude(&mut self) -> f32 {
        let bits = (self.next() >> 32) as u32;
        let e = (bits % 254) + 1; // normal exponents
        let f = f32::from_bits((e << 23) | (bits >> 9 & 0x7f_ffff));
        if bits & 1 == 1 { -f } else { f }
    }
}

/// Hard inputs, `k·π/2` neighbours, then random ones: every bit pattern, and uniform over
/// ranges from [-1, 1] to [-10⁶, 10⁶], and any magnitude.
fn inputs() -> Vec<f32> {
    let mut v = hard();
    v.extend(near_pi_2());
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    for _ in 0..3000 {
        v.push(f32::from_bits(rng.next() as u32));
        v.push(rng.any_magnitude());
        for r in [1.0, 2.0, 10.0, 100.0, 1e4, 1e6] {
            v.push(rng.uniform(r));
        }
    }
    v
}

/// Pairs for `pow` and `atan2`: hard × hard, integer and half-integer exponents on ordinary
/// and negative bases, and random pairs.
fn pairs() -> Vec<(f32, f32)> {
    let h = hard();
    let mut v: Vec<(f32, f32)> = Vec::new();
    for &a in &h {
        for &b in &h {
            v.push((a, b));
        }
    }
    let bases = [
        0.5f32, -0.5, 2.0, -2.0, 3.0, -3.0, 1.1, -1.1, 0.9, 10.0, -7.5, 1e-3, 1e-20,
    ];
    for &a in &bases {
        for n in -70..=70 {
            v.push((a, n as f32));
            v.push((a, n as f32 + 0.5));
        }
        v.extend([
            (a, 1e7),
            (a, 1e7 + 1.0),
            (a, 16_777_215.0),
            (a, -16_777_215.0),
        ]);
    }
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);
    for _ in 0..6000 {
        v.push((rng.uniform(4.0), rng.uniform(10.0)));
        v.push((rng.uniform(100.0), rng.uniform(100.0)));
        v.push((rng.any_magnitude(), rng.any_magnitude()));
        v.push((rng.uniform(8.0), (rng.uniform(40.0) as i32) as f32));
        let (a, b) = (rng.next() as u32, (rng.next() >> 32) as u32);
        v.push((f32::from_bits(a), f32::from_bits(b)));
    }
    v
}

fn paths() -> Vec<Path> {
    for p in Path::ALL.iter().filter(|p| !p.available()) {
        eprintln!("SKIPPED: the {p:?} copy: this CPU lacks the feature");
    }
    Path::ALL.into_iter().filter(|p| p.available()).collect()
}

/// Packets of four in two arrangements: in order, and interleaved with a far-away stride (so
/// hard values share packets with ordinary ones).
fn packets<T: Copy + Default>(xs: &[T]) -> Vec<[T; 4]> {
    let n = xs.len();
    let mut out: Vec<[T; 4]> = xs
        .chunks(4)
        .map(|c| std::array::from_fn(|l| c.get(l).copied().unwrap_or_default()))
        .collect();
    out.extend((0..n.div_ceil(4)).map(|i| std::array::from_fn(|l| xs[(i + l * (n / 4 + 7)) % n])));
    out
}

fn check_unary(name: &str, pick: fn(&Table) -> Unary, scalar: fn(f32) -> f32) {
    let xs = inputs();
    let ps = packets(&xs);
    for path in paths() {
        let f = pick(table(path));
        for p in &ps {
            let got = f(*p);
            for l in 0..4 {
                let want = scalar(p[l]);
                assert_eq!(
                    got[l].to_bits(),
                    want.to_bits(),
                    "{name} on {path:?} at {:e} ({:#x}): {:e} vs {:e}",
                    p[l],
                    p[l].to_bits(),
                    got[l],
                    want
                );
            }
        }
    }
}

fn check_binary(name: &str, pick: fn(&Table) -> Binary, scalar: fn(f32, f32) -> f32) {
    let xs = pairs();
    let ps = packets(&xs);
    for path in paths() {
        let f = pick(table(path));
        for p in &ps {
            let got = f(p.map(|(a, _)| a), p.map(|(_, b)| b));
            for l in 0..4 {
                let (a, b) = p[l];
                let want = scalar(a, b);
                assert_eq!(
                    got[l].to_bits(),
                    want.to_bits(),
                    "{name} on {path:?} at ({a:e}, {b:e}) = ({:#x}, {:#x}): {:e} vs {:e}",
                    a.to_bits(),
                    b.to_bits(),
                    got[l],
                    want
                );
            }
        }
    }
}

#[test]
fn exp_x4_has_the_scalar_bits() {
    check_unary("exp", |t| t.exp, ops::exp::<f32>);
}

#[test]
fn log_x4_has_the_scalar_bits() {
    check_unary("log", |t| t.log, ops::log::<f32>);
}

#[test]
fn sin_x4_has_the_scalar_bits() {
    check_unary("sin", |t| t.sin, ops::sin::<f32>);
}

#[test]
fn cos_x4_has_the_scalar_bits() {
    check_unary("cos", |t| t.cos, ops::cos::<f32>);
}

#[test]
fn tan_x4_has_the_scalar_bits() {
    check_unary("tan", |t| t.tan, ops::tan::<f32>);
}

#[test]
fn asin_x4_has_the_scalar_bits() {
    check_unary("asin", |t| t.asin, ops::asin::<f32>);
}

#[test]
fn acos_x4_has_the_scalar_bits() {
    check_unary("acos", |t| t.acos, ops::acos::<f32>);
}

#[test]
fn pow_x4_has_the_scalar_bits() {
    check_binary("pow", |t| t.pow, ops::pow::<f32>);
}

#[test]
fn atan2_x4_has_the_scalar_bits() {
    check_binary("atan2", |t| t.atan2, ops::atan2::<f32>);
}

/// The inputs reach the four-lane code, not only the scalar fallback: most lanes of the
/// random packets are ordinary (a guard against a rare-lane mask that is always set, which
/// would pass the tests above while computing nothing in SIMD).
#[test]
fn ordinary_lanes_take_the_simd_path() {
    let xs: Vec<f32> = (0..64).map(|i| i as f32 * 0.37 - 11.0).collect();
    for p in packets(&xs) {
        let px = widen(p);
        let (_, _, _, rare) = rem_pio2_k(px);
        assert!(!rare.any(), "{p:?} needs Payne–Hanek");
    }
    // A lane flagged rare is recomputed; one not flagged keeps the SIMD value.
    let out = patch([1.0, 2.0, 3.0, 4.0], m4(|l| l == 2), |_| -1.0);
    assert_eq!(out, [1.0, 2.0, -1.0, 4.0]);
}

// ---- the f64 kernels ≡ `math`'s f64 functions, bit for bit ----
//
// An f32 result hides most f64-level slips (a reordered sum moves the f64 value by an ulp,
// which rounding to f32 almost always absorbs), so the kernels are also held to `math`'s f64
// functions directly, on f64 inputs where they claim to be exact.

/// f64 inputs: the f32 ones widened, f64 bit patterns, and uniform over ranges.
fn inputs_f64() -> Vec<f64> {
    let mut v: Vec<f64> = inputs().into_iter().map(f64::from).collect();
    let mut rng = Rng(0xD1B5_4A32_D192_ED03);
    for _ in 0..4000 {
        v.push(f64::from_bits(rng.next()));
        let u = (rng.next() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
        for r in [1.0, 3.0, 50.0, 800.0, 1e6] {
            v.push(u * r);
        }
    }
    v
}

/// Checks `kernel` against `reference` on the lanes `valid` accepts.
fn check_f64(name: &str, kernel: impl Fn(D4) -> (D4, M4), reference: impl Fn(f64) -> f64) {
    let xs = inputs_f64();
    let mut checked = 0;
    for p in packets(&xs) {
        let (got, skip) = kernel(D4(p));
        for (l, &x) in p.iter().enumerate() {
            if skip.lane(l) {
                continue;
            }
            checked += 1;
            let want = reference(x);
            assert_eq!(
                got.0[l].to_bits(),
                want.to_bits(),
                "{name} kernel at {x:e}: {:e} vs {:e}",
                got.0[l],
                want
            );
        }
    }
    assert!(
        checked > xs.len() / 2,
        "{name}: only {checked} lanes checked"
    );
}

#[test]
fn the_f64_kernels_are_maths_functions() {
    check_f64("exp", |x| (exp_k(x), m4(|l| x.0[l].is_nan())), math::exp);
    let not_normal = |x: D4| m4(|l| !(x.0[l].is_normal() && x.0[l] > 0.0));
    check_f64("log", |x| (log_k(x), not_normal(x)), math::log);
    let not_finite = |x: D4| m4(|l| !x.0[l].is_finite());
    for (name, pick, reference) in [
        (
            "sin",
            pick_sin as fn(M4, M4, D4, D4) -> D4,
            math::sin as fn(f64) -> f64,
        ),
        ("cos", pick_cos, math::cos),
        ("tan", pick_tan, math::tan),
    ] {
        let kernel = |x: D4| {
            let (v, rare) = trig_k(x, pick);
            (v, rare.or(not_finite(x)))
        };
        check_f64(name, kernel, reference);
    }
    let outside = |x: D4| m4(|l| x.0[l].is_nan() || x.0[l].abs() > 1.0);
    check_f64("asin", |x| (asin_k(x), outside(x)), math::asin);
    check_f64("acos", |x| (acos_k(x), outside(x)), math::acos);
    // atan2 and pow: the second argument from a rotation of the inputs.
    let xs = inputs_f64();
    let second = |x: D4| -> D4 {
        d4(|l| {
            let i = (x.0[l].to_bits() % xs.len() as u64) as usize;
            xs[i]
        })
    };
    let atan2_of = |y: D4| {
        let x = second(y);
        let skip = not_finite(y).or(not_finite(x));
        (atan2_k(y, x), skip)
    };
    check_f64("atan2", atan2_of, |y| {
        let i = (y.to_bits() % xs.len() as u64) as usize;
        math::atan2(y, xs[i])
    });
    let pow_of = |x: D4| {
        let y = second(x);
        let (r, is_int, _) = pow_k(x, y);
        let ordinary = |v: f64| v.is_finite() && v != 0.0;
        let skip = m4(|l| {
            let (a, b) = (x.0[l], y.0[l]);
            !(ordinary(a) && ordinary(b) && b.abs() < (1u64 << 51) as f64)
                || (a < 0.0 && !is_int.lane(l))
        });
        (r, skip)
    };
    check_f64("pow", pow_of, |x| {
        let i = (x.to_bits() % xs.len() as u64) as usize;
        math::pow(x, xs[i])
    });
}
