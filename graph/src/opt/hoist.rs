//! Uniform hoisting: computations that depend only on parameters and constants move into the
//! prelude, which a back end evaluates once per material instance instead of per fragment.
//!
//! A value is **hoisted** when
//! - its op may be in the prelude: constants, parameters and the pure ops (`Unary`,
//!   `Binary`, `Select`, `Construct`, `Extract`, `Splat`, `Convert`, `Call`); never a
//!   stream, transform, component query, light read, texture lookup, region or `proj` (the
//!   prelude rules of [`crate::ir::validate`](fn@crate::ir::validate));
//! - every operand is a prelude value or itself qualifies (constants, parameters, values
//!   computed from them);
//! - it is a computation (not a bare constant or parameter) that depends on at least one
//!   `param`.
//!
//! It is moved from wherever it is listed (the top-level block or any nested block: `If`
//! arms, illuminance bodies, loop blocks: a loop-invariant value) to the end of the prelude. Every op is total, so computing a
//! value unconditionally, once, instead of only when its arm runs or once per light sample,
//! gives the same bits and cannot fail. The operands of hoisted values move with them
//! (constants, parameters, and constant-only computations that feed a hoisted value), so a
//! prelude value reads only prelude values; values keep their handles, and prelude values
//! are visible everywhere in the body, so the remaining users need no rewriting. Moved
//! values keep their evaluation order, so operands stay before users.
//!
//! **Not hoisted.** Bare constants and parameters no hoisted value reads stay where they are
//! (reading one costs no more than reading a prelude value), and so do computations over
//! constants only that feed no hoisted value: folding them is the fold pass's job, and with
//! fold switched off they stay per-fragment on purpose (benchmarks measure per-node cost).
//! With baked parameters (instance compilation) there are no parameters left, so nothing
//! moves. Duplicates that end up side by side in the prelude (from two `If` arms, which CSE
//! may not merge) are left as they are.
//!
//! The pass returns how many values it moved (0 when it changed nothing).

use super::Specialization;
use crate::ir::{Op, Program, Value};

/// Moves parameter-only computations into the prelude; returns how many values moved.
pub fn run(p: &mut Program, _spec: &Specialization) -> usize {
    let n = p.exprs.len();
    let mut in_prelude = vec![false; n];
    // Computable in the prelude (prelude values, and body values that qualify).
    let mut uniform = vec![false; n];
    // Depends on a parameter.
    let mut param_dep = vec![false; n];
    let depends = |op: &Op, param_dep: &[bool]| {
        let mut d = matches!(op, Op::Param(_));
        op.for_each_operand(|a| d |= param_dep[a.index()]);
        d
    };
    for &v in &p.prelude.body {
        in_prelude[v.index()] = true;
        uniform[v.index()] = true;
        param_dep[v.index()] = depends(p.op(v), &param_dep);
    }
    let mut order = Vec::new();
    p.walk(&p.body, &mut |v| order.push(v));
    let mut hoist = vec![false; n];
    for &v in &order {
        let op = p.op(v);
        let mut ok = allowed(op);
        op.for_each_operand(|a| ok &= uniform[a.index()]);
        if !ok {
            continue;
        }
        uniform[v.index()] = true;
        param_dep[v.index()] = depends(op, &param_dep);
        hoist[v.index()] = param_dep[v.index()] && !matches!(op, Op::Const(_) | Op::Param(_));
    }
    // Operands come before their users in evaluation order: one backward sweep brings every
    // operand a hoisted value reads (all uniform) along.
    for &v in order.iter().rev() {
        if hoist[v.index()] {
            p.op(v).for_each_operand(|a| {
                if !in_prelude[a.index()] {
                    hoist[a.index()] = true;
                }
            });
        }
    }
    let moved: Vec<Value> = order.into_iter().filter(|v| hoist[v.index()]).collect();
    if moved.is_empty() {
        return 0;
    }
    let stay = |v: &Value| !hoist[v.index()];
    for e in &mut p.exprs {
        for b in e.op.blocks_mut() {
            b.body.retain(stay);
        }
    }
    p.body.body.retain(stay);
    let count = moved.len();
    p.prelude.body.extend(moved);
    count
}

/// Whether an op may be computed in the prelude (given prelude operands): constants,
/// parameters and pure ops ([`Op::is_pure`]).
fn allowed(op: &Op) -> bool {
    matches!(op, Op::Const(_) | Op::Param(_)) || op.is_pure()
}
