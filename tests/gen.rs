//! Generated networks: the benchmark multiplication tree (`shadenet::generate::mult_tree` and
//! `shadenet gen mult-tree`).

mod common;
use common::shadenet;

use serde_json::Value as Json;
use shadenet::generate::{GenError, mult_tree};
use shadenet_graph::ir::{Space, XformKind};
use shadenet_graph::{NodeLibrary, compile_json};
use shadenet_runtime::interp::transform;
use shadenet_runtime::{Fragment, Interpreter, ShadeCtx, ShadeEnv, Transform};
use std::path::PathBuf;

fn count(net: &Json, ty: &str) -> usize {
    net["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|n| n["type"] == ty)
        .count()
}

#[test]
fn node_counts_names_and_compiles() {
    let lib = NodeLibrary::standard();
    for levels in [1u32, 3, 10] {
        let net = mult_tree(levels, Space::World).unwrap();
        let n = 1usize << levels;
        assert_eq!(count(&net, "multiply"), n - 1, "level {levels}");
        assert_eq!(count(&net, "samplerInfo"), n, "level {levels}");
        assert_eq!(net["nodes"].as_array().unwrap().len(), 2 * n - 1);
        // Predictable names: leaves p0…, the root m<levels>_0 is the output.
        let names: Vec<&str> = net["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n["name"].as_str().unwrap())
            .collect();
        assert!(names.contains(&format!("p{}", n - 1).as_str()));
        assert!(names.contains(&format!("m{levels}_0").as_str()));
        assert_eq!(net["outputs"]["color"], format!("m{levels}_0.out"));
        let c = compile_json(&net.to_string(), &lib).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(c.program.output_names(), ["color"]);
        assert_eq!(c.program.ty(c.program.outputs[0].value).name(), "vec3");
    }
}

#[test]
fn levels_outside_1_to_16_are_errors() {
    for bad in [0, 17, 100] {
        let e = mult_tree(bad, Space::World).unwrap_err();
        assert_eq!(e, GenError::Levels { levels: bad });
        assert!(e.to_string().contains("1 to 16"), "{e}");
    }
    assert!(mult_tree(16, Space::Camera).is_ok());
}

/// The tree computed by hand in f32, in the tree's order: every leaf is the same `p`, so
/// level `l` is the square of level `l − 1`.
fn by_hand(p: [f32; 3], levels: u32) -> [f32; 3] {
    let mut v = p.map(|x| x * x);
    for _ in 1..levels {
        v = v.map(|x| x * x);
    }
    v
}

fn shade(net: &Json, frag: Fragment, env: &ShadeEnv) -> Vec<f32> {
    let c = compile_json(&net.to_string(), &NodeLibrary::standard()).unwrap();
    let out = Interpreter::<f32>::new(&c.program)
        .unwrap()
        .shade(&ShadeCtx::new(frag, env));
    assert_eq!(out.nonfinite, 0);
    out.values
}

/// Level 3 is `P^8` component-wise. Checked **exactly** against the same tree multiplied by
/// hand in f32 (`((P·P)·(P·P))·((P·P)·(P·P))`, i.e. three squarings), and loosely (relative
/// 1e-6, three roundings) against `P^8` in f64.
#[test]
fn level_3_is_p_to_the_8th_in_world_and_camera_space() {
    let p = [1.1f32, -0.7, 2.5];
    let frag = Fragment {
        p,
        n: [0.0, 0.0, 1.0],
        ..Fragment::default()
    };
    let world = shade(
        &mult_tree(3, Space::World).unwrap(),
        frag,
        &ShadeEnv::default(),
    );
    let want = by_hand(p, 3);
    assert_eq!(world, want.to_vec(), "world");
    for (got, x) in world.iter().zip(p) {
        let exact = f64::from(x).powi(8);
        assert!(
            (f64::from(*got) - exact).abs() <= 1e-6 * exact,
            "{got} vs {exact}"
        );
    }

    // Camera space: the leaves read P through the camera transform.
    let env = ShadeEnv {
        camera: Transform::look_at([1.0, 2.0, 5.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]).unwrap(),
        ..ShadeEnv::default()
    };
    let camera = shade(&mult_tree(3, Space::Camera).unwrap(), frag, &env);
    let pc = transform::<f32>(&env, XformKind::Point, Space::World, Space::Camera, p);
    assert_ne!(pc, p);
    assert_eq!(camera, by_hand(pc, 3).to_vec(), "camera");
}

fn tmp(name: &str) -> PathBuf {
    common::tmp("gen", name)
}

#[test]
fn cli_writes_a_tree_that_check_accepts() {
    let path = tmp("tree4.json");
    let p = path.to_str().unwrap();
    let (code, out, err) = shadenet(&[
        "gen",
        "mult-tree",
        "--levels",
        "4",
        "--space",
        "camera",
        "-o",
        p,
    ]);
    assert_eq!(code, 0, "{out}\n{err}");
    let net: Json = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(net, mult_tree(4, Space::Camera).unwrap());
    assert_eq!(count(&net, "multiply"), 15);
    let (code, out, err) = shadenet(&["check", p]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(
        out.starts_with("ok:") && out.contains("outputs: color"),
        "{out}"
    );
}

#[test]
fn cli_rejects_levels_0_and_17_with_a_message() {
    for bad in ["0", "17"] {
        let path = tmp(&format!("bad{bad}.json"));
        let (code, out, err) = shadenet(&[
            "gen",
            "mult-tree",
            "--levels",
            bad,
            "-o",
            path.to_str().unwrap(),
        ]);
        assert_eq!(code, 1, "--levels {bad}: {out}\n{err}");
        assert!(
            err.contains("--levels") && err.contains("1 to 16") && err.contains(bad),
            "--levels {bad}: {err}"
        );
        assert!(!path.exists(), "--levels {bad} wrote a file");
    }
}
