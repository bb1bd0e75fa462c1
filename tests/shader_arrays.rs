//! Fixed-size arrays in shading-language sources (issue 21, and OSL's of issue 22): declared
//! with a length or an initialiser list, read and written at constant and run-time indices
//! (run-time ones clamped to the array, as OSL does), carried through `if` and loops,
//! passed to functions (output arrays written back), shader array parameters as program
//! parameters `name[k]`, and errors that name the place.

mod common;
use common::*;
use shadenet::graph::ir::Program;
use shadenet::graph::opt::{self, Specialization};
use shadenet::lang::Dialect;
use shadenet::runtime::Backend;

fn compile(src: &str, dialect: Dialect) -> Result<Program, String> {
    compile_shader(src, dialect)
}

/// Output `name` at texture coordinate `u`, f64 and f32 equal (small integers).
fn at(p: &Program, name: &str, u: f64) -> Vec<f64> {
    let mut f = plane_fragment();
    f.uv = [u as f32, 0.5];
    let o = run_program(p, &f, &[], u32::MAX);
    assert_eq!(o.get(name), o.get32(name), "f32 = f64");
    o.get(name)
}

#[test]
fn constant_and_run_time_indices_in_rsl() {
    let src = r#"
        surface s(float w[3] = { 10, 20, 30 }) {
            float a[4] = { 1, 2, 3, 4 };
            float b[] = { 5, 6 };
            float i = floor(u * 8) - 2;     /* -2 … 5 across the plane */
            a[1] = a[0] + a[3];             /* 5 */
            a[i] = 100;                     /* clamped: i < 0 writes a[0], i > 3 writes a[3] */
            Ci = color(a[i], a[1] + b[1] + arraylength(b), w[2] + w[i]);
        }"#;
    let p = compile(src, Dialect::Rsl).unwrap();
    // u → i = floor(8u) − 2, clamped to 0…3.
    for (u, i) in [
        (0.01, 0usize),
        (0.3, 0),
        (0.4, 1),
        (0.55, 2),
        (0.7, 3),
        (0.99, 3),
    ] {
        let w = [10.0, 20.0, 30.0][i.min(2)];
        // a[i] reads back the 100 just written (a[1] = 5 unless i = 1).
        assert_eq!(
            at(&p, "Ci", u),
            [
                100.0,
                if i == 1 { 100.0 } else { 5.0 } + 6.0 + 2.0,
                30.0 + w
            ],
            "u = {u}"
        );
    }
    // The elements are the program's parameters `w[k]`.
    let names: Vec<&str> = p.params.iter().map(|q| q.name.as_str()).collect();
    assert_eq!(names, ["w[0]", "w[1]", "w[2]"]);
}

#[test]
fn arrays_through_ifs_loops_and_functions_in_osl() {
    let src = r#"
        void fill(float k, output float a[4]) {
            for (int j = 0; j < 4; j++) a[j] = k * j;
        }
        float total(float a[]) {
            float t = 0;
            for (int j = 0; j < arraylength(a); j++) t += a[j];
            return t;
        }
        shader s(output color o = 0, output float m = 0) {
            float a[4];
            fill(2, a);                       /* 0 2 4 6 */
            int n = int(u * 4);               /* 0 … 3 */
            if (u > 0.5) a[n] += 10;
            color c[2] = { color(1, 2, 3), color(4, 5, 6) };
            for (int j = 0; j < n; j++) c[j % 2] *= 2;
            o = color(total(a), a[n], c[1][2]);
            m = c[0].g;
        }"#;
    let p = compile(src, Dialect::Osl).unwrap();
    for (u, n) in [(0.1, 0usize), (0.3, 1), (0.6, 2), (0.9, 3)] {
        let mut a = [0.0, 2.0, 4.0, 6.0];
        if u > 0.5 {
            a[n] += 10.0;
        }
        let mut c = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]];
        for j in 0..n {
            for x in &mut c[j % 2] {
                *x *= 2.0;
            }
        }
        assert_eq!(at(&p, "o", u), [a.iter().sum(), a[n], c[1][2]], "u = {u}");
        assert_eq!(at(&p, "m", u), [c[0][1]], "u = {u}");
    }
}

