//! The seam between the tracer and whatever runs compiled materials.
//!
//! The tracer specializes programs itself (one per distinct component mask the ray-match
//! rules produce) and hands each specialized program to a [`ShaderBackend`], getting back a
//! [`Shader`] it calls per hit from every rayon thread (and recursively, from inside a
//! shader's `trace`). [`RuntimeBackend`] adapts any `shadenet_runtime::Backend` (the
//! interpreter, the JIT) to it; [`InterpBackend`] is the interpreter, the reference.

use shadenet_graph::ir::Program;
use shadenet_runtime::{Backend, Material, ShadeCtx, ShadeOut};
use std::sync::Arc;
use std::time::Duration;

/// A compiled material: shades one fragment, writing every output (each component part
/// separately) into `out`, laid out as the interpreter lays out the program's outputs.
pub trait Shader: Send + Sync {
    /// Shades one fragment. May be called recursively (a shader's `trace` shades another
    /// hit on the same thread before this call returns).
    fn shade(&self, ctx: &ShadeCtx, out: &mut ShadeOut<f32>);
}

/// Compiles specialized programs into shaders.
pub trait ShaderBackend: Send + Sync {
    /// The back end's name, for the render summary.
    fn name(&self) -> &str;
    /// Compiles one (already specialized and optimized) program.
    fn compile(&self, program: &Program) -> Result<Arc<dyn Shader>, String>;
}

/// Any runtime back end as a shader back end. The runtime's materials are re-entrant (the
/// interpreter takes fresh registers when re-entered, compiled code keeps its state on the
/// stack), so recursive shading needs nothing more here.
pub struct RuntimeBackend(pub Arc<dyn Backend>);

struct MaterialShader(Arc<dyn Material>);

impl Shader for MaterialShader {
    fn shade(&self, ctx: &ShadeCtx, out: &mut ShadeOut<f32>) {
        out.values.resize(self.0.width(), 0.0);
        out.nonfinite = self.0.shade(ctx, &mut out.values);
    }
}

impl ShaderBackend for RuntimeBackend {
    fn name(&self) -> &str {
        self.0.name()
    }

    fn compile(&self, program: &Program) -> Result<Arc<dyn Shader>, String> {
        let m = self
            .0
            .compile_program(program, Duration::ZERO)
            .map_err(|e| e.to_string())?;
        Ok(Arc::new(MaterialShader(m)))
    }
}

/// The interpreter in f32, the reference back end.
#[derive(Clone, Copy, Debug, Default)]
pub struct InterpBackend;

impl ShaderBackend for InterpBackend {
    fn name(&self) -> &str {
        "interp"
    }

    fn compile(&self, program: &Program) -> Result<Arc<dyn Shader>, String> {
        RuntimeBackend(Arc::new(shadenet_runtime::InterpBackend)).compile(program)
    }
}
