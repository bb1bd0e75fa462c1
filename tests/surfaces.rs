//! The standard surfaces of MaterialX 1.39's bxdf library through the libraries' own graphs
//! (issue 15): `standard_surface`, `open_pbr_surface`, `UsdPreviewSurface` and `gltf_pbr`
//! compile (link, lower, optimize, JIT) with default parameters, and specialization leaves
//! exactly the lobes their weights leave (observed with the lobe probes of
//! `graph::closure::probe`: a lobe is gone when its weight folds to the constant 0). The
//! parameters that enable coat, sheen, transmission and thin film bring those lobes back;
//! what is not built (zeltner sheen, volumes) is refused with a message saying so, and
//! specializes away where the default weights leave it out.
//!
//! The layered white furnace: each material's closure (the lowering's lobe list, with
//! `layer` scaling its base by `1 − albedo(top)`) is sampled under a uniform environment of
//! radiance 1, `E[sample weight]` over many uniform numbers — white base, coat, sheen,
//! specular 1, transmission, white metal, at roughness 0…1 and views 0…89.9° — and must
//! never exceed 1 beyond Monte Carlo noise.
//!
//! Tests need the MaterialX libraries: they fail when `CI` is set and the libraries are
//! missing, and skip with a printed reason otherwise.

mod common;
use shadenet::graph::error_chain;
use shadenet::graph::mtlx::{self, Library, Selection};
use shadenet_graph::closure::Closure;
use shadenet_graph::ir::{Builder, Program, Stream, UnOp};
use shadenet_graph::lower::LowerOptions;
use shadenet_graph::opt::{self, Specialization};
use shadenet_graph::types::Type;
use shadenet_jit::JitBackend;
use shadenet_runtime::{Backend, Fragment, ShadeEnv};
use std::time::Duration;

fn lib() -> Option<&'static Library> {
    common::mtlx_library()
}

/// A document with one `node` surface of `inputs` (`name`, MaterialX type, value) under
/// material `M`.
fn doc(node: &str, inputs: &[(&str, &str, String)]) -> String {
    let mut s = format!(
        "<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n  <{node} name=\"S\" type=\"surfaceshader\">\n"
    );
    for (name, ty, value) in inputs {
        s.push_str(&format!(
            "    <input name=\"{name}\" type=\"{ty}\" value=\"{value}\" />\n"
        ));
    }
    s.push_str(&format!(
        "  </{node}>\n  <surfacematerial name=\"M\" type=\"material\">\n    <input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"S\" />\n  </surfacematerial>\n</materialx>\n"
    ));
    s
}

fn f(name: &'static str, x: f64) -> (&'static str, &'static str, String) {
    (name, "float", format!("{x}"))
}

fn c(name: &'static str, x: [f64; 3]) -> (&'static str, &'static str, String) {
    (name, "color3", format!("{}, {}, {}", x[0], x[1], x[2]))
}

const WHITE: [f64; 3] = [1.0, 1.0, 1.0];

/// The lobes left after optimizing with the default specialization, as `kind (component)`,
/// sorted, and the number of lobes the lowering emitted.
fn live(lib: &Library, text: &str) -> Result<(Vec<String>, usize), String> {
    let spec = Specialization::default();
    let lobes = mtlx::lobes("t.mtlx", text, lib, &Selection::default(), &spec)
        .map_err(|e| error_chain(&e))?;
    let mut v: Vec<String> = lobes
        .iter()
        .filter(|l| l.live)
        .map(|l| format!("{} ({})", l.kind, l.component))
        .collect();
    v.sort();
    Ok((v, lobes.len()))
}

/// Compiles `text` as a renderer would (shaded), optimizes and JIT-compiles it; the op
/// counts before and after.
fn compile_and_jit(lib: &Library, text: &str) -> Result<(usize, usize), String> {
    let c =
        mtlx::compile("t.mtlx", text, lib, &Selection::default()).map_err(|e| error_chain(&e))?;
    let (p, report) = opt::run(&c.program, &Specialization::default());
    shadenet_graph::ir::validate(&p).map_err(|e| e.to_string())?;
    JitBackend::new()
        .compile_program(&p, Duration::ZERO)
        .map_err(|e| e.to_string())?;
    Ok((report.ops_before, report.ops_after))
}

fn lobes(list: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = list.iter().map(|s| s.to_string()).collect();
    v.sort();
    v
}

