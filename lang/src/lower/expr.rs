//! Expressions: typing rules (RSL's: a float widens to any triple; points, vectors and
//! normals mix, a point minus a point is a vector; colors mix only with colors and
//! floats), operators, constructors, assignments as expressions, calls.

use super::{Lower, Ty, Val, an, closest, compound_of};
use crate::ast::{self, AssignOp, BinaryOp, Expr, ExprKind, UnaryOp};
use crate::source::Span;
use shadenet_graph::ir::{BinOp, Builder, UnOp, Value};

impl<'a> Lower<'a> {
    /// Lowers `e` where a `ty` is expected: a triple `(a, b, c)` becomes one, a float
    /// widens, a mismatch is an error naming both types.
    pub(crate) fn expr_as(&mut self, b: &mut Builder, e: &'a Expr, ty: Ty) -> Val {
        let v = match &e.kind {
            ExprKind::Tuple(items) if ty.is_triple() => self.triple(b, items, ty, e.span),
            ExprKind::Call { .. } => {
                self.want = Some(ty);
                let v = self.expr(b, e);
                self.want = None;
                v
            }
            _ => self.expr(b, e),
        };
        self.coerce(b, v, ty, e.span)
    }

    /// `v` as a `to`: the same type, a float widened to a triple, a geometric type as
    /// another; else an error naming both types.
    pub(crate) fn coerce(&mut self, b: &mut Builder, v: Val, to: Ty, span: Span) -> Val {
        let Val::V {
            mut v,
            mut ty,
            varying,
        } = v
        else {
            let found = v.type_name();
            self.error(
                format!("expected {}, found {}", an(to.name()), an(found)),
                span,
                an(found),
            );
            return Self::poison(b, to);
        };
        if ty == to || (ty.is_geometric() && to.is_geometric()) {
            return Val::V { v, ty: to, varying };
        }
        // OSL: an int (or a comparison's truth, an int there) widens to a float; the
        // triples (point, vector, normal, color) convert to one another.
        let osl = self.dialect == crate::Dialect::Osl;
        if osl && ty.is_triple() && to.is_triple() {
            return Val::V {
                v: b.retype(to.ir(), v),
                ty: to,
                varying,
            };
        }
        if osl && ty == Ty::Bool && matches!(to, Ty::Int | Ty::Float) {
            return Val::V {
                v: b.convert(to.ir(), v),
                ty: to,
                varying,
            };
        }
        if osl && ty == Ty::Bool && to.is_triple() {
            // A comparison is an int in OSL: widened as one (`color(a == b)`).
            v = b.convert(shadenet_graph::Type::Int, v);
            ty = Ty::Int;
        }
        if to == Ty::Matrix && matches!(ty, Ty::Int | Ty::Float) {
            // A number as a matrix: it on the diagonal (OSL's `matrix m = 1`).
            let f = if ty == Ty::Int {
                b.convert(shadenet_graph::Type::Float, v)
            } else {
                v
            };
            let v = super::matrix::diagonal(b, f);
            return Val::V { v, ty: to, varying };
        }
        if ty == Ty::Int && (to == Ty::Float || to.is_triple()) {
            v = b.convert(shadenet_graph::Type::Float, v);
            ty = Ty::Float;
            if to == Ty::Float {
                return Val::V { v, ty, varying };
            }
        }
        if ty == Ty::Float && to.is_triple() {
            let v = b.splat(to.ir(), v);
            return Val::V { v, ty: to, varying };
        }
        self.error(
            format!("expected {}, found {}", an(to.name()), an(ty.name())),
            span,
            format!("this is a {}", ty.name()),
        );
        Self::poison(b, to)
    }

    /// A value that must be an IR value (not a string), or an error.
    pub(crate) fn value(&mut self, b: &mut Builder, e: &'a Expr) -> (Value, Ty, bool) {
        let v = self.expr(b, e);
        self.plain(b, v, e.span)
    }

    /// `v` as an IR value, or an error (a string or a closure is not one).
    pub(crate) fn plain(&mut self, b: &mut Builder, v: Val, span: Span) -> (Value, Ty, bool) {
        match v {
            Val::V { v, ty, varying } => (v, ty, varying),
            other => {
                let what = other.type_name();
                self.error(
                    format!("a {what} cannot be used here"),
                    span,
                    format!("a {what}"),
                );
                (b.float(0.0), Ty::Float, false)
            }
        }
    }

    /// A condition: a comparison's truth; in OSL also an int or a float (true where not 0).
    pub(crate) fn truth(
        &mut self,
        b: &mut Builder,
        (v, t, vy): (Value, Ty, bool),
    ) -> (Value, Ty, bool) {
        if self.dialect != crate::Dialect::Osl || !matches!(t, Ty::Int | Ty::Float) {
            return (v, t, vy);
        }
        (super::nonzero(b, v, t), Ty::Bool, vy)
    }

    /// A condition expression ([`Lower::truth`] of its value).
    pub(crate) fn condition(&mut self, b: &mut Builder, e: &'a Expr) -> (Value, Ty, bool) {
        let v = self.value(b, e);
        self.truth(b, v)
    }

