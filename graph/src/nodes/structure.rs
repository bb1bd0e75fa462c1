//! Standard nodes: structure.

use super::NodeLibrary;

/// Registers the structure nodes.
pub fn register(_lib: &mut NodeLibrary) {}
