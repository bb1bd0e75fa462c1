//! Shader sources (`.sl` RSL, `.osl` OSL, `.oslgroup` OSL shader groups): read, preprocessed,
//! parsed, checked and lowered by `shadenet-lang` into a material program, as a network file
//! is by [`crate::load_network`] ([`load`]), or into a light shader's program
//! ([`load_light`]; the scene lights it becomes are [`crate::render`]'s). Errors come back rendered as the front end prints them
//! (file:line:column, the source line, a caret, what was expected).

use crate::Compiled;
use shadenet_graph::ir::Program;
use shadenet_lang::ast::{Item, ShaderKind};
use shadenet_lang::{Options, SourceMap};
use std::path::{Path, PathBuf};

/// A shader source that could not be compiled, or is not the kind of shader asked for.
#[derive(Debug, thiserror::Error)]
pub enum ShaderError {
    /// The front end's diagnostics, rendered.
    #[error("{}: the shader does not compile\n{rendered}", path.display())]
    Compile {
        /// The shader file.
        path: PathBuf,
        /// The diagnostics as the front end renders them.
        rendered: String,
    },
    /// The shader compiles but is of another kind than its use needs.
    #[error("{}: `{shader}` is a {found} shader: {wanted}", path.display())]
    Kind {
        /// The shader file.
        path: PathBuf,
        /// The shader's name.
        shader: String,
        /// Its kind (`surface`, `light`, …).
        found: &'static str,
        /// What the use needs, and where the shader would go.
        wanted: &'static str,
    },
}

/// Reads and compiles the surface shader file at `path` (its first shader) with `#include`
/// search folders `include` and macros `defines` (`NAME` or `NAME=VALUE`) into a material.
/// The material is named after the shader; relative texture names are relative to the
/// file's folder. A light shader is refused, naming where it goes ([`load_light`]).
pub fn load(path: &Path, include: &[PathBuf], defines: &[String]) -> Result<Compiled, ShaderError> {
    let (compiled, kind) = load_any(path, include, defines)?;
    if kind == ShaderKind::Light {
        return Err(ShaderError::Kind {
            path: path.to_path_buf(),
            shader: compiled.program.name,
            found: "light",
            wanted: "a material needs a surface shader (a light shader is a scene light: [[lights]] type = \"shader\")",
        });
    }
    Ok(compiled)
}

/// [`load`] of a shader of any kind that compiles (surface or light), and its kind: what
/// `shadenet check` and `compile` show.
pub fn load_any(
    path: &Path,
    include: &[PathBuf],
    defines: &[String],
) -> Result<(Compiled, ShaderKind), ShaderError> {
    let (mut program, kind) = compile_file(path, include, defines)?;
    let dir = path.parent().unwrap_or(Path::new(""));
    program.resolve_textures(dir);
    let compiled = Compiled {
        program,
        lights: Vec::new(),
    };
    Ok((compiled, kind))
}

/// Reads and compiles the light shader file at `path` (its first shader) into its light
/// program (`shadenet_graph::nodes::shader_light`); any other kind is refused.
pub fn load_light(path: &Path) -> Result<Program, ShaderError> {
    let (program, kind) = compile_file(path, &[], &[])?;
    if kind != ShaderKind::Light {
        return Err(ShaderError::Kind {
            path: path.to_path_buf(),
            shader: program.name,
            found: shadenet_lang::lower::kind_name(kind),
            wanted: "a scene light needs a light shader (a surface shader is a material: [materials.NAME] network = …)",
        });
    }
    Ok(program)
}

/// The file's first shader compiled, and its kind.
fn compile_file(
    path: &Path,
    include: &[PathBuf],
    defines: &[String],
) -> Result<(Program, ShaderKind), ShaderError> {
    if path.extension().is_some_and(|e| e == GROUP_EXTENSION) {
        // A group's program is a material (its layers are surfaces and patterns).
        return load_group(path, include, defines).map(|c| (c.program, ShaderKind::Surface));
    }
    let options = front_end_options(include, defines, path.parent().unwrap_or(Path::new("")));
    let mut sources = SourceMap::new();
    let fail = |sources: &SourceMap, d| compile_error(path, sources, d);
    let parsed =
        shadenet_lang::parse_file(&mut sources, path, &options).map_err(|d| fail(&sources, d))?;
    let program = shadenet_lang::lower::compile(&parsed, None).map_err(|d| fail(&sources, d))?;
    let kind = parsed
        .file
        .items
        .iter()
        .find_map(|i| match i {
            Item::Shader(s) => Some(s.kind),
            _ => None,
        })
        .unwrap_or(ShaderKind::Surface);
    Ok((program, kind))
}

