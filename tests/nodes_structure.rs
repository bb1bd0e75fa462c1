//! The structure nodes (split, merge, constants, switch, condition), run through the
//! interpreter in f32 and f64 against values worked out by hand.
mod common;
use common::*;
use shadenet_graph::ir::{Builder, Op, Program};
use shadenet_graph::lower::{Literal, declare_output, lower_single};
use shadenet_graph::nodes::{InputVal, LowVal, NodeInputs, NodeLibrary};
use shadenet_graph::types::{ConstValue, Type};

fn run(node: &str, ty: Type, inputs: &[(&str, Literal)]) -> Outputs {
    eval_node(node, ty, inputs, &plane_fragment(), &[])
}

fn v2(x: f64, y: f64) -> Literal {
    Literal::Const(ConstValue::Vec2([x, y]))
}

fn int(i: i32) -> Literal {
    Literal::Const(ConstValue::Int(i))
}

fn boolean(b: bool) -> Literal {
    Literal::Const(ConstValue::Bool(b))
}

/// Asserts output `out` is exactly `want` in f64 and within f32 rounding in f32, with
/// nothing caught by the guard.
fn expect(o: &Outputs, out: &str, want: &[f64]) {
    assert_close(&o.get(out), want, 0.0, &format!("{out} (f64)"));
    let w32: Vec<f64> = want.iter().map(|x| *x as f32 as f64).collect();
    assert_close(&o.get32(out), &w32, 0.0, &format!("{out} (f32)"));
    assert_eq!(o.nonfinite32, 0, "{out}");
}

/// Number of `If` regions in a program.
fn if_count(p: &Program) -> usize {
    let mut n = 0;
    p.walk(&p.body, &mut |v| {
        if matches!(p.op(v), Op::If { .. }) {
            n += 1;
        }
    });
    n
}

#[test]
fn split_vec3_color_vec2() {
    let o = run("split", Type::Vec3, &[("input", v(1.0, -2.0, 0.1))]);
    expect(&o, "x", &[1.0]);
    expect(&o, "y", &[-2.0]);
    expect(&o, "z", &[0.1]);
    let o = run("split", Type::Color, &[("input", c(0.25, 0.5, 0.75))]);
    expect(&o, "x", &[0.25]);
    expect(&o, "y", &[0.5]);
    expect(&o, "z", &[0.75]);
    // vec2: z is 0.
    let o = run("split", Type::Vec2, &[("input", v2(4.0, 5.0))]);
    expect(&o, "x", &[4.0]);
    expect(&o, "y", &[5.0]);
    expect(&o, "z", &[0.0]);
}

#[test]
fn merge_builds_every_vector() {
    let o = run(
        "merge",
        Type::Float,
        &[("x", f(1.0)), ("y", f(2.0)), ("z", f(-0.3))],
    );
    expect(&o, "outVec3", &[1.0, 2.0, -0.3]);
    expect(&o, "outColor", &[1.0, 2.0, -0.3]);
    expect(&o, "outVec2", &[1.0, 2.0]);
    // Defaults: zeros.
    let o = run("merge", Type::Float, &[]);
    expect(&o, "outVec3", &[0.0; 3]);
}

#[test]
fn constants_of_every_type() {
    expect(
        &run("constantBool", Type::Float, &[("value", boolean(true))]),
        "out",
        &[1.0],
    );
    expect(&run("constantBool", Type::Float, &[]), "out", &[0.0]);
    expect(
        &run("constantInt", Type::Float, &[("value", int(-7))]),
        "out",
        &[-7.0],
    );
    expect(
        &run("constantFloat", Type::Float, &[("value", f(2.5))]),
        "out",
        &[2.5],
    );
    expect(
        &run("constantVec2", Type::Float, &[("value", v2(0.5, -1.0))]),
        "out",
        &[0.5, -1.0],
    );
    expect(
        &run("constantVec3", Type::Float, &[("value", v(1.0, 2.0, 3.0))]),
        "out",
        &[1.0, 2.0, 3.0],
    );
    expect(
        &run("constantColor", Type::Float, &[("value", c(0.1, 0.2, 0.3))]),
        "out",
        &[0.1, 0.2, 0.3],
    );
    // A non-finite literal passes through and is caught by the output guard.
    let o = run("constantFloat", Type::Float, &[("value", f(f64::NAN))]);
    assert_eq!(o.get32("out"), vec![0.0]);
    assert_eq!(o.nonfinite32, 1);
    let o = run(
        "constantColor",
        Type::Float,
        &[("value", c(f64::INFINITY, 1.0, f64::NEG_INFINITY))],
    );
    assert_eq!(o.get32("out"), vec![0.0, 1.0, 0.0]);
    assert_eq!(o.nonfinite32, 2);
    // Strings never reach the IR: there is no constantString.
    assert!(NodeLibrary::standard().get("constantString").is_none());
}

