//! The CSE and uniform-hoisting passes on real networks: the Larsson multiplication tree
//! (DESIGN §9, B1) folds to one multiply per level with CSE and keeps every node without
//! it; on every example network both passes keep the program valid, report no changes on a
//! second run, and leave the f32 interpreter's results bit-identical over a grid.

use shadenet::shade::{Grid, grid_env, shade_grid};
use shadenet_graph::ir::{BinOp, Op, Program, validate};
use shadenet_graph::opt::{self, Specialization, cse, hoist};
use shadenet_graph::types::Type;
use shadenet_graph::{NodeLibrary, compile_json};
use shadenet_runtime::ShadeEnv;
use std::fmt::Write;
use std::path::PathBuf;

/// A balanced tree of `2^levels − 1` `multiply` nodes over `2^levels` `samplerInfo` leaves,
/// each leaf's world-space `P` feeding the first level; output `color` is the root.
fn mult_tree(levels: u32) -> String {
    let mut nodes = Vec::new();
    for i in 0..1u32 << levels {
        nodes.push(format!(r#"{{ "name": "s_{i}", "type": "samplerInfo" }}"#));
    }
    for level in 1..=levels {
        for i in 0..1u32 << (levels - level) {
            let input = |k: u32| {
                if level == 1 {
                    format!("s_{k}.P")
                } else {
                    format!("m_{}_{k}.out", level - 1)
                }
            };
            nodes.push(format!(
                r#"{{ "name": "m_{level}_{i}", "type": "multiply", "inputs": {{ "input1": "{}", "input2": "{}" }} }}"#,
                input(2 * i),
                input(2 * i + 1)
            ));
        }
    }
    let mut s = String::new();
    write!(
        s,
        r#"{{ "name": "tree{levels}", "nodes": [{}], "outputs": {{ "color": "m_{levels}_0.out" }} }}"#,
        nodes.join(",\n")
    )
    .unwrap();
    s
}

/// vec3 multiplies listed in the program.
fn vec3_muls(p: &Program) -> usize {
    p.listed()
        .into_iter()
        .filter(|v| {
            matches!(p.op(*v), Op::Binary(BinOp::Mul, ..)) && p.expr(*v).ty == Some(Type::Vec3)
        })
        .count()
}

#[test]
fn mult_tree_folds_to_one_multiply_per_level_with_cse() {
    let lib = NodeLibrary::standard();
    for levels in [1, 2, 5, 10] {
        let c = compile_json(&mult_tree(levels), &lib).unwrap();
        let all = (1usize << levels) - 1;
        assert_eq!(vec3_muls(&c.program), all, "level {levels}: lowered");
        let on = opt::run(&c.program, &Specialization::default()).0;
        let mut off_spec = Specialization::default();
        off_spec.passes.cse = false;
        let off = opt::run(&c.program, &off_spec).0;
        validate(&on).unwrap();
        validate(&off).unwrap();
        let (n_on, n_off) = (vec3_muls(&on), vec3_muls(&off));
        println!("level {levels}: {n_on} multiplies with CSE, {n_off} without");
        // Every leaf reads the same stream, so each level collapses to one multiply.
        assert_eq!(n_on, levels as usize, "level {levels} with CSE\n{on}");
        assert!(n_on <= 12);
        assert_eq!(n_off, all, "level {levels} without CSE");
        if levels == 10 {
            let env = grid_env(&[]);
            same_bits(&grid(&on, &env), &grid(&off, &env), "mult tree, CSE on/off");
        }
    }
}

fn examples() -> Vec<PathBuf> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/networks");
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("examples/networks")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    v.sort();
    assert!(v.len() >= 5, "expected the bundled examples, found {v:?}");
    v
}

/// Each example's name, program and shading environment (its lights, or one key light).
fn example_programs() -> Vec<(String, Program, ShadeEnv)> {
    let lib = NodeLibrary::standard();
    examples()
        .into_iter()
        .map(|path| {
            let src = std::fs::read_to_string(&path).unwrap();
            let c = compile_json(&src, &lib).unwrap();
            let mut lights = c.lights.clone();
            if lights.is_empty() {
                lights.push(shadenet_graph::nodes::LightDesc {
                    name: "key".into(),
                    kind: shadenet_graph::nodes::LightKind::Point {
                        position: [1.0, 1.0, 2.0],
                    },
                    power: [20.0; 3],
                });
            }
            let name = path.file_stem().unwrap().to_string_lossy().into_owned();
            (name, c.program, grid_env(&lights))
        })
        .collect()
}

fn grid(p: &Program, env: &ShadeEnv) -> Grid {
    shade_grid::<f32>(p, env, 16, 16, u32::MAX).unwrap()
}

fn same_bits(a: &Grid, b: &Grid, what: &str) {
    assert_eq!(a.stride, b.stride, "{what}: output layout");
    assert_eq!(a.nonfinite, b.nonfinite, "{what}: non-finite count");
    for (i, (x, y)) in a.pixel_values().iter().zip(&b.pixel_values()).enumerate() {
        assert_eq!(
            x.to_bits(),
            y.to_bits(),
            "{what}: value {i} differs: {x:e} vs {y:e}"
        );
    }
}

fn class() -> Specialization {
    Specialization {
        bake: false,
        ..Specialization::default()
    }
}

#[test]
fn cse_keeps_examples_bit_identical() {
    for (name, program, env) in example_programs() {
        let before = grid(&program, &env);
        let mut p = program.clone();
        let changes = cse::run(&mut p, &Specialization::default());
        validate(&p).unwrap_or_else(|e| panic!("{name}: {e}\n{p}"));
        println!(
            "{name}: cse merged {changes} values ({} → {} ops)",
            program.op_count(),
            p.op_count()
        );
        assert_eq!(program.op_count() - p.op_count(), changes, "{name}");
        assert_eq!(cse::run(&mut p, &Specialization::default()), 0, "{name}");
        same_bits(&before, &grid(&p, &env), &format!("{name}: cse alone"));

        // Through the pipeline, instance and class compilation, with and without CSE.
        for spec in [Specialization::default(), class()] {
            let on = opt::run(&program, &spec).0;
            let mut off_spec = spec.clone();
            off_spec.passes.cse = false;
            let off = opt::run(&program, &off_spec).0;
            assert!(on.op_count() <= off.op_count(), "{name}");
            same_bits(
                &grid(&on, &env),
                &grid(&off, &env),
                &format!("{name}: pipeline with/without cse, bake={}", spec.bake),
            );
        }
    }
}

#[test]
fn hoist_keeps_examples_bit_identical() {
    let mut hoisted_somewhere = false;
    for (name, program, env) in example_programs() {
        let before = grid(&program, &env);
        let mut p = program.clone();
        let moved = hoist::run(&mut p, &class());
        validate(&p).unwrap_or_else(|e| panic!("{name}: {e}\n{p}"));
        println!(
            "{name}: hoist moved {moved} values ({} in the prelude of {} ops)",
            p.prelude.body.len(),
            p.op_count()
        );
        assert_eq!(p.prelude.body.len(), moved, "{name}");
        assert_eq!(
            p.op_count(),
            program.op_count(),
            "{name}: hoisting only moves"
        );
        assert_eq!(hoist::run(&mut p, &class()), 0, "{name}");
        same_bits(&before, &grid(&p, &env), &format!("{name}: hoist alone"));

        // Class compilation through the pipeline, with and without hoisting.
        let (on, report) = opt::run(&program, &class());
        let mut off_spec = class();
        off_spec.passes.hoist = false;
        let off = opt::run(&program, &off_spec).0;
        let hoist_changes = report.passes.iter().find(|s| s.pass == "hoist").unwrap();
        assert_eq!(
            hoist_changes.changes > 0,
            !on.prelude.body.is_empty(),
            "{name}"
        );
        hoisted_somewhere |= !on.prelude.body.is_empty();
        assert!(off.prelude.body.is_empty(), "{name}");
        same_bits(
            &grid(&on, &env),
            &grid(&off, &env),
            &format!("{name}: class pipeline with/without hoist"),
        );

        // Instance compilation: parameters are constants, nothing to hoist.
        let (baked, report) = opt::run(&program, &Specialization::default());
        assert!(baked.prelude.body.is_empty(), "{name}\n{baked}");
        let h = report.passes.iter().find(|s| s.pass == "hoist").unwrap();
        assert_eq!(h.changes, 0, "{name}");
    }
    assert!(hoisted_somewhere);
}

#[test]
fn marble_class_compilation_hoists_the_phong_parameters() {
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/networks/marble.json"
    ))
    .unwrap();
    let c = compile_json(&src, &NodeLibrary::standard()).unwrap();
    let (p, report) = opt::run(&c.program, &class());
    let moved = report.passes.iter().find(|s| s.pass == "hoist").unwrap();
    println!("{report}\n{p}");
    assert!(moved.changes > 0);
    // Computations, not just parameter reads, run once per instance.
    let computed = p
        .prelude
        .body
        .iter()
        .filter(|v| !matches!(p.op(**v), Op::Param(_) | Op::Const(_)))
        .count();
    assert!(computed > 0, "{p}");
    // Nothing in the body is a computation over parameters and constants only.
    let mut uniform = vec![false; p.exprs.len()];
    for v in &p.prelude.body {
        uniform[v.index()] = true;
    }
    for v in p.listed() {
        let op = p.op(v);
        if matches!(op, Op::Const(_) | Op::Param(_)) {
            uniform[v.index()] = true;
            continue;
        }
        let pure = matches!(
            op,
            Op::Unary(..)
                | Op::Binary(..)
                | Op::Select { .. }
                | Op::Construct(_)
                | Op::Extract(..)
                | Op::Splat(_)
                | Op::Convert(_)
                | Op::Call(..)
        );
        let mut all = pure;
        let mut param = false;
        op.for_each_operand(|a| {
            all &= uniform[a.index()];
            param |= matches!(p.op(a), Op::Param(_));
        });
        if all && !p.prelude.body.contains(&v) {
            assert!(!param, "{v:?} reads only uniform values but stayed:\n{p}");
        }
    }
}
