//! Phase 1, expansion: checks the format version, registers the compounds, and flattens the
//! network into library nodes ([`Flat`]), inlining every compound instance (its inner nodes
//! are renamed `instance/inner`, its `$input` references replaced by the instance's inputs,
//! its outputs recorded as aliases of inner outputs).
//!
//! It owns node names, node types, port names and the shape of input values (literal,
//! connection string, array of records). It must not resolve a connection to a node (that is
//! `resolve.rs`) or look at types beyond "is this port a string or an array".

use super::error::LinkError;
use super::names::{bad_name, suggest};
use crate::network::{CompoundSpec, Network, NodeSpec};
use crate::nodes::{NodeDef, NodeLibrary, PortType};
use crate::types::Type;
use serde_json::Value as Json;
use std::collections::{HashMap, HashSet};

/// An input value after compound expansion: a literal, a connection with full node names, or
/// an array of records.
#[derive(Clone, Debug)]
pub(super) enum Raw {
    /// A literal, not yet checked against the port's type.
    Lit(Json),
    /// A connection `node.output[.component]` with the node's full name.
    Conn(String),
    /// An array input: per element, its (field, value) pairs as written.
    Array(Vec<Vec<(String, Raw)>>),
}

/// A node after compound expansion.
#[derive(Debug)]
pub(super) struct Flat<'l> {
    /// Its full name (`instance/inner` inside compounds).
    pub(super) name: String,
    /// Its library node type.
    pub(super) def: &'l NodeDef,
    /// The inputs it sets, in the order written.
    pub(super) inputs: Vec<(String, Raw)>,
}

/// What expansion hands to resolution.
pub(super) struct Expanded<'l> {
    /// The library nodes, in the order written (compound instances inlined in place).
    pub(super) flat: Vec<Flat<'l>>,
    /// (full node name, output) of a compound instance → the inner reference it stands for.
    pub(super) aliases: HashMap<(String, String), String>,
    /// Nodes already reported as unusable (unknown type): connections to them are not
    /// reported again.
    pub(super) broken: HashSet<String>,
}

/// Expands `net` against `lib`, appending what is wrong to `errors`.
pub(super) fn network<'l>(
    net: &Network,
    lib: &'l NodeLibrary,
    errors: &mut Vec<LinkError>,
) -> Expanded<'l> {
    let mut ex = Expander {
        lib,
        compounds: HashMap::new(),
        flat: Vec::new(),
        aliases: HashMap::new(),
        errors: std::mem::take(errors),
        stack: Vec::new(),
        broken: HashSet::new(),
    };
    if net.version != 1 {
        ex.errors.push(LinkError::BadOutput {
            output: "version".into(),
            msg: format!("format version {} is not supported (only 1)", net.version),
        });
    }
    ex.register(&net.compounds);
    ex.expand(&net.nodes, "", None);
    *errors = ex.errors;
    Expanded {
        flat: ex.flat,
        aliases: ex.aliases,
        broken: ex.broken,
    }
}

struct Expander<'n, 'l> {
    lib: &'l NodeLibrary,
    compounds: HashMap<&'n str, &'n CompoundSpec>,
    flat: Vec<Flat<'l>>,
    /// (full node name, output) of a compound instance → the inner reference it stands for.
    aliases: HashMap<(String, String), String>,
    errors: Vec<LinkError>,
    stack: Vec<&'n str>,
    /// Nodes already reported as unusable (unknown type): connections to them are not
    /// reported again.
    broken: HashSet<String>,
}

/// Whether a port takes strings (a string there is a literal, not a connection).
fn port_is_string(def_port: Option<&PortType>) -> bool {
    matches!(def_port, Some(PortType::Simple(Type::String)))
}

impl<'n, 'l> Expander<'n, 'l> {
    /// Records the network's compound definitions by name.
    fn register(&mut self, compounds: &'n [CompoundSpec]) {
        for c in compounds {
            if self.lib.get(&c.name).is_some() {
                self.errors.push(LinkError::Compound {
                    compound: c.name.clone(),
                    msg: "has the name of a library node type".into(),
                });
            } else if self.compounds.insert(&c.name, c).is_some() {
                self.errors.push(LinkError::Compound {
                    compound: c.name.clone(),
                    msg: "is defined twice".into(),
                });
            }
        }
    }

