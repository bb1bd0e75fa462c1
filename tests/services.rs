//! Shading services: traced reflection and refraction (Fresnel, total internal reflection),
//! light visibility and the `shadow` part, ambient occlusion and bump mapping through a
//! stream override, checked with a fake scene that records what it is asked.

use shadenet_graph::ir::{self, Op, Program, RAY_REFLECTION, RAY_REFRACTION};
use shadenet_graph::lower::{Literal, lower_single};
use shadenet_graph::nodes::{LightDesc, LightKind, NodeLibrary};
use shadenet_graph::opt::{self, Specialization};
use shadenet_graph::types::{ConstValue, Type};
use shadenet_runtime::{Backend, Fragment, Interpreter, SceneServices, ShadeCtx, ShadeEnv};
use std::sync::Mutex;
use std::time::Duration;

// ---- the fake scene ----

/// One `trace` call: origin, direction, ray type, depth.
type TraceCall = ([f32; 3], [f32; 3], i32, i32);
/// One `occlusion` call: point, normal, samples, max distance, seed.
type OcclusionCall = ([f32; 3], [f32; 3], u32, f32, u32);

/// A scene whose traced rays all see the constant radiance `sky`, whose shadow rays are
/// blocked where `to.x > block_x`, and whose occlusion is `open`; it records every call.
struct Fake {
    sky: [f32; 3],
    block_x: f32,
    open: f32,
    traces: Mutex<Vec<TraceCall>>,
    shadow_rays: Mutex<Vec<([f32; 3], [f32; 3])>>,
    occlusions: Mutex<Vec<OcclusionCall>>,
}

impl Fake {
    fn new(sky: [f32; 3]) -> Fake {
        Fake {
            sky,
            block_x: f32::INFINITY,
            open: 1.0,
            traces: Mutex::new(Vec::new()),
            shadow_rays: Mutex::new(Vec::new()),
            occlusions: Mutex::new(Vec::new()),
        }
    }

    fn traces(&self) -> Vec<TraceCall> {
        self.traces.lock().unwrap().clone()
    }

    fn clear(&self) {
        self.traces.lock().unwrap().clear();
        self.shadow_rays.lock().unwrap().clear();
        self.occlusions.lock().unwrap().clear();
    }
}

impl SceneServices for Fake {
    fn trace(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        ray_type: i32,
        depth: i32,
        _: f32,
    ) -> [f32; 3] {
        self.traces
            .lock()
            .unwrap()
            .push((origin, dir, ray_type, depth));
        self.sky
    }
    fn occluded(&self, from: [f32; 3], to: [f32; 3]) -> bool {
        self.shadow_rays.lock().unwrap().push((from, to));
        to[0] > self.block_x
    }
    fn occlusion(&self, p: [f32; 3], n: [f32; 3], samples: u32, max: f32, seed: u32) -> f32 {
        self.occlusions
            .lock()
            .unwrap()
            .push((p, n, samples, max, seed));
        self.open
    }
}

// ---- running programs ----

/// One output: name, component, f32 values widened, f64 values.
type Entry = (String, Option<String>, Vec<f64>, Vec<f64>);

/// The outputs of one shading call.
struct Shaded {
    entries: Vec<Entry>,
    nonfinite: u32,
}

impl Shaded {
    /// Part `component` of output `name` in f64 (the total where `component` is `None`).
    fn get(&self, name: &str, component: Option<&str>) -> Vec<f64> {
        self.pick(name, component, |e| &e.3)
    }

    /// The same in f32.
    fn get32(&self, name: &str, component: Option<&str>) -> Vec<f64> {
        self.pick(name, component, |e| &e.2)
    }

    fn pick(
        &self,
        name: &str,
        component: Option<&str>,
        f: impl Fn(&Entry) -> &Vec<f64>,
    ) -> Vec<f64> {
        let mut sum: Option<Vec<f64>> = None;
        for e in self.entries.iter().filter(|e| e.0 == name) {
            if component.is_some() && e.1.as_deref() != component {
                continue;
            }
            let v = f(e);
            sum = Some(match sum {
                None => v.clone(),
                Some(s) => s.iter().zip(v).map(|(a, b)| a + b).collect(),
            });
        }
        sum.unwrap_or_else(|| panic!("no {name} {component:?}"))
    }

    fn all_finite(&self) -> bool {
        self.nonfinite == 0
            && self
                .entries
                .iter()
                .all(|e| e.2.iter().chain(&e.3).all(|x| x.is_finite()))
    }
}

fn shade(
    program: &Program,
    frag: &Fragment,
    lights: &[LightDesc],
    mask: u32,
    scene: Option<&dyn SceneServices>,
) -> Shaded {
    let env = ShadeEnv::with_lights(lights);
    let mut ctx = ShadeCtx::new(*frag, &env);
    ctx.mask = mask;
    ctx.scene = scene;
    let i32_ = Interpreter::<f32>::new(program).unwrap();
    let i64_ = Interpreter::<f64>::new(program).unwrap();
    let (o32, o64) = (i32_.shade(&ctx), i64_.shade(&ctx));
    let entries = i32_
        .slots()
        .iter()
        .map(|s| {
            let w = s.ty.width().max(1);
            let comp = s.component.map(|k| program.components[k as usize].clone());
            let v32 = o32.values[s.offset..s.offset + w]
                .iter()
                .map(|x| *x as f64)
                .collect();
            (
                s.name.clone(),
                comp,
                v32,
                o64.values[s.offset..s.offset + w].to_vec(),
            )
        })
        .collect();
    Shaded {
        entries,
        nonfinite: o32.nonfinite + o64.nonfinite,
    }
}

fn node(name: &str, inputs: &[(&str, Literal)]) -> Program {
    lower_single(&NodeLibrary::standard(), name, Type::Float, inputs).unwrap()
}

fn network(src: &str) -> Program {
    shadenet::compile_json(src, &NodeLibrary::standard())
        .unwrap_or_else(|e| panic!("{e}"))
        .program
}

fn f(x: f64) -> Literal {
    Literal::Const(ConstValue::Float(x))
}

fn c(r: f64, g: f64, b: f64) -> Literal {
    Literal::Const(ConstValue::Color([r, g, b]))
}

fn yes() -> Literal {
    Literal::Const(ConstValue::Bool(true))
}

fn mask_of(p: &Program, names: &[&str]) -> u32 {
    names
        .iter()
        .map(|n| 1u32 << p.component_index(n).unwrap())
        .fold(0, |a, b| a | b)
}

/// A fragment on the z = 0 plane (outward normal +z), seen along unit `i`.
fn plane(i: [f64; 3]) -> Fragment {
    let n = if i[2] > 0.0 { -1.0 } else { 1.0 };
    Fragment {
        p: [0.0, 0.0, 0.0],
        n: [0.0, 0.0, n],
        ng: [0.0, 0.0, 1.0],
        i: i.map(|x| x as f32),
        uv: [0.5, 0.5],
        dpdu: [1.0, 0.0, 0.0],
        dpdv: [0.0, 1.0, 0.0],
        ray_depth: 2,
        seed: 7,
        ..Fragment::default()
    }
}

