//! Nodedef resolution, as the MaterialX specification defines it: a node's category, its
//! output type and the types of the inputs it sets choose one nodedef (`ND_add_color3` vs
//! `ND_add_color3FA`); the document's own nodedefs come before the libraries'.
//!
//! This module owns choosing a nodedef and the errors when none fits (with the closest
//! names); it must not translate nodes or check connections.

use super::document::{Document, NodeDefElem, NodeElem};
use super::error::MtlxError;
use super::library::Library;
use crate::link::edit_distance;

/// The nodedefs visible to a document: its own, then the libraries'.
#[derive(Clone, Copy)]
pub struct Defs<'a> {
    /// The libraries.
    pub lib: &'a Library,
    /// The document.
    pub doc: &'a Document,
}

impl<'a> Defs<'a> {
    /// The nodedef called `name`.
    pub fn nodedef(&self, name: &str) -> Option<&'a NodeDefElem> {
        self.doc
            .nodedefs
            .iter()
            .find(|d| d.name == name)
            .or_else(|| self.lib.nodedef(name))
    }

    fn candidates(&self, category: &str) -> Vec<&'a NodeDefElem> {
        let mut c: Vec<&NodeDefElem> = self
            .doc
            .nodedefs
            .iter()
            .filter(|d| d.node == category)
            .collect();
        c.extend(self.lib.of_node(category));
        c
    }

    /// Resolves a node instance to its nodedef.
    pub fn resolve(&self, node: &NodeElem) -> Result<&'a NodeDefElem, MtlxError> {
        if let Some(name) = &node.nodedef {
            return self.nodedef(name).ok_or_else(|| MtlxError::UnknownNode {
                at: node.pos.clone(),
                node: node.name.clone(),
                category: name.clone(),
                hint: String::new(),
            });
        }
        let cands = self.candidates(&node.category);
        if cands.is_empty() {
            return Err(MtlxError::UnknownNode {
                at: node.pos.clone(),
                node: node.name.clone(),
                category: node.category.clone(),
                hint: self.closest(&node.category),
            });
        }
        if let Some(d) = cands.iter().find(|d| matches(d, node)) {
            return Ok(d);
        }
        let set: Vec<String> = node
            .inputs
            .iter()
            .filter(|i| !i.ty.is_empty())
            .map(|i| format!("{}: {}", i.name, i.ty))
            .collect();
        let shown: Vec<String> = cands.iter().take(8).map(|d| signature(d)).collect();
        Err(MtlxError::NoNodeDef {
            at: node.pos.clone(),
            node: node.name.clone(),
            category: node.category.clone(),
            msg: format!(
                "type {}, inputs ({}); candidates: {}{}",
                if node.ty.is_empty() { "?" } else { &node.ty },
                set.join(", "),
                shown.join("; "),
                if cands.len() > 8 { "; …" } else { "" }
            ),
        })
    }

    /// ` (closest: `a` (ND_a_float), …)` for the categories nearest to `category`.
    fn closest(&self, category: &str) -> String {
        let mut cats: Vec<(usize, &str)> = self
            .lib
            .categories()
            .chain(self.doc.nodedefs.iter().map(|d| d.node.as_str()))
            .map(|c| {
                (
                    edit_distance(&c.to_lowercase(), &category.to_lowercase()),
                    c,
                )
            })
            .filter(|(d, _)| *d <= 3)
            .collect();
        cats.sort();
        cats.dedup();
        if cats.is_empty() {
            return String::new();
        }
        let names: Vec<String> = cats
            .iter()
            .take(3)
            .map(|(_, c)| {
                let nd = self.candidates(c).first().map(|d| d.name.clone());
                format!("`{c}` ({})", nd.unwrap_or_default())
            })
            .collect();
        format!(" (closest: {})", names.join(", "))
    }
}

fn matches(d: &NodeDefElem, node: &NodeElem) -> bool {
    let out_ok = match node.ty.as_str() {
        "" => true,
        "multioutput" => d.outputs.len() > 1,
        t => d.outputs.len() == 1 && d.outputs[0].ty == t,
    };
    out_ok
        && node.inputs.iter().all(|i| {
            d.inputs
                .iter()
                .any(|di| di.name == i.name && (i.ty.is_empty() || di.ty == i.ty))
        })
}

fn signature(d: &NodeDefElem) -> String {
    let ins: Vec<String> = d
        .inputs
        .iter()
        .map(|i| format!("{}: {}", i.name, i.ty))
        .collect();
    let outs: Vec<&str> = d.outputs.iter().map(|o| o.ty.as_str()).collect();
    format!("{} ({}) → {}", d.name, ins.join(", "), outs.join(", "))
}
