//! Screen-space derivatives built into the IR (`Builder::derivs`) and the filtered checker
//! that reads them: chain rules against central differences, uv's derivatives from the
//! surface frame, intrinsics by a difference over the footprint, and the box-filtered
//! checker against a supersampled box.

mod common;
use shadenet::graph::ir::{BinOp, Builder, Intrinsic, Program, Stream, UnOp, Value};
use shadenet::graph::types::{ConstValue, Type};
use shadenet_runtime::{Fragment, Interpreter, ShadeCtx, ShadeEnv};

/// A surface frame whose uv derivatives are known exactly: dP/du = (2, 0, 0), dP/dv =
/// (0, 3, 0), so dP/dx = (0.02, 0.03, 0) is (du, dv) = (0.01, 0.01) and dP/dy = (−0.01,
/// 0.06, 0.5) — off the tangent plane by 0.5 along z, which the projection ignores — is
/// (−0.005, 0.02).
const DUV: [[f64; 2]; 2] = [[0.01, 0.01], [-0.005, 0.02]];

fn fragment(uv: [f64; 2], p: [f64; 3]) -> Fragment {
    Fragment {
        p: p.map(|x| x as f32),
        uv: uv.map(|x| x as f32),
        dpdu: [2.0, 0.0, 0.0],
        dpdv: [0.0, 3.0, 0.0],
        dpdx: [0.02, 0.03, 0.0],
        dpdy: [-0.01, 0.06, 0.5],
        ..Fragment::default()
    }
}

/// Values of every output of `p` at `f`, in f64.
fn eval(p: &Program, f: Fragment) -> Vec<f64> {
    let i = Interpreter::<f64>::new(p).unwrap();
    let env = ShadeEnv::default();
    i.shade(&ShadeCtx::new(f, &env)).values
}

/// Builds `f(b, uv, p)` for each case, outputs each value with its two derivatives, and
/// checks the derivatives against central differences along the screen axes (uv moved by
/// `h·DUV[axis]`, P by `h·dPdaxis`).
/// A case: builds a value from uv and P.
type Case = fn(&mut Builder, Value, Value) -> Value;

fn check_against_differences(cases: &[(&str, Case)]) {
    let mut b = Builder::new("derivs");
    let mut widths = Vec::new();
    for (name, f) in cases {
        let uv = b.stream(Stream::Uv);
        let p = b.stream(Stream::P);
        let v = f(&mut b, uv, p);
        let ty = b.ty(v);
        assert!(ty.is_float_based(), "{name}: {ty}");
        let [dx, dy] = b
            .derivs(v)
            .unwrap_or_else(|| panic!("{name}: no derivatives"));
        b.output(name, None, v);
        b.output(&format!("{name}_dx"), None, dx);
        b.output(&format!("{name}_dy"), None, dy);
        widths.push((*name, ty.width()));
    }
    let prog = b.finish().unwrap();
    shadenet::graph::ir::validate(&prog).unwrap();
    let (uv0, p0) = ([0.3125, 0.40625], [0.25, 0.5, 0.75]);
    let at = eval(&prog, fragment(uv0, p0));
    let h = 1.0 / 64.0;
    let dp = [[0.02, 0.03, 0.0], [-0.01, 0.06, 0.5]];
    for axis in 0..2 {
        let moved = |s: f64| {
            let uv = [0, 1].map(|k| uv0[k] + s * h * DUV[axis][k]);
            let p = [0, 1, 2].map(|k| p0[k] + s * h * dp[axis][k]);
            eval(&prog, fragment(uv, p))
        };
        let (plus, minus) = (moved(1.0), moved(-1.0));
        let mut offset = 0;
        for (name, w) in &widths {
            let d = &at[offset + w * (1 + axis)..offset + w * (2 + axis)];
            for c in 0..*w {
                let fd = (plus[offset + c] - minus[offset + c]) / (2.0 * h);
                let tol = 2e-3 * (1.0 + fd.abs());
                assert!(
                    (d[c] - fd).abs() <= tol,
                    "{name}[{c}] d/d{}: {} vs central difference {fd}",
                    ["x", "y"][axis],
                    d[c]
                );
            }
            offset += 3 * w;
        }
    }
}

