//! Walks over the syntax tree: every expression of a statement or an expression, nested
//! ones included, in source order. Shared by the lowering's analyses (what a statement
//! assigns, whether it traces or sets a message); it must not lower anything.

use super::Lower;
use crate::ast::{self, Expr, ExprKind, Stmt, StmtKind};
use std::collections::{HashMap, HashSet};

/// The user functions of an OSL file that call `builtin` (`trace`, `setmessage`: calls
/// whose effect reaches past the statement), directly or through the functions they call:
/// a fixpoint over the call graph (each pass adds the callers of what it knows). Computed
/// once per file, so that asking it of a statement never walks the call graph again.
pub(crate) fn functions_calling<'a>(
    dialect: crate::Dialect,
    functions: &HashMap<&'a str, Vec<&'a ast::FunctionDef>>,
    builtin: &str,
) -> HashSet<&'a str> {
    let mut set = HashSet::new();
    if dialect != crate::Dialect::Osl {
        return set;
    }
    loop {
        let before = set.len();
        for (name, defs) in functions {
            if set.contains(name) {
                continue;
            }
            let mut calls = false;
            for s in defs.iter().flat_map(|f| &f.body.stmts) {
                walk_stmt(s, &mut |e| {
                    if let ExprKind::Call { callee, .. } = &e.kind {
                        let c = callee.name.as_str();
                        calls |= if functions.contains_key(c) {
                            set.contains(c)
                        } else {
                            c == builtin
                        };
                    }
                });
            }
            if calls {
                set.insert(*name);
            }
        }
        if set.len() == before {
            return set;
        }
    }
}

impl<'a> Lower<'a> {
    /// Whether any of `stmts` calls OSL's `builtin`, itself or through a user function of
    /// `callers` (its [`functions_calling`] set).
    pub(crate) fn stmts_call(
        &self,
        stmts: &[&'a Stmt],
        builtin: &str,
        callers: &HashSet<String>,
    ) -> bool {
        if self.dialect != crate::Dialect::Osl {
            return false;
        }
        let mut found = false;
        for s in stmts {
            walk_stmt(s, &mut |e| {
                if let ExprKind::Call { callee, .. } = &e.kind {
                    let c = callee.name.as_str();
                    found |= if self.functions.contains_key(c) {
                        callers.contains(c)
                    } else {
                        c == builtin
                    };
                }
            });
        }
        found
    }
}

/// Calls `f` on every expression of `s`, nested ones included.
pub(crate) fn walk_stmt<'s>(s: &'s Stmt, f: &mut dyn FnMut(&'s Expr)) {
    match &s.kind {
        StmtKind::Block(b) => b.stmts.iter().for_each(|s| walk_stmt(s, f)),
        StmtKind::Decl(d) => d
            .vars
            .iter()
            .filter_map(|v| v.init.as_ref())
            .for_each(|e| walk_expr(e, f)),
        StmtKind::Expr(e) => walk_expr(e, f),
        StmtKind::If { cond, then, els } => {
            walk_expr(cond, f);
            walk_stmt(then, f);
            if let Some(e) = els {
                walk_stmt(e, f);
            }
        }
        StmtKind::Illuminance { args, body, .. }
        | StmtKind::Illuminate { args, body }
        | StmtKind::Solar { args, body } => {
            args.iter().for_each(|e| walk_expr(e, f));
            walk_stmt(body, f);
        }
        StmtKind::For {
            init,
            cond,
            step,
            body,
        } => {
            match init {
                ast::ForInit::None => {}
                ast::ForInit::Decl(d) => d
                    .vars
                    .iter()
                    .filter_map(|v| v.init.as_ref())
                    .for_each(|e| walk_expr(e, f)),
                ast::ForInit::Exprs(es) => es.iter().for_each(|e| walk_expr(e, f)),
            }
            cond.iter().chain(step).for_each(|e| walk_expr(e, f));
            walk_stmt(body, f);
        }
        StmtKind::While { cond, body } | StmtKind::DoWhile { body, cond } => {
            walk_expr(cond, f);
            walk_stmt(body, f);
        }
        StmtKind::Return(Some(e)) => walk_expr(e, f),
        _ => {}
    }
}

/// Calls `f` on `e` and every expression inside it.
pub(crate) fn walk_expr<'s>(e: &'s Expr, f: &mut dyn FnMut(&'s Expr)) {
    f(e);
    match &e.kind {
        ExprKind::Call { args, .. } | ExprKind::Tuple(args) | ExprKind::InitList(args) => {
            args.iter().for_each(|a| walk_expr(a, f))
        }
        ExprKind::Construct { args, .. } => args.iter().for_each(|a| walk_expr(a, f)),
        ExprKind::Cast { expr, .. } => walk_expr(expr, f),
        ExprKind::Unary { operand, .. } => walk_expr(operand, f),
        ExprKind::Binary { lhs, rhs, .. } => {
            walk_expr(lhs, f);
            walk_expr(rhs, f);
        }
        ExprKind::Ternary { cond, then, els } => {
            walk_expr(cond, f);
            walk_expr(then, f);
            walk_expr(els, f);
        }
        ExprKind::Assign { target, value, .. } => {
            walk_expr(target, f);
            walk_expr(value, f);
        }
        ExprKind::IncDec { target, .. } => walk_expr(target, f),
        ExprKind::Index { base, index } => {
            walk_expr(base, f);
            walk_expr(index, f);
        }
        ExprKind::Member { base, .. } => walk_expr(base, f),
        _ => {}
    }
}
