//! shadenet-tracer: the ray tracer the shading system is embedded in (DESIGN §1, §2, §8).
//!
//! It owns the scene format and its loaders ([`scene`], [`geometry`]), the camera with ray
//! differentials ([`camera`]), the BVH and ray queries ([`accel`]), render passes and
//! ray-match rules ([`passes`]), the integrator and the scene services shaders call back
//! into ([`render`]), the files of image environment lights ([`envmap`]), the film
//! ([`film`]), image output ([`output`]) and the assembly of region renders ([`merge`]).
//!
//! It must not touch nodes or networks: it receives compiled [`shadenet_graph::ir::Program`]s
//! (the facade links networks) and runs them through a [`shader::ShaderBackend`] (the
//! interpreter, any runtime `Backend`: the JIT, the GPU), shading camera hits immediately or,
//! for a back end that prefers batches, deferred in batches ([`render`]). It specializes programs
//! with `graph::opt` (one per component mask the ray-match rules produce) and builds its
//! override shaders with `graph::ir::Builder`, but never looks inside a program beyond its
//! outputs and needs. It does not depend on the facade.
//!
//! ```no_run
//! use shadenet_tracer::{render::Renderer, scene, shader::InterpBackend};
//! // The facade links each material's network; a stand-in here.
//! let compile = |m: &scene::MaterialRef| {
//!     shadenet_graph::ir::Builder::new(&m.name).finish().unwrap_or_default()
//! };
//! let scene = scene::load(std::path::Path::new("examples/scenes/showcase.toml"))?;
//! let programs = scene.materials.iter().map(compile).collect();
//! let renderer = Renderer::new(scene, programs, &InterpBackend)?;
//! let (film, stats) = renderer.render(&|_done, _total| {});
//! film.write_exr(std::path::Path::new("out.exr"))?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod accel;
pub mod camera;
pub mod envmap;
pub mod film;
pub mod geometry;
pub mod merge;
pub mod output;
pub mod passes;
pub mod render;
pub mod scene;
pub mod shader;
pub mod window;

pub use film::{Film, Layer, Window};
pub use render::{DeferredOptions, RenderError, RenderStats, Renderer, ShadingMode};
pub use scene::{Scene, SceneError};