fn deg(a: f64) -> f64 {
    a.to_radians()
}

/// The exact dielectric Fresnel reflectance for light going from index `n1` into `n2` at
/// incidence cosine `cos_i` (pbrt's `FrDielectric`).
fn fresnel(cos_i: f64, n1: f64, n2: f64) -> f64 {
    let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
    let sin_t = n1 / n2 * sin_i;
    if sin_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
    let par = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    let perp = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    (par * par + perp * perp) / 2.0
}

fn assert_close(got: &[f64], want: &[f64], rel: f64, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (g, w) in got.iter().zip(want) {
        assert!(
            (g - w).abs() <= rel * w.abs().max(1e-30) || g == w,
            "{what}: got {got:?}, want {want:?}"
        );
    }
}

const SKY: [f32; 3] = [0.25, 0.5, 2.0];

fn sky_times(w: [f64; 3]) -> Vec<f64> {
    (0..3).map(|k| w[k] * SKY[k] as f64).collect()
}

// ---- reflection ----

#[test]
fn a_mirror_returns_the_traced_color_exactly() {
    let frag = plane([0.0, 0.0, -1.0]);
    for surface in ["phong", "blinn"] {
        let p = node(
            surface,
            &[
                ("reflectivity", f(1.0)),
                ("color", c(0.0, 0.0, 0.0)),
                ("specularColor", c(0.0, 0.0, 0.0)),
            ],
        );
        let scene = Fake::new(SKY);
        let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
        let want: Vec<f64> = SKY.iter().map(|x| *x as f64).collect();
        assert_eq!(o.get("outColor", Some("reflection")), want, "{surface}");
        assert_eq!(o.get32("outColor", Some("reflection")), want, "{surface}");
        assert_eq!(o.get("outColor", None), want, "nothing else: {surface}");
        // One ray per precision, from P, straight back up, one level deeper.
        let calls = scene.traces();
        assert_eq!(calls.len(), 2, "{surface}: {calls:?}");
        for (origin, dir, ray_type, depth) in calls {
            assert_eq!(origin, [0.0; 3]);
            assert_eq!(dir, [0.0, 0.0, 1.0]);
            assert_eq!(ray_type, RAY_REFLECTION);
            assert_eq!(depth, 3);
        }
        // reflectedColor tints, reflectivity scales.
        let p = node(
            surface,
            &[
                ("reflectivity", f(0.5)),
                ("reflectedColor", c(1.0, 0.5, 0.0)),
            ],
        );
        let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
        assert_eq!(
            o.get("outColor", Some("reflection")),
            sky_times([0.5, 0.25, 0.0])
        );
    }
}

#[test]
fn the_mirror_direction_follows_the_incidence() {
    let a = deg(30.0);
    let frag = plane([a.sin(), 0.0, -a.cos()]);
    let p = node("phong", &[("reflectivity", f(1.0))]);
    let scene = Fake::new(SKY);
    shade(&p, &frag, &[], u32::MAX, Some(&scene));
    let (_, dir, _, _) = scene.traces()[1];
    let want = [a.sin(), 0.0, a.cos()];
    assert_close(&dir.map(|x| x as f64), &want, 1e-6, "R = reflect(I, N)");
}

#[test]
fn without_a_scene_traced_parts_are_black_and_nothing_else_changes() {
    let frag = plane([0.0, 0.0, -1.0]);
    let lights = [LightDesc {
        name: "l".into(),
        kind: LightKind::Point {
            position: [0.3, 0.1, 2.0],
        },
        power: [4.0; 3],
    }];
    let glass = node(
        "phong",
        &[
            ("reflectivity", f(0.5)),
            ("refractions", yes()),
            ("transparency", c(0.5, 0.5, 0.5)),
        ],
    );
    let plain = node("phong", &[("transparency", c(0.5, 0.5, 0.5))]);
    let o = shade(&glass, &frag, &lights, u32::MAX, None);
    let q = shade(&plain, &frag, &lights, u32::MAX, None);
    for k in ["reflection", "refraction"] {
        assert_eq!(o.get("outColor", Some(k)), vec![0.0; 3], "{k}");
    }
    for k in ["diffuse", "specular", "indirect", "emission"] {
        assert_eq!(
            o.get32("outColor", Some(k)),
            q.get32("outColor", Some(k)),
            "{k}"
        );
    }
    assert_eq!(o.get("outShadow", Some("shadow")), vec![0.0; 3]);
    // Refracting surfaces leave nothing to composite.
    assert_eq!(o.get("outTransparency", None), vec![0.0; 3]);
    assert_eq!(q.get("outTransparency", None), vec![0.5; 3]);
}

// ---- refraction ----

#[test]
fn refraction_at_normal_incidence_with_unit_index_passes_the_traced_color() {
    let frag = plane([0.0, 0.0, -1.0]);
    for surface in ["lambert", "phong", "blinn"] {
        let p = node(
            surface,
            &[
                ("refractions", yes()),
                ("refractiveIndex", f(1.0)),
                ("transparency", c(0.5, 0.25, 1.0)),
            ],
        );
        let scene = Fake::new(SKY);
        let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
        let want = sky_times([0.5, 0.25, 1.0]);
        assert_eq!(o.get("outColor", Some("refraction")), want, "{surface}");
        assert_eq!(o.get32("outColor", Some("refraction")), want, "{surface}");
        // F = 0: nothing is reflected, and no reflection ray is traced.
        assert_eq!(o.get("outColor", Some("reflection")), vec![0.0; 3]);
        let calls = scene.traces();
        assert_eq!(calls.len(), 2, "{surface}: {calls:?}");
        for (origin, dir, ray_type, depth) in calls {
            assert_eq!((origin, dir), ([0.0; 3], [0.0, 0.0, -1.0]), "T = I");
            assert_eq!((ray_type, depth), (RAY_REFRACTION, 3));
        }
    }
}

#[test]
fn refraction_follows_snell_and_fresnel() {
    // Entering glass (η = 1.5) at 45°, and leaving it at 30°.
    for (leaving, angle) in [(false, 45.0), (true, 30.0)] {
        let a = deg(angle);
        let i = if leaving {
            [a.sin(), 0.0, a.cos()]
        } else {
            [a.sin(), 0.0, -a.cos()]
        };
        let frag = plane(i);
        let p = node(
            "lambert",
            &[
                ("refractions", yes()),
                ("refractiveIndex", f(1.5)),
                ("transparency", c(1.0, 1.0, 1.0)),
            ],
        );
        let scene = Fake::new(SKY);
        let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
        let (n1, n2) = if leaving { (1.5, 1.0) } else { (1.0, 1.5) };
        let fr = fresnel(a.cos(), n1, n2);
        let want_t = sky_times([1.0 - fr; 3]);
        let want_r = sky_times([fr; 3]);
        // (I is stored in f32: the angle is off by its rounding.)
        assert_close(&o.get("outColor", Some("refraction")), &want_t, 1e-6, "T");
        assert_close(&o.get("outColor", Some("reflection")), &want_r, 1e-6, "R");
        // Snell: sin θ_t = n1/n2 sin θ_i, on the far side.
        let t = scene
            .traces()
            .into_iter()
            .find(|c| c.2 == RAY_REFRACTION)
            .unwrap();
        let sin_t = n1 / n2 * a.sin();
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let want = [sin_t, 0.0, if leaving { cos_t } else { -cos_t }];
        assert_close(&t.1.map(|x| x as f64), &want, 1e-6, "Snell");
    }
}

