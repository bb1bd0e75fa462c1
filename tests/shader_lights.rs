//! RenderMan Shading Language light shaders (`examples/shaders/*light.sl`) as scene lights:
//! the acceptance comparison (`matte` under `pointlight` is our `lambert` under our point
//! light, the unit conversion stated), each light's formula, the cone, shadows in a render
//! on the interpreter and the JIT, and the errors that name the file.
//!
//! Units: RSL's `diffuse()` has no 1/π and reads a light's `Cl` as it arrives, so `matte`
//! (Kd = 1) under `pointlight` of intensity `I_rsl` gives `I_rsl · cosθ / r²`; our `lambert`
//! (color 1) under our point light of intensity `I` gives `I / π · cosθ / r²`. They are
//! equal when `I_rsl = I / π`.

mod common;
use common::*;
use serde_json::json;
use shadenet::graph::NodeLibrary;
use shadenet::graph::compile_json;
use shadenet::graph::nodes::{LightDesc, LightKind};
use shadenet::render::{self as r, BackendKind, RenderOptions};
use std::path::{Path, PathBuf};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/shaders")
        .join(name)
}

/// The light shader `file` with `set` overrides `(parameter, value)` of shader `shader`.
fn shader_light(file: &str, shader: &str, set: &[(&str, serde_json::Value)]) -> LightDesc {
    let overrides: Vec<(String, String, serde_json::Value)> = set
        .iter()
        .map(|(k, v)| (shader.to_string(), k.to_string(), v.clone()))
        .collect();
    shadenet::scene_lights::light(&example(file), &overrides, "l".into(), false).unwrap()
}

fn lambert() -> shadenet::graph::ir::Program {
    compile_json(
        r#"{"nodes": [{"name": "l", "type": "lambert",
            "inputs": {"color": [1, 1, 1], "diffuse": 1}}],
            "outputs": {"color": "l.outColor"}}"#,
        &NodeLibrary::standard(),
    )
    .unwrap()
    .program
}

fn matte() -> shadenet::graph::ir::Program {
    shadenet::shader::load(&example("matte.sl"), &[], &[])
        .unwrap()
        .program
}

/// The acceptance test: `matte` under `pointlight` (intensity I/π, a color, a position)
/// equals `lambert` under our point light (intensity I, the same color and position) to
/// 1e-6, at points lit from several angles and distances, in f32 and f64, with the light
/// program on the interpreter and on the JIT (which give the same bits).
#[test]
fn matte_under_pointlight_is_lambert_under_our_point_light() {
    let pi = std::f64::consts::PI;
    let (i, color, from) = (7.0, [1.0, 0.8, 0.5], [0.6, -0.3, 1.5]);
    let overrides: Vec<(String, String, serde_json::Value)> = [
        ("intensity", json!(i / pi)),
        ("lightcolor", json!(color)),
        ("from", json!(from)),
    ]
    .into_iter()
    .map(|(k, v)| ("pointlight".to_string(), k.to_string(), v))
    .collect();
    let rsl = |jit: bool| {
        let file = example("pointlight.sl");
        shadenet::scene_lights::light(&file, &overrides, "l".into(), jit).unwrap()
    };
    let (interp, jit) = (rsl(false), rsl(true));
    assert!(matches!(interp.kind, LightKind::Shader { .. }));
    let ours = LightDesc::new(
        "l",
        LightKind::Point { position: from },
        color.map(|c| c * i),
    )
    .unwrap();
    let (matte, lambert) = (matte(), lambert());
    for p in [
        [0.0, 0.0, 0.0],
        [0.2, 0.1, 0.0],
        [-1.5, 2.0, 0.0],
        [3.0, -0.4, 0.0],
    ] {
        let mut f = plane_fragment();
        f.p = p;
        f.i = [p[0], p[1], -1.0];
        let got = run_program(&matte, &f, std::slice::from_ref(&interp), u32::MAX);
        let got_jit = run_program(&matte, &f, std::slice::from_ref(&jit), u32::MAX);
        let want = run_program(&lambert, &f, std::slice::from_ref(&ours), u32::MAX);
        let want = want.get("color");
        assert!(want.iter().all(|x| *x > 1e-3), "{p:?}: lit {want:?}");
        assert_close(
            &got.get("Ci"),
            &want,
            1e-6,
            "matte·pointlight = lambert (f64)",
        );
        assert_close(
            &got.get32("Ci"),
            &want,
            1e-6,
            "matte·pointlight = lambert (f32)",
        );
        let bits = |v: Vec<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(got.get32("Ci")),
            bits(got_jit.get32("Ci")),
            "JIT light"
        );
    }
}

