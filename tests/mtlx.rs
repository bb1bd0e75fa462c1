//! MaterialX front end end to end: documents compile against the installed libraries,
//! atoms match their specification formulas on the interpreter (f32 and f64), and bad
//! documents give errors naming the place. Tests needing the libraries fail when `CI` is set
//! and they are missing (`.ci/run` installs them), and skip with a printed reason otherwise.

mod common;
use common::*;
use shadenet::graph::error_chain;
use shadenet::graph::mtlx::{self, Library, Selection};

fn lib() -> Option<&'static Library> {
    mtlx_library()
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
    let e = err(r#"<volume name="v" type="volumeshader"/>
        <volumematerial name="M" type="material"><input name="volumeshader" type="volumeshader" nodename="v"/></volumematerial>"#)
    .unwrap();
    assert!(
        e.contains("node `M`: ND_volumematerial is not supported: no volumes yet"),
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

#[test]
fn four_component_atoms_match_their_formulas() {
    // premult: (rgb·a, a).
    let Some(v) = eval(
        r#"<premult name="p" type="color4"><input name="in" type="color4" value="0.5, 0.25, 1, 0.5"/></premult>
           <output name="out" type="color4" nodename="p"/>"#,
        [0.5, 0.5],
    ) else {
        return;
    };
    assert_close(&v, &[0.25, 0.125, 0.5, 0.5], 0.0, "premult");
    // over: fg + bg·(1 − fg.a), mix 1.
    let v = eval(
        r#"<over name="o" type="color4"><input name="fg" type="color4" value="0.5, 0.5, 0.5, 0.5"/>
             <input name="bg" type="color4" value="1, 0, 0.25, 1"/></over>
           <output name="out" type="color4" nodename="o"/>"#,
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(&v, &[1.0, 0.5, 0.625, 1.0], 0.0, "over");
    // unpremult of a zero alpha: the total division gives 0.
    let v = eval(
        r#"<unpremult name="u" type="color4"><input name="in" type="color4" value="0.5, 0.25, 1, 0"/></unpremult>
           <output name="out" type="color4" nodename="u"/>"#,
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(&v, &[0.0, 0.0, 0.0, 0.0], 0.0, "unpremult at alpha 0");
    // combine4 of varying channels (a 1.38 swizzle), scaled by a float, then a dot product.
    let v = eval(
        r#"<texcoord name="uv" type="vector2"/>
           <combine4 name="c" type="vector4"><input name="in1" type="float" nodename="uv" channels="x"/>
             <input name="in2" type="float" nodename="uv" channels="y"/>
             <input name="in3" type="float" value="2"/><input name="in4" type="float" value="-1"/></combine4>
           <multiply name="m" type="vector4"><input name="in1" type="vector4" nodename="c"/>
             <input name="in2" type="float" value="2"/></multiply>
           <output name="out" type="vector4" nodename="m"/>"#,
        [0.5, 0.25],
    )
    .unwrap();
    assert_close(&v, &[1.0, 0.5, 4.0, -2.0], 0.0, "combine4 × float");
    let v = eval(
        r#"<texcoord name="uv" type="vector2"/>
           <combine4 name="c" type="vector4"><input name="in1" type="float" nodename="uv" channels="x"/>
             <input name="in2" type="float" nodename="uv" channels="y"/>
             <input name="in3" type="float" value="2"/><input name="in4" type="float" value="-1"/></combine4>
           <dotproduct name="d" type="float"><input name="in1" type="vector4" nodename="c"/>
             <input name="in2" type="vector4" value="1, 0, 0, 1"/></dotproduct>
           <extract name="e" type="float"><input name="in" type="vector4" nodename="c"/>
             <input name="index" type="integer" value="3"/></extract>
           <add name="s" type="float"><input name="in1" type="float" nodename="d"/>
             <input name="in2" type="float" nodename="e"/></add>
           <output name="out" type="float" nodename="s"/>"#,
        [0.5, 0.25],
    )
    .unwrap();
    assert_close(&v, &[-1.5], 0.0, "dot(c, (1,0,0,1)) + c[3] = 0.5 - 1 - 1");
    // combine2 of a color3 and a float; luminance keeps alpha; a channel swizzle reads alpha.
    let v = eval(
        r#"<combine2 name="c" type="color4"><input name="in1" type="color3" value="1, 0.5, 0.25"/>
             <input name="in2" type="float" value="0.75"/></combine2>
           <luminance name="l" type="color4"><input name="in" type="color4" nodename="c"/>
             <input name="lumacoeffs" type="color3" value="0.5, 0.25, 1"/></luminance>
           <output name="out" type="color4" nodename="l"/>"#,
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(
        &v,
        &[0.875, 0.875, 0.875, 0.75],
        0.0,
        "luminance of a color4",
    );
    // remap and smoothstep (the atoms the color4 range/colorcorrect graphs use).
    let v = eval(
        r#"<remap name="r" type="vector4"><input name="in" type="vector4" value="0.5, 1, 0, 2"/>
             <input name="inlow" type="float" value="0"/><input name="inhigh" type="float" value="2"/>
             <input name="outlow" type="float" value="1"/><input name="outhigh" type="float" value="3"/></remap>
           <output name="out" type="vector4" nodename="r"/>"#,
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(&v, &[1.5, 2.0, 1.0, 3.0], 0.0, "remap");
    let v = eval(
        r#"<smoothstep name="s" type="float"><input name="in" type="float" value="0.25"/></smoothstep>
           <output name="out" type="float" nodename="s"/>"#,
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(&v, &[0.15625], 0.0, "smoothstep(0, 1, 0.25) = t²(3 − 2t)");
    // A color4 feeding a color3 port is a type error naming both types.
    let e = err(
        r#"<constant name="k" type="color4"><input name="value" type="color4" value="1, 1, 1, 1"/></constant>
           <add name="a" type="color3"><input name="in1" type="color3" nodename="k"/>
             <input name="in2" type="color3" value="0, 0, 0"/></add>
           <output name="out" type="color3" nodename="a"/>"#,
    )
    .unwrap();
    assert!(e.contains("color4") && e.contains("color3"), "{e}");
}

/// A color4 output shades through the CLI: its EXR layer has R, G, B and A channels.
#[test]
fn a_color4_output_writes_rgba_layers() {
    if lib().is_none() {
        return;
    }
    let out = tmp("mtlx", "over.exr");
    let (code, _, err) = shadenet(&[
        "shade",
        "examples/materials/over.mtlx",
        "-o",
        out.to_str().unwrap(),
        "--res",
        "8x8",
    ]);
    assert_eq!(code, 0, "{err}");
    let bytes = std::fs::read(&out).unwrap();
    let text = String::from_utf8_lossy(&bytes);
    for ch in ["out.R", "out.G", "out.B", "out.A"] {
        assert!(text.contains(ch), "EXR lacks channel {ch}");
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
    // Four components (MaterialX mx_noise2d_vector4): the vector noise and the float noise
    // at uv + (19, 73); the fractal's fourth at uv + (19, 193).
    let v = node(
        r#"<noise2d name="n" type="color4"><input name="amplitude" type="vector4" value="1, 1, 1, 2"/>
             <input name="pivot" type="float" value="0.5"/></noise2d>"#,
        "color4",
    )
    .unwrap();
    let w = o::perlin2([uv[0] + 19.0, uv[1] + 73.0]);
    let want = [n[0] + 0.5, n[1] + 0.5, n[2] + 0.5, w * 2.0 + 0.5];
    assert_close(&v, &want, 1e-12, "noise2d color4");
    let v = node(
        r#"<fractal2d name="n" type="vector4"><input name="octaves" type="integer" value="3"/></fractal2d>"#,
        "vector4",
    )
    .unwrap();
    let c = o::vfractal2(uv, 3, 2.0, 0.5);
    let w = o::fractal2([uv[0] + 19.0, uv[1] + 193.0], 3, 2.0, 0.5);
    assert_close(&v, &[c[0], c[1], c[2], w], 1e-12, "fractal2d vector4");
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

/// A matrix node `node` on the MaterialX matrix33 A (determinant 1; its inverse has integer
/// entries) followed by an `extract` of row `row`: `wrap` gives the node's XML with `{A}`.
fn row_of(node_xml: &str, ty: &str, row: i32) -> Vec<f64> {
    let vty = if ty == "matrix33" {
        "vector3"
    } else {
        "vector4"
    };
    let body = format!(
        r#"{node_xml}
           <extract name="e" type="{vty}"><input name="in" type="{ty}" nodename="m"/>
             <input name="index" type="integer" value="{row}"/></extract>
           <output name="out" type="{vty}" nodename="e"/>"#
    );
    eval(&body, [0.5, 0.5]).expect("libraries checked by the caller")
}

const A: &str = "1,2,3, 0,1,4, 5,6,0";

#[test]
fn matrix_atoms_match_their_formulas() {
    // det A = 1·(0−24) − 2·(0−20) + 3·(0−5) = 1.
    let Some(v) = eval(
        &format!(
            r#"<determinant name="d" type="float"><input name="in" type="matrix33" value="{A}"/></determinant>
               <output name="out" type="float" nodename="d"/>"#
        ),
        [0.5, 0.5],
    ) else {
        return;
    };
    assert_close(&v, &[1.0], 0.0, "determinant");
    let m = |xml: &str| xml.replace("{A}", A);
    // A⁻¹ = ((−24, 18, 5), (20, −15, −4), (−5, 4, 1)), rows as MaterialX writes them.
    let inv = m(
        r#"<invertmatrix name="m" type="matrix33"><input name="in" type="matrix33" value="{A}"/></invertmatrix>"#,
    );
    assert_close(
        &row_of(&inv, "matrix33", 1),
        &[20.0, -15.0, -4.0],
        0.0,
        "inverse row 1",
    );
    // extract: an index past the last row gives the last row (mx_extract_matrix33).
    assert_close(
        &row_of(&inv, "matrix33", 7),
        &[-5.0, 4.0, 1.0],
        0.0,
        "row 7 → last",
    );
    // multiply is A·B: B swaps columns 0 and 1 (B·A would swap rows).
    let mul = m(
        r#"<multiply name="m" type="matrix33"><input name="in1" type="matrix33" value="{A}"/>
             <input name="in2" type="matrix33" value="0,1,0, 1,0,0, 0,0,1"/></multiply>"#,
    );
    assert_close(
        &row_of(&mul, "matrix33", 0),
        &[2.0, 1.0, 3.0],
        0.0,
        "A·B row 0",
    );
    // divide is A·B⁻¹: A / A = identity.
    let div = m(
        r#"<divide name="m" type="matrix33"><input name="in1" type="matrix33" value="{A}"/>
             <input name="in2" type="matrix33" value="{A}"/></divide>"#,
    );
    assert_close(
        &row_of(&div, "matrix33", 2),
        &[0.0, 0.0, 1.0],
        0.0,
        "A / A row 2",
    );
    let tr = m(
        r#"<transpose name="m" type="matrix33"><input name="in" type="matrix33" value="{A}"/></transpose>"#,
    );
    assert_close(
        &row_of(&tr, "matrix33", 0),
        &[1.0, 0.0, 5.0],
        0.0,
        "transpose row 0",
    );
    let add = m(
        r#"<add name="m" type="matrix33"><input name="in1" type="matrix33" value="{A}"/>
             <input name="in2" type="float" value="1"/></add>"#,
    );
    assert_close(
        &row_of(&add, "matrix33", 0),
        &[2.0, 3.0, 4.0],
        0.0,
        "A + 1 row 0",
    );
    let sub = m(
        r#"<subtract name="m" type="matrix33"><input name="in1" type="matrix33" value="{A}"/>
             <input name="in2" type="matrix33" value="{A}"/></subtract>"#,
    );
    assert_close(&row_of(&sub, "matrix33", 1), &[0.0; 3], 0.0, "A − A row 1");
    // A singular matrix inverts to the zero matrix (adj/det with the total division).
    let sing = r#"<invertmatrix name="m" type="matrix33"><input name="in" type="matrix33" value="1,2,3, 2,4,6, 0,0,1"/></invertmatrix>"#;
    assert_close(
        &row_of(sing, "matrix33", 0),
        &[0.0; 3],
        0.0,
        "singular inverse",
    );
    // transformmatrix is v·M (MaterialX row vectors): (1,1,1)·A = the sum of A's rows.
    let v = eval(
        &m(r#"<transformmatrix name="t" type="vector3"><input name="in" type="vector3" value="1,1,1"/>
             <input name="mat" type="matrix33" value="{A}"/></transformmatrix>
           <output name="out" type="vector3" nodename="t"/>"#),
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(&v, &[6.0, 9.0, 7.0], 0.0, "vector3 · A");
    // vector2 by a matrix33: the point (x, y, 1), translation in the last row.
    let v = eval(
        r#"<transformmatrix name="t" type="vector2"><input name="in" type="vector2" value="1,2"/>
             <input name="mat" type="matrix33" value="1,0,0, 0,1,0, 5,6,1"/></transformmatrix>
           <output name="out" type="vector2" nodename="t"/>"#,
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(&v, &[6.0, 8.0], 0.0, "vector2 · M3 (a point)");
}

#[test]
fn matrix44_atoms_match_their_formulas() {
    // creatematrix from vector3 rows: w = 0, and 1 for the fourth (the translation) row.
    let create = r#"<creatematrix name="m" type="matrix44" nodedef="ND_creatematrix_vector3_matrix44">
             <input name="in1" type="vector3" value="2,0,0"/><input name="in2" type="vector3" value="0,3,0"/>
             <input name="in3" type="vector3" value="0,0,4"/><input name="in4" type="vector3" value="10,20,30"/></creatematrix>"#;
    let Some(v) = eval(
        &format!(
            r#"{create}
               <transformmatrix name="t" type="vector3"><input name="in" type="vector3" value="1,1,1"/>
                 <input name="mat" type="matrix44" nodename="m"/></transformmatrix>
               <output name="out" type="vector3" nodename="t"/>"#
        ),
        [0.5, 0.5],
    ) else {
        return;
    };
    assert_close(&v, &[12.0, 23.0, 34.0], 0.0, "point (1,1,1) · M");
    assert_close(
        &row_of(create, "matrix44", 3),
        &[10.0, 20.0, 30.0, 1.0],
        0.0,
        "row 3",
    );
    let v = eval(
        &format!(
            r#"{create}
               <determinant name="d" type="float"><input name="in" type="matrix44" nodename="m"/></determinant>
               <output name="out" type="float" nodename="d"/>"#
        ),
        [0.5, 0.5],
    )
    .unwrap();
    assert_close(&v, &[24.0], 0.0, "determinant");
    // vector4 · M: (0, 0, 0, 1) picks the last row; the inverse undoes the translation.
    let v = eval(
        &format!(
            r#"{create}
               <invertmatrix name="i" type="matrix44"><input name="in" type="matrix44" nodename="m"/></invertmatrix>
               <transformmatrix name="t" type="vector4"><input name="in" type="vector4" value="10,20,30,1"/>
                 <input name="mat" type="matrix44" nodename="i"/></transformmatrix>
               <output name="out" type="vector4" nodename="t"/>"#
        ),
        [0.5, 0.5],
    )
    .unwrap();
    // (thirds and quarters: exact up to rounding)
    assert_close(&v, &[0.0, 0.0, 0.0, 1.0], 1e-6, "(10,20,30,1) · M⁻¹");
    // A matrix output is our layout: row-major of the transpose (MaterialX columns).
    let v = eval(
        &format!("{create}\n<output name=\"out\" type=\"matrix44\" nodename=\"m\"/>"),
        [0.5, 0.5],
    )
    .unwrap();
    let want = [
        2.0, 0.0, 0.0, 10.0, 0.0, 3.0, 0.0, 20.0, 0.0, 0.0, 4.0, 30.0, 0.0, 0.0, 0.0, 1.0,
    ];
    assert_close(&v, &want, 0.0, "matrix44 output");
}

/// The stdlib coverage the README and docs/materialx.md report, exactly: a change that
/// loses a nodedef (as the image node's `filtertype` once lost `tiledimage` and
/// `triplanarprojection`, whose graphs pass it through `interfacename`) fails here, and one
/// that gains nodedefs updates the documents with the figure.
#[test]
fn stdlib_coverage_is_the_documented_figure() {
    use shadenet::graph::mtlx::coverage::{self, Status};
    let Some(lib) = lib() else {
        return;
    };
    let rows = coverage::check(lib, "stdlib");
    let count = |f: &dyn Fn(&Status) -> bool| rows.iter().filter(|r| f(&r.status)).count();
    let native = count(&|s| *s == Status::Native);
    let graph = count(&|s| *s == Status::ViaNodegraph);
    let folded = count(&|s| *s == Status::Folded);
    assert_eq!((rows.len(), native, graph, folded), (693, 482, 198, 6));
    let geometric: Vec<&coverage::Row> = rows.iter().filter(|r| r.group == "geometric").collect();
    assert_eq!(geometric.len(), 20);
    for r in geometric {
        assert!(
            !matches!(r.status, Status::Unsupported(_)),
            "{}: {:?}",
            r.nodedef,
            r.status
        );
    }
    for nd in [
        "ND_tiledimage_color3",
        "ND_triplanarprojection_vector4",
        "ND_surface_unlit",
        "ND_convert_color4_surfaceshader",
    ] {
        let row = rows.iter().find(|r| r.nodedef == nd).unwrap();
        assert!(
            !matches!(row.status, Status::Unsupported(_)),
            "{nd}: {:?}",
            row.status
        );
    }
}

/// `examples/scenes/vertex_colors.toml`: its OBJ plane is the generator's output
/// (`shadenet gen vertex-colors`; `SHADENET_BLESS=1` rewrites it), and the scene renders
/// with the interpreter and the JIT to the same bits: the plane's colours interpolated
/// across its triangles (many distinct colours), the colourless sphere at `geomcolor`'s
/// default, exactly black.
#[test]
fn vertex_colour_example_renders() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/scenes/meshes/vertex_colors.obj");
    let text = shadenet::generate::vertex_color_obj();
    if std::env::var("SHADENET_BLESS").is_ok_and(|v| v == "1") {
        std::fs::write(&path, &text).unwrap();
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == text,
        "{} differs from `shadenet gen vertex-colors` (SHADENET_BLESS=1 to rewrite)",
        path.display()
    );
    if lib().is_none() {
        return;
    }
    let [interp, jit] = render_interp_and_jit("vertex_colors.toml", 1, (64, 32));
    assert_eq!(beauty_bits(&interp), beauty_bits(&jit), "interpreter ≡ JIT");
    let beauty = &interp.layers[0];
    let pixels: Vec<[u32; 3]> = beauty
        .data
        .chunks(beauty.channels.len())
        .map(|c| [c[0].to_bits(), c[1].to_bits(), c[2].to_bits()])
        .collect();
    let black = pixels.iter().filter(|p| **p == [0; 3]).count();
    assert!(
        black > 50,
        "{black} black pixels: the sphere has no colours"
    );
    let distinct: std::collections::HashSet<_> = pixels.iter().collect();
    assert!(distinct.len() > 200, "{} distinct colours", distinct.len());
}

/// `geompropvalue` of every variant and `geomcolor` compile to attribute reads with their
/// defaults (no geometry here: the defaults come out; the integer and boolean variants go
/// through float and back); an empty `geomprop` reads nothing; `geomcolor`'s index (a
/// parameter here) selects among the colour sets `COLOR_0` to `COLOR_7`.
#[test]
fn geometry_property_nodes_read_attributes_with_defaults() {
    let gp = |ty: &str, default: &str| {
        format!(
            r#"<geompropvalue name="g" type="{ty}"><input name="geomprop" type="string" value="_id" /><input name="default" type="{ty}" value="{default}" /></geompropvalue>
               <output name="out" type="{ty}" nodename="g" />"#
        )
    };
    for (ty, default, want) in [
        ("integer", "3", vec![3.0]),
        ("boolean", "true", vec![1.0]),
        ("float", "0.25", vec![0.25]),
        ("vector2", "1, 2", vec![1.0, 2.0]),
        ("color4", "1, 2, 3, 4", vec![1.0, 2.0, 3.0, 4.0]),
    ] {
        let Some(c) = compile(&doc(&gp(ty, default))) else {
            return;
        };
        let c = c.unwrap_or_else(|e| panic!("{ty}: {e}"));
        assert_eq!(c.program.attributes.len(), 1, "{ty}");
        assert_eq!(c.program.attributes[0].name, "_id");
        let Some(v) = eval(&gp(ty, default), [0.5, 0.5]) else {
            return;
        };
        assert_eq!(v, want, "{ty}");
    }
    let empty = gp("float", "0.5").replace("value=\"_id\"", "value=\"\"");
    let c = compile(&doc(&empty)).unwrap().unwrap();
    assert!(
        c.program.attributes.is_empty(),
        "an empty name reads nothing"
    );
    let gc = |index: &str| {
        format!(
            r#"<geomcolor name="g" type="color3"><input name="index" type="integer" value="{index}" /></geomcolor>
               <output name="out" type="color3" nodename="g" />"#
        )
    };
    let c = compile(&doc(&gc("2"))).unwrap().unwrap();
    let mut names: Vec<&str> = c
        .program
        .attributes
        .iter()
        .map(|a| a.name.as_str())
        .collect();
    names.sort();
    assert_eq!(
        names,
        (0..8).map(|i| format!("COLOR_{i}")).collect::<Vec<_>>()
    );
    assert_eq!(eval(&gc("2"), [0.5, 0.5]).unwrap(), [0.0; 3]);
    assert_eq!(eval(&gc("-1"), [0.5, 0.5]).unwrap(), [0.0; 3]);
}
