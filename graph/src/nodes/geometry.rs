//! Standard nodes: geometry.

use super::NodeLibrary;

/// Registers the geometry nodes.
pub fn register(_lib: &mut NodeLibrary) {}
