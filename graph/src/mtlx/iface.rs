//! The interface a scope's `interfacename`s refer to: the inputs of the enclosing
//! nodegraph (or nodedef), and what an input naming one of them becomes (`$name`, which the
//! linker resolves against the compound instance's arguments).
//!
//! This module owns that check; it must not translate nodes.

use super::document::Input;
use super::error::MtlxError;
use serde_json::Value as Json;

/// The interface of one scope: its nodegraph's name (for messages) and inputs.
pub struct Iface<'a> {
    /// The nodegraph.
    pub graph: &'a str,
    /// Its interface inputs.
    pub inputs: &'a [Input],
}

/// `$name` for input `i` of `node` naming interface input `name`, which the enclosing
/// nodegraph must declare.
pub fn interface_value(
    node: &str,
    i: &Input,
    name: &str,
    iface: Option<&Iface>,
) -> Result<Json, MtlxError> {
    if iface.is_some_and(|f| f.inputs.iter().any(|x| x.name == name)) {
        return Ok(Json::String(format!("${name}")));
    }
    Err(MtlxError::Interface {
        at: i.pos.clone(),
        node: node.to_string(),
        input: i.name.clone(),
        name: name.to_string(),
        graph: iface
            .map_or("(none: a top-level node)", |f| f.graph)
            .to_string(),
    })
}