    /// Lowers an expression.
    pub(crate) fn expr(&mut self, b: &mut Builder, e: &'a Expr) -> Val {
        match &e.kind {
            ExprKind::Float(x) => self.number(b, *x, e.span),
            ExprKind::Int(i) if self.dialect == crate::Dialect::Osl => self.int(b, *i, e.span),
            ExprKind::Int(i) => self.number(b, *i as f64, e.span),
            ExprKind::Str(s) => Val::Str(s.clone()),
            ExprKind::Ident(id) => match self.lookup(&id.name).map(|v| v.val.clone()) {
                Some(Val::ArrayVar { .. } | Val::StructVar(_)) => self
                    .read_var(&id.name)
                    .unwrap_or_else(|| Self::poison(b, Ty::Float)),
                Some(v) => v,
                None => self.unknown(b, id, "name"),
            },
            ExprKind::Tuple(items) => self.triple(b, items, Ty::Point, e.span),
            ExprKind::Unary { op, operand } => self.unary(b, *op, operand, e.span),
            ExprKind::Binary { op, lhs, rhs } => self.binary(b, *op, lhs, rhs, e.span),
            ExprKind::Ternary { cond, then, els } => self.ternary(b, cond, then, els),
            ExprKind::Assign { op, target, value } => self.assign(b, *op, target, value, e.span),
            ExprKind::IncDec {
                increment,
                prefix,
                target,
            } => self.incdec(b, *increment, *prefix, target, e.span),
            ExprKind::Call { callee, args } => self.call(b, callee, args, e.span),
            ExprKind::Construct {
                ty,
                ty_span,
                space,
                args,
                ..
            } => self.construct(b, ty, *ty_span, space.as_ref(), args, e.span),
            ExprKind::Cast { ty, ty_span, expr } => {
                let to = self.base_type(ty, *ty_span);
                // `(color) noise(…)`: the cast is the type the call's result goes to.
                if matches!(expr.kind, ExprKind::Call { .. }) {
                    self.want = Some(to);
                }
                let v = self.expr(b, expr);
                self.want = None;
                self.cast(b, v, to, expr.span)
            }
            ExprKind::Index { base, index } => self.index(b, base, index),
            ExprKind::Member { base, field } if self.dialect == crate::Dialect::Osl => {
                self.member(b, base, field)
            }
            ExprKind::InitList(items) if self.dialect == crate::Dialect::Osl => {
                self.init_list(b, items, e.span)
            }
            ExprKind::Member { .. } | ExprKind::InitList(_) => {
                self.error(
                    "RSL has no structs: a `{…}` list initialises an array in its declaration",
                    e.span,
                    "not here",
                );
                Self::poison(b, Ty::Float)
            }
        }
    }

    /// The error for an unknown `what` (name, function), with the closest visible name.
    pub(crate) fn unknown(&mut self, b: &mut Builder, id: &ast::Ident, what: &str) -> Val {
        let names = self.visible_names();
        let hint = closest(&id.name, &names)
            .map(|c| format!(" (did you mean `{c}`?)"))
            .unwrap_or_default();
        self.error(
            format!("unknown {what} `{}`{hint}", id.name),
            id.span,
            "not defined",
        );
        Self::poison(b, Ty::Float)
    }

    /// An OSL integer literal.
    fn int(&mut self, b: &mut Builder, i: i64, span: Span) -> Val {
        let Ok(k) = i32::try_from(i) else {
            self.error(
                format!("{i} does not fit a 32-bit int"),
                span,
                "out of range",
            );
            return Self::poison(b, Ty::Int);
        };
        Val::V {
            v: b.int(k),
            ty: Ty::Int,
            varying: false,
        }
    }

    /// An explicit conversion `(ty) x` or `ty(x)`: as [`Lower::coerce`], and a float to an
    /// int (toward zero) where OSL allows it.
    fn cast(&mut self, b: &mut Builder, v: Val, to: Ty, span: Span) -> Val {
        match v {
            Val::V {
                v,
                ty: Ty::Float | Ty::Bool,
                varying,
            } if to == Ty::Int => Val::V {
                v: b.convert(shadenet_graph::Type::Int, v),
                ty: Ty::Int,
                varying,
            },
            v => self.coerce(b, v, to, span),
        }
    }

    /// OSL's `p.x`, `c.r`…: a component of a triple.
    fn member(&mut self, b: &mut Builder, base: &'a Expr, field: &ast::Ident) -> Val {
        let v = self.expr(b, base);
        if let Val::Struct(..) = v {
            return self.field_of(b, v, field);
        }
        let (v, ty, varying) = self.plain(b, v, base.span);
        let k = match component(&field.name) {
            Some(k) if ty.is_triple() => k,
            _ => {
                self.error(
                    format!(
                        "a {} has no field `{}` (structs are not built yet; triples have x, y, z or r, g, b)",
                        ty.name(),
                        field.name
                    ),
                    field.span,
                    "no such field",
                );
                return Self::poison(b, Ty::Float);
            }
        };
        Val::V {
            v: b.extract(v, k),
            ty: Ty::Float,
            varying,
        }
    }