#[test]
fn the_four_surfaces_compile_with_default_parameters_to_the_lobes_their_weights_leave() {
    let Some(lib) = lib() else {
        return;
    };
    // What the defaults leave, read off each library graph:
    // - standard_surface: base 0.8 (diffuse), specular 1 (a dielectric reflection); metal,
    //   coat, sheen, transmission, subsurface and thin film are weight 0.
    // - open_pbr_surface: base_weight 1 (diffuse), specular_weight 1 (dielectric
    //   reflection); metalness, coat, fuzz, transmission, subsurface, thin film 0.
    // - UsdPreviewSurface: diffuse + specular (a generalized Schlick reflection; metallic
    //   0 and clearcoat 0 leave one specular lobe).
    // - gltf_pbr: metallic 1 by default keeps the metal lobe alone (the dielectric branch,
    //   diffuse under a reflection, is mixed in by 1 − metallic); clearcoat, sheen,
    //   transmission, iridescence 0.
    let want: [(&str, Vec<String>); 4] = [
        (
            "standard_surface",
            lobes(&["dielectric(R) (specular)", "oren_nayar_diffuse (diffuse)"]),
        ),
        (
            "open_pbr_surface",
            lobes(&["dielectric(R) (specular)", "oren_nayar_diffuse (diffuse)"]),
        ),
        (
            "UsdPreviewSurface",
            lobes(&[
                "generalized_schlick(R) (specular)",
                "oren_nayar_diffuse (diffuse)",
            ]),
        ),
        ("gltf_pbr", lobes(&["generalized_schlick(R) (specular)"])),
    ];
    for (node, want) in want {
        let text = doc(node, &[]);
        let (ops_before, ops_after) =
            compile_and_jit(lib, &text).unwrap_or_else(|e| panic!("{node}: {e}"));
        let (left, emitted) = live(lib, &text).unwrap_or_else(|e| panic!("{node}: {e}"));
        eprintln!("{node}: {ops_before} → {ops_after} ops; lobes {left:?} of {emitted}");
        assert_eq!(left, want, "{node}: the lobes specialization leaves");
        assert!(
            emitted > left.len(),
            "{node}: the graph emits more lobes ({emitted}) than its defaults leave"
        );
        assert!(
            ops_after * 4 < ops_before,
            "{node}: specialization removes most of the graph: {ops_before} → {ops_after}"
        );
    }
}