    /// Flattens `nodes` (the network's, or a compound's with `prefix` `instance/` and the
    /// instance's inputs as `args`).
    fn expand(&mut self, nodes: &'n [NodeSpec], prefix: &str, args: Option<&HashMap<String, Raw>>) {
        for spec in nodes {
            let full = format!("{prefix}{}", spec.name);
            if let Some(reason) = bad_name(&spec.name) {
                self.errors.push(LinkError::BadName {
                    node: full.clone(),
                    reason,
                });
                continue;
            }
            if let Some(def) = self.lib.get(&spec.ty) {
                self.library_node(spec, def, full, prefix, args);
            } else if let Some(&comp) = self.compounds.get(spec.ty.as_str()) {
                self.instance(spec, comp, &full, prefix, args);
            } else {
                let hint = suggest(&spec.ty, self.lib)
                    .map(|s| format!(" (did you mean `{s}`?)"))
                    .unwrap_or_default();
                self.broken.insert(full.clone());
                self.errors.push(LinkError::UnknownType {
                    node: full,
                    ty: spec.ty.clone(),
                    hint,
                });
            }
        }
    }

    /// One node of a library type: its inputs classified against the def's ports.
    fn library_node(
        &mut self,
        spec: &'n NodeSpec,
        def: &'l NodeDef,
        full: String,
        prefix: &str,
        args: Option<&HashMap<String, Raw>>,
    ) {
        let mut inputs = Vec::new();
        for (port, json) in &spec.inputs {
            let Some(pd) = def.input(port) else {
                self.errors.push(LinkError::UnknownPort {
                    node: full.clone(),
                    ty: spec.ty.clone(),
                    port: port.clone(),
                    valid: def
                        .inputs
                        .iter()
                        .map(|p| p.name)
                        .collect::<Vec<_>>()
                        .join(", "),
                });
                continue;
            };
            let raw = match &pd.ty {
                PortType::Array(fields) => {
                    let names: Vec<&str> = fields.iter().map(|f| f.0).collect();
                    self.array(json, &names, prefix, args, &full, port)
                }
                ty => self.classify(json, port_is_string(Some(ty)), prefix, args, &full, port),
            };
            if let Some(raw) = raw {
                inputs.push((port.clone(), raw));
            }
        }
        self.flat.push(Flat {
            name: full,
            def,
            inputs,
        });
    }

