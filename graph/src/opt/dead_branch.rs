//! Dead branches: constant conditions pick their live side.
//!
//! - An `if` whose condition is a constant bool is replaced by its live arm: the arm's values
//!   move into the enclosing block at the `if`'s place (their operands are visible there:
//!   they were visible inside the arm, which sees everything before the `if`), every use of
//!   a `proj r, k` of the region becomes the arm's `k`-th yield (through
//!   [`Program::substitute`]), and the `if` and its `proj`s leave their blocks. The dead arm
//!   goes with the `if`. The moved values are visited in turn, so an `if` nested in the live
//!   arm is resolved too; `if`s are found at any depth (inside other arms and illuminance
//!   bodies).
//! - A `select` whose condition is a constant bool is replaced by the operand it picks (its
//!   uses are substituted; the `select` stays listed for DCE to remove). This is how a `mix`
//!   with a constant weight of exactly 0 or 1 becomes one of its inputs: the builder lowers
//!   `mix` to `select(t == 0, a, select(t == 1, b, lerp))`, and fold makes the comparisons
//!   constant.
//!
//! Both rewrites are exact: the interpreter evaluates exactly the picked side, so results are
//! bit-identical. The pass does not fold conditions itself (that is fold's job; `switch` and
//! `condition` nodes with constant selectors lower to `if`s on comparisons that fold
//! decides), never touches an `illuminance` (its body runs once per light sample, not
//! conditionally on a constant), and never reorders values other than by splicing an arm.
//!
//! It reports one change per `if` removed and per `select` replaced that still had a use,
//! so it reports 0 exactly when it leaves the program as it found it.

use super::Specialization;
use super::fold::{resolve, used_values};
use crate::ir::{Block, Op, Program, Value};
use crate::types::ConstValue;
use std::collections::VecDeque;

/// Replaces constant-condition `if`s by their live arm and constant-condition `select`s by
/// the operand they pick; returns the number of changes.
pub fn run(p: &mut Program, _spec: &Specialization) -> usize {
    let mut pass = DeadBranch {
        used: used_values(p),
        map: vec![None; p.exprs.len()],
        removed: vec![None; p.exprs.len()],
        changes: 0,
        substituted: false,
    };
    let mut prelude = std::mem::take(&mut p.prelude);
    pass.block(p, &mut prelude);
    p.prelude = prelude;
    let mut body = std::mem::take(&mut p.body);
    pass.block(p, &mut body);
    p.body = body;
    if pass.substituted {
        p.substitute(&pass.map);
    }
    pass.changes
}

struct DeadBranch {
    /// Values read by a listed value or an output before the pass.
    used: Vec<bool>,
    /// The value replacing each value (`proj`s of removed regions, decided `select`s).
    map: Vec<Option<Value>>,
    /// For each removed `if`: the yields of its live arm.
    removed: Vec<Option<Vec<Value>>>,
    changes: usize,
    substituted: bool,
}

impl DeadBranch {
    /// The constant bool `v` stands for, if any.
    fn const_bool(&self, p: &Program, v: Value) -> Option<bool> {
        match p.exprs.get(resolve(&self.map, v).index()).map(|e| &e.op) {
            Some(Op::Const(ConstValue::Bool(b))) => Some(*b),
            _ => None,
        }
    }

    fn replace(&mut self, v: Value, by: Value) {
        self.map[v.index()] = Some(resolve(&self.map, by));
        self.substituted = true;
    }

    /// Rewrites one block (and the blocks nested in it) in evaluation order.
    fn block(&mut self, p: &mut Program, block: &mut Block) {
        let mut queue: VecDeque<Value> = std::mem::take(&mut block.body).into();
        let mut out = Vec::with_capacity(queue.len());
        while let Some(v) = queue.pop_front() {
            let i = v.index();
            let Some(e) = p.exprs.get(i) else {
                out.push(v);
                continue;
            };
            match &e.op {
                Op::If { cond, .. } => {
                    let c = self.const_bool(p, *cond);
                    match (c, &mut p.exprs[i].op) {
                        (Some(c), Op::If { then_, else_, .. }) => {
                            let arm = std::mem::take(if c { then_ } else { else_ });
                            // The arm's values are visited next, where the `if` stood.
                            for &a in arm.body.iter().rev() {
                                queue.push_front(a);
                            }
                            self.removed[i] = Some(arm.yields);
                            self.changes += 1;
                        }
                        _ => {
                            self.region(p, i);
                            out.push(v);
                        }
                    }
                }
                Op::Illuminance { .. } | Op::Loop { .. } => {
                    self.region(p, i);
                    out.push(v);
                }
                Op::Proj(r, k) => {
                    let (r, k) = (*r, *k as usize);
                    match self.removed.get(r.index()) {
                        Some(Some(yields)) => {
                            // A proj of a removed `if` leaves with it; its uses read the
                            // live arm's yield.
                            if let Some(&y) = yields.get(k) {
                                self.replace(v, y);
                            }
                        }
                        _ => out.push(v),
                    }
                }
                Op::Select { cond, a, b } => {
                    if let Some(c) = self.const_bool(p, *cond) {
                        let by = if c { *a } else { *b };
                        self.replace(v, by);
                        if self.used[i] {
                            self.changes += 1;
                        }
                    }
                    out.push(v);
                }
                _ => out.push(v),
            }
        }
        block.body = out;
    }

    /// Rewrites the blocks of the region `i`, kept in place.
    fn region(&mut self, p: &mut Program, i: usize) {
        p.rewrite_blocks(Value::new(i), |p, b| {
            self.block(p, b);
            0
        });
    }
}
