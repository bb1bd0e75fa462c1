//! Calls: user functions (overloads chosen by argument types, then inlined) and RSL's
//! builtins, each lowered to IR ops by the RenderMan Interface's definition: `diffuse`,
//! `specular` and `phong` are light loops over the scene's lights (with RSL's
//! normalisation: `diffuse` has no 1/π), `ambient` is the ambient light, `trace` traces a
//! reflection ray, `noise` is OSL's Perlin noise mapped to [0, 1].

use super::geometry::{reflect, refract};
use super::{Lower, Ty, Val, osl};
use crate::Dialect;
use crate::ast::{self, Expr};
use crate::source::Span;
use shadenet_graph::Type;
use shadenet_graph::ir::{BinOp, Builder, Intrinsic, RAY_REFLECTION, Stream, UnOp, Value};

/// The builtins' names (for "did you mean").
pub(crate) const NAMES: &[&str] = &[
    "abs",
    "floor",
    "ceil",
    "sqrt",
    "exp",
    "log",
    "sin",
    "cos",
    "tan",
    "asin",
    "acos",
    "atan",
    "pow",
    "min",
    "max",
    "mod",
    "clamp",
    "mix",
    "step",
    "smoothstep",
    "radians",
    "degrees",
    "length",
    "normalize",
    "distance",
    "faceforward",
    "reflect",
    "refract",
    "fresnel",
    "xcomp",
    "ycomp",
    "zcomp",
    "comp",
    "ambient",
    "diffuse",
    "specular",
    "phong",
    "trace",
    "noise",
    "texture",
    "arraylength",
    "spline",
];

/// The signatures, for errors: `name(args) -> result`.
fn signature(name: &str) -> &'static str {
    match name {
        "abs" | "floor" | "ceil" | "sqrt" | "exp" | "log" | "sin" | "cos" | "tan" | "asin"
        | "acos" => "(float or triple) -> same",
        "atan" => "(float y[, float x]) -> float",
        "pow" | "min" | "max" | "mod" => "(a, b) of one type (a float widens) -> that type",
        "clamp" => "(x, lo, hi) -> x's type",
        "mix" => "(a, b, float t) -> a's type",
        "step" => "(float edge, float x) -> float",
        "smoothstep" => "(float e0, float e1, float x) -> float",
        "radians" | "degrees" => "(float) -> float",
        "length" => "(vector) -> float",
        "normalize" => "(vector) -> vector",
        "distance" => "(point, point) or (point a, point b, point q) -> float",
        "rotate" => {
            "(point p, float angle, vector axis) or (point p, float angle, point a, point b) -> point"
        }
        "logb" => "(float or triple) -> same",
        "faceforward" => "(normal N, vector I[, normal Nref]) -> normal",
        "reflect" => "(vector I, normal N) -> vector",
        "refract" => "(vector I, normal N, float eta) -> vector",
        "fresnel" => {
            "(vector I, normal N, float eta, output float Kr, output float Kt[, output vector R, output vector T])"
        }
        "xcomp" | "ycomp" | "zcomp" => "(point) -> float",
        "comp" => "(triple, constant 0, 1 or 2) -> float",
        "ambient" => "() -> color",
        "diffuse" => "(normal N) -> color",
        "specular" => "(normal N, vector V, float roughness) -> color",
        "phong" => "(normal N, vector V, float size) -> color",
        "trace" => "(point P, vector R) -> color",
        "noise" => "(float or point) -> float",
        "texture" => "(string file[, float s, float t]) -> color",
        "arraylength" => "(array) -> its length",
        "spline" => "([string basis,] float x, knots… or an array of knots) -> the knots' type",
        _ => "",
    }
}

