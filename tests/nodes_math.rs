//! The math nodes, run through the interpreter in f32 and f64 against values computed by
//! hand or with f64 `std` functions (never with `shadenet_graph::ops`), including the hard
//! inputs of DESIGN §7.
mod common;
use common::*;
use shadenet_graph::ir::Builder;
use shadenet_graph::lower::{Literal, declare_output, lower_single};
use shadenet_graph::nodes::{InputVal, LowVal, NodeInputs, NodeLibrary, lowering};
use shadenet_graph::types::{ConstValue, Type};
use std::f64::consts::{E, FRAC_PI_2, FRAC_PI_4, PI};

/// `ln(f32::MIN_POSITIVE)`: what `log` returns for arguments ≤ 0.
fn log_floor() -> f64 {
    (f32::MIN_POSITIVE as f64).ln()
}

fn v2(x: f64, y: f64) -> Literal {
    Literal::Const(ConstValue::Vec2([x, y]))
}

fn run(node: &str, ty: Type, inputs: &[(&str, Literal)]) -> Outputs {
    eval_node(node, ty, inputs, &plane_fragment(), &[])
}

/// Asserts output `out` equals `want`: within 1e-12 relative in f64 and within `tol32`
/// relative in f32 (relative to `max(1, |want|)`); and that the f32 guard caught nothing.
fn expect_tol(o: &Outputs, out: &str, want: &[f64], tol32: f64) {
    let scale = |w: &[f64]| w.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    assert_close(
        &o.get(out),
        want,
        1e-12 * scale(want),
        &format!("{out} (f64)"),
    );
    assert_close(
        &o.get32(out),
        want,
        tol32 * scale(want),
        &format!("{out} (f32)"),
    );
    assert_eq!(o.nonfinite32, 0, "{out}: guard caught non-finite values");
}

fn expect(o: &Outputs, out: &str, want: &[f64]) {
    expect_tol(o, out, want, 1e-6);
}

/// Runs a one-output node with `T = float` and returns (f64 result, f32 result).
fn scalar(node: &str, out: &str, inputs: &[(&str, Literal)]) -> (f64, f64) {
    let o = run(node, Type::Float, inputs);
    (o.get(out)[0], o.get32(out)[0])
}

#[test]
fn add_subtract_float_and_color() {
    expect(
        &run(
            "add",
            Type::Float,
            &[("input1", f(1.5)), ("input2", f(2.25))],
        ),
        "out",
        &[3.75],
    );
    expect(
        &run(
            "add",
            Type::Color,
            &[("input1", c(1.0, 2.0, 3.0)), ("input2", f(0.5))],
        ),
        "out",
        &[1.5, 2.5, 3.5],
    );
    expect(
        &run(
            "subtract",
            Type::Float,
            &[("input1", f(5.0)), ("input2", f(7.5))],
        ),
        "out",
        &[-2.5],
    );
    expect(
        &run(
            "subtract",
            Type::Color,
            &[("input1", c(1.0, 2.0, 3.0)), ("input2", c(0.5, 3.0, -1.0))],
        ),
        "out",
        &[0.5, -1.0, 4.0],
    );
    // Defaults: 0 + 0.
    expect(&run("add", Type::Vec2, &[]), "out", &[0.0, 0.0]);
}

#[test]
fn multiply_and_its_overflow() {
    expect(
        &run(
            "multiply",
            Type::Float,
            &[("input1", f(3.0)), ("input2", f(-2.0))],
        ),
        "out",
        &[-6.0],
    );
    expect(
        &run(
            "multiply",
            Type::Color,
            &[("input1", c(1.0, 2.0, 3.0)), ("input2", c(0.5, -1.0, 0.0))],
        ),
        "out",
        &[0.5, -2.0, 0.0],
    );
    // input2 defaults to 1: the identity.
    expect(
        &run("multiply", Type::Vec3, &[("input1", v(1.0, -2.0, 0.25))]),
        "out",
        &[1.0, -2.0, 0.25],
    );
    // 1e30² overflows f32 to inf: the guard zeroes and counts it; f64 is exact.
    let o = run(
        "multiply",
        Type::Float,
        &[("input1", f(1e30)), ("input2", f(1e30))],
    );
    assert_close(&o.get("out"), &[1e60], 1e48, "f64 product");
    assert_eq!(o.get32("out"), vec![0.0]);
    assert_eq!(o.nonfinite32, 1);
}

#[test]
fn divide_is_total() {
    expect(
        &run(
            "divide",
            Type::Float,
            &[("input1", f(1.0)), ("input2", f(4.0))],
        ),
        "out",
        &[0.25],
    );
    expect(
        &run(
            "divide",
            Type::Float,
            &[("input1", f(1.0)), ("input2", f(0.0))],
        ),
        "out",
        &[0.0],
    );
    expect(
        &run(
            "divide",
            Type::Float,
            &[("input1", f(0.0)), ("input2", f(0.0))],
        ),
        "out",
        &[0.0],
    );
    expect(
        &run(
            "divide",
            Type::Color,
            &[("input1", c(1.0, 2.0, 3.0)), ("input2", c(2.0, 0.0, -4.0))],
        ),
        "out",
        &[0.5, 0.0, -0.75],
    );
}

