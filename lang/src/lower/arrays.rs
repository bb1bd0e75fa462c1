//! Fixed-size arrays in the front end (RSL and OSL alike), without an IR array type: an
//! array variable `a` of length n is n hidden element variables `a[0]` … `a[n-1]` (names no
//! program can write), so `if` and loop regions carry the elements an assignment may change
//! like any variable, and a function call copies them. A constant index reads or writes one
//! element (out of range: an error naming the index and the length); an index computed at
//! run time is clamped to the array, as OSL does, and reads through a chain of selects (the
//! element whose position equals it) or writes every element, each keeping its value where
//! the index is another. Clamped run-time indices are not counted yet (that needs an op
//! with an effect). Owns the array rules; it must not hold op semantics.

use super::{Lower, Ty, Val};
use crate::ast::{self, AssignOp, Expr, ExprKind};
use crate::source::Span;
use shadenet_graph::Type;
use shadenet_graph::ir::{BinOp, Builder, Value};

/// The longest array (elements are separate values; a run-time index costs one select per
/// element).
pub(crate) const MAX_ARRAY_LEN: usize = 1024;

use super::element;

impl<'a> Lower<'a> {
    /// The length of a declared array: its constant `[N]`, or the initialiser list's
    /// length for `[]`; `None` after an error.
    pub(crate) fn array_len(
        &mut self,
        a: &'a ast::ArrayLen,
        init: Option<&'a Expr>,
    ) -> Option<usize> {
        let n = match (&a.len, init.map(|e| &e.kind)) {
            (Some(len), _) => match super::eval(len).as_deref() {
                Some([x]) if x.fract() == 0.0 && *x >= 1.0 => *x as usize,
                _ => {
                    self.error(
                        "an array length must be a constant positive integer",
                        len.span,
                        "not a constant length",
                    );
                    return None;
                }
            },
            (None, Some(ExprKind::InitList(items))) => items.len(),
            (None, _) => {
                self.error(
                    "an array declared `[]` needs an initialiser list `{ … }`",
                    a.span,
                    "no length",
                );
                return None;
            }
        };
        if n > MAX_ARRAY_LEN {
            self.error(
                format!("an array of {n} elements: the limit is {MAX_ARRAY_LEN}"),
                a.span,
                "too long",
            );
            return None;
        }
        Some(n)
    }

    /// Declares array `name` of `len` elements of `ty`, from `init` (a `{ … }` list of
    /// exactly `len` values, or another array) or zero.
    pub(crate) fn declare_array(
        &mut self,
        b: &mut Builder,
        name: &ast::Ident,
        (ty, len): (Ty, usize),
        init: Option<&'a Expr>,
        uniform: bool,
    ) {
        let values: Vec<Val> = match init.map(|e| (e, &e.kind)) {
            None => (0..len).map(|_| Self::poison(b, ty)).collect(),
            Some((e, ExprKind::InitList(items))) => {
                if items.len() != len {
                    self.list_length_error(name, len, items.len(), e.span);
                }
                (0..len)
                    .map(|k| match items.get(k) {
                        Some(x) => self.expr_as(b, x, ty),
                        None => Self::poison(b, ty),
                    })
                    .collect()
            }
            Some((e, _)) => match self.expr(b, e) {
                Val::Array(vs) if vs.len() == len => vs
                    .into_iter()
                    .map(|v| self.coerce(b, v, ty, e.span))
                    .collect(),
                other => {
                    self.error(
                        format!(
                            "`{}` is an array of {len}: it takes a `{{ … }}` list or an array of {len}, not {}",
                            name.name,
                            super::an(other.type_name())
                        ),
                        e.span,
                        "not an array of that length",
                    );
                    (0..len).map(|_| Self::poison(b, ty)).collect()
                }
            },
        };
        self.bind_array(name, Some(ty), values, uniform);
    }

    /// The error for a `{ … }` list of `given` items initialising array `name` of `len`.
    pub(crate) fn list_length_error(
        &mut self,
        name: &ast::Ident,
        len: usize,
        given: usize,
        at: Span,
    ) {
        self.error(
            format!("`{}` has {len} elements; the list gives {given}", name.name),
            at,
            "wrong number of values",
        );
    }

