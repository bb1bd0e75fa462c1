//! `shadenet render` and the tracer: analytic radiance, a mirror's reflection, glass at
//! grazing angles and total internal reflection (finite, energy-bounded, measured against
//! Fresnel), the shadow pass, passes that sum to beauty, thread-count independence, the
//! EXR's layers, and bad scenes that fail clearly without touching existing files. Renders
//! are tiny so the suite stays fast in debug builds.

mod common;
use common::shadenet;

use shadenet::render::{RenderOptions, setup};
use shadenet::tracer::camera::Camera;
use shadenet::tracer::{Film, RenderStats};
use std::path::{Path, PathBuf};

fn tmp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shadenet-render-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/scenes")
        .join(name)
}

/// Renders a scene file on a pool of `threads` threads.
fn render(path: &Path, opts: &RenderOptions, threads: usize) -> Film {
    let r = setup(Some(path), opts).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| r.render(&|_, _| {})).0
}

/// Renders a scene text (written to `dir/scene.toml`) on 2 threads, with the statistics.
fn render_text(dir: &Path, text: &str, opts: &RenderOptions) -> (Film, RenderStats) {
    let path = write_scene(dir, text);
    let r = setup(Some(&path), opts).unwrap_or_else(|e| panic!("{e}\n{text}"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    pool.install(|| r.render(&|_, _| {}))
}

/// The exact Fresnel reflectance of unpolarized light at incidence cosine `cos_i` going
/// from index `eta` into index 1 (or 1 under total internal reflection).
fn fresnel_leaving(cos_i: f64, eta: f64) -> f64 {
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if k < 0.0 {
        return 1.0;
    }
    let cos_t = k.sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rs * rs + rp * rp)
}

fn write_scene(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// A Lambertian plane of albedo ρ under a point light of intensity I at distance r and angle
/// θ from the normal reflects radiance ρ/π · I cosθ / r² — measured in a render, at the
/// pixel whose camera ray hits the plane at the origin.
#[test]
fn lambertian_plane_under_a_point_light_matches_the_formula() {
    let dir = tmp_dir("lambert");
    let rho = 0.6f64;
    for (i, (intensity, r, theta_deg)) in [
        (4.0f64, 2.0f64, 0.0f64),
        (10.0, 3.0, 30.0),
        (7.5, 1.5, 60.0),
        (25.0, 4.0, 80.0),
    ]
    .into_iter()
    .enumerate()
    {
        let th = theta_deg.to_radians();
        let light = [r * th.sin(), 0.0, r * th.cos()];
        let text = format!(
            r#"
[camera]
position = [0, 0, 2]
look_at = [0, 0, 0]
fov = 30
resolution = [3, 3]

[materials.plane.inline]
nodes = [ {{ name = "surf", type = "lambert", inputs = {{ color = [1, 1, 1], diffuse = 1.0 }} }} ]
outputs = {{ color = "surf.outColor" }}

[materials.plane]
set = {{ "surf.diffuse" = {rho} }}

[meshes.plane]
type = "quad"

[[instances]]
mesh = "plane"
material = "plane"
scale = 10

[[lights]]
type = "point"
position = [{}, {}, {}]
intensity = {intensity}
"#,
            light[0], light[1], light[2]
        );
        let path = write_scene(&dir, &text);
        let film = render(&path, &RenderOptions::default(), 1);
        let beauty = film.layer("beauty").unwrap();
        let expected = rho / std::f64::consts::PI * intensity * th.cos() / (r * r);
        for c in 0..3 {
            let got = beauty.at(4, c) as f64; // the centre pixel of 3×3
            let rel = (got - expected).abs() / expected;
            if c == 0 {
                eprintln!("θ = {theta_deg}°, r = {r}: {got} vs {expected}, relative error {rel:e}");
            }
            assert!(
                rel < 1e-5,
                "case {i}: θ = {theta_deg}°, r = {r}: got {got}, expected {expected} (rel {rel:e})"
            );
        }
        assert_eq!(beauty.at(4, 3), 1.0, "alpha");
    }
}

/// The Cornell box in passes (Figure 3 of the thesis): its component passes (diffuse,
/// specular, indirect, emission, reflection, refraction) sum to its beauty per pixel within
/// 1e-5 (relative above 1: the light's face is 25), with every pass of the figure carrying
/// what it should — the mirror box's reflections, the glass sphere's refraction, the
/// shadows under the boxes (outside the beauty: the sum holds without them), a highlight,
/// and occlusion darker in the corners than mid-floor.
#[test]
fn cornell_box_passes_sum_to_beauty() {
    let (w, h) = (32usize, 32usize);
    let opts = RenderOptions {
        spp: Some(2),
        res: Some((w as u32, h as u32)),
        passes: None,
        light_strategy: None,
    };
    let film = render(&example("cornell.toml"), &opts, 2);
    let beauty = film.layer("beauty").unwrap();
    let names = [
        "diffuse",
        "specular",
        "indirect",
        "emission",
        "reflection",
        "refraction",
    ];
    let passes: Vec<_> = names.iter().map(|n| film.layer(n).unwrap()).collect();
    let mut lit = 0;
    let mut worst = 0.0f32;
    for i in 0..(w * h) {
        for c in 0..3 {
            let sum: f32 = passes.iter().map(|p| p.at(i, c)).sum();
            let b = beauty.at(i, c);
            worst = worst.max((sum - b).abs() / b.abs().max(1.0));
            assert!(
                (sum - b).abs() <= 1e-5 * b.abs().max(1.0),
                "pixel {i} channel {c}: passes sum to {sum}, beauty is {b}"
            );
            if b > 0.01 {
                lit += 1;
            }
        }
    }
    eprintln!("largest |Σ passes − beauty| / max(1, beauty) over the Cornell box: {worst:e}");
    assert!(lit > w * h, "the box should be lit: {lit} lit channels");
    // How many pixels of a layer have channel 0 above `t`.
    let count = |name: &str, t: f32| {
        let l = film.layer(name).unwrap();
        (0..w * h).filter(|&i| l.at(i, 0) > t).count()
    };
    // The light's face is seen directly and counted as emission.
    assert!(count("emission", 10.0) > 0, "no pixel sees the light");
    let counts: Vec<(&str, usize)> = [
        ("diffuse", 0.05),
        ("specular", 0.01),
        ("reflection", 0.05),
        ("refraction", 0.1),
        ("shadow", 0.05),
    ]
    .into_iter()
    .map(|(n, t)| (n, count(n, t)))
    .collect();
    eprintln!(
        "Cornell box, pixels (of {}) with light in each pass: {counts:?}",
        w * h
    );
    for (n, k) in counts {
        let least = if n == "specular" { 1 } else { w * h / 50 };
        assert!(k >= least, "{n}: only {k} pixels carry light");
    }
    // The shadow is not everywhere: most of the room is lit.
    assert!(count("shadow", 0.0) < w * h / 2);
    // The occlusion override pass is in [0, 1] and darker in the corners than mid-floor.
    let occ = film.layer("occlusion").unwrap();
    assert!(occ.data.iter().all(|x| (0.0..=1.0).contains(x)));
    assert!(occ.data.iter().any(|x| *x < 0.9) && occ.data.iter().any(|x| *x > 0.9));
}

/// Tiles go to whichever thread is free, but every pixel's samples and seeds depend only on
/// the pixel: 1 and 2 threads give bit-identical films (area-light sampling included).
#[test]
fn one_and_two_threads_give_identical_images() {
    let opts = RenderOptions {
        spp: Some(2),
        res: Some((20, 20)),
        passes: None,
        light_strategy: None,
    };
    let a = render(&example("cornell.toml"), &opts, 1);
    let b = render(&example("cornell.toml"), &opts, 2);
    assert_eq!(a.layers.len(), b.layers.len());
    for (la, lb) in a.layers.iter().zip(&b.layers) {
        assert_eq!(la.name, lb.name);
        let same = la
            .data
            .iter()
            .zip(&lb.data)
            .all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same, "layer {} differs between 1 and 2 threads", la.name);
    }
}

/// The embedded default scene renders through the CLI; the EXR carries the layer names
/// (read back with the exr crate), and the PNG is a real image.
#[test]
fn default_render_writes_exr_layers_and_png() {
    let dir = tmp_dir("default");
    let exr = dir.join("out.exr");
    let png = dir.join("out.png");
    let (code, out, err) = shadenet(&[
        "render",
        "-o",
        exr.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--res",
        "32x18",
        "--spp",
        "1",
        "--threads",
        "2",
    ]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(
        out.contains("rays/s") && out.contains("shading calls"),
        "{out}"
    );
    assert!(out.contains("non-finite"), "{out}");
    let meta = exr::meta::MetaData::read_from_file(&exr, false).expect("read the EXR header");
    let names: Vec<String> = meta.headers[0]
        .channels
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    for want in [
        "beauty.R",
        "beauty.G",
        "beauty.B",
        "beauty.A",
        "diffuse.R",
        "specular.G",
        "indirect.B",
        "reflection.R",
        "refraction.G",
        "shadow.B",
        "normal.X",
        "depth.Z",
        "occlusion.Y",
    ] {
        assert!(
            names.iter().any(|n| n == want),
            "{want} missing from {names:?}"
        );
    }
    assert!(
        meta.headers[0]
            .channels
            .list
            .iter()
            .all(|c| c.sample_type == exr::meta::attribute::SampleType::F32)
    );
    let img = image::open(&png).expect("PNG").to_rgb8();
    assert_eq!(img.dimensions(), (32, 18));
}

/// The JIT and the interpreter render the same image, bit for bit, on a scene with every
/// kind of shading service (mirror, glass, area-light shadows).
#[test]
fn jit_and_interpreter_renders_are_identical() {
    let opts = RenderOptions {
        spp: Some(1),
        res: Some((24, 24)),
        passes: None,
        light_strategy: None,
    };
    let path = example("cornell_glass.toml");
    let run = |kind| {
        let b = shadenet::render::backend(kind).unwrap();
        let r = shadenet::render::setup_with(Some(&path), &opts, b.as_ref()).unwrap();
        r.render(&|_, _| {}).0
    };
    let a = run(shadenet::render::BackendKind::Interp);
    let j = run(shadenet::render::BackendKind::Jit);
    assert_eq!(a.layers.len(), j.layers.len());
    for (la, lj) in a.layers.iter().zip(&j.layers) {
        let differing = la
            .data
            .iter()
            .zip(&lj.data)
            .filter(|(x, y)| x.to_bits() != y.to_bits())
            .count();
        assert_eq!(differing, 0, "layer {}: {differing} values differ", la.name);
    }
}

/// Bad scenes fail with a message naming the key or the path, exit 1, and leave an existing
/// output file byte-for-byte untouched.
#[test]
fn bad_scenes_fail_clearly_and_leave_outputs_untouched() {
    let dir = tmp_dir("bad");
    let good_head = r#"
[camera]
position = [0, 0, 3]
look_at = [0, 0, 0]
resolution = [8, 8]

[materials.m]
network = "MATTE"

[meshes.q]
type = "quad"
"#
    .replace("MATTE", example("materials/matte.json").to_str().unwrap());
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "syntax",
            format!("{good_head}\n[[instances]\nmesh = \"q\"\n"),
            vec!["scene.toml", "line"],
        ),
        (
            "unknown_material",
            format!("{good_head}\n[[instances]]\nmesh = \"q\"\nmaterial = \"gold\"\n"),
            vec!["instances[0].material", "gold", "m"],
        ),
        (
            "missing_mesh",
            format!(
                "{good_head}\n[meshes.bunny]\ntype = \"obj\"\nfile = \"no/such/bunny.obj\"\n\
                 [[instances]]\nmesh = \"bunny\"\nmaterial = \"m\"\n"
            ),
            vec!["meshes.bunny.file", "no/such/bunny.obj"],
        ),
        (
            "nan_transform",
            format!(
                "{good_head}\n[[instances]]\nmesh = \"q\"\nmaterial = \"m\"\n\
                 translate = [0, nan, 0]\n"
            ),
            vec!["instances[0].translate", "NaN"],
        ),
        (
            "unknown_key",
            good_head.replace("resolution", "resoluton"),
            vec!["resoluton"],
        ),
        (
            "bad_override",
            format!(
                "{good_head}\n[materials.m.set]\n\"surf.colr\" = [1, 0, 0]\n\
                 [[instances]]\nmesh = \"q\"\nmaterial = \"m\"\n"
            ),
            vec!["material `m`", "colr"],
        ),
    ];
    for (name, text, wants) in cases {
        let case = dir.join(name);
        std::fs::create_dir_all(&case).unwrap();
        let scene = write_scene(&case, &text);
        let out = case.join("out.exr");
        let png = case.join("out.png");
        std::fs::write(&out, b"precious").unwrap();
        std::fs::write(&png, b"precious too").unwrap();
        let (code, stdout, err) = shadenet(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--png",
            png.to_str().unwrap(),
            "-q",
        ]);
        assert_eq!(code, 1, "{name}: {stdout}\n{err}");
        assert!(err.starts_with("error: "), "{name}: {err}");
        for w in wants {
            assert!(err.contains(w), "{name}: `{w}` not in: {err}");
        }
        assert!(!err.contains("panicked"), "{name}: {err}");
        assert_eq!(std::fs::read(&out).unwrap(), b"precious", "{name}");
        assert_eq!(std::fs::read(&png).unwrap(), b"precious too", "{name}");
        // No temporary files are left behind.
        let left: Vec<_> = std::fs::read_dir(&case)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".tmp."))
            .collect();
        assert!(left.is_empty(), "{name}: {left:?}");
    }
}

