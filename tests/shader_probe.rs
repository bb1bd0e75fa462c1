//! OSL's probe rays (issue 22): `trace(pos, dir, …)` returns whether the ray hits a surface
//! and `getmessage("trace", …)` reads the hit (distance, point, normals, uv) — the IR's
//! `probe` op, answered by the renderer's scene on every CPU back end, refused by the GPU
//! path, zero without a scene.

mod common;
use common::*;
use shadenet::graph::ir::{Op, ProbeField};
use shadenet::lang::Dialect;
use shadenet::runtime::{ProbeHit, SceneServices, ShadeCtx, ShadeEnv};

/// A floor that looks straight up: red where something is above it, green the distance,
/// blue the hit's geometric normal's y.
const FLOOR: &str = r#"surface floor(float maxdist = 10) {
    float d = -1;
    normal n = 0;
    int h = trace(P, vector(0, 1, 0), "maxdist", maxdist);
    int got = getmessage("trace", "hitdist", d);
    getmessage("trace", "Ng", n);
    Ci = color(h + 2 * got, d, n[1]) * emission();
}"#;

/// A scene: the floor at y = 0 seen from above, a ball of radius ½ at height 1.5 (its
/// lowest point at y = 1).
fn scene(dir: &std::path::Path, maxdist: f64) -> std::path::PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("floor.osl"), FLOOR).unwrap();
    std::fs::write(dir.join("black.osl"), "surface black() { Ci = 0; }").unwrap();
    let toml = format!(
        r#"[camera]
position = [0.0, 6.0, 3.0]
look_at = [0.0, 0.0, 0.0]
fov = 40
resolution = [40, 40]

[render]
spp = 1

[materials.floor]
network = "floor.osl"
set = {{ "floor.maxdist" = {maxdist} }}

[materials.black]
network = "black.osl"

[meshes.ground]
type = "quad"

[meshes.ball]
type = "sphere"
segments = 32

[[instances]]
mesh = "ground"
material = "floor"
rotate = [-90, 0, 0]
scale = 10

[[instances]]
mesh = "ball"
material = "black"
translate = [0.0, 1.5, 0.0]
scale = 0.5
"#
    );
    let path = dir.join("probe.toml");
    std::fs::write(&path, toml).unwrap();
    path
}

fn render(path: &std::path::Path, kind: shadenet::render::BackendKind) -> Vec<[f32; 3]> {
    render_in(path, kind, shadenet::tracer::ShadingMode::Immediate)
}

/// Renders in `mode` (deferred: the hits shaded in batches, the JIT's batch entry with
/// each lane's own services).
fn render_in(
    path: &std::path::Path,
    kind: shadenet::render::BackendKind,
    mode: shadenet::tracer::ShadingMode,
) -> Vec<[f32; 3]> {
    use shadenet::render::{self as r, RenderOptions};
    let backend = r::backend(kind).unwrap();
    let mut renderer =
        r::setup_with(Some(path), &RenderOptions::default(), backend.as_ref()).unwrap();
    renderer.set_shading_mode(mode);
    let film = renderer.render(&|_, _| {}).0;
    let beauty = &film.layers[0];
    (0..40 * 40)
        .map(|p| std::array::from_fn(|c| beauty.at(p, c)))
        .collect()
}

/// Floor points under the ball hit it, at a distance between the ball's lowest point (1)
/// and its equator (1.5), on its underside (normal pointing down); the others miss and
/// leave `getmessage`'s output as it was; interpreter and JIT agree bit for bit; a
/// maximum distance short of the ball finds nothing.
#[test]
fn trace_finds_what_is_above_the_floor() {
    use shadenet::render::BackendKind;
    let dir = std::env::temp_dir().join(format!("shadenet-probe-{}", std::process::id()));
    let path = scene(&dir, 10.0);
    let interp = render(&path, BackendKind::Interp);
    let jit = render(&path, BackendKind::Jit);
    let deferred = shadenet::tracer::ShadingMode::Deferred(Default::default());
    let batched = render_in(&path, BackendKind::Jit, deferred);
    let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&interp), bits(&jit), "interp and JIT");
    assert_eq!(
        bits(&interp),
        bits(&batched),
        "interp and the JIT's batch entry"
    );
    // The floor's pixels: red 3 (hit, message found) or 0 (miss, none); the ball's are black.
    let (mut hits, mut misses) = (0, 0);
    for (p, [r, g, b]) in interp.iter().copied().enumerate() {
        match r {
            3.0 => {
                hits += 1;
                assert!((0.999..=1.501).contains(&g), "pixel {p}: distance {g}");
                assert!(
                    b < 0.0,
                    "pixel {p}: the ball's underside faces down, Ng.y = {b}"
                );
            }
            0.0 if g == -1.0 => {
                misses += 1;
                assert_eq!(b, 0.0, "pixel {p}: a miss leaves the output as it was");
            }
            _ => assert_eq!([r, g, b], [0.0; 3], "pixel {p}: the ball is black"),
        }
    }
    assert!(hits > 20 && misses > 500, "hits {hits}, misses {misses}");
    let short = render(&scene(&dir.join("short"), 0.9), BackendKind::Jit);
    assert!(short.iter().all(|c| c[0] == 0.0), "nothing within 0.9");
}

/// A scene that answers every probe with one hit, to check each field on the interpreter.
struct OneHit;

