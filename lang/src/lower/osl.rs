//! OSL's side of the lowering: a `surface` or `shader` with OSL's globals (`P`, `I`, `N`,
//! `Ng`, `u`, `v`, `dPdu`, `dPdv`, `time`, `Ci`), its output parameters as the program's
//! outputs, and the builtins whose meaning differs from RSL's: OSL's extra math, `raytype`,
//! `isconnected`, `transformc`, the spectral colours ([`super::spectral`]). The noise family
//! is [`super::noise`]'s (the generators themselves `shadenet_graph::ops::osl_noise`, OSL's
//! code ported, reached through the IR's intrinsics), the closures [`super::closure`]'s. It
//! owns OSL's language rules.

use super::colorspace;
use super::components::{componentwise, componentwise2};
use super::{Lower, Ty, Val};
use crate::ast::{self, ShaderKind};
use crate::source::Span;
use shadenet_graph::ir::{BinOp, Builder, Stream, UnOp, Value};
use shadenet_graph::nodes::LowVal;
use shadenet_graph::{ConstValue, Type};
use std::collections::HashMap;

/// OSL's builtins beyond those both dialects share (for "did you mean"); the string
/// builtins are [`super::strings::NAMES`].
pub(crate) const NAMES: &[&str] = &[
    "trace",
    "getmessage",
    "setmessage",
    "rotate",
    "logb",
    "gettextureinfo",
    "noise",
    "snoise",
    "cellnoise",
    "hashnoise",
    "pnoise",
    "psnoise",
    "fabs",
    "sign",
    "trunc",
    "round",
    "fmod",
    "exp2",
    "log2",
    "log10",
    "inversesqrt",
    "hypot",
    "dot",
    "cross",
    "luminance",
    "blackbody",
    "wavelength_color",
    "linearstep",
    "atan2",
    "backfacing",
    "isnan",
    "isinf",
    "isfinite",
    "Dx",
    "Dy",
    "filterwidth",
    "area",
    "calculatenormal",
    "aastep",
    "getattribute",
    "transformc",
    "raytype",
    "isconnected",
    "splineinverse",
    "environment",
    "smooth_linearstep",
    "select",
    "sinh",
    "cosh",
    "tanh",
    "expm1",
    "cbrt",
    "erf",
    "erfc",
    "sincos",
];

/// RSL builtins that OSL does not have (or has as closures: `diffuse`, `phong`).
pub(crate) const RSL_ONLY: &[&str] = &["ambient", "specular", "trace", "xcomp", "ycomp", "zcomp"];

/// The OSL builtins we know of but have not built, with what to use instead.
const UNBUILT: &[(&str, &str)] = &[
    ("transformu", "unit conversions are not built yet"),
    ("pointcloud_search", "point clouds are not built"),
    ("pointcloud_get", "point clouds are not built"),
    ("pointcloud_write", "point clouds are not built"),
    ("dict_find", "dictionaries are not built"),
    ("dict_next", "dictionaries are not built"),
    ("dict_value", "dictionaries are not built"),
    ("regex_search", "regular expressions are not built"),
    ("regex_match", "regular expressions are not built"),
    (
        "hash",
        "the hash of a string (OpenImageIO's ustring hash) is not built",
    ),
    ("split", "arrays of strings are not built yet"),
];

impl<'a> Lower<'a> {
    /// An OSL `surface` or `shader`: the globals, the parameters, the body; then the outputs
    /// ([`Lower::osl_outputs`]).
    pub(crate) fn osl_shader(&mut self, b: &mut Builder, shader: &'a ast::ShaderDef) {
        let outputs = self.osl_layer(b, shader, Val::Closure(Box::default()));
        declare_outputs(b, outputs);
    }

