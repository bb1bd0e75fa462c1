//! The linker: from a parsed [`Network`] to a [`Linked`] network a lowering can trust.
//!
//! It expands compounds (inner nodes are renamed `instance/inner`), resolves every name to an
//! index, orders the nodes so sources come first (detecting cycles), picks each generic
//! node's type, checks and converts literals, checks connection types with the documented
//! coercions, builds light descriptions from light nodes, and resolves the material outputs.
//! It reports **every** error it finds, each naming the node and port as the user wrote them
//! (a compound's inner node as `instance/inner`).
//!
//! Coercions a connection may make (anything else is an error naming both types):
//! `float → vec2/vec3/color` (broadcast), `color ↔ vec3`, `int → float`, `bool → int`,
//! `bool → float`. A connection may select one component (`tex.outColor.r`), which makes it
//! a float.

use crate::network::{CompoundSpec, Network, NodeSpec};
use crate::nodes::{LightDesc, NodeDef, NodeKind, NodeLibrary, PortDefault, PortType};
use crate::types::{ConstValue, Type};
use serde_json::Value as Json;
use std::collections::HashMap;
use std::fmt;

/// A network after linking: nodes in dependency order with resolved, typed inputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Linked {
    /// The material's name.
    pub name: String,
    /// Shading nodes, sources before users.
    pub nodes: Vec<LinkedNode>,
    /// Material outputs, in declaration order.
    pub outputs: Vec<(String, Source)>,
    /// The lights the network's light nodes describe.
    pub lights: Vec<LightDesc>,
}

/// One shading node after linking.
#[derive(Clone, Debug, PartialEq)]
pub struct LinkedNode {
    /// Its full name (`instance/inner` inside compounds).
    pub name: String,
    /// Its library node type.
    pub ty: String,
    /// Its generic type `T` (`Float` for non-generic nodes).
    pub generic: Type,
    /// One input per port of its def, in port order.
    pub inputs: Vec<LinkedInput>,
}

/// A resolved input.
#[derive(Clone, Debug, PartialEq)]
pub enum LinkedInput {
    /// Unset: the port's default.
    Default,
    /// A literal, already of the port's type.
    Const(ConstValue),
    /// A string literal (string ports).
    Str(String),
    /// A connection.
    Conn(Source),
    /// An array input: per element, per record field.
    Array(Vec<Vec<LinkedInput>>),
}

/// Where a connection comes from, and how its value is converted on the way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source {
    /// Index of the source node in [`Linked::nodes`].
    pub node: usize,
    /// Index of the source node's output.
    pub output: usize,
    /// The selected component, if any.
    pub component: Option<u8>,
    /// The type delivered by the source (after component selection).
    pub from: Type,
    /// The type the port receives (after coercion).
    pub to: Type,
}

/// One problem found while linking.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LinkError {
    /// A node names a type that is neither in the library nor a compound.
    #[error("node `{node}`: unknown node type `{ty}`{hint}")]
    UnknownType {
        /// The node.
        node: String,
        /// The type it names.
        ty: String,
        /// A suggestion, if a similar name exists.
        hint: String,
    },
    /// Two nodes share a name.
    #[error("duplicate node name `{node}`")]
    DuplicateName {
        /// The name.
        node: String,
    },
    /// A node name the linker cannot use.
    #[error("node name `{node}` is invalid: {reason}")]
    BadName {
        /// The name.
        node: String,
        /// Why.
        reason: String,
    },
    /// An input that the node type does not have.
    #[error("node `{node}` ({ty}): unknown input `{port}`; its inputs are: {valid}")]
    UnknownPort {
        /// The node.
        node: String,
        /// Its type.
        ty: String,
        /// The port named.
        port: String,
        /// The valid ports.
        valid: String,
    },
    /// A connection to a node that does not exist.
    #[error("node `{node}` input `{port}`: connection `{conn}` names no node `{target}`")]
    Dangling {
        /// The node.
        node: String,
        /// The port.
        port: String,
        /// The connection as written.
        conn: String,
        /// The missing node.
        target: String,
    },
    /// A connection to an output the source does not have.
    #[error(
        "node `{node}` input `{port}`: node `{target}` ({ty}) has no output `{output}`; its outputs are: {valid}"
    )]
    UnknownOutput {
        /// The node.
        node: String,
        /// The port.
        port: String,
        /// The source node.
        target: String,
        /// The source's type.
        ty: String,
        /// The output named.
        output: String,
        /// The valid outputs.
        valid: String,
    },
    /// A connection whose type cannot be coerced to the port's.
    #[error(
        "node `{node}` input `{port}`: type mismatch: the input is {expected}, but `{conn}` is {found}"
    )]
    TypeMismatch {
        /// The node.
        node: String,
        /// The port.
        port: String,
        /// The port's type.
        expected: Type,
        /// The connection as written.
        conn: String,
        /// The source's type.
        found: Type,
    },
    /// A literal or connection that is malformed or out of range.
    #[error("node `{node}` input `{port}`: {msg}")]
    BadInput {
        /// The node.
        node: String,
        /// The port.
        port: String,
        /// What is wrong.
        msg: String,
    },
    /// Nodes that depend on themselves.
    #[error("cycle: {path}")]
    Cycle {
        /// The nodes around the cycle, `a → b → a`.
        path: String,
    },
    /// A material output that cannot be resolved.
    #[error("material output `{output}`: {msg}")]
    BadOutput {
        /// The output's name.
        output: String,
        /// What is wrong.
        msg: String,
    },
    /// The network declares no material output.
    #[error(
        "the network declares no material outputs (add \"outputs\": {{\"color\": \"node.outColor\"}})"
    )]
    NoOutputs,
    /// A compound definition that cannot be used.
    #[error("compound `{compound}`: {msg}")]
    Compound {
        /// The compound's name.
        compound: String,
        /// What is wrong.
        msg: String,
    },
    /// A node whose lowering rejected its inputs.
    #[error("node `{node}` ({ty}): {msg}")]
    Lowering {
        /// The node.
        node: String,
        /// Its type.
        ty: String,
        /// What is wrong.
        msg: String,
    },
}

