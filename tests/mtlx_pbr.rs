//! MaterialX closures end to end (issue 15): pbrlib BSDF and EDF nodes become lobe lists,
//! `mix`/`add`/`multiply`/`layer` act on the lists, `surface`/`surfacematerial` carry them to
//! the material output, and the surface lowering lights them: each component's part equals
//! the lobe formulas under a point light, on the interpreter in f32 and f64. The pbrlib value
//! nodes match the MaterialX reference formulas. Tests needing the libraries fail when `CI`
//! is set and they are missing, and skip with a printed reason otherwise.

mod common;
use common::*;
use shadenet::graph::error_chain;
use shadenet::graph::mtlx::{self, Library, Selection};
use shadenet_graph::nodes::{LightDesc, LightKind};
use std::f64::consts::PI;

fn lib() -> Option<&'static Library> {
    mtlx_library()
}

fn doc(body: &str) -> String {
    format!("<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n{body}\n</materialx>\n")
}

fn compile_sel(body: &str, sel: &Selection) -> Option<Result<shadenet::Compiled, String>> {
    let lib = lib()?;
    Some(mtlx::compile("t.mtlx", &doc(body), lib, sel).map_err(|e| error_chain(&e)))
}

/// A point light of intensity `i` (W/sr, white) at `pos`.
fn point(pos: [f64; 3], i: f64) -> LightDesc {
    LightDesc::new("l", LightKind::Point { position: pos }, [i; 3]).unwrap()
}

/// Shades `body`'s first material on the plane fragment (normal +z, viewed from +z) under
/// `lights`; every component on.
fn shade(body: &str, lights: &[LightDesc]) -> Option<Outputs> {
    let c = compile_sel(body, &Selection::default())?.unwrap_or_else(|e| panic!("{e}"));
    Some(run_program(&c.program, &plane_fragment(), lights, u32::MAX))
}

