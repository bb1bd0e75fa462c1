//! `matrix` values (OSL's, and RSL's which are the same): the type, its constructors,
//! operators, element access and builtins. A language matrix is a 4×4 of row vectors
//! (`p·M`, OSL's and RenderMan's convention); the IR's `matrix44` is a column-vector matrix
//! (`M·p`) stored row-major, so — as the MaterialX front end does
//! (`shadenet_graph::mtlx::atoms_matrix`) — **a language matrix `M` is held as the IR value
//! `Mᵀ`**, and every formula is rewritten for it: `A * B` is `Bᵀ·Aᵀ`, `A / B` is
//! `inverse(Bᵀ)·Aᵀ`, `transform(M, p)` is `Mᵀ·p`, the element `M[r][c]` is the IR element
//! `c·4 + r`, and `matrix(16 floats)` (row by row) fills the IR matrix column by column.
//! Determinant and inverse commute with transposing. The formulas themselves (product,
//! transpose, determinant, inverse) are `shadenet_graph::ir::matrix`'s, element by element,
//! so every back end runs them as floats.
//!
//! Named spaces: `"common"` and `"world"` are the renderer's world space, `"object"` and
//! `"camera"` the shading context's; a space matrix is built honestly from the IR's
//! `transform` op (the images of the three axes and of the origin: exact elements of the
//! affine map the renderer uses). Other spaces (`"shader"`, `"screen"`, `"NDC"`, `"raster"`,
//! named coordinate systems) are an error naming the space. It owns the language's matrix
//! rules; it must not hold op semantics.

use super::arrays::Position;
use super::{Lower, Ty, Val, an};
use crate::Dialect;
use crate::ast::{self, BinaryOp, Expr, ExprKind};
use crate::source::Span;
use shadenet_graph::ir::matrix::{self as mx, Mat};
use shadenet_graph::ir::{BinOp, Builder, Op, Space, UnOp, Value, XformKind};
use shadenet_graph::{ConstValue, Type};

/// The matrix builtins (both dialects; `vtransform`/`ntransform` are RSL's).
pub(crate) const NAMES: &[&str] = &[
    "determinant",
    "transpose",
    "inverse",
    "transform",
    "getmatrix",
];

/// RSL's spellings of `transform` for vectors and normals.
pub(crate) const RSL_NAMES: &[&str] = &["vtransform", "ntransform"];

/// The IR element index of the language element `M[r][c]` (the IR holds `Mᵀ`).
pub(crate) fn slot(r: usize, c: usize) -> usize {
    c * 4 + r
}

/// The renderer space a space name stands for, or `None` where we have none. OSL's
/// `"shader"` space is the one the shader was bound in; ours are bound to objects with no
/// transform of their own, so it is object space (as in Cycles).
fn space(name: &str) -> Option<Space> {
    match name {
        "common" | "world" | "current" => Some(Space::World),
        "object" | "shader" => Some(Space::Object),
        "camera" => Some(Space::Camera),
        _ => None,
    }
}

/// A matrix value of the elements `e` (IR order) and whether it varies.
fn mat_val(b: &mut Builder, m: &Mat, varying: bool) -> Val {
    Val::V {
        v: m.build(b),
        ty: Ty::Matrix,
        varying,
    }
}

/// `f` on the diagonal, 0 elsewhere (OSL's `matrix(f)`, and a float assigned to a matrix).
pub(crate) fn diagonal(b: &mut Builder, f: Value) -> Value {
    let zero = b.float(0.0);
    let e: Vec<Value> = (0..16).map(|i| if i % 5 == 0 { f } else { zero }).collect();
    b.construct(Type::Matrix44, &e)
}

impl<'a> Lower<'a> {
    /// The space named `name` (at `at`), or an error naming it.
    fn named_space(&mut self, name: &str, at: Span) -> Option<Space> {
        let s = space(name);
        if s.is_none() {
            self.error(
                format!(
                    "the space \"{name}\" is not available here: matrices and transforms are built for \"common\" (= \"world\"), \"object\" (= \"shader\") and \"camera\""
                ),
                at,
                "unknown space",
            );
        }
        s
    }

