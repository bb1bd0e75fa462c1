//! From a MaterialX document to a shadenet [`Network`]: nodes become instances of atom
//! nodedefs (named by the nodedef), nodegraph-implemented nodedefs and the document's
//! nodegraphs become compounds the linker expands, `interfacename` becomes `$name`,
//! `nodename`/`nodegraph` + `output` become connections, and the chosen outputs become the
//! material's outputs.
//!
//! This module owns that translation and the checks that need MaterialX types (exact
//! connection types, interface names, closures, nodegraph cycles); it must not lower nodes
//! (the atoms do) nor link (the linker does).

use super::atoms::geomprop_node;
use super::atoms::is_string;
use super::document::{Document, Graph, Input, NodeDefElem, NodeElem};
use super::error::{MtlxError, Pos, doc_err};
use super::iface::{Iface, interface_value};
use super::library::{Impl, Library};
use super::resolve::Defs;
use super::strings::{Fold, Folded, folded_value};
use super::value::{MxType, classify, literal, unsupported_reason};
use crate::network::{CompoundInput, CompoundSpec, Network, NodeSpec};
use serde_json::{Map, Value as Json};
use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};

/// Which part of a document to shade, and for which geometry.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Selection {
    /// A material by name; only the nodes and nodegraphs it reaches are translated.
    pub material: Option<String>,
    /// An output: a top-level `<output>`, a nodegraph (all its outputs) or `graph/output`.
    pub output: Option<String>,
    /// The uniform string-valued geometric properties of the geometry the material is
    /// bound to (name → value), which `geompropvalueuniform` string and filename nodes read;
    /// a property not given takes the node's `default` (see [`super::strings`]).
    pub geomprops: BTreeMap<String, String>,
}

struct Tr<'a> {
    defs: Defs<'a>,
    compounds: Vec<CompoundSpec>,
    done: HashSet<String>,
    stack: Vec<String>,
    /// The selection's geometric properties.
    geomprops: &'a BTreeMap<String, String>,
    /// The geometric properties the translated nodes read.
    props: BTreeSet<String>,
}

/// What one scope's nodes are: each translated node's nodedef (for output names and types)
/// and each folded string node's value.
struct Scope<'a> {
    types: HashMap<&'a str, &'a NodeDefElem>,
    strings: Folded,
}

/// The compound name of a document nodegraph without a nodedef.
fn graph_compound(name: &str) -> String {
    format!("nodegraph {name}")
}

