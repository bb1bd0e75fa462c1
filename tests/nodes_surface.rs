//! Surface shaders (lambert, phong, blinn, surfaceShader) and light nodes, checked against
//! formulas computed independently here in f64.
mod common;
use common::*;

use shadenet_graph::ir::Builder;
use shadenet_graph::lower::{Literal, declare_output, default_input, lower_single};
use shadenet_graph::nodes::{
    InputVal, LightDesc, LightKind, LowVal, NodeInputs, NodeKind, NodeLibrary, PortDefault,
};
use shadenet_graph::types::{ConstValue, Type};
use shadenet_runtime::Fragment;
use std::f64::consts::PI;

// ---- independent f64 helpers ----

type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn muls(a: V3, s: f64) -> V3 {
    a.map(|x| x * s)
}

fn mulv(a: V3, b: V3) -> V3 {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}

fn norm(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    if l == 0.0 { [0.0; 3] } else { muls(a, 1.0 / l) }
}

/// `v` rounded to f32, as a [`Fragment`] stores it: expectations use what the shader sees.
fn r32(v: V3) -> V3 {
    v.map(|x| x as f32 as f64)
}

fn deg(x: f64) -> f64 {
    x.to_radians()
}

/// A light description from a light node's defaults and `overrides`, through its LightFn.
fn light(node: &str, overrides: &[(&str, ConstValue)]) -> Result<LightDesc, String> {
    let lib = NodeLibrary::standard();
    let def = lib.get(node).expect("light node exists");
    let NodeKind::Light(f) = def.kind else {
        panic!("{node} is not a light");
    };
    let inputs: Vec<ConstValue> = def
        .inputs
        .iter()
        .map(|p| {
            overrides
                .iter()
                .find(|(n, _)| *n == p.name)
                .map(|(_, c)| c.clone())
                .unwrap_or_else(|| match &p.default {
                    PortDefault::Value(c) => c.clone(),
                    other => panic!("light port {} has default {other:?}", p.name),
                })
        })
        .collect();
    f(node, &inputs)
}

fn vec3(v: V3) -> ConstValue {
    ConstValue::Vec3(v)
}

fn col(v: V3) -> ConstValue {
    ConstValue::Color(v)
}

fn point_light(pos: V3, color: V3, intensity: f64) -> LightDesc {
    light(
        "pointLight",
        &[
            ("position", vec3(pos)),
            ("color", col(color)),
            ("intensity", ConstValue::Float(intensity)),
        ],
    )
    .unwrap()
}

fn distant_light(direction: V3, color: V3, intensity: f64) -> LightDesc {
    light(
        "directionalLight",
        &[
            ("direction", vec3(direction)),
            ("color", col(color)),
            ("intensity", ConstValue::Float(intensity)),
        ],
    )
    .unwrap()
}

fn ambient_light(color: V3, intensity: f64) -> LightDesc {
    light(
        "ambientLight",
        &[
            ("color", col(color)),
            ("intensity", ConstValue::Float(intensity)),
        ],
    )
    .unwrap()
}

/// A fragment at `p` with normal `n`, seen along `i` (eye → P).
fn frag(p: V3, n: V3, i: V3) -> Fragment {
    let f32s = |v: V3| v.map(|x| x as f32);
    Fragment {
        p: f32s(p),
        n: f32s(n),
        ng: f32s(n),
        i: f32s(i),
        ..plane_fragment()
    }
}

/// Relative closeness `|got − want| ≤ rel · max|want|` per component (absolute near 0).
fn assert_rel(got: &[f64], want: &[f64], rel: f64, what: &str) {
    let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-30);
    assert_close(got, want, rel * scale, what);
}

const Z: V3 = [0.0, 0.0, 1.0];

// ---- lambert ----

#[test]
fn lambert_plane_under_point_light_is_rho_over_pi_i_cos_over_r2() {
    let color = [0.6, 0.4, 0.2];
    let kd = 0.9;
    let light_color = [1.0, 0.5, 0.25];
    let intensity = 2.5;
    let rho = muls(color, kd);
    for theta_deg in [0.0, 20.0, 45.0, 70.0, 85.0] {
        for r in [0.5, 1.0, 3.0, 10.0] {
            let th = deg(theta_deg);
            let pos = [r * th.sin(), 0.0, r * th.cos()];
            let lights = [point_light(pos, light_color, intensity)];
            let o = eval_node(
                "lambert",
                Type::Float,
                &[
                    ("color", c(color[0], color[1], color[2])),
                    ("diffuse", f(kd)),
                ],
                &plane_fragment(),
                &lights,
            );
            let want: Vec<f64> = (0..3)
                .map(|k| rho[k] / PI * intensity * light_color[k] * th.cos() / (r * r))
                .collect();
            let what = format!("θ={theta_deg} r={r}");
            assert_rel(&o.get("outColor"), &want, 1e-12, &what);
            assert_rel(&o.get32("outColor"), &want, 1e-5, &what);
            assert_rel(&o.part("outColor", "diffuse").unwrap(), &want, 1e-12, &what);
            assert_eq!(o.nonfinite32, 0);
        }
    }
}