impl<'a> Lower<'a> {
    /// A call: a user function if one has the name, else a builtin.
    pub(crate) fn call(
        &mut self,
        b: &mut Builder,
        callee: &'a ast::Ident,
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let want = self.want.take();
        let want_struct = self.want_struct.take();
        let vals: Vec<(Val, Span)> = args.iter().map(|a| (self.expr(b, a), a.span)).collect();
        // User overloads come first; a name that is also a builtin's falls back to it
        // (OSL's user functions add overloads, as MaterialX's `abs(color4)`).
        let wanted = (want, want_struct);
        if self.functions.contains_key(callee.name.as_str()) {
            let found = self.overload(&callee.name, &vals, &wanted);
            if found.is_some() || !self.is_builtin(&callee.name) {
                return self.user_call(b, (&callee.name, found), vals, args, span);
            }
        }
        let name = callee.name.as_str();
        if self.dialect == Dialect::Osl && name == "trace" {
            return self.osl_trace(b, &vals, span);
        }
        if self.dialect == Dialect::Osl && name == "getmessage" {
            if vals.len() == 2 {
                return self.layer_getmessage(b, &vals, args, span);
            }
            return self.getmessage(b, &vals, args, span);
        }
        if self.dialect == Dialect::Osl && name == "setmessage" {
            return self.setmessage(b, &vals, span);
        }
        if self.dialect == Dialect::Osl && name == "getattribute" {
            return self.getattribute(b, vals, args, span);
        }
        if self.dialect == Dialect::Osl && name == "isconnected" {
            return self.isconnected(b, args, span);
        }
        if self.dialect == Dialect::Osl && name == "texture" && vals.len() > 3 {
            return self.osl_texture(b, &vals, args, span);
        }
        if self.dialect == Dialect::Osl && name == "environment" {
            return self.osl_environment(b, &vals, args, span);
        }
        if let Some(severity) = super::print::severity(self.dialect, name) {
            return self.print(b, (name, severity), &vals, span);
        }
        if self.dialect == Dialect::Osl && name == "sincos" {
            return self.sincos(b, &vals, args, span);
        }
        if self.dialect == Dialect::Osl && name == "gettextureinfo" {
            return self.gettextureinfo(b, &vals, args, span);
        }
        if name == "fresnel" {
            return self.fresnel(b, &vals, args, span);
        }
        if let Some(def) = self.struct_def(name) {
            if let Some(v) = self.construct_struct(b, def, &vals) {
                return v;
            }
            let n: usize = def.fields.iter().map(|d| d.vars.len()).sum();
            self.error(
                format!("struct `{name}` is made of its {n} fields in order"),
                span,
                "wrong number of fields",
            );
            return Self::poison(b, Ty::Float);
        }
        if let Some(v) = self.matrix_builtin(b, name, &vals, args, span) {
            return v;
        }
        if self.dialect == Dialect::Osl {
            if let Some(v) = self.closure_call(b, name, &vals, span) {
                return v;
            }
            if let Some(v) = self.osl_builtin(b, name, &vals, span, want) {
                return v;
            }
            if osl::RSL_ONLY.contains(&name) {
                return self.unknown(b, callee, "function");
            }
        }
        match self.builtin(b, name, &vals, span) {
            Some(v) => v,
            None => {
                let known = NAMES.contains(&name)
                    || (self.dialect == Dialect::Osl
                        && (osl::NAMES.contains(&name) || super::strings::NAMES.contains(&name)));
                if !known {
                    return self.unknown(b, callee, "function");
                } else {
                    let got: Vec<&str> = vals.iter().map(|(v, _)| v.type_name()).collect();
                    let takes = match signature(&callee.name) {
                        "" => String::new(),
                        s => format!(": it takes {s}"),
                    };
                    self.error(
                        format!(
                            "`{}` does not take ({}){takes}",
                            callee.name,
                            got.join(", "),
                        ),
                        span,
                        "wrong arguments",
                    );
                }
                Self::poison(b, Ty::Float)
            }
        }
    }