impl<'a> Tr<'a> {
    /// Resolves a node and checks that its nodedef can be used, translating its nodegraph.
    fn usable(&mut self, node: &NodeElem) -> Result<&'a NodeDefElem, MtlxError> {
        let nd = self.defs.resolve(node)?;
        for p in nd.outputs.iter().chain(&nd.inputs) {
            match classify(&p.ty) {
                MxType::Value(_) => {}
                // An input of a closure kind not built yet (a material's displacement
                // shader) is ignored, never connected (see `scope`).
                MxType::Closure if nd.inputs.iter().any(|i| std::ptr::eq(i, p)) => {}
                MxType::Closure => {
                    return Err(MtlxError::Closure {
                        at: node.pos.clone(),
                        node: node.name.clone(),
                        ty: p.ty.clone(),
                    });
                }
                MxType::Unsupported => {
                    return Err(MtlxError::Unsupported {
                        at: node.pos.clone(),
                        node: node.name.clone(),
                        msg: format!("{} ({}): {}", nd.name, p.name, unsupported_reason(&p.ty)),
                    });
                }
            }
        }
        match self.implementation(nd) {
            Impl::Graph(g) => self.compound(nd, g)?,
            Impl::Atom => {}
            // Folded in `fold_strings` before nodes get here.
            Impl::Folded => {
                return Err(MtlxError::Unsupported {
                    at: node.pos.clone(),
                    node: node.name.clone(),
                    msg: format!("{} is a compile-time string node out of place", nd.name),
                });
            }
            Impl::None(reason) => {
                return Err(MtlxError::Unsupported {
                    at: node.pos.clone(),
                    node: node.name.clone(),
                    msg: format!("{} is not supported: {reason}", nd.name),
                });
            }
        }
        Ok(nd)
    }

    fn implementation(&self, nd: &'a NodeDefElem) -> Impl<'a> {
        if let Some(g) = self
            .defs
            .doc
            .graphs
            .iter()
            .find(|g| g.nodedef.as_deref() == Some(&nd.name))
        {
            return Impl::Graph(g);
        }
        self.defs.lib.implementation(nd)
    }

    /// Makes the nodedefs of helper nodes (swizzle combines, output pass-throughs) usable:
    /// those implemented by nodegraphs become compounds too.
    fn helpers(&mut self, top: &[NodeSpec]) -> Result<(), MtlxError> {
        loop {
            let mut wanted: Vec<String> = top
                .iter()
                .chain(self.compounds.iter().flat_map(|c| c.nodes.iter()))
                .map(|n| n.ty.clone())
                .filter(|t| t.starts_with("ND_") && !self.done.contains(t))
                .collect();
            wanted.sort();
            wanted.dedup();
            let mut added = false;
            for name in wanted {
                let Some(nd) = self.defs.nodedef(&name) else {
                    continue;
                };
                if let Impl::Graph(g) = self.implementation(nd) {
                    self.compound(nd, g)?;
                    added = true;
                }
            }
            if !added {
                return Ok(());
            }
        }
    }

    /// Translates a nodedef's nodegraph into a compound named after the nodedef.
    fn compound(&mut self, nd: &'a NodeDefElem, g: &'a Graph) -> Result<(), MtlxError> {
        if self.done.contains(&nd.name) {
            return Ok(());
        }
        if let Some(start) = self.stack.iter().position(|s| *s == g.name) {
            let mut path = self.stack[start..].to_vec();
            path.push(g.name.clone());
            return Err(MtlxError::Cycle {
                path: path.join(" → "),
            });
        }
        self.stack.push(g.name.clone());
        let iface = Iface {
            graph: &g.name,
            inputs: &nd.inputs,
        };
        let (nodes, sc) = self.scope(&g.nodes, Some(&iface))?;
        let outputs = self.graph_outputs(g, &nd.outputs, &iface, &sc)?;
        let mut spec = CompoundSpec {
            name: nd.name.clone(),
            doc: None,
            inputs: interface(&nd.inputs)?,
            outputs: Map::new(),
            nodes,
        };
        for (name, conn, extra) in outputs {
            spec.outputs.insert(name, Json::String(conn));
            spec.nodes.extend(extra);
        }
        self.stack.pop();
        self.done.insert(nd.name.clone());
        self.compounds.push(spec);
        Ok(())
    }

    /// Resolves and translates the nodes of one scope (string nodes folded); returns them
    /// and what each node is.
    fn scope(
        &mut self,
        all: &'a [NodeElem],
        iface: Option<&Iface>,
    ) -> Result<(Vec<NodeSpec>, Scope<'a>), MtlxError> {
        // Top-level nodes of closure kinds not built yet (volume, displacement and light
        // shaders) are left out: they are reported only when selected.
        let nodes: Vec<&'a NodeElem> = all
            .iter()
            .filter(|n| iface.is_some() || classify(&n.ty) != MxType::Closure)
            .collect();
        let (strings, nodes) = Fold {
            defs: &self.defs,
            geomprops: self.geomprops,
            props: &mut self.props,
            iface,
        }
        .split(nodes)?;
        let mut types = HashMap::new();
        for &n in &nodes {
            types.insert(n.name.as_str(), self.usable(n)?);
        }
        let sc = Scope { types, strings };
        let mut out = Vec::new();
        for &n in &nodes {
            let nd = sc.types[n.name.as_str()];
            let mut spec = NodeSpec {
                name: n.name.clone(),
                ty: nd.name.clone(),
                inputs: Map::new(),
            };
            for i in &n.inputs {
                let Some(di) = nd.inputs.iter().find(|d| d.name == i.name) else {
                    let valid: Vec<&str> = nd.inputs.iter().map(|d| d.name.as_str()).collect();
                    return Err(doc_err(
                        &i.pos,
                        format!(
                            "node `{}` ({}) has no input `{}`; its inputs are: {}",
                            n.name,
                            nd.name,
                            i.name,
                            valid.join(", ")
                        ),
                    ));
                };
                if classify(&di.ty) == MxType::Closure {
                    // A displacement or volume shader input: not built, ignored (DESIGN §12).
                    continue;
                }
                let v = self.input_value(&n.name, i, &di.ty, iface, &sc, &mut out)?;
                if let Some(v) = v {
                    spec.inputs.insert(i.name.clone(), v);
                }
                // A file's color space travels to the atom's lowering as a string port of
                // its own (`file_colorspace`, added by the library for filename inputs).
                if di.ty == "filename"
                    && i.nodename.is_none()
                    && i.interfacename.is_none()
                    && !matches!(self.implementation(nd), Impl::Graph(_))
                    && let Some(cs) = &i.colorspace
                {
                    let key = super::value::colorspace_port(&i.name);
                    spec.inputs.insert(key, Json::String(cs.clone()));
                }
            }
            if matches!(self.implementation(nd), Impl::Graph(_)) {
                geomprops(&mut spec, nd, &mut out);
            }
            out.push(spec);
        }
        Ok((out, sc))
    }

    /// The network value of one input: a literal, a connection, `$interface`, or `None`
    /// (unset). Swizzles add a combine node to `extra`.
    fn input_value(
        &self,
        node: &str,
        i: &Input,
        ty: &str,
        iface: Option<&Iface>,
        sc: &Scope,
        extra: &mut Vec<NodeSpec>,
    ) -> Result<Option<Json>, MtlxError> {
        let MxType::Value(t) = classify(ty) else {
            return Err(doc_err(&i.pos, unsupported_reason(ty)));
        };
        if let Some(name) = &i.interfacename {
            return interface_value(node, i, name, iface).map(Some);
        }
        if let Some(v) = folded_value(&sc.strings, node, i, ty) {
            return v.map(Some);
        }
        let (src, src_ty) = if let Some(n) = &i.nodename {
            let Some(sd) = sc.types.get(n.as_str()) else {
                return Err(doc_err(
                    &i.pos,
                    format!(
                        "node `{node}` input `{}`: nodename `{n}` names no node here",
                        i.name
                    ),
                ));
            };
            let out = match &i.output {
                Some(o) => sd.outputs.iter().find(|x| &x.name == o),
                None => sd.outputs.first(),
            };
            let Some(out) = out else {
                return Err(doc_err(
                    &i.pos,
                    format!(
                        "node `{node}` input `{}`: node `{n}` has no output `{}`",
                        i.name,
                        i.output.as_deref().unwrap_or("")
                    ),
                ));
            };
            (format!("{n}.{}", out.name), out.ty.clone())
        } else if let Some(g) = &i.nodegraph {
            let (conn, t) = self.graph_output(g, i.output.as_deref(), &i.pos)?;
            (conn, t)
        } else if let Some(v) = &i.value {
            if v.is_empty() && t != crate::types::Type::String {
                return Ok(None);
            }
            return literal(v, t)
                .map(Some)
                .map_err(|m| doc_err(&i.pos, format!("node `{node}` input `{}`: {m}", i.name)));
        } else {
            return Ok(None);
        };
        if let Some(ch) = &i.channels {
            return super::channels::swizzle(node, i, ch, &src, &src_ty, t, extra).map(Some);
        }
        if src_ty != ty {
            return Err(MtlxError::TypeMismatch {
                at: i.pos.clone(),
                node: node.to_string(),
                input: i.name.clone(),
                expected: ty.to_string(),
                source_name: src,
                found: src_ty,
            });
        }
        Ok(Some(Json::String(src)))
    }

    /// A document nodegraph's output as a connection and its type.
    fn graph_output(
        &self,
        graph: &str,
        output: Option<&str>,
        at: &Pos,
    ) -> Result<(String, String), MtlxError> {
        let g = self
            .defs
            .doc
            .graphs
            .iter()
            .find(|g| g.name == graph && g.nodedef.is_none())
            .ok_or_else(|| doc_err(at, format!("nodegraph `{graph}` does not exist")))?;
        let o = match output {
            Some(o) => g.outputs.iter().find(|x| x.name == o),
            None => g.outputs.first(),
        }
        .ok_or_else(|| {
            doc_err(
                at,
                format!(
                    "nodegraph `{graph}` has no output `{}`",
                    output.unwrap_or("")
                ),
            )
        })?;
        Ok((format!("{graph}.{}", o.name), o.ty.clone()))
    }

    /// Each declared output of a graph → (name, inner connection, helper nodes).
    fn graph_outputs(
        &self,
        g: &Graph,
        decls: &[Input],
        iface: &Iface,
        sc: &Scope,
    ) -> Result<Vec<(String, String, Vec<NodeSpec>)>, MtlxError> {
        let mut res = Vec::new();
        for d in decls {
            if is_string(&d.ty) {
                return Err(string_output(&g.pos, &format!("{}.{}", g.name, d.name)));
            }
            let Some(o) = g.outputs.iter().find(|o| o.name == d.name) else {
                return Err(doc_err(
                    &g.pos,
                    format!("nodegraph `{}` has no output `{}`", g.name, d.name),
                ));
            };
            let mut extra = Vec::new();
            let holder = format!("{}_output", o.name);
            let v = self.input_value(&holder, o, &d.ty, Some(iface), sc, &mut extra)?;
            let conn = match v {
                Some(Json::String(c)) if !c.starts_with('$') => c,
                v => {
                    // A value or an interface input: pass it through a `dot` node.
                    let mut inputs = Map::new();
                    if let Some(v) = v {
                        inputs.insert("in".into(), v);
                    }
                    extra.push(NodeSpec {
                        name: holder.clone(),
                        ty: format!("ND_dot_{}", d.ty),
                        inputs,
                    });
                    format!("{holder}.out")
                }
            };
            res.push((d.name.clone(), conn, extra));
        }
        Ok(res)
    }
}