    /// The globals (unless already bound: a group's layers share one set; `Ci` starting
    /// as `ci`), the parameters and the body of `shader`; its
    /// outputs by name: `Ci` first for a surface (or a shader without outputs), then the
    /// output parameters in order.
    pub(crate) fn osl_layer(
        &mut self,
        b: &mut Builder,
        shader: &'a ast::ShaderDef,
        ci: Val,
    ) -> Vec<(String, Val)> {
        if self.scopes[0].is_empty() {
            self.osl_globals(b);
        }
        self.scopes[0].insert(
            "Ci".to_string(),
            super::Var {
                val: ci,
                uniform: false,
                decl: None,
            },
        );
        for p in &shader.params {
            let bits = self.connections.get(&p.name.name).copied().unwrap_or(0);
            self.shader_params.insert(p.name.name.clone(), bits);
            self.param(b, p);
        }
        self.scopes.push(HashMap::new());
        if shader.body.stmts.iter().any(super::returns::has_return) {
            // `return;` ends the shader: what follows runs where it did not.
            self.begin_returns(b, None, None);
        }
        self.block(b, &shader.body);
        self.returns = None;
        self.scopes.pop();
        let outputs: Vec<&str> = shader
            .params
            .iter()
            .filter(|p| p.ty.output.is_some())
            .map(|p| p.name.name.as_str())
            .collect();
        let mut names: Vec<&str> = Vec::new();
        if shader.kind == ShaderKind::Surface || outputs.is_empty() {
            names.push("Ci");
        }
        names.extend(outputs);
        names
            .into_iter()
            .filter_map(|n| Some((n.to_string(), self.read_var(n)?)))
            .collect()
    }

    /// OSL's shader globals. `time` is the fragment's time (the stream MaterialX's `time`
    /// node reads; the renderer has no motion, so `dtime` is 0 and `dPdtime` zero); `Ci`
    /// starts as the empty closure.
    pub(crate) fn osl_globals(&mut self, b: &mut Builder) {
        let set = |me: &mut Self, name: &str, val: Val| {
            me.scopes[0].insert(
                name.to_string(),
                super::Var {
                    val,
                    uniform: false,
                    decl: None,
                },
            );
        };
        for (name, stream, ty) in [
            ("P", Stream::P, Ty::Point),
            ("N", Stream::N, Ty::Normal),
            ("Ng", Stream::Ng, Ty::Normal),
            ("I", Stream::I, Ty::Vector),
            ("dPdu", Stream::DPdu, Ty::Vector),
            ("dPdv", Stream::DPdv, Ty::Vector),
        ] {
            let v = b.stream(stream);
            set(
                self,
                name,
                Val::V {
                    v,
                    ty,
                    varying: true,
                },
            );
        }
        let uv = b.stream(Stream::Uv);
        for (k, name) in ["u", "v"].into_iter().enumerate() {
            let v = b.extract(uv, k);
            set(
                self,
                name,
                Val::V {
                    v,
                    ty: Ty::Float,
                    varying: true,
                },
            );
        }
        let time = b.stream(Stream::Time);
        set(
            self,
            "time",
            Val::V {
                v: time,
                ty: Ty::Float,
                varying: true,
            },
        );
        let v = b.float(0.0);
        set(
            self,
            "dtime",
            Val::V {
                v,
                ty: Ty::Float,
                varying: false,
            },
        );
        let v = b.zero(Type::Vec3);
        set(
            self,
            "dPdtime",
            Val::V {
                v,
                ty: Ty::Vector,
                varying: false,
            },
        );
        set(self, "Ci", Val::Closure(Box::default()));
        self.declare_trace_vars(b);
        self.declare_message_vars(b);
    }

