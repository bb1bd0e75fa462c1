//! OSL shaders (issue 22) compiled by `shadenet-lang` into the IR: OSL's `int` and its
//! operators, casts, output parameters of shaders and functions, the noise family with
//! OSL's generators (equal to `ops::osl_noise`, OSL's code ported), closures lowered onto
//! the lobe lists and lit like the MaterialX and Maya surfaces that use the same lobes,
//! every CPU back end agreeing bit for bit, and errors that name the place.

mod common;
use common::*;
use shadenet::graph::NodeLibrary;
use shadenet::graph::compile_json;
use shadenet::graph::nodes::{LightDesc, LightKind};
use shadenet::graph::ops::{osl_noise, osl_simplex};
use shadenet::graph::opt::{self, Specialization};
use shadenet::lang::Dialect;
use shadenet::runtime::Backend;

/// Compiles OSL `src`'s first shader; `Err` is the rendered diagnostics.
fn compile(src: &str) -> Result<shadenet::graph::ir::Program, String> {
    compile_shader(src, Dialect::Osl)
}

/// Each source fails to compile with an error containing its text.
fn assert_errors(cases: &[(&str, &str)]) {
    for (src, want) in cases {
        let err = compile(src).unwrap_err();
        assert!(err.contains(want), "{src}\n→ {err}");
    }
}

fn point(pos: [f64; 3], i: f64) -> LightDesc {
    LightDesc::new("l", LightKind::Point { position: pos }, [i; 3]).unwrap()
}

/// Output `name` in f64 and f32, checked equal to `want` within `tol`.
fn check(o: &Outputs, name: &str, want: &[f64], tol: f64) {
    assert_close(&o.get(name), want, tol, &format!("{name} (f64)"));
    assert_close(
        &o.get32(name),
        want,
        tol.max(1e-6),
        &format!("{name} (f32)"),
    );
}

/// `int` arithmetic (C's truncating `/` and `%`, 0 for a zero divisor), `%` of floats as
/// `fmod`, explicit casts toward zero, ints widening to floats and triples, truth values
/// of ints and floats, `++` on ints, `.x`/`.g` components, `M_PI`, `#include "stdosl.h"`.
#[test]
fn ints_casts_and_operators() {
    let src = r#"
        #include "stdosl.h"
        shader ints(int k = 7, float x = -7.5,
                    output color a = 0, output color b = 0, output color c = 0,
                    output float d = 0, output float m = 0)
        {
            int z = 0;
            a = color(k / 2, -k / 2, k % 3);
            b = color(-k % 3, k % z, x % 2);
            c = color(int(2.7), (int) -2.7, float(k / 2) + 0.5);
            int n = 0;
            for (int i = 0; i < k; i++) n += i;
            d = n;
            if (k) d += 100;
            if (!z) d += 1000;
            float t = (k > 3) ? 0.25 : 0.5;
            d += t + M_PI - M_PI;
            vector p = vector(1, 2, 3) * k;
            d += p.y * 10000;
            color e = color(k);
            d += e.g * 100000;
            int j = clamp(max(k, 2) - min(k, 9), -3, 3) + abs(-k);
            m = j;
        }"#;
    let p = compile(src).unwrap();
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    check(&o, "a", &[3.0, -3.0, 1.0], 0.0);
    check(&o, "b", &[-1.0, 0.0, -1.5], 0.0);
    check(&o, "c", &[2.0, -2.0, 3.5], 0.0);
    // 0+…+6 = 21; +100 (k ≠ 0); +1000 (!0); +0.25; p.y = 14; e.g = 7.
    let want = 21.0 + 100.0 + 1000.0 + 0.25 + 140000.0 + 700000.0;
    check(&o, "d", &[want], 1e-9);
    // j = clamp(7 − 7, −3, 3) + 7 (ints throughout: an int variable takes it).
    check(&o, "m", &[7.0], 0.0);
    // The first output of a `shader` is its first output parameter.
    assert_eq!(p.outputs[0].name, "a");
}

/// Output parameters of functions write back to the variable passed; overloads are chosen
/// by argument types, an exact match first (an int argument picks the `int` overload).
#[test]
fn functions_with_output_parameters_and_overloads() {
    let src = r#"
        float f(float x) { return 1; }
        float f(int x) { return 2; }
        void split(color c, output float r, output float g) { r = c[0]; g = c[1]; }
        shader s(output color o = 0) {
            float r = 0, g = 0;
            split(color(0.25, 0.5, 0.75), r, g);
            o = color(r, g, f(1) * 10 + f(1.0));
        }"#;
    let p = compile(src).unwrap();
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    check(&o, "o", &[0.25, 0.5, 21.0], 0.0);
}

/// The fragments (`P`, `uv`) the noise tests shade: ordinary, negative and near the ends of
/// the texture coordinates.
const NOISE_POINTS: [([f32; 3], [f32; 2]); 3] = [
    ([0.123, 0.456, 0.0], [0.11, 0.93]),
    ([-2.5, 7.25, 1.0], [0.5, 0.5]),
    ([13.1, -0.7, 3.3], [0.999, 0.001]),
];

/// The noise tests' `q = P * 3.7 + point(0.3, -1.2, 5.1)`, in f32 as the shader computes it.
fn noise_domain(pos: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|i| pos[i] * 3.7 + [0.3, -1.2, 5.1][i])
}

/// The noise family is OSL's: `snoise`/`"perlin"` is `osl_noise::perlin`, `noise` is
/// `0.5 (perlin + 1)`, `cellnoise`/`"cell"` is `osl_noise::cell`, `hashnoise`/`"hash"`
/// `osl_noise::hash`, in 1D `(x)`, 2D `(x, y)`, 3D `(p)` and 4D `(p, t)`, float or vector
/// by the type assigned to.
#[test]
fn noise_is_osls() {
    let src = r#"
        shader n(output color a = 0, output vector vp = 0, output color vc = 0,
                 output color d2 = 0, output color c14 = 0, output color vc1 = 0,
                 output color vc4 = 0, output color p14 = 0, output vector vp1 = 0,
                 output vector vp4 = 0, output color h = 0, output color vh = 0) {
            point q = P * 3.7 + point(0.3, -1.2, 5.1);
            a = color(snoise(q), noise(q), cellnoise(q));
            vp = noise("perlin", q);
            vc = cellnoise(q);
            d2 = color(noise("perlin", u * 9, v * 9), noise(u * 9, v * 9), cellnoise(u * 9, v * 9));
            c14 = color(cellnoise(u * 9), cellnoise(q, v * 9), noise("cell", q, u * 9));
            vc1 = cellnoise(u * 9);
            vc4 = noise("cell", q, v * 9);
            p14 = color(snoise(u * 9), snoise(q, v * 9), noise(q, u * 9));
            vp1 = snoise(u * 9);
            vp4 = noise("perlin", q, v * 9);
            h = color(hashnoise(u * 9), hashnoise(q), noise("hash", q, v * 9))
                + color(hashnoise(u * 9, v * 9), 0, 0);
            vh = hashnoise(q, u * 9);
        }"#;
    let p = compile(src).unwrap();
    let mut f = plane_fragment();
    for (k, (pos, uv)) in NOISE_POINTS.into_iter().enumerate() {
        f.p = pos;
        f.uv = uv;
        let o = run_program(&p, &f, &[], u32::MAX);
        let q = noise_domain(pos);
        let per = osl_noise::perlin3(q) as f64;
        let cell = osl_noise::cell3(q) as f64;
        // f32 shading is OSL's own arithmetic, bit for bit.
        let a32 = o.get32("a");
        assert_eq!(a32[0], per, "snoise, point {k}");
        assert_eq!(
            a32[1],
            (0.5f32 * (per as f32 + 1.0)) as f64,
            "noise, point {k}"
        );
        assert_eq!(a32[2], cell, "cellnoise, point {k}");
        let vp: Vec<f64> = osl_noise::vperlin3(q).iter().map(|x| *x as f64).collect();
        assert_eq!(o.get32("vp"), vp, "vector perlin, point {k}");
        let vc: Vec<f64> = osl_noise::vcell3(q).iter().map(|x| *x as f64).collect();
        assert_eq!(o.get32("vc"), vc, "color cellnoise, point {k}");
        let uv9 = [uv[0] * 9.0, uv[1] * 9.0];
        let p2 = osl_noise::perlin2(uv9);
        let d2 = [p2, 0.5 * (p2 + 1.0), osl_noise::cell2(uv9)];
        let d2: Vec<f64> = d2.iter().map(|x| *x as f64).collect();
        assert_eq!(o.get32("d2"), d2, "2D noise, point {k}");
        let c14 = [
            osl_noise::cell1(uv9[0]),
            osl_noise::cell4(q, uv9[1]),
            osl_noise::cell4(q, uv9[0]),
        ];
        let c14: Vec<f64> = c14.iter().map(|x| *x as f64).collect();
        assert_eq!(o.get32("c14"), c14, "1D and 4D cell noise, point {k}");
        let vc1: Vec<f64> = osl_noise::vcell1(uv9[0])
            .iter()
            .map(|x| *x as f64)
            .collect();
        assert_eq!(o.get32("vc1"), vc1, "1D vector cell noise, point {k}");
        let vc4: Vec<f64> = osl_noise::vcell4(q, uv9[1])
            .iter()
            .map(|x| *x as f64)
            .collect();
        assert_eq!(o.get32("vc4"), vc4, "4D vector cell noise, point {k}");
        let p14 = [
            osl_noise::perlin1(uv9[0]),
            osl_noise::perlin4(q, uv9[1]),
            0.5 * (osl_noise::perlin4(q, uv9[0]) + 1.0),
        ];
        let p14: Vec<f64> = p14.iter().map(|x| *x as f64).collect();
        assert_eq!(o.get32("p14"), p14, "1D and 4D Perlin noise, point {k}");
        let vp1: Vec<f64> = osl_noise::vperlin1(uv9[0])
            .iter()
            .map(|x| *x as f64)
            .collect();
        assert_eq!(o.get32("vp1"), vp1, "1D vector Perlin noise, point {k}");
        let vp4: Vec<f64> = osl_noise::vperlin4(q, uv9[1])
            .iter()
            .map(|x| *x as f64)
            .collect();
        assert_eq!(o.get32("vp4"), vp4, "4D vector Perlin noise, point {k}");
        let h = [
            osl_noise::hash1(uv9[0]) + osl_noise::hash2(uv9),
            osl_noise::hash3(q),
            osl_noise::hash4(q, uv9[1]),
        ];
        let h: Vec<f64> = h.iter().map(|x| *x as f64).collect();
        assert_eq!(o.get32("h"), h, "hash noise, point {k}");
        let vh: Vec<f64> = osl_noise::vhash4(q, uv9[0])
            .iter()
            .map(|x| *x as f64)
            .collect();
        assert_eq!(o.get32("vh"), vh, "4D vector hash noise, point {k}");
    }
}

/// A Lambertian reflector of albedo 1 under one point light: `cos θ / π · I / r²`, the
/// value of our `lambert` node (tests/shaders.rs derives it from the RenderMan formulas).
fn lambert_value(lights: &[LightDesc], f: &shadenet::runtime::Fragment) -> Vec<f64> {
    let lambert = compile_json(
        r#"{"nodes": [{"name": "l", "type": "lambert",
            "inputs": {"color": [1, 1, 1], "diffuse": 1}}],
            "outputs": {"color": "l.outColor"}}"#,
        &NodeLibrary::standard(),
    )
    .unwrap();
    run_program(&lambert.program, f, lights, u32::MAX).get("color")
}