/// A string-typed output asked for: strings are compile-time values, never shaded.
fn string_output(at: &Pos, name: &str) -> MtlxError {
    doc_err(
        at,
        format!(
            "output `{name}` is a string: strings are compile-time values (file names, \
             property names), folded into the inputs that read them, and cannot be shaded \
             or leave a nodegraph"
        ),
    )
}

/// Compound inputs from interface declarations (defaults from their values).
fn interface(inputs: &[Input]) -> Result<Vec<CompoundInput>, MtlxError> {
    let mut res = Vec::new();
    for i in inputs {
        let MxType::Value(t) = classify(&i.ty) else {
            return Err(doc_err(&i.pos, unsupported_reason(&i.ty)));
        };
        let default = match &i.value {
            Some(v) if !v.is_empty() || t == crate::types::Type::String => {
                Some(literal(v, t).map_err(|m| doc_err(&i.pos, m))?)
            }
            _ if i.defaultgeomprop.is_some() => None,
            _ => Some(zero_json(t)),
        };
        res.push(CompoundInput {
            name: i.name.clone(),
            ty: t.name().to_string(),
            default,
        });
    }
    Ok(res)
}

fn zero_json(t: crate::types::Type) -> Json {
    use crate::types::Type;
    match t {
        Type::Bool => Json::Bool(false),
        Type::String => Json::String(String::new()),
        // Scalars are plain numbers (gltf_pbr's `attenuation_distance` has no value).
        Type::Float => serde_json::json!(0.0),
        Type::Int => serde_json::json!(0),
        Type::Matrix33 => serde_json::json!([[1, 0, 0], [0, 1, 0], [0, 0, 1]]),
        Type::Matrix44 => {
            serde_json::json!([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
        }
        _ => serde_json::json!(vec![0.0; t.width()]),
    }
}

/// Unset inputs of a nodegraph instance that default to a geometric property get a node
/// reading that stream.
fn geomprops(spec: &mut NodeSpec, nd: &NodeDefElem, out: &mut Vec<NodeSpec>) {
    for di in &nd.inputs {
        let Some(g) = &di.defaultgeomprop else {
            continue;
        };
        if spec.inputs.contains_key(&di.name) {
            continue;
        }
        let Some((ty, space)) = geomprop_node(g) else {
            continue;
        };
        let name = format!("{}_{}_{}", spec.name, di.name, g);
        let mut inputs = Map::new();
        if let Some(s) = space {
            inputs.insert("space".into(), Json::String(s.into()));
        }
        out.push(NodeSpec {
            name: name.clone(),
            ty: ty.into(),
            inputs,
        });
        spec.inputs
            .insert(di.name.clone(), Json::String(format!("{name}.out")));
    }
}

/// The output that shades material `name`: the material node's `out`, named after it; an
/// error listing the document's materials when there is none of that name.
fn material_output(doc: &Document, name: &str) -> Result<Map<String, Json>, MtlxError> {
    let Some(m) = doc.materials().find(|m| m.name == name) else {
        let names: Vec<&str> = doc.materials().map(|m| m.name.as_str()).collect();
        return Err(MtlxError::Select {
            file: doc.file.clone(),
            msg: format!(
                "no material `{name}` (materials: {})",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            ),
        });
    };
    if classify(&m.ty) == MxType::Closure {
        return Err(MtlxError::Closure {
            at: m.pos.clone(),
            node: m.name.clone(),
            ty: m.ty.clone(),
        });
    }
    let mut out = Map::new();
    out.insert(m.name.clone(), Json::String(format!("{}.out", m.name)));
    Ok(out)
}

/// Translates a document into a network for the selection; the compounds it needs are
/// included, the atoms are [`Library::atoms`].
pub fn to_network(doc: &Document, lib: &Library, sel: &Selection) -> Result<Network, MtlxError> {
    translate(doc, lib, sel).map(|(net, _)| net)
}

/// [`to_network`], and the names of the uniform geometric properties that the selection's
/// string-valued `geompropvalueuniform` nodes read: a renderer compiles the material once
/// per distinct set of their values among the objects it is bound to.
pub fn translate(
    doc: &Document,
    lib: &Library,
    sel: &Selection,
) -> Result<(Network, BTreeSet<String>), MtlxError> {
    // With a material chosen, only what it reaches is translated: another material's
    // unsupported node must not fail this one.
    let keep = chosen_material(doc, sel).map(|m| reachable(doc, m));
    let top: Cow<[NodeElem]> = match &keep {
        Some((names, _)) => doc
            .nodes
            .iter()
            .filter(|n| names.contains(n.name.as_str()))
            .cloned()
            .collect(),
        None => Cow::Borrowed(&doc.nodes),
    };
    let wanted = |g: &&Graph| {
        g.nodedef.is_none()
            && keep
                .as_ref()
                .is_none_or(|(_, graphs)| graphs.contains(g.name.as_str()))
    };
    let mut tr = Tr {
        defs: Defs { lib, doc },
        compounds: Vec::new(),
        done: HashSet::new(),
        stack: Vec::new(),
        geomprops: &sel.geomprops,
        props: BTreeSet::new(),
    };
    let mut nodes = Vec::new();
    for g in doc.graphs.iter().filter(wanted) {
        let iface = Iface {
            graph: &g.name,
            inputs: &g.inputs,
        };
        let (inner, sc) = tr.scope(&g.nodes, Some(&iface))?;
        let outputs = tr.graph_outputs(g, &g.outputs, &iface, &sc)?;
        let mut spec = CompoundSpec {
            name: graph_compound(&g.name),
            doc: None,
            inputs: interface(&g.inputs)?,
            outputs: Map::new(),
            nodes: inner,
        };
        for (name, conn, extra) in outputs {
            spec.outputs.insert(name, Json::String(conn));
            spec.nodes.extend(extra);
        }
        tr.compounds.push(spec);
        nodes.push(NodeSpec {
            name: g.name.clone(),
            ty: graph_compound(&g.name),
            inputs: Map::new(),
        });
    }
    let (top_nodes, sc) = tr.scope(&top, None)?;
    let outputs = match &sel.material {
        Some(m) => material_output(doc, m)?,
        None => select_outputs(&tr, doc, sel, &sc, &mut nodes)?,
    };
    nodes.extend(top_nodes);
    tr.helpers(&nodes)?;
    let net = Network {
        name: None,
        version: 1,
        nodes,
        outputs,
        compounds: tr.compounds,
    };
    Ok((net, tr.props))
}

/// The material a selection names, if the document has it (a missing one is reported by
/// [`material_output`]).
fn chosen_material<'d>(doc: &'d Document, sel: &Selection) -> Option<&'d NodeElem> {
    let name = sel.material.as_ref()?;
    doc.materials().find(|m| &m.name == name)
}

