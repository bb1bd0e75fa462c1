//! OSL `struct`s in the front end, as arrays are ([`super::arrays`]): a struct variable `s`
//! is its fields' hidden variables `s.f` (names no program can write; an array field is an
//! array variable `s.f`, a struct field a struct variable), so regions carry the fields an
//! assignment changes and calls copy them. `s.f` reads and writes a field, `s = t` copies
//! every field, `Name(a, b, …)` constructs one from its fields in order, functions take and
//! return structs (`output` structs written back). Owns the struct rules.

use super::{Lower, Ty, Val};
use crate::Dialect;
use crate::ast::{self, Expr, ExprKind};
use crate::source::Span;
use shadenet_graph::ir::Builder;

/// The hidden variable holding field `f` of struct variable `s`.
pub(crate) fn field(s: &str, f: &str) -> String {
    format!("{s}.{f}")
}

/// The variable an assignment target names: `x`, or a field's hidden variable for `s.f`,
/// `s.f.g` …; `None` for anything else.
pub(crate) fn place(e: &Expr) -> Option<ast::Ident> {
    place_of(&e.kind)
}

/// [`place`] of an expression's kind.
pub(crate) fn place_of(e: &ExprKind) -> Option<ast::Ident> {
    match e {
        ExprKind::Ident(id) => Some(id.clone()),
        ExprKind::Member { base, field: f } => place(base).map(|s| ast::Ident {
            name: field(&s.name, &f.name),
            span: f.span,
        }),
        _ => None,
    }
}

/// How deep structs may nest inside structs.
const MAX_NESTING: usize = 16;