#[test]
fn compile_stats_lists_the_lobes_left() {
    if lib().is_none() {
        return;
    }
    let (code, out, err) = common::shadenet(&[
        "compile",
        "examples/materials/surfaces.mtlx",
        "--material",
        "M_gltf_pbr",
        "--stats",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("lobes: 1 of 8 left: generalized_schlick(R) (specular)\n"),
        "{out}"
    );
}

#[test]
fn coat_sheen_and_transmission_bring_their_lobes_back() {
    let Some(lib) = lib() else {
        return;
    };
    let cases: [(&str, Vec<_>, &str); 11] = [
        (
            "standard_surface",
            vec![f("coat", 1.0)],
            "dielectric(R) (specular)",
        ),
        ("standard_surface", vec![f("sheen", 1.0)], "sheen (sheen)"),
        (
            "standard_surface",
            vec![f("transmission", 1.0)],
            "dielectric(T) (transmission)",
        ),
        (
            "standard_surface",
            vec![f("metalness", 1.0)],
            "conductor (specular)",
        ),
        (
            "open_pbr_surface",
            vec![f("coat_weight", 1.0)],
            "dielectric(R) (specular)",
        ),
        (
            "open_pbr_surface",
            vec![f("transmission_weight", 1.0)],
            "dielectric(T) (transmission)",
        ),
        (
            "open_pbr_surface",
            vec![f("base_metalness", 1.0)],
            "generalized_schlick(R) (specular)",
        ),
        (
            "gltf_pbr",
            vec![f("clearcoat", 1.0)],
            "dielectric(R) (specular)",
        ),
        (
            "gltf_pbr",
            vec![f("metallic", 0.0), f("transmission", 1.0)],
            "dielectric(T) (transmission)",
        ),
        ("gltf_pbr", vec![c("sheen_color", WHITE)], "sheen (sheen)"),
        (
            "UsdPreviewSurface",
            vec![f("clearcoat", 1.0)],
            "generalized_schlick(R) (specular)",
        ),
    ];
    for (node, inputs, lobe) in cases {
        let (base, _) = live(lib, &doc(node, &[])).unwrap();
        let (more, _) = live(lib, &doc(node, &inputs)).unwrap_or_else(|e| panic!("{node}: {e}"));
        let count = |v: &[String]| v.iter().filter(|l| *l == lobe).count();
        assert_eq!(
            count(&more),
            count(&base) + 1,
            "{node} with {inputs:?}: one more {lobe} lobe: {base:?} → {more:?}"
        );
    }
}

#[test]
fn what_is_not_built_is_refused_where_its_weight_is_not_zero() {
    let Some(lib) = lib() else {
        return;
    };
    let refused = [
        (
            "open_pbr_surface",
            vec![f("fuzz_weight", 1.0)],
            "sheen mode `zeltner` is not built yet",
        ),
        (
            "open_pbr_surface",
            vec![
                f("transmission_weight", 1.0),
                f("transmission_depth", 1.0),
                c("transmission_color", [0.5, 0.5, 0.5]),
            ],
            "volumes are not built yet",
        ),
    ];
    for (node, inputs, msg) in refused {
        let e = compile_and_jit(lib, &doc(node, &inputs)).unwrap_err();
        assert!(e.contains(msg), "{node} {inputs:?}: {e}");
    }
    // A clear medium (white transmission_color, no scattering) is a vacuum at any depth.
    compile_and_jit(
        lib,
        &doc(
            "open_pbr_surface",
            &[f("transmission_weight", 1.0), f("transmission_depth", 1.0)],
        ),
    )
    .unwrap();
    // Thin film with a zero thickness is no film; the variant mixed in with weight 0 goes.
    compile_and_jit(
        lib,
        &doc(
            "open_pbr_surface",
            &[f("thin_film_weight", 1.0), f("thin_film_thickness", 0.0)],
        ),
    )
    .unwrap();
}

/// Thin film is built (`closure::thin_film`): each surface's film parameter compiles and
/// brings the film's Fresnel in (more ops than the same surface without it).
#[test]
fn thin_film_of_every_surface_compiles() {
    let Some(lib) = lib() else {
        return;
    };
    let cases = [
        ("open_pbr_surface", vec![f("thin_film_weight", 1.0)]),
        ("gltf_pbr", vec![f("iridescence", 1.0)]),
        ("standard_surface", vec![f("thin_film_thickness", 300.0)]),
    ];
    for (node, inputs) in cases {
        let (_, plain) = compile_and_jit(lib, &doc(node, &[])).unwrap();
        let (_, film) =
            compile_and_jit(lib, &doc(node, &inputs)).unwrap_or_else(|e| panic!("{node}: {e}"));
        assert!(
            film > plain + 50,
            "{node} {inputs:?}: {film} vs {plain} ops"
        );
    }
}

/// The furnace outputs of a closure: the sample weight for uniform numbers `rand.xyz`, seen
/// from `−I`, and `Σ w · albedo(−I)`.
fn furnace_outputs(b: &mut Builder, _name: &str, c: &Closure) {
    let i = b.stream(Stream::I);
    let i = b.normalize(i);
    let wo = b.unary(UnOp::Neg, i);
    let r = b.stream(Stream::Rand);
    let xyz = [b.extract(r, 0), b.extract(r, 1), b.extract(r, 2)];
    let u = b.construct(Type::Vec3, &xyz);
    let s = c.sample(b, wo, u);
    b.output("weight", None, s.weight);
    let a = c.albedo(b, wo);
    b.output("albedo", None, a);
}

/// [`furnace_outputs`] counting flux: a transmitted sample's weight times `ior²` = 2.25
/// (ior 1.5, the dielectric of [`ggx_single_scattering_energy_loss`]), undoing the
/// radiance scaling of refraction.
fn flux_outputs(b: &mut Builder, _name: &str, c: &Closure) {
    let i = b.stream(Stream::I);
    let i = b.normalize(i);
    let wo = b.unary(UnOp::Neg, i);
    let r = b.stream(Stream::Rand);
    let xyz = [b.extract(r, 0), b.extract(r, 1), b.extract(r, 2)];
    let u = b.construct(Type::Vec3, &xyz);
    let s = c.sample(b, wo, u);
    let n = b.stream(Stream::N);
    let cos = b.dot(s.wi, n);
    let zero = b.float(0.0);
    let below = b.binary(shadenet_graph::ir::BinOp::Lt, cos, zero);
    let (k, one) = (b.float(2.25), b.float(1.0));
    let k = b.select(below, k, one);
    let k = b.splat(Type::Color, k);
    let w = b.mul(s.weight, k);
    b.output("weight", None, w);
    let a = c.albedo(b, wo);
    b.output("albedo", None, a);
}

/// The closure program of `text`'s material with `hook`'s outputs, optimized.
fn furnace_program_with(
    lib: &Library,
    text: &str,
    hook: shadenet_graph::lower::ClosureOutputFn,
) -> Program {
    let opts = LowerOptions {
        closure_output: Some(hook),
        ..LowerOptions::default()
    };
    let c = mtlx::compile_with("t.mtlx", text, lib, &Selection::default(), opts)
        .unwrap_or_else(|e| panic!("{}", error_chain(&e)));
    opt::run(&c.program, &Specialization::default()).0
}

/// The view angles of the furnace (degrees).
const VIEWS: [f64; 7] = [0.0, 30.0, 60.0, 75.0, 85.0, 89.0, 89.9];
/// Samples per view.
const SAMPLES: usize = 16384;

/// Mean sample weight (max channel) and its standard error for each view of [`VIEWS`],
/// with the closure's albedo estimate.
fn furnace(lib: &Library, text: &str) -> Vec<(f64, f64, f64)> {
    furnace_with(lib, text, furnace_outputs)
}

fn furnace_with(
    lib: &Library,
    text: &str,
    hook: shadenet_graph::lower::ClosureOutputFn,
) -> Vec<(f64, f64, f64)> {
    let p = furnace_program_with(lib, text, hook);
    let m = JitBackend::new()
        .compile_program(&p, Duration::ZERO)
        .unwrap_or_else(|e| panic!("{e}"));
    let at = |name: &str| {
        m.layout()
            .iter()
            .find(|s| s.name == name)
            .map(|s| s.offset)
            .unwrap()
    };
    let (wat, aat, w) = (at("weight"), at("albedo"), m.width());
    VIEWS
        .iter()
        .map(|deg| {
            let th = deg.to_radians();
            let wo = [th.sin() as f32, 0.0, th.cos() as f32];
            // Roberts' R3 sequence: low-discrepancy numbers in [0, 1)³.
            let g = [0.819_172_513_4, 0.671_043_606_7, 0.549_700_477_9];
            let frags: Vec<Fragment> = (0..SAMPLES)
                .map(|k| {
                    let u = g.map(|a| ((0.5 + a * k as f64) % 1.0) as f32);
                    Fragment {
                        i: wo.map(|x| -x),
                        n: [0.0, 0.0, 1.0],
                        ng: [0.0, 0.0, 1.0],
                        dpdu: [1.0, 0.0, 0.0],
                        dpdv: [0.0, 1.0, 0.0],
                        rand: [u[0], u[1], u[2], 0.5],
                        ..Fragment::default()
                    }
                })
                .collect();
            let mut out = vec![f32::NAN; w * frags.len()];
            let r = shadenet_runtime::shade_many_unpacked(
                &*m,
                &ShadeEnv::default(),
                u32::MAX,
                None,
                &frags,
                &mut out,
            );
            assert_eq!(r.nonfinite, 0, "non-finite sample weights at {deg}°");
            let xs: Vec<f64> = out
                .chunks(w)
                .map(|o| o[wat..wat + 3].iter().fold(0f64, |a, x| a.max(*x as f64)))
                .collect();
            let n = xs.len() as f64;
            let mean = xs.iter().sum::<f64>() / n;
            let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
            let albedo = out[aat..aat + 3].iter().fold(0f64, |a, x| a.max(*x as f64));
            (mean, (var / n).sqrt(), albedo)
        })
        .collect()
}

/// The furnace's configurations of a surface: name, inputs at roughness `r`, and the most
/// the mean may exceed 1 beyond three standard errors (the measured excess, rounded up).
type Config = (
    &'static str,
    fn(f64) -> Vec<(&'static str, &'static str, String)>,
    f64,
);

const STANDARD: [Config; 7] = [
    (
        "white diffuse + specular",
        |r| {
            vec![
                f("base", 1.0),
                c("base_color", WHITE),
                f("specular_roughness", r),
            ]
        },
        0.006,
    ),
    (
        "+ coat",
        |r| {
            vec![
                f("base", 1.0),
                c("base_color", WHITE),
                f("specular_roughness", r),
                f("coat", 1.0),
                f("coat_roughness", r),
            ]
        },
        0.006,
    ),
    (
        "+ coat + sheen",
        |r| {
            vec![
                f("base", 1.0),
                c("base_color", WHITE),
                f("specular_roughness", r),
                f("coat", 1.0),
                f("coat_roughness", r),
                f("sheen", 1.0),
                c("sheen_color", WHITE),
                f("sheen_roughness", r),
            ]
        },
        0.006,
    ),
    (
        "+ sheen",
        |r| {
            vec![
                f("base", 1.0),
                c("base_color", WHITE),
                f("specular_roughness", r),
                f("sheen", 1.0),
                c("sheen_color", WHITE),
                f("sheen_roughness", r),
            ]
        },
        0.006,
    ),
    (
        "transmission",
        |r| vec![f("transmission", 1.0), f("specular_roughness", r)],
        0.005,
    ),
    (
        "white metal",
        |r| {
            vec![
                f("base", 1.0),
                c("base_color", WHITE),
                f("metalness", 1.0),
                f("specular_roughness", r),
            ]
        },
        0.005,
    ),
    (
        "white metal + coat",
        |r| {
            vec![
                f("base", 1.0),
                c("base_color", WHITE),
                f("metalness", 1.0),
                f("specular_roughness", r),
                f("coat", 1.0),
                f("coat_roughness", r),
            ]
        },
        0.006,
    ),
];

const OPEN_PBR: [Config; 5] = [
    (
        "white diffuse + specular",
        |r| vec![c("base_color", WHITE), f("specular_roughness", r)],
        0.006,
    ),
    (
        "+ coat",
        |r| {
            vec![
                c("base_color", WHITE),
                f("specular_roughness", r),
                f("coat_weight", 1.0),
                f("coat_roughness", r),
            ]
        },
        0.006,
    ),
    (
        "transmission",
        |r| vec![f("transmission_weight", 1.0), f("specular_roughness", r)],
        0.005,
    ),
    (
        "white metal",
        |r| {
            vec![
                c("base_color", WHITE),
                f("base_metalness", 1.0),
                f("specular_roughness", r),
            ]
        },
        0.005,
    ),
    (
        "white metal + coat",
        |r| {
            vec![
                c("base_color", WHITE),
                f("base_metalness", 1.0),
                f("specular_roughness", r),
                f("coat_weight", 1.0),
                f("coat_roughness", r),
            ]
        },
        0.006,
    ),
];

const GLTF: [Config; 4] = [
    (
        "white diffuse + specular",
        |r| {
            vec![
                c("base_color", WHITE),
                f("metallic", 0.0),
                f("roughness", r),
            ]
        },
        0.006,
    ),
    (
        "+ clearcoat",
        |r| {
            vec![
                c("base_color", WHITE),
                f("metallic", 0.0),
                f("roughness", r),
                f("clearcoat", 1.0),
                f("clearcoat_roughness", r),
            ]
        },
        0.006,
    ),
    (
        "+ sheen",
        |r| {
            vec![
                c("base_color", WHITE),
                f("metallic", 0.0),
                f("roughness", r),
                c("sheen_color", WHITE),
                f("sheen_roughness", r),
            ]
        },
        0.006,
    ),
    (
        "+ clearcoat + sheen",
        |r| {
            vec![
                c("base_color", WHITE),
                f("metallic", 0.0),
                f("roughness", r),
                f("clearcoat", 1.0),
                f("clearcoat_roughness", r),
                c("sheen_color", WHITE),
                f("sheen_roughness", r),
            ]
        },
        0.006,
    ),
];

/// Runs the furnace over configurations × roughness × views; every estimate printed, and
/// per configuration the largest mean beyond three standard errors must not exceed 1 by
/// more than its bound. Returns the largest mean of all.
fn layered_furnace(node: &str, configs: &[Config]) -> Option<f64> {
    let lib = lib()?;
    let mut largest: f64 = 0.0;
    for (name, inputs, bound) in configs {
        let mut worst = (f64::MIN, String::new());
        for r in [0.0, 0.25, 0.5, 0.75, 1.0] {
            let est = furnace(lib, &doc(node, &inputs(r)));
            for ((mean, se, albedo), deg) in est.iter().zip(VIEWS) {
                eprintln!(
                    "{node} {name}, roughness {r}, {deg}°: E[weight] = {mean:.4} ± {se:.4} (albedo {albedo:.4})"
                );
                largest = largest.max(*mean);
                let excess = mean - 3.0 * se - 1.0;
                if excess > worst.0 {
                    worst = (
                        excess,
                        format!("roughness {r}, {deg}°: {mean:.4} ± {se:.4}"),
                    );
                }
            }
        }
        eprintln!("{node} {name}: worst {}", worst.1);
        assert!(
            worst.0 <= *bound,
            "{node} {name} gains more than {bound} in a white furnace: {}",
            worst.1
        );
    }
    Some(largest)
}

// The measured excess (README, docs/closures.md): `layer` scales the base by `1 − albedo
// (top)`, and every albedo it subtracts is a table of our own integration of the lobe
// itself (GGX, the exact-Fresnel dielectric, the normalized sheen). What remains is the
// tables' interpolation at grazing views of near-mirror lobes: at most +0.55 % (roughness 0,
// 89.9°), hence 0.006 for every configuration. (Before the dielectric and sheen tables:
// +3.3 % under a coat at roughness 0.25 and 60°, +8.4 % with sheen at roughness 1, 89.9°.)
// Transmission and white metal alone stay within noise of ≤ 1.

#[test]
fn layered_standard_surface_gains_at_most_its_tables_errors_in_a_white_furnace() {
    layered_furnace("standard_surface", &STANDARD);
}

#[test]
fn layered_open_pbr_surface_gains_at_most_its_tables_errors_in_a_white_furnace() {
    layered_furnace("open_pbr_surface", &OPEN_PBR);
}

#[test]
fn layered_gltf_pbr_gains_at_most_its_tables_errors_in_a_white_furnace() {
    layered_furnace("gltf_pbr", &GLTF);
}

/// A material of one pbrlib BSDF node `bsdf` (its inputs in `inputs`, MaterialX syntax).
fn bsdf_doc(bsdf: &str, inputs: &str) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n  <{bsdf} name=\"B\" type=\"BSDF\">{inputs}</{bsdf}>\n  <surface name=\"S\" type=\"surfaceshader\"><input name=\"bsdf\" type=\"BSDF\" nodename=\"B\" /></surface>\n  <surfacematerial name=\"M\" type=\"material\"><input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"S\" /></surfacematerial>\n</materialx>\n"
    )
}