    /// A call of user function `name` inlined, `found` its overload that takes `vals`
    /// ([`Lower::overload`]); an error listing the candidates when none does. `args` are
    /// the argument expressions (for `output` parameters; empty for operators).
    pub(crate) fn user_call(
        &mut self,
        b: &mut Builder,
        (name, found): (&str, Option<&'a ast::FunctionDef>),
        vals: Vec<(Val, Span)>,
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        if let Some(f) = found {
            let vals = vals.into_iter().map(|v| v.0).collect();
            return self.inline(b, f, vals, args, span);
        }
        let defs = self.functions.get(name).cloned().unwrap_or_default();
        let got: Vec<&str> = vals.iter().map(|(v, _)| v.type_name()).collect();
        let cands: Vec<String> = defs
            .iter()
            .map(|f| {
                let ps: Vec<String> = f
                    .params
                    .iter()
                    .map(|p| match &p.ty.base {
                        ast::BaseType::Struct(n) => n.name.clone(),
                        other => format!("{other:?}").to_lowercase(),
                    })
                    .collect();
                format!("{}({})", f.name.name, ps.join(", "))
            })
            .collect();
        self.error(
            format!(
                "no `{name}` takes ({}); candidates: {}",
                got.join(", "),
                cands.join("; ")
            ),
            span,
            "no matching overload",
        );
        Self::poison(b, Ty::Float)
    }

    /// The overload of user function `name` that takes `vals` (by widening where needed),
    /// the closest: the most arguments of exactly the parameter's type.
    pub(crate) fn overload(
        &self,
        name: &str,
        vals: &[(Val, Span)],
        wanted: &Wanted,
    ) -> Option<&'a ast::FunctionDef> {
        let defs = self.functions.get(name)?;
        // Among the overloads that take the arguments (by widening where needed), the one
        // with the most arguments of exactly its parameters' types; the first of equals.
        let mut best: Option<(usize, &'a ast::FunctionDef)> = None;
        for f in defs {
            if f.params.len() != vals.len()
                || !f
                    .params
                    .iter()
                    .zip(vals)
                    .all(|(p, (v, _))| accepts(p, v, false))
            {
                continue;
            }
            // Arguments of exactly the parameter's type count twice; a result of the type
            // the value is assigned to once (OSL overloads by return type too).
            let exact = 3 * f
                .params
                .iter()
                .zip(vals)
                .filter(|(p, (v, _))| accepts(p, v, true))
                .count()
                + returns_wanted(&f.ret, wanted);
            if best.is_none_or(|(e, _)| exact > e) {
                best = Some((exact, f));
            }
        }
        best.map(|(_, f)| f)
    }

    /// OSL's `sincos(x, output s, output c)`: the sine and cosine of a float or, per
    /// component, a triple, stored in the output arguments (their types as `x`'s).
    fn sincos(
        &mut self,
        b: &mut Builder,
        vals: &[(Val, Span)],
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let x = match vals {
            [(Val::V { v, ty, varying }, _), _, _] if *ty == Ty::Float || ty.is_triple() => {
                (*v, *ty, *varying)
            }
            _ => {
                self.error(
                    "`sincos` takes (float or triple x, output s, output c)",
                    span,
                    "wrong arguments",
                );
                return Self::poison(b, Ty::Float);
            }
        };
        let (v, ty, varying) = x;
        for (k, op) in [(1, UnOp::Sin), (2, UnOp::Cos)] {
            let r = b.unary(op, v);
            let val = Val::V { v: r, ty, varying };
            self.store_output_arg(b, &args[k], val, (k + 1, "sincos"));
        }
        Self::void(b)
    }

    /// Whether `name` is a builtin of the dialect (or an OSL closure).
    fn is_builtin(&self, name: &str) -> bool {
        match self.dialect {
            _ if super::matrix::NAMES.contains(&name) => true,
            d if super::print::severity(d, name).is_some() => true,
            Dialect::Rsl => NAMES.contains(&name) || super::matrix::RSL_NAMES.contains(&name),
            Dialect::Osl => {
                (NAMES.contains(&name) && !osl::RSL_ONLY.contains(&name))
                    || osl::NAMES.contains(&name)
                    || super::strings::NAMES.contains(&name)
                    || super::closure::names().any(|n| n == name)
            }
        }
    }

    /// A builtin call, or `None` when the name or the arguments do not fit one.
    fn builtin(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
        span: Span,
    ) -> Option<Val> {
        if name == "texture" {
            return self.texture(b, args);
        }
        if let Some(v) = self.array_builtin(b, name, args, span) {
            return Some(v);
        }
        let vs = super::numbers(b, args)?;
        let varying = vs.iter().any(|v| v.2);
        let out = |v: Value, ty: Ty| Some(Val::V { v, ty, varying });
        let float = |t: Ty| t == Ty::Float;
        match (name, vs.as_slice()) {
            (
                "abs" | "floor" | "ceil" | "sqrt" | "exp" | "log" | "sin" | "cos" | "tan" | "asin"
                | "acos",
                [(x, t, _)],
            ) if *t != Ty::Bool => {
                let op = match name {
                    "abs" => UnOp::Abs,
                    "floor" => UnOp::Floor,
                    "ceil" => UnOp::Ceil,
                    "sqrt" => UnOp::Sqrt,
                    "exp" => UnOp::Exp,
                    "log" => UnOp::Log,
                    "sin" => UnOp::Sin,
                    "cos" => UnOp::Cos,
                    "tan" => UnOp::Tan,
                    "asin" => UnOp::Asin,
                    _ => UnOp::Acos,
                };
                out(b.unary(op, *x), *t)
            }
            ("atan", [(y, t, _)]) if float(*t) => {
                let one = b.float(1.0);
                out(b.binary(BinOp::Atan2, *y, one), Ty::Float)
            }
            ("atan", [(y, ty, _), (x, tx, _)]) if float(*ty) && float(*tx) => {
                out(b.binary(BinOp::Atan2, *y, *x), Ty::Float)
            }
            ("pow" | "min" | "max" | "mod", [(x, tx, _), (y, ty, _)]) => {
                let (x, y, t) = super::same(b, (*x, *tx), (*y, *ty))?;
                let op = match name {
                    "pow" => BinOp::Pow,
                    "min" => BinOp::Min,
                    "max" => BinOp::Max,
                    _ => BinOp::Mod,
                };
                out(b.binary(op, x, y), t)
            }
            ("clamp", [(x, tx, _), (lo, tl, _), (hi, th, _)]) => {
                let (x, lo, t) = super::same(b, (*x, *tx), (*lo, *tl))?;
                let (x, hi, t) = super::same(b, (x, t), (*hi, *th))?;
                let lo = b.splat_to(t.ir(), lo);
                out(b.clamp(x, lo, hi), t)
            }
            ("mix", [(x, tx, _), (y, ty, _), (t, tt, _)]) if float(*tt) => {
                let (x, y, ty) = super::same(b, (*x, *tx), (*y, *ty))?;
                out(b.mix(x, y, *t), ty)
            }
            ("step", [(e, te, _), (x, tx, _)]) if float(*te) && float(*tx) => {
                let below = b.binary(BinOp::Lt, *x, *e);
                let (zero, one) = (b.float(0.0), b.float(1.0));
                out(b.select(below, zero, one), Ty::Float)
            }
            ("smoothstep", [e0, e1, x]) => {
                let osl = self.dialect == Dialect::Osl;
                out(smoothstep_any(b, osl, *e0, *e1, *x)?, x.1)
            }
            ("radians" | "degrees", [(x, t, _)]) if float(*t) => {
                let k = if name == "radians" {
                    std::f64::consts::PI / 180.0
                } else {
                    180.0 / std::f64::consts::PI
                };
                let k = b.float(k);
                out(b.mul(*x, k), Ty::Float)
            }
            ("length", [(x, t, _)]) if t.is_geometric() => {
                out(b.unary(UnOp::Length, *x), Ty::Float)
            }
            ("normalize", [(x, t, _)]) if t.is_geometric() => out(
                b.normalize(*x),
                if *t == Ty::Normal {
                    Ty::Normal
                } else {
                    Ty::Vector
                },
            ),
            ("distance", [(x, tx, _), (y, ty, _)]) if tx.is_geometric() && ty.is_geometric() => {
                out(b.binary(BinOp::Distance, *x, *y), Ty::Float)
            }
            ("faceforward", [(n, tn, _), (i, ti, _)]) if tn.is_geometric() && ti.is_geometric() => {
                let ng = b.stream(Stream::Ng);
                out(faceforward(b, *n, *i, ng), Ty::Normal)
            }
            ("faceforward", [(n, tn, _), (i, ti, _), (r, tr, _)])
                if tn.is_geometric() && ti.is_geometric() && tr.is_geometric() =>
            {
                out(faceforward(b, *n, *i, *r), Ty::Normal)
            }
            ("reflect", [(i, ti, _), (n, tn, _)]) if ti.is_geometric() && tn.is_geometric() => {
                out(reflect(b, *i, *n), Ty::Vector)
            }
            ("refract", [(i, ti, _), (n, tn, _), (eta, te, _)])
                if ti.is_geometric() && tn.is_geometric() && float(*te) =>
            {
                out(refract(b, *i, *n, *eta), Ty::Vector)
            }
            ("xcomp" | "ycomp" | "zcomp", [(p, t, _)]) if t.is_geometric() => {
                let k = match name {
                    "xcomp" => 0,
                    "ycomp" => 1,
                    _ => 2,
                };
                out(b.extract(*p, k), Ty::Float)
            }
            ("comp", [(p, t, _), _]) if t.is_triple() => {
                let k = match &args[1].0 {
                    Val::V { v, .. } => b.program().exprs[v.index()].op.clone(),
                    _ => return None,
                };
                match k {
                    shadenet_graph::ir::Op::Const(shadenet_graph::ConstValue::Float(k))
                        if [0.0, 1.0, 2.0].contains(&k) =>
                    {
                        out(b.extract(*p, k as usize), Ty::Float)
                    }
                    _ => {
                        self.error(
                            "comp's index must be a constant 0, 1 or 2",
                            args[1].1,
                            "here",
                        );
                        Some(Self::poison(b, Ty::Float))
                    }
                }
            }
            _ => self.shading_builtin(b, name, &vs, span),
        }
    }

    /// The builtins that read the scene: `ambient`, the lit builtins (light loops),
    /// `trace`, and `noise`; `None` when the arguments do not fit.
    fn shading_builtin(
        &mut self,
        b: &mut Builder,
        name: &str,
        vs: &[(Value, Ty, bool)],
        span: Span,
    ) -> Option<Val> {
        let varying = vs.iter().any(|v| v.2);
        let out = |v: Value, ty: Ty| Some(Val::V { v, ty, varying });
        let float = |t: Ty| t == Ty::Float;
        match (name, vs) {
            ("ambient", []) => Some(Val::V {
                v: b.ambient(),
                ty: Ty::Color,
                varying: true,
            }),
            ("diffuse" | "specular" | "phong", _) if self.in_illuminance => {
                self.error(
                    format!("`{name}` is a light loop: not inside `illuminance`"),
                    span,
                    "nested light loop",
                );
                Some(Self::poison(b, Ty::Color))
            }
            ("diffuse", [(n, t, _)]) if t.is_geometric() => Some(self.lit(b, *n, |b, n, l| {
                let d = b.dot(n, l);
                let zero = b.float(0.0);
                b.max(d, zero)
            })),
            ("specular", [(n, tn, _), (v, tv, _), (r, tr, _)])
                if tn.is_geometric() && tv.is_geometric() && float(*tr) =>
            {
                let one = b.float(1.0);
                let e = b.div(one, *r);
                let v = b.normalize(*v);
                Some(self.lit(b, *n, |b, n, l| {
                    let lv = b.add(l, v);
                    let h = b.normalize(lv);
                    let d = b.dot(n, h);
                    let zero = b.float(0.0);
                    let d = b.max(d, zero);
                    b.binary(BinOp::Pow, d, e)
                }))
            }
            ("phong", [(n, tn, _), (v, tv, _), (s, ts, _)])
                if tn.is_geometric() && tv.is_geometric() && float(*ts) =>
            {
                let v = b.normalize(*v);
                let nv = b.unary(UnOp::Neg, v);
                let nn = b.normalize(*n);
                let r = reflect(b, nv, nn);
                Some(self.lit(b, *n, |b, _, l| {
                    let d = b.dot(r, l);
                    let zero = b.float(0.0);
                    let d = b.max(d, zero);
                    b.binary(BinOp::Pow, d, *s)
                }))
            }
            ("trace", [(_, tp, _), (r, tr, _)]) if tp.is_geometric() && tr.is_geometric() => {
                Some(Val::V {
                    v: b.trace(*r, RAY_REFLECTION),
                    ty: Ty::Color,
                    varying: true,
                })
            }
            ("noise", [(x, t, _)]) if float(*t) || t.is_geometric() => {
                let p = if float(*t) {
                    let zero = b.float(0.0);
                    b.construct(Type::Vec3, &[*x, zero, zero])
                } else {
                    *x
                };
                let n = b.call(Intrinsic::OslPerlin3, &[p]);
                let half = b.float(0.5);
                let h = b.mul(n, half);
                out(b.add(h, half), Ty::Float)
            }
            _ => None,
        }
    }

    /// `texture("file" [, s, t])`: a filtered lookup (the texture system's default filter,
    /// footprint from the ray differentials) at `(s, t)`, the globals without them. RSL's
    /// `t` runs down the image and our `v` up: the lookup reads `(s, 1 − t)`. A relative
    /// file name is relative to the shader's folder.
    fn texture(&mut self, b: &mut Builder, args: &[(Val, Span)]) -> Option<Val> {
        let (Val::Str(file), rest) = args.split_first().map(|(f, r)| (&f.0, r))? else {
            return None;
        };
        let (s, t) = match rest {
            [] => {
                let uv = b.stream(Stream::Uv);
                (b.extract(uv, 0), b.extract(uv, 1))
            }
            [
                (
                    Val::V {
                        v: s,
                        ty: Ty::Float,
                        ..
                    },
                    _,
                ),
                (
                    Val::V {
                        v: t,
                        ty: Ty::Float,
                        ..
                    },
                    _,
                ),
            ] => (*s, *t),
            _ => return None,
        };
        let uv = st_uv(b, s, t);
        let index = b.texture_index(&shadenet_graph::ir::TextureFile::auto(file.clone()));
        let c = b.texture(index, uv, shadenet_graph::ir::Sampling::default(), false);
        Some(Val::V {
            v: c,
            ty: Ty::Color,
            varying: true,
        })
    }

    /// RSL's lit builtins: `Σ Cl · w(N̂, L)` over the lights within 90° of `N` (the sample
    /// blocked: black), as `illuminance(P, N, PI/2) C += Cl * w`.
    fn lit(
        &mut self,
        b: &mut Builder,
        n: Value,
        w: impl FnOnce(&mut Builder, Value, Value) -> Value,
    ) -> Val {
        let p = b.stream(Stream::P);
        let n = b.normalize(n);
        let sum = b.illuminance(p, |b, l, cl| {
            let d = b.dot(n, l);
            let zero = b.float(0.0);
            let facing = b.binary(BinOp::Ge, d, zero);
            let w = w(b, n, l);
            let w = b.select(facing, w, zero);
            let vis = b.light_visible();
            let w = b.mul(w, vis);
            let w = b.splat(Type::Color, w);
            vec![b.mul(cl, w)]
        });
        Val::V {
            v: sum[0],
            ty: Ty::Color,
            varying: true,
        }
    }
}

/// The type a call's result is assigned to, where known: a value type or a struct name.
pub(crate) type Wanted = (Option<Ty>, Option<String>);

/// How well return type `ret` fits the `wanted` one: 2 the same, 1 a triple for a triple
/// (OSL converts them), 0 otherwise.
fn returns_wanted(ret: &ast::Type, (ty, st): &Wanted) -> usize {
    use ast::BaseType as B;
    let triple = matches!(ret.base, B::Color | B::Point | B::Vector | B::Normal);
    match (&ret.base, ty, st) {
        (B::Struct(n), _, Some(s)) if n.name == *s => 2,
        (B::Float, Some(Ty::Float), _) | (B::Int, Some(Ty::Int), _) => 2,
        (B::Color, Some(Ty::Color), _) | (B::Matrix, Some(Ty::Matrix), _) => 2,
        (B::Point | B::Vector | B::Normal, Some(t), _) if t.is_geometric() => 2,
        (_, Some(t), _) if triple && t.is_triple() => 1,
        _ => 0,
    }
}

/// Whether a parameter of type `p` takes the value `v`: the same type when `exact`, else
/// by widening (a float or int to a triple, an int to a float, geometric types mixed).
fn accepts(param: &ast::Param, v: &Val, exact: bool) -> bool {
    let p = &param.ty;
    if param.array.is_some() {
        return matches!(v, Val::Array(..));
    }
    let ty = match v {
        Val::Closure(_) => return p.closure.is_some(),
        Val::Str(_) => return matches!(p.base, ast::BaseType::String),
        Val::Struct(s, _) => return matches!(&p.base, ast::BaseType::Struct(n) if n.name == *s),
        Val::Array(..) | Val::ArrayVar { .. } | Val::StructVar(_) => return false,
        Val::V { ty, .. } => *ty,
    };
    if p.closure.is_some() {
        return false;
    }
    let same = match p.base {
        ast::BaseType::Float => ty == Ty::Float,
        ast::BaseType::Int => ty == Ty::Int,
        ast::BaseType::Color => ty == Ty::Color,
        ast::BaseType::Point => ty == Ty::Point,
        ast::BaseType::Vector => ty == Ty::Vector,
        ast::BaseType::Normal => ty == Ty::Normal,
        ast::BaseType::Matrix => ty == Ty::Matrix,
        _ => false,
    };
    if same || exact {
        return same;
    }
    // A comparison's truth passes as an int or a float (OSL's conditions are ints), and the
    // triples convert to one another (MaterialX's OSL passes colors to vector parameters).
    let number = matches!(ty, Ty::Float | Ty::Int | Ty::Bool);
    match p.base {
        ast::BaseType::Float | ast::BaseType::Int if ty == Ty::Bool => true,
        ast::BaseType::Float => number,
        ast::BaseType::Color => number || ty.is_geometric(),
        ast::BaseType::Point | ast::BaseType::Vector | ast::BaseType::Normal => {
            ty.is_triple() || number
        }
        _ => false,
    }
}

/// The texture coordinates a `texture(file, s, t)` call reads: `(s, 1 − t)` (the
/// languages' `t` runs down the image, the IR's `v` up it).
pub(super) fn st_uv(b: &mut Builder, s: Value, t: Value) -> Value {
    let one = b.float(1.0);
    let v = b.sub(one, t);
    b.construct(Type::Vec2, &[s, v])
}

/// `smoothstep` of floats, or (`osl`) OSL's form for a triple `x`, per component, each
/// edge a triple of its type or a float; `None` for other types.
fn smoothstep_any(
    b: &mut Builder,
    osl: bool,
    (e0, t0, _): (Value, Ty, bool),
    (e1, t1, _): (Value, Ty, bool),
    (x, tx, _): (Value, Ty, bool),
) -> Option<Value> {
    if [t0, t1, tx].iter().all(|t| *t == Ty::Float) {
        return Some(smoothstep(b, e0, e1, x));
    }
    if !osl || !tx.is_triple() || ![t0, t1].iter().all(|t| *t == tx || *t == Ty::Float) {
        return None;
    }
    let part = |b: &mut Builder, v: Value, t: Ty, k: usize| {
        if t == Ty::Float { v } else { b.extract(v, k) }
    };
    let c: Vec<Value> = (0..3)
        .map(|k| {
            let (lo, hi) = (part(b, e0, t0, k), part(b, e1, t1, k));
            let xk = b.extract(x, k);
            smoothstep(b, lo, hi, xk)
        })
        .collect();
    Some(b.construct(tx.ir(), &c))
}

/// `smoothstep(e0, e1, x)`: 0 below `e0`, 1 above `e1`, the cubic `3t² − 2t³` between.
fn smoothstep(b: &mut Builder, e0: Value, e1: Value, x: Value) -> Value {
    let d = b.sub(x, e0);
    let w = b.sub(e1, e0);
    let t = b.div(d, w);
    let (zero, one) = (b.float(0.0), b.float(1.0));
    let t = b.clamp(t, zero, one);
    let (two, three) = (b.float(2.0), b.float(3.0));
    let tt = b.mul(t, t);
    let twice = b.mul(two, t);
    let k = b.sub(three, twice);
    let s = b.mul(tt, k);
    // Exact ends where the edges coincide (a step at e0).
    let below = b.binary(BinOp::Lt, x, e0);
    let s = b.select(below, zero, s);
    let above = b.binary(BinOp::Ge, x, e1);
    b.select(above, one, s)
}

/// `faceforward(N, I, Nref)`: `N` where `−I·Nref ≥ 0` (N faces the viewer), else `−N`.
fn faceforward(b: &mut Builder, n: Value, i: Value, nref: Value) -> Value {
    let d = b.dot(i, nref);
    let zero = b.float(0.0);
    let away = b.binary(BinOp::Gt, d, zero);
    let neg = b.unary(UnOp::Neg, n);
    b.select(away, neg, n)
}
