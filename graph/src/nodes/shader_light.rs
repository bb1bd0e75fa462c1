//! Lights written as shaders (RSL `light` shaders, compiled by shadenet-lang): the contract
//! between the program such a light carries ([`super::LightKind::Shader`], through a
//! [`LightProgram`] that evaluates it) and the runtime that samples it. The program is
//! evaluated once per light sample with the shaded point as the fragment's `P` stream; its
//! instance parameters are already set. Its outputs:
//!
//! - [`OUT_CL`] (color): what arrives at the point, before shadowing;
//! - [`OUT_FROM`] (vec3): the light's position — a positional light (`illuminate`): the
//!   direction to it is `from - P` and shadow rays end there;
//! - or [`OUT_AXIS`] (vec3): the direction the light travels — a directional light
//!   (`solar`): the direction to it is `-axis`, shadow rays go far along it.
//!
//! A light shader with neither (an ambient light) is not a `Shader` light: its `Cl` is
//! evaluated once and becomes an ambient light's power. Owns the names, the check and the
//! evaluator's interface; the evaluator is the runtime's (`shadenet_runtime::light_shader`),
//! which the light list holds as a trait object so that sampling a light does not depend on
//! the interpreter that evaluates it.

use crate::ir::Program;
use crate::types::Type;
use std::sync::Arc;

/// The output holding the light's color as it arrives at the shaded point.
pub const OUT_CL: &str = "Cl";
/// The output of a positional light: its position.
pub const OUT_FROM: &str = "from";
/// The output of a directional light: the direction its light travels.
pub const OUT_AXIS: &str = "axis";

/// Where a light shader's light comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShaderLightForm {
    /// From a position ([`OUT_FROM`]): `illuminate`.
    Positional,
    /// From a direction ([`OUT_AXIS`]): `solar`.
    Directional,
    /// From nowhere: only [`OUT_CL`], an ambient light.
    Ambient,
}

/// The form of a light shader's program, or what is wrong with its outputs (a color
/// [`OUT_CL`], at most one of a vec3 [`OUT_FROM`] or [`OUT_AXIS`], nothing else).
pub fn form(program: &Program) -> Result<ShaderLightForm, String> {
    let ty = |name: &str| {
        program
            .outputs
            .iter()
            .find(|o| o.name == name)
            .map(|o| program.ty(o.value))
    };
    if ty(OUT_CL) != Some(Type::Color) {
        return Err(format!(
            "`{}` is not a light shader's program: it has no color output `{OUT_CL}`",
            program.name
        ));
    }
    if let Some(o) = program
        .outputs
        .iter()
        .find(|o| ![OUT_CL, OUT_FROM, OUT_AXIS].contains(&o.name.as_str()))
    {
        return Err(format!(
            "`{}` is not a light shader's program: it has an output `{}`",
            program.name, o.name
        ));
    }
    let (from, axis) = (ty(OUT_FROM), ty(OUT_AXIS));
    match (from, axis) {
        (None, None) => Ok(ShaderLightForm::Ambient),
        (Some(Type::Vec3), None) => Ok(ShaderLightForm::Positional),
        (None, Some(Type::Vec3)) => Ok(ShaderLightForm::Directional),
        _ => Err(format!(
            "`{}` is not a light shader's program: it needs one vec3 output `{OUT_FROM}` or `{OUT_AXIS}`",
            program.name
        )),
    }
}

/// A light shader's program prepared for evaluation (the runtime's interpreter implements
/// it).
pub trait LightProgram: Send + Sync + std::fmt::Debug {
    /// The program evaluated.
    fn program(&self) -> &Program;
    /// `Cl` and `from` (positional) or `axis` (directional) at shaded point `p`, non-finite
    /// components made 0.
    fn eval(&self, p: [f32; 3]) -> ([f32; 3], [f32; 3]);
}

/// A positional or directional light shader's evaluator, shared by every copy of its light;
/// equal when the programs are.
#[derive(Clone, Debug)]
pub struct SharedLightProgram {
    eval: Arc<dyn LightProgram>,
    form: ShaderLightForm,
}

impl SharedLightProgram {
    /// Wraps an evaluator whose program is a positional or directional light's ([`form`]);
    /// an ambient light shader is refused (it is evaluated once and is an ambient light).
    pub fn new(eval: Arc<dyn LightProgram>) -> Result<SharedLightProgram, String> {
        match form(eval.program())? {
            ShaderLightForm::Ambient => Err(format!(
                "`{}` is an ambient light shader: evaluate its `{OUT_CL}` once as an ambient light's power",
                eval.program().name
            )),
            form => Ok(SharedLightProgram { eval, form }),
        }
    }

    /// Positional or directional.
    pub fn form(&self) -> ShaderLightForm {
        self.form
    }

    /// The evaluator.
    pub fn eval(&self) -> &dyn LightProgram {
        self.eval.as_ref()
    }
}

impl PartialEq for SharedLightProgram {
    fn eq(&self, other: &Self) -> bool {
        self.form == other.form && self.eval.program() == other.eval.program()
    }
}
