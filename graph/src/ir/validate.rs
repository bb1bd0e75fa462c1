//! The IR validator: checks that a [`Program`] is well formed, once, so that nothing
//! downstream (passes, interpreter, back ends) needs to check again (STYLE 4).
//!
//! The rules are listed on [`validate`](fn@validate).

use super::{AttributeDecl, Block, Op, Program, Value, is_traceable_ray_type};
use crate::ops;
use crate::types::Type;
use std::collections::HashMap;

/// The most render components a program may declare (bits of a `u32` mask).
const MAX_COMPONENTS: usize = 32;

/// Why a program is not valid; each variant names the value (or the declaration) at fault.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ValidationError {
    /// A block lists a handle past the end of the arena.
    #[error("{value:?} is listed in a block but is not in the arena")]
    NotInArena {
        /// The dangling handle.
        value: Value,
    },
    /// A value is listed twice: in two blocks, twice in one, or inside its own region.
    #[error("{value:?} is listed more than once in the program's blocks")]
    ListedTwice {
        /// The value.
        value: Value,
    },
    /// An operand (or a yield, for a region) is a handle past the end of the arena.
    #[error("{value:?} refers to {operand:?}, which is not in the arena")]
    OperandNotInArena {
        /// The user.
        value: Value,
        /// The dangling operand.
        operand: Value,
    },
    /// An operand is in the arena but in no block: it is never computed.
    #[error("{value:?} refers to {operand:?}, which is in no block")]
    OperandUnlisted {
        /// The user.
        value: Value,
        /// The operand.
        operand: Value,
    },
    /// An operand is not defined earlier in the user's block or an enclosing block (it comes
    /// later, or lives in a region that does not enclose the user).
    #[error(
        "{value:?} refers to {operand:?}, which is not defined before it in its block or an \
         enclosing block"
    )]
    OperandNotVisible {
        /// The user (for a yield: its region).
        value: Value,
        /// The operand.
        operand: Value,
    },
    /// A region is used where a typed value is needed; its results are read with `proj`.
    #[error("{value:?} uses region {operand:?} as a value; read its results with proj")]
    RegionAsValue {
        /// The user (for a yield: its region).
        value: Value,
        /// The region.
        operand: Value,
    },
    /// The recorded type is not the one the op gives.
    #[error("{value:?} is recorded as {} but its op gives {}", ty_name(.recorded), ty_name(.inferred))]
    WrongType {
        /// The value.
        value: Value,
        /// `Expr::ty`.
        recorded: Option<Type>,
        /// What the op rules give.
        inferred: Option<Type>,
    },
    /// The op is not defined on its operands' types.
    #[error("{value:?}: {reason}")]
    IllTyped {
        /// The value.
        value: Value,
        /// What does not fit.
        reason: String,
    },
    /// `texture` with an index past `Program::textures`.
    #[error("{value:?} reads texture {index}, but the program has {count}")]
    TextureIndex {
        /// The value.
        value: Value,
        /// The index.
        index: u32,
        /// `Program::textures.len()`.
        count: usize,
    },
    /// `attribute` with a slot past `Program::attributes`.
    #[error("{value:?} reads attribute {index}, but the program has {count}")]
    AttributeIndex {
        /// The value.
        value: Value,
        /// The slot.
        index: u32,
        /// `Program::attributes.len()`.
        count: usize,
    },
    /// A prelude value that is not uniform (it reads the fragment, lights, the component
    /// mask or a texture, or is a region) or that reads a value of the top-level block.
    #[error("{value:?} cannot be in the prelude: {reason}")]
    Prelude {
        /// The value.
        value: Value,
        /// Why.
        reason: String,
    },
    /// `param` with an index past `Program::params`.
    #[error("{value:?} reads parameter {index}, but the program has {count}")]
    ParamIndex {
        /// The value.
        value: Value,
        /// The index.
        index: u32,
        /// `Program::params.len()`.
        count: usize,
    },
    /// `component_enabled` with an index past `Program::components`.
    #[error("{value:?} asks for component {index}, but the program has {count}")]
    ComponentIndex {
        /// The value.
        value: Value,
        /// The index.
        index: u8,
        /// `Program::components.len()`.
        count: usize,
    },
    /// `proj` of something that is not a region.
    #[error("{value:?} projects {operand:?}, which is not an if or illuminance")]
    ProjOfNonRegion {
        /// The `proj`.
        value: Value,
        /// The operand.
        operand: Value,
    },
    /// `proj` with an index past the region's results.
    #[error("{value:?} reads result {index} of {region:?}, which has {count}")]
    ProjIndex {
        /// The `proj`.
        value: Value,
        /// The region.
        region: Value,
        /// The index.
        index: u8,
        /// The number of results.
        count: usize,
    },
    /// The arms of an `If` yield different types.
    #[error("{value:?}: the then arm yields {then_:?} but the else arm {else_:?}")]
    ArmsDiffer {
        /// The `If`.
        value: Value,
        /// The then arm's yield types.
        then_: Vec<Type>,
        /// The else arm's yield types.
        else_: Vec<Type>,
    },
    /// An illuminance body yields a value that cannot be summed.
    #[error("{value:?}: an illuminance body can only yield floats and vectors, not {ty}")]
    IlluminanceYield {
        /// The `Illuminance`.
        value: Value,
        /// The offending type.
        ty: Type,
    },
    /// A loop's `cond` block does not yield exactly one bool, or its `body` does not yield
    /// the carried values' types.
    #[error("{value:?}: {reason}")]
    LoopYields {
        /// The `Loop`.
        value: Value,
        /// What does not fit.
        reason: String,
    },
    /// `loop.var` outside a loop's blocks, or with an index past the innermost loop's
    /// carried values.
    #[error("{value:?} reads carried value {index}, but {reason}")]
    LoopVar {
        /// The `loop.var`.
        value: Value,
        /// Its index.
        index: u8,
        /// Why it is not there.
        reason: String,
    },
    /// `trace` with a ray type it cannot trace (see [`super::is_traceable_ray_type`]).
    #[error(
        "{value:?} traces rays of type {ray_type}: only reflection (4), refraction (8) and diffuse (16) rays can be traced"
    )]
    RayType {
        /// The `trace`.
        value: Value,
        /// Its ray type code.
        ray_type: i32,
    },
    /// `light.L`, `light.Cl` or `light.visible` outside an illuminance body.
    #[error("{value:?} reads the light sample outside an illuminance body")]
    LightOutsideIlluminance {
        /// The value.
        value: Value,
    },
    /// The top-level block yields values.
    #[error("the top-level block yields {count} values; it must yield none")]
    TopLevelYields {
        /// How many it yields.
        count: usize,
    },
    /// An output reads a value that is not in the top-level block.
    #[error("output `{output}` reads {value:?}, which is not defined in the top-level block")]
    OutputNotVisible {
        /// The output's name.
        output: String,
        /// The value.
        value: Value,
    },
    /// An output reads a region instead of one of its results.
    #[error("output `{output}` reads region {value:?}; read its results with proj")]
    OutputRegion {
        /// The output's name.
        output: String,
        /// The region.
        value: Value,
    },
    /// An output's component index is past `Program::components`.
    #[error("output `{output}` is tagged with component {index}, but the program has {count}")]
    OutputComponent {
        /// The output's name.
        output: String,
        /// The index.
        index: u8,
        /// `Program::components.len()`.
        count: usize,
    },
    /// A component name is declared twice.
    #[error("component `{name}` is declared twice")]
    DuplicateComponent {
        /// The name.
        name: String,
    },
    /// More components than a mask has bits.
    #[error("{count} components declared; at most 32 fit a component mask")]
    TooManyComponents {
        /// How many are declared.
        count: usize,
    },
    /// A parameter's default is not of the parameter's type.
    #[error("parameter {index} `{name}` is a {ty} but its default is a {default_ty}")]
    ParamDefault {
        /// The parameter's index.
        index: usize,
        /// Its name.
        name: String,
        /// Its declared type.
        ty: Type,
        /// Its default's type.
        default_ty: Type,
    },
}

