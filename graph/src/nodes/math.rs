//! Standard nodes: math.

use super::NodeLibrary;

/// Registers the math nodes.
pub fn register(_lib: &mut NodeLibrary) {}
