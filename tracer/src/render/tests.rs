//! The renderer's unit tests: stages reached through the renderer's private items.

use super::deferred::group_tiles;
use super::services::{BatchServices, HitServices};
use super::stats::TileStats;
use super::trace::{Found, HitDiffs, RayState};
use super::*;
use crate::film::Film;
use crate::passes::{OverrideKind, RayMatch};
use crate::scene::Scene;
use crate::shader::InterpBackend;
use glam::Vec3;
use shadenet_graph::ir::{Builder, RAY_REFLECTION, RAY_SHADOW};
use shadenet_graph::ir::{Program, Stream};
use shadenet_graph::{NodeLibrary, compile_json};
use shadenet_runtime::SceneServices;
use std::path::Path;

fn scene(text: &str) -> Scene {
    crate::scene::parse(text, Path::new("test.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn lambert(rgb: [f64; 3]) -> Program {
    let src = format!(
        r#"{{ "nodes": [ {{ "name": "s", "type": "lambert",
             "inputs": {{ "color": [{}, {}, {}], "diffuse": 1.0 }} }} ],
             "outputs": {{ "color": "s.outColor" }} }}"#,
        rgb[0], rgb[1], rgb[2]
    );
    compile_json(&src, &NodeLibrary::standard())
        .unwrap()
        .program
}

/// A program whose one output is a stream (to look at what the tracer fills in).
fn stream_program(s: Stream) -> Program {
    let mut b = Builder::new("probe");
    let v = b.stream(s);
    b.output("value", None, v);
    b.finish().unwrap()
}

const PLANE: &str = r#"
[camera]
position = [0, 0, 2]
look_at = [0, 0, 0]
fov = 30
resolution = [5, 5]

[materials.m]
json = '{"nodes": [], "outputs": {}}'

[meshes.q]
type = "quad"

[[instances]]
mesh = "q"
material = "m"
"#;

fn render_one(text: &str, program: Program) -> (Renderer, Film) {
    let r = Renderer::new(scene(text), vec![program], &InterpBackend).unwrap();
    let film = r.render(&|_, _| {}).0;
    (r, film)
}

#[test]
fn ray_differentials_reach_the_shader_when_it_reads_them() {
    let (r, film) = render_one(PLANE, stream_program(Stream::DPdx));
    assert!(r.differentials);
    let b = film.layer("beauty").unwrap();
    // One pixel at distance 2 with a 30° vertical field over 5 pixels.
    let footprint = 2.0 * 2.0 * (15.0f32.to_radians()).tan() / 5.0;
    assert!(
        (b.at(12, 0) - footprint).abs() < 1e-5 * footprint.max(1.0),
        "{}",
        b.at(12, 0)
    );
    assert!(b.at(12, 1).abs() < 1e-6 && b.at(12, 2).abs() < 1e-6);
    let (_, film) = render_one(PLANE, stream_program(Stream::DPdy));
    let b = film.layer("beauty").unwrap();
    assert!((b.at(12, 1) + footprint).abs() < 1e-5, "{}", b.at(12, 1));
}

#[test]
fn uv_and_tangents_are_computed_only_when_needed() {
    let (r, film) = render_one(PLANE, stream_program(Stream::Uv));
    assert!(r.shaders[0][0].uv_tangents && !r.differentials);
    let b = film.layer("beauty").unwrap();
    assert!((b.at(12, 0) - 0.5).abs() < 1e-6 && (b.at(12, 1) - 0.5).abs() < 1e-6);
    let (_, film) = render_one(PLANE, stream_program(Stream::DPdu));
    let b = film.layer("beauty").unwrap();
    assert!(
        (b.at(12, 0) - 2.0).abs() < 1e-5,
        "dPdu of the [-1,1] quad over u in [0,1]"
    );
    let (r, _) = render_one(PLANE, lambert([0.5; 3]));
    assert!(!r.shaders[0][0].uv_tangents && !r.differentials);
}

#[test]
fn camera_hits_see_camera_ray_type_and_depth_zero() {
    let (_, film) = render_one(PLANE, stream_program(Stream::RayType));
    let b = film.layer("beauty").unwrap();
    assert_eq!(b.at(12, 0), RayMatch::Camera.code() as f32);
    let (_, film) = render_one(PLANE, stream_program(Stream::RayDepth));
    assert_eq!(film.layer("beauty").unwrap().at(12, 0), 0.0);
}

