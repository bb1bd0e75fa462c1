//! Needs analysis: what a (specialized) program still reads.
//!
//! The renderer computes only the streams listed here (no tangents if nothing reads `dPdu`
//! or `dPdv`, no ray differentials if nothing reads `dPdx`/`dPdy`), sets up only the listed
//! space transforms, resolves and interpolates only the listed geometry attributes, and the
//! runtime loads only the listed textures. `trace` and `occlusion`
//! say whether the material asks the scene for secondary rays at all (a renderer without
//! them, or a pass that wants none, can tell).

use crate::ir::{AttributeDecl, Intrinsic, Op, Program, Space, Stream, TextureFile};
use std::collections::BTreeSet;
use std::fmt;

/// What a program reads.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Needs {
    /// Implicit streams read.
    pub streams: BTreeSet<Stream>,
    /// Spaces other than world that values are transformed to or from.
    pub spaces: BTreeSet<Space>,
    /// Intrinsic functions called.
    pub intrinsics: BTreeSet<Intrinsic>,
    /// Texture files read (after optimization: only live ones).
    pub textures: Vec<TextureFile>,
    /// Whether the light loop runs (non-ambient lights are sampled).
    pub lights: bool,
    /// Whether ambient light is read.
    pub ambient: bool,
    /// Whether the program traces secondary rays ([`Op::Trace`]) or probe rays
    /// ([`Op::Probe`]).
    pub trace: bool,
    /// Whether the program asks for ambient occlusion ([`Op::Occlusion`]).
    pub occlusion: bool,
    /// Uniform parameters still read.
    pub params: usize,
    /// Geometry attributes read by live [`Op::Attribute`] and [`Op::AttributeFound`] ops (after optimization: only
    /// live ones), by name and type, sorted: the renderer resolves and interpolates only
    /// these.
    pub attributes: Vec<AttributeDecl>,
}

impl Needs {
    /// Whether tangents (`dPdu`, `dPdv`) are needed.
    pub fn tangents(&self) -> bool {
        self.streams.contains(&Stream::DPdu) || self.streams.contains(&Stream::DPdv)
    }

    /// Whether ray differentials (`dPdx`, `dPdy`) are needed.
    pub fn differentials(&self) -> bool {
        self.streams.contains(&Stream::DPdx) || self.streams.contains(&Stream::DPdy)
    }
}

/// Collects the needs of the values listed in `p` (prelude and body).
pub fn analyze(p: &Program) -> Needs {
    let mut n = Needs::default();
    let mut params = BTreeSet::new();
    let mut textures = BTreeSet::new();
    let mut attributes = BTreeSet::new();
    for v in p.listed() {
        match p.op(v) {
            Op::Stream(s) => {
                n.streams.insert(*s);
            }
            Op::Transform { from, to, .. } => {
                for s in [from, to] {
                    if *s != Space::World {
                        n.spaces.insert(*s);
                    }
                }
            }
            Op::Call(i, _) => {
                n.intrinsics.insert(*i);
            }
            Op::Texture { texture, .. } => {
                textures.insert(*texture);
            }
            Op::Attribute { slot, .. } | Op::AttributeFound { slot } => {
                if let Some(a) = p.attributes.get(*slot as usize) {
                    attributes.insert(a.clone());
                }
            }
            Op::Illuminance { .. } => n.lights = true,
            Op::Ambient => n.ambient = true,
            Op::Trace { .. } | Op::Probe { .. } => n.trace = true,
            Op::Occlusion { .. } => n.occlusion = true,
            Op::Param(i) => {
                params.insert(*i);
            }
            _ => {}
        }
    }
    n.params = params.len();
    n.attributes = attributes.into_iter().collect();
    n.textures = textures
        .into_iter()
        .filter_map(|t| p.textures.get(t as usize).cloned())
        .collect();
    n
}

impl fmt::Display for Needs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let list = |v: Vec<&str>| {
            if v.is_empty() {
                "none".to_string()
            } else {
                v.join(" ")
            }
        };
        writeln!(
            f,
            "needs: streams: {}",
            list(self.streams.iter().map(|s| s.name()).collect())
        )?;
        writeln!(
            f,
            "       spaces: {}; tangents: {}; differentials: {}",
            list(self.spaces.iter().map(|s| s.name()).collect()),
            if self.tangents() { "yes" } else { "no" },
            if self.differentials() { "yes" } else { "no" }
        )?;
        writeln!(
            f,
            "       intrinsics: {}; lights: {}; ambient: {}; params: {}",
            list(self.intrinsics.iter().map(|i| i.name()).collect()),
            if self.lights { "yes" } else { "no" },
            if self.ambient { "yes" } else { "no" },
            self.params
        )?;
        writeln!(
            f,
            "       trace: {}; occlusion: {}",
            if self.trace { "yes" } else { "no" },
            if self.occlusion { "yes" } else { "no" }
        )?;
        writeln!(
            f,
            "       textures: {}",
            list(self.textures.iter().map(|t| t.path.as_str()).collect())
        )?;
        if self.attributes.is_empty() {
            return Ok(());
        }
        let attributes: Vec<String> = self
            .attributes
            .iter()
            .map(|a| format!("{}:{}", a.name, a.ty))
            .collect();
        writeln!(f, "       attributes: {}", attributes.join(" "))
    }
}
