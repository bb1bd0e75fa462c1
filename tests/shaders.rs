//! RenderMan Shading Language surface shaders compiled by `shadenet-lang` into the IR:
//! values against the RenderMan Interface's formulas and our built-in `lambert`, the
//! optimizer seeing through the language, every back end agreeing, and errors that name
//! the place. (Loops: `tests/shader_loops.rs`; light shaders: `tests/shader_lights.rs`;
//! arrays: `tests/shader_arrays.rs`; OSL: `tests/shader_osl.rs`; volume shaders: issue 21,
//! not built yet.)

mod common;
use common::*;
use shadenet::graph::nodes::{LightDesc, LightKind};
use shadenet::graph::opt::{self, Specialization};
use shadenet::graph::{NodeLibrary, compile_json};
use shadenet::lang::Dialect;
use shadenet::runtime::Backend;

/// Compiles RSL `src`'s first shader; `Err` is the rendered diagnostics.
fn compile(src: &str) -> Result<shadenet::graph::ir::Program, String> {
    compile_shader(src, Dialect::Rsl)
}

fn point(pos: [f64; 3], i: f64) -> LightDesc {
    LightDesc::new("l", LightKind::Point { position: pos }, [i; 3]).unwrap()
}

const MATTE: &str = include_str!("../lang/tests/shaders/matte.sl");
const PLASTIC: &str = include_str!("../lang/tests/shaders/plastic.sl");

/// `matte` under a point light is our `lambert` times π: RSL's `diffuse()` sums
/// `Cl · max(0, N·L)` without the Lambert BRDF's 1/π, and both read a point light's `Cl`
/// as `intensity / r²`.
#[test]
fn matte_is_lambert_times_pi() {
    let lights = [point([0.6, -0.3, 1.5], 3.0)];
    let matte = compile(MATTE).unwrap();
    let mut f = plane_fragment();
    f.p = [0.2, 0.1, 0.0];
    f.i = [0.2, 0.1, -1.0];
    let got = run_program(&matte, &f, &lights, u32::MAX);
    let lambert = compile_json(
        r#"{"nodes": [{"name": "l", "type": "lambert",
            "inputs": {"color": [1, 1, 1], "diffuse": 1}}],
            "outputs": {"color": "l.outColor"}}"#,
        &NodeLibrary::standard(),
    )
    .unwrap();
    let want = run_program(&lambert.program, &f, &lights, u32::MAX);
    let pi = std::f64::consts::PI;
    let want64: Vec<f64> = want.get("color").iter().map(|x| x * pi).collect();
    assert_close(&got.get("Ci"), &want64, 1e-12, "matte Ci (f64) = π lambert");
    assert_close(&got.get32("Ci"), &want64, 1e-6, "matte Ci (f32)");
    // And the formula itself: Kd · Cs · I/r² · N·L.
    let l = [0.4, -0.4, 1.5];
    let r2: f64 = l.iter().map(|x| x * x).sum();
    let cos = l[2] / r2.sqrt();
    // (The light record holds its position in f32: 1e-8 relative.)
    assert_close(&got.get("Ci"), &[3.0 / r2 * cos; 3], 1e-8, "formula");
    assert_close(&got.get("Oi"), &[1.0; 3], 0.0, "Oi = Os");
}

