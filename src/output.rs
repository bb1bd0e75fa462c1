//! Writing images: PNG previews (sRGB, clamped) and multi-layer f32 EXR, each written to a
//! temporary file and renamed into place; reading EXR back and comparing two images per
//! layer (`shadenet diff`). The code lives in the tracer (`shadenet_tracer::output`), which
//! the facade depends on; this module re-exports it.

pub use shadenet_tracer::output::*;
