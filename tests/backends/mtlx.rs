//! The parity suite on MaterialX (issue 13): every stdlib nodedef that compiles natively,
//! with its value inputs wired to the hard fragments' streams, and every example document,
//! through every back end against the interpreter. Needs the MaterialX libraries: fails
//! without them when `CI` is set (`.ci/run` installs them), skips with the reason otherwise.

use super::*;
use shadenet::graph::mtlx::coverage::{self, Status};
use shadenet::graph::mtlx::document::NodeDefElem;
use shadenet::graph::mtlx::{self as mx, Library, Selection};

fn library() -> Option<&'static Library> {
    match shadenet::mtlx::locate(None).and_then(|d| shadenet::mtlx::library(&d)) {
        Ok(l) => Some(l),
        Err(e) if std::env::var_os("CI").is_some() => panic!(
            "CI needs the MaterialX libraries: {}",
            shadenet::graph::error_chain(&e)
        ),
        Err(e) => {
            eprintln!("SKIPPED: {}", shadenet::graph::error_chain(&e));
            None
        }
    }
}

/// Streams the wired inputs read: position (object space), normal and uv, their
/// components, colour versions of them, and per-fragment matrices made of them (MaterialX
/// rows: position, normal, the default third row; a matrix44's fourth row the position).
const SOURCES: &str = r#"
  <position name="sp" type="vector3" space="object" />
  <normal name="sn" type="vector3" space="object" />
  <texcoord name="suv" type="vector2" />
  <extract name="px" type="float"><input name="in" type="vector3" nodename="sp" /><input name="index" type="integer" value="0" /></extract>
  <extract name="py" type="float"><input name="in" type="vector3" nodename="sp" /><input name="index" type="integer" value="1" /></extract>
  <extract name="pz" type="float"><input name="in" type="vector3" nodename="sp" /><input name="index" type="integer" value="2" /></extract>
  <extract name="ux" type="float"><input name="in" type="vector2" nodename="suv" /><input name="index" type="integer" value="0" /></extract>
  <combine2 name="pyx" type="vector2"><input name="in1" type="float" nodename="py" /><input name="in2" type="float" nodename="px" /></combine2>
  <convert name="spc" type="color3"><input name="in" type="vector3" nodename="sp" /></convert>
  <convert name="snc" type="color3"><input name="in" type="vector3" nodename="sn" /></convert>
  <creatematrix name="m3a" type="matrix33" nodedef="ND_creatematrix_vector3_matrix33"><input name="in1" type="vector3" nodename="sp" /><input name="in2" type="vector3" nodename="sn" /></creatematrix>
  <creatematrix name="m3b" type="matrix33" nodedef="ND_creatematrix_vector3_matrix33"><input name="in1" type="vector3" nodename="sn" /><input name="in3" type="vector3" nodename="sp" /></creatematrix>
  <creatematrix name="m4a" type="matrix44" nodedef="ND_creatematrix_vector3_matrix44"><input name="in1" type="vector3" nodename="sp" /><input name="in2" type="vector3" nodename="sn" /><input name="in4" type="vector3" nodename="sp" /></creatematrix>
  <creatematrix name="m4b" type="matrix44" nodedef="ND_creatematrix_vector3_matrix44"><input name="in1" type="vector3" nodename="sn" /><input name="in3" type="vector3" nodename="sp" /></creatematrix>
"#;

/// The source node of the `k`-th wired input of type `ty`, if that type is wired.
fn source(ty: &str, k: usize) -> Option<&'static str> {
    let pick = |xs: &'static [&'static str]| Some(xs[k % xs.len()]);
    match ty {
        "float" => pick(&["px", "py", "pz", "ux"]),
        "vector2" => pick(&["suv", "pyx"]),
        "vector3" => pick(&["sp", "sn"]),
        "color3" => pick(&["spc", "snc"]),
        "matrix33" => pick(&["m3a", "m3b"]),
        "matrix44" => pick(&["m4a", "m4b"]),
        _ => None,
    }
}

/// A document with one node of `nd`, every float, vector2, vector3, color3 and matrix input wired
/// to a varying source (others at their defaults), and an output per node output.
fn atom_document(nd: &NodeDefElem) -> String {
    let ty = if nd.outputs.len() > 1 {
        "multioutput"
    } else {
        nd.outputs[0].ty.as_str()
    };
    let mut doc = format!(
        "<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n{SOURCES}  <{} name=\"n\" type=\"{ty}\" nodedef=\"{}\">\n",
        nd.node, nd.name
    );
    let mut seen: HashMap<&str, usize> = HashMap::new();
    for i in &nd.inputs {
        let k = seen.entry(i.ty.as_str()).or_default();
        if let Some(src) = source(&i.ty, *k) {
            doc += &format!(
                "    <input name=\"{}\" type=\"{}\" nodename=\"{src}\" />\n",
                i.name, i.ty
            );
        }
        *k += 1;
    }
    doc += &format!("  </{}>\n", nd.node);
    for o in &nd.outputs {
        doc += &format!(
            "  <output name=\"o_{0}\" type=\"{1}\" nodename=\"n\" output=\"{0}\" />\n",
            o.name, o.ty
        );
    }
    doc + "</materialx>\n"
}

