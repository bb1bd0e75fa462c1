//! Phase 4, generic types: picks each generic node's type `T`, in dependency order, from the
//! widths of its literals and the types of its connections on generic ports, within the
//! types its def allows; and answers what type each output and connection delivers
//! ([`Typed`]).
//!
//! It owns the choice of `T` and its errors. It must not check a port's value against its
//! type (that is `check.rs`) or convert literals.

use super::error::LinkError;
use super::expand::Flat;
use super::resolve::{Conn, In};
use crate::nodes::{NodeDef, PortType};
use crate::types::Type;
use serde_json::Value as Json;

/// The flattened nodes with their generic types: what every output delivers.
pub(super) struct Typed<'a, 'l> {
    /// The flattened nodes.
    pub(super) flat: &'a [Flat<'l>],
    /// Per flattened node, its generic type (`Float` for non-generic nodes).
    pub(super) generic: Vec<Type>,
}

impl Typed<'_, '_> {
    /// The type output `output` of node `node` delivers.
    pub(super) fn out_ty(&self, node: usize, output: usize) -> Type {
        self.flat[node].def.outputs[output]
            .ty
            .unwrap_or(self.generic[node])
    }

    /// The type a connection delivers (a selected component is a float).
    pub(super) fn conn_ty(&self, c: &Conn) -> Type {
        let t = self.out_ty(c.node, c.output);
        if c.component.is_some() {
            Type::Float
        } else {
            t
        }
    }

    /// What a generic node's inputs say about `T`: the widest literal on a generic port or
    /// field (at least 1), and the types of its connections there.
    fn evidence(&self, def: &NodeDef, inputs: &[In]) -> (usize, Vec<Type>) {
        let mut width = 1;
        let mut seen: Vec<Type> = Vec::new();
        for (pi, p) in def.inputs.iter().enumerate() {
            let generic_field = |f: usize| match &p.ty {
                PortType::Array(fields) => fields[f].1.is_none(),
                _ => false,
            };
            match (&p.ty, &inputs[pi]) {
                (PortType::Generic, In::Lit(Json::Array(a))) => width = width.max(a.len()),
                (PortType::Generic, In::Conn(c)) => seen.push(self.conn_ty(c)),
                (PortType::Array(_), In::Array(a)) => {
                    for rec in a {
                        for (fi, v) in rec {
                            if !generic_field(*fi) {
                                continue;
                            }
                            match v {
                                In::Lit(Json::Array(a)) => width = width.max(a.len()),
                                In::Conn(c) => seen.push(self.conn_ty(c)),
                                _ => {}
                            }
                        }
                    }
                }
                _ => {}
            }
        }
        (width, seen)
    }
}

/// Picks the generic type of every node of `flat`, visiting them in `order` so that each
/// node's sources are typed first.
pub(super) fn infer<'a, 'l>(
    flat: &'a [Flat<'l>],
    ins: &[Vec<In>],
    order: &[usize],
    errors: &mut Vec<LinkError>,
) -> Typed<'a, 'l> {
    let mut typed = Typed {
        flat,
        generic: vec![Type::Float; flat.len()],
    };
    for &i in order {
        let def = flat[i].def;
        if def.generic.is_empty() {
            continue;
        }
        let (width, seen) = typed.evidence(def, &ins[i]);
        typed.generic[i] = choose(def, &flat[i].name, width, &seen, errors);
    }
    typed
}

/// The type `T` of node `name` (of type `def`): the type of `width` components (color
/// when a color feeds it or the def prefers color, else vec3 at width 3), fitted to the
/// types `def` allows. Reports widths no type has and types the def does not take.
fn choose(
    def: &NodeDef,
    name: &str,
    width: usize,
    seen: &[Type],
    errors: &mut Vec<LinkError>,
) -> Type {
    let width = seen.iter().fold(width, |w, t| w.max(t.width()));
    let any_color = seen.contains(&Type::Color);
    let any_vec3 = seen.contains(&Type::Vec3);
    let t = match width {
        1 => Type::Float,
        2 => Type::Vec2,
        3 if any_color || (!any_vec3 && def.generic.contains(&Type::Color)) => Type::Color,
        3 => Type::Vec3,
        w => {
            errors.push(LinkError::BadInput {
                node: name.to_string(),
                port: "(generic)".into(),
                msg: format!("no {}-component type exists for this node", w),
            });
            Type::Float
        }
    };
    if def.generic.contains(&t) {
        t
    } else if t == Type::Color && def.generic.contains(&Type::Vec3) {
        Type::Vec3
    } else if t == Type::Vec3 && def.generic.contains(&Type::Color) {
        Type::Color
    } else if t == Type::Float && !def.generic.contains(&Type::Float) {
        def.generic[0]
    } else {
        errors.push(LinkError::BadInput {
            node: name.to_string(),
            port: "(generic)".into(),
            msg: format!(
                "its inputs make it {t}, which {} does not support (it takes {})",
                def.name,
                def.generic
                    .iter()
                    .map(|t| t.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        });
        def.generic[0]
    }
}