    /// An OSL `output` parameter (or a closure parameter): a variable holding its default
    /// (zero where it has none), read back as a program output at the end.
    pub(crate) fn osl_output_param(&mut self, b: &mut Builder, p: &'a ast::Param) {
        if p.ty.output.is_none() {
            // A closure input: what a group layer connects to it, else the empty closure.
            let v = match self.inputs.remove(&p.name.name) {
                Some(super::LayerInput::Connected(v @ Val::Closure(_), _)) => v,
                Some(super::LayerInput::Connected(_, at) | super::LayerInput::Values(_, at)) => {
                    self.error(
                        format!("closure parameter `{}` takes a closure output", p.name.name),
                        at,
                        "not a closure",
                    );
                    Val::Closure(Box::default())
                }
                None => Val::Closure(Box::default()),
            };
            self.declare(&p.name, v, false);
            return;
        }
        if p.ty.closure.is_some() {
            if let Some(d) = &p.default {
                let v = self.expr(b, d);
                if !Self::closure_or_zero(b, &v) {
                    self.error(
                        "a closure output's default must be 0 or a closure",
                        d.span,
                        "not a closure",
                    );
                }
            }
            self.declare(&p.name, Val::Closure(Box::default()), false);
            return;
        }
        if let ast::BaseType::Struct(n) = &p.ty.base
            && let Some(def) = self.struct_def(&n.name)
        {
            let v = match &p.default {
                Some(d) => self.expr_for_struct(b, d, def),
                None => self.struct_zero(b, def, 0),
            };
            let v = match v {
                v @ Val::Struct(..) => v,
                _ => self.struct_zero(b, def, 0),
            };
            self.bind_struct(&p.name, def, v, false);
            return;
        }
        if p.ty.base == ast::BaseType::String {
            // A string output: what the shader leaves in it is known when it compiles; a
            // group passes it to the string inputs it connects (not a program output).
            let val = match p.default.as_ref().map(|d| (d, self.expr(b, d))) {
                None => Val::Str(String::new()),
                Some((_, s @ Val::Str(_))) => s,
                Some((d, other)) => {
                    self.error(
                        format!(
                            "`{}` is a string: not {}",
                            p.name.name,
                            super::an(other.type_name())
                        ),
                        d.span,
                        "not a string",
                    );
                    Val::Str(String::new())
                }
            };
            self.declare(&p.name, val, true);
            return;
        }
        let Some(ty) = self.declared_type(&p.ty) else {
            return;
        };
        let val = match &p.default {
            Some(d) => self.expr_as(b, d, ty),
            None => Self::poison(b, ty),
        };
        self.declare(&p.name, val, false);
    }