#[test]
fn total_internal_reflection_traces_a_reflection_and_stays_finite() {
    // Inside glass (I·Ng > 0), beyond the critical angle 41.8°, up to grazing.
    for angle in [45.0, 60.0, 89.0, 89.999, 90.0] {
        let a = deg(angle);
        let frag = plane([a.sin(), 0.0, a.cos()]);
        let p = node(
            "lambert",
            &[
                ("refractions", yes()),
                ("refractiveIndex", f(1.5)),
                ("transparency", c(0.5, 0.5, 0.5)),
            ],
        );
        let scene = Fake::new(SKY);
        let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
        assert!(o.all_finite(), "{angle}°");
        assert_eq!(o.get("outColor", Some("refraction")), vec![0.0; 3]);
        // All the transparent part's light is reflected.
        assert_eq!(
            o.get("outColor", Some("reflection")),
            sky_times([0.5; 3]),
            "{angle}°"
        );
        let calls = scene.traces();
        assert!(!calls.is_empty());
        for (_, dir, ray_type, _) in calls {
            assert_eq!(ray_type, RAY_REFLECTION, "{angle}°");
            let want = [a.sin(), 0.0, -a.cos()];
            assert_close(&dir.map(|x| x as f64), &want, 1e-6, "mirrored back inside");
        }
    }
}

#[test]
fn grazing_and_degenerate_angles_stay_finite_and_conserve_energy() {
    let mut cases = Vec::new();
    for eta in [1.0, 1.33, 1.5, 2.4, 0.7] {
        for angle in [0.0, 10.0, 41.8, 80.0, 89.9, 89.9999, 90.0] {
            for leaving in [false, true] {
                let a = deg(angle);
                let z = if leaving { a.cos() } else { -a.cos() };
                cases.push((eta, plane([a.sin(), 0.0, z]), true));
            }
        }
    }
    // A zero incident direction, a zero normal, a NaN normal, no geometric normal.
    let mut zero_i = plane([0.0, 0.0, -1.0]);
    zero_i.i = [0.0; 3];
    let mut zero_n = plane([0.0, 0.6, -0.8]);
    zero_n.n = [0.0; 3];
    let mut nan_n = plane([0.0, 0.6, -0.8]);
    nan_n.n = [f32::NAN; 3];
    let mut no_ng = plane([0.0, 0.6, -0.8]);
    no_ng.ng = [0.0; 3];
    for frag in [zero_i, zero_n, nan_n, no_ng] {
        cases.push((1.5, frag, false));
    }
    let scene = Fake::new(SKY);
    for (eta, frag, energy) in cases {
        for surface in ["lambert", "phong", "blinn"] {
            let p = node(
                surface,
                &[
                    ("refractions", yes()),
                    ("refractiveIndex", f(eta)),
                    ("transparency", c(1.0, 1.0, 1.0)),
                    ("color", c(0.0, 0.0, 0.0)),
                ],
            );
            let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
            assert!(o.all_finite(), "{surface} η={eta} {frag:?}");
            // A constant sky: F · sky + (1 − F) · sky = sky.
            if energy {
                let total = o.get("outColor", None);
                let what = format!("{surface} η={eta} {:?}", frag.i);
                assert_close(&total, &sky_times([1.0; 3]), 1e-6, &what);
            }
            for (_, dir, _, _) in scene.traces() {
                assert!(dir.iter().all(|x| x.is_finite()), "{dir:?}");
                let len = dir.iter().map(|x| x * x).sum::<f32>().sqrt();
                assert!((len - 1.0).abs() < 1e-5, "unit direction: {dir:?}");
            }
            scene.clear();
        }
    }
}

#[test]
fn trace_is_black_for_a_zero_direction() {
    // A zero incident direction and a zero normal give a zero mirror direction: no call.
    let mut frag = plane([0.0, 0.0, -1.0]);
    frag.i = [0.0; 3];
    frag.n = [0.0; 3];
    let p = node("phong", &[("reflectivity", f(1.0))]);
    let scene = Fake::new(SKY);
    let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
    assert_eq!(o.get("outColor", Some("reflection")), vec![0.0; 3]);
    assert!(scene.traces().is_empty());
}

// ---- shadows ----

fn three_lights() -> Vec<LightDesc> {
    let point = |x: f64, power: f64| LightDesc {
        name: format!("p{x}"),
        kind: LightKind::Point {
            position: [x, 0.2, 1.5],
        },
        power: [power, 0.8 * power, 0.5 * power],
    };
    vec![
        point(-1.0, 3.0),
        point(1.0, 5.0),
        LightDesc {
            name: "q".into(),
            kind: LightKind::Quad {
                corner: [-1.0, -1.0, 2.0],
                edge_u: [0.0, 2.0, 0.0],
                edge_v: [2.0, 0.0, 0.0],
                samples: 16,
            },
            power: [1.5; 3],
        },
    ]
}

#[test]
fn shadow_is_the_diffuse_light_lost_to_blocked_samples() {
    let frag = plane([0.2, 0.1, -1.0]);
    let lights = three_lights();
    for surface in ["lambert", "phong", "blinn"] {
        let p = node(surface, &[("color", c(0.9, 0.6, 0.3))]);
        let open = shade(&p, &frag, &lights, u32::MAX, None);
        let mut scene = Fake::new(SKY);
        scene.block_x = 0.0; // blocks the right point light and half the quad's samples
        let o = shade(&p, &frag, &lights, u32::MAX, Some(&scene));
        let lit = o.get("outColor", Some("diffuse"));
        let lost = o.get("outShadow", Some("shadow"));
        let unshadowed = open.get("outColor", Some("diffuse"));
        let sum: Vec<f64> = lit.iter().zip(&lost).map(|(a, b)| a + b).collect();
        assert_close(&sum, &unshadowed, 1e-6, surface);
        let sum32: Vec<f64> = o
            .get32("outColor", Some("diffuse"))
            .iter()
            .zip(o.get32("outShadow", Some("shadow")))
            .map(|(a, b)| a + b)
            .collect();
        assert_close(
            &sum32,
            &open.get32("outColor", Some("diffuse")),
            1e-6,
            "f32",
        );
        assert!(lost[0] > 0.2 * unshadowed[0] && lit[0] > 0.2 * unshadowed[0]);
        // The beauty is shadowed: outColor's parts do not include the shadow.
        assert_close(
            &o.get("outColor", None),
            &[
                "diffuse",
                "specular",
                "reflection",
                "refraction",
                "indirect",
                "emission",
            ]
            .iter()
            .filter(|k| p.component_index(k).is_some())
            .map(|k| o.get("outColor", Some(k)))
            .fold(vec![0.0; 3], |a, v| {
                a.iter().zip(&v).map(|(x, y)| x + y).collect()
            }),
            1e-12,
            "beauty",
        );
        // Without a scene nothing is lost, and the diffuse part does not change by a bit.
        assert_eq!(open.get("outShadow", Some("shadow")), vec![0.0; 3]);
        let mut none_blocked = Fake::new(SKY);
        none_blocked.block_x = f32::INFINITY;
        let clear = shade(&p, &frag, &lights, u32::MAX, Some(&none_blocked));
        assert_eq!(
            clear.get32("outColor", None),
            open.get32("outColor", None),
            "{surface}"
        );
    }
}

