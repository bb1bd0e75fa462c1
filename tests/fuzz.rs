//! Fuzz targets, run for a bounded time in CI (docs/fuzzing.md says how to run them for
//! hours): byte-level mutation of network JSON, scene TOML, MaterialX documents, shader
//! source (`.sl`, `.osl`), OSL shader groups, OBJ meshes and image files, and
//! value-level mutation of our example scenes and networks (a number replaced by ±1e308,
//! 1e-45, 2³¹, 0…; a key deleted; an array element duplicated), each loaded and rendered or
//! shaded as a tiny image on every CPU back end. Any panic, hang or over-allocation fails
//! the test, with the input printed in the log and saved under `target/fuzz-crashes/`;
//! every input ever found is kept under `tests/fuzz/regressions/` and replayed by
//! [`fuzz_regressions`].

mod fuzzing;

use fuzzing::{HOSTILE_FLOATS, HOSTILE_INTS, Rng, Target};
use shadenet::graph::ir::TextureFile;
use shadenet::graph::nodes::{LightDesc, LightKind};
use shadenet::graph::opt::{self, Specialization};
use shadenet::graph::{NodeLibrary, compile_json};
use shadenet::render::{self as r, BackendKind, Files, RenderOptions};
use shadenet::runtime::Backend;
use shadenet::shade::{grid_env, shade_grid, shade_grid_with};
use std::path::{Path, PathBuf};

#[global_allocator]
static ALLOC: fuzzing::CountingAlloc = fuzzing::CountingAlloc;

/// The CI budget per target in seconds (eight targets: about two and two-thirds minutes).
const CI_SECS: f64 = 20.0;

/// Inputs larger than this are cut (seeds are a few kilobytes).
const MAX_INPUT: usize = 64 << 10;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The files of a directory with one of `exts`, sorted, as seeds.
fn files(dir: &Path, exts: &[&str]) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| exts.contains(&e))
        })
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p.file_name().unwrap().to_string_lossy().into_owned(), bytes)
        })
        .collect();
    v.sort();
    v
}

/// A scratch directory of this process and thread for files the targets write.
fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "shadenet-fuzz-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    std::fs::create_dir_all(&d).unwrap();
    d
}

// ---- what each input goes through ----

/// A network: compiled, validated, optimized, then shaded as a 4×3 grid by the
/// interpreter, the JIT's scalar entry and its batch entry.
fn exec_network(bytes: &[u8]) {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    let Ok(c) = compile_json(text, &NodeLibrary::standard()) else {
        return;
    };
    shade_compiled(&c);
}

/// A MaterialX document (through a file, as users hand it in), compiled against the
/// libraries `SHADENET_MTLX_LIBRARIES` names and shaded as [`exec_network`] does. Without
/// the libraries (outside CI) there is nothing to run.
fn exec_mtlx(bytes: &[u8]) {
    let path = scratch().join("fuzz.mtlx");
    std::fs::write(&path, bytes).unwrap();
    if let Ok(c) = shadenet::compile_mtlx(&path, &shadenet::mtlx::MtlxOptions::default()) {
        shade_compiled(&c);
    }
}

/// Validates, optimizes and shades a compiled network on the interpreter, the JIT's scalar
/// entry and its batch entry.
fn shade_compiled(c: &shadenet::Compiled) {
    if let Err(e) = shadenet::graph::ir::validate(&c.program) {
        panic!("linked network lowers to invalid IR: {e}");
    }
    let spec = Specialization::default();
    let (p, _) = opt::run(&c.program, &spec);
    if let Err(e) = shadenet::graph::ir::validate(&p) {
        panic!("the optimizer produced invalid IR: {e}");
    }
    let mut lights = c.lights.clone();
    if lights.is_empty() {
        let point = LightKind::Point {
            position: [1.0, 1.0, 2.0],
        };
        lights.push(LightDesc::new("key", point, [20.0; 3]).expect("a valid light"));
    }
    let env = grid_env(&lights);
    let _ = shade_grid::<f32>(&p, &env, 4, 3, spec.components);
    let jit = shadenet_jit::JitBackend::new();
    if let Ok(m) = jit.compile(&c.program, &spec) {
        shade_grid_with(&*m, &env, 4, 3, spec.components, false);
        shade_grid_with(&*m, &env, 4, 3, spec.components, true);
    }
}