#[test]
fn chain_rules_match_central_differences() {
    check_against_differences(&[
        ("uv", |_, uv, _| uv),
        ("p", |_, _, p| p),
        ("scaled", |b, uv, _| {
            let s = b.constant(ConstValue::Vec2([4.0, -2.5]));
            b.mul(uv, s)
        }),
        ("rotated", |b, uv, _| {
            // place2d-style: rotate by 0.7 rad around (0.5, 0.5), then offset and repeat.
            let c = b.constant(ConstValue::Vec2([0.5, 0.5]));
            let q = b.sub(uv, c);
            let (x, y) = (b.extract(q, 0), b.extract(q, 1));
            let (cs, sn) = (b.float(0.7f64.cos()), b.float(0.7f64.sin()));
            let (xc, ys) = (b.mul(x, cs), b.mul(y, sn));
            let (xs, yc) = (b.mul(x, sn), b.mul(y, cs));
            let rx = b.sub(xc, ys);
            let ry = b.add(xs, yc);
            let r = b.construct(Type::Vec2, &[rx, ry]);
            let r = b.add(r, c);
            let rep = b.constant(ConstValue::Vec2([3.0, 5.0]));
            b.mul(r, rep)
        }),
        ("fract", |b, uv, _| {
            let s = b.constant(ConstValue::Vec2([1.5, 1.5]));
            let t = b.mul(uv, s);
            b.unary(UnOp::Fract, t)
        }),
        ("div", |b, uv, _| {
            let (x, y) = (b.extract(uv, 0), b.extract(uv, 1));
            b.div(x, y)
        }),
        ("mod", |b, uv, _| {
            let (x, y) = (b.extract(uv, 0), b.extract(uv, 1));
            let k = b.float(0.17);
            let y2 = b.add(y, k);
            b.binary(BinOp::Mod, x, y2)
        }),
        ("pow", |b, uv, _| {
            let (x, y) = (b.extract(uv, 0), b.extract(uv, 1));
            let e = b.float(2.0);
            let ye = b.add(y, e);
            b.binary(BinOp::Pow, x, ye)
        }),
        ("smooth", |b, uv, _| {
            let x = b.extract(uv, 0);
            let fs = [
                UnOp::Sqrt,
                UnOp::Exp,
                UnOp::Log,
                UnOp::Sin,
                UnOp::Cos,
                UnOp::Tan,
            ];
            let mut acc = b.float(0.0);
            for f in fs {
                let y = b.unary(f, x);
                acc = b.add(acc, y);
            }
            let (s, c) = (b.unary(UnOp::Asin, x), b.unary(UnOp::Acos, x));
            let sc = b.mul(s, c);
            let a = b.unary(UnOp::Abs, sc);
            let n = b.unary(UnOp::Neg, a);
            b.add(acc, n)
        }),
        ("vector", |b, uv, p| {
            let len = b.unary(UnOp::Length, p);
            let n = b.unary(UnOp::Normalize, p);
            let k = b.vec3([0.3, -0.2, 0.9]);
            let cr = b.binary(BinOp::Cross, n, k);
            let d = b.dot(cr, p);
            let dist = b.binary(BinOp::Distance, p, k);
            let (x, y) = (b.extract(uv, 0), b.extract(uv, 1));
            let at = b.binary(BinOp::Atan2, y, x);
            let s = b.add(len, d);
            let s = b.add(s, dist);
            let s = b.add(s, at);
            let sp = b.splat(Type::Vec3, s);
            // x < y at the test point: the select takes the min/max arm.
            let sel = b.binary(BinOp::Lt, x, y);
            let m = b.min(sp, n);
            let m2 = b.max(m, k);
            let picked = b.select(sel, m2, sp);
            let rc = b.retype(Type::Color, picked);
            let sc = b.splat(Type::Color, s);
            b.mul(rc, sc)
        }),
        ("if_outside", |b, uv, _| {
            // Both arms yield values from outside: a select of their derivatives.
            let (x, y) = (b.extract(uv, 0), b.extract(uv, 1));
            let k = b.float(3.0);
            let t = b.mul(x, k);
            let e = b.mul(y, y);
            let c = b.binary(BinOp::Lt, x, y);
            b.if_(c, |_| vec![t], |_| vec![e])[0]
        }),
        ("if_inside", |b, uv, _| {
            // The taken arm computes its yield inside: rebuilt in a new if.
            let (x, y) = (b.extract(uv, 0), b.extract(uv, 1));
            let c = b.binary(BinOp::Lt, x, y);
            b.if_(
                c,
                |b| {
                    let s = b.unary(UnOp::Sin, x);
                    vec![b.mul(s, y)]
                },
                |b| vec![b.add(x, y)],
            )[0]
        }),
        ("normalize", |b, _, p| {
            let q = b.vec3([0.1, -0.3, 0.2]);
            let t = b.add(p, q);
            b.unary(UnOp::Normalize, t)
        }),
        ("matrix", |b, _, p| {
            let m: Vec<f64> = (0..16).map(|k| ((k * 7) % 5) as f64 - 1.5).collect();
            let m = b.constant(ConstValue::from_floats(Type::Matrix44, &m).unwrap());
            b.binary(BinOp::MulPoint, m, p)
        }),
    ]);
}