#[test]
fn blocked_samples_have_no_highlight() {
    let frag = plane([0.2, 0.1, -1.0]);
    let lights = three_lights();
    let mut scene = Fake::new(SKY);
    scene.block_x = -10.0; // everything
    for surface in ["phong", "blinn"] {
        let p = node(surface, &[]);
        let o = shade(&p, &frag, &lights, u32::MAX, Some(&scene));
        assert_eq!(o.get("outColor", Some("specular")), vec![0.0; 3]);
        assert_eq!(o.get("outColor", Some("diffuse")), vec![0.0; 3]);
        let open = shade(&p, &frag, &lights, u32::MAX, None);
        assert_close(
            &o.get("outShadow", Some("shadow")),
            &open.get("outColor", Some("diffuse")),
            1e-12,
            "everything lost",
        );
    }
}

#[test]
fn each_sample_is_tested_once_per_shading_call() {
    // Diffuse, specular and shadow each loop over the 18 samples; the scene is asked once
    // per sample (per precision).
    let frag = plane([0.2, 0.1, -1.0]);
    let p = node("phong", &[]);
    let scene = Fake::new(SKY);
    shade(&p, &frag, &three_lights(), u32::MAX, Some(&scene));
    assert_eq!(scene.shadow_rays.lock().unwrap().len(), 2 * 18);
    // The JIT (its visibility memo) and the GPU (one light set at P, computed by the host)
    // ask as often as the interpreter: the same images with the same number of shadow rays.
    let env = ShadeEnv::with_lights(&three_lights());
    let (opt, _) = opt::run(&p, &Specialization::default());
    let jit = shadenet_jit::JitBackend::with_options(shadenet_jit::JitOptions {
        fallback: false,
        ..Default::default()
    });
    let mut backends: Vec<(&str, Box<dyn Backend>)> = vec![("jit", Box::new(jit))];
    if shadenet_gpu::testing::device_or_skip("each_sample_is_tested_once_per_shading_call (GPU)")
        .is_some()
    {
        let gpu = shadenet_gpu::GpuBackend::new(
            shadenet_gpu::GpuOptions::default(),
            std::sync::Arc::new(shadenet_runtime::InterpBackend),
        )
        .unwrap()
        .without_fallback();
        backends.push(("gpu", Box::new(gpu)));
    }
    for (name, b) in backends {
        for program in [&p, &opt] {
            let m = b.compile_program(program, Duration::ZERO).unwrap();
            scene.clear();
            let mut out = vec![0.0; m.width() * 2];
            shadenet_runtime::shade_many_unpacked(
                &*m,
                &env,
                u32::MAX,
                Some(&scene),
                &[frag, frag],
                &mut out,
            );
            assert_eq!(
                scene.shadow_rays.lock().unwrap().len(),
                2 * 18,
                "{name}: two fragments, 18 samples each"
            );
        }
    }
}

// ---- inactive components cost nothing ----

#[test]
fn inactive_components_trace_nothing() {
    let frag = plane([0.3, 0.0, -1.0]);
    let lights = three_lights();
    let glass = node(
        "phong",
        &[
            ("reflectivity", f(1.0)),
            ("refractions", yes()),
            ("transparency", c(1.0, 1.0, 1.0)),
        ],
    );
    let scene = Fake::new(SKY);
    let all = !0u32;
    let no_reflection = all & !mask_of(&glass, &["reflection"]);
    shade(&glass, &frag, &lights, no_reflection, Some(&scene));
    let calls = scene.traces();
    assert!(calls.iter().all(|c| c.2 == RAY_REFRACTION), "{calls:?}");
    scene.clear();
    let neither = all & !mask_of(&glass, &["reflection", "refraction"]);
    shade(&glass, &frag, &lights, neither, Some(&scene));
    assert!(scene.traces().is_empty());
    // No light loop that reads visibility: no shadow ray either.
    scene.clear();
    let emission = mask_of(&glass, &["emission", "indirect"]);
    shade(&glass, &frag, &lights, emission, Some(&scene));
    assert!(scene.traces().is_empty());
    assert!(scene.shadow_rays.lock().unwrap().is_empty());

    // Specialized without reflection and refraction, the program traces nothing whatever
    // mask it is run with.
    let spec = Specialization {
        components: neither,
        ..Specialization::default()
    };
    let (o, _) = opt::run(&glass, &spec);
    scene.clear();
    shade(&o, &frag, &lights, all, Some(&scene));
    assert!(scene.traces().is_empty());
    let (o, report) = opt::run(&glass, &Specialization::default());
    assert!(report.needs.trace, "{o}");
    assert!(!report.needs.occlusion);
}

// ---- ambient occlusion ----