    fn number(&mut self, b: &mut Builder, x: f64, span: Span) -> Val {
        if !(x.is_finite() && x.abs() <= f32::MAX as f64) {
            self.error(
                format!("{x} does not fit a 32-bit float"),
                span,
                "out of range",
            );
        }
        Val::V {
            v: b.float(x),
            ty: Ty::Float,
            varying: false,
        }
    }

    /// `(a, b, c)` as a `ty`.
    pub(crate) fn triple(&mut self, b: &mut Builder, items: &'a [Expr], ty: Ty, span: Span) -> Val {
        if items.len() != 3 {
            self.error(
                format!("a triple has 3 components, this has {}", items.len()),
                span,
                "expected (a, b, c)",
            );
            return Self::poison(b, ty);
        }
        let mut comps = Vec::new();
        let mut varying = false;
        for i in items {
            if let Val::V { v, varying: vy, .. } = self.expr_as(b, i, Ty::Float) {
                comps.push(v);
                varying |= vy;
            }
        }
        if comps.len() != 3 {
            return Self::poison(b, ty);
        }
        Val::V {
            v: b.construct(ty.ir(), &comps),
            ty,
            varying,
        }
    }

    /// The language type of a type name in a constructor or cast.
    fn base_type(&mut self, t: &ast::BaseType, span: Span) -> Ty {
        match t {
            ast::BaseType::Float => Ty::Float,
            ast::BaseType::Int if self.dialect == crate::Dialect::Osl => Ty::Int,
            ast::BaseType::Point => Ty::Point,
            ast::BaseType::Vector => Ty::Vector,
            ast::BaseType::Normal => Ty::Normal,
            ast::BaseType::Color => Ty::Color,
            ast::BaseType::Matrix => Ty::Matrix,
            _ => {
                self.error(
                    "only float, point, vector, normal, color and matrix values (and OSL's int) are built",
                    span,
                    "this type",
                );
                Ty::Float
            }
        }
    }

    fn unary(&mut self, b: &mut Builder, op: UnaryOp, operand: &'a Expr, span: Span) -> Val {
        // `-2147483648`: the literal is negated before it must fit an int.
        if let (UnaryOp::Neg, ExprKind::Int(i), crate::Dialect::Osl) =
            (op, &operand.kind, self.dialect)
        {
            return self.int(b, -i, span);
        }
        let v = self.expr(b, operand);
        if let Val::Struct(..) = v {
            let name = match op {
                UnaryOp::Neg => "-",
                UnaryOp::Not => "!",
                UnaryOp::BitNot => "~",
                UnaryOp::Plus => return v,
            };
            return self.operator(b, name, vec![(v, operand.span)], span);
        }
        let v = self.plain(b, v, operand.span);
        let (v, ty, varying) = match op {
            UnaryOp::Not => self.truth(b, v),
            _ => v,
        };
        let v = match (op, ty) {
            (UnaryOp::Plus, _) if ty != Ty::Bool => v,
            (UnaryOp::Neg, Ty::Matrix) => Self::matrix_neg(b, v),
            (UnaryOp::Neg, _) if ty != Ty::Bool => b.unary(UnOp::Neg, v),
            (UnaryOp::Not, Ty::Bool) => b.unary(UnOp::Not, v),
            (UnaryOp::BitNot, Ty::Int) => b.unary(UnOp::BitNot, v),
            _ => {
                self.error(
                    format!("this operator does not apply to a {}", ty.name()),
                    span,
                    format!("a {}", ty.name()),
                );
                return Self::poison(b, ty);
            }
        };
        Val::V { v, ty, varying }
    }

    /// The two operands of an arithmetic operator brought to one type (a float widened to
    /// the other's triple), and the result type: RSL's rules.
    fn arith(
        &mut self,
        b: &mut Builder,
        op: BinaryOp,
        (a, ta): (Value, Ty),
        (c, tc): (Value, Ty),
        span: Span,
    ) -> Option<(Value, Value, Ty)> {
        let bad = |me: &mut Self| {
            me.error(
                format!(
                    "`{}` does not combine a {} and a {}",
                    op.as_str(),
                    ta.name(),
                    tc.name()
                ),
                span,
                format!("{} and {}", ta.name(), tc.name()),
            );
            None
        };
        // OSL: truth values count as ints; ints widen to floats beside anything else.
        let osl = self.dialect == crate::Dialect::Osl;
        let (mut a, mut ta, mut c, mut tc) = (a, ta, c, tc);
        for (v, t) in [(&mut a, &mut ta), (&mut c, &mut tc)] {
            if osl && *t == Ty::Bool {
                *v = b.convert(shadenet_graph::Type::Int, *v);
                *t = Ty::Int;
            }
        }
        if ta == Ty::Int && tc == Ty::Int {
            return Some((a, c, Ty::Int));
        }
        for (v, t) in [(&mut a, &mut ta), (&mut c, &mut tc)] {
            if *t == Ty::Int {
                *v = b.convert(shadenet_graph::Type::Float, *v);
                *t = Ty::Float;
            }
        }
        if ta == Ty::Bool || tc == Ty::Bool || ta == Ty::Matrix || tc == Ty::Matrix {
            return bad(self);
        }
        if ta == Ty::Float && tc != Ty::Float {
            return Some((b.splat(tc.ir(), a), c, tc));
        }
        if tc == Ty::Float && ta != Ty::Float {
            return Some((a, b.splat(ta.ir(), c), ta));
        }
        if ta == tc {
            let ty = if ta == Ty::Point && op == BinaryOp::Sub {
                Ty::Vector
            } else {
                ta
            };
            return Some((a, c, ty));
        }
        if ta.is_geometric() && tc.is_geometric() {
            let ty = match (ta, tc, op) {
                (Ty::Point, _, _) | (_, Ty::Point, BinaryOp::Add) => Ty::Point,
                _ => Ty::Vector,
            };
            return Some((a, c, ty));
        }
        bad(self)
    }

