//! Phase 3, ordering: puts the flattened nodes in dependency order (sources before users) by
//! an iterative depth-first search, reporting the first cycle it meets, and numbers the
//! shading nodes in that order (their indices in [`Linked::nodes`](super::Linked::nodes)).
//!
//! It owns the order and the cycle report. It must not look at types, literals or names
//! beyond naming the nodes of a cycle.

use super::error::LinkError;
use super::expand::Flat;
use super::resolve::In;
use crate::nodes::NodeKind;

/// The nodes `inputs` (one node's resolved inputs) connect from, in port order.
fn deps(inputs: &[In]) -> Vec<usize> {
    let mut d = Vec::new();
    for p in inputs {
        match p {
            In::Conn(c) => d.push(c.node),
            In::Array(a) => {
                for rec in a {
                    for (_, v) in rec {
                        if let In::Conn(c) = v {
                            d.push(c.node);
                        }
                    }
                }
            }
            _ => {}
        }
    }
    d
}

/// The flattened nodes in dependency order, or `None` when they form a cycle (the first one
/// found is reported in `errors`).
pub(super) fn dependency_order(
    flat: &[Flat<'_>],
    ins: &[Vec<In>],
    errors: &mut Vec<LinkError>,
) -> Option<Vec<usize>> {
    let mut state = vec![0u8; flat.len()]; // 0 new, 1 on stack, 2 done
    let mut order: Vec<usize> = Vec::new();
    let mut cyclic = false;
    // Roots are visited last node first: a network usually lists its outputs' nodes last,
    // so the post-order is depth-first from the outputs, which keeps few values live at
    // once (a breadth-first order of a big tree spills registers in compiled code).
    for root in (0..flat.len()).rev() {
        if state[root] != 0 {
            continue;
        }
        let mut stack: Vec<(usize, Vec<usize>)> = vec![(root, deps(&ins[root]))];
        state[root] = 1;
        while let Some((node, pending)) = stack.last_mut() {
            let node = *node;
            if let Some(d) = pending.pop() {
                match state[d] {
                    0 => {
                        state[d] = 1;
                        stack.push((d, deps(&ins[d])));
                    }
                    1 => {
                        if !cyclic {
                            let start = stack.iter().position(|(n, _)| *n == d).unwrap_or(0);
                            let mut path: Vec<&str> = stack[start..]
                                .iter()
                                .map(|(n, _)| flat[*n].name.as_str())
                                .collect();
                            path.push(&flat[d].name);
                            errors.push(LinkError::Cycle {
                                path: path.join(" → "),
                            });
                        }
                        cyclic = true;
                    }
                    _ => {}
                }
            } else {
                state[node] = 2;
                order.push(node);
                stack.pop();
            }
        }
    }
    (!cyclic).then_some(order)
}

/// Per flattened node, its index among the shading nodes of `order` (`usize::MAX` for
/// lights).
pub(super) fn shading_positions(flat: &[Flat<'_>], order: &[usize]) -> Vec<usize> {
    let mut pos = vec![usize::MAX; flat.len()];
    let shading = order
        .iter()
        .copied()
        .filter(|&i| matches!(flat[i].def.kind, NodeKind::Shading));
    for (k, i) in shading.enumerate() {
        pos[i] = k;
    }
    pos
}