/// Scene text, read as if it were `examples/scenes/fuzz.toml` (so the examples' relative
/// paths resolve), rendered at 4×3 with 1 spp on the interpreter and the JIT.
fn exec_scene(bytes: &[u8]) {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    let dir = root().join("examples/scenes");
    render_scene_text(text, &dir);
}

fn render_scene_text(text: &str, dir: &Path) {
    let Ok(mut scene) = shadenet::tracer::scene::parse(text, &dir.join("fuzz.toml")) else {
        return;
    };
    let tiny = RenderOptions {
        spp: Some(1),
        passes: None,
        res: Some((4, 3)),
        light_strategy: None,
    };
    if r::apply_options(&mut scene, &tiny).is_err() {
        return;
    }
    for kind in [BackendKind::Interp, BackendKind::Jit] {
        let backend = r::backend(kind).expect("CPU back ends start");
        if let Ok((renderer, _)) =
            r::prepare(scene.clone(), Files::Disk, dir, backend.as_ref(), None)
        {
            let _ = renderer.render(&|_, _| {});
        }
    }
}

/// An OBJ file: loaded, then placed in a small scene and rendered (the BVH sees its
/// vertices).
fn exec_obj(bytes: &[u8]) {
    let dir = scratch();
    let obj = dir.join("fuzz.obj");
    std::fs::write(&obj, bytes).unwrap();
    if shadenet::tracer::geometry::load_obj(&obj).is_err() {
        return;
    }
    let scene = format!(
        r#"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
[render]
spp = 1
[[lights]]
type = "point"
position = [2, 2, 4]
intensity = 10
[materials.m]
network = {:?}
[meshes.fuzz]
type = "obj"
file = "fuzz.obj"
[[instances]]
mesh = "fuzz"
material = "m"
"#,
        root().join("examples/scenes/materials/matte.json")
    );
    render_scene_text(&scene, &dir);
}

/// The two OSL shaders the group target's layers may name.
const GROUP_SHADERS: [(&str, &str); 2] = [
    (
        "noisy",
        "shader noisy(float scale = 1, color tint = 1, output float n = 0, output color c = 0) { n = snoise(P * scale); c = tint * n; }",
    ),
    (
        "tint",
        "surface tint(color base = 1, float amount = 0, float k = 1) { Ci = (base * k + amount) * diffuse(N); }",
    ),
];

/// OSL shader-group text: parsed; a group whose layers name the two shaders above is
/// lowered, and what lowers is a valid program.
fn exec_osl_group(bytes: &[u8]) {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    if text.len() > shadenet_lang::source::MAX_FILE_BYTES {
        return;
    }
    let mut sources = shadenet_lang::SourceMap::new();
    let file = sources.add("fuzz.oslgroup", text.to_string());
    let group = match shadenet_lang::group::parse(&sources, file) {
        Ok(g) => g,
        Err(d) => {
            let _ = d.render(&sources);
            return;
        }
    };
    let options = shadenet_lang::Options::new(shadenet_lang::Dialect::Osl);
    let mut shaders = std::collections::HashMap::new();
    for layer in &group.layers {
        let Some((name, src)) = GROUP_SHADERS.iter().find(|(n, _)| *n == layer.shader.name) else {
            return;
        };
        let parsed = shadenet_lang::parse_str(&mut sources, &format!("{name}.osl"), src, &options)
            .expect("the group target's shaders parse");
        shaders.insert(name.to_string(), parsed);
    }
    let loaded = shadenet_lang::group::LoadedGroup { group, shaders };
    match shadenet_lang::lower::compile_group(&loaded) {
        Ok(p) => {
            if let Err(e) = shadenet::graph::ir::validate(&p) {
                panic!("a shader group lowered to an invalid program: {e}\n{p}");
            }
        }
        Err(d) => {
            let _ = d.render(&sources);
        }
    }
}