/// The interpreter and the JIT's scalar and batch entries give the same bits on run-time
/// indexing inside a loop with a varying trip count.
#[test]
fn the_jit_agrees_with_the_interpreter_on_arrays() {
    let src = r#"
        shader s(float k[5] = { 0.1, 0.7, 0.3, 0.9, 0.5 }, output color o = 0) {
            float acc = 0;
            int n = int(u * 9);
            for (int j = 0; j < n; j++) acc += k[(j * 3 + int(v * 7)) % 5] * noise(P * j);
            o = color(acc, k[int(v * 5)], n);
        }"#;
    let p = compile(src, Dialect::Osl).unwrap();
    let env = shadenet::shade::grid_env(&[]);
    let spec = Specialization::default();
    let (o, _) = opt::run(&p, &spec);
    let interp = shadenet::shade::shade_grid::<f32>(&o, &env, 16, 9, spec.components).unwrap();
    let m = shadenet_jit::JitBackend::new().compile(&p, &spec).unwrap();
    let bits = |v: Vec<f64>| v.iter().map(|x| (*x as f32).to_bits()).collect::<Vec<_>>();
    for batch in [false, true] {
        let g = shadenet::shade::shade_grid_with(&*m, &env, 16, 9, spec.components, batch);
        assert_eq!(
            bits(interp.pixel_values()),
            bits(g.pixel_values()),
            "batch {batch}"
        );
    }
}

#[test]
fn array_errors_name_the_place() {
    for (src, dialect, want) in [
        (
            "surface s() { float a[3]; Ci = a[3]; }",
            Dialect::Rsl,
            "index 3 is out of range: the length is 3",
        ),
        (
            "surface s() { float a[3] = { 1, 2 }; }",
            Dialect::Rsl,
            "`a` has 3 elements; the list gives 2",
        ),
        (
            "surface s() { float a[u]; }",
            Dialect::Rsl,
            "an array length must be a constant positive integer",
        ),
        (
            "surface s() { float a[]; }",
            Dialect::Rsl,
            "needs an initialiser list",
        ),
        (
            "surface s() { float a[5000]; }",
            Dialect::Rsl,
            "the limit is 1024",
        ),
        (
            "surface s() { float a[2]; float x = a; }",
            Dialect::Rsl,
            "expected a float, found an array",
        ),
        (
            "surface s() { float x = 1; Ci = x[0]; }",
            Dialect::Rsl,
            "a float cannot be indexed",
        ),
        (
            "surface s() { float a[2], b[3]; a = b; }",
            Dialect::Rsl,
            "it takes an array of 2",
        ),
        (
            "float f(float a[2]) { return a[0]; } surface s() { float b[3]; Ci = f(b); }",
            Dialect::Rsl,
            "parameter `a` is an array of 2",
        ),
    ] {
        let err = compile(src, dialect).unwrap_err();
        assert!(err.contains(want), "{src}\n→ {err}");
        assert!(err.contains(":1:"), "{src}: the place\n{err}");
    }
}

