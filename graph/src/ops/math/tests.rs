//! Accuracy of the math library against std's f64 functions (glibc: within an f64 ulp),
//! on the hard inputs and on random ones; the figures of the module documentation.

use super::*;

/// A small deterministic generator (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    /// Any finite f32 (uniform over bit patterns).
    fn any_f32(&mut self) -> f32 {
        loop {
            let x = f32::from_bits(self.next() as u32);
            if x.is_finite() {
                return x;
            }
        }
    }
    /// Any finite f64 (uniform over bit patterns).
    fn any_f64(&mut self) -> f64 {
        loop {
            let x = f64::from_bits(self.next());
            if x.is_finite() {
                return x;
            }
        }
    }
    /// Uniform in `[lo, hi)`.
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

/// Hard f32 inputs: zeros, subnormals, extremes, infinities, NaN, ±1, and values near
/// multiples of π/2 (their neighbours too).
fn hard_f32() -> Vec<f32> {
    let mut v = vec![
        0.0,
        -0.0,
        f32::from_bits(1),
        -f32::from_bits(1),
        f32::from_bits(0x007f_ffff),
        f32::MIN_POSITIVE,
        f32::MAX,
        -f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1.0,
        -1.0,
        0.5,
        2.0,
        88.72,
        88.73,
        -87.3,
        -103.9,
        -104.0,
        1e-30,
        1e30,
        3.0e38,
        16777216.0,
    ];
    for k in [
        1i64,
        2,
        3,
        4,
        5,
        10,
        100,
        1000,
        12345,
        1 << 20,
        1 << 22,
        1 << 40,
    ] {
        for sign in [1.0, -1.0] {
            let x = (sign * k as f64 * std::f64::consts::FRAC_PI_2) as f32;
            let b = x.to_bits();
            v.extend([x, f32::from_bits(b + 1), f32::from_bits(b - 1)]);
        }
    }
    for b in [0x3f7f_ffffu32, 0x3f80_0001, 0x3f7f_fff0] {
        v.push(f32::from_bits(b));
        v.push(-f32::from_bits(b));
    }
    v
}

fn hard_f64() -> Vec<f64> {
    let mut v: Vec<f64> = hard_f32().into_iter().map(f64::from).collect();
    v.extend([
        f64::from_bits(1),
        -f64::from_bits(1),
        f64::MIN_POSITIVE,
        f64::MAX,
        -f64::MAX,
        709.78,
        709.79,
        -745.1,
        -745.2,
        1e300,
        1e-300,
        std::f64::consts::FRAC_PI_2,
        std::f64::consts::PI,
        1.0 - f64::EPSILON / 2.0,
        1.0 + f64::EPSILON,
    ]);
    v.push(MULLER);
    v
}

/// The f64 nearest to a multiple of π/2 (Muller's table: 6381956970095103·2⁷⁹⁷).
const MULLER: f64 = 5.319372648326541e255;

