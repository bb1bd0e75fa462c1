//! OSL's messages: `setmessage(name, value)` and `getmessage(name, value)` — a value one
//! layer of a shader group (or an earlier statement of the same shader) leaves for the
//! layers after it, per shaded point.
//!
//! A group's layers are inlined into one program in order, so a message is two hidden
//! variables declared with the globals — `$msg.NAME` (its value, zero until set) and
//! `$msg.NAME?` (an int, 1 once set) — handed from layer to layer with the globals
//! ([`super::group`]). `setmessage` assigns both; `getmessage(name, v)` writes the value
//! into `v` where the message is set (leaving `v` as it was elsewhere) and returns the flag;
//! a message nothing sets reads as not set (0). A `setmessage` under an `if` or in a loop
//! reaches later statements through the regions' yields, as an assignment would (the
//! statements that call it, directly or through a user function, count as assigning every
//! message: [`ALL_MESSAGES`]).
//!
//! A variable needs its type before the first region that may assign it, and only lowering
//! `setmessage`'s argument tells it; so a file or group that calls `setmessage` is lowered
//! twice: the first lowering only records each message's type ([`Lower::messages_found`]),
//! the second declares them ([`Lower::message_types`]) and builds the program. The names are
//! compile-time strings (as all of ours); one name keeps one type (a second type is an
//! error naming the first). Values are ints, floats, triples and matrices; strings,
//! closures, arrays and structs are refused as not built. Owns these two builtins (the
//! `"trace"` source of `getmessage` is [`super::probe`]'s).

use super::{Lower, Ty, Val, an};
use crate::Parsed;
use crate::ast::{self, Expr, ExprKind, Item, Stmt};
use crate::source::Span;
use shadenet_graph::ir::Builder;

/// Stands, among the names a statement may assign, for every message's hidden variables
/// (what a `setmessage` — directly or in a called function — may set).
pub(crate) const ALL_MESSAGES: &str = "$msg.*";

/// The hidden variable holding message `name`'s value.
fn value_var(name: &str) -> String {
    format!("$msg.{name}")
}

/// The hidden variable saying whether message `name` is set (an int, 0 or 1).
fn set_var(name: &str) -> String {
    format!("$msg.{name}?")
}

/// Whether a hidden variable is a message's (the group hands these from layer to layer).
pub(crate) fn is_message_var(name: &str) -> bool {
    name.starts_with("$msg.")
}

/// Whether a parsed OSL file calls `setmessage` anywhere: then it is lowered twice (see the
/// module docs).
pub(crate) fn calls_setmessage(parsed: &Parsed) -> bool {
    if parsed.dialect != crate::Dialect::Osl {
        return false;
    }
    let mut found = false;
    let mut look = |s: &Stmt| {
        super::walk::walk_stmt(s, &mut |e| {
            if let ExprKind::Call { callee, .. } = &e.kind {
                found |= callee.name == "setmessage";
            }
        })
    };
    for item in &parsed.file.items {
        match item {
            Item::Function(f) => f.body.stmts.iter().for_each(&mut look),
            Item::Shader(s) => s.body.stmts.iter().for_each(&mut look),
            Item::Struct(_) => {}
        }
    }
    found
}

/// Whether a message of type `ty` can be kept in a hidden variable.
fn storable(ty: Ty) -> bool {
    matches!(ty, Ty::Int | Ty::Float | Ty::Matrix) || ty.is_triple()
}

impl<'a> Lower<'a> {
    /// Declares the hidden variables of every message of known type (called with the
    /// globals' scope current): zero, not set.
    pub(crate) fn declare_message_vars(&mut self, b: &mut Builder) {
        let types: Vec<(String, Ty)> = self
            .message_types
            .iter()
            .map(|(n, t)| (n.clone(), *t))
            .collect();
        for (name, ty) in types {
            let (zero, unset) = (Self::poison(b, ty), Self::poison(b, Ty::Int));
            self.declare_hidden(&value_var(&name), zero);
            self.declare_hidden(&set_var(&name), unset);
        }
    }

    /// The hidden variables of every declared message, as identifiers at `span` (what a
    /// statement that sets a message may assign).
    pub(crate) fn message_vars(&self, span: Span) -> Vec<ast::Ident> {
        self.message_types
            .keys()
            .flat_map(|n| [value_var(n), set_var(n)])
            .map(|name| ast::Ident { name, span })
            .collect()
    }

