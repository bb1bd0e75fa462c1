//! What the caller chooses: the dialect ([`Dialect`]: RSL or OSL) and the preprocessor's
//! inputs ([`Options`]: include directories and `-D` defines).

use std::path::{Path, PathBuf};

/// Which shading language a source is written in. The dialect decides the keywords, the
/// predefined macros and what `^` and `.` mean.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// The RenderMan Shading Language (`.sl`): `^` is the cross product, `.` the dot product.
    Rsl,
    /// Open Shading Language (`.osl`): `^` is bitwise xor, `.` selects a struct field.
    Osl,
}

impl Dialect {
    /// The dialect of a file by its extension: `.sl` is RSL, `.osl` (and `.h` headers
    /// are not main files) is OSL; anything else is `None`.
    pub fn from_path(path: &Path) -> Option<Dialect> {
        match path.extension()?.to_str()? {
            "sl" => Some(Dialect::Rsl),
            "osl" => Some(Dialect::Osl),
            _ => None,
        }
    }

    /// `"RSL"` or `"OSL"`.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::Rsl => "RSL",
            Dialect::Osl => "OSL",
        }
    }
}

/// Front-end options. The default has no dialect (taken from the file's extension), no
/// include directories and no defines.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Options {
    /// The dialect; `None` picks it from the file's extension ([`Dialect::from_path`]).
    pub dialect: Option<Dialect>,
    /// `-I` directories, searched in order after the including file's folder (for
    /// `#include "f"`; `#include <f>` searches only these).
    pub include_dirs: Vec<PathBuf>,
    /// `-D NAME[=VALUE]` defines, in order: `(NAME, VALUE)`, the value `1` when not given.
    pub defines: Vec<(String, String)>,
}

impl Options {
    /// Options for `dialect` with no include directories and no defines.
    pub fn new(dialect: Dialect) -> Options {
        Options {
            dialect: Some(dialect),
            include_dirs: Vec::new(),
            defines: Vec::new(),
        }
    }

    /// Adds a `-D` define given as `NAME` or `NAME=VALUE`.
    pub fn define(mut self, arg: &str) -> Options {
        let (name, value) = arg.split_once('=').unwrap_or((arg, "1"));
        self.defines.push((name.to_string(), value.to_string()));
        self
    }

    /// Adds a `-I` directory.
    pub fn include_dir(mut self, dir: impl Into<PathBuf>) -> Options {
        self.include_dirs.push(dir.into());
        self
    }
}