    /// An OSL builtin other than the closures, or `None` when `name` is not one (or is one
    /// RSL has that takes these arguments: the caller tries those next). `want` is the type
    /// the result is assigned to (noise is a float or a vector by it).
    pub(crate) fn osl_builtin(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
        span: Span,
        want: Option<Ty>,
    ) -> Option<Val> {
        if let Some((_, why)) = UNBUILT.iter().find(|(n, _)| *n == name) {
            self.error(format!("`{name}`: {why}"), span, "not built yet");
            return Some(Self::poison(b, want.unwrap_or(Ty::Float)));
        }
        if matches!(
            name,
            "noise" | "snoise" | "cellnoise" | "hashnoise" | "pnoise" | "psnoise"
        ) {
            return Some(self.osl_noise(b, name, args, span, want));
        }
        if let Some(v) = int_builtin(b, name, args) {
            return Some(v);
        }
        if name == "transformc" {
            return Some(self.transformc(b, args, span));
        }
        if name == "raytype" {
            return Some(self.raytype(b, args, span));
        }
        if let Some(v) = self.string_builtin(b, name, args, span) {
            return Some(v);
        }
        let vs = super::numbers(b, args)?;
        let extra = super::stdosl::builtin(b, name, &vs);
        if let Some(v) = extra.or_else(|| super::oslmath::builtin(b, name, &vs)) {
            return Some(v);
        }
        let varying = vs.iter().any(|v| v.2);
        let out = |v: Value, ty: Ty| Some(Val::V { v, ty, varying });
        let num = |t: Ty| t == Ty::Float || t.is_triple();
        match (name, vs.as_slice()) {
            ("fabs", [(x, t, _)]) if num(*t) => out(b.unary(UnOp::Abs, *x), *t),
            ("sign", [(x, t, _)]) if num(*t) => {
                let s = componentwise(b, *x, *t, |b, x| {
                    let z = b.float(0.0);
                    let (p, m) = (b.float(1.0), b.float(-1.0));
                    let gt = b.binary(BinOp::Gt, x, z);
                    let lt = b.binary(BinOp::Lt, x, z);
                    let s = b.select(lt, m, z);
                    b.select(gt, p, s)
                });
                out(s, *t)
            }
            ("trunc", [(x, t, _)]) if num(*t) => out(componentwise(b, *x, *t, trunc), *t),
            ("round", [(x, t, _)]) if num(*t) => out(
                componentwise(b, *x, *t, |b, x| {
                    // Half away from zero, as C's roundf.
                    let half = b.float(0.5);
                    let a = b.unary(UnOp::Abs, x);
                    let a = b.add(a, half);
                    let r = b.unary(UnOp::Floor, a);
                    let zero = b.float(0.0);
                    let neg = b.binary(BinOp::Lt, x, zero);
                    let nr = b.unary(UnOp::Neg, r);
                    b.select(neg, nr, r)
                }),
                *t,
            ),
            ("fmod", [(x, tx, _), (y, ty, _)]) if num(*tx) && num(*ty) => {
                let (x, y, t) = super::same(b, (*x, *tx), (*y, *ty))?;
                out(componentwise2(b, x, y, t, fmod), t)
            }
            ("exp2" | "log2" | "log10", [(x, t, _)]) if num(*t) => {
                let k = match name {
                    "exp2" => std::f64::consts::LN_2,
                    "log2" => std::f64::consts::LOG2_E,
                    _ => std::f64::consts::LOG10_E,
                };
                let k = b.float(k);
                let k = b.splat_to(t.ir(), k);
                let v = if name == "exp2" {
                    let a = b.mul(*x, k);
                    b.unary(UnOp::Exp, a)
                } else {
                    let l = b.unary(UnOp::Log, *x);
                    b.mul(l, k)
                };
                out(v, *t)
            }
            ("inversesqrt", [(x, t, _)]) if num(*t) => {
                let s = b.unary(UnOp::Sqrt, *x);
                let one = b.float(1.0);
                let one = b.splat_to(t.ir(), one);
                out(b.div(one, s), *t)
            }
            ("hypot", [(x, tx, _), (y, ty, _)]) if *tx == Ty::Float && *ty == Ty::Float => {
                let v = b.construct(Type::Vec2, &[*x, *y]);
                out(b.unary(UnOp::Length, v), Ty::Float)
            }
            ("dot", [(x, tx, _), (y, ty, _)]) if tx.is_triple() && ty.is_triple() => {
                out(b.dot(*x, *y), Ty::Float)
            }
            ("cross", [(x, tx, _), (y, ty, _)]) if tx.is_geometric() && ty.is_geometric() => {
                out(b.binary(BinOp::Cross, *x, *y), Ty::Vector)
            }
            ("blackbody", [(t, Ty::Float, _)]) => out(Self::blackbody(b, *t), Ty::Color),
            ("wavelength_color", [(l, Ty::Float, _)]) => {
                out(Self::wavelength_color(b, *l), Ty::Color)
            }
            ("luminance", [(c, Ty::Color, _)]) => {
                let w = b.color(LUMA_REC709);
                out(b.dot(*c, w), Ty::Float)
            }
            ("atan2", [(y, ty, _), (x, tx, _)]) if *ty == Ty::Float && *tx == Ty::Float => {
                out(b.binary(BinOp::Atan2, *y, *x), Ty::Float)
            }
            // OSL's triple form, per component.
            ("atan2", [(y, ty, _), (x, tx, _)]) if ty.is_triple() && ty == tx => {
                let v = componentwise2(b, *y, *x, *ty, |b, y, x| b.binary(BinOp::Atan2, y, x));
                out(v, *ty)
            }

            ("linearstep", [(e0, t0, _), (e1, t1, _), (x, tx, _)])
                if [*t0, *t1, *tx].iter().all(|t| *t == Ty::Float) =>
            {
                let d = b.sub(*x, *e0);
                let w = b.sub(*e1, *e0);
                let t = b.div(d, w);
                let (zero, one) = (b.float(0.0), b.float(1.0));
                let t = b.clamp(t, zero, one);
                // Exact ends where the edges coincide (a step at e0).
                let below = b.binary(BinOp::Lt, *x, *e0);
                let t = b.select(below, zero, t);
                let above = b.binary(BinOp::Ge, *x, *e1);
                out(b.select(above, one, t), Ty::Float)
            }
            ("backfacing", []) => {
                let ng = b.stream(Stream::Ng);
                let i = b.stream(Stream::I);
                let d = b.dot(ng, i);
                let zero = b.float(0.0);
                let back = b.binary(BinOp::Gt, d, zero);
                let k = b.convert(Type::Int, back);
                Some(Val::V {
                    v: k,
                    ty: Ty::Int,
                    varying: true,
                })
            }
            _ => self.osl_more(b, name, &vs),
        }
    }