#[test]
fn ambient_occlusion_asks_the_scene() {
    let mut frag = plane([0.0, 0.0, -1.0]);
    frag.p = [1.0, 2.0, 3.0];
    frag.n = [0.0, 0.0, 2.0]; // normalized before the scene sees it
    let p = node(
        "ambientOcclusion",
        &[("bright", c(1.0, 0.5, 0.0)), ("dark", c(0.0, 0.0, 1.0))],
    );
    let mut scene = Fake::new(SKY);
    scene.open = 0.25;
    let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
    assert_eq!(o.get("outAlpha", None), vec![0.25]);
    assert_eq!(o.get("outColor", None), vec![0.25, 0.125, 0.75]);
    let calls = scene.occlusions.lock().unwrap().clone();
    assert_eq!(calls.len(), 2);
    assert_eq!(calls[0], ([1.0, 2.0, 3.0], [0.0, 0.0, 1.0], 16, 1e30, 7));
    // Without a scene the point is open.
    let o = shade(&p, &frag, &[], u32::MAX, None);
    assert_eq!(o.get("outAlpha", None), vec![1.0]);
    assert_eq!(o.get("outColor", None), vec![1.0, 0.5, 0.0]);
    // Out-of-range answers are clamped; no distance asks nothing; samples ≥ 1.
    scene.open = 7.0;
    let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
    assert_eq!(o.get("outAlpha", None), vec![1.0]);
    scene.clear();
    let p = node(
        "ambientOcclusion",
        &[
            ("maxDistance", f(0.0)),
            ("samples", Literal::Const(ConstValue::Int(0))),
        ],
    );
    scene.open = 0.0;
    let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
    assert_eq!(o.get("outAlpha", None), vec![1.0]);
    assert!(scene.occlusions.lock().unwrap().is_empty());
    let p = node(
        "ambientOcclusion",
        &[("samples", Literal::Const(ConstValue::Int(-3)))],
    );
    let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
    assert_eq!(o.get("outAlpha", None), vec![0.0]);
    assert_eq!(scene.occlusions.lock().unwrap()[0].2, 1);
    let (_, report) = opt::run(&p, &Specialization::default());
    assert!(report.needs.occlusion && !report.needs.trace);
}

// ---- bump2d ----

fn bumped(src_nodes: &str, frag: &Fragment) -> ([f32; 3], Program) {
    let src = format!(
        r#"{{"nodes": [{src_nodes},
              {{"name": "surf", "type": "lambert", "inputs": {{"normal": "bump.outNormal"}}}}],
            "outputs": {{"n": "bump.outNormal", "c": "surf.outColor"}}}}"#
    );
    let p = network(&src);
    let o = shade(&p, frag, &[], u32::MAX, None);
    let n = o.get32("n", None);
    ([n[0] as f32, n[1] as f32, n[2] as f32], p)
}

#[test]
fn a_constant_bump_leaves_the_normal_unchanged_bit_for_bit() {
    let mut frag = plane([0.0, 0.0, -1.0]);
    let n = [0.267_261_24f32, 0.534_522_5, 0.801_783_7]; // (1, 2, 3) normalized, in f32
    frag.n = n;
    // A literal height, and a pattern that reads uv but is constant (both checks alike).
    let literal = r#"{"name": "bump", "type": "bump2d", "inputs": {"bumpValue": 0.3}}"#;
    let flat_checker = r#"{"name": "tex", "type": "checker",
                           "inputs": {"color1": [0.4, 0.4, 0.4], "color2": [0.4, 0.4, 0.4]}},
        {"name": "bump", "type": "bump2d",
         "inputs": {"bumpValue": "tex.outAlpha", "bumpDepth": 3}}"#;
    for nodes in [literal, flat_checker] {
        let (got, _) = bumped(nodes, &frag);
        assert_eq!(got.map(f32::to_bits), n.map(f32::to_bits), "{nodes}");
    }
    // Through lower_single too (the literal path of re-evaluation).
    let p = node("bump2d", &[("bumpValue", f(0.7))]);
    let o = shade(&p, &frag, &[], u32::MAX, None);
    let got = o.get32("outNormal", None);
    assert_eq!(got, n.map(|x| x as f64).to_vec());
}

#[test]
fn a_linear_ramp_in_u_tilts_the_normal_by_the_analytic_angle() {
    let frag = plane([0.0, 0.0, -1.0]);
    // h = u (read through samplerInfo, which reads the uv stream itself), depth 0.5: the
    // surface z = 0.5·x, whose normal is tilted by atan(0.5) towards −x.
    let by_uv = r#"{"name": "info", "type": "samplerInfo"},
        {"name": "bump", "type": "bump2d",
         "inputs": {"bumpValue": "info.uv.u", "bumpDepth": 0.5}}"#;
    // h = P.x through a port default (checker3d reads P) would be piecewise constant; use
    // samplerInfo's P instead: moving uv by Δ moves P by Δ·dPdu.
    let by_p = r#"{"name": "info", "type": "samplerInfo"},
        {"name": "bump", "type": "bump2d",
         "inputs": {"bumpValue": "info.P.x", "bumpDepth": 0.5}}"#;
    let want = [-(0.5f64.atan().sin()), 0.0, 0.5f64.atan().cos()];
    for nodes in [by_uv, by_p] {
        let (got, _) = bumped(nodes, &frag);
        assert_close(&got.map(|x| x as f64), &want, 1e-6, nodes);
        let angle = (got[2] as f64).acos();
        assert!((angle - 0.5f64.atan()).abs() < 1e-6, "{angle}");
    }
    // Stretched parameterization: u runs half as fast along x, so the slope halves.
    let mut stretched = frag;
    stretched.dpdu = [2.0, 0.0, 0.0];
    let (got, _) = bumped(by_uv, &stretched);
    let want = [-(0.25f64.atan().sin()), 0.0, 0.25f64.atan().cos()];
    assert_close(&got.map(|x| x as f64), &want, 1e-6, "stretched");
    // A normal facing away from dPdu × dPdv bumps towards its own side.
    let mut under = frag;
    under.n = [0.0, 0.0, -1.0];
    let (got, _) = bumped(by_uv, &under);
    let want = [-(0.5f64.atan().sin()), 0.0, -(0.5f64.atan().cos())];
    assert_close(&got.map(|x| x as f64), &want, 1e-6, "under");
    // In v, through a ramp-like pattern chain: h = 2·v (multiply reads no stream itself).
    let by_v = r#"{"name": "info", "type": "samplerInfo"},
        {"name": "twice", "type": "multiply", "inputs": {"input1": "info.uv.v", "input2": 2}},
        {"name": "bump", "type": "bump2d", "inputs": {"bumpValue": "twice.out"}}"#;
    let (got, _) = bumped(by_v, &frag);
    let want = [0.0, -(2f64.atan().sin()), 2f64.atan().cos()];
    assert_close(&got.map(|x| x as f64), &want, 1e-6, "v");
}