#[test]
fn lambert_defaults_and_pass_through_outputs() {
    let lights = [point_light([0.0, 0.0, 1.0], [1.0; 3], 1.0)];
    let o = eval_node(
        "lambert",
        Type::Float,
        &[
            ("transparency", c(0.1, 0.2, 0.3)),
            ("incandescence", c(0.5, 0.25, 0.0)),
            ("glowIntensity", f(2.0)),
        ],
        &plane_fragment(),
        &lights,
    );
    // default albedo 0.5 · 0.8 = 0.4; N·L = 1, r = 1
    let d = 0.4 / PI;
    assert_rel(
        &o.part("outColor", "diffuse").unwrap(),
        &[d; 3],
        1e-12,
        "diffuse",
    );
    assert_eq!(
        o.part("outColor", "emission").unwrap(),
        vec![0.5, 0.25, 0.0]
    );
    assert_eq!(
        o.part("outColor", "specular"),
        None,
        "lambert has no specular part"
    );
    assert_rel(
        &o.get("outColor"),
        &[d + 0.5, d + 0.25, d],
        1e-12,
        "outColor = diffuse + emission",
    );
    assert_rel(
        &o.get("outTransparency"),
        &[0.1, 0.2, 0.3],
        1e-12,
        "transparency",
    );
    assert_rel(&o.get("outGlow"), &[1.0, 0.5, 0.0], 1e-12, "glow");
}

// ---- phong and blinn against their formulas ----

fn phong_expected(n_: V3, l: V3, v: V3, cl: V3, ks: V3, n: f64) -> V3 {
    let ndl = dot(n_, l).max(0.0);
    let r = sub(muls(n_, 2.0 * dot(n_, l)), l);
    let rv = dot(r, v).max(0.0);
    muls(mulv(ks, cl), (n + 2.0) / (2.0 * PI) * rv.powf(n) * ndl)
}

fn blinn_k(n: f64) -> f64 {
    (n + 2.0) * (n + 4.0) / (8.0 * PI * (2f64.powf(-n / 2.0) + n))
}

fn blinn_expected(n_: V3, l: V3, v: V3, cl: V3, ks: V3, ecc: f64, r: f64) -> V3 {
    let e = ecc.clamp(0.01, 1.0);
    let n = 2.0 / (e * e) - 2.0;
    let ndl = dot(n_, l).max(0.0);
    let h = norm(add(l, v));
    let nh = dot(n_, h).max(0.0);
    let vh = dot(v, h).max(0.0);
    let fr = r + (1.0 - r) * (1.0 - vh).powi(5);
    muls(mulv(ks, cl), fr * blinn_k(n) * nh.powf(n) * ndl)
}

#[test]
fn phong_peak_at_mirror_direction_and_off_peak() {
    let ks = [0.9, 0.6, 0.3];
    for n in [1.0, 20.0, 100.0] {
        for theta_deg in [0.0, 30.0, 60.0] {
            let th = deg(theta_deg);
            let l = [th.sin(), 0.0, th.cos()];
            let r = 2.0;
            let cl = 1.5 / (r * r);
            let lights = [point_light(muls(l, r), [1.0; 3], 1.5)];
            // viewer at the mirror direction, then 5° and 15° off it
            for off_deg in [0.0, 5.0, 15.0] {
                let a = th + deg(off_deg);
                let i = r32([3.0 * a.sin(), 0.0, -3.0 * a.cos()]); // not normalized on purpose
                let v = norm(muls(i, -1.0));
                let o = eval_node(
                    "phong",
                    Type::Float,
                    &[
                        ("specularColor", c(ks[0], ks[1], ks[2])),
                        ("cosinePower", f(n)),
                    ],
                    &frag([0.0; 3], Z, i),
                    &lights,
                );
                let want = phong_expected(Z, l, v, [cl; 3], ks, n);
                if off_deg == 0.0 {
                    let peak = muls(ks, (n + 2.0) / (2.0 * PI) * cl * th.cos());
                    assert_rel(&want, &peak, 1e-5, "test formula at the peak");
                }
                let what = format!("phong n={n} θ={theta_deg} off={off_deg}");
                let got = o.part("outColor", "specular").unwrap();
                assert_rel(&got, &want, 1e-9, &what);
                let got32 = o
                    .entries
                    .iter()
                    .find(|e| e.1.as_deref() == Some("specular"));
                assert_rel(&got32.unwrap().2, &want, 1e-4, &what);
            }
        }
    }
}

#[test]
fn blinn_peak_at_half_vector_and_off_peak() {
    let ks = [0.9, 0.6, 0.3];
    for ecc in [0.1, 0.3, 0.7, 1.0] {
        for rolloff in [0.7, 1.0, 0.0] {
            for theta_deg in [0.0, 30.0, 60.0] {
                let th = deg(theta_deg);
                let l = [th.sin(), 0.0, th.cos()];
                let lights = [distant_light(muls(l, -1.0), [1.0, 0.8, 0.6], 2.0)];
                let cl = [2.0, 1.6, 1.2];
                for off_deg in [0.0, 4.0, 12.0] {
                    let a = th + deg(off_deg);
                    let v = r32([-a.sin(), 0.0, a.cos()]);
                    let o = eval_node(
                        "blinn",
                        Type::Float,
                        &[
                            ("specularColor", c(ks[0], ks[1], ks[2])),
                            ("eccentricity", f(ecc)),
                            ("specularRollOff", f(rolloff)),
                        ],
                        &frag([0.0; 3], Z, muls(v, -1.0)),
                        &lights,
                    );
                    let v = norm(v);
                    let want = blinn_expected(Z, l, v, cl, ks, ecc, rolloff);
                    if off_deg == 0.0 {
                        // H = N: N·H = 1, V·H = cos θ
                        let n = 2.0 / (ecc * ecc) - 2.0;
                        let fr = rolloff + (1.0 - rolloff) * (1.0 - th.cos()).powi(5);
                        let peak = muls(mulv(ks, cl), fr * blinn_k(n) * th.cos());
                        assert_rel(&want, &peak, 1e-6, "test formula at the peak");
                    }
                    let what = format!("blinn e={ecc} r={rolloff} θ={theta_deg} off={off_deg}");
                    let got = o.part("outColor", "specular").unwrap();
                    assert_rel(&got, &want, 1e-9, &what);
                }
            }
        }
    }
}

