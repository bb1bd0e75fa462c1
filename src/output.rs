//! Writing images: PNG previews (sRGB, clamped) and multi-layer f32 EXR, each written to a
//! temporary file and renamed into place. The writers live in the tracer
//! (`shadenet_tracer::output`), which the facade depends on; this module re-exports them.

pub use shadenet_tracer::output::*;
