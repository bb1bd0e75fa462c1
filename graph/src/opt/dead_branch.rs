//! The dead_branch pass (being written on its own branch; this placeholder changes nothing).

use super::Specialization;
use crate::ir::Program;

/// Runs the pass; returns the number of changes.
pub fn run(_p: &mut Program, _spec: &Specialization) -> usize {
    0
}