    fn binary(
        &mut self,
        b: &mut Builder,
        op: BinaryOp,
        lhs: &'a Expr,
        rhs: &'a Expr,
        span: Span,
    ) -> Val {
        let l = self.expr(b, lhs);
        let r = self.expr(b, rhs);
        self.binary_vals(b, op, (l, lhs.span), (r, rhs.span), span)
    }

    /// A binary operator on lowered operands (with their spans, for errors).
    pub(crate) fn binary_vals(
        &mut self,
        b: &mut Builder,
        op: BinaryOp,
        (l, lspan): (Val, Span),
        (r, rspan): (Val, Span),
        span: Span,
    ) -> Val {
        if matches!(l, Val::Closure(_)) || matches!(r, Val::Closure(_)) {
            return self.closure_binary(b, op, &l, &r, span);
        }
        if matches!(l, Val::Struct(..)) || matches!(r, Val::Struct(..)) {
            return self.operator(b, op.as_str(), vec![(l, lspan), (r, rspan)], span);
        }
        // Strings are compile-time values: comparing two is a constant.
        if let (Val::Str(x), Val::Str(y), BinaryOp::Eq | BinaryOp::Ne) = (&l, &r, op) {
            return Val::V {
                v: b.boolean((x == y) == (op == BinaryOp::Eq)),
                ty: Ty::Bool,
                varying: false,
            };
        }
        let (a, ta, va) = self.plain(b, l, lspan);
        let (c, tc, vc) = self.plain(b, r, rspan);
        let varying = va || vc;
        let out = |v, ty| Val::V { v, ty, varying };
        if ta == Ty::Matrix || tc == Ty::Matrix {
            return match self.matrix_binary(b, op, (a, ta), (c, tc), span) {
                Some((v, ty)) => out(v, ty),
                None => Self::poison(b, Ty::Matrix),
            };
        }
        match op {
            BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul | BinaryOp::Div | BinaryOp::Rem => {
                let Some((a, c, ty)) = self.arith(b, op, (a, ta), (c, tc), span) else {
                    return Self::poison(b, ta);
                };
                if op == BinaryOp::Rem && self.dialect == crate::Dialect::Osl {
                    return out(rem(b, a, c, ty), ty);
                }
                let ir = match op {
                    BinaryOp::Add => BinOp::Add,
                    BinaryOp::Sub => BinOp::Sub,
                    BinaryOp::Mul => BinOp::Mul,
                    BinaryOp::Div => BinOp::Div,
                    _ => BinOp::Mod,
                };
                out(b.binary(ir, a, c), ty)
            }
            BinaryOp::Dot | BinaryOp::Cross => {
                if !(ta.is_geometric() && tc.is_geometric()) {
                    self.error(
                        format!(
                            "`{}` takes two points, vectors or normals, not a {} and a {}",
                            op.as_str(),
                            ta.name(),
                            tc.name()
                        ),
                        span,
                        "here",
                    );
                    return Self::poison(b, Ty::Float);
                }
                if op == BinaryOp::Dot {
                    out(b.dot(a, c), Ty::Float)
                } else {
                    out(b.binary(BinOp::Cross, a, c), Ty::Vector)
                }
            }
            BinaryOp::Lt
            | BinaryOp::Le
            | BinaryOp::Gt
            | BinaryOp::Ge
            | BinaryOp::Eq
            | BinaryOp::Ne => {
                let (a, c, ta, tc) = match (ta, tc) {
                    (Ty::Int, Ty::Float) => (b.convert(shadenet_graph::Type::Float, a), c, tc, tc),
                    (Ty::Float, Ty::Int) => (a, b.convert(shadenet_graph::Type::Float, c), ta, ta),
                    _ => (a, c, ta, tc),
                };
                let number = |t: Ty| matches!(t, Ty::Float | Ty::Int);
                // OSL's `==`/`!=` of two triples: every component equal (or not).
                if matches!(op, BinaryOp::Eq | BinaryOp::Ne)
                    && ta.is_triple()
                    && (ta == tc || (ta.is_geometric() && tc.is_geometric()))
                {
                    return out(triples_equal(b, op == BinaryOp::Ne, a, c), Ty::Bool);
                }
                if !number(ta) || ta != tc {
                    self.error(
                        format!(
                            "comparisons are built for floats (and `==`, `!=` of triples) only, not a {} and a {}",
                            ta.name(),
                            tc.name()
                        ),
                        span,
                        "here",
                    );
                    return Self::poison(b, Ty::Bool);
                }
                let ir = match op {
                    BinaryOp::Lt => BinOp::Lt,
                    BinaryOp::Le => BinOp::Le,
                    BinaryOp::Gt => BinOp::Gt,
                    BinaryOp::Ge => BinOp::Ge,
                    BinaryOp::Eq => BinOp::Eq,
                    _ => BinOp::Ne,
                };
                out(b.binary(ir, a, c), Ty::Bool)
            }
            BinaryOp::And | BinaryOp::Or => {
                let (a, ta, _) = self.truth(b, (a, ta, va));
                let (c, tc, _) = self.truth(b, (c, tc, vc));
                if ta != Ty::Bool || tc != Ty::Bool {
                    self.error(
                        format!(
                            "`{}` joins conditions, not a {} and a {}",
                            op.as_str(),
                            ta.name(),
                            tc.name()
                        ),
                        span,
                        "here",
                    );
                    return Self::poison(b, Ty::Bool);
                }
                let ir = if op == BinaryOp::And {
                    BinOp::And
                } else {
                    BinOp::Or
                };
                out(b.binary(ir, a, c), Ty::Bool)
            }
            BinaryOp::BitAnd
            | BinaryOp::BitOr
            | BinaryOp::BitXor
            | BinaryOp::Shl
            | BinaryOp::Shr => match self.bitwise(b, op, (a, ta), (c, tc), span) {
                Some(v) => out(v, Ty::Int),
                None => Self::poison(b, Ty::Int),
            },
        }
    }

