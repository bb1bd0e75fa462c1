//! The node library: every standard node defined once, as a lowering to IR ops.
//!
//! A [`NodeDef`] declares a node's typed inputs (with defaults), its outputs, its docs and its
//! [`LowerFn`]. Back ends never see nodes: they implement IR ops, so adding a node is adding a
//! lowering and its tests. `shadenet nodes` prints [`NodeLibrary::reference`], from which
//! `docs/nodes.md` is generated.
//!
//! Generic nodes (`add`, `mix`, `clamp`, …) have ports of [`PortType::Generic`]: one type
//! `T` per node instance, chosen by the linker from what is connected (see
//! `docs/network-format.md`), one of the def's `generic` types.
//!
//! Render components: a surface node returns its color as a [`LowVal`] whose `parts` are
//! the per-component contributions (each computed under `component_enabled(k)`); linear
//! nodes (`add`, `multiply` by an untagged factor, `mix`, `blend`) carry parts through, so a
//! material output knows each component separately (DESIGN §8).
//!
//! Stream overrides (DESIGN §3): a lowering may ask for one of its inputs as it would be with
//! some implicit streams replaced — [`NodeInputs::reevaluate`] — which re-lowers the nodes
//! upstream of that input with the overridden values (bump mapping samples its input at an
//! offset `uv` this way). The lowering driver provides it through [`Upstream`].

pub mod env_image;
pub mod filtered;
pub mod filtered_noise;
pub mod geometry;
pub mod math;
pub mod pattern;
pub mod shader_light;
pub mod structure;
pub mod surface;
pub mod utility;

use crate::closure::Closure;
use crate::ir::{Builder, Space, Stream, Value};
use crate::types::{ConstValue, Type};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::sync::Arc;

/// The type of an input port.
#[derive(Clone, Debug, PartialEq)]
pub enum PortType {
    /// One simple type.
    Simple(Type),
    /// The node's generic type `T`.
    Generic,
    /// An array (fixed length per instance) of records with these simple-typed fields; the
    /// field type [`Type::String`] is not allowed. A field of type `Generic` is written with
    /// [`None`].
    Array(Vec<(&'static str, Option<Type>)>),
}

/// What an unconnected input gets.
#[derive(Clone, Debug, PartialEq)]
pub enum PortDefault {
    /// A constant (for a generic port: a float, broadcast to `T`).
    Value(ConstValue),
    /// An implicit stream, in world space.
    Stream(Stream),
    /// An empty array.
    EmptyArray,
    /// The empty closure (black, no emission): what an unset closure input gets.
    EmptyClosure,
}

/// One input port.
#[derive(Clone, Debug)]
pub struct PortDef {
    /// The port's name.
    pub name: &'static str,
    /// Its type.
    pub ty: PortType,
    /// Its default.
    pub default: PortDefault,
    /// For string ports: the accepted values (empty: any string).
    pub options: &'static [&'static str],
    /// One line of documentation.
    pub doc: &'static str,
}

/// One output port.
#[derive(Clone, Debug)]
pub struct OutDef {
    /// The port's name.
    pub name: &'static str,
    /// Its type (`None`: the node's generic type `T`).
    pub ty: Option<Type>,
    /// One line of documentation.
    pub doc: &'static str,
}

/// A lowered value: the total and, for shaded colors, its per-component parts (component
/// index, value); the total equals the sum of the parts when there are any. A closure-typed
/// value (`BSDF`, `EDF`, `surfaceshader`, `material`) is its lobe list in `closure`; its
/// `value` is then a placeholder float 0 that nothing reads.
#[derive(Clone, Debug, PartialEq)]
pub struct LowVal {
    /// The value.
    pub value: Value,
    /// Per-component contributions.
    pub parts: Vec<(u8, Value)>,
    /// The lobe list of a closure-typed value.
    pub closure: Option<Arc<Closure>>,
}

impl LowVal {
    /// A value without component parts.
    pub fn plain(value: Value) -> LowVal {
        LowVal::with_parts(value, Vec::new())
    }