/// Shader source through the shading-language front end (preprocess, parse) in both
/// dialects; a diagnostic is rendered against the source map as the CLI prints it.
fn exec_shader_source(bytes: &[u8]) {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    for dialect in [shadenet_lang::Dialect::Rsl, shadenet_lang::Dialect::Osl] {
        let mut sources = shadenet_lang::SourceMap::new();
        let options = shadenet_lang::Options::new(dialect);
        let parsed = match shadenet_lang::parse_str(&mut sources, "fuzz", text, &options) {
            Ok(p) => p,
            Err(d) => {
                let _ = d.render(&sources);
                continue;
            }
        };
        // What parses is checked and lowered; what lowers is a valid program that the
        // optimizer keeps valid and the interpreter shades (loops end at their limit).
        let program = match shadenet_lang::lower::compile(&parsed, None) {
            Ok(p) => p,
            Err(d) => {
                let _ = d.render(&sources);
                continue;
            }
        };
        if let Err(e) = shadenet::graph::ir::validate(&program) {
            panic!("the front end lowered an invalid program: {e}\n{program}");
        }
        let (o, _) = opt::run(&program, &Specialization::default());
        if let Err(e) = shadenet::graph::ir::validate(&o) {
            panic!("the optimizer left an invalid program: {e}\n{o}");
        }
        let _ = shade_grid::<f32>(&o, &grid_env(&[]), 2, 2, u32::MAX);
    }
}

/// Image bytes as a PNG texture and as an EXR.
fn exec_image(bytes: &[u8]) {
    let dir = scratch();
    let png = dir.join("fuzz.png");
    std::fs::write(&png, bytes).unwrap();
    let _ = shadenet::runtime::Texture::load(&TextureFile::auto(png.to_string_lossy()));
    let exr = dir.join("fuzz.exr");
    std::fs::write(&exr, bytes).unwrap();
    // The same bytes as an EXR texture (the texture decoder's reader, not the film's).
    let _ = shadenet::runtime::Texture::load(&TextureFile::auto(exr.to_string_lossy()));
    let _ = shadenet::output::read_exr(&exr);
}

// ---- value-level mutation ----

/// Counts the values of a tree (each table, array and leaf).
trait Tree: Sized {
    fn children(&mut self) -> Vec<&mut Self>;
    fn mutate_here(&mut self, rng: &mut Rng);
}

fn count<T: Tree>(v: &mut T) -> usize {
    1 + v.children().into_iter().map(count).sum::<usize>()
}

/// Mutates the `k`-th value in pre-order; returns whether it was found.
fn mutate_nth<T: Tree>(v: &mut T, k: usize, i: &mut usize, rng: &mut Rng) -> bool {
    if *i == k {
        v.mutate_here(rng);
        return true;
    }
    *i += 1;
    for c in v.children() {
        if mutate_nth(c, k, i, rng) {
            return true;
        }
    }
    false
}

fn mutate_tree<T: Tree>(v: &mut T, rng: &mut Rng) {
    for _ in 0..1 + rng.below(3) {
        let n = count(v);
        let k = rng.below(n);
        mutate_nth(v, k, &mut 0, rng);
    }
}

impl Tree for toml::Value {
    fn children(&mut self) -> Vec<&mut Self> {
        match self {
            toml::Value::Table(t) => t.iter_mut().map(|(_, v)| v).collect(),
            toml::Value::Array(a) => a.iter_mut().collect(),
            _ => Vec::new(),
        }
    }

    fn mutate_here(&mut self, rng: &mut Rng) {
        use toml::Value as V;
        let hostile_float = |rng: &mut Rng| match rng.below(12) {
            0 => f64::NAN,
            1 => f64::INFINITY,
            2 => f64::NEG_INFINITY,
            _ => *rng.pick(HOSTILE_FLOATS),
        };
        match self {
            V::Integer(_) if rng.one_in(3) => *self = V::Float(hostile_float(rng)),
            V::Integer(_) => *self = V::Integer(*rng.pick(HOSTILE_INTS)),
            V::Float(_) => *self = V::Float(hostile_float(rng)),
            V::Table(t) if !t.is_empty() => {
                let keys: Vec<String> = t.keys().cloned().collect();
                t.remove(rng.pick(&keys));
            }
            V::Array(a) if !a.is_empty() => {
                let i = rng.below(a.len());
                match rng.below(3) {
                    0 => {
                        a.remove(i);
                    }
                    _ => {
                        let dup = a[i].clone();
                        a.insert(i, dup);
                    }
                }
            }
            V::String(_) => {
                let s = *rng.pick(&["", "nope", "/dev/zero", "../../../etc/passwd", "x.obj"]);
                *self = V::String(s.into());
            }
            V::Boolean(b) => *b = !*b,
            _ => *self = V::Integer(*rng.pick(HOSTILE_INTS)),
        }
    }
}

impl Tree for serde_json::Value {
    fn children(&mut self) -> Vec<&mut Self> {
        match self {
            serde_json::Value::Object(o) => o.values_mut().collect(),
            serde_json::Value::Array(a) => a.iter_mut().collect(),
            _ => Vec::new(),
        }
    }