    /// OSL's bitwise operators, defined on two ints (`None` after reporting anything else).
    fn bitwise(
        &mut self,
        b: &mut Builder,
        op: BinaryOp,
        (a, ta): (Value, Ty),
        (c, tc): (Value, Ty),
        span: Span,
    ) -> Option<Value> {
        if self.dialect != crate::Dialect::Osl || ta != Ty::Int || tc != Ty::Int {
            let why = if self.dialect == crate::Dialect::Osl {
                format!("not {} and {}", an(ta.name()), an(tc.name()))
            } else {
                "RSL has no integers (OSL's bitwise operators are)".to_string()
            };
            self.error(
                format!("`{}` takes two ints: {why}", op.as_str()),
                span,
                "here",
            );
            return None;
        }
        let ir = match op {
            BinaryOp::BitAnd => BinOp::BitAnd,
            BinaryOp::BitOr => BinOp::BitOr,
            BinaryOp::BitXor => BinOp::BitXor,
            BinaryOp::Shl => BinOp::Shl,
            _ => BinOp::Shr,
        };
        Some(b.binary(ir, a, c))
    }

    fn ternary(&mut self, b: &mut Builder, cond: &'a Expr, then: &'a Expr, els: &'a Expr) -> Val {
        let (c, tc, vc) = self.condition(b, cond);
        let (tv, ev) = (self.expr(b, then), self.expr(b, els));
        if tc == Ty::Bool && (matches!(tv, Val::Closure(_)) || matches!(ev, Val::Closure(_))) {
            let zero = |me: &mut Self, v: Val| match v {
                Val::V { .. } if Self::closure_or_zero(b, &v) => Val::Closure(Box::default()),
                v => {
                    if !matches!(v, Val::Closure(_)) {
                        me.error(
                            "both arms must be closures (or 0)",
                            then.span.to(els.span),
                            "here",
                        );
                    }
                    v
                }
            };
            let (tv, ev) = (zero(self, tv), zero(self, ev));
            return self.merge(b, (c, vc), tv, ev, then.span.to(els.span));
        }
        if tc != Ty::Bool {
            self.error(
                format!("a condition must be a comparison, not a {}", tc.name()),
                cond.span,
                "here",
            );
        }
        let (t, tt, vt) = self.plain(b, tv, then.span);
        let (e, te, ve) = self.plain(b, ev, els.span);
        let (t, e, ty) = if tt == te {
            (t, e, tt)
        } else {
            match self.arith(b, BinaryOp::Add, (t, tt), (e, te), then.span.to(els.span)) {
                Some(x) => x,
                None => return Self::poison(b, tt),
            }
        };
        if tc != Ty::Bool {
            return Self::poison(b, ty);
        }
        Val::V {
            v: b.select(c, t, e),
            ty,
            varying: vc || vt || ve,
        }
    }