/// The bundled scenes with mirrors and glass (and bump) render: finite everywhere, nothing
/// caught by the output guard, light in the reflection, refraction and shadow passes.
#[test]
fn scenes_with_mirrors_and_glass_render() {
    for scene in ["cornell_glass.toml", "showcase.toml", "default.toml"] {
        let opts = RenderOptions {
            spp: Some(1),
            res: Some((32, 24)),
            passes: None,
            light_strategy: None,
        };
        let r = setup(Some(&example(scene)), &opts).unwrap_or_else(|e| panic!("{scene}: {e}"));
        let (film, stats) = r.render(&|_, _| {});
        assert_eq!(stats.nonfinite, 0, "{scene}");
        for l in &film.layers {
            assert!(l.data.iter().all(|x| x.is_finite()), "{scene}: {}", l.name);
        }
        for pass in ["reflection", "refraction", "shadow"] {
            let l = film
                .layer(pass)
                .unwrap_or_else(|| panic!("{scene}: no {pass} pass"));
            assert!(l.data.iter().any(|x| *x > 0.0), "{scene}: {pass} is black");
        }
    }
}

/// Every bundled scene parses (the TOML and its meshes), whether or not its materials link
/// today.
#[test]
fn bundled_scenes_parse() {
    for e in std::fs::read_dir(example("")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            shadenet::tracer::scene::load(&p).unwrap_or_else(|e| panic!("{e}"));
        }
    }
}