    /// Binds array `name` with element values `values` in the innermost scope (`ty`
    /// `None`: the elements are structs, each bound as a struct variable).
    pub(crate) fn bind_array(
        &mut self,
        name: &ast::Ident,
        ty: Option<Ty>,
        values: Vec<Val>,
        uniform: bool,
    ) {
        let len = values.len();
        for (k, v) in values.into_iter().enumerate() {
            let id = ast::Ident {
                name: element(&name.name, k),
                span: name.span,
            };
            self.bind_value(&id, v, uniform);
        }
        self.declare(name, Val::ArrayVar { len, ty }, uniform);
    }

    /// `a = x` for array variable `a`: `x` an array of the same length (or a `{ … }` list);
    /// every element rebound.
    pub(crate) fn assign_array(
        &mut self,
        b: &mut Builder,
        id: &ast::Ident,
        len: usize,
        value: &'a Expr,
    ) -> Val {
        let old = match self.read_var(&id.name) {
            Some(Val::Array(old)) if old.len() == len => old,
            _ => return Self::poison(b, Ty::Float),
        };
        let elems = match self.expr(b, value) {
            Val::Array(elems) if elems.len() == len => elems,
            other => {
                self.error(
                    format!(
                        "`{}` is an array of {len}: it takes an array of {len}, not {}",
                        id.name,
                        super::an(other.type_name())
                    ),
                    value.span,
                    "not an array of that length",
                );
                return old[0].clone();
            }
        };
        let elems: Vec<Val> = elems
            .into_iter()
            .zip(&old)
            .map(|(v, like)| self.fit(b, v, like, value.span))
            .collect();
        for (k, e) in elems.iter().enumerate() {
            let el = ast::Ident {
                name: element(&id.name, k),
                span: id.span,
            };
            self.store(&el, e.clone(), value.span);
        }
        Val::Array(elems)
    }

    /// `base[index]`: an array element, or a component of a triple (the index constant or
    /// computed, as for arrays).
    pub(crate) fn index(&mut self, b: &mut Builder, base: &'a Expr, index: &'a Expr) -> Val {
        if let ExprKind::Index {
            base: inner,
            index: i,
        } = &base.kind
        {
            // `m[i][j]` of a matrix; else `a[i][j]`, a component of an array's element.
            let outer = self.expr(b, inner);
            if let Val::V {
                v,
                ty: Ty::Matrix,
                varying,
            } = outer
            {
                return self.matrix_read(b, (v, varying), i, index);
            }
            let row = self.index_of(b, outer, inner.span, i);
            return self.index_of(b, row, base.span, index);
        }
        let v = self.expr(b, base);
        self.index_of(b, v, base.span, index)
    }

    /// `v[index]` of a lowered `v` (at `at`).
    fn index_of(&mut self, b: &mut Builder, v: Val, at: Span, index: &'a Expr) -> Val {
        let elems = match v {
            Val::Array(elems) => elems,
            Val::V { v, ty, varying } if ty.is_triple() => (0..3)
                .map(|k| Val::V {
                    v: b.extract(v, k),
                    ty: Ty::Float,
                    varying,
                })
                .collect(),
            Val::V { ty: Ty::Matrix, .. } => {
                self.error("a matrix element is `m[row][column]`", at, "a matrix");
                return Self::poison(b, Ty::Float);
            }
            other => {
                self.error(
                    format!("{} cannot be indexed", super::an(other.type_name())),
                    at,
                    "not an array or a triple",
                );
                return Self::poison(b, Ty::Float);
            }
        };
        let pos = self.position(b, index, elems.len());
        self.pick(b, &elems, &pos, index.span)
    }

    /// The element of `elems` at `pos` (a chain of selects for a run-time position).
    pub(crate) fn pick(&mut self, b: &mut Builder, elems: &[Val], pos: &Position, at: Span) -> Val {
        match *pos {
            Position::Known(k) => elems[k].clone(),
            Position::Computed(i, vi) => {
                let mut acc = elems[0].clone();
                for (k, e) in elems.iter().enumerate().skip(1) {
                    let kk = b.int(k as i32);
                    let here = b.binary(BinOp::Eq, i, kk);
                    acc = self.merge(b, (here, vi), e.clone(), acc, at);
                }
                acc
            }
            Position::Bad => Self::poison(b, Ty::Float),
        }
    }

