//! shadenet-runtime: what runs a compiled material.
//!
//! This crate owns the shading context ABI ([`ctx`]), the intrinsics that need the scene
//! (light samples: [`lights`], textures: [`texture`]) and the interpreter ([`interp`]), the reference every other
//! back end is tested against. It depends on `shadenet-graph` for the IR and the op semantics
//! and must not know about networks' file formats, Cranelift, wgpu or the tracer.

pub mod ctx;
pub mod interp;
pub mod lights;
pub mod texture;

pub use ctx::{Fragment, SceneServices, ShadeCtx, ShadeEnv, Transform};
pub use interp::{Interpreter, OutputSlot, Scratch, ShadeOut};
pub use lights::Light;
pub use texture::{Texture, TextureError, TextureSet};
