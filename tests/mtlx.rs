//! MaterialX front end end to end: documents compile against the installed libraries,
//! atoms match their specification formulas on the interpreter (f32 and f64), and bad
//! documents give errors naming the place. Tests needing the libraries fail when `CI` is set
//! and they are missing (`.ci/run` installs them), and skip with a printed reason otherwise.

mod common;
use common::*;
use shadenet::graph::error_chain;
use shadenet::graph::mtlx::{self, Library, Selection};

fn lib() -> Option<&'static Library> {
    match shadenet::mtlx::locate(None).and_then(|d| shadenet::mtlx::library(&d)) {
        Ok(l) => Some(l),
        Err(e) if std::env::var_os("CI").is_some() => {
            panic!("CI needs the MaterialX libraries: {}", error_chain(&e))
        }
        Err(e) => {
            eprintln!("skipped: {}", error_chain(&e));
            None
        }
    }
}

fn doc(body: &str) -> String {
    format!("<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n{body}\n</materialx>\n")
}

/// Compiles a document; `None` when the libraries are absent (and not in CI).
fn compile(src: &str) -> Option<Result<shadenet::Compiled, String>> {
    let lib = lib()?;
    Some(mtlx::compile("t.mtlx", src, lib, &Selection::default()).map_err(|e| error_chain(&e)))
}

/// Output `out` of a one-output document at uv, f64 interpreter (f32 checked close).
fn eval(body: &str, uv: [f64; 2]) -> Option<Vec<f64>> {
    let c = compile(&doc(body))?.unwrap_or_else(|e| panic!("{e}"));
    let mut frag = plane_fragment();
    frag.uv = uv.map(|x| x as f32);
    let o = run_program(&c.program, &frag, &[], u32::MAX);
    let (v64, v32) = (o.get("out"), o.get32("out"));
    assert_close(&v32, &v64, 1e-5, "f32 vs f64");
    Some(v64)
}

fn err(body: &str) -> Option<String> {
    Some(compile(&doc(body))?.expect_err("the document should not compile"))
}