    /// `a[index] op= value` (or `= v`) for array variable `a` (or a component of a triple variable):
    /// each element it may change rebound.
    pub(crate) fn assign_index(
        &mut self,
        b: &mut Builder,
        (id, index): (&ast::Ident, &'a Expr),
        rhs: Rhs<'a>,
        span: Span,
    ) -> Val {
        self.assign_element(b, (id, At::Index(index)), rhs, span)
    }

    /// `v.x op= value` (`.y`, `.z`, `.r`, `.g`, `.b`) for triple variable `v`: component
    /// `k`, as `v[k]`.
    pub(crate) fn assign_component(
        &mut self,
        b: &mut Builder,
        (id, k): (&ast::Ident, usize),
        rhs: Rhs<'a>,
        span: Span,
    ) -> Val {
        self.assign_element(b, (id, At::Component(k)), rhs, span)
    }

    /// `a[index].f op= value` for an array of structs `a`: the element read once, its field
    /// `f` changed, the element stored back as `a[index] = …` would; the field's new value
    /// is the expression's.
    pub(crate) fn assign_element_field(
        &mut self,
        b: &mut Builder,
        (id, index, f): (&ast::Ident, &'a Expr, &ast::Ident),
        (op, value): (AssignOp, &'a Expr),
        span: Span,
    ) -> Val {
        let Some(Val::Array(elems)) = self.read_var(&id.name) else {
            return self.unknown(b, id, "name");
        };
        let pos = self.position(b, index, elems.len());
        if matches!(pos, Position::Bad) {
            return Self::poison(b, Ty::Float);
        }
        let elem = self.pick(b, &elems, &pos, index.span);
        let Val::Struct(s, mut fields) = elem.clone() else {
            self.error("only struct elements have fields", f.span, "not a struct");
            return Self::poison(b, Ty::Float);
        };
        let old = self.field_of(b, elem, f);
        let new = match super::compound_of(op) {
            None => self.expr(b, value),
            Some(bin) => {
                let v = self.expr(b, value);
                self.binary_vals(b, bin, (old.clone(), span), (v, value.span), span)
            }
        };
        let new = self.fit(b, new, &old, value.span);
        if let Some(slot) = fields.iter_mut().find(|(n, _)| *n == f.name) {
            slot.1 = new.clone();
        }
        self.assign_element(
            b,
            (id, At::Pos(pos)),
            Rhs::Val(Val::Struct(s, fields)),
            span,
        );
        new
    }

    /// [`Lower::assign_index`] or [`Lower::assign_component`]: element `at` of `id`.
    fn assign_element(
        &mut self,
        b: &mut Builder,
        (id, at): (&ast::Ident, At<'a>),
        rhs: Rhs<'a>,
        span: Span,
    ) -> Val {
        let Some(var) = self.lookup(&id.name).cloned() else {
            return self.unknown(b, id, "name");
        };
        let (len, ty) = match var.val {
            Val::ArrayVar { len, ty } => (len, ty),
            Val::V { ty, .. } if ty.is_triple() => (3, Some(Ty::Float)),
            other => {
                self.error(
                    format!("{} cannot be indexed", super::an(other.type_name())),
                    id.span,
                    "not an array or a triple",
                );
                return Self::poison(b, Ty::Float);
            }
        };
        let pos = match at {
            At::Index(index) => self.position(b, index, len),
            At::Pos(pos) => pos,
            At::Component(k) if k < len => Position::Known(k),
            At::Component(_) => Position::Bad,
        };
        if matches!(pos, Position::Bad) {
            return Self::poison(b, ty.unwrap_or(Ty::Float));
        }
        let triple = matches!(var.val, Val::V { .. });
        let mut elems: Vec<Val> = match &var.val {
            Val::V { v, varying, .. } => (0..3)
                .map(|k| Val::V {
                    v: b.extract(*v, k),
                    ty: Ty::Float,
                    varying: *varying,
                })
                .collect(),
            _ => match self.read_var(&id.name) {
                Some(Val::Array(elems)) => elems,
                _ => Vec::new(),
            },
        };
        let Some(first) = elems.first().cloned() else {
            return Self::poison(b, Ty::Float);
        };
        let rhs = match rhs {
            Rhs::Val(v) => self.fit(b, v, &first, span),
            Rhs::Expr(op, value) => match super::compound_of(op) {
                None => {
                    let v = match (&first, ty) {
                        (_, Some(ty)) => self.expr_as(b, value, ty),
                        (Val::Struct(s, _), None) => match self.struct_def(s) {
                            Some(def) => self.expr_for_struct(b, value, def),
                            None => self.expr(b, value),
                        },
                        _ => self.expr(b, value),
                    };
                    self.fit(b, v, &first, value.span)
                }
                Some(bin) => {
                    let old = self.pick(b, &elems, &pos, span);
                    let v = self.expr(b, value);
                    let v = self.binary_vals(b, bin, (old, span), (v, value.span), span);
                    self.fit(b, v, &first, span)
                }
            },
        };
        match pos {
            Position::Known(k) => elems[k] = rhs.clone(),
            Position::Computed(i, vi) => {
                for (k, e) in elems.iter_mut().enumerate() {
                    let kk = b.int(k as i32);
                    let here = b.binary(BinOp::Eq, i, kk);
                    *e = self.merge(b, (here, vi), rhs.clone(), e.clone(), span);
                }
            }
            Position::Bad => {}
        }
        if triple {
            let mut comps = Vec::new();
            let mut varying = false;
            for e in &elems {
                if let Val::V { v, varying: vy, .. } = e {
                    comps.push(*v);
                    varying |= vy;
                }
            }
            let Val::V { ty: tt, .. } = var.val else {
                return rhs;
            };
            let v = b.construct(tt.ir(), &comps);
            self.rebind(id, Val::V { v, ty: tt, varying }, var.uniform, span);
        } else {
            for (k, e) in elems.into_iter().enumerate() {
                let el = ast::Ident {
                    name: element(&id.name, k),
                    span: id.span,
                };
                self.store(&el, e, span);
            }
        }
        rhs
    }

    /// `v` as a value of `like`'s kind: converted to its type (a value), or checked to be
    /// the same struct (an error otherwise, and `like` kept).
    pub(crate) fn fit(&mut self, b: &mut Builder, v: Val, like: &Val, span: Span) -> Val {
        match like {
            Val::V { ty, .. } => self.coerce(b, v, *ty, span),
            Val::Struct(s, _) => {
                if matches!(&v, Val::Struct(t, _) if t == s) {
                    return v;
                }
                self.error(
                    format!("expected a `{s}`, found {}", super::an(v.type_name())),
                    span,
                    "wrong type",
                );
                like.clone()
            }
            _ => v,
        }
    }

    /// Where `index` points in a sequence of `len`: a constant position (out of range: an
    /// error), or a run-time one clamped to `[0, len − 1]` (an int).
    pub(crate) fn position(&mut self, b: &mut Builder, index: &'a Expr, len: usize) -> Position {
        let (v, ty, varying) = self.value(b, index);
        if !matches!(ty, Ty::Int | Ty::Float) {
            self.error(
                format!("an index is a number, not {}", super::an(ty.name())),
                index.span,
                "not a number",
            );
            return Position::Bad;
        }
        let i = b.convert(Type::Int, v);
        if let Some(c) = shadenet_graph::opt::fold::constant(b.program(), i)
            && !reads_param(b, i)
        {
            let k = match c {
                shadenet_graph::ConstValue::Int(k) => k as i64,
                _ => -1,
            };
            if !(0..len as i64).contains(&k) {
                self.error(
                    format!("index {k} is out of range: the length is {len}"),
                    index.span,
                    "out of range",
                );
                return Position::Bad;
            }
            return Position::Known(k as usize);
        }
        let zero = b.int(0);
        let last = b.int(len as i32 - 1);
        let lo = b.max(i, zero);
        Position::Computed(b.min(lo, last), varying)
    }
}

/// What an indexed assignment stores: `op= expr`, or a value (an `output` argument).
pub(crate) enum Rhs<'a> {
    /// `a[i] op= expr`.
    Expr(AssignOp, &'a Expr),
    /// A value computed elsewhere.
    Val(Val),
}

/// Which element an assignment writes: an index expression, or a triple's component.
enum At<'a> {
    /// `a[index]`.
    Index(&'a Expr),
    /// `v.x` … (0, 1 or 2).
    Component(usize),
    /// An index already lowered.
    Pos(Position),
}

/// Where an index points.
pub(crate) enum Position {
    /// A constant element.
    Known(usize),
    /// A run-time element (an int in range) and whether it varies.
    Computed(Value, bool),
    /// An error was reported.
    Bad,
}

/// Whether `v` depends on a program parameter (a scene may change it after compiling).
fn reads_param(b: &Builder, v: Value) -> bool {
    super::reads_param(b.program(), v)
}

impl<'a> Lower<'a> {
    /// The array-valued parameter `p` of a function, bound to argument `arg` (an array of
    /// the parameter's length, any length for `[]`).
    pub(crate) fn bind_array_param(
        &mut self,
        b: &mut Builder,
        p: &'a ast::Param,
        arg: Val,
        span: Span,
    ) {
        // The element an argument's elements must be like: a value of the declared type,
        // or a struct of the declared struct type.
        let like = match &p.ty.base {
            ast::BaseType::Struct(n) if self.struct_def(&n.name).is_some() => {
                let def = self.struct_def(&n.name).expect("checked");
                self.struct_zero(b, def, 0)
            }
            _ => match self.declared_type(&p.ty) {
                Some(ty) => Self::poison(b, ty),
                None => return,
            },
        };
        let ty = match &like {
            Val::V { ty, .. } => Some(*ty),
            _ => None,
        };
        let want = p.array.as_ref().and_then(|a| a.len.as_ref()).and_then(|l| {
            match super::eval(l).as_deref() {
                Some([x]) => Some(*x as usize),
                _ => None,
            }
        });
        match arg {
            Val::Array(elems) if want.is_none_or(|n| n == elems.len()) => {
                let elems = elems
                    .into_iter()
                    .map(|v| self.fit(b, v, &like, span))
                    .collect();
                self.bind_array(&p.name, ty, elems, false);
            }
            other => {
                self.error(
                    format!(
                        "parameter `{}` is an array{}: not {}",
                        p.name.name,
                        want.map(|n| format!(" of {n}")).unwrap_or_default(),
                        super::an(other.type_name())
                    ),
                    span,
                    "not such an array",
                );
                self.bind_array(&p.name, ty, vec![like], false);
            }
        }
    }
}

impl<'a> Lower<'a> {
    /// A shader's array parameter `float w[3] = { … }`: each element a program parameter
    /// named `w[k]` (a constant default), or its default expression.
    pub(crate) fn array_param(&mut self, b: &mut Builder, p: &'a ast::Param, a: &'a ast::ArrayLen) {
        let Some(ty) = self.declared_type(&p.ty) else {
            return;
        };
        if p.ty.output.is_some() {
            self.error(
                "output array parameters are not built yet",
                p.span,
                "`output`",
            );
            return;
        }
        let Some(len) = self.array_len(a, p.default.as_ref()) else {
            return;
        };
        let items = match p.default.as_ref().map(|d| &d.kind) {
            Some(ExprKind::InitList(items)) if items.len() == len => items,
            _ => {
                self.error(
                    format!(
                        "array parameter `{}` needs a default list of {len} values `{{ … }}`",
                        p.name.name
                    ),
                    p.span,
                    "no default list",
                );
                return;
            }
        };
        let uniform = !matches!(p.ty.rate, Some((ast::Rate::Varying, _)));
        let values = items
            .iter()
            .enumerate()
            .map(|(k, e)| match super::const_eval(e, ty) {
                Some(c) => Val::V {
                    v: b.param(&format!("{}{}", self.prefix, element(&p.name.name, k)), c),
                    ty,
                    varying: false,
                },
                None => self.expr_as(b, e, ty),
            })
            .collect();
        self.bind_array(&p.name, Some(ty), values, uniform);
    }
}

impl<'a> Lower<'a> {
    /// The builtins that take arrays: `arraylength(a)` (an int in OSL, a float in RSL,
    /// which has no ints) and `spline` (`spline.rs`); `None` for any other call.
    pub(crate) fn array_builtin(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
        span: Span,
    ) -> Option<Val> {
        if let Some(v) = self.spline(b, name, args, span) {
            return Some(v);
        }
        let ("arraylength", [(Val::Array(elems), _)]) = (name, args) else {
            return None;
        };
        let n = elems.len() as i32;
        Some(match self.dialect {
            crate::Dialect::Osl => Val::V {
                v: b.int(n),
                ty: Ty::Int,
                varying: false,
            },
            crate::Dialect::Rsl => Val::V {
                v: b.float(n as f64),
                ty: Ty::Float,
                varying: false,
            },
        })
    }
}
