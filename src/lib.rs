#![doc = include_str!("../README.md")]
//!
//! ## Crate map
//!
//! The facade re-exports the member crates: [`graph`] (networks, node library, linker, IR,
//! op semantics), [`runtime`] (shading context, lights, interpreter, back-end traits),
//! [`jit`] (the Cranelift back end) and [`tracer`] (scenes, BVH, passes, film); [`shade`]
//! shades a network over a grid (or any fragments) without a renderer, [`lights`] parses
//! the one-line light strings of `shade --light`, [`render`] links a scene's materials and
//! hands them to the tracer ([`scene_lights`] compiles its light shaders into lights),
//! [`output`] writes PNG and EXR images, [`mtlx`] reads MaterialX documents, [`shader`]
//! compiles shader sources (`.sl`, `.osl`, `.oslgroup`) and
//! finds the MaterialX libraries, [`genosl`] compiles MaterialX's own OSL implementations,
//! [`generate`] builds
//! networks for benchmarks (the multiplication tree) and [`bench`] is `shadenet bench`. It owns the `shadenet` CLI and must not
//! add shading semantics of its own.

pub mod bench;
pub mod generate;
pub mod genosl;
pub mod lights;
pub mod mtlx;
pub mod output;
pub mod render;
pub mod scene_lights;
pub mod shade;
pub mod shader;
pub mod specialize;

pub use shadenet_graph as graph;
pub use shadenet_jit as jit;
pub use shadenet_lang as lang;
pub use shadenet_runtime as runtime;
pub use shadenet_tracer as tracer;

pub use mtlx::{MtlxOptions, compile_mtlx};
pub use shadenet_graph::{CompileError, Compiled, NodeLibrary, compile_json};

use std::path::{Path, PathBuf};

/// A network file that could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read (missing, not a regular file, over the size limit).
    #[error(transparent)]
    Input(#[from] shadenet_runtime::input::InputError),
    /// The file is not a valid network.
    #[error("{}", path.display())]
    Compile {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        source: CompileError,
    },
}

/// Reads, links and lowers a network file with the standard library. The material is named
/// after the file's stem unless the network names it, and relative texture paths are made
/// relative to the file's directory.
pub fn load_network(path: &Path) -> Result<Compiled, LoadError> {
    let src = shadenet_runtime::input::read_to_string(
        path,
        shadenet_runtime::input::FileKind::Text,
        "network",
    )?;
    let mut compiled =
        compile_json(&src, &NodeLibrary::standard()).map_err(|source| LoadError::Compile {
            path: path.to_path_buf(),
            source,
        })?;
    if compiled.program.name == "material"
        && let Some(stem) = path.file_stem()
    {
        compiled.program.name = stem.to_string_lossy().into_owned();
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    compiled.program.resolve_textures(dir);
    Ok(compiled)
}
pub use shadenet_runtime::{Fragment, Interpreter, ShadeCtx, ShadeEnv};
