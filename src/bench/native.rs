//! The native reference of benchmark B1 (DESIGN §9): the multiplication trees of levels 1–10
//! written out as Rust (SSE intrinsics) by `build.rs` and compiled by rustc with the rest of
//! this crate — rustc-compiled code, not the JIT. [`TREES`]`[L − 1]` shades a packet of four
//! fragments as the level-`L` tree compiled with CSE off does.

include!(concat!(env!("OUT_DIR"), "/larsson_native.rs"));