/// The multiplication-tree scene's box face fills the whole 640×480 frame (checked on a
/// subsampled grid of camera rays at the same field of view).
#[test]
fn mult_tree_face_fills_the_frame() {
    let film = render(
        &example("mult_tree.toml"),
        &RenderOptions {
            res: Some((64, 48)),
            ..RenderOptions::default()
        },
        2,
    );
    let b = film.layer("beauty").unwrap();
    assert!(
        (0..64 * 48).all(|i| b.at(i, 3) == 1.0),
        "a pixel misses the face"
    );
}

/// The complete example in docs/scene-format.md is a valid scene (with stand-ins for the
/// files it names).
#[test]
fn scene_format_doc_example_loads() {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/scene-format.md"))
            .unwrap();
    let start = doc.find("```toml\n").expect("a toml block") + 8;
    let end = start + doc[start..].find("```").unwrap();
    let dir = tmp_dir("doc");
    std::fs::create_dir_all(dir.join("materials")).unwrap();
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    std::fs::copy(
        example("materials/matte.json"),
        dir.join("materials/matte.json"),
    )
    .unwrap();
    std::fs::write(
        dir.join("meshes/bunny.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n\
         f 1/1/1 2/2/1 3/3/1\nf 2/2/1 4/4/1 3/3/1\n",
    )
    .unwrap();
    let path = write_scene(&dir, &doc[start..end]);
    let film = render(
        &path,
        &RenderOptions {
            res: Some((8, 8)),
            ..RenderOptions::default()
        },
        1,
    );
    let names: Vec<&str> = film.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "beauty",
            "diffuse",
            "specular",
            "indirect",
            "occlusion",
            "normal",
            "depth",
            "lighting"
        ]
    );
}

