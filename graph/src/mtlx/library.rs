//! The MaterialX data libraries as an index: nodedefs by name and by node category, the
//! nodegraphs that implement nodedefs, and the atom node library built from the rest.
//!
//! This module owns indexing parsed library documents; it must not read files or look for
//! the libraries on disk (the facade does, through `runtime::input`, and caches the result
//! per process) nor decide how an atom lowers (the [`super::atoms`] table does).

use super::atoms;
use super::document::{Document, Graph, NodeDefElem};
use super::value::{MxType, classify, colorspace_port};
use crate::lower::convert_const;
use crate::nodes::{NodeDef, NodeKind, NodeLibrary, OutDef, PortDef, PortDefault, PortType};
use crate::types::{ConstValue, Type};
use std::collections::HashMap;

/// Parsed, indexed MaterialX libraries.
#[derive(Debug)]
pub struct Library {
    defs: Vec<NodeDefElem>,
    /// The library folder each nodedef came from (`stdlib`, `pbrlib`, …).
    groups: Vec<String>,
    by_name: HashMap<String, usize>,
    by_node: HashMap<String, Vec<usize>>,
    graphs: HashMap<String, Graph>,
    atoms: NodeLibrary,
}

/// A nodedef and how it is implemented.
#[derive(Clone, Copy, Debug)]
pub enum Impl<'a> {
    /// By a nodegraph: a compound.
    Graph(&'a Graph),
    /// By one of our atoms.
    Atom,
    /// Folded when the document compiles: a string node ([`super::strings`]).
    Folded,
    /// Neither: the reason.
    None(&'static str),
}

impl Library {
    /// Indexes library documents, each with the library folder it came from (`stdlib`, …).
    /// Later definitions of a name are ignored (the first wins, as in MaterialX).
    pub fn new(docs: Vec<(String, Document)>) -> Library {
        let mut lib = Library {
            defs: Vec::new(),
            groups: Vec::new(),
            by_name: HashMap::new(),
            by_node: HashMap::new(),
            graphs: HashMap::new(),
            atoms: NodeLibrary::new(),
        };
        let mut by_graph: HashMap<String, Graph> = HashMap::new();
        let mut implementations = Vec::new();
        for (group, doc) in docs {
            for d in doc.nodedefs {
                if lib.by_name.contains_key(&d.name) {
                    continue;
                }
                let i = lib.defs.len();
                lib.by_name.insert(d.name.clone(), i);
                lib.by_node.entry(d.node.clone()).or_default().push(i);
                lib.defs.push(d);
                lib.groups.push(group.clone());
            }
            for g in doc.graphs {
                if let Some(nd) = g.nodedef.clone() {
                    lib.graphs.entry(nd).or_insert_with(|| g.clone());
                }
                by_graph.entry(g.name.clone()).or_insert(g);
            }
            implementations.extend(doc.implementations);
        }
        // `<implementation nodedef=… nodegraph=…>` binds a nodegraph declared by name.
        for (nd, ng) in implementations {
            if let Some(g) = by_graph.get(&ng) {
                lib.graphs.entry(nd).or_insert_with(|| g.clone());
            }
        }
        lib.inherit();
        for i in 0..lib.defs.len() {
            if lib.graphs.contains_key(&lib.defs[i].name) {
                continue;
            }
            if let Some(def) = atom_def(&lib.defs[i]) {
                lib.atoms.add(def);
            }
        }
        lib
    }

    /// Gives each nodedef that `inherit`s the inputs and outputs of its parent chain that it
    /// does not declare itself (its own declarations win; a missing parent or a cycle ends
    /// the chain).
    fn inherit(&mut self) {
        for i in 0..self.defs.len() {
            let mut seen = vec![self.defs[i].name.clone()];
            let mut parent = self.defs[i].inherit.clone();
            while let Some(p) = parent.take() {
                if seen.contains(&p) {
                    break;
                }
                let Some(&j) = self.by_name.get(&p) else {
                    break;
                };
                let (inputs, outputs) = (self.defs[j].inputs.clone(), self.defs[j].outputs.clone());
                let d = &mut self.defs[i];
                for inp in inputs {
                    if !d.inputs.iter().any(|x| x.name == inp.name) {
                        d.inputs.push(inp);
                    }
                }
                if d.outputs.is_empty() {
                    d.outputs = outputs;
                }
                seen.push(p);
                parent = self.defs[j].inherit.clone();
            }
        }
    }

    /// Every nodedef, in library order, with its library folder.
    pub fn defs(&self) -> impl Iterator<Item = (&NodeDefElem, &str)> {
        self.defs.iter().zip(self.groups.iter().map(String::as_str))
    }

    /// The nodedef called `name`.
    pub fn nodedef(&self, name: &str) -> Option<&NodeDefElem> {
        self.by_name.get(name).map(|&i| &self.defs[i])
    }

    /// The nodedefs of a node category, in library order.
    pub fn of_node(&self, node: &str) -> impl Iterator<Item = &NodeDefElem> {
        self.by_node
            .get(node)
            .into_iter()
            .flatten()
            .map(|&i| &self.defs[i])
    }

    /// Every node category.
    pub fn categories(&self) -> impl Iterator<Item = &str> {
        self.by_node.keys().map(String::as_str)
    }

    /// How nodedef `name` is implemented.
    pub fn implementation(&self, nd: &NodeDefElem) -> Impl<'_> {
        if let Some(g) = self.graphs.get(&nd.name) {
            return Impl::Graph(g);
        }
        if self.atoms.get(&nd.name).is_some() {
            return Impl::Atom;
        }
        if atoms::is_folded(nd) {
            return Impl::Folded;
        }
        Impl::None(atoms::missing_reason(nd))
    }

    /// The atoms: one node type per natively lowered nodedef, named by the nodedef.
    pub fn atoms(&self) -> &NodeLibrary {
        &self.atoms
    }
}