    /// One compound instance: its inputs become the `args` of the compound's inner nodes,
    /// its outputs aliases of inner outputs, and its inner nodes are expanded under
    /// `instance/`.
    fn instance(
        &mut self,
        spec: &'n NodeSpec,
        comp: &'n CompoundSpec,
        full: &str,
        prefix: &str,
        args: Option<&HashMap<String, Raw>>,
    ) {
        if self.stack.contains(&comp.name.as_str()) {
            self.errors.push(LinkError::Compound {
                compound: comp.name.clone(),
                msg: format!("uses itself (through {})", self.stack.join(" → ")),
            });
            return;
        }
        let mut inner_args = HashMap::new();
        for (port, json) in &spec.inputs {
            let Some(decl) = comp.inputs.iter().find(|i| &i.name == port) else {
                self.errors.push(LinkError::UnknownPort {
                    node: full.to_string(),
                    ty: spec.ty.clone(),
                    port: port.clone(),
                    valid: comp
                        .inputs
                        .iter()
                        .map(|i| i.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
                continue;
            };
            let is_string = decl.ty == "string";
            if let Some(raw) = self.classify(json, is_string, prefix, args, full, port) {
                inner_args.insert(port.clone(), raw);
            }
        }
        for decl in &comp.inputs {
            if Type::from_name(&decl.ty).is_none() {
                self.errors.push(LinkError::Compound {
                    compound: comp.name.clone(),
                    msg: format!("input `{}` has unknown type `{}`", decl.name, decl.ty),
                });
            }
            if !inner_args.contains_key(&decl.name) {
                match &decl.default {
                    Some(d) => {
                        inner_args.insert(decl.name.clone(), Raw::Lit(d.clone()));
                    }
                    None => self.errors.push(LinkError::BadInput {
                        node: full.to_string(),
                        port: decl.name.clone(),
                        msg: format!(
                            "compound `{}` requires this input (it has no default)",
                            comp.name
                        ),
                    }),
                }
            }
        }
        let inner_prefix = format!("{full}/");
        for (out, target) in &comp.outputs {
            match target.as_str() {
                Some(t) if !t.starts_with('$') => {
                    self.aliases.insert(
                        (full.to_string(), out.clone()),
                        format!("{inner_prefix}{t}"),
                    );
                }
                _ => self.errors.push(LinkError::Compound {
                    compound: comp.name.clone(),
                    msg: format!(
                        "output `{out}` must be a string \"inner_node.output\", not {target}"
                    ),
                }),
            }
        }
        self.stack.push(&comp.name);
        self.expand(&comp.nodes, &inner_prefix, Some(&inner_args));
        self.stack.pop();
    }

    /// Classifies one input value (not an array port).
    fn classify(
        &mut self,
        json: &Json,
        string_port: bool,
        prefix: &str,
        args: Option<&HashMap<String, Raw>>,
        node: &str,
        port: &str,
    ) -> Option<Raw> {
        let conn = match json {
            Json::Object(m) => match (m.len(), m.get("connect")) {
                (1, Some(Json::String(s))) => Some(s.as_str()),
                _ => {
                    self.errors.push(LinkError::BadInput {
                        node: node.to_string(),
                        port: port.to_string(),
                        msg: format!(
                            "an object input must be {{\"connect\": \"node.output\"}}, not {json}"
                        ),
                    });
                    return None;
                }
            },
            Json::String(s) if !string_port => Some(s.as_str()),
            // A string input forwards a compound's input only by naming one (`$filtertype`
            // inside a compound with a `filtertype` input): any other string is its value.
            Json::String(s)
                if s.strip_prefix('$').is_some_and(|name| {
                    let name = name.split_once('.').map_or(name, |(n, _)| n);
                    args.is_some_and(|a| a.contains_key(name))
                }) =>
            {
                Some(s.as_str())
            }
            _ => None,
        };
        let Some(conn) = conn else {
            return Some(Raw::Lit(json.clone()));
        };
        if let Some(rest) = conn.strip_prefix('$') {
            let (name, comp) = match rest.split_once('.') {
                Some((n, c)) => (n, Some(c)),
                None => (rest, None),
            };
            let Some(args) = args else {
                self.errors.push(LinkError::BadInput {
                    node: node.to_string(),
                    port: port.to_string(),
                    msg: format!("`{conn}` refers to a compound input outside any compound"),
                });
                return None;
            };
            return match (args.get(name), comp) {
                (Some(raw), None) => Some(raw.clone()),
                (Some(Raw::Conn(c)), Some(comp)) => Some(Raw::Conn(format!("{c}.{comp}"))),
                (Some(_), Some(_)) => {
                    self.errors.push(LinkError::BadInput {
                        node: node.to_string(),
                        port: port.to_string(),
                        msg: format!(
                            "`{conn}` selects a component of a compound input that is a literal"
                        ),
                    });
                    None
                }
                (None, _) => {
                    self.errors.push(LinkError::BadInput {
                        node: node.to_string(),
                        port: port.to_string(),
                        msg: format!("`{conn}`: the compound has no input `{name}`"),
                    });
                    None
                }
            };
        }
        Some(Raw::Conn(format!("{prefix}{conn}")))
    }

    /// Classifies an array input: a list of records whose fields are `fields` (or a `$input`
    /// of the enclosing compound).
    fn array(
        &mut self,
        json: &Json,
        fields: &[&str],
        prefix: &str,
        args: Option<&HashMap<String, Raw>>,
        node: &str,
        port: &str,
    ) -> Option<Raw> {
        let Json::Array(elems) = json else {
            if let Json::String(s) = json
                && s.starts_with('$')
            {
                return self.classify(json, false, prefix, args, node, port);
            }
            self.errors.push(LinkError::BadInput {
                node: node.to_string(),
                port: port.to_string(),
                msg: format!(
                    "expects an array of {{{}}} records, not {json}",
                    fields.join(", ")
                ),
            });
            return None;
        };
        let mut out = Vec::new();
        for (i, e) in elems.iter().enumerate() {
            let Json::Object(m) = e else {
                self.errors.push(LinkError::BadInput {
                    node: node.to_string(),
                    port: format!("{port}[{i}]"),
                    msg: format!("expects a record {{{}}}, not {e}", fields.join(", ")),
                });
                continue;
            };
            let mut rec = Vec::new();
            for (k, v) in m {
                let where_ = format!("{port}[{i}].{k}");
                if !fields.contains(&k.as_str()) {
                    self.errors.push(LinkError::BadInput {
                        node: node.to_string(),
                        port: where_,
                        msg: format!("unknown field; the fields are: {}", fields.join(", ")),
                    });
                    continue;
                }
                if let Some(raw) = self.classify(v, false, prefix, args, node, &where_) {
                    rec.push((k.clone(), raw));
                }
            }
            out.push(rec);
        }
        Some(Raw::Array(out))
    }
}
