//! Walks over the syntax tree: every expression of a statement or an expression, nested
//! ones included, in source order. Shared by the lowering's analyses (what a statement
//! assigns, what the file's functions write); it must not lower anything.

use crate::ast::{self, Expr, ExprKind, Stmt, StmtKind};

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