#[test]
fn uv_derivatives_come_from_the_surface_frame() {
    let mut b = Builder::new("uv");
    let uv = b.stream(Stream::Uv);
    let [dx, dy] = b.derivs(uv).unwrap();
    b.output("dx", None, dx);
    b.output("dy", None, dy);
    let p = b.finish().unwrap();
    let got = eval(&p, fragment([0.5, 0.5], [0.0; 3]));
    let want = [DUV[0][0], DUV[0][1], DUV[1][0], DUV[1][1]];
    for (g, w) in got.iter().zip(want) {
        // The frame is given in f32: exact to its rounding.
        assert!((g - w).abs() < 1e-8, "{got:?} vs {want:?}");
    }
    // A degenerate frame (dP/du ∥ dP/dv) gives no footprint rather than inf or NaN.
    let flat = Fragment {
        dpdv: [4.0, 0.0, 0.0],
        ..fragment([0.5, 0.5], [0.0; 3])
    };
    assert_eq!(eval(&p, flat), vec![0.0; 4]);
}

#[test]
fn values_without_a_path_from_the_streams_have_no_derivatives() {
    let mut b = Builder::new("consts");
    let c = b.float(2.0);
    let n = b.stream(Stream::N);
    let uv = b.stream(Stream::Uv);
    let f = b.unary(UnOp::Floor, uv);
    let i = b.int(3);
    assert!(b.derivs(c).is_none());
    assert!(
        b.derivs(n).is_none(),
        "N is taken as constant across the pixel"
    );
    assert!(b.derivs(f).is_none(), "floor is piecewise constant");
    assert!(b.derivs(i).is_none(), "ints have no derivatives");
}

#[test]
fn intrinsics_differ_over_the_footprint() {
    // d noise = noise(p + ∂p) − noise(p): the change across the pixel, every octave seen.
    let mut b = Builder::new("noise");
    let p = b.stream(Stream::P);
    let s = b.vec3([7.0, 7.0, 7.0]);
    let q = b.mul(p, s);
    let oct = b.int(6);
    let (lac, gain) = (b.float(2.0), b.float(0.5));
    let n = b.call(Intrinsic::Fbm3, &[q, oct, lac, gain]);
    let [dx, _] = b.derivs(n).unwrap();
    b.output("n", None, n);
    b.output("dx", None, dx);
    let prog = b.finish().unwrap();
    let p0 = [0.25, 0.5, 0.75];
    let at = eval(&prog, fragment([0.0; 2], p0));
    let moved = [p0[0] + 0.02, p0[1] + 0.03, p0[2]];
    let there = eval(&prog, fragment([0.0; 2], moved));
    assert!(at[1] != 0.0);
    assert!(
        (at[1] - (there[0] - at[0])).abs() < 1e-6,
        "{at:?} {there:?}"
    );
}