/// Each example light's formula at one point: pointlight `I·c/(L.L)`, distantlight `I·c`
/// along `to - from`, spotlight's cone, beam and smoothstep edge (and black outside the
/// cone), ambientlight an ambient light of power `I·c`.
#[test]
fn each_light_shader_follows_its_formula() {
    // A surface that returns diffuse() without the faceforward: Cl · max(0, N·L).
    let mut f = plane_fragment();
    f.p = [0.5, 0.0, 0.0];
    let diffuse = |light: &LightDesc, f: &shadenet::runtime::Fragment| {
        let m = matte();
        run_program(&m, f, std::slice::from_ref(light), u32::MAX).get("Ci")
    };
    // distantlight from (0,0,1) to (1,0,-1)·…: direction (1, 0, -2) normalized.
    let d = shader_light(
        "distantlight.sl",
        "distantlight",
        &[
            ("intensity", json!(2.0)),
            ("from", json!([0, 0, 1])),
            ("to", json!([1, 0, -1])),
        ],
    );
    let cos = 2.0 / 5f64.sqrt();
    assert_close(&diffuse(&d, &f), &[2.0 * cos; 3], 1e-6, "distantlight");
    // spotlight above the point, aimed down: on the axis the beam is full.
    let spot = |at: [f64; 3]| {
        shader_light(
            "spotlight.sl",
            "spotlight",
            &[
                ("intensity", json!(4.0)),
                ("from", json!(at)),
                ("to", json!([at[0], at[1], 0.0])),
            ],
        )
    };
    assert_close(
        &diffuse(&spot([0.5, 0.0, 2.0]), &f),
        &[1.0; 3],
        1e-6,
        "spot axis",
    );
    // 20 degrees off the axis (inside the 25-degree fully lit cone): cos^2 beam, 1/r².
    let a = 20f64.to_radians();
    let off = spot([0.5 - 2.0 * a.tan(), 0.0, 2.0]);
    let r2 = 4.0 / (a.cos() * a.cos());
    let want = 4.0 * a.cos().powi(2) / r2 * a.cos();
    assert_close(&diffuse(&off, &f), &[want; 3], 1e-6, "spot 20°");
    // 27.5 degrees: inside the smoothstep edge (25 to 30 degrees), half way.
    let a = 27.5f64.to_radians();
    let edge = spot([0.5 - 2.0 * a.tan(), 0.0, 2.0]);
    let (c_out, c_in) = (30f64.to_radians().cos(), 25f64.to_radians().cos());
    let t = (a.cos() - c_out) / (c_in - c_out);
    let smooth = t * t * (3.0 - 2.0 * t);
    let r2 = 4.0 / (a.cos() * a.cos());
    let want = 4.0 * a.cos().powi(2) / r2 * smooth * a.cos();
    // (Light shaders run in f32: the edge's divisor cos 25° - cos 30° ≈ 0.04 magnifies
    // their rounding to a few 1e-6.)
    assert_close(&diffuse(&edge, &f), &[want; 3], 1e-5, "spot edge");
    // 35 degrees: outside the cone, black.
    let outside = spot([0.5 - 2.0 * 35f64.to_radians().tan(), 0.0, 2.0]);
    assert_close(&diffuse(&outside, &f), &[0.0; 3], 0.0, "spot outside");
    // ambientlight is an ambient light of power intensity · lightcolor.
    let amb = shader_light(
        "ambientlight.sl",
        "ambientlight",
        &[
            ("intensity", json!(0.5)),
            ("lightcolor", json!([1, 0.5, 0.25])),
        ],
    );
    assert!(matches!(amb.kind, LightKind::Ambient), "{:?}", amb.kind);
    assert_eq!(amb.power, [0.5, 0.25, 0.125]);
}

