//! Standard nodes: surface.

use super::NodeLibrary;

/// Registers the surface nodes.
pub fn register(_lib: &mut NodeLibrary) {}
