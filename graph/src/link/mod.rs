//! The linker: from a parsed [`Network`] to a [`Linked`] network a lowering can trust.
//!
//! It expands compounds (inner nodes are renamed `instance/inner`), resolves every name to an
//! index, orders the nodes so sources come first (detecting cycles), picks each generic
//! node's type, checks and converts literals, checks connection types with the documented
//! coercions, builds light descriptions from light nodes, and resolves the material outputs.
//! It reports **every** error it finds, each naming the node and port as the user wrote them
//! (a compound's inner node as `instance/inner`).
//!
//! Coercions a connection may make (anything else is an error naming both types):
//! `float → vec2/vec3/color` (broadcast), `color ↔ vec3`, `int → float`, `bool → int`,
//! `bool → float`. A connection may select one component (`tex.outColor.r`), which makes it
//! a float.
//!
//! [`link`] runs the phases in order, one file each; each appends its errors, so they are
//! reported in phase order:
//!
//! 1. `expand.rs`: format version, compound definitions, flattening into library nodes.
//! 2. `resolve.rs`: node names → indices, connection strings → (node, output, component).
//! 3. `order.rs`: dependency order and cycles (a cycle stops linking here).
//! 4. `generic.rs`: each generic node's type.
//! 5. `check.rs` (with `light.rs`): every input against its port's type; linked nodes and
//!    lights.
//! 6. `outputs.rs`: the material outputs.
//!
//! Beside them: `error.rs` (the error types), `linked.rs` (the product), `values.rs`
//! (coercions and literals) and `names.rs` (name rules and suggestions). This file owns only
//! the order of the phases and the public surface; it must not check anything itself (a new
//! check belongs to the phase whose facts it needs, or is a new phase).

mod check;
mod error;
mod expand;
mod generic;
mod light;
mod linked;
mod names;
mod order;
mod outputs;
mod resolve;
mod values;

pub use error::{LinkError, LinkErrors};
pub use linked::{Linked, LinkedInput, LinkedNode, Source};
pub use names::edit_distance;
pub use values::{coercible, literal};

use crate::network::Network;
use crate::nodes::NodeLibrary;
use resolve::Resolver;

/// Links a network against a node library.
pub fn link(net: &Network, lib: &NodeLibrary) -> Result<Linked, LinkErrors> {
    let mut errors = Vec::new();
    let expanded = expand::network(net, lib, &mut errors);
    let resolver = Resolver::new(&expanded, &mut errors);
    let ins = resolver.inputs(&mut errors);
    let Some(order) = order::dependency_order(&expanded.flat, &ins, &mut errors) else {
        return Err(LinkErrors(errors));
    };
    let typed = generic::infer(&expanded.flat, &ins, &order, &mut errors);
    let pos = order::shading_positions(&expanded.flat, &order);
    let (nodes, lights) = check::nodes(&typed, &ins, &order, &pos, &mut errors);
    let outputs = outputs::material(net, &resolver, &typed, &pos, &mut errors);
    if !errors.is_empty() {
        return Err(LinkErrors(errors));
    }
    Ok(Linked {
        name: net.name.clone().unwrap_or_else(|| "material".into()),
        nodes,
        outputs,
        lights,
    })
}