    fn mutate_here(&mut self, rng: &mut Rng) {
        use serde_json::Value as V;
        match self {
            V::Number(n) if n.is_i64() || n.is_u64() => {
                *self = if rng.one_in(3) {
                    serde_json::json!(*rng.pick(HOSTILE_FLOATS))
                } else {
                    serde_json::json!(*rng.pick(HOSTILE_INTS))
                }
            }
            V::Number(_) => *self = serde_json::json!(*rng.pick(HOSTILE_FLOATS)),
            V::Object(o) if !o.is_empty() => {
                let keys: Vec<String> = o.keys().cloned().collect();
                o.remove(rng.pick(&keys));
            }
            V::Array(a) if !a.is_empty() => {
                let i = rng.below(a.len());
                if rng.one_in(3) {
                    a.remove(i);
                } else {
                    let dup = a[i].clone();
                    a.insert(i, dup);
                }
            }
            V::String(_) => {
                let s = *rng.pick(&["", "nope", "/dev/zero", "a.outColor", "a.outColor.r"]);
                *self = V::String(s.into());
            }
            V::Bool(b) => *b = !*b,
            _ => *self = serde_json::json!(*rng.pick(HOSTILE_INTS)),
        }
    }
}

fn mutate_scene_values(rng: &mut Rng, seed: &[u8], _: &[Vec<u8>]) -> Vec<u8> {
    let Ok(mut v) = std::str::from_utf8(seed)
        .map_err(|_| ())
        .and_then(|t| t.parse::<toml::Value>().map_err(|_| ()))
    else {
        return seed.to_vec();
    };
    mutate_tree(&mut v, rng);
    toml::to_string(&v).map_or_else(|_| seed.to_vec(), String::into_bytes)
}

fn mutate_network_values(rng: &mut Rng, seed: &[u8], _: &[Vec<u8>]) -> Vec<u8> {
    let Ok(mut v) = serde_json::from_slice::<serde_json::Value>(seed) else {
        return seed.to_vec();
    };
    mutate_tree(&mut v, rng);
    serde_json::to_vec_pretty(&v).unwrap_or_else(|_| seed.to_vec())
}

fn mutate_bytes(rng: &mut Rng, seed: &[u8], others: &[Vec<u8>]) -> Vec<u8> {
    fuzzing::mutate_bytes(rng, seed, others, MAX_INPUT)
}

// ---- the targets ----

/// Small images written by our own code: 8-bit RGB, 8-bit gray + alpha, 16-bit RGBA PNGs,
/// and a two-layer EXR.
fn image_seeds() -> Vec<(String, Vec<u8>)> {
    use image::{DynamicImage, ImageBuffer, ImageFormat, Luma, LumaA, Rgb, Rgba};
    let mut out = Vec::new();
    let mut push = |name: &str, img: DynamicImage| {
        let mut bytes = std::io::Cursor::new(Vec::new());
        img.write_to(&mut bytes, ImageFormat::Png).unwrap();
        out.push((name.to_string(), bytes.into_inner()));
    };
    push(
        "rgb8.png",
        DynamicImage::ImageRgb8(ImageBuffer::from_fn(5, 3, |x, y| {
            Rgb([x as u8 * 40, y as u8 * 80, 7])
        })),
    );
    push(
        "la8.png",
        DynamicImage::ImageLumaA8(ImageBuffer::from_fn(2, 4, |x, y| LumaA([x as u8, y as u8]))),
    );
    push(
        "rgba16.png",
        DynamicImage::ImageRgba16(ImageBuffer::from_fn(3, 3, |x, y| {
            Rgba([x as u16 * 9000, y as u16 * 9000, 1, 65535])
        })),
    );
    push(
        "l8.png",
        DynamicImage::ImageLuma8(ImageBuffer::from_fn(1, 1, |_, _| Luma([200]))),
    );
    let exr = scratch().join("seed.exr");
    shadenet::output::write_exr(
        &exr,
        2,
        2,
        vec![
            ("color.R".to_string(), vec![0.0, 0.5, 1.0, 2.0]),
            ("depth.Y".to_string(), vec![1.0, 2.0, 3.0, 4.0]),
        ],
    )
    .unwrap();
    out.push(("two_layers.exr".into(), std::fs::read(&exr).unwrap()));
    out
}

