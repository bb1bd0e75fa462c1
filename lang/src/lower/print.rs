//! Messages: OSL's `printf`, `warning` and `error` (and RSL's `printf`) lowered to the IR's
//! print op ([`Op::Print`]), which every CPU back end writes in fragment order.
//!
//! The format must be a string known at compile time. Arguments known at compile time —
//! strings, and numbers the front end has folded to constants — are formatted here and
//! spliced into the format as text ([`printf::specialize`]); the others stay conversions,
//! formatted while shading from the values the op carries. Every conversion is checked
//! against its argument here, so a message never fails at run time.
//!
//! A print under a flattened `if` (one that assigns closures: both arms are lowered in the
//! enclosing block) would run whatever the condition says; [`Lower::print_guard`] holds
//! the conditions of the flattened arms around the current point, and a print under any
//! runs inside an `if` region on their conjunction. Owns these three builtins; the formatting
//! is `shadenet_graph::ops::printf`'s.
//!
//! [`Op::Print`]: shadenet_graph::ir::Op::Print

use super::{Lower, Val};
use crate::options::Dialect;
use crate::source::Span;
use shadenet_graph::ir::{BinOp, Builder, Severity, UnOp, Value};
use shadenet_graph::ops::printf::{self, Arg};

/// The message builtins of `dialect` (RSL has `printf` only).
pub(crate) fn severity(dialect: Dialect, name: &str) -> Option<Severity> {
    match (dialect, name) {
        (_, "printf") => Some(Severity::Printf),
        (Dialect::Osl, "warning") => Some(Severity::Warning),
        (Dialect::Osl, "error") => Some(Severity::Error),
        _ => None,
    }
}

impl Lower<'_> {
    /// `printf(format, args…)`, `warning(…)`, `error(…)`: one print op (under the flattened
    /// arms' conditions, if any). Its value is void (a float 0 no one reads).
    pub(crate) fn print(
        &mut self,
        b: &mut Builder,
        (name, severity): (&str, Severity),
        args: &[(Val, Span)],
        span: Span,
    ) -> Val {
        let void = Self::void;
        let Some((Val::Str(format), _)) = args.first() else {
            self.error(
                format!("`{name}` takes a format string first (a string known at compile time)"),
                args.first().map_or(span, |a| a.1),
                "not a string",
            );
            return void(b);
        };
        let mut slots = Vec::with_capacity(args.len() - 1);
        let mut values = Vec::new();
        for (k, (v, at)) in args.iter().enumerate().skip(1) {
            let slot = match v {
                Val::Str(s) => Some((Arg::Str(s.clone()), true)),
                Val::V { v, ty, .. } => {
                    match shadenet_graph::opt::fold::constant(b.program(), *v) {
                        Some(c) => Some((printf::const_arg(&c), true)),
                        None => {
                            values.push(*v);
                            printf::placeholder(ty.ir()).map(|a| (a, false))
                        }
                    }
                }
                _ => None,
            };
            let Some(slot) = slot else {
                self.error(
                    format!(
                        "`{name}`'s argument {} cannot be printed: a message formats numbers, \
                         triples, matrices and strings (print an array's elements or a \
                         struct's fields one by one)",
                        k + 1
                    ),
                    *at,
                    "not printable",
                );
                return void(b);
            };
            slots.push(slot);
        }
        let format = match printf::specialize(format, &slots) {
            Ok(f) => f,
            Err(e) => {
                self.error(format!("`{name}`: {e}"), span, "here");
                return void(b);
            }
        };
        match self.guard_condition(b) {
            None => {
                b.print(severity, format, values);
            }
            Some(c) => {
                b.if_(
                    c,
                    |b| {
                        b.print(severity, format, values);
                        Vec::new()
                    },
                    |_| Vec::new(),
                );
            }
        }
        void(b)
    }

    /// The conjunction of the flattened arms' conditions around the current point, or
    /// `None` outside any.
    fn guard_condition(&mut self, b: &mut Builder) -> Option<Value> {
        let mut all: Option<Value> = None;
        for (c, holds) in self.print_guard.clone() {
            let c = if holds { c } else { b.unary(UnOp::Not, c) };
            all = Some(match all {
                Some(a) => b.binary(BinOp::And, a, c),
                None => c,
            });
        }
        all
    }
}
