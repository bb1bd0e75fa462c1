//! The multiplication tree of Larsson 2005, §5.1.1 (DESIGN §9, benchmark B1): a balanced
//! tree of `2^n − 1` `multiply` nodes over `2^n` `samplerInfo` leaves giving the fragment
//! position, its root the material's output.
//!
//! Nodes are listed in post-order (each subtree's leaves and products before its root), so
//! that lowering keeps the evaluation order of a depth-first walk: at most `n` partial
//! products are alive at a time.

use std::fmt::Write as _;

/// The network of the level-`level` tree (`level` ≥ 1) as JSON, its leaves reading `P` in
/// `space` (`"world"`, `"camera"` or `"object"`).
pub fn multiplication_tree(level: u32, space: &str) -> String {
    let mut nodes = Vec::new();
    let mut next = 0usize;
    let root = subtree(level, space, &mut nodes, &mut next);
    let mut s = String::new();
    let _ = write!(
        s,
        "{{\n  \"name\": \"tree{level}\",\n  \"nodes\": [\n{}\n  ],\n  \"outputs\": {{ \"color\": \"{root}\" }}\n}}\n",
        nodes.join(",\n")
    );
    s
}

/// Appends the nodes of a subtree of `depth` levels; returns the port its value leaves by.
fn subtree(depth: u32, space: &str, nodes: &mut Vec<String>, next: &mut usize) -> String {
    *next += 1;
    let id = *next;
    if depth == 0 {
        nodes.push(format!(
            "    {{ \"name\": \"p{id}\", \"type\": \"samplerInfo\", \"inputs\": {{ \"space\": \"{space}\" }} }}"
        ));
        return format!("p{id}.P");
    }
    let a = subtree(depth - 1, space, nodes, next);
    let b = subtree(depth - 1, space, nodes, next);
    nodes.push(format!(
        "    {{ \"name\": \"m{id}\", \"type\": \"multiply\", \"inputs\": {{ \"input1\": \"{a}\", \"input2\": \"{b}\" }} }}"
    ));
    format!("m{id}.out")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tree_has_the_thesis_node_counts() {
        for level in 1..=4 {
            let net = multiplication_tree(level, "world");
            let muls = net.matches("\"multiply\"").count();
            let leaves = net.matches("\"samplerInfo\"").count();
            assert_eq!(muls, (1 << level) - 1);
            assert_eq!(leaves, 1 << level);
            let c = shadenet_graph::compile_json(&net, &shadenet_graph::NodeLibrary::standard())
                .unwrap();
            shadenet_graph::ir::validate(&c.program).unwrap();
        }
    }
}
