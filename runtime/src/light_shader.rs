//! Light shaders as lights: a light's program (`LightKind::Shader`, the outputs of
//! `shadenet_graph::nodes::shader_light`) prepared once by [`ShaderLight::new`] and
//! evaluated by the f32 interpreter per light sample with the shaded point as the
//! fragment's `P`. The light holds it as a `shader_light::LightProgram`, which
//! [`crate::lights::sample`] calls; every back end samples lights through that function
//! (the JIT's light intrinsic, the GPU's host step of light samples), so each gets the same
//! bits.
//!
//! Owns the evaluation of one sample; what a sample is (direction, shadow-ray end) is
//! [`crate::lights`]'.

use crate::ctx::{Fragment, ShadeCtx, ShadeEnv};
use crate::interp::{Interpreter, Scratch, ShadeOut, output_layout};
use shadenet_graph::ir::Program;
use shadenet_graph::nodes::shader_light::{
    self, LightProgram, OUT_AXIS, OUT_CL, OUT_FROM, ShaderLightForm,
};
use std::cell::RefCell;

thread_local! {
    /// Each thread's storage for evaluating light programs, so a sample allocates nothing
    /// (a light program samples no light, so no evaluation runs inside another).
    static STORAGE: RefCell<(Scratch<f32>, ShadeOut<f32>)> =
        RefCell::new((Scratch::default(), ShadeOut::default()));
}

/// A light shader's program, prepared for evaluation.
#[derive(Debug)]
pub struct ShaderLight {
    interp: Interpreter<f32>,
    env: ShadeEnv,
    /// Offsets of `Cl` and of `from` / `axis` in the output floats.
    cl: usize,
    at: usize,
}

impl ShaderLight {
    /// Prepares `program`, a positional or directional light shader's that reads no
    /// texture; the error says which rule it breaks.
    pub fn new(program: &Program) -> Result<ShaderLight, String> {
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
        let (slots, _) = output_layout(program);
        let offset = |name: &str| {
            slots
                .iter()
                .find(|s| s.name == name)
                .map(|s| s.offset)
                .ok_or_else(|| format!("`{}` has no output `{name}`", program.name))
        };
        Ok(ShaderLight {
            interp: Interpreter::new(program).map_err(|e| e.to_string())?,
            env: ShadeEnv::default(),
            cl: offset(OUT_CL)?,
            at: offset(at_name)?,
        })
    }
}

impl LightProgram for ShaderLight {
    fn program(&self) -> &Program {
        self.interp.program()
    }

    fn eval(&self, p: [f32; 3]) -> ([f32; 3], [f32; 3]) {
        let frag = Fragment {
            p,
            ..Fragment::default()
        };
        let ctx = ShadeCtx::new(frag, &self.env);
        let read = |out: &ShadeOut<f32>| {
            let three = |o: usize| [out.values[o], out.values[o + 1], out.values[o + 2]];
            (three(self.cl), three(self.at))
        };
        STORAGE.with(|s| match s.try_borrow_mut() {
            Ok(mut s) => {
                let (scratch, out) = &mut *s;
                self.interp.shade_with(&ctx, scratch, out);
                read(out)
            }
            Err(_) => read(&self.interp.shade(&ctx)),
        })
    }
}
