//! The geometry nodes (samplerInfo, place2d, pointMatrixMult), run through the interpreter
//! in f32 and f64 against values computed by hand or with independent f64 matrix code.
mod common;
use common::*;
use shadenet_graph::ir::Program;
use shadenet_graph::lower::{Literal, lower_single};
use shadenet_graph::nodes::NodeLibrary;
use shadenet_graph::types::{ConstValue, Type};
use shadenet_runtime::{Fragment, Interpreter, ShadeCtx, ShadeEnv, Transform};

type V3 = [f64; 3];

fn v2(x: f64, y: f64) -> Literal {
    Literal::Const(ConstValue::Vec2([x, y]))
}

fn mat(m: [f64; 16]) -> Literal {
    Literal::Const(ConstValue::Matrix44(m))
}

fn boolean(b: bool) -> Literal {
    Literal::Const(ConstValue::Bool(b))
}

/// Runs `program` on `frag` in f32 and f64 with the space transforms of `env` (the common
/// harness uses identity transforms).
fn run_env(program: &Program, frag: &Fragment, env: &ShadeEnv) -> Outputs {
    let ctx = ShadeCtx::new(*frag, env);
    let i32_ = Interpreter::<f32>::new(program).expect("textures load");
    let i64_ = Interpreter::<f64>::new(program).expect("textures load");
    let (o32, o64) = (i32_.shade(&ctx), i64_.shade(&ctx));
    let entries = i32_
        .slots()
        .iter()
        .map(|slot| {
            let w = slot.ty.width().max(1);
            let r = slot.offset..slot.offset + w;
            let v32 = o32.values[r.clone()].iter().map(|x| *x as f64).collect();
            (slot.name.clone(), None, v32, o64.values[r].to_vec())
        })
        .collect();
    Outputs {
        entries,
        nonfinite32: o32.nonfinite,
        loop_limits: [o32.loop_limits, 0],
    }
}

fn sampler_info(space: &str, frag: &Fragment, env: &ShadeEnv) -> Outputs {
    let lib = NodeLibrary::standard();
    let prog =
        lower_single(&lib, "samplerInfo", Type::Float, &[("space", s(space))]).expect("lowers");
    run_env(&prog, frag, env)
}

/// Asserts output `out` is `want` within `tol` (relative to `max(1, |want|)`) in both
/// precisions.
fn expect_tol(o: &Outputs, out: &str, want: &[f64], tol64: f64, tol32: f64) {
    let scale = want.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    assert_close(&o.get(out), want, tol64 * scale, &format!("{out} (f64)"));
    assert_close(&o.get32(out), want, tol32 * scale, &format!("{out} (f32)"));
    assert_eq!(o.nonfinite32, 0, "{out}");
}

fn expect(o: &Outputs, out: &str, want: &[f64]) {
    expect_tol(o, out, want, 1e-12, 1e-6);
}

// ---- independent f64 vector and matrix code ----

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    if l == 0.0 { [0.0; 3] } else { a.map(|x| x / l) }
}

/// `M·(p, w)` for a row-major matrix.
fn mul(m: &[f64; 16], p: V3, w: f64) -> V3 {
    std::array::from_fn(|r| {
        m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3] * w
    })
}

/// `Mᵀ·(n, 0)`.
fn mul_transposed(m: &[f64; 16], n: V3) -> V3 {
    std::array::from_fn(|c| m[c] * n[0] + m[4 + c] * n[1] + m[8 + c] * n[2])
}

/// A fragment with non-unit, non-axis-aligned streams (all exact in f32 but `n`, which is
/// (0, 0.6, 0.8) rounded to f32).
fn tilted_fragment() -> Fragment {
    Fragment {
        p: [1.0, 2.0, -3.0],
        n: [0.0, 0.6, 0.8],
        ng: [0.0, 0.0, 1.0],
        i: [0.0, 3.0, -4.0],
        uv: [0.25, 0.75],
        dpdu: [2.0, 0.0, 0.0],
        dpdv: [0.0, 0.5, 0.5],
        ..Fragment::default()
    }
}

