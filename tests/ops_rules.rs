//! DESIGN §7: every op is total, in f32 and in f64, and the output guard catches the rest.

use shadenet_graph::ir::{BinOp, Builder, Stream, UnOp};
use shadenet_graph::ops::{self, Real, Val};
use shadenet_runtime::{Fragment, Interpreter, ShadeCtx, ShadeEnv};

fn check_total<F: Real>() {
    let f = F::from_f64;
    let z = F::ZERO;
    // x / 0 = 0, also 0/0 and inf/0
    assert_eq!(ops::div(f(1.0), z), z);
    assert_eq!(ops::div(z, z), z);
    assert_eq!(ops::div(f(f64::INFINITY), z), z);
    assert_eq!(ops::div(f(-3.0), f(-0.0)), z);
    // sqrt of negatives
    assert_eq!(ops::sqrt(f(-4.0)), z);
    assert_eq!(ops::sqrt(f(4.0)), f(2.0));
    // pow(neg, non-integer) = 0; pow(neg, integer) keeps the sign; 0^negative = 0
    assert_eq!(ops::pow(f(-2.0), f(0.5)), z);
    assert_eq!(ops::pow(f(-2.0), f(3.0)), f(-8.0));
    assert_eq!(ops::pow(f(-2.0), f(2.0)), f(4.0));
    assert_eq!(ops::pow(z, f(-1.0)), z);
    // asin/acos clamp
    assert_eq!(ops::asin(f(2.0)), f(std::f64::consts::FRAC_PI_2));
    assert_eq!(ops::acos(f(-7.0)), f(std::f64::consts::PI));
    // log(x <= 0) = ln(f32::MIN_POSITIVE)
    let lmin = f((f32::MIN_POSITIVE as f64).ln());
    assert_eq!(ops::log(z), lmin);
    assert_eq!(ops::log(f(-1.0)), lmin);
    assert!(lmin.to_f64() < -87.0 && lmin.to_f64() > -88.0);
    // mod(x, 0) = 0; mod has the sign of the divisor
    assert_eq!(ops::fmod(f(5.0), z), z);
    assert_eq!(ops::fmod(f(-1.0), f(3.0)), f(2.0));
    assert_eq!(ops::fmod(f(1.0), f(-3.0)), f(-2.0));
    // normalize(0) = 0, also for a denormal vector whose squared length underflows
    assert_eq!(ops::normalize([z; 3]), [z; 3]);
    let tiny = f(1e-30);
    let n = ops::normalize([tiny, z, z]);
    assert!(n.iter().all(|x| x.is_finite()));
    // min/max: exactly a<b?a:b and a>b?a:b (a NaN in `a` yields `b`)
    let nan = f(f64::NAN);
    assert_eq!(ops::min(nan, f(1.0)), f(1.0));
    assert_eq!(ops::max(nan, f(1.0)), f(1.0));
    assert!(ops::min(f(1.0), nan).is_nan());
    // integer ops wrap and divide totally
    assert_eq!(
        ops::binary::<F>(BinOp::Add, Val::Int(i32::MAX), Val::Int(1)),
        Val::Int(i32::MIN)
    );
    assert_eq!(
        ops::binary::<F>(BinOp::Div, Val::Int(7), Val::Int(0)),
        Val::Int(0)
    );
    assert_eq!(
        ops::binary::<F>(BinOp::Mod, Val::Int(7), Val::Int(0)),
        Val::Int(0)
    );
    assert_eq!(
        ops::binary::<F>(BinOp::Div, Val::Int(i32::MIN), Val::Int(-1)),
        Val::Int(i32::MIN)
    );
    assert_eq!(
        ops::unary::<F>(UnOp::Neg, Val::Int(i32::MIN)),
        Val::Int(i32::MIN)
    );
    // float → int conversion saturates, NaN → 0
    let to_int = |x: f64| ops::convert(shadenet_graph::types::Type::Int, Val::Float(f(x)));
    assert_eq!(to_int(1e20), Val::Int(i32::MAX));
    assert_eq!(to_int(f64::NAN), Val::Int(0));
    assert_eq!(to_int(-2.7), Val::Int(-2));
}

