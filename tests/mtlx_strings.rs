//! Compile-time strings in MaterialX documents: `constant`, `dot` and
//! `geompropvalueuniform` string and filename nodes are folded into the inputs that read
//! them, and a scene's instances give the uniform geometric properties, each distinct set
//! compiling its own specialization of the material.
//! Needs the MaterialX libraries (fails without them when `CI` is set, skips otherwise).

mod common;
use common::*;
use shadenet::graph::error_chain;
use shadenet::graph::mtlx::{self, Selection};

fn doc(body: &str) -> String {
    format!("<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n{body}\n</materialx>\n")
}

fn compile_with(body: &str, props: &[(&str, &str)]) -> Option<Result<shadenet::Compiled, String>> {
    let lib = mtlx_library()?;
    let sel = Selection {
        geomprops: props
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        ..Selection::default()
    };
    Some(mtlx::compile("t.mtlx", &doc(body), lib, &sel).map_err(|e| error_chain(&e)))
}

/// The texture files a program reads.
fn files(c: &shadenet::Compiled) -> Vec<String> {
    c.program.textures.iter().map(|t| t.path.clone()).collect()
}

/// An image whose file is a uniform geometric property `tex`, default `fallback.png`.
const PER_OBJECT_IMAGE: &str = r#"
  <geompropvalueuniform name="g" type="filename">
    <input name="geomprop" type="string" value="tex" />
    <input name="default" type="filename" value="fallback.png" />
  </geompropvalueuniform>
  <image name="i" type="color3"><input name="file" type="filename" nodename="g" /></image>
  <output name="o" type="color3" nodename="i" />"#;

#[test]
fn a_uniform_geomprop_is_the_bound_geometrys_value_or_the_default() {
    let Some(given) = compile_with(PER_OBJECT_IMAGE, &[("tex", "brick.png"), ("other", "x")])
    else {
        return;
    };
    assert_eq!(files(&given.unwrap()), ["brick.png"]);
    let absent = compile_with(PER_OBJECT_IMAGE, &[("other", "x")]).unwrap();
    assert_eq!(files(&absent.unwrap()), ["fallback.png"]);
    let lib = mtlx_library().unwrap();
    let read =
        mtlx::uniform_geomprops("t.mtlx", &doc(PER_OBJECT_IMAGE), lib, &Selection::default())
            .unwrap();
    assert_eq!(read.into_iter().collect::<Vec<_>>(), ["tex"]);
}

/// Constants and dots chain, through a nodegraph's interface too.
#[test]
fn string_constants_and_dots_fold_into_their_readers() {
    let body = r#"
  <constant name="c" type="filename"><input name="value" type="filename" value="a.png" /></constant>
  <dot name="d1" type="filename"><input name="in" type="filename" nodename="c" /></dot>
  <dot name="d2" type="filename"><input name="in" type="filename" nodename="d1" /></dot>
  <image name="i" type="color3"><input name="file" type="filename" nodename="d2" /></image>
  <nodegraph name="ng">
    <input name="f" type="filename" value="b.png" />
    <dot name="d" type="filename"><input name="in" type="filename" interfacename="f" /></dot>
    <image name="i2" type="color3"><input name="file" type="filename" nodename="d" /></image>
    <output name="out" type="color3" nodename="i2" />
  </nodegraph>
  <constant name="s" type="string"><input name="value" type="string" value="Cd" /></constant>
  <geompropvalue name="gp" type="float"><input name="geomprop" type="string" nodename="s" /></geompropvalue>
  <add name="sum" type="color3"><input name="in1" type="color3" nodename="i" />
    <input name="in2" type="color3" nodegraph="ng" output="out" /></add>
  <output name="o" type="color3" nodename="sum" />
  <output name="a" type="float" nodename="gp" />"#;
    let Some(c) = compile_with(body, &[]) else {
        return;
    };
    let c = c.unwrap();
    let mut f = files(&c);
    f.sort();
    assert_eq!(f, ["a.png", "b.png"]);
    let attrs: Vec<&str> = c
        .program
        .attributes
        .iter()
        .map(|a| a.name.as_str())
        .collect();
    assert_eq!(attrs, ["Cd"]);
}

