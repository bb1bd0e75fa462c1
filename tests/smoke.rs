//! The harness itself: a program built by hand runs in both precisions.
mod common;
use common::*;
use shadenet_graph::ir::{Builder, Stream};

#[test]
fn hand_built_program_runs_in_f32_and_f64() {
    let mut b = Builder::new("t");
    let p = b.stream(Stream::P);
    let two = b.vec3([2.0, 2.0, 2.0]);
    let x = b.mul(p, two);
    b.output("out", None, x);
    let prog = b.finish().unwrap();
    let mut frag = plane_fragment();
    frag.p = [1.0, -0.5, 0.25];
    let o = run_program(&prog, &frag, &[], u32::MAX);
    assert_eq!(o.get("out"), vec![2.0, -1.0, 0.5]);
    assert_eq!(o.get32("out"), vec![2.0, -1.0, 0.5]);
}