/// Every problem found while linking (never empty).
#[derive(Clone, Debug, PartialEq)]
pub struct LinkErrors(pub Vec<LinkError>);

impl fmt::Display for LinkErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.len() == 1 {
            return write!(f, "{}", self.0[0]);
        }
        write!(f, "{} errors:", self.0.len())?;
        for e in &self.0 {
            write!(f, "\n  - {e}")?;
        }
        Ok(())
    }
}

impl std::error::Error for LinkErrors {}

/// An input value after compound expansion: a literal, a connection with full node names, or
/// an array of records.
#[derive(Clone, Debug)]
enum Raw {
    Lit(Json),
    Conn(String),
    Array(Vec<Vec<(String, Raw)>>),
}

/// A node after compound expansion.
#[derive(Debug)]
struct Flat<'l> {
    name: String,
    def: &'l NodeDef,
    inputs: Vec<(String, Raw)>,
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
    broken: std::collections::HashSet<String>,
}

/// The type a port of a library node or a compound instance takes (None for arrays and
/// generic ports whose type is not known yet).
fn port_is_string(def_port: Option<&PortType>) -> bool {
    matches!(def_port, Some(PortType::Simple(Type::String)))
}

impl<'n, 'l> Expander<'n, 'l> {
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
                        ty => {
                            self.classify(json, port_is_string(Some(ty)), prefix, args, &full, port)
                        }
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

fn bad_name(name: &str) -> Option<String> {
    if name.is_empty() {
        Some("it is empty".into())
    } else if name.contains(['.', '/']) || name.starts_with('$') {
        Some("it must not contain `.` or `/` or start with `$`".into())
    } else {
        None
    }
}

/// A library node type whose name is close to `ty` (case-insensitive match or edit
/// distance ≤ 2).
fn suggest<'a>(ty: &str, lib: &'a NodeLibrary) -> Option<&'a str> {
    let lower = ty.to_lowercase();
    lib.defs()
        .iter()
        .map(|d| d.name)
        .map(|n| (edit_distance(&lower, &n.to_lowercase()), n))
        .filter(|(d, _)| *d <= 2)
        .min()
        .map(|(_, n)| n)
}

/// Levenshtein distance between two names (for "did you mean" suggestions).
pub(crate) fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur.push(sub.min(prev[j + 1] + 1).min(cur[j] + 1));
        }
        prev = cur;
    }
    prev[b.len()]
}

/// Whether a connection delivering `from` may feed a port of type `to`.
pub fn coercible(from: Type, to: Type) -> bool {
    from == to
        || (from == Type::Float && to.is_vector())
        || from.is_renaming_of(to)
        || (from == Type::Int && to == Type::Float)
        || (from == Type::Bool && matches!(to, Type::Int | Type::Float))
}

