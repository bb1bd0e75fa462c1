//! The seam between the tracer and whatever runs compiled materials.
//!
//! The tracer specializes programs itself (one per distinct component mask the ray-match
//! rules produce) and hands each specialized program to a [`ShaderBackend`], getting back a
//! [`Shader`] it calls per hit from every rayon thread (and recursively, from inside a
//! shader's `trace`). [`RuntimeBackend`] adapts any `shadenet_runtime::Backend` (the
//! interpreter, the JIT) to it, [`BatchedBackend`] one that shades best in large batches
//! (the GPU); [`InterpBackend`] is the interpreter, the reference.
//!
//! A shader has two entries: [`Shader::shade`] (one fragment: every hit in the immediate
//! mode, and secondary hits shaded from inside a `trace` in both modes) and
//! [`Shader::shade_many`] (a batch of fragments sharing environment and component mask: the
//! camera hits of the renderer's deferred mode, see `render`), which maps to the runtime's
//! `Material::shade_many`.

use shadenet_graph::ir::Program;
use shadenet_runtime::{
    Backend, BatchResult, BatchTimes, Fragments, Material, SceneServices, ShadeCtx, ShadeEnv,
    ShadeOut, packed_index, packed_len,
};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A compiled material: shades one fragment, writing every output (each component part
/// separately) into `out`, laid out as the interpreter lays out the program's outputs.
pub trait Shader: Send + Sync {
    /// Shades one fragment. May be called recursively (a shader's `trace` shades another
    /// hit on the same thread before this call returns).
    fn shade(&self, ctx: &ShadeCtx, out: &mut ShadeOut<f32>);

    /// Loop executions stopped at the IR's iteration limit over all calls so far (see
    /// `Material::loop_limits`); 0 where the back end does not count.
    fn loop_limits(&self) -> u64 {
        0
    }

    /// Shades a batch: every fragment with the same environment and component mask, and
    /// fragment `i` with the scene services `scene.fragment(i)` where the scene gives
    /// per-fragment services (see `SceneServices::fragment`), else `scene`. `out` is
    /// cleared and receives the outputs in the packets' layout of `Material::shade_many`
    /// (fragment `i`'s float `k` at `shadenet_runtime::packed_index(width, i, k)`, where
    /// `width` is `out.len()` over [`shadenet_runtime::packed_len`]`(1, frags.len())`). The
    /// default calls [`Shader::shade`] once per fragment.
    fn shade_many(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        frags: &Fragments,
        out: &mut Vec<f32>,
    ) -> BatchResult {
        let t = Instant::now();
        out.clear();
        let mut one = ShadeOut::default();
        let mut nonfinite = 0u64;
        for i in 0..frags.len() {
            let ctx = ShadeCtx {
                frag: frags.get(i),
                env,
                mask,
                scene: shadenet_runtime::fragment_services(scene, i),
            };
            self.shade(&ctx, &mut one);
            nonfinite += one.nonfinite as u64;
            let w = one.values.len();
            out.resize(packed_len(w, frags.len()), 0.0);
            for (k, x) in one.values.iter().enumerate() {
                out[packed_index(w, i, k)] = *x;
            }
        }
        BatchResult {
            nonfinite,
            times: BatchTimes {
                kernels: t.elapsed(),
                ..BatchTimes::default()
            },
        }
    }
}

/// Compiles specialized programs into shaders.
pub trait ShaderBackend: Send + Sync {
    /// The back end's name, for the render summary.
    fn name(&self) -> &str;
    /// Compiles one (already specialized and optimized) program.
    fn compile(&self, program: &Program) -> Result<Arc<dyn Shader>, String>;
    /// Whether the back end shades best in large batches (the GPU: a dispatch per hit would
    /// cost more than the shading), so that the renderer shades camera hits deferred, in
    /// batches through [`Shader::shade_many`]. Default: false (shade each hit as it is found).
    fn prefers_batches(&self) -> bool {
        false
    }
}

/// Any runtime back end as a shader back end. The runtime's materials are re-entrant (the
/// interpreter takes fresh registers when re-entered, compiled code keeps its state on the
/// stack), so recursive shading needs nothing more here.
pub struct RuntimeBackend(pub Arc<dyn Backend>);

/// A runtime material as a shader: [`Shader::shade`] is `Material::shade`,
/// [`Shader::shade_many`] is `Material::shade_many`.
pub struct MaterialShader(pub Arc<dyn Material>);

impl Shader for MaterialShader {
    fn shade(&self, ctx: &ShadeCtx, out: &mut ShadeOut<f32>) {
        out.values.resize(self.0.width(), 0.0);
        out.nonfinite = self.0.shade(ctx, &mut out.values);
    }

    fn loop_limits(&self) -> u64 {
        self.0.loop_limits()
    }

    fn shade_many(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        frags: &Fragments,
        out: &mut Vec<f32>,
    ) -> BatchResult {
        out.clear();
        out.resize(packed_len(self.0.width(), frags.len()), 0.0);
        self.0.shade_many(env, mask, scene, frags, out)
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

/// A runtime back end that shades best in large batches (the GPU) as a shader back end:
/// [`RuntimeBackend`] with [`ShaderBackend::prefers_batches`] true, so the renderer shades
/// camera hits in deferred batches.
pub struct BatchedBackend(pub Arc<dyn Backend>);

impl ShaderBackend for BatchedBackend {
    fn name(&self) -> &str {
        self.0.name()
    }

    fn compile(&self, program: &Program) -> Result<Arc<dyn Shader>, String> {
        RuntimeBackend(self.0.clone()).compile(program)
    }

    fn prefers_batches(&self) -> bool {
        true
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
