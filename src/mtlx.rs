//! MaterialX documents from files: finding the MaterialX data libraries, reading and caching
//! them once per process, and compiling a `.mtlx` file ([`compile_mtlx`]).
//!
//! This module owns the file side (every file read through `runtime::input`, the search
//! order, the cache); it must not interpret MaterialX, which is `graph::mtlx`'s.

use shadenet_graph::Compiled;
use shadenet_graph::mtlx::{self, Library, MtlxError, Selection};
use shadenet_graph::network::Network;
use shadenet_runtime::input::{FileKind, InputError, read_to_string};
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// The library folders read, in order (nodedefs of earlier folders win).
pub const FOLDERS: &[&str] = &["stdlib", "pbrlib", "bxdf", "cmlib", "lights", "nprlib"];

/// The MaterialX data libraries could not be found or read.
#[derive(Debug, thiserror::Error)]
pub enum LibraryError {
    /// No candidate folder holds the libraries.
    #[error(
        "the MaterialX data libraries were not found; looked in: {looked}. Install them with `pip install materialx` (they ship in the package's `MaterialX/libraries` folder) and pass that folder with --mtlx-libraries or SHADENET_MTLX_LIBRARIES"
    )]
    NotFound {
        /// Where it looked, in order.
        looked: String,
    },
    /// A library file could not be read.
    #[error("cannot read the MaterialX libraries")]
    Read(#[source] InputError),
    /// A library file is not a valid document.
    #[error("a MaterialX library file is invalid")]
    Parse(#[source] Box<MtlxError>),
}

/// Where to look for the libraries and what to shade.
#[derive(Clone, Debug, Default)]
pub struct MtlxOptions {
    /// `--mtlx-libraries`: a `libraries` folder, tried first.
    pub libraries: Option<PathBuf>,
    /// The material or output to shade.
    pub selection: Selection,
}

fn holds_libraries(dir: &Path) -> bool {
    dir.join("stdlib").join("stdlib_defs.mtlx").is_file()
}

/// Finds the libraries folder: `explicit`, then `SHADENET_MTLX_LIBRARIES`, then each
/// `MATERIALX_SEARCH_PATH` entry's `libraries/` (or the entry itself if it is one).
pub fn locate(explicit: Option<&Path>) -> Result<PathBuf, LibraryError> {
    locate_with(explicit, &|k| std::env::var_os(k))
}

/// [`locate`] with the environment given as a function (for tests).
pub fn locate_with(
    explicit: Option<&Path>,
    env: &dyn Fn(&str) -> Option<std::ffi::OsString>,
) -> Result<PathBuf, LibraryError> {
    let mut looked = Vec::new();
    let mut candidates: Vec<(String, PathBuf)> = Vec::new();
    if let Some(p) = explicit {
        candidates.push(("--mtlx-libraries".into(), p.to_path_buf()));
    }
    if let Some(p) = env("SHADENET_MTLX_LIBRARIES") {
        candidates.push(("SHADENET_MTLX_LIBRARIES".into(), PathBuf::from(p)));
    }
    if let Some(sp) = env("MATERIALX_SEARCH_PATH") {
        for e in std::env::split_paths(&sp) {
            candidates.push(("MATERIALX_SEARCH_PATH".into(), e.join("libraries")));
            candidates.push(("MATERIALX_SEARCH_PATH".into(), e));
        }
    }
    for (from, dir) in candidates {
        if holds_libraries(&dir) {
            return Ok(dir);
        }
        looked.push(format!("{} ({from})", dir.display()));
    }
    if looked.is_empty() {
        looked.push(
            "nowhere: neither --mtlx-libraries, SHADENET_MTLX_LIBRARIES nor MATERIALX_SEARCH_PATH is set"
                .into(),
        );
    }
    Err(LibraryError::NotFound {
        looked: looked.join(", "),
    })
}

/// Reads and indexes the libraries in `dir`; cached per process and folder.
pub fn library(dir: &Path) -> Result<&'static Library, LibraryError> {
    static CACHE: OnceLock<Mutex<HashMap<PathBuf, &'static Library>>> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    if let Some(l) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(dir) {
        return Ok(l);
    }
    // Leaked on purpose: one library per folder per process, shared by every compile.
    let lib: &'static Library = Box::leak(Box::new(read_library(dir)?));
    cache
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(dir.to_path_buf(), lib);
    Ok(lib)
}

