//! The errors of reading a MaterialX document and turning it into a network.
//!
//! This module owns the error enum and [`Pos`] (file:line:column); it must not decide what
//! is an error: the parser, the resolver and the translator do.

use crate::link::LinkErrors;
use std::fmt;

/// Where something is in a document: file, 1-based line and column.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pos {
    /// The file (as given to the parser).
    pub file: String,
    /// 1-based line.
    pub line: u32,
    /// 1-based column.
    pub column: u32,
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.column)
    }
}

/// A MaterialX document or library that cannot be used. Each variant's text says its own
/// level; a cause is a `source`.
#[derive(Debug, thiserror::Error)]
pub enum MtlxError {
    /// Not well-formed XML.
    #[error("{at}: malformed XML")]
    Xml {
        /// Where the XML parser stopped.
        at: Pos,
        /// The XML parser's message.
        source: roxmltree::Error,
    },
    /// A document of a MaterialX version we do not read.
    #[error(
        "{at}: MaterialX version {version} is not supported (1.38 and 1.39 are; convert older documents with MaterialX's own upgrade)"
    )]
    Version {
        /// The root element.
        at: Pos,
        /// The version as written.
        version: String,
    },
    /// A structural problem: a missing attribute, a bad value, a name used twice.
    #[error("{at}: {msg}")]
    Document {
        /// Where.
        at: Pos,
        /// What is wrong.
        msg: String,
    },
    /// A node whose category no nodedef has.
    #[error("{at}: node `{node}`: unknown node `{category}`{hint}")]
    UnknownNode {
        /// Where.
        at: Pos,
        /// The node's name.
        node: String,
        /// Its category (element name).
        category: String,
        /// The closest nodedef names, if any.
        hint: String,
    },
    /// A node of a known category whose types no nodedef matches.
    #[error("{at}: node `{node}`: no nodedef of `{category}` matches: {msg}")]
    NoNodeDef {
        /// Where.
        at: Pos,
        /// The node's name.
        node: String,
        /// Its category.
        category: String,
        /// The types asked for and the candidates.
        msg: String,
    },
    /// A connection whose source type differs from the input's.
    #[error(
        "{at}: node `{node}` input `{input}`: type mismatch: the input is {expected}, but `{source_name}` gives {found}"
    )]
    TypeMismatch {
        /// Where.
        at: Pos,
        /// The node.
        node: String,
        /// The input.
        input: String,
        /// The input's MaterialX type.
        expected: String,
        /// The connected output, as written.
        source_name: String,
        /// Its MaterialX type.
        found: String,
    },
    /// An `interfacename` that names no input of the enclosing nodegraph.
    #[error(
        "{at}: node `{node}` input `{input}`: interfacename `{name}` names no input of nodegraph `{graph}`"
    )]
    Interface {
        /// Where.
        at: Pos,
        /// The node.
        node: String,
        /// The input.
        input: String,
        /// The interface name.
        name: String,
        /// The nodegraph.
        graph: String,
    },
    /// Nodegraphs that use themselves through their nodedefs.
    #[error("cycle through nodegraphs: {path}")]
    Cycle {
        /// The nodegraphs around the cycle, `a → b → a`.
        path: String,
    },
    /// A closure-typed value (BSDF, EDF, shaders, materials): not built yet.
    #[error(
        "{at}: node `{node}` is of type {ty}: closures (BSDF, EDF, surfaceshader, material) are not built yet (issue 15); shade a color or float output instead (--output)"
    )]
    Closure {
        /// Where.
        at: Pos,
        /// The node.
        node: String,
        /// Its type.
        ty: String,
    },
    /// A value type with no IR type yet.
    #[error("{at}: node `{node}`: {msg}")]
    Unsupported {
        /// Where.
        at: Pos,
        /// The node (or nodedef).
        node: String,
        /// Why.
        msg: String,
    },
    /// The material or output asked for does not exist, or there is nothing to shade.
    #[error("{file}: {msg}")]
    Select {
        /// The document.
        file: String,
        /// What is wrong, with the names that exist.
        msg: String,
    },
    /// The translated network did not link.
    #[error("{file}: the network does not link")]
    Link {
        /// The document.
        file: String,
        /// The linker's errors (node names are `nodegraph/node`).
        source: LinkErrors,
    },
}

/// An error in the document at `at`.
pub fn doc_err(at: &Pos, msg: String) -> MtlxError {
    MtlxError::Document {
        at: at.clone(),
        msg,
    }
}