#[test]
fn multiply_divide_operations() {
    let a = v(-2.0, -2.0, 4.0);
    let b = v(3.0, 0.5, 0.5);
    let go = |op: &str| {
        run(
            "multiplyDivide",
            Type::Float,
            &[
                ("input1", a.clone()),
                ("input2", b.clone()),
                ("operation", s(op)),
            ],
        )
    };
    expect(&go("noOperation"), "output", &[-2.0, -2.0, 4.0]);
    expect(&go("multiply"), "output", &[-6.0, -1.0, 2.0]);
    expect(&go("divide"), "output", &[-2.0 / 3.0, -4.0, 8.0]);
    // power: (−2)³ = −8, (−2)^0.5 = 0 (total), 4^0.5 = 2.
    expect(&go("power"), "output", &[-8.0, 0.0, 2.0]);
    // Maya defaults: input1 (0,0,0), input2 (1,1,1), operation multiply.
    expect(
        &run("multiplyDivide", Type::Float, &[("input1", a.clone())]),
        "output",
        &[-2.0, -2.0, 4.0],
    );
    // Division by a zero component.
    expect(
        &run(
            "multiplyDivide",
            Type::Float,
            &[
                ("input1", v(1.0, 2.0, 3.0)),
                ("input2", v(0.0, 4.0, 0.0)),
                ("operation", s("divide")),
            ],
        ),
        "output",
        &[0.0, 0.5, 0.0],
    );
    // An unknown operation is a lowering error, not a panic.
    let lib = NodeLibrary::standard();
    let r = lower_single(
        &lib,
        "multiplyDivide",
        Type::Float,
        &[("operation", s("modulo"))],
    );
    assert!(r.is_err());
}

#[test]
fn dot_cross() {
    expect(
        &run(
            "dot",
            Type::Vec3,
            &[("input1", v(1.0, 2.0, 3.0)), ("input2", v(4.0, -5.0, 6.0))],
        ),
        "out",
        &[12.0],
    );
    expect(
        &run(
            "dot",
            Type::Color,
            &[("input1", c(0.5, 0.5, 1.0)), ("input2", c(2.0, 4.0, 0.25))],
        ),
        "out",
        &[3.25],
    );
    expect(
        &run(
            "dot",
            Type::Vec2,
            &[("input1", v2(1.0, -1.0)), ("input2", v2(3.0, 2.0))],
        ),
        "out",
        &[1.0],
    );
    expect(
        &run(
            "cross",
            Type::Float,
            &[("input1", v(1.0, 0.0, 0.0)), ("input2", v(0.0, 1.0, 0.0))],
        ),
        "out",
        &[0.0, 0.0, 1.0],
    );
    // (1,2,3) × (4,5,6) = (2·6 − 3·5, 3·4 − 1·6, 1·5 − 2·4).
    expect(
        &run(
            "cross",
            Type::Float,
            &[("input1", v(1.0, 2.0, 3.0)), ("input2", v(4.0, 5.0, 6.0))],
        ),
        "out",
        &[-3.0, 6.0, -3.0],
    );
    // Parallel and zero inputs.
    expect(
        &run(
            "cross",
            Type::Float,
            &[("input1", v(1.0, 2.0, 3.0)), ("input2", v(2.0, 4.0, 6.0))],
        ),
        "out",
        &[0.0, 0.0, 0.0],
    );
    expect(&run("cross", Type::Float, &[]), "out", &[0.0, 0.0, 0.0]);
}

