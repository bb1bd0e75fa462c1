//! The GPU back end (`GpuBackend`, `GpuMaterial`) against the interpreter, and the planner.
//!
//! Every program runs through [`Material::shade_many`] under several pass plans — fused
//! (one kernel between host steps), 2, 3 and 6 passes, the cost model with a tiny op budget
//! (nearly one op per pass) and with the default one, and batches smaller than the fragment
//! count — and must match the interpreter (`InterpBackend`, with the same scene): bit for
//! bit for programs of exact ops, within a small relative tolerance where transcendentals
//! are involved; and every plan must give the same bits as the fused one (values cross
//! passes through `sn_tmp` unchanged).
//!
//! Covered: if/else with varying conditions (diverging and agreeing), nested ifs, light loops
//! over point, distant, spot, quad and environment lights (several samples each) with ambient
//! light, a light loop at a point other than `P` (a host step), ifs inside and around light
//! loops, transforms between every pair of spaces, textures, parameters and the prelude (class
//! compilation), component masks, the scene services (trace, occlusion and light visibility
//! through a hashing fake scene), every example network, loops (constant and varying trip
//! counts, nested, with an `if` inside, inside an `if` arm and a light loop, no iteration,
//! every carried type, the iteration limit; host steps inside refused), the fallback, the
//! statistics and the time split. Without a device (naga only): every example network's kernels
//! under every plan, the plan's listing, and the limits.
//!
//! On a hardware GPU (or under `SHADENET_GPU_ACCURACY=hardware`) the comparisons are the
//! hardware contract instead (`shadenet_gpu::testing::hardware::check_outputs`: fragments
//! with subnormal, non-finite or huge inputs left out, every output within 64 ulps or 1e-5
//! relative, at most 5% of the outputs beyond), against the interpreter and the fused plan.
//!
//! Device tests skip (printing why) without an adapter, unless `SHADENET_REQUIRE_GPU=1`.

use shadenet_gpu::plan::{HostKind, ItemKind, Step};
use shadenet_gpu::testing::{accuracy, device_or_skip, hardware};
use shadenet_gpu::{
    Accuracy, GpuBackend, GpuContext, GpuMaterial, GpuOptions, PassMode, Plan, plan,
};
use shadenet_graph::ir::{Program, parse};
use shadenet_graph::nodes::NodeLibrary;
use shadenet_graph::opt::{self, Passes, Specialization};
use shadenet_runtime::testing::HashScene;
use shadenet_runtime::{
    Backend, BackendError, Fragment, InterpBackend, Light, Material, SceneServices, ShadeEnv,
};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

// ---- environment, fragments, scene ----

/// The parity environment (`runtime::testing::parity_env`): six kinds of light, a camera
/// and an object transform.
fn env() -> ShadeEnv {
    shadenet_runtime::testing::parity_env()
}

/// Ordinary fragments: a grid on a bumpy surface with varied normals, incident directions,
/// uv, ray depths and types, and seeds; the count is not a multiple of the workgroup size.
fn fragments(count: usize) -> Vec<Fragment> {
    (0..count)
        .map(|k| {
            let t = k as f32 / count as f32;
            let (s, c) = (t * 37.0).sin_cos();
            let x = (k % 23) as f32 / 11.0 - 1.0;
            let y = (k / 23) as f32 / 7.0 - 1.0;
            let n = [0.3 * s, 0.2 * c, 1.0];
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            Fragment {
                p: [x, y, 0.1 * s],
                n: n.map(|v| v / l),
                ng: [0.0, 0.0, 1.0],
                i: [x - 0.5, y - 0.2, -1.5],
                uv: [t * 3.0 - 1.0, 1.0 - t * 2.0],
                dpdu: [1.0, 0.0, 0.1 * c],
                dpdv: [0.0, 1.0, 0.1 * s],
                dpdx: [0.01, 0.0, 0.0],
                dpdy: [0.0, -0.01, 0.0],
                time: t,
                ray_type: [1, 4, 8, 16][k % 4],
                ray_depth: (k % 3) as i32,
                seed: 7919 * k as u32,
                rand: [t, 1.0 - t, (t * 7.0).fract(), (t * 13.0).fract()],
            }
        })
        .collect()
}

/// Hard floats: zeros of both signs, subnormals, huge, infinite and NaN values.
const HARD: &[f32] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    -2.5,
    3.0,
    1e-45,
    -3e-41,
    f32::MIN_POSITIVE,
    1e30,
    -1e30,
    f32::MAX,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    16777216.0,
];

/// Fragments over every pair of hard floats in (P.x, P.y), hard vectors in N and uv, and
/// extreme ints in ray depth and type.
fn hard_fragments() -> Vec<Fragment> {
    let h = HARD;
    let n = h.len();
    let ints = [0, 1, -1, 7, i32::MAX, i32::MIN];
    let mut v = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let k = |o: usize| h[(i * 7 + j * 3 + o) % n];
            v.push(Fragment {
                p: [h[i], h[j], k(1)],
                n: [h[j], k(2), h[i]],
                ng: [k(3), h[i], h[j]],
                i: [k(4), h[j], h[i]],
                uv: [h[i], h[j]],
                dpdu: [k(5), k(6), k(7)],
                dpdv: [h[j], h[i], k(8)],
                time: k(9),
                ray_type: ints[j % ints.len()],
                ray_depth: ints[i % ints.len()],
                seed: (i * n + j) as u32,
                ..Fragment::default()
            });
        }
    }
    v
}

// ---- running and comparing ----

/// How close the GPU must come to the interpreter.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Tol {
    /// Bit for bit (and the same non-finite count).
    Exact,
    /// Within this relative error (absolute below 1), for transcendentals.
    Rel(f32),
}

/// The plans every program runs under.
fn modes() -> Vec<(&'static str, GpuOptions)> {
    let o = |passes, op_budget, batch, workgroup_size| GpuOptions {
        passes,
        op_budget,
        batch,
        workgroup_size,
    };
    let d = GpuOptions::default();
    vec![
        ("fused", o(PassMode::Fused, d.op_budget, d.batch, 64)),
        ("2 passes", o(PassMode::Count(2), d.op_budget, d.batch, 64)),
        ("3 passes", o(PassMode::Count(3), d.op_budget, d.batch, 32)),
        ("6 passes", o(PassMode::Count(6), d.op_budget, d.batch, 64)),
        ("auto, budget 1", o(PassMode::Auto, 1, d.batch, 64)),
        ("auto, budget 5", o(PassMode::Auto, 5, 97, 16)),
        ("auto, batches of 37", o(PassMode::Auto, d.op_budget, 37, 8)),
    ]
}

fn backend(options: GpuOptions) -> GpuBackend {
    GpuBackend::new(options, Arc::new(InterpBackend))
        .expect("the device opened for device_or_skip")
        .without_fallback()
}

/// Shades every fragment with `m` through `shade_many` (outputs fragment after fragment).
fn shade(
    m: &dyn Material,
    env: &ShadeEnv,
    mask: u32,
    scene: Option<&dyn SceneServices>,
    frags: &[Fragment],
) -> (Vec<f32>, u64, shadenet_runtime::BatchTimes) {
    let mut out = vec![f32::NAN; m.width() * frags.len()];
    let r = shadenet_runtime::shade_many_unpacked(m, env, mask, scene, frags, &mut out);
    (out, r.nonfinite, r.times)
}

fn compile(b: &GpuBackend, what: &str, program: &Program) -> GpuMaterial {
    b.compile_gpu(program, Duration::ZERO)
        .unwrap_or_else(|e| panic!("{what}: {e}\n{program}"))
}

/// Runs `program` under every plan of [`modes`] and checks it against the interpreter (with
/// the same scene) and every plan against the fused one. Returns the fused material's plan.
fn check(
    what: &str,
    program: &Program,
    env: &ShadeEnv,
    mask: u32,
    scene: Option<&dyn SceneServices>,
    frags: &[Fragment],
    tol: Tol,
) -> Plan {
    check_modes(what, program, env, mask, scene, frags, tol, &modes())
}

