//! Generated networks for benchmarks and tests (DESIGN §9), written by `shadenet gen`.
//!
//! [`mult_tree`] is benchmark B1, the multiplication tree of Larsson (2005, §5.1.1): a
//! balanced binary tree of `2^n − 1` `multiply` nodes over `2^n` leaves, each leaf its own
//! `samplerInfo` node whose position `P` (in world or camera space) feeds the bottom row, and
//! the root feeding the material output `color`. Since every leaf reads the fragment, nothing
//! folds away: the tree measures the cost of passing data between nodes and from the renderer
//! to the shading system.

use serde_json::{Map, Value, json};
use shadenet_graph::ir::Space;
use std::ops::RangeInclusive;

/// The levels a multiplication tree may have: level 16 is 65 535 multiplies over 65 536
/// leaves, far beyond the thesis's level 10.
pub const MULT_TREE_LEVELS: RangeInclusive<u32> = 1..=16;

/// A network that cannot be generated.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum GenError {
    /// The tree's level is outside [`MULT_TREE_LEVELS`].
    #[error(
        "a multiplication tree has {} to {} levels, not {levels}",
        MULT_TREE_LEVELS.start(),
        MULT_TREE_LEVELS.end()
    )]
    Levels {
        /// The level asked for.
        levels: u32,
    },
}

/// The multiplication-tree network of `levels` levels (benchmark B1), as network JSON
/// (`docs/network-format.md`), with leaves reading `P` in `space`.
///
/// Nodes are named by position: leaf `p<i>` (`i` in `0..2^levels`) is a `samplerInfo` with
/// `space` set; `m<l>_<i>` (`l` in `1..=levels`, `i` in `0..2^(levels − l)`) is a `multiply`
/// of the product of the `2^l` leaves `p<i·2^l>` … `p<(i+1)·2^l − 1>`: `m1_<i>` multiplies
/// `p<2i>.P` by `p<2i+1>.P`, and `m<l>_<i>` multiplies `m<l−1>_<2i>.out` by
/// `m<l−1>_<2i+1>.out`. The root `m<levels>_0` is the output `color` (a vec3: `P^(2^levels)`
/// component-wise, multiplied in tree order). Leaves come first in the node list, then the
/// rows bottom-up. The network is named `mult_tree_<levels>_<space>`.
pub fn mult_tree(levels: u32, space: Space) -> Result<Value, GenError> {
    if !MULT_TREE_LEVELS.contains(&levels) {
        return Err(GenError::Levels { levels });
    }
    let leaves = 1usize << levels;
    let mut nodes = Vec::with_capacity(2 * leaves - 1);
    for i in 0..leaves {
        nodes.push(json!({
            "name": format!("p{i}"),
            "type": "samplerInfo",
            "inputs": { "space": space.name() },
        }));
    }
    for l in 1..=levels {
        for i in 0..leaves >> l {
            let (a, b) = if l == 1 {
                (format!("p{}.P", 2 * i), format!("p{}.P", 2 * i + 1))
            } else {
                (
                    format!("m{}_{}.out", l - 1, 2 * i),
                    format!("m{}_{}.out", l - 1, 2 * i + 1),
                )
            };
            nodes.push(json!({
                "name": format!("m{l}_{i}"),
                "type": "multiply",
                "inputs": { "input1": a, "input2": b },
            }));
        }
    }
    let mut outputs = Map::new();
    outputs.insert("color".into(), Value::String(format!("m{levels}_0.out")));
    Ok(json!({
        "name": format!("mult_tree_{levels}_{}", space.name()),
        "version": 1,
        "nodes": nodes,
        "outputs": outputs,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tree_links_with_the_thesis_node_counts() {
        for level in 1..=4 {
            let net = mult_tree(level, Space::World).unwrap().to_string();
            assert_eq!(net.matches("\"multiply\"").count(), (1 << level) - 1);
            assert_eq!(net.matches("\"samplerInfo\"").count(), 1 << level);
            let c = shadenet_graph::compile_json(&net, &shadenet_graph::NodeLibrary::standard())
                .unwrap();
            shadenet_graph::ir::validate(&c.program).unwrap();
        }
    }
}
