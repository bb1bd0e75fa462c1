//! Every example network: compiles, validates, its IR text round-trips exactly, and it
//! shades a grid with finite results whose f32 run agrees with the f64 reference.

use shadenet::shade::{grid_env, shade_grid};
use shadenet_graph::ir::{parse, validate};
use shadenet_graph::{NodeLibrary, compile_json};
use std::path::PathBuf;

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

#[test]
fn every_example_compiles_and_its_ir_round_trips() {
    let lib = NodeLibrary::standard();
    for path in examples() {
        let src = std::fs::read_to_string(&path).unwrap();
        let c = compile_json(&src, &lib).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        validate(&c.program).unwrap();
        let text = c.program.to_string();
        let back = parse(&text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", path.display()));
        validate(&back).unwrap();
        assert_eq!(
            back.to_string(),
            text,
            "{}: print → parse → print differs",
            path.display()
        );
        assert_eq!(back.op_count(), c.program.op_count());
    }
}

/// f32 against the f64 reference on every example: the largest difference allowed is
/// `1e-4 · max(1, |reference|)`. The bound covers transcendental functions (libm's f32
/// versions are within a few ulp) and the few pixels where noise picks its lattice cell
/// differently in f32 and f64 right at a cell boundary; measured differences are printed.
#[test]
fn every_example_shades_finite_and_f32_agrees_with_f64() {
    let lib = NodeLibrary::standard();
    for path in examples() {
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
        let env = grid_env(&lights);
        let g32 = shade_grid::<f32>(&c.program, &env, 24, 24, u32::MAX).unwrap();
        let g64 = shade_grid::<f64>(&c.program, &env, 24, 24, u32::MAX).unwrap();
        assert_eq!(g32.nonfinite, 0, "{}", path.display());
        assert_eq!(g64.nonfinite, 0, "{}", path.display());
        let mut worst = 0.0f64;
        let (v32, v64) = (g32.pixel_values(), g64.pixel_values());
        for (a, b) in v32.iter().zip(&v64) {
            assert!(a.is_finite());
            worst = worst.max((a - b).abs() / b.abs().max(1.0));
        }
        println!("{}: max f32/f64 difference {worst:.3e}", path.display());
        assert!(
            worst <= 1e-4,
            "{}: f32 differs from f64 by {worst}",
            path.display()
        );
        // Not a flat image: the examples are meant to show something.
        let first: Vec<f64> = v64[..g64.stride].to_vec();
        let varies = v64.chunks(g64.stride).any(|px| px != first.as_slice());
        assert!(varies, "{} shades to a constant", path.display());
    }
}