/// Closures become lobes lit by the surface lowering: `diffuse(N)` is Lambert (OSL's
/// diffuse has the 1/π), closure arithmetic scales and adds lobes, `emission()` emits its
/// weight as radiance, a closure chosen by a varying condition keeps each side's lobes
/// where the condition holds, and the render components are the lobes'.
#[test]
fn closures_are_lit_as_their_lobes() {
    let lights = [point([0.6, -0.3, 1.5], 3.0)];
    let mut f = plane_fragment();
    f.p = [0.2, 0.1, 0.0];
    f.i = [0.2, 0.1, -1.0];
    let lambert = lambert_value(&lights, &f);
    let run = |src: &str, f: &shadenet::runtime::Fragment| {
        let p = compile(src).unwrap();
        run_program(&p, f, &lights, u32::MAX)
    };
    let o = run("surface s() { Ci = diffuse(N); }", &f);
    check(&o, "Ci", &lambert, 1e-9);
    assert!(o.part("Ci", "diffuse").is_some(), "the diffuse component");
    let o = run(
        "surface s() { Ci = 0.5 * diffuse(N) + diffuse(N) * color(0.25, 0.5, 1); }",
        &f,
    );
    let want: Vec<f64> = [0.75, 1.0, 1.5]
        .iter()
        .zip(&lambert)
        .map(|(k, l)| k * l)
        .collect();
    check(&o, "Ci", &want, 1e-9);
    let o = run(
        "surface s() { Ci = color(0.1, 0.2, 0.3) * emission(); }",
        &f,
    );
    check(&o, "Ci", &[0.1, 0.2, 0.3], 1e-9);
    let o = run("surface s() { Ci = emission(); Ci /= 4; }", &f);
    check(&o, "Ci", &[0.25; 3], 1e-9);
    // Chosen by the side of the plane: u < 0.5 emits, u > 0.5 reflects.
    let src = r#"surface s() {
        if (u > 0.5) Ci = diffuse(N); else Ci = color(0.1, 0.2, 0.3) * emission();
    }"#;
    f.uv = [0.75, 0.5];
    check(&run(src, &f), "Ci", &lambert, 1e-9);
    f.uv = [0.25, 0.5];
    check(&run(src, &f), "Ci", &[0.1, 0.2, 0.3], 1e-9);
    let src = "surface s() { Ci = u > 0.5 ? diffuse(N) : 0; }";
    check(&run(src, &f), "Ci", &[0.0; 3], 0.0);
    // A user function returning a closure, and a closure local.
    let src = r#"
        closure color matte(color c) { return c * diffuse(N); }
        surface s() { closure color m = matte(color(0.5)); Ci = m + m; }"#;
    check(&run(src, &f), "Ci", &lambert, 1e-9);
    // A loop with a constant trip count that adds closures is unrolled.
    let src = "surface s() { for (int i = 0; i < 4; i++) Ci += 0.25 * diffuse(N); }";
    check(&run(src, &f), "Ci", &lambert, 1e-9);
    // The MaterialX closure of the same lobe.
    let src = "surface s() { Ci = oren_nayar_diffuse_bsdf(N, color(1), 0); }";
    check(&run(src, &f), "Ci", &lambert, 1e-9);
}

/// Each OSL closure maps onto the lobe that has its formula: compiled side by side with the
/// lobe's own MaterialX node (same lobe, same parameters), the lit values are equal.
#[test]
fn osl_closures_equal_the_pbrlib_lobes() {
    // Two lights above the surface, one below it (which only transmission sees).
    let lights = [
        point([0.6, -0.3, 1.5], 3.0),
        point([-1.0, 0.5, 0.7], 2.0),
        point([0.3, 0.2, -1.0], 2.0),
    ];
    let mut f = plane_fragment();
    f.p = [0.2, 0.1, 0.0];
    f.i = [0.3, 0.1, -1.0];
    let pairs = [
        (
            "Ci = microfacet(\"ggx\", N, 0.09, 1.5, 0);",
            "Ci = dielectric_bsdf(N, vector(0), color(1), color(0), 0.09, 0.09, 1.5, \"ggx\");",
        ),
        (
            "Ci = oren_nayar(N, 0.3);",
            "Ci = oren_nayar_diffuse_bsdf(N, color(1), 0.3);",
        ),
        (
            "Ci = translucent(N);",
            "Ci = translucent_bsdf(N, color(1));",
        ),
        (
            "Ci = reflection(N, 1.5);",
            "Ci = dielectric_bsdf(N, vector(0), color(1), color(0), 0, 0, 1.5, \"ggx\");",
        ),
    ];
    for (a, b) in pairs {
        let pa = compile(&format!("surface s() {{ {a} }}")).unwrap();
        let pb = compile(&format!("surface s() {{ {b} }}")).unwrap();
        let oa = run_program(&pa, &f, &lights, u32::MAX);
        let ob = run_program(&pb, &f, &lights, u32::MAX);
        assert_eq!(oa.get("Ci"), ob.get("Ci"), "{a} = {b}");
        assert!(oa.get("Ci").iter().any(|x| *x != 0.0), "{a} is lit");
    }
    // Seen from inside (the geometric normal away from the viewer), OSL's `eta` is the
    // index on the viewer's side, as a shader writes it with `backfacing()`; the lobe's
    // is the material's.
    f.ng = [0.0, 0.0, -1.0];
    let glass = r#"surface s(float ior = 1.5) {
        float eta = backfacing() ? 1 / ior : ior;
        Ci = refraction(N, eta) + reflection(N, eta); }"#;
    let mx = "surface s() { Ci = dielectric_bsdf(N, vector(0), color(1), color(1), 0, 0, 1.5, \"ggx\"); }";
    for f in [f, plane_fragment()] {
        let oa = run_program(&compile(glass).unwrap(), &f, &lights, u32::MAX);
        let ob = run_program(&compile(mx).unwrap(), &f, &lights, u32::MAX);
        assert_close(
            &oa.get("Ci"),
            &ob.get("Ci"),
            1e-12,
            "glass = dielectric_bsdf",
        );
        assert!(
            oa.get("Ci").iter().any(|x| *x != 0.0),
            "glass is lit, ng {:?}",
            f.ng
        );
    }
}

/// The interpreter and the JIT (scalar and batch) give the same bits on an OSL shader with
/// noise (Perlin, cell and simplex), `splineinverse` (an IR loop per segment), ints and
/// closures under a varying condition.
#[test]
fn the_jit_agrees_with_the_interpreter_bit_for_bit() {
    let src = r#"
        surface s(color Cd = color(0.8, 0.3, 0.2), float rough = 0.2, int octaves = 3) {
            float n = 0;
            float amp = 1;
            point q = P * 4;
            for (int i = 0; i < octaves; i++) {
                n += amp * snoise(q);
                q *= 2;
                amp *= 0.5;
            }
            color c = mix(Cd, color(cellnoise(P * 8)), 0.5 + 0.5 * n);
            c += 0.1 * (cellnoise(u * 7) + cellnoise(P * 3, v * 5))
                + 0.05 * (color(cellnoise(u * 7)) + color(cellnoise(P * 3, v * 5)));
            c *= 0.5 + 0.25 * (noise("simplex", q, v) + noise("usimplex", u * 7, v * 3))
                + 0.2 * splineinverse("catmull-rom", u, 0, 0.1, 0.5, 0.6, 0.9, 1);
            c += 0.1 * color(noise("simplex", P * 3));
            if (n > 0)
                Ci = c * diffuse(N);
            else
                Ci = c * oren_nayar(N, 0.5) + 0.2 * microfacet("ggx", N, rough * rough, 1.5, 0);
        }"#;
    let p = compile(src).unwrap();
    let lights = [point([1.0, 1.0, 2.0], 5.0)];
    let env = shadenet::shade::grid_env(&lights);
    let spec = Specialization::default();
    let (o, _) = opt::run(&p, &spec);
    let interp = shadenet::shade::shade_grid::<f32>(&o, &env, 16, 9, spec.components).unwrap();
    let jit = shadenet_jit::JitBackend::new();
    let m = jit.compile(&p, &spec).unwrap();
    let bits = |v: Vec<f64>| v.iter().map(|x| (*x as f32).to_bits()).collect::<Vec<_>>();
    let reference = bits(interp.pixel_values());
    assert!(reference.iter().any(|b| *b != 0), "the shader is lit");
    for batch in [false, true] {
        let g = shadenet::shade::shade_grid_with(&*m, &env, 16, 9, spec.components, batch);
        assert_eq!(reference, bits(g.pixel_values()), "batch {batch}");
    }
}

/// Bad input: each error names the place and what is wrong; what is not built says so.
#[test]
fn errors_name_the_place_and_the_problem() {
    for (src, want) in [
        (
            "surface s() { int i = 1.5; }",
            "expected an int, found a float",
        ),
        (
            "surface s() { float x = diffuse(N); }",
            "expected a float, found a closure color",
        ),
        (
            "surface s() { Ci = diffuse(N) * diffuse(N); }",
            "closures add to closures and scale by a float or a color",
        ),
        (
            "surface s(int n = 3) { for (int i = 0; i < n; i++) Ci += diffuse(N); }",
            "its trip count is not a compile-time constant",
        ),
        (
            "surface s() { float x = 0; while (x < u) { Ci += diffuse(N); x += 0.1; } }",
            "its trip count is not a compile-time constant",
        ),
        (
            "surface s() { for (int i = 0; i < 3; i++) { if (u > 0.5) break; Ci += diffuse(N); } }",
            "it has `break` or `continue`",
        ),
        (
            "surface s() { for (int i = 0; i < 100; i++) Ci += diffuse(N); }",
            "it runs more than 64 times",
        ),
        (
            "surface s() { Ci = ward(N, dPdu, 0.1, 0.2); }",
            "`ward`: the Ward lobe is not built",
        ),
        (
            "surface s() { Ci = microfacet(\"beckmann\", N, 0.1, 1.5, 0); }",
            "microfacet distribution \"beckmann\" is not built (only \"ggx\")",
        ),
        (
            "surface s() { float x = noise(\"gabor\", u); }",
            "`noise`: gabor noise is not built yet",
        ),
        (
            "surface s() { float x = noise(\"fancy\", P); }",
            "unknown noise generator \"fancy\"",
        ),
        (
            "surface s() { float x = transformu(\"m\", \"cm\", u); }",
            "`transformu`: unit conversions are not built yet",
        ),
        ("surface s() { Ci = difuse(N); }", "did you mean `diffuse`?"),
        (
            "surface s() { color c = ambient(); }",
            "unknown function `ambient`",
        ),
        (
            "surface s() { vector v = P; float x = v.w; }",
            "has no field `w`",
        ),
        ("volume v() { }", "volume shaders are not compiled yet"),
    ] {
        let err = compile(src).unwrap_err();
        assert!(err.contains(want), "{src}\n→ {err}");
        assert!(err.contains("t.osl:1:"), "{src}: the place\n{err}");
    }
}

/// `examples/scenes/osl.toml` renders its OSL materials: the interpreter and the JIT give
/// the same bits, the three spheres are lit and finite, the glossy one red.
#[test]
fn the_osl_scene_renders() {
    let films = common::render_interp_and_jit("osl.toml", 2, (48, 27));
    assert_eq!(
        beauty_bits(&films[0]),
        beauty_bits(&films[1]),
        "interp and JIT"
    );
    let beauty = &films[1].layers[0];
    let px = |x: usize, y: usize| -> [f32; 3] { std::array::from_fn(|c| beauty.at(y * 48 + x, c)) };
    // The three spheres' centres: row 12, columns 16, 24, 32.
    let spheres: Vec<[f32; 3]> = [16, 24, 32].iter().map(|&x| px(x, 12)).collect();
    for s in &spheres {
        assert!(
            s.iter().all(|c| c.is_finite()) && s.iter().sum::<f32>() > 0.02,
            "{spheres:?}"
        );
    }
    // The glossy sphere's base is red.
    assert!(spheres[0][0] > 2.0 * spheres[0][2], "{spheres:?}");
}

/// Writes `files` (name, text) into a fresh folder and returns it.
fn folder(name: &str, files: &[(&str, &str)]) -> std::path::PathBuf {
    let dir = common::tmp("shader_osl", name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for (f, text) in files {
        std::fs::write(dir.join(f), text).unwrap();
    }
    dir
}

const NOISE_LAYER: &str = "shader noisy(float scale = 1, output float n = 0, output color c = 0) {
    n = snoise(P * scale); c = color(n, 2 * n, scale); }";
const TINT_LAYER: &str =
    "surface tint(color base = color(1, 0, 0), float amount = 0, float k = 1) {
    Ci = (base * k + amount) * emission(); }";

/// A shader group in OSL's serialized text: `param` values for the next layer, layers
/// connected output to parameter (an int or float widening as in calls), the last layer's
/// outputs the program's, the instance values program parameters named `layer.param`.
#[test]
fn shader_groups_connect_layers() {
    let group = "param float scale 3.5 ;\nshader noisy tex ;\n\
                 param float k 0.5 [[ string help = \"gain\" ]] ;\nshader tint mat ;\n\
                 connect tex.c mat.base ;\nconnect tex.n mat.amount ;\n";
    let dir = folder(
        "group",
        &[
            ("noisy.osl", NOISE_LAYER),
            ("tint.osl", TINT_LAYER),
            ("g.oslgroup", group),
        ],
    );
    let compiled = shadenet::shader::load(&dir.join("g.oslgroup"), &[], &[]).unwrap();
    let p = &compiled.program;
    assert_eq!(p.name, "mat");
    let names: Vec<&str> = p.params.iter().map(|q| q.name.as_str()).collect();
    assert_eq!(names, ["tex.scale", "mat.k"]);
    let mut f = plane_fragment();
    f.p = [0.3, -0.7, 0.2];
    let o = run_program(p, &f, &[], u32::MAX);
    let q: [f32; 3] = std::array::from_fn(|i| f.p[i] * 3.5);
    let n = osl_noise::perlin3(q) as f64;
    let want = [n * 0.5 + n, 2.0 * n * 0.5 + n, 3.5 * 0.5 + n];
    assert_close(&o.get("Ci"), &want, 1e-6, "Ci of the group");
    // `--param tex.scale=1` reaches the first layer.
    let mut p2 = p.clone();
    shadenet::shader::set_param(&mut p2, "tex.scale", &[1.0]).unwrap();
    let o = run_program(&p2, &f, &[], u32::MAX);
    let q: [f32; 3] = f.p;
    let n = osl_noise::perlin3(q) as f64;
    assert_close(&o.get("Ci"), &[1.5 * n, 2.0 * n, 0.5 + n], 1e-6, "scale 1");
}