/// The bundled multiplication tree is balanced: level 3 is 2³ − 1 = 7 multiply nodes over
/// 2³ = 8 world-space position leaves, each multiply fed by two distinct nodes.
#[test]
fn mult_tree_network_is_a_balanced_level_3_tree() {
    let text = std::fs::read_to_string(example("materials/mult_tree_3.json")).unwrap();
    let net = shadenet::graph::Network::from_json(&text).unwrap();
    let count = |t: &str| net.nodes.iter().filter(|n| n.ty == t).count();
    assert_eq!(count("multiply"), 7);
    assert_eq!(count("samplerInfo"), 8);
    let mut fed = std::collections::BTreeSet::new();
    for n in net.nodes.iter().filter(|n| n.ty == "multiply") {
        for k in ["input1", "input2"] {
            let src = n.inputs[k]
                .as_str()
                .unwrap()
                .split('.')
                .next()
                .unwrap()
                .to_string();
            assert!(fed.insert(src), "a node feeds two multiplies");
        }
    }
    assert_eq!(fed.len(), 14);
}

/// A perfect mirror (phong with reflectivity 1, no diffuse or highlight) on the floor
/// shows a red Lambertian quad standing on it: every mirror pixel whose reflected ray
/// (computed here from the camera model) meets the quad has the radiance of the quad seen
/// directly, ρ/π·E (distant light of irradiance E straight at it), to 1e-5 relative, all of
/// it in the `reflection` pass; mirror pixels whose reflected ray misses it show the black
/// background. Reflectivity 0.5 halves the reflection.
#[test]
fn a_mirror_shows_the_reflected_object() {
    let dir = tmp_dir("mirror");
    let (w, h) = (32u32, 24u32);
    let text = |reflectivity: f64| {
        format!(
            r#"
[camera]
position = [0, 1, 4]
look_at = [0, 0.6, 0]
fov = 40
resolution = [{w}, {h}]

[render]
passes = ["diffuse", "reflection"]

[materials.mirror.inline]
nodes = [ {{ name = "surf", type = "phong", inputs = {{ color = [0, 0, 0], diffuse = 0.0,
            specularColor = 0.0, reflectivity = {reflectivity}, reflectedColor = [1, 1, 1] }} }} ]
outputs = {{ color = "surf.outColor" }}

[materials.red.inline]
nodes = [ {{ name = "surf", type = "lambert", inputs = {{ color = [0.9, 0.1, 0.05], diffuse = 1.0 }} }} ]
outputs = {{ color = "surf.outColor" }}

[meshes.quad]
type = "quad"

[[instances]]
name = "mirror floor"
mesh = "quad"
material = "mirror"
rotate = [-90, 0, 0]
scale = 20

# The red quad: x in [-1, 1], y in [0.2, 2.2], in the plane z = -1, facing +z.
[[instances]]
name = "red quad"
mesh = "quad"
material = "red"
translate = [0, 1.2, -1]

[[lights]]
type = "distant"
direction = [0, 0, -1]
intensity = 3
"#
        )
    };
    let expected = [0.9, 0.1, 0.05].map(|rho: f64| rho / std::f64::consts::PI * 3.0);
    // Where camera ray (o, d) ends: 0 background, 1 the quad directly, 2 the quad in the
    // mirror, 3 the mirror showing the background; None within 0.05 of an edge.
    let classify = |o: [f64; 3], d: [f64; 3]| -> Option<u8> {
        // Signed distance inside the quad's rectangle where a ray meets z = −1 (−1: never).
        let on_quad = |o: [f64; 3], d: [f64; 3]| -> f64 {
            if d[2] >= 0.0 {
                return -1.0;
            }
            let t = (-1.0 - o[2]) / d[2];
            let (qx, qy) = (o[0] + d[0] * t, o[1] + d[1] * t);
            (1.0 - qx.abs()).min(qy - 0.2).min(2.2 - qy)
        };
        let floor_t = if d[1] < 0.0 {
            -o[1] / d[1]
        } else {
            f64::INFINITY
        };
        let quad_t = if d[2] < 0.0 {
            (-1.0 - o[2]) / d[2]
        } else {
            f64::INFINITY
        };
        let inside = on_quad(o, d);
        if quad_t < floor_t && inside.abs() > 0.05 {
            return Some(if inside > 0.0 { 1 } else { 0 });
        }
        if floor_t < quad_t && inside < -0.05 {
            let p = [0, 1, 2].map(|k| o[k] + d[k] * floor_t);
            let m = on_quad(p, [d[0], -d[1], d[2]]);
            if m.abs() > 0.05 {
                return Some(if m > 0.0 { 2 } else { 3 });
            }
        }
        None
    };
    let opts = RenderOptions::default();
    let (film, stats) = render_text(&dir, &text(1.0), &opts);
    assert_eq!(stats.nonfinite, 0);
    let scene = shadenet::tracer::scene::load(&dir.join("scene.toml")).unwrap();
    let camera = Camera::new(&scene.camera);
    let (beauty, refl) = (
        film.layer("beauty").unwrap(),
        film.layer("reflection").unwrap(),
    );
    let mut counts = [0usize; 4];
    let mut worst = 0.0f64;
    let mut mirrored = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let ray = camera.ray(x as f32 + 0.5, y as f32 + 0.5, false);
            let (o, d) = (ray.o.to_array(), ray.d.to_array());
            let Some(class) = classify(o.map(f64::from), d.map(f64::from)) else {
                continue;
            };
            counts[class as usize] += 1;
            let i = (y * w + x) as usize;
            for (c, want) in expected.iter().enumerate() {
                let got = beauty.at(i, c) as f64;
                match class {
                    1 | 2 => {
                        let rel = (got - want).abs() / want;
                        worst = worst.max(rel);
                        assert!(
                            rel < 1e-5,
                            "pixel ({x}, {y}) class {class}: {got} vs {want}"
                        );
                    }
                    _ => assert_eq!(got, 0.0, "pixel ({x}, {y}) class {class}"),
                }
                if class == 2 {
                    assert_eq!(refl.at(i, c), beauty.at(i, c), "all of it is reflection");
                }
            }
            if class == 2 {
                mirrored.push(i);
            }
        }
    }
    eprintln!(
        "mirror: {counts:?} pixels (background, quad, quad in the mirror, mirror showing the \
         background); largest relative error {worst:e}"
    );
    assert!(
        counts.iter().all(|&n| n >= 8),
        "every case is seen: {counts:?}"
    );
    let (half, _) = render_text(&dir, &text(0.5), &opts);
    let hb = half.layer("beauty").unwrap();
    for &i in &mirrored {
        for c in 0..3 {
            let want = 0.5 * beauty.at(i, c);
            assert!((hb.at(i, c) - want).abs() <= 1e-6 * want, "{i}");
        }
    }
}