#[test]
fn constant_matrix_feeds_point_matrix_mult() {
    // A row-major matrix: scale x by 2, then translate by (1, 2, 3).
    let m = [
        2.0, 0.0, 0.0, 1.0, //
        0.0, 1.0, 0.0, 2.0, //
        0.0, 0.0, 1.0, 3.0, //
        0.0, 0.0, 0.0, 1.0,
    ];
    let lib = NodeLibrary::standard();
    // Alone, the node's output is the matrix constant.
    let prog = lower_single(
        &lib,
        "constantMatrix",
        Type::Float,
        &[("value", Literal::Const(ConstValue::Matrix44(m)))],
    )
    .expect("lowers");
    let out = prog.outputs[0].value;
    assert_eq!(prog.op(out), &Op::Const(ConstValue::Matrix44(m)));
    // Its default is the identity.
    let prog = lower_single(&lib, "constantMatrix", Type::Float, &[]).expect("lowers");
    assert_eq!(
        prog.op(prog.outputs[0].value),
        &Op::Const(ConstValue::identity())
    );

    // Chained into pointMatrixMult: M·(p, 1) and M·(p, 0).
    for (vector, want) in [(false, [3.0, 1.0, 2.0]), (true, [2.0, -1.0, -1.0])] {
        let mut b = Builder::new("t");
        let cm = lib.get("constantMatrix").expect("node");
        let mv = b.constant(ConstValue::Matrix44(m));
        let ni = NodeInputs {
            node: "m",
            def: cm,
            generic: Type::Float,
            values: vec![InputVal::Value(LowVal::plain(mv))],
            upstream: None,
        };
        let mat = (cm.lower)(&mut b, &ni).expect("lowers").remove(0);
        let pmm = lib.get("pointMatrixMult").expect("node");
        let p = b.vec3([1.0, -1.0, -1.0]);
        let flag = b.boolean(vector);
        let ni = NodeInputs {
            node: "x",
            def: pmm,
            generic: Type::Float,
            values: vec![
                InputVal::Value(mat),
                InputVal::Value(LowVal::plain(p)),
                InputVal::Value(LowVal::plain(flag)),
            ],
            upstream: None,
        };
        let r = (pmm.lower)(&mut b, &ni).expect("lowers");
        declare_output(&mut b, "output", &r[0]);
        let prog = b.finish().expect("valid");
        let o = run_program(&prog, &plane_fragment(), &[], u32::MAX);
        expect(&o, "output", &want);
    }
}

fn switch_inputs(vals: &[f64]) -> Literal {
    Literal::Array(vals.iter().map(|x| vec![ConstValue::Float(*x)]).collect())
}

#[test]
fn switch_picks_by_index_and_falls_back_to_default() {
    let inputs = switch_inputs(&[10.0, 20.0, 30.0]);
    for (sel, want) in [
        (0, 10.0),
        (1, 20.0),
        (2, 30.0),
        (3, -1.0),
        (-1, -1.0),
        (i32::MIN, -1.0),
        (i32::MAX, -1.0),
    ] {
        let o = run(
            "switch",
            Type::Float,
            &[
                ("selector", int(sel)),
                ("inputs", inputs.clone()),
                ("default", f(-1.0)),
            ],
        );
        expect(&o, "out", &[want]);
    }
    // Colors; a float default broadcast.
    let arr = Literal::Array(vec![
        vec![ConstValue::Color([1.0, 0.0, 0.0])],
        vec![ConstValue::Color([0.0, 1.0, 0.0])],
    ]);
    let go = |sel: i32| {
        run(
            "switch",
            Type::Color,
            &[
                ("selector", int(sel)),
                ("inputs", arr.clone()),
                ("default", f(0.5)),
            ],
        )
    };
    expect(&go(1), "out", &[0.0, 1.0, 0.0]);
    expect(&go(2), "out", &[0.5, 0.5, 0.5]);
    expect(&go(-3), "out", &[0.5, 0.5, 0.5]);
    // No inputs at all: the default, and no region.
    let o = run(
        "switch",
        Type::Float,
        &[("selector", int(0)), ("default", f(7.0))],
    );
    expect(&o, "out", &[7.0]);
    let lib = NodeLibrary::standard();
    let p = lower_single(&lib, "switch", Type::Float, &[]).expect("lowers");
    assert_eq!(if_count(&p), 0);
    // One nested If per input (no selects), so dead arms can be removed.
    let p = lower_single(
        &lib,
        "switch",
        Type::Float,
        &[("inputs", switch_inputs(&[1.0, 2.0, 3.0, 4.0]))],
    )
    .expect("lowers");
    assert_eq!(if_count(&p), 4);
}