#[test]
fn normalize_length_distance() {
    expect(
        &run("normalize", Type::Vec3, &[("input", v(3.0, 4.0, 0.0))]),
        "out",
        &[0.6, 0.8, 0.0],
    );
    expect(
        &run("normalize", Type::Vec2, &[("input", v2(0.0, -2.0))]),
        "out",
        &[0.0, -1.0],
    );
    let k = 1.0 / 3f64.sqrt();
    expect(
        &run("normalize", Type::Color, &[("input", c(2.0, 2.0, 2.0))]),
        "out",
        &[k, k, k],
    );
    // normalize(0) = 0.
    expect(
        &run("normalize", Type::Vec3, &[("input", v(0.0, 0.0, 0.0))]),
        "out",
        &[0.0, 0.0, 0.0],
    );
    // A vector whose squared length overflows f32 normalizes to zero there (documented);
    // f64 gets the unit vector.
    let o = run("normalize", Type::Vec3, &[("input", v(1e30, 0.0, 0.0))]);
    assert_eq!(o.get("out"), vec![1.0, 0.0, 0.0]);
    assert_eq!(o.get32("out"), vec![0.0, 0.0, 0.0]);
    assert_eq!(o.nonfinite32, 0);
    // A denormal vector: the squared length underflows to 0 in f32, so it normalizes to 0;
    // f64 gets the unit vector.
    let o = run("normalize", Type::Vec3, &[("input", v(1e-40, 0.0, 0.0))]);
    assert_eq!(o.get("out"), vec![1.0, 0.0, 0.0]);
    assert_eq!(o.get32("out"), vec![0.0, 0.0, 0.0]);

    expect(
        &run("length", Type::Vec2, &[("input", v2(3.0, -4.0))]),
        "out",
        &[5.0],
    );
    expect(
        &run("length", Type::Vec3, &[("input", v(1.0, 2.0, 2.0))]),
        "out",
        &[3.0],
    );
    expect(
        &run("length", Type::Color, &[("input", c(0.0, 0.0, 0.0))]),
        "out",
        &[0.0],
    );
    expect(
        &run(
            "distance",
            Type::Vec3,
            &[("input1", v(1.0, 1.0, 1.0)), ("input2", v(4.0, 5.0, 1.0))],
        ),
        "out",
        &[5.0],
    );
    expect(
        &run(
            "distance",
            Type::Vec2,
            &[("input1", v2(0.5, 0.5)), ("input2", v2(0.5, 0.5))],
        ),
        "out",
        &[0.0],
    );
}

#[test]
fn rounding_nodes() {
    let x = c(-1.5, 2.25, -0.0);
    expect(
        &run("abs", Type::Color, &[("input", x.clone())]),
        "out",
        &[1.5, 2.25, 0.0],
    );
    expect(
        &run("floor", Type::Color, &[("input", x.clone())]),
        "out",
        &[-2.0, 2.0, 0.0],
    );
    expect(
        &run("ceil", Type::Color, &[("input", x.clone())]),
        "out",
        &[-1.0, 3.0, 0.0],
    );
    expect(
        &run("fract", Type::Color, &[("input", x)]),
        "out",
        &[0.5, 0.25, 0.0],
    );
    // fract of a tiny negative number: 1 − 1e−9 in f64, which rounds to exactly 1 in f32.
    let (d, s32) = scalar("fract", "out", &[("input", f(-1e-9))]);
    assert!((d - (1.0 - 1e-9)).abs() < 1e-15, "{d}");
    assert_eq!(s32, 1.0);
}

#[test]
fn exp_log_sqrt() {
    expect(&run("exp", Type::Float, &[("input", f(1.0))]), "out", &[E]);
    expect(
        &run("exp", Type::Color, &[("input", c(0.0, -1.0, 2.0))]),
        "out",
        &[1.0, (-1f64).exp(), 2f64.exp()],
    );
    // exp(100) overflows f32 (guarded to 0 and counted), not f64.
    let o = run("exp", Type::Float, &[("input", f(100.0))]);
    assert_close(&o.get("out"), &[100f64.exp()], 1e31, "exp(100) f64");
    assert_eq!(o.get32("out"), vec![0.0]);
    assert_eq!(o.nonfinite32, 1);

    expect(&run("log", Type::Float, &[("input", f(E))]), "out", &[1.0]);
    // log(0) and log(−1) = ln(f32::MIN_POSITIVE), in both precisions.
    let lf = log_floor();
    assert!((lf + 87.336_544_750_553_1).abs() < 1e-9);
    expect(
        &run("log", Type::Color, &[("input", c(0.0, -1.0, 4.0))]),
        "out",
        &[lf, lf, 4f64.ln()],
    );

    expect(
        &run("sqrt", Type::Color, &[("input", c(2.0, 0.0, 0.25))]),
        "out",
        &[2f64.sqrt(), 0.0, 0.5],
    );
    // sqrt of a negative number is 0.
    expect(
        &run("sqrt", Type::Float, &[("input", f(-4.0))]),
        "out",
        &[0.0],
    );
}

#[test]
fn trigonometry() {
    for x in [-2.0f64, -0.5, 0.0, 0.3, 1.0, 2.5] {
        for (node, want) in [("sin", x.sin()), ("cos", x.cos()), ("tan", x.tan())] {
            expect(&run(node, Type::Float, &[("input", f(x))]), "out", &[want]);
        }
    }
    expect(
        &run("sin", Type::Color, &[("input", c(0.0, FRAC_PI_2, -1.0))]),
        "out",
        &[0.0, 1.0, (-1f64).sin()],
    );
    for (node, fun) in [("cos", f64::cos as fn(f64) -> f64), ("tan", f64::tan)] {
        expect(
            &run(node, Type::Color, &[("input", c(0.0, 1.25, -0.5))]),
            "out",
            &[fun(0.0), fun(1.25), fun(-0.5)],
        );
    }
    // asin/acos clamp their argument.
    expect(
        &run("asin", Type::Color, &[("input", c(0.5, 2.0, -5.0))]),
        "out",
        &[0.5f64.asin(), FRAC_PI_2, -FRAC_PI_2],
    );
    expect(
        &run("acos", Type::Color, &[("input", c(0.5, 2.0, -3.0))]),
        "out",
        &[0.5f64.acos(), 0.0, PI],
    );
    // atan2(y, x).
    expect(
        &run(
            "atan2",
            Type::Color,
            &[("y", c(1.0, 1.0, -1.0)), ("x", c(1.0, -1.0, 0.0))],
        ),
        "out",
        &[FRAC_PI_4, 3.0 * FRAC_PI_4, -FRAC_PI_2],
    );
    expect(
        &run("atan2", Type::Float, &[("y", f(0.0)), ("x", f(0.0))]),
        "out",
        &[0.0],
    );
}

