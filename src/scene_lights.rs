//! A scene's light shaders (`[[lights]] type = "shader"`) made lights: each compiled once by
//! [`crate::shader::load_light`], its `set` overrides applied, optimized with its parameters
//! baked in, compiled by the JIT (or the interpreter, for renders on the interpreter), and
//! appended to the scene's lights as a `LightKind::Shader` (positional or
//! directional: the runtime evaluates it per light sample on every back end) or, for an
//! ambient light shader, as an ambient light whose power is its `Cl`, evaluated once.
//!
//! Owns the checks a light program must pass to be sampled (what it may read); must not
//! sample it (`shadenet_runtime::lights` does).

use shadenet_graph::ir::Program;
use shadenet_graph::nodes::shader_light::{self, ShaderLightForm, SharedLightProgram};
use shadenet_graph::nodes::{LightDesc, LightKind};
use shadenet_graph::opt::{self, Specialization};
use shadenet_runtime::light_shader::ShaderLight;
use shadenet_runtime::{Fragment, InterpBackend, Interpreter, ShadeCtx, ShadeEnv};
use shadenet_tracer::scene::Scene;
use std::path::Path;
use std::sync::Arc;

/// A scene light's shader that could not be compiled or used as a light.
#[derive(Debug, thiserror::Error)]
#[error("{light} ({file}): {message}")]
pub struct ShaderLightError {
    /// The light's key, `lights[i]`.
    pub light: String,
    /// Its shader file.
    pub file: String,
    /// What is wrong.
    pub message: String,
}

/// Compiles every light shader of `scene` and appends the lights to `scene.lights` (in the
/// order the file gives them, after its built-in lights), emptying `scene.shader_lights`.
/// `from_disk`: false for a scene embedded in the binary, whose shader files cannot be read;
/// `jit`: compile the light programs with the JIT (else they run on the interpreter; the two
/// agree bit for bit).
pub fn compile(scene: &mut Scene, from_disk: bool, jit: bool) -> Result<(), ShaderLightError> {
    for r in std::mem::take(&mut scene.shader_lights) {
        let fail = |message: String| ShaderLightError {
            light: r.key.clone(),
            file: r.file.display().to_string(),
            message,
        };
        if !from_disk {
            return Err(fail("shader sources are read from disk only".into()));
        }
        let name = format!("light{}", scene.lights.len());
        let desc = light(&r.file, &r.overrides, name, jit).map_err(fail)?;
        scene.lights.push(desc);
    }
    Ok(())
}

/// The light shader in `file`, its parameters set by `overrides` (`(shader, parameter,
/// value)`, as a scene's `set` gives them), as a light named `name`, its program compiled
/// by the JIT (`jit`) or the interpreter.
pub fn light(
    file: &Path,
    overrides: &[(String, String, serde_json::Value)],
    name: String,
    jit: bool,
) -> Result<LightDesc, String> {
    let mut program = crate::shader::load_light(file).map_err(|e| e.to_string())?;
    crate::shader::set_overrides(&mut program, overrides)?;
    shadenet_graph::ir::validate(&program)
        .map_err(|e| format!("internal error: invalid IR: {e}"))?;
    let (program, report) = opt::run(&program, &Specialization::default());
    let needs = &report.needs;
    let refused = [
        (
            needs.lights || needs.ambient,
            "reads other lights (illuminance, diffuse, ambient…)",
        ),
        (
            needs.trace || needs.occlusion,
            "traces rays or asks occlusion",
        ),
        (
            !needs.textures.is_empty(),
            "reads textures (not built for light shaders yet)",
        ),
    ];
    if let Some((_, what)) = refused.iter().find(|(bad, _)| *bad) {
        return Err(format!(
            "light shader `{}` {what}: a light's program may read only Ps and its parameters",
            program.name
        ));
    }
    let form = shader_light::form(&program)?;
    let (kind, power) = match form {
        ShaderLightForm::Ambient => {
            if !needs.streams.is_empty() {
                return Err(format!(
                    "ambient light shader `{}` depends on Ps: an ambient light's Cl must be the same everywhere (lights without illuminate or solar are evaluated once)",
                    program.name
                ));
            }
            (LightKind::Ambient, ambient_cl(&program)?)
        }
        _ => {
            let eval = if jit {
                ShaderLight::new(&program, &shadenet_jit::JitBackend::new())?
            } else {
                ShaderLight::new(&program, &InterpBackend)?
            };
            (
                LightKind::Shader {
                    program: SharedLightProgram::new(Arc::new(eval))?,
                },
                [1.0; 3],
            )
        }
    };
    LightDesc::new(name, kind, power).map_err(|e| e.to_string())
}

/// An ambient light shader's `Cl`, which reads no stream: evaluated once (f64).
fn ambient_cl(program: &Program) -> Result<[f64; 3], String> {
    let interp = Interpreter::<f64>::new(program).map_err(|e| e.to_string())?;
    let env = ShadeEnv::default();
    let out = interp.shade(&ShadeCtx::new(Fragment::default(), &env));
    let slot = interp
        .slots()
        .iter()
        .find(|s| s.name == shader_light::OUT_CL)
        .ok_or("no Cl output")?;
    let v = &out.values[slot.offset..slot.offset + 3];
    if out.nonfinite > 0 {
        return Err(format!(
            "ambient light shader `{}` gives a Cl that is not finite",
            program.name
        ));
    }
    Ok([v[0], v[1], v[2]])
}