#[test]
fn sampler_info_world_space() {
    let env = ShadeEnv::default();
    let o = sampler_info("world", &plane_fragment(), &env);
    expect(&o, "P", &[0.0, 0.0, 0.0]);
    expect(&o, "N", &[0.0, 0.0, 1.0]);
    expect(&o, "Ng", &[0.0, 0.0, 1.0]);
    expect(&o, "I", &[0.0, 0.0, -1.0]);
    expect(&o, "uv", &[0.5, 0.5]);
    expect(&o, "dPdu", &[1.0, 0.0, 0.0]);
    expect(&o, "dPdv", &[0.0, 1.0, 0.0]);
    expect(&o, "facingRatio", &[1.0]);

    // I is normalized: (0, 3, −4)/5. N is (0, 0.6, 0.8) as rounded to f32 by the fragment
    // (world-space normals are passed on unchanged); facingRatio = dot(N, −I), about
    // 0.6·(−0.6) + 0.8·0.8 = 0.28.
    let frag = tilted_fragment();
    let n = frag.n.map(|x| x as f64);
    let o = sampler_info("world", &frag, &env);
    expect(&o, "P", &[1.0, 2.0, -3.0]);
    expect(&o, "N", &n);
    expect(&o, "I", &[0.0, 0.6, -0.8]);
    expect(&o, "uv", &[0.25, 0.75]);
    expect(&o, "dPdu", &[2.0, 0.0, 0.0]);
    expect(&o, "dPdv", &[0.0, 0.5, 0.5]);
    let facing = -n[1] * 0.6 + n[2] * 0.8;
    assert!((facing - 0.28).abs() < 1e-7);
    expect(&o, "facingRatio", &[facing]);
}

#[test]
fn sampler_info_hard_fragments() {
    let env = ShadeEnv::default();
    // A back-facing normal: facingRatio clamps to 0.
    let mut frag = plane_fragment();
    frag.n = [0.0, 0.0, -1.0];
    expect(&sampler_info("world", &frag, &env), "facingRatio", &[0.0]);
    // Grazing: I perpendicular to N.
    let mut frag = plane_fragment();
    frag.i = [1.0, 0.0, 0.0];
    expect(&sampler_info("world", &frag, &env), "facingRatio", &[0.0]);
    // Zero I and zero N: everything stays finite and zero.
    let mut frag = plane_fragment();
    frag.i = [0.0; 3];
    frag.n = [0.0; 3];
    for space in ["world", "camera", "object"] {
        let o = sampler_info(space, &frag, &env);
        expect(&o, "I", &[0.0; 3]);
        expect(&o, "N", &[0.0; 3]);
        expect(&o, "facingRatio", &[0.0]);
    }
    // A denormal incident direction: f64 normalizes it, f32 underflows to zero (both
    // finite).
    let mut frag = plane_fragment();
    frag.i = [0.0, 0.0, -1e-40];
    let o = sampler_info("world", &frag, &env);
    assert_eq!(o.get("I"), vec![0.0, 0.0, -1.0]);
    assert_eq!(o.get32("I"), vec![0.0, 0.0, 0.0]);
    assert_eq!(o.nonfinite32, 0);
    // A non-finite stream is caught by the guard.
    let mut frag = plane_fragment();
    frag.p = [f32::INFINITY, 0.0, f32::NAN];
    let o = sampler_info("world", &frag, &env);
    assert_eq!(o.get32("P"), vec![0.0, 0.0, 0.0]);
    assert_eq!(o.nonfinite32, 2);
    // An unknown space is a lowering error.
    let lib = NodeLibrary::standard();
    assert!(lower_single(&lib, "samplerInfo", Type::Float, &[("space", s("screen"))]).is_err());
}

/// A camera and an object transform with a non-uniform scale.
fn env_with_transforms() -> ShadeEnv {
    let camera =
        Transform::look_at([3.0, 4.0, 5.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]).expect("camera");
    // world → object: scale (2, 1, 0.5), then translate by (1, −2, 0.5).
    let object = Transform::new([
        2.0, 0.0, 0.0, 1.0, //
        0.0, 1.0, 0.0, -2.0, //
        0.0, 0.0, 0.5, 0.5, //
        0.0, 0.0, 0.0, 1.0,
    ])
    .expect("object");
    ShadeEnv {
        camera,
        object,
        ..ShadeEnv::default()
    }
}