fn services<'a>(r: &'a Renderer, stats: &'a TileStats, p: Vec3, n: Vec3) -> HitServices<'a> {
    HitServices {
        r,
        stats,
        p,
        ng_facing: n,
        n_facing: n,
        d_in: -n,
        diffs: None,
        seed: 7,
        attrs: None,
    }
}

/// `trace` shades what a secondary ray hits (recursively, as that ray type and depth),
/// returns black past the depth limit and for shadow rays, and the background on a miss.
#[test]
fn trace_shades_the_hit_and_respects_depth_limits() {
    let text = format!(
        "{PLANE}\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = 4\n\
         [[lights]]\ntype = \"environment\"\nintensity = 0.25\nsamples = 1\n"
    );
    let rho = [0.8, 0.4, 0.2];
    let r = Renderer::new(scene(&text), vec![lambert(rho)], &InterpBackend).unwrap();
    let stats = TileStats::default();
    let s = services(&r, &stats, Vec3::new(0.0, 0.0, 1.0), Vec3::Z);
    let got = s.trace([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], RAY_REFLECTION, 1, 0.0);
    // Point light at distance 2 straight above, plus the environment's uniform sample
    // from some direction: check the point-light part by removing the environment.
    let text2 =
        format!("{PLANE}\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = 4\n");
    let r2 = Renderer::new(scene(&text2), vec![lambert(rho)], &InterpBackend).unwrap();
    let s2 = services(&r2, &stats, Vec3::new(0.0, 0.0, 1.0), Vec3::Z);
    let direct = s2.trace([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], RAY_REFLECTION, 1, 0.0);
    for c in 0..3 {
        let want = rho[c] / std::f64::consts::PI * 4.0 / 4.0;
        assert!(
            ((direct[c] as f64) - want).abs() < 1e-5 * want,
            "{direct:?}"
        );
        assert!(got[c] >= direct[c]);
    }
    // Past the limit (4 by default): black.
    assert_eq!(
        s2.trace([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], RAY_REFLECTION, 5, 0.0),
        [0.0; 3]
    );
    assert_eq!(
        s2.trace([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], RAY_SHADOW, 1, 0.0),
        [0.0; 3]
    );
    // A miss sees the environment.
    assert_eq!(
        s.trace([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], RAY_REFLECTION, 1, 0.0),
        [0.25; 3]
    );
    assert!(stats.shading_calls.load(Ordering::Relaxed) >= 2);
}

const ROOM: &str = r#"
[camera]
position = [0, 3, 3]
look_at = [0, 0, 0]
resolution = [4, 4]

[materials.m]
json = '{"nodes": [], "outputs": {}}'

[meshes.q]
type = "quad"

[[instances]]
mesh = "q"
material = "m"
rotate = [-90, 0, 0]
scale = 10

[[instances]]
mesh = "q"
material = "m"
translate = [0, 0.5, 0]
rotate = [90, 0, 0]
scale = 10
"#;

#[test]
fn occlusion_and_shadow_rays_see_the_geometry() {
    let r = Renderer::new(scene(ROOM), vec![lambert([0.5; 3])], &InterpBackend).unwrap();
    let stats = TileStats::default();
    let p = Vec3::ZERO; // on the floor, under a ceiling 0.5 above
    let s = services(&r, &stats, p, Vec3::Y);
    let n = [0.0, 1.0, 0.0];
    assert_eq!(
        s.occlusion(p.to_array(), n, 64, 0.3, 1),
        1.0,
        "ceiling out of reach"
    );
    let closed = s.occlusion(p.to_array(), n, 64, 2.0, 1);
    assert!(closed < 0.05, "{closed}");
    assert_eq!(
        closed,
        s.occlusion(p.to_array(), n, 64, 2.0, 1),
        "deterministic"
    );
    // Half open: only within reach for directions steeper than 60° from the horizon.
    let part = s.occlusion(p.to_array(), n, 256, 0.5 / 30f32.to_radians().cos(), 3);
    assert!(part > 0.0 && part < 1.0, "{part}");
    // Shadow rays: to a point above the ceiling (blocked) and below it (free).
    assert!(s.occluded(p.to_array(), [0.3, 2.0, 0.1]));
    assert!(!s.occluded(p.to_array(), [0.3, 0.4, 0.1]));
    // From the hit point itself, the offset keeps the floor from shadowing itself at
    // grazing angles.
    assert!(!s.occluded(p.to_array(), [5.0, 0.01, 0.0]));
}