#[test]
fn only_nodes_that_read_the_overridden_streams_are_lowered_again() {
    // `moving` reads uv (its port default), `fixed` has a literal uv: only `moving` is
    // evaluated again at the two offsets.
    let src = r#"{"nodes": [
        {"name": "moving", "type": "noise"},
        {"name": "fixed", "type": "noise", "inputs": {"uvCoord": [0.3, 0.7]}},
        {"name": "sum", "type": "add", "inputs": {"input1": "moving.outAlpha", "input2": "fixed.outAlpha"}},
        {"name": "bump", "type": "bump2d", "inputs": {"bumpValue": "sum.out"}}],
      "outputs": {"n": "bump.outNormal"}}"#;
    let p = network(src);
    let noise_calls = p
        .listed()
        .into_iter()
        .filter(|v| matches!(p.op(*v), Op::Call(ir::Intrinsic::Noise2, _)))
        .count();
    assert_eq!(noise_calls, 3 + 1, "{p}");
    // The two parameters of the literal are declared once.
    let names: Vec<&str> = p.params.iter().map(|d| d.name.as_str()).collect();
    assert_eq!(
        names.iter().filter(|n| **n == "fixed.uvCoord").count(),
        1,
        "{names:?}"
    );
    ir::validate(&p).unwrap();
    // Bumps nest: a bump whose height comes from a bumped normal re-evaluates inside the
    // outer re-evaluation.
    let nested = r#"{"nodes": [
        {"name": "info", "type": "samplerInfo"},
        {"name": "inner", "type": "bump2d", "inputs": {"bumpValue": "info.uv.u"}},
        {"name": "h", "type": "multiply", "inputs": {"input1": "inner.outNormal.x", "input2": 1}},
        {"name": "bump", "type": "bump2d", "inputs": {"bumpValue": "h.out"}}],
      "outputs": {"n": "bump.outNormal"}}"#;
    let p = network(nested);
    ir::validate(&p).unwrap();
    let o = shade(&p, &plane([0.0, 0.0, -1.0]), &[], u32::MAX, None);
    assert!(o.all_finite());
    // inner's normal does not change with uv (a constant tilt): the outer bump is flat.
    let n = o.get32("n", None);
    assert_eq!(n, vec![0.0, 0.0, 1.0]);
}

// ---- the IR of a lowered material ----

#[test]
fn lowered_services_print_and_parse_back() {
    let glass = node(
        "blinn",
        &[
            ("reflectivity", f(0.2)),
            ("refractions", yes()),
            ("transparency", c(1.0, 1.0, 1.0)),
        ],
    );
    let ao = node("ambientOcclusion", &[]);
    for p in [glass, ao] {
        let text = p.to_string();
        let q = ir::parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert_eq!(q.to_string(), text);
        ir::validate(&q).unwrap();
    }
    let text = node("blinn", &[]).to_string();
    for needle in ["trace reflection %", "trace refraction %", "light.visible"] {
        assert!(text.contains(needle), "{needle}");
    }
    assert!(
        node("ambientOcclusion", &[])
            .to_string()
            .contains("occlusion %")
    );
}

// ---- the interpreter's light loop ----

#[test]
fn every_sample_runs_the_body_and_visibility_tells_them_apart() {
    // Yields (1, visible, Cl): the sample count, the visible count and the arriving color
    // of all samples, blocked ones included.
    let src = r#"program "count" {
  %0 = stream P : vec3
  %1 = illuminance %0 {
    %2 = const 1.0 : float
    %3 = light.visible : float
    %4 = light.Cl : color
    yield %2, %3, %4
  }
  %5 = proj %1, 0 : float
  %6 = proj %1, 1 : float
  %7 = proj %1, 2 : color
  output samples %5
  output visible %6
  output cl %7
}
"#;
    let p = ir::parse(src).unwrap();
    ir::validate(&p).unwrap();
    let frag = plane([0.0, 0.0, -1.0]);
    let lights = three_lights();
    let open = shade(&p, &frag, &lights, u32::MAX, None);
    assert_eq!(open.get("samples", None), vec![18.0]);
    assert_eq!(open.get("visible", None), vec![18.0]);
    let mut scene = Fake::new(SKY);
    scene.block_x = 0.0;
    let o = shade(&p, &frag, &lights, u32::MAX, Some(&scene));
    assert_eq!(o.get("samples", None), vec![18.0]);
    let visible = o.get("visible", None)[0];
    assert!(visible > 1.0 && visible < 17.0, "{visible}");
    assert_eq!(
        o.get("cl", None),
        open.get("cl", None),
        "Cl ignores shadows"
    );
    // A loop that does not read light.visible asks the scene nothing.
    let blind = ir::parse(&src.replace("light.visible", "const 0.5")).unwrap();
    scene.clear();
    shade(&blind, &frag, &lights, u32::MAX, Some(&scene));
    assert!(scene.shadow_rays.lock().unwrap().is_empty());
}

#[test]
fn trace_and_occlusion_ops_follow_their_definition() {
    let src = r#"program "q" {
  %0 = const vec3 (0.0, 3.0, 4.0) : vec3
  %1 = trace diffuse %0 : color
  %2 = const 4 : int
  %3 = const 2.5 : float
  %4 = occlusion %0, %2, %3 : float
  output c %1
  output o %4
}
"#;
    let p = ir::parse(src).unwrap();
    ir::validate(&p).unwrap();
    let mut frag = plane([0.0, 0.0, -1.0]);
    frag.p = [1.0, -1.0, 0.5];
    frag.ray_depth = 9;
    let mut scene = Fake::new(SKY);
    scene.open = 0.5;
    let o = shade(&p, &frag, &[], u32::MAX, Some(&scene));
    assert_eq!(o.get("c", None), sky_times([1.0; 3]));
    assert_eq!(o.get("o", None), vec![0.5]);
    // Directions and normals reach the scene normalized.
    assert_eq!(
        scene.traces()[0],
        ([1.0, -1.0, 0.5], [0.0, 0.6, 0.8], ir::RAY_DIFFUSE, 10)
    );
    let occ = scene.occlusions.lock().unwrap()[0];
    assert_eq!(occ, ([1.0, -1.0, 0.5], [0.0, 0.6, 0.8], 4, 2.5, 7));
    let none = shade(&p, &frag, &[], u32::MAX, None);
    assert_eq!(none.get("c", None), vec![0.0; 3]);
    assert_eq!(none.get("o", None), vec![1.0]);
    let rates = ir::rates(&p);
    for v in [1, 4] {
        assert_eq!(
            rates[v],
            ir::Rate::Varying,
            "constant operands, varying result"
        );
    }
}

// ---- the batch entry with a scene ----