/// The energy single-scattering GGX loses (README): the directional albedo, by Monte Carlo,
/// of a white conductor (a generalized Schlick lobe with every color 1: Fresnel ≡ 1) and of
/// the flux through a clear dielectric of ior 1.5 (`RT`, reflected + transmitted), at
/// normal and 60° views. Both are lossless at roughness 0 and lose more as roughness grows.
#[test]
fn ggx_single_scattering_energy_loss() {
    let Some(lib) = lib() else {
        return;
    };
    let mut table = String::from("| roughness | conductor 0° | 60° | dielectric 0° | 60° |\n");
    let mut prev = [1.0f64 + 1e-3; 4];
    for r in [0.0, 0.25, 0.5, 0.75, 1.0] {
        let rough = format!(
            "<input name=\"roughness\" type=\"vector2\" value=\"{a}, {a}\" />",
            a = r * r
        );
        let conductor = bsdf_doc(
            "generalized_schlick_bsdf",
            &format!(
                "<input name=\"color0\" type=\"color3\" value=\"1, 1, 1\" /><input name=\"color90\" type=\"color3\" value=\"1, 1, 1\" />{rough}"
            ),
        );
        let dielectric = bsdf_doc(
            "dielectric_bsdf",
            &format!(
                "<input name=\"ior\" type=\"float\" value=\"1.5\" /><input name=\"scatter_mode\" type=\"string\" value=\"RT\" />{rough}"
            ),
        );
        let c = furnace(lib, &conductor);
        let d = furnace_with(lib, &dielectric, flux_outputs);
        // VIEWS[0] = 0°, VIEWS[2] = 60°.
        let row = [c[0], c[2], d[0], d[2]];
        table.push_str(&format!(
            "| {r} | {:.3} | {:.3} | {:.3} | {:.3} |\n",
            row[0].0, row[1].0, row[2].0, row[3].0
        ));
        for (k, (mean, se, _)) in row.iter().enumerate() {
            assert!(
                *mean <= 1.0 + 3.0 * se + 1e-3,
                "roughness {r}: albedo {mean} > 1"
            );
            assert!(
                *mean <= prev[k] + 3.0 * se + 1e-3,
                "roughness {r}: albedo {mean} grows with roughness (was {})",
                prev[k]
            );
            if r == 0.0 {
                assert!(
                    (mean - 1.0).abs() < 0.01,
                    "a smooth interface loses nothing: {mean}"
                );
            }
            prev[k] = *mean;
        }
    }
    eprintln!("{table}");
}