#[test]
fn rules_pick_components_and_overrides_per_ray_type() {
    let base = format!(
        "{PLANE}\n[render]\npasses = [\"diffuse\", \"indirect\"]\n\
         [[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = 4\n\
         [[lights]]\ntype = \"ambient\"\nintensity = 0.5\n"
    );
    let (r, film) = render_one(&base, lambert([0.5; 3]));
    assert_eq!(r.stats.shaders, 1);
    let ind = film.layer("indirect").unwrap().at(12, 0);
    assert!(ind > 0.2, "{ind}");
    // Camera rays keep only `diffuse`: beauty is the diffuse pass; the material is
    // specialized twice (camera: diffuse; deeper rays: everything).
    let text = base.replace(
        "passes = [\"diffuse\", \"indirect\"]\n",
        "passes = [\"diffuse\", \"indirect\"]\n\n[[render.rules]]\nray = \"camera\"\ncomponents = [\"diffuse\"]\n",
    );
    let (r, film) = render_one(&text, lambert([0.5; 3]));
    assert_eq!(r.stats.shaders, 2);
    let (b, d) = (
        film.layer("beauty").unwrap(),
        film.layer("diffuse").unwrap(),
    );
    assert_eq!(b.at(12, 0), d.at(12, 0));
    assert_eq!(film.layer("indirect").unwrap().at(12, 0), 0.0);
    // An override rule: camera hits shade with the normal shader.
    let text = base.replace(
        "passes = [\"diffuse\", \"indirect\"]\n",
        "passes = [\"diffuse\", \"indirect\"]\n\n[[render.rules]]\nray = \"camera\"\noverride = \"normal\"\n",
    );
    let (_, film) = render_one(&text, lambert([0.5; 3]));
    let b = film.layer("beauty").unwrap();
    assert_eq!([b.at(12, 0), b.at(12, 1), b.at(12, 2)], [0.0, 0.0, 1.0]);
    // A one-channel override (occlusion: 1 over the open plane; depth: 2) shows grey.
    for (kind, v) in [("occlusion", 1.0), ("depth", 2.0)] {
        let (_, film) = render_one(
            &text.replace("\"normal\"", &format!("\"{kind}\"")),
            lambert([0.5; 3]),
        );
        let b = film.layer("beauty").unwrap();
        for c in 0..3 {
            assert!((b.at(12, c) - v).abs() < 1e-5, "{kind}: {}", b.at(12, c));
        }
    }
}

#[test]
fn unknown_pass_components_are_errors_and_known_ones_warnings() {
    // Lambert has no specular part: a known component it lacks is a warning.
    let text = format!("{PLANE}\n[render]\npasses = [\"specular\", \"diffuse\"]\n");
    let r = Renderer::new(scene(&text), vec![lambert([0.5; 3])], &InterpBackend).unwrap();
    assert_eq!(r.warnings().len(), 1, "{:?}", r.warnings());
    assert!(r.warnings()[0].contains("specular"));
    let text = format!("{PLANE}\n[render]\npasses = [\"difuse\"]\n");
    let e = Renderer::new(scene(&text), vec![lambert([0.5; 3])], &InterpBackend)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("difuse") && e.contains("diffuse"), "{e}");
}

/// Reflection mirrors the direction differentials about the normal; a refraction that
/// does not bend (η = 1) keeps them; diffuse rays drop them.
#[test]
fn differentials_follow_reflection_and_refraction() {
    let r = Renderer::new(scene(PLANE), vec![lambert([0.5; 3])], &InterpBackend).unwrap();
    let stats = TileStats::default();
    let mut s = services(&r, &stats, Vec3::ZERO, Vec3::Z);
    s.diffs = Some(HitDiffs {
        dpdx: Vec3::new(0.01, 0.0, 0.0),
        dpdy: Vec3::new(0.0, 0.01, 0.0),
        dddx: Vec3::new(0.02, 0.0, 0.003),
        dddy: Vec3::new(0.0, 0.02, 0.0),
    });
    let refl = s.child_diffs(RayMatch::Reflection, Vec3::Z).unwrap();
    assert_eq!(refl.dodx, Vec3::new(0.01, 0.0, 0.0));
    assert!((refl.dddx - Vec3::new(0.02, 0.0, -0.003)).length() < 1e-7);
    assert_eq!(refl.dddy, Vec3::new(0.0, 0.02, 0.0));
    let straight = s.child_diffs(RayMatch::Refraction, -Vec3::Z).unwrap();
    assert!((straight.dddx - Vec3::new(0.02, 0.0, 0.003)).length() < 1e-7);
    assert!(s.child_diffs(RayMatch::Diffuse, Vec3::Z).is_none());
}

