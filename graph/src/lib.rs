//! shadenet-graph: shading networks, the node library, the linker, the IR and its op
//! semantics.
//!
//! This crate owns everything that happens before code runs: parsing a network file
//! ([`network`]), resolving and type-checking it against a [`nodes::NodeLibrary`] ([`link`]),
//! lowering it to the IR ([`lower`], [`ir`]) and the one definition of what each op computes
//! ([`ops`]). It must not touch rendering, back ends or the shading context: the runtime, the
//! JIT and the GPU back end depend on this crate, never the reverse (DESIGN §2).

pub mod closure;
pub mod ir;
pub mod link;
pub mod lower;
pub mod mtlx;
pub mod network;
pub mod nodes;
pub mod ops;
pub mod opt;
pub mod transport;
pub mod types;

pub use link::{LinkError, LinkErrors, Linked, edit_distance, link};
pub use lower::{CompileError, Compiled, compile_json, lower};
pub use network::Network;
pub use nodes::NodeLibrary;
pub use transport::LightStrategy;
pub use types::{ClosureKind, ConstValue, Type};

/// An error and its causes, outermost first, joined by `": "`: how the CLI prints an error,
/// for code that must put a whole error into a message (each level's `Display` says its own
/// level only, so `to_string()` alone would drop the causes).
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text.push_str(": ");
        text.push_str(&c.to_string());
        cause = c.source();
    }
    text
}