    /// `s = value` for string variable `s`: `value` must be a string (strings are
    /// compile-time values: an assignment under a varying condition is refused where the
    /// arms meet, [`Lower::merge`]).
    fn assign_string(
        &mut self,
        b: &mut Builder,
        op: AssignOp,
        id: &ast::Ident,
        value: &'a Expr,
        span: Span,
    ) -> Val {
        if op != AssignOp::Set {
            self.error("strings are only assigned with `=`", span, "a string");
            return Val::Str(String::new());
        }
        match self.expr(b, value) {
            s @ Val::Str(_) => {
                self.rebind(id, s.clone(), true, span);
                s
            }
            other => {
                self.error(
                    format!("`{}` is a string: not {}", id.name, an(other.type_name())),
                    value.span,
                    "not a string",
                );
                Val::Str(String::new())
            }
        }
    }

    /// `x op= value`: the variable rebound to the new value, which is the expression's.
    fn assign(
        &mut self,
        b: &mut Builder,
        op: AssignOp,
        target: &'a Expr,
        value: &'a Expr,
        span: Span,
    ) -> Val {
        // `m[i][j]` of a matrix variable (or field: `s.m[i][j]`).
        if let Some((base, i, j)) = super::matrix::double_index(target)
            && let Some(id) = super::structs::place(base)
            && matches!(
                self.lookup(&id.name).map(|v| &v.val),
                Some(Val::V { ty: Ty::Matrix, .. })
            )
        {
            return self.assign_matrix_element(b, &id, (i, j), (op, value), span);
        }
        // `a[i].f` of an array of structs.
        if let ExprKind::Member { base, field } = &target.kind
            && let ExprKind::Index { base: array, index } = &base.kind
            && let Some(id) = super::structs::place(array)
            && matches!(
                self.lookup(&id.name).map(|v| &v.val),
                Some(Val::ArrayVar { ty: None, .. })
            )
        {
            return self.assign_element_field(b, (&id, index, field), (op, value), span);
        }
        // `a[i]`, `s.a[i]` (the field's hidden array variable), `s.f`, `s.f.g`.
        if let ExprKind::Index { base, index } = &target.kind
            && let Some(id) = super::structs::place(base)
        {
            return self.assign_index(b, (&id, index), super::arrays::Rhs::Expr(op, value), span);
        }
        if let ExprKind::Member { .. } = &target.kind
            && let Some(id) = super::structs::place(target)
            && self.lookup(&id.name).is_some()
        {
            return self.assign_field(b, op, (&id, target), value, span);
        }
        // `v.x`, `c.g` … of a triple variable (or field): its component, as `v[0]`.
        if let ExprKind::Member { base, field } = &target.kind
            && let Some(id) = super::structs::place(base)
            && matches!(self.lookup(&id.name).map(|v| &v.val), Some(Val::V { ty, .. }) if ty.is_triple())
            && let Some(k) = component(&field.name)
        {
            let rhs = super::arrays::Rhs::Expr(op, value);
            return self.assign_component(b, (&id, k), rhs, span);
        }
        let ExprKind::Ident(id) = &target.kind else {
            self.error(
                "only variables, array elements and components can be assigned",
                target.span,
                "not a variable",
            );
            return self.expr(b, value);
        };
        let Some(var) = self.lookup(&id.name).cloned() else {
            return self.unknown(b, id, "name");
        };
        let ty = match var.val {
            Val::V { ty, .. } => ty,
            Val::Closure(_) => return self.assign_closure(b, op, id, target, value, span),
            Val::ArrayVar { len, .. } if op == AssignOp::Set => {
                return self.assign_array(b, id, len, value);
            }
            Val::StructVar(s) => {
                let v = match compound_of(op) {
                    None => match self.struct_def(&s) {
                        Some(def) => self.expr_for_struct(b, value, def),
                        None => self.expr(b, value),
                    },
                    // `s op= x`: the struct's overloaded operator, then stored.
                    Some(bin) => {
                        let old = self.read_var(&id.name).unwrap_or(Val::Str(String::new()));
                        let x = self.expr(b, value);
                        self.binary_vals(b, bin, (old, target.span), (x, value.span), span)
                    }
                };
                if !matches!(&v, Val::Struct(t, _) if *t == s) {
                    self.error(
                        format!("`{}` is a `{s}`: not {}", id.name, an(v.type_name())),
                        value.span,
                        "wrong type",
                    );
                    return Self::poison(b, Ty::Float);
                }
                self.store(id, v.clone(), span);
                return v;
            }
            Val::Array(..) | Val::ArrayVar { .. } | Val::Struct(..) => {
                self.error(
                    format!(
                        "`{}` is an array or a struct: assign its parts, or all of it with `=`",
                        id.name
                    ),
                    span,
                    "an array",
                );
                return Self::poison(b, Ty::Float);
            }
            Val::Str(_) => return self.assign_string(b, op, id, value, span),
        };
        let rhs = match compound_of(op) {
            None => self.expr_as(b, value, ty),
            Some(bin) => {
                let v = self.binary(b, bin, target, value, span);
                self.coerce(b, v, ty, span)
            }
        };
        self.rebind(id, rhs.clone(), var.uniform, span);
        rhs
    }