#[test]
fn blinn_eccentricity_zero_and_out_of_range_are_clamped() {
    let l = [0.0, 0.0, 1.0];
    let lights = [distant_light([0.0, 0.0, -1.0], [1.0; 3], 1.0)];
    for (ecc, used) in [(0.0, 0.01), (-1.0, 0.01), (2.0, 1.0), (f64::NAN, 0.01)] {
        let o = eval_node(
            "blinn",
            Type::Float,
            &[("eccentricity", f(ecc)), ("specularRollOff", f(1.0))],
            &plane_fragment(),
            &lights,
        );
        let want = blinn_expected(Z, l, Z, [1.0; 3], [0.5; 3], used, 1.0);
        let got = o.part("outColor", "specular").unwrap();
        assert_rel(&got, &want, 1e-9, &format!("ecc {ecc}"));
        assert!(got.iter().all(|x| x.is_finite()));
        assert_eq!(o.nonfinite32, 0, "ecc {ecc}");
    }
}

// ---- hard inputs ----

const SURFACES: [&str; 3] = ["lambert", "phong", "blinn"];

#[test]
fn grazing_and_back_facing_lights_give_zero() {
    // light exactly in the tangent plane (N·L = 0), and below it
    for pos in [
        [2.0, 0.0, 0.0],
        [0.0, 3.0, 0.0],
        [1.0, 0.0, -1.0],
        [0.0, 0.0, -2.0],
    ] {
        let lights = [
            point_light(pos, [1.0; 3], 5.0),
            distant_light(muls(pos, -1.0), [1.0; 3], 5.0),
        ];
        for node in SURFACES {
            for (blinn_v, i) in [(false, [0.0, 0.0, -1.0]), (true, [-1.0, 0.0, -0.2])] {
                let o = eval_node(node, Type::Float, &[], &frag([0.0; 3], Z, i), &lights);
                let what = format!("{node} light at {pos:?} (oblique view {blinn_v})");
                assert_eq!(o.get("outColor"), vec![0.0; 3], "{what}");
                assert_eq!(o.get32("outColor"), vec![0.0; 3], "{what}");
                assert_eq!(o.nonfinite32, 0, "{what}");
            }
        }
    }
}

#[test]
fn zero_normal_reflects_nothing_and_stays_finite() {
    let lights = [
        point_light([0.3, 0.2, 1.0], [1.0; 3], 3.0),
        distant_light([0.0, 0.0, -1.0], [1.0; 3], 1.0),
    ];
    for node in SURFACES {
        let o = eval_node(
            node,
            Type::Float,
            &[("normal", v(0.0, 0.0, 0.0))],
            &plane_fragment(),
            &lights,
        );
        assert_eq!(o.get("outColor"), vec![0.0; 3], "{node}");
        assert_eq!(o.get32("outColor"), vec![0.0; 3], "{node}");
        assert_eq!(o.part("outColor", "diffuse").unwrap(), vec![0.0; 3]);
        assert_eq!(o.nonfinite32, 0, "{node}");
    }
}

#[test]
fn zero_length_i_is_finite() {
    let mut fr = plane_fragment();
    fr.i = [0.0; 3];
    let l = norm([0.5, 0.0, 1.0]);
    let lights = [point_light(muls(l, 2.0), [1.0; 3], 4.0)];
    let cl = 1.0;
    for node in SURFACES {
        let o = eval_node(node, Type::Float, &[], &fr, &lights);
        let diffuse = 0.4 / PI * cl * l[2];
        assert_rel(
            &o.part("outColor", "diffuse").unwrap(),
            &[diffuse; 3],
            1e-12,
            node,
        );
        assert!(o.get32("outColor").iter().all(|x| x.is_finite()));
        assert_eq!(o.nonfinite32, 0, "{node}");
    }
    // phong: V = 0, so R·V = 0 and the highlight is 0 (n = 20 > 0)
    let o = eval_node("phong", Type::Float, &[], &fr, &lights);
    assert_eq!(o.part("outColor", "specular").unwrap(), vec![0.0; 3]);
    // blinn: V = 0, so H = L, N·H = N·L, V·H = 0 and F = 1
    let o = eval_node("blinn", Type::Float, &[], &fr, &lights);
    let want = blinn_expected(Z, l, [0.0; 3], [cl; 3], [0.5; 3], 0.3, 0.7);
    let n = 2.0 / 0.09 - 2.0;
    assert_rel(
        &want,
        &[0.5 * blinn_k(n) * l[2].powf(n) * l[2]; 3],
        1e-12,
        "formula",
    );
    assert_rel(
        &o.part("outColor", "specular").unwrap(),
        &want,
        1e-9,
        "blinn V = 0",
    );
}

#[test]
fn nan_normal_gives_zero_light_and_the_guard_catches_nan_colors() {
    // A NaN normal: every cosine is max(NaN, 0) = 0, so nothing non-finite reaches the
    // output at all.
    let mut fr = plane_fragment();
    fr.n = [f32::NAN, 0.0, 1.0];
    let lights = [point_light([0.0, 0.0, 1.0], [1.0; 3], 1.0)];
    for node in SURFACES {
        let o = eval_node(node, Type::Float, &[], &fr, &lights);
        assert_eq!(o.get32("outColor"), vec![0.0; 3], "{node}");
        assert_eq!(o.get("outColor"), vec![0.0; 3], "{node}");
        assert_eq!(o.nonfinite32, 0, "{node}");
    }
    // A NaN color does reach the diffuse part: the guard turns it into 0 and counts it.
    for node in SURFACES {
        let o = eval_node(
            node,
            Type::Float,
            &[("color", c(f64::NAN, 0.5, 0.5))],
            &plane_fragment(),
            &lights,
        );
        assert!(o.nonfinite32 > 0, "{node}");
        let d = o.part("outColor", "diffuse").unwrap();
        assert_eq!(d[0], 0.0, "{node}: guarded");
        assert_rel(&d[1..], &[0.4 / PI; 2], 1e-12, node);
    }
}

