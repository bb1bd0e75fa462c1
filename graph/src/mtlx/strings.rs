//! Compile-time strings. Nodes whose one output is a `string` or `filename` and whose value
//! is known when the document compiles — `constant`, `dot` and `geompropvalueuniform` (a
//! uniform geometric property of the geometry the material is bound to, given by
//! [`Selection::geomprops`](super::Selection::geomprops)) — are folded into the inputs that
//! read them: strings never reach the IR, they are uniform inputs of the atoms (file names,
//! address modes, attribute names).
//!
//! This module owns which nodes fold and what they fold to, and records which geometric
//! properties a document reads. It must not translate other nodes (`translate` does), nor
//! decide which geometry a material is bound to: the renderer compiles a material once per
//! distinct set of the properties it reads ([`super::uniform_geomprops`]).

use super::atoms::is_folded;
use super::document::{Input, NodeDefElem, NodeElem};
use super::error::MtlxError;
use super::error::doc_err;
use super::iface::{Iface, interface_value};
use super::resolve::Defs;
use serde_json::Value as Json;
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};

/// Folded nodes of one scope: node name → (its value, its MaterialX type). A value is a
/// literal string or `$name`, an interface input of the enclosing nodegraph.
pub(super) type Folded = HashMap<String, (Json, String)>;

/// The folded nodes of a scope, by name, before their values are known.
type Pending<'a> = HashMap<&'a str, (&'a NodeElem, &'a NodeDefElem)>;

/// What folding one scope needs: the nodedefs, the selection's geometric properties, the
/// set of properties read (added to), and the scope's interface.
pub(super) struct Fold<'a, 'b> {
    pub(super) defs: &'b Defs<'a>,
    pub(super) geomprops: &'b BTreeMap<String, String>,
    pub(super) props: &'b mut BTreeSet<String>,
    pub(super) iface: Option<&'b Iface<'b>>,
}

impl<'a> Fold<'a, '_> {
    /// Splits a scope's nodes into the folded string nodes (their values) and the others
    /// (returned, to be translated). A node whose nodedef does not resolve stays with the
    /// others, for `usable` to report.
    pub(super) fn split(
        mut self,
        nodes: Vec<&'a NodeElem>,
    ) -> Result<(Folded, Vec<&'a NodeElem>), MtlxError> {
        let mut pending = Pending::new();
        let mut rest = Vec::new();
        let mut names = HashSet::new();
        for n in nodes {
            if !names.insert(n.name.as_str()) {
                return Err(doc_err(
                    &n.pos,
                    format!("node name `{}` is used twice", n.name),
                ));
            }
            match self.defs.resolve(n) {
                Ok(nd) if is_folded(nd) => {
                    pending.insert(n.name.as_str(), (n, nd));
                }
                _ => rest.push(n),
            }
        }
        let mut order: Vec<&str> = pending.keys().copied().collect();
        order.sort_unstable();
        let mut folded = Folded::new();
        for name in order {
            self.fold(name, &pending, &mut folded, &mut Vec::new())?;
        }
        Ok((folded, rest))
    }

    /// Folds node `name` (and the folded nodes it reads) into `folded`.
    fn fold(
        &mut self,
        name: &'a str,
        pending: &Pending<'a>,
        folded: &mut Folded,
        path: &mut Vec<&'a str>,
    ) -> Result<(), MtlxError> {
        if folded.contains_key(name) {
            return Ok(());
        }
        if path.contains(&name) {
            path.push(name);
            return Err(doc_err(
                &pending[name].0.pos,
                format!("string nodes connect in a cycle: {}", path.join(" → ")),
            ));
        }
        path.push(name);
        let (n, nd) = pending[name];
        let value = match nd.node.as_str() {
            "geompropvalueuniform" => {
                let prop = match self.string_input(n, nd, "geomprop", pending, folded, path)? {
                    Json::String(s) if !s.starts_with('$') => s,
                    _ => {
                        return Err(doc_err(
                            &n.pos,
                            format!(
                                "node `{}`: the geomprop of a string-valued geompropvalueuniform \
                                 must be a literal name (the renderer needs it before the \
                                 material compiles), not an interface input",
                                n.name
                            ),
                        ));
                    }
                };
                self.props.insert(prop.clone());
                match self.geomprops.get(&prop) {
                    Some(v) => Json::String(v.clone()),
                    None => self.string_input(n, nd, "default", pending, folded, path)?,
                }
            }
            "constant" => self.string_input(n, nd, "value", pending, folded, path)?,
            _ => self.string_input(n, nd, "in", pending, folded, path)?,
        };
        path.pop();
        folded.insert(name.to_string(), (value, nd.outputs[0].ty.clone()));
        Ok(())
    }

    /// The value of a folded node's string input: a literal, `$name` (an interface input),
    /// another folded node's value, or the nodedef's default.
    fn string_input(
        &mut self,
        n: &'a NodeElem,
        nd: &'a NodeDefElem,
        input: &str,
        pending: &Pending<'a>,
        folded: &mut Folded,
        path: &mut Vec<&'a str>,
    ) -> Result<Json, MtlxError> {
        let decl = nd.inputs.iter().find(|d| d.name == input);
        let Some(i) = n.inputs.iter().find(|i| i.name == input) else {
            let v = decl.and_then(|d| d.value.clone()).unwrap_or_default();
            return Ok(Json::String(v));
        };
        let want = decl.map_or("string", |d| d.ty.as_str());
        if let Some(name) = &i.interfacename {
            return interface_value(&n.name, i, name, self.iface);
        }
        if let Some(src) = &i.nodename {
            let Some(&(sn, _)) = pending.get(src.as_str()) else {
                return Err(doc_err(
                    &i.pos,
                    format!(
                        "node `{}` input `{}`: `{src}` is not a string constant, dot or \
                         geompropvalueuniform of this scope (strings are compile-time values)",
                        n.name, i.name
                    ),
                ));
            };
            self.fold(&sn.name, pending, folded, path)?;
            return folded_value(folded, &n.name, i, want)
                .unwrap_or_else(|| unreachable!("`{src}` was just folded"));
        }
        if i.nodegraph.is_some() {
            return Err(doc_err(
                &i.pos,
                format!(
                    "node `{}` input `{}`: a string cannot come from a nodegraph output \
                     (strings are compile-time values)",
                    n.name, i.name
                ),
            ));
        }
        Ok(Json::String(i.value.clone().unwrap_or_default()))
    }
}

/// The value of the folded node that input `i` of `node` connects to (`nodename`), for an
/// input of MaterialX type `want`; a type mismatch names both types. `None` where `i`
/// reads no folded node.
pub(super) fn folded_value(
    folded: &Folded,
    node: &str,
    i: &Input,
    want: &str,
) -> Option<Result<Json, MtlxError>> {
    let src = i.nodename.as_ref()?;
    let (v, ty) = folded.get(src.as_str())?;
    Some(if ty == want {
        Ok(v.clone())
    } else {
        Err(MtlxError::TypeMismatch {
            at: i.pos.clone(),
            node: node.to_string(),
            input: i.name.clone(),
            expected: want.to_string(),
            source_name: src.clone(),
            found: ty.clone(),
        })
    })
}