    /// A value with per-component parts.
    pub fn with_parts(value: Value, parts: Vec<(u8, Value)>) -> LowVal {
        LowVal {
            value,
            parts,
            closure: None,
        }
    }

    /// A closure-typed value.
    pub fn closure(b: &mut Builder, closure: Closure) -> LowVal {
        LowVal {
            value: b.float(0.0),
            parts: Vec::new(),
            closure: Some(Arc::new(closure)),
        }
    }

    /// The lobe list of a closure-typed value; the empty closure for anything else (an
    /// unset closure input).
    pub fn as_closure(&self) -> Closure {
        self.closure.as_deref().cloned().unwrap_or_default()
    }
}

/// One resolved input, as a lowering sees it.
#[derive(Clone, Debug)]
pub enum InputVal {
    /// A value of the port's type (defaults and coercions already applied).
    Value(LowVal),
    /// A string literal.
    Str(String),
    /// An array input: one entry per element, one value per record field.
    Array(Vec<Vec<LowVal>>),
}

/// Re-evaluates a node's inputs with implicit streams overridden: what the lowering driver
/// offers a lowering through [`NodeInputs::reevaluate`].
pub trait Upstream {
    /// The value input `port` (of the node these inputs belong to) would have if every node
    /// upstream of it read the streams in `overrides` (each a value of the stream's type,
    /// world space, defined where the caller is) instead of the fragment's. The ops are
    /// emitted at the builder's current point. Overrides already in force (an enclosing
    /// re-evaluation) stay in force beneath these.
    fn reevaluate(
        &self,
        b: &mut Builder,
        port: &str,
        overrides: &[(Stream, Value)],
    ) -> Result<LowVal, String>;
}

impl std::fmt::Debug for dyn Upstream + '_ {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Upstream")
    }
}

/// The inputs of one node instance, in the order of its def's ports.
#[derive(Clone, Debug)]
pub struct NodeInputs<'a> {
    /// The node's name in the network (for error messages).
    pub node: &'a str,
    /// The node's definition.
    pub def: &'a NodeDef,
    /// The resolved generic type `T` (`Float` for non-generic nodes).
    pub generic: Type,
    /// One value per input port, in `def.inputs` order.
    pub values: Vec<InputVal>,
    /// Re-evaluation of the inputs with streams overridden, where the caller can offer it
    /// (the lowering driver and [`crate::lower::lower_single`] do; `None` makes
    /// [`NodeInputs::reevaluate`] fail).
    pub upstream: Option<&'a dyn Upstream>,
}

impl NodeInputs<'_> {
    fn slot(&self, port: &str) -> &InputVal {
        let i = self
            .def
            .inputs
            .iter()
            .position(|p| p.name == port)
            .unwrap_or_else(|| panic!("node {} has no input {port}", self.def.name));
        &self.values[i]
    }

    /// The value of a simple or generic input (with its component parts).
    pub fn low(&self, port: &str) -> &LowVal {
        match self.slot(port) {
            InputVal::Value(v) => v,
            other => panic!(
                "input {port} of {} is not a value: {other:?}",
                self.def.name
            ),
        }
    }

    /// The value of a simple or generic input.
    pub fn get(&self, port: &str) -> Value {
        self.low(port).value
    }

    /// A string input.
    pub fn string(&self, port: &str) -> &str {
        match self.slot(port) {
            InputVal::Str(s) => s,
            other => panic!(
                "input {port} of {} is not a string: {other:?}",
                self.def.name
            ),
        }
    }

    /// The value input `port` would have with the implicit streams in `overrides` replaced by
    /// the given values in everything upstream of it (DESIGN §3 stream overrides; see
    /// [`Upstream::reevaluate`]). Nodes upstream that depend on none of the overridden streams
    /// are not lowered again: their values are reused. An unconnected port bound to an
    /// overridden stream gets the override; any other unconnected port keeps its value.
    /// `Err` for a value of the wrong type, or where no driver offers re-evaluation.
    pub fn reevaluate(
        &self,
        b: &mut Builder,
        port: &str,
        overrides: &[(Stream, Value)],
    ) -> Result<LowVal, String> {
        if self.def.input(port).is_none() {
            return Err(format!("{} has no input `{port}`", self.def.name));
        }
        for &(s, v) in overrides {
            if b.ty(v) != s.ty() {
                return Err(format!(
                    "stream {} is a {}, but its override is a {}",
                    s.name(),
                    s.ty(),
                    b.ty(v)
                ));
            }
        }
        match self.upstream {
            Some(up) => up.reevaluate(b, port, overrides),
            None => Err(format!(
                "input `{port}` of {} cannot be re-evaluated here (no lowering driver)",
                self.node
            )),
        }
    }

    /// An array input.
    pub fn array(&self, port: &str) -> &[Vec<LowVal>] {
        match self.slot(port) {
            InputVal::Array(a) => a,
            other => panic!(
                "input {port} of {} is not an array: {other:?}",
                self.def.name
            ),
        }
    }
}

