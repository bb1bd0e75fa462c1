//! OSL's probe rays: `trace(pos, dir, …)` and `getmessage("trace", name, value)`.
//!
//! `trace` asks the renderer for the closest surface along a ray without shading it
//! (returns 1 where it hits); `getmessage("trace", …)` reads the hit of the last `trace`
//! that ran. The IR's `probe` op gives one property of a ray's hit, so a `trace` emits one
//! probe per property (`hit`, `hitdist`, `P`, `N`, `Ng`, `u`, `v`) into hidden variables
//! (`$trace.hit` …, declared with the globals, zero until a trace runs); `getmessage` reads
//! them. Because they are variables, a `trace` under an `if` or in a loop reaches a
//! `getmessage` after it through the regions' yields, as an assignment would (the
//! statements that call `trace`, directly or through a user function, count as assigning
//! them: `Lower::hidden_writes`, with what user functions write found once per file); probes no `getmessage` reads are removed as dead
//! code, and equal ones merged. Options: `"mindist"`, `"maxdist"` (floats, default 0 and
//! 10³⁰); `"shade"` only 0 (what a probe hits is not shaded), `"traceset"` is not built.
//! Owns these two builtins; the ray itself is the runtime's and the renderer's.

use super::{Lower, Ty, Val};
use crate::ast::{self, Expr};
use crate::source::Span;
use shadenet_graph::ir::{Builder, ProbeField, Value};
use shadenet_graph::types::{ConstValue, Type};

/// The properties a `trace` records, by their `getmessage` names, with their OSL types.
const FIELDS: [(ProbeField, Ty); 7] = [
    (ProbeField::Hit, Ty::Int),
    (ProbeField::HitDist, Ty::Float),
    (ProbeField::P, Ty::Point),
    (ProbeField::N, Ty::Normal),
    (ProbeField::Ng, Ty::Normal),
    (ProbeField::U, Ty::Float),
    (ProbeField::V, Ty::Float),
];

/// The hidden variable holding property `field` of the last trace.
fn hidden(field: ProbeField) -> String {
    format!("$trace.{}", field.name())
}

/// The hidden variables' names, as identifiers at `span`.
pub(crate) fn trace_vars(span: Span) -> Vec<ast::Ident> {
    FIELDS
        .iter()
        .map(|(f, _)| ast::Ident {
            name: hidden(*f),
            span,
        })
        .collect()
}

impl<'a> Lower<'a> {
    /// Declares the hidden trace variables (called with the globals' scope current): zero
    /// (no trace yet).
    pub(crate) fn declare_trace_vars(&mut self, b: &mut Builder) {
        for (f, ty) in FIELDS {
            let zero = Self::poison(b, ty);
            self.declare_hidden(&hidden(f), zero);
        }
    }

    /// `trace(pos, dir, "option", value, …)`: one probe per property into the hidden
    /// variables; the call's value is whether the ray hit (an int).
    pub(crate) fn osl_trace(&mut self, b: &mut Builder, args: &[(Val, Span)], span: Span) -> Val {
        let fail = |me: &mut Self, b: &mut Builder, why: String, at: Span| {
            me.error(why, at, "trace");
            Self::poison(b, Ty::Int)
        };
        let (pos, dir) = match args {
            [
                (Val::V { v: p, ty: tp, .. }, _),
                (Val::V { v: d, ty: td, .. }, _),
                ..,
            ] if tp.is_triple() && td.is_triple() => {
                (b.retype(Type::Vec3, *p), b.retype(Type::Vec3, *d))
            }
            _ => {
                let why = "`trace` takes (point pos, vector dir) and then option names and values";
                return fail(self, b, why.into(), span);
            }
        };
        let (mut lo, mut hi) = (b.float(0.0), b.float(1.0e30));
        for pair in args[2..].chunks(2) {
            let [(Val::Str(name), at), (value, vat)] = pair else {
                let why = "`trace`'s options come in pairs: a name (a string) and its value";
                return fail(self, b, why.into(), pair[0].1);
            };
            match name.as_str() {
                "mindist" | "maxdist" => {
                    let Val::V {
                        v,
                        ty: Ty::Float | Ty::Int,
                        ..
                    } = value
                    else {
                        return fail(self, b, format!("`trace`'s \"{name}\" is a float"), *vat);
                    };
                    let v = if b.ty(*v) == Type::Int {
                        b.convert(Type::Float, *v)
                    } else {
                        *v
                    };
                    if name == "mindist" {
                        lo = v;
                    } else {
                        hi = v;
                    }
                }
                "shade" => {
                    let shaded = match value {
                        Val::V { v, .. } => shadenet_graph::opt::fold::constant(b.program(), *v)
                            .map(|c| match c {
                                ConstValue::Int(i) => i != 0,
                                ConstValue::Bool(x) => x,
                                c => c.floats().iter().any(|x| *x != 0.0),
                            }),
                        _ => None,
                    };
                    if shaded != Some(false) {
                        let why = "`trace` with \"shade\": shading what a probe ray hits is not built (a probe reports the hit only; 0 is accepted)";
                        return fail(self, b, why.into(), *vat);
                    }
                }
                "traceset" => {
                    let why =
                        "`trace`'s \"traceset\" (tracing against named object sets) is not built";
                    return fail(self, b, why.into(), *at);
                }
                other => {
                    let why = format!(
                        "`trace` has no option \"{other}\" (it takes \"mindist\", \"maxdist\", \"shade\")"
                    );
                    return fail(self, b, why, *at);
                }
            }
        }
        // `hit` (first in FIELDS) is the call's value too.
        let mut hit = None;
        for (f, ty) in FIELDS {
            let v = b.probe(f, pos, dir, lo, hi);
            let v = if ty == Ty::Int {
                b.convert(Type::Int, v)
            } else {
                v
            };
            hit.get_or_insert(v);
            self.set_flag(
                &hidden(f),
                Val::V {
                    v,
                    ty,
                    varying: true,
                },
            );
        }
        Val::V {
            v: hit.expect("FIELDS is not empty"),
            ty: Ty::Int,
            varying: true,
        }
    }