impl<'a> Lower<'a> {
    /// The struct type named `name`, if the file defines one.
    pub(crate) fn struct_def(&self, name: &str) -> Option<&'a ast::StructDef> {
        self.structs.get(name).copied()
    }

    /// The fields of struct type `def` as (name, declared type, array length): one entry per
    /// declared name.
    fn fields(
        &mut self,
        def: &'a ast::StructDef,
    ) -> Vec<(&'a ast::Ident, &'a ast::Type, Option<usize>)> {
        let mut out = Vec::new();
        for d in &def.fields {
            for v in &d.vars {
                let len = match &v.array {
                    Some(a) => match self.array_len(a, None) {
                        Some(n) => Some(n),
                        None => continue,
                    },
                    None => None,
                };
                out.push((&v.name, &d.ty, len));
            }
        }
        out
    }

    /// A zero value of struct type `def` (every field zero).
    pub(crate) fn struct_zero(
        &mut self,
        b: &mut Builder,
        def: &'a ast::StructDef,
        depth: usize,
    ) -> Val {
        let mut fields = Vec::new();
        for (name, ty, len) in self.fields(def) {
            let v = self.zero_of(b, ty, len, depth + 1);
            fields.push((name.name.clone(), v));
        }
        Val::Struct(def.name.name.clone(), fields)
    }

    /// A zero value of a declared type (an array of `len` where given).
    fn zero_of(
        &mut self,
        b: &mut Builder,
        ty: &'a ast::Type,
        len: Option<usize>,
        depth: usize,
    ) -> Val {
        if let ast::BaseType::Struct(s) = &ty.base
            && depth <= MAX_NESTING
            && let Some(def) = self.struct_def(&s.name)
        {
            let one = self.struct_zero(b, def, depth);
            return match len {
                Some(n) => Val::Array(vec![one; n]),
                None => one,
            };
        }
        if ty.closure.is_some() && self.dialect == Dialect::Osl {
            // A closure field: the empty closure, set by assignment like a closure local.
            let none = Val::Closure(Box::default());
            return match len {
                Some(n) => Val::Array(vec![none; n]),
                None => none,
            };
        }
        let t = self.declared_type(ty).unwrap_or(Ty::Float);
        match len {
            Some(n) => Val::Array((0..n).map(|_| Self::poison(b, t)).collect()),
            None => Self::poison(b, t),
        }
    }

    /// Binds struct variable `name` to `value` (a struct of type `def`): each field its
    /// hidden variable.
    pub(crate) fn bind_struct(
        &mut self,
        name: &ast::Ident,
        def: &'a ast::StructDef,
        value: Val,
        uniform: bool,
    ) {
        let Val::Struct(_, fields) = value else {
            return;
        };
        for (f, v) in fields {
            let id = ast::Ident {
                name: field(&name.name, &f),
                span: name.span,
            };
            self.bind_value(&id, v, uniform);
        }
        self.declare(name, Val::StructVar(def.name.name.clone()), uniform);
    }

    /// Binds `id` to `v`: a plain variable, or an array's or a struct's hidden variables.
    pub(crate) fn bind_value(&mut self, id: &ast::Ident, v: Val, uniform: bool) {
        match v {
            Val::Array(elems) => {
                let ty = match elems.first() {
                    Some(Val::V { ty, .. }) => Some(*ty),
                    _ => None,
                };
                self.bind_array(id, ty, elems, uniform);
            }
            Val::Struct(ref s, _) => match self.struct_def(s) {
                Some(def) => self.bind_struct(id, def, v, uniform),
                None => self.declare(id, v, uniform),
            },
            v => self.declare(id, v, uniform),
        }
    }

    /// Stores `v` in the variable `id` where it lives (plain, array or struct).
    pub(crate) fn store(&mut self, id: &ast::Ident, v: Val, span: Span) {
        let Some(var) = self.lookup(&id.name).cloned() else {
            return;
        };
        match (var.val, v) {
            (Val::ArrayVar { len, .. }, Val::Array(elems)) if elems.len() == len => {
                for (k, e) in elems.into_iter().enumerate() {
                    let el = ast::Ident {
                        name: super::element(&id.name, k),
                        span: id.span,
                    };
                    self.store(&el, e, span);
                }
            }
            (Val::StructVar(_), Val::Struct(_, fields)) => {
                for (f, e) in fields {
                    let el = ast::Ident {
                        name: field(&id.name, &f),
                        span: id.span,
                    };
                    self.store(&el, e, span);
                }
            }
            (_, v) => self.rebind(id, v, var.uniform, span),
        }
    }

    /// The value of variable `name` whatever it holds: a plain value, or the elements of
    /// an array, or the fields of a struct.
    pub(crate) fn read_var(&self, name: &str) -> Option<Val> {
        match self.lookup(name)?.val.clone() {
            Val::ArrayVar { len, .. } => Some(Val::Array(
                (0..len)
                    .map(|k| {
                        self.read_var(&super::element(name, k))
                            .unwrap_or(Val::Str(String::new()))
                    })
                    .collect(),
            )),
            Val::StructVar(s) => {
                let def = self.struct_def(&s)?;
                let mut fields = Vec::new();
                for d in &def.fields {
                    for v in &d.vars {
                        let val = self.read_var(&field(name, &v.name.name))?;
                        fields.push((v.name.name.clone(), val));
                    }
                }
                Some(Val::Struct(s, fields))
            }
            v => Some(v),
        }
    }

    /// `Name x [= init];` for struct type `def`.
    pub(crate) fn struct_decl(
        &mut self,
        b: &mut Builder,
        def: &'a ast::StructDef,
        v: &'a ast::VarDecl,
    ) {
        if let Some(a) = &v.array {
            if let Some(len) = self.array_len(a, v.init.as_ref()) {
                let elems = self.struct_array_init(b, def, (&v.name, len), v.init.as_ref());
                self.bind_array(&v.name, None, elems, false);
            }
            return;
        }
        let value = match &v.init {
            None => self.struct_zero(b, def, 0),
            Some(e) => {
                let x = self.expr_for_struct(b, e, def);
                match x {
                    Val::Struct(ref s, _) if *s == def.name.name => x,
                    other => {
                        self.error(
                            format!(
                                "`{}` is a `{}`: not {}",
                                v.name.name,
                                def.name.name,
                                super::an(other.type_name())
                            ),
                            e.span,
                            "wrong type",
                        );
                        self.struct_zero(b, def, 0)
                    }
                }
            }
        };
        self.bind_struct(&v.name, def, value, false);
    }

    /// The elements of an array of `len` structs of type `def` named `name`: zero, the
    /// items of a `{ … }` list (each one struct), or an array value of that length.
    fn struct_array_init(
        &mut self,
        b: &mut Builder,
        def: &'a ast::StructDef,
        (name, len): (&ast::Ident, usize),
        init: Option<&'a Expr>,
    ) -> Vec<Val> {
        let zero = self.struct_zero(b, def, 0);
        let given: Vec<Val> = match init.map(|e| (e, &e.kind)) {
            None => return vec![zero; len],
            Some((_, ExprKind::InitList(items))) if items.len() == len => items
                .iter()
                .map(|x| {
                    let v = self.expr_for_struct(b, x, def);
                    self.fit(b, v, &zero, x.span)
                })
                .collect(),
            Some((e, ExprKind::InitList(items))) => {
                self.list_length_error(name, len, items.len(), e.span);
                return vec![zero; len];
            }
            Some((e, _)) => match self.expr(b, e) {
                Val::Array(vs) if vs.len() == len => vs
                    .into_iter()
                    .map(|v| self.fit(b, v, &zero, e.span))
                    .collect(),
                other => {
                    self.error(
                        format!(
                            "`{}` is an array of {len} `{}`: it takes a `{{ … }}` list or an array of {len}, not {}",
                            name.name,
                            def.name.name,
                            super::an(other.type_name())
                        ),
                        e.span,
                        "not an array of that length",
                    );
                    return vec![zero; len];
                }
            },
        };
        given
    }

    /// Expression `e` where a struct of type `def` is expected (a declaration's initialiser,
    /// an assignment to a struct variable, a struct's `return`): a `{…}` list is that
    /// struct's fields in order, and a call prefers the overload that returns it.
    pub(crate) fn expr_for_struct(
        &mut self,
        b: &mut Builder,
        e: &'a Expr,
        def: &'a ast::StructDef,
    ) -> Val {
        self.want_struct = Some(def.name.name.clone());
        let x = self.expr(b, e);
        self.want_struct = None;
        x
    }

    /// `{ a, b, … }` (OSL's compound initialiser) where a struct is expected
    /// ([`Lower::expr_for_struct`]): the struct of its fields in order, each item of a
    /// struct field itself expected to be one (`{ {a, b}, c }`). Anywhere else it is an
    /// error: an array's `{…}` is its declaration's ([`super::arrays`]).
    pub(crate) fn init_list(&mut self, b: &mut Builder, items: &'a [Expr], span: Span) -> Val {
        let Some(def) = self.want_struct.take().and_then(|n| self.struct_def(&n)) else {
            self.error(
                "a `{…}` list initialises an array in its declaration, or a struct where one is expected (declared, assigned, returned)",
                span,
                "no struct or array expected here",
            );
            return Self::poison(b, Ty::Float);
        };
        let fields = self.fields(def);
        if fields.len() != items.len() {
            self.error(
                format!(
                    "struct `{}` is made of its {} fields in order: this list has {}",
                    def.name.name,
                    fields.len(),
                    items.len()
                ),
                span,
                "wrong number of fields",
            );
            return self.struct_zero(b, def, 0);
        }
        let mut vals = Vec::new();
        for ((_, ty, _), item) in fields.into_iter().zip(items) {
            let inner = match &ty.base {
                ast::BaseType::Struct(n) => self.struct_def(&n.name),
                _ => None,
            };
            let v = match inner {
                Some(inner) => self.expr_for_struct(b, item, inner),
                None => self.expr(b, item),
            };
            vals.push((v, item.span));
        }
        self.construct_struct(b, def, &vals)
            .unwrap_or_else(|| Self::poison(b, Ty::Float))
    }

    /// `base.f`: a field of a struct value.
    pub(crate) fn field_of(&mut self, b: &mut Builder, base: Val, f: &ast::Ident) -> Val {
        let Val::Struct(s, fields) = base else {
            unreachable!("called on structs");
        };
        match fields.into_iter().find(|(n, _)| *n == f.name) {
            Some((_, v)) => v,
            None => {
                let names: Vec<String> = self
                    .struct_def(&s)
                    .map(|d| {
                        d.fields
                            .iter()
                            .flat_map(|x| x.vars.iter().map(|v| v.name.name.clone()))
                            .collect()
                    })
                    .unwrap_or_default();
                self.error(
                    format!(
                        "struct `{s}` has no field `{}` (its fields: {})",
                        f.name,
                        names.join(", ")
                    ),
                    f.span,
                    "no such field",
                );
                Self::poison(b, Ty::Float)
            }
        }
    }

    /// `s.f op= value` (`hidden` the field's variable, `target` the written place).
    pub(crate) fn assign_field(
        &mut self,
        b: &mut Builder,
        op: ast::AssignOp,
        (hidden, target): (&ast::Ident, &'a Expr),
        value: &'a Expr,
        span: Span,
    ) -> Val {
        let Some(old) = self.read_var(&hidden.name) else {
            // Not a field of a struct variable: read it for the error it gives.
            return self.expr(b, target);
        };
        let rhs = match super::compound_of(op) {
            None => {
                let v = self.expr(b, value);
                match (&old, v) {
                    (Val::V { ty, .. }, v) => self.coerce(b, v, *ty, value.span),
                    (_, v) => v,
                }
            }
            Some(bin) => {
                let v = self.expr(b, value);
                let ty = match &old {
                    Val::V { ty, .. } => *ty,
                    _ => Ty::Float,
                };
                let r = self.binary_vals(b, bin, (old, span), (v, value.span), span);
                self.coerce(b, r, ty, span)
            }
        };
        self.store(hidden, rhs.clone(), span);
        rhs
    }

    /// `Name(a, b, …)`: a struct of type `def` from its fields in order; `None` when the
    /// argument count differs.
    pub(crate) fn construct_struct(
        &mut self,
        b: &mut Builder,
        def: &'a ast::StructDef,
        args: &[(Val, Span)],
    ) -> Option<Val> {
        let fields = self.fields(def);
        if fields.len() != args.len() {
            return None;
        }
        let mut out = Vec::new();
        for ((name, ty, _), (v, at)) in fields.into_iter().zip(args) {
            let v = match (self.declared_type_quiet(ty), v) {
                _ if ty.closure.is_some() => self.closure_field(b, v, *at),
                (Some(t), v @ Val::V { .. }) => self.coerce(b, v.clone(), t, *at),
                (_, v) => v.clone(),
            };
            out.push((name.name.clone(), v));
        }
        Some(Val::Struct(def.name.name.clone(), out))
    }

    /// The value of a closure field given `v`: a closure, or OSL's null closure for a
    /// constant 0; anything else is an error (and the null closure).
    fn closure_field(&mut self, b: &Builder, v: &Val, at: Span) -> Val {
        match v {
            Val::Closure(_) => v.clone(),
            _ => {
                if !Self::closure_or_zero(b, v) {
                    self.error(
                        format!("expected a closure (or 0), found {}", v.type_name()),
                        at,
                        "not a closure",
                    );
                }
                Val::Closure(Box::default())
            }
        }
    }

    /// The value type of `t` without an error (`None` for structs and closures).
    fn declared_type_quiet(&self, t: &ast::Type) -> Option<Ty> {
        if t.closure.is_some() {
            return None;
        }
        match t.base {
            ast::BaseType::Float => Some(Ty::Float),
            ast::BaseType::Int => Some(Ty::Int),
            ast::BaseType::Point => Some(Ty::Point),
            ast::BaseType::Vector => Some(Ty::Vector),
            ast::BaseType::Normal => Some(Ty::Normal),
            ast::BaseType::Color => Some(Ty::Color),
            _ => None,
        }
    }
}