#[test]
fn string_nodes_report_what_is_wrong() {
    let cases = [
        (
            r#"<dot name="a" type="filename"><input name="in" type="filename" nodename="b" /></dot>
  <dot name="b" type="filename"><input name="in" type="filename" nodename="a" /></dot>
  <image name="i" type="color3"><input name="file" type="filename" nodename="a" /></image>
  <output name="o" type="color3" nodename="i" />"#,
            "a → b → a",
        ),
        (
            r#"<constant name="s" type="string"><input name="value" type="string" value="x.png" /></constant>
  <image name="i" type="color3"><input name="file" type="filename" nodename="s" /></image>
  <output name="o" type="color3" nodename="i" />"#,
            "string",
        ),
        (
            r#"<constant name="s" type="string"><input name="value" type="string" value="x" /></constant>
  <output name="o" type="string" nodename="s" />"#,
            "output `o` is a string",
        ),
        (
            r#"<nodegraph name="ng">
    <input name="p" type="string" value="tex" />
    <geompropvalueuniform name="g" type="filename"><input name="geomprop" type="string" interfacename="p" /></geompropvalueuniform>
    <image name="i" type="color3"><input name="file" type="filename" nodename="g" /></image>
    <output name="out" type="color3" nodename="i" />
  </nodegraph>"#,
            "must be a literal name",
        ),
    ];
    for (body, want) in cases {
        let Some(r) = compile_with(body, &[]) else {
            return;
        };
        let e = r.err().unwrap_or_else(|| panic!("compiled:\n{body}"));
        assert!(e.contains(want), "want `{want}` in: {e}");
        assert!(e.contains("t.mtlx"), "no file in: {e}");
    }
}

/// A 1×1 PNG of colour `rgb` at `path`.
fn png(path: &std::path::Path, rgb: [u8; 3]) {
    image::save_buffer(path, &rgb, 1, 1, image::ExtendedColorType::Rgb8).unwrap();
}

/// Three quads side by side share one material whose image is the instance's `tex`
/// property: the left one and a fourth (behind the camera, same value) share one compile,
/// the middle one has its own, the right one gives none (the default file).
#[test]
fn instances_specialize_a_material_per_distinct_property() {
    use shadenet::render::{self as r, BackendKind, RenderOptions};
    if mtlx_library().is_none() {
        return;
    }
    let at = |name: &str| tmp("geomprops", name);
    png(&at("red.png"), [255, 0, 0]);
    png(&at("green.png"), [0, 255, 0]);
    png(&at("fallback.png"), [0, 0, 255]);
    std::fs::write(at("m.mtlx"), doc(PER_OBJECT_IMAGE)).unwrap();
    let scene = r#"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
fov = 20
resolution = [30, 10]

[render]
spp = 1

[materials.m]
mtlx = "m.mtlx"

[meshes.q]
type = "quad"

[[instances]]
mesh = "q"
material = "m"
translate = [-2.2, 0, 0]
geomprops = { tex = "red.png", unread = "1" }

[[instances]]
mesh = "q"
material = "m"
geomprops = { tex = "green.png" }

[[instances]]
mesh = "q"
material = "m"
translate = [2.2, 0, 0]

[[instances]]
mesh = "q"
material = "m"
translate = [0, 0, 10]
geomprops = { tex = "red.png" }
"#;
    let path = at("s.toml");
    std::fs::write(&path, scene).unwrap();
    let opts = RenderOptions::default();
    for kind in [BackendKind::Interp, BackendKind::Jit] {
        let backend = r::backend(kind).unwrap();
        let renderer = r::setup_with(Some(&path), &opts, backend.as_ref())
            .unwrap_or_else(|e| panic!("{}", error_chain(&e)));
        let names: Vec<&str> = renderer
            .scene()
            .materials
            .iter()
            .map(|m| m.name.as_str())
            .collect();
        assert_eq!(names, ["m{tex=red.png}", "m{tex=green.png}", "m{}"]);
        let bound: Vec<usize> = renderer
            .scene()
            .instances
            .iter()
            .map(|i| i.material)
            .collect();
        assert_eq!(bound, [0, 1, 2, 0]);
        let film = renderer.render(&|_, _| {}).0;
        let beauty = &film.layers[0];
        let nc = beauty.channels.len();
        let px = |x: usize| {
            let i = (5 * 30 + x) * nc;
            [beauty.data[i], beauty.data[i + 1], beauty.data[i + 2]]
        };
        for (x, want) in [
            (4, [1.0, 0.0, 0.0]),
            (15, [0.0, 1.0, 0.0]),
            (26, [0.0, 0.0, 1.0]),
        ] {
            assert_eq!(px(x), want, "pixel {x} of the middle row ({kind:?})");
        }
    }
}

/// `compile --geomprop NAME=VALUE` gives the shaded geometry's properties; a value without
/// `=` is a usage error.
#[test]
fn the_cli_takes_geomprops() {
    if mtlx_library().is_none() {
        return;
    }
    let file = tmp("geomprops-cli", "g.mtlx");
    std::fs::write(&file, doc(PER_OBJECT_IMAGE)).unwrap();
    let f = file.to_str().unwrap();
    let (code, out, err) = shadenet(&["compile", f, "--geomprop", "tex=brick.png"]);
    assert_eq!(code, 0, "{err}");
    let want = format!("texture \"{}\"", file.with_file_name("brick.png").display());
    assert!(out.contains(&want), "want {want} in:\n{out}");
    let (code, out, _) = shadenet(&["compile", f]);
    assert_eq!(code, 0);
    assert!(out.contains("fallback.png\""), "{out}");
    let (code, _, err) = shadenet(&["compile", f, "--geomprop", "tex"]);
    assert_eq!(code, 2);
    assert!(err.contains("expected NAME=VALUE"), "{err}");
}
