//! Render passes (DESIGN §8, thesis §4.4): which layers the film gets, and the ray-match
//! rules that pick, per ray type and depth, what a hit computes.
//!
//! - A **component pass** is the sum of some render components of the camera hit's single
//!   shading call (every active component comes back separately; the film adds them up).
//!   `beauty` is always written: the total of each material's first output (the sum of its
//!   components). A component the first output lacks may come from another output (a
//!   surface's `outShadow`): it fills its pass and stays out of the beauty.
//! - An **override pass** replaces the surface shader at camera hits with a built-in
//!   program: `normal` (world-space shading normal), `depth` (camera-space distance along
//!   the view axis), `uv` (surface parameters) or `occlusion` (the IR's `occlusion` op
//!   around the shading normal, asking the tracer's occlusion service) — each built with
//!   `graph::ir::Builder` and run by the same back end as the materials.
//! - **Ray-match rules** say what hits of a ray type at a depth compute: a list of
//!   components (the material is specialized to exactly that mask) or an override shader.
//!   The first matching rule wins; no match means every component. The default makes "the
//!   reflection pass: camera rays keep only `reflection`, deeper rays shade fully" a plain
//!   component pass: the camera hit's `reflection` part already holds the full shading of
//!   what the reflected ray hit.

use shadenet_graph::ir::{
    Builder, Program, RAY_CAMERA, RAY_DIFFUSE, RAY_REFLECTION, RAY_REFRACTION, Space, Stream, UnOp,
};
use shadenet_graph::types::Type;
use std::str::FromStr;

/// The render components the shading system defines or is about to (DESIGN §8): a pass may
/// name one of these even when no material of the scene has it (its layer is then black).
pub const KNOWN_COMPONENTS: &[&str] = &[
    "diffuse",
    "specular",
    "indirect",
    "emission",
    "reflection",
    "refraction",
    "shadow",
    "occlusion",
];

/// A built-in shader that replaces a material.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum OverrideKind {
    /// World-space shading normal (X, Y, Z).
    Normal,
    /// Camera-space depth: distance from the eye along the view axis (Z).
    Depth,
    /// Surface parameters (U, V).
    Uv,
    /// Ambient occlusion: the fraction of cosine-weighted directions unblocked within
    /// `render.occlusion_distance` (Y).
    Occlusion,
}

impl OverrideKind {
    /// Every override.
    pub const ALL: [OverrideKind; 4] = [
        OverrideKind::Normal,
        OverrideKind::Depth,
        OverrideKind::Uv,
        OverrideKind::Occlusion,
    ];

    /// Its name in scene files.
    pub fn name(self) -> &'static str {
        match self {
            OverrideKind::Normal => "normal",
            OverrideKind::Depth => "depth",
            OverrideKind::Uv => "uv",
            OverrideKind::Occlusion => "occlusion",
        }
    }

    /// The EXR channel names of its layer.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            OverrideKind::Normal => &["X", "Y", "Z"],
            OverrideKind::Depth => &["Z"],
            OverrideKind::Uv => &["U", "V"],
            OverrideKind::Occlusion => &["Y"],
        }
    }

    /// The built-in program. Its one output, `value`, has as many floats as
    /// [`OverrideKind::channels`]. [`OverrideKind::Occlusion`] is the `occlusion` op around
    /// the shading normal `N` with `occlusion_samples` rays reaching `occlusion_distance`
    /// (the scene's settings, as constants); the other kinds ignore them. Fails only if
    /// the builder rejects an op (an internal error).
    pub fn program(
        self,
        occlusion_samples: u32,
        occlusion_distance: f32,
    ) -> Result<Program, String> {
        let mut b = Builder::new(&format!("override:{}", self.name()));
        let v = match self {
            OverrideKind::Normal => b.stream(Stream::N),
            OverrideKind::Depth => {
                let p = b.stream_in(Stream::P, Space::Camera);
                let z = b.extract(p, 2);
                b.unary(UnOp::Neg, z)
            }
            OverrideKind::Uv => b.stream(Stream::Uv),
            OverrideKind::Occlusion => {
                let n = b.stream(Stream::N);
                let samples = b.int(occlusion_samples.min(i32::MAX as u32) as i32);
                let reach = b.float(f64::from(occlusion_distance));
                b.occlusion(n, samples, reach)
            }
        };
        b.output("value", None, v);
        b.finish()
    }
}

impl FromStr for OverrideKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        OverrideKind::ALL
            .into_iter()
            .find(|o| o.name() == s)
            .ok_or_else(|| {
                format!("`{s}` is not an override shader (normal, depth, uv, occlusion)")
            })
    }
}

/// What a pass's layer holds.
#[derive(Clone, Debug, PartialEq)]
pub enum PassKind {
    /// The sum of these components of the camera hit.
    Components(Vec<String>),
    /// An override shader's value at the camera hit.
    Override(OverrideKind),
}

/// One pass: a layer of the film.
#[derive(Clone, Debug, PartialEq)]
pub struct PassDef {
    /// The layer name.
    pub name: String,
    /// What it holds.
    pub kind: PassKind,
}

