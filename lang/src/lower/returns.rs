//! `return` before the end of an inlined function, lowered as `break` is: the function gets
//! two hidden variables, `$ret` (whether it has returned) and `$retval` (what it returned);
//! `return e` assigns both, the statements after one that may return run under an `if`
//! that it did not, and the call's value is `$retval` at the end. A `return` inside a loop
//! of the function is an error that says it is not built; so is an early return from a
//! function whose result is a closure or a struct (those are not values a region carries).
//! Owns the lowering of returns; calls are [`super::stmt`]'s.

use super::{Lower, Ty, Val, Var};
use crate::ast::{Expr, Stmt, StmtKind};
use crate::source::Span;
use shadenet_graph::ir::{Builder, UnOp, Value};

/// The hidden flag: the function has returned.
pub(crate) const RETURNED: &str = "$ret";
/// The hidden variable holding the value returned.
pub(crate) const RETVAL: &str = "$retval";

/// An inlined function that returns early: its result type (`None`: `void`, or a struct).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Returns<'a> {
    /// The type `return e` converts `e` to.
    pub(crate) ty: Option<Ty>,
    /// The struct type returned, where it is one (`$retval` is then a struct variable).
    pub(crate) structure: Option<&'a crate::ast::StructDef>,
}

/// Whether `s` holds a `return` at any depth (functions are not nested).
pub(crate) fn has_return(s: &Stmt) -> bool {
    match &s.kind {
        StmtKind::Return(_) => true,
        StmtKind::Block(b) => b.stmts.iter().any(has_return),
        StmtKind::If { then, els, .. } => {
            has_return(then) || els.as_deref().is_some_and(has_return)
        }
        StmtKind::For { body, .. }
        | StmtKind::While { body, .. }
        | StmtKind::DoWhile { body, .. } => has_return(body),
        _ => false,
    }
}

impl<'a> Lower<'a> {
    /// Binds the hidden return variables of a function returning `ty` (`None`: `void`) or
    /// the struct `structure`.
    pub(crate) fn begin_returns(
        &mut self,
        b: &mut Builder,
        ty: Option<Ty>,
        structure: Option<&'a crate::ast::StructDef>,
    ) {
        let scope = self.scopes.last_mut().expect("a scope");
        let no = Val::V {
            v: b.boolean(false),
            ty: Ty::Bool,
            varying: false,
        };
        scope.insert(RETURNED.to_string(), hidden(no));
        let val = Self::poison(b, ty.unwrap_or(Ty::Float));
        scope.insert(RETVAL.to_string(), hidden(val));
        if let Some(def) = structure {
            let zero = self.struct_zero(b, def, 0);
            let id = crate::ast::Ident {
                name: RETVAL.to_string(),
                span: def.span,
            };
            self.bind_struct(&id, def, zero, false);
        }
        self.returns = Some(Returns { ty, structure });
    }

    /// `return e;` / `return;` inside a function that returns early.
    pub(crate) fn return_stmt(&mut self, b: &mut Builder, e: Option<&'a Expr>, span: Span) {
        let Some(r) = self.returns else {
            self.error(
                "`return` outside a function (or from a function whose result is a closure or struct before its end: not built yet)",
                span,
                "here",
            );
            return;
        };
        if !self.loops.is_empty() {
            self.error(
                "`return` inside a loop is not built yet: leave the loop with `break`, then return",
                span,
                "in a loop",
            );
            return;
        }
        if let (Some(ty), Some(e)) = (r.ty, e) {
            let v = self.expr_as(b, e, ty);
            self.set_flag(RETVAL, v);
        }
        if let (Some(def), Some(e)) = (r.structure, e) {
            let v = self.expr_for_struct(b, e, def);
            if !matches!(&v, Val::Struct(n, _) if *n == def.name.name) {
                self.error(
                    format!("this function returns a `{}`", def.name.name),
                    e.span,
                    "not one",
                );
            } else {
                let id = crate::ast::Ident {
                    name: RETVAL.to_string(),
                    span: e.span,
                };
                self.store(&id, v, e.span);
            }
        }
        let yes = Val::V {
            v: b.boolean(true),
            ty: Ty::Bool,
            varying: false,
        };
        self.set_flag(RETURNED, yes);
    }

    /// `!$ret` and whether it varies, where the function returns early; `None` otherwise.
    pub(crate) fn not_returned(&mut self, b: &mut Builder) -> Option<(Value, bool)> {
        self.returns?;
        match self.lookup(RETURNED).map(|v| v.val.clone()) {
            Some(Val::V { v, varying, .. }) => Some((b.unary(UnOp::Not, v), varying)),
            _ => None,
        }
    }

    /// The hidden return variables, for the regions around statements that may return.
    pub(crate) fn return_names(&self, span: Span) -> Vec<crate::ast::Ident> {
        [RETURNED, RETVAL]
            .iter()
            .map(|n| crate::ast::Ident {
                name: n.to_string(),
                span,
            })
            .collect()
    }
}

fn hidden(val: Val) -> Var {
    Var {
        val,
        uniform: false,
        decl: None,
    }
}