/// The names of the top-level nodes and of the nodegraphs (without nodedef) that `root`
/// reaches through `nodename` and `nodegraph` connections (a nodegraph's interface inputs
/// included), `root` itself among the nodes.
fn reachable<'d>(doc: &'d Document, root: &'d NodeElem) -> (HashSet<&'d str>, HashSet<&'d str>) {
    let mut nodes: HashSet<&str> = HashSet::from([root.name.as_str()]);
    let mut graphs: HashSet<&str> = HashSet::new();
    let mut todo: Vec<&[Input]> = vec![&root.inputs];
    while let Some(inputs) = todo.pop() {
        for i in inputs {
            if let Some(n) = &i.nodename
                && let Some(node) = doc.nodes.iter().find(|x| &x.name == n)
                && nodes.insert(node.name.as_str())
            {
                todo.push(&node.inputs);
            }
            if let Some(g) = &i.nodegraph
                && let Some(graph) = doc.graphs.iter().find(|x| &x.name == g)
                && graphs.insert(graph.name.as_str())
            {
                todo.push(&graph.inputs);
            }
        }
    }
    (nodes, graphs)
}

/// The material outputs the selection asks for: by default every top-level `<output>` and
/// every output of the document's nodegraphs.
fn select_outputs(
    tr: &Tr,
    doc: &Document,
    sel: &Selection,
    sc: &Scope,
    extra: &mut Vec<NodeSpec>,
) -> Result<Map<String, Json>, MtlxError> {
    let mut all: Vec<(String, String, &Input)> = Vec::new();
    for o in &doc.outputs {
        all.push((o.name.clone(), String::new(), o));
    }
    for g in doc.graphs.iter().filter(|g| g.nodedef.is_none()) {
        for o in &g.outputs {
            all.push((o.name.clone(), g.name.clone(), o));
        }
    }
    let chosen: Vec<&(String, String, &Input)> = match &sel.output {
        None => all.iter().collect(),
        Some(want) => all
            .iter()
            .filter(|(n, g, _)| {
                (g.is_empty() && n == want)
                    || g == want
                    || format!("{g}/{n}") == *want
                    || format!("{g}.{n}") == *want
            })
            .collect(),
    };
    if chosen.is_empty() {
        let names: Vec<String> = all
            .iter()
            .map(|(n, g, _)| {
                if g.is_empty() {
                    n.clone()
                } else {
                    format!("{g}/{n}")
                }
            })
            .collect();
        let what = match &sel.output {
            Some(w) => format!("no output `{w}`"),
            None if doc.materials().next().is_some() => {
                let m = doc
                    .materials()
                    .next()
                    .map(|m| m.name.clone())
                    .unwrap_or_default();
                return material_output(doc, &m);
            }
            None => "nothing to shade: the document has no <output> and no nodegraph output".into(),
        };
        return Err(MtlxError::Select {
            file: doc.file.clone(),
            msg: format!(
                "{what} (outputs: {})",
                if names.is_empty() {
                    "none".into()
                } else {
                    names.join(", ")
                }
            ),
        });
    }
    let unique = chosen.iter().map(|c| &c.0).collect::<HashSet<_>>().len() == chosen.len();
    let mut outputs = Map::new();
    for (name, graph, o) in chosen {
        if classify(&o.ty) == MxType::Closure {
            return Err(MtlxError::Closure {
                at: o.pos.clone(),
                node: o.nodename.clone().unwrap_or_else(|| o.name.clone()),
                ty: o.ty.clone(),
            });
        }
        if is_string(&o.ty) {
            return Err(string_output(&o.pos, name));
        }
        let conn = if graph.is_empty() {
            match tr.input_value(name, o, &o.ty, None, sc, extra)? {
                Some(Json::String(c)) => c,
                _ => {
                    return Err(doc_err(
                        &o.pos,
                        format!("output `{name}` connects to no node (nodename or nodegraph)"),
                    ));
                }
            }
        } else {
            format!("{graph}.{name}")
        };
        let key = if unique || graph.is_empty() {
            name.clone()
        } else {
            format!("{graph}_{name}")
        };
        outputs.insert(key, Json::String(conn));
    }
    Ok(outputs)
}