/// B1's tree as a group of 2^N leaf and 2^N − 1 multiply layers (`shadenet gen mult-tree -o
/// tree.oslgroup`) shades what the network does and optimizes to as few ops.
#[test]
fn the_multiplication_tree_as_a_group_is_the_network() {
    let levels = 6;
    let mut files: Vec<(&str, String)> = shadenet::generate::MULT_TREE_SHADERS
        .iter()
        .map(|(n, s)| (*n, s.to_string()))
        .collect();
    files.push((
        "tree.oslgroup",
        shadenet::generate::mult_tree_group(levels).unwrap(),
    ));
    let refs: Vec<(&str, &str)> = files.iter().map(|(n, s)| (*n, s.as_str())).collect();
    let dir = folder("tree", &refs);
    let group = shadenet::shader::load(&dir.join("tree.oslgroup"), &[], &[]).unwrap();
    let net = shadenet::generate::mult_tree(levels, shadenet::graph::ir::Space::World).unwrap();
    let net = compile_json(&net.to_string(), &NodeLibrary::standard()).unwrap();
    let spec = Specialization::default();
    let (g, _) = opt::run(&group.program, &spec);
    let (n, _) = opt::run(&net.program, &spec);
    // The leaves' point-to-color construct is the only difference.
    assert!(
        g.op_count() <= n.op_count() + 4,
        "{} vs {}",
        g.op_count(),
        n.op_count()
    );
    let mut f = plane_fragment();
    f.p = [1.01, 0.99, 1.003];
    let a = run_program(&g, &f, &[], u32::MAX);
    let b = run_program(&n, &f, &[], u32::MAX);
    assert_eq!(a.get32("out"), b.get32("color"));
    assert_eq!(a.get("out"), b.get("color"));
}

/// Bad groups: each error names the statement (file:line) and what is wrong.
#[test]
fn shader_group_errors_name_the_statement() {
    for (group, want) in [
        (
            "shader tint mat ;\nconnect tex.c mat.base ;",
            "no layer `tex` in the group",
        ),
        (
            "shader noisy a ;\nshader tint b ;\nconnect b.Ci a.scale ;",
            "`b` is not an earlier layer than `a`",
        ),
        (
            "param float scal 2 ;\nshader noisy a ;",
            "has no input parameter `scal`",
        ),
        (
            "shader noisy a ;\nshader tint b ;\nconnect a.m b.k ;",
            "layer `a` has no output `m`",
        ),
        ("shader nowhere a ;", "no source for shader `nowhere`"),
        (
            "shader noisy a ;\nshader noisy a ;",
            "a second layer named `a`",
        ),
        (
            "param float scale \"big\" ;\nshader noisy a ;",
            "(\"big\") is not a float value",
        ),
        (
            "param float scale ;\nshader noisy a ;",
            "`param scale` has no value",
        ),
        (
            "shader noisy a ;\nparam float scale 1 ;",
            "`param` after the last `shader`",
        ),
        (
            "layer noisy a ;",
            "expected `param`, `shader` or `connect`, found `layer`",
        ),
        ("shader noisy ;", "expected a layer name"),
    ] {
        let dir = folder(
            "group_errors",
            &[
                ("noisy.osl", NOISE_LAYER),
                ("tint.osl", TINT_LAYER),
                ("g.oslgroup", group),
            ],
        );
        let err = shadenet::shader::load(&dir.join("g.oslgroup"), &[], &[])
            .unwrap_err()
            .to_string();
        assert!(err.contains(want), "{group}\n→ {err}");
        assert!(err.contains("g.oslgroup"), "{group}: names the file\n{err}");
    }
}