#[test]
fn sampler_info_camera_and_object_space() {
    let env = env_with_transforms();
    let frag = tilted_fragment();
    let f3 = |v: [f32; 3]| v.map(|x| x as f64);
    let world_facing = dot(f3(frag.n), normalize(f3(frag.i)).map(|x| -x)).max(0.0);
    for (space, t) in [("camera", env.camera), ("object", env.object)] {
        let o = sampler_info(space, &frag, &env);
        let m = &t.m;
        expect(&o, "P", &mul(m, f3(frag.p), 1.0));
        // Normals: inverse transpose, then renormalized.
        expect(&o, "N", &normalize(mul_transposed(&t.inv, f3(frag.n))));
        expect(&o, "Ng", &normalize(mul_transposed(&t.inv, f3(frag.ng))));
        expect(&o, "I", &normalize(mul(m, f3(frag.i), 0.0)));
        expect(&o, "dPdu", &mul(m, f3(frag.dpdu), 0.0));
        expect(&o, "dPdv", &mul(m, f3(frag.dpdv), 0.0));
        expect(&o, "uv", &[0.25, 0.75]);
        // facingRatio is the world-space cosine whatever the space.
        expect(&o, "facingRatio", &[world_facing]);
    }
    // Sanity of the reference: the object space scales, so its unnormalized normal differs
    // in length from the world one.
    let n_obj = mul_transposed(&env.object.inv, f3(frag.n));
    assert!((dot(n_obj, n_obj).sqrt() - 1.0).abs() > 0.1);
}

fn place(inputs: &[(&str, Literal)], frag: &Fragment) -> Outputs {
    eval_node("place2d", Type::Float, inputs, frag, &[])
}

/// place2d in f64: rotate about (0.5, 0.5) counterclockwise, then repeat and offset.
fn place_ref(uv: [f64; 2], rep: [f64; 2], off: [f64; 2], deg: f64) -> [f64; 2] {
    let (s, c) = deg.to_radians().sin_cos();
    let (du, dv) = (uv[0] - 0.5, uv[1] - 0.5);
    let r = [c * du - s * dv + 0.5, s * du + c * dv + 0.5];
    [r[0] * rep[0] + off[0], r[1] * rep[1] + off[1]]
}

#[test]
fn place2d_repeat_offset_rotate() {
    // Defaults: the identity on the uv stream, exactly, even for values not exact in binary.
    let mut frag = plane_fragment();
    frag.uv = [0.1, 0.7];
    let o = place(&[], &frag);
    assert_eq!(o.get32("outUV"), vec![0.1f32 as f64, 0.7f32 as f64]);
    assert_eq!(o.get("outUV"), vec![0.1f32 as f64, 0.7f32 as f64]);
    // Repeat and offset on the stream (uv = (0.5, 0.5)): by hand (1, 1.5) + (0.1, −0.5).
    let o = place(
        &[
            ("repeatU", f(2.0)),
            ("repeatV", f(3.0)),
            ("offsetU", f(0.1)),
            ("offsetV", f(-0.5)),
        ],
        &plane_fragment(),
    );
    expect(&o, "outUV", &[1.1, 1.0]);
    // 90° about the center: (0.25, 0.75) → (0.25, 0.25) by hand; then ×(2, 1) + (0, 1).
    let o = place(
        &[
            ("uvCoord", v2(0.25, 0.75)),
            ("rotateUV", f(90.0)),
            ("repeatU", f(2.0)),
            ("offsetV", f(1.0)),
        ],
        &plane_fragment(),
    );
    expect(&o, "outUV", &[0.5, 1.25]);
    // The center is fixed by any rotation.
    let o = place(&[("rotateUV", f(37.0))], &plane_fragment());
    expect(&o, "outUV", &[0.5, 0.5]);
    // Against the f64 formula, including a negative repeat and a large angle.
    for (uv, rep, off, deg) in [
        ([0.1, 0.9], [1.0, 1.0], [0.0, 0.0], 30.0),
        ([0.0, 0.0], [4.0, -2.0], [0.5, 0.25], -45.0),
        ([1.5, -0.5], [0.5, 3.0], [-1.0, 2.0], 725.0),
    ] {
        let o = place(
            &[
                ("uvCoord", v2(uv[0], uv[1])),
                ("repeatU", f(rep[0])),
                ("repeatV", f(rep[1])),
                ("offsetU", f(off[0])),
                ("offsetV", f(off[1])),
                ("rotateUV", f(deg)),
            ],
            &plane_fragment(),
        );
        expect(&o, "outUV", &place_ref(uv, rep, off, deg));
    }
    // A NaN offset reaches the output and is caught by the guard.
    let o = place(&[("offsetU", f(f64::NAN))], &plane_fragment());
    assert_eq!(o.get32("outUV"), vec![0.0, 0.5]);
    assert_eq!(o.nonfinite32, 1);
}