/// `plastic`: ambient, diffuse and the RenderMan specular `pow(max(0, N·H), 1/roughness)`
/// from their formulas, at a point where all three are non-zero.
#[test]
fn plastic_follows_the_renderman_formulas() {
    let amb = LightDesc::new("a", LightKind::Ambient, [0.25; 3]).unwrap();
    let lights = [point([0.0, 0.0, 2.0], 4.0), amb];
    let p = compile(PLASTIC).unwrap();
    let f = plane_fragment();
    let got = run_program(&p, &f, &lights, u32::MAX);
    // Light straight above at r = 2: Cl = 1, N·L = 1, H = N: N·H = 1.
    let (ks, kd, ka) = (0.5, 0.5, 1.0);
    let want = ka * 0.25 + kd * 1.0 + ks * 1.0;
    assert_close(&got.get("Ci"), &[want; 3], 1e-12, "plastic on axis");
    // Off the highlight: the light moved sideways.
    let lights = [point([1.0, 0.0, 1.0], 2.0)];
    let got = run_program(&p, &f, &lights, u32::MAX);
    let r2 = 2.0f64;
    let l = [1.0 / r2.sqrt(), 0.0, 1.0 / r2.sqrt()];
    let cl = 2.0 / r2;
    let h = {
        let v = [l[0], l[1], l[2] + 1.0];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / n, v[1] / n, v[2] / n]
    };
    let spec = h[2].powf(1.0 / 0.1);
    let want = kd * cl * l[2] + ks * cl * spec;
    assert_close(&got.get("Ci"), &[want; 3], 1e-12, "plastic off axis");
}

/// `if`/`else` assigning outer variables, compound assignments, user functions with
/// overloads, the ternary, constructors and builtins: values checked per fragment side.
#[test]
fn statements_functions_and_operators() {
    let src = r#"
        float twice(float x) { return 2 * x; }
        color twice(color c) { return c + c; }
        surface s(float k = 3; color tint = color "rgb" (0.5, 0.25, 1)) {
            float a = k;
            color c = 0;
            if (u < 0.5) { a += 1; c = twice(tint); } else { a = twice(a); }
            a *= 2;
            c += (v > 0.5) ? color(1) : color(0, 0, 0);
            Ci = c + a * color "rgb" (1, 0, 0) + (I . N) * zcomp(dPdu ^ dPdv);
            Oi = mix(color(0), color(1), smoothstep(0, 1, 0.5));
        }"#;
    let p = compile(src).unwrap();
    let mut f = plane_fragment();
    for (u, v, want) in [
        // u < 0.5: a = (3 + 1)·2 = 8, c = 2·tint (+1 when v > 0.5); I·N = −1 and
        // (dPdu ^ dPdv).z = 1 add −1.
        (
            0.25,
            0.75,
            [1.0 + 1.0 + 8.0 - 1.0, 0.5 + 1.0 - 1.0, 2.0 + 1.0 - 1.0],
        ),
        // u ≥ 0.5: a = 2·3·2 = 12, c = 0.
        (0.75, 0.25, [12.0 - 1.0, -1.0, -1.0]),
    ] {
        f.uv = [u, v];
        let o = run_program(&p, &f, &[], u32::MAX);
        assert_close(&o.get("Ci"), &want, 1e-12, &format!("u = {u}"));
        assert_close(&o.get("Oi"), &[0.5; 3], 1e-12, "smoothstep(0, 1, 0.5)");
    }
}

/// A user-written light loop: `illuminance(P, N, PI/2)` accumulating `Cl · N·L` is
/// `diffuse(N)`; the one-argument form also sums the lights behind the surface; lights
/// outside the cone add nothing.
#[test]
fn illuminance_sums_the_lights_in_its_cone() {
    let lights = [point([0.5, 0.2, 1.0], 2.0), point([0.3, 0.0, -1.0], 5.0)];
    let src = |args: &str| {
        format!(
            "surface s() {{ color c = 0; illuminance({args}) {{ c += Cl * max(0, normalize(L) . N); }} \
             color d = 0; illuminance({args}) {{ d += Cl; }} Ci = c; Oi = d; }}"
        )
    };
    let f = plane_fragment();
    let cone = run_program(
        &compile(&src("P, N, PI / 2")).unwrap(),
        &f,
        &lights,
        u32::MAX,
    );
    let diffuse = run_program(
        &compile("surface s() { Ci = diffuse(N); }").unwrap(),
        &f,
        &lights,
        u32::MAX,
    );
    assert_close(
        &cone.get("Ci"),
        &diffuse.get("Ci"),
        1e-12,
        "illuminance(P, N, π/2) = diffuse(N)",
    );
    // Only the light above the plane is inside the cone: Oi is its Cl.
    let r2 = 0.25 + 0.04 + 1.0;
    assert_close(&cone.get("Oi"), &[2.0 / r2; 3], 1e-8, "the cone's Cl sum");
    let all = run_program(&compile(&src("P")).unwrap(), &f, &lights, u32::MAX);
    let r2b = 0.09 + 1.0;
    assert_close(
        &all.get("Oi"),
        &[2.0 / r2 + 5.0 / r2b; 3],
        1e-8,
        "every light",
    );
}