/// `shadenet shade --group FILE` reads a group whatever its file is called; `check` takes
/// `.oslgroup` files as they are.
#[test]
fn the_cli_shades_a_group() {
    let group =
        "param float scale 2 ;\nshader noisy tex ;\nshader tint mat ;\nconnect tex.c mat.base ;\n";
    let dir = folder(
        "group_cli",
        &[
            ("noisy.osl", NOISE_LAYER),
            ("tint.osl", TINT_LAYER),
            ("layers.txt", group),
        ],
    );
    let file = dir.join("layers.txt");
    let out = dir.join("out.exr");
    let (code, _, err) = shadenet(&[
        "shade",
        "--group",
        file.to_str().unwrap(),
        "--res",
        "8x8",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.is_file());
    std::fs::copy(&file, dir.join("layers.oslgroup")).unwrap();
    let (code, stdout, err) = shadenet(&["check", dir.join("layers.oslgroup").to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("outputs: Ci"), "{stdout}");
    let (code, _, err) = shadenet(&["check", file.to_str().unwrap()]);
    assert_ne!(code, 0, "a .txt file without --group is not a group");
    assert!(!err.is_empty());
}

/// OSL structs: declared, fields read and written (array fields by index), whole-struct
/// copies, constructors, structs through `if` and loops, passed to and returned from
/// functions, `output` structs written back.
#[test]
fn structs_hold_fields() {
    let src = r#"
        struct Layer { color tint; float weight; float w[2]; };
        struct Pair { Layer a; Layer b; };
        Layer scaled(Layer l, float k) { Layer r = l; r.weight *= k; return r; }
        void bump(output Layer l) { l.w[1] += 1; }
        shader s(output color o = 0, output color p = 0) {
            Layer l;
            l.tint = color(0.5, 0.25, 1);
            l.weight = 2;
            l.w[0] = 3;
            Layer m = Layer(color(1), 0.5, l.w);
            if (u > 0.5) { m.weight = 7; m.w[1] = 9; }
            for (int i = 0; i < 3; i++) l.weight += 1;
            Layer n = scaled(l, 10);
            bump(n);
            Pair pr;
            pr.a = n;
            pr.b.weight = pr.a.w[1];
            o = color(n.weight, m.weight + m.w[1], n.w[1]);
            p = color(pr.b.weight, pr.a.tint[2], m.w[0]);
        }"#;
    let p = compile(src).unwrap();
    for (u, m_weight, m_w1) in [(0.25, 0.5, 0.0), (0.75, 7.0, 9.0)] {
        let mut f = plane_fragment();
        f.uv = [u, 0.5];
        let o = run_program(&p, &f, &[], u32::MAX);
        // l.weight = 2 + 3 = 5; scaled ×10 = 50; bump: n.w[1] = 0 + 1.
        check(&o, "o", &[50.0, m_weight + m_w1, 1.0], 0.0);
        check(&o, "p", &[1.0, 1.0, 3.0], 0.0);
    }
    assert_errors(&[
        (
            "struct S { float a; }; surface s() { S x; float y = x.b; }",
            "struct `S` has no field `b` (its fields: a)",
        ),
        (
            "struct S { float a; }; surface s() { S x = 1; }",
            "`x` is a `S`: not an int",
        ),
        (
            "struct S { float a, b; }; surface s() { S x = S(1); }",
            "struct `S` is made of its 2 fields in order",
        ),
    ]);
}

/// Operators on structs are OSL's overloads `__operator__add__` and kin, chosen by the
/// operand types as any overload is (MaterialX's OSL library defines `vector2` this way).
#[test]
fn operators_on_structs_call_their_overloads() {
    let src = r#"
        struct v2 { float x; float y; };
        v2 __operator__add__(v2 a, v2 b) { return v2(a.x + b.x, a.y + b.y); }
        v2 __operator__add__(v2 a, float b) { return a + v2(b, b); }
        v2 __operator__mul__(v2 a, float b) { return v2(a.x * b, a.y * b); }
        v2 __operator__neg__(v2 a) { return v2(-a.x, -a.y); }
        int __operator__eq__(v2 a, v2 b) { return a.x == b.x && a.y == b.y; }
        shader s(output color o = 0) {
            v2 p = v2(u, 2);
            v2 q = -(p + 1) * 3 + p;
            o = color(q.x, q.y, p == v2(u, 2));
        }"#;
    let p = compile(src).unwrap();
    let mut f = plane_fragment();
    f.uv = [0.25, 0.5];
    let o = run_program(&p, &f, &[], u32::MAX);
    check(&o, "o", &[-(1.25 * 3.0) + 0.25, -9.0 + 2.0, 1.0], 0.0);
    let err = compile(
        "struct v2 { float x; float y; }; shader s(output float o = 0) { v2 a; v2 b = a - a; }",
    )
    .unwrap_err();
    assert!(
        err.contains("`-` on (struct, struct): define `__operator__sub__`"),
        "{err}"
    );
}

/// `return` before a function's end (the rest runs where it did not return), `return;` in
/// a shader, `output` arguments that are array elements and components, user overloads
/// beside a builtin of the same name (MaterialX's OSL library defines `abs(color4)`).
#[test]
fn early_returns_and_output_elements() {
    let src = r#"
        struct c4 { color rgb; float a; };
        c4 abs(c4 x) { return c4(abs(x.rgb), abs(x.a)); }
        void burn(float fg, float bg, output float result) {
            if (abs(fg) < 1e-8) { result = 0; return; }
            result = 1 - (1 - bg) / fg;
        }
        float sgn(float x) { if (x < 0) return -1; if (x > 0) return 1; return 0; }
        shader s(output color o = 0, output float k[2] = { 0, 0 }, output float m = 0) {
            color r;
            burn(u, 0.2, r[0]);
            burn(0, 0.4, r[1]);
            burn(0.5, v, r[2]);
            o = r;
            m = sgn(u - 0.5) + abs(c4(color(-2), -3)).a * 10;
            if (v > 0.5) return;
            m += 100;
        }"#;
    let p = compile(src);
    let p = match p {
        Ok(p) => p,
        Err(e) if e.contains("output array parameters") => {
            // Output arrays are not built: the same without `k`.
            compile(&src.replace(", output float k[2] = { 0, 0 }", "")).unwrap()
        }
        Err(e) => panic!("{e}"),
    };
    for (u, v) in [(0.25f32, 0.25f32), (0.75, 0.75), (0.5, 0.1)] {
        let mut f = plane_fragment();
        f.uv = [u, v];
        let o = run_program(&p, &f, &[], u32::MAX);
        let burn = |fg: f64, bg: f64| {
            if fg.abs() < 1e-8 {
                0.0
            } else {
                1.0 - (1.0 - bg) / fg
            }
        };
        let (u, v) = (u as f64, v as f64);
        assert_close(&o.get("o"), &[burn(u, 0.2), 0.0, burn(0.5, v)], 1e-12, "o");
        let sgn = (u - 0.5).signum() * ((u - 0.5) != 0.0) as i32 as f64;
        let m = sgn + 30.0 + if v > 0.5 { 0.0 } else { 100.0 };
        check(&o, "m", &[m], 0.0);
    }
    let err = compile(
        "float f(float x) { for (int i = 0; i < 3; i++) { if (x > i) return i; } return 0; } \
         shader s(output float o = 0) { o = f(u); }",
    )
    .unwrap_err();
    assert!(
        err.contains("`return` inside a loop is not built yet"),
        "{err}"
    );
}

/// A closure output connected to a later layer's closure input: the lobes flow through the
/// group (an unconnected closure input is the empty closure).
#[test]
fn closures_connect_between_layers() {
    let dir = folder(
        "group_closure",
        &[
            (
                "bsdf.osl",
                "shader bsdf(output closure color c = 0) { c = diffuse(N); }",
            ),
            (
                "half.osl",
                "surface half(closure color base = 0) { Ci = base * 0.5; }",
            ),
            (
                "g.oslgroup",
                "shader bsdf a ;\nshader half b ;\nconnect a.c b.base ;\n",
            ),
            ("alone.oslgroup", "shader half b ;\n"),
        ],
    );
    let lights = [point([0.6, -0.3, 1.5], 3.0)];
    let mut f = plane_fragment();
    f.p = [0.2, 0.1, 0.0];
    f.i = [0.2, 0.1, -1.0];
    let lambert = lambert_value(&lights, &f);
    let g = shadenet::shader::load(&dir.join("g.oslgroup"), &[], &[]).unwrap();
    let o = run_program(&g.program, &f, &lights, u32::MAX);
    let half: Vec<f64> = lambert.iter().map(|x| x * 0.5).collect();
    check(&o, "Ci", &half, 1e-9);
    let alone = shadenet::shader::load(&dir.join("alone.oslgroup"), &[], &[]).unwrap();
    let o = run_program(&alone.program, &f, &lights, u32::MAX);
    check(&o, "Ci", &[0.0; 3], 0.0);
}

/// `Dx`, `Dy`, `filterwidth`, `area`, `calculatenormal` and `aastep` read the screen-space
/// derivatives: on the
/// plane with ray differentials, `P`'s are the differentials, `u`'s their x components, a
/// product's by the chain rule; a parameter's are zero; `aastep` is stdosl.h's box step
/// (a ramp across the footprint, hard where there is none).
#[test]
fn derivative_builtins_read_the_footprint() {
    let src = r#"
        shader d(float k = 3, output vector dp = 0, output color w = 0,
                 output color s = 0, output float a = 0, output vector cn = 0,
                 output vector cd = 0)
        {
            dp = Dx(P) + 10 * Dy(P);
            float f = u * u * k;
            w = color(filterwidth(u), Dx(f), Dy(k));
            s = color(aastep(0.5, u), aastep(0.5, u, 0.2), aastep(0.5, u, 0, 0.2));
            a = area(P);
            cn = calculatenormal(P);
            cd = calculatenormal(P + N * u * 0.5);
        }"#;
    let p = compile(src).unwrap();
    let f = shadenet::runtime::Fragment {
        uv: [0.45, 0.5],
        p: [0.45, 0.5, 0.0],
        dpdx: [0.04, 0.0, 0.0],
        dpdy: [0.0, 0.02, 0.0],
        ..plane_fragment()
    };
    let o = run_program(&p, &f, &[], u32::MAX);
    check(&o, "dp", &[0.04, 0.2, 0.0], 1e-7);
    // d(u²k)/dx = 2·u·k·du/dx.
    check(&o, "w", &[0.04, 2.0 * 0.45 * 3.0 * 0.04, 0.0], 1e-6);
    // u = 0.45: [0.43, 0.47] is below 0.5 (w = 0.04); with ds = 0.2, [0.35, 0.55] → 0.25.
    check(&o, "s", &[0.0, 0.25, 0.25], 1e-6);
    check(&o, "a", &[0.04 * 0.02], 1e-9);
    // calculatenormal: Dx(P) × Dy(P), facing as N; displaced by 0.5·u along N, Dx gains
    // 0.5·0.04 in z: (0.04, 0, 0.02) × (0, 0.02, 0).
    check(&o, "cn", &[0.0, 0.0, 0.04 * 0.02], 1e-9);
    check(&o, "cd", &[-0.02 * 0.02, 0.0, 0.04 * 0.02], 1e-9);
    // Screen axes left-handed on the surface (its dP/dx × dP/dy against N): OSL's
    // flipHandedness, Dy × Dx, so the result still faces as N does.
    let mirrored = shadenet::runtime::Fragment {
        n: [0.0, 0.0, -1.0],
        ..f
    };
    let o = run_program(&p, &mirrored, &[], u32::MAX);
    check(&o, "cn", &[0.0, 0.0, -0.04 * 0.02], 1e-9);
    let flat = plane_fragment();
    let o = run_program(&p, &flat, &[], u32::MAX);
    check(&o, "w", &[0.0, 0.0, 0.0], 0.0);
    // No footprint: OSL's formula is 0 at the edge itself (u = 0.5: `s <= edge − 0`), and
    // the ramps of the given widths are [0.4, 0.6] → 0.5.
    check(&o, "s", &[0.0, 0.5, 0.5], 1e-6);
    let o = run_program(
        &p,
        &shadenet::runtime::Fragment {
            uv: [0.6, 0.5],
            ..flat
        },
        &[],
        u32::MAX,
    );
    check(&o, "s", &[1.0, 1.0, 1.0], 0.0);
}

/// A mesh with named attributes for [`getattribute_reads_the_geometry`]: each of the
/// program's attribute slots resolved by name, as a renderer resolves them.
struct Primvars {
    /// The program's attribute table's values here (`None`: the mesh lacks it).
    slots: Vec<Option<Vec<f32>>>,
}

impl Primvars {
    fn new(p: &shadenet::graph::ir::Program, have: &[(&str, &[f32])]) -> Primvars {
        let slots = p
            .attributes
            .iter()
            .map(|a| {
                have.iter()
                    .find(|(n, _)| *n == a.name)
                    .map(|(_, v)| v.to_vec())
            })
            .collect();
        Primvars { slots }
    }
}

impl shadenet::runtime::SceneServices for Primvars {
    fn trace(&self, _: [f32; 3], _: [f32; 3], _: i32, _: i32, _: f32) -> [f32; 3] {
        [0.0; 3]
    }
    fn occluded(&self, _: [f32; 3], _: [f32; 3]) -> bool {
        false
    }
    fn occlusion(&self, _: [f32; 3], _: [f32; 3], _: u32, _: f32, _: u32) -> f32 {
        1.0
    }
    fn attribute(&self, slot: u32, out: &mut [f32]) -> bool {
        match &self.slots[slot as usize] {
            Some(v) => {
                for (o, x) in out.iter_mut().zip(v) {
                    *o = *x;
                }
                true
            }
            None => false,
        }
    }
}

/// `getattribute(name, value)` reads the shaded geometry's attributes (the IR's attribute
/// ops): 1 and the value where the mesh has the name, 0 and the output unchanged where it
/// has not or no renderer asks; into floats, ints (truncated), triples and float arrays;
/// `"color"` is colour set `COLOR_0`, `"time"` the fragment's time; a string output is never
/// found; called under a varying condition the output changes only there. The
/// interpreter (f32) and the JIT agree. Other forms are errors naming the call.
#[test]
fn getattribute_reads_the_geometry() {
    let src = r#"
        shader s(output float a = 0, output float fa = 0, output color c = 0,
                 output float k = 0, output float fk = 0, output color arr = 0,
                 output float t = 0, output float m = 0, output float st = 0,
                 string name = "x")
        {
            a = -1;
            fa = getattribute("temperature", a);
            if (getattribute("color", c) == 0) c = color(9);
            int n = 5;
            fk = getattribute("count", n);
            k = n;
            float w[3] = { -1, -2, -3 };
            getattribute("weights", w);
            arr = color(w[0], w[1], w[2]);
            getattribute("time", t);
            m = 4;
            if (u > 0.5) getattribute("mask", m);
            st = getattribute("label", name) + 10;
        }"#;
    let p = compile(src).unwrap();
    let names: Vec<&str> = p.attributes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(
        names,
        ["temperature", "COLOR_0", "count", "weights", "mask"]
    );
    let have: &[(&str, &[f32])] = &[
        ("temperature", &[310.5]),
        ("COLOR_0", &[0.25, 0.5, 0.75]),
        ("count", &[7.9]),
        ("weights", &[1.0, 2.0, 3.0]),
        ("mask", &[0.5]),
    ];
    let full = Primvars::new(&p, have);
    let empty = Primvars::new(&p, &[]);
    let jit = shadenet::jit::JitBackend::new()
        .compile_program(&p, std::time::Duration::ZERO)
        .unwrap();
    assert_eq!(jit.info().backend, "jit");
    let interp = shadenet::runtime::InterpBackend
        .compile_program(&p, std::time::Duration::ZERO)
        .unwrap();
    let env = shadenet::runtime::ShadeEnv::default();
    for (scene, u, want) in [
        (
            &full,
            0.75,
            [
                310.5, 1.0, 0.25, 0.5, 0.75, 7.0, 1.0, 1.0, 2.0, 3.0, 2.5, 0.5, 10.0,
            ],
        ),
        (
            &full,
            0.25,
            [
                310.5, 1.0, 0.25, 0.5, 0.75, 7.0, 1.0, 1.0, 2.0, 3.0, 2.5, 4.0, 10.0,
            ],
        ),
        (
            &empty,
            0.75,
            [
                -1.0, 0.0, 9.0, 9.0, 9.0, 5.0, 0.0, -1.0, -2.0, -3.0, 2.5, 4.0, 10.0,
            ],
        ),
    ] {
        let mut f = plane_fragment();
        f.uv = [u, 0.5];
        f.time = 2.5;
        for m in [&interp, &jit] {
            let mut out = vec![f32::NAN; m.width()];
            let ctx = shadenet::runtime::ShadeCtx {
                frag: f,
                env: &env,
                mask: u32::MAX,
                scene: Some(scene),
            };
            m.shade(&ctx, &mut out);
            assert_eq!(out, want, "{} at u = {u}", m.info().backend);
        }
    }
    assert_errors(&[
        (
            "shader s(output float a = 0) { getattribute(\"obj\", \"x\", a); }",
            "`getattribute` of a named object is not built",
        ),
        (
            "shader s(output float a = 0) { float x[3]; getattribute(\"x\", 1, a); }",
            "one element of an array attribute",
        ),
        (
            "shader s(output float a = 0) { matrix m = 1; a = getattribute(\"x\", m); }",
            "not into a matrix",
        ),
        (
            "shader s(output float a = 0) { a = getattribute(\"x\", 2); }",
            "is an `output` parameter: pass a variable",
        ),
    ]);
}

/// OSL's `{ … }` compound initialisers build a struct where one is expected: a declaration,
/// an assignment to a struct variable or output, a `return` (early or last), a struct
/// parameter's default, nested for a struct field; the wrong count, and a list where no
/// struct or array is expected, are errors.
#[test]
fn brace_initialisers_build_structs() {
    let src = r#"
        struct V2 { float x; float y; };
        struct C4 { color rgb; float a; };
        struct Pair { V2 p; float k; };
        V2 make(float x) { if (x > 5) return { x, 1 }; return { x, 2 }; }
        C4 tint(float a) { return { color(a, 0, 1), a }; }
        shader s(V2 d = { 3, 4 }, output V2 o = { 1, 2 }, output color c = 0,
                 output color e = 0)
        {
            V2 v = { 5, 6 };
            Pair pr = { { 7, 8 }, 9 };
            if (u > 0.5) o = { d.x, v.y };
            V2 m = make(u * 10);
            C4 t = tint(0.5);
            c = color(pr.p.x + pr.p.y, pr.k, m.y);
            e = color(t.rgb[0], t.a, m.x);
        }"#;
    let p = compile(src).unwrap();
    for (u, o, my) in [(0.25, [1.0, 2.0], 2.0), (0.75, [3.0, 6.0], 1.0)] {
        let mut f = plane_fragment();
        f.uv = [u, 0.5];
        let out = run_program(&p, &f, &[], u32::MAX);
        check(&out, "o.x", &[o[0]], 0.0);
        check(&out, "o.y", &[o[1]], 0.0);
        check(&out, "c", &[15.0, 9.0, my], 0.0);
        check(&out, "e", &[0.5, 0.5, f64::from(u) * 10.0], 1e-6);
    }
    assert_errors(&[
        (
            "struct V2 { float x; float y; }; shader s() { V2 v = { 1, 2, 3 }; }",
            "struct `V2` is made of its 2 fields in order: this list has 3",
        ),
        (
            "shader s(output float a = 0) { a = { 1, 2 }; }",
            "a `{…}` list initialises an array in its declaration, or a struct where one is expected",
        ),
    ]);
}

/// `environment(file, R)` reads a lat-long map in the layout of the scene's environment
/// lights (`env_image::uv_to_direction` at rotation 0): the texel whose direction `R` is,
/// whatever `R`'s length; periodic across the longitude, clamped at the poles; options as
/// `texture`'s.
#[test]
fn environment_reads_the_lat_long_map() {
    let dir = std::env::temp_dir().join(format!("shadenet-osl-env-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("env.png");
    // 8 × 4 texels: red = column · 32, green = row · 64, blue 255.
    let px: Vec<u8> = (0..4u8)
        .flat_map(|r| (0..8u8).flat_map(move |c| [c * 32, r * 64, 255]))
        .collect();
    image::save_buffer(&path, &px, 8, 4, image::ExtendedColorType::Rgb8).unwrap();
    let src = format!(
        r#"shader e(output color c = 0, output color d = 0) {{
               c = environment({:?}, P, "interp", "closest", "colorspace", "lin_rec709");
               d = environment({:?}, P * 3, "interp", "closest", "colorspace", "lin_rec709");
           }}"#,
        path.to_string_lossy(),
        path.to_string_lossy()
    );
    let p = compile(&src).unwrap();
    let texel = |c: usize, r: usize| [c as f64 * 32.0 / 255.0, r as f64 * 64.0 / 255.0, 1.0];
    for (c, r) in [(0, 0), (3, 1), (4, 2), (7, 3), (5, 0), (1, 3)] {
        let uv = [(c as f64 + 0.5) / 8.0, (r as f64 + 0.5) / 4.0];
        let (d, _) = shadenet::graph::nodes::env_image::uv_to_direction(uv, (1.0, 0.0));
        let mut f = plane_fragment();
        f.p = d.map(|x| x as f32);
        let o = run_program(&p, &f, &[], u32::MAX);
        check(&o, "c", &texel(c, r), 1e-6);
        check(&o, "d", &texel(c, r), 1e-6);
    }
    // Straight up is the top row; straight down the bottom one.
    let mut f = plane_fragment();
    f.p = [0.0, 1.0, 0.0];
    let top = run_program(&p, &f, &[], u32::MAX).get("c");
    assert_eq!(top[1], 0.0, "top row: {top:?}");
    f.p = [0.0, -1.0, 0.0];
    let bottom = run_program(&p, &f, &[], u32::MAX).get("c");
    assert!(
        (bottom[1] - 192.0 / 255.0).abs() < 1e-6,
        "bottom row: {bottom:?}"
    );
    assert_errors(&[
        (
            "shader s(output color c = 0) { c = environment(\"sky.exr\", 1.0); }",
            "`environment` takes (string file, vector R) before its optional arguments",
        ),
        (
            "shader s(output color c = 0) { c = environment(\"sky.exr\", N, \"blur\", 0.1); }",
            "`environment` option \"blur\" is not built",
        ),
    ]);
}

/// `texture`'s optional arguments become the lookup's sampling, colour space and alpha
/// (the IR's texture ops say which), strings compare as the constants they are, and an
/// option not built, a wrap mode that is none, or a lone token are errors naming them.
#[test]
fn texture_options_and_string_comparisons() {
    let src = r#"
        shader s(output color c = 0, output float a = 0, string mode = "constant")
        {
            float al[2] = { 0, 0 };
            c = texture("t.png", u, v, "swrap", mode, "twrap", "mirror", "interp", "closest",
                        "colorspace", "srgb_texture", "alpha", al[1], "subimage", "",
                        "missingcolor", color(1), "missingalpha", 0.5);
            a = al[1];
        }"#;
    let p = compile(src).unwrap();
    assert_eq!(p.textures.len(), 1);
    assert_eq!(p.textures[0].path, "t.png");
    assert_eq!(
        p.textures[0].colorspace,
        shadenet::graph::ir::ColorSpace::SrgbTexture
    );
    let text = p.to_string();
    assert!(
        text.contains("= texture #0 closest black mirror %"),
        "{text}"
    );
    assert!(
        text.contains("= texture.alpha #0 closest black mirror %"),
        "{text}"
    );
    let eq = compile(
        r#"shader s(output float eq = 0, string mode = "constant") {
               eq = (mode == "constant") + 2 * (mode != "clamp") + 4 * ("a" == "b");
           }"#,
    )
    .unwrap();
    let o = run_program(&eq, &plane_fragment(), &[], u32::MAX);
    check(&o, "eq", &[3.0], 0.0);
    assert_errors(&[
        (
            "shader s(output color c = 0) { c = texture(\"t.png\", u, v, \"firstchannel\", 1); }",
            "`texture` option \"firstchannel\" is not built",
        ),
        (
            "shader s(output color c = 0) { c = texture(\"t.png\", u, v, \"blur\", \"x\"); }",
            "`texture` option \"blur\": a float",
        ),
        (
            "shader s(output color c = 0) { c = texture(\"t.png\", u, v, \"swrap\", \"wobble\"); }",
            "`texture` option \"swrap\": a wrap mode",
        ),
        (
            "shader s(output color c = 0) { c = texture(\"t.png\", u, v, \"swrap\"); }",
            "pairs of a token string and a value",
        ),
        (
            "shader s(output color c = 0) { c = texture(\"t.png\", u, v, \"subimage\", \"diffuse\"); }",
            "named subimages (layers) are not built",
        ),
    ]);
}

/// OSL's triple forms of `smoothstep` (edges triples or floats) and `atan2` work per
/// component, as MaterialX's `smoothstep` and `atan2` of a vector3 use them.
#[test]
fn smoothstep_and_atan2_of_triples() {
    let p = compile(
        r#"shader s(output vector a = 0, output color b = 0, output vector c = 0) {
               a = smoothstep(vector(0), vector(1, 1, 4), vector(0.5, -1, 2));
               b = smoothstep(0, 1, color(0.25, 1.5, 0));
               c = atan2(vector(1, 0, -1), vector(1, 1, 1));
           }"#,
    )
    .unwrap();
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    check(&o, "a", &[0.5, 0.0, 0.5], 1e-7);
    check(&o, "b", &[0.15625, 1.0, 0.0], 1e-7);
    let q = std::f64::consts::FRAC_PI_4;
    check(&o, "c", &[q, 0.0, -q], 1e-6);
}