/// The error of `ours` in f32 ulps against the exact value `r` (an f64).
fn ulps_f32(ours: f32, r: f64) -> f64 {
    if ours.is_nan() || r.is_nan() {
        return if ours.is_nan() && r.is_nan() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    if ours.is_infinite() || (r as f32).is_infinite() {
        return if ours == r as f32 { 0.0 } else { f64::INFINITY };
    }
    if r == 0.0 {
        return if ours == 0.0 && ours.is_sign_negative() == r.is_sign_negative() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    let a = r.abs();
    let ulp = if a < f32::MIN_POSITIVE as f64 {
        f32::from_bits(1) as f64
    } else {
        let e = ((a.to_bits() >> 52) as i32) - 1023;
        2f64.powi(e - 23)
    };
    (ours as f64 - r).abs() / ulp
}

/// The distance in representable f64s between `a` and `b` (0 for two NaNs).
fn ulps_f64(a: f64, b: f64) -> u64 {
    if a.is_nan() || b.is_nan() {
        return if a.is_nan() && b.is_nan() {
            0
        } else {
            u64::MAX
        };
    }
    let key = |x: f64| {
        let b = x.to_bits() as i64;
        if b < 0 { i64::MIN - b } else { b }
    };
    key(a).abs_diff(key(b))
}

/// A binary function: name, ours in f32, the f64 reference.
type Binary = (&'static str, fn(f32, f32) -> f32, fn(f64, f64) -> f64);

type Unary = (
    &'static str,
    fn(f32) -> f32,
    fn(f64) -> f64,
    fn(f64) -> f64,
    (f64, f64),
);

fn unary_table() -> Vec<Unary> {
    vec![
        ("exp", exp_f32, exp, f64::exp, (-110.0, 90.0)),
        ("log", log_f32, log, f64::ln, (0.0, 4.0)),
        ("sin", sin_f32, sin, f64::sin, (-20.0, 20.0)),
        ("cos", cos_f32, cos, f64::cos, (-20.0, 20.0)),
        ("tan", tan_f32, tan, f64::tan, (-20.0, 20.0)),
        ("asin", asin_f32, asin, f64::asin, (-1.0, 1.0)),
        ("acos", acos_f32, acos, f64::acos, (-1.0, 1.0)),
        ("atan", atan_f32, atan, f64::atan, (-10.0, 10.0)),
    ]
}

const RANDOM: usize = 100_000;

/// The f32 bound: correctly rounded but for results within 2⁻²⁰ ulp of a rounding boundary.
const F32_BOUND: f64 = 0.5 + 1.0 / (1u64 << 20) as f64;

#[test]
fn unary_functions_f32_are_within_half_an_ulp() {
    let mut report = Vec::new();
    for (name, ours, _, reference, (lo, hi)) in unary_table() {
        let mut rng = Rng(0x5EED ^ name.len() as u64);
        let mut inputs = hard_f32();
        for _ in 0..RANDOM {
            inputs.push(rng.any_f32());
            inputs.push(rng.range(lo, hi) as f32);
        }
        let mut worst = (0.0f64, 0.0f32);
        for x in inputs {
            let e = ulps_f32(ours(x), reference(x as f64));
            if e > worst.0 {
                worst = (e, x);
            }
        }
        report.push(format!("{name}_f32: {:.6} ulps at {:e}", worst.0, worst.1));
        assert!(
            worst.0 <= F32_BOUND,
            "{name}_f32: {} ulps at {:e}",
            worst.0,
            worst.1
        );
    }
    eprintln!("{}", report.join("\n"));
}

#[test]
fn unary_functions_f64_are_within_documented_ulps() {
    let mut report = Vec::new();
    for (name, _, ours, reference, (lo, hi)) in unary_table() {
        let bound = match name {
            "exp" | "log" | "sin" | "cos" => 2,
            "tan" => 4,
            _ => 3,
        };
        let mut rng = Rng(0xF64 ^ name.len() as u64);
        let mut inputs = hard_f64();
        for _ in 0..RANDOM {
            inputs.push(rng.any_f64());
            inputs.push(rng.range(lo, hi));
        }
        let mut worst = (0u64, 0.0f64);
        for x in inputs {
            if x == MULLER {
                continue; // glibc's cos is 8 ulps off here: see `the_worst_case_for_reduction`
            }
            let e = ulps_f64(ours(x), reference(x));
            if e > worst.0 {
                worst = (e, x);
            }
        }
        report.push(format!("{name}_f64: {} ulps at {:e}", worst.0, worst.1));
        assert!(
            worst.0 <= bound,
            "{name}: {} ulps at {:e}",
            worst.0,
            worst.1
        );
    }
    eprintln!("{}", report.join("\n"));
}

fn binary_inputs(rng: &mut Rng, pow: bool) -> Vec<(f64, f64)> {
    let hard = hard_f32();
    let mut v = Vec::new();
    for &a in &hard {
        for &b in &hard {
            v.push((a as f64, b as f64));
        }
    }
    for _ in 0..RANDOM {
        v.push((rng.any_f32() as f64, rng.any_f32() as f64));
        if pow {
            v.push((
                rng.range(0.0, 4.0) as f32 as f64,
                rng.range(-30.0, 30.0) as f32 as f64,
            ));
            let base = -(rng.range(0.0, 3.0) as f32) as f64;
            v.push((base, (rng.range(-40.0, 40.0) as f32).round() as f64));
        } else {
            v.push((
                rng.range(-5.0, 5.0) as f32 as f64,
                rng.range(-5.0, 5.0) as f32 as f64,
            ));
        }
    }
    v
}

#[test]
fn atan2_and_pow_f32_are_within_half_an_ulp() {
    let mut rng = Rng(0xA7A2);
    let table: [Binary; 2] = [
        ("atan2", atan2_f32, f64::atan2),
        ("pow", pow_f32, f64::powf),
    ];
    for (name, ours, reference) in table {
        let mut worst = (0.0f64, (0.0f64, 0.0f64));
        for (a, b) in binary_inputs(&mut rng, name == "pow") {
            let e = ulps_f32(ours(a as f32, b as f32), reference(a, b));
            if e > worst.0 {
                worst = (e, (a, b));
            }
        }
        eprintln!("{name}_f32: {:.6} ulps at {:?}", worst.0, worst.1);
        assert!(
            worst.0 <= F32_BOUND,
            "{name}_f32: {} ulps at {:?}",
            worst.0,
            worst.1
        );
    }
}

#[test]
fn atan2_and_pow_f64_are_within_documented_ulps() {
    let mut rng = Rng(0xB0B);
    for (a, b) in binary_inputs(&mut rng, false) {
        let e = ulps_f64(atan2(a, b), a.atan2(b));
        assert!(e <= 3, "atan2({a:e}, {b:e}): {e} ulps");
    }
    let mut worst = 0u64;
    for (a, b) in binary_inputs(&mut rng, true) {
        let r = a.powf(b);
        let e = ulps_f64(pow(a, b), r);
        // y·ln|x| carries ln's error and the product's rounding (no extra precision):
        // 2 ulps plus 3·|y·ln x|.
        // By squaring (integer |y| ≤ 64): each rounding grows with the power taken.
        let bound = if b.trunc() == b && b.abs() <= 64.0 {
            4 + 2 * b.abs() as u64
        } else {
            2 + (3.0 * b * a.abs().ln()).abs().ceil().min(1e6) as u64
        };
        if r.is_finite() && r != 0.0 && r.abs() >= f64::MIN_POSITIVE {
            assert!(e <= bound, "pow({a:e}, {b:e}): {e} ulps");
            worst = worst.max(e);
        } else {
            assert!(
                e <= bound || r.abs() < f64::MIN_POSITIVE,
                "pow({a:e}, {b:e}): {e} ulps"
            );
        }
    }
    eprintln!("pow_f64: {worst} ulps");
}

#[test]
fn constants_match_their_known_values() {
    // 2/π = 0.A2F9836E4E441529FC27…₁₆ (the first word after the zero pad).
    assert_eq!(TWO_OVER_PI[0], 0);
    assert_eq!(TWO_OVER_PI[1], 0xA2F9_836E_4E44_1529);
    assert_eq!(PIO2_HI, std::f64::consts::FRAC_PI_2);
    assert_eq!(PIO2_1 + PIO2_2, PIO2_1 + PIO2_2 + PIO2_3 - PIO2_3);
    assert!((PIO2_1 + PIO2_2 - std::f64::consts::FRAC_PI_2).abs() < 1e-19);
    assert_eq!(LN2_HI + LN2_LO, std::f64::consts::LN_2);
    assert_eq!(
        PIO2_1.to_bits() & ((1 << 20) - 1),
        0,
        "33 bits: n·PIO2_1 is exact"
    );
}

#[test]
fn special_values_follow_annex_f() {
    let (inf, nan) = (f64::INFINITY, f64::NAN);
    assert_eq!(exp(-inf), 0.0);
    assert_eq!(exp(inf), inf);
    assert_eq!(log(0.0), -inf);
    assert!(log(-1.0).is_nan());
    assert_eq!(pow(nan, 0.0), 1.0);
    assert_eq!(pow(1.0, nan), 1.0);
    let snan32 = f32::from_bits(0x7fbc_ad8c);
    assert!(pow_f32(snan32, 0.0).is_nan() && pow_f32(1.0, snan32).is_nan());
    assert!(pow(f64::from_bits(0x7ff4_0000_0000_0000), 0.0).is_nan());
    assert_eq!(pow(-1.0, inf), 1.0);
    assert_eq!(pow(-0.0, 3.0).to_bits(), (-0.0f64).to_bits());
    assert_eq!(pow(-0.0, -3.0), -inf);
    assert_eq!(pow(-inf, 3.0), -inf);
    assert_eq!(pow(-inf, -3.0).to_bits(), (-0.0f64).to_bits());
    assert!(pow(-2.0, 0.5).is_nan());
    assert!(ulps_f64(pow(-2.0, 3.0), -8.0) <= 2);
    assert_eq!(atan2(0.0, -0.0), std::f64::consts::PI);
    assert_eq!(atan2(-0.0, 0.0).to_bits(), (-0.0f64).to_bits());
    assert_eq!(atan2(inf, -inf), 3.0 * std::f64::consts::FRAC_PI_4);
    assert_eq!(atan2(1.0, -0.0), std::f64::consts::FRAC_PI_2);
    assert_eq!(sin(-0.0).to_bits(), (-0.0f64).to_bits());
    assert!(sin(inf).is_nan() && cos(nan).is_nan() && tan(-inf).is_nan());
    assert_eq!(asin(1.0), std::f64::consts::FRAC_PI_2);
    assert_eq!(acos(-1.0), std::f64::consts::PI);
    assert_eq!(acos(1.0), 0.0);
    assert!(asin(1.5).is_nan());
}

#[test]
fn the_worst_case_for_reduction() {
    // MULLER = n·π/2 + 4.687165924254627611…e-19 with n ≡ 1 (mod 4) (3 000-bit mpmath).
    assert_eq!(
        MULLER.to_bits(),
        (6381956970095103.0 * 2f64.powi(797)).to_bits()
    );
    assert_eq!(cos(MULLER), -4.687165924254628e-19);
    assert_eq!(sin(MULLER), 1.0);
}
