//! Shader sources (`.sl` RSL, `.osl` OSL, `.oslgroup` OSL shader groups): read, preprocessed,
//! parsed, checked and lowered by `shadenet-lang` into a material program, as a network file
//! is by [`crate::load_network`]. Errors come back rendered as the front end prints them
//! (file:line:column, the source line, a caret, what was expected).

use crate::Compiled;
use shadenet_lang::{Options, SourceMap};
use std::path::{Path, PathBuf};

/// A shader source that could not be compiled: every diagnostic, rendered.
#[derive(Debug, thiserror::Error)]
#[error("{}: the shader does not compile\n{rendered}", path.display())]
pub struct ShaderError {
    /// The shader file.
    pub path: PathBuf,
    /// The diagnostics as the front end renders them.
    pub rendered: String,
}

/// Reads and compiles the shader file at `path` (its first shader) with `#include` search
/// folders `include` and macros `defines` (`NAME` or `NAME=VALUE`). The material is named
/// after the shader; relative texture names are relative to the file's folder.
pub fn load(path: &Path, include: &[PathBuf], defines: &[String]) -> Result<Compiled, ShaderError> {
    let mut options = Options {
        include_dirs: include.to_vec(),
        ..Options::default()
    };
    for d in defines {
        options = options.define(d);
    }
    let mut sources = SourceMap::new();
    let fail = |sources: &SourceMap, d: shadenet_lang::Diagnostics| ShaderError {
        path: path.to_path_buf(),
        rendered: d.render(sources).trim_end().to_string(),
    };
    if path.extension().is_some_and(|e| e == GROUP_EXTENSION) {
        return load_group(path, include, defines);
    }
    let parsed =
        shadenet_lang::parse_file(&mut sources, path, &options).map_err(|d| fail(&sources, d))?;
    let mut program =
        shadenet_lang::lower::compile(&parsed, None).map_err(|d| fail(&sources, d))?;
    let dir = path.parent().unwrap_or(Path::new(""));
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
    let mut options = Options {
        include_dirs: include.to_vec(),
        ..Options::default()
    };
    for d in defines {
        options = options.define(d);
    }
    let mut sources = SourceMap::new();
    let fail = |sources: &SourceMap, d: shadenet_lang::Diagnostics| ShaderError {
        path: path.to_path_buf(),
        rendered: d.render(sources).trim_end().to_string(),
    };
    let loaded =
        shadenet_lang::group::load(&mut sources, path, &options).map_err(|d| fail(&sources, d))?;
    let mut program =
        shadenet_lang::lower::compile_group(&loaded).map_err(|d| fail(&sources, d))?;
    let dir = path.parent().unwrap_or(Path::new(""));
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
