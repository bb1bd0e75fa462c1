//! Loops: `for`, `while` and `do … while` on the IR's loop region, with `break` and
//! `continue` (RSL's `break N` / `continue N` included) lowered to flags.
//!
//! A loop carries every outer variable its condition, step or body assigns (as the IR
//! loop's carried values, read in its blocks through `loop.var`). `break` and `continue`
//! become assignments of hidden bool variables, one pair per enclosing loop (`$break1`,
//! `$continue1`, … — names no program can write): the statements after one that may jump
//! run under an `if` that none of the innermost loop's flags is set, the step runs only
//! where the loop did not break, the condition is `!$break && cond`, and `$continue` starts
//! false in every iteration. So the region has one exit test, as the IR wants; a leaving
//! `break 2` sets the flags of both loops it leaves. The `do … while` loop carries a
//! `$first` flag that runs its body once before the condition counts.
//!
//! Rates: a carried variable is varying inside the loop unless it was declared `uniform`
//! (RSL's locals are varying by default) or is a flag; after the loop it is varying where
//! its value or the condition may vary, so a uniform variable assigned under a varying trip
//! count is refused as an `if` with a varying condition is.
//!
//! Owns the lowering of loops and jumps; the IR's loop semantics (the iteration limit) are
//! the IR's, not repeated here.

use super::{Lower, Ty, Val};
use crate::ast::{self, Expr, ForInit, Stmt, StmtKind};
use crate::source::Span;
use shadenet_graph::ir::{BinOp, Builder, UnOp, Value};
use std::cell::RefCell;
use std::collections::HashMap;

/// The hidden flag variables of one enclosing loop.
#[derive(Clone, Debug)]
pub(crate) struct LoopFlags {
    /// Set by a `break` that leaves this loop.
    pub(crate) brk: String,
    /// Set by a `continue` of this loop (reset in every iteration).
    pub(crate) cnt: String,
}

/// What a loop form gives [`Lower::lower_loop`].
struct LoopParts<'a> {
    cond: Option<&'a Expr>,
    step: &'a [Expr],
    body: &'a Stmt,
    do_while: bool,
}

/// Which flags of the loop around some statements they may set: those of loop `depth`
/// (0 = the outermost) when the statements sit inside `inner` further loops of their own.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Jumps {
    /// Some jump leaves the innermost enclosing loop.
    pub(crate) brk: bool,
    /// Some `continue` continues it.
    pub(crate) cnt: bool,
}

impl<'a> Lower<'a> {
    /// `for (init; cond; step) body`.
    pub(crate) fn for_stmt(
        &mut self,
        b: &mut Builder,
        init: &'a ForInit,
        cond: Option<&'a Expr>,
        step: &'a [Expr],
        body: &'a Stmt,
    ) {
        // The init's declarations live in a scope around the loop.
        self.scopes.push(HashMap::new());
        match init {
            ForInit::None => {}
            ForInit::Decl(d) => self.decl(b, d),
            ForInit::Exprs(es) => {
                for e in es {
                    self.expr(b, e);
                }
            }
        }
        let parts = LoopParts {
            cond,
            step,
            body,
            do_while: false,
        };
        self.lower_loop(b, parts);
        self.scopes.pop();
    }

    /// `while (cond) body`.
    pub(crate) fn while_stmt(&mut self, b: &mut Builder, cond: &'a Expr, body: &'a Stmt) {
        let parts = LoopParts {
            cond: Some(cond),
            step: &[],
            body,
            do_while: false,
        };
        self.lower_loop(b, parts);
    }

    /// `do body while (cond);`.
    pub(crate) fn do_while(&mut self, b: &mut Builder, body: &'a Stmt, cond: &'a Expr) {
        let parts = LoopParts {
            cond: Some(cond),
            step: &[],
            body,
            do_while: true,
        };
        self.lower_loop(b, parts);
    }

    /// `break N` / `continue N`: sets the flags of the loops it leaves or continues.
    pub(crate) fn jump(&mut self, b: &mut Builder, is_break: bool, levels: u32, span: Span) {
        let word = if is_break { "break" } else { "continue" };
        let depth = self.loops.len();
        if depth == 0 {
            let why = match self.in_illuminance {
                true => "inside an `illuminance` body, which runs once per light sample",
                false => "outside a loop",
            };
            self.error(format!("`{word}` {why}"), span, "no loop to leave");
            return;
        }
        let n = levels.max(1) as usize;
        if n > depth {
            self.error(
                format!("`{word} {n}` leaves {n} loops, but only {depth} enclose it"),
                span,
                "too many levels",
            );
            return;
        }
        let t = Self::known(b, true);
        // Every loop it leaves breaks; `continue N` continues the N-th.
        let leaves = if is_break { n } else { n - 1 };
        let flags: Vec<LoopFlags> = self.loops[depth - n..].to_vec();
        for (k, f) in flags.iter().rev().enumerate() {
            let name = if k < leaves { &f.brk } else { &f.cnt };
            self.set_flag(name, t.clone());
        }
    }