    /// `c = x`, `c += x`, `c *= k`, `c /= k` for a closure variable `c` (`x` a closure or
    /// 0, `k` a float or a color).
    fn assign_closure(
        &mut self,
        b: &mut Builder,
        op: AssignOp,
        id: &ast::Ident,
        target: &'a Expr,
        value: &'a Expr,
        span: Span,
    ) -> Val {
        let v = match op {
            AssignOp::Set => {
                let v = self.expr(b, value);
                if Self::closure_or_zero(b, &v) && !matches!(v, Val::Closure(_)) {
                    Val::Closure(Box::default())
                } else {
                    v
                }
            }
            AssignOp::Add => self.binary(b, BinaryOp::Add, target, value, span),
            AssignOp::Mul => self.binary(b, BinaryOp::Mul, target, value, span),
            AssignOp::Div => self.binary(b, BinaryOp::Div, target, value, span),
            _ => Val::Str(String::new()),
        };
        if !matches!(v, Val::Closure(_)) {
            self.error(
                format!(
                    "`{}` is a closure: it takes a closure (or 0) by `=` and `+=`, and a float or color by `*=` and `/=`",
                    id.name
                ),
                span,
                "not a closure",
            );
            return Val::Closure(Box::default());
        }
        self.rebind(id, v.clone(), false, span);
        v
    }

    /// An operator with a closure operand ([`Lower::closure_arith`]), or an error.
    fn closure_binary(
        &mut self,
        b: &mut Builder,
        op: BinaryOp,
        l: &Val,
        r: &Val,
        span: Span,
    ) -> Val {
        match self.closure_arith(b, op, l, r) {
            Some(c) => Val::Closure(Box::new(c)),
            None => {
                self.error(
                    format!(
                        "`{}` does not combine a {} and a {}: closures add to closures and scale by a float or a color",
                        op.as_str(),
                        l.type_name(),
                        r.type_name()
                    ),
                    span,
                    "here",
                );
                Val::Closure(Box::default())
            }
        }
    }

    /// Stores `val` in the variable `id` where it lives; a uniform variable may not take a
    /// varying value.
    pub(crate) fn rebind(&mut self, id: &ast::Ident, val: Val, uniform: bool, span: Span) {
        if uniform && matches!(val, Val::V { varying: true, .. }) {
            let decl = self.lookup(&id.name).and_then(|v| v.decl);
            let mut d = crate::diag::Diagnostic::error(
                format!("uniform variable `{}` is assigned a varying value", id.name),
                span,
                "varying value",
            );
            if let Some(at) = decl {
                d = d.with_secondary(at, "declared uniform here");
            }
            if !self.stopped() {
                self.diags.push(d);
            }
        }
        for scope in self.scopes.iter_mut().rev() {
            if let Some(v) = scope.get_mut(&id.name) {
                v.val = val;
                return;
            }
        }
    }

    fn incdec(
        &mut self,
        b: &mut Builder,
        increment: bool,
        prefix: bool,
        target: &'a Expr,
        span: Span,
    ) -> Val {
        let before = self.expr(b, target);
        let ExprKind::Ident(id) = &target.kind else {
            self.error(
                "only variables can be incremented",
                target.span,
                "not a variable",
            );
            return before;
        };
        let (v, ty, varying) = match before.clone() {
            Val::V {
                v,
                ty: ty @ (Ty::Float | Ty::Int),
                varying,
            } => (v, ty, varying),
            _ => {
                self.error(
                    "`++` and `--` apply to floats and ints",
                    span,
                    "not a number",
                );
                return before;
            }
        };
        let one = if ty == Ty::Int {
            b.int(1)
        } else {
            b.float(1.0)
        };
        let after = if increment {
            b.add(v, one)
        } else {
            b.sub(v, one)
        };
        let after = Val::V {
            v: after,
            ty,
            varying,
        };
        let uniform = self.lookup(&id.name).is_some_and(|v| v.uniform);
        self.rebind(id, after.clone(), uniform, span);
        if prefix { after } else { before }
    }