fn targets() -> Vec<Target> {
    let networks = files(&root().join("examples/networks"), &["json"])
        .into_iter()
        .chain(files(&root().join("examples/scenes/materials"), &["json"]))
        .collect::<Vec<_>>();
    let scenes = files(&root().join("examples/scenes"), &["toml"]);
    vec![
        Target {
            name: "network_json",
            seeds: networks.clone(),
            mutate: mutate_bytes,
            exec: exec_network,
            ext: "json",
        },
        Target {
            name: "network_values",
            seeds: networks,
            mutate: mutate_network_values,
            exec: exec_network,
            ext: "json",
        },
        Target {
            name: "scene_toml",
            seeds: scenes.clone(),
            mutate: mutate_bytes,
            exec: exec_scene,
            ext: "toml",
        },
        Target {
            name: "scene_values",
            seeds: scenes,
            mutate: mutate_scene_values,
            exec: exec_scene,
            ext: "toml",
        },
        Target {
            name: "obj",
            seeds: files(&root().join("tests/fuzz/corpus/obj"), &["obj"]),
            mutate: mutate_bytes,
            exec: exec_obj,
            ext: "obj",
        },
        Target {
            name: "image",
            seeds: image_seeds(),
            mutate: mutate_bytes,
            exec: exec_image,
            ext: "bin",
        },
        Target {
            name: "shading_language",
            seeds: [
                files(&root().join("lang/tests/shaders"), &["sl", "osl"]),
                files(&root().join("examples/shaders"), &["osl"]),
            ]
            .concat(),
            mutate: mutate_bytes,
            exec: exec_shader_source,
            ext: "sl",
        },
        Target {
            name: "osl_group",
            seeds: files(&root().join("tests/fuzz/corpus/oslgroup"), &["oslgroup"]),
            mutate: mutate_bytes,
            exec: exec_osl_group,
            ext: "oslgroup",
        },
        Target {
            name: "mtlx",
            seeds: files(&root().join("examples/materials"), &["mtlx"]),
            mutate: mutate_bytes,
            exec: exec_mtlx,
            ext: "mtlx",
        },
    ]
}

/// Every target for its budget (`SHADENET_FUZZ_SECS`, default 20 s each; only the target
/// named by `SHADENET_FUZZ_TARGET` when it is set).
#[test]
fn fuzz_targets() {
    let only = std::env::var("SHADENET_FUZZ_TARGET").ok();
    let budget = fuzzing::budget(CI_SECS);
    let seed = fuzzing::seed();
    let mut failed = Vec::new();
    let mut ran = 0;
    for t in targets() {
        if only.as_deref().is_some_and(|o| o != t.name) {
            continue;
        }
        assert!(!t.seeds.is_empty(), "fuzz target {} has no seeds", t.name);
        let start = std::time::Instant::now();
        let report = fuzzing::run(&t, budget, seed);
        ran += 1;
        eprintln!(
            "fuzz {}: {} cases in {:.1} s (seed {seed}, {} seeds), {} findings",
            t.name,
            report.cases,
            start.elapsed().as_secs_f64(),
            t.seeds.len(),
            report.findings.len()
        );
        for (what, path) in report.findings {
            failed.push(format!("{}: {what} ({})", t.name, path.display()));
        }
    }
    assert!(ran > 0, "SHADENET_FUZZ_TARGET={only:?} names no target");
    assert!(
        failed.is_empty(),
        "fuzzing found {} problem(s); each input is printed above and saved (add it to \
         tests/fuzz/regressions/<target>/ with the fix):\n{}",
        failed.len(),
        failed.join("\n")
    );
}

/// Every input fuzzing ever found, replayed through its target: none may panic, hang or
/// over-allocate.
#[test]
fn fuzz_regressions() {
    let dir = root().join("tests/fuzz/regressions");
    fuzzing::install_panic_hook();
    let mut replayed = 0;
    for t in targets() {
        let sub = dir.join(t.name);
        if !sub.is_dir() {
            continue;
        }
        for (name, bytes) in files(&sub, &[t.ext, "json", "toml", "obj", "png", "exr", "bin"]) {
            if let Some(what) = fuzzing::run_one(t.exec, &bytes) {
                panic!("regression {}/{name}: {what}", t.name);
            }
            replayed += 1;
        }
    }
    assert!(replayed > 0, "no regression inputs under {}", dir.display());
}
