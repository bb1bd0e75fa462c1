//! Standard nodes: pattern.

use super::NodeLibrary;

/// Registers the pattern nodes.
pub fn register(_lib: &mut NodeLibrary) {}
