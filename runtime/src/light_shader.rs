//! Light shaders as lights: a light's program (`LightKind::Shader`, the outputs of
//! `shadenet_graph::nodes::shader_light`) compiled once by a back end ([`ShaderLight::new`]:
//! the interpreter or the JIT, which agree bit for bit) and run per light sample with the
//! shaded point as the fragment's `P`. The light holds it as a `shader_light::LightProgram`,
//! which [`crate::lights::sample`] calls; every back end samples lights through that
//! function (the interpreter, the JIT's light intrinsic, the GPU's host step of light
//! samples).
//!
//! Owns the evaluation of one sample; what a sample is (direction, shadow-ray end) is
//! [`crate::lights`]'.

use crate::backend::{Backend, Material};
use crate::ctx::{Fragment, ShadeCtx, ShadeEnv};
use crate::interp::output_layout;
use shadenet_graph::ir::Program;
use shadenet_graph::nodes::shader_light::{
    self, LightProgram, OUT_AXIS, OUT_CL, OUT_FROM, ShaderLightForm,
};
use std::cell::RefCell;
use std::sync::Arc;
use std::time::Duration;

thread_local! {
    /// Each thread's output floats for light programs, so a sample allocates nothing (a light
    /// program samples no light, so no evaluation runs inside another).
    static OUT: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
}

/// A light shader's program, compiled.
pub struct ShaderLight {
    program: Program,
    material: Arc<dyn Material>,
    env: ShadeEnv,
    /// Offsets of `Cl` and of `from` / `axis` in the output floats, and their count.
    cl: usize,
    at: usize,
    width: usize,
}

impl std::fmt::Debug for ShaderLight {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShaderLight")
            .field("program", &self.program.name)
            .field("backend", &self.material.info().backend)
            .finish()
    }
}

impl ShaderLight {
    /// Compiles `program`, a positional or directional light shader's that reads no texture,
    /// with `backend`; the error says which rule it breaks or why it did not compile.
    pub fn new(program: &Program, backend: &dyn Backend) -> Result<ShaderLight, String> {
        let at_name = match shader_light::form(program)? {
            ShaderLightForm::Positional => OUT_FROM,
            ShaderLightForm::Directional => OUT_AXIS,
            ShaderLightForm::Ambient => {
                return Err(format!(
                    "`{}` is an ambient light shader: it is evaluated once, not per sample",
                    program.name
                ));
            }
        };
        if !program.textures.is_empty() {
            return Err(format!(
                "light shader `{}` reads textures (not built for light shaders yet)",
                program.name
            ));
        }
        let (slots, width) = output_layout(program);
        let offset = |name: &str| {
            slots
                .iter()
                .find(|s| s.name == name)
                .map(|s| s.offset)
                .ok_or_else(|| format!("`{}` has no output `{name}`", program.name))
        };
        let material = backend
            .compile_program(program, Duration::ZERO)
            .map_err(|e| e.to_string())?;
        Ok(ShaderLight {
            program: program.clone(),
            material,
            env: ShadeEnv::default(),
            cl: offset(OUT_CL)?,
            at: offset(at_name)?,
            width,
        })
    }
}

impl LightProgram for ShaderLight {
    fn program(&self) -> &Program {
        &self.program
    }

    fn eval(&self, p: [f32; 3]) -> ([f32; 3], [f32; 3]) {
        let frag = Fragment {
            p,
            ..Fragment::default()
        };
        let ctx = ShadeCtx::new(frag, &self.env);
        let read = |out: &[f32]| {
            let three = |o: usize| [out[o], out[o + 1], out[o + 2]];
            (three(self.cl), three(self.at))
        };
        OUT.with(|buf| match buf.try_borrow_mut() {
            Ok(mut out) => {
                out.resize(self.width, 0.0);
                self.material.shade(&ctx, &mut out[..self.width]);
                read(&out)
            }
            Err(_) => {
                let mut out = vec![0.0; self.width];
                self.material.shade(&ctx, &mut out);
                read(&out)
            }
        })
    }
}