/// Writes a scene: a floor (matte, or lambert) with a blocker sphere, lit by `light`.
fn scene_file(dir: &Path, name: &str, surface: &str, light: &str) -> PathBuf {
    let text = format!(
        "[camera]\nposition = [0, 3, 3]\nlook_at = [0, 0, 0]\nfov = 50\nresolution = [24, 16]\n\
         [render]\nspp = 1\n\
         [materials.m]\n{surface}\n\
         [meshes.ground]\ntype = \"quad\"\n[meshes.ball]\ntype = \"sphere\"\nsegments = 24\n\
         [[instances]]\nmesh = \"ground\"\nmaterial = \"m\"\nrotate = [-90, 0, 0]\nscale = 6\n\
         [[instances]]\nmesh = \"ball\"\nmaterial = \"m\"\ntranslate = [0, 0.8, 0]\nscale = 0.4\n\
         [[lights]]\n{light}\n"
    );
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn render(path: &Path, kind: BackendKind) -> shadenet::tracer::film::Layer {
    let opts = RenderOptions::default();
    let backend = r::backend(kind).unwrap();
    let renderer = r::setup_with(Some(path), &opts, backend.as_ref()).unwrap();
    renderer.render(&|_, _| {}).0.layers[0].clone()
}

/// A scene lit by `pointlight` renders as the same scene with our point light and `lambert`
/// (the intensity converted) to 1e-6 per pixel, on the interpreter and the JIT (which agree
/// bit for bit), shadow of the sphere on the floor included.
#[test]
fn a_light_shader_lights_a_scene_with_ray_traced_shadows() {
    let dir = tmp("shader-lights", "scene");
    std::fs::create_dir_all(&dir).unwrap();
    let pi = std::f64::consts::PI;
    let matte = format!("network = {:?}", example("matte.sl"));
    let rsl = scene_file(
        &dir,
        "rsl.toml",
        &matte,
        &format!(
            "type = \"shader\"\nshader = {:?}\nset = {{ \"pointlight.intensity\" = {}, \"pointlight.from\" = [0.5, 2.5, 0.2] }}",
            example("pointlight.sl"),
            6.0 / pi
        ),
    );
    let lambert = "inline = { nodes = [{ name = \"l\", type = \"lambert\", inputs = { color = [1, 1, 1], diffuse = 1 } }], outputs = { color = \"l.outColor\" } }";
    let ours = scene_file(
        &dir,
        "ours.toml",
        lambert,
        "type = \"point\"\nposition = [0.5, 2.5, 0.2]\nintensity = 6",
    );
    let interp = render(&rsl, BackendKind::Interp);
    let jit = render(&rsl, BackendKind::Jit);
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&interp.data), bits(&jit.data), "interp and JIT");
    let want = render(&ours, BackendKind::Interp);
    let wide = |v: &[f32]| v.iter().map(|x| *x as f64).collect::<Vec<f64>>();
    assert_close(
        &wide(&interp.data),
        &wide(&want.data),
        1e-6,
        "pointlight scene = point-light scene",
    );
    // The image's centre sees the floor at the origin, inside the sphere's shadow (the
    // light at (0.5, 2.5, 0.2) through the sphere at (0, 0.8, 0) falls around
    // (-0.24, 0, -0.09)): black there, as in ours, while much of the floor is lit.
    let red = |x: usize, y: usize| interp.at(y * 24 + x, 0);
    assert_eq!(red(12, 8), 0.0, "shadowed centre");
    let lit = (0..16)
        .flat_map(|y| (0..24).map(move |x| (x, y)))
        .filter(|&(x, y)| red(x, y) > 0.05)
        .count();
    assert!(lit > 20, "lit pixels: {lit}");
}

