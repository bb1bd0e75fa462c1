//! Shader sources (`.sl`; `.osl` is parsed, compiled with issue 22): read, preprocessed,
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