/// `==` and `!=` of two triples compare every component (MaterialX's `normalmap` tests
/// `value == vector(0.0)`).
#[test]
fn triples_compare_by_every_component() {
    let p = compile(
        r#"shader s(vector w = vector(1, 2, 3), output float a = 0) {
               a = (w == vector(1, 2, 3)) + 2 * (w != vector(1, 2, 4))
                   + 4 * (w == point(1, 0, 3)) + 8 * (color(1) != color(1));
           }"#,
    )
    .unwrap();
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    check(&o, "a", &[3.0], 0.0);
    let err = compile("shader s(output float a = 0) { a = vector(1) < vector(2); }").unwrap_err();
    assert!(err.contains("not a vector and a vector"), "{err}");
}

/// `transformc` between `"rgb"` and `"hsv"` is the colour conversion RSL's `color "hsv"`
/// uses (there and back is the colour), of any triple; another space is an error naming it.
#[test]
fn transformc_converts_between_rgb_and_hsv() {
    let p = compile(
        r#"shader s(output color h = 0, output vector back = 0, output color same = 0) {
               h = transformc("rgb", "hsv", color(1, 0, 0));
               back = transformc("hsv", "rgb", transformc("rgb", "hsv", vector(0.2, 0.4, 0.8)));
               same = transformc("hsv", "hsv", color(0.1, 0.2, 0.3));
           }"#,
    )
    .unwrap();
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    check(&o, "h", &[0.0, 1.0, 1.0], 1e-7);
    check(&o, "back", &[0.2, 0.4, 0.8], 1e-6);
    check(&o, "same", &[0.1, 0.2, 0.3], 1e-7);
    // The other spaces: tests/shader_color.rs; an unknown one is an error naming it.
    let err =
        compile("shader s(output color c = 0) { c = transformc(\"rgb\", \"Lab\", color(1)); }")
            .unwrap_err();
    assert!(
        err.contains("`transformc`: unknown color space \"Lab\""),
        "{err}"
    );
}

/// A triple's components are assigned by name (`v.x = …`, `c.g += …`), also inside `if`
/// regions and loops (MaterialX's Worley noise of a vector3 keeps its three distances so).
#[test]
fn triple_components_are_assigned_by_name() {
    let p = compile(
        r#"struct S { vector w; };
           shader s(output vector a = 0, output color c = 0, output vector f = 0) {
               vector d = vector(9);
               for (int i = 0; i < 3; i++) {
                   float x = 3 - i;
                   if (x < d.x) { d.z = d.y; d.y = d.x; d.x = x; }
               }
               a = d;
               c = color(0.5);
               if (u > 0.5) c.g += 1;
               S s;
               s.w = vector(1, 2, 3);
               s.w.y = 7;
               f = s.w;
           }"#,
    )
    .unwrap();
    for (u, g) in [(0.25, 0.5), (0.75, 1.5)] {
        let mut fr = plane_fragment();
        fr.uv = [u, 0.5];
        let o = run_program(&p, &fr, &[], u32::MAX);
        check(&o, "a", &[1.0, 2.0, 3.0], 0.0);
        check(&o, "c", &[0.5, g, 0.5], 0.0);
        check(&o, "f", &[1.0, 7.0, 3.0], 0.0);
    }
}

/// MaterialX's OSL closures take their thin film by OSL keyword arguments, as MaterialX's
/// OSL generator writes them: equal to the MaterialX node with the same film; a thickness
/// of 0 is the plain lobe, the film's index defaults to 1.5; an unknown keyword is an
/// error naming it. stdosl.h's `mix` of two closures is `x (1 − a) + y a`.
#[test]
fn closure_keywords_and_mix() {
    let lights = [point([0.6, -0.3, 1.5], 3.0), point([-1.0, 0.5, 0.7], 2.0)];
    let mut f = plane_fragment();
    f.p = [0.2, 0.1, 0.0];
    f.i = [0.3, 0.1, -1.0];
    let ci = |src: &str| {
        let p = compile(&format!("surface s() {{ Ci = {src}; }}")).unwrap();
        run_program(&p, &f, &lights, u32::MAX).get("Ci")
    };
    let conductor = "conductor_bsdf(N, vector(0), 0.2, 0.2, color(0.2, 0.4, 1.4), color(3.9, 2.4, 1.6), \"ggx\"";
    let plain = ci(&format!("{conductor})"));
    let film = ci(&format!(
        "{conductor}, \"thinfilm_thickness\", 550, \"thinfilm_ior\", 1.5)"
    ));
    assert!(plain.iter().all(|x| *x > 0.0), "{plain:?}");
    assert!(
        film.iter().zip(&plain).any(|(a, b)| (a - b).abs() > 1e-3),
        "the film changes the colour: {film:?} vs {plain:?}"
    );
    assert_eq!(
        ci(&format!("{conductor}, \"thinfilm_thickness\", 550)")),
        film
    );
    assert_eq!(
        ci(&format!(
            "{conductor}, \"thinfilm_thickness\", 0, \"thinfilm_ior\", 2)"
        )),
        plain
    );
    // The MaterialX node with the same film.
    if let Some(lib) = mtlx_library() {
        let doc = r#"<?xml version="1.0"?><materialx version="1.39">
            <conductor_bsdf name="b" type="BSDF">
              <input name="ior" type="color3" value="0.2, 0.4, 1.4"/>
              <input name="extinction" type="color3" value="3.9, 2.4, 1.6"/>
              <input name="roughness" type="vector2" value="0.2, 0.2"/>
              <input name="thinfilm_thickness" type="float" value="550"/>
              <input name="thinfilm_ior" type="float" value="1.5"/>
            </conductor_bsdf>
            <surface name="s" type="surfaceshader"><input name="bsdf" type="BSDF" nodename="b"/></surface>
            <surfacematerial name="M" type="material">
              <input name="surfaceshader" type="surfaceshader" nodename="s"/></surfacematerial>
            </materialx>"#;
        let c = shadenet::graph::mtlx::compile("t.mtlx", doc, lib, &Default::default()).unwrap();
        let m = run_program(&c.program, &f, &lights, u32::MAX).get("M");
        assert_close(
            &film,
            &m,
            1e-9,
            "OSL conductor_bsdf with a film = MaterialX's",
        );
    }
    let d = "diffuse(N)";
    let e = "color(0.1, 0.2, 0.3) * emission()";
    assert_eq!(
        ci(&format!("mix({d}, {e}, 0.25)")),
        ci(&format!("0.75 * {d} + 0.25 * {e}"))
    );
    assert_errors(&[(
        &format!("surface s() {{ Ci = {conductor}, \"thinfilm_width\", 5); }}"),
        "closure keyword \"thinfilm_width\" is not built",
    )]);
}

