//! `shadenet mtlx-coverage`: for every nodedef of a library folder (stdlib by default), does
//! it compile — natively (an atom), via its nodegraph, or not (and why).
//!
//! This module owns the measurement: each nodedef is instantiated alone in a one-node
//! document with every output connected, and compiled as a user's document would be. It
//! must not change what compiles.

use super::library::{Impl, Library};
use super::translate::Selection;
use super::value::{MxType, classify, unsupported_reason};
use std::fmt::Write as _;

/// How one nodedef fares.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// Lowered by an atom of the table.
    Native,
    /// Expanded from its nodegraph.
    ViaNodegraph,
    /// A compile-time string, folded into the inputs that read it.
    Folded,
    /// Does not compile: why.
    Unsupported(String),
}

/// One row of the report.
#[derive(Clone, Debug)]
pub struct Row {
    /// The nodedef.
    pub nodedef: String,
    /// Its node group.
    pub group: String,
    /// Its status.
    pub status: Status,
}

/// Checks every nodedef of library folder `folder` (`stdlib`, `pbrlib`, …).
pub fn check(lib: &Library, folder: &str) -> Vec<Row> {
    let mut rows = Vec::new();
    for (nd, f) in lib.defs() {
        if f != folder {
            continue;
        }
        let status = status(lib, nd);
        rows.push(Row {
            nodedef: nd.name.clone(),
            group: nd.group.clone(),
            status,
        });
    }
    rows
}

fn status(lib: &Library, nd: &super::document::NodeDefElem) -> Status {
    for p in nd.outputs.iter().chain(&nd.inputs) {
        // Inputs of closure kinds not built yet (a material's displacement shader) are
        // ignored, as the translator ignores them.
        let ignored =
            classify(&p.ty) == MxType::Closure && nd.inputs.iter().any(|i| std::ptr::eq(i, p));
        if !ignored && classify(&p.ty) != MxType::Value(classify_value(&p.ty)) {
            return Status::Unsupported(unsupported_reason(&p.ty));
        }
    }
    let kind = match lib.implementation(nd) {
        Impl::Graph(_) => Status::ViaNodegraph,
        Impl::Atom => Status::Native,
        Impl::Folded => Status::Folded,
        Impl::None(reason) => return Status::Unsupported(reason.to_string()),
    };
    let doc = if kind == Status::Folded {
        folded_doc(nd)
    } else {
        alone_doc(nd)
    };
    match super::compile("coverage.mtlx", &doc, lib, &Selection::default()) {
        Ok(_) => kind,
        Err(e) => Status::Unsupported(crate::error_chain(&e)),
    }
}

/// A document with the nodedef alone, every output a document output.
fn alone_doc(nd: &super::document::NodeDefElem) -> String {
    let mut doc = format!(
        "<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n  <{} name=\"n\" type=\"{}\" nodedef=\"{}\" />\n",
        nd.node,
        if nd.outputs.len() > 1 {
            "multioutput"
        } else {
            nd.outputs[0].ty.as_str()
        },
        nd.name
    );
    for o in &nd.outputs {
        let _ = writeln!(
            doc,
            "  <output name=\"o_{0}\" type=\"{1}\" nodename=\"n\" output=\"{0}\" />",
            o.name, o.ty
        );
    }
    doc.push_str("</materialx>\n");
    doc
}

/// A document where a folded string node's output feeds an input of its type, which is
/// shaded: a filename the `file` of an `image`, a string the `geomprop` of a
/// `geompropvalue` (strings cannot be shaded themselves).
fn folded_doc(nd: &super::document::NodeDefElem) -> String {
    let ty = &nd.outputs[0].ty;
    let (consumer, port) = if ty == "filename" {
        ("image", "file")
    } else {
        ("geompropvalue", "geomprop")
    };
    format!(
        "<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n  \
         <{node} name=\"n\" type=\"{ty}\" nodedef=\"{nd}\" />\n  \
         <{consumer} name=\"c\" type=\"float\">\n    \
         <input name=\"{port}\" type=\"{ty}\" nodename=\"n\" />\n  </{consumer}>\n  \
         <output name=\"o\" type=\"float\" nodename=\"c\" />\n</materialx>\n",
        node = nd.node,
        nd = nd.name,
    )
}

fn classify_value(ty: &str) -> crate::types::Type {
    match classify(ty) {
        MxType::Value(t) => t,
        _ => crate::types::Type::Bool,
    }
}

/// The report as text: one line per nodedef, then the totals.
pub fn report(rows: &[Row]) -> String {
    let mut s = String::new();
    let (mut native, mut graph, mut folded) = (0, 0, 0);
    for r in rows {
        let st = match &r.status {
            Status::Native => {
                native += 1;
                "native".to_string()
            }
            Status::ViaNodegraph => {
                graph += 1;
                "via nodegraph".to_string()
            }
            Status::Folded => {
                folded += 1;
                "folded (a compile-time string)".to_string()
            }
            Status::Unsupported(why) => format!("unsupported: {why}"),
        };
        let _ = writeln!(s, "{:<40} {:<14} {st}", r.nodedef, r.group);
    }
    let total = rows.len().max(1);
    let ok = native + graph + folded;
    let _ = writeln!(
        s,
        "\ntotal: {} nodedefs; {ok} compile ({native} native, {graph} via nodegraph, {folded} folded) = {:.1} %; {} unsupported",
        rows.len(),
        100.0 * ok as f64 / total as f64,
        rows.len() - ok
    );
    s
}
