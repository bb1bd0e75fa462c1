//! Test helpers for the GPU back end: the device or a skip that says why, and the documented
//! accuracy of the transcendentals (the table in [`crate::emit`]) as code.
//!
//! Every test that needs a device starts with [`device_or_skip`]. Without an adapter the test
//! prints `SKIPPED: <test>: <why>` to stderr and returns (it passes: a machine without any
//! Vulkan or GL driver cannot run it); with `SHADENET_REQUIRE_GPU=1` in the environment (CI,
//! which installs Mesa's lavapipe) a missing device fails the test instead.
//!
//! [`documented_bound`] and [`within`] are the bounds `gpu/tests/emit.rs` measures and the
//! parity suite (`tests/backends.rs`) applies to rows of one transcendental op.
//!
//! [`accuracy`] says which contract a test checks: bit-exact on a software rasterizer
//! (CI's lavapipe), the bounded contract of [`hardware`] on a hardware GPU (or anywhere
//! under `SHADENET_GPU_ACCURACY=hardware`).

pub mod hardware;

use crate::{Accuracy, GpuContext};
use shadenet_graph::ir::{BinOp, UnOp};
use std::sync::Arc;

/// The environment variable that turns a skip into a failure when set to `1`.
pub const REQUIRE_GPU: &str = "SHADENET_REQUIRE_GPU";

/// The shared device ([`GpuContext::shared`]); `None` after printing
/// `SKIPPED: <test>: <error>` to stderr when there is none. Panics instead (naming the test
/// and the error) when `SHADENET_REQUIRE_GPU=1`.
pub fn device_or_skip(test: &str) -> Option<Arc<GpuContext>> {
    match GpuContext::shared() {
        Ok(ctx) => Some(ctx),
        Err(e) => {
            if std::env::var(REQUIRE_GPU).is_ok_and(|v| v == "1") {
                panic!("{test}: {REQUIRE_GPU}=1 but the GPU back end cannot run: {e}");
            }
            eprintln!("SKIPPED: {test}: {e}");
            None
        }
    }
}

/// The accuracy class the tests check on `ctx` ([`GpuContext::accuracy`]), printed once
/// per test binary to stderr with the adapter's name.
pub fn accuracy(ctx: &GpuContext) -> Accuracy {
    static SAID: std::sync::Once = std::sync::Once::new();
    SAID.call_once(|| {
        eprintln!(
            "GPU accuracy on {}: {}",
            ctx.info.name,
            ctx.accuracy.describe()
        )
    });
    ctx.accuracy
}

/// The ops the GPU computes with its own code rather than a port of the CPU's (see the
/// table in [`crate::emit`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Transcendental {
    /// `exp` (fdlibm port).
    Exp,
    /// `log` (fdlibm port).
    Log,
    /// `sin` (the device's).
    Sin,
    /// `cos` (the device's).
    Cos,
    /// `tan` (the device's).
    Tan,
    /// `asin` (fdlibm port).
    Asin,
    /// `acos` (fdlibm port).
    Acos,
    /// `atan2` (fdlibm port).
    Atan2,
    /// `pow` (fdlibm port).
    Pow,
}

impl Transcendental {
    /// The transcendental a unary op is, if any.
    pub fn of_unary(op: UnOp) -> Option<Transcendental> {
        Some(match op {
            UnOp::Exp => Transcendental::Exp,
            UnOp::Log => Transcendental::Log,
            UnOp::Sin => Transcendental::Sin,
            UnOp::Cos => Transcendental::Cos,
            UnOp::Tan => Transcendental::Tan,
            UnOp::Asin => Transcendental::Asin,
            UnOp::Acos => Transcendental::Acos,
            _ => return None,
        })
    }

    /// The transcendental a binary op is, if any.
    pub fn of_binary(op: BinOp) -> Option<Transcendental> {
        Some(match op {
            BinOp::Pow => Transcendental::Pow,
            BinOp::Atan2 => Transcendental::Atan2,
            _ => return None,
        })
    }
}

/// What the GPU's result of a transcendental must satisfy against the CPU's on a domain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bound {
    /// The same bits (NaN equals NaN).
    Exact,
    /// At most this many ulps from the CPU's result.
    Ulps(u64),
    /// At most `ulps` ulps, or an error at most `2^-log2_per_x · |x| · (1 + r²)` (r the
    /// CPU's result): the device reduces the argument of sin, cos and tan modulo π/2 with a
    /// π/2 of about 48 bits, so near their zeros the error is absolute (the error of the
    /// reduced argument times the derivative, 1 for sin and cos, 1 + tan² for tan).
    Reduced {
        /// The ulps bound.
        ulps: u64,
        /// The absolute bound's exponent.
        log2_per_x: i32,
    },
    /// Finite exactly where the CPU's result is, and of magnitude at most 1 when `unit`
    /// (sin and cos of |x| > 10⁴: the device's argument reduction has too few bits of π).
    FiniteIffFinite {
        /// Whether the result must lie in [-1, 1].
        unit: bool,
    },
    /// A hardware GPU's own `sin`, `cos` and `tan` ([`hardware::transcendental_bound`]): an
    /// error at most `2^-log2_per_x · max(1, |x|)`, in the angle `atan(result)` (modulo π)
    /// for tan, whose value is unbounded near its poles.
    DeviceTrig {
        /// The absolute bound's exponent.
        log2_per_x: i32,
        /// Whether the op is tan (the error is measured in the angle).
        tan: bool,
    },
}