/// A light shader with a bad parameter, a surface shader as a light and a light shader as a
/// material are refused with messages naming the file and the light or material.
#[test]
fn light_shader_errors_name_the_file() {
    let dir = tmp("shader-lights", "errors");
    std::fs::create_dir_all(&dir).unwrap();
    let matte = format!("network = {:?}", example("matte.sl"));
    let point = example("pointlight.sl");
    let cases = [
        (
            matte.clone(),
            format!("type = \"shader\"\nshader = {point:?}\nset = {{ \"pointlight.power\" = 1 }}"),
            vec![
                "lights[0]",
                "pointlight.sl",
                "`pointlight` has no parameter `power` (its parameters: intensity, lightcolor, from)",
            ],
        ),
        (
            matte.clone(),
            format!(
                "type = \"shader\"\nshader = {point:?}\nset = {{ \"pointlight.from\" = [1, 2] }}"
            ),
            vec!["lights[0]", "parameter `from` is a vec3: (1, 2) is not one"],
        ),
        (
            matte.clone(),
            format!("type = \"shader\"\nshader = {:?}", example("matte.sl")),
            vec![
                "lights[0]",
                "matte.sl",
                "`matte` is a surface shader: a scene light needs a light shader",
            ],
        ),
        (
            format!("network = {point:?}"),
            "type = \"point\"\nposition = [0, 2, 0]".to_string(),
            vec![
                "`m`",
                "pointlight.sl",
                "`pointlight` is a light shader: a material needs a surface shader",
            ],
        ),
    ];
    for (i, (surface, light, wants)) in cases.iter().enumerate() {
        let p = scene_file(&dir, &format!("e{i}.toml"), surface, light);
        let e = match r::setup_with(
            Some(&p),
            &RenderOptions::default(),
            &shadenet::tracer::shader::InterpBackend,
        ) {
            Ok(_) => panic!("case {i}: accepted"),
            Err(e) => shadenet::graph::error_chain(&e),
        };
        for w in wants {
            assert!(e.contains(w), "case {i}: {e}\nwants {w}");
        }
    }
    // A light shader whose Cl depends on Ps without illuminate, and one that reads other
    // lights, are refused by what they read.
    for (src, want) in [
        ("light l() { Cl = xcomp(Ps); }", "depends on Ps"),
        (
            "light l() { illuminate(point(0, 0, 1)) Cl = ambient(); }",
            "reads other lights",
        ),
    ] {
        let f = dir.join("l.sl");
        std::fs::write(&f, src).unwrap();
        let e = shadenet::scene_lights::light(&f, &[], "l".into(), true).unwrap_err();
        assert!(e.contains(want) && e.contains("`l`"), "{src}: {e}");
    }
    // The renderer refuses a scene whose light shaders its caller did not compile.
    let p = scene_file(
        &dir,
        "raw.toml",
        &matte,
        &format!("type = \"shader\"\nshader = {point:?}"),
    );
    let scene = shadenet::tracer::scene::load(&p).unwrap();
    assert_eq!(scene.shader_lights.len(), 1);
    let programs = vec![matte_program_for(&scene)];
    let e = match shadenet::tracer::Renderer::new(
        scene,
        programs,
        &shadenet::tracer::shader::InterpBackend,
    ) {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("lights[0]") && e.contains("was not compiled"),
        "{e}"
    );
}

fn matte_program_for(_: &shadenet::tracer::scene::Scene) -> shadenet::graph::ir::Program {
    matte()
}