/// The program of a network (JSON) on the standard node library.
fn network(src: &str) -> Program {
    shadenet::compile_json(src, &shadenet::NodeLibrary::standard())
        .unwrap()
        .program
}

/// A checker network on uv with the footprint of `fragment`, scaled by `filter`.
fn checker(filter: f64) -> Program {
    let src = format!(
        r#"{{"nodes": [{{"name": "c", "type": "checker",
              "inputs": {{"color1": [1, 1, 1], "color2": [0, 0, 0], "filter": {filter}}}}}],
            "outputs": {{"c": "c.outColor"}}}}"#
    );
    network(&src)
}

#[test]
fn filtered_checker_is_the_box_average_of_the_checks() {
    // An axis-aligned footprint: uv moves by (w, 0) along x and (0, w) along y, so with
    // filterwidth √(∂x² + ∂y²) the box is w·2 wide (checks are 1/2 wide in uv) per axis.
    let prog = checker(1.0);
    for (w, uv) in [
        (0.1, [0.47, 0.21]),
        (0.3, [0.52, 0.49]),
        (0.05, [0.24, 0.26]),
        (1.7, [0.1, 0.9]),
    ] {
        let f = Fragment {
            uv: [uv[0] as f32, uv[1] as f32],
            dpdu: [1.0, 0.0, 0.0],
            dpdv: [0.0, 1.0, 0.0],
            dpdx: [w as f32, 0.0, 0.0],
            dpdy: [0.0, w as f32, 0.0],
            ..Fragment::default()
        };
        let got = eval(&prog, f)[0];
        // Brute force: the share of color1 over the box of side w (in uv) around uv.
        let n = 400;
        let mut even = 0usize;
        for i in 0..n {
            for j in 0..n {
                let u = uv[0] + w * ((i as f64 + 0.5) / n as f64 - 0.5);
                let v = uv[1] + w * ((j as f64 + 0.5) / n as f64 - 0.5);
                let cell = (2.0 * u).floor() as i64 + (2.0 * v).floor() as i64;
                even += (cell.rem_euclid(2) == 0) as usize;
            }
        }
        let want = even as f64 / (n * n) as f64;
        assert!(
            (got - want).abs() < 5e-3,
            "w {w} uv {uv:?}: {got} vs {want}"
        );
    }
}

/// The share of `color1` over the parallelogram `uv + a·d0 + b·d1`, `a, b ∈ [−½, ½]`, from
/// `n²` samples (checks are 1/2 wide in uv).
fn parallelogram_share(uv: [f64; 2], d0: [f64; 2], d1: [f64; 2]) -> f64 {
    let n = 400;
    let mut even = 0usize;
    for i in 0..n {
        for j in 0..n {
            let a = (i as f64 + 0.5) / n as f64 - 0.5;
            let b = (j as f64 + 0.5) / n as f64 - 0.5;
            let u = uv[0] + a * d0[0] + b * d1[0];
            let v = uv[1] + a * d0[1] + b * d1[1];
            let cell = (2.0 * u).floor() as i64 + (2.0 * v).floor() as i64;
            even += (cell.rem_euclid(2) == 0) as usize;
        }
    }
    even as f64 / (n * n) as f64
}

