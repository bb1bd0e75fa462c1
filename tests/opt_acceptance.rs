//! Partial evaluation, end to end: component specialization removes other components' work,
//! needs list only what is read, dead branches never open their textures.

use shadenet_graph::ir::{Op, Program, Value};
use shadenet_graph::opt::{self, Specialization};
use shadenet_graph::{NodeLibrary, compile_json};
use std::collections::HashSet;

fn compile(src: &str) -> Program {
    compile_json(src, &NodeLibrary::standard()).unwrap().program
}

/// Values `roots` depend on (operands, region blocks' values and yields, transitively).
fn slice(p: &Program, roots: &[Value]) -> HashSet<Value> {
    let mut seen = HashSet::new();
    let mut stack: Vec<Value> = roots.to_vec();
    while let Some(v) = stack.pop() {
        if !seen.insert(v) {
            continue;
        }
        let op = p.op(v);
        op.for_each_operand(|a| stack.push(a));
        for b in op.blocks() {
            stack.extend(b.body.iter().copied());
            stack.extend(b.yields.iter().copied());
        }
        // A value inside a region's block needs the region's own operands evaluated.
        if let Op::Proj(r, _) = op {
            stack.push(*r);
        }
    }
    seen
}

const PHONG: &str = r#"{
  "nodes": [
    {"name": "tex", "type": "checker", "inputs": {"color1": [0.8, 0.2, 0.1]}},
    {"name": "surf", "type": "phong",
     "inputs": {"color": "tex.outColor", "incandescence": [0.1, 0.0, 0.0], "cosinePower": 30}}
  ],
  "outputs": {"color": "surf.outColor"}
}"#;

#[test]
fn specular_only_keeps_no_op_of_other_components() {
    let p = compile(PHONG);
    let spec = Specialization {
        components: Specialization::mask_of(&p, &["specular".into()]).unwrap(),
        ..Specialization::default()
    };
    let (o, report) = opt::run(&p, &spec);
    shadenet_graph::ir::validate(&o).unwrap();
    let k = o.component_index("specular").unwrap();
    let spec_roots: Vec<Value> = o
        .outputs
        .iter()
        .filter(|x| x.component == Some(k))
        .map(|x| x.value)
        .collect();
    let live = slice(&o, &spec_roots);
    for v in o.listed() {
        if live.contains(&v) {
            continue;
        }
        // Everything else is the constant an inactive component's output is.
        assert!(
            matches!(o.op(v), Op::Const(_)),
            "{v:?} = {:?} feeds only inactive components\n{o}",
            o.op(v)
        );
    }
    for out in o.outputs.iter().filter(|x| x.component != Some(k)) {
        assert!(
            matches!(o.op(out.value), Op::Const(_)),
            "{} is not constant",
            out.name
        );
    }
    // One light loop (specular) instead of two, and no checker work feeds it? The specular
    // term does not read the albedo: the checker is gone too.
    let loops = o
        .listed()
        .into_iter()
        .filter(|v| matches!(o.op(*v), Op::Illuminance { .. }))
        .count();
    assert_eq!(loops, 1, "{o}");
    assert!(report.ops_after < report.ops_before / 2, "{report}");
    assert!(
        !report
            .needs
            .streams
            .contains(&shadenet_graph::ir::Stream::Uv),
        "{report}"
    );
}

#[test]
fn needs_list_no_tangents_or_differentials_unless_read() {
    // The checker filters over uv's footprint, which reads the frame and the differentials;
    // with its filter off nothing reads them.
    let (_, r) = opt::run(&compile(PHONG), &Specialization::default());
    assert!(r.needs.tangents() && r.needs.differentials(), "{}", r.needs);
    let unfiltered = PHONG.replace(
        r#""inputs": {"color1": [0.8, 0.2, 0.1]}"#,
        r#""inputs": {"color1": [0.8, 0.2, 0.1], "filter": 0}"#,
    );
    assert_ne!(unfiltered, PHONG);
    let (_, r) = opt::run(&compile(&unfiltered), &Specialization::default());
    assert!(
        !r.needs.tangents() && !r.needs.differentials(),
        "{}",
        r.needs
    );
    assert!(r.needs.lights);
    let with_tangent = compile(
        r#"{"nodes": [{"name": "g", "type": "samplerInfo"},
                      {"name": "l", "type": "length", "inputs": {"input": "g.dPdu"}}],
            "outputs": {"t": "l.out"}}"#,
    );
    let (_, r) = opt::run(&with_tangent, &Specialization::default());
    assert!(r.needs.tangents(), "{}", r.needs);
    assert!(!r.needs.differentials());
    assert!(!r.needs.lights);
}

fn texture_network(dir: &std::path::Path, live: bool) -> std::path::PathBuf {
    // `condition` with constant terms: 1 > 2 is false, so colorIfFalse is live.
    let (t, f) = if live {
        ("[0, 0, 1]", "\"img.outColor\"")
    } else {
        ("\"img.outColor\"", "[0, 0, 1]")
    };
    let net = format!(
        r#"{{"nodes": [
              {{"name": "img", "type": "file", "inputs": {{"fileTextureName": "missing.png"}}}},
              {{"name": "pick", "type": "condition",
                "inputs": {{"firstTerm": 1, "secondTerm": 2, "operation": "greaterThan",
                           "colorIfTrue": {t}, "colorIfFalse": {f}}}}}],
            "outputs": {{"color": "pick.outColor"}}}}"#
    );
    let path = dir.join(if live { "live.json" } else { "dead.json" });
    std::fs::write(&path, net).unwrap();
    path
}

#[test]
fn texture_on_a_dead_branch_is_never_opened() {
    let dir = std::env::temp_dir().join(format!("shadenet-deadtex-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for live in [false, true] {
        let path = texture_network(&dir, live);
        let c = shadenet::load_network(&path).unwrap();
        assert_eq!(
            c.program.textures.len(),
            1,
            "the unoptimized program names the texture"
        );
        let (o, r) = opt::run(&c.program, &Specialization::default());
        let loaded = shadenet_runtime::Interpreter::<f32>::new(&o);
        if live {
            assert_eq!(r.needs.textures.len(), 1);
            // The filtered lookup reads uv's footprint: the ray differentials.
            assert!(r.needs.differentials(), "{}", r.needs);
            let e = loaded.unwrap_err().to_string();
            assert!(e.contains("missing.png"), "{e}");
        } else {
            assert!(r.needs.textures.is_empty(), "{}", r.needs);
            assert!(o.textures.is_empty());
            // Its derivative ops died with it: nothing asks for ray differentials.
            assert!(!r.needs.differentials(), "{}", r.needs);
            let i = loaded.expect("nothing to load");
            let env = shadenet_runtime::ShadeEnv::default();
            let out = i.shade(&shadenet_runtime::ShadeCtx::new(Default::default(), &env));
            assert_eq!(out.values, vec![0.0, 0.0, 1.0]);
        }
        // The CLI optimizes before shading: dead → an image, live → a clear error.
        let png = dir.join("out.png");
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_shadenet"))
            .args([
                "shade",
                path.to_str().unwrap(),
                "-o",
                png.to_str().unwrap(),
                "--res",
                "8x8",
                "-q",
            ])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&run.stderr);
        if live {
            assert_eq!(run.status.code(), Some(1), "{err}");
            assert!(
                err.contains("cannot load texture") && err.contains("missing.png"),
                "{err}"
            );
        } else {
            assert!(run.status.success(), "{err}");
        }
    }
}