    /// The IR matrix (ours, column vectors) taking `from` coordinates to `to` coordinates,
    /// from the IR's transform of the axes and the origin; the identity where they match.
    fn space_matrix(b: &mut Builder, from: Space, to: Space) -> (Value, bool) {
        if from == to {
            return (b.constant(ConstValue::identity()), false);
        }
        let mut cols: Vec<[Value; 3]> = Vec::new();
        for k in 0..4 {
            let mut e = [0.0; 3];
            if k < 3 {
                e[k] = 1.0;
            }
            let arg = b.constant(ConstValue::Vec3(e));
            let kind = if k < 3 {
                XformKind::Vector
            } else {
                XformKind::Point
            };
            let t = b.push(
                Op::Transform {
                    kind,
                    from,
                    to,
                    arg,
                },
                Some(Type::Vec3),
            );
            cols.push([b.extract(t, 0), b.extract(t, 1), b.extract(t, 2)]);
        }
        let (zero, one) = (b.float(0.0), b.float(1.0));
        let e: Vec<Value> = (0..16)
            .map(|i| match (i / 4, i % 4) {
                (3, c) => {
                    if c == 3 {
                        one
                    } else {
                        zero
                    }
                }
                (r, c) => cols[c][r],
            })
            .collect();
        (b.construct(Type::Matrix44, &e), true)
    }

    /// A matrix constructor: `matrix(f)`, `matrix(16 floats)` (row by row), `matrix(M)`,
    /// `matrix("from")` (from `from` to common), `matrix("from", "to")`, and a numeric
    /// matrix given in a space (`matrix "object" (…)`, `matrix("object", …)`): relative to
    /// that space, i.e. followed by the space's matrix to common.
    pub(crate) fn matrix_construct(
        &mut self,
        b: &mut Builder,
        space: Option<&(String, Span)>,
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let vals: Vec<(Val, Span)> = args.iter().map(|a| (self.expr(b, a), a.span)).collect();
        let strings = vals
            .iter()
            .take_while(|(v, _)| matches!(v, Val::Str(_)))
            .count();
        let mut names: Vec<(String, Span)> = space.iter().map(|(s, at)| (s.clone(), *at)).collect();
        for (v, at) in &vals[..strings] {
            if let Val::Str(s) = v {
                names.push((s.clone(), *at));
            }
        }
        let nums = &vals[strings..];
        if names.len() > 2 || (names.len() == 2 && !nums.is_empty()) {
            self.error(
                "a matrix is made of a float, 16 floats, (\"from\"), (\"from\", \"to\") or (\"from\", a float or 16 floats)",
                span,
                "wrong arguments",
            );
            return Self::poison(b, Ty::Matrix);
        }
        if nums.is_empty() && names.len() == 2 && names[0].0 == names[1].0 {
            // From a space to itself: the identity, whatever the space.
            return Val::V {
                v: b.constant(ConstValue::identity()),
                ty: Ty::Matrix,
                varying: false,
            };
        }
        let mut spaces = Vec::new();
        for (n, at) in &names {
            match self.named_space(n, *at) {
                Some(s) => spaces.push(s),
                None => return Self::poison(b, Ty::Matrix),
            }
        }
        if nums.is_empty() {
            let Some(&from) = spaces.first() else {
                self.error(
                    "a matrix is made of a float, 16 floats or space names",
                    span,
                    "no arguments",
                );
                return Self::poison(b, Ty::Matrix);
            };
            let to = spaces.get(1).copied().unwrap_or(Space::World);
            let (v, varying) = Self::space_matrix(b, from, to);
            return Val::V {
                v,
                ty: Ty::Matrix,
                varying,
            };
        }
        let Some(m) = self.matrix_of_numbers(b, nums, span) else {
            return Self::poison(b, Ty::Matrix);
        };
        match spaces.first() {
            None => m,
            Some(&from) => {
                // Relative to `from`: M · matrix(from, common); ours S_from·Mᵀ.
                let (s, vs) = Self::space_matrix(b, from, Space::World);
                let Val::V { v, varying, .. } = m else {
                    return m;
                };
                let r = self.mat_product(b, s, v);
                Val::V {
                    v: r,
                    ty: Ty::Matrix,
                    varying: varying || vs,
                }
            }
        }
    }