    /// Sets a hidden variable (a loop flag) where it is declared.
    pub(crate) fn set_flag(&mut self, name: &str, val: Val) {
        for scope in self.scopes.iter_mut().rev() {
            if let Some(v) = scope.get_mut(name) {
                v.val = val;
                return;
            }
        }
    }

    /// Whether `s` may leave or continue the innermost enclosing loop.
    pub(crate) fn may_jump(&self, s: &'a Stmt) -> bool {
        self.jumps(&[s]) != Jumps::default()
    }

    /// The flags of the innermost loop a statement list may set (see [`jumps_in`]).
    pub(crate) fn jumps(&self, stmts: &[&'a Stmt]) -> Jumps {
        let mut j = Jumps::default();
        for s in stmts {
            jumps_in(s, 0, &mut j);
        }
        j
    }

    /// `!($break || $continue)` of the innermost loop: whether the statements after a jump
    /// still run. `None` outside a loop.
    pub(crate) fn still_running(&mut self, b: &mut Builder) -> Option<(Value, bool)> {
        let f = self.loops.last()?.clone();
        let mut set: Option<(Value, bool)> = None;
        for name in [&f.brk, &f.cnt] {
            if let Some((v, varying)) = self.flag(name) {
                set = Some(match set {
                    None => (v, varying),
                    Some((s, vs)) => (b.binary(BinOp::Or, s, v), vs || varying),
                });
            }
        }
        let (s, varying) = set?;
        Some((b.unary(UnOp::Not, s), varying))
    }

    fn lower_loop(&mut self, b: &mut Builder, parts: LoopParts<'a>) {
        let mut closures = self.assigned_closures(&[parts.body]);
        if closures.is_empty() {
            let wrapped: Vec<Stmt> = parts
                .step
                .iter()
                .map(|e| Stmt {
                    kind: StmtKind::Expr(e.clone()),
                    span: e.span,
                })
                .collect();
            closures = self.assigned_closures(&wrapped.iter().collect::<Vec<_>>());
        }
        if let Some(c) = closures.first() {
            let form = (parts.cond, parts.step, parts.body, parts.do_while);
            self.unroll_closure_loop(b, form, c);
            return;
        }
        let depth = self.loops.len() + 1;
        let flags = LoopFlags {
            brk: format!("$break{depth}"),
            cnt: format!("$continue{depth}"),
        };
        let jumps = self.jumps(&[parts.body]);
        self.scopes.push(HashMap::new());
        let first = format!("$first{depth}");
        if jumps.brk {
            let f = Self::known(b, false);
            self.declare_hidden(&flags.brk, f);
        }
        if parts.do_while {
            let t = Self::known(b, true);
            self.declare_hidden(&first, t);
        }
        // What the loop carries: outer variables assigned anywhere in it, and its flags.
        self.loops.push(flags.clone());
        let mut names = self.assigned_outer(&[parts.body]);
        for n in self.assigned_in_exprs(parts.step) {
            if !names.iter().any(|(m, _)| m.name == n.0.name) {
                names.push(n);
            }
        }
        for hidden in [(jumps.brk, &flags.brk), (parts.do_while, &first)] {
            if hidden.0 && !names.iter().any(|(n, _)| n.name == *hidden.1) {
                let id = ast::Ident {
                    name: hidden.1.clone(),
                    span: parts.body.span,
                };
                names.push((id, Ty::Bool));
            }
        }
        let init = self.current(b, &names);
        // Inside the loop a carried variable varies unless declared uniform (or a flag).
        let inside: Vec<bool> = names
            .iter()
            .map(|(n, _)| match self.lookup(&n.name) {
                Some(v) if n.name.starts_with('$') || v.uniform => {
                    matches!(v.val, Val::V { varying: true, .. })
                }
                _ => true,
            })
            .collect();
        let uniform: Vec<bool> = names
            .iter()
            .map(|(n, _)| self.lookup(&n.name).is_some_and(|v| v.uniform))
            .collect();
        let saved = self.snapshot(&names);
        // Whether the condition varies, and each carried value at the body's end.
        let cond_varying = RefCell::new(false);
        let yields_varying = RefCell::new(vec![false; names.len()]);
        let me = RefCell::new(&mut *self);
        let results = b.loop_(
            &init,
            |b, vars| {
                let mut me = me.borrow_mut();
                me.bind(&names, vars, &inside);
                let (c, vc) = me.loop_cond(b, &parts, &flags, &first);
                *cond_varying.borrow_mut() = vc;
                c
            },
            |b, vars| {
                let mut me = me.borrow_mut();
                me.bind(&names, vars, &inside);
                me.loop_body(b, &parts, &flags, jumps, &first);
                let out = me.current(b, &names);
                for ((n, _), vy) in names.iter().zip(yields_varying.borrow_mut().iter_mut()) {
                    *vy = matches!(
                        me.lookup(&n.name).map(|v| &v.val),
                        Some(Val::V { varying: true, .. })
                    );
                }
                out
            },
        );
        self.restore(&names, saved);
        self.loops.pop();
        let cond_varying = cond_varying.into_inner();
        let yields_varying = yields_varying.into_inner();
        for (k, ((n, ty), v)) in names.iter().zip(results).enumerate() {
            let val = Val::V {
                v,
                ty: *ty,
                varying: cond_varying || yields_varying[k] || inside[k],
            };
            if n.name.starts_with('$') {
                self.set_flag(&n.name, val);
            } else {
                self.rebind(n, val, uniform[k], n.span);
            }
        }
        self.scopes.pop();
    }

    /// A bool known at compile time, as a value.
    fn known(b: &mut Builder, x: bool) -> Val {
        Val::V {
            v: b.boolean(x),
            ty: Ty::Bool,
            varying: false,
        }
    }

    /// The current value of a hidden flag and whether it varies; `None` where the flag is not
    /// declared (its loop has no such jump).
    fn flag(&self, name: &str) -> Option<(Value, bool)> {
        match self.lookup(name).map(|v| &v.val) {
            Some(Val::V { v, varying, .. }) => Some((*v, *varying)),
            _ => None,
        }
    }

    /// Declares a hidden variable (a loop flag; with the globals, the trace's and the
    /// messages' variables) in the current scope.
    pub(crate) fn declare_hidden(&mut self, name: &str, val: Val) {
        let scope = self.scopes.last_mut().expect("a scope");
        let var = super::Var {
            val,
            uniform: false,
            decl: None,
        };
        scope.insert(name.to_string(), var);
    }

    /// Binds carried variables to the loop's current values.
    fn bind(&mut self, names: &[(ast::Ident, Ty)], vars: &[Value], varying: &[bool]) {
        for (((n, ty), v), vy) in names.iter().zip(vars).zip(varying) {
            let val = Val::V {
                v: *v,
                ty: *ty,
                varying: *vy,
            };
            self.set_flag(&n.name, val);
        }
    }

    /// The condition block: `!$break && (cond)`, or `$first || …` for `do … while`.
    fn loop_cond(
        &mut self,
        b: &mut Builder,
        parts: &LoopParts<'a>,
        flags: &LoopFlags,
        first: &str,
    ) -> (Value, bool) {
        let (mut c, mut vc) = match parts.cond {
            None => (b.boolean(true), false),
            Some(e) => {
                let (c, t, vc) = self.condition(b, e);
                if t != Ty::Bool {
                    self.error(
                        format!("a loop condition must be a comparison, not a {}", t.name()),
                        e.span,
                        "here",
                    );
                    return (b.boolean(false), false);
                }
                (c, vc)
            }
        };
        if parts.do_while
            && let Some((f, vf)) = self.flag(first)
        {
            c = b.binary(BinOp::Or, f, c);
            vc |= vf;
        }
        if let Some((brk, vb)) = self.flag(&flags.brk) {
            let go = b.unary(UnOp::Not, brk);
            c = b.binary(BinOp::And, go, c);
            vc |= vb;
        }
        (c, vc)
    }

    /// The body block: `$continue` reset, the body, then the step where it did not break.
    fn loop_body(
        &mut self,
        b: &mut Builder,
        parts: &LoopParts<'a>,
        flags: &LoopFlags,
        jumps: Jumps,
        first: &str,
    ) {
        self.scopes.push(HashMap::new());
        if jumps.cnt {
            let f = Self::known(b, false);
            self.declare_hidden(&flags.cnt, f);
        }
        if parts.do_while {
            let f = Self::known(b, false);
            self.set_flag(first, f);
        }
        self.stmt(b, parts.body);
        if !parts.step.is_empty() {
            match self.flag(&flags.brk) {
                None => {
                    for e in parts.step {
                        self.expr(b, e);
                    }
                }
                Some((brk, vb)) => {
                    let go = b.unary(UnOp::Not, brk);
                    self.guarded_exprs(b, go, vb, parts.step);
                }
            }
        }
        self.scopes.pop();
    }
}

/// Adds to `j` what `s` may do to the loop around it, from inside `inner` loops of its own.
fn jumps_in(s: &Stmt, inner: u32, j: &mut Jumps) {
    match &s.kind {
        StmtKind::Break { levels } if *levels.max(&1) > inner => j.brk = true,
        StmtKind::Continue { levels } => {
            let n = *levels.max(&1);
            if n == inner + 1 {
                j.cnt = true;
            } else if n > inner + 1 {
                j.brk = true;
            }
        }
        StmtKind::Block(b) => b.stmts.iter().for_each(|s| jumps_in(s, inner, j)),
        StmtKind::If { then, els, .. } => {
            jumps_in(then, inner, j);
            if let Some(e) = els {
                jumps_in(e, inner, j);
            }
        }
        StmtKind::For { body, .. }
        | StmtKind::While { body, .. }
        | StmtKind::DoWhile { body, .. } => jumps_in(body, inner + 1, j),
        // A light loop's body cannot jump out of it (refused where the jump is lowered).
        _ => {}
    }
}
