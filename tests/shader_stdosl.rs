//! stdosl.h's functions that were missing (issue 22): `distance(a, b, q)`, `rotate` (both
//! forms), `fresnel` (both forms, OSL's and RSL's, issue 21) and `logb` — against the header's formulas computed here in
//! f64 and against independent facts (Fresnel's normal incidence, total internal reflection,
//! exact exponents next to powers of two), interpreter f32/f64, and the JIT's scalar and
//! batch entries bit for bit with the interpreter; and builtins' output arguments assigned
//! under a varying `if` (`sincos`, `fresnel`, `getmatrix`), which made invalid programs.

mod common;
use common::*;
use shadenet::lang::Dialect;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[test]
fn distance_to_a_segment() {
    for (q, want) in [
        ([1.0, 1.0, 0.0], 1.0),          // beside the middle
        ([3.0, 0.0, 0.0], 1.0),          // beyond b
        ([-1.0, 0.0, 2.0], 5f64.sqrt()), // before a
        ([0.5, 0.0, 0.0], 0.0),          // on it
    ] {
        let body = format!(
            "out = distance(point(0), point(2, 0, 0), point({}, {}, {}));",
            q[0], q[1], q[2]
        );
        osl_close(&body, [want; 3], 1e-6);
    }
    // A degenerate segment is its point.
    osl_close(
        "out = distance(point(1, 1, 1), point(1, 1, 1), point(1, 4, 5));",
        [5.0; 3],
        1e-6,
    );
}

/// stdosl.h's rotation of `p` about the line through `a` and `b`, in f64.
fn rotate(p: [f64; 3], angle: f64, a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let d = sub(b, a);
    let l = dot(d, d).sqrt();
    let [x, y, z] = d.map(|c| c / l);
    let (s, c) = angle.sin_cos();
    let c1 = 1.0 - c;
    let m = [
        [
            x * x + (1.0 - x * x) * c,
            x * y * c1 + z * s,
            x * z * c1 - y * s,
        ],
        [
            x * y * c1 - z * s,
            y * y + (1.0 - y * y) * c,
            y * z * c1 + x * s,
        ],
        [
            x * z * c1 + y * s,
            y * z * c1 - x * s,
            z * z + (1.0 - z * z) * c,
        ],
    ];
    let v = sub(p, a);
    std::array::from_fn(|j| v[0] * m[0][j] + v[1] * m[1][j] + v[2] * m[2][j] + a[j])
}

#[test]
fn rotate_is_stdosls() {
    // A quarter turn about +z takes x to y (right-handed).
    osl_close(
        "out = color(rotate(point(1, 0, 0), M_PI / 2, vector(0, 0, 1)));",
        [0.0, 1.0, 0.0],
        1e-6,
    );
    // About an oblique line off the origin, against the header's matrix.
    let (p, a, b) = ([0.3, -1.2, 2.0], [1.0, 0.5, -0.5], [2.0, 3.0, 1.0]);
    let want = rotate(p, 0.7, a, b);
    osl_close(
        "out = color(rotate(point(0.3, -1.2, 2), 0.7, point(1, 0.5, -0.5), point(2, 3, 1)));",
        want,
        1e-5,
    );
    // A full turn comes back; the axis form is the two-point form from the origin.
    osl_close(
        "out = color(rotate(point(0.3, -1.2, 2), 2 * M_PI, point(1, 0.5, -0.5), point(2, 3, 1)));",
        p,
        1e-5,
    );
    let want = rotate(p, -1.1, [0.0; 3], [1.0, 2.0, 2.0]);
    osl_close(
        "out = color(rotate(point(0.3, -1.2, 2), -1.1, vector(1, 2, 2)));",
        want,
        1e-5,
    );
}

/// stdosl.h's `fresnel` in f64: (Kr, Kt, T·N) for a unit `i` and `n`.
fn fresnel(i: [f64; 3], n: [f64; 3], eta: f64) -> (f64, f64, bool) {
    let c = dot(i, n).abs();
    let g2 = 1.0 / (eta * eta) - 1.0 + c * c;
    if g2 < 0.0 {
        return (1.0, 0.0, true);
    }
    let g = g2.sqrt();
    let beta = g - c;
    let f = (c * (g + c) - 1.0) / (c * beta + 1.0);
    let kr = 0.5 * (1.0 + f * f) * (beta / (g + c)).powi(2);
    (kr, (1.0 - kr) * eta * eta, false)
}