/// Glass (transparency 1, η = 1.5, no diffuse or highlight) over a uniform environment of
/// radiance 1, in two scenes:
///
/// - a glass sphere filling most of the frame, 4 samples per pixel (its silhouette is
///   seen at every angle up to grazing);
/// - a wide glass slab seen from 0.1 above its top face, so that the lower half of the image
///   meets that face between 85° and 89.8° from its normal; the light refracted there
///   reaches the bottom face just under the critical angle (41.8°), where the Fresnel
///   reflectance is near 1 and light bounces many times inside.
///
/// Every path ends in the environment (1) or at a depth limit (0), and each interface splits
/// its weight into F and 1 − F, so no pixel may be brighter than the background (tolerance
/// 1e-4 for the f32 sums); the sphere, which cannot trap light, must pass nearly all of it
/// (> 0.99 inside its disc), and the grazing slab must not be dark (> 0.8). Nothing may be
/// non-finite: the output guard catches nothing, and the reflection and refraction passes
/// both carry light.
#[test]
fn glass_at_grazing_angles_stays_finite_and_passes_the_background() {
    let dir = tmp_dir("glass");
    let scene = |camera: &str, instance: &str| {
        format!(
            r#"
[camera]
{camera}
resolution = [16, 16]

[render]
spp = 4
max_reflection_depth = 6
max_refraction_depth = 8
passes = ["reflection", "refraction"]

[materials.glass.inline]
nodes = [ {{ name = "surf", type = "phong", inputs = {{ color = [0, 0, 0], diffuse = 0.0,
            specularColor = 0.0, transparency = [1, 1, 1], refractions = true,
            refractiveIndex = 1.5 }} }} ]
outputs = {{ color = "surf.outColor" }}

[meshes.ball]
type = "sphere"
segments = 48

[meshes.cube]
type = "box"

[[instances]]
material = "glass"
{instance}

[[lights]]
type = "environment"
intensity = 1
samples = 1
"#
        )
    };
    let sphere = scene(
        "position = [0, 0, 4]\nlook_at = [0, 0, 0]\nfov = 35",
        "mesh = \"ball\"",
    );
    // The slab: x, z in [-20, 20], y in [-1, 1]; the eye 0.1 above its top face.
    let slab = scene(
        "position = [0, 1.1, 19]\nlook_at = [0, 1.1, 0]\nfov = 10",
        "mesh = \"cube\"\nscale = [20, 1, 20]",
    );
    for (name, text) in [("sphere", sphere), ("slab", slab)] {
        let (film, stats) = render_text(&dir, &text, &RenderOptions::default());
        assert_eq!(
            stats.nonfinite, 0,
            "{name}: the output guard caught non-finite values"
        );
        for l in &film.layers {
            assert!(l.data.iter().all(|x| x.is_finite()), "{name}: {}", l.name);
        }
        let (b, refl, refr) = (
            film.layer("beauty").unwrap(),
            film.layer("reflection").unwrap(),
            film.layer("refraction").unwrap(),
        );
        let (mut hi, mut lo) = (0.0f32, f32::MAX);
        for y in 0..16usize {
            for x in 0..16usize {
                let i = y * 16 + x;
                for c in 0..3 {
                    hi = hi.max(b.at(i, c));
                    assert!(
                        b.at(i, c) <= 1.0 + 1e-4,
                        "{name} ({x}, {y}): {}",
                        b.at(i, c)
                    );
                }
                // The sphere's disc has a radius of 7.2 pixels; the slab fills rows 8 to 15.
                let (dx, dy) = (x as f32 - 7.5, y as f32 - 7.5);
                let inside = if name == "sphere" {
                    dx * dx + dy * dy < 6.0 * 6.0
                } else {
                    y >= 8
                };
                if inside {
                    lo = lo.min(b.at(i, 0));
                    assert!(refl.at(i, 0) > 0.0, "{name} ({x}, {y}): no reflection");
                    assert!(refr.at(i, 0) > 0.0, "{name} ({x}, {y}): no refraction");
                }
            }
        }
        eprintln!("glass {name} over a background of 1: brightest pixel {hi}, darkest {lo}");
        let floor = if name == "sphere" { 0.99 } else { 0.8 };
        assert!(lo > floor, "{name}: {lo}");
    }
}