fn ty_name(t: &Option<Type>) -> &'static str {
    t.map_or("no type", Type::name)
}

/// The declaration of attribute `slot`, which `value` reads (`attribute` or
/// `attribute.found`): in range and of a type attributes have.
fn attribute_decl(p: &Program, value: Value, slot: u32) -> Result<&AttributeDecl, ValidationError> {
    let Some(decl) = p.attributes.get(slot as usize) else {
        return Err(ValidationError::AttributeIndex {
            value,
            index: slot,
            count: p.attributes.len(),
        });
    };
    if !super::is_attribute_type(decl.ty) {
        return Err(ValidationError::IllTyped {
            value,
            reason: format!(
                "attribute {:?} is read as a {}; attributes are floats, vectors and colors",
                decl.name, decl.ty
            ),
        });
    }
    Ok(decl)
}

/// Checks that `p` is well formed: walks the program in evaluation order and returns the
/// first problem found. The rules:
///
/// - **structure**: every value listed in a block is in the arena and is listed exactly once
///   in the whole program; the top-level block yields nothing;
/// - **scoping**: an operand (or a yield) is defined earlier in the same block or in an
///   enclosing one. Values inside an `If` arm or an `Illuminance` body are not visible
///   outside it (their results leave through the yields, read with `proj`), and a region is
///   defined only after its blocks, so a `proj` comes after its region;
/// - **types**: each expr's recorded type is the one the op rules of [`crate::ops`] give
///   ([`ops::unary_type`], [`ops::binary_type`], [`ops::intrinsic_type`],
///   [`ops::convert_ok`], and the rules of [`Op`] for the others); region exprs have no
///   type and are only read through `proj`;
/// - **regions**: an `If` condition is a bool and both arms yield the same types; an
///   `Illuminance` point is a vec3 and its yields are float-based; `light.L`, `light.Cl` and
///   `light.visible` occur only inside an illuminance body (at any depth);
/// - **scene queries**: `trace` takes a vec3 and a reflection, refraction or diffuse ray
///   type and gives a color; `occlusion` takes (vec3, int, float) and gives a float; neither
///   may be in the prelude (they are varying);
/// - **indices**: parameter, component and result indices are in range; component names are
///   distinct and at most 32 (one bit each in a component mask); a parameter's default has
///   the parameter's type;
/// - **outputs**: each reads a typed value of the top-level block.
///
/// Values are named by their arena handle (`v12`), not by their number in the text form.
pub fn validate(p: &Program) -> Result<(), ValidationError> {
    check_declarations(p)?;
    let mut v = Validator {
        p,
        listed: vec![false; p.exprs.len()],
        visible: vec![false; p.exprs.len()],
        region_types: HashMap::new(),
        illuminance_depth: 0,
        loops: Vec::new(),
    };
    v.list(&p.prelude)?;
    v.list(&p.body)?;
    if !p.prelude.yields.is_empty() {
        return Err(ValidationError::TopLevelYields {
            count: p.prelude.yields.len(),
        });
    }
    // The prelude: uniform values only, visible to everything after them.
    for &value in &p.prelude.body {
        let reason = match &p.exprs[value.index()].op {
            Op::Stream(_) | Op::Transform { .. } => Some("it reads the fragment"),
            Op::ComponentEnabled(_) => Some("it reads the component mask"),
            Op::LightL | Op::LightCl | Op::LightVisible | Op::LightPdf | Op::Ambient => {
                Some("it reads the lights")
            }
            Op::Trace { .. } | Op::Occlusion { .. } | Op::Probe { .. } => {
                Some("it asks the scene for rays")
            }
            Op::Texture { .. } => Some("it reads a texture"),
            Op::Attribute { .. } | Op::AttributeFound { .. } => {
                Some("it reads the geometry's attributes")
            }
            Op::If { .. } | Op::Illuminance { .. } | Op::Loop { .. } | Op::Proj(..) => {
                Some("it is a region")
            }
            Op::LoopVar(_) => Some("it reads a loop's carried value"),
            Op::Print { .. } => Some("it writes a message for each fragment"),
            _ => None,
        };
        if let Some(reason) = reason {
            return Err(ValidationError::Prelude {
                value,
                reason: reason.into(),
            });
        }
        v.value(value)?;
        v.visible[value.index()] = true;
    }
    if !p.body.yields.is_empty() {
        return Err(ValidationError::TopLevelYields {
            count: p.body.yields.len(),
        });
    }
    // The top-level values stay visible afterwards, for the outputs.
    for &value in &p.body.body {
        v.value(value)?;
        v.visible[value.index()] = true;
    }
    for o in &p.outputs {
        let value = o.value;
        let visible = v.visible.get(value.index()).copied().unwrap_or(false);
        if !visible {
            let output = o.name.clone();
            return Err(ValidationError::OutputNotVisible { output, value });
        }
        if p.exprs[value.index()].ty.is_none() {
            let output = o.name.clone();
            return Err(ValidationError::OutputRegion { output, value });
        }
        if let Some(index) = o.component.filter(|k| *k as usize >= p.components.len()) {
            return Err(ValidationError::OutputComponent {
                output: o.name.clone(),
                index,
                count: p.components.len(),
            });
        }
    }
    Ok(())
}

/// Components and parameter declarations.
fn check_declarations(p: &Program) -> Result<(), ValidationError> {
    if p.components.len() > MAX_COMPONENTS {
        return Err(ValidationError::TooManyComponents {
            count: p.components.len(),
        });
    }
    for (i, name) in p.components.iter().enumerate() {
        if p.components[..i].contains(name) {
            return Err(ValidationError::DuplicateComponent { name: name.clone() });
        }
    }
    for (index, d) in p.params.iter().enumerate() {
        if d.default.ty() != d.ty {
            return Err(ValidationError::ParamDefault {
                index,
                name: d.name.clone(),
                ty: d.ty,
                default_ty: d.default.ty(),
            });
        }
    }
    Ok(())
}