/// Lowers one node instance: emits its ops with the builder and returns one value per
/// output, in `def.outputs` order. An `Err` is a user-facing message about this node's
/// inputs (the caller adds the node's name).
pub type LowerFn = fn(&mut Builder, &NodeInputs) -> Result<Vec<LowVal>, String>;

/// A light description built from a light node's constant inputs.
#[derive(Clone, Debug, PartialEq)]
pub struct LightDesc {
    /// The light node's name.
    pub name: String,
    /// What kind of light and its geometry.
    pub kind: LightKind,
    /// Color × intensity: W/sr for point and spot lights, W/m² (irradiance) for distant
    /// lights, radiance for ambient light.
    pub power: [f64; 3],
}

/// The kinds of light and their geometry (world space, angles in radians).
#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    /// A point light at `position`.
    Point {
        /// World-space position.
        position: [f64; 3],
    },
    /// A spot light at `position` aiming along `direction`.
    Spot {
        /// World-space position.
        position: [f64; 3],
        /// Unit direction the spot points in.
        direction: [f64; 3],
        /// Full cone angle.
        cone_angle: f64,
        /// Penumbra angle: > 0 softens outward, < 0 inward (Maya).
        penumbra_angle: f64,
        /// Exponent of `cos` to the axis.
        dropoff: f64,
    },
    /// A distant (directional) light shining along `direction`.
    Distant {
        /// Unit direction the light travels in.
        direction: [f64; 3],
    },
    /// Ambient light: no direction.
    Ambient,
    /// A one-sided quad area light `corner + s·edge_u + t·edge_v` (s, t ∈ [0, 1]) emitting
    /// radiance `power` from the side `edge_u × edge_v` points to; sampled by Monte Carlo with
    /// `samples` points per shaded point.
    Quad {
        /// One corner, world space.
        corner: [f64; 3],
        /// First edge.
        edge_u: [f64; 3],
        /// Second edge.
        edge_v: [f64; 3],
        /// Samples per shaded point (at least 1).
        samples: u32,
    },
    /// An environment: radiance `power` arriving from every direction (times the map's
    /// texel in that direction when there is a `map`), sampled with `samples` directions per
    /// shaded point: uniformly on the sphere without a map, importance-sampled by the map's
    /// luminance with one.
    Environment {
        /// Samples per shaded point (at least 1).
        samples: u32,
        /// The lat-long radiance map (shared, never copied), or none for a constant
        /// environment.
        map: Option<std::sync::Arc<env_image::EnvImage>>,
    },
    /// A light shader's program ([`shader_light`]: its outputs, how it is sampled): a
    /// positional or directional light whose color the program computes per sample; the
    /// light's `power` is unused.
    Shader {
        /// The program, its parameters set, with its evaluator (shared, never copied).
        program: shader_light::SharedLightProgram,
    },
}

/// What is wrong with a light's parameters ([`LightDesc::new`]): the field, named as
/// [`LightKind`]'s fields are (`direction`, `cone_angle`, `samples`, …, and `power`), and
/// why. Each source of lights maps the field to its own names (a node's port, a scene file's
/// key, the `--light` option).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct LightError {
    /// The offending field.
    pub field: &'static str,
    /// Why it is rejected.
    pub reason: String,
}