#[test]
fn point_matrix_mult() {
    // Rotate 90° about z ((x, y) → (−y, x)), then translate by (10, 20, 30).
    let m = [
        0.0, -1.0, 0.0, 10.0, //
        1.0, 0.0, 0.0, 20.0, //
        0.0, 0.0, 1.0, 30.0, //
        0.0, 0.0, 0.0, 1.0,
    ];
    let go = |inputs: &[(&str, Literal)]| {
        eval_node(
            "pointMatrixMult",
            Type::Float,
            inputs,
            &plane_fragment(),
            &[],
        )
    };
    let p = v(1.0, 2.0, 3.0);
    expect(
        &go(&[("inMatrix", mat(m)), ("inPoint", p.clone())]),
        "output",
        &[8.0, 21.0, 33.0],
    );
    expect(
        &go(&[
            ("inMatrix", mat(m)),
            ("inPoint", p.clone()),
            ("vectorMultiply", boolean(true)),
        ]),
        "output",
        &[-2.0, 1.0, 3.0],
    );
    // Default matrix: the identity.
    expect(&go(&[("inPoint", p.clone())]), "output", &[1.0, 2.0, 3.0]);
    // The bottom row is ignored (no perspective divide).
    let mut persp = m;
    persp[12..].copy_from_slice(&[0.0, 0.0, 1.0, 0.0]);
    expect(
        &go(&[("inMatrix", mat(persp)), ("inPoint", p.clone())]),
        "output",
        &[8.0, 21.0, 33.0],
    );
    // Against the independent product, on a general affine matrix.
    let g = [
        0.5, -1.25, 2.0, 0.1, //
        3.0, 0.75, -0.5, -2.0, //
        -1.0, 0.25, 1.5, 4.0, //
        0.0, 0.0, 0.0, 1.0,
    ];
    for (q, vector) in [([0.3, -0.7, 1.9], false), ([0.3, -0.7, 1.9], true)] {
        let o = go(&[
            ("inMatrix", mat(g)),
            ("inPoint", v(q[0], q[1], q[2])),
            ("vectorMultiply", boolean(vector)),
        ]);
        expect(&o, "output", &mul(&g, q, if vector { 0.0 } else { 1.0 }));
    }
    // An overflowing product is caught by the guard in f32.
    let o = go(&[("inMatrix", mat(g)), ("inPoint", v(1e38, 1e38, 0.0))]);
    assert!(o.nonfinite32 >= 1);
}

/// f32 and f64 agree on ordinary inputs: bound 1e-6 relative to `max(|x|, 1)` (place2d
/// includes sin/cos; samplerInfo transforms and normalizes).
#[test]
fn f32_agrees_with_f64() {
    let env = env_with_transforms();
    let mut worst = (0.0f64, String::new());
    let mut check = |o: &Outputs, out: &str, what: &str| {
        for (a, b) in o.get32(out).iter().zip(o.get(out)) {
            let r = (a - b).abs() / b.abs().max(1.0);
            if r > worst.0 {
                worst = (r, format!("{what} {out}: {a} vs {b}"));
            }
        }
    };
    let mut frag = tilted_fragment();
    for k in 0..6 {
        let t = k as f32 * 0.37;
        frag.p = [t.sin() * 3.0, t.cos(), 1.0 - t];
        frag.n = [t.cos() * 0.6, 0.8, t.sin() * 0.6];
        frag.i = [0.1 + t, -1.0, -2.0 * t];
        for space in ["world", "camera", "object"] {
            let o = sampler_info(space, &frag, &env);
            for out in ["P", "N", "Ng", "I", "uv", "dPdu", "dPdv", "facingRatio"] {
                check(&o, out, space);
            }
        }
        let o = place(
            &[
                ("uvCoord", v2(0.1 * k as f64, 0.9 - 0.05 * k as f64)),
                ("rotateUV", f(17.0 * k as f64 - 40.0)),
                ("repeatU", f(1.5)),
                ("repeatV", f(-2.0)),
                ("offsetU", f(0.3)),
            ],
            &frag,
        );
        check(&o, "outUV", "place2d");
    }
    println!(
        "worst relative f32/f64 difference: {:.3e} at {}",
        worst.0, worst.1
    );
    assert!(worst.0 <= 1e-6, "{:.3e} at {}", worst.0, worst.1);
}
