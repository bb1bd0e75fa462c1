//! What the linker reports: one [`LinkError`] per problem, all of them in a [`LinkErrors`].
//!
//! It owns the error types and their messages (the text a user reads, each naming the node
//! and port as written). It must not decide when an error is raised: the phases do.

use crate::types::Type;
use std::fmt;

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