    /// The messages the lowering found, with their types (for the second lowering).
    pub(crate) fn found_message_types(&self) -> std::collections::BTreeMap<String, Ty> {
        self.messages_found
            .iter()
            .map(|(n, (t, _))| (n.clone(), *t))
            .collect()
    }

    /// `setmessage(name, value)`.
    pub(crate) fn setmessage(&mut self, b: &mut Builder, args: &[(Val, Span)], span: Span) -> Val {
        let void = Self::void;
        let [(name, nat), (value, vat)] = args else {
            self.error(
                "`setmessage` takes (string name, value)",
                span,
                "setmessage",
            );
            return void(b);
        };
        let Val::Str(name) = name else {
            self.error(
                format!(
                    "`setmessage`'s name is a string known at compile time, not {}",
                    an(name.type_name())
                ),
                *nat,
                "the name",
            );
            return void(b);
        };
        let ty = match value {
            Val::V { ty, .. } if storable(*ty) => *ty,
            other => {
                self.error(
                    format!(
                        "`setmessage` of {} is not built (ints, floats, points, vectors, normals, colors and matrices are)",
                        an(other.type_name())
                    ),
                    *vat,
                    "this value",
                );
                return void(b);
            }
        };
        match self.messages_found.get(name) {
            Some((first, at)) if *first != ty => {
                let d = crate::diag::Diagnostic::error(
                    format!(
                        "message \"{name}\" is {}; here {}: a message keeps one type",
                        an(first.name()),
                        an(ty.name())
                    ),
                    *vat,
                    "another type",
                )
                .with_secondary(*at, format!("set as {} here", an(first.name())));
                if self.diags.len() < super::MAX_ERRORS {
                    self.diags.push(d);
                }
                return void(b);
            }
            Some(_) => {}
            None => {
                self.messages_found.insert(name.clone(), (ty, *vat));
            }
        }
        // The first lowering only learns the type.
        if self.message_types.get(name) == Some(&ty) {
            let one = b.int(1);
            self.set_flag(&value_var(name), value.clone());
            self.set_flag(
                &set_var(name),
                Val::V {
                    v: one,
                    ty: Ty::Int,
                    varying: false,
                },
            );
        }
        void(b)
    }

    /// `getmessage(name, value)`: the message into `value` where it is set (unchanged
    /// elsewhere); returns whether it is set.
    pub(crate) fn layer_getmessage(
        &mut self,
        b: &mut Builder,
        vals: &[(Val, Span)],
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let ([(Val::Str(name), _), (old, _)], [_, target]) = (vals, args) else {
            self.error(
                "`getmessage` takes (string name, output value) or (string source, string name, output value)",
                span,
                "getmessage",
            );
            return Self::poison(b, Ty::Int);
        };
        let read = |me: &Self, var: &str| me.lookup(var).map(|v| v.val.clone());
        let (
            Some(msg),
            Some(Val::V {
                v: set,
                varying: set_varying,
                ..
            }),
        ) = (read(self, &value_var(name)), read(self, &set_var(name)))
        else {
            // Nothing sets it (or this is the first lowering): not set.
            return Val::V {
                v: b.int(0),
                ty: Ty::Int,
                varying: false,
            };
        };
        let Val::V {
            v: old_v, ty: oty, ..
        } = old.clone()
        else {
            self.error(
                format!(
                    "`getmessage(\"{name}\", …)` writes {} (not into {})",
                    an(msg.type_name()),
                    an(old.type_name())
                ),
                target.span,
                "wrong type",
            );
            return Self::poison(b, Ty::Int);
        };
        let Val::V { v: got, .. } = self.coerce(b, msg.clone(), oty, target.span) else {
            return Self::poison(b, Ty::Int);
        };
        let found = super::nonzero(b, set, Ty::Int);
        let new = b.select(found, got, old_v);
        let varying = set_varying
            || matches!(msg, Val::V { varying: true, .. })
            || matches!(old, Val::V { varying: true, .. });
        self.store_output_arg(
            b,
            target,
            Val::V {
                v: new,
                ty: oty,
                varying,
            },
            (2, "getmessage"),
        );
        Val::V {
            v: set,
            ty: Ty::Int,
            varying,
        }
    }
}