    /// `matrix(f)`, `matrix(M)` or `matrix(16 floats)` of lowered arguments.
    fn matrix_of_numbers(
        &mut self,
        b: &mut Builder,
        nums: &[(Val, Span)],
        span: Span,
    ) -> Option<Val> {
        match nums {
            [(v, at)] => Some(self.coerce(b, v.clone(), Ty::Matrix, *at)),
            _ if nums.len() == 16 => {
                let mut e = vec![b.float(0.0); 16];
                let mut varying = false;
                for (k, (v, at)) in nums.iter().enumerate() {
                    if let Val::V { v, varying: vy, .. } = self.coerce(b, v.clone(), Ty::Float, *at)
                    {
                        e[slot(k / 4, k % 4)] = v;
                        varying |= vy;
                    }
                }
                Some(Val::V {
                    v: b.construct(Type::Matrix44, &e),
                    ty: Ty::Matrix,
                    varying,
                })
            }
            _ => {
                self.error(
                    format!("a matrix is made of 1 or 16 floats, not {}", nums.len()),
                    span,
                    "wrong number of values",
                );
                None
            }
        }
    }

    /// The IR product `x·y` of two IR matrices.
    fn mat_product(&mut self, b: &mut Builder, x: Value, y: Value) -> Value {
        match (Mat::of(b, x), Mat::of(b, y)) {
            (Ok(x), Ok(y)) => mx::product(b, &x, &y).build(b),
            _ => b.zero(Type::Matrix44),
        }
    }

    /// A binary operator with a matrix operand (`(a, ta)` and `(c, tc)` lowered values):
    /// `*`, `/` (matrix, float or int on either side), `+`, `-` (two matrices), `==`, `!=`.
    pub(crate) fn matrix_binary(
        &mut self,
        b: &mut Builder,
        op: BinaryOp,
        (a, ta): (Value, Ty),
        (c, tc): (Value, Ty),
        span: Span,
    ) -> Option<(Value, Ty)> {
        let (a, ta) = to_float(b, a, ta);
        let (c, tc) = to_float(b, c, tc);
        let scalar = |t: Ty| t == Ty::Float;
        let both = ta == Ty::Matrix && tc == Ty::Matrix;
        let ok = both
            || (matches!(op, BinaryOp::Mul | BinaryOp::Div)
                && ((ta == Ty::Matrix && scalar(tc)) || (scalar(ta) && tc == Ty::Matrix)));
        if !ok {
            self.error(
                format!(
                    "`{}` does not combine {} and {} (matrices multiply and divide by matrices and floats, and add, subtract and compare to matrices)",
                    op.as_str(),
                    an(ta.name()),
                    an(tc.name())
                ),
                span,
                format!("{} and {}", ta.name(), tc.name()),
            );
            return None;
        }
        let (ma, mc) = (Mat::of(b, a).ok(), Mat::of(b, c).ok());
        let each = |b: &mut Builder,
                    m: &Mat,
                    s: Value,
                    f: &dyn Fn(&mut Builder, Value, Value) -> Value| {
            m.map(|x| f(b, *x, s))
        };
        let r = match (op, ma, mc) {
            (BinaryOp::Mul, Some(x), Some(y)) => mx::product(b, &y, &x),
            (BinaryOp::Div, Some(x), Some(y)) => {
                let yi = mx::inverse(b, &y);
                mx::product(b, &yi, &x)
            }
            (BinaryOp::Mul, Some(x), None) => each(b, &x, c, &|b, e, s| b.mul(e, s)),
            (BinaryOp::Mul, None, Some(y)) => each(b, &y, a, &|b, e, s| b.mul(s, e)),
            (BinaryOp::Div, Some(x), None) => each(b, &x, c, &|b, e, s| b.div(e, s)),
            (BinaryOp::Div, None, Some(y)) => {
                // f / M = f · inverse(M).
                let yi = mx::inverse(b, &y);
                each(b, &yi, a, &|b, e, s| b.mul(s, e))
            }
            (BinaryOp::Add | BinaryOp::Sub, Some(x), Some(y)) => {
                let ir = if op == BinaryOp::Add {
                    BinOp::Add
                } else {
                    BinOp::Sub
                };
                let e =
                    x.e.iter()
                        .zip(&y.e)
                        .map(|(p, q)| b.binary(ir, *p, *q))
                        .collect();
                Mat { n: 4, e }
            }
            (BinaryOp::Eq | BinaryOp::Ne, Some(x), Some(y)) => {
                let mut all = b.binary(BinOp::Eq, x.e[0], y.e[0]);
                for k in 1..16 {
                    let q = b.binary(BinOp::Eq, x.e[k], y.e[k]);
                    all = b.binary(BinOp::And, all, q);
                }
                let v = if op == BinaryOp::Ne {
                    b.unary(UnOp::Not, all)
                } else {
                    all
                };
                return Some((v, Ty::Bool));
            }
            _ => {
                self.error(
                    format!("`{}` does not apply to matrices", op.as_str()),
                    span,
                    "not a matrix operator",
                );
                return None;
            }
        };
        Some((r.build(b), Ty::Matrix))
    }