#[test]
fn override_passes_report_normal_depth_uv_and_occlusion() {
    let text =
        format!("{PLANE}\n[render]\npasses = [\"normal\", \"depth\", \"uv\", \"occlusion\"]\n");
    let (_, film) = render_one(&text, lambert([0.5; 3]));
    let names: Vec<&str> = film.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["beauty", "normal", "depth", "uv", "occlusion"]);
    let l = |n: &str| film.layer(n).unwrap();
    assert_eq!(l("normal").channels, ["X", "Y", "Z"]);
    assert_eq!(
        [
            l("normal").at(12, 0),
            l("normal").at(12, 1),
            l("normal").at(12, 2)
        ],
        [0.0, 0.0, 1.0]
    );
    assert_eq!(l("depth").channels, ["Z"]);
    assert!(
        (l("depth").at(12, 0) - 2.0).abs() < 1e-5,
        "{}",
        l("depth").at(12, 0)
    );
    assert!((l("uv").at(12, 0) - 0.5).abs() < 1e-6 && (l("uv").at(12, 1) - 0.5).abs() < 1e-6);
    assert_eq!(l("occlusion").at(12, 0), 1.0, "nothing above the plane");
}

/// The occlusion override is a built program around the IR's `occlusion` op, compiled
/// and run by the back end like the other overrides; at every camera hit its value is,
/// bit for bit, what the tracer's occlusion service answers when asked directly with the
/// hit's point, facing normal and seed and the scene's settings (what the pass computed
/// before it was a program).
#[test]
fn the_occlusion_pass_is_a_program_asking_the_occlusion_service() {
    use shadenet_graph::ir::Op;
    let p = OverrideKind::Occlusion.program(32, 0.8).unwrap();
    let ops: Vec<&Op> = p.exprs.iter().map(|e| &e.op).collect();
    assert!(ops.iter().any(|o| matches!(o, Op::Occlusion { .. })), "{p}");
    let text = r#"
[camera]
position = [0, 2.5, 3]
look_at = [0, 0.2, 0]
resolution = [12, 12]

[render]
passes = ["occlusion"]
occlusion_samples = 32
occlusion_distance = 0.8

[materials.m]
json = '{"nodes": [], "outputs": {}}'

[meshes.q]
type = "quad"

[meshes.cube]
type = "box"

[[instances]]
mesh = "q"
material = "m"
rotate = [-90, 0, 0]
scale = 3

[[instances]]
mesh = "cube"
material = "m"
translate = [0, 0.4, 0]
scale = 0.4
"#;
    let (r, film) = render_one(text, lambert([0.5; 3]));
    assert_eq!(r.stats.shaders, 2, "the material and the occlusion program");
    let occ = film.layer("occlusion").unwrap();
    let stats = TileStats::default();
    let (mut partial, mut hits) = (0, 0);
    for y in 0..12u32 {
        for x in 0..12u32 {
            let i = (y * 12 + x) as usize;
            let cam = r.camera.ray(x as f32 + 0.5, y as f32 + 0.5, false);
            let state = RayState {
                o: cam.o,
                d: cam.d,
                ray: RayMatch::Camera,
                depth: 0,
                seed: hash3(x, y, 0),
                diffs: None,
                bsdf_pdf: 0.0,
            };
            let Found::Surface(hit) = r.intersect(cam.o, cam.d) else {
                assert_eq!(occ.at(i, 0), 0.0, "a miss has no occlusion");
                continue;
            };
            let prep = r.prepare(&state, &hit, false);
            let want = r
                .services(&r.shaders[0][0], &state, &prep, &stats)
                .occlusion(
                    prep.surface.p.to_array(),
                    prep.n_facing.to_array(),
                    32,
                    0.8,
                    state.seed,
                );
            assert_eq!(occ.at(i, 0).to_bits(), want.to_bits(), "pixel ({x}, {y})");
            hits += 1;
            if want > 0.0 && want < 1.0 {
                partial += 1;
            }
        }
    }
    assert!(
        hits >= 100 && partial >= 10,
        "{hits} hits, {partial} partly occluded"
    );
}

