//! Loops that assign closures, unrolled while lowering. A closure is a lobe list built at
//! compile time, so the IR's loop region cannot carry one; a loop whose trip count is a
//! compile-time constant (its condition folds to a constant in every iteration without
//! reading a parameter, which a scene may change after compiling) is lowered as its
//! iterations one after another, at most [`MAX_TRIPS`] of them. Any other loop that assigns
//! a closure is an error that says why. Owns this decision only; loops of values are
//! [`super::loops`]'.

use super::stmt::has_jump;
use super::{Lower, Ty};
use crate::ast::{Expr, Stmt};
use shadenet_graph::ConstValue;
use shadenet_graph::ir::{Builder, Program, Value};
use std::collections::HashMap;

/// The most iterations a closure-assigning loop is unrolled to (the optimizer's unroll
/// budget of trips).
pub(crate) const MAX_TRIPS: usize = 64;

impl<'a> Lower<'a> {
    /// Lowers a loop that assigns closures (`cond` absent: forever) by unrolling it; the
    /// error names the closure `what` and why the loop cannot be unrolled.
    pub(crate) fn unroll_closure_loop(
        &mut self,
        b: &mut Builder,
        (cond, step, body, do_while): (Option<&'a Expr>, &'a [Expr], &'a Stmt, bool),
        what: &crate::ast::Ident,
    ) {
        let refuse = |me: &mut Self, why: &str| {
            me.error(
                format!(
                    "closure `{}` is assigned inside a loop that cannot be unrolled: {why} (closures are lobe lists built while compiling)",
                    what.name
                ),
                what.span,
                "assigned in a loop",
            );
        };
        if has_jump(body) {
            return refuse(self, "it has `break` or `continue`");
        }
        let Some(cond) = cond else {
            return refuse(self, "it has no condition");
        };
        for trip in 0..=MAX_TRIPS {
            if !(do_while && trip == 0) {
                let (c, t, _) = self.condition(b, cond);
                if t != Ty::Bool {
                    return refuse(self, "its condition is not a comparison");
                }
                match known(b.program(), c) {
                    Some(true) => {}
                    Some(false) => return,
                    None => {
                        return refuse(
                            self,
                            "its trip count is not a compile-time constant (it reads a parameter or a varying value)",
                        );
                    }
                }
            }
            if trip == MAX_TRIPS {
                return refuse(self, &format!("it runs more than {MAX_TRIPS} times"));
            }
            self.scopes.push(HashMap::new());
            self.stmt(b, body);
            self.scopes.pop();
            for e in step {
                self.expr(b, e);
            }
            if self.stopped() {
                return;
            }
        }
    }
}

/// The constant truth of condition `c`, where it reads no parameter (nor anything varying).
pub(crate) fn known(p: &Program, c: Value) -> Option<bool> {
    if super::reads_param(p, c) {
        return None;
    }
    match shadenet_graph::opt::fold::constant(p, c)? {
        ConstValue::Bool(t) => Some(t),
        _ => None,
    }
}