/// The optimizer sees through the language: plastic's uniform parameters fold into the
/// program, and with only the diffuse-free passes the light loops go.
#[test]
fn the_optimizer_sees_through_the_language() {
    let p = compile(PLASTIC).unwrap();
    assert_eq!(
        p.params.iter().map(|d| d.name.as_str()).collect::<Vec<_>>(),
        ["Ks", "Kd", "Ka", "roughness", "specularcolor"]
    );
    let before = p.exprs.len();
    // Class compilation: the parameters stay uniform values.
    let class = Specialization {
        bake: false,
        ..Specialization::default()
    };
    let (o, _) = opt::run(&p, &class);
    assert!(o.exprs.len() < before, "{} → {}", before, o.exprs.len());
    assert!(o.to_string().contains("= param"), "{o}");
    // Baked (instance compilation): no parameter is read any more, and the uniform
    // products of the parameters are folded.
    let spec = Specialization {
        bake: true,
        ..Specialization::default()
    };
    let (baked, _) = opt::run(&p, &spec);
    let text = baked.to_string();
    assert!(!text.contains("= param"), "{text}");
    assert!(baked.exprs.len() < o.exprs.len(), "{text}");
    // A `0 · diffuse(…)` is not folded (0 · ∞ is NaN under the IR's rules), but an `if`
    // on a uniform parameter is a dead branch once baked: the light loop goes.
    let src = "surface s(float Kd = 0) { if (Kd > 0) { Ci = Kd * diffuse(N); } else { Ci = Cs; } }";
    let (o, _) = opt::run(&compile(src).unwrap(), &spec);
    assert!(!o.to_string().contains("illuminance"), "{o}");
}

/// The interpreter and the JIT (scalar and batch) give the same bits on a shader; the
/// batch entry, compiled on first use, too.
#[test]
fn the_jit_agrees_with_the_interpreter_bit_for_bit() {
    let p = compile(PLASTIC).unwrap();
    let lights = [point([1.0, 1.0, 2.0], 5.0)];
    let env = shadenet::shade::grid_env(&lights);
    let spec = Specialization::default();
    let (o, _) = opt::run(&p, &spec);
    let interp = shadenet::shade::shade_grid::<f32>(&o, &env, 16, 9, spec.components).unwrap();
    let jit = shadenet_jit::JitBackend::new();
    let m = jit.compile(&p, &spec).unwrap();
    // The batch entry is compiled when the first batch call needs it: at compile time the
    // material holds the code of the scalar entry alone.
    let scalar_only = shadenet_jit::JitBackend::with_options(shadenet_jit::JitOptions {
        batch: false,
        ..Default::default()
    });
    let s = scalar_only.compile(&p, &spec).unwrap();
    assert_eq!(m.info().stats.ir_insts, s.info().stats.ir_insts);
    for batch in [false, true] {
        let g = shadenet::shade::shade_grid_with(&*m, &env, 16, 9, spec.components, batch);
        let bits = |v: Vec<f64>| v.iter().map(|x| (*x as f32).to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(interp.pixel_values()),
            bits(g.pixel_values()),
            "batch {batch}"
        );
    }
}