/// Films and statistics of one scene rendered immediately and deferred (with groups of
/// `group` samples) are identical, bit for bit, on every layer.
fn assert_deferred_matches(text: &str, program: Program, group: usize) -> RenderStats {
    let mut r = Renderer::new(scene(text), vec![program], &InterpBackend).unwrap();
    assert_eq!(r.shading_mode(), ShadingMode::Immediate);
    let (a, sa) = r.render(&|_, _| {});
    r.set_shading_mode(ShadingMode::Deferred(DeferredOptions {
        group_samples: group,
    }));
    let (b, sb) = r.render(&|_, _| {});
    for (la, lb) in a.layers.iter().zip(&b.layers) {
        assert_eq!(la.name, lb.name);
        let differ = la
            .data
            .iter()
            .zip(&lb.data)
            .filter(|(x, y)| x.to_bits() != y.to_bits())
            .count();
        assert_eq!(differ, 0, "layer {}: {differ} values differ", la.name);
    }
    assert_eq!(a.layers.len(), b.layers.len());
    let counts = |s: &RenderStats| {
        (
            (s.rays, s.camera_rays, s.shadow_rays, s.secondary_rays),
            (s.shading_calls, s.nonfinite),
        )
    };
    assert_eq!(counts(&sa), counts(&sb));
    assert_eq!(sa.batches, 0);
    assert!(sb.batches > 0 && sb.batched_fragments > 0, "{sb:?}");
    sb
}

/// A floor with a box on it, partly out of frame (misses see the background), lit by a
/// point light and a quad light (shadow rays from inside the batch), in passes with
/// override passes (occlusion asks the scene from inside the batch); 3 spp, tiles of
/// 2×2 over a 9×7 frame (partial tiles).
const BOX_ON_FLOOR: &str = r#"
[camera]
position = [0, 2.5, 3]
look_at = [0, 0.2, 0]
resolution = [9, 7]

[render]
spp = 3
tile_size = 2
passes = ["diffuse", "normal", "depth", "uv", "occlusion"]
occlusion_samples = 8
occlusion_distance = 0.8

[materials.m]
json = '{"nodes": [], "outputs": {}}'

[meshes.q]
type = "quad"

[meshes.cube]
type = "box"

[[instances]]
mesh = "q"
material = "m"
rotate = [-90, 0, 0]
scale = 1.5

[[instances]]
mesh = "cube"
material = "m"
translate = [0.2, 0.4, 0]
scale = 0.4

[[lights]]
type = "point"
position = [0.8, 1.5, 0.6]
intensity = 3

[[lights]]
type = "quad"
corner = [-0.3, 1.8, -0.3]
edge_u = [0.6, 0, 0]
edge_v = [0, 0, 0.6]
intensity = 2
samples = 3
"#;

/// Rays are counted per kind (camera, shadow and occlusion queries, secondary), adding up
/// to the total, and every stage of the tile loop is timed.
#[test]
fn rays_are_counted_per_kind_and_stages_timed() {
    let r = Renderer::new(
        scene(BOX_ON_FLOOR),
        vec![lambert([0.6, 0.5, 0.4])],
        &InterpBackend,
    )
    .unwrap();
    let (_, s) = r.render(&|_, _| {});
    assert_eq!(s.camera_rays, 9 * 7 * 3);
    assert_eq!(
        s.secondary_rays, 0,
        "a Lambert surface traces no secondary ray"
    );
    // Each camera hit shades five times (material, four override passes) and asks 12
    // occlusion queries: the point light's, the quad light's 3 samples, the occlusion
    // pass's 8.
    let hits = s.shading_calls / 5;
    assert!(hits > 50, "{s:?}");
    assert_eq!(s.shadow_rays, 12 * hits, "{s:?}");
    assert_eq!(s.rays, s.camera_rays + s.shadow_rays + s.secondary_rays);
    let st = s.stages;
    for (name, t) in [
        ("sample", st.sample),
        ("trace", st.trace),
        ("shade", st.shade),
        ("film", st.film),
    ] {
        assert!(
            t > std::time::Duration::ZERO,
            "stage {name} not timed: {st:?}"
        );
    }
    // A traced ray is a secondary ray; it shades a Lambert hit, whose light sample is a
    // shadow ray.
    let stats = TileStats::default();
    let s = services(&r, &stats, Vec3::new(0.0, 1.0, 0.0), -Vec3::Y);
    s.trace([0.0, 1.0, 0.0], [0.0, -1.0, 0.0], RAY_REFLECTION, 1, 0.0);
    let mut total = RenderStats::default();
    stats.add_to(&mut total);
    assert_eq!(
        (total.camera_rays, total.secondary_rays),
        (0, 1),
        "{total:?}"
    );
    assert!(total.shadow_rays >= 1, "{total:?}");
}