/// Most samples per shaded point an area or environment light may take.
pub const MAX_LIGHT_SAMPLES: u32 = 65536;

impl LightDesc {
    /// A light whose parameters obey the rules every source of lights shares (the light
    /// nodes, the scene file, `shadenet shade --light`): every number finite; directions
    /// nonzero (normalized here); a spot's cone in [0, π] and its dropoff ≥ 0; a quad's
    /// edges spanning an area; area and environment lights 1 to [`MAX_LIGHT_SAMPLES`]
    /// samples; an environment's map within its size limits with every texel finite and ≥ 0
    /// ([`env_image::EnvImage::check`]). Negative power is allowed (a light that removes
    /// light, as Maya allows).
    pub fn new(
        name: impl Into<String>,
        kind: LightKind,
        power: [f64; 3],
    ) -> Result<LightDesc, LightError> {
        let err = |field: &'static str, reason: String| LightError { field, reason };
        let finite = |field: &'static str, v: &[f64]| match v.iter().find(|x| !x.is_finite()) {
            Some(x) => Err(err(field, format!("{x} is not a finite number"))),
            None => Ok(()),
        };
        let direction = |field: &'static str, d: [f64; 3]| {
            finite(field, &d)?;
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            if len > 0.0 && len.is_finite() {
                Ok(d.map(|x| x / len))
            } else {
                Err(err(
                    field,
                    "the direction is zero: a light direction must be nonzero".into(),
                ))
            }
        };
        let samples = |n: u32| {
            if (1..=MAX_LIGHT_SAMPLES).contains(&n) {
                Ok(n)
            } else {
                Err(err(
                    "samples",
                    format!("{n} samples: must be 1 to {MAX_LIGHT_SAMPLES}"),
                ))
            }
        };
        finite("power", &power)?;
        let kind = match kind {
            LightKind::Point { position } => {
                finite("position", &position)?;
                LightKind::Point { position }
            }
            LightKind::Spot {
                position,
                direction: d,
                cone_angle,
                penumbra_angle,
                dropoff,
            } => {
                finite("position", &position)?;
                finite("cone_angle", &[cone_angle])?;
                finite("penumbra_angle", &[penumbra_angle])?;
                finite("dropoff", &[dropoff])?;
                if !(0.0..=std::f64::consts::PI).contains(&cone_angle) {
                    return Err(err(
                        "cone_angle",
                        format!(
                            "{} degrees: must lie in [0, 180] degrees",
                            cone_angle.to_degrees()
                        ),
                    ));
                }
                if dropoff < 0.0 {
                    return Err(err("dropoff", format!("{dropoff}: must be ≥ 0")));
                }
                LightKind::Spot {
                    position,
                    direction: direction("direction", d)?,
                    cone_angle,
                    penumbra_angle,
                    dropoff,
                }
            }
            LightKind::Distant { direction: d } => LightKind::Distant {
                direction: direction("direction", d)?,
            },
            LightKind::Ambient => LightKind::Ambient,
            LightKind::Quad {
                corner,
                edge_u,
                edge_v,
                samples: n,
            } => {
                finite("corner", &corner)?;
                finite("edge_u", &edge_u)?;
                finite("edge_v", &edge_v)?;
                let [a, b] = [edge_u, edge_v];
                let c = [
                    a[1] * b[2] - a[2] * b[1],
                    a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0],
                ];
                if c.iter().all(|x| *x == 0.0) {
                    return Err(err(
                        "edge_v",
                        "the quad has no area (parallel or zero edges)".into(),
                    ));
                }
                LightKind::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    samples: samples(n)?,
                }
            }
            LightKind::Environment { samples: n, map } => {
                if let Some(m) = &map {
                    m.check().map_err(|reason| err("map", reason))?;
                }
                LightKind::Environment {
                    samples: samples(n)?,
                    map,
                }
            }
            LightKind::Shader { program } => LightKind::Shader { program },
        };
        Ok(LightDesc {
            name: name.into(),
            kind,
            power,
        })
    }
}