/// A sheared, elongated footprint (a grazing view off the image's centre line): the checker
/// slices it along its major axis (`CHECKER_PROBES`), where one separable box over the whole
/// parallelogram (the filter before) is far off. Measured against a 400² supersampled
/// parallelogram, the share of `color1` in these four cases: 0.5677 / 0.6392, 0.0396 /
/// 0.0185, 0.5227 / 0.5227, 0.5694 / 0.6142 (worst error 0.072); one separable box gave
/// 0.5352, 0.4993 (for 0.0185: error 0.48), 0.5227, 0.5915.
#[test]
fn filtered_checker_follows_a_sheared_footprint() {
    let prog = checker(1.0);
    let mut worst: f64 = 0.0;
    for (uv, d0, d1) in [
        ([0.31, 0.17], [0.02, 0.0], [0.6, 0.9]),
        ([0.52, 0.49], [0.03, 0.01], [-0.7, 0.8]),
        ([0.1, 0.9], [0.01, 0.0], [1.1, 0.4]),
        ([0.77, 0.36], [0.05, -0.02], [0.5, 1.4]),
    ] {
        let f = Fragment {
            uv: [uv[0] as f32, uv[1] as f32],
            dpdu: [1.0, 0.0, 0.0],
            dpdv: [0.0, 1.0, 0.0],
            dpdx: [d0[0] as f32, d0[1] as f32, 0.0],
            dpdy: [d1[0] as f32, d1[1] as f32, 0.0],
            ..Fragment::default()
        };
        let got = eval(&prog, f)[0];
        let want = parallelogram_share(uv, d0, d1);
        worst = worst.max((got - want).abs());
    }
    assert!(worst < 0.08, "worst {worst}");
}

#[test]
fn checker_without_a_footprint_is_unfiltered_bit_for_bit() {
    for prog in [checker(1.0), checker(0.0)] {
        for (uv, want) in [
            ([0.25f32, 0.25], 1.0),
            ([0.75, 0.25], 0.0),
            ([0.5, 0.5], 1.0),
        ] {
            let f = Fragment {
                uv,
                ..Fragment::default()
            };
            assert_eq!(eval(&prog, f), vec![want; 3], "uv {uv:?}");
        }
    }
    // filter = 0 turns filtering off even with a footprint.
    let f = Fragment {
        uv: [0.49, 0.2],
        dpdu: [1.0, 0.0, 0.0],
        dpdv: [0.0, 1.0, 0.0],
        dpdx: [0.3, 0.0, 0.0],
        dpdy: [0.0, 0.3, 0.0],
        ..Fragment::default()
    };
    assert_eq!(eval(&checker(0.0), f), vec![1.0; 3]);
    let blurred = eval(&checker(1.0), f)[0];
    assert!(blurred > 0.2 && blurred < 0.8, "{blurred}");
    // A huge footprint is the average; NaN differentials fall back to the point value.
    let wide = Fragment {
        dpdx: [1e6, 0.0, 0.0],
        dpdy: [0.0, 1e6, 0.0],
        ..f
    };
    assert!((eval(&checker(1.0), wide)[0] - 0.5).abs() < 1e-3);
    let nan = Fragment {
        dpdx: [f32::NAN, 0.0, 0.0],
        dpdy: [0.0, f32::NAN, 0.0],
        ..f
    };
    assert_eq!(eval(&checker(1.0), nan), vec![1.0; 3]);
}

/// The first texture lookup of `p` with outputs added for its uv and footprint operands.
fn with_lookup_operands(mut p: Program) -> Program {
    use shadenet::graph::ir::{Op, Output};
    let (uv, [dx, dy]) = p
        .body
        .body
        .iter()
        .find_map(|v| match p.op(*v) {
            Op::Texture { uv, derivs, .. } => Some((*uv, derivs.expect("a footprint"))),
            _ => None,
        })
        .expect("a texture lookup in the top-level block");
    for (name, value) in [("uv", uv), ("dx", dx), ("dy", dy)] {
        p.outputs.push(Output {
            name: name.into(),
            component: None,
            value,
        });
    }
    p
}

