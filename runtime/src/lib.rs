//! shadenet-runtime: what runs a compiled material.
//!
//! This crate owns the shading context ABI ([`ctx`]), the intrinsics that need the scene
//! (light samples: [`lights`] with image environments prepared by [`envmap`], textures:
//! [`texture`]), the interpreter ([`interp`]), the
//! reference every other back end is tested against, and the back-end traits with the
//! material cache ([`backend`]), the fixtures of the back ends' parity tests
//! ([`testing`]), and the bounded gate every input file passes ([`input`]). It depends on `shadenet-graph` for the IR and the op
//! semantics and must not know about networks' file formats, Cranelift, wgpu or the tracer.

pub mod backend;
pub mod ctx;
pub mod envmap;
pub mod input;
pub mod interp;
pub mod lights;
pub mod testing;
pub mod texture;

pub use backend::{
    Backend, BackendError, BatchResult, BatchTimes, CompileStats, FragmentX4, InterpBackend,
    InterpMaterial, LANES, Material, MaterialCache, MaterialInfo, shade_batch,
};
pub use ctx::{Fragment, SceneServices, ShadeCtx, ShadeEnv, Transform, fragment_services};
pub use interp::{Interpreter, OutputSlot, Scratch, ShadeOut, output_layout};
pub use lights::Light;
pub use texture::{Texture, TextureError, TextureSet};