/// `shadenet check` and `compile` take a light shader and show its light program; `shade`
/// refuses it, naming the file and where a light shader goes.
#[test]
fn the_cli_checks_and_compiles_light_shaders() {
    let (code, out, err) = shadenet(&["check", "examples/shaders/pointlight.sl"]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(out.contains("outputs: Cl, from"), "{out}");
    let (code, out, err) = shadenet(&["check", "examples/shaders/distantlight.sl"]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(out.contains("outputs: Cl, axis"), "{out}");
    let (code, out, err) = shadenet(&[
        "compile",
        "examples/shaders/spotlight.sl",
        "--param",
        "intensity=2",
        "--emit",
        "ir",
    ]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(out.contains("Cl") && out.contains("from"), "{out}");
    let png = tmp("shader-lights", "light.png");
    let (code, out, err) = shadenet(&[
        "shade",
        "examples/shaders/pointlight.sl",
        "-o",
        png.to_str().unwrap(),
        "-q",
    ]);
    assert_ne!(code, 0, "{out}");
    assert!(
        err.contains("pointlight.sl") && err.contains("`pointlight` is a light shader"),
        "{err}"
    );
}

/// `examples/scenes/rsl.toml`, lit by `pointlight`, `distantlight`, `spotlight` and
/// `ambientlight`, renders as the same scene with our point, distant, spot (a 60° cone, -5°
/// penumbra, dropoff 2: the same smoothstep edge and cos² beam) and ambient lights of the
/// same numbers: every surface sees the same light, whatever its shader (RSL's `diffuse` and
/// `specular` read `Cl` as it arrives in both). Measured at 640×360, 4 spp: max abs 6.6e-7,
/// RMSE 1.3e-8 (f32 rounding of the light programs, magnified at the spot's edge).
#[test]
fn the_rsl_scene_renders_as_with_our_lights() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("examples/scenes/rsl.toml")).unwrap();
    let shaders = root.join("examples/shaders");
    let text = text.replace("\"../shaders/", &format!("\"{}/", shaders.display()));
    let cut = text.find("[[lights]]").unwrap();
    let ours = format!(
        "{}{}",
        &text[..cut],
        "[[lights]]\ntype = \"point\"\nposition = [3.0, 5.0, 4.0]\nintensity = 6\n\
         [[lights]]\ntype = \"distant\"\ndirection = [4.0, -3.0, -2.0]\nintensity = 0.07\n\
         [[lights]]\ntype = \"spot\"\nposition = [1.8, 3.0, 1.0]\ndirection = [0.0, -2.5, -1.6]\n\
         cone_angle = 60\npenumbra_angle = -5\ndropoff = 2\nintensity = 3\ncolor = [1.0, 0.9, 0.7]\n\
         [[lights]]\ntype = \"ambient\"\nintensity = 0.05\n"
    );
    let dir = tmp("shader-lights", "rsl");
    std::fs::create_dir_all(&dir).unwrap();
    let (a, b) = (dir.join("rsl.toml"), dir.join("ours.toml"));
    std::fs::write(&a, &text).unwrap();
    std::fs::write(&b, ours).unwrap();
    let opts = RenderOptions {
        spp: Some(1),
        res: Some((96, 54)),
        ..RenderOptions::default()
    };
    let film = |p: &Path| {
        let backend = r::backend(BackendKind::Jit).unwrap();
        let renderer = r::setup_with(Some(p), &opts, backend.as_ref()).unwrap();
        renderer.render(&|_, _| {}).0.layers[0].clone()
    };
    let (got, want) = (film(&a), film(&b));
    let wide = |v: &[f32]| v.iter().map(|x| *x as f64).collect::<Vec<f64>>();
    assert_close(
        &wide(&got.data),
        &wide(&want.data),
        5e-6,
        "rsl.toml = our lights",
    );
    let lit = got.data.iter().filter(|x| **x > 0.05).count();
    assert!(lit > 1000, "lit values: {lit}");
}