/// The JIT's `shade_many` with a scene runs the batch entry, whose lanes ask their own
/// fragment's services (`SceneServices::fragment(first + lane)`) for traces, occlusion and
/// light visibility, in every packet — and padding lanes ask nothing: 101 fragments (the
/// last packet has one), against each fragment shaded alone with its own services.
#[test]
fn the_batch_entry_asks_each_fragment_for_its_own_services() {
    let text = "program \"tagged\" {\n  %p = stream P : vec3\n  %n = stream N : vec3\n  \
        %ii = stream I : vec3\n  %t = trace reflection %ii : color\n  %ns = const 4 : int\n  \
        %md = const 2.0 : float\n  %o = occlusion %n, %ns, %md : float\n  \
        %l = illuminance %p {\n    %v = light.visible : float\n    yield %v\n  }\n  \
        %vis = proj %l, 0 : float\n  output t %t\n  output o %o\n  output vis %vis\n}\n";
    let p = ir::parse(text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    let light = LightDesc::new(
        "key",
        LightKind::Point {
            position: [1.0, 1.0, 2.0],
        },
        [1.0; 3],
    )
    .unwrap();
    let env = ShadeEnv::with_lights(&[light]);
    let frags: Vec<Fragment> = (0..101)
        .map(|i| Fragment {
            p: [i as f32 * 0.01, 0.5, 0.0],
            n: [0.0, 0.0, 1.0],
            i: [0.1, 0.0, -1.0],
            seed: i,
            ..Fragment::default()
        })
        .collect();
    let scene = shadenet_runtime::testing::TaggedScene::with_fragments(frags.len() + 4);
    let m = shadenet_jit::JitBackend::new()
        .compile_program(&p, Duration::ZERO)
        .unwrap();
    assert_eq!(m.info().backend, "jit");
    let w = m.width();
    let mut got = vec![f32::NAN; w * frags.len()];
    shadenet_runtime::shade_many_unpacked(&*m, &env, u32::MAX, Some(&scene), &frags, &mut got);
    let mut one = vec![0.0f32; w];
    for (i, row) in got.chunks(w).enumerate() {
        assert_eq!(row[..3], [i as f32, 0.5, 0.25], "fragment {i}: trace");
        assert_eq!(row[3], i as f32 / 1000.0, "fragment {i}: occlusion");
        assert_eq!(
            row[4],
            if i % 3 == 1 { 0.0 } else { 1.0 },
            "fragment {i}: visible"
        );
        let ctx = ShadeCtx {
            frag: frags[i],
            env: &env,
            mask: u32::MAX,
            scene: scene.fragment(i),
        };
        m.shade(&ctx, &mut one);
        assert_eq!(
            row.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            one.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            "fragment {i}: batch vs alone"
        );
    }
}

// ---- geometry attributes (Op::Attribute) ----

/// A program reading attributes of every width (slots 0 to 3: float, vec2, color, color4)
/// with distinct defaults, each an output.
const ATTRIBUTES: &str = "program \"attrs\" {
  attribute \"_temp\" float
  attribute \"TEXCOORD_1\" vec2
  attribute \"COLOR_0\" color
  attribute \"COLOR_1\" color4
  %0 = const -1.0 : float
  %1 = attribute #0 %0 : float
  %2 = const (-2.0, -3.0) : vec2
  %3 = attribute #1 %2 : vec2
  %4 = const (-4.0, -5.0, -6.0) : color
  %5 = attribute #2 %4 : color
  %6 = const (-7.0, -8.0, -9.0, -10.0) : color4
  %7 = attribute #3 %6 : color4
  output a %1
  output b %3
  output c %5
  output d %7
}
";

/// What `TaggedScene` gives fragment `i` for slot `slot` of `width` floats, or the default.
fn tagged_attribute(i: usize, slot: u32, default: &[f32]) -> Vec<f32> {
    if (i as u32 + slot).is_multiple_of(4) || i % 7 == 5 {
        return default.to_vec();
    }
    (0..default.len())
        .map(|k| i as f32 / 4.0 + slot as f32 + k as f32 / 2.0)
        .collect()
}

/// How [`on_cpu_backends`] shaded a fragment.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Run {
    /// The interpreter or the JIT's scalar entry (named), with the fragment's services.
    Scalar(&'static str),
    /// The same without a scene.
    NoScene(&'static str),
    /// The JIT's batch entry (`shade_many`, each lane asking its own fragment's services).
    Batch,
}

/// Shades `p` (`width` output floats) at 43 fragments of a [`TaggedScene`] on the
/// interpreter and the JIT's scalar entry (with the fragment's services and without a
/// scene) and on the JIT's batch entry, handing each result to `check(fragment, run, got)`.
///
/// [`TaggedScene`]: shadenet_runtime::testing::TaggedScene
fn on_cpu_backends(p: &Program, width: usize, mut check: impl FnMut(usize, Run, &[f32])) {
    let env = ShadeEnv::default();
    let frags: Vec<Fragment> = (0..43)
        .map(|i| Fragment {
            p: [i as f32, 0.0, 0.0],
            ..Fragment::default()
        })
        .collect();
    let scene = shadenet_runtime::testing::TaggedScene::with_fragments(frags.len());
    let interp = shadenet_runtime::InterpBackend
        .compile_program(p, Duration::ZERO)
        .unwrap();
    let jit = shadenet_jit::JitBackend::new()
        .compile_program(p, Duration::ZERO)
        .unwrap();
    assert_eq!(jit.info().backend, "jit");
    let w = jit.width();
    assert_eq!(w, width);
    let mut batch = vec![f32::NAN; w * frags.len()];
    shadenet_runtime::shade_many_unpacked(&*jit, &env, u32::MAX, Some(&scene), &frags, &mut batch);
    for (i, f) in frags.iter().enumerate() {
        for (what, m) in [("interpreter", &interp), ("jit scalar", &jit)] {
            let mut one = vec![f32::NAN; w];
            let ctx = ShadeCtx {
                frag: *f,
                env: &env,
                mask: u32::MAX,
                scene: scene.fragment(i),
            };
            m.shade(&ctx, &mut one);
            check(i, Run::Scalar(what), &one);
            let ctx = ShadeCtx { scene: None, ..ctx };
            m.shade(&ctx, &mut one);
            check(i, Run::NoScene(what), &one);
        }
        check(i, Run::Batch, &batch[i * w..(i + 1) * w]);
    }
}

/// The IR text form of `attribute` round-trips; validation names a slot past the table and
/// a default of the wrong type.
#[test]
fn attribute_ops_print_parse_and_validate() {
    let p = ir::parse(ATTRIBUTES).unwrap();
    ir::validate(&p).unwrap();
    assert_eq!(p.to_string(), ATTRIBUTES);
    assert_eq!(p.attributes.len(), 4);
    let bad_slot = ATTRIBUTES.replace("attribute #3 %6", "attribute #4 %6");
    let e = ir::validate(&ir::parse(&bad_slot).unwrap()).unwrap_err();
    assert!(
        e.to_string()
            .contains("reads attribute 4, but the program has 4"),
        "{e}"
    );
    let bad_default = ATTRIBUTES.replace("attribute #3 %6", "attribute #3 %4");
    let e = ir::validate(&ir::parse(&bad_default).unwrap()).unwrap_err();
    assert!(
        e.to_string()
            .contains("is a color4 but its default is a color"),
        "{e}"
    );
}

/// The interpreter, the JIT's scalar entry and its batch entry (`shade_many`, each lane
/// asking its own fragment's services) read attributes through the one lookup: the same
/// bits, the scene's values where it has them, the default where it has none, where a
/// value is not finite, and without a scene.
#[test]
fn attributes_agree_across_interpreter_jit_scalar_and_batch() {
    let p = ir::parse(ATTRIBUTES).unwrap();
    let defaults: [&[f32]; 4] = [
        &[-1.0],
        &[-2.0, -3.0],
        &[-4.0, -5.0, -6.0],
        &[-7.0, -8.0, -9.0, -10.0],
    ];
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    on_cpu_backends(&p, 10, |i, run, got| {
        let want: Vec<f32> = (0..4)
            .flat_map(|s| tagged_attribute(i, s, defaults[s as usize]))
            .collect();
        match run {
            Run::Scalar(what) => assert_eq!(bits(got), bits(&want), "fragment {i}: {what}"),
            // Without a scene: the defaults.
            Run::NoScene(what) => assert_eq!(
                got,
                defaults.concat(),
                "fragment {i}: {what} without a scene"
            ),
            Run::Batch => assert_eq!(bits(got), bits(&want), "fragment {i}: jit batch"),
        }
    });
}

/// [`ATTRIBUTES`]' slots asked whether they are found ([`ir::Op::AttributeFound`]): 1 or
/// 0 per slot, then slot 2's value with its default.
const ATTRIBUTES_FOUND: &str = "program \"found\" {
  attribute \"_temp\" float
  attribute \"TEXCOORD_1\" vec2
  attribute \"COLOR_0\" color
  attribute \"COLOR_1\" color4
  %0 = const 1.0 : float
  %1 = const 0.0 : float
  %2 = attribute.found #0 : bool
  %3 = select %2, %0, %1 : float
  %4 = attribute.found #1 : bool
  %5 = select %4, %0, %1 : float
  %6 = attribute.found #2 : bool
  %7 = select %6, %0, %1 : float
  %8 = attribute.found #3 : bool
  %9 = select %8, %0, %1 : float
  %10 = const (-4.0, -5.0, -6.0) : color
  %11 = attribute #2 %10 : color
  output a %3
  output b %5
  output c %7
  output d %9
  output v %11
}
";

