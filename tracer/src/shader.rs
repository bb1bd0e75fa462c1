//! The seam between the tracer and whatever runs compiled materials.
//!
//! The tracer specializes programs itself (one per distinct component mask the ray-match
//! rules produce) and hands each specialized program to a [`ShaderBackend`], getting back a
//! [`Shader`] it calls per hit from every rayon thread. Today the only back end is the
//! interpreter ([`InterpBackend`]); the runtime's `Backend`/`Material` traits (being built
//! with the JIT) will replace these two traits, and this file is the one place that changes.

use shadenet_graph::ir::Program;
use shadenet_runtime::{Interpreter, Scratch, ShadeCtx, ShadeOut};
use std::cell::RefCell;
use std::sync::Arc;

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

/// The interpreter in f32, the reference back end.
#[derive(Clone, Copy, Debug, Default)]
pub struct InterpBackend;

struct InterpShader(Interpreter<f32>);

thread_local! {
    /// Free interpreter scratch buffers of this thread: a recursive shading call takes its
    /// own, so nested calls never share one.
    static SCRATCH: RefCell<Vec<Scratch<f32>>> = const { RefCell::new(Vec::new()) };
}

impl Shader for InterpShader {
    fn shade(&self, ctx: &ShadeCtx, out: &mut ShadeOut<f32>) {
        let mut scratch = SCRATCH.with(|s| s.borrow_mut().pop()).unwrap_or_default();
        self.0.shade_with(ctx, &mut scratch, out);
        SCRATCH.with(|s| s.borrow_mut().push(scratch));
    }
}

impl ShaderBackend for InterpBackend {
    fn name(&self) -> &str {
        "interp"
    }

    fn compile(&self, program: &Program) -> Result<Arc<dyn Shader>, String> {
        let interp = Interpreter::<f32>::new(program).map_err(|e| e.to_string())?;
        Ok(Arc::new(InterpShader(interp)))
    }
}