/// [`check`] under the given plans only (the first one is the reference plan).
#[allow(clippy::too_many_arguments)]
fn check_modes(
    what: &str,
    program: &Program,
    env: &ShadeEnv,
    mask: u32,
    scene: Option<&dyn SceneServices>,
    frags: &[Fragment],
    tol: Tol,
    modes: &[(&str, GpuOptions)],
) -> Plan {
    shadenet_graph::ir::validate(program).unwrap_or_else(|e| panic!("{what}: {e}\n{program}"));
    let reference = InterpBackend
        .compile_program(program, Duration::ZERO)
        .unwrap_or_else(|e| panic!("{what}: interp: {e}"));
    let (want, want_bad, _) = shade(&*reference, env, mask, scene, frags);
    let hw = hardware_contract();
    let mut fused: Option<(Vec<f32>, Plan)> = None;
    for (label, options) in modes {
        let label = *label;
        let m = compile(&backend(options.clone()), what, program);
        assert_eq!(m.layout(), reference.layout(), "{what} ({label}): layout");
        assert_eq!(m.info().backend, "gpu");
        let (got, bad, times) = shade(&m, env, mask, scene, frags);
        assert!(
            !m.device_failed(),
            "{what} ({label}): a batch failed on the device (see stderr)"
        );
        let w = m.width().max(1);
        let batches = frags.len().div_ceil(m.plan().max_batch(samples(env)));
        assert!(
            times.passes as usize <= m.plan().passes() * batches,
            "{what} ({label}): {} passes dispatched for {} planned × {batches} batches",
            times.passes,
            m.plan().passes()
        );
        if hw {
            // The hardware contract (`shadenet_gpu::testing::hardware`), against the
            // interpreter and against the fused plan (the driver contracts each plan's
            // kernels its own way).
            let streams = hardware::streams_read(program);
            let compared = |f: usize| hardware::fragment_in_domain(&frags[f], &streams);
            let r = hardware::check_outputs(&got, &want, w, &compared)
                .unwrap_or_else(|e| panic!("{what} ({label}): hardware contract: {e}"));
            eprintln!("{what} ({label}): hardware contract: {r}");
            if let Some((f, _)) = &fused {
                let r = hardware::check_outputs(&got, f, w, &compared).unwrap_or_else(|e| {
                    panic!("{what} ({label}): against the fused plan: hardware contract: {e}")
                });
                eprintln!("{what} ({label}): against the fused plan: {r}");
            } else {
                fused = Some((got, m.plan().clone()));
            }
            continue;
        }
        for (k, (g, x)) in got.iter().zip(&want).enumerate() {
            let ok = match tol {
                Tol::Exact => same(*g, *x),
                Tol::Rel(r) => same(*g, *x) || (g - x).abs() <= r * x.abs().max(1.0),
            };
            assert!(
                ok,
                "{what} ({label}): fragment {} output float {}: got {g:?} ({:#010x}), want \
                 {x:?} ({:#010x})\nfragment: {:?}\n{}\n{program}",
                k / w,
                k % w,
                g.to_bits(),
                x.to_bits(),
                frags[k / w],
                m.plan()
            );
        }
        if tol == Tol::Exact {
            assert_eq!(bad, want_bad, "{what} ({label}): non-finite count");
        }
        match &fused {
            None => fused = Some((got, m.plan().clone())),
            Some((f, fp)) => {
                for (k, (g, x)) in got.iter().zip(f).enumerate() {
                    assert!(
                        g.to_bits() == x.to_bits(),
                        "{what} ({label}): differs from the fused plan at fragment {} float \
                         {}: {g:?} vs {x:?}\n{}\nfused:\n{fp}",
                        k / w,
                        k % w,
                        m.plan()
                    );
                }
            }
        }
    }
    fused.expect("at least one mode").1
}

/// Whether the shared device is held to the hardware contract
/// ([`shadenet_gpu::Accuracy::Hardware`]) instead of the bit-exact one.
fn hardware_contract() -> bool {
    GpuContext::shared().is_ok_and(|c| accuracy(&c) == Accuracy::Hardware)
}

/// Bit for bit, except that zeros of either sign are equal: the emitter's `sqrt` gives +0
/// for -0 on lavapipe (`select(sqrt(x), 0.0, x < 0.0)` becomes `sqrt(max(x, 0.0))` in
/// Mesa), which is the emitter's business (`tests/emit.rs`), not the planner's. Plans are
/// compared with each other strictly.
fn same(g: f32, x: f32) -> bool {
    g.to_bits() == x.to_bits() || (g == 0.0 && x == 0.0)
}

fn samples(env: &ShadeEnv) -> usize {
    env.lights
        .iter()
        .map(|l| shadenet_runtime::lights::sample_count(l) as usize)
        .sum()
}

/// The inputs every test program reads, as IR text.
const INPUTS: &str = "
  %p = stream P : vec3
  %n = stream N : vec3
  %a = extract %p, 0 : float
  %b = extract %p, 1 : float
  %c = extract %p, 2 : float
  %uv = stream uv : vec2
  %pc = construct %a, %b, %c : color
  %k = stream raydepth : int
  %m = stream raytype : int
  %q = lt %a, %b : bool
  %r = gt %k, %m : bool
";

