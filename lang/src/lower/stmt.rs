//! Statements: declarations, expression statements, blocks, `if` (an IR `if` region
//! yielding every outer variable its branches assign), `illuminance` (the IR's light loop:
//! the body's contributions to outer variables are summed over the light samples), and
//! user functions, inlined at each call.

use super::walk::{walk_expr, walk_stmt};
use super::{Lower, MAX_INLINE_DEPTH, Ty, Val, Var};
use crate::ast::{self, AssignOp, Expr, ExprKind, Stmt, StmtKind};
use crate::source::Span;
use shadenet_graph::ir::{Builder, Value};
use std::cell::RefCell;
use std::collections::HashMap;

impl<'a> Lower<'a> {
    /// The statements of a block, in a scope of their own. Inside a loop, the statements
    /// after one that may `break` or `continue` run under an `if` that it did not.
    pub(crate) fn block(&mut self, b: &mut Builder, block: &'a ast::Block) {
        self.scopes.push(HashMap::new());
        self.stmts(b, &block.stmts.iter().collect::<Vec<_>>());
        self.scopes.pop();
    }

    /// Statements in the current scope (see [`Lower::block`]).
    fn stmts(&mut self, b: &mut Builder, stmts: &[&'a Stmt]) {
        for (i, s) in stmts.iter().enumerate() {
            if self.stopped() {
                break;
            }
            self.stmt(b, s);
            let rest = &stmts[i + 1..];
            if !rest.is_empty()
                && self.returns.is_some()
                && super::returns::has_return(s)
                && let Some((go, varying)) = self.not_returned(b)
            {
                let names = self.assigned_outer(rest);
                self.guarded(b, go, varying, &names, &mut |me, b| me.stmts(b, rest));
                break;
            }
            if rest.is_empty() || self.loops.is_empty() || !self.may_jump(s) {
                continue;
            }
            if let Some((go, varying)) = self.still_running(b) {
                let names = self.assigned_outer(rest);
                self.guarded(b, go, varying, &names, &mut |me, b| me.stmts(b, rest));
            }
            break;
        }
    }

    /// One statement.
    pub(crate) fn stmt(&mut self, b: &mut Builder, s: &'a Stmt) {
        match &s.kind {
            StmtKind::Block(block) => self.block(b, block),
            StmtKind::Decl(d) => self.decl(b, d),
            StmtKind::Expr(e) => {
                self.expr(b, e);
            }
            StmtKind::Empty => {}
            StmtKind::If { cond, then, els } => self.if_stmt(b, cond, then, els.as_deref()),
            StmtKind::Illuminance {
                category,
                args,
                body,
            } => {
                // No jump leaves a light loop's body.
                let outer = std::mem::take(&mut self.loops);
                self.illuminance(b, category.as_ref(), args, body, s.span);
                self.loops = outer;
            }
            StmtKind::For {
                init,
                cond,
                step,
                body,
            } => {
                cond.iter().for_each(|c| self.loop_cond_pure(c));
                self.for_stmt(b, init, cond.as_ref(), step, body)
            }
            StmtKind::While { cond, body } => {
                self.loop_cond_pure(cond);
                self.while_stmt(b, cond, body)
            }
            StmtKind::DoWhile { body, cond } => {
                self.loop_cond_pure(cond);
                self.do_while(b, body, cond)
            }
            StmtKind::Break { levels } => self.jump(b, true, *levels, s.span),
            StmtKind::Continue { levels } => self.jump(b, false, *levels, s.span),
            StmtKind::Return(e) => self.return_stmt(b, e.as_ref(), s.span),
            StmtKind::Illuminate { .. } | StmtKind::Solar { .. } => self.error(
                "`illuminate` and `solar` belong at the top level of a light shader's body",
                s.span,
                "not here",
            ),
        }
    }

    /// A loop's condition runs in the loop's condition block, which yields only the test:
    /// an assignment there is refused.
    fn loop_cond_pure(&mut self, cond: &Expr) {
        if let Some(at) = assignment_in(cond) {
            self.error(
                "assignments in a loop's condition are not built; assign in its body",
                at,
                "assignment",
            );
        }
    }

    pub(crate) fn decl(&mut self, b: &mut Builder, d: &'a ast::Decl) {
        if d.ty.closure.is_some() && self.dialect == crate::Dialect::Osl {
            self.closure_decl(b, d);
            return;
        }
        if let ast::BaseType::Struct(name) = &d.ty.base
            && let Some(def) = self.struct_def(&name.name)
        {
            for v in &d.vars {
                self.struct_decl(b, def, v);
            }
            return;
        }
        if d.ty.base == ast::BaseType::String && self.dialect == crate::Dialect::Osl {
            self.string_decl(b, d);
            return;
        }
        let Some(ty) = self.declared_type(&d.ty) else {
            return;
        };
        let uniform = matches!(d.ty.rate, Some((ast::Rate::Uniform, _)));
        for v in &d.vars {
            if let Some(a) = &v.array {
                if let Some(len) = self.array_len(a, v.init.as_ref()) {
                    self.declare_array(b, &v.name, (ty, len), v.init.as_ref(), uniform);
                }
                continue;
            }
            let val = match &v.init {
                Some(e) => self.expr_as(b, e, ty),
                None => Self::poison(b, ty),
            };
            if uniform && matches!(val, Val::V { varying: true, .. }) {
                self.error(
                    format!(
                        "uniform variable `{}` is initialised with a varying value",
                        v.name.name
                    ),
                    v.span,
                    "varying value",
                );
            }
            self.declare(&v.name, val, uniform);
        }
    }

    /// `string s [= x], …;`: string variables, compile-time values like every string here
    /// (`""` until assigned).
    fn string_decl(&mut self, b: &mut Builder, d: &'a ast::Decl) {
        for v in &d.vars {
            if let Some(a) = &v.array {
                self.error("arrays of strings are not built yet", a.span, "an array");
                continue;
            }
            let val = match &v.init {
                None => Val::Str(String::new()),
                Some(e) => match self.expr(b, e) {
                    s @ Val::Str(_) => s,
                    other => {
                        self.error(
                            format!(
                                "`{}` is a string: not {}",
                                v.name.name,
                                super::an(other.type_name())
                            ),
                            e.span,
                            "not a string",
                        );
                        Val::Str(String::new())
                    }
                },
            };
            self.declare(&v.name, val, true);
        }
    }

    /// `closure color c [= x], …;`: closure variables, empty or holding `x` (a closure or 0).
    fn closure_decl(&mut self, b: &mut Builder, d: &'a ast::Decl) {
        for v in &d.vars {
            if let Some(a) = &v.array {
                self.error("arrays are not built yet (issue 21)", a.span, "an array");
                continue;
            }
            let val = match &v.init {
                None => Val::Closure(Box::default()),
                Some(e) => {
                    let x = self.expr(b, e);
                    match x {
                        Val::Closure(_) => x,
                        _ if Self::closure_or_zero(b, &x) => Val::Closure(Box::default()),
                        _ => {
                            self.error(
                                format!("`{}` is a closure: it takes a closure or 0", v.name.name),
                                e.span,
                                "not a closure",
                            );
                            Val::Closure(Box::default())
                        }
                    }
                }
            };
            self.declare(&v.name, val, false);
        }
    }

    /// The variables `stmts` assign that hold compile-time things — closures (lobe lists)
    /// and strings — visible here (array elements and struct fields by their hidden
    /// names). A region cannot carry them: an `if` assigning one is lowered flat
    /// ([`Lower::flat_if`]), a loop unrolled.
    pub(crate) fn assigned_closures(&self, stmts: &[&'a Stmt]) -> Vec<ast::Ident> {
        self.assigned_places(stmts)
            .into_iter()
            .filter(|n| {
                matches!(
                    self.lookup(&n.name).map(|v| &v.val),
                    Some(Val::Closure(_) | Val::Str(_))
                )
            })
            .collect()
    }

    /// The outer variables `stmts` assign, in order of first assignment, that are visible
    /// here (the values an `if`, `illuminance` or loop region must yield); where they hold a
    /// `break` or `continue`, the enclosing loops' flags too.
    pub(crate) fn assigned_outer(&self, stmts: &[&'a Stmt]) -> Vec<(ast::Ident, Ty)> {
        self.assigned_places(stmts)
            .into_iter()
            .filter_map(|n| match self.lookup(&n.name) {
                Some(Var {
                    val: Val::V { ty, .. },
                    ..
                }) => Some((n, *ty)),
                _ => None,
            })
            .collect()
    }

    /// Each user function's own writes — every name its statements assign, a superset of
    /// the globals it writes, which costs nothing (a region yields only the variables
    /// visible around it) — and the user functions it calls. `FileFacts::of` closes the
    /// writes over the calls.
    #[allow(clippy::type_complexity)]
    pub(crate) fn function_writes(
        &self,
    ) -> (HashMap<String, Vec<String>>, Vec<(String, Vec<String>)>) {
        let mut writes = HashMap::new();
        let mut calls = Vec::new();
        for (name, defs) in &self.functions {
            let stmts: Vec<&'a Stmt> = defs.iter().flat_map(|f| &f.body.stmts).collect();
            let mut names: Vec<String> = self
                .assigned_places(&stmts)
                .into_iter()
                .map(|n| n.name)
                .collect();
            names.sort();
            names.dedup();
            writes.insert(name.to_string(), names);
            let mut callees: Vec<String> = Vec::new();
            for s in &stmts {
                walk_stmt(s, &mut |e| {
                    if let ExprKind::Call { callee, .. } = &e.kind
                        && self.functions.contains_key(callee.name.as_str())
                        && !callees.contains(&callee.name)
                    {
                        callees.push(callee.name.clone());
                    }
                });
            }
            calls.push((name.to_string(), callees));
        }
        (writes, calls)
    }

    /// Every variable `stmts` may assign (arrays and structs expanded to their hidden
    /// variables), with the return and loop flags they may set.
    pub(crate) fn assigned_places(&self, stmts: &[&'a Stmt]) -> Vec<ast::Ident> {
        let mut names: Vec<ast::Ident> = Vec::new();
        for s in stmts {
            walk_stmt(s, &mut |e| {
                let targets = match &e.kind {
                    ExprKind::Assign { target, .. } | ExprKind::IncDec { target, .. } => {
                        vec![&**target]
                    }
                    ExprKind::Call { callee, args } => {
                        // What the call writes beyond its output arguments: a user
                        // function's globals, the hidden variables of OSL's `trace` and
                        // `setmessage`.
                        for w in self.hidden_writes(&callee.name, e.span) {
                            if !names.iter().any(|n| n.name == w.name) {
                                names.push(w);
                            }
                        }
                        self.output_args(&callee.name, args)
                    }
                    _ => return,
                };
                for target in targets {
                    // The variable an assignment changes: `x`, `a[i]`, `s.f`, `s.f[i]`.
                    let mut t = &target.kind;
                    if let ExprKind::Index { base, .. } = t {
                        t = &base.kind;
                    }
                    let Some(mut id) = super::structs::place_of(t).or_else(|| indexed(t)) else {
                        continue;
                    };
                    // `v.x` of a triple variable changes `v`.
                    if self.lookup(&id.name).is_none()
                        && let ExprKind::Member { base, .. } = t
                        && let Some(v) = super::structs::place(base)
                    {
                        id = v;
                    }
                    if !names.iter().any(|n| n.name == id.name) {
                        names.push(id);
                    }
                }
            });
        }
        if self.returns.is_some()
            && let Some(first) = stmts.iter().find(|s| super::returns::has_return(s))
        {
            names.extend(self.return_names(first.span));
        }
        // A `setmessage` (or a function that calls one) may set every message.
        if let Some(all) = names
            .iter()
            .find(|n| n.name == super::messages::ALL_MESSAGES)
        {
            names.extend(self.message_vars(all.span));
        }
        if let Some(first) = stmts.iter().find(|s| has_jump(s)) {
            for f in &self.loops {
                for name in [&f.brk, &f.cnt] {
                    names.push(ast::Ident {
                        name: name.to_string(),
                        span: first.span,
                    });
                }
            }
        }
        // An array or a struct stands for its hidden variables.
        names.into_iter().flat_map(|n| self.expand(n)).collect()
    }

    /// What a call of `callee` assigns besides its arguments: the names a user function
    /// writes ([`super::FileFacts::globals_written`]: its globals, through the functions it
    /// calls too), `trace`'s hidden variables, and for `setmessage`
    /// [`super::messages::ALL_MESSAGES`], which stands for every message's.
    fn hidden_writes(&self, callee: &str, span: Span) -> Vec<ast::Ident> {
        let ident = |name: &str| ast::Ident {
            name: name.to_string(),
            span,
        };
        if self.functions.contains_key(callee) {
            let written = self.facts.globals_written.get(callee);
            return written.into_iter().flatten().map(|n| ident(n)).collect();
        }
        match (self.dialect, callee) {
            (crate::Dialect::Osl, "trace") => super::probe::trace_vars(span),
            (crate::Dialect::Osl, "setmessage") => vec![ident(super::messages::ALL_MESSAGES)],
            _ => Vec::new(),
        }
    }

    /// The arguments of a call of `callee` that it may assign: those passed for an
    /// `output` parameter of any of the user function's overloads that take as many, and
    /// the builtins' output arguments (`getattribute`'s, `getmessage`'s and `getmatrix`'s
    /// last, `sincos`'s two, `fresnel`'s after the third, `texture`'s and `environment`'s
    /// `"alpha"` value).
    fn output_args<'e>(&self, callee: &str, args: &'e [Expr]) -> Vec<&'e Expr> {
        let mut out: Vec<&Expr> = Vec::new();
        if let Some(defs) = self.functions.get(callee) {
            for f in defs.iter().filter(|f| f.params.len() == args.len()) {
                for (p, a) in f.params.iter().zip(args) {
                    if p.ty.output.is_some() && !out.iter().any(|o| std::ptr::eq(*o, a)) {
                        out.push(a);
                    }
                }
            }
        } else if self.dialect == crate::Dialect::Osl {
            match callee {
                "getattribute" | "getmessage" | "getmatrix" | "gettextureinfo" => {
                    out.extend(args.last())
                }
                "sincos" => out.extend(args.iter().skip(1)),
                "fresnel" => out.extend(args.iter().skip(3)),
                "texture" | "environment" => {
                    // The value after an `"alpha"` token among the options.
                    let first = if callee == "texture" { 3 } else { 2 };
                    let alpha = args
                        .iter()
                        .skip(first)
                        .step_by(2)
                        .position(|a| matches!(&a.kind, ExprKind::Str(s) if s == "alpha"));
                    out.extend(alpha.and_then(|k| args.get(first + 2 * k + 1)));
                }
                _ => {}
            }
        } else if callee == "getmatrix" {
            out.extend(args.last());
        } else if callee == "fresnel" {
            out.extend(args.iter().skip(3));
        }
        out
    }

    /// The plain variables that variable `n` is: itself, or an array's elements and a
    /// struct's fields, expanded in turn.
    pub(crate) fn expand(&self, n: ast::Ident) -> Vec<ast::Ident> {
        let parts: Vec<String> = match self.lookup(&n.name).map(|v| &v.val) {
            Some(Val::ArrayVar { len, .. }) => {
                (0..*len).map(|k| super::element(&n.name, k)).collect()
            }
            Some(Val::StructVar(s)) => match self.struct_def(s) {
                Some(def) => def
                    .fields
                    .iter()
                    .flat_map(|d| d.vars.iter())
                    .map(|v| super::structs::field(&n.name, &v.name.name))
                    .collect(),
                None => Vec::new(),
            },
            _ => return vec![n],
        };
        parts
            .into_iter()
            .flat_map(|name| self.expand(ast::Ident { name, span: n.span }))
            .collect()
    }

    /// The current values of `names`, for a region's yields.
    pub(crate) fn current(&self, b: &mut Builder, names: &[(ast::Ident, Ty)]) -> Vec<Value> {
        names
            .iter()
            .map(|(n, ty)| match self.lookup(&n.name).map(|v| &v.val) {
                Some(Val::V { v, .. }) => *v,
                _ => b.zero(ty.ir()),
            })
            .collect()
    }

    pub(crate) fn snapshot(&self, names: &[(ast::Ident, Ty)]) -> Vec<Option<Var>> {
        names
            .iter()
            .map(|(n, _)| self.lookup(&n.name).cloned())
            .collect()
    }

    pub(crate) fn restore(&mut self, names: &[(ast::Ident, Ty)], saved: Vec<Option<Var>>) {
        let ids: Vec<ast::Ident> = names.iter().map(|(n, _)| n.clone()).collect();
        self.put_back(&ids, &saved);
    }

    /// One arm of an `if`: lowered from the values before the `if`, yielding `names`' values
    /// at its end; the variables are then put back for the other arm.
    fn arm(
        &mut self,
        b: &mut Builder,
        run: &mut dyn FnMut(&mut Self, &mut Builder),
        names: &[(ast::Ident, Ty)],
    ) -> (Vec<Value>, bool) {
        let saved = self.snapshot(names);
        self.scopes.push(HashMap::new());
        run(self, b);
        self.scopes.pop();
        let out = self.current(b, names);
        let varying = names.iter().any(|(n, _)| {
            matches!(
                self.lookup(&n.name).map(|v| &v.val),
                Some(Val::V { varying: true, .. })
            )
        });
        self.restore(names, saved);
        (out, varying)
    }

    /// An `if` region on `c` (`vc`: whether it varies) whose then arm is `run` and whose
    /// else arm does nothing; `names` are the variables it may assign, rebound after it.
    pub(crate) fn guarded(
        &mut self,
        b: &mut Builder,
        c: Value,
        vc: bool,
        names: &[(ast::Ident, Ty)],
        run: &mut dyn FnMut(&mut Self, &mut Builder),
    ) {
        self.if_region(b, c, vc, names, run, &mut |_, _| {});
    }

    /// The outer variables expressions (a loop's step) assign, as [`Lower::assigned_outer`].
    pub(crate) fn assigned_in_exprs(&self, exprs: &[Expr]) -> Vec<(ast::Ident, Ty)> {
        let mut names: Vec<(ast::Ident, Ty)> = Vec::new();
        for e in exprs {
            let wrapped = Stmt {
                kind: StmtKind::Expr(e.clone()),
                span: e.span,
            };
            for n in self.assigned_outer(&[&wrapped]) {
                if !names.iter().any(|(m, _)| m.name == n.0.name) {
                    names.push(n);
                }
            }
        }
        names
    }

    /// Expressions (a loop's step) run only where `c` holds.
    pub(crate) fn guarded_exprs(&mut self, b: &mut Builder, c: Value, vc: bool, exprs: &'a [Expr]) {
        let names = self.assigned_in_exprs(exprs);
        self.guarded(b, c, vc, &names, &mut |me, b| {
            for e in exprs {
                me.expr(b, e);
            }
        });
    }

    /// An `if` region with arms `then` and `els` over the variables `names`.
    fn if_region(
        &mut self,
        b: &mut Builder,
        c: Value,
        vc: bool,
        names: &[(ast::Ident, Ty)],
        then: &mut dyn FnMut(&mut Self, &mut Builder),
        els: &mut dyn FnMut(&mut Self, &mut Builder),
    ) {
        let uniform: Vec<bool> = names
            .iter()
            .map(|(n, _)| self.lookup(&n.name).is_some_and(|v| v.uniform))
            .collect();
        let varying = RefCell::new(vc);
        let me = RefCell::new(&mut *self);
        let values = b.if_(
            c,
            |b| {
                let (v, vy) = me.borrow_mut().arm(b, then, names);
                *varying.borrow_mut() |= vy;
                v
            },
            |b| {
                let (v, vy) = me.borrow_mut().arm(b, els, names);
                *varying.borrow_mut() |= vy;
                v
            },
        );
        let varying = varying.into_inner();
        for (((n, ty), v), uniform) in names.iter().zip(values).zip(uniform) {
            let val = Val::V {
                v,
                ty: *ty,
                varying,
            };
            if n.name.starts_with('$') {
                self.set_flag(&n.name, val);
            } else {
                self.rebind(n, val, uniform, n.span);
            }
        }
    }

    fn if_stmt(&mut self, b: &mut Builder, cond: &'a Expr, then: &'a Stmt, els: Option<&'a Stmt>) {
        let (c, tc, vc) = self.condition(b, cond);
        if tc != Ty::Bool {
            self.error(
                format!(
                    "an `if` condition must be a comparison, not a {}",
                    tc.name()
                ),
                cond.span,
                "here",
            );
            return;
        }
        let arms: Vec<&Stmt> = [Some(then), els].into_iter().flatten().collect();
        let names = self.assigned_outer(&arms);
        if !self.assigned_closures(&arms).is_empty() {
            self.flat_if(b, (c, vc), &arms, &names);
            return;
        }
        self.if_region(
            b,
            c,
            vc,
            &names,
            &mut |me, b| me.stmt(b, then),
            &mut |me, b| {
                if let Some(e) = els {
                    me.stmt(b, e)
                }
            },
        );
    }

    /// An `if` that assigns closures: both arms lowered in the enclosing block, then each
    /// variable they assign set to the arm's value the condition picks ([`Lower::merge`]:
    /// closures keep both lobe lists, weighted by the condition). Shading ops have no side
    /// effects, so running both arms changes nothing but cost — except prints, which run
    /// under the arm's condition ([`Lower::print_guard`]).
    fn flat_if(
        &mut self,
        b: &mut Builder,
        (c, vc): (Value, bool),
        arms: &[&'a Stmt],
        values: &[(ast::Ident, Ty)],
    ) {
        let mut names: Vec<ast::Ident> = values.iter().map(|(n, _)| n.clone()).collect();
        names.extend(self.assigned_closures(arms));
        let before: Vec<Option<Var>> = names
            .iter()
            .map(|n| self.lookup(&n.name).cloned())
            .collect();
        let mut results: Vec<Vec<Option<Val>>> = Vec::new();
        for k in 0..2 {
            if let Some(arm) = arms.get(k) {
                self.scopes.push(HashMap::new());
                self.print_guard.push((c, k == 0));
                self.stmt(b, arm);
                self.print_guard.pop();
                self.scopes.pop();
            }
            results.push(
                names
                    .iter()
                    .map(|n| self.lookup(&n.name).map(|v| v.val.clone()))
                    .collect(),
            );
            self.put_back(&names, &before);
        }
        let (els, then) = (
            results.pop().unwrap_or_default(),
            results.pop().unwrap_or_default(),
        );
        for ((n, t), e) in names.iter().zip(then).zip(els) {
            let (Some(t), Some(e)) = (t, e) else { continue };
            let val = self.merge(b, (c, vc), t, e, n.span);
            if n.name.starts_with('$') {
                self.set_flag(&n.name, val);
            } else {
                let uniform = self.lookup(&n.name).is_some_and(|v| v.uniform);
                self.rebind(n, val, uniform, n.span);
            }
        }
    }

    /// Puts the variables `names` back to `saved` (their values before an arm).
    fn put_back(&mut self, names: &[ast::Ident], saved: &[Option<Var>]) {
        for (n, var) in names.iter().zip(saved) {
            let Some(var) = var else { continue };
            for scope in self.scopes.iter_mut().rev() {
                if let Some(v) = scope.get_mut(&n.name) {
                    *v = var.clone();
                    break;
                }
            }
        }
    }

    /// `illuminance(P [, N, angle]) body`: the IR's light loop over the light samples seen
    /// from `P` (within `angle` of `N`), with `L` the unit direction to the sample and `Cl`
    /// its color as it arrives (shadowed samples black). The loop sums what the body adds to
    /// outer variables, so the body may change them only by `+=` / `-=` and not read them.
    fn illuminance(
        &mut self,
        b: &mut Builder,
        category: Option<&'a Expr>,
        args: &'a [Expr],
        body: &'a Stmt,
        span: Span,
    ) {
        if let Some(c) = category {
            self.error(
                "light categories are not built yet",
                c.span,
                "not built yet",
            );
            return;
        }
        if self.in_illuminance {
            self.error(
                "`illuminance` inside `illuminance`",
                span,
                "nested light loop",
            );
            return;
        }
        let p = self.expr_as(b, &args[0], Ty::Point);
        let cone = match args {
            [_] => None,
            [_, n, angle] => Some((
                self.expr_as(b, n, Ty::Normal),
                self.expr_as(b, angle, Ty::Float),
            )),
            _ => {
                self.error("illuminance takes (P) or (P, N, angle)", span, "here");
                return;
            }
        };
        let (Val::V { v: p, .. }, cone) = (p, cone) else {
            return;
        };
        let names = self.assigned_outer(&[body]);
        self.only_accumulated(body, &names);
        let me = RefCell::new(&mut *self);
        let sums = b.illuminance(p, |b, l, cl| {
            let mut me = me.borrow_mut();
            let saved = me.snapshot(&names);
            let mut scope = HashMap::new();
            let vis = b.light_visible();
            let vis = b.splat(shadenet_graph::Type::Color, vis);
            let cl = b.mul(cl, vis);
            for (name, v, ty) in [("L", l, Ty::Vector), ("Cl", cl, Ty::Color)] {
                let val = Val::V {
                    v,
                    ty,
                    varying: true,
                };
                scope.insert(
                    name.to_string(),
                    Var {
                        val,
                        uniform: false,
                        decl: None,
                    },
                );
            }
            me.scopes.push(scope);
            for (n, ty) in &names {
                let val = Self::poison(b, *ty);
                me.rebind(n, val, false, n.span);
            }
            me.in_illuminance = true;
            let deltas = match &cone {
                None => {
                    me.stmt(b, body);
                    me.current(b, &names)
                }
                Some((Val::V { v: n, .. }, Val::V { v: angle, .. })) => {
                    let n = b.normalize(*n);
                    let d = b.dot(n, l);
                    let c = b.unary(shadenet_graph::ir::UnOp::Cos, *angle);
                    let inside = b.binary(shadenet_graph::ir::BinOp::Ge, d, c);
                    let inner = RefCell::new(&mut **me);
                    b.if_(
                        inside,
                        |b| {
                            let mut me = inner.borrow_mut();
                            me.stmt(b, body);
                            me.current(b, &names)
                        },
                        |b| names.iter().map(|(_, t)| b.zero(t.ir())).collect(),
                    )
                }
                Some(_) => Vec::new(),
            };
            me.in_illuminance = false;
            me.scopes.pop();
            me.restore(&names, saved);
            deltas
        });
        if sums.len() != names.len() {
            return;
        }
        for ((n, ty), s) in names.iter().zip(sums) {
            let Some(var) = self.lookup(&n.name).cloned() else {
                continue;
            };
            if let Val::V { v, .. } = var.val {
                let total = b.add(v, s);
                self.rebind(
                    n,
                    Val::V {
                        v: total,
                        ty: *ty,
                        varying: true,
                    },
                    var.uniform,
                    n.span,
                );
            }
        }
    }

    /// Inside an `illuminance` body, the outer variables it changes may only be added to
    /// (`+=`, `-=`): anything else is an error at the place.
    fn only_accumulated(&mut self, body: &'a Stmt, names: &[(ast::Ident, Ty)]) {
        let mut bad: Vec<(String, Span)> = Vec::new();
        walk_stmt(body, &mut |e| {
            if let ExprKind::Assign { op, target, .. } = &e.kind
                && let ExprKind::Ident(id) = &target.kind
                && names.iter().any(|(n, _)| n.name == id.name)
                && !matches!(op, AssignOp::Add | AssignOp::Sub)
            {
                bad.push((id.name.clone(), e.span));
            }
        });
        reads(body, names, &mut bad);
        for (name, at) in bad {
            self.error(
                format!(
                    "inside `illuminance`, `{name}` (declared outside it) may only be accumulated with += or -=: the light loop sums its body over the lights"
                ),
                at,
                "here",
            );
        }
    }

    /// Inlines a call of user function `f` with `args` (the values of `arg_exprs`): its
    /// parameters bound to the arguments in a scope that sees only the globals, its body
    /// lowered, its value the expression of its final `return`; then each `output`
    /// parameter's final value is stored in the variable passed for it.
    pub(crate) fn inline(
        &mut self,
        b: &mut Builder,
        f: &'a ast::FunctionDef,
        args: Vec<Val>,
        arg_exprs: &'a [Expr],
        span: Span,
    ) -> Val {
        // No jump leaves a function.
        let outer = std::mem::take(&mut self.loops);
        let (v, outs) = self.inline_body(b, f, args, span);
        self.loops = outer;
        for (k, val) in outs {
            let Some(e) = arg_exprs.get(k) else { continue };
            self.store_output_arg(b, e, val, (k + 1, &f.name.name));
        }
        v
    }

    /// The value of a struct-returning function's last `return` expression `last` (a
    /// `{…}` list builds the return type `def`).
    fn struct_result(
        &mut self,
        b: &mut Builder,
        last: Option<&'a Expr>,
        def: Option<&'a ast::StructDef>,
    ) -> Option<Val> {
        match (last, def) {
            (Some(e), Some(def)) => Some(self.expr_for_struct(b, e, def)),
            (e, _) => e.map(|e| self.expr(b, e)),
        }
    }

    /// Stores `val` in the place argument `e` names (argument number `n` of `callee`, an
    /// `output` parameter): a variable, a field or an element; an error where `e` is none.
    pub(crate) fn store_output_arg(
        &mut self,
        b: &mut Builder,
        e: &'a Expr,
        val: Val,
        (n, callee): (usize, &str),
    ) {
        // `f(…, a[i], …)`, `f(…, s.a[i], …)`: the element takes the value.
        if let ExprKind::Index { base, index } = &e.kind
            && let Some(id) = super::structs::place(base)
        {
            let rhs = super::arrays::Rhs::Val(val);
            self.assign_index(b, (&id, index), rhs, e.span);
            return;
        }
        let Some(id) = super::structs::place(e) else {
            self.error(
                format!("argument {n} of `{callee}` is an `output` parameter: pass a variable"),
                e.span,
                "not a variable",
            );
            return;
        };
        let Some(var) = self.lookup(&id.name).cloned() else {
            return;
        };
        let val = match (&var.val, val) {
            (Val::V { ty, .. }, v @ Val::V { .. }) => self.coerce(b, v, *ty, e.span),
            (_, v) => v,
        };
        self.store(&id, val, e.span);
    }

    /// The body of [`Lower::inline`]: the value and the output parameters' final values
    /// (by argument position).
    fn inline_body(
        &mut self,
        b: &mut Builder,
        f: &'a ast::FunctionDef,
        args: Vec<Val>,
        span: Span,
    ) -> (Val, Vec<(usize, Val)>) {
        if let Some((_, at, _)) = self.inlining.iter().find(|(_, _, d)| *d == f.span) {
            let chain: Vec<&str> = self
                .inlining
                .iter()
                .map(|(n, _, _)| *n)
                .chain([f.name.name.as_str()])
                .collect();
            let d = crate::diag::Diagnostic::error(
                format!("recursion is not allowed: {}", chain.join(" → ")),
                span,
                "this call recurses",
            )
            .with_secondary(*at, "first called here");
            if !self.stopped() {
                self.diags.push(d);
            }
            return (Self::poison(b, Ty::Float), Vec::new());
        }
        if self.inlining.len() >= MAX_INLINE_DEPTH {
            self.error("functions nest too deeply", span, "here");
            return (Self::poison(b, Ty::Float), Vec::new());
        }
        let closure_ret = f.ret.closure.is_some() && self.dialect == crate::Dialect::Osl;
        let struct_ret = matches!(f.ret.base, ast::BaseType::Struct(_));
        let ret = match &f.ret.base {
            _ if closure_ret || struct_ret => None,
            ast::BaseType::Void => None,
            _ => self.declared_type(&f.ret),
        };
        let (last, body) = match f.body.stmts.split_last() {
            Some((
                Stmt {
                    kind: StmtKind::Return(e),
                    ..
                },
                rest,
            )) => (e.as_ref(), rest),
            _ => (None, f.body.stmts.as_slice()),
        };
        let globals = self.scopes[0].clone();
        let saved = std::mem::replace(&mut self.scopes, vec![globals, HashMap::new()]);
        self.bind_params(b, f, args, span);
        self.inlining.push((f.name.name.as_str(), span, f.span));
        let outer_returns = self.returns.take();
        let early = body.iter().any(super::returns::has_return);
        let early_value = early && !closure_ret;
        let ret_struct = match &f.ret.base {
            ast::BaseType::Struct(n) => self.struct_def(&n.name),
            _ => None,
        };
        if early_value {
            // Returns before the end: every `return` (the last one too) sets the hidden
            // result, and what follows one runs where it did not.
            self.begin_returns(b, ret, ret_struct);
            let all: Vec<&Stmt> = f.body.stmts.iter().collect();
            self.stmts(b, &all);
        } else {
            if early {
                self.error(
                    format!(
                        "`{}` returns a closure before its end: only a last `return` is built for closures",
                        f.name.name
                    ),
                    f.name.span,
                    "early return",
                );
            }
            for s in body {
                self.stmt(b, s);
            }
        }
        let out = match (ret, last) {
            _ if early_value && (ret.is_some() || ret_struct.is_some()) => self
                .read_var(super::returns::RETVAL)
                .unwrap_or_else(|| Self::poison(b, Ty::Float)),
            _ if early_value => Self::poison(b, Ty::Float),
            _ if struct_ret => match self.struct_result(b, last, ret_struct) {
                Some(v @ Val::Struct(..)) => v,
                _ => {
                    self.error(
                        format!("function `{}` must return a struct", f.name.name),
                        f.name.span,
                        "returns a struct",
                    );
                    Self::poison(b, Ty::Float)
                }
            },
            _ if closure_ret => match last.map(|e| self.expr(b, e)) {
                Some(v @ Val::Closure(_)) => v,
                Some(v) if Self::closure_or_zero(b, &v) => Val::Closure(Box::default()),
                _ => {
                    self.error(
                        format!("function `{}` must return a closure", f.name.name),
                        f.name.span,
                        "returns a closure",
                    );
                    Val::Closure(Box::default())
                }
            },
            (Some(ty), Some(e)) => self.expr_as(b, e, ty),
            (Some(ty), None) => {
                self.error(
                    format!("function `{}` must end with `return`", f.name.name),
                    f.name.span,
                    "no return",
                );
                Self::poison(b, ty)
            }
            (None, _) => Self::poison(b, Ty::Float),
        };
        let outs = f
            .params
            .iter()
            .enumerate()
            .filter(|(_, p)| p.ty.output.is_some())
            .filter_map(|(k, p)| Some((k, self.read_var(&p.name.name)?)))
            .collect();
        self.inlining.pop();
        self.returns = outer_returns;
        // What the function wrote into the globals (`Ci`, `N`, the hidden trace and message
        // variables) is the caller's: the function's scope 0 is the globals.
        let globals = std::mem::replace(&mut self.scopes, saved).swap_remove(0);
        self.scopes[0].extend(globals);
        (out, outs)
    }

    /// Binds a function's parameters to the arguments of a call, in the function's scope.
    fn bind_params(
        &mut self,
        b: &mut Builder,
        f: &'a ast::FunctionDef,
        args: Vec<Val>,
        span: Span,
    ) {
        for (p, a) in f.params.iter().zip(args) {
            if p.array.is_some() {
                self.bind_array_param(b, p, a, span);
            } else if let (ast::BaseType::Struct(_), Val::Struct(..)) = (&p.ty.base, &a) {
                // `accepts` matched the struct type.
                self.bind_value(&p.name, a, false);
            } else if p.ty.base == ast::BaseType::String && matches!(a, Val::Str(_)) {
                // A string argument (a noise or space name): known while compiling.
                self.declare(&p.name, a, true);
            } else if p.ty.closure.is_some() && self.dialect == crate::Dialect::Osl {
                // `accepts` matched a closure to it.
                self.declare(&p.name, a, false);
            } else if let Some(ty) = self.declared_type(&p.ty) {
                let v = self.coerce(b, a, ty, span);
                self.declare(&p.name, v, false);
            }
        }
    }
}

/// The array a write into a field of one of its elements changes (`a[i].f`, `s.a[i].f.g`:
/// the array whole).
fn indexed(t: &ExprKind) -> Option<ast::Ident> {
    match t {
        ExprKind::Index { base, .. } => super::structs::place(base).or_else(|| indexed(&base.kind)),
        ExprKind::Member { base, .. } => indexed(&base.kind),
        _ => None,
    }
}

/// The span of an assignment (or `++`/`--`) inside `e`, if any.
fn assignment_in(e: &Expr) -> Option<Span> {
    let mut at = None;
    walk_expr(e, &mut |x| {
        if matches!(x.kind, ExprKind::Assign { .. } | ExprKind::IncDec { .. }) {
            at.get_or_insert(x.span);
        }
    });
    at
}

/// Whether `s` holds a `break` or `continue` (at any depth).
pub(crate) fn has_jump(s: &Stmt) -> bool {
    match &s.kind {
        StmtKind::Break { .. } | StmtKind::Continue { .. } => true,
        StmtKind::Block(b) => b.stmts.iter().any(has_jump),
        StmtKind::If { then, els, .. } => has_jump(then) || els.as_deref().is_some_and(has_jump),
        StmtKind::For { body, .. }
        | StmtKind::While { body, .. }
        | StmtKind::DoWhile { body, .. } => has_jump(body),
        _ => false,
    }
}

/// Reads of `names` in `s` other than as the target of `+=` / `-=`.
fn reads(s: &Stmt, names: &[(ast::Ident, Ty)], out: &mut Vec<(String, Span)>) {
    let mut targets: Vec<Span> = Vec::new();
    walk_stmt(s, &mut |e| {
        if let ExprKind::Assign {
            op: AssignOp::Add | AssignOp::Sub,
            target,
            ..
        } = &e.kind
        {
            targets.push(target.span);
        }
    });
    walk_stmt(s, &mut |e| {
        if let ExprKind::Ident(id) = &e.kind
            && names.iter().any(|(n, _)| n.name == id.name)
            && !targets.contains(&e.span)
            && !out.iter().any(|(_, at)| *at == e.span)
        {
            out.push((id.name.clone(), e.span));
        }
    });
}