impl SceneServices for OneHit {
    fn trace(&self, _: [f32; 3], _: [f32; 3], _: i32, _: i32, _: f32) -> [f32; 3] {
        [0.0; 3]
    }
    fn occluded(&self, _: [f32; 3], _: [f32; 3]) -> bool {
        false
    }
    fn occlusion(&self, _: [f32; 3], _: [f32; 3], _: u32, _: f32, _: u32) -> f32 {
        1.0
    }
    fn probe(&self, o: [f32; 3], d: [f32; 3], lo: f32, hi: f32) -> Option<ProbeHit> {
        // The direction arrives normalized; the distances as given.
        assert!((d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - 1.0).abs() < 1e-6);
        (lo <= 2.0 && 2.0 <= hi).then_some(ProbeHit {
            distance: 2.0,
            p: [o[0] + 2.0 * d[0], o[1] + 2.0 * d[1], o[2] + 2.0 * d[2]],
            n: [0.0, 0.0, 1.0],
            ng: [0.0, 1.0, 0.0],
            uv: [0.25, 0.75],
        })
    }
}

/// Every field `getmessage` reads, `trace`'s options, a trace under an `if` read after it,
/// a trace in a user function, and no scene: no hit.
#[test]
fn getmessage_reads_every_field_of_the_last_trace() {
    let src = r#"
        int probe_up(point p) { return trace(p, vector(0, 3, 0), "mindist", 1); }
        shader s(output color a = 0, output color b = 0, output color c = 0,
                 output color e = 0, output float f = 0) {
            point hp = 0; normal n = 0, ng = 0; float uu = -1, vv = -1, d = -1; int h = 0;
            if (u > 0.25)
                trace(P, vector(1, 0, 0), "maxdist", 5, "shade", 0);
            getmessage("trace", "hit", h);
            getmessage("trace", "hitdist", d);
            getmessage("trace", "P", hp);
            getmessage("trace", "N", n);
            getmessage("trace", "Ng", ng);
            getmessage("trace", "u", uu);
            getmessage("trace", "v", vv);
            a = color(h, d, uu); b = color(hp); c = color(n) + 10 * color(ng);
            e = color(vv, probe_up(P), trace(P, N, "maxdist", 1.5));
            f = trace(P, N, "mindist", 3);
        }"#;
    let p = compile_shader(src, Dialect::Osl).unwrap();
    let probes = p
        .exprs
        .iter()
        .filter(|e| {
            matches!(
                e.op,
                Op::Probe {
                    field: ProbeField::Hit,
                    ..
                }
            )
        })
        .count();
    assert_eq!(probes, 4, "one hit probe per trace call");
    let env = ShadeEnv::default();
    let mut frag = plane_fragment();
    frag.p = [0.5, 0.0, 0.0];
    let interp = shadenet::runtime::Interpreter::<f32>::new(&p).unwrap();
    let get = |o: &shadenet::runtime::ShadeOut<f32>, name: &str| -> Vec<f32> {
        let s = interp.slots().iter().find(|s| s.name == name).unwrap();
        o.values[s.offset..s.offset + s.ty.width()].to_vec()
    };
    for (uv, scene) in [([0.5, 0.5], true), ([0.1, 0.5], true), ([0.5, 0.5], false)] {
        frag.uv = uv;
        let mut ctx = ShadeCtx::new(frag, &env);
        if scene {
            ctx.scene = Some(&OneHit);
        }
        let o = interp.shade(&ctx);
        let traced = scene && uv[0] > 0.25;
        if traced {
            assert_eq!(get(&o, "a"), [1.0, 2.0, 0.25]);
            assert_eq!(get(&o, "b"), [2.5, 0.0, 0.0]);
            assert_eq!(get(&o, "c"), [0.0, 10.0, 1.0]);
        } else {
            assert_eq!(
                get(&o, "a"),
                [0.0, -1.0, -1.0],
                "no trace ran: outputs unchanged"
            );
            assert_eq!(get(&o, "b"), [0.0; 3]);
        }
        // The function's ray starts at distance 1 and hits at 2; the normal's ray may go
        // 1.5 only; the last one starts past the hit.
        let e = get(&o, "e");
        assert_eq!(e[1..], if scene { [1.0, 0.0] } else { [0.0, 0.0] });
        assert_eq!(e[0], if traced { 0.75 } else { -1.0 });
        assert_eq!(get(&o, "f"), [0.0]);
    }
}

/// Bad calls name the call and the problem; the GPU path refuses a material that traces.
#[test]
fn bad_traces_are_errors_that_say_why() {
    for (body, want) in [
        ("int h = trace(P);", "`trace` takes (point pos, vector dir)"),
        ("int h = trace(P, N, \"mindist\");", "options come in pairs"),
        (
            "int h = trace(P, N, \"bias\", 1);",
            "`trace` has no option \"bias\"",
        ),
        (
            "int h = trace(P, N, \"shade\", 1);",
            "shading what a probe ray hits is not built",
        ),
        ("int h = trace(P, N, \"traceset\", \"a\");", "\"traceset\""),
        (
            "float d; getmessage(\"trace\", \"colour\", d);",
            "the trace records hit, hitdist",
        ),
        (
            "float d; getmessage(\"other\", \"x\", d);",
            "only the \"trace\" source is built",
        ),
    ] {
        let err = compile_shader(&format!("surface s() {{ {body} }}"), Dialect::Osl).unwrap_err();
        assert!(err.contains(want), "{body}\n→ {err}");
    }
    let file = tmp("probe", "f.osl");
    std::fs::write(&file, FLOOR).unwrap();
    let (code, _, err) = shadenet_env(
        &["compile", file.to_str().unwrap(), "--emit", "wgsl"],
        &[("SHADENET_GPU_ADAPTER", "none")],
    );
    assert_ne!(code, 0);
    assert!(
        err.contains("probe rays (OSL's trace) ask the renderer's scene"),
        "{err}"
    );
}