/// The deferred mode gives the immediate mode's image, bit for bit, on every layer, and
/// the same statistics, for groups of one tile, several tiles and the whole frame; an
/// override rule on camera rays shades the override in the batch.
#[test]
fn deferred_shading_gives_the_immediate_image() {
    for group in [1, 20, 1 << 20] {
        let st = assert_deferred_matches(BOX_ON_FLOOR, lambert([0.6, 0.5, 0.4]), group);
        // Every camera hit's shading calls went through batches: material and four
        // override passes per hit.
        assert_eq!(st.batched_fragments, st.shading_calls, "{st:?}");
        assert!(st.largest_batch > 1);
    }
    let rule =
        format!("{BOX_ON_FLOOR}\n[[render.rules]]\nray = \"camera\"\noverride = \"occlusion\"\n");
    assert_deferred_matches(&rule, lambert([0.6, 0.5, 0.4]), 30);
    // A material reading object space is batched per instance.
    let st = assert_deferred_matches(BOX_ON_FLOOR, object_p(), 1 << 20);
    assert!(st.batches >= 2, "{st:?}");
}

/// A program whose output is `P` in object space.
fn object_p() -> Program {
    let src = r#"{ "nodes": [ { "name": "i", "type": "samplerInfo",
         "inputs": { "space": "object" } } ],
         "outputs": { "color": "i.P" } }"#;
    compile_json(src, &NodeLibrary::standard())
        .unwrap_or_else(|e| panic!("{e}"))
        .program
}

/// A batch's services give each fragment its own services by index (`fragment`); a
/// direct call gets detached services (no hit point, a seed from the origin).
#[test]
fn batch_services_give_each_fragment_its_own() {
    let r = Renderer::new(scene(ROOM), vec![lambert([0.5; 3])], &InterpBackend).unwrap();
    let stats = TileStats::default();
    let a = services(&r, &stats, Vec3::ZERO, Vec3::Y);
    let mut b = services(&r, &stats, Vec3::new(0.2, 0.0, 0.1), Vec3::Y);
    b.seed = 99;
    let bs = BatchServices { hits: vec![a, b] };
    assert!(bs.fragment(1).is_some() && bs.fragment(2).is_none());
    assert!(bs.detached([0.2, 0.0, 0.1]).p.is_nan());
    assert_ne!(bs.detached([0.2, 0.0, 0.1]).seed, 99);
    // From the fragment's own point the ray is offset: the floor does not shadow its own
    // point at a grazing angle.
    assert!(
        !bs.fragment(0)
            .unwrap()
            .occluded([0.0, 0.0, 0.0], [5.0, 0.01, 0.0])
    );
}

#[test]
fn tiles_group_until_enough_samples() {
    let tiles: Vec<_> = (0..5).map(|i| (i * 2, 0, i * 2 + 2, 2)).collect();
    assert_eq!(group_tiles(&tiles, 1, 8), vec![0..2, 2..4, 4..5]);
    assert_eq!(
        group_tiles(&tiles, 2, 1),
        vec![0..1, 1..2, 2..3, 3..4, 4..5]
    );
    assert_eq!(group_tiles(&tiles, 1, 1000), vec![0..5]);
    assert!(group_tiles(&[], 1, 8).is_empty());
}