/// Bad input: each error names the place with the source line, and what is wrong.
#[test]
fn errors_name_the_place_and_the_problem() {
    for (src, want) in [
        ("surface s() { Ci = colr(1); }", "unknown function `colr`"),
        (
            "surface s() { Ci = Cz; }",
            "unknown name `Cz` (did you mean `C",
        ),
        (
            "surface s() { float f = N; }",
            "expected a float, found a normal",
        ),
        (
            "surface s() { Ci = Cs + P; }",
            "`+` does not combine a color and a point",
        ),
        (
            "surface s() { Ci = diffuse(N, N); }",
            "`diffuse` does not take (normal, normal): it takes (normal N) -> color",
        ),
        (
            "float f(float x) { return g(x); } float g(float x) { return f(x); } surface s() { Ci = f(1); }",
            "recursion is not allowed: f → g → f",
        ),
        (
            "float f(float x) { return x; } surface s() { Ci = f(N); }",
            "no `f` takes (normal); candidates: f(float)",
        ),
        (
            "surface s() { uniform float k = u; }",
            "uniform variable `k` is initialised with a varying value",
        ),
        (
            "surface s() { uniform float k = 1; k = v; }",
            "uniform variable `k` is assigned a varying value",
        ),
        (
            "surface s() { matrix m = matrix(\"screen\"); }",
            "the space \"screen\" is not available here",
        ),
        (
            "surface s() { color c = 0; illuminance(P) { c = Cl; } Ci = c; }",
            "may only be accumulated with += or -=",
        ),
        ("volume v() { }", "volume shaders are not compiled yet"),
        (
            "light l() { illuminate(Ps, Ps) Cl = 1; }",
            "'illuminate' takes (P) or (P, axis, angle); found 2 arguments",
        ),
        (
            "surface s() { illuminate(P) Ci = 1; }",
            "`illuminate` and `solar` belong at the top level of a light shader's body",
        ),
        (
            "light l() { if (1 > 0) { solar(vector(0, 0, 1), 0) Cl = 1; } }",
            "belong at the top level of a light shader's body",
        ),
        (
            "light l() { solar(vector(0, 0, 1), 0.5) Cl = 1; }",
            "solar with a spread angle is not built",
        ),
        (
            "light l() { solar() Cl = 1; }",
            "solar() without an axis (light from every direction) is not built",
        ),
        (
            "light l() { illuminate(Ps) Cl = 1; solar(vector(0, 0, 1), 0) Cl = 1; }",
            "more than one `illuminate` or `solar`",
        ),
        ("light l() { Cl = N; }", "unknown name `N`"),
        (
            "surface s() { Ci = color point \"bogus\" (1, 2, 3); }",
            "the space \"bogus\" is not available here",
        ),
    ] {
        let e = compile(src).unwrap_err();
        assert!(e.contains(want), "{src}\n{e}");
        assert!(e.contains("t.sl:1:"), "{src}: names the place\n{e}");
    }
}

