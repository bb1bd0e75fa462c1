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

/// The noise nodes are OSL's noise and MaterialX's `mx_noise` library
/// (`graph::ops::osl_noise`): amplitude, pivot, the vector2 outputs' `.xy` and the fractal's
/// second sample at `p + (19, 193[, 17])` as the genglsl/genosl implementations write them.
#[test]
fn noise_nodes_are_osl_and_materialx_noise() {
    use shadenet::graph::ops::osl_noise as o;
    let uv = [0.37, 1.81];
    let node = |body: &str, ty: &str| {
        let body = format!("{body}\n<output name=\"out\" type=\"{ty}\" nodename=\"n\"/>");
        eval(&body, uv)
    };
    // The fragment's uv is f32.
    let uv = uv.map(|x| x as f32 as f64);
    let Some(v) = node(
        r#"<noise2d name="n" type="float"><input name="amplitude" type="float" value="2"/>
             <input name="pivot" type="float" value="0.5"/></noise2d>"#,
        "float",
    ) else {
        return;
    };
    assert_close(&v, &[o::perlin2(uv) * 2.0 + 0.5], 1e-12, "noise2d float");
    let v = node(
        r#"<noise2d name="n" type="vector3"><input name="amplitude" type="vector3" value="1, 2, 3"/>
             <input name="pivot" type="float" value="0.25"/></noise2d>"#,
        "vector3",
    )
    .unwrap();
    let n = o::vperlin2(uv);
    let want = [n[0] + 0.25, n[1] * 2.0 + 0.25, n[2] * 3.0 + 0.25];
    assert_close(&v, &want, 1e-12, "noise2d vector3 (OSL vector snoise)");
    let v = node(r#"<noise2d name="n" type="vector2"/>"#, "vector2").unwrap();
    assert_close(&v, &[n[0], n[1]], 1e-12, "noise2d vector2 is value.xy");
    let v = node(
        r#"<fractal2d name="n" type="vector2"><input name="octaves" type="integer" value="4"/></fractal2d>"#,
        "vector2",
    )
    .unwrap();
    let q = [uv[0] + 19.0, uv[1] + 193.0];
    let want = [o::fractal2(uv, 4, 2.0, 0.5), o::fractal2(q, 4, 2.0, 0.5)];
    assert_close(&v, &want, 1e-12, "fractal2d vector2");
    let v = node(r#"<cellnoise2d name="n" type="float"/>"#, "float").unwrap();
    assert_close(&v, &[o::cell2(uv)], 1e-12, "cellnoise2d");
    let v = node(
        r#"<worleynoise2d name="n" type="vector3"><input name="jitter" type="float" value="0.8"/></worleynoise2d>"#,
        "vector3",
    )
    .unwrap();
    assert_close(
        &v,
        &o::worley2_v3(uv, 0.8, 0, 0),
        1e-12,
        "worleynoise2d F1 F2 F3",
    );
    let v = node(
        r#"<worleynoise2d name="n" type="float"><input name="style" type="integer" value="1"/></worleynoise2d>"#,
        "float",
    )
    .unwrap();
    assert_close(
        &v,
        &[o::worley2(uv, 1.0, 1, 0)],
        1e-12,
        "worleynoise2d solid",
    );
    let p = [0.3, 0.7, 1.9];
    let pos = r#"<input name="position" type="vector3" value="0.3, 0.7, 1.9"/>"#;
    let v = node(
        &format!(r#"<noise3d name="n" type="float">{pos}</noise3d>"#),
        "float",
    )
    .unwrap();
    assert_close(&v, &[o::perlin3(p)], 1e-12, "noise3d float");
    let v = node(
        &format!(r#"<fractal3d name="n" type="vector3">{pos}</fractal3d>"#),
        "vector3",
    )
    .unwrap();
    assert_close(
        &v,
        &o::vfractal3(p, 3, 2.0, 0.5),
        1e-12,
        "fractal3d vector3",
    );
    let v = node(
        &format!(r#"<worleynoise3d name="n" type="vector2">{pos}</worleynoise3d>"#),
        "vector2",
    )
    .unwrap();
    assert_close(
        &v,
        &o::worley3_v2(p, 1.0, 0, 0),
        1e-12,
        "worleynoise3d F1 F2",
    );
    let v = node(
        &format!(r#"<cellnoise3d name="n" type="float">{pos}</cellnoise3d>"#),
        "float",
    )
    .unwrap();
    assert_close(&v, &[o::cell3(p)], 1e-12, "cellnoise3d");
}