    /// `-M`, element by element.
    pub(crate) fn matrix_neg(b: &mut Builder, m: Value) -> Value {
        match Mat::of(b, m) {
            Ok(x) => x.map(|e| b.unary(UnOp::Neg, *e)).build(b),
            Err(_) => m,
        }
    }

    /// `M[i][j]` read: one element for constant indices, a chain of selects over the 16
    /// for run-time ones (each clamped to 0…3, as array indices are).
    pub(crate) fn matrix_read(
        &mut self,
        b: &mut Builder,
        (m, varying): (Value, bool),
        i: &'a Expr,
        j: &'a Expr,
    ) -> Val {
        let Some(pos) = self.matrix_position(b, i, j) else {
            return Self::poison(b, Ty::Float);
        };
        let elems: Vec<Val> = (0..16)
            .map(|k| Val::V {
                v: b.extract(m, k),
                ty: Ty::Float,
                varying,
            })
            .collect();
        self.pick(b, &elems, &pos, i.span.to(j.span))
    }

    /// The IR position of `M[i][j]`: known for constant indices, else `j·4 + i` computed
    /// from the clamped indices.
    fn matrix_position(&mut self, b: &mut Builder, i: &'a Expr, j: &'a Expr) -> Option<Position> {
        let (pi, pj) = (self.position(b, i, 4), self.position(b, j, 4));
        let as_int = |b: &mut Builder, p: &Position| match *p {
            Position::Known(k) => Some((b.int(k as i32), false)),
            Position::Computed(v, vy) => Some((v, vy)),
            Position::Bad => None,
        };
        match (&pi, &pj) {
            (Position::Known(r), Position::Known(c)) => Some(Position::Known(slot(*r, *c))),
            _ => {
                let (r, vr) = as_int(b, &pi)?;
                let (c, vc) = as_int(b, &pj)?;
                let four = b.int(4);
                let c4 = b.mul(c, four);
                Some(Position::Computed(b.add(c4, r), vr || vc))
            }
        }
    }