/// Total internal reflection, measured: the camera sits inside a glass slab (η = 1.5) and
/// looks at its top face 60° from the normal (28° to 32° over the image), beyond the
/// critical angle of 41.8°. The camera hit traces no refraction (the `refraction` pass is
/// exactly 0); the light arrives by three total reflections (top, bottom, top) and leaves
/// through the slab's far end at the same angle to its normal, so each pixel is `1 − F`
/// (exact Fresnel, leaving glass at that angle) times the environment's 1, to 1e-4.
#[test]
fn total_internal_reflection_guides_the_light_and_stays_finite() {
    let dir = tmp_dir("tir");
    let text = r#"
[camera]
position = [0, 0, 0]
look_at = [0.8660254, 0.5, 0]
fov = 4
resolution = [4, 4]

[render]
max_reflection_depth = 4
max_refraction_depth = 6
passes = ["reflection", "refraction"]

[materials.glass.inline]
nodes = [ { name = "surf", type = "phong", inputs = { color = [0, 0, 0], diffuse = 0.0,
            specularColor = 0.0, transparency = [1, 1, 1], refractions = true,
            refractiveIndex = 1.5 } } ]
outputs = { color = "surf.outColor" }

[meshes.cube]
type = "box"

# x in [-10, 10], y in [-1, 1], z in [-3, 3].
[[instances]]
mesh = "cube"
material = "glass"
scale = [10, 1, 3]

[[lights]]
type = "environment"
intensity = 1
samples = 1
"#;
    let (film, stats) = render_text(&dir, text, &RenderOptions::default());
    assert_eq!(stats.nonfinite, 0);
    let scene = shadenet::tracer::scene::load(&dir.join("scene.toml")).unwrap();
    let camera = Camera::new(&scene.camera);
    let (b, refl, refr) = (
        film.layer("beauty").unwrap(),
        film.layer("reflection").unwrap(),
        film.layer("refraction").unwrap(),
    );
    let mut worst = 0.0f64;
    for y in 0..4u32 {
        for x in 0..4u32 {
            let i = (y * 4 + x) as usize;
            let d = camera
                .ray(x as f32 + 0.5, y as f32 + 0.5, false)
                .d
                .to_array();
            assert!(d[1] < 0.745, "the camera hit is beyond the critical angle");
            // Reflections off y faces keep |d.x|: the far end sees cosθ = |d.x|.
            let want = 1.0 - fresnel_leaving(f64::from(d[0]).abs(), 1.5);
            for c in 0..3 {
                assert_eq!(refr.at(i, c), 0.0, "pixel {i}: no refraction under TIR");
                assert_eq!(
                    refl.at(i, c),
                    b.at(i, c),
                    "pixel {i}: all of it is reflection"
                );
                let got = b.at(i, c) as f64;
                worst = worst.max((got - want).abs());
                assert!(
                    (got - want).abs() < 1e-4,
                    "pixel {i}: {got} vs 1 − F = {want}"
                );
            }
        }
    }
    eprintln!("light guide: largest |pixel − (1 − F)| = {worst:e}");
}