/// The CLI takes a `.sl` file where it takes a network: check, compile, shade.
#[test]
fn the_cli_compiles_and_shades_shader_files() {
    let (code, out, err) = shadenet(&["compile", "lang/tests/shaders/plastic.sl", "--stats"]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(out.contains("jit:") && out.contains("ops"), "{out}");
    let png = common::tmp("shaders", "matte.png");
    let (code, out, err) = shadenet(&[
        "shade",
        "lang/tests/shaders/matte.sl",
        "-o",
        png.to_str().unwrap(),
        "--res",
        "32x32",
        "--light",
        "point:1,1,2:2",
    ]);
    assert_eq!(code, 0, "{out}\n{err}");
    let (code, _, err) = shadenet(&["check", "lang/tests/shaders/fog.sl"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("volume shaders are not compiled yet") && err.contains("fog.sl:2:1"),
        "{err}"
    );
    let (code, _, err) = shadenet(&["check", "examples/networks/marble.json", "-I", "x"]);
    assert_eq!(code, 1);
    assert!(err.contains("-I and -D apply to shader sources"), "{err}");
}

/// Benchmark B1's tree written as a shader (`shadenet gen mult-tree -o tree.sl`) optimizes
/// to the network's program: the same products (all of them with CSE off, one per level
/// with it on), plus the point-to-color conversion RSL needs for `Ci` (three extracts and a
/// construct).
#[test]
fn the_multiplication_tree_as_a_shader_reaches_the_networks_program() {
    use shadenet::graph::ir::Op;
    for levels in [1u32, 4, 7] {
        let net = shadenet::generate::mult_tree(levels, shadenet::graph::ir::Space::World).unwrap();
        let net = compile_json(&net.to_string(), &NodeLibrary::standard())
            .unwrap()
            .program;
        let sl = compile(&shadenet::generate::mult_tree_sl(levels).unwrap()).unwrap();
        for cse in [false, true] {
            let mut spec = Specialization::default();
            spec.passes.cse = cse;
            let count = |p: &shadenet::graph::ir::Program, f: &dyn Fn(&Op) -> bool| {
                opt::run(p, &spec)
                    .0
                    .exprs
                    .iter()
                    .filter(|e| f(&e.op))
                    .count()
            };
            let muls = |op: &Op| matches!(op, Op::Binary(shadenet::graph::ir::BinOp::Mul, ..));
            let want = if cse {
                levels as usize
            } else {
                (1 << levels) - 1
            };
            assert_eq!(
                count(&net, &muls),
                want,
                "network, level {levels}, cse {cse}"
            );
            assert_eq!(count(&sl, &muls), want, "shader, level {levels}, cse {cse}");
            let conv = |op: &Op| matches!(op, Op::Extract(..) | Op::Construct(_));
            assert_eq!((count(&net, &conv), count(&sl, &conv)), (0, 4));
        }
    }
}

/// `examples/scenes/rsl.toml`: the classic shaders as scene materials (`network =
/// "…/plastic.sl"`, `set = { "plastic.tint" = … }`), rendered by the interpreter and the
/// JIT to the same bits; the spheres are lit and differ. Bad overrides name the material's
/// shader and parameters.
#[test]
fn the_rsl_scene_renders_and_overrides_set_parameters() {
    let films = common::render_interp_and_jit("rsl.toml", 1, (48, 27));
    assert_eq!(
        beauty_bits(&films[0]),
        beauty_bits(&films[1]),
        "interp and JIT"
    );
    // The four spheres sit on row 12 around columns 13, 20, 28, 35: lit, and not alike.
    let beauty = &films[1].layers[0];
    let px = |x: usize, y: usize| {
        [
            beauty.at(y * 48 + x, 0),
            beauty.at(y * 48 + x, 1),
            beauty.at(y * 48 + x, 2),
        ]
    };
    let spheres: Vec<[f32; 3]> = [13, 20, 28, 35].iter().map(|&x| px(x, 12)).collect();
    for s in &spheres {
        assert!(
            s.iter().all(|c| c.is_finite()) && s.iter().sum::<f32>() > 0.05,
            "{spheres:?}"
        );
    }
    // The plastic sphere is red (its `tint` override).
    assert!(spheres[2][0] > 2.0 * spheres[2][2], "{spheres:?}");
    // Bad overrides.
    let dir = common::tmp("shaders", "scene");
    std::fs::create_dir_all(&dir).unwrap();
    let shader =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/shaders/plastic.sl");
    for (set, want) in [
        (
            "\"plastic.Kx\" = 1",
            "`plastic` has no parameter `Kx` (its parameters: Ks, Kd, Ka, roughness, specularcolor, tint)",
        ),
        ("\"matte.Kd\" = 1", "the shader is `plastic`"),
        (
            "\"plastic.tint\" = \"red\"",
            "\"red\" is not a number or a list of numbers",
        ),
        (
            "\"plastic.tint\" = [1, 2]",
            "parameter `tint` is a color: (1, 2) is not one",
        ),
    ] {
        let scene = format!(
            "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nresolution = [8, 8]\n\
             [materials.m]\nnetwork = {shader:?}\nset = {{ {set} }}\n\
             [meshes.b]\ntype = \"sphere\"\n[[instances]]\nmesh = \"b\"\nmaterial = \"m\"\n"
        );
        let p = dir.join("scene.toml");
        std::fs::write(&p, scene).unwrap();
        let opts = shadenet::render::RenderOptions {
            spp: Some(1),
            res: Some((48, 27)),
            ..Default::default()
        };
        let e = match shadenet::render::setup_with(
            Some(&p),
            &opts,
            &shadenet::tracer::shader::InterpBackend,
        ) {
            Ok(_) => panic!("{set}: accepted"),
            Err(e) => shadenet::graph::error_chain(&e),
        };
        assert!(e.contains(want) && e.contains("`m`"), "{set}: {e}");
    }
}

/// A parameter whose default is an expression of earlier parameters is uniform code: class
/// compilation (parameters left uniform) hoists it into the prelude, evaluated once per
/// instance; an instance compilation folds it.
#[test]
fn parameter_default_expressions_are_hoisted_once_per_instance() {
    use shadenet::graph::ir::{BinOp, Op};
    let p = compile("surface s(float a = 2; float b = a * 3) { Ci = b * Cs * u; }").unwrap();
    assert_eq!(
        p.params.iter().map(|d| d.name.as_str()).collect::<Vec<_>>(),
        ["a"]
    );
    let class = Specialization {
        bake: false,
        ..Specialization::default()
    };
    let (o, _) = opt::run(&p, &class);
    let muls = o
        .prelude
        .body
        .iter()
        .filter(|v| matches!(o.op(**v), Op::Binary(BinOp::Mul, ..)))
        .count();
    assert_eq!(muls, 1, "{o}");
    let (baked, _) = opt::run(&p, &Specialization::default());
    assert!(baked.prelude.body.is_empty(), "{baked}");
    let f = plane_fragment();
    let out = run_program(&p, &f, &[], u32::MAX);
    assert_close(
        &out.get("Ci"),
        &[3.0; 3],
        1e-12,
        "b = a·3 = 6, times u = 0.5",
    );
}

/// RSL `output` parameters: a surface's are program outputs after `Ci` and `Oi` (arbitrary
/// output variables), a function's write the caller's variables (also under a varying
/// `if`); a light shader's are refused.
#[test]
fn rsl_output_parameters() {
    let p = compile(
        "void split(color c; output float r; output float g) { r = comp(c, 0); g = comp(c, 1); }
         surface aov(output varying color albedo = 0; output varying float mask = 1) {
             float r, g;
             split(color(u, v, 0.5), r, g);
             if (u > 0.6) split(color(2, 3, 4), r, g);
             albedo = color(r, g, 0);
             mask = r + g;
             Ci = albedo;
         }",
    )
    .unwrap();
    let names: Vec<&str> = p.outputs.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["Ci", "Oi", "albedo", "mask"]);
    for (u, want) in [(0.25f32, [0.25, 0.5]), (0.75, [2.0, 3.0])] {
        let mut f = plane_fragment();
        f.uv = [u, 0.5];
        let o = run_program(&p, &f, &[], u32::MAX);
        assert_close(&o.get("albedo"), &[want[0], want[1], 0.0], 1e-6, "albedo");
        assert_close(&o.get("mask"), &[want[0] + want[1]], 1e-6, "mask");
    }
    let err = compile_shader(
        "light l(output float x = 0) { illuminate(P) { Cl = 1; } }",
        Dialect::Rsl,
    )
    .unwrap_err();
    assert!(
        err.contains("output parameters of light shaders are not built yet"),
        "{err}"
    );
}