#[test]
fn atoms_match_their_formulas() {
    let Some(v) = eval(
        r#"<add name="a" type="color3"><input name="in1" type="color3" value="0.1, 0.2, 0.3"/>
             <input name="in2" type="float" value="1"/></add>
           <output name="out" type="color3" nodename="a"/>"#,
        [0.5, 0.5],
    ) else {
        return;
    };
    assert_close(
        &v,
        &[1.1, 1.2, 1.3],
        1e-12,
        "ND_add_color3FA broadcasts in2",
    );
    let v = eval(
        r#"<modulo name="m" type="float"><input name="in1" type="float" value="-1.25"/>
             <input name="in2" type="float" value="1"/></modulo>
           <output name="out" type="float" nodename="m"/>"#,
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(&v, &[0.75], 1e-12, "modulo is in1 - in2*floor(in1/in2)");
    let v = eval(
        r#"<rotate2d name="r" type="vector2"><input name="in" type="vector2" value="1, 0"/>
             <input name="amount" type="float" value="90"/></rotate2d>
           <output name="out" type="vector2" nodename="r"/>"#,
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(&v, &[0.0, -1.0], 1e-9, "rotate2d (mx_rotate_vector2)");
    let v = eval(
        r#"<texcoord name="uv" type="vector2"/>
           <ifgreater name="g" type="float"><input name="value1" type="float" nodename="uv" channels="x"/>
             <input name="value2" type="float" value="0.5"/>
             <input name="in1" type="float" value="7"/><input name="in2" type="float" value="3"/></ifgreater>
           <output name="out" type="float" nodename="g"/>"#,
        [0.75, 0.1],
    )
    .unwrap();
    assert_close(&v, &[7.0], 0.0, "ifgreater with a 1.38 channel swizzle");
    let v = eval(
        r#"<ramplr name="r" type="float"><input name="valuel" type="float" value="2"/>
             <input name="valuer" type="float" value="4"/></ramplr>
           <output name="out" type="float" nodename="r"/>"#,
        [0.25, 0.9],
    )
    .unwrap();
    assert_close(&v, &[2.5], 1e-12, "ramplr reads the uv stream by default");
    let v = eval(
        r#"<texcoord name="uv" type="vector2"/>
           <combine3 name="c" type="color3"><input name="in1" type="float" nodename="uv" channels="y"/>
             <input name="in2" type="float" value="0"/><input name="in3" type="float" nodename="uv" channels="x"/></combine3>
           <output name="out" type="color3" nodename="c"/>"#,
        [0.25, 0.75],
    )
    .unwrap();
    assert_close(&v, &[0.75, 0.0, 0.25], 0.0, "combine3 of swizzled channels");
}

/// remap and smoothstep (MaterialX 1.39 "adjustment" atoms) against their formulas, on the
/// edges as well: remap is unclamped, smoothstep tests `in >= high` before `in <= low`.
#[test]
fn remap_and_smoothstep_match_the_specification() {
    let remap = |x: f64| {
        eval(
            &format!(
                r#"<remap name="r" type="float"><input name="in" type="float" value="{x}"/>
             <input name="inlow" type="float" value="0.2"/><input name="inhigh" type="float" value="0.6"/>
             <input name="outlow" type="float" value="-1"/><input name="outhigh" type="float" value="3"/></remap>
           <output name="out" type="float" nodename="r"/>"#
            ),
            [0.5, 0.5],
        )
    };
    let Some(v) = remap(0.3) else {
        return;
    };
    assert_close(&v, &[-1.0 + (0.3 - 0.2) * 4.0 / 0.4], 1e-12, "remap inside");
    assert_close(
        &remap(1.0).unwrap(),
        &[-1.0 + 0.8 * 4.0 / 0.4],
        1e-12,
        "remap is unclamped",
    );
    let step = |x: f64, lo: f64, hi: f64| {
        eval(
            &format!(
                r#"<smoothstep name="s" type="float"><input name="in" type="float" value="{x}"/>
             <input name="low" type="float" value="{lo}"/><input name="high" type="float" value="{hi}"/></smoothstep>
           <output name="out" type="float" nodename="s"/>"#
            ),
            [0.5, 0.5],
        )
        .unwrap()[0]
    };
    let t: f64 = (0.35 - 0.2) / 0.4;
    assert!((step(0.35, 0.2, 0.6) - t * t * (3.0 - 2.0 * t)).abs() < 1e-12);
    assert_eq!(step(0.1, 0.2, 0.6), 0.0);
    assert_eq!(step(0.6, 0.2, 0.6), 1.0, "in >= high is 1");
    assert_eq!(
        step(0.5, 0.5, 0.5),
        1.0,
        "low = high: a step, high tested first"
    );
    assert_eq!(step(0.4, 0.5, 0.5), 0.0);
    // The vector variants are library nodegraphs over the float atom.
    let v = eval(
        r#"<smoothstep name="s" type="color3"><input name="in" type="color3" value="0.1, 0.4, 0.9"/>
             <input name="low" type="color3" value="0.2, 0.2, 0.2"/><input name="high" type="color3" value="0.6, 0.6, 0.6"/></smoothstep>
           <output name="out" type="color3" nodename="s"/>"#,
        [0.5, 0.5],
    )
    .unwrap();
    let t: f64 = 0.5;
    assert_close(
        &v,
        &[0.0, t * t * (3.0 - 2.0 * t), 1.0],
        1e-12,
        "ND_smoothstep_color3",
    );
}

/// A scene takes a MaterialX document as a material (`mtlx = …`), shows its colour output
/// as the beauty, and `set` reaches a nodegraph's interface input (`graph.input`) and a node
/// inside it (`graph/node.input`); bad keys are errors naming them.
#[test]
fn scenes_take_mtlx_materials_with_overrides() {
    if lib().is_none() {
        return;
    }
    let dir = tmp("mtlx-scene", "");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("flat.mtlx"),
        doc(r#"<nodegraph name="g">
             <input name="gain" type="float" value="1.0"/>
             <constant name="c" type="color3"><input name="value" type="color3" value="0.25, 0.5, 0.75"/></constant>
             <multiply name="m" type="color3"><input name="in1" type="color3" nodename="c"/>
               <input name="in2" type="float" interfacename="gain"/></multiply>
             <output name="out" type="color3" nodename="m"/>
           </nodegraph>"#),
    )
    .unwrap();
    let scene = |material: &str| {
        let p = dir.join("s.toml");
        std::fs::write(
            &p,
            format!(
                "[camera]\nposition = [0, 0, 2]\nlook_at = [0, 0, 0]\nfov = 20\nresolution = [4, 4]\n\
                 [render]\nspp = 1\n[materials.m]\n{material}\n[meshes.q]\ntype = \"quad\"\n\
                 [[instances]]\nmesh = \"q\"\nmaterial = \"m\"\n"
            ),
        )
        .unwrap();
        let opts = shadenet::render::RenderOptions::default();
        shadenet::render::setup(Some(&p), &opts).map(|r| {
            let (film, _) = r.render(&|_, _| {});
            let b = film.layer("beauty").unwrap();
            (0..3).map(|c| b.at(5, c)).collect::<Vec<f32>>()
        })
    };
    let beauty = scene("mtlx = \"flat.mtlx\"").unwrap();
    assert_eq!(beauty, [0.25, 0.5, 0.75], "the colour output is the beauty");
    let beauty = scene("mtlx = \"flat.mtlx\"\nset = { \"g.gain\" = 2.0 }").unwrap();
    assert_eq!(beauty, [0.5, 1.0, 1.5], "an interface input");
    let beauty = scene("mtlx = \"flat.mtlx\"\nset = { \"g/c.value\" = [1.0, 0.0, 0.5] }").unwrap();
    assert_eq!(beauty, [1.0, 0.0, 0.5], "a node inside the nodegraph");
    let e = |m: &str| error_chain(&scene(m).expect_err("should fail"));
    let text = e("mtlx = \"flat.mtlx\"\nset = { \"g/nope.value\" = 1.0 }");
    assert!(
        text.contains("the nodegraph `g` has no node `nope` (its nodes: c, m)"),
        "{text}"
    );
    let text = e("network = \"a.json\"\nmaterial = \"M\"");
    assert!(
        text.contains("materials.m.material") && text.contains("only a MaterialX material"),
        "{text}"
    );
    let text = e("mtlx = \"flat.mtlx\"\noutput = \"nope\"");
    assert!(
        text.contains("flat.mtlx") && text.contains("nope"),
        "{text}"
    );
    let text = e("mtlx = \"missing.mtlx\"");
    assert!(text.contains("missing.mtlx"), "{text}");
}

#[test]
fn library_nodegraphs_expand_as_compounds() {
    // place2d is implemented by a nodegraph in stdlib_ng: (uv - pivot)/scale, rotated, offset.
    let Some(v) = eval(
        r#"<texcoord name="uv" type="vector2"/>
           <place2d name="p" type="vector2"><input name="texcoord" type="vector2" nodename="uv"/>
             <input name="scale" type="vector2" value="0.5, 0.25"/></place2d>
           <output name="out" type="vector2" nodename="p"/>"#,
        [0.25, 0.5],
    ) else {
        return;
    };
    assert_close(&v, &[0.5, 2.0], 1e-9, "place2d via its nodegraph");
    let v = eval(
        r#"<nodegraph name="g"><input name="k" type="float" value="3"/>
             <multiply name="m" type="float"><input name="in1" type="float" interfacename="k"/>
               <input name="in2" type="float" value="2"/></multiply>
             <output name="o" type="float" nodename="m"/></nodegraph>
           <add name="a" type="float"><input name="in1" type="float" nodegraph="g" output="o"/></add>
           <output name="out" type="float" nodename="a"/>"#,
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(&v, &[6.0], 0.0, "document nodegraph with interfacename");
}

#[test]
fn errors_name_the_place() {
    let Some(e) =
        err(r#"<addd name="x" type="float"/><output name="out" type="float" nodename="x"/>"#)
    else {
        return;
    };
    assert!(
        e.starts_with("t.mtlx:3:1: node `x`: unknown node `addd`"),
        "{e}"
    );
    assert!(e.contains("closest: `add` (ND_add_float"), "{e}");
    let e = err(r#"<texcoord name="uv" type="vector2"/>
        <sin name="s" type="float"><input name="in" type="float" nodename="uv"/></sin>
        <output name="out" type="float" nodename="s"/>"#)
    .unwrap();
    assert!(
        e.contains(
            "node `s` input `in`: type mismatch: the input is float, but `uv.out` gives vector2"
        ),
        "{e}"
    );
    let e = err(r#"<nodegraph name="g"><sin name="s" type="float"><input name="in" type="float" interfacename="nope"/></sin>
        <output name="o" type="float" nodename="s"/></nodegraph>"#)
    .unwrap();
    assert!(
        e.contains("interfacename `nope` names no input of nodegraph `g`"),
        "{e}"
    );
    let e = err(
        r#"<add name="a" type="float"><input name="in1" type="string" value="x"/></add>
        <output name="out" type="float" nodename="a"/>"#,
    )
    .unwrap();
    assert!(
        e.contains("no nodedef of `add` matches") && e.contains("in1: string"),
        "{e}"
    );
    let e = err(r#"<standard_surface name="ss" type="surfaceshader"/>
        <surfacematerial name="M" type="material"><input name="surfaceshader" type="surfaceshader" nodename="ss"/></surfacematerial>"#)
    .unwrap();
    assert!(
        e.contains("node `ss` is of type surfaceshader") && e.contains("issue 15"),
        "{e}"
    );
}

#[test]
fn nodegraph_cycles_name_the_path() {
    let Some(e) = err(
        r#"<nodedef name="ND_a" node="a"><input name="in" type="float" value="0"/><output name="out" type="float"/></nodedef>
        <nodedef name="ND_b" node="b"><input name="in" type="float" value="0"/><output name="out" type="float"/></nodedef>
        <nodegraph name="NG_a" nodedef="ND_a"><b name="x" type="float"/><output name="out" type="float" nodename="x"/></nodegraph>
        <nodegraph name="NG_b" nodedef="ND_b"><a name="y" type="float"/><output name="out" type="float" nodename="y"/></nodegraph>
        <a name="top" type="float"/><output name="out" type="float" nodename="top"/>"#,
    ) else {
        return;
    };
    assert!(
        e.contains("cycle through nodegraphs: NG_a → NG_b → NG_a"),
        "{e}"
    );
}

#[test]
fn missing_libraries_say_where_and_how() {
    let e = shadenet::mtlx::locate_with(Some(std::path::Path::new("/nonexistent/mtlx")), &|_| None);
    let text = error_chain(&e.expect_err("no libraries there"));
    assert!(
        text.contains("/nonexistent/mtlx (--mtlx-libraries)"),
        "{text}"
    );
    assert!(text.contains("pip install materialx"), "{text}");
}

#[test]
fn examples_compile_and_the_cli_shades_them() {
    if lib().is_none() {
        return;
    }
    for entry in std::fs::read_dir("examples/materials").unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "mtlx") {
            let out = tmp(
                "mtlx",
                &format!("{}.png", p.file_stem().unwrap().to_string_lossy()),
            );
            let (code, _, err) = shadenet(&[
                "shade",
                p.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--res",
                "32x32",
            ]);
            assert_eq!(code, 0, "{}: {err}", p.display());
        }
    }
}