/// The shadow pass of the bundled `matte.json` (its `shadow` output, `surf.outShadow`): a
/// plane under a point light, half of it (y > 0) shadowed by a wall the camera cannot see.
/// With the wall, `shadow` is non-zero exactly where the wall blocks the light (and
/// `diffuse` is 0 there), zero elsewhere; `diffuse + shadow` equals the diffuse of the same
/// render without the wall to 1e-5 relative per pixel; and the shadow stays out of the
/// beauty (beauty = diffuse, the material's only lit component).
#[test]
fn shadow_pass_is_the_diffuse_light_the_shadows_take() {
    let dir = tmp_dir("shadow");
    let text = |wall: bool| {
        let wall = if wall {
            // The plane x = 3, y in [0, 20], z in [0, 2.5]: it blocks the light's rays to
            // the points of the plane with y > 0.
            "[[instances]]\nname = \"wall\"\nmesh = \"q\"\nmaterial = \"m\"\n\
             translate = [3, 10, 1.25]\nrotate = [0, 90, 0]\nscale = [1.25, 10, 1]\n"
        } else {
            ""
        };
        format!(
            r#"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
fov = 30
resolution = [16, 16]

[render]
passes = ["diffuse", "shadow"]

[materials.m]
network = "{}"

[meshes.q]
type = "quad"

[[instances]]
name = "plane"
mesh = "q"
material = "m"
scale = 3

{wall}
[[lights]]
type = "point"
position = [5, 0, 3]
intensity = 20
"#,
            example("materials/matte.json").display()
        )
    };
    let opts = RenderOptions::default();
    let (lit, _) = render_text(&dir, &text(false), &opts);
    let (film, _) = render_text(&dir, &text(true), &opts);
    let l = |f: &Film, n: &str| f.layer(n).unwrap().clone();
    let (open, diffuse, shadow, beauty) = (
        l(&lit, "diffuse"),
        l(&film, "diffuse"),
        l(&film, "shadow"),
        l(&film, "beauty"),
    );
    assert!(
        l(&lit, "shadow").data.iter().all(|x| *x == 0.0),
        "no wall, no shadow"
    );
    let mut worst = 0.0f32;
    for y in 0..16usize {
        for x in 0..16usize {
            let i = y * 16 + x;
            // Rows 0–7 see y > 0 on the plane (row 0 at the top).
            let shadowed = y < 8;
            for c in 0..3 {
                let (d, s, o) = (diffuse.at(i, c), shadow.at(i, c), open.at(i, c));
                assert!(o > 0.0, "({x}, {y}): the plane is lit without the wall");
                if shadowed {
                    assert!(s > 0.0 && d == 0.0, "({x}, {y}): diffuse {d}, shadow {s}");
                } else {
                    assert!(s == 0.0 && d > 0.0, "({x}, {y}): diffuse {d}, shadow {s}");
                }
                worst = worst.max((d + s - o).abs() / o);
                assert!(
                    (d + s - o).abs() <= 1e-5 * o,
                    "({x}, {y}): diffuse {d} + shadow {s} vs unshadowed {o}"
                );
                assert_eq!(
                    beauty.at(i, c),
                    d,
                    "({x}, {y}): the shadow is not in the beauty"
                );
            }
        }
    }
    eprintln!("shadow: largest |diffuse + shadow − unshadowed| / unshadowed = {worst:e}");
}