    /// `M[i][j] op= value` for the matrix variable `id`: the element (or, for run-time
    /// indices, every element where the position matches) replaced; the variable rebound.
    pub(crate) fn assign_matrix_element(
        &mut self,
        b: &mut Builder,
        id: &ast::Ident,
        (i, j): (&'a Expr, &'a Expr),
        (op, value): (ast::AssignOp, &'a Expr),
        span: Span,
    ) -> Val {
        let Some(var) = self.lookup(&id.name).cloned() else {
            return self.unknown(b, id, "name");
        };
        let Val::V {
            v: m,
            ty: Ty::Matrix,
            varying,
        } = var.val
        else {
            return Self::poison(b, Ty::Float);
        };
        let Some(pos) = self.matrix_position(b, i, j) else {
            return Self::poison(b, Ty::Float);
        };
        let mut elems: Vec<Val> = (0..16)
            .map(|k| Val::V {
                v: b.extract(m, k),
                ty: Ty::Float,
                varying,
            })
            .collect();
        let rhs = match super::compound_of(op) {
            None => self.expr_as(b, value, Ty::Float),
            Some(bin) => {
                let old = self.pick(b, &elems, &pos, span);
                let v = self.expr(b, value);
                let v = self.binary_vals(b, bin, (old, span), (v, value.span), span);
                self.coerce(b, v, Ty::Float, span)
            }
        };
        match pos {
            Position::Known(k) => elems[k] = rhs.clone(),
            Position::Computed(at, vi) => {
                for (k, e) in elems.iter_mut().enumerate() {
                    let kk = b.int(k as i32);
                    let here = b.binary(BinOp::Eq, at, kk);
                    *e = self.merge(b, (here, vi), rhs.clone(), e.clone(), span);
                }
            }
            Position::Bad => {}
        }
        let mut comps = Vec::new();
        let mut vy = false;
        for e in &elems {
            if let Val::V { v, varying, .. } = e {
                comps.push(*v);
                vy |= varying;
            }
        }
        let v = b.construct(Type::Matrix44, &comps);
        self.rebind(
            id,
            Val::V {
                v,
                ty: Ty::Matrix,
                varying: vy,
            },
            var.uniform,
            span,
        );
        rhs
    }
}

/// An int operand as a float (a matrix or a float unchanged).
fn to_float(b: &mut Builder, v: Value, t: Ty) -> (Value, Ty) {
    match t {
        Ty::Int | Ty::Bool => {
            let v = if t == Ty::Bool {
                b.convert(Type::Int, v)
            } else {
                v
            };
            (b.convert(Type::Float, v), Ty::Float)
        }
        _ => (v, t),
    }
}

/// Whether `e` is `base[i][j]` (an element of a matrix, if `base` is one).
pub(crate) fn double_index(e: &Expr) -> Option<(&Expr, &Expr, &Expr)> {
    match &e.kind {
        ExprKind::Index { base, index: j } => match &base.kind {
            ExprKind::Index { base, index: i } => Some((base, i, j)),
            _ => None,
        },
        _ => None,
    }
}

impl<'a> Lower<'a> {
    /// A matrix builtin, or `None` when `name` is not one: `determinant`, `transpose`,
    /// `inverse`, `transform(M, p)` (a point with OSL's division by w where w ≠ 0, a vector,
    /// a normal by the inverse transpose, by the argument's type; RSL's `transform` always
    /// a point, `vtransform`/`ntransform` vectors/normals), `transform("to", p)`,
    /// `transform("from", "to", p)`, `getmatrix("from", "to", output M)`.
    pub(crate) fn matrix_builtin(
        &mut self,
        b: &mut Builder,
        name: &str,
        vals: &[(Val, Span)],
        args: &'a [Expr],
        span: Span,
    ) -> Option<Val> {
        let rsl = self.dialect == Dialect::Rsl;
        if !(NAMES.contains(&name) || (rsl && RSL_NAMES.contains(&name))) {
            return None;
        }
        let bad = |me: &mut Self, b: &mut Builder, sig: &str, ty: Ty| {
            let got: Vec<&str> = vals.iter().map(|(v, _)| v.type_name()).collect();
            me.error(
                format!(
                    "`{name}` does not take ({}): it takes {sig}",
                    got.join(", ")
                ),
                span,
                "wrong arguments",
            );
            Some(Self::poison(b, ty))
        };
        match name {
            "determinant" | "transpose" | "inverse" => {
                let [
                    (
                        Val::V {
                            v,
                            ty: Ty::Matrix,
                            varying,
                        },
                        _,
                    ),
                ] = vals
                else {
                    return bad(self, b, "(matrix)", Ty::Float);
                };
                let x = Mat::of(b, *v).ok()?;
                Some(match name {
                    "determinant" => Val::V {
                        v: mx::determinant(b, &x),
                        ty: Ty::Float,
                        varying: *varying,
                    },
                    "transpose" => mat_val(b, &mx::transpose(&x), *varying),
                    _ => {
                        let inv = mx::inverse(b, &x);
                        mat_val(b, &inv, *varying)
                    }
                })
            }
            "getmatrix" => self.getmatrix(b, vals, args, span),
            _ => self.transform_call(b, name, vals, span),
        }
    }