#[test]
fn condition_operations() {
    let ops = [
        "equal",
        "notEqual",
        "greaterThan",
        "greaterOrEqual",
        "lessThan",
        "lessOrEqual",
    ];
    let truth = |op: &str, a: f64, b: f64| match op {
        "equal" => a == b,
        "notEqual" => a != b,
        "greaterThan" => a > b,
        "greaterOrEqual" => a >= b,
        "lessThan" => a < b,
        _ => a <= b,
    };
    let t = [0.25, 0.5, 0.75];
    let e = [1.0, 0.0, 0.5];
    for op in ops {
        for (a, b) in [(1.0, 2.0), (2.0, 2.0), (3.0, 2.0), (f64::NAN, 2.0)] {
            let o = run(
                "condition",
                Type::Float,
                &[
                    ("firstTerm", f(a)),
                    ("secondTerm", f(b)),
                    ("operation", s(op)),
                    ("colorIfTrue", c(t[0], t[1], t[2])),
                    ("colorIfFalse", c(e[0], e[1], e[2])),
                ],
            );
            let want = if truth(op, a, b) { t } else { e };
            expect(&o, "outColor", &want);
        }
    }
    // With a NaN term only notEqual holds (checked by hand, not through `truth`).
    let nan = |op: &str| {
        run(
            "condition",
            Type::Float,
            &[("firstTerm", f(f64::NAN)), ("operation", s(op))],
        )
        .get("outColor")
    };
    assert_eq!(nan("notEqual"), vec![0.0; 3]);
    assert_eq!(nan("equal"), vec![1.0; 3]);
    assert_eq!(nan("lessOrEqual"), vec![1.0; 3]);
    // Maya defaults: 0 equal 0 → colorIfTrue (black).
    expect(
        &run("condition", Type::Float, &[]),
        "outColor",
        &[0.0, 0.0, 0.0],
    );
    let lib = NodeLibrary::standard();
    let p = lower_single(&lib, "condition", Type::Float, &[]).expect("lowers");
    assert_eq!(if_count(&p), 1);
    assert!(
        lower_single(
            &lib,
            "condition",
            Type::Float,
            &[("operation", s("between"))]
        )
        .is_err()
    );
}

/// The structure nodes only move values: f32 equals f64 rounded to f32, exactly (so the
/// relative difference is at most 2⁻²⁴ ≈ 6e-8, well inside 1e-6), on non-dyadic inputs.
#[test]
fn f32_agrees_with_f64() {
    let vals = [0.1, -2.7, 1.0 / 3.0, 1e-3, 12345.678];
    let round = |x: f64| x as f32 as f64;
    let mut worst = 0.0f64;
    let mut check = |o: &Outputs, out: &str| {
        for (a, b) in o.get32(out).iter().zip(o.get(out)) {
            assert_eq!(*a, round(b), "{out}");
            worst = worst.max((a - b).abs() / b.abs().max(1.0));
        }
    };
    for (i, &x) in vals.iter().enumerate() {
        let y = vals[(i + 1) % vals.len()];
        let z = vals[(i + 2) % vals.len()];
        let o = run("split", Type::Vec3, &[("input", v(x, y, z))]);
        for out in ["x", "y", "z"] {
            check(&o, out);
        }
        let o = run(
            "merge",
            Type::Float,
            &[("x", f(x)), ("y", f(y)), ("z", f(z))],
        );
        for out in ["outVec3", "outColor", "outVec2"] {
            check(&o, out);
        }
        let o = run("constantColor", Type::Float, &[("value", c(x, y, z))]);
        check(&o, "out");
        let o = run(
            "switch",
            Type::Color,
            &[
                ("selector", int(i as i32 % 3)),
                (
                    "inputs",
                    Literal::Array(vec![
                        vec![ConstValue::Color([x, y, z])],
                        vec![ConstValue::Color([z, x, y])],
                    ]),
                ),
                ("default", f(y)),
            ],
        );
        check(&o, "out");
        let o = run(
            "condition",
            Type::Float,
            &[
                ("firstTerm", f(x)),
                ("secondTerm", f(y)),
                ("operation", s("lessThan")),
                ("colorIfTrue", c(x, y, z)),
                ("colorIfFalse", c(z, y, x)),
            ],
        );
        check(&o, "outColor");
    }
    assert!(worst <= 1e-6, "{worst}");
}