/// Builds a light from a light node's inputs (all constants, in `def.inputs` order).
pub type LightFn = fn(name: &str, inputs: &[ConstValue]) -> Result<LightDesc, String>;

/// What a node is.
#[derive(Clone, Copy, Debug)]
pub enum NodeKind {
    /// A node evaluated by the material program.
    Shading,
    /// A light: its constant inputs make a [`LightDesc`]; it has no outputs.
    Light(LightFn),
}

/// A node type of the library.
#[derive(Clone, Debug)]
pub struct NodeDef {
    /// The type name used in network files.
    pub name: &'static str,
    /// Section in the reference (`math`, `structure`, `pattern`, `geometry`, `surface`,
    /// `light`, `utility`).
    pub category: &'static str,
    /// Documentation: what it computes, the formula, hard-input behaviour.
    pub doc: &'static str,
    /// The types a generic node may take (empty for non-generic nodes).
    pub generic: &'static [Type],
    /// Inputs.
    pub inputs: Vec<PortDef>,
    /// Outputs.
    pub outputs: Vec<OutDef>,
    /// The lowering (unused for lights).
    pub lower: LowerFn,
    /// Shading node or light.
    pub kind: NodeKind,
}

impl NodeDef {
    /// A shading node of `category` (the common case of a node definition).
    pub fn shading(
        category: &'static str,
        name: &'static str,
        doc: &'static str,
        generic: &'static [Type],
        inputs: Vec<PortDef>,
        outputs: Vec<OutDef>,
        lower: LowerFn,
    ) -> NodeDef {
        NodeDef {
            name,
            category,
            doc,
            generic,
            inputs,
            outputs,
            lower,
            kind: NodeKind::Shading,
        }
    }

    /// The input port called `name`.
    pub fn input(&self, name: &str) -> Option<&PortDef> {
        self.inputs.iter().find(|p| p.name == name)
    }

    /// The index of the output called `name`.
    pub fn output_index(&self, name: &str) -> Option<usize> {
        self.outputs.iter().position(|o| o.name == name)
    }
}

/// Shorthand constructors for port definitions, used by the node modules.
pub mod port {
    use super::*;

    /// A simple input with a constant default.
    pub fn input(name: &'static str, ty: Type, default: ConstValue, doc: &'static str) -> PortDef {
        PortDef {
            name,
            ty: PortType::Simple(ty),
            default: PortDefault::Value(default),
            options: &[],
            doc,
        }
    }

    /// A float input.
    pub fn float(name: &'static str, default: f64, doc: &'static str) -> PortDef {
        input(name, Type::Float, ConstValue::Float(default), doc)
    }

    /// An int input.
    pub fn int(name: &'static str, default: i32, doc: &'static str) -> PortDef {
        input(name, Type::Int, ConstValue::Int(default), doc)
    }

    /// A bool input.
    pub fn boolean(name: &'static str, default: bool, doc: &'static str) -> PortDef {
        input(name, Type::Bool, ConstValue::Bool(default), doc)
    }

    /// A color input.
    pub fn color(name: &'static str, default: [f64; 3], doc: &'static str) -> PortDef {
        input(name, Type::Color, ConstValue::Color(default), doc)
    }

    /// A vec3 input.
    pub fn vec3(name: &'static str, default: [f64; 3], doc: &'static str) -> PortDef {
        input(name, Type::Vec3, ConstValue::Vec3(default), doc)
    }

    /// A vec2 input.
    pub fn vec2(name: &'static str, default: [f64; 2], doc: &'static str) -> PortDef {
        input(name, Type::Vec2, ConstValue::Vec2(default), doc)
    }

    /// A generic input (type `T`) whose default is a float broadcast to `T`.
    pub fn generic(name: &'static str, default: f64, doc: &'static str) -> PortDef {
        PortDef {
            name,
            ty: PortType::Generic,
            default: PortDefault::Value(ConstValue::Float(default)),
            options: &[],
            doc,
        }
    }