struct Validator<'a> {
    p: &'a Program,
    /// Listed in some block (after [`Validator::list`]).
    listed: Vec<bool>,
    /// Defined and in scope at the current point of the walk.
    visible: Vec<bool>,
    /// The result types of the regions checked so far.
    region_types: HashMap<Value, Vec<Type>>,
    /// How many illuminance bodies enclose the current point.
    illuminance_depth: usize,
    /// The carried types of the loops enclosing the current point, innermost last.
    loops: Vec<Vec<Type>>,
}

impl Validator<'_> {
    /// Marks every listed value; fails on dangling or repeated listings (so the blocks form
    /// a tree and the walk below terminates).
    fn list(&mut self, block: &Block) -> Result<(), ValidationError> {
        for &value in &block.body {
            let Some(e) = self.p.exprs.get(value.index()) else {
                return Err(ValidationError::NotInArena { value });
            };
            if std::mem::replace(&mut self.listed[value.index()], true) {
                return Err(ValidationError::ListedTwice { value });
            }
            for inner in e.op.blocks() {
                self.list(inner)?;
            }
        }
        Ok(())
    }

    /// Checks a region's block and returns its yield types; its values go out of scope
    /// afterwards.
    fn block(&mut self, region: Value, block: &Block) -> Result<Vec<Type>, ValidationError> {
        for &value in &block.body {
            self.value(value)?;
            self.visible[value.index()] = true;
        }
        let tys = block
            .yields
            .iter()
            .map(|y| self.operand(region, *y))
            .collect::<Result<Vec<Type>, _>>()?;
        for &value in &block.body {
            self.visible[value.index()] = false;
        }
        Ok(tys)
    }

    /// A loop's blocks: `cond` yields one bool, `body` the carried types.
    fn loop_region(
        &mut self,
        value: Value,
        carried: Vec<Type>,
        cond: &Block,
        body: &Block,
    ) -> Result<(), ValidationError> {
        self.loops.push(carried.clone());
        let ct = self.block(value, cond);
        let bt = self.block(value, body);
        self.loops.pop();
        let (ct, bt) = (ct?, bt?);
        let names = |ts: &[Type]| ts.iter().map(|t| t.name()).collect::<Vec<_>>().join(", ");
        if ct != [Type::Bool] {
            let reason = format!("the loop condition yields ({}), not one bool", names(&ct));
            return Err(ValidationError::LoopYields { value, reason });
        }
        if bt != carried {
            let reason = format!(
                "the loop body yields ({}) but the loop carries ({})",
                names(&bt),
                names(&carried)
            );
            return Err(ValidationError::LoopYields { value, reason });
        }
        self.region_types.insert(value, carried);
        Ok(())
    }

    /// An operand that must be visible here, with its expr.
    fn visible_operand(
        &self,
        value: Value,
        operand: Value,
    ) -> Result<Option<Type>, ValidationError> {
        let Some(e) = self.p.exprs.get(operand.index()) else {
            return Err(ValidationError::OperandNotInArena { value, operand });
        };
        if !self.listed[operand.index()] {
            return Err(ValidationError::OperandUnlisted { value, operand });
        }
        if !self.visible[operand.index()] {
            return Err(ValidationError::OperandNotVisible { value, operand });
        }
        Ok(e.ty)
    }

    /// A typed operand visible here: its type.
    fn operand(&self, value: Value, operand: Value) -> Result<Type, ValidationError> {
        // A visible operand has been checked: only regions lack a type.
        self.visible_operand(value, operand)?
            .ok_or(ValidationError::RegionAsValue { value, operand })
    }

    fn operands(&self, value: Value, args: &[Value]) -> Result<Vec<Type>, ValidationError> {
        args.iter().map(|a| self.operand(value, *a)).collect()
    }

    /// Checks one value (and the blocks of a region).
    fn value(&mut self, value: Value) -> Result<(), ValidationError> {
        let p = self.p;
        let e = &p.exprs[value.index()];
        let ill = |reason: String| ValidationError::IllTyped { value, reason };
        let tys = |ts: &[Type]| ts.iter().map(|t| t.name()).collect::<Vec<_>>().join(", ");
        let inferred: Option<Type> = match &e.op {
            Op::Const(c) => Some(c.ty()),
            Op::Param(index) => match p.params.get(*index as usize) {
                Some(d) => Some(d.ty),
                None => {
                    return Err(ValidationError::ParamIndex {
                        value,
                        index: *index,
                        count: p.params.len(),
                    });
                }
            },
            Op::Stream(s) => Some(s.ty()),
            Op::Texture {
                texture,
                uv,
                derivs,
                alpha,
                ..
            } => {
                if *texture as usize >= p.textures.len() {
                    return Err(ValidationError::TextureIndex {
                        value,
                        index: *texture,
                        count: p.textures.len(),
                    });
                }
                let t = self.operand(value, *uv)?;
                if t != Type::Vec2 {
                    return Err(ill(format!("texture coordinates are {t}, not vec2")));
                }
                for d in derivs.iter().flatten() {
                    let t = self.operand(value, *d)?;
                    if t != Type::Vec2 {
                        return Err(ill(format!("texture derivatives are {t}, not vec2")));
                    }
                }
                Some(if *alpha { Type::Float } else { Type::Color })
            }
            Op::Attribute { slot, default } => {
                let decl = attribute_decl(p, value, *slot)?;
                let t = self.operand(value, *default)?;
                if t != decl.ty {
                    return Err(ill(format!(
                        "attribute {:?} is a {} but its default is a {t}",
                        decl.name, decl.ty
                    )));
                }
                Some(decl.ty)
            }
            Op::AttributeFound { slot } => {
                attribute_decl(p, value, *slot)?;
                Some(Type::Bool)
            }
            Op::Transform { arg, .. } => {
                let t = self.operand(value, *arg)?;
                if t != Type::Vec3 {
                    return Err(ill(format!("transform needs a vec3, not a {t}")));
                }
                Some(Type::Vec3)
            }
            Op::ComponentEnabled(index) => {
                if *index as usize >= p.components.len() {
                    return Err(ValidationError::ComponentIndex {
                        value,
                        index: *index,
                        count: p.components.len(),
                    });
                }
                Some(Type::Bool)
            }
            Op::Unary(op, a) => {
                let t = self.operand(value, *a)?;
                let r = ops::unary_type(*op, t);
                Some(r.ok_or_else(|| ill(format!("{} is not defined on {t}", op.name())))?)
            }
            Op::Binary(op, a, b) => {
                let (at, bt) = (self.operand(value, *a)?, self.operand(value, *b)?);
                let r = ops::binary_type(*op, at, bt);
                Some(r.ok_or_else(|| ill(format!("{} is not defined on ({at}, {bt})", op.name())))?)
            }
            Op::Select { cond, a, b } => {
                let ct = self.operand(value, *cond)?;
                let (at, bt) = (self.operand(value, *a)?, self.operand(value, *b)?);
                if ct != Type::Bool {
                    return Err(ill(format!("select condition is a {ct}, not a bool")));
                }
                if at != bt {
                    return Err(ill(format!("select between a {at} and a {bt}")));
                }
                Some(at)
            }
            Op::Construct(args) => {
                let ts = self.operands(value, args)?;
                match e.ty {
                    Some(t)
                        if (t.is_vector() || t.is_matrix())
                            && ts.len() == t.width()
                            && ts.iter().all(|x| *x == Type::Float) =>
                    {
                        Some(t)
                    }
                    _ => {
                        let to = ty_name(&e.ty);
                        return Err(ill(format!("cannot construct {to} from ({})", tys(&ts))));
                    }
                }
            }
            Op::Extract(a, index) => {
                let t = self.operand(value, *a)?;
                if !(t.is_vector() || t.is_matrix()) || *index as usize >= t.width() {
                    return Err(ill(format!("no component {index} in a {t}")));
                }
                Some(Type::Float)
            }
            Op::Splat(a) => {
                let t = self.operand(value, *a)?;
                match e.ty {
                    Some(to) if t == Type::Float && to.is_vector() => Some(to),
                    _ => return Err(ill(format!("cannot splat a {t} to {}", ty_name(&e.ty)))),
                }
            }
            Op::Convert(a) => {
                let t = self.operand(value, *a)?;
                match e.ty {
                    Some(to) if ops::convert_ok(t, to) => Some(to),
                    _ => return Err(ill(format!("cannot convert a {t} to {}", ty_name(&e.ty)))),
                }
            }
            Op::Call(i, args) => {
                let ts = self.operands(value, args)?;
                let r = ops::intrinsic_type(*i, &ts);
                Some(r.ok_or_else(|| ill(format!("{} does not take ({})", i.name(), tys(&ts))))?)
            }
            Op::If { cond, then_, else_ } => {
                let ct = self.operand(value, *cond)?;
                if ct != Type::Bool {
                    return Err(ill(format!("if condition is a {ct}, not a bool")));
                }
                let tt = self.block(value, then_)?;
                let et = self.block(value, else_)?;
                if tt != et {
                    return Err(ValidationError::ArmsDiffer {
                        value,
                        then_: tt,
                        else_: et,
                    });
                }
                self.region_types.insert(value, tt);
                None
            }
            Op::Illuminance { p: point, body } => {
                let pt = self.operand(value, *point)?;
                if pt != Type::Vec3 {
                    return Err(ill(format!("illuminance point is a {pt}, not a vec3")));
                }
                self.illuminance_depth += 1;
                let bt = self.block(value, body)?;
                self.illuminance_depth -= 1;
                if let Some(ty) = bt.iter().copied().find(|t| !t.is_float_based()) {
                    return Err(ValidationError::IlluminanceYield { value, ty });
                }
                self.region_types.insert(value, bt);
                None
            }
            Op::Loop { init, cond, body } => {
                let types = self.operands(value, init)?;
                self.loop_region(value, types, cond, body)?;
                None
            }
            Op::LoopVar(index) => {
                let Some(carried) = self.loops.last() else {
                    let reason = "it is not inside a loop".into();
                    return Err(ValidationError::LoopVar {
                        value,
                        index: *index,
                        reason,
                    });
                };
                match carried.get(*index as usize) {
                    Some(t) => Some(*t),
                    None => {
                        let reason = format!("the innermost loop carries {}", carried.len());
                        return Err(ValidationError::LoopVar {
                            value,
                            index: *index,
                            reason,
                        });
                    }
                }
            }
            Op::LightL | Op::LightCl | Op::LightVisible | Op::LightPdf => {
                if self.illuminance_depth == 0 {
                    return Err(ValidationError::LightOutsideIlluminance { value });
                }
                Some(match e.op {
                    Op::LightL => Type::Vec3,
                    Op::LightCl => Type::Color,
                    _ => Type::Float,
                })
            }
            Op::Trace { dir, ray_type, pdf } => {
                let t = self.operand(value, *dir)?;
                if t != Type::Vec3 {
                    return Err(ill(format!("trace direction is a {t}, not a vec3")));
                }
                if let Some(p) = pdf {
                    let t = self.operand(value, *p)?;
                    if t != Type::Float {
                        return Err(ill(format!("trace pdf is a {t}, not a float")));
                    }
                }
                if !is_traceable_ray_type(*ray_type) {
                    return Err(ValidationError::RayType {
                        value,
                        ray_type: *ray_type,
                    });
                }
                Some(Type::Color)
            }
            Op::Occlusion {
                n,
                samples,
                max_distance,
            } => {
                let ts = self.operands(value, &[*n, *samples, *max_distance])?;
                if ts != [Type::Vec3, Type::Int, Type::Float] {
                    return Err(ill(format!(
                        "occlusion takes (vec3, int, float), not ({})",
                        tys(&ts)
                    )));
                }
                Some(Type::Float)
            }
            Op::Probe {
                field,
                origin,
                dir,
                min_distance,
                max_distance,
            } => {
                let ts = self.operands(value, &[*origin, *dir, *min_distance, *max_distance])?;
                if ts != [Type::Vec3, Type::Vec3, Type::Float, Type::Float] {
                    return Err(ill(format!(
                        "probe takes (vec3, vec3, float, float), not ({})",
                        tys(&ts)
                    )));
                }
                Some(field.ty())
            }
            Op::Print { format, args, .. } => {
                let ts = self.operands(value, args)?;
                let placeholders = ts
                    .iter()
                    .map(|t| crate::ops::printf::placeholder(*t))
                    .collect::<Option<Vec<_>>>()
                    .ok_or_else(|| ill(format!("a message cannot format a ({})", tys(&ts))))?;
                crate::ops::printf::format(format, &placeholders)
                    .map_err(|e| ill(format!("message format {format:?}: {e}")))?;
                Some(Type::Int)
            }
            Op::Ambient => Some(Type::Color),
            Op::Proj(region, index) => {
                let region = *region;
                self.visible_operand(value, region)?;
                if !p.op(region).is_region() {
                    return Err(ValidationError::ProjOfNonRegion {
                        value,
                        operand: region,
                    });
                }
                let results = self.region_types.get(&region).map_or(&[][..], |v| v);
                match results.get(*index as usize) {
                    Some(t) => Some(*t),
                    None => {
                        return Err(ValidationError::ProjIndex {
                            value,
                            region,
                            index: *index,
                            count: results.len(),
                        });
                    }
                }
            }
        };
        if let Some(t @ Type::Closure(_)) = e.ty {
            return Err(ValidationError::IllTyped {
                value,
                reason: format!("a {t} is a compile-time lobe list, never an IR value"),
            });
        }
        if e.ty != inferred {
            return Err(ValidationError::WrongType {
                value,
                recorded: e.ty,
                inferred,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::{
        BinOp, Builder, Expr, Intrinsic, Output, ParamDecl, RAY_CAMERA, RAY_DIFFUSE,
        RAY_REFLECTION, RAY_REFRACTION, RAY_SHADOW, Stream, UnOp,
    };
    use crate::types::ConstValue;

    /// A valid program and the handles the tests break it through.
    struct Base {
        p: Program,
        f: Value,
        c: Value,
        pos: Value,
        sum: Value,
        enabled: Value,
        region: Value,
        then_val: Value,
        proj: Value,
        illum: Value,
        light_l: Value,
        nested_cl: Value,
        illum_proj: Value,
        param: Value,
    }

    fn region_of(p: &Program, proj: Value) -> Value {
        match p.op(proj) {
            Op::Proj(r, _) => *r,
            other => panic!("not a proj: {other:?}"),
        }
    }

    fn base() -> Base {
        let mut b = Builder::new("base");
        let f = b.float(0.5);
        let c = b.color([1.0, 0.5, 0.25]);
        let pos = b.stream(Stream::P);
        let sum = b.add(f, f);
        let enabled = b.component_enabled("diffuse");
        let param = b.push(Op::Param(0), Some(Type::Color));
        let mut then_val = None;
        let r = b.if_(
            enabled,
            |b| {
                let x = b.mul(c, param);
                then_val = Some(x);
                vec![x, sum]
            },
            |_| vec![c, f],
        );
        let (mut light_l, mut nested_cl) = (None, None);
        let lit = b.illuminance(pos, |b, l, cl| {
            light_l = Some(l);
            let d = b.dot(l, l);
            let zero = b.float(0.0);
            let front = b.binary(BinOp::Gt, d, zero);
            // The light sample is readable at any depth inside the body.
            let inner = b.if_(
                front,
                |b| {
                    let cl2 = b.push(Op::LightCl, Some(Type::Color));
                    nested_cl = Some(cl2);
                    vec![cl2]
                },
                |_| vec![cl],
            );
            vec![inner[0], d]
        });
        let total = b.add(lit[0], r[0]);
        b.output("color", Some(0), total);
        b.output("alpha", None, r[1]);
        let mut p = b.finish().expect("builds");
        p.params.push(ParamDecl {
            name: "surf.color".into(),
            ty: Type::Color,
            default: ConstValue::Color([0.5; 3]),
        });
        Base {
            region: region_of(&p, r[0]),
            illum: region_of(&p, lit[0]),
            p,
            f,
            c,
            pos,
            sum,
            enabled,
            then_val: then_val.unwrap(),
            proj: r[0],
            light_l: light_l.unwrap(),
            nested_cl: nested_cl.unwrap(),
            illum_proj: lit[0],
            param,
        }
    }

    /// Appends an expr to the top-level block.
    fn push(p: &mut Program, op: Op, ty: Option<Type>) -> Value {
        p.exprs.push(Expr { op, ty });
        let v = Value::new(p.exprs.len() - 1);
        p.body.body.push(v);
        v
    }

    fn err(p: &Program) -> ValidationError {
        validate(p).expect_err("the program should be invalid")
    }

    fn blocks_mut(p: &mut Program, region: Value) -> Vec<&mut Block> {
        match &mut p.exprs[region.index()].op {
            Op::If { then_, else_, .. } => vec![then_, else_],
            Op::Illuminance { body, .. } => vec![body],
            Op::Loop { cond, body, .. } => vec![cond, body],
            _ => panic!("not a region"),
        }
    }

    #[test]
    fn base_is_valid() {
        let b = base();
        assert_eq!(validate(&b.p), Ok(()));
        // It reads the light inside a nested if and through illuminance results.
        assert_eq!(b.p.op(b.nested_cl), &Op::LightCl);
        assert!(matches!(b.p.op(b.illum), Op::Illuminance { .. }));
    }

    #[test]
    fn programs_with_every_op_validate() {
        // Ops the base does not use.
        let mut b = base();
        let p = &mut b.p;
        let m = push(p, Op::Const(ConstValue::identity()), Some(Type::Matrix44));
        let x = push(p, Op::Binary(BinOp::MulPoint, m, b.pos), Some(Type::Vec3));
        push(p, Op::Binary(BinOp::MulVector, m, x), Some(Type::Vec3));
        let e = push(p, Op::Extract(b.c, 2), Some(Type::Float));
        push(p, Op::Construct(vec![e, b.f]), Some(Type::Vec2));
        push(p, Op::Splat(e), Some(Type::Color));
        let i = push(p, Op::Convert(e), Some(Type::Int));
        push(p, Op::Convert(i), Some(Type::Bool));
        push(
            p,
            Op::Call(Intrinsic::Fbm3, vec![b.pos, i, e, e]),
            Some(Type::Float),
        );
        push(p, Op::Unary(UnOp::Length, b.c), Some(Type::Float));
        let t = push(p, Op::Const(ConstValue::Bool(true)), Some(Type::Bool));
        push(
            p,
            Op::Select {
                cond: t,
                a: b.c,
                b: b.c,
            },
            Some(Type::Color),
        );
        push(p, Op::Ambient, Some(Type::Color));
        push(p, Op::Stream(Stream::RayDepth), Some(Type::Int));
        push(
            p,
            Op::Transform {
                kind: crate::ir::XformKind::Normal,
                from: crate::ir::Space::Object,
                to: crate::ir::Space::World,
                arg: b.pos,
            },
            Some(Type::Vec3),
        );
        push(
            p,
            Op::Const(ConstValue::String("x".into())),
            Some(Type::String),
        );
        assert_eq!(validate(p), Ok(()));
    }

    // ---- structure ----

    #[test]
    fn dangling_listing() {
        let mut b = base();
        b.p.body.body.push(Value::new(999));
        assert_eq!(
            err(&b.p),
            ValidationError::NotInArena {
                value: Value::new(999)
            }
        );
    }

    #[test]
    fn value_in_two_blocks() {
        let mut b = base();
        b.p.body.body.push(b.then_val);
        assert_eq!(
            err(&b.p),
            ValidationError::ListedTwice { value: b.then_val }
        );
    }

    #[test]
    fn value_twice_in_one_block() {
        let mut b = base();
        b.p.body.body.insert(1, b.f);
        assert_eq!(err(&b.p), ValidationError::ListedTwice { value: b.f });
    }

    #[test]
    fn region_inside_itself() {
        let mut b = base();
        let region = b.region;
        blocks_mut(&mut b.p, region)[1].body.push(region);
        assert_eq!(err(&b.p), ValidationError::ListedTwice { value: region });
    }

    #[test]
    fn top_level_yields() {
        let mut b = base();
        b.p.body.yields.push(b.f);
        assert_eq!(err(&b.p), ValidationError::TopLevelYields { count: 1 });
    }

    // ---- scoping ----

    #[test]
    fn operand_past_the_arena() {
        let mut b = base();
        let v = push(
            &mut b.p,
            Op::Unary(UnOp::Neg, Value::new(500)),
            Some(Type::Float),
        );
        let want = ValidationError::OperandNotInArena {
            value: v,
            operand: Value::new(500),
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn operand_in_no_block() {
        let mut b = base();
        b.p.exprs.push(Expr {
            op: Op::Const(ConstValue::Float(1.0)),
            ty: Some(Type::Float),
        });
        let ghost = Value::new(b.p.exprs.len() - 1);
        let v = push(&mut b.p, Op::Unary(UnOp::Neg, ghost), Some(Type::Float));
        let want = ValidationError::OperandUnlisted {
            value: v,
            operand: ghost,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn forward_reference() {
        let mut b = base();
        // `sum` reads `f`; put `sum` first.
        let body = &mut b.p.body.body;
        let (fi, si) = (
            body.iter().position(|v| *v == b.f).unwrap(),
            body.iter().position(|v| *v == b.sum).unwrap(),
        );
        body.swap(fi, si);
        let want = ValidationError::OperandNotVisible {
            value: b.sum,
            operand: b.f,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn arm_value_read_outside_its_region() {
        let mut b = base();
        let v = push(
            &mut b.p,
            Op::Unary(UnOp::Neg, b.then_val),
            Some(Type::Color),
        );
        let want = ValidationError::OperandNotVisible {
            value: v,
            operand: b.then_val,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn arm_value_read_from_the_other_arm() {
        let mut b = base();
        let region = b.region;
        let then_val = b.then_val;
        blocks_mut(&mut b.p, region)[1].yields[0] = then_val;
        let want = ValidationError::OperandNotVisible {
            value: region,
            operand: then_val,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn yield_of_a_nested_value() {
        // The illuminance body yields a value from inside its nested if.
        let mut b = base();
        let illum = b.illum;
        let cl = b.nested_cl;
        blocks_mut(&mut b.p, illum)[0].yields[0] = cl;
        let want = ValidationError::OperandNotVisible {
            value: illum,
            operand: cl,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn proj_before_its_region() {
        let mut b = base();
        let body = &mut b.p.body.body;
        let ri = body.iter().position(|v| *v == b.region).unwrap();
        let pi = body.iter().position(|v| *v == b.proj).unwrap();
        let proj = body.remove(pi);
        body.insert(ri, proj);
        let want = ValidationError::OperandNotVisible {
            value: b.proj,
            operand: b.region,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn region_used_as_a_value() {
        let mut b = base();
        let v = push(
            &mut b.p,
            Op::Binary(BinOp::Add, b.region, b.c),
            Some(Type::Color),
        );
        let want = ValidationError::RegionAsValue {
            value: v,
            operand: b.region,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn region_yielded_as_a_value() {
        let mut b = base();
        let illum = b.illum;
        // The illuminance body yields its own nested if instead of a result of it.
        let inner = match b.p.op(illum) {
            Op::Illuminance { body, .. } => body.body.iter().copied(),
            _ => unreachable!(),
        }
        .find(|v| matches!(b.p.op(*v), Op::If { .. }))
        .unwrap();
        blocks_mut(&mut b.p, illum)[0].yields[1] = inner;
        let want = ValidationError::RegionAsValue {
            value: illum,
            operand: inner,
        };
        assert_eq!(err(&b.p), want);
    }

    // ---- types ----

    #[test]
    fn wrong_recorded_type() {
        let mut b = base();
        b.p.exprs[b.sum.index()].ty = Some(Type::Vec3);
        let want = ValidationError::WrongType {
            value: b.sum,
            recorded: Some(Type::Vec3),
            inferred: Some(Type::Float),
        };
        assert_eq!(err(&b.p), want);
        assert_eq!(
            want.to_string(),
            format!("{:?} is recorded as vec3 but its op gives float", b.sum)
        );
    }

    #[test]
    fn missing_type() {
        let mut b = base();
        b.p.exprs[b.pos.index()].ty = None;
        let want = ValidationError::WrongType {
            value: b.pos,
            recorded: None,
            inferred: Some(Type::Vec3),
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn typed_region() {
        let mut b = base();
        b.p.exprs[b.region.index()].ty = Some(Type::Color);
        let want = ValidationError::WrongType {
            value: b.region,
            recorded: Some(Type::Color),
            inferred: None,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn const_stream_param_and_proj_types() {
        type Pick = fn(&Base) -> Value;
        let cases: [(Pick, Type, Type); 5] = [
            (|b| b.c, Type::Vec3, Type::Color),
            (|b| b.pos, Type::Color, Type::Vec3),
            (|b| b.param, Type::Vec3, Type::Color),
            (|b| b.proj, Type::Float, Type::Color),
            (|b| b.illum_proj, Type::Vec3, Type::Color),
        ];
        for (pick, recorded, inferred) in cases {
            let mut b = base();
            let v = pick(&b);
            b.p.exprs[v.index()].ty = Some(recorded);
            let want = ValidationError::WrongType {
                value: v,
                recorded: Some(recorded),
                inferred: Some(inferred),
            };
            assert_eq!(err(&b.p), want);
        }
    }

    #[test]
    fn light_types() {
        let mut b = base();
        b.p.exprs[b.light_l.index()].ty = Some(Type::Color);
        assert!(matches!(
            err(&b.p),
            ValidationError::WrongType { value, .. } if value == b.light_l
        ));
    }

    /// Appends `op` with type `ty` and expects `IllTyped` naming it, with `reason` in the
    /// message.
    fn ill_typed(op: impl FnOnce(&Base) -> Op, ty: Type, reason: &str) {
        let mut b = base();
        let op = op(&b);
        let v = push(&mut b.p, op, Some(ty));
        match err(&b.p) {
            ValidationError::IllTyped { value, reason: r } => {
                assert_eq!(value, v);
                assert!(r.contains(reason), "{r:?} lacks {reason:?}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn op_rules() {
        ill_typed(
            |b| Op::Unary(UnOp::Not, b.f),
            Type::Bool,
            "not is not defined on float",
        );
        ill_typed(
            |b| Op::Binary(BinOp::Add, b.f, b.c),
            Type::Float,
            "add is not defined on (float, color)",
        );
        ill_typed(
            |b| Op::Binary(BinOp::MulPoint, b.pos, b.pos),
            Type::Vec3,
            "mulpoint is not defined on (vec3, vec3)",
        );
        ill_typed(
            |b| Op::Binary(BinOp::MulVector, b.f, b.pos),
            Type::Vec3,
            "mulvector is not defined on (float, vec3)",
        );
        ill_typed(
            |b| Op::Call(Intrinsic::Noise3, vec![b.c]),
            Type::Float,
            "noise3 does not take (color)",
        );
        ill_typed(
            |b| Op::Select {
                cond: b.f,
                a: b.c,
                b: b.c,
            },
            Type::Color,
            "condition is a float",
        );
        ill_typed(
            |b| Op::Select {
                cond: b.enabled,
                a: b.c,
                b: b.pos,
            },
            Type::Color,
            "between a color and a vec3",
        );
        ill_typed(
            |b| Op::Construct(vec![b.f, b.f]),
            Type::Vec3,
            "cannot construct vec3 from (float, float)",
        );
        ill_typed(
            |b| Op::Construct(vec![b.f, b.c]),
            Type::Vec2,
            "cannot construct vec2 from (float, color)",
        );
        ill_typed(
            |b| Op::Construct(vec![b.f]),
            Type::Float,
            "cannot construct float",
        );
        ill_typed(
            |b| Op::Extract(b.c, 3),
            Type::Float,
            "no component 3 in a color",
        );
        ill_typed(
            |b| Op::Extract(b.f, 0),
            Type::Float,
            "no component 0 in a float",
        );
        ill_typed(|b| Op::Splat(b.c), Type::Color, "cannot splat a color");
        ill_typed(
            |b| Op::Splat(b.f),
            Type::Float,
            "cannot splat a float to float",
        );
        ill_typed(|b| Op::Convert(b.c), Type::Float, "cannot convert a color");
        ill_typed(
            |b| Op::Transform {
                kind: crate::ir::XformKind::Point,
                from: crate::ir::Space::World,
                to: crate::ir::Space::Camera,
                arg: b.c,
            },
            Type::Vec3,
            "transform needs a vec3, not a color",
        );
    }

    #[test]
    fn untyped_construct_splat_convert() {
        for op in [
            |b: &Base| Op::Construct(vec![b.f, b.f]),
            |b: &Base| Op::Splat(b.f),
            |b: &Base| Op::Convert(b.f),
        ] {
            let mut b = base();
            let op = op(&b);
            let v = push(&mut b.p, op, None);
            assert!(matches!(err(&b.p), ValidationError::IllTyped { value, .. } if value == v));
        }
    }

    // ---- regions ----

    #[test]
    fn if_condition_not_bool() {
        let mut b = base();
        let f = b.f;
        if let Op::If { cond, .. } = &mut b.p.exprs[b.region.index()].op {
            *cond = f;
        }
        assert!(matches!(
            err(&b.p),
            ValidationError::IllTyped { value, reason } if value == b.region && reason.contains("if condition")
        ));
    }

    #[test]
    fn arms_differ() {
        let mut b = base();
        let (region, f) = (b.region, b.f);
        blocks_mut(&mut b.p, region)[1].yields[0] = f;
        let want = ValidationError::ArmsDiffer {
            value: region,
            then_: vec![Type::Color, Type::Float],
            else_: vec![Type::Float, Type::Float],
        };
        assert_eq!(err(&b.p), want);
        // A different count.
        let mut b = base();
        blocks_mut(&mut b.p, region)[1].yields.pop();
        assert!(matches!(err(&b.p), ValidationError::ArmsDiffer { value, .. } if value == region));
    }

    #[test]
    fn illuminance_point_not_vec3() {
        let mut b = base();
        let c = b.c;
        if let Op::Illuminance { p, .. } = &mut b.p.exprs[b.illum.index()].op {
            *p = c;
        }
        assert!(matches!(
            err(&b.p),
            ValidationError::IllTyped { value, reason } if value == b.illum && reason.contains("point is a color")
        ));
    }

    #[test]
    fn illuminance_yields_a_bool() {
        let mut b = base();
        let (illum, enabled) = (b.illum, b.enabled);
        blocks_mut(&mut b.p, illum)[0].yields.push(enabled);
        let want = ValidationError::IlluminanceYield {
            value: illum,
            ty: Type::Bool,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn light_outside_illuminance() {
        let mut b = base();
        let v = push(&mut b.p, Op::LightL, Some(Type::Vec3));
        assert_eq!(
            err(&b.p),
            ValidationError::LightOutsideIlluminance { value: v }
        );
        // In an if arm that is not inside an illuminance body.
        let mut b = base();
        b.p.exprs.push(Expr {
            op: Op::LightCl,
            ty: Some(Type::Color),
        });
        let v = Value::new(b.p.exprs.len() - 1);
        let region = b.region;
        blocks_mut(&mut b.p, region)[0].body.push(v);
        assert_eq!(
            err(&b.p),
            ValidationError::LightOutsideIlluminance { value: v }
        );
    }

    // ---- scene queries and light visibility ----

    #[test]
    fn scene_queries_and_light_visibility_validate() {
        let mut b = base();
        let (pos, f, illum) = (b.pos, b.f, b.illum);
        let p = &mut b.p;
        let samples = push(p, Op::Const(ConstValue::Int(16)), Some(Type::Int));
        for ray_type in [RAY_REFLECTION, RAY_REFRACTION, RAY_DIFFUSE] {
            push(
                p,
                Op::Trace {
                    dir: pos,
                    ray_type,
                    pdf: None,
                },
                Some(Type::Color),
            );
        }
        let occlusion = Op::Occlusion {
            n: pos,
            samples,
            max_distance: f,
        };
        push(p, occlusion, Some(Type::Float));
        // light.visible at any depth inside an illuminance body.
        p.exprs.push(Expr {
            op: Op::LightVisible,
            ty: Some(Type::Float),
        });
        let vis = Value::new(p.exprs.len() - 1);
        blocks_mut(p, illum)[0].body.push(vis);
        blocks_mut(p, illum)[0].yields.push(vis);
        assert_eq!(validate(p), Ok(()));
        // Its type is float.
        p.exprs[vis.index()].ty = Some(Type::Bool);
        assert!(matches!(err(p), ValidationError::WrongType { value, .. } if value == vis));
        // A trace gives a color.
        let mut b = base();
        let t = push(
            &mut b.p,
            Op::Trace {
                dir: b.pos,
                ray_type: RAY_REFLECTION,
                pdf: None,
            },
            Some(Type::Float),
        );
        let want = ValidationError::WrongType {
            value: t,
            recorded: Some(Type::Float),
            inferred: Some(Type::Color),
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn light_visible_outside_illuminance() {
        let mut b = base();
        let v = push(&mut b.p, Op::LightVisible, Some(Type::Float));
        assert_eq!(
            err(&b.p),
            ValidationError::LightOutsideIlluminance { value: v }
        );
        // In an if arm outside any illuminance body.
        let mut b = base();
        b.p.exprs.push(Expr {
            op: Op::LightVisible,
            ty: Some(Type::Float),
        });
        let v = Value::new(b.p.exprs.len() - 1);
        let region = b.region;
        blocks_mut(&mut b.p, region)[0].body.push(v);
        assert_eq!(
            err(&b.p),
            ValidationError::LightOutsideIlluminance { value: v }
        );
    }

    #[test]
    fn trace_rules() {
        ill_typed(
            |b| Op::Trace {
                dir: b.c,
                ray_type: RAY_REFLECTION,
                pdf: None,
            },
            Type::Color,
            "trace direction is a color, not a vec3",
        );
        for ray_type in [RAY_CAMERA, RAY_SHADOW, 0, 12, -4] {
            let mut b = base();
            let dir = b.pos;
            let op = Op::Trace {
                dir,
                ray_type,
                pdf: None,
            };
            let v = push(&mut b.p, op, Some(Type::Color));
            assert_eq!(err(&b.p), ValidationError::RayType { value: v, ray_type });
        }
        ill_typed(
            |b| Op::Occlusion {
                n: b.pos,
                samples: b.f,
                max_distance: b.f,
            },
            Type::Float,
            "occlusion takes (vec3, int, float), not (vec3, float, float)",
        );
    }

    #[test]
    fn scene_queries_are_not_uniform() {
        // Neither a trace nor light visibility may be computed once per instance.
        let mut b = Builder::new("p");
        let d = b.vec3([0.0, 0.0, 1.0]);
        b.trace(d, RAY_REFLECTION);
        let mut p = b.finish().unwrap();
        p.prelude = std::mem::take(&mut p.body);
        assert!(matches!(
            err(&p),
            ValidationError::Prelude { reason, .. } if reason.contains("scene")
        ));
        let mut b = Builder::new("p");
        let d = b.vec3([0.0, 0.0, 1.0]);
        let (s, m) = (b.int(4), b.float(1.0));
        b.occlusion(d, s, m);
        let mut p = b.finish().unwrap();
        p.prelude = std::mem::take(&mut p.body);
        assert!(matches!(err(&p), ValidationError::Prelude { .. }));
    }

    // ---- indices ----

    #[test]
    fn param_index() {
        let mut b = base();
        let v = push(&mut b.p, Op::Param(1), Some(Type::Color));
        let want = ValidationError::ParamIndex {
            value: v,
            index: 1,
            count: 1,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn component_index() {
        let mut b = base();
        b.p.exprs[b.enabled.index()].op = Op::ComponentEnabled(1);
        let want = ValidationError::ComponentIndex {
            value: b.enabled,
            index: 1,
            count: 1,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn proj_of_a_non_region() {
        let mut b = base();
        let v = push(&mut b.p, Op::Proj(b.sum, 0), Some(Type::Float));
        let want = ValidationError::ProjOfNonRegion {
            value: v,
            operand: b.sum,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn proj_index() {
        let mut b = base();
        let v = push(&mut b.p, Op::Proj(b.illum, 2), Some(Type::Float));
        let want = ValidationError::ProjIndex {
            value: v,
            region: b.illum,
            index: 2,
            count: 2,
        };
        assert_eq!(err(&b.p), want);
    }

    // ---- outputs and declarations ----

    #[test]
    fn output_reads_an_inner_value() {
        let mut b = base();
        b.p.outputs[0].value = b.then_val;
        let want = ValidationError::OutputNotVisible {
            output: "color".into(),
            value: b.then_val,
        };
        assert_eq!(err(&b.p), want);
        let mut b = base();
        b.p.outputs[1].value = Value::new(999);
        assert!(matches!(
            err(&b.p),
            ValidationError::OutputNotVisible { .. }
        ));
    }

    #[test]
    fn output_reads_a_region() {
        let mut b = base();
        b.p.outputs[1].value = b.region;
        let want = ValidationError::OutputRegion {
            output: "alpha".into(),
            value: b.region,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn output_component() {
        let mut b = base();
        b.p.outputs.push(Output {
            name: "spec".into(),
            component: Some(1),
            value: b.f,
        });
        let want = ValidationError::OutputComponent {
            output: "spec".into(),
            index: 1,
            count: 1,
        };
        assert_eq!(err(&b.p), want);
    }

    #[test]
    fn components() {
        let mut b = base();
        b.p.components.push("diffuse".into());
        let want = ValidationError::DuplicateComponent {
            name: "diffuse".into(),
        };
        assert_eq!(err(&b.p), want);
        let mut b = base();
        b.p.components = (0..33).map(|k| format!("c{k}")).collect();
        assert_eq!(err(&b.p), ValidationError::TooManyComponents { count: 33 });
        b.p.components.pop();
        assert_eq!(validate(&b.p), Ok(()));
    }

    #[test]
    fn param_default_type() {
        let mut b = base();
        b.p.params[0].default = ConstValue::Vec3([0.0; 3]);
        let want = ValidationError::ParamDefault {
            index: 0,
            name: "surf.color".into(),
            ty: Type::Color,
            default_ty: Type::Vec3,
        };
        assert_eq!(err(&b.p), want);
    }

    const LOOP: &str = "program \"l\" {
  %0 = const 0 : int
  %1 = const 0.5 : float
  %2 = loop %0, %1 while {
    %3 = loop.var 0 : int
    %4 = const 3 : int
    %5 = lt %3, %4 : bool
    yield %5
  } do {
    %6 = loop.var 0 : int
    %7 = loop.var 1 : float
    %8 = const 1 : int
    %9 = add %6, %8 : int
    %10 = mul %7, %7 : float
    yield %9, %10
  }
  %11 = proj %2, 1 : float
  output x %11
}
";

    /// A loop prints and parses back, and each of its rules is checked: the condition
    /// yields one bool, the body the carried types, `loop.var` only inside a loop and within
    /// its carried values, no loop in the prelude.
    #[test]
    fn loops_round_trip_and_check_their_blocks() {
        let p = crate::ir::parse(LOOP).unwrap();
        assert_eq!(validate(&p), Ok(()));
        assert_eq!(p.to_string(), LOOP);
        let bad = |from: &str, to: &str| {
            let text = LOOP.replacen(from, to, 1);
            assert_ne!(text, LOOP, "{from}");
            validate(&crate::ir::parse(&text).unwrap()).unwrap_err()
        };
        let e = bad("    yield %5\n", "    yield %3\n");
        assert!(matches!(e, ValidationError::LoopYields { .. }), "{e}");
        assert!(e.to_string().contains("yields (int), not one bool"), "{e}");
        let e = bad("yield %9, %10", "yield %10, %10");
        assert!(
            e.to_string()
                .contains("yields (float, float) but the loop carries (int, float)"),
            "{e}"
        );
        let e = bad("%7 = loop.var 1 : float", "%7 = loop.var 2 : float");
        assert!(
            matches!(e, ValidationError::LoopVar { index: 2, .. }),
            "{e}"
        );
        let e = bad(
            "  %11 = proj %2, 1 : float\n",
            "  %11 = loop.var 1 : float\n",
        );
        assert!(e.to_string().contains("it is not inside a loop"), "{e}");
        let e = bad("%7 = loop.var 1 : float", "%7 = loop.var 1 : int");
        assert!(matches!(e, ValidationError::WrongType { .. }), "{e}");
        // The carried rates reach their fixed point: the loop is varying only through a
        // varying initial value.
        let rates = crate::ir::rates(&p);
        assert_eq!(rates[2], crate::ir::Rate::Const);
        let varying = LOOP.replacen("%1 = const 0.5 : float", "%1 = stream time : float", 1);
        let p = crate::ir::parse(&varying).unwrap();
        let rates = crate::ir::rates(&p);
        let names: Vec<_> = (0..p.exprs.len()).map(|i| rates[i]).collect();
        assert_eq!(names[2], crate::ir::Rate::Varying);
        assert_eq!(
            names[6],
            crate::ir::Rate::Const,
            "the counter stays constant"
        );
        assert_eq!(names[7], crate::ir::Rate::Varying);
    }
}