impl PassDef {
    /// A pass by standard name: `normal`, `depth`, `uv` and `occlusion` are override passes;
    /// any other name is the pass of that one render component.
    pub fn standard(name: &str) -> Result<PassDef, String> {
        if name.is_empty() || name.contains(|c: char| c.is_whitespace() || c == '.') {
            return Err(format!(
                "`{name}` is not a pass name (no spaces or dots; e.g. diffuse, normal)"
            ));
        }
        let kind = match name.parse::<OverrideKind>() {
            Ok(o) => PassKind::Override(o),
            Err(_) => PassKind::Components(vec![name.to_string()]),
        };
        Ok(PassDef {
            name: name.to_string(),
            kind,
        })
    }
}

/// Checks that pass names are unique, usable as EXR layer names, and not `beauty`.
pub fn check_pass_names(passes: &[PassDef]) -> Result<(), String> {
    for (i, p) in passes.iter().enumerate() {
        if p.name == "beauty" {
            return Err("`beauty` is always written; it cannot be a pass".into());
        }
        if p.name.is_empty() || p.name.contains(|c: char| c.is_whitespace() || c == '.') {
            return Err(format!(
                "`{}` is not a pass name (no spaces or dots)",
                p.name
            ));
        }
        if passes[..i].iter().any(|q| q.name == p.name) {
            return Err(format!("pass `{}` is listed twice", p.name));
        }
    }
    Ok(())
}

/// The ray types a rule can match (shadow rays shade nothing).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayMatch {
    /// Primary rays (depth 0).
    Camera,
    /// Mirror reflection rays.
    Reflection,
    /// Refraction rays.
    Refraction,
    /// Diffuse (indirect) rays.
    Diffuse,
}

impl RayMatch {
    /// Every ray type that shades.
    pub const ALL: [RayMatch; 4] = [
        RayMatch::Camera,
        RayMatch::Reflection,
        RayMatch::Refraction,
        RayMatch::Diffuse,
    ];

    /// Parses a rule's `ray`.
    pub fn parse(s: &str) -> Result<RayMatch, String> {
        match s {
            "camera" => Ok(RayMatch::Camera),
            "reflection" => Ok(RayMatch::Reflection),
            "refraction" => Ok(RayMatch::Refraction),
            "diffuse" => Ok(RayMatch::Diffuse),
            _ => Err(format!(
                "`{s}` is not a ray type (camera, reflection, refraction, diffuse, any)"
            )),
        }
    }

    /// The `RAY_*` code.
    pub fn code(self) -> i32 {
        match self {
            RayMatch::Camera => RAY_CAMERA,
            RayMatch::Reflection => RAY_REFLECTION,
            RayMatch::Refraction => RAY_REFRACTION,
            RayMatch::Diffuse => RAY_DIFFUSE,
        }
    }

    /// From a `RAY_*` code (`None` for shadow rays and unknown codes).
    pub fn from_code(code: i32) -> Option<RayMatch> {
        RayMatch::ALL.into_iter().find(|r| r.code() == code)
    }
}

/// What matching hits compute.
#[derive(Clone, Debug, PartialEq)]
pub enum RuleAction {
    /// Every component.
    All,
    /// Only these components.
    Components(Vec<String>),
    /// An override shader instead of the material.
    Override(OverrideKind),
}

/// A ray-match rule.
#[derive(Clone, Debug, PartialEq)]
pub struct Rule {
    /// The ray type (`None`: any).
    pub ray: Option<RayMatch>,
    /// Smallest depth matched.
    pub min_depth: u32,
    /// Largest depth matched.
    pub max_depth: u32,
    /// What matching hits compute.
    pub action: RuleAction,
}

/// The action for a hit of ray type `ray` at `depth`: the first matching rule's, else
/// [`RuleAction::All`].
pub fn action_for(rules: &[Rule], ray: RayMatch, depth: u32) -> &RuleAction {
    rules
        .iter()
        .find(|r| r.ray.is_none_or(|t| t == ray) && (r.min_depth..=r.max_depth).contains(&depth))
        .map_or(&RuleAction::All, |r| &r.action)
}

/// The scene-wide component table: every component any material has, then the known ones
/// passes name; each material maps its own component indices onto it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Components {
    /// Names, in first-seen order.
    pub names: Vec<String>,
}

impl Components {
    /// The table of these programs' components.
    pub fn of(programs: &[&Program]) -> Components {
        let mut names: Vec<String> = Vec::new();
        for p in programs {
            for c in &p.components {
                if !names.contains(c) {
                    names.push(c.clone());
                }
            }
        }
        Components { names }
    }

    /// The index of a name, adding it if missing.
    pub fn intern(&mut self, name: &str) -> usize {
        match self.names.iter().position(|n| n == name) {
            Some(i) => i,
            None => {
                self.names.push(name.to_string());
                self.names.len() - 1
            }
        }
    }

    /// The index of a name.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
}

/// The mask of `program` for an action's components (every component for `All`).
pub fn program_mask(program: &Program, action: &RuleAction) -> u32 {
    match action {
        RuleAction::All | RuleAction::Override(_) => u32::MAX,
        RuleAction::Components(names) => names
            .iter()
            .filter_map(|n| program.component_index(n))
            .fold(0, |m, k| m | 1u32 << (k as u32 & 31)),
    }
}

/// The type of an override program's output.
pub fn override_width(kind: OverrideKind) -> usize {
    match kind {
        OverrideKind::Normal => Type::Vec3.width(),
        OverrideKind::Depth | OverrideKind::Occlusion => 1,
        OverrideKind::Uv => 2,
    }
}
