//! shadenet-lang: the front end shared by the RenderMan Shading Language (`.sl`) and Open
//! Shading Language (`.osl`): [`lex`] → [`preprocess`] → [`parse`] to a spanned [`ast`] →
//! [`lower`], which checks a shader and lowers it to the IR (DESIGN §16; RSL surface
//! shaders today, the rest a clear error).
//!
//! ```
//! use shadenet_lang::{Dialect, Options, SourceMap, parse_str};
//! let mut sources = SourceMap::new();
//! let src = "surface matte(float Kd = 1) { Ci = Kd * Cs * diffuse(N); }";
//! let parsed = parse_str(&mut sources, "matte.sl", src, &Options::new(Dialect::Rsl)).unwrap();
//! assert_eq!(parsed.file.items.len(), 1);
//! let err = parse_str(&mut sources, "bad.sl", "surface s() { x = 1 }", &Options::new(Dialect::Rsl))
//!     .unwrap_err();
//! assert!(err.render(&sources).contains("expected ';' after the expression, found '}'"));
//! ```
//!
//! Every entry point returns errors as [`Diagnostics`] and never panics; the source map is the
//! caller's, so the diagnostics (and the checker's, later) can be rendered against it.

pub mod ast;
pub mod diag;
pub mod group;
pub mod lex;
pub mod lower;
mod options;
pub mod parse;
pub mod preprocess;
pub mod pretty;
pub mod source;

pub use diag::{Diagnostic, Diagnostics, Severity};
pub use options::{Dialect, Options, TextureInfo, TextureInfoFn, TextureInfoSource};
pub use source::{FileId, SourceMap, Span};

use std::path::Path;

/// A parsed source file.
#[derive(Debug)]
pub struct Parsed {
    /// The dialect it was parsed in.
    pub dialect: Dialect,
    /// The main file's id in the source map.
    pub main: FileId,
    /// The syntax tree.
    pub file: ast::File,
    /// Warnings (ignored pragmas, `#warning`); rendered like errors.
    pub warnings: Diagnostics,
    /// What answers `gettextureinfo` ([`Options::texture_info`] of the parse).
    pub(crate) texture_info: Option<TextureInfoSource>,
    /// What the lowering learns once about the file's functions (filled on first use).
    pub(crate) facts: std::sync::OnceLock<lower::FileFacts>,
}

/// Reads, preprocesses and parses the file at `path` into `sources`. The dialect is
/// `options.dialect`, else the extension's (`.sl` RSL, `.osl` OSL). A file already in
/// `sources` (by canonical path) is not read again: use a fresh map to see edits.
pub fn parse_file(
    sources: &mut SourceMap,
    path: &Path,
    options: &Options,
) -> Result<Parsed, Diagnostics> {
    let Some(dialect) = options.dialect.or_else(|| Dialect::from_path(path)) else {
        return Err(Diagnostic::error_nowhere(format!(
            "cannot tell the language of '{}': name it .sl (RSL) or .osl (OSL), or give the dialect",
            path.display()
        ))
        .into());
    };
    let main = preprocess::load_main(sources, path)?;
    parse_loaded(sources, main, dialect, options)
}

/// Preprocesses and parses `text`, named `name` (its folder, if any, is where
/// `#include "f"` looks first).
pub fn parse_str(
    sources: &mut SourceMap,
    name: &str,
    text: &str,
    options: &Options,
) -> Result<Parsed, Diagnostics> {
    let Some(dialect) = options
        .dialect
        .or_else(|| Dialect::from_path(Path::new(name)))
    else {
        return Err(Diagnostic::error_nowhere(format!(
            "cannot tell the language of '{name}': name it .sl (RSL) or .osl (OSL), or give the dialect"
        ))
        .into());
    };
    if text.len() > source::MAX_FILE_BYTES {
        return Err(Diagnostic::error_nowhere(format!(
            "'{name}' is {} bytes; the limit is {}",
            text.len(),
            source::MAX_FILE_BYTES
        ))
        .into());
    }
    let main = sources.add(name, text.to_string());
    parse_loaded(sources, main, dialect, options)
}

/// Stack size of the thread the front end runs on (16 MiB). The parser's nesting limit
/// ([`parse::MAX_NESTING`]) keeps its recursion bounded; unoptimised builds take about 20 KiB
/// of stack per nested parenthesis, more than a default 2 MiB thread has for 128 of them, so
/// the front end does not run on the caller's stack.
pub const STACK_BYTES: usize = 16 << 20;

/// Runs `f` on a scoped thread with a [`STACK_BYTES`] stack (or on this thread if one cannot
/// be started).
pub(crate) fn on_big_stack<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    let mut slot = Some(f);
    let ran = std::thread::scope(|s| {
        let spawned = std::thread::Builder::new()
            .name("shadenet-lang".into())
            .stack_size(STACK_BYTES)
            .spawn_scoped(s, || slot.take().map(|f| f()));
        match spawned {
            Ok(h) => match h.join() {
                Ok(r) => r,
                Err(panic) => std::panic::resume_unwind(panic),
            },
            Err(_) => None,
        }
    });
    match (ran, slot.take()) {
        (Some(r), _) => r,
        (None, Some(f)) => f(),
        // The thread took `f` and returned nothing: impossible, `f` always returns.
        (None, None) => unreachable!("the front end's thread took its work and returned none"),
    }
}

fn parse_loaded(
    sources: &mut SourceMap,
    main: FileId,
    dialect: Dialect,
    options: &Options,
) -> Result<Parsed, Diagnostics> {
    on_big_stack(|| parse_loaded_here(sources, main, dialect, options))
}

fn parse_loaded_here(
    sources: &mut SourceMap,
    main: FileId,
    dialect: Dialect,
    options: &Options,
) -> Result<Parsed, Diagnostics> {
    let pre = preprocess::preprocess(sources, main, dialect, options)?;
    let len = sources.file(main).text.len();
    let end = Span::new(main, len, len);
    let file = parse::parse(&pre.tokens, sources, dialect, end).map_err(|mut d| {
        if let Some(p) = &d.primary
            && let Some(chain) = pre.include_chains.get(&p.span.file)
        {
            d.include_chain = chain.clone();
        }
        d
    })?;
    Ok(Parsed {
        dialect,
        main,
        file,
        warnings: Diagnostics(pre.warnings),
        texture_info: options.texture_info.clone(),
        facts: std::sync::OnceLock::new(),
    })
}
