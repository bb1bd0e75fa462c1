//! Phase 2, resolution: gives every flattened node an index (reporting duplicate names) and
//! resolves every connection string to a [`Conn`] (source node index, output index,
//! component), following compound output aliases, so each node's inputs become one [`In`]
//! per port of its def.
//!
//! It owns names → indices, output names → output indices and component letters → component
//! indices. It must not check types or literals: a component's validity for the source's type
//! is checked once generic types are known (`generic.rs`, `check.rs`).

use super::error::LinkError;
use super::expand::{Expanded, Flat, Raw};
use super::names::split_ref;
use crate::nodes::PortType;
use serde_json::Value as Json;
use std::collections::{HashMap, HashSet};

/// A connection resolved to indices.
pub(super) struct Conn {
    /// Index of the source node among the flattened nodes.
    pub(super) node: usize,
    /// Index of the source node's output.
    pub(super) output: usize,
    /// The selected component, if any (not yet checked against the output's type).
    pub(super) component: Option<u8>,
    /// The connection as written.
    pub(super) text: String,
}

/// One input after resolution: per def port, the value with its connections resolved.
pub(super) enum In {
    /// Unset, or unusable (its error already reported).
    Default,
    /// A literal, not yet checked against the port's type.
    Lit(Json),
    /// A resolved connection.
    Conn(Conn),
    /// An array input: per element, (field index, value).
    Array(Vec<Vec<(usize, In)>>),
}

/// Resolves connection strings against the expanded network.
pub(super) struct Resolver<'a, 'l> {
    flat: &'a [Flat<'l>],
    aliases: &'a HashMap<(String, String), String>,
    broken: &'a HashSet<String>,
    index: HashMap<&'a str, usize>,
}

/// The component a letter names (`x/y/z`, `r/g/b`, `u/v`).
fn component(c: &str) -> Option<u8> {
    ["x", "y", "z"]
        .iter()
        .position(|x| *x == c)
        .or_else(|| ["r", "g", "b"].iter().position(|x| *x == c))
        .or_else(|| ["u", "v"].iter().position(|x| *x == c))
        .map(|k| k as u8)
}

impl<'a, 'l> Resolver<'a, 'l> {
    /// Indexes the flattened nodes by name, reporting names used twice.
    pub(super) fn new(ex: &'a Expanded<'l>, errors: &mut Vec<LinkError>) -> Self {
        let mut index: HashMap<&str, usize> = HashMap::new();
        for (i, n) in ex.flat.iter().enumerate() {
            if index.insert(&n.name, i).is_some() {
                errors.push(LinkError::DuplicateName {
                    node: n.name.clone(),
                });
            }
        }
        Resolver {
            flat: &ex.flat,
            aliases: &ex.aliases,
            broken: &ex.broken,
            index,
        }
    }

    /// Resolves the connection `conn` written at `node`'s input `port`, following compound
    /// output aliases. `None` (with its error reported, unless the target was already
    /// reported as broken) when it cannot be resolved.
    pub(super) fn conn(
        &self,
        conn: &str,
        node: &str,
        port: &str,
        errors: &mut Vec<LinkError>,
    ) -> Option<Conn> {
        let mut cur = conn.to_string();
        let mut hops = 0;
        loop {
            let Some((n, o, c)) = split_ref(&cur) else {
                errors.push(LinkError::BadInput {
                    node: node.into(),
                    port: port.into(),
                    msg: format!(
                        "`{conn}` is not a connection of the form node.output or node.output.component"
                    ),
                });
                return None;
            };
            let Some(target) = self.aliases.get(&(n.to_string(), o.to_string())) else {
                return self.direct((n, o, c), conn, node, port, errors);
            };
            hops += 1;
            if hops > 64 {
                errors.push(LinkError::BadInput {
                    node: node.into(),
                    port: port.into(),
                    msg: format!("`{conn}`: compound outputs refer to each other endlessly"),
                });
                return None;
            }
            cur = match c {
                Some(c) => format!("{target}.{c}"),
                None => target.clone(),
            };
        }
    }