fn program(name: &str, body: &str, outputs: &str) -> Program {
    let text = format!("program \"{name}\" {{\n{INPUTS}\n{body}\n{outputs}\n}}\n");
    parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

// ---- on the device ----

#[test]
fn conditionals_diverging_agreeing_and_nested() {
    if device_or_skip("conditionals_diverging_agreeing_and_nested").is_none() {
        return;
    }
    let rows = [
        (
            "if diverging",
            "  %x0 = if %q {\n    %t = mul %a, %b : float\n    yield %t\n  } else {\n    %e = sqrt %b : float\n    yield %e\n  }\n  %x = proj %x0, 0 : float",
        ),
        (
            "if on a constant, two results",
            "  %u = const true : bool\n  %x0 = if %u {\n    %t = div %a, %b : float\n    yield %t, %q\n  } else {\n    %e = floor %b : float\n    yield %e, %r\n  }\n  %x1 = proj %x0, 0 : float\n  %x2 = proj %x0, 1 : bool\n  %x3 = convert %x2 : float\n  %x = add %x1, %x3 : float",
        ),
        (
            "if nested, ints and vectors",
            "  %x0 = if %q {\n    %i0 = if %r {\n      %t = mul %a, %a : float\n      %tv = splat %t : vec3\n      yield %tv, %k\n    } else {\n      %t2 = add %p, %n : vec3\n      yield %t2, %m\n    }\n    %y0 = proj %i0, 0 : vec3\n    %y1 = proj %i0, 1 : int\n    yield %y0, %y1\n  } else {\n    %e = normalize %n : vec3\n    %ei = div %k, %m : int\n    yield %e, %ei\n  }\n  %x1 = proj %x0, 0 : vec3\n  %x2 = proj %x0, 1 : int\n  %x3 = convert %x2 : float\n  %x4 = splat %x3 : vec3\n  %x = add %x1, %x4 : vec3",
        ),
        (
            "a value of an arm used later in the arm, an outer value in both",
            "  %o = mul %a, %c : float\n  %x0 = if %r {\n    %t = add %o, %b : float\n    %t2 = mul %t, %t : float\n    %t3 = sub %t2, %o : float\n    %g = gt %t3, %o : bool\n    yield %t3, %g\n  } else {\n    %e = neg %o : float\n    yield %e, %q\n  }\n  %x1 = proj %x0, 0 : float\n  %x2 = proj %x0, 1 : bool\n  %x = select %x2, %x1, %o : float",
        ),
    ];
    for (name, body) in rows {
        let p = program(name, body, "  output r %x\n  output q %q");
        for (label, frags) in [("ordinary", fragments(301)), ("hard", hard_fragments())] {
            check(
                &format!("{name}, {label} fragments"),
                &p,
                &env(),
                u32::MAX,
                None,
                &frags,
                Tol::Exact,
            );
        }
    }
}

#[test]
fn light_loops_and_ambient_light() {
    if device_or_skip("light_loops_and_ambient_light").is_none() {
        return;
    }
    let rows = [
        (
            "illuminance at P with ambient",
            "  %l0 = illuminance %p {\n    %L = light.L : vec3\n    %C = light.Cl : color\n    %d = dot %n, %L : float\n    %z = const 0.0 : float\n    %mx = max %d, %z : float\n    %s = splat %mx : color\n    %y = mul %C, %s : color\n    yield %y, %d\n  }\n  %l1 = proj %l0, 0 : color\n  %l2 = proj %l0, 1 : float\n  %amb = ambient : color\n  %s2 = splat %l2 : color\n  %x3 = add %l1, %amb : color\n  %x = add %x3, %s2 : color",
            Tol::Exact,
        ),
        (
            "if inside illuminance, illuminance at N inside if",
            "  %x0 = if %r {\n    %l0 = illuminance %n {\n      %L = light.L : vec3\n      %C = light.Cl : color\n      %d = dot %p, %L : float\n      %z = const 0.0 : float\n      %g = gt %d, %z : bool\n      %i0 = if %g {\n        %w = pow %d, %b : float\n        %ws = splat %w : color\n        %y = mul %C, %ws : color\n        yield %y\n      } else {\n        %y2 = const (0.0, -0.0, 1.0) : color\n        yield %y2\n      }\n      %yy = proj %i0, 0 : color\n      yield %yy\n    }\n    %l1 = proj %l0, 0 : color\n    yield %l1\n  } else {\n    yield %pc\n  }\n  %x = proj %x0, 0 : color",
            Tol::Rel(2e-5),
        ),
        (
            "two light loops at P and one at a computed point",
            "  %l0 = illuminance %p {\n    %C = light.Cl : color\n    yield %C\n  }\n  %s0 = proj %l0, 0 : color\n  %off = add %p, %n : vec3\n  %l1 = illuminance %off {\n    %L = light.L : vec3\n    %d = dot %L, %n : float\n    yield %d\n  }\n  %s1 = proj %l1, 0 : float\n  %l2 = illuminance %p {\n    %L2 = light.L : vec3\n    %e = extract %L2, 2 : float\n    %ee = mul %e, %s1 : float\n    yield %ee\n  }\n  %s2 = proj %l2, 0 : float\n  %t = add %s1, %s2 : float\n  %ts = splat %t : color\n  %x = add %s0, %ts : color",
            Tol::Exact,
        ),
    ];
    let e = env();
    for (name, body, tol) in rows {
        let p = program(name, body, "  output r %x");
        let plan = check(name, &p, &e, u32::MAX, None, &fragments(150), tol);
        // Without lights, and with only the ambient one, the loops run zero times.
        for lights in [Vec::new(), vec![e.lights[1].desc.clone()]] {
            let none = ShadeEnv {
                lights: lights.iter().map(Light::from_desc).collect(),
                ..e.clone()
            };
            check(
                &format!("{name}, no direct light"),
                &p,
                &none,
                u32::MAX,
                None,
                &fragments(70),
                tol,
            );
        }
        if name.starts_with("two") {
            let sets = &plan.layout.light_sets;
            assert_eq!(sets.len(), 2, "{plan}");
            assert!(sets[0].point.is_none() && sets[1].point.is_some(), "{plan}");
            assert!(plan.steps.iter().any(|s| matches!(
                s,
                Step::Host(h) if matches!(h.kind, HostKind::LightSamples { .. })
            )));
        }
    }
}

#[test]
fn transforms_between_every_pair_of_spaces() {
    if device_or_skip("transforms_between_every_pair_of_spaces").is_none() {
        return;
    }
    let mut body = String::new();
    let mut outs = String::new();
    let mut k = 0;
    for kind in ["point", "vector", "normal"] {
        for from in ["world", "camera", "object"] {
            for to in ["world", "camera", "object"] {
                body.push_str(&format!(
                    "  %t{k} = transform {kind} {from} -> {to} %n : vec3\n"
                ));
                outs.push_str(&format!("  output t{k} %t{k}\n"));
                k += 1;
            }
        }
    }
    let p = program("transforms", &body, &outs);
    check(
        "transforms",
        &p,
        &env(),
        u32::MAX,
        None,
        &fragments(64),
        Tol::Exact,
    );
}

#[test]
fn textures_match_the_interpreter() {
    if device_or_skip("textures_match_the_interpreter").is_none() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("shadenet-gpu-backend-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let a = dir.join("a.png");
    let px: Vec<u8> = vec![
        255, 0, 0, 255, 0, 255, 0, 255, 30, 60, 90, 128, //
        0, 0, 255, 255, 255, 255, 255, 0, 10, 20, 30, 40,
    ];
    image::save_buffer(&a, &px, 3, 2, image::ExtendedColorType::Rgba8).unwrap();
    let b = dir.join("b.png");
    let px: Vec<u8> = (0..5 * 4 * 4).map(|k| (k * 37 % 256) as u8).collect();
    image::save_buffer(&b, &px, 5, 4, image::ExtendedColorType::Rgba8).unwrap();
    let text = format!(
        "program \"tex\" {{\n  texture {:?}\n  texture {:?}\n  %uv = stream uv : vec2\n  \
         %t = texture #0 %uv : color\n  %a = texture.alpha #0 %uv : float\n  \
         %u = texture #1 %uv : color\n  %s = splat %a : color\n  %x = mul %u, %s : color\n  \
         output c %t\n  output a %a\n  output x %x\n}}\n",
        a.to_string_lossy(),
        b.to_string_lossy()
    );
    let p = parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    check(
        "textures",
        &p,
        &env(),
        u32::MAX,
        None,
        &fragments(211),
        Tol::Exact,
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn parameters_prelude_and_component_masks() {
    if device_or_skip("parameters_prelude_and_component_masks").is_none() {
        return;
    }
    let text = r#"program "uniforms" {
  components diffuse specular
  param "k" float = 2.5
  param "c" color = (0.25, -0.0, 1e-40)
  param "on" bool = true
  param "n" int = -3
  param "m" matrix44 = (2.0, -1.0, 0.5, 3.0, 0.0, 1e-30, -0.0, 1e30, 1.5, 2.5, -3.5, 0.25, 0.0, 0.0, 0.0, 1.0)
  prelude {
    %k = param 0 : float
    %c3 = const 3.0 : float
    %kk = mul %k, %c3 : float
    %ks = splat %kk : color
    %cc = param 1 : color
    %pre = add %ks, %cc : color
    %on = param 2 : bool
    %ni = param 3 : int
  }
  %p = stream P : vec3
  %a = extract %p, 0 : float
  %ac = splat %a : color
  %d = component_enabled diffuse : bool
  %s = component_enabled specular : bool
  %x0 = select %d, %pre, %ac : color
  %x1 = select %s, %ac, %x0 : color
  %x2 = select %on, %x1, %x0 : color
  %nf = convert %ni : float
  %x3 = mul %nf, %a : float
  %mm = param 4 : matrix44
  %mp = mulpoint %mm, %p : vec3
  %i0 = if %s {
    %y = mul %x3, %x3 : float
    yield %y
  } else {
    yield %a
  }
  %x4 = proj %i0, 0 : float
  output out[diffuse] %x1
  output out[specular] %x2
  output extra %x3
  output flag %on
  output count %ni
  output mp %mp
  output guarded %x4
  output const %c3
}
"#;
    let p = parse(text).unwrap();
    for mask in [u32::MAX, 0, 1, 2] {
        check(
            &format!("uniforms, mask {mask}"),
            &p,
            &env(),
            mask,
            None,
            &fragments(90),
            Tol::Exact,
        );
    }
    // A guard the host can evaluate: with the component off, its pass is not dispatched.
    let b = backend(GpuOptions {
        passes: PassMode::Auto,
        op_budget: 1,
        ..GpuOptions::default()
    });
    let m = compile(&b, "uniforms", &p);
    let frags = fragments(10);
    let on = shade(&m, &env(), u32::MAX, None, &frags).2.passes;
    let off = shade(&m, &env(), 1, None, &frags).2.passes;
    assert!(
        off < on,
        "{off} passes with specular off, {on} on\n{}",
        m.plan()
    );
}

#[test]
fn scene_services_match_the_interpreter() {
    if device_or_skip("scene_services_match_the_interpreter").is_none() {
        return;
    }
    let p = parse(
        r#"program "ops" {
  %p = stream P : vec3
  %n = stream N : vec3
  %i = stream I : vec3
  %k = stream raydepth : int
  %x = extract %p, 0 : float
  %t = trace reflection %i : color
  %u = trace diffuse %n : color
  %o = occlusion %n, %k, %x : float
  %tt = add %t, %u : color
  %d = add %i, %n : vec3
  %g = gt %o, %x : bool
  %z = if %g {
    %w = trace refraction %d : color
    %w2 = mul %w, %tt : color
    yield %w2
  } else {
    yield %t
  }
  %zz = proj %z, 0 : color
  %l = illuminance %p {
    %v = light.visible : float
    %c = light.Cl : color
    %b = gt %v, %x : bool
    %r = if %b {
      %w0 = light.visible : float
      %w1 = splat %w0 : color
      %s = mul %c, %w1 : color
      yield %s
    } else {
      yield %c
    }
    %s1 = proj %r, 0 : color
    yield %v, %s1
  }
  %vis = proj %l, 0 : float
  %cl = proj %l, 1 : color
  %m = illuminance %n {
    %c2 = light.Cl : color
    %v2 = light.visible : float
    %v3 = splat %v2 : color
    %c3 = mul %c2, %v3 : color
    yield %c3
  }
  %cl2 = proj %m, 0 : color
  output t %t
  output u %u
  output o %o
  output z %zz
  output vis %vis
  output cl %cl
  output cl2 %cl2
}
"#,
    )
    .unwrap();
    let e = env();
    let scene = HashScene::new(hardware_contract());
    let mut frags = fragments(120);
    frags.extend(hard_fragments().into_iter().step_by(5));
    let plan = check(
        "scene ops",
        &p,
        &e,
        u32::MAX,
        Some(&scene),
        &frags,
        Tol::Exact,
    );
    assert!(scene.calls() > 0);
    let hosts = plan.host_steps();
    assert_eq!(hosts, 5, "3 traces, 1 occlusion, 1 light set at N\n{plan}");
    // Without a scene: black traces, occlusion 1, every light visible.
    check(
        "scene ops, no scene",
        &p,
        &e,
        u32::MAX,
        None,
        &frags,
        Tol::Exact,
    );
    let (o, _) = opt::run(&p, &Specialization::default());
    check(
        "scene ops (optimized)",
        &o,
        &e,
        u32::MAX,
        Some(&scene),
        &frags,
        Tol::Exact,
    );
}

/// Host steps ask each fragment's own services (`SceneServices::fragment`, the tracer's
/// per-hit state) for its traces, occlusion and light visibility, in every batch of a call
/// (fragment `i` of the third batch is fragment `2 × batch + i` of the call).
#[test]
fn host_steps_ask_each_fragment_for_its_own_services() {
    if device_or_skip("host_steps_ask_each_fragment_for_its_own_services").is_none() {
        return;
    }
    let p = program(
        "per-fragment services",
        "  %ii = stream I : vec3\n  %t = trace reflection %ii : color\n  \
         %ns = const 4 : int\n  %md = const 2.0 : float\n  %o = occlusion %n, %ns, %md : float\n  %l = illuminance %p {\n    \
         %v = light.visible : float\n    yield %v\n  }\n  %vis = proj %l, 0 : float",
        "  output t %t\n  output o %o\n  output vis %vis",
    );
    let e = env();
    let frags = fragments(100);
    let scene = shadenet_runtime::testing::TaggedScene::with_fragments(frags.len());
    let options = GpuOptions {
        batch: 37,
        ..GpuOptions::default()
    };
    let m = compile(&backend(options.clone()), "per-fragment services", &p);
    let (got, _, _) = shade(&m, &e, u32::MAX, Some(&scene), &frags);
    let w = m.width();
    for (i, row) in got.chunks(w).enumerate() {
        assert_eq!(row[..3], [i as f32, 0.5, 0.25], "fragment {i}: trace");
        assert_eq!(row[3], i as f32 / 1000.0, "fragment {i}: occlusion");
    }
    // The batch's own services see every light occluded; fragments 0 and 2 see theirs.
    assert!(
        got[4] > 0.0 && got[2 * w + 4] > 0.0,
        "visibility: {:?}",
        &got[..3 * w]
    );
    // Visibility too: the interpreter asks each fragment's services as well.
    check_modes(
        "per-fragment services",
        &p,
        &e,
        u32::MAX,
        Some(&scene),
        &frags,
        Tol::Exact,
        &[("batches of 37", options)],
    );
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Every example network and scene material, with its name.
fn examples() -> Vec<(String, shadenet_graph::Compiled)> {
    let mut out = Vec::new();
    for dir in ["examples/networks", "examples/scenes/materials"] {
        let mut paths: Vec<PathBuf> = std::fs::read_dir(root().join(dir))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "json"))
            .collect();
        paths.sort();
        for path in paths {
            let src = std::fs::read_to_string(&path).unwrap();
            let mut c = shadenet_graph::compile_json(&src, &NodeLibrary::standard())
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let name = path.file_stem().unwrap().to_string_lossy().into_owned();
            c.program.name = name.clone();
            c.program.resolve_textures(path.parent().unwrap());
            out.push((name, c));
        }
    }
    out
}

fn specializations() -> Vec<(&'static str, Specialization)> {
    vec![
        ("default", Specialization::default()),
        (
            "no cse",
            Specialization {
                passes: Passes {
                    cse: false,
                    ..Passes::default()
                },
                ..Specialization::default()
            },
        ),
        (
            "class",
            Specialization {
                bake: false,
                ..Specialization::default()
            },
        ),
        (
            "first component",
            Specialization {
                components: 1,
                ..Specialization::default()
            },
        ),
    ]
}

/// Every example network and scene material with a scene: the default specialization fused,
/// in 3 passes and by the cost model with a tiny budget and small batches; class
/// compilation, one component and unoptimized fused (the planner-only test below runs every
/// plan of every specialization through naga).
#[test]
fn every_example_network_matches_the_interpreter() {
    if device_or_skip("every_example_network_matches_the_interpreter").is_none() {
        return;
    }
    let frags = fragments(23 * 17);
    let scene = HashScene::new(hardware_contract());
    let all = modes();
    let some: Vec<(&str, GpuOptions)> = all
        .into_iter()
        .filter(|(l, _)| ["fused", "3 passes", "auto, budget 5"].contains(l))
        .collect();
    for (name, c) in examples() {
        let mut e = env();
        e.lights
            .extend(c.lights.iter().map(Light::from_desc).collect::<Vec<_>>());
        let mut runs: Vec<(String, Program, u32)> = specializations()
            .into_iter()
            .filter(|(l, _)| *l != "no cse")
            .map(|(l, spec)| {
                (
                    l.to_string(),
                    opt::run(&c.program, &spec).0,
                    spec.components,
                )
            })
            .collect();
        runs.push(("unoptimized".into(), c.program.clone(), u32::MAX));
        for (label, p, mask) in runs {
            if std::env::var("SN_TRACE").is_ok() {
                eprintln!("{name} ({label}) at {:?}", std::time::SystemTime::now());
            }
            // Every plan for the default specialization, the fused one for the others.
            let modes = if label == "default" {
                &some[..]
            } else {
                &some[..1]
            };
            check_modes(
                &format!("{name} ({label})"),
                &p,
                &e,
                mask,
                Some(&scene),
                &frags,
                Tol::Rel(1e-4),
                modes,
            );
        }
    }
}

#[test]
fn fallback_statistics_and_times() {
    let Some(ctx) = device_or_skip("fallback_statistics_and_times") else {
        return;
    };
    // A trace inside a light loop cannot run on the GPU: the interpreter stands in.
    let p = program(
        "trace in a light loop",
        "  %l = illuminance %p {\n    %L = light.L : vec3\n    %t = trace reflection %L : color\n    yield %t\n  }\n  %x = proj %l, 0 : color",
        "  output r %x",
    );
    let strict = backend(GpuOptions::default());
    match strict.compile_gpu(&p, Duration::ZERO) {
        Err(BackendError::Unsupported { backend, op, .. }) => {
            assert_eq!(backend, "gpu");
            assert!(op.contains("trace"), "{op}");
        }
        Err(e) => panic!("expected Unsupported, got {e}"),
        Ok(_) => panic!("expected Unsupported"),
    }
    let lenient = GpuBackend::new(GpuOptions::default(), Arc::new(InterpBackend)).unwrap();
    let m = lenient.compile_program(&p, Duration::ZERO).unwrap();
    assert_eq!(m.info().backend, "interp");
    assert!(
        m.info()
            .fallback
            .as_deref()
            .is_some_and(|w| w.contains("trace")),
        "{:?}",
        m.info().fallback
    );

    // Statistics and the time split of a real material.
    let (name, c) = examples()
        .into_iter()
        .find(|(n, _)| n == "marble")
        .expect("marble example");
    let (o, _) = opt::run(&c.program, &Specialization::default());
    let b = backend(GpuOptions {
        batch: 1000,
        ..GpuOptions::default()
    });
    let m = compile(&b, &name, &o);
    let s = m.info().stats;
    assert_eq!(m.info().backend, "gpu");
    assert!(m.info().fallback.is_none());
    assert!(
        s.ir_insts > 0 && s.code_bytes > 0 && s.ops == o.op_count(),
        "{s}"
    );
    assert_eq!(s.ir_insts, m.plan().wgsl_lines());
    let frags = fragments(2500);
    let (_, _, t) = shade(&m, &env(), u32::MAX, None, &frags);
    assert_eq!(t.passes as usize, 3 * m.plan().passes(), "{t:?}");
    assert!(
        t.kernels > Duration::ZERO && t.readback > Duration::ZERO,
        "{t:?}"
    );
    assert!(t.total() >= t.kernels);
    // Single fragments go to the companion.
    let ctx_env = env();
    let mut one = vec![0.0; m.width()];
    let mut want = vec![0.0; m.width()];
    let f = frags[17];
    m.shade(&shadenet_runtime::ShadeCtx::new(f, &ctx_env), &mut one);
    m.companion()
        .shade(&shadenet_runtime::ShadeCtx::new(f, &ctx_env), &mut want);
    assert_eq!(one, want);
    // The limits of the device shape the batch.
    assert!(m.plan().max_batch(0) <= 1000);
    assert_eq!(
        m.plan().binding_size,
        ctx.limits
            .max_storage_buffer_binding_size
            .min(ctx.limits.max_buffer_size)
    );
}

// ---- without a device ----

#[test]
fn every_example_network_plans_and_validates_without_a_device() {
    let limits = wgpu::Limits::default();
    let mut lines = Vec::new();
    for (name, c) in examples() {
        for (label, spec) in specializations() {
            let (p, _) = opt::run(&c.program, &spec);
            let mut fused_ops = None;
            for (mode, options) in modes() {
                let what = format!("{name} ({label}, {mode})");
                let pl = plan(&p, &options, &limits).unwrap_or_else(|e| panic!("{what}: {e}"));
                assert!(!pl.kernels().is_empty(), "{what}: no kernel\n{pl}");
                for k in pl.kernels() {
                    assert!(k.wgsl.contains("@compute"), "{what}");
                    shadenet_gpu::kernel::validate(k.wgsl)
                        .unwrap_or_else(|e| panic!("{what}: pass {}: {e}", k.pass));
                }
                // Every plan computes the same ops.
                let ops = pl.ops();
                assert_eq!(*fused_ops.get_or_insert(ops), ops, "{what}\n{pl}");
                if let PassMode::Count(n) = options.passes {
                    let runs = pl.host_steps() + 1;
                    assert!(
                        pl.passes() <= (n as usize).max(runs),
                        "{what}: {} passes for {n} asked\n{pl}",
                        pl.passes()
                    );
                }
                if label == "default" && (mode == "fused" || mode == "auto, budget 5") {
                    lines.push(format!(
                        "{name} ({mode}): {} passes, {} host steps, {} ops, sn_tmp {} columns \
                         ({} without reuse)",
                        pl.passes(),
                        pl.host_steps(),
                        ops,
                        pl.layout.tmp_columns,
                        pl.layout.tmp_columns_no_reuse
                    ));
                }
            }
        }
    }
    println!("{}", lines.join("\n"));
}

#[test]
fn the_plan_listing_names_passes_host_steps_and_columns() {
    let p = program(
        "listing",
        "  %s = mul %a, %b : float\n  %x0 = if %q {\n    %t = trace reflection %n : color\n    %y = mul %t, %pc : color\n    yield %y, %t\n  } else {\n    yield %pc, %pc\n  }\n  %x = proj %x0, 0 : color\n  %t2 = proj %x0, 1 : color\n  %ss = splat %s : color\n  %z = add %x, %ss : color",
        "  output r %z\n  output t %t2",
    );
    let options = GpuOptions {
        passes: PassMode::Count(3),
        ..GpuOptions::default()
    };
    let pl = plan(&p, &options, &wgpu::Limits::default()).unwrap();
    let text = pl.to_string();
    for want in [
        "gpu plan of `listing`",
        "host (step",
        "trace %",
        "pass 0 (step 0)",
        "guard %",
        "sn_tmp:",
        "without reuse",
        "fragments per batch",
        "WGSL lines",
        "outputs r@0 t@3",
    ] {
        assert!(text.contains(want), "missing {want:?} in\n{text}");
    }
    assert_eq!(pl.host_steps(), 1, "{text}");
    assert!(pl.passes() >= 2, "{text}");
    // The trace's result crosses the host step; %s crosses into a later pass.
    let Some(Step::Host(h)) = pl.steps.iter().find(|s| matches!(s, Step::Host(_))) else {
        panic!("{text}");
    };
    let HostKind::Trace(t) = h.kind else {
        panic!("{text}")
    };
    assert!(pl.layout.tmp[t.index()].is_some(), "{text}");
    // The arm's items carry the guard.
    let guarded = pl.steps.iter().any(|s| match s {
        Step::Pass(ps) => ps
            .items
            .iter()
            .any(|i| !i.guard.is_empty() && matches!(i.kind, ItemKind::Value(_))),
        Step::Host(_) => false,
    });
    assert!(guarded, "{text}");
    // The WGSL of every kernel names the material and pass.
    assert!(pl.wgsl().contains("material `listing`, pass 0"));
}

#[test]
fn tmp_columns_are_reused_once_live_ranges_end() {
    // A chain of values each used only by the next one: with one op per pass every value
    // crosses one boundary, and one column suffices for all of them.
    let mut body = String::from("  %v0 = mul %a, %b : float\n");
    for k in 1..12 {
        body.push_str(&format!("  %v{k} = add %v{}, %c : float\n", k - 1));
    }
    let p = program("chain", &body, "  output r %v11");
    let options = GpuOptions {
        passes: PassMode::Auto,
        op_budget: 1,
        ..GpuOptions::default()
    };
    let pl = plan(&p, &options, &wgpu::Limits::default()).unwrap();
    assert!(pl.passes() >= 12, "{pl}");
    // %a, %b, %c cross many passes; the chain needs one column at a time.
    assert!(pl.layout.tmp_columns <= 4, "{pl}");
    assert!(pl.layout.tmp_columns_no_reuse >= 11, "{pl}");
    // Fused: nothing crosses.
    let f = plan(
        &p,
        &GpuOptions {
            passes: PassMode::Fused,
            ..GpuOptions::default()
        },
        &wgpu::Limits::default(),
    )
    .unwrap();
    assert_eq!((f.passes(), f.layout.tmp_columns), (1, 0), "{f}");
}

#[test]
fn limits_shape_batches_and_reject_what_does_not_fit() {
    let p = program(
        "limits",
        "  %x = mul %a, %b : float",
        "  output r %x\n  output p %p",
    );
    let mut limits = wgpu::Limits {
        max_storage_buffer_binding_size: 4 * 8 * 1000,
        ..wgpu::Limits::default()
    };
    let pl = plan(&p, &GpuOptions::default(), &limits).unwrap();
    // sn_frag is the widest buffer (the streams of INPUTS and the seed).
    let widest = pl.layout.frag_columns.max(pl.layout.out_columns) as u64;
    assert_eq!(pl.max_batch(0) as u64, 32000 / (4 * widest), "{pl}");
    // Light samples take 7 columns each, in sn_light.
    assert_eq!(pl.max_batch(10), pl.max_batch(0), "no light loop: {pl}");
    limits.max_storage_buffers_per_shader_stage = 3;
    match plan(&p, &GpuOptions::default(), &limits) {
        Err(BackendError::Unsupported { reason, .. }) => {
            assert!(reason.contains("storage buffers"), "{reason}")
        }
        other => panic!("expected Unsupported, got {other:?}"),
    }
    let bad = GpuOptions {
        workgroup_size: 0,
        ..GpuOptions::default()
    };
    assert!(plan(&p, &bad, &wgpu::Limits::default()).is_err());
}

/// The material keeps its device buffers, read-back buffer and host vectors between batches
/// and calls: calls of growing, shrinking and odd sizes on one material (a light loop, a
/// guarded branch and the light samples' host vectors), each against the interpreter —
/// stale values of a larger earlier batch must not leak into a smaller one.
#[test]
fn kept_buffers_serve_calls_of_any_size() {
    if device_or_skip("kept_buffers_serve_calls_of_any_size").is_none() {
        return;
    }
    let p = program(
        "kept buffers",
        "  %z = const 0.0 : float\n  %pos = gt %a, %z : bool\n  %kk = if %pos {\n    %s = sqrt %a : float\n    yield %s\n  } else {\n    %mm = mul %b, %c : float\n    yield %mm\n  }\n  %v = proj %kk, 0 : float\n  %l = illuminance %p {\n    %L = light.L : vec3\n    %d = dot %n, %L : float\n    yield %d\n  }\n  %w = proj %l, 0 : float",
        "  output r %v\n  output q %w",
    );
    let reference = InterpBackend.compile_program(&p, Duration::ZERO).unwrap();
    let m = compile(
        &backend(GpuOptions {
            batch: 1000,
            ..GpuOptions::default()
        }),
        "kept buffers",
        &p,
    );
    let env = env();
    let all = fragments(3100);
    let hw = hardware_contract();
    let streams = hardware::streams_read(&p);
    for (k, n) in [2500usize, 7, 3100, 1, 999, 1001].into_iter().enumerate() {
        // A different slice each call: a stale value would show.
        let frags: Vec<Fragment> = all.iter().cycle().skip(k * 131).take(n).copied().collect();
        let (want, want_bad, _) = shade(&*reference, &env, u32::MAX, None, &frags);
        let (got, bad, _) = shade(&m, &env, u32::MAX, None, &frags);
        assert!(!m.device_failed(), "call {k} ({n} fragments) failed");
        if hw {
            let compared = |f: usize| hardware::fragment_in_domain(&frags[f], &streams);
            hardware::check_outputs(&got, &want, m.width(), &compared)
                .unwrap_or_else(|e| panic!("call {k} ({n} fragments): {e}"));
            continue;
        }
        for (i, (g, x)) in got.iter().zip(&want).enumerate() {
            assert!(
                same(*g, *x),
                "call {k} ({n} fragments): float {i}: got {g:?}, want {x:?}"
            );
        }
        assert_eq!(bad, want_bad, "call {k}: non-finite count");
    }
}

// ---- loops ----

/// Loop programs (`Op::Loop`, mostly the rows of `tests/backends.rs`' `loops`) as (name,
/// body, tolerance); each defines `%x`.
const LOOPS: &[(&str, &str, Tol)] = &[
    (
        "loop, constant trip count",
        "  %i0 = const 0 : int\n  %s0 = const 0.0 : float\n  %l = loop %i0, %s0 while {\n    %ci = loop.var 0 : int\n    %ten = const 10 : int\n    %cc = lt %ci, %ten : bool\n    yield %cc\n  } do {\n    %bi = loop.var 0 : int\n    %bs = loop.var 1 : float\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    %fi = convert %bi : float\n    %t = mul %fi, %a : float\n    %t2 = add %t, %b : float\n    %bs1 = add %bs, %t2 : float\n    yield %bi1, %bs1\n  }\n  %x = proj %l, 1 : float",
        Tol::Exact,
    ),
    (
        "loop, varying trip count",
        "  %x0 = const 0.0 : float\n  %n0 = const 0 : int\n  %l = loop %x0, %n0 while {\n    %cx = loop.var 0 : float\n    %twenty = const 20.0 : float\n    %lim = mul %b, %twenty : float\n    %cc = lt %cx, %lim : bool\n    yield %cc\n  } do {\n    %bx = loop.var 0 : float\n    %bn = loop.var 1 : int\n    %one = const 1.0 : float\n    %ab = abs %a : float\n    %st = add %one, %ab : float\n    %bx1 = add %bx, %st : float\n    %ione = const 1 : int\n    %bn1 = add %bn, %ione : int\n    yield %bx1, %bn1\n  }\n  %lx = proj %l, 0 : float\n  %ln = proj %l, 1 : int\n  %lnf = convert %ln : float\n  %x = construct %lx, %lnf : vec2",
        Tol::Exact,
    ),
    (
        "loop, nested (the inner trip count depends on the outer carried value)",
        "  %o0 = const 0 : int\n  %c0 = const (0.0, 0.0, 0.0) : color\n  %lo = loop %o0, %c0 while {\n    %oi = loop.var 0 : int\n    %four = const 4 : int\n    %oc = lt %oi, %four : bool\n    yield %oc\n  } do {\n    %oi2 = loop.var 0 : int\n    %oacc = loop.var 1 : color\n    %j0 = const 0 : int\n    %li = loop %j0, %oacc while {\n      %ij = loop.var 0 : int\n      %qi = convert %q : int\n      %lim2 = add %oi2, %qi : int\n      %ic = lt %ij, %lim2 : bool\n      yield %ic\n    } do {\n      %ij2 = loop.var 0 : int\n      %iacc = loop.var 1 : color\n      %half = const 0.5 : float\n      %hs = splat %half : color\n      %sc = mul %iacc, %hs : color\n      %jf = convert %ij2 : float\n      %js = splat %jf : color\n      %pj = mul %pc, %js : color\n      %na = add %sc, %pj : color\n      %ione = const 1 : int\n      %ij3 = add %ij2, %ione : int\n      yield %ij3, %na\n    }\n    %inner = proj %li, 1 : color\n    %oone = const 1 : int\n    %oi3 = add %oi2, %oone : int\n    yield %oi3, %inner\n  }\n  %x = proj %lo, 1 : color",
        Tol::Exact,
    ),
    (
        "loop, if inside the body",
        "  %i0 = const 0 : int\n  %v0 = const (0.0, 0.0, 0.0) : vec3\n  %l = loop %i0, %v0 while {\n    %ci = loop.var 0 : int\n    %sev = const 7 : int\n    %lim = mod %m, %sev : int\n    %cc = lt %ci, %lim : bool\n    yield %cc\n  } do {\n    %bi = loop.var 0 : int\n    %bv = loop.var 1 : vec3\n    %two = const 2 : int\n    %par = mod %bi, %two : int\n    %zero = const 0 : int\n    %even = eq %par, %zero : bool\n    %e = and %even, %q : bool\n    %r0 = if %e {\n      %t = add %bv, %p : vec3\n      yield %t\n    } else {\n      %u = cross %bv, %n : vec3\n      %u2 = sub %u, %n : vec3\n      yield %u2\n    }\n    %nv = proj %r0, 0 : vec3\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    yield %bi1, %nv\n  }\n  %x = proj %l, 1 : vec3",
        Tol::Exact,
    ),
    (
        "loop inside an if arm",
        "  %x0 = if %q {\n    %i0 = const 0 : int\n    %l = loop %i0, %a while {\n      %ci = loop.var 0 : int\n      %five = const 5 : int\n      %lim = mod %m, %five : int\n      %cc = lt %ci, %lim : bool\n      yield %cc\n    } do {\n      %bi = loop.var 0 : int\n      %bs = loop.var 1 : float\n      %one = const 1 : int\n      %bi1 = add %bi, %one : int\n      %t = mul %bs, %a : float\n      %t2 = add %t, %b : float\n      yield %bi1, %t2\n    }\n    %y = proj %l, 1 : float\n    yield %y\n  } else {\n    yield %b\n  }\n  %x = proj %x0, 0 : float",
        Tol::Exact,
    ),
    (
        "loop, no iteration",
        "  %l = loop %a, %p while {\n    %za = loop.var 0 : float\n    %zc = lt %za, %za : bool\n    yield %zc\n  } do {\n    %zb = loop.var 0 : float\n    %zp = loop.var 1 : vec3\n    %z2 = add %zb, %zb : float\n    %zq = add %zp, %n : vec3\n    yield %z2, %zq\n  }\n  %l2 = loop while {\n    %f = const false : bool\n    yield %f\n  } do {\n    yield\n  }\n  %x1 = proj %l, 0 : float\n  %xv = proj %l, 1 : vec3\n  %x2 = extract %xv, 1 : float\n  %x = add %x1, %x2 : float",
        Tol::Exact,
    ),
    (
        "loop, every carried type (the bool flips each turn, the int wraps)",
        "  %i0 = const 0 : int\n  %p4 = construct %a, %b, %c, %a : vec4\n  %l = loop %i0, %p, %pc, %k, %q, %uv, %p4 while {\n    %ci = loop.var 0 : int\n    %cb = loop.var 4 : bool\n    %three = const 3 : int\n    %lt3 = lt %ci, %three : bool\n    %six = const 6 : int\n    %lt6 = lt %ci, %six : bool\n    %more = and %lt6, %cb : bool\n    %cc = or %lt3, %more : bool\n    yield %cc\n  } do {\n    %bi = loop.var 0 : int\n    %bv = loop.var 1 : vec3\n    %bc = loop.var 2 : color\n    %bk = loop.var 3 : int\n    %bq = loop.var 4 : bool\n    %bu = loop.var 5 : vec2\n    %b4 = loop.var 6 : vec4\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    %bv1 = mul %bv, %n : vec3\n    %bc1 = sub %bc, %pc : color\n    %kk = const 3 : int\n    %bk0 = mul %bk, %kk : int\n    %bk1 = add %bk0, %one : int\n    %bq1 = not %bq : bool\n    %bu1 = add %bu, %uv : vec2\n    %b41 = mul %b4, %p4 : vec4\n    yield %bi1, %bv1, %bc1, %bk1, %bq1, %bu1, %b41\n  }\n  %r0 = proj %l, 0 : int\n  %r1 = proj %l, 1 : vec3\n  %r2 = proj %l, 2 : color\n  %r3 = proj %l, 3 : int\n  %r4 = proj %l, 4 : bool\n  %r5 = proj %l, 5 : vec2\n  %r6 = proj %l, 6 : vec4\n  %f0 = convert %r0 : float\n  %f3 = convert %r3 : float\n  %f4 = convert %r4 : float\n  %e1 = dot %r1, %r1 : float\n  %e2 = extract %r2, 1 : float\n  %e5 = extract %r5, 0 : float\n  %e6 = extract %r6, 3 : float\n  %s1 = add %f0, %f3 : float\n  %s2 = add %s1, %f4 : float\n  %s3 = add %s2, %e1 : float\n  %s4 = add %s3, %e2 : float\n  %s5 = add %s4, %e5 : float\n  %x = add %s5, %e6 : float",
        Tol::Exact,
    ),
    (
        "loop that never ends (stops at the iteration limit)",
        "  %l = loop %a while {\n    %t = const true : bool\n    yield %t\n  } do {\n    %v = loop.var 0 : float\n    %v1 = add %v, %b : float\n    yield %v1\n  }\n  %x = proj %l, 0 : float",
        Tol::Exact,
    ),
    (
        "loop that never ends, inside a loop of varying trip count",
        "  %i0 = const 0 : int\n  %z = const 0.0 : float\n  %l = loop %i0, %z while {\n    %ci = loop.var 0 : int\n    %four = const 4 : int\n    %lim = mod %m, %four : int\n    %cc = lt %ci, %lim : bool\n    yield %cc\n  } do {\n    %bi = loop.var 0 : int\n    %bs = loop.var 1 : float\n    %li = loop %bs while {\n      %t = const true : bool\n      yield %t\n    } do {\n      %v = loop.var 0 : float\n      %v1 = add %v, %a : float\n      yield %v1\n    }\n    %iv = proj %li, 0 : float\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    yield %bi1, %iv\n  }\n  %x = proj %l, 1 : float",
        Tol::Exact,
    ),
    (
        "loop inside a light loop",
        "  %l0 = illuminance %p {\n    %L = light.L : vec3\n    %C = light.Cl : color\n    %d = dot %n, %L : float\n    %s0 = const 0.0 : float\n    %w0 = abs %d : float\n    %lp = loop %s0, %w0 while {\n      %lw = loop.var 1 : float\n      %eps = const 0.01 : float\n      %gc = gt %lw, %eps : bool\n      yield %gc\n    } do {\n      %ls = loop.var 0 : float\n      %lw2 = loop.var 1 : float\n      %lsn = add %ls, %lw2 : float\n      %hf = const 0.5 : float\n      %lwn = mul %lw2, %hf : float\n      yield %lsn, %lwn\n    }\n    %ss = proj %lp, 0 : float\n    %sc = splat %ss : color\n    %y = mul %C, %sc : color\n    yield %y\n  }\n  %x = proj %l0, 0 : color",
        Tol::Exact,
    ),
];

/// A value computed before a loop and read inside it, a loop result read by later values
/// (so that plans of several passes cut around the loop item).
const LOOP_AROUND: &str = "  %o = mul %a, %c : float\n  %l = loop %o, %k while {\n    %cv = loop.var 1 : int\n    %z = const 3 : int\n    %cc = lt %cv, %z : bool\n    yield %cc\n  } do {\n    %bv = loop.var 0 : float\n    %bk = loop.var 1 : int\n    %w = mul %bv, %o : float\n    %w2 = add %w, %b : float\n    %one = const 1 : int\n    %bk1 = add %bk, %one : int\n    yield %w2, %bk1\n  }\n  %l0 = proj %l, 0 : float\n  %l1 = proj %l, 1 : int\n  %lf = convert %l1 : float\n  %y = mul %l0, %lf : float\n  %x = sub %y, %o : float";

/// The fragments on which the interpreter stops a loop nest at its budget
/// (`LOOP_ITERATION_LIMIT` body runs), by index.
fn interp_stops(p: &Program, env: &ShadeEnv, frags: &[Fragment]) -> Vec<usize> {
    let m = InterpBackend.compile_program(p, Duration::ZERO).unwrap();
    let mut out = vec![0.0; m.width()];
    let mut stopped = Vec::new();
    for (k, f) in frags.iter().enumerate() {
        let before = m.loop_limits();
        m.shade(&shadenet_runtime::ShadeCtx::new(*f, env), &mut out);
        if m.loop_limits() > before {
            stopped.push(k);
        }
    }
    stopped
}

/// Loops run on the GPU, whole in one kernel item, as the interpreter runs them: bit for
/// bit under every plan, as written (a loop) and optimized (the `unroll` pass may unroll
/// constant trip counts), on ordinary and hard fragments.
///
/// Fragments whose loop nest runs out of its budget (65 536 body runs) are compared on a
/// hardware adapter only: llvmpipe (lavapipe) stops every shader after 65 535 loop
/// iterations of all its loops together (`LP_MAX_TGSI_LOOP_ITERATIONS`, Mesa's
/// `lp_bld_limits.h`), one short of the budget, so there it gives the values of 65 535 body
/// runs (measured: 65535.0 for 65536.0); the test prints how many such fragments differ.
#[test]
fn loops_match_the_interpreter() {
    let Some(ctx) = device_or_skip("loops_match_the_interpreter") else {
        return;
    };
    let capped = ctx.info.is_software();
    let rows = LOOPS
        .iter()
        .copied()
        .chain([("values around a loop", LOOP_AROUND, Tol::Exact)]);
    for (name, body, tol) in rows {
        let p = program(name, body, "  output r %x\n  output q %q");
        let (o, _) = opt::run(&p, &Specialization::default());
        for (label, all) in [("ordinary", fragments(150)), ("hard", hard_fragments())] {
            let what = format!("{name}, {label} fragments");
            let stopped = interp_stops(&p, &env(), &all);
            if name.contains("never ends") {
                assert!(
                    !stopped.is_empty(),
                    "{what}: no fragment reaches the budget"
                );
            }
            let frags: Vec<Fragment> = (0..all.len())
                .filter(|k| !stopped.contains(k))
                .map(|k| all[k])
                .collect();
            if !frags.is_empty() {
                let plan = check(&what, &p, &env(), u32::MAX, None, &frags, tol);
                let loops = plan
                    .steps
                    .iter()
                    .filter_map(|s| match s {
                        Step::Pass(ps) => Some(ps),
                        Step::Host(_) => None,
                    })
                    .flat_map(|ps| &ps.items)
                    .filter(|it| matches!(it.kind, ItemKind::Loop { .. }))
                    .count();
                assert!(loops >= 1 || name.contains("light loop"), "{what}\n{plan}");
                let what = format!("{what} (optimized)");
                check(&what, &o, &env(), u32::MAX, None, &frags, tol);
            }
            if stopped.is_empty() {
                continue;
            }
            let at_budget: Vec<Fragment> = stopped.iter().map(|&k| all[k]).collect();
            if !capped {
                let what = format!("{what}, at the budget");
                check(&what, &p, &env(), u32::MAX, None, &at_budget, tol);
                continue;
            }
            let reference = InterpBackend.compile_program(&p, Duration::ZERO).unwrap();
            let (want, _, _) = shade(&*reference, &env(), u32::MAX, None, &at_budget);
            let m = compile(&backend(GpuOptions::default()), &what, &p);
            let (got, _, _) = shade(&m, &env(), u32::MAX, None, &at_budget);
            assert!(!m.device_failed(), "{what}");
            let differ = got
                .iter()
                .zip(&want)
                .filter(|(g, x)| !same(**g, **x))
                .count();
            eprintln!(
                "{what}: {} fragments at the budget, {differ} of {} floats differ on this \
                 software adapter (its loop cap)",
                at_budget.len(),
                got.len()
            );
        }
    }
}

/// A loop whose body asks the scene or runs a light loop is refused with the reason (the
/// material falls back); without a device, every loop row plans into kernels naga accepts,
/// with one `loop` item per top-level loop and the iteration limit in the WGSL.
#[test]
fn loops_plan_without_a_device_and_refuse_host_steps_inside() {
    let limits = wgpu::Limits::default();
    for (name, body, _) in LOOPS {
        let p = program(name, body, "  output r %x");
        for (mode, options) in modes() {
            let pl = plan(&p, &options, &limits).unwrap_or_else(|e| panic!("{name}: {e}"));
            for k in pl.kernels() {
                shadenet_gpu::kernel::validate(k.wgsl)
                    .unwrap_or_else(|e| panic!("{name} ({mode}): pass {}: {e}", k.pass));
            }
            let wgsl = pl.wgsl();
            assert!(
                wgsl.contains(" = 0u;") && wgsl.contains(" == 65536u) { break; }"),
                "{name}"
            );
            // One budget per loop nest, taken by every loop of it.
            if mode == "fused" && name.starts_with("loop, nested") {
                assert_eq!(wgsl.matches("var sn_budget_").count(), 1, "{wgsl}");
                assert_eq!(wgsl.matches(" == 65536u) { break; }").count(), 2, "{wgsl}");
            }
        }
    }
    let refused = [
        (
            "trace in a loop",
            "  %l = loop %pc while {\n    %t = const true : bool\n    yield %t\n  } do {\n    %tr = trace reflection %n : color\n    yield %tr\n  }\n  %x = proj %l, 0 : color",
            "trace",
        ),
        (
            "occlusion in an if in a loop",
            "  %l = loop %a while {\n    %t = const true : bool\n    yield %t\n  } do {\n    %v = loop.var 0 : float\n    %w = if %q {\n      %oc = occlusion %n, %k, %v : float\n      yield %oc\n    } else {\n      yield %v\n    }\n    %wv = proj %w, 0 : float\n    yield %wv\n  }\n  %x = proj %l, 0 : float",
            "occlusion",
        ),
        (
            "light loop in a loop",
            "  %l = loop %pc while {\n    %t = const true : bool\n    yield %t\n  } do {\n    %il = illuminance %p {\n      %C = light.Cl : color\n      yield %C\n    }\n    %s = proj %il, 0 : color\n    yield %s\n  }\n  %x = proj %l, 0 : color",
            "illuminance",
        ),
    ];
    for (name, body, op) in refused {
        let p = program(name, body, "  output r %x");
        match plan(&p, &GpuOptions::default(), &limits) {
            Err(BackendError::Unsupported {
                backend,
                op: o,
                reason,
                ..
            }) => {
                assert_eq!(backend, "gpu");
                assert!(o.contains(op), "{name}: {o}");
                assert!(
                    reason.starts_with("inside the loop %")
                        && reason.contains("runs a loop whole in one kernel"),
                    "{name}: {reason}"
                );
            }
            Err(e) => panic!("{name}: expected Unsupported, got {e}"),
            Ok(pl) => panic!("{name}: expected Unsupported, got\n{pl}"),
        }
    }
}

/// A loop the GPU refuses falls back to the companion back end, which runs it.
#[test]
fn a_loop_with_a_trace_falls_back() {
    if device_or_skip("a_loop_with_a_trace_falls_back").is_none() {
        return;
    }
    let p = program(
        "trace in a loop",
        "  %i0 = const 0 : int\n  %l = loop %i0, %pc while {\n    %ci = loop.var 0 : int\n    %two = const 2 : int\n    %cc = lt %ci, %two : bool\n    yield %cc\n  } do {\n    %bi = loop.var 0 : int\n    %d = loop.var 1 : color\n    %dv = construct %b, %a, %c : vec3\n    %tr = trace reflection %dv : color\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    yield %bi1, %tr\n  }\n  %x = proj %l, 1 : color",
        "  output r %x",
    );
    let lenient = GpuBackend::new(GpuOptions::default(), Arc::new(InterpBackend)).unwrap();
    let m = lenient.compile_program(&p, Duration::ZERO).unwrap();
    assert_eq!(m.info().backend, "interp");
    let why = m.info().fallback.clone().unwrap_or_default();
    assert!(
        why.contains("trace") && why.contains("inside the loop"),
        "{why}"
    );
}

/// A loop is written once whatever its trip count: the same WGSL for 10 and 4000 iterations
/// (only the constant differs), one WGSL `loop` per IR loop.
#[test]
fn a_loop_kernel_does_not_grow_with_the_trip_count() {
    let body = |trips: i32| {
        format!(
            "  %i0 = const 0 : int\n  %l = loop %i0, %p while {{\n    %ci = loop.var 0 : int\n    %nt = const {trips} : int\n    %cc = lt %ci, %nt : bool\n    yield %cc\n  }} do {{\n    %bi = loop.var 0 : int\n    %bv = loop.var 1 : vec3\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    %w = cross %bv, %n : vec3\n    %w2 = normalize %w : vec3\n    %bv1 = add %bv, %w2 : vec3\n    yield %bi1, %bv1\n  }}\n  %x = proj %l, 1 : vec3"
        )
    };
    let wgsl = |trips| {
        let p = program("trips", &body(trips), "  output r %x");
        let pl = plan(&p, &GpuOptions::default(), &wgpu::Limits::default()).unwrap();
        assert_eq!(pl.passes(), 1, "{pl}");
        pl.wgsl()
    };
    let (short, long) = (wgsl(10), wgsl(4000));
    eprintln!(
        "a loop of 10 and of 4000 trips: {} and {} WGSL lines",
        short.lines().count(),
        long.lines().count()
    );
    assert_eq!(short.replace("10", "4000"), long.replace("10", "4000"));
    assert_eq!(short.matches("loop {").count(), 1, "{short}");
}