/// Checks the lookup's footprint operands against central differences of its uv operand
/// (the last three outputs, two floats each).
fn check_lookup_footprint(p: &Program, what: &str) {
    let n = eval(p, fragment([0.3, 0.4], [0.0; 3])).len();
    let at = |uv: [f64; 2]| eval(p, fragment(uv, [0.0; 3]))[n - 6..].to_vec();
    let base = at([0.3, 0.4]);
    let h = 1.0 / 64.0;
    for axis in 0..2 {
        let plus = at([0.3 + h * DUV[axis][0], 0.4 + h * DUV[axis][1]]);
        let minus = at([0.3 - h * DUV[axis][0], 0.4 - h * DUV[axis][1]]);
        for c in 0..2 {
            let fd = (plus[c] - minus[c]) / (2.0 * h);
            let d = base[2 + 2 * axis + c];
            assert!(
                (d - fd).abs() <= 2e-3 * (1.0 + fd.abs()),
                "{what}: d{}uv[{c}] = {d}, central difference {fd}",
                ["x", "y"][axis]
            );
        }
    }
}

fn png_in_temp(name: &str) -> String {
    let d = std::env::temp_dir().join(format!("shadenet-derivs-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join("t.png");
    image::save_buffer(
        &p,
        &[200u8, 100, 50, 25],
        2,
        2,
        image::ExtendedColorType::L8,
    )
    .unwrap();
    p.to_string_lossy().into_owned()
}

#[test]
fn texture_footprints_follow_place2d_rotation_and_scale() {
    let file = png_in_temp("maya");
    let src = format!(
        r#"{{"nodes": [
              {{"name": "uvs", "type": "place2d",
                "inputs": {{"repeatU": 7, "repeatV": 3, "offsetU": 0.25, "rotateUV": 0.6}}}},
              {{"name": "img", "type": "file",
                "inputs": {{"fileTextureName": "{file}", "uvCoord": "uvs.outUV"}}}}],
            "outputs": {{"c": "img.outColor"}}}}"#
    );
    check_lookup_footprint(&with_lookup_operands(network(&src)), "Maya place2d");
}

#[test]
fn texture_footprints_follow_materialx_place2d() {
    let Some(lib) = common::mtlx_library() else {
        return;
    };
    let file = png_in_temp("mtlx");
    let doc = format!(
        r#"<?xml version="1.0"?>
<materialx version="1.39">
  <texcoord name="tc" type="vector2"/>
  <place2d name="pl" type="vector2">
    <input name="texcoord" type="vector2" nodename="tc"/>
    <input name="scale" type="vector2" value="0.2, 0.5"/>
    <input name="rotate" type="float" value="35"/>
    <input name="offset" type="vector2" value="0.1, -0.3"/>
  </place2d>
  <image name="img" type="color3">
    <input name="file" type="filename" value="{file}"/>
    <input name="texcoord" type="vector2" nodename="pl"/>
  </image>
  <output name="out" type="color3" nodename="img"/>
</materialx>"#
    );
    let c = shadenet::graph::mtlx::compile(
        "t.mtlx",
        &doc,
        lib,
        &shadenet::graph::mtlx::Selection::default(),
    )
    .unwrap();
    check_lookup_footprint(&with_lookup_operands(c.program), "MaterialX place2d");
}

/// A checker whose uv comes through `place2d` rotated by `deg` (repeat 1, no offset).
fn placed_checker(deg: f64) -> Program {
    let src = format!(
        r#"{{"nodes": [{{"name": "p", "type": "place2d", "inputs": {{"rotateUV": {deg}}}}},
              {{"name": "c", "type": "checker",
               "inputs": {{"uvCoord": "p.outUV", "color1": [1, 1, 1], "color2": [0, 0, 0]}}}}],
            "outputs": {{"c": "c.outColor"}}}}"#
    );
    network(&src)
}