/// Strings of a node definition built at run time live as long as the process: the
/// libraries are parsed once per process and cached (see the facade), so this leaks a
/// bounded amount, once.
fn leak(s: &str) -> &'static str {
    Box::leak(s.to_string().into_boxed_str())
}

/// Our node definition for an atom nodedef: its ports typed and defaulted from the nodedef,
/// its lowering from the table. `None` when the table has no lowering or a port's type has
/// no IR type.
fn atom_def(nd: &NodeDefElem) -> Option<NodeDef> {
    let lower = atoms::lowering(nd)?;
    let mut inputs = Vec::new();
    for i in &nd.inputs {
        let ty = match classify(&i.ty) {
            MxType::Value(ty) => ty,
            // A displacement or volume shader input: not built, not a port.
            MxType::Closure => continue,
            MxType::Unsupported => return None,
        };
        let default = match (&i.value, i.defaultgeomprop.as_deref()) {
            _ if ty.is_closure() => PortDefault::EmptyClosure,
            (_, Some(g)) => PortDefault::Stream(atoms::geomprop_stream(g)?),
            (Some(v), None) => {
                let json = super::value::literal(v, ty).ok()?;
                let c = crate::link::literal(&json, ty).ok()?;
                PortDefault::Value(convert_const(&c, ty).unwrap_or(c))
            }
            (None, None) => PortDefault::Value(ConstValue::zero(ty)),
        };
        inputs.push(PortDef {
            name: leak(&i.name),
            ty: PortType::Simple(ty),
            default,
            options: &[],
            doc: "",
        });
        if i.ty == "filename" {
            inputs.push(PortDef {
                name: leak(&colorspace_port(&i.name)),
                ty: PortType::Simple(Type::String),
                default: PortDefault::Value(ConstValue::String(String::new())),
                options: &[],
                doc: "The file's `colorspace` attribute (own or inherited); empty: none.",
            });
        }
    }
    let mut outputs = Vec::new();
    for o in &nd.outputs {
        let MxType::Value(ty) = classify(&o.ty) else {
            return None;
        };
        outputs.push(OutDef {
            name: leak(&o.name),
            ty: Some(ty),
            doc: "",
        });
    }
    if outputs.is_empty() || outputs.iter().any(|o| o.ty == Some(Type::String)) {
        return None;
    }
    Some(NodeDef {
        name: leak(&nd.name),
        category: leak(&nd.node),
        doc: "A MaterialX atom (see the MaterialX specification).",
        generic: &[],
        inputs,
        outputs,
        lower,
        kind: NodeKind::Shading,
    })
}