/// Converts a JSON literal to a constant of type `ty`: numbers for float/int (integral,
/// within i32), bools, arrays of 2/3/16 numbers (or 4 rows of 4) for vectors, colors and
/// matrices, a single number broadcast to a vector or color. Floats must be finite and fit
/// an f32.
pub fn literal(json: &Json, ty: Type) -> Result<ConstValue, String> {
    let num = |j: &Json| -> Result<f64, String> {
        let x = j
            .as_f64()
            .ok_or_else(|| format!("expects a number, not {j}"))?;
        if !x.is_finite() || x.abs() > f32::MAX as f64 {
            return Err(format!("{x} is out of range for a 32-bit float"));
        }
        Ok(x)
    };
    match ty {
        Type::Bool => json
            .as_bool()
            .map(ConstValue::Bool)
            .ok_or_else(|| format!("expects true or false, not {json}")),
        Type::Int => {
            let x = num(json).map_err(|_| format!("expects an integer, not {json}"))?;
            if x.fract() != 0.0 || x < i32::MIN as f64 || x > i32::MAX as f64 {
                return Err(format!("expects a 32-bit integer, not {json}"));
            }
            Ok(ConstValue::Int(x as i32))
        }
        Type::Float => num(json).map(ConstValue::Float),
        Type::Closure(k) => Err(format!(
            "is a {} (a closure): connect a closure node; closures have no literal values",
            k.name()
        )),
        Type::String => json
            .as_str()
            .map(|s| ConstValue::String(s.to_string()))
            .ok_or_else(|| format!("expects a string, not {json}")),
        Type::Vec2
        | Type::Vec3
        | Type::Color
        | Type::Vec4
        | Type::Color4
        | Type::Matrix33
        | Type::Matrix44 => {
            let n = ty.width();
            let k = ty.matrix_size();
            let flat: Vec<&Json> = match json {
                Json::Number(_) if !ty.is_matrix() => vec![json; n],
                Json::Array(rows) if ty.is_matrix() && rows.len() == k => {
                    let mut v = Vec::new();
                    for r in rows {
                        match r {
                            Json::Array(r) if r.len() == k => v.extend(r.iter()),
                            _ => {
                                return Err(format!("expects {k} rows of {k} numbers, not {json}"));
                            }
                        }
                    }
                    v
                }
                Json::Array(v) => v.iter().collect(),
                _ => return Err(format!("expects a {ty} ({n} numbers), not {json}")),
            };
            if flat.len() != n {
                return Err(format!(
                    "expects a {ty} of {n} numbers, not {} ({json})",
                    flat.len()
                ));
            }
            let v = flat.into_iter().map(num).collect::<Result<Vec<_>, _>>()?;
            Ok(ConstValue::from_floats(ty, &v).expect("width checked"))
        }
    }
}

/// A parsed connection: node, output, optional component name.
fn split_ref(s: &str) -> Option<(&str, &str, Option<&str>)> {
    let mut it = s.split('.');
    let node = it.next()?;
    let out = it.next()?;
    let comp = it.next();
    if it.next().is_some() || node.is_empty() || out.is_empty() {
        return None;
    }
    Some((node, out, comp))
}