    /// `getmatrix("from", "to", output M)`: `M = matrix("from", "to")`, and 1 (success).
    fn getmatrix(
        &mut self,
        b: &mut Builder,
        vals: &[(Val, Span)],
        args: &'a [Expr],
        span: Span,
    ) -> Option<Val> {
        let ([(Val::Str(f), fa), (Val::Str(t), ta), _], [_, _, out]) = (vals, args) else {
            self.error(
                "`getmatrix` takes (string from, string to, output matrix M)",
                span,
                "wrong arguments",
            );
            return Some(Self::poison(b, Ty::Int));
        };
        let ExprKind::Ident(id) = &out.kind else {
            self.error(
                "getmatrix writes a matrix variable",
                out.span,
                "not a variable",
            );
            return Some(Self::poison(b, Ty::Int));
        };
        let (Some(from), Some(to)) = (self.named_space(f, *fa), self.named_space(t, *ta)) else {
            return Some(Self::poison(b, Ty::Int));
        };
        let (v, varying) = Self::space_matrix(b, from, to);
        let uniform = match self.lookup(&id.name) {
            Some(super::Var {
                val: Val::V { ty: Ty::Matrix, .. },
                uniform,
                ..
            }) => *uniform,
            _ => {
                self.error(
                    "getmatrix writes a matrix variable",
                    out.span,
                    "not a matrix",
                );
                return Some(Self::poison(b, Ty::Int));
            }
        };
        let m = Val::V {
            v,
            ty: Ty::Matrix,
            varying,
        };
        self.rebind(id, m, uniform, span);
        let one = if self.dialect == Dialect::Osl {
            b.int(1)
        } else {
            b.float(1.0)
        };
        let ty = if self.dialect == Dialect::Osl {
            Ty::Int
        } else {
            Ty::Float
        };
        Some(Val::V {
            v: one,
            ty,
            varying: false,
        })
    }