#[test]
fn derivatives_flow_through_place2d() {
    // The usual Maya chain, place2d → checker: unrotated, the filtered checker sees the
    // same footprint as on uv directly (the value bit for bit); rotated, it is filtered too
    // (a grey between the checks where the footprint straddles an edge). place2d rotates in
    // an `if` region: derivatives must flow through it, else the checker is never filtered.
    let f = Fragment {
        uv: [0.49, 0.2],
        dpdu: [1.0, 0.0, 0.0],
        dpdv: [0.0, 1.0, 0.0],
        dpdx: [0.3, 0.0, 0.0],
        dpdy: [0.0, 0.3, 0.0],
        ..Fragment::default()
    };
    let direct = eval(&checker(1.0), f);
    assert_eq!(eval(&placed_checker(0.0), f), direct);
    assert!(direct[0] > 0.2 && direct[0] < 0.8, "{direct:?}");
    let turned = eval(&placed_checker(30.0), f)[0];
    assert!(turned > 0.01 && turned < 0.99, "{turned}");
    // Without a footprint the rotated checker is the point value.
    let point = eval(
        &placed_checker(30.0),
        Fragment {
            uv: [0.49, 0.2],
            ..Fragment::default()
        },
    )[0];
    assert!(point == 0.0 || point == 1.0, "{point}");
}

#[test]
fn filter_width_and_filter_step_use_the_footprint() {
    use shadenet::graph::nodes::filtered::{filter_step, filter_width};
    // x = 10·u: ∂x = (10·0.01, 10·(−0.005)), width √(0.1² + 0.05²).
    let build = |scale: f64| {
        let mut b = Builder::new("fs");
        let uv = b.stream(Stream::Uv);
        let u = b.extract(uv, 0);
        let ten = b.float(10.0);
        let x = b.mul(u, ten);
        let w = filter_width(&mut b, x);
        let (edge, s) = (b.float(3.0), b.float(scale));
        let st = filter_step(&mut b, edge, x, s);
        b.output("w", None, w);
        b.output("step", None, st);
        b.finish().unwrap()
    };
    let p = build(1.0);
    let width = (0.1f64 * 0.1 + 0.05 * 0.05).sqrt();
    let at = |p: &Program, u: f64| eval(p, fragment([u, 0.5], [0.0; 3]));
    let r = at(&p, 0.3);
    assert!((r[0] - width).abs() < 1e-7, "{r:?}");
    // Exactly at the edge: half the box is above it.
    assert!((r[1] - 0.5).abs() < 1e-5, "{r:?}");
    // A little below: the share of the box above the edge.
    let x = 2.97f64;
    let want = (x + width / 2.0 - 3.0) / width;
    assert!((at(&p, 0.297)[1] - want).abs() < 1e-5);
    assert_eq!(at(&p, 0.31)[1], 1.0);
    assert_eq!(at(&p, 0.29)[1], 0.0);
    // No footprint, or the filter off: the plain step (1 at or above the edge).
    let still = |u: f32| Fragment {
        uv: [u, 0.5],
        ..Fragment::default()
    };
    assert_eq!(eval(&p, still(0.3)), vec![0.0, 1.0]);
    assert_eq!(eval(&p, still(0.2999)), vec![0.0, 0.0]);
    let off = build(0.0);
    assert_eq!(at(&off, 0.2995)[1], 0.0);
    assert_eq!(at(&off, 0.3)[1], 1.0);
}

#[test]
fn the_filter_nodes_link_and_lower() {
    let src = r#"{"nodes": [
          {"name": "w", "type": "filterWidth", "inputs": {"in": 2.0}},
          {"name": "s", "type": "filterStep", "inputs": {"edge": 0.5, "in": 0.75}}],
        "outputs": {"w": "w.outValue", "s": "s.outValue"}}"#;
    let c = shadenet::compile_json(src, &shadenet::NodeLibrary::standard()).unwrap();
    // Constants have no footprint: width 0, the plain step.
    assert_eq!(
        eval(&c.program, fragment([0.3, 0.4], [0.0; 3])),
        vec![0.0, 1.0]
    );
}