#[test]
fn min_max_clamp_and_nan() {
    expect(
        &run(
            "min",
            Type::Color,
            &[("input1", c(1.0, -2.0, 3.0)), ("input2", c(0.5, 0.0, 3.0))],
        ),
        "out",
        &[0.5, -2.0, 3.0],
    );
    expect(
        &run(
            "max",
            Type::Color,
            &[("input1", c(1.0, -2.0, 3.0)), ("input2", c(0.5, 0.0, 3.0))],
        ),
        "out",
        &[1.0, 0.0, 3.0],
    );
    // A NaN first operand yields the second (x86 minss/maxss).
    for node in ["min", "max"] {
        expect(
            &run(
                node,
                Type::Float,
                &[("input1", f(f64::NAN)), ("input2", f(1.0))],
            ),
            "out",
            &[1.0],
        );
        // A NaN second operand is returned, and caught by the guard.
        let o = run(
            node,
            Type::Float,
            &[("input1", f(1.0)), ("input2", f(f64::NAN))],
        );
        assert_eq!(o.get32("out"), vec![0.0]);
        assert_eq!(o.get("out"), vec![0.0]);
        assert_eq!(o.nonfinite32, 1);
    }
    expect(
        &run("clamp", Type::Color, &[("input", c(-1.0, 0.5, 2.0))]),
        "output",
        &[0.0, 0.5, 1.0],
    );
    // min > max gives max; NaN gives min.
    expect(
        &run(
            "clamp",
            Type::Float,
            &[("input", f(0.5)), ("min", f(2.0)), ("max", f(1.0))],
        ),
        "output",
        &[1.0],
    );
    expect(
        &run(
            "clamp",
            Type::Float,
            &[("input", f(f64::NAN)), ("min", f(0.25)), ("max", f(1.0))],
        ),
        "output",
        &[0.25],
    );
}

#[test]
fn mod_is_floored_and_total() {
    let cases = [
        (5.5f64, 2.0f64),
        (-1.0, 3.0),
        (1.0, -3.0),
        (-7.25, -2.0),
        (7.0, 0.0),
    ];
    for (a, b) in cases {
        let want = if b == 0.0 {
            0.0
        } else {
            a - b * (a / b).floor()
        };
        expect(
            &run("mod", Type::Float, &[("input1", f(a)), ("input2", f(b))]),
            "out",
            &[want],
        );
    }
    // By hand: the result has the sign of the divisor.
    expect(
        &run(
            "mod",
            Type::Color,
            &[("input1", c(5.5, -1.0, 7.0)), ("input2", c(2.0, 3.0, 0.0))],
        ),
        "out",
        &[1.5, 2.0, 0.0],
    );
    expect(
        &run(
            "mod",
            Type::Float,
            &[("input1", f(1.0)), ("input2", f(-3.0))],
        ),
        "out",
        &[-2.0],
    );
}

#[test]
fn pow_hard_bases() {
    let cases = [
        (2.0, 10.0, 1024.0),
        (-2.0, 3.0, -8.0),
        (-2.0, 2.0, 4.0),
        (-2.0, 0.5, 0.0),
        (-8.0, -1.0, -0.125),
        (-8.0, 1.0 / 3.0, 0.0),
        (0.0, -1.0, 0.0),
        (0.0, 0.0, 1.0),
        (9.0, 0.5, 3.0),
    ];
    for (a, e, want) in cases {
        expect(
            &run("pow", Type::Float, &[("base", f(a)), ("exponent", f(e))]),
            "out",
            &[want],
        );
    }
    expect(
        &run(
            "pow",
            Type::Color,
            &[("base", c(-2.0, -2.0, 4.0)), ("exponent", c(3.0, 0.5, 1.5))],
        ),
        "out",
        &[-8.0, 0.0, 8.0],
    );
}