    /// The rest of [`Lower::osl_builtin`]: `mix` of triples by a triple, `isnan`,
    /// `isinf`, `isfinite`, and the derivative builtins ([`super::derivs`]).
    fn osl_more(&mut self, b: &mut Builder, name: &str, vs: &[(Value, Ty, bool)]) -> Option<Val> {
        let varying = vs.iter().any(|v| v.2);
        let out = |v: Value, ty: Ty| Some(Val::V { v, ty, varying });
        match (name, vs) {
            ("mix", [(x, tx, _), (y, ty, _), (a, ta, _)])
                if tx.is_triple() && *ty == *tx && *ta == *tx =>
            {
                // OSL's mix of triples by a triple: x (1 − a) + y a, per component.
                let one = b.float(1.0);
                let one = b.splat_to(tx.ir(), one);
                let om = b.sub(one, *a);
                let xa = b.mul(*x, om);
                let ya = b.mul(*y, *a);
                out(b.add(xa, ya), *tx)
            }
            ("isnan" | "isinf" | "isfinite", [(x, Ty::Float, _)]) => {
                let nan = b.binary(BinOp::Ne, *x, *x);
                let a = b.unary(UnOp::Abs, *x);
                let big = b.float(f64::from(f32::MAX));
                let inf = b.binary(BinOp::Gt, a, big);
                let v = match name {
                    "isnan" => nan,
                    "isinf" => inf,
                    _ => {
                        let bad = b.binary(BinOp::Or, nan, inf);
                        b.unary(UnOp::Not, bad)
                    }
                };
                out(b.convert(Type::Int, v), Ty::Int)
            }
            _ => super::derivs::builtin(b, name, vs),
        }
    }

    /// Whether `v` is a closure or a constant 0 (OSL's null closure: `closure color c = 0`).
    pub(crate) fn closure_or_zero(b: &Builder, v: &Val) -> bool {
        match v {
            Val::Closure(_) => true,
            Val::V { v, .. } => {
                shadenet_graph::opt::fold::constant(b.program(), *v)
                    .as_ref()
                    .and_then(const_number)
                    == Some(0.0)
            }
            _ => false,
        }
    }
}

/// `abs`, `min`, `max` and `clamp` of ints: ints (the IR's int ops), as OSL overloads them.
fn int_builtin(b: &mut Builder, name: &str, args: &[(Val, Span)]) -> Option<Val> {
    let mut ints = Vec::new();
    let mut varying = false;
    for (v, _) in args {
        match v {
            Val::V {
                v,
                ty: Ty::Int,
                varying: vy,
            } => {
                ints.push(*v);
                varying |= vy;
            }
            _ => return None,
        }
    }
    let v = match (name, ints.as_slice()) {
        ("abs", [x]) => b.unary(UnOp::Abs, *x),
        ("min", [x, y]) => b.min(*x, *y),
        ("max", [x, y]) => b.max(*x, *y),
        ("clamp", [x, lo, hi]) => {
            let m = b.max(*x, *lo);
            b.min(m, *hi)
        }
        _ => return None,
    };
    Some(Val::V {
        v,
        ty: Ty::Int,
        varying,
    })
}

/// Declares `outputs` as the program's outputs in order: values as they are, closures lit
/// by the surface lowering (one output per render component), a struct's fields as
/// `name.field` and an array's elements as `name[k]`.
pub(crate) fn declare_outputs(b: &mut Builder, outputs: Vec<(String, Val)>) {
    for (name, val) in outputs {
        match val {
            Val::Struct(_, fields) => {
                let named = fields
                    .into_iter()
                    .map(|(f, v)| (super::structs::field(&name, &f), v))
                    .collect();
                declare_outputs(b, named);
            }
            Val::Array(elems) => {
                let named = elems
                    .into_iter()
                    .enumerate()
                    .map(|(k, v)| (super::element(&name, k), v))
                    .collect();
                declare_outputs(b, named);
            }
            Val::V { v, .. } => b.output(&name, None, v),
            Val::Closure(c) => {
                let low = LowVal::closure(b, *c);
                shadenet_graph::lower::declare_output(b, &name, &low);
            }
            _ => {}
        }
    }
}

impl<'a> Lower<'a> {
    /// `isconnected(param)`: OSL's connection bits of a shader parameter, known when the
    /// group is lowered — 1 where a group connects an earlier layer's output to it, 2 where
    /// it is an output a later layer reads, 3 both, 0 otherwise (a lone shader's).
    pub(crate) fn isconnected(&mut self, b: &mut Builder, args: &[ast::Expr], span: Span) -> Val {
        let bits = match args {
            [
                ast::Expr {
                    kind: ast::ExprKind::Ident(id),
                    ..
                },
            ] => self.shader_params.get(&id.name).copied(),
            _ => None,
        };
        let Some(bits) = bits else {
            self.error(
                "`isconnected` takes the name of one of the shader's parameters",
                span,
                "not a shader parameter",
            );
            return Self::poison(b, Ty::Int);
        };
        Val::V {
            v: b.int(bits),
            ty: Ty::Int,
            varying: false,
        }
    }

