//! MaterialX front end (DESIGN §11): `.mtlx` documents to the same [`Network`] the JSON
//! front end produces, with the MaterialX data libraries as the node definitions.
//!
//! The pipeline: [`document::parse`] (XML text → [`Document`], positions kept) →
//! [`translate::to_network`] (nodedef resolution per the specification, nodegraph-defined
//! nodedefs as compounds the linker expands, every other nodedef an atom of the table in
//! [`atoms`]) → the ordinary linker and lowering, against [`Library::atoms`].
//!
//! This module owns MaterialX semantics; it must not read files or search the disk for the
//! libraries (the facade does, through `runtime::input`), nor add IR ops: atoms lower to
//! the existing ones. Closures (BSDF, EDF, shaders, materials) are issue 15: selecting one is
//! an error naming the node, never a wrong image.

// Errors carry positions and names for the user; they are built once, on the cold path.
#![allow(clippy::result_large_err)]

pub mod atoms;
pub mod atoms_closure;
pub mod atoms_flake;
pub mod atoms_geom;
pub mod atoms_lower;
pub mod atoms_matrix;
pub mod atoms_pbr;
pub mod atoms_tiling;
pub mod channels;
pub mod coverage;
pub mod document;
pub mod error;
pub mod iface;
pub mod library;
pub mod resolve;
pub mod strings;
pub mod translate;
pub mod value;

pub use document::{Document, parse};
pub use error::{MtlxError, Pos};
pub use library::Library;
pub use translate::{Selection, to_network};

use std::collections::BTreeSet;

use crate::closure::probe::LobeStat;
use crate::lower::{Compiled, LowerOptions, lower_with};
use crate::network::Network;
use crate::opt::Specialization;

/// Parses a document's text and translates it to a network (`file` names it in errors).
pub fn network(
    file: &str,
    text: &str,
    lib: &Library,
    sel: &Selection,
) -> Result<Network, MtlxError> {
    network_reading(file, text, lib, sel).map(|(net, _)| net)
}

/// [`network`], and the uniform geometric properties its selected string-valued
/// `geompropvalueuniform` nodes read ([`translate::translate`]).
pub fn network_reading(
    file: &str,
    text: &str,
    lib: &Library,
    sel: &Selection,
) -> Result<(Network, BTreeSet<String>), MtlxError> {
    let doc = parse(file, text)?;
    translate::translate(&doc, lib, sel)
}

/// Parses a document's text and names the uniform geometric properties its selected
/// string-valued `geompropvalueuniform` nodes read.
pub fn uniform_geomprops(
    file: &str,
    text: &str,
    lib: &Library,
    sel: &Selection,
) -> Result<BTreeSet<String>, MtlxError> {
    network_reading(file, text, lib, sel).map(|(_, props)| props)
}

/// Parses, translates, links and lowers a document's text.
pub fn compile(
    file: &str,
    text: &str,
    lib: &Library,
    sel: &Selection,
) -> Result<Compiled, MtlxError> {
    compile_with(file, text, lib, sel, LowerOptions::default())
}

/// [`compile`] with lowering options.
pub fn compile_with(
    file: &str,
    text: &str,
    lib: &Library,
    sel: &Selection,
    opts: LowerOptions,
) -> Result<Compiled, MtlxError> {
    let net = network(file, text, lib, sel)?;
    let link = |source| MtlxError::Link {
        file: file.to_string(),
        source,
    };
    let linked = crate::link::link(&net, lib.atoms()).map_err(link)?;
    let program = lower_with(&linked, lib.atoms(), opts).map_err(link)?;
    Ok(Compiled {
        program,
        lights: linked.lights,
    })
}

/// The lobes of the selected material(s) and whether each is left after optimizing with
/// `spec` ([`crate::closure::probe`]).
pub fn lobes(
    file: &str,
    text: &str,
    lib: &Library,
    sel: &Selection,
    spec: &Specialization,
) -> Result<Vec<LobeStat>, MtlxError> {
    let opts = LowerOptions {
        closure_output: Some(crate::closure::probe::declare),
        ..LowerOptions::default()
    };
    let c = compile_with(file, text, lib, sel, opts)?;
    let (p, _) = crate::opt::run(&c.program, spec);
    Ok(crate::closure::probe::read(&p))
}