/// Struct fields may hold closures (MaterialX's `surfaceshader`: `bsdf`, `edf`, `opacity`):
/// set through an output parameter, built by the constructor (0 is the null closure), read
/// back as the lobes they hold. OSL's shader types are names, not keywords: `surface` is a
/// parameter of MaterialX's `mx_surfacematerial`.
#[test]
fn closures_in_struct_fields_and_shader_types_as_names() {
    let lights = [point([0.6, -0.3, 1.5], 3.0)];
    let mut f = plane_fragment();
    f.p = [0.2, 0.1, 0.0];
    f.i = [0.2, 0.1, -1.0];
    let ci = |src: &str| {
        let p = compile(src).unwrap_or_else(|e| panic!("{e}"));
        run_program(&p, &f, &lights, u32::MAX).get("Ci")
    };
    let want = ci("surface s() { Ci = diffuse(N) + 0.5 * emission(); }");
    assert!(want.iter().all(|x| *x > 0.5), "{want:?}");
    let by_output = r#"
        struct S { closure color bsdf; closure color edf; float opacity; };
        void mk(output S r) { r.bsdf = diffuse(N); r.edf = 0.5 * emission(); r.opacity = 1; }
        surface s() { S r = S(0, 0, 0); mk(r); Ci = (r.bsdf + r.edf) * r.opacity; }"#;
    assert_eq!(ci(by_output), want);
    let by_constructor = r#"
        struct S { closure color bsdf; closure color edf; float opacity; };
        surface s() { S r = S(diffuse(N), 0.5 * emission(), 1); Ci = r.bsdf + r.edf; }"#;
    assert_eq!(ci(by_constructor), want);
    // A surfaceshader whose fields are left null renders nothing.
    let null = r#"
        struct S { closure color bsdf; closure color edf; float opacity; };
        surface s() { S r = S(0, 0, 1); Ci = r.bsdf + r.edf; }"#;
    assert_eq!(ci(null), vec![0.0; 3]);
    // `surface` and `displacement` as names.
    let named = r#"
        struct S { closure color bsdf; closure color edf; float opacity; };
        closure color m(S surface, float displacement) { return surface.bsdf * displacement; }
        surface s() { Ci = m(S(diffuse(N), 0, 1), 1) + 0.5 * emission(); }"#;
    assert_eq!(ci(named), want);
    assert_errors(&[(
        "struct S { closure color c; }; surface s() { S r = S(1.5); Ci = r.c; }",
        "expected a closure (or 0), found float",
    )]);
}

/// Arrays of structs (MaterialX's hex tiling keeps `vector2 ctr[3]` and a struct field
/// `vector2 coords[3]`): declared zero or from a `{ … }` list of structs, written and read
/// at a run-time index inside a loop, whole elements and their fields, passed to a
/// function, copied whole; the wrong element type and the wrong list length are errors.
#[test]
fn arrays_of_structs() {
    let src = r#"
        struct V2 { float x; float y; };
        struct Tiles { V2 c[3]; float w; };
        float total(V2 a[3]) { return a[0].x + a[1].x + a[2].x + a[0].y + a[1].y + a[2].y; }
        shader s(output color o = 0, output color p = 0) {
            V2 ctr[3];
            V2 init[2] = { V2(1, 2), { 3, 4 } };
            Tiles t;
            for (int i = 0; i < 3; i++) {
                ctr[i] = V2(i * u, i + 10);
                t.c[i] = V2(ctr[i].x * 2, ctr[i].y);
            }
            int k = u > 0.5 ? 2 : 1;
            ctr[k].y = 0;
            for (int i = 0; i < 3; i++) t.c[i].y += 1;
            if (u > 0.5) t.c[1].x = 7;
            V2 copy[3] = ctr;
            ctr[0] = init[1];
            o = color(copy[1].x, copy[k].y, t.c[2].x + t.c[1].x);
            p = color(total(copy), ctr[0].x + init[0].y, t.c[k].y);
        }"#;
    let p = compile(src).unwrap();
    for u in [0.25f64, 0.75] {
        let mut f = plane_fragment();
        f.uv = [u as _, 0.5];
        let o = run_program(&p, &f, &[], u32::MAX);
        let uf = f64::from(u as f32);
        let k = if u > 0.5 { 2.0 } else { 1.0 };
        // copy: (0, 10), (u, 11), (2u, 12) with element k's y set to 0.
        let ys = [10.0, 11.0, 12.0];
        let ys_k: Vec<f64> = (0..3)
            .map(|i| if i as f64 == k { 0.0 } else { ys[i] })
            .collect();
        let c1x = if u > 0.5 { 7.0 } else { 2.0 * uf };
        check(&o, "o", &[uf, 0.0, 4.0 * uf + c1x], 1e-6);
        let total = 3.0 * uf + ys_k.iter().sum::<f64>();
        check(&o, "p", &[total, 3.0 + 2.0, 11.0 + k], 1e-5);
    }
    assert_errors(&[
        (
            "struct V2 { float x; float y; }; shader s() { V2 a[2]; a[0] = 1; }",
            "expected a `V2`, found an int",
        ),
        (
            "struct V2 { float x; float y; }; shader s() { V2 a[2] = { V2(1, 2) }; }",
            "`a` has 2 elements; the list gives 1",
        ),
        (
            "struct V2 { float x; float y; }; shader s() { V2 a[2] = 3; }",
            "`a` is an array of 2 `V2`: it takes a `{ … }` list or an array of 2, not an int",
        ),
    ]);
}

/// String variables and outputs (MaterialX's `geompropvalueuniform` of strings, `constant`
/// and `dot` of strings): declared, assigned, compared, set by `getattribute` (never found:
/// geometry attributes are numbers) or by an `if` whose condition is known while
/// compiling, held in struct fields, and passed from a layer's string output to the next
/// layer's string input. A string picked by a condition known only while shading, and a
/// non-string assigned to a string, are errors.
#[test]
fn string_variables_and_outputs() {
    let src = r#"
        struct Res { string filename; float k; };
        shader s(string which = "b", output string name = "", output color o = 0) {
            string a = "a", c;
            c = which;
            if (getattribute("no_such_attribute", a) == 0)
                a = "fallback";
            Res r = Res("x.png", 1);
            if (which == "b") r.filename = "y.png";
            name = r.filename;
            o = color(a == "fallback", c == "b" && name == "y.png", u);
        }"#;
    let p = compile(src).unwrap();
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    check(&o, "o", &[1.0, 1.0, f64::from(plane_fragment().uv[0])], 0.0);
    let names: Vec<&str> = p.outputs.iter().map(|o| o.name.as_str()).collect();
    assert!(
        !names.contains(&"name"),
        "a string is no program output: {names:?}"
    );
    let first = "shader first(string pick = \"q\", output string label = \"\") { label = pick; }";
    let second =
        "shader second(string label = \"\", output color Ci = 0) { Ci = color(label == \"v\"); }";
    for (value, want) in [("v", 1.0), ("w", 0.0)] {
        let group = format!(
            "param string pick \"{value}\" ;\nshader first a ;\nshader second b ;\nconnect a.label b.label ;\n"
        );
        let dir = folder(
            "strings_group",
            &[
                ("first.osl", first),
                ("second.osl", second),
                ("g.oslgroup", &group),
            ],
        );
        let compiled = shadenet::shader::load(&dir.join("g.oslgroup"), &[], &[]).unwrap();
        let o = run_program(&compiled.program, &plane_fragment(), &[], u32::MAX);
        assert_close(&o.get("Ci"), &[want; 3], 0.0, value);
    }
    assert_errors(&[
        (
            "shader s(output float o = 0) { string a = \"x\"; if (u > 0.5) a = \"y\"; o = a == \"y\"; }",
            "a string is \"y\" or \"x\" by a condition known only while shading",
        ),
        (
            "shader s() { string a = 1; }",
            "`a` is a string: not an int",
        ),
        (
            "shader s() { string a; a = u; }",
            "`a` is a string: not a float",
        ),
        (
            "shader s() { string a; a += \"b\"; }",
            "strings are only assigned with `=`",
        ),
    ]);
}

/// `blackbody` is Planck's law integrated against the CIE 1931 matching functions in the
/// Rec. 709 colour system, as OSL computes it: CIE Illuminant A (a blackbody at 2856 K)
/// comes out at its published chromaticity (0.44757, 0.40745), 6504 K close to D65's
/// white, hotter is bluer, brightness grows with the temperature, and below Draper's point
/// (800 K) it is OSL's dim red. `wavelength_color` is the matching functions at one
/// wavelength (scaled by 1/2.52): green at 530 nm, black outside 380–780 nm.
#[test]
fn blackbody_and_wavelength_color_are_osls() {
    let src = "shader s(float t = 1000, float l = 500, output color bb = 0, output color w = 0) {
                   bb = blackbody(t); w = wavelength_color(l); }";
    let p = compile(src).unwrap();
    let shade = |t: f64, l: f64| {
        let mut q = p.clone();
        shadenet::shader::set_param(&mut q, "t", &[t]).unwrap();
        shadenet::shader::set_param(&mut q, "l", &[l]).unwrap();
        let o = run_program(&q, &plane_fragment(), &[], u32::MAX);
        (o.get("bb"), o.get("w"), o.get32("bb"))
    };
    // Rec. 709 RGB → CIE xy (the standard matrix, written out independently).
    let xy = |c: &[f64]| {
        let m = [
            [0.4124, 0.3576, 0.1805],
            [0.2126, 0.7152, 0.0722],
            [0.0193, 0.1192, 0.9505],
        ];
        let v: Vec<f64> = m
            .iter()
            .map(|r| r[0] * c[0] + r[1] * c[1] + r[2] * c[2])
            .collect();
        let s = v[0] + v[1] + v[2];
        (v[0] / s, v[1] / s)
    };
    let (a, _, a32) = shade(2856.0, 500.0);
    let (x, y) = xy(&a);
    assert!(
        (x - 0.44757).abs() < 2e-3 && (y - 0.40745).abs() < 2e-3,
        "A: {x} {y}"
    );
    for (k, (u, v)) in a.iter().zip(&a32).enumerate() {
        assert!(
            (u - v).abs() <= 1e-5 * u.abs().max(1.0),
            "f32 {k}: {u} vs {v}"
        );
    }
    let (d, _, _) = shade(6504.0, 500.0);
    let (x, y) = xy(&d);
    assert!(
        (x - 0.3127).abs() < 5e-3 && (y - 0.3290).abs() < 8e-3,
        "6504 K: {x} {y}"
    );
    let (hot, _, _) = shade(20000.0, 500.0);
    assert!(hot[2] > hot[0] && a[0] > a[2], "hot {hot:?}, A {a:?}");
    let luma = |c: &[f64]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    assert!(luma(&d) > 10.0 * luma(&a) && luma(&a) > 0.0);
    let (cold, _, _) = shade(500.0, 500.0);
    assert_close(&cold, &[1e-6, 0.0, 0.0], 0.0, "below Draper's point");
    let (_, green, _) = shade(1000.0, 530.0);
    assert!(
        green[1] > green[0] && green[1] > green[2] && green[1] < 1.0,
        "{green:?}"
    );
    for l in [300.0, 780.0, 900.0] {
        let (_, w, _) = shade(1000.0, l);
        assert_close(&w, &[0.0; 3], 0.0, &format!("{l} nm"));
    }
}

/// `raytype(name)` reads the ray type the renderer shades with: 1 for its own type, 0 for
/// another and for a name the renderer does not have (OSL's renderer-defined names);
/// specialization to one ray type folds it to a constant.
#[test]
fn raytype_reads_the_ray() {
    use shadenet::graph::ir::{RAY_CAMERA, RAY_REFLECTION, RAY_SHADOW};
    let src = "shader s(output float o = 0) {
                   o = raytype(\"camera\") + 2 * raytype(\"reflection\") + 4 * raytype(\"glossy\"); }";
    let p = compile(src).unwrap();
    for (ray, want) in [(RAY_CAMERA, 1.0), (RAY_REFLECTION, 2.0), (RAY_SHADOW, 0.0)] {
        let mut f = plane_fragment();
        f.ray_type = ray;
        let o = run_program(&p, &f, &[], u32::MAX);
        check(&o, "o", &[want], 0.0);
    }
    let spec = Specialization {
        ray_types: RAY_REFLECTION as u32,
        ..Specialization::default()
    };
    let (o, _) = opt::run(&p, &spec);
    assert!(
        !o.exprs
            .iter()
            .any(|e| matches!(e.op, shadenet::graph::ir::Op::Stream(_))),
        "specialized to reflection rays, the ray type folds: {:?}",
        o.exprs
    );
    assert_errors(&[(
        "shader s() { int k = raytype(1); }",
        "`raytype` takes (string name)",
    )]);
}

/// `isconnected(param)` is what the group makes of the parameter: 1 for an input an earlier
/// layer's output feeds, 2 for an output a later layer reads, 3 for both, 0 otherwise and
/// in a lone shader; anything but a parameter is an error.
#[test]
fn isconnected_reads_the_group() {
    let first = "shader first(float k = 1, output float o = 0, output float spare = 0) {
                     o = k + 10 * isconnected(o) + 100 * isconnected(spare); }";
    let mid = "shader mid(float x = 0, output float y = 0) { y = x + 1000 * isconnected(x)
                   + 10000 * isconnected(y); }";
    let last = "shader last(float a = 0, float b = 5, output color Ci = 0) {
                    Ci = color(a, isconnected(a) + 10 * isconnected(b), 0); }";
    let group = "shader first f ;\nshader mid m ;\nshader last l ;\n\
                 connect f.o m.x ;\nconnect m.y l.a ;\n";
    let dir = folder(
        "isconnected",
        &[
            ("first.osl", first),
            ("mid.osl", mid),
            ("last.osl", last),
            ("g.oslgroup", group),
        ],
    );
    let compiled = shadenet::shader::load(&dir.join("g.oslgroup"), &[], &[]).unwrap();
    let o = run_program(&compiled.program, &plane_fragment(), &[], u32::MAX);
    // f.o = 1 + 10·2 = 21; m.y = 21 + 1000·1 + 10000·2 = 21021; l: a connected (1), b not.
    assert_close(&o.get("Ci"), &[21021.0, 1.0, 0.0], 0.0, "Ci");
    let lone =
        compile("shader s(float k = 0, output float o = 0) { o = isconnected(k); }").unwrap();
    let o = run_program(&lone, &plane_fragment(), &[], u32::MAX);
    check(&o, "o", &[0.0], 0.0);
    assert_errors(&[(
        "shader s(output float o = 0) { float z = 1; o = isconnected(z); }",
        "`isconnected` takes the name of one of the shader's parameters",
    )]);
}