    /// An input bound to an implicit stream unless connected.
    pub fn stream(name: &'static str, ty: Type, s: Stream, doc: &'static str) -> PortDef {
        PortDef {
            name,
            ty: PortType::Simple(ty),
            default: PortDefault::Stream(s),
            options: &[],
            doc,
        }
    }

    /// A string option input.
    pub fn option(
        name: &'static str,
        default: &'static str,
        options: &'static [&'static str],
        doc: &'static str,
    ) -> PortDef {
        PortDef {
            name,
            ty: PortType::Simple(Type::String),
            default: PortDefault::Value(ConstValue::String(default.to_string())),
            options,
            doc,
        }
    }

    /// A space option input (`world`, `camera`, `object`).
    pub fn space(name: &'static str, default: &'static str, doc: &'static str) -> PortDef {
        option(name, default, &["world", "camera", "object"], doc)
    }

    /// An array-of-records input.
    pub fn array(
        name: &'static str,
        fields: Vec<(&'static str, Option<Type>)>,
        doc: &'static str,
    ) -> PortDef {
        PortDef {
            name,
            ty: PortType::Array(fields),
            default: PortDefault::EmptyArray,
            options: &[],
            doc,
        }
    }

    /// An output of a fixed type.
    pub fn out(name: &'static str, ty: Type, doc: &'static str) -> OutDef {
        OutDef {
            name,
            ty: Some(ty),
            doc,
        }
    }

    /// An output of the generic type `T`.
    pub fn out_generic(name: &'static str, doc: &'static str) -> OutDef {
        OutDef {
            name,
            ty: None,
            doc,
        }
    }
}

/// Parses a space option (validated by the linker against the port's options).
pub fn space_of(s: &str) -> Space {
    Space::from_name(s).unwrap_or(Space::World)
}

/// The float types generic math nodes accept.
pub const FLOAT_TYPES: &[Type] = &[Type::Float, Type::Vec2, Type::Vec3, Type::Color];

/// A set of node definitions, by type name.
#[derive(Clone, Debug, Default)]
pub struct NodeLibrary {
    defs: Vec<NodeDef>,
    by_name: HashMap<&'static str, usize>,
}

impl NodeLibrary {
    /// An empty library.
    pub fn new() -> NodeLibrary {
        NodeLibrary::default()
    }

    /// The standard node library.
    pub fn standard() -> NodeLibrary {
        let mut lib = NodeLibrary::new();
        math::register(&mut lib);
        structure::register(&mut lib);
        pattern::register(&mut lib);
        geometry::register(&mut lib);
        surface::register(&mut lib);
        utility::register(&mut lib);
        lib
    }

    /// Adds a definition; a later definition of the same name replaces the earlier one.
    pub fn add(&mut self, def: NodeDef) {
        if let Some(&i) = self.by_name.get(def.name) {
            self.defs[i] = def;
        } else {
            self.by_name.insert(def.name, self.defs.len());
            self.defs.push(def);
        }
    }

    /// The definition of a node type.
    pub fn get(&self, name: &str) -> Option<&NodeDef> {
        self.by_name.get(name).map(|&i| &self.defs[i])
    }

    /// Every definition, in registration order.
    pub fn defs(&self) -> &[NodeDef] {
        &self.defs
    }