/// A material `M` over surface `body` (nodes named in it; `bsdf`/`edf` give the surface's
/// connections).
fn material(nodes: &str, bsdf: Option<&str>, edf: Option<&str>, opacity: Option<f64>) -> String {
    let mut s = String::from(nodes);
    s.push_str(r#"<surface name="surf" type="surfaceshader">"#);
    if let Some(b) = bsdf {
        s.push_str(&format!(
            r#"<input name="bsdf" type="BSDF" nodename="{b}"/>"#
        ));
    }
    if let Some(e) = edf {
        s.push_str(&format!(r#"<input name="edf" type="EDF" nodename="{e}"/>"#));
    }
    if let Some(o) = opacity {
        s.push_str(&format!(
            r#"<input name="opacity" type="float" value="{o}"/>"#
        ));
    }
    s.push_str(
        r#"</surface><surfacematerial name="M" type="material">
        <input name="surfaceshader" type="surfaceshader" nodename="surf"/></surfacematerial>"#,
    );
    s
}

fn diffuse(name: &str, color: [f64; 3], roughness: f64) -> String {
    format!(
        r#"<oren_nayar_diffuse_bsdf name="{name}" type="BSDF">
        <input name="color" type="color3" value="{}, {}, {}"/>
        <input name="roughness" type="float" value="{roughness}"/></oren_nayar_diffuse_bsdf>"#,
        color[0], color[1], color[2]
    )
}

fn part(o: &Outputs, comp: &str) -> Vec<f64> {
    o.part("M", comp)
        .unwrap_or_else(|| panic!("no part {comp}: {:?}", o.entries))
}

#[test]
fn a_diffuse_material_is_lit_by_the_lambert_formula() {
    // Light straight above at distance 2: E = I / r² = 8 / 4, cos = 1; roughness 0 is Lambert.
    let c = [0.8, 0.4, 0.2];
    let body = material(&diffuse("d", c, 0.0), Some("d"), None, None);
    let Some(o) = shade(&body, &[point([0.0, 0.0, 2.0], 8.0)]) else {
        return;
    };
    let want: Vec<f64> = c.iter().map(|x| x / PI * 2.0).collect();
    assert_close(&part(&o, "diffuse"), &want, 1e-12, "diffuse part (f64)");
    assert_close(&o.get32("M"), &want, 1e-6, "total (f32)");
    assert_eq!(o.nonfinite32, 0);
}

#[test]
fn oren_nayar_roughness_matches_the_formula_off_axis() {
    // Light at 60° from the normal in the x-z plane, viewer along the normal: s = 0, so the
    // qualitative model gives A · color/π · E cos θi.
    let (sigma, th) = (0.5f64, 60f64.to_radians());
    let pos = [2.0 * th.sin(), 0.0, 2.0 * th.cos()];
    let body = material(&diffuse("d", [1.0, 1.0, 1.0], sigma), Some("d"), None, None);
    let Some(o) = shade(&body, &[point(pos, 4.0)]) else {
        return;
    };
    let s2 = sigma * sigma;
    let a = 1.0 - 0.5 * s2 / (s2 + 0.33);
    let want = a / PI * 1.0 * th.cos();
    assert_close(&part(&o, "diffuse"), &[want; 3], 1e-12, "diffuse part");
}

#[test]
fn emission_opacity_and_components() {
    let nodes = format!(
        r#"{}<uniform_edf name="e" type="EDF"><input name="color" type="color3" value="0.5, 1, 2"/></uniform_edf>"#,
        diffuse("d", [0.5, 0.5, 0.5], 0.0)
    );
    let body = material(&nodes, Some("d"), Some("e"), Some(0.25));
    let Some(o) = shade(&body, &[point([0.0, 0.0, 1.0], 1.0)]) else {
        return;
    };
    // Every part is scaled by the opacity; without a scene the pass-through ray is black.
    assert_close(
        &part(&o, "emission"),
        &[0.125, 0.25, 0.5],
        1e-12,
        "emission",
    );
    assert_close(
        &part(&o, "diffuse"),
        &[0.25 * 0.5 / PI; 3],
        1e-12,
        "diffuse",
    );
    assert_close(&part(&o, "transmission"), &[0.0; 3], 0.0, "transmission");
}

#[test]
fn mix_add_multiply_and_layer_weight_the_lobes() {
    let lights = [point([0.0, 0.0, 1.0], 1.0)];
    let two = format!(
        "{}{}",
        diffuse("a", [1.0, 0.0, 0.0], 0.0),
        diffuse("b", [0.0, 1.0, 0.0], 0.0)
    );
    let mix = format!(
        r#"{two}<mix name="m" type="BSDF"><input name="fg" type="BSDF" nodename="a"/>
        <input name="bg" type="BSDF" nodename="b"/><input name="mix" type="float" value="0.25"/></mix>"#
    );
    let Some(o) = shade(&material(&mix, Some("m"), None, None), &lights) else {
        return;
    };
    assert_close(&o.get("M"), &[0.25 / PI, 0.75 / PI, 0.0], 1e-12, "mix");

    let add = format!(
        r#"{two}<add name="s" type="BSDF"><input name="in1" type="BSDF" nodename="a"/>
        <input name="in2" type="BSDF" nodename="b"/></add>
        <multiply name="k" type="BSDF"><input name="in1" type="BSDF" nodename="s"/>
        <input name="in2" type="color3" value="0.5, 0.25, 1"/></multiply>"#
    );
    let o = shade(&material(&add, Some("k"), None, None), &lights).unwrap();
    assert_close(
        &o.get("M"),
        &[0.5 / PI, 0.25 / PI, 0.0],
        1e-12,
        "add, multiply",
    );

    // A white Lambertian top reflects everything: the base gets 1 − 1 = 0.
    let layer = format!(
        r#"{}{}<layer name="l" type="BSDF"><input name="top" type="BSDF" nodename="t"/>
        <input name="base" type="BSDF" nodename="b"/></layer>"#,
        diffuse("t", [1.0, 1.0, 1.0], 0.0),
        diffuse("b", [0.0, 1.0, 0.0], 0.0)
    );
    let o = shade(&material(&layer, Some("l"), None, None), &lights).unwrap();
    assert_close(&o.get("M"), &[1.0 / PI; 3], 1e-12, "layer under white");
    let layer = layer.replace(r#"value="1, 1, 1""#, r#"value="0.25, 0.25, 0.25""#);
    let o = shade(&material(&layer, Some("l"), None, None), &lights).unwrap();
    assert_close(
        &o.get("M"),
        &[0.25 / PI, (0.25 + 0.75) / PI, 0.25 / PI],
        1e-12,
        "layer under a grey top",
    );
}

#[test]
fn a_constant_mix_weight_specializes_the_other_lobe_away() {
    let two = format!(
        "{}{}",
        diffuse("a", [1.0, 0.0, 0.0], 0.3),
        diffuse("b", [0.0, 1.0, 0.0], 0.7)
    );
    let ops = |w: f64| {
        let mix = format!(
            r#"{two}<mix name="m" type="BSDF"><input name="fg" type="BSDF" nodename="a"/>
            <input name="bg" type="BSDF" nodename="b"/><input name="mix" type="float" value="{w}"/></mix>"#
        );
        let c = compile_sel(
            &material(&mix, Some("m"), None, None),
            &Selection::default(),
        )?
        .unwrap_or_else(|e| panic!("{e}"));
        let p = shadenet_graph::opt::run(&c.program, &Default::default()).0;
        Some(p.op_count())
    };
    let single = {
        let body = material(&diffuse("a", [1.0, 0.0, 0.0], 0.3), Some("a"), None, None);
        let Some(c) = compile_sel(&body, &Selection::default()) else {
            return;
        };
        let c = c.unwrap();
        shadenet_graph::opt::run(&c.program, &Default::default())
            .0
            .op_count()
    };
    let (half, one) = (ops(0.5).unwrap(), ops(1.0).unwrap());
    // The second lobe shares the frame (CSE) but not its roughness terms. With weight 0 its
    // evaluations and samples fold away; what stays is a handful of additions of zeros to
    // the lobe-selection sums (`x + 0` and `0 · x` do not fold: −0 and NaN).
    assert!(
        half > one + 20,
        "a real mix keeps both lobes: {half} vs {one}"
    );
    assert!(
        one >= single && one <= single + 12,
        "mix = 1 leaves the one lobe: {one} vs {single} ops"
    );
}

#[test]
fn materials_are_selected_by_name() {
    let body = format!(
        "{}{}",
        material(&diffuse("d", [0.5; 3], 0.0), Some("d"), None, None),
        r#"<surfacematerial name="Other" type="material"><input name="surfaceshader" type="surfaceshader" nodename="surf"/></surfacematerial>"#
    );
    let sel = |m: &str| Selection {
        material: Some(m.into()),
        output: None,
        ..Default::default()
    };
    let Some(c) = compile_sel(&body, &sel("Other")) else {
        return;
    };
    let c = c.unwrap();
    assert!(c.program.outputs.iter().all(|o| o.name == "Other"));
    let e = compile_sel(&body, &sel("Nope")).unwrap().unwrap_err();
    assert!(
        e.contains("no material `Nope` (materials: M, Other)"),
        "{e}"
    );
    let c = compile_sel(&body, &Selection::default()).unwrap().unwrap();
    assert!(
        c.program.outputs.iter().all(|o| o.name == "M"),
        "the first material by default"
    );
}

fn value_node(node: &str, ty: &str, inputs: &str, out: &str) -> Option<Vec<f64>> {
    let body = format!(
        r#"<{node} name="n" type="{ty}">{inputs}</{node}>
        <output name="out" type="{}" nodename="n" output="{out}"/>"#,
        if out == "ior" || out == "extinction" {
            "color3"
        } else {
            ty
        }
    );
    let body = if out == "out" {
        body.replace(r#" output="out""#, "")
    } else {
        body
    };
    let c = compile_sel(&body, &Selection::default())?.unwrap_or_else(|e| panic!("{e}"));
    let o = run_program(&c.program, &plane_fragment(), &[], u32::MAX);
    for (a, b) in o.get32("out").iter().zip(o.get("out")) {
        assert!(
            (a - b).abs() <= 1e-6 * b.abs().max(1.0),
            "f32 {a} vs f64 {b}"
        );
    }
    Some(o.get("out"))
}

#[test]
fn pbr_value_nodes_match_the_reference_formulas() {
    let Some(v) = value_node(
        "roughness_anisotropy",
        "vector2",
        r#"<input name="roughness" type="float" value="0.5"/><input name="anisotropy" type="float" value="0.5"/>"#,
        "out",
    ) else {
        return;
    };
    let (a, k) = (0.25f64, (0.5f64).sqrt());
    assert_close(&v, &[(a / k).min(1.0), a * k], 1e-7, "roughness_anisotropy");
    let v = value_node(
        "roughness_dual",
        "vector2",
        r#"<input name="roughness" type="vector2" value="0.3, -1"/>"#,
        "out",
    )
    .unwrap();
    assert_close(
        &v,
        &[0.09, 0.09],
        1e-7,
        "roughness_dual takes x for a negative y",
    );
    let refl = [0.9f64, 0.5, 0.1];
    let edge = [0.5f64, 1.0, 0.0];
    let inputs = r#"<input name="reflectivity" type="color3" value="0.9, 0.5, 0.1"/>
        <input name="edge_color" type="color3" value="0.5, 1, 0"/>"#;
    let ior = value_node("artistic_ior", "multioutput", inputs, "ior").unwrap();
    let ext = value_node("artistic_ior", "multioutput", inputs, "extinction").unwrap();
    for c in 0..3 {
        let r = refl[c];
        let (lo, hi) = ((1.0 - r) / (1.0 + r), (1.0 + r.sqrt()) / (1.0 - r.sqrt()));
        let n = hi * (1.0 - edge[c]) + lo * edge[c];
        let k = (((n + 1.0).powi(2) * r - (n - 1.0).powi(2)) / (1.0 - r))
            .max(0.0)
            .sqrt();
        assert!(
            (ior[c] - n).abs() < 1e-9 * n.max(1.0),
            "ior[{c}] {} vs {n}",
            ior[c]
        );
        assert!(
            (ext[c] - k).abs() < 1e-9 * k.max(1.0),
            "extinction[{c}] {} vs {k}",
            ext[c]
        );
    }
    // 6500 K is close to D65 white: all channels near 1, none negative.
    let v = value_node(
        "blackbody",
        "color3",
        r#"<input name="temperature" type="float" value="6500"/>"#,
        "out",
    )
    .unwrap();
    assert!(v.iter().all(|x| (x - 1.0).abs() < 0.12), "{v:?}");
    let cold = value_node(
        "blackbody",
        "color3",
        r#"<input name="temperature" type="float" value="1500"/>"#,
        "out",
    )
    .unwrap();
    assert!(
        cold[0] > cold[1] && cold[1] > cold[2] && cold[2] >= 0.0,
        "{cold:?}"
    );
}

/// A conductor over the plane, with `thinfilm_thickness`/`thinfilm_ior` inputs written out
/// when `film` is given (`Err` naming a node connects the thickness to it).
fn filmed_conductor(film: Option<(Result<f64, &str>, f64)>) -> String {
    let film = match film {
        None => String::new(),
        Some((Ok(t), ior)) => format!(
            r#"<input name="thinfilm_thickness" type="float" value="{t}"/>
            <input name="thinfilm_ior" type="float" value="{ior}"/>"#
        ),
        Some((Err(node), ior)) => format!(
            r#"<input name="thinfilm_thickness" type="float" nodename="{node}"/>
            <input name="thinfilm_ior" type="float" value="{ior}"/>"#
        ),
    };
    let nodes = format!(
        r#"<position name="pos" type="vector3"/>
        <dotproduct name="thick" type="float"><input name="in1" type="vector3" nodename="pos"/>
        <input name="in2" type="vector3" value="100, 200, 300"/></dotproduct>
        <conductor_bsdf name="c" type="BSDF">
        <input name="ior" type="color3" value="0.18, 0.42, 1.37"/>
        <input name="extinction" type="color3" value="3.42, 2.35, 1.77"/>
        <input name="roughness" type="vector2" value="0.3, 0.3"/>{film}</conductor_bsdf>"#
    );
    material(&nodes, Some("c"), None, None)
}

/// Thin film through MaterialX (issue 15): a thickness of 0 compiles to the plain lobe (the
/// film folds away entirely), a positive one changes the lit color, and a connected
/// (per-fragment) thickness compiles and agrees with the same constant where it evaluates
/// to it.
#[test]
fn thin_film_through_materialx() {
    let lights = [point([0.0, 0.0, 2.0], 8.0)];
    let ops = |body: &str| -> Option<usize> {
        let c = compile_sel(body, &Selection::default())?.unwrap_or_else(|e| panic!("{e}"));
        Some(
            shadenet_graph::opt::run(&c.program, &Default::default())
                .0
                .op_count(),
        )
    };
    let Some(plain_ops) = ops(&filmed_conductor(None)) else {
        return;
    };
    assert_eq!(
        ops(&filmed_conductor(Some((Ok(0.0), 1.5)))),
        Some(plain_ops)
    );
    let film_ops = ops(&filmed_conductor(Some((Ok(400.0), 1.5)))).unwrap();
    assert!(film_ops > plain_ops + 50, "{film_ops} vs {plain_ops}");
    let plain = shade(&filmed_conductor(None), &lights).unwrap();
    let film = shade(&filmed_conductor(Some((Ok(400.0), 1.5))), &lights).unwrap();
    let (a, b) = (part(&plain, "specular"), part(&film, "specular"));
    assert!(a.iter().all(|x| *x > 0.01), "{a:?}");
    assert!(
        (0..3).any(|c| (a[c] - b[c]).abs() > 0.02 * a[c]),
        "the film changes the color: {a:?} vs {b:?}"
    );
    // The plane fragment sits at the origin: the connected thickness is 0 there.
    let conn = shade(&filmed_conductor(Some((Err("thick"), 1.5))), &lights).unwrap();
    assert_eq!(part(&conn, "specular"), a);
}

/// Choosing a material translates only what it reaches: a second material built on a node
/// no library defines does not stop the first from compiling, and choosing that second one
/// reports the node.
#[test]
fn a_chosen_material_is_not_stopped_by_another_materials_nodes() {
    let good = material(&diffuse("d", [0.8, 0.8, 0.8], 0.0), Some("d"), None, None);
    let bad = r#"<no_such_bsdf name="x" type="BSDF"/>
        <surface name="surf2" type="surfaceshader"><input name="bsdf" type="BSDF" nodename="x"/></surface>
        <surfacematerial name="M2" type="material">
        <input name="surfaceshader" type="surfaceshader" nodename="surf2"/></surfacematerial>"#;
    let body = format!("{good}{bad}");
    let pick = |m: &str| Selection {
        material: Some(m.to_string()),
        output: None,
        ..Default::default()
    };
    let Some(ok) = compile_sel(&body, &pick("M")) else {
        return;
    };
    let c = ok.unwrap_or_else(|e| panic!("{e}"));
    let o = run_program(
        &c.program,
        &plane_fragment(),
        &[point([0.0, 0.0, 2.0], 8.0)],
        u32::MAX,
    );
    assert!(part(&o, "diffuse")[0] > 0.0);
    let e = compile_sel(&body, &pick("M2")).unwrap().unwrap_err();
    assert!(e.contains("no_such_bsdf"), "{e}");
}

/// `surface_unlit` (and the `convert` to `surfaceshader` graphs built on it): emission
/// `emission · emission_color` scaled by the cutout opacity, no light-dependent part; its
/// transmission is a lobe only where `transmission` is not zero (it traces the ray behind).
#[test]
fn unlit_surfaces_emit_their_color_and_transmit_only_when_asked() {
    let unlit = |extra: &str| {
        format!(
            r#"<surface_unlit name="u" type="surfaceshader">
            <input name="emission" type="float" value="0.5"/>
            <input name="emission_color" type="color3" value="1, 0.5, 0.25"/>{extra}</surface_unlit>
            <surfacematerial name="M" type="material">
            <input name="surfaceshader" type="surfaceshader" nodename="u"/></surfacematerial>"#
        )
    };
    let lights = [point([0.0, 0.0, 1.0], 5.0)];
    let Some(o) = shade(
        &unlit(r#"<input name="opacity" type="float" value="0.5"/>"#),
        &lights,
    ) else {
        return;
    };
    assert_close(
        &part(&o, "emission"),
        &[0.25, 0.125, 0.0625],
        1e-12,
        "emission",
    );
    assert_close(&o.get("M"), &[0.25, 0.125, 0.0625], 1e-12, "total: unlit");
    let ir = |body: &str| {
        let c = compile_sel(body, &Selection::default()).unwrap().unwrap();
        shadenet::graph::opt::run(&c.program, &Default::default())
            .0
            .to_string()
    };
    let opaque = ir(&unlit(""));
    assert!(!opaque.contains("trace"), "{opaque}");
    let clear = ir(&unlit(
        r#"<input name="transmission" type="float" value="1"/>
        <input name="transmission_color" type="color3" value="0.2, 0.4, 0.6"/>"#,
    ));
    assert!(clear.contains("trace"), "{clear}");
    // convert(color3 → surfaceshader): an unlit surface emitting the color.
    let body = r#"<convert name="c" type="surfaceshader">
        <input name="in" type="color3" value="0.3, 0.6, 0.9"/></convert>
        <surfacematerial name="M" type="material">
        <input name="surfaceshader" type="surfaceshader" nodename="c"/></surfacematerial>"#;
    let o = shade(body, &lights).unwrap();
    assert_close(
        &o.get("M"),
        &[0.3, 0.6, 0.9],
        1e-12,
        "convert color3 → surfaceshader",
    );
}