    /// Resolves `node.output[.component]` naming a library node (no alias left).
    fn direct(
        &self,
        (n, o, c): (&str, &str, Option<&str>),
        conn: &str,
        node: &str,
        port: &str,
        errors: &mut Vec<LinkError>,
    ) -> Option<Conn> {
        let Some(&i) = self.index.get(n) else {
            if self.broken.contains(n) {
                return None;
            }
            errors.push(LinkError::Dangling {
                node: node.into(),
                port: port.into(),
                conn: conn.into(),
                target: n.into(),
            });
            return None;
        };
        let def = self.flat[i].def;
        let Some(out) = def.output_index(o) else {
            errors.push(LinkError::UnknownOutput {
                node: node.into(),
                port: port.into(),
                target: n.into(),
                ty: def.name.into(),
                output: o.into(),
                valid: def
                    .outputs
                    .iter()
                    .map(|x| x.name)
                    .collect::<Vec<_>>()
                    .join(", "),
            });
            return None;
        };
        // The component index is checked against the type once generics are known.
        let component = match c {
            None => None,
            Some(c) => match component(c) {
                Some(k) => Some(k),
                None => {
                    errors.push(LinkError::BadInput {
                        node: node.into(),
                        port: port.into(),
                        msg: format!(
                            "`{conn}`: `{c}` is not a component (use r/g/b, x/y/z or u/v)"
                        ),
                    });
                    return None;
                }
            },
        };
        Some(Conn {
            node: i,
            output: out,
            component,
            text: conn.to_string(),
        })
    }

    /// Per flattened node, per def port, the input with its connections resolved.
    pub(super) fn inputs(&self, errors: &mut Vec<LinkError>) -> Vec<Vec<In>> {
        self.flat.iter().map(|n| self.node(n, errors)).collect()
    }

    /// One node's inputs, one per port of its def.
    fn node(&self, n: &Flat<'l>, errors: &mut Vec<LinkError>) -> Vec<In> {
        let mut ports: Vec<In> = n.def.inputs.iter().map(|_| In::Default).collect();
        for (port, raw) in &n.inputs {
            let pi = n
                .def
                .inputs
                .iter()
                .position(|p| p.name == port)
                .expect("checked");
            ports[pi] = match raw {
                Raw::Lit(j) => In::Lit(j.clone()),
                Raw::Conn(c) => match self.conn(c, &n.name, port, errors) {
                    Some(c) => In::Conn(c),
                    None => In::Default,
                },
                Raw::Array(elems) => {
                    let PortType::Array(fields) = &n.def.inputs[pi].ty else {
                        continue;
                    };
                    self.array(n, port, fields, elems, errors)
                }
            };
        }
        ports
    }

    /// An array input: each record's fields resolved, missing fields reported.
    fn array(
        &self,
        n: &Flat<'l>,
        port: &str,
        fields: &[(&'static str, Option<crate::types::Type>)],
        elems: &[Vec<(String, Raw)>],
        errors: &mut Vec<LinkError>,
    ) -> In {
        let mut arr = Vec::new();
        for (ei, rec) in elems.iter().enumerate() {
            let mut r = Vec::new();
            for (field, raw) in rec {
                let fi = fields.iter().position(|f| f.0 == field).expect("checked");
                let where_ = format!("{port}[{ei}].{field}");
                let v = match raw {
                    Raw::Lit(j) => In::Lit(j.clone()),
                    Raw::Conn(c) => match self.conn(c, &n.name, &where_, errors) {
                        Some(c) => In::Conn(c),
                        None => In::Default,
                    },
                    Raw::Array(_) => {
                        errors.push(LinkError::BadInput {
                            node: n.name.clone(),
                            port: where_,
                            msg: "nested arrays are not allowed".into(),
                        });
                        In::Default
                    }
                };
                r.push((fi, v));
            }
            for (fi, (fname, _)) in fields.iter().enumerate() {
                if !r.iter().any(|(i, _)| *i == fi) {
                    errors.push(LinkError::BadInput {
                        node: n.name.clone(),
                        port: format!("{port}[{ei}]"),
                        msg: format!("the record has no `{fname}`"),
                    });
                }
            }
            arr.push(r);
        }
        In::Array(arr)
    }
}