/// The fuzzer's seed `lang/tests/shaders/patterns.osl` (simplex noise, splineinverse,
/// calculatenormal) compiles, and the JIT (scalar and batch) shades it as the interpreter
/// does, bit for bit.
#[test]
fn the_patterns_seed_compiles_and_the_jit_agrees() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("lang/tests/shaders/patterns.osl");
    let src = std::fs::read_to_string(path).unwrap();
    let p = compile(&src).unwrap();
    let env = shadenet::shade::grid_env(&[]);
    let spec = Specialization::default();
    let (o, _) = opt::run(&p, &spec);
    let interp = shadenet::shade::shade_grid::<f32>(&o, &env, 16, 9, spec.components).unwrap();
    let bits = |v: Vec<f64>| v.iter().map(|x| (*x as f32).to_bits()).collect::<Vec<_>>();
    let reference = bits(interp.pixel_values());
    assert!(
        reference.iter().any(|b| *b != 0),
        "the pattern is not all zero"
    );
    let m = shadenet_jit::JitBackend::new().compile(&p, &spec).unwrap();
    for batch in [false, true] {
        let g = shadenet::shade::shade_grid_with(&*m, &env, 16, 9, spec.components, batch);
        assert_eq!(reference, bits(g.pixel_values()), "batch {batch}");
    }
}

/// OSL's string builtins on compile-time strings: `concat`, `strlen`, `startswith`,
/// `endswith`, `substr` (a negative start from the end), `getchar`, `stoi`, `stof` and
/// `format` with C's conversions (a color's components each by the conversion); what makes a
/// string from a value known only while shading, a mismatched conversion and the builtins
/// OSL has that we do not are errors naming them.
#[test]
fn string_builtins_are_osls() {
    let src = r#"
        shader s(string name = "brick_wall.tx", output float a = 0, output float b = 0,
                 output float c = 0, output float d = 0) {
            string base = substr(name, 0, strlen(name) - 3);
            string file = concat(base, "_", format("%03d", 7), ".png");
            a = strlen(file) + 100 * startswith(file, "brick") + 1000 * endswith(name, ".tx");
            b = stof(substr("k=2.5e1", -5)) + stoi(" -3px") + getchar(name, 0) / 1000.0;
            string f = format("%s|%5.2f|%g|%x|%c", base, 3.14159, color(0.5, 1, 2), 255, 65);
            c = (f == "brick_wall| 3.14|0.5 1 2|ff|A") ? 1 : 0;
            if (file == "brick_wall_007.png") d = 1;
        }"#;
    let p = compile(src).unwrap();
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    check(&o, "a", &[18.0 + 100.0 + 1000.0], 0.0);
    check(&o, "b", &[25.0 - 3.0 + 0.098], 1e-6);
    check(&o, "c", &[1.0], 0.0);
    check(&o, "d", &[1.0], 0.0);
    assert_errors(&[
        (
            "shader s(output float o = 0) { string f = format(\"%f\", u); }",
            "`format`'s argument 2 is known only while shading",
        ),
        (
            "shader s(output float o = 0) { string f = format(\"%d\", 1.5); }",
            "`format`: conversion 1 (`%d`) takes an int",
        ),
        (
            "shader s(output float o = 0) { o = strlen(\"a\", \"b\"); }",
            "`strlen`: takes 1 arguments, not 2",
        ),
        (
            "shader s(output float o = 0) { setmessage(\"k\", \"text\"); }",
            "`setmessage` of a string is not built",
        ),
        (
            "shader s(output float o = 0) { o = transformu(\"cm\", \"m\", u); }",
            "`transformu`: unit conversions are not built yet",
        ),
    ]);
}

/// stdosl.h's `smooth_linearstep` (its if-chain, transcribed below in f32), `select(a, b,
/// cond)` (per component for a triple condition), `hypot(x, y, z)`, and OSL's constructors
/// with a space first: `point("object", …)` is `transform("object", "common", point(…))`,
/// `color("hsv", …)` is `transformc("hsv", "rgb", color(…))`.
#[test]
fn stdosl_helpers_and_constructors_in_a_space() {
    let src = r#"
        shader s(output float a = 0, output float a2 = 0, output color c = 0,
                 output float h = 0, output point p = 0, output point q = 0,
                 output color hc = 0, output color hq = 0) {
            float x = u * 1.4 - 0.2;
            a = smooth_linearstep(0.1, 0.9, x, 0.15);
            a2 = smooth_linearstep(0.5, 0.5, x, 0.1);
            c = select(color(1), color(0, 2, 3), color(1, 0, 1)) + select(10, 20, u > 0.5);
            h = hypot(3, 4, 12);
            p = point("object", 1, 2, 3);
            q = transform("object", "common", point(1, 2, 3));
            hc = color("hsv", 0.3, 0.5, 0.8);
            hq = transformc("hsv", "rgb", color(0.3, 0.5, 0.8));
        }"#;
    let p = compile(src).unwrap();
    // stdosl.h, operation for operation, in f32.
    let sls = |e0: f32, e1: f32, x_: f32, eps_: f32| -> f32 {
        if e0 == e1 {
            return if x_ < e0 { 0.0 } else { 1.0 };
        }
        let rampup = |x: f32, r: f32| 0.5 / r * x * x;
        let width_inv = 1.0 / (e1 - e0);
        let eps = eps_ * width_inv;
        let x = (x_ - e0) * width_inv;
        if x <= -eps {
            0.0
        } else if x >= eps && x <= 1.0 - eps {
            x
        } else if x >= 1.0 + eps {
            1.0
        } else if x < eps {
            rampup(x + eps, 2.0 * eps)
        } else {
            1.0 - rampup(1.0 + eps - x, 2.0 * eps)
        }
    };
    let mut f = plane_fragment();
    f.p = [0.3, -0.2, 0.4];
    for k in 0..=28 {
        let u = k as f32 / 28.0;
        f.uv = [u, 0.5];
        let o = run_program(&p, &f, &[], u32::MAX);
        let x = u * 1.4 - 0.2;
        assert_eq!(o.get32("a"), [sls(0.1, 0.9, x, 0.15) as f64], "x = {x}");
        assert_eq!(o.get32("a2"), [sls(0.5, 0.5, x, 0.1) as f64], "x = {x}");
        let s = if u > 0.5 { 20.0 } else { 10.0 };
        check(&o, "c", &[s, 1.0 + s, 3.0 + s], 0.0);
        check(&o, "h", &[13.0], 0.0);
        assert_eq!(o.get("p"), o.get("q"), "point(\"object\", …)");
        assert_eq!(o.get("hc"), o.get("hq"), "color(\"hsv\", …)");
    }
    assert_errors(&[
        (
            "shader s(output point o = 0) { o = point(\"bogus\", 1, 0, 0); }",
            "the space \"bogus\" is not available here",
        ),
        (
            "shader s(output color o = 0) { o = color(\"xyz\", 1, 0, 0); }",
            "unknown color space \"xyz\"",
        ),
    ]);
}

/// OSL's `sinh`, `cosh`, `tanh`, `expm1`, `cbrt`, `erf`, `erfc`, `log(x, base)` and
/// `sincos` (into output arguments), on
/// floats and per component on triples, within a few f32 ulps of f64 references (erf's
/// series summed in f64) from tiny to large arguments.
#[test]
fn osl_math_builtins() {
    let src = r#"
        shader m(output color h = 0, output color e = 0, output color f = 0,
                 output vector t = 0, output color g = 1) {
            float x = u;
            h = color(sinh(x), cosh(x), tanh(x));
            e = color(expm1(x), cbrt(x), log(abs(x) + 2, 3));
            f = color(erf(x), erfc(x), 0);
            t = tanh(vector(x, -x, 2 * x));
            float s, c;
            sincos(x, s, c);
            vector vs, vc;
            sincos(vector(x, 0, 1), vs, vc);
            g = color(s - sin(x), c - cos(x), vs[0] - s) + color(vc[0] - c, vc[2] - cos(1), 0);
        }"#;
    let p = compile(src).unwrap();
    let erf_ref = |x: f64| -> f64 {
        // 2/√π Σ (−1)ⁿ x²ⁿ⁺¹ / (n! (2n + 1)), converging for the |x| ≤ 3 used here.
        let (mut term, mut sum) = (x, 0.0);
        for n in 0..80 {
            sum += term / (2 * n + 1) as f64;
            term *= -x * x / (n + 1) as f64;
        }
        sum * std::f64::consts::FRAC_2_SQRT_PI
    };
    let close = |got: f64, want: f64, what: &str, x: f64| {
        let tol = 4e-7 * want.abs().max(1e-30) + 1e-30;
        assert!(
            (got - want).abs() <= tol.max(want.abs() * 2e-6),
            "{what}({x}) = {got}, want {want}"
        );
    };
    for x in [
        -2.9f64, -1.3, -0.7, -0.2, -1e-5, 0.0, 3e-6, 0.01, 0.4, 0.6, 1.0, 2.5, 2.9,
    ] {
        let xf = x as f32;
        let x = xf as f64;
        let mut frag = plane_fragment();
        frag.uv = [xf, 0.5];
        let o = run_program(&p, &frag, &[], u32::MAX);
        let h = o.get32("h");
        close(h[0], x.sinh(), "sinh", x);
        close(h[1], x.cosh(), "cosh", x);
        close(h[2], x.tanh(), "tanh", x);
        let e = o.get32("e");
        close(e[0], x.exp_m1(), "expm1", x);
        close(e[1], x.cbrt(), "cbrt", x);
        close(e[2], ((xf.abs() + 2.0) as f64).ln() / 3f64.ln(), "log3", x);
        let f = o.get32("f");
        close(f[0], erf_ref(x), "erf", x);
        close(f[1], 1.0 - erf_ref(x), "erfc", x);
        let t = o.get32("t");
        close(t[1], (-x).tanh(), "tanh of a vector's y", x);
        assert_eq!(o.get32("g"), [0.0; 3], "sincos is sin and cos, at {x}");
    }
    // Far out: saturated, never NaN.
    let mut frag = plane_fragment();
    frag.uv = [100.0, 0.5];
    let o = run_program(&p, &frag, &[], u32::MAX);
    assert_eq!(o.get32("h")[2], 1.0);
    assert!(
        o.get32("e").iter().all(|v| !v.is_nan()),
        "{:?}",
        o.get32("e")
    );
    assert_eq!(o.get32("f")[..2], [1.0, 0.0]);
}

