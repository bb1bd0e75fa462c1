//! What the caller chooses: the dialect ([`Dialect`]: RSL or OSL) and the preprocessor's
//! inputs ([`Options`]: include directories and `-D` defines).

use std::path::{Path, PathBuf};
use std::sync::Arc;

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
    /// What answers OSL's `gettextureinfo` while compiling (the texture system, which this
    /// crate does not hold); without one, `gettextureinfo` is an error that says so.
    pub texture_info: Option<TextureInfoSource>,
}

/// What `gettextureinfo` learns of a texture file: its header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextureInfo {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Channels per texel (1 grey, 2 grey and alpha, 3 RGB, 4 RGBA).
    pub channels: u32,
}

/// The header of the texture file a shader names (as written in the shader: the source
/// resolves a relative name as the loader resolves the shader's textures), or why it cannot
/// be read. OSL's optimizer folds `gettextureinfo` of a constant name the same way, once,
/// while the shader group is prepared.
#[derive(Clone)]
pub struct TextureInfoSource(pub Arc<TextureInfoFn>);

/// The function inside a [`TextureInfoSource`]: a file name as the shader wrote it to its
/// header, or why it cannot be read.
pub type TextureInfoFn = dyn Fn(&str) -> Result<TextureInfo, String> + Send + Sync;

impl std::fmt::Debug for TextureInfoSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("TextureInfoSource(..)")
    }
}

impl PartialEq for TextureInfoSource {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Options {
    /// Options for `dialect` with no include directories and no defines.
    pub fn new(dialect: Dialect) -> Options {
        Options {
            dialect: Some(dialect),
            include_dirs: Vec::new(),
            defines: Vec::new(),
            texture_info: None,
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