/// The input domain of `t` at arguments `(x, y)` (y only for `atan2(x, y)` and `pow(x, y)`)
/// whose CPU result is `cpu`, and the bound documented for it (the table in
/// [`crate::emit`]).
pub fn documented_bound(t: Transcendental, x: f32, y: f32, cpu: f32) -> (&'static str, Bound) {
    use Bound::*;
    use Transcendental as T;
    let special = |v: f32| !v.is_finite();
    let reduced = |ulps| Reduced {
        ulps,
        log2_per_x: 46,
    };
    match t {
        T::Exp => match cpu {
            _ if special(x) => ("x non-finite", Exact),
            r if r.is_infinite() => ("overflow (x > 88.72)", Ulps(2)),
            0.0 => ("underflow to 0 (x < -103.97)", Ulps(2)),
            r if r.is_subnormal() => ("subnormal result (-103.97 <= x < -87.34)", Ulps(2)),
            _ => ("normal result (-87.34 <= x <= 88.72)", Ulps(2)),
        },
        T::Log => match x {
            x if x.is_nan() || x <= 0.0 || special(x) => ("x <= 0, inf or NaN", Exact),
            x if x.is_subnormal() => ("x subnormal", Ulps(2)),
            x if (0.5..=2.0).contains(&x) => ("x in [0.5, 2]", Ulps(2)),
            _ => ("x normal, outside [0.5, 2]", Ulps(2)),
        },
        T::Sin | T::Cos | T::Tan => {
            let ulps = if t == T::Tan { 4 } else { 2 };
            match x.abs() {
                a if !a.is_finite() => ("x non-finite", Exact),
                a if a <= std::f32::consts::PI => ("|x| <= pi", Ulps(ulps)),
                a if a <= 100.0 => ("pi < |x| <= 100", reduced(ulps)),
                a if a <= 1e4 => ("100 < |x| <= 1e4", reduced(ulps)),
                _ => ("|x| > 1e4", FiniteIffFinite { unit: t != T::Tan }),
            }
        }
        T::Asin | T::Acos => {
            let ulps = if t == T::Asin { 4 } else { 2 };
            match x.abs() {
                a if a.is_nan() => ("NaN", Exact),
                a if a < 1.0 => ("|x| < 1", Ulps(ulps)),
                _ => ("|x| >= 1 (clamped)", Exact),
            }
        }
        T::Atan2 => {
            if special(x) || special(y) || x == 0.0 || y == 0.0 {
                ("a zero, inf or NaN operand", Exact)
            } else if x.is_subnormal() || y.is_subnormal() {
                ("finite non-zero, a subnormal operand", Ulps(4))
            } else {
                ("finite non-zero normal operands", Ulps(4))
            }
        }
        T::Pow => {
            if special(x) || special(y) || x == 0.0 || y == 0.0 || x.abs() == 1.0 {
                ("base or exponent 0, ±1, ±inf or NaN", Exact)
            } else if x < 0.0 && y.trunc() != y {
                ("negative base, non-integer exponent (0)", Exact)
            } else if cpu.is_infinite() {
                ("overflow", Ulps(2))
            } else if cpu == 0.0 {
                ("underflow to 0", Ulps(2))
            } else if cpu.is_subnormal() {
                ("subnormal result", Ulps(2))
            } else if x.is_subnormal() {
                ("subnormal base, normal result", Ulps(2))
            } else if (x.abs().ln() as f64 * y as f64).abs() <= 10.0 {
                ("normal result, |y ln |x|| <= 10", Ulps(2))
            } else {
                ("normal result, |y ln |x|| > 10", Ulps(2))
            }
        }
    }
}

/// Whether the GPU's `got` is within `bound` of the CPU's `want` (`x`: the first argument).
pub fn within(bound: Bound, x: f32, got: f32, want: f32) -> bool {
    match bound {
        Bound::Exact => same(got, want),
        Bound::Ulps(n) => same(got, want) || ulps(got, want) <= n,
        Bound::Reduced {
            ulps: n,
            log2_per_x,
        } => {
            let err = (got as f64 - want as f64).abs();
            let per_x = 2f64.powi(-log2_per_x) * (x.abs() as f64) * (1.0 + (want as f64).powi(2));
            same(got, want) || ulps(got, want) <= n || err <= per_x
        }
        Bound::DeviceTrig { log2_per_x, tan } => {
            let eps = 2f64.powi(-log2_per_x) * (x.abs() as f64).max(1.0);
            let (g, w) = (got as f64, want as f64);
            let angle = (g.atan() - w.atan()).abs();
            same(got, want)
                || (!tan && (g - w).abs() <= eps)
                || (tan && angle.min(std::f64::consts::PI - angle) <= eps)
        }
        Bound::FiniteIffFinite { unit } => {
            got.is_finite() == want.is_finite() && (!unit || got.abs() <= 1.0 || got.is_nan())
        }
    }
}

/// The same bits, or both NaN.
pub fn same(got: f32, want: f32) -> bool {
    got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan())
}

/// Distance in ulps: the number of representable floats from one to the other (0 for equal
/// bits; the zeros are 1 apart, infinity is one past the largest finite float).
pub fn ulps(a: f32, b: f32) -> u64 {
    if a.to_bits() == b.to_bits() {
        return 0;
    }
    let key = |x: f32| {
        let b = x.to_bits() as i64;
        if b & 0x8000_0000 != 0 {
            -(b & 0x7fff_ffff)
        } else {
            b
        }
    };
    (key(a) - key(b)).unsigned_abs().max(1)
}
