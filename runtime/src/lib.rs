//! shadenet-runtime: what runs a compiled material.
//!
//! This crate owns the shading context ABI ([`ctx`]), the intrinsics that need the scene
//! (light samples: [`lights`] with image environments prepared by [`envmap`] and light
//! shaders evaluated by [`light_shader`], textures:
//! [`texture`]), the interpreter ([`interp`]), the
//! reference every other back end is tested against, and the back-end traits with the
//! material cache ([`backend`]), the four-lane fragment packets batches are made of
//! ([`packets`]), the fixtures of the back ends' parity tests
//! ([`testing`]), the bounded gate every input file passes ([`input`]), the log of the
//! messages shaders write ([`messages`]), and the Radiance RGBE format ([`rgbe`]). It depends on `shadenet-graph` for the IR and the op
//! semantics and must not know about networks' file formats, Cranelift, wgpu or the tracer.

pub mod backend;
pub mod ctx;
pub mod envmap;
pub mod input;
pub mod interp;
pub mod light_shader;
pub mod lights;
pub mod messages;
pub mod packets;
pub mod rgbe;
pub mod testing;
pub mod texture;

pub use backend::{
    Backend, BackendError, BatchResult, BatchTimes, CompileStats, InterpBackend, InterpMaterial,
    Material, MaterialCache, MaterialInfo, shade_batch, shade_each, shade_many_unpacked,
    shade_packets,
};
pub use ctx::{
    Fragment, ProbeHit, SceneServices, ShadeCtx, ShadeEnv, Transform, fragment_services,
};
pub use interp::{Interpreter, OutputSlot, Scratch, ShadeOut, output_layout};
pub use lights::Light;
pub use packets::{FragmentX4, Fragments, LANES, packed_index, packed_len, unpacked};
pub use texture::{Texture, TextureError, TextureSet, TextureStats};
