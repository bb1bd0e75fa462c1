//! Rendering through the runtime's back ends: adapters from [`Backend`] (and the f64
//! interpreter, the accuracy reference) to the tracer's [`ShaderBackend`], so that a scene
//! renders with any back end and the back end that actually runs each material is known.

use shadenet_graph::ir::Program;
use shadenet_runtime::{Backend, Interpreter, Scratch, ShadeCtx, ShadeOut};
use shadenet_tracer::shader::{MaterialShader, Shader, ShaderBackend};
use std::cell::RefCell;
use std::sync::{Arc, Mutex};

/// A runtime [`Backend`] as the tracer's shader back end. It records, per compiled shader,
/// the back end that runs it (`jit`, or `interp` where the JIT fell back, with why).
pub struct RuntimeShaders {
    backend: Box<dyn Backend>,
    used: Mutex<Vec<(String, Option<String>)>>,
    batched: bool,
}

impl RuntimeShaders {
    /// Wraps a back end (camera hits shaded immediately).
    pub fn new(backend: Box<dyn Backend>) -> RuntimeShaders {
        RuntimeShaders {
            backend,
            used: Mutex::new(Vec::new()),
            batched: false,
        }
    }

    /// Wraps a back end that prefers batches (the GPU: the renderer shades camera hits
    /// deferred, in batches).
    pub fn batched(backend: Box<dyn Backend>) -> RuntimeShaders {
        RuntimeShaders {
            batched: true,
            ..RuntimeShaders::new(backend)
        }
    }

    /// Per shader compiled so far: the material's name and, where the back end fell back to
    /// the interpreter, why.
    pub fn used(&self) -> Vec<(String, Option<String>)> {
        self.used.lock().map(|u| u.clone()).unwrap_or_default()
    }

    /// The back end actually used: its name, or `interp (fallback from NAME: k of n
    /// shaders)` when some shaders fell back.
    pub fn actual(&self) -> String {
        let used = self.used();
        let fell = used.iter().filter(|u| u.1.is_some()).count();
        if fell == 0 {
            self.backend.name().to_string()
        } else if fell == used.len() {
            format!("interp (fallback from {})", self.backend.name())
        } else {
            format!(
                "{}+interp ({fell} of {} shaders fell back)",
                self.backend.name(),
                used.len()
            )
        }
    }
}

impl ShaderBackend for RuntimeShaders {
    fn name(&self) -> &str {
        self.backend.name()
    }

    fn prefers_batches(&self) -> bool {
        self.batched
    }

    fn compile(&self, program: &Program) -> Result<Arc<dyn Shader>, String> {
        let m = self
            .backend
            .compile_program(program, std::time::Duration::ZERO)
            .map_err(|e| e.to_string())?;
        if let Ok(mut u) = self.used.lock() {
            u.push((program.name.clone(), m.info().fallback.clone()));
        }
        Ok(Arc::new(MaterialShader(m)))
    }
}

/// The interpreter in f64 as the tracer's shader back end: the accuracy reference of
/// rendered benchmarks (outputs rounded to f32 only when stored in the film).
#[derive(Clone, Copy, Debug, Default)]
pub struct F64Shaders;

struct F64Shader(Interpreter<f64>);

thread_local! {
    static SCRATCH64: RefCell<Vec<(Scratch<f64>, ShadeOut<f64>)>> = const { RefCell::new(Vec::new()) };
}

impl Shader for F64Shader {
    fn shade(&self, ctx: &ShadeCtx, out: &mut ShadeOut<f32>) {
        let (mut scratch, mut o) = SCRATCH64
            .with(|s| s.borrow_mut().pop())
            .unwrap_or_else(|| (Scratch::default(), ShadeOut::default()));
        self.0.shade_with(ctx, &mut scratch, &mut o);
        out.values.clear();
        out.values.extend(o.values.iter().map(|v| *v as f32));
        out.nonfinite = o.nonfinite;
        SCRATCH64.with(|s| s.borrow_mut().push((scratch, o)));
    }
}

impl ShaderBackend for F64Shaders {
    fn name(&self) -> &str {
        "interp-f64"
    }

    fn compile(&self, program: &Program) -> Result<Arc<dyn Shader>, String> {
        let interp = Interpreter::<f64>::new(program).map_err(|e| e.to_string())?;
        Ok(Arc::new(F64Shader(interp)))
    }
}