    /// `transform`, `vtransform`, `ntransform` by a matrix or between named spaces.
    pub(crate) fn transform_call(
        &mut self,
        b: &mut Builder,
        name: &str,
        vals: &[(Val, Span)],
        span: Span,
    ) -> Option<Val> {
        let Some(((p, pty, pvary), rest)) =
            vals.split_last().and_then(|(last, rest)| match &last.0 {
                Val::V { v, ty, varying } if ty.is_triple() => Some(((*v, *ty, *varying), rest)),
                _ => None,
            })
        else {
            self.error(
                format!("`{name}` takes (matrix M, p), (string to, p) or (string from, string to, p), p a point, vector or normal"),
                span,
                "wrong arguments",
            );
            return Some(Self::poison(b, Ty::Point));
        };
        let kind = match (name, self.dialect, pty) {
            ("vtransform", ..) => XformKind::Vector,
            ("ntransform", ..) => XformKind::Normal,
            (_, Dialect::Rsl, _) => XformKind::Point,
            (_, _, Ty::Vector) => XformKind::Vector,
            (_, _, Ty::Normal) => XformKind::Normal,
            _ => XformKind::Point,
        };
        let out_ty = if pty == Ty::Color { Ty::Point } else { pty };
        match rest {
            [
                (
                    Val::V {
                        v: m,
                        ty: Ty::Matrix,
                        varying,
                    },
                    _,
                ),
            ] => {
                let v = by_matrix(b, kind, *m, p);
                Some(Val::V {
                    v,
                    ty: out_ty,
                    varying: *varying || pvary,
                })
            }
            [(Val::Str(_), _)] | [(Val::Str(_), _), (Val::Str(_), _)] => {
                let mut names = rest.iter().filter_map(|(v, at)| match v {
                    Val::Str(s) => Some((s.clone(), *at)),
                    _ => None,
                });
                let (a, aat) = names.next()?;
                let second = names.next();
                if second.as_ref().is_some_and(|(t, _)| *t == a) {
                    // From a space to itself (even one we do not have, or MaterialX's
                    // empty default): `p` unchanged.
                    return Some(Val::V {
                        v: p,
                        ty: out_ty,
                        varying: pvary,
                    });
                }
                let spaces = match second {
                    None => (Some(Space::World), self.named_space(&a, aat)),
                    Some((t, tat)) => (self.named_space(&a, aat), self.named_space(&t, tat)),
                };
                let (Some(from), Some(to)) = spaces else {
                    return Some(Self::poison(b, out_ty));
                };
                if from == to {
                    return Some(Val::V {
                        v: p,
                        ty: out_ty,
                        varying: pvary,
                    });
                }
                let v = b.push(
                    Op::Transform {
                        kind,
                        from,
                        to,
                        arg: p,
                    },
                    Some(Type::Vec3),
                );
                Some(Val::V {
                    v,
                    ty: out_ty,
                    varying: true,
                })
            }
            _ => {
                self.error(
                    format!("`{name}` takes (matrix M, p), (string to, p) or (string from, string to, p)"),
                    span,
                    "wrong arguments",
                );
                Some(Self::poison(b, out_ty))
            }
        }
    }
}

/// `p·M` of the language (the IR's `Mᵀ·p` with `m` holding `Mᵀ`): a point with w = 1,
/// divided by the resulting w, or the origin where w is 0 (OSL's `robust_multVecMatrix`;
/// w is exactly 1 for an affine matrix, so the division changes no bit), a vector
/// with w = 0, a normal by the inverse transpose.
fn by_matrix(b: &mut Builder, kind: XformKind, m: Value, p: Value) -> Value {
    let p = b.retype(Type::Vec3, p);
    match kind {
        XformKind::Vector => b.binary(BinOp::MulVector, m, p),
        XformKind::Normal => match Mat::of(b, m) {
            Ok(x) => {
                let inv = mx::inverse(b, &x);
                let it = mx::transpose(&inv).build(b);
                b.binary(BinOp::MulVector, it, p)
            }
            Err(_) => p,
        },
        XformKind::Point => {
            let q = b.binary(BinOp::MulPoint, m, p);
            let row: Vec<Value> = (12..16).map(|k| b.extract(m, k)).collect();
            let p0 = b.extract(p, 0);
            let mut w = b.mul(row[0], p0);
            for (k, rk) in row.iter().enumerate().take(3).skip(1) {
                let pk = b.extract(p, k);
                let t = b.mul(*rk, pk);
                w = b.add(w, t);
            }
            w = b.add(w, row[3]);
            let zero = b.float(0.0);
            let nz = b.binary(BinOp::Ne, w, zero);
            let ww = b.splat(Type::Vec3, w);
            let d = b.div(q, ww);
            let origin = b.zero(Type::Vec3);
            b.select(nz, d, origin)
        }
    }
}