/// `noise("simplex", …)` is `osl_simplex::simplex*` (float: seed 0; vector: seeds 0, 1, 2)
/// and `"usimplex"` its `0.5 (n + 1)`, in 1D to 4D, bit for bit through the front end.
#[test]
fn simplex_noise_is_osls() {
    let src = r#"
        shader n(output color s = 0, output color u4 = 0, output vector v1 = 0,
                 output vector v2 = 0, output color v3 = 0, output vector v4 = 0) {
            point q = P * 3.7 + point(0.3, -1.2, 5.1);
            s = color(noise("simplex", u * 9), noise("simplex", u * 9, v * 9),
                      noise("simplex", q));
            u4 = color(noise("simplex", q, v * 9), noise("usimplex", q), noise("usimplex", u * 9));
            v1 = noise("simplex", u * 9);
            v2 = noise("usimplex", u * 9, v * 9);
            v3 = noise("simplex", q);
            v4 = noise("simplex", q, u * 9);
        }"#;
    let p = compile(src).unwrap();
    let mut f = plane_fragment();
    let f64s = |v: &[f32]| v.iter().map(|x| *x as f64).collect::<Vec<_>>();
    let unsigned = |x: f32| 0.5 * (x + 1.0);
    for (k, (pos, uv)) in NOISE_POINTS.into_iter().enumerate() {
        f.p = pos;
        f.uv = uv;
        let o = run_program(&p, &f, &[], u32::MAX);
        let q = noise_domain(pos);
        let (u9, v9) = (uv[0] * 9.0, uv[1] * 9.0);
        let want = [
            osl_simplex::simplex1(u9, 0),
            osl_simplex::simplex2([u9, v9], 0),
            osl_simplex::simplex3(q, 0),
        ];
        assert_eq!(o.get32("s"), f64s(&want), "float simplex, point {k}");
        let want = [
            osl_simplex::simplex4(q, v9, 0),
            unsigned(osl_simplex::simplex3(q, 0)),
            unsigned(osl_simplex::simplex1(u9, 0)),
        ];
        assert_eq!(o.get32("u4"), f64s(&want), "4D and usimplex, point {k}");
        assert_eq!(
            o.get32("v1"),
            f64s(&osl_simplex::vsimplex1(u9)),
            "v1, point {k}"
        );
        let v2 = osl_simplex::vsimplex2([u9, v9]).map(unsigned);
        assert_eq!(o.get32("v2"), f64s(&v2), "v2, point {k}");
        assert_eq!(
            o.get32("v3"),
            f64s(&osl_simplex::vsimplex3(q)),
            "v3, point {k}"
        );
        let v4 = osl_simplex::vsimplex4(q, u9);
        assert_eq!(o.get32("v4"), f64s(&v4), "v4, point {k}");
        // Vector noise's first component is the float noise; the others differ.
        assert_eq!(v4[0], osl_simplex::simplex4(q, u9, 0));
        assert!(v4[1] != v4[0] && v4[2] != v4[1], "seeds differ: {v4:?}");
    }
}

/// `pnoise`/`psnoise`: periodic Perlin noise is `osl_noise::pperlin*` (float and vector, 1D
/// to 4D) bit for bit, `pnoise`'s default `0.5 (n + 1)` of it; `pnoise("cell", …)` is cell
/// noise of the coordinates wrapped into the period (OSL's `wrap`); periodic hash and simplex
/// noise (OSL has neither) and mismatched period shapes are errors.
#[test]
fn periodic_noise_is_osls() {
    let src = r#"
        shader n(float px = 3.5, output color a = 0, output color b = 0, output vector c = 0,
                 output color d = 0) {
            point q = P * 3.7 + point(0.3, -1.2, 5.1);
            point pp = point(px, 2, 5);
            a = color(psnoise(u * 9, px), psnoise(u * 9, v * 9, px, 4), psnoise(q, pp));
            b = color(psnoise(q, v * 9, pp, 3), pnoise(q, pp), pnoise("perlin", u * 9, px));
            c = psnoise(q, v * 9, pp, 3);
            d = pnoise("cell", q, pp);
        }"#;
    let p = compile(src).unwrap();
    let mut f = plane_fragment();
    for (pos, uv) in [
        ([0.123, 0.456, 0.0], [0.11, 0.93]),
        ([-2.5, 7.25, 1.0], [0.5, 0.75]),
    ] {
        f.p = pos;
        f.uv = uv;
        let o = run_program(&p, &f, &[], u32::MAX);
        let q: [f32; 3] = std::array::from_fn(|i| pos[i] * 3.7 + [0.3, -1.2, 5.1][i]);
        let pp = [3.5f32, 2.0, 5.0];
        let (u9, v9) = (uv[0] * 9.0, uv[1] * 9.0);
        let f64s = |v: &[f32]| v.iter().map(|x| *x as f64).collect::<Vec<_>>();
        let a = [
            osl_noise::pperlin1(u9, 3.5),
            osl_noise::pperlin2([u9, v9], [3.5, 4.0]),
            osl_noise::pperlin3(q, pp),
        ];
        assert_eq!(o.get32("a"), f64s(&a), "a at {pos:?}");
        let b = [
            osl_noise::pperlin4(q, v9, pp, 3.0),
            0.5 * (osl_noise::pperlin3(q, pp) + 1.0),
            osl_noise::pperlin1(u9, 3.5),
        ];
        assert_eq!(o.get32("b"), f64s(&b), "b at {pos:?}");
        assert_eq!(
            o.get32("c"),
            f64s(&osl_noise::vpperlin4(q, v9, pp, 3.0)),
            "c"
        );
        let wrapped: [f32; 3] = std::array::from_fn(|k| {
            let per = pp[k].floor().max(1.0);
            q[k] - per * (q[k] / per).floor()
        });
        assert_eq!(
            o.get32("d"),
            f64s(&osl_noise::vcell3(wrapped)),
            "d at {pos:?}"
        );
    }
    assert_errors(&[
        (
            "shader s() { float x = pnoise(\"hash\", u, 2); }",
            "OSL has no periodic \"hash\" noise",
        ),
        (
            "shader s() { vector x = pnoise(\"usimplex\", P, 2); }",
            "OSL has no periodic \"usimplex\" noise",
        ),
        (
            "shader s() { float x = psnoise(P, 2); }",
            "each followed by as many periods",
        ),
    ]);
}

/// A user function that assigns a global (`N`, `Ci`) changes the caller's: straight, through
/// another function, and called under a varying `if` (the region yields what the functions
/// write).
#[test]
fn functions_write_the_globals() {
    let src = r#"
        void bend(float x) { N = normalize(N + vector(x, 0, 0)); }
        void twice(float x) { bend(x); bend(x); }
        void paint(float k) { Ci = k * emission(); }
        surface s(output color f = 0) {
            if (u > 0.5)
                twice(v);
            paint(2);
            f = color(N);
        }"#;
    let p = common::compile_shader(src, Dialect::Osl).unwrap_or_else(|e| panic!("{e}"));
    for u in [0.25f32, 0.75] {
        let mut frag = plane_fragment();
        frag.uv = [u, 0.5];
        let o = run_program(&p, &frag, &[], u32::MAX);
        let mut n = [0.0f64, 0.0, 1.0];
        if u > 0.5 {
            for _ in 0..2 {
                let m = [n[0] + 0.5, n[1], n[2]];
                let l = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                n = m.map(|x| x / l);
            }
        }
        assert_close(&o.get("f"), &n, 1e-6, &format!("N at u = {u}"));
        assert_close(&o.get("Ci"), &[2.0; 3], 0.0, "Ci");
    }
}

/// `texture`'s `"width"` and `"blur"`: a 64² checker of single texels looked up at a texel
/// centre is that texel unfiltered, and blurred over half the image it is the checker's
/// mean; `"width", 0` is the point lookup whatever the derivatives; `"time"` is accepted.
#[test]
fn texture_width_and_blur() {
    let dir = folder("texblur", &[]);
    let path = dir.join("checker.png");
    let px: Vec<u8> = (0..64 * 64)
        .flat_map(|i| {
            let (x, y) = (i % 64, i / 64);
            let c = if (x + y) % 2 == 0 { 255u8 } else { 0 };
            [c, c, c]
        })
        .collect();
    image::save_buffer(&path, &px, 64, 64, image::ExtendedColorType::Rgb8).unwrap();
    let shade = |opts: &str| {
        let src = format!(
            "shader s(output color c = 0) {{ c = texture(\"{}\", u, v{opts}); }}",
            path.display()
        );
        let p = compile(&src).unwrap_or_else(|e| panic!("{e}"));
        let mut f = plane_fragment();
        // The centre of texel (32, 31) (t runs down the image: v = 1 − t).
        f.uv = [32.5 / 64.0, 1.0 - 31.5 / 64.0];
        run_program(&p, &f, &[], u32::MAX).get("c")[0]
    };
    let plain = shade("");
    assert!(plain == 0.0 || plain == 1.0, "one texel: {plain}");
    assert_eq!(shade(", \"width\", 0, \"time\", 1"), plain);
    let blurred = shade(", \"blur\", 0.5");
    assert!((blurred - 0.5).abs() < 0.02, "blurred: {blurred}");
    let one_axis = shade(", \"sblur\", 0.5");
    assert!((one_axis - 0.5).abs() < 0.1, "blurred along s: {one_axis}");
    // The footprint is the options' in the IR: swidth scales uv's derivatives along s,
    // tblur lengthens ∂t/∂y (towards its sign).
    let p = compile(
        "shader s(output color c = 0) { c = texture(\"t.png\", u * 3, v, \"swidth\", 2, \"tblur\", 0.25); }",
    )
    .unwrap();
    let (o, _) = opt::run(&p, &Specialization::default());
    let text = o.to_string();
    for want in [
        "const (2.0, 1.0) : vec2",
        "const -0.25 : float",
        "const 0.25 : float",
    ] {
        assert!(text.contains(want), "{want}\n{text}");
    }
}

/// `gettextureinfo` reads the file's header while the shader loads (a missing file: not
/// found, the output unchanged; `"exists"` succeeds either way); without a texture system,
/// an unknown query, a wrong output type and a UDIM pattern are errors naming them.
#[test]
fn gettextureinfo_reads_the_header() {
    let dir = folder("texinfo", &[]);
    let rgb: Vec<u8> = (0..64 * 32 * 3).map(|i| (i % 251) as u8).collect();
    image::save_buffer(
        dir.join("rgb.png"),
        &rgb,
        64,
        32,
        image::ExtendedColorType::Rgb8,
    )
    .unwrap();
    let la: Vec<u8> = (0..5 * 7 * 2).map(|i| i as u8).collect();
    image::save_buffer(dir.join("la.png"), &la, 5, 7, image::ExtendedColorType::La8).unwrap();
    let src = r#"
        shader s(output color r = 0, output color c = 0, output color e = 0) {
            int res[2] = { -1, -1 };
            int got = 0;
            if (u > 0.25)
                got = gettextureinfo("rgb.png", "resolution", res);
            int ch = 0;
            gettextureinfo("la.png", "channels", ch);
            int ex = -1, ex2 = -1;
            int okex = gettextureinfo("missing.png", "exists", ex);
            gettextureinfo("rgb.png", "exists", ex2);
            int miss[2] = { 7, 7 };
            int gotmiss = gettextureinfo("missing.png", "resolution", miss);
            int dw[4] = { 0, 0, 0, 0 };
            gettextureinfo("rgb.png", "datawindow", dw);
            string t = "";
            gettextureinfo("rgb.png", "type", t);
            r = color(res[0], res[1], got);
            c = color(ch, ex, okex);
            e = color(ex2, miss[0] + gotmiss * 100, dw[2] + dw[3] * 100 + (t == "Plain Texture") * 10000);
        }"#;
    std::fs::write(dir.join("info.osl"), src).unwrap();
    let compiled = shadenet::shader::load(&dir.join("info.osl"), &[], &[]).unwrap();
    let o = run_program(&compiled.program, &plane_fragment(), &[], u32::MAX);
    check(&o, "r", &[64.0, 32.0, 1.0], 0.0);
    check(&o, "c", &[2.0, 0.0, 1.0], 0.0);
    check(&o, "e", &[1.0, 7.0, 63.0 + 3100.0 + 10000.0], 0.0);
    assert_errors(&[(
        "shader s(output float o = 0) { int n; gettextureinfo(\"a.png\", \"channels\", n); }",
        "this compile has no texture system",
    )]);
    for (body, want) in [
        (
            "int n; gettextureinfo(\"rgb.png\", \"averagecolor\", n);",
            "`gettextureinfo`: \"averagecolor\" is not built (built: exists, resolution",
        ),
        (
            "float n; gettextureinfo(\"rgb.png\", \"channels\", n);",
            "`gettextureinfo(…, \"channels\", …)` writes an int (not into a float)",
        ),
        (
            "int n[3]; gettextureinfo(\"rgb.png\", \"resolution\", n);",
            "writes an int[2]",
        ),
        (
            "int n; gettextureinfo(\"t.<UDIM>.png\", \"channels\", n);",
            "of a UDIM pattern is not built",
        ),
    ] {
        let path = dir.join("bad.osl");
        std::fs::write(&path, format!("shader s(output float o = 0) {{ {body} }}")).unwrap();
        let err = shadenet::shader::load(&path, &[], &[])
            .unwrap_err()
            .to_string();
        assert!(err.contains(want), "{body}\n→ {err}");
    }
}