use std::collections::HashMap;

/// Whether a fragment's streams leave the domain where the GPU's transcendentals have a
/// documented bound (DESIGN §7; `shadenet_gpu::testing::documented_bound`).
fn beyond_gpu_domains(f: &Fragment) -> bool {
    f.p.iter()
        .chain(&f.n)
        .chain(&f.uv)
        .any(|x| !x.is_finite() || x.abs() > 1e4)
}

/// Every natively lowered stdlib nodedef (the atoms), inputs wired to the hard fragments.
#[test]
fn every_materialx_atom() {
    let Some(lib) = library() else {
        return;
    };
    let env = env();
    let frags = hard_fragments();
    let mut checked = 0;
    let unsupported = std::cell::RefCell::new(Vec::new());
    for row in coverage::check(lib, "stdlib") {
        if row.status != Status::Native {
            continue;
        }
        let nd = lib.nodedef(&row.nodedef).expect("listed");
        let doc = atom_document(nd);
        let c = mx::compile("atom.mtlx", &doc, lib, &Selection::default())
            .unwrap_or_else(|e| panic!("{}: {}\n{doc}", nd.name, shadenet::graph::error_chain(&e)));
        // The JIT must agree bit for bit everywhere; the GPU within the mixed bound where
        // the streams are within its transcendentals' documented domains.
        let class = Class::MixedExcept {
            why: "a stream component beyond ±1e4 or not finite: outside the GPU \
                  transcendentals' documented domains",
            excused: beyond_gpu_domains,
        };
        // A back end that says it does not support an op is listed, not compared (in a
        // render that material falls back to the interpreter); none may today.
        let supports = |ut: &UnderTest| match ut.backend.compile_program(&c.program, Duration::ZERO)
        {
            Err(shadenet_runtime::BackendError::Unsupported { .. }) => {
                unsupported
                    .borrow_mut()
                    .push(format!("{} on {}", nd.name, ut.name));
                false
            }
            _ => true,
        };
        check_program_on(
            &nd.name,
            &c.program,
            &env,
            u32::MAX,
            &frags,
            class,
            &supports,
        );
        checked += 1;
    }
    assert!(checked > 250, "only {checked} atoms checked");
    let unsupported = unsupported.into_inner();
    eprintln!(
        "{checked} MaterialX atoms: every back end agrees with the interpreter; not compiled \
         (the material falls back to the interpreter): {}",
        unsupported.join(", ")
    );
    // Every back end compiles every atom (matrices, matrix33 and matrix44 per fragment
    // here, are values like vectors on each of them) but the geometry-attribute atoms on
    // the GPU, which refuses them (no attribute buffers: those materials run on the CPU).
    let reads_attributes = |u: &String| {
        (u.starts_with("ND_geomcolor_") || u.starts_with("ND_geompropvalue_"))
            && u.ends_with(" on gpu")
    };
    let unexpected: Vec<&String> = unsupported
        .iter()
        .filter(|u| !reads_attributes(u))
        .collect();
    assert!(
        unexpected.is_empty(),
        "unexpectedly unsupported: {unexpected:?}"
    );
}

/// Every example document of `examples/materials/`, optimized and as lowered, over a grid
/// whose size is not a multiple of 4.
#[test]
fn every_example_material() {
    // The libraries are found as `shadenet shade` finds them (skipped or failed without).
    if library().is_none() {
        return;
    }
    let (w, h) = (23, 17);
    let frags: Vec<Fragment> = (0..h)
        .flat_map(|y| (0..w).map(move |x| shadenet::shade::grid_fragment(x, y, w, h)))
        .collect();
    let env = shadenet::shade::grid_env(&[]);
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/materials");
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "mtlx"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 12, "{} example documents", paths.len());
    for path in paths {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        // As `shadenet shade` loads a document: its files relative to it (maps.mtlx).
        let c = shadenet::mtlx::compile_mtlx(&path, &Default::default())
            .unwrap_or_else(|e| panic!("{name}: {}", shadenet::graph::error_chain(&e)));
        let (p, _) = opt::run(&c.program, &Specialization::default());
        // The GPU refuses geometry attributes (those materials run on the CPU): it is
        // checked to say so, and left out.
        let reads_attributes = !c.program.attributes.is_empty();
        let include = |ut: &UnderTest| {
            if reads_attributes && ut.name == "gpu" {
                let e = ut.backend.compile_program(&p, Duration::ZERO).err();
                assert!(
                    matches!(e, Some(shadenet_runtime::BackendError::Unsupported { .. })),
                    "{name}: the GPU must refuse attributes: {e:?}"
                );
                return false;
            }
            true
        };
        check_program_on(&name, &p, &env, u32::MAX, &frags, Class::Mixed, &include);
        let what = format!("{name} (unoptimized)");
        check_program_on(
            &what,
            &c.program,
            &env,
            u32::MAX,
            &frags,
            Class::Mixed,
            &include,
        );
    }
}