#[test]
fn mix_and_blend() {
    let a = c(1.0, 2.0, 3.0);
    let b = c(3.0, 2.0, -1.0);
    let go = |w: f64| {
        run(
            "mix",
            Type::Color,
            &[
                ("input1", a.clone()),
                ("input2", b.clone()),
                ("weight", f(w)),
            ],
        )
    };
    expect(&go(0.0), "out", &[1.0, 2.0, 3.0]);
    expect(&go(1.0), "out", &[3.0, 2.0, -1.0]);
    expect(&go(0.25), "out", &[1.5, 2.0, 2.0]);
    // Extrapolation.
    expect(&go(2.0), "out", &[5.0, 2.0, -5.0]);
    expect(
        &run(
            "mix",
            Type::Float,
            &[
                ("input1", f(10.0)),
                ("input2", f(20.0)),
                ("weight", f(0.75)),
            ],
        ),
        "out",
        &[17.5],
    );

    let blend = |w: f64| {
        run(
            "blend",
            Type::Float,
            &[
                ("color1", a.clone()),
                ("color2", b.clone()),
                ("blender", f(w)),
            ],
        )
    };
    expect(&blend(1.0), "output", &[1.0, 2.0, 3.0]);
    expect(&blend(0.0), "output", &[3.0, 2.0, -1.0]);
    // color1·0.25 + color2·0.75.
    expect(&blend(0.25), "output", &[2.5, 2.0, 0.0]);
    // Maya defaults: red and blue at 0.5.
    expect(&run("blend", Type::Float, &[]), "output", &[0.5, 0.0, 0.5]);
}