/// A component the first output lacks comes from another output (as a surface's
/// `outShadow` will): it fills its pass but stays out of the beauty.
#[test]
fn components_outside_the_first_output_fill_passes_not_beauty() {
    let src = r#"{ "nodes": [
        { "name": "m", "type": "lambert", "inputs": { "color": [0.5, 0.5, 0.5], "diffuse": 1.0 } },
        { "name": "p", "type": "phong", "inputs": { "specularColor": 0.5, "cosinePower": 1 } } ],
        "outputs": { "color": "m.outColor", "extra": "p.outColor" } }"#;
    let program = compile_json(src, &NodeLibrary::standard()).unwrap().program;
    let text = format!(
        "{PLANE}\n[render]\npasses = [\"diffuse\", \"specular\"]\n\
         [[lights]]\ntype = \"point\"\nposition = [0.5, 0, 2]\nintensity = 4\n"
    );
    let (_, film) = render_one(&text, program);
    let l = |n: &str| film.layer(n).unwrap().at(12, 0);
    assert!(l("specular") > 0.01, "{}", l("specular"));
    assert_eq!(
        l("beauty"),
        l("diffuse"),
        "specular is not in the first output"
    );
    // The diffuse pass is the first output's, not the sum with the other output's.
    let lambert_only = render_one(&text, lambert([0.5; 3])).1;
    assert_eq!(
        l("diffuse"),
        lambert_only.layer("diffuse").unwrap().at(12, 0)
    );
}

/// The sampler is per pixel: 1 and 3 threads give the same bits, with every pixel filter;
/// the filters change the image (they move the samples), the box filter keeps each pixel's
/// samples inside it.
#[test]
fn sampler_and_filters_are_deterministic_per_pixel() {
    let render = |filter: &str, threads: usize| {
        let text = BOX_ON_FLOOR.replace("spp = 3\n", &format!("spp = 16\nfilter = \"{filter}\"\n"));
        let r =
            Renderer::new(scene(&text), vec![lambert([0.6, 0.5, 0.4])], &InterpBackend).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let film = pool.install(|| r.render(&|_, _| {}).0);
        film.layer("beauty").unwrap().data.clone()
    };
    let mut images = Vec::new();
    for filter in ["box", "gaussian", "blackman-harris"] {
        let one = render(filter, 1);
        let three = render(filter, 3);
        let differ = one
            .iter()
            .zip(&three)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(
            differ, 0,
            "{filter}: {differ} values differ between 1 and 3 threads"
        );
        images.push(one);
    }
    assert_ne!(images[0], images[1]);
    assert_ne!(images[1], images[2]);
    for k in 0..64 {
        let (x, y) = pixel_sample(4, 2, k, 64);
        assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
    }
}

/// The Gaussian and Blackman–Harris samplers put samples within ±width/2 of the centre,
/// symmetric on average and denser near the centre; the box spreads them evenly.
#[test]
fn filter_sampling_follows_the_filter() {
    use crate::scene::{FilterKind, PixelFilter};
    for kind in [
        FilterKind::Box,
        FilterKind::Gaussian,
        FilterKind::BlackmanHarris,
    ] {
        let width = 3.0;
        let s = super::pixel::PixelSampler::new(PixelFilter { kind, width });
        let n = 4096u32;
        let (mut sum, mut inner) = (0.0f64, 0u32);
        for k in 0..n {
            let (px, _) = s.position(10, 20, super::pixel::pixel_seeds(10, 20), k, n);
            let dx = px - 10.5;
            assert!(dx.abs() <= width / 2.0 + 1e-4, "{kind:?}: {dx}");
            sum += f64::from(dx);
            if dx.abs() < 0.5 {
                inner += 1;
            }
        }
        assert!(
            (sum / f64::from(n)).abs() < 0.01,
            "{kind:?}: mean {}",
            sum / f64::from(n)
        );
        let share = f64::from(inner) / f64::from(n);
        // Box: 1/3 of the width; Gaussian (σ = 0.5): 68 % of its truncated mass;
        // Blackman–Harris: 76.28 % (its integral over ±0.5 px, computed numerically).
        let want = match kind {
            FilterKind::Box => 1.0 / 3.0,
            FilterKind::Gaussian => 0.6827 / 0.9973,
            FilterKind::BlackmanHarris => 0.7628,
        };
        assert!(
            (share - want).abs() < 0.03,
            "{kind:?}: {share} within ±0.5 px, want {want}"
        );
    }
}
