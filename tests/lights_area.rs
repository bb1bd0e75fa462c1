//! Monte Carlo lights against closed forms: a quad area light's irradiance (the rectangle
//! form factor) and a constant environment's (π·L), plus determinism and shadows.

use shadenet_graph::nodes::{LightDesc, LightKind};
use shadenet_runtime::lights::{Light, sample, sample_count};

fn irradiance(light: &Light, p: [f64; 3], n: [f64; 3], seed: u32) -> f64 {
    let mut e = 0.0;
    for k in 0..sample_count(light) {
        let s = sample::<f64>(light, 0, k, p, seed).unwrap();
        let cos = (s.l[0] * n[0] + s.l[1] * n[1] + s.l[2] * n[2]).max(0.0);
        e += s.cl[0] * cos;
    }
    e
}

/// Form factor from a point to a parallel a×b rectangle at height c, the point below one
/// corner (Howell's catalogue, configuration B-3); irradiance = π · L · F.
fn corner_factor(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let sx = (1.0 + x * x).sqrt();
    let sy = (1.0 + y * y).sqrt();
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

#[test]
fn quad_light_matches_the_rectangle_form_factor() {
    // A 1×1 quad at height 1, centred over the origin, facing down, radiance 2.
    let light = Light::from_desc(&LightDesc {
        name: "q".into(),
        kind: LightKind::Quad {
            corner: [-0.5, -0.5, 1.0],
            edge_u: [0.0, 1.0, 0.0],
            edge_v: [1.0, 0.0, 0.0],
            samples: 20000,
        },
        power: [2.0; 3],
    });
    let e = irradiance(&light, [0.0; 3], [0.0, 0.0, 1.0], 7);
    let want = 2.0 * std::f64::consts::PI * 4.0 * corner_factor(0.5, 0.5, 1.0);
    assert!((e - want).abs() / want < 0.01, "E = {e}, want {want}");
    // Seen from above, the one-sided light gives nothing.
    let e_back = irradiance(&light, [0.0, 0.0, 2.0], [0.0, 0.0, -1.0], 7);
    assert_eq!(e_back, 0.0);
}

#[test]
fn environment_irradiance_is_pi_l() {
    let light = Light::from_desc(&LightDesc {
        name: "sky".into(),
        kind: LightKind::Environment {
            samples: 40000,
            map: None,
        },
        power: [0.5; 3],
    });
    let e = irradiance(&light, [0.0; 3], [0.0, 0.0, 1.0], 3);
    let want = std::f64::consts::PI * 0.5;
    assert!((e - want).abs() / want < 0.02, "E = {e}, want {want}");
}

#[test]
fn samples_are_deterministic_in_the_seed_and_differ_between_seeds() {
    let light = Light::from_desc(&LightDesc {
        name: "q".into(),
        kind: LightKind::Quad {
            corner: [0.0, 0.0, 1.0],
            edge_u: [1.0, 0.0, 0.0],
            edge_v: [0.0, 1.0, 0.0],
            samples: 4,
        },
        power: [1.0; 3],
    });
    let a = sample::<f32>(&light, 0, 2, [0.1, 0.2, 0.0], 99).unwrap();
    let b = sample::<f32>(&light, 0, 2, [0.1, 0.2, 0.0], 99).unwrap();
    let c = sample::<f32>(&light, 0, 2, [0.1, 0.2, 0.0], 100).unwrap();
    assert_eq!(a, b);
    assert_ne!(a.to, c.to);
    assert_eq!(sample_count(&light), 4);
}

struct Wall(bool);

impl shadenet_runtime::SceneServices for Wall {
    fn trace(&self, _: [f32; 3], _: [f32; 3], _: i32, _: i32, _: f32) -> [f32; 3] {
        [0.0; 3]
    }
    fn occluded(&self, _: [f32; 3], _: [f32; 3]) -> bool {
        self.0
    }
    fn occlusion(&self, _: [f32; 3], _: [f32; 3], _: u32, _: f32, _: u32) -> f32 {
        1.0
    }
}

#[test]
fn light_loop_asks_the_scene_for_shadows() {
    let src = r#"{"nodes": [
        {"name": "s", "type": "lambert", "inputs": {"color": 1, "diffuse": 1}},
        {"name": "l", "type": "pointLight", "inputs": {"position": [0, 0, 1], "intensity": 3}}],
      "outputs": {"c": "s.outColor"}}"#;
    let c = shadenet::compile_json(src, &shadenet::NodeLibrary::standard()).unwrap();
    let interp = shadenet_runtime::Interpreter::<f64>::new(&c.program).unwrap();
    let env = shadenet_runtime::ShadeEnv::with_lights(&c.lights);
    let frag = shadenet_runtime::Fragment {
        n: [0.0, 0.0, 1.0],
        i: [0.0, 0.0, -1.0],
        ..Default::default()
    };
    let red = |scene: Option<&dyn shadenet_runtime::SceneServices>| {
        let mut ctx = shadenet_runtime::ShadeCtx::new(frag, &env);
        ctx.scene = scene;
        let out = interp.shade(&ctx);
        out.values.chunks(3).map(|c| c[0]).sum::<f64>()
    };
    let open = red(None);
    assert!((open - 3.0 / std::f64::consts::PI).abs() < 1e-12, "{open}");
    assert_eq!(red(Some(&Wall(false))), open);
    assert_eq!(red(Some(&Wall(true))), 0.0);
}
