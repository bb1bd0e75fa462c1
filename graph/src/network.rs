//! The network file format (JSON): nodes, their inputs, material outputs and compound
//! definitions. `docs/network-format.md` is the user's reference.
//!
//! This module only parses; what the names and values mean is the linker's business
//! ([`crate::link`]). Input values stay raw JSON here because whether a string is a literal
//! or a connection depends on the port's type, which only the node library knows.

use serde::Deserialize;
use serde_json::{Map, Value as Json};

/// A shading network as written in a file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Network {
    /// The material's name (defaults to the file stem in the CLI).
    #[serde(default)]
    pub name: Option<String>,
    /// Format version; only 1 exists.
    #[serde(default = "one")]
    pub version: u32,
    /// The node instances, in any order (connections may point forward).
    pub nodes: Vec<NodeSpec>,
    /// Material outputs: output name → `"node.output"` or `"node.output.component"`.
    #[serde(default)]
    pub outputs: Map<String, Json>,
    /// Compound node definitions usable as node types in `nodes` (and in each other).
    #[serde(default)]
    pub compounds: Vec<CompoundSpec>,
}

fn one() -> u32 {
    1
}

/// One node instance.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NodeSpec {
    /// Unique name within its network or compound.
    pub name: String,
    /// A library node type or a compound's name.
    #[serde(rename = "type")]
    pub ty: String,
    /// Input port → literal, array, `"node.output[.component]"` connection, or
    /// `{"connect": "…"}`.
    #[serde(default)]
    pub inputs: Map<String, Json>,
}

/// A compound node: a network used as a node type.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CompoundSpec {
    /// The node type name it defines.
    pub name: String,
    /// Documentation.
    #[serde(default)]
    pub doc: Option<String>,
    /// The compound's interface inputs; inside, `"$name"` refers to one.
    #[serde(default)]
    pub inputs: Vec<CompoundInput>,
    /// Interface outputs: name → `"inner_node.output[.component]"`.
    pub outputs: Map<String, Json>,
    /// The inner nodes.
    pub nodes: Vec<NodeSpec>,
}

/// An interface input of a compound.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CompoundInput {
    /// Its name.
    pub name: String,
    /// Its type name (`float`, `color`, …).
    #[serde(rename = "type")]
    pub ty: String,
    /// Its value when the instance leaves it unset; without one, the input is required.
    #[serde(default)]
    pub default: Option<Json>,
}

/// A network file that is not valid JSON or not of the expected shape.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct ParseError(serde_json::Error);

impl From<serde_json::Error> for ParseError {
    fn from(e: serde_json::Error) -> ParseError {
        // Not a `#[source]`: the message above is the JSON error's own text, so a chain
        // printed level by level would say it twice.
        ParseError(e)
    }
}

impl ParseError {
    /// 1-based line of the error.
    pub fn line(&self) -> usize {
        self.0.line()
    }

    /// 1-based column of the error.
    pub fn column(&self) -> usize {
        self.0.column()
    }
}

impl Network {
    /// Parses a network from JSON text.
    pub fn from_json(src: &str) -> Result<Network, ParseError> {
        Ok(serde_json::from_str(src)?)
    }
}