/// `attribute.found` prints and parses, validates its slot, and is true on the
/// interpreter, the JIT's scalar entry and its batch entry exactly where `attribute` gives
/// the scene's value (not where the scene has none, gives a non-finite value, or there is
/// no scene); the needs list its attributes; the GPU back end refuses it (no attribute
/// buffers) and the material falls back to a CPU back end.
#[test]
fn attribute_found_agrees_with_the_lookup_on_every_back_end() {
    let p = ir::parse(ATTRIBUTES_FOUND).unwrap();
    ir::validate(&p).unwrap();
    assert_eq!(p.to_string(), ATTRIBUTES_FOUND);
    let bad = ATTRIBUTES_FOUND.replace("attribute.found #3", "attribute.found #4");
    let e = ir::validate(&ir::parse(&bad).unwrap()).unwrap_err();
    assert!(
        e.to_string()
            .contains("reads attribute 4, but the program has 4"),
        "{e}"
    );
    let (o, report) = opt::run(&p, &Specialization::default());
    assert_eq!(report.needs.attributes.len(), 4);
    assert!(o.to_string().contains("attribute.found #3"), "{o}");
    let widths = [1, 2, 3, 4];
    let mut founds = 0;
    on_cpu_backends(&o, 7, |i, run, got| {
        let mut want: Vec<f32> = (0..4u32)
            .map(|s| {
                let d = vec![f32::NAN; widths[s as usize]];
                let got = tagged_attribute(i, s, &d);
                f32::from(u8::from(!got[0].is_nan()))
            })
            .collect();
        want.extend(tagged_attribute(i, 2, &[-4.0, -5.0, -6.0]));
        let none = [0.0, 0.0, 0.0, 0.0, -4.0, -5.0, -6.0];
        match run {
            Run::Scalar(what) => assert_eq!(got, want, "fragment {i}: {what}"),
            Run::NoScene(what) => assert_eq!(got, none, "fragment {i}: {what} without a scene"),
            Run::Batch => {
                founds += want[..4].iter().filter(|x| **x == 1.0).count();
                assert_eq!(got, &want[..], "fragment {i}: jit batch");
            }
        }
    });
    assert!(
        founds > 40 && founds < 4 * 43,
        "found {founds} of {}",
        4 * 43
    );
    // The GPU has no attribute buffers: it refuses the op, naming why (and with its
    // fallback, the material runs on the CPU back end it falls back to).
    if shadenet_gpu::testing::device_or_skip("attribute_found (GPU)").is_some() {
        let gpu = || {
            shadenet_gpu::GpuBackend::new(
                shadenet_gpu::GpuOptions::default(),
                std::sync::Arc::new(shadenet_runtime::InterpBackend),
            )
            .unwrap()
        };
        let strict = gpu().without_fallback();
        let err = strict
            .compile_program(&o, Duration::ZERO)
            .err()
            .expect("the GPU refuses attribute ops")
            .to_string();
        assert!(err.contains("attribute"), "{err}");
        let m = gpu().compile_program(&o, Duration::ZERO).unwrap();
        assert_eq!(m.info().backend, "interp");
        let (env, scene) = (
            ShadeEnv::default(),
            shadenet_runtime::testing::TaggedScene::with_fragments(43),
        );
        let mut one = vec![f32::NAN; 7];
        let ctx = ShadeCtx {
            frag: Fragment {
                p: [1.0, 0.0, 0.0],
                ..Fragment::default()
            },
            env: &env,
            mask: u32::MAX,
            scene: scene.fragment(1),
        };
        m.shade(&ctx, &mut one);
        assert_eq!(one[..4], [1.0, 1.0, 1.0, 0.0]);
    }
}

/// The needs list an attribute only while a live op reads it; a program without attribute
/// ops has an empty table and needs none (it prints and compiles as before: no `attribute`
/// line), and the table's slots survive optimization.
#[test]
fn needs_list_only_live_attributes() {
    let p = ir::parse(ATTRIBUTES).unwrap();
    let (o, report) = opt::run(&p, &Specialization::default());
    let names: Vec<&str> = report
        .needs
        .attributes
        .iter()
        .map(|a| a.name.as_str())
        .collect();
    assert_eq!(names, ["COLOR_0", "COLOR_1", "TEXCOORD_1", "_temp"]);
    assert_eq!(o.attributes, p.attributes, "slots are stable");
    // Only `a` and `c` live: the others are not needed.
    let mut dead = p.clone();
    dead.outputs.retain(|o| o.name == "a" || o.name == "c");
    let (o, report) = opt::run(&dead, &Specialization::default());
    let names: Vec<&str> = report
        .needs
        .attributes
        .iter()
        .map(|a| a.name.as_str())
        .collect();
    assert_eq!(names, ["COLOR_0", "_temp"]);
    assert!(
        report
            .needs
            .to_string()
            .contains("attributes: COLOR_0:color _temp:float")
    );
    assert_eq!(o.attributes.len(), 4);
    // No attribute op: nothing in the table, the needs or the text.
    let plain = ir::parse(
        "program \"p\" {\n  %0 = stream uv : vec2\n  %1 = extract %0, 0 : float\n  output x %1\n}\n",
    )
    .unwrap();
    let (o, report) = opt::run(&plain, &Specialization::default());
    assert!(o.attributes.is_empty() && report.needs.attributes.is_empty());
    assert!(
        !o.to_string().contains("attribute") && !report.needs.to_string().contains("attributes")
    );
}