/// What answers `gettextureinfo` for a shader whose textures are relative to `dir` (as
/// [`shadenet_graph::ir::Program::resolve_textures`] resolves them): the file's header, read
/// by the texture system's decoder within its memory budget, once per file name (a shader
/// asks several queries of one file; a group's layers share the source).
fn texture_info(dir: &Path) -> shadenet_lang::TextureInfoSource {
    type Answer = Result<shadenet_lang::TextureInfo, String>;
    let dir = dir.to_path_buf();
    let read = move |name: &str| -> Answer {
        let p = Path::new(name);
        let path = if p.is_relative() {
            dir.join(p)
        } else {
            p.to_path_buf()
        };
        let budget = shadenet_runtime::texture::cache::budget_bytes().map_err(|e| e.to_string())?;
        let (width, height, channels) = shadenet_runtime::texture::decode::header(&path, budget)?;
        Ok(shadenet_lang::TextureInfo {
            width,
            height,
            channels: channels as u32,
        })
    };
    let seen = std::sync::Mutex::new(std::collections::HashMap::<String, Answer>::new());
    shadenet_lang::TextureInfoSource(std::sync::Arc::new(move |name: &str| {
        let mut seen = seen
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        seen.entry(name.to_string())
            .or_insert_with(|| read(name))
            .clone()
    }))
}

/// The front end's options for `-I` folders `include` and `-D` macros `defines`, with
/// `gettextureinfo` reading textures relative to `dir` (as the loader resolves them).
fn front_end_options(include: &[PathBuf], defines: &[String], dir: &Path) -> Options {
    let mut options = Options {
        include_dirs: include.to_vec(),
        texture_info: Some(texture_info(dir)),
        ..Options::default()
    };
    for d in defines {
        options = options.define(d);
    }
    options
}

/// The error of `path`'s shader: every diagnostic, rendered against `sources`.
fn compile_error(path: &Path, sources: &SourceMap, d: shadenet_lang::Diagnostics) -> ShaderError {
    ShaderError::Compile {
        path: path.to_path_buf(),
        rendered: d.render(sources).trim_end().to_string(),
    }
}

/// Applies `set` overrides `(shader, parameter, value)` to a shader's program, as scenes give
/// them (`"shader.param" = value`, the shader named as in its file; a value is a number or a
/// list of numbers). The error names the override.
pub fn set_overrides(
    program: &mut Program,
    overrides: &[(String, String, serde_json::Value)],
) -> Result<(), String> {
    for (node, input, value) in overrides {
        // A parameter named `node.input` itself: a group layer's, a displacement shader's.
        let full = format!("{node}.{input}");
        let name = if program.params.iter().any(|p| p.name == full) {
            full.as_str()
        } else if node == &program.name {
            input.as_str()
        } else {
            return Err(format!(
                "set \"{full}\": the shader is `{}` (write \"{}.{input}\"; a group layer's or a displacement shader's parameter is \"layer.NAME\" or \"displacement.NAME\")",
                program.name, program.name
            ));
        };
        let values = json_numbers(value).ok_or_else(|| {
            format!("set \"{full}\": {value} is not a number or a list of numbers")
        })?;
        set_param(program, name, &values).map_err(|e| format!("set \"{full}\": {e}"))?;
    }
    Ok(())
}

/// A JSON number or array of numbers as floats.
fn json_numbers(value: &serde_json::Value) -> Option<Vec<f64>> {
    match value {
        serde_json::Value::Array(a) => a.iter().map(|v| v.as_f64()).collect(),
        v => v.as_f64().map(|x| vec![x]),
    }
}