#[test]
fn ops_are_total_in_f32() {
    check_total::<f32>();
}

#[test]
fn ops_are_total_in_f64() {
    check_total::<f64>();
}

#[test]
fn guard_zeroes_and_counts_nonfinite_outputs() {
    // P * 1e30 * 1e30 overflows f32 (inf) but not f64; P/P is NaN-free by the total division.
    let mut b = Builder::new("guard");
    let p = b.stream(Stream::P);
    let big = b.vec3([1e30, 1e30, 1e30]);
    let x = b.mul(p, big);
    let y = b.mul(x, big);
    b.output("y", None, y);
    let q = b.div(p, p);
    b.output("q", None, q);
    let prog = b.finish().unwrap();
    shadenet_graph::ir::validate(&prog).unwrap();
    let env = ShadeEnv::default();
    let frag = Fragment {
        p: [1.0, -1.0, 0.0],
        ..Fragment::default()
    };
    let ctx = ShadeCtx::new(frag, &env);
    let o32 = Interpreter::<f32>::new(&prog).unwrap().shade(&ctx);
    assert_eq!(
        o32.nonfinite, 2,
        "x and y components overflow to ±inf in f32"
    );
    assert_eq!(&o32.values[..3], &[0.0, 0.0, 0.0]);
    assert_eq!(
        &o32.values[3..],
        &[1.0, 1.0, 0.0],
        "0/0 = 0 by the total division"
    );
    let o64 = Interpreter::<f64>::new(&prog).unwrap().shade(&ctx);
    assert_eq!(o64.nonfinite, 0);
    assert_eq!(o64.values[0], 1e30 * 1e30);
}

/// vec4 and color4 values: component-wise arithmetic, the total division and normalize, and
/// the constant folder's direction keeps color4 apart from vec4.
#[test]
fn four_component_values() {
    let a: Val<f32> = Val::Vec4([1.0, -2.0, 0.0, 4.0]);
    let b: Val<f32> = Val::Vec4([2.0, 0.0, 0.0, -0.5]);
    assert_eq!(
        ops::binary(BinOp::Div, a, b),
        Val::Vec4([0.5, 0.0, 0.0, -8.0])
    );
    assert_eq!(
        ops::binary(BinOp::Min, a, b),
        Val::Vec4([1.0, -2.0, 0.0, -0.5])
    );
    assert_eq!(ops::binary(BinOp::Dot, a, b), Val::Float(0.0));
    assert_eq!(
        ops::unary(UnOp::Length, Val::<f64>::Vec4([1.0, 1.0, 1.0, 1.0])),
        Val::Float(2.0)
    );
    assert_eq!(
        ops::unary(UnOp::Normalize, Val::<f64>::Vec4([0.0, 0.0, 3.0, 4.0])),
        Val::Vec4([0.0, 0.0, 0.6, 0.8])
    );
    assert_eq!(
        ops::unary(UnOp::Normalize, Val::<f32>::Vec4([0.0; 4])),
        Val::Vec4([0.0; 4])
    );
    let c = ops::construct::<f32>(
        shadenet_graph::types::Type::Color4,
        &[
            Val::Float(1.0),
            Val::Float(0.5),
            Val::Float(0.25),
            Val::Float(0.0),
        ],
    );
    assert_eq!(
        c.to_const(shadenet_graph::types::Type::Color4),
        shadenet_graph::types::ConstValue::Color4([1.0, 0.5, 0.25, 0.0])
    );
    assert_eq!(ops::extract(c, 3), Val::Float(0.0));
    assert_eq!(
        ops::splat::<f32>(shadenet_graph::types::Type::Vec4, Val::Float(2.0)),
        Val::Vec4([2.0; 4])
    );
}