    /// `getmessage("trace", name, value)`: property `name` of the last trace's hit into
    /// `value` (unchanged where the ray hit nothing); the call's value is whether there is
    /// a hit (for `"hit"`, 1: the hit flag itself is the message).
    pub(crate) fn getmessage(
        &mut self,
        b: &mut Builder,
        vals: &[(Val, Span)],
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let fail = |me: &mut Self, b: &mut Builder, why: String, at: Span| {
            me.error(why, at, "getmessage");
            Self::poison(b, Ty::Int)
        };
        let ([(Val::Str(source), sat), (Val::Str(name), nat), (old, _)], [_, _, target]) =
            (vals, args)
        else {
            let why = "`getmessage` takes (string source, string name, output value)";
            return fail(self, b, why.into(), span);
        };
        if source != "trace" {
            let why = format!(
                "`getmessage(\"{source}\", …)`: only the \"trace\" source is built (a message `setmessage` left is `getmessage(name, value)`)"
            );
            return fail(self, b, why, *sat);
        }
        let Some((field, fty)) = FIELDS.iter().copied().find(|(f, _)| f.name() == name) else {
            let names: Vec<&str> = FIELDS.iter().map(|(f, _)| f.name()).collect();
            let why = format!(
                "`getmessage(\"trace\", \"{name}\", …)`: the trace records {}",
                names.join(", ")
            );
            return fail(self, b, why, *nat);
        };
        let read = |me: &Self, f: ProbeField| match me.lookup(&hidden(f)).map(|v| v.val.clone()) {
            Some(Val::V { v, .. }) => Some(v),
            _ => None,
        };
        let (Some(value), Some(hit)) = (read(self, field), read(self, ProbeField::Hit)) else {
            let why = "`getmessage(\"trace\", …)` outside a shader's scope".to_string();
            return fail(self, b, why, span);
        };
        let Val::V {
            ty: oty, v: old_v, ..
        } = old.clone()
        else {
            let why = format!(
                "`getmessage(\"trace\", \"{name}\", …)` writes a {} (not into {})",
                fty.name(),
                super::an(old.type_name())
            );
            return fail(self, b, why, target.span);
        };
        let got = self.coerce(
            b,
            Val::V {
                v: value,
                ty: fty,
                varying: true,
            },
            oty,
            target.span,
        );
        let Val::V { v: got, .. } = got else {
            return Self::poison(b, Ty::Int);
        };
        let found = super::nonzero(b, hit, Ty::Int);
        let new = if field == ProbeField::Hit {
            got
        } else {
            b.select(found, got, old_v)
        };
        let new = Val::V {
            v: new,
            ty: oty,
            varying: true,
        };
        self.store_output_arg(b, target, new, (3, "getmessage"));
        let result: Value = if field == ProbeField::Hit {
            b.int(1)
        } else {
            hit
        };
        Val::V {
            v: result,
            ty: Ty::Int,
            varying: true,
        }
    }
}