    /// The node reference in Markdown (what `shadenet nodes` prints and `docs/nodes.md`
    /// holds).
    pub fn reference(&self) -> String {
        let mut s = String::from(
            "# Node reference\n\nGenerated by `shadenet nodes`; do not edit by hand.\n\
             `T` is a generic node's type, chosen per instance by the linker.\n",
        );
        let mut categories: Vec<&str> = Vec::new();
        for d in &self.defs {
            if !categories.contains(&d.category) {
                categories.push(d.category);
            }
        }
        for cat in categories {
            let _ = write!(s, "\n## {cat}\n");
            for d in self.defs.iter().filter(|d| d.category == cat) {
                let _ = write!(s, "\n### `{}`\n\n{}\n", d.name, d.doc.trim());
                if !d.generic.is_empty() {
                    let tys: Vec<&str> = d.generic.iter().map(|t| t.name()).collect();
                    let _ = write!(s, "\n`T` ∈ {{{}}}.\n", tys.join(", "));
                }
                if !d.inputs.is_empty() {
                    s.push_str("\n| input | type | default | |\n|---|---|---|---|\n");
                    for p in &d.inputs {
                        let ty = match &p.ty {
                            PortType::Simple(t) => t.name().to_string(),
                            PortType::Generic => "T".to_string(),
                            PortType::Array(fields) => {
                                let f: Vec<String> = fields
                                    .iter()
                                    .map(|(n, t)| format!("{n}: {}", t.map_or("T", |t| t.name())))
                                    .collect();
                                format!("[{{{}}}]", f.join(", "))
                            }
                        };
                        let default = match &p.default {
                            PortDefault::Value(v) => format!("`{v}`"),
                            PortDefault::Stream(st) => format!("stream `{}`", st.name()),
                            PortDefault::EmptyArray => "`[]`".to_string(),
                            PortDefault::EmptyClosure => "none (black)".to_string(),
                        };
                        let mut doc = p.doc.to_string();
                        if !p.options.is_empty() {
                            let _ = write!(doc, " One of: {}.", p.options.join(", "));
                        }
                        let _ = writeln!(s, "| `{}` | {ty} | {default} | {doc} |", p.name);
                    }
                }
                if !d.outputs.is_empty() {
                    s.push_str("\n| output | type | |\n|---|---|---|\n");
                    for o in &d.outputs {
                        let _ = writeln!(
                            s,
                            "| `{}` | {} | {} |",
                            o.name,
                            o.ty.map_or("T", |t| t.name()),
                            o.doc
                        );
                    }
                }
            }
        }
        s
    }
}

/// Helpers shared by lowerings.
pub mod lowering {
    use super::LowVal;
    use crate::ir::{Builder, Value};
    use crate::types::Type;

    /// Computes a contribution to render component `name` only where the component is
    /// active: `component_enabled(k) ? f() : 0`, as an `If` region so an inactive
    /// component costs nothing. Returns the value and its part.
    pub fn contribution(
        b: &mut Builder,
        name: &str,
        ty: Type,
        f: impl FnOnce(&mut Builder) -> Value,
    ) -> (u8, Value) {
        let k = b.component(name);
        let on = b.component_enabled(name);
        let r = b.if_(on, |b| vec![f(b)], |b| vec![b.zero(ty)]);
        (k, r[0])
    }

    /// The sum of contributions as a [`LowVal`] whose parts are the contributions.
    pub fn sum_parts(b: &mut Builder, ty: Type, parts: Vec<(u8, Value)>) -> LowVal {
        let mut total = None;
        for (_, v) in &parts {
            total = Some(match total {
                None => *v,
                Some(t) => b.add(t, *v),
            });
        }
        let value = total.unwrap_or_else(|| b.zero(ty));
        LowVal::with_parts(value, parts)
    }

    /// Applies `f` to the total and to each part (for ops linear in this input).
    pub fn map_parts(
        b: &mut Builder,
        v: &LowVal,
        mut f: impl FnMut(&mut Builder, Value) -> Value,
    ) -> LowVal {
        let value = f(b, v.value);
        let parts = v.parts.iter().map(|(k, p)| (*k, f(b, *p))).collect();
        LowVal::with_parts(value, parts)
    }

    /// `a + b` with parts: the parts of both, summed per component.
    pub fn add_parts(b: &mut Builder, x: &LowVal, y: &LowVal) -> LowVal {
        let value = b.add(x.value, y.value);
        if x.parts.is_empty() || y.parts.is_empty() {
            // An untagged term has no component: the sum keeps no parts rather than
            // misattributing it.
            return LowVal::plain(value);
        }
        let mut parts = x.parts.clone();
        for (k, p) in &y.parts {
            if let Some(slot) = parts.iter_mut().find(|(j, _)| j == k) {
                slot.1 = b.add(slot.1, *p);
            } else {
                parts.push((*k, *p));
            }
        }
        LowVal::with_parts(value, parts)
    }
}