/// Reads and compiles surface shader `path` with displacement shader `displacement` (each
/// its file's first shader; RSL or OSL, not groups) into one material that shades with the
/// displaced normal (`shadenet_lang::lower::compile_displaced`): the displacement's
/// parameters are `displacement.NAME`; relative texture names in both are relative to the
/// surface shader's folder.
pub fn load_displaced(
    path: &Path,
    displacement: &Path,
    include: &[PathBuf],
    defines: &[String],
) -> Result<Compiled, ShaderError> {
    let dir = path.parent().unwrap_or(Path::new(""));
    let options = front_end_options(include, defines, dir);
    let parse = |file: &Path, sources: &mut SourceMap| {
        shadenet_lang::parse_file(sources, file, &options)
            .map_err(|d| compile_error(file, sources, d))
    };
    let mut sources = SourceMap::new();
    let surface = parse(path, &mut sources)?;
    let disp = parse(displacement, &mut sources)?;
    let mut program = shadenet_lang::lower::compile_displaced(&surface, &disp)
        .map_err(|d| compile_error(path, &sources, d))?;
    program.resolve_textures(dir);
    Ok(Compiled {
        program,
        lights: Vec::new(),
    })
}

/// The extension of OSL shader-group files (`shade --group` reads any name).
pub const GROUP_EXTENSION: &str = "oslgroup";

/// Reads an OSL shader group in OSL's serialized text (`param`, `shader`, `connect`
/// statements) and the `NAME.osl` source of each shader it names (in the group file's
/// folder, then `include`), and compiles the group into one material named after its last
/// layer; its parameters are named `layer.param`.
pub fn load_group(
    path: &Path,
    include: &[PathBuf],
    defines: &[String],
) -> Result<Compiled, ShaderError> {
    let dir = path.parent().unwrap_or(Path::new(""));
    let options = front_end_options(include, defines, dir);
    let mut sources = SourceMap::new();
    let fail = |sources: &SourceMap, d| compile_error(path, sources, d);
    let loaded =
        shadenet_lang::group::load(&mut sources, path, &options).map_err(|d| fail(&sources, d))?;
    let mut program =
        shadenet_lang::lower::compile_group(&loaded).map_err(|d| fail(&sources, d))?;
    program.resolve_textures(dir);
    Ok(Compiled {
        program,
        lights: Vec::new(),
    })
}

/// Sets parameter `name` of `program` to `values` (one number for a float or int, one or
/// three for a color or vec3: one is repeated), as `set` overrides in scenes and `--param`
/// on the command line do. The error names the parameter and, for an unknown one, lists
/// the program's parameters.
pub fn set_param(
    program: &mut shadenet_graph::ir::Program,
    name: &str,
    values: &[f64],
) -> Result<(), String> {
    use shadenet_graph::ConstValue as C;
    let names: Vec<String> = program.params.iter().map(|p| p.name.clone()).collect();
    let Some(param) = program.params.iter_mut().find(|p| p.name == name) else {
        let list = if names.is_empty() {
            "it has none".to_string()
        } else {
            format!("its parameters: {}", names.join(", "))
        };
        return Err(format!(
            "`{}` has no parameter `{name}` ({list})",
            program.name
        ));
    };
    let ok = values
        .iter()
        .all(|x| x.is_finite() && x.abs() <= f32::MAX as f64);
    let three = match values {
        [x] => Some([*x; 3]),
        [a, b, c] => Some([*a, *b, *c]),
        _ => None,
    };
    let v = match (&param.default, values) {
        _ if !ok => None,
        (C::Float(_), [x]) => Some(C::Float(*x)),
        (C::Int(_), [x]) if x.fract() == 0.0 && x.abs() <= i32::MAX as f64 => {
            Some(C::Int(*x as i32))
        }
        (C::Color(_), _) => three.map(C::Color),
        (C::Vec3(_), _) => three.map(C::Vec3),
        _ => None,
    };
    let shown: Vec<String> = values.iter().map(|x| x.to_string()).collect();
    param.default = v.ok_or_else(|| {
        format!(
            "parameter `{name}` is a {}: ({}) is not one",
            param.ty,
            shown.join(", ")
        )
    })?;
    Ok(())
}
