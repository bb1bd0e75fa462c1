//! Phase 5, checking: in dependency order, checks every input against its port's type and
//! emits the linked nodes. Literals are converted to the port's type ([`literal`]),
//! connections are checked (component in range, source not a light, [`coercible`]) and
//! carry their coercion, string options are checked; shading nodes become
//! [`LinkedNode`]s and light nodes become light descriptions (`light.rs`).
//!
//! It owns the per-input type errors. It must not pick generic types (`generic.rs`) or
//! resolve names (`resolve.rs`); it reads their results.

use super::error::LinkError;
use super::generic::Typed;
use super::light;
use super::linked::{LinkedInput, LinkedNode, Source};
use super::resolve::{Conn, In};
use super::values::{coercible, literal};
use crate::nodes::{LightDesc, NodeKind, PortDef, PortType};
use crate::types::{ConstValue, Type};

/// The linked shading nodes (in `order`) and the lights the light nodes describe.
pub(super) fn nodes(
    typed: &Typed<'_, '_>,
    ins: &[Vec<In>],
    order: &[usize],
    pos: &[usize],
    errors: &mut Vec<LinkError>,
) -> (Vec<LinkedNode>, Vec<LightDesc>) {
    let checker = Checker { typed, pos };
    let mut nodes = Vec::new();
    let mut lights = Vec::new();
    for &i in order {
        let n = &typed.flat[i];
        let def = n.def;
        let inputs: Vec<LinkedInput> = def
            .inputs
            .iter()
            .zip(&ins[i])
            .map(|(p, v)| checker.port(i, p, v, errors))
            .collect();
        match def.kind {
            NodeKind::Shading => nodes.push(LinkedNode {
                name: n.name.clone(),
                ty: def.name.to_string(),
                generic: typed.generic[i],
                inputs,
            }),
            NodeKind::Light(make) => {
                lights.extend(light::describe(&n.name, def, make, &inputs, errors));
            }
        }
    }
    (nodes, lights)
}

/// Checks inputs against the typed network.
struct Checker<'a, 'b, 'l> {
    typed: &'a Typed<'b, 'l>,
    /// Per flattened node, its index among the linked nodes.
    pos: &'a [usize],
}

impl Checker<'_, '_, '_> {
    /// Node `i`'s input `v` at port `p`, checked against the port's type and options.
    fn port(&self, i: usize, p: &PortDef, v: &In, errors: &mut Vec<LinkError>) -> LinkedInput {
        let generic = self.typed.generic[i];
        let li = match (&p.ty, v) {
            (PortType::Simple(t), v) => self.value(i, p.name, *t, v, errors),
            (PortType::Generic, v) => self.value(i, p.name, generic, v, errors),
            (PortType::Array(fields), In::Array(a)) => {
                let mut arr = Vec::new();
                for (ei, rec) in a.iter().enumerate() {
                    let mut out = vec![LinkedInput::Default; fields.len()];
                    for (fi, v) in rec {
                        let (fname, fty) = fields[*fi];
                        let where_ = format!("{}[{ei}].{fname}", p.name);
                        out[*fi] = self.value(i, &where_, fty.unwrap_or(generic), v, errors);
                    }
                    arr.push(out);
                }
                LinkedInput::Array(arr)
            }
            (PortType::Array(_), _) => LinkedInput::Default,
        };
        if let (LinkedInput::Str(s), false) = (&li, p.options.is_empty())
            && !p.options.contains(&s.as_str())
        {
            errors.push(LinkError::BadInput {
                node: self.typed.flat[i].name.clone(),
                port: p.name.into(),
                msg: format!("`{s}` is not one of: {}", p.options.join(", ")),
            });
        }
        li
    }

    /// One value (not an array) for node `i`'s `port` of type `ty`.
    fn value(
        &self,
        i: usize,
        port: &str,
        ty: Type,
        v: &In,
        errors: &mut Vec<LinkError>,
    ) -> LinkedInput {
        match v {
            In::Default => LinkedInput::Default,
            In::Lit(j) => match literal(j, ty) {
                Ok(ConstValue::String(s)) => LinkedInput::Str(s),
                Ok(c) => LinkedInput::Const(c),
                Err(msg) => {
                    errors.push(LinkError::BadInput {
                        node: self.typed.flat[i].name.clone(),
                        port: port.into(),
                        msg,
                    });
                    LinkedInput::Default
                }
            },
            In::Conn(c) => self.conn(i, port, ty, c, errors),
            In::Array(_) => LinkedInput::Default,
        }
    }

    /// A connection into node `i`'s `port` of type `ty`: its component must exist, its
    /// source must be a shading node, and its type must coerce to `ty`.
    fn conn(
        &self,
        i: usize,
        port: &str,
        ty: Type,
        c: &Conn,
        errors: &mut Vec<LinkError>,
    ) -> LinkedInput {
        let name = &self.typed.flat[i].name;
        let src = &self.typed.flat[c.node];
        let full = self.typed.out_ty(c.node, c.output);
        if let Some(k) = c.component
            && (!full.is_vector() || k as usize >= full.width())
        {
            errors.push(LinkError::BadInput {
                node: name.clone(),
                port: port.into(),
                msg: format!("`{}`: a {full} has no such component", c.text),
            });
            return LinkedInput::Default;
        }
        if !matches!(src.def.kind, NodeKind::Shading) {
            errors.push(LinkError::BadInput {
                node: name.clone(),
                port: port.into(),
                msg: format!("`{}` is a light; lights have no outputs", c.text),
            });
            return LinkedInput::Default;
        }
        let from = self.typed.conn_ty(c);
        if ty == Type::String || !coercible(from, ty) {
            errors.push(LinkError::TypeMismatch {
                node: name.clone(),
                port: port.into(),
                expected: ty,
                conn: c.text.clone(),
                found: from,
            });
            return LinkedInput::Default;
        }
        LinkedInput::Conn(Source {
            node: self.pos[c.node],
            output: c.output,
            component: c.component,
            from,
            to: ty,
        })
    }
}