/// Reads every library document in `dir`'s [`FOLDERS`] (files in name order) and indexes
/// them, uncached: what [`library`] does once per folder (and what the benchmark times).
pub fn read_library(dir: &Path) -> Result<Library, LibraryError> {
    let mut docs = Vec::new();
    for folder in FOLDERS {
        let Ok(entries) = std::fs::read_dir(dir.join(folder)) else {
            continue;
        };
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "mtlx") && p.is_file())
            .collect();
        files.sort();
        for f in files {
            let text = read_to_string(&f, FileKind::Text, "MaterialX library")
                .map_err(LibraryError::Read)?;
            let doc = mtlx::parse(&f.display().to_string(), &text)
                .map_err(|e| LibraryError::Parse(Box::new(e)))?;
            docs.push((folder.to_string(), doc));
        }
    }
    Ok(Library::new(docs))
}

/// A MaterialX document that could not be compiled.
#[derive(Debug, thiserror::Error)]
pub enum MtlxLoadError {
    /// The document could not be read.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The libraries are missing or unreadable.
    #[error(transparent)]
    Libraries(#[from] LibraryError),
    /// The document is invalid (the error names file:line:column).
    #[error(transparent)]
    Document(#[from] Box<MtlxError>),
}

/// Reads a `.mtlx` file, finds the libraries (`libraries`, else as [`locate`] says) and
/// translates the selected outputs to a network, to be linked against the returned
/// library's atoms (the renderer applies a scene's `set` overrides in between); and names
/// the uniform geometric properties its string-valued `geompropvalueuniform` nodes read
/// ([`mtlx::network_reading`]: the renderer specializes the material by them).
pub fn mtlx_network(
    path: &Path,
    libraries: Option<&Path>,
    selection: &Selection,
) -> Result<(Network, &'static Library, BTreeSet<String>), MtlxLoadError> {
    let text = read_to_string(path, FileKind::Text, "MaterialX document")?;
    let lib = library(&locate(libraries)?)?;
    let (net, read) = mtlx::network_reading(&path.display().to_string(), &text, lib, selection)
        .map_err(Box::new)?;
    Ok((net, lib, read))
}

/// Reads a `.mtlx` file and says which lobes of its selected material(s) are left after
/// optimizing with `spec` (`graph::closure::probe`; `compile --stats` prints them).
pub fn mtlx_lobes(
    path: &Path,
    opts: &MtlxOptions,
    spec: &shadenet_graph::opt::Specialization,
) -> Result<Vec<shadenet_graph::closure::probe::LobeStat>, MtlxLoadError> {
    let text = read_to_string(path, FileKind::Text, "MaterialX document")?;
    let lib = library(&locate(opts.libraries.as_deref())?)?;
    let file = path.display().to_string();
    Ok(mtlx::lobes(&file, &text, lib, &opts.selection, spec).map_err(Box::new)?)
}

/// Reads a `.mtlx` file, finds the libraries and compiles the selected outputs. The
/// material is named after the file's stem; relative texture paths are made relative to the
/// file's directory.
pub fn compile_mtlx(path: &Path, opts: &MtlxOptions) -> Result<Compiled, MtlxLoadError> {
    let text = read_to_string(path, FileKind::Text, "MaterialX document")?;
    let lib = library(&locate(opts.libraries.as_deref())?)?;
    let mut c = mtlx::compile(&path.display().to_string(), &text, lib, &opts.selection)
        .map_err(Box::new)?;
    if let Some(stem) = path.file_stem() {
        c.program.name = stem.to_string_lossy().into_owned();
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    c.program.resolve_textures(dir);
    Ok(c)
}