    /// `raytype(name)`: 1 where the ray being shaded is of type `name`, else 0 — the IR's
    /// ray-type stream compared with the type's bit, which specialization folds for a
    /// material that sees one type. Our names are `camera`, `shadow`, `reflection`,
    /// `refraction` and `diffuse`; as in OSL, where the renderer names the types, a name
    /// the renderer does not have is never the ray's type (0).
    fn raytype(&mut self, b: &mut Builder, args: &[(Val, Span)], span: Span) -> Val {
        let [(Val::Str(name), _)] = args else {
            self.error("`raytype` takes (string name)", span, "wrong arguments");
            return Self::poison(b, Ty::Int);
        };
        let Some(bit) = shadenet_graph::ir::ray_type_from_name(name) else {
            return Val::V {
                v: b.int(0),
                ty: Ty::Int,
                varying: false,
            };
        };
        let ray = b.stream(Stream::RayType);
        let k = b.int(bit);
        let is = b.binary(BinOp::Eq, ray, k);
        Val::V {
            v: b.convert(Type::Int, is),
            ty: Ty::Int,
            varying: true,
        }
    }

    /// `transformc(from, to, c)`: colour `c` (or any triple, as a colour) from colour
    /// space `from` to `to` ([`colorspace`]: OSL's names; the same space is the identity);
    /// an unknown space is an error naming it.
    fn transformc(&mut self, b: &mut Builder, args: &[(Val, Span)], span: Span) -> Val {
        let [
            (Val::Str(from), _),
            (Val::Str(to), _),
            (Val::V { v, ty, varying }, _),
        ] = args
        else {
            self.error(
                "`transformc` takes (string from, string to, color c)",
                span,
                "wrong arguments",
            );
            return Self::poison(b, Ty::Color);
        };
        if !ty.is_triple() {
            self.error(
                format!(
                    "`transformc` converts a color, not {}",
                    super::an(ty.name())
                ),
                span,
                "not a color",
            );
            return Self::poison(b, Ty::Color);
        }
        let (Some(f), Some(t)) = (colorspace::space(from), colorspace::space(to)) else {
            let bad = if colorspace::space(from).is_none() {
                from
            } else {
                to
            };
            self.error(
                format!(
                    "`transformc`: unknown color space \"{bad}\" (known: {}; OpenColorIO spaces are not built)",
                    colorspace::NAMES
                ),
                span,
                "unknown color space",
            );
            return Self::poison(b, Ty::Color);
        };
        let c = b.retype(Type::Color, *v);
        let c = colorspace::transform(b, f, t, c);
        Val::V {
            v: c,
            ty: Ty::Color,
            varying: *varying,
        }
    }
}

/// Rec. 709 luminance weights (OSL's default color space).
const LUMA_REC709: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// `trunc(x)`: toward zero.
pub(crate) fn trunc(b: &mut Builder, x: Value) -> Value {
    let zero = b.float(0.0);
    let neg = b.binary(BinOp::Lt, x, zero);
    let c = b.unary(UnOp::Ceil, x);
    let f = b.unary(UnOp::Floor, x);
    b.select(neg, c, f)
}

/// C's `fmod(x, y)` = `x − y · trunc(x / y)` (the sign of `x`); 0 where `y` is 0, as
/// OSL's safe `fmod`.
pub(crate) fn fmod(b: &mut Builder, x: Value, y: Value) -> Value {
    let q = b.div(x, y);
    let t = trunc(b, q);
    let yt = b.mul(y, t);
    let r = b.sub(x, yt);
    let zero = b.float(0.0);
    let y0 = b.binary(BinOp::Eq, y, zero);
    b.select(y0, zero, r)
}

/// A float constant `x` of a numeric const type, if `c` is one.
pub(crate) fn const_number(c: &ConstValue) -> Option<f64> {
    match c {
        ConstValue::Float(x) => Some(*x),
        ConstValue::Int(i) => Some(*i as f64),
        _ => None,
    }
}