/// Links a network against a node library.
pub fn link(net: &Network, lib: &NodeLibrary) -> Result<Linked, LinkErrors> {
    let mut ex = Expander {
        lib,
        compounds: HashMap::new(),
        flat: Vec::new(),
        aliases: HashMap::new(),
        errors: Vec::new(),
        stack: Vec::new(),
        broken: Default::default(),
    };
    if net.version != 1 {
        ex.errors.push(LinkError::BadOutput {
            output: "version".into(),
            msg: format!("format version {} is not supported (only 1)", net.version),
        });
    }
    for c in &net.compounds {
        if lib.get(&c.name).is_some() {
            ex.errors.push(LinkError::Compound {
                compound: c.name.clone(),
                msg: "has the name of a library node type".into(),
            });
        } else if ex.compounds.insert(&c.name, c).is_some() {
            ex.errors.push(LinkError::Compound {
                compound: c.name.clone(),
                msg: "is defined twice".into(),
            });
        }
    }
    ex.expand(&net.nodes, "", None);
    let Expander {
        flat,
        aliases,
        mut errors,
        broken,
        ..
    } = ex;

    // Names → indices.
    let mut index: HashMap<&str, usize> = HashMap::new();
    for (i, n) in flat.iter().enumerate() {
        if index.insert(&n.name, i).is_some() {
            errors.push(LinkError::DuplicateName {
                node: n.name.clone(),
            });
        }
    }

    // Resolve every connection string to (node, output, component).
    struct Conn {
        node: usize,
        output: usize,
        component: Option<u8>,
        text: String,
    }
    let resolve = |conn: &str,
                   node: &str,
                   port: &str,
                   errors: &mut Vec<LinkError>|
     -> Option<Conn> {
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
            if let Some(target) = aliases.get(&(n.to_string(), o.to_string())) {
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
                continue;
            }
            let Some(&i) = index.get(n) else {
                if broken.contains(n) {
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
            let def = flat[i].def;
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
                Some(c) => match ["x", "y", "z"]
                    .iter()
                    .position(|x| *x == c)
                    .or_else(|| ["r", "g", "b"].iter().position(|x| *x == c))
                    .or_else(|| ["u", "v"].iter().position(|x| *x == c))
                {
                    Some(k) => Some(k as u8),
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
            return Some(Conn {
                node: i,
                output: out,
                component,
                text: conn.to_string(),
            });
        }
    };

    // Per flat node: per def port, the raw input with resolved connections.
    enum In {
        Default,
        Lit(Json),
        Conn(Conn),
        Array(Vec<Vec<(usize, In)>>),
    }
    let mut ins: Vec<Vec<In>> = Vec::new();
    for n in &flat {
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
                Raw::Conn(c) => match resolve(c, &n.name, port, &mut errors) {
                    Some(c) => In::Conn(c),
                    None => In::Default,
                },
                Raw::Array(elems) => {
                    let PortType::Array(fields) = &n.def.inputs[pi].ty else {
                        continue;
                    };
                    let mut arr = Vec::new();
                    for (ei, rec) in elems.iter().enumerate() {
                        let mut r = Vec::new();
                        for (field, raw) in rec {
                            let fi = fields.iter().position(|f| f.0 == field).expect("checked");
                            let where_ = format!("{port}[{ei}].{field}");
                            let v = match raw {
                                Raw::Lit(j) => In::Lit(j.clone()),
                                Raw::Conn(c) => match resolve(c, &n.name, &where_, &mut errors) {
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
            };
        }
        ins.push(ports);
    }

    // Dependency order (iterative DFS), reporting cycles.
    let deps = |i: usize| -> Vec<usize> {
        let mut d = Vec::new();
        for p in &ins[i] {
            match p {
                In::Conn(c) => d.push(c.node),
                In::Array(a) => {
                    for rec in a {
                        for (_, v) in rec {
                            if let In::Conn(c) = v {
                                d.push(c.node);
                            }
                        }
                    }
                }
                _ => {}
            }
        }
        d
    };
    let mut state = vec![0u8; flat.len()]; // 0 new, 1 on stack, 2 done
    let mut order: Vec<usize> = Vec::new();
    let mut cyclic = false;
    // Roots are visited last node first: a network usually lists its outputs' nodes last,
    // so the post-order is depth-first from the outputs, which keeps few values live at
    // once (a breadth-first order of a big tree spills registers in compiled code).
    for root in (0..flat.len()).rev() {
        if state[root] != 0 {
            continue;
        }
        let mut stack: Vec<(usize, Vec<usize>)> = vec![(root, deps(root))];
        state[root] = 1;
        while let Some((node, pending)) = stack.last_mut() {
            let node = *node;
            if let Some(d) = pending.pop() {
                match state[d] {
                    0 => {
                        state[d] = 1;
                        stack.push((d, deps(d)));
                    }
                    1 => {
                        if !cyclic {
                            let start = stack.iter().position(|(n, _)| *n == d).unwrap_or(0);
                            let mut path: Vec<&str> = stack[start..]
                                .iter()
                                .map(|(n, _)| flat[*n].name.as_str())
                                .collect();
                            path.push(&flat[d].name);
                            errors.push(LinkError::Cycle {
                                path: path.join(" → "),
                            });
                        }
                        cyclic = true;
                    }
                    _ => {}
                }
            } else {
                state[node] = 2;
                order.push(node);
                stack.pop();
            }
        }
    }
    if cyclic {
        return Err(LinkErrors(errors));
    }

    // Generic types, in dependency order; output types per node.
    let mut generic = vec![Type::Float; flat.len()];
    let out_ty = |i: usize, o: usize, generic: &[Type]| -> Type {
        flat[i].def.outputs[o].ty.unwrap_or(generic[i])
    };
    let conn_ty = |c: &Conn, generic: &[Type]| -> Type {
        let t = out_ty(c.node, c.output, generic);
        if c.component.is_some() {
            Type::Float
        } else {
            t
        }
    };
    for &i in &order {
        let def = flat[i].def;
        if def.generic.is_empty() {
            continue;
        }
        let mut width = 1;
        let mut seen: Vec<Type> = Vec::new();
        for (pi, p) in def.inputs.iter().enumerate() {
            let generic_field = |f: usize| match &p.ty {
                PortType::Array(fields) => fields[f].1.is_none(),
                _ => false,
            };
            match (&p.ty, &ins[i][pi]) {
                (PortType::Generic, In::Lit(Json::Array(a))) => width = width.max(a.len()),
                (PortType::Generic, In::Conn(c)) => seen.push(conn_ty(c, &generic)),
                (PortType::Array(_), In::Array(a)) => {
                    for rec in a {
                        for (fi, v) in rec {
                            if !generic_field(*fi) {
                                continue;
                            }
                            match v {
                                In::Lit(Json::Array(a)) => width = width.max(a.len()),
                                In::Conn(c) => seen.push(conn_ty(c, &generic)),
                                _ => {}
                            }
                        }
                    }
                }
                _ => {}
            }
        }
        for t in &seen {
            width = width.max(t.width());
        }
        let any_color = seen.contains(&Type::Color);
        let any_vec3 = seen.contains(&Type::Vec3);
        let t = match width {
            1 => Type::Float,
            2 => Type::Vec2,
            3 if any_color || (!any_vec3 && def.generic.contains(&Type::Color)) => Type::Color,
            3 => Type::Vec3,
            w => {
                errors.push(LinkError::BadInput {
                    node: flat[i].name.clone(),
                    port: "(generic)".into(),
                    msg: format!("no {}-component type exists for this node", w),
                });
                Type::Float
            }
        };
        let t = if def.generic.contains(&t) {
            t
        } else if t == Type::Color && def.generic.contains(&Type::Vec3) {
            Type::Vec3
        } else if t == Type::Vec3 && def.generic.contains(&Type::Color) {
            Type::Color
        } else if t == Type::Float && !def.generic.contains(&Type::Float) {
            def.generic[0]
        } else {
            errors.push(LinkError::BadInput {
                node: flat[i].name.clone(),
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
        };
        generic[i] = t;
    }

    // Literals, connection types, lights.
    let mut pos = vec![usize::MAX; flat.len()];
    let shading: Vec<usize> = order
        .iter()
        .copied()
        .filter(|&i| matches!(flat[i].def.kind, NodeKind::Shading))
        .collect();
    for (k, &i) in shading.iter().enumerate() {
        pos[i] = k;
    }
    let check =
        |i: usize, port: &str, ty: Type, v: &In, errors: &mut Vec<LinkError>| -> LinkedInput {
            let n = &flat[i];
            match v {
                In::Default => LinkedInput::Default,
                In::Lit(j) => match literal(j, ty) {
                    Ok(ConstValue::String(s)) => LinkedInput::Str(s),
                    Ok(c) => LinkedInput::Const(c),
                    Err(msg) => {
                        errors.push(LinkError::BadInput {
                            node: n.name.clone(),
                            port: port.into(),
                            msg,
                        });
                        LinkedInput::Default
                    }
                },
                In::Conn(c) => {
                    let src = &flat[c.node];
                    let full = out_ty(c.node, c.output, &generic);
                    if let Some(k) = c.component
                        && (!full.is_vector() || k as usize >= full.width())
                    {
                        {
                            errors.push(LinkError::BadInput {
                                node: n.name.clone(),
                                port: port.into(),
                                msg: format!("`{}`: a {full} has no such component", c.text),
                            });
                            return LinkedInput::Default;
                        }
                    }
                    if !matches!(src.def.kind, NodeKind::Shading) {
                        errors.push(LinkError::BadInput {
                            node: n.name.clone(),
                            port: port.into(),
                            msg: format!("`{}` is a light; lights have no outputs", c.text),
                        });
                        return LinkedInput::Default;
                    }
                    let from = conn_ty(c, &generic);
                    if ty == Type::String || !coercible(from, ty) {
                        errors.push(LinkError::TypeMismatch {
                            node: n.name.clone(),
                            port: port.into(),
                            expected: ty,
                            conn: c.text.clone(),
                            found: from,
                        });
                        return LinkedInput::Default;
                    }
                    LinkedInput::Conn(Source {
                        node: pos[c.node],
                        output: c.output,
                        component: c.component,
                        from,
                        to: ty,
                    })
                }
                In::Array(_) => LinkedInput::Default,
            }
        };

    let mut nodes = Vec::new();
    let mut lights = Vec::new();
    for &i in &order {
        let n = &flat[i];
        let def = n.def;
        let mut inputs = Vec::new();
        for (pi, p) in def.inputs.iter().enumerate() {
            let v = &ins[i][pi];
            let li = match (&p.ty, v) {
                (PortType::Simple(t), v) => check(i, p.name, *t, v, &mut errors),
                (PortType::Generic, v) => check(i, p.name, generic[i], v, &mut errors),
                (PortType::Array(fields), In::Array(a)) => {
                    let mut arr = Vec::new();
                    for (ei, rec) in a.iter().enumerate() {
                        let mut out = vec![LinkedInput::Default; fields.len()];
                        for (fi, v) in rec {
                            let (fname, fty) = fields[*fi];
                            let where_ = format!("{}[{ei}].{fname}", p.name);
                            out[*fi] = check(i, &where_, fty.unwrap_or(generic[i]), v, &mut errors);
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
                {
                    errors.push(LinkError::BadInput {
                        node: n.name.clone(),
                        port: p.name.into(),
                        msg: format!("`{s}` is not one of: {}", p.options.join(", ")),
                    });
                }
            }
            inputs.push(li);
        }
        match def.kind {
            NodeKind::Shading => nodes.push(LinkedNode {
                name: n.name.clone(),
                ty: def.name.to_string(),
                generic: generic[i],
                inputs,
            }),
            NodeKind::Light(make) => {
                let mut vals = Vec::new();
                let mut ok = true;
                for (p, li) in def.inputs.iter().zip(&inputs) {
                    vals.push(match (li, &p.default) {
                        (LinkedInput::Const(c), _) => c.clone(),
                        (LinkedInput::Str(s), _) => ConstValue::String(s.clone()),
                        (LinkedInput::Default, PortDefault::Value(c)) => c.clone(),
                        _ => {
                            errors.push(LinkError::BadInput {
                                node: n.name.clone(),
                                port: p.name.into(),
                                msg: "light parameters must be literals (connections to lights are not supported)".into(),
                            });
                            ok = false;
                            ConstValue::Float(0.0)
                        }
                    });
                }
                if ok {
                    match make(&n.name, &vals) {
                        Ok(l) => lights.push(l),
                        Err(msg) => errors.push(LinkError::Lowering {
                            node: n.name.clone(),
                            ty: def.name.into(),
                            msg,
                        }),
                    }
                }
            }
        }
    }

    // Material outputs.
    let mut outputs = Vec::new();
    if net.outputs.is_empty() {
        errors.push(LinkError::NoOutputs);
    }
    for (name, target) in &net.outputs {
        let Some(t) = target.as_str() else {
            errors.push(LinkError::BadOutput {
                output: name.clone(),
                msg: format!("expects \"node.output\", not {target}"),
            });
            continue;
        };
        let mut errs = Vec::new();
        let Some(c) = resolve(t, "(outputs)", name, &mut errs) else {
            errors.extend(errs.into_iter().map(|e| {
                LinkError::BadOutput {
                    output: name.clone(),
                    msg: e
                        .to_string()
                        .replace(&format!("node `(outputs)` input `{name}`: "), ""),
                }
            }));
            continue;
        };
        if !matches!(flat[c.node].def.kind, NodeKind::Shading) {
            errors.push(LinkError::BadOutput {
                output: name.clone(),
                msg: format!("`{t}` is a light; lights have no outputs"),
            });
            continue;
        }
        let full = out_ty(c.node, c.output, &generic);
        if c.component
            .is_some_and(|k| !full.is_vector() || k as usize >= full.width())
        {
            errors.push(LinkError::BadOutput {
                output: name.clone(),
                msg: format!("`{t}`: a {full} has no such component"),
            });
            continue;
        }
        let ty = conn_ty(&c, &generic);
        outputs.push((
            name.clone(),
            Source {
                node: pos[c.node],
                output: c.output,
                component: c.component,
                from: ty,
                to: ty,
            },
        ));
    }

    if !errors.is_empty() {
        return Err(LinkErrors(errors));
    }
    Ok(Linked {
        name: net.name.clone().unwrap_or_else(|| "material".into()),
        nodes,
        outputs,
        lights,
    })
}