    fn construct(
        &mut self,
        b: &mut Builder,
        ty: &ast::BaseType,
        ty_span: Span,
        space: Option<&(String, Span)>,
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let to = self.base_type(ty, ty_span);
        if to == Ty::Matrix {
            return self.matrix_construct(b, space, args, span);
        }
        // OSL's `point("object", x, y, z)`, `color("hsv", h, s, v)`: the space first.
        let named: Option<(String, Span)>;
        let (space, args) = match args {
            [first, rest @ ..] if rest.len() == 3 && space.is_none() && to.is_triple() => {
                match &first.kind {
                    ast::ExprKind::Str(s) => {
                        named = Some((s.clone(), first.span));
                        (named.as_ref(), rest)
                    }
                    _ => (space, args),
                }
            }
            _ => (space, args),
        };
        if let Some((s, at)) = space
            && to.is_geometric()
            && !matches!(s.as_str(), "current" | "world" | "common")
        {
            // Coordinates in space `s`, transformed to common space as `transform` does.
            let v = self.triple(b, args, to, span);
            let vals = [
                (Val::Str(s.clone()), *at),
                (Val::Str("common".into()), *at),
                (v, span),
            ];
            return self
                .transform_call(b, "transform", &vals, span)
                .unwrap_or_else(|| Self::poison(b, to));
        }
        let color_space = match space {
            None => None,
            Some((s, at)) if to == Ty::Color => match super::colorspace::space(s) {
                Some(cs) => Some(cs),
                None => {
                    self.error(
                        format!(
                            "unknown color space \"{s}\" (known: {})",
                            super::colorspace::NAMES
                        ),
                        *at,
                        "unknown color space",
                    );
                    return Self::poison(b, to);
                }
            },
            Some((s, _))
                if to.is_geometric() && matches!(s.as_str(), "current" | "world" | "common") =>
            {
                None
            }
            Some((s, at)) => {
                self.error(
                    format!(
                        "a {} takes no space \"{s}\" (colors take color spaces; points, vectors and normals the spaces `transform` knows)",
                        to.name()
                    ),
                    *at,
                    "wrong space",
                );
                return Self::poison(b, to);
            }
        };
        let v = match args {
            [one] if to == Ty::Int => {
                let v = self.expr(b, one);
                self.cast(b, v, to, one.span)
            }
            [one] => self.expr_as(b, one, to),
            [_, _, _] if to.is_triple() => self.triple(b, args, to, span),
            _ => {
                self.error(
                    format!(
                        "a {} is made of 1 or {} values, not {}",
                        to.name(),
                        if to.is_triple() { 3 } else { 1 },
                        args.len()
                    ),
                    span,
                    "here",
                );
                return Self::poison(b, to);
            }
        };
        match (v, color_space) {
            (Val::V { v, ty, varying }, Some(cs)) => Val::V {
                v: super::colorspace::to_rgb(b, cs, v),
                ty,
                varying,
            },
            (v, _) => v,
        }
    }
}

/// OSL's `%`: C's remainder (the sign of `a`) of ints, `fmod` of floats; 0 where `c` is 0.
fn rem(b: &mut Builder, a: Value, c: Value, ty: Ty) -> Value {
    if ty == Ty::Int {
        let q = b.div(a, c);
        let qc = b.mul(q, c);
        let r = b.sub(a, qc);
        let zero = b.int(0);
        let c0 = b.binary(BinOp::Eq, c, zero);
        return b.select(c0, zero, r);
    }
    super::components::componentwise2(b, a, c, ty, super::osl::fmod)
}

impl<'a> Lower<'a> {
    /// An operator on a struct: OSL's overload `__operator__NAME__` (`add`, `sub`, `mul`,
    /// `div`, `mod`, `neg`, `eq`, `ne`, `lt`, `le`, `gt`, `ge`, `not`…) inlined, or an error.
    fn operator(&mut self, b: &mut Builder, op: &str, vals: Vec<(Val, Span)>, span: Span) -> Val {
        let name = match (op, vals.len()) {
            ("+", 2) => "add",
            ("-", 2) => "sub",
            ("*", 2) => "mul",
            ("/", 2) => "div",
            ("%", 2) => "mod",
            ("-", 1) => "neg",
            ("!", 1) => "not",
            ("~", 1) => "compl",
            ("==", _) => "eq",
            ("!=", _) => "ne",
            ("<", _) => "lt",
            ("<=", _) => "le",
            (">", _) => "gt",
            (">=", _) => "ge",
            ("&&", _) => "and",
            ("||", _) => "or",
            ("&", _) => "bitand",
            ("|", _) => "bitor",
            ("^", _) => "xor",
            ("<<", _) => "shl",
            (">>", _) => "shr",
            _ => "",
        };
        let f = format!("__operator__{name}__");
        if name.is_empty() || !self.functions.contains_key(f.as_str()) {
            let types: Vec<&str> = vals.iter().map(|(v, _)| v.type_name()).collect();
            self.error(
                format!(
                    "`{op}` on ({}): define `{f}` for these types",
                    types.join(", ")
                ),
                span,
                "no operator",
            );
            return Self::poison(b, Ty::Float);
        }
        let found = self.overload(&f, &vals, &(None, None));
        self.user_call(b, (&f, found), vals, &[], span)
    }
}

/// The component of a triple that OSL's field `name` is: `x`/`r` 0, `y`/`g` 1, `z`/`b` 2.
fn component(name: &str) -> Option<usize> {
    match name {
        "x" | "r" => Some(0),
        "y" | "g" => Some(1),
        "z" | "b" => Some(2),
        _ => None,
    }
}

/// Whether triples `a` and `c` are equal in every component (`not`: whether they differ).
fn triples_equal(b: &mut Builder, not: bool, a: Value, c: Value) -> Value {
    let mut all = b.boolean(true);
    for k in 0..3 {
        let (x, y) = (b.extract(a, k), b.extract(c, k));
        let e = b.binary(BinOp::Eq, x, y);
        all = b.binary(BinOp::And, all, e);
    }
    if not {
        b.unary(shadenet_graph::ir::UnOp::Not, all)
    } else {
        all
    }
}