#[test]
fn point_light_at_the_shaded_point_gives_zero() {
    let lights = [point_light([0.0; 3], [1.0; 3], 10.0)];
    for node in SURFACES {
        let o = eval_node(node, Type::Float, &[], &plane_fragment(), &lights);
        assert_eq!(o.get("outColor"), vec![0.0; 3], "{node}");
        assert_eq!(o.get32("outColor"), vec![0.0; 3], "{node}");
        assert_eq!(o.nonfinite32, 0, "{node}");
    }
}

// ---- light types ----

fn smoothstep(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

#[test]
fn spot_light_cone_penumbra_and_dropoff() {
    // spot 2 above the plane pointing down; cone 40° (half 20°), penumbra 10° outwards
    let h = 2.0;
    let intensity = 3.0;
    let rho = 0.4;
    let spot = |dropoff: f64| {
        light(
            "spotLight",
            &[
                ("position", vec3([0.0, 0.0, h])),
                ("direction", vec3([0.0, 0.0, -1.0])),
                ("intensity", ConstValue::Float(intensity)),
                ("coneAngle", ConstValue::Float(40.0)),
                ("penumbraAngle", ConstValue::Float(10.0)),
                ("dropoff", ConstValue::Float(dropoff)),
            ],
        )
        .unwrap()
    };
    let (cos_in, cos_out) = (deg(20.0).cos(), deg(30.0).cos());
    for (alpha_deg, region) in [
        (0.0, "axis"),
        (10.0, "inside"),
        (25.0, "penumbra"),
        (35.0, "outside"),
    ] {
        for dropoff in [0.0, 3.0] {
            let x = (h * deg(alpha_deg).tan()) as f32 as f64;
            let r2 = x * x + h * h;
            let cos_a = h / r2.sqrt();
            let cone = if cos_a >= cos_in {
                1.0
            } else if cos_a <= cos_out {
                0.0
            } else {
                smoothstep((cos_a - cos_out) / (cos_in - cos_out))
            };
            let fall = cos_a.powf(dropoff);
            let ndl = cos_a;
            let want = rho / PI * intensity / r2 * cone * fall * ndl;
            let o = eval_node(
                "lambert",
                Type::Float,
                &[],
                &frag([x, 0.0, 0.0], Z, [0.0, 0.0, -1.0]),
                &[spot(dropoff)],
            );
            let got = o.part("outColor", "diffuse").unwrap();
            let what = format!("{region} α={alpha_deg} dropoff={dropoff}");
            assert_rel(&got, &[want; 3], 1e-9, &what);
            assert_rel(&o.get32("outColor"), &[want; 3], 1e-5, &what);
            match region {
                "penumbra" => {
                    let full = rho / PI * intensity / r2 * fall * ndl;
                    assert!(
                        got[0] > 0.0 && got[0] < full,
                        "{what}: {got:?} vs full {full}"
                    );
                }
                "outside" => assert_eq!(got, vec![0.0; 3], "{what}"),
                _ => assert!(cone == 1.0),
            }
        }
    }
}

#[test]
fn directional_light_delivers_its_irradiance() {
    let e = [2.0, 1.0, 0.5];
    let lights = [distant_light([-1.0, 0.0, -1.0], e, 1.0)]; // arrives at 45°
    for p in [[0.0; 3], [100.0, -50.0, 0.0]] {
        let o = eval_node(
            "lambert",
            Type::Float,
            &[],
            &frag(p, Z, [0.0, 0.0, -1.0]),
            &lights,
        );
        let want: Vec<f64> = e.iter().map(|x| 0.4 / PI * x * deg(45.0).cos()).collect();
        assert_rel(&o.get("outColor"), &want, 1e-12, "distant");
        assert_rel(&o.get32("outColor"), &want, 1e-6, "distant f32");
    }
}

#[test]
fn ambient_light_is_reflected_as_albedo_times_radiance_in_indirect() {
    let la = [0.5, 0.25, 1.0];
    let lights = [ambient_light(la, 2.0)];
    let color = [0.8, 0.6, 0.4];
    let amb_color = [0.1, 0.2, 0.3];
    for node in SURFACES {
        let o = eval_node(
            node,
            Type::Float,
            &[
                ("color", c(color[0], color[1], color[2])),
                ("diffuse", f(0.5)),
                ("ambientColor", c(amb_color[0], amb_color[1], amb_color[2])),
            ],
            &plane_fragment(),
            &lights,
        );
        let want: Vec<f64> = (0..3)
            .map(|k| color[k] * 0.5 * la[k] * 2.0 + color[k] * amb_color[k])
            .collect();
        assert_rel(&o.part("outColor", "indirect").unwrap(), &want, 1e-12, node);
        assert_eq!(
            o.part("outColor", "diffuse").unwrap(),
            vec![0.0; 3],
            "{node}"
        );
        assert_rel(&o.get("outColor"), &want, 1e-12, node);
    }
}

#[test]
fn multiple_lights_sum() {
    let lights = vec![
        point_light([1.0, 0.5, 2.0], [1.0, 0.9, 0.8], 4.0),
        distant_light([0.3, -0.2, -1.0], [0.5, 0.5, 1.0], 1.5),
        light(
            "spotLight",
            &[
                ("position", vec3([-1.0, 0.0, 3.0])),
                ("direction", vec3([1.0, 0.0, -3.0])),
                ("coneAngle", ConstValue::Float(60.0)),
                ("intensity", ConstValue::Float(7.0)),
            ],
        )
        .unwrap(),
        ambient_light([0.2, 0.2, 0.2], 1.0),
    ];
    let i = [0.3, -0.1, -1.0];
    for node in SURFACES {
        let fr = frag([0.1, 0.2, 0.0], Z, i);
        let all = eval_node(node, Type::Float, &[], &fr, &lights);
        let mut sum = [0.0; 3];
        for l in &lights {
            let one = eval_node(node, Type::Float, &[], &fr, std::slice::from_ref(l));
            let one: V3 = one.get("outColor").try_into().unwrap();
            assert!(
                one.iter().all(|x| *x > 0.0),
                "{node}: {} contributes",
                l.name
            );
            sum = add(sum, one);
        }
        assert_rel(&all.get("outColor"), &sum, 1e-12, node);
    }
}

// ---- render components ----

fn phong_scene() -> (Fragment, Vec<LightDesc>, Vec<(&'static str, Literal)>) {
    let l = norm([0.4, -0.3, 1.0]);
    let v = r32(norm([-0.35, 0.3, 1.0]));
    let fr = frag([0.0; 3], Z, muls(v, -1.0));
    let lights = vec![
        point_light(muls(l, 2.0), [1.0, 0.8, 0.6], 4.0),
        ambient_light([0.1, 0.2, 0.3], 1.0),
    ];
    let inputs = vec![
        ("color", c(0.7, 0.5, 0.3)),
        ("diffuse", f(0.8)),
        ("incandescence", c(0.05, 0.0, 0.1)),
        ("specularColor", c(0.6, 0.6, 0.6)),
        ("cosinePower", f(10.0)),
    ];
    (fr, lights, inputs)
}

#[test]
fn phong_components_equal_their_terms_and_sum_to_the_total() {
    let (fr, lights, inputs) = phong_scene();
    let o = eval_node("phong", Type::Float, &inputs, &fr, &lights);
    let l = norm([0.4, -0.3, 1.0]);
    let v = norm(r32(norm([-0.35, 0.3, 1.0])));
    let cl = [1.0, 0.8, 0.6].map(|x| x * 4.0 / 4.0);
    let albedo = muls([0.7, 0.5, 0.3], 0.8);
    let diffuse = muls(mulv(albedo, cl), l[2] / PI);
    let specular = phong_expected(Z, l, v, cl, [0.6; 3], 10.0);
    let indirect = mulv(albedo, [0.1, 0.2, 0.3]);
    let emission = [0.05, 0.0, 0.1];
    assert_rel(
        &o.part("outColor", "diffuse").unwrap(),
        &diffuse,
        1e-12,
        "diffuse",
    );
    assert_rel(
        &o.part("outColor", "specular").unwrap(),
        &specular,
        1e-9,
        "specular",
    );
    assert_rel(
        &o.part("outColor", "indirect").unwrap(),
        &indirect,
        1e-12,
        "indirect",
    );
    assert_rel(
        &o.part("outColor", "emission").unwrap(),
        &emission,
        1e-12,
        "emission",
    );
    let total = add(add(diffuse, specular), add(indirect, emission));
    assert_rel(&o.get("outColor"), &total, 1e-9, "total");
    // Reflection and refraction are traced: without a scene (and with the defaults:
    // reflectivity 0, refractions off) they are 0.
    for k in ["reflection", "refraction"] {
        assert_eq!(o.part("outColor", k).unwrap(), vec![0.0; 3], "{k}");
    }
    let parts = o.entries.iter().filter(|e| e.0 == "outColor").count();
    assert_eq!(parts, 6, "outColor has exactly six parts");
}

#[test]
fn masking_out_specular_zeroes_it_and_leaves_diffuse_unchanged() {
    let (fr, lights, inputs) = phong_scene();
    let lib = NodeLibrary::standard();
    for node in ["phong", "blinn"] {
        let inputs: Vec<_> = inputs
            .iter()
            .filter(|(n, _)| *n != "cosinePower")
            .cloned()
            .collect();
        let program = lower_single(&lib, node, Type::Float, &inputs).unwrap();
        let mut names = program.components.clone();
        names.sort();
        assert_eq!(
            names,
            [
                "diffuse",
                "emission",
                "indirect",
                "reflection",
                "refraction",
                "shadow",
                "specular"
            ]
        );
        let spec = program.component_index("specular").unwrap();
        let full = run_program(&program, &fr, &lights, u32::MAX);
        let masked = run_program(&program, &fr, &lights, !(1u32 << spec));
        assert!(
            full.part("outColor", "specular").unwrap()[0] > 0.0,
            "{node}"
        );
        assert_eq!(masked.part("outColor", "specular").unwrap(), vec![0.0; 3]);
        for k in ["diffuse", "indirect", "emission"] {
            assert_eq!(
                masked.part("outColor", k),
                full.part("outColor", k),
                "{node} {k}"
            );
        }
        let only_emission = 1u32 << program.component_index("emission").unwrap();
        let e = run_program(&program, &fr, &lights, only_emission);
        assert_eq!(e.get("outColor"), vec![0.05, 0.0, 0.1]);
    }
}

// ---- energy ----

/// Directional albedo for a viewer along `v`: ∫ f(L, V) cos θ_L dω_L by the midpoint rule
/// over (θ, φ) cells, each cell a directional light of irradiance equal to its solid angle,
/// so one shading call sums the whole integral.
fn directional_albedo(node: &str, inputs: &[(&str, Literal)], v: V3, nt: usize, np: usize) -> f64 {
    let mut lights = Vec::new();
    for i in 0..nt {
        let (t0, t1) = (
            i as f64 * PI / 2.0 / nt as f64,
            (i + 1) as f64 * PI / 2.0 / nt as f64,
        );
        let t = 0.5 * (t0 + t1);
        let d_omega = (t0.cos() - t1.cos()) * 2.0 * PI / np as f64;
        for j in 0..np {
            let p = (j as f64 + 0.5) * 2.0 * PI / np as f64;
            let l = [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
            lights.push(distant_light(muls(l, -1.0), [1.0; 3], d_omega));
        }
    }
    let o = eval_node(
        node,
        Type::Float,
        inputs,
        &frag([0.0; 3], Z, muls(v, -1.0)),
        &lights,
    );
    o.part("outColor", "specular").unwrap()[0]
}

#[test]
fn normalized_lobes_reflect_at_most_what_they_receive() {
    // At normal incidence the integrand does not depend on φ: a fine θ grid suffices. It is
    // exactly 1 analytically for both lobes; the quadrature is good to better than 1e-3.
    let white = c(1.0, 1.0, 1.0);
    for n in [1.0, 5.0, 20.0, 100.0] {
        let inputs = [("specularColor", white.clone()), ("cosinePower", f(n))];
        let a0 = directional_albedo("phong", &inputs, Z, 512, 4);
        assert!((a0 - 1.0).abs() <= 1e-3, "phong n={n}: albedo {a0}");
    }
    for ecc in [1.0, 0.5, 0.3, 0.1] {
        let inputs = [
            ("specularColor", white.clone()),
            ("eccentricity", f(ecc)),
            ("specularRollOff", f(1.0)),
        ];
        let a0 = directional_albedo("blinn", &inputs, Z, 512, 4);
        assert!((a0 - 1.0).abs() <= 1e-3, "blinn e={ecc}: albedo {a0}");
        // the roll-off only removes energy
        let rolled = [
            ("specularColor", white.clone()),
            ("eccentricity", f(ecc)),
            ("specularRollOff", f(0.7)),
        ];
        let a_r = directional_albedo("blinn", &rolled, Z, 512, 4);
        assert!(a_r < a0, "blinn e={ecc} roll-off 0.7: {a_r} vs {a0}");
    }
    // Oblique incidence (45°): a 2D grid; the lobes lose energy below the horizon.
    let oblique = norm([1.0, 0.0, 1.0]);
    for n in [5.0, 20.0] {
        let inputs = [("specularColor", white.clone()), ("cosinePower", f(n))];
        let a = directional_albedo("phong", &inputs, oblique, 160, 160);
        assert!(a > 0.5 && a < 1.0, "phong n={n} at 45°: albedo {a}");
    }
    for ecc in [0.5, 0.3] {
        let inputs = [
            ("specularColor", white.clone()),
            ("eccentricity", f(ecc)),
            ("specularRollOff", f(1.0)),
        ];
        let a = directional_albedo("blinn", &inputs, oblique, 160, 160);
        assert!(a > 0.5 && a < 1.0, "blinn e={ecc} at 45°: albedo {a}");
    }
}

// ---- surfaceShader ----

#[test]
fn surface_shader_tags_a_plain_color_as_emission() {
    let lib = NodeLibrary::standard();
    let program = lower_single(
        &lib,
        "surfaceShader",
        Type::Float,
        &[
            ("outColor", c(0.25, 0.5, 1.0)),
            ("outTransparency", c(0.5, 0.5, 0.5)),
        ],
    )
    .unwrap();
    let lights = [point_light([0.0, 0.0, 1.0], [1.0; 3], 100.0)];
    let o = run_program(&program, &plane_fragment(), &lights, u32::MAX);
    assert_eq!(
        o.part("outColor", "emission").unwrap(),
        vec![0.25, 0.5, 1.0]
    );
    assert_eq!(
        o.get("outColor"),
        vec![0.25, 0.5, 1.0],
        "lights are ignored"
    );
    assert_eq!(o.get("outTransparency"), vec![0.5, 0.5, 0.5]);
    assert_eq!(o.get("outGlow"), vec![0.0; 3]);
    let off = run_program(&program, &plane_fragment(), &lights, 0);
    assert_eq!(off.get("outColor"), vec![0.0; 3]);
}

#[test]
fn surface_shader_keeps_the_parts_of_a_shaded_input() {
    let lib = NodeLibrary::standard();
    let lambert = lib.get("lambert").unwrap();
    let shader = lib.get("surfaceShader").unwrap();
    let mut b = Builder::new("t");
    let values: Vec<InputVal> = (0..lambert.inputs.len())
        .map(|i| default_input(&mut b, lambert, i, Type::Float))
        .collect();
    let ni = NodeInputs {
        node: "l",
        def: lambert,
        generic: Type::Float,
        values,
        upstream: None,
    };
    let outs = (lambert.lower)(&mut b, &ni).unwrap();
    assert_eq!(outs[0].parts.len(), 5);
    let mut values = vec![InputVal::Value(outs[0].clone())];
    for i in 1..shader.inputs.len() {
        values.push(default_input(&mut b, shader, i, Type::Float));
    }
    let ni = NodeInputs {
        node: "s",
        def: shader,
        generic: Type::Float,
        values,
        upstream: None,
    };
    let souts: Vec<LowVal> = (shader.lower)(&mut b, &ni).unwrap();
    assert_eq!(souts[0], outs[0], "parts passed through unchanged");
    declare_output(&mut b, "outColor", &souts[0]);
    let program = b.finish().unwrap();
    let lights = [point_light([0.0, 0.0, 1.0], [1.0; 3], 1.0)];
    let o = run_program(&program, &plane_fragment(), &lights, u32::MAX);
    assert_rel(
        &o.part("outColor", "diffuse").unwrap(),
        &[0.4 / PI; 3],
        1e-12,
        "diffuse",
    );
    assert_eq!(o.part("outColor", "emission").unwrap(), vec![0.0; 3]);
}

// ---- light nodes ----

#[test]
fn light_nodes_build_their_descriptions() {
    let lib = NodeLibrary::standard();
    for name in [
        "pointLight",
        "spotLight",
        "directionalLight",
        "ambientLight",
    ] {
        let def = lib.get(name).unwrap();
        assert!(matches!(def.kind, NodeKind::Light(_)), "{name}");
        assert!(def.outputs.is_empty(), "{name}");
        assert_eq!(def.category, "light");
        let mut b = Builder::new("t");
        let ni = NodeInputs {
            node: name,
            def,
            generic: Type::Float,
            values: Vec::new(),
            upstream: None,
        };
        assert_eq!((def.lower)(&mut b, &ni), Ok(Vec::new()), "{name}");
    }

    let p = light("pointLight", &[]).unwrap();
    assert_eq!(p.name, "pointLight");
    assert_eq!(p.power, [1.0; 3]);
    assert_eq!(p.kind, LightKind::Point { position: [0.0; 3] });

    let p = light(
        "pointLight",
        &[
            ("color", col([1.0, 0.5, 0.25])),
            ("intensity", ConstValue::Float(4.0)),
            ("position", vec3([1.0, 2.0, 3.0])),
        ],
    )
    .unwrap();
    assert_eq!(p.power, [4.0, 2.0, 1.0]);
    assert_eq!(
        p.kind,
        LightKind::Point {
            position: [1.0, 2.0, 3.0]
        }
    );

    let s = light(
        "spotLight",
        &[
            ("color", col([0.5, 1.0, 1.0])),
            ("intensity", ConstValue::Float(2.0)),
            ("direction", vec3([0.0, -3.0, -4.0])),
            ("penumbraAngle", ConstValue::Float(-5.0)),
            ("dropoff", ConstValue::Float(2.0)),
        ],
    )
    .unwrap();
    assert_eq!(s.power, [1.0, 2.0, 2.0]);
    let LightKind::Spot {
        position,
        direction,
        cone_angle,
        penumbra_angle,
        dropoff,
    } = s.kind
    else {
        panic!("not a spot: {s:?}");
    };
    assert_eq!(position, [0.0; 3]);
    assert_close(
        &direction,
        &[0.0, -0.6, -0.8],
        1e-15,
        "spot direction normalized",
    );
    assert!((cone_angle - 40f64.to_radians()).abs() < 1e-15);
    assert!((penumbra_angle + 5f64.to_radians()).abs() < 1e-15);
    assert_eq!(dropoff, 2.0);
    let s = light("spotLight", &[]).unwrap();
    assert!(matches!(
        s.kind,
        LightKind::Spot {
            direction: [0.0, 0.0, -1.0],
            ..
        }
    ));

    let d = light("directionalLight", &[("direction", vec3([3.0, 0.0, 4.0]))]).unwrap();
    assert_eq!(d.power, [1.0; 3]);
    let LightKind::Distant { direction } = d.kind else {
        panic!("not distant: {d:?}");
    };
    assert_close(
        &direction,
        &[0.6, 0.0, 0.8],
        1e-15,
        "distant direction normalized",
    );

    let a = ambient_light([0.2, 0.4, 0.6], 0.5);
    assert_eq!(a.kind, LightKind::Ambient);
    assert_close(&a.power, &[0.1, 0.2, 0.3], 1e-15, "ambient power");

    // negative intensity is allowed (a light that removes light)
    let neg = light("pointLight", &[("intensity", ConstValue::Float(-1.0))]).unwrap();
    assert_eq!(neg.power, [-1.0; 3]);
}

#[test]
fn light_nodes_reject_bad_inputs_naming_the_port() {
    let zero = vec3([0.0; 3]);
    let e = light("spotLight", &[("direction", zero.clone())]).unwrap_err();
    assert!(e.contains("`direction`") && e.contains("zero"), "{e}");
    let e = light("directionalLight", &[("direction", zero)]).unwrap_err();
    assert!(e.contains("`direction`"), "{e}");
    let e = light("pointLight", &[("intensity", ConstValue::Float(f64::NAN))]).unwrap_err();
    assert!(e.contains("`intensity`"), "{e}");
    let e = light(
        "pointLight",
        &[("position", vec3([f64::INFINITY, 0.0, 0.0]))],
    )
    .unwrap_err();
    assert!(e.contains("`position`"), "{e}");
    let e = light("spotLight", &[("coneAngle", ConstValue::Float(200.0))]).unwrap_err();
    assert!(e.contains("`coneAngle`"), "{e}");
    let e = light("spotLight", &[("dropoff", ConstValue::Float(-1.0))]).unwrap_err();
    assert!(e.contains("`dropoff`"), "{e}");
    // too few inputs is an error, not a panic
    let lib = NodeLibrary::standard();
    let NodeKind::Light(f) = lib.get("spotLight").unwrap().kind else {
        panic!()
    };
    assert!(f("s", &[col([1.0; 3])]).is_err());
    assert!(f("s", &[ConstValue::Bool(true)]).is_err());
}

// ---- precision ----

/// A tiny deterministic generator for the sweep.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    fn dir(&mut self) -> V3 {
        loop {
            let v = [
                2.0 * self.next() - 1.0,
                2.0 * self.next() - 1.0,
                2.0 * self.next() - 1.0,
            ];
            let l2 = dot(v, v);
            if l2 > 0.01 && l2 <= 1.0 {
                return norm(v);
            }
        }
    }
}

/// f32 and f64 agree to 2e-5 relative to the largest output component of each call (the
/// sweep's worst case is printed: about 4e-6, with exponents up to 100).
#[test]
fn f32_agrees_with_f64_on_a_sweep() {
    let lib = NodeLibrary::standard();
    let mut rng = Lcg(7);
    let mut worst: f64 = 0.0;
    for node in SURFACES {
        for case in 0..40 {
            let n = rng.dir();
            let n = if dot(n, Z) < 0.0 { muls(n, -1.0) } else { n };
            let v = rng.dir();
            let v = if dot(v, n) < 0.0 { muls(v, -1.0) } else { v };
            let p = [rng.next() * 4.0 - 2.0, rng.next() * 4.0 - 2.0, rng.next()];
            let lights = vec![
                point_light(
                    add(p, muls(rng.dir(), 1.0 + 3.0 * rng.next())),
                    [1.0, 0.7, 0.5],
                    5.0,
                ),
                distant_light(rng.dir(), [0.3, 0.6, 0.9], 2.0),
                ambient_light([0.05; 3], 1.0),
            ];
            let inputs = vec![
                ("color", c(rng.next(), rng.next(), rng.next())),
                ("cosinePower", f(1.0 + 99.0 * rng.next())),
                ("eccentricity", f(0.05 + 0.9 * rng.next())),
            ];
            let inputs: Vec<_> = inputs
                .into_iter()
                .filter(|(k, _)| lib.get(node).unwrap().input(k).is_some())
                .collect();
            let o = eval_node(
                node,
                Type::Float,
                &inputs,
                &frag(p, n, muls(v, -2.0)),
                &lights,
            );
            let (a, b) = (o.get32("outColor"), o.get("outColor"));
            let scale = b.iter().fold(1e-3f64, |m, x| m.max(x.abs()));
            for k in 0..3 {
                let err = (a[k] - b[k]).abs() / scale;
                worst = worst.max(err);
                assert!(err <= 2e-5, "{node} case {case}: f32 {a:?} vs f64 {b:?}");
            }
            assert_eq!(o.nonfinite32, 0);
        }
    }
    eprintln!("worst f32/f64 relative difference: {worst:e}");
}

// ---- docs ----

#[test]
fn every_surface_and_light_node_is_documented() {
    let lib = NodeLibrary::standard();
    let names = [
        "lambert",
        "phong",
        "blinn",
        "surfaceShader",
        "pointLight",
        "spotLight",
        "directionalLight",
        "ambientLight",
    ];
    for name in names {
        let def = lib.get(name).unwrap_or_else(|| panic!("{name} registered"));
        assert!(def.doc.len() > 100, "{name} doc");
        for p in &def.inputs {
            assert!(!p.doc.is_empty(), "{name}.{}", p.name);
        }
        for o in &def.outputs {
            assert!(!o.doc.is_empty(), "{name}.{}", o.name);
        }
    }
    let reference = lib.reference();
    assert!(reference.contains("## surface") && reference.contains("## light"));
    assert!(reference.contains("(n+2)/(2π)"));
}

/// The rules every source of lights shares (`LightDesc::new`): the field it names, and the
/// direction normalized as the light nodes normalize it.
#[test]
fn light_desc_new_checks_every_kind() {
    use shadenet_graph::nodes::{LightDesc, LightKind, MAX_LIGHT_SAMPLES};
    let field =
        |kind: LightKind, power: [f64; 3]| LightDesc::new("l", kind, power).map_err(|e| e.field);
    let spot = |cone_angle: f64, dropoff: f64, direction: [f64; 3]| LightKind::Spot {
        position: [0.0; 3],
        direction,
        cone_angle,
        penumbra_angle: 0.1,
        dropoff,
    };
    let quad = |edge_v: [f64; 3], samples: u32| LightKind::Quad {
        corner: [0.0; 3],
        edge_u: [1.0, 0.0, 0.0],
        edge_v,
        samples,
    };
    let ok = [1.0; 3];
    assert_eq!(
        field(spot(3.5, 0.0, [0.0, 0.0, 1.0]), ok),
        Err("cone_angle")
    );
    assert_eq!(
        field(spot(-0.1, 0.0, [0.0, 0.0, 1.0]), ok),
        Err("cone_angle")
    );
    assert_eq!(
        field(spot(f64::NAN, 0.0, [0.0, 0.0, 1.0]), ok),
        Err("cone_angle")
    );
    assert_eq!(field(spot(1.0, -1.0, [0.0, 0.0, 1.0]), ok), Err("dropoff"));
    assert_eq!(field(spot(1.0, 0.0, [0.0; 3]), ok), Err("direction"));
    assert_eq!(
        field(
            LightKind::Distant {
                direction: [0.0, f64::INFINITY, 0.0]
            },
            ok
        ),
        Err("direction")
    );
    assert_eq!(
        field(
            LightKind::Point {
                position: [0.0, 0.0, f64::NAN]
            },
            ok
        ),
        Err("position")
    );
    assert_eq!(
        field(LightKind::Ambient, [1.0, f64::NAN, 1.0]),
        Err("power")
    );
    assert_eq!(field(quad([2.0, 0.0, 0.0], 4), ok), Err("edge_v"));
    assert_eq!(field(quad([0.0, 1.0, 0.0], 0), ok), Err("samples"));
    assert_eq!(
        field(
            LightKind::Environment {
                samples: MAX_LIGHT_SAMPLES + 1,
                map: None,
            },
            ok
        ),
        Err("samples")
    );
    // Accepted: the full cone, negative power, a quad, directions normalized (x / |x|).
    assert!(field(spot(std::f64::consts::PI, 0.0, [0.0, 0.0, 1.0]), [-1.0; 3]).is_ok());
    assert!(field(quad([0.0, 1.0, 0.0], MAX_LIGHT_SAMPLES), ok).is_ok());
    let l = LightDesc::new(
        "d",
        LightKind::Distant {
            direction: [3.0, 0.0, 4.0],
        },
        ok,
    )
    .unwrap();
    assert_eq!(
        l.kind,
        LightKind::Distant {
            direction: [3.0 / 5.0, 0.0, 4.0 / 5.0]
        }
    );
}
