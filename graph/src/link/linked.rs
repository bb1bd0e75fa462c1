//! The linker's product: a [`Linked`] network whose nodes are in dependency order and whose
//! inputs are resolved and typed.
//!
//! It owns only the data types a lowering reads; it must not compute anything (the phases
//! fill these types in).

use crate::nodes::LightDesc;
use crate::types::{ConstValue, Type};

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