/// OSL's `spline_evaluate` in f32, for the tests: the same operations in the same order.
fn spline_ref(basis: &str, x: f32, knots: &[f32]) -> f32 {
    let (step, m): (usize, [[f32; 4]; 4]) = match basis {
        "catmull-rom" => (
            1,
            [
                [-0.5, 1.5, -1.5, 0.5],
                [1.0, -2.5, 2.0, -0.5],
                [-0.5, 0.0, 0.5, 0.0],
                [0.0, 1.0, 0.0, 0.0],
            ],
        ),
        "bezier" => (
            3,
            [
                [-1.0, 3.0, -3.0, 1.0],
                [3.0, -6.0, 3.0, 0.0],
                [-3.0, 3.0, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
            ],
        ),
        "bspline" => (
            1,
            [
                [-1.0 / 6.0, 3.0 / 6.0, -3.0 / 6.0, 1.0 / 6.0],
                [3.0 / 6.0, -6.0 / 6.0, 3.0 / 6.0, 0.0],
                [-3.0 / 6.0, 0.0, 3.0 / 6.0, 0.0],
                [1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0, 0.0],
            ],
        ),
        "hermite" => (
            2,
            [
                [2.0, 1.0, -2.0, 1.0],
                [-3.0, -2.0, 3.0, -1.0],
                [0.0, 1.0, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
            ],
        ),
        "linear" => (
            1,
            [
                [0.0; 4],
                [0.0; 4],
                [0.0, -1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
            ],
        ),
        _ => (1, [[0.0; 4]; 4]),
    };
    let nsegs = (knots.len() - 4) / step + 1;
    let x = x.clamp(0.0, 1.0) * nsegs as f32;
    let seg = (x as usize).min(nsegs - 1);
    if basis == "constant" {
        return knots[seg + 1];
    }
    let x = x - seg as f32;
    let p = &knots[seg * step..seg * step + 4];
    let tk: Vec<f32> = m
        .iter()
        .map(|r| r[0] * p[0] + r[1] * p[1] + r[2] * p[2] + r[3] * p[3])
        .collect();
    ((tk[0] * x + tk[1]) * x + tk[2]) * x + tk[3]
}

/// `spline` is OSL's: every basis on knots given as arguments and as an array, at points
/// inside, between and outside the segments, bit for bit in f32; RSL's `spline` without a
/// basis is Catmull-Rom.
#[test]
fn splines_are_osls() {
    let knots = [0.0f32, 0.3, 1.2, 0.7, -0.4, 0.9, 2.0];
    for basis in [
        "catmull-rom",
        "bezier",
        "bspline",
        "hermite",
        "linear",
        "constant",
    ] {
        let src = format!(
            r#"shader s(output float a = 0, output float b = 0, output color c = 0) {{
                float k[7] = {{ 0, 0.3, 1.2, 0.7, -0.4, 0.9, 2 }};
                float x = u * 1.4 - 0.2;
                a = spline("{basis}", x, k);
                b = spline("{basis}", x, 0, 0.3, 1.2, 0.7, -0.4, 0.9, 2);
                c = spline("{basis}", x, color(0), color(0.3), color(1.2), color(0.7), color(-0.4), color(0.9), color(2));
            }}"#
        );
        let p = compile(&src, Dialect::Osl).unwrap();
        for u in [0.0, 0.1, 0.25, 0.5, 0.61, 0.75, 0.9, 1.0] {
            let mut f = plane_fragment();
            f.uv = [u, 0.5];
            let o = run_program(&p, &f, &[], u32::MAX);
            let want = spline_ref(basis, u * 1.4 - 0.2, &knots) as f64;
            assert_eq!(o.get32("a"), [want], "{basis} at u = {u} (array)");
            assert_eq!(o.get32("b"), [want], "{basis} at u = {u} (arguments)");
            assert_eq!(o.get32("c"), [want; 3], "{basis} at u = {u} (colors)");
        }
    }
    let p = compile(
        "surface s() { Ci = spline(u, 0, 1, 0.5, 1, 0); }",
        Dialect::Rsl,
    )
    .unwrap();
    let mut f = plane_fragment();
    f.uv = [0.4, 0.5];
    let want = spline_ref("catmull-rom", 0.4, &[0.0, 1.0, 0.5, 1.0, 0.0]) as f64;
    assert_eq!(run_program(&p, &f, &[], u32::MAX).get32("Ci"), [want; 3]);
    for (src, want) in [
        (
            "shader s(output float a = 0) { a = spline(\"cubic\", u, 0, 1, 2, 3); }",
            "unknown spline basis \"cubic\"",
        ),
        (
            "shader s(output float a = 0) { a = spline(\"linear\", u, 0, 1, 2); }",
            "a spline needs at least 4 knots; it has 3",
        ),
    ] {
        let err = compile(src, Dialect::Osl).unwrap_err();
        assert!(err.contains(want), "{src}\n→ {err}");
    }
}

/// OSL's `Spline::inverse` with OpenImageIO's `invert` in f32, for the tests: the same
/// operations in the same order.
fn spline_inverse_ref(basis: &str, y: f32, knots: &[f32]) -> f32 {
    let step = match basis {
        "bezier" => 3,
        "hermite" => 2,
        _ => 1,
    };
    let n = knots.len();
    let (lo, hi) = if step == 1 { (1, n - 2) } else { (0, n - 1) };
    let increasing = knots[1] < knots[n - 2];
    if increasing {
        if y <= knots[lo] {
            return 0.0;
        }
        if y >= knots[hi] {
            return 1.0;
        }
    } else {
        if y >= knots[lo] {
            return 0.0;
        }
        if y <= knots[hi] {
            return 1.0;
        }
    }
    let s = |x: f32| spline_ref(basis, x, knots);
    let invert = |y: f32, mut xmin: f32, mut xmax: f32| -> (f32, bool) {
        let (mut v0, mut v1) = (s(xmin), s(xmax));
        let mut x = xmin;
        let increasing = v0 < v1;
        let (vmin, vmax) = if increasing { (v0, v1) } else { (v1, v0) };
        if !(y >= vmin && y <= vmax) {
            return (if (y < vmin) == increasing { xmin } else { xmax }, false);
        }
        if (v0 - v1).abs() < 1e-6 {
            return (x, true);
        }
        for iters in 0..32 {
            let mut t = 0.5;
            if iters < 24 {
                t = (y - v0) / (v1 - v0);
                if t <= 0.0 || t >= 1.0 {
                    t = 0.5;
                }
            }
            x = xmin * (1.0 - t) + xmax * t;
            let v = s(x);
            if (v < y) == increasing {
                xmin = x;
                v0 = v;
            } else {
                xmax = x;
                v1 = v;
            }
            if (xmax - xmin).abs() < 1e-6 || (v - y).abs() < 1e-6 {
                return (x, true);
            }
        }
        (x, true)
    };
    let nsegs = (n - 4) / step + 1;
    let nseginv = 1.0f32 / nsegs as f32;
    let (mut r0, mut x) = (0.0f32, 0.0f32);
    for seg in 0..nsegs {
        let r1 = nseginv * (seg + 1) as f32;
        let (sx, brack) = invert(y, r0, r1);
        x = sx;
        if brack {
            return x;
        }
        r0 = r1;
    }
    x
}

/// `splineinverse` is OSL's search bit for bit in f32: every basis on increasing,
/// decreasing and non-monotonic knots (where no segment brackets y, OSL's edge), given as
/// arguments, as an array and as a count and an array; values beyond the knots are 0 or 1,
/// and the spline of the inverse is y again on a monotonic curve.
#[test]
fn splineinverse_is_osls() {
    let sets: [&[f32]; 3] = [
        &[0.0, 0.1, 0.3, 0.35, 0.8, 0.9, 1.0],
        &[2.0, 1.5, 1.2, 0.4, 0.3, -0.5, -1.0],
        &[0.0, 0.3, 1.2, 0.7, -0.4, 0.9, 2.0],
    ];
    for knots in sets {
        let list: Vec<String> = knots.iter().map(|k| format!("{k:?}")).collect();
        let list = list.join(", ");
        for basis in [
            "catmull-rom",
            "bezier",
            "bspline",
            "hermite",
            "linear",
            "constant",
        ] {
            let src = format!(
                r#"shader s(output float a = 0, output float b = 0, output float c = 0) {{
                    float k[7] = {{ {list} }};
                    float y = u * 3.6 - 1.2;
                    a = splineinverse("{basis}", y, k);
                    b = splineinverse("{basis}", y, {list});
                    c = splineinverse("{basis}", y, 5, k);
                }}"#
            );
            let p = compile(&src, Dialect::Osl).unwrap();
            for k in 0..=40 {
                let u = k as f32 / 40.0;
                let mut f = plane_fragment();
                f.uv = [u, 0.5];
                let o = run_program(&p, &f, &[], u32::MAX);
                let y = u * 3.6 - 1.2;
                let want = spline_inverse_ref(basis, y, knots) as f64;
                let five = spline_inverse_ref(basis, y, &knots[..5]) as f64;
                let at = format!("{basis} on {knots:?} at y = {y}");
                assert_eq!(o.get32("a"), [want], "{at} (array)");
                assert_eq!(o.get32("b"), [want], "{at} (arguments)");
                assert_eq!(o.get32("c"), [five], "{at} (first 5 knots)");
                let x = want as f32;
                assert!((0.0..=1.0).contains(&x), "{at}: {x}");
                if knots == sets[0] && basis == "linear" && (0.1..=0.9).contains(&y) {
                    let back = spline_ref(basis, x, knots);
                    assert!((back - y).abs() < 1e-5, "{at}: spline({x}) = {back}");
                }
            }
        }
    }
    for (src, want) in [
        (
            "shader s(output float a = 0) { a = splineinverse(\"linear\", u, color(0), color(1), color(2), color(3)); }",
            "splineinverse takes float knots, not color",
        ),
        (
            "shader s(output float a = 0) { float k[4] = { 0, 1, 2, 3 }; a = splineinverse(\"linear\", u, 9, k); }",
            "knot count 9 is outside the array's 4",
        ),
        (
            "shader s(output float a = 0) { float k[4] = { 0, 1, 2, 3 }; int n = int(u * 4); a = splineinverse(\"linear\", u, n, k); }",
            "a knot count known only while shading is not built",
        ),
        (
            "shader s(output float a = 0) { a = splineinverse(u, 0, 1, 2, 3); }",
            "splineinverse takes (string basis, float y, knots…)",
        ),
    ] {
        let err = compile(src, Dialect::Osl).unwrap_err();
        assert!(err.contains(want), "{src}\n→ {err}");
        assert!(err.contains(":1:"), "{src}: the place\n{err}");
    }
}