/// The GLSL smoothstep in f64, with the documented step for equal edges.
fn smoothstep_ref(e0: f64, e1: f64, x: f64) -> f64 {
    if e0 == e1 {
        return if x >= e0 { 1.0 } else { 0.0 };
    }
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[test]
fn smoothstep_including_equal_edges() {
    let cases = [
        (0.0, 1.0, -1.0),
        (0.0, 1.0, 0.25),
        (0.0, 1.0, 0.5),
        (0.0, 1.0, 2.0),
        (-2.0, 6.0, 1.0),
        // Reversed edges: the mirrored curve.
        (1.0, 0.0, 0.25),
        // Equal edges: a hard step, 1 at the edge.
        (0.5, 0.5, 0.25),
        (0.5, 0.5, 0.5),
        (0.5, 0.5, 0.75),
    ];
    for (e0, e1, x) in cases {
        expect(
            &run(
                "smoothstep",
                Type::Float,
                &[("edge0", f(e0)), ("edge1", f(e1)), ("x", f(x))],
            ),
            "out",
            &[smoothstep_ref(e0, e1, x)],
        );
    }
    // By hand.
    let (d, _) = scalar(
        "smoothstep",
        "out",
        &[("edge0", f(0.0)), ("edge1", f(1.0)), ("x", f(0.25))],
    );
    assert_eq!(d, 0.15625);
    let (d, _) = scalar(
        "smoothstep",
        "out",
        &[("edge0", f(1.0)), ("edge1", f(0.0)), ("x", f(0.25))],
    );
    assert_eq!(d, 0.84375);
    // Per component: the middle component has equal edges.
    expect(
        &run(
            "smoothstep",
            Type::Color,
            &[
                ("edge0", c(0.0, 1.0, 0.0)),
                ("edge1", c(1.0, 1.0, 2.0)),
                ("x", c(0.5, 1.0, 0.5)),
            ],
        ),
        "out",
        &[0.5, 1.0, smoothstep_ref(0.0, 2.0, 0.5)],
    );
    // A NaN x gives 0.
    expect(
        &run("smoothstep", Type::Float, &[("x", f(f64::NAN))]),
        "out",
        &[0.0],
    );
}

#[test]
fn remap_including_equal_old_range() {
    let go = |x: f64, o0: f64, o1: f64, n0: f64, n1: f64| {
        run(
            "remap",
            Type::Float,
            &[
                ("value", f(x)),
                ("oldMin", f(o0)),
                ("oldMax", f(o1)),
                ("newMin", f(n0)),
                ("newMax", f(n1)),
            ],
        )
    };
    expect(&go(0.5, 0.0, 1.0, 10.0, 20.0), "outValue", &[15.0]);
    expect(&go(2.0, 0.0, 1.0, 10.0, 20.0), "outValue", &[30.0]);
    expect(&go(-1.0, -3.0, 1.0, 1.0, 0.0), "outValue", &[0.5]);
    // oldMin == oldMax: newMin.
    expect(&go(0.7, 2.0, 2.0, 4.0, 9.0), "outValue", &[4.0]);
    expect(
        &run(
            "remap",
            Type::Color,
            &[
                ("value", c(0.0, 0.5, 1.0)),
                ("oldMin", c(0.0, 0.0, 1.0)),
                ("oldMax", c(1.0, 2.0, 1.0)),
                ("newMin", f(-1.0)),
                ("newMax", f(1.0)),
            ],
        ),
        "outValue",
        &[-1.0, -0.5, -1.0],
    );
}

#[test]
fn invert_luminance_hsv() {
    expect(
        &run("invert", Type::Color, &[("input", c(0.25, 1.0, 2.0))]),
        "output",
        &[0.75, 0.0, -1.0],
    );
    expect(
        &run("invert", Type::Float, &[("input", f(0.125))]),
        "output",
        &[0.875],
    );
    expect(
        &run("luminance", Type::Float, &[("value", c(1.0, 1.0, 1.0))]),
        "outValue",
        &[1.0],
    );
    expect(
        &run("luminance", Type::Float, &[("value", c(0.5, 0.25, 2.0))]),
        "outValue",
        &[0.2126 * 0.5 + 0.7152 * 0.25 + 0.0722 * 2.0],
    );

    // Hand values.
    let hsv = |r: f64, g: f64, b: f64| {
        run("rgbToHsv", Type::Float, &[("inRgb", c(r, g, b))]).get("outHsv")
    };
    assert_close(&hsv(1.0, 0.0, 0.0), &[0.0, 1.0, 1.0], 1e-12, "red");
    assert_close(&hsv(0.0, 0.5, 0.5), &[0.5, 1.0, 0.5], 1e-12, "teal");
    assert_close(&hsv(0.25, 0.25, 0.25), &[0.0, 0.0, 0.25], 1e-12, "grey");
    assert_close(&hsv(0.0, 0.0, 0.0), &[0.0, 0.0, 0.0], 1e-12, "black");
    // An independent (textbook) RGB → HSV on ordinary colors, in both precisions.
    for rgb in [
        [0.2, 0.4, 0.8],
        [0.9, 0.3, 0.6],
        [0.5, 0.7, 0.1],
        [1.0, 0.2, 0.9],
    ] {
        let want = hsv_ref(rgb);
        let o = run(
            "rgbToHsv",
            Type::Float,
            &[("inRgb", c(rgb[0], rgb[1], rgb[2]))],
        );
        expect(&o, "outHsv", &want);
        let back = run(
            "hsvToRgb",
            Type::Float,
            &[("inHsv", c(want[0], want[1], want[2]))],
        );
        expect(&back, "outRgb", &rgb);
    }
    let rgb = |h: f64, s_: f64, v_: f64| run("hsvToRgb", Type::Float, &[("inHsv", c(h, s_, v_))]);
    expect(&rgb(0.0, 1.0, 1.0), "outRgb", &[1.0, 0.0, 0.0]);
    expect(&rgb(1.0 / 3.0, 1.0, 1.0), "outRgb", &[0.0, 1.0, 0.0]);
    // The hue wraps: 1.25 ≡ 0.25, a yellow-green (0.5, 1, 0).
    expect(&rgb(1.25, 1.0, 1.0), "outRgb", &[0.5, 1.0, 0.0]);
    expect(&rgb(0.7, 0.0, 0.5), "outRgb", &[0.5, 0.5, 0.5]);
}

/// Textbook RGB → HSV (hue in [0, 1)).
fn hsv_ref([r, g, b]: [f64; 3]) -> [f64; 3] {
    let mx = r.max(g).max(b);
    let mn = r.min(g).min(b);
    let d = mx - mn;
    let h = if d == 0.0 {
        0.0
    } else if mx == r {
        ((g - b) / d).rem_euclid(6.0)
    } else if mx == g {
        (b - r) / d + 2.0
    } else {
        (r - g) / d + 4.0
    };
    let s = if mx == 0.0 { 0.0 } else { d / mx };
    [h / 6.0, s, mx]
}

#[test]
fn non_finite_inputs_are_caught_by_the_output_guard() {
    // NaN in a float: the output is zeroed in both precisions and counted.
    let o = run(
        "add",
        Type::Float,
        &[("input1", f(f64::NAN)), ("input2", f(1.0))],
    );
    assert_eq!(o.get("out"), vec![0.0]);
    assert_eq!(o.get32("out"), vec![0.0]);
    assert_eq!(o.nonfinite32, 1);
    // inf and NaN components of a color: each counted, the finite one kept.
    let o = run(
        "multiply",
        Type::Color,
        &[
            ("input1", c(f64::INFINITY, 2.0, f64::NAN)),
            ("input2", f(0.5)),
        ],
    );
    assert_eq!(o.get32("out"), vec![0.0, 1.0, 0.0]);
    assert_eq!(o.nonfinite32, 2);
    // inf · 0 = NaN, also caught.
    let o = run(
        "multiply",
        Type::Float,
        &[("input1", f(f64::INFINITY)), ("input2", f(0.0))],
    );
    assert_eq!(o.get32("out"), vec![0.0]);
    assert_eq!(o.nonfinite32, 1);
    // sqrt(inf) = inf; normalize of an infinite vector is NaN: both guarded.
    let o = run("sqrt", Type::Float, &[("input", f(f64::INFINITY))]);
    assert_eq!((o.get32("out")[0], o.nonfinite32), (0.0, 1));
    let o = run(
        "normalize",
        Type::Vec3,
        &[("input", v(f64::INFINITY, 0.0, 0.0))],
    );
    assert_eq!(o.get32("out"), vec![0.0, 0.0, 0.0]);
    assert!(o.nonfinite32 >= 1);
    // Ops that select instead of computing absorb a NaN: clamp (smoothstep: see its test).
    let o = run("clamp", Type::Float, &[("input", f(f64::NAN))]);
    assert_eq!((o.get32("output")[0], o.nonfinite32), (0.0, 0));
}

#[test]
fn parts_survive_multiply_add_mix_blend_through_the_interpreter() {
    // input: a color with a diffuse and a specular part, made with `contribution` (so each
    // part is computed only when its component is active); then each carrying node is
    // lowered with it and run with every mask.
    let lib = NodeLibrary::standard();
    for (node, ports) in [
        ("multiply", &["input1", "input2"][..]),
        ("add", &["input1", "input2"][..]),
        ("mix", &["input1", "input2", "weight"][..]),
        ("blend", &["color1", "color2", "blender"][..]),
    ] {
        let def = lib.get(node).expect("node");
        let mut b = Builder::new(node);
        let tagged = |b: &mut Builder, d: [f64; 3], s_: [f64; 3]| {
            let pd = lowering::contribution(b, "diffuse", Type::Color, |b| b.color(d));
            let ps = lowering::contribution(b, "specular", Type::Color, |b| b.color(s_));
            lowering::sum_parts(b, Type::Color, vec![pd, ps])
        };
        let x = tagged(&mut b, [1.0, 2.0, 3.0], [0.5, 0.5, 0.5]);
        // add and mix need parts on both sides; multiply scales by an untagged factor.
        let y = if node == "multiply" {
            LowVal::plain(b.color([2.0, 0.5, 4.0]))
        } else {
            tagged(&mut b, [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
        };
        let mut values = vec![InputVal::Value(x), InputVal::Value(y)];
        if ports.len() == 3 {
            values.push(InputVal::Value(LowVal::plain(b.float(0.25))));
        }
        let ni = NodeInputs {
            node,
            def,
            generic: Type::Color,
            values,
            upstream: None,
        };
        let outs = (def.lower)(&mut b, &ni).expect("lowers");
        let out = def.outputs[0].name;
        declare_output(&mut b, out, &outs[0]);
        let prog = b.finish().expect("valid");
        let lin = |a: [f64; 3], b_: [f64; 3], wa: f64, wb: f64| -> Vec<f64> {
            (0..3).map(|i| a[i] * wa + b_[i] * wb).collect()
        };
        let (want_d, want_s) = match node {
            "multiply" => (vec![2.0, 1.0, 12.0], vec![1.0, 0.25, 2.0]),
            "add" => (vec![1.0, 3.0, 3.0], vec![1.5, 0.5, 0.5]),
            // input1·0.75 + input2·0.25
            "mix" => (
                lin([1.0, 2.0, 3.0], [0.0, 1.0, 0.0], 0.75, 0.25),
                lin([0.5; 3], [1.0, 0.0, 0.0], 0.75, 0.25),
            ),
            // color1·0.25 + color2·0.75
            _ => (
                lin([1.0, 2.0, 3.0], [0.0, 1.0, 0.0], 0.25, 0.75),
                lin([0.5; 3], [1.0, 0.0, 0.0], 0.25, 0.75),
            ),
        };
        let all = run_program(&prog, &plane_fragment(), &[], u32::MAX);
        let part = |o: &Outputs, k: &str| o.part(out, k).unwrap_or_else(|| panic!("{node} {k}"));
        assert_close(&part(&all, "diffuse"), &want_d, 1e-12, node);
        assert_close(&part(&all, "specular"), &want_s, 1e-12, node);
        let total: Vec<f64> = want_d.iter().zip(&want_s).map(|(a, b)| a + b).collect();
        assert_close(&all.get(out), &total, 1e-12, node);
        // Only diffuse active: the specular part is computed as zero.
        let k = prog.component_index("diffuse").expect("diffuse") as u32;
        let only_d = run_program(&prog, &plane_fragment(), &[], 1 << k);
        assert_close(&part(&only_d, "diffuse"), &want_d, 1e-12, node);
        assert_close(&part(&only_d, "specular"), &[0.0; 3], 0.0, node);
    }
}

/// One node of the sweep: name, output, generic type, inputs as (port, values to try).
type Sweep = (
    &'static str,
    &'static str,
    Type,
    Vec<(&'static str, Vec<f64>)>,
);

/// Difference between the f32 and f64 runs relative to `max(|f64 value|, 1)`: relative for
/// large results, absolute for results below 1 (inputs are of order 1, so a small result
/// comes from cancellation, e.g. in `remap` or `subtract`, and is only as accurate as the
/// inputs' scale).
fn rel(a32: f64, a64: f64) -> f64 {
    (a32 - a64).abs() / a64.abs().max(1.0)
}

/// The f32 and f64 runs agree on ordinary inputs. All inputs are dyadic (exact in f32), so
/// the difference is the f32 rounding of the ops alone. Bound: 1e-6 relative (to
/// `max(|x|, 1)`, see [`rel`]) for every node, transcendental ones (exp, log, sin, cos, tan,
/// asin, acos, atan2, pow) included.
#[test]
fn f32_agrees_with_f64_on_ordinary_inputs() {
    let g = vec![-2.5, -1.0, -0.375, 0.0, 0.125, 0.5, 0.75, 1.0, 1.5, 3.25];
    let pos = vec![0.125, 0.5, 0.75, 1.0, 1.5, 3.25, 10.0];
    let unit = vec![-1.0, -0.75, -0.5, -0.125, 0.0, 0.375, 0.875, 1.0];
    let small = vec![-1.0, 0.0, 0.5, 1.25];
    let mut sweeps: Vec<Sweep> = Vec::new();
    for node in [
        "abs", "floor", "ceil", "fract", "exp", "sin", "cos", "tan", "invert",
    ] {
        let out = if node == "invert" { "output" } else { "out" };
        sweeps.push((node, out, Type::Float, vec![("input", g.clone())]));
    }
    sweeps.push(("log", "out", Type::Float, vec![("input", pos.clone())]));
    sweeps.push(("sqrt", "out", Type::Float, vec![("input", pos.clone())]));
    for node in ["asin", "acos"] {
        sweeps.push((node, "out", Type::Float, vec![("input", unit.clone())]));
    }
    for node in ["add", "subtract", "multiply", "divide", "min", "max", "mod"] {
        sweeps.push((
            node,
            "out",
            Type::Float,
            vec![("input1", g.clone()), ("input2", g.clone())],
        ));
    }
    sweeps.push((
        "pow",
        "out",
        Type::Float,
        vec![
            ("base", g.clone()),
            ("exponent", vec![-2.0, -0.5, 0.5, 1.0, 2.0, 3.0]),
        ],
    ));
    sweeps.push((
        "atan2",
        "out",
        Type::Float,
        vec![("y", g.clone()), ("x", g.clone())],
    ));
    sweeps.push((
        "mix",
        "out",
        Type::Color,
        vec![
            ("input1", g.clone()),
            ("input2", g.clone()),
            ("weight", small.clone()),
        ],
    ));
    sweeps.push((
        "clamp",
        "output",
        Type::Float,
        vec![
            ("input", g.clone()),
            ("min", small.clone()),
            ("max", small.clone()),
        ],
    ));
    sweeps.push((
        "smoothstep",
        "out",
        Type::Float,
        vec![
            ("edge0", small.clone()),
            ("edge1", small.clone()),
            ("x", g.clone()),
        ],
    ));
    sweeps.push((
        "remap",
        "outValue",
        Type::Float,
        vec![
            ("value", g.clone()),
            ("oldMin", small.clone()),
            ("oldMax", small.clone()),
            ("newMin", vec![-1.0, 2.0]),
            ("newMax", vec![0.5, 4.0]),
        ],
    ));
    for node in ["normalize", "length"] {
        sweeps.push((node, "out", Type::Vec3, vec![("input", g.clone())]));
    }
    for node in ["dot", "distance"] {
        sweeps.push((
            node,
            "out",
            Type::Vec3,
            vec![("input1", g.clone()), ("input2", small.clone())],
        ));
    }
    let mut worst: (f64, String) = (0.0, String::new());
    for (node, out, ty, ports) in &sweeps {
        // Every combination of the port values; vectors get (x, x/2, −x) per port so their
        // components differ.
        let mut combos: Vec<Vec<f64>> = vec![Vec::new()];
        for (_, vals) in ports {
            combos = combos
                .into_iter()
                .flat_map(|c| {
                    vals.iter().map(move |x| {
                        let mut c = c.clone();
                        c.push(*x);
                        c
                    })
                })
                .collect();
        }
        for combo in combos {
            let inputs: Vec<(&str, Literal)> = ports
                .iter()
                .zip(&combo)
                .map(|((p, _), &x)| {
                    let lit = match ty {
                        Type::Float => f(x),
                        Type::Vec3 => v(x, x * 0.5, -x),
                        _ => c(x, x * 0.5, -x),
                    };
                    // `weight` is a float port whatever T is.
                    let lit = if *p == "weight" { f(x) } else { lit };
                    (*p, lit)
                })
                .collect();
            let o = run(node, *ty, &inputs);
            assert_eq!(o.nonfinite32, 0, "{node} {combo:?}");
            for (a32, a64) in o.get32(out).iter().zip(o.get(out)) {
                let r = rel(*a32, a64);
                if r > worst.0 {
                    worst = (r, format!("{node} {combo:?}: f32 {a32} f64 {a64}"));
                }
            }
        }
    }
    println!(
        "worst relative f32/f64 difference: {:.3e} at {}",
        worst.0, worst.1
    );
    assert!(worst.0 <= 1e-6, "worst {:.3e} at {}", worst.0, worst.1);
}