#[test]
fn fresnel_is_stdosls() {
    // Normal incidence into glass (eta = 1/1.5): Kr = ((n − 1)/(n + 1))² = 0.04.
    osl_close(
        "float kr, kt; fresnel(vector(0, 0, -1), normal(0, 0, 1), 1 / 1.5, kr, kt); out = color(kr, kt, 0);",
        [0.04, 0.96 / 2.25, 0.0],
        1e-6,
    );
    for (angle, eta) in [
        (0.3f64, 1.0 / 1.5),
        (1.2, 1.0 / 1.33),
        (1.5, 1.0 / 1.5),
        (0.9, 1.5),
    ] {
        let i = [angle.sin(), 0.0, -angle.cos()];
        let (kr, kt, tir) = fresnel(i, [0.0, 0.0, 1.0], eta);
        let body = format!(
            "vector I = vector({}, 0, {}); float kr, kt; vector R, T;
             fresnel(I, normal(0, 0, 1), {eta}, kr, kt, R, T);
             out = color(kr, kt, dot(R, vector(0, 0, 1)) + 10 * length(T));",
            i[0], i[2]
        );
        // R mirrors I's normal component; T is a unit vector unless totally reflected.
        let t = if tir { 0.0 } else { 10.0 };
        osl_close(&body, [kr, kt, angle.cos() + t], 2e-5);
    }
    // eta = 1.5 from inside at 0.9 rad is beyond the critical angle (asin(1/1.5) ≈ 0.73).
    assert!(fresnel([0.9f64.sin(), 0.0, -0.9f64.cos()], [0.0, 0.0, 1.0], 1.5).2);
    // RSL's fresnel is the same function (RenderMan's, which stdosl.h keeps).
    let src = "surface s() { float kr, kt; fresnel(vector(0.29552, 0, -0.955336), normal(0, 0, 1), 1 / 1.5, kr, kt); Ci = color(kr, kt, 0); }";
    let p = compile_shader(src, Dialect::Rsl).unwrap_or_else(|e| panic!("{e}"));
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    let (kr, kt, _) = fresnel([0.29552, 0.0, -0.955336], [0.0, 0.0, 1.0], 1.0 / 1.5);
    assert_close(&o.get("Ci"), &[kr, kt, 0.0], 1e-5, "RSL fresnel");
}

#[test]
fn logb_is_the_exact_exponent() {
    for (x, want) in [
        ("1", 0.0),
        ("1.5", 0.0),
        ("1.9999999", 0.0),
        ("2", 1.0),
        ("0.75", -1.0),
        ("-8", 3.0),
        ("1048576", 20.0),
        ("1048575", 19.0),
        ("1e-30", -100.0),
        ("1.1754944e-38", -126.0),
        // Clamped to the normal range as OpenImageIO's fast_logb: subnormals, 0, overflow.
        ("1e-40", -126.0),
        ("0", -126.0),
        ("3e38", 127.0),
    ] {
        osl_close(
            &format!("out = color(logb({x}), 0, 0);"),
            [want, 0.0, 0.0],
            0.0,
        );
    }
    osl_close("out = logb(color(0.3, 5, 1e10));", [-2.0, 2.0, 33.0], 0.0);
}

/// All of them on a grid: the JIT's scalar and batch entries give the interpreter's bits.
#[test]
fn they_run_on_the_jit_as_on_the_interpreter() {
    let src = r#"shader s(output color out = 0, output color more = 0) {
        float kr = 0, kt = 0; vector R = 0, T = 0;
        if (u > 0.3)
            fresnel(normalize(vector(u - 0.5, v, -1)), normal(0, 0, 1), 1 / (1 + v), kr, kt, R, T);
        float s = 0, c = 0;
        if (v > 0.5)
            sincos(u * 7, s, c);
        matrix M = 1;
        if (u < 0.5)
            getmatrix("object", "world", M);
        out = color(kr, kt, logb(u * 1000 + v)) + color(R) + color(T) + color(s, c, M[0][0]);
        more = color(rotate(P + point(u, v, 0), u * 3, point(v), point(1, 2, 3)))
             + distance(point(0), point(1, v, 0), point(u, 1, 0));
    }"#;
    let p = compile_shader(src, Dialect::Osl).unwrap_or_else(|e| panic!("{e}"));
    assert_jit_is_interp(&p, 9, 7);
}

#[test]
fn bad_calls_name_the_function() {
    for (body, want) in [
        (
            "float kr; fresnel(I, N, 1.5, kr);",
            "`fresnel` takes (vector I, normal N, float eta, output float Kr, output float Kt",
        ),
        (
            "point p = rotate(P, \"a\", vector(1));",
            "`rotate` does not take (point, string, vector): it takes (point p, float angle, vector axis)",
        ),
    ] {
        let err = compile_shader(&format!("surface s() {{ {body} }}"), Dialect::Osl).unwrap_err();
        assert!(err.contains(want), "{body}\n→ {err}");
    }
}
