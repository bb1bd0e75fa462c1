//! Lowering: from a linked network to an IR [`Program`].
//!
//! Each node instance is lowered once, in dependency order, by its def's [`LowerFn`]; its
//! inputs are the values of what they are connected to (after the linker's coercions) or
//! their defaults. Material outputs become program outputs: an output whose value carries
//! render-component parts becomes one program output per part (DESIGN §8).

use crate::ir::{Builder, Program, Value};
use crate::link::{LinkError, LinkErrors, Linked, LinkedInput, Source};
use crate::nodes::{InputVal, LowVal, NodeDef, NodeInputs, NodeLibrary, PortDefault, PortType};
use crate::types::{ConstValue, Type};

/// Emits the value an unconnected port gets: its default, converted to the port's type
/// (a float default of a generic port is broadcast to `generic`).
pub fn default_input(b: &mut Builder, def: &NodeDef, port: usize, generic: Type) -> InputVal {
    let p = &def.inputs[port];
    match (&p.default, &p.ty) {
        (PortDefault::EmptyArray, _) => InputVal::Array(Vec::new()),
        (PortDefault::Stream(s), _) => InputVal::Value(LowVal::plain(b.stream(*s))),
        (PortDefault::Value(ConstValue::String(s)), _) => InputVal::Str(s.clone()),
        (PortDefault::Value(c), PortType::Generic) => {
            InputVal::Value(LowVal::plain(constant_as(b, c, generic)))
        }
        (PortDefault::Value(c), _) => InputVal::Value(LowVal::plain(b.constant(c.clone()))),
    }
}

/// Converts constant `c` to type `ty`: floats broadcast to vectors, ints and bools converted
/// to floats, vec3 and color interchangeable. `None` if no such conversion exists.
pub fn convert_const(c: &ConstValue, ty: Type) -> Option<ConstValue> {
    match (c, ty) {
        (c, t) if c.ty() == t => Some(c.clone()),
        (ConstValue::Float(x), t) if t.is_vector() => {
            ConstValue::from_floats(t, &vec![*x; t.width()])
        }
        (ConstValue::Int(i), t) if t.is_float_based() => {
            ConstValue::from_floats(t, &vec![*i as f64; t.width()])
        }
        (ConstValue::Bool(x), t) if t.is_float_based() => {
            ConstValue::from_floats(t, &vec![*x as i32 as f64; t.width()])
        }
        (ConstValue::Bool(x), Type::Int) => Some(ConstValue::Int(*x as i32)),
        (ConstValue::Vec3(v) | ConstValue::Color(v), t) => ConstValue::from_floats(t, v),
        _ => None,
    }
}

/// Emits constant `c` as type `ty` (see [`convert_const`]).
pub fn constant_as(b: &mut Builder, c: &ConstValue, ty: Type) -> Value {
    match convert_const(c, ty) {
        Some(c) => b.constant(c),
        None => {
            b.fail(format!("constant {c} cannot be used as {ty}"));
            b.zero(ty)
        }
    }
}

/// Emits a literal set on a node's port as a uniform parameter `node.port` of type `ty`
/// (class compilation keeps it adjustable; baking turns it into a constant).
pub fn param_as(b: &mut Builder, name: &str, c: &ConstValue, ty: Type) -> Value {
    match convert_const(c, ty) {
        Some(c) => b.param(name, c),
        None => {
            b.fail(format!("parameter {name} = {c} cannot be used as {ty}"));
            b.zero(ty)
        }
    }
}

/// A literal input for [`lower_single`].
#[derive(Clone, Debug)]
pub enum Literal {
    /// A constant (strings go to string ports).
    Const(ConstValue),
    /// An array input: per element, per field, a constant.
    Array(Vec<Vec<ConstValue>>),
}

/// Lowers one node of type `node_type` with literal inputs (others at their defaults) into a
/// program whose outputs are the node's outputs, with component parts as separate outputs.
/// Used by tests and `shadenet nodes --eval`; the linker path is [`crate::link`].
pub fn lower_single(
    lib: &NodeLibrary,
    node_type: &str,
    generic: Type,
    inputs: &[(&str, Literal)],
) -> Result<Program, String> {
    let def = lib
        .get(node_type)
        .ok_or_else(|| format!("unknown node type `{node_type}`"))?;
    let mut b = Builder::new(node_type);
    let mut values = Vec::new();
    for (i, port) in def.inputs.iter().enumerate() {
        let lit = inputs.iter().find(|(n, _)| *n == port.name).map(|(_, l)| l);
        let v = match lit {
            None => default_input(&mut b, def, i, generic),
            Some(Literal::Const(ConstValue::String(s))) => InputVal::Str(s.clone()),
            Some(Literal::Const(c)) => {
                let ty = match &port.ty {
                    PortType::Simple(t) => *t,
                    _ => generic,
                };
                InputVal::Value(LowVal::plain(constant_as(&mut b, c, ty)))
            }
            Some(Literal::Array(elems)) => {
                let PortType::Array(fields) = &port.ty else {
                    return Err(format!("input {} is not an array", port.name));
                };
                let mut arr = Vec::new();
                for e in elems {
                    let mut rec = Vec::new();
                    for ((_, fty), c) in fields.iter().zip(e) {
                        let v = constant_as(&mut b, c, fty.unwrap_or(generic));
                        rec.push(LowVal::plain(v));
                    }
                    arr.push(rec);
                }
                InputVal::Array(arr)
            }
        };
        values.push(v);
    }
    for (n, _) in inputs {
        if def.input(n).is_none() {
            return Err(format!("node type `{node_type}` has no input `{n}`"));
        }
    }
    let ni = NodeInputs {
        node: node_type,
        def,
        generic,
        values,
    };
    let outs = (def.lower)(&mut b, &ni)?;
    if outs.len() != def.outputs.len() {
        return Err(format!(
            "lowering of `{node_type}` returned {} outputs, its def declares {}",
            outs.len(),
            def.outputs.len()
        ));
    }
    for (o, lv) in def.outputs.iter().zip(&outs) {
        declare_output(&mut b, o.name, lv);
    }
    b.finish()
}

/// Declares a material output: one program output per component part when the value has
/// parts, else a single untagged output.
pub fn declare_output(b: &mut Builder, name: &str, v: &LowVal) {
    if v.parts.is_empty() {
        b.output(name, None, v.value);
    } else {
        for (k, p) in &v.parts {
            b.output(name, Some(*k), *p);
        }
    }
}

/// Converts a connected value from `src.from` to `src.to` (the linker checked the pair):
/// component selection, broadcast, color ↔ vec3, int/bool → float. Component parts follow
/// the linear conversions.
fn coerce(b: &mut Builder, v: &LowVal, src: &Source) -> LowVal {
    use crate::nodes::lowering::map_parts;
    let mut v = v.clone();
    if let Some(k) = src.component {
        v = map_parts(b, &v, |b, x| b.extract(x, k as usize));
    }
    let (from, to) = (src.from, src.to);
    if from == to {
        v
    } else if from == Type::Float && to.is_vector() {
        map_parts(b, &v, |b, x| b.splat(to, x))
    } else if from.is_vector() && to.is_vector() {
        map_parts(b, &v, |b, x| b.retype(to, x))
    } else {
        LowVal::plain(b.convert(to, v.value))
    }
}

/// Lowers a linked network to a program. Only nodes that some material output depends on
/// are lowered. Errors name the node whose lowering failed.
pub fn lower(linked: &Linked, lib: &NodeLibrary) -> Result<Program, LinkErrors> {
    // Which nodes reach an output.
    let mut live = vec![false; linked.nodes.len()];
    for (_, s) in &linked.outputs {
        live[s.node] = true;
    }
    for i in (0..linked.nodes.len()).rev() {
        if !live[i] {
            continue;
        }
        for input in &linked.nodes[i].inputs {
            mark_sources(input, &mut live);
        }
    }

    let mut b = Builder::new(&linked.name);
    let mut outs: Vec<Vec<LowVal>> = vec![Vec::new(); linked.nodes.len()];
    let mut errors = Vec::new();
    for (i, node) in linked.nodes.iter().enumerate() {
        if !live[i] {
            continue;
        }
        let def = lib.get(&node.ty).ok_or_else(|| {
            LinkErrors(vec![LinkError::UnknownType {
                node: node.name.clone(),
                ty: node.ty.clone(),
                hint: String::new(),
            }])
        })?;
        let mut values = Vec::new();
        for (pi, input) in node.inputs.iter().enumerate() {
            let port_ty = match &def.inputs[pi].ty {
                PortType::Simple(t) => *t,
                _ => node.generic,
            };
            let v = match input {
                LinkedInput::Default => default_input(&mut b, def, pi, node.generic),
                LinkedInput::Array(elems) => {
                    let PortType::Array(fields) = &def.inputs[pi].ty else {
                        unreachable_input(&mut b, &mut errors, node, def, pi);
                        continue;
                    };
                    let mut arr = Vec::new();
                    for rec in elems {
                        let mut r = Vec::new();
                        for ((_, fty), fv) in fields.iter().zip(rec) {
                            let fty = fty.unwrap_or(node.generic);
                            let lv = match fv {
                                LinkedInput::Const(c) => LowVal::plain(constant_as(&mut b, c, fty)),
                                LinkedInput::Conn(s) => coerce(&mut b, &outs[s.node][s.output], s),
                                _ => LowVal::plain(b.zero(fty)),
                            };
                            r.push(lv);
                        }
                        arr.push(r);
                    }
                    InputVal::Array(arr)
                }
                LinkedInput::Const(c) => {
                    let name = format!("{}.{}", node.name, def.inputs[pi].name);
                    InputVal::Value(LowVal::plain(param_as(&mut b, &name, c, port_ty)))
                }
                LinkedInput::Str(s) => InputVal::Str(s.clone()),
                LinkedInput::Conn(s) => InputVal::Value(coerce(&mut b, &outs[s.node][s.output], s)),
            };
            values.push(v);
        }
        let ni = NodeInputs {
            node: &node.name,
            def,
            generic: node.generic,
            values,
        };
        match (def.lower)(&mut b, &ni) {
            Ok(o) if o.len() == def.outputs.len() => outs[i] = o,
            Ok(o) => {
                errors.push(LinkError::Lowering {
                    node: node.name.clone(),
                    ty: node.ty.clone(),
                    msg: format!(
                        "internal error: lowering returned {} outputs, the def declares {}",
                        o.len(),
                        def.outputs.len()
                    ),
                });
                outs[i] = def
                    .outputs
                    .iter()
                    .map(|o| LowVal::plain(b.zero(o.ty.unwrap_or(node.generic))))
                    .collect();
            }
            Err(msg) => {
                errors.push(LinkError::Lowering {
                    node: node.name.clone(),
                    ty: node.ty.clone(),
                    msg,
                });
                outs[i] = def
                    .outputs
                    .iter()
                    .map(|o| LowVal::plain(b.zero(o.ty.unwrap_or(node.generic))))
                    .collect();
            }
        }
    }
    for (name, s) in &linked.outputs {
        let v = coerce(&mut b, &outs[s.node][s.output], s);
        declare_output(&mut b, name, &v);
    }
    if !errors.is_empty() {
        return Err(LinkErrors(errors));
    }
    let internal = |msg: String| {
        LinkErrors(vec![LinkError::Lowering {
            node: linked.name.clone(),
            ty: "(program)".into(),
            msg: format!("internal error: {msg}"),
        }])
    };
    let program = b.finish().map_err(internal)?;
    // Validate once: after this, nothing downstream may panic on the program.
    crate::ir::validate(&program).map_err(|e| internal(e.to_string()))?;
    Ok(program)
}

fn unreachable_input(
    b: &mut Builder,
    errors: &mut Vec<LinkError>,
    node: &crate::link::LinkedNode,
    def: &NodeDef,
    pi: usize,
) {
    b.fail("array input on a non-array port");
    errors.push(LinkError::Lowering {
        node: node.name.clone(),
        ty: node.ty.clone(),
        msg: format!(
            "internal error: input `{}` is not an array port",
            def.inputs[pi].name
        ),
    });
}

fn mark_sources(input: &LinkedInput, live: &mut [bool]) {
    match input {
        LinkedInput::Conn(s) => live[s.node] = true,
        LinkedInput::Array(a) => a.iter().flatten().for_each(|i| mark_sources(i, live)),
        _ => {}
    }
}

/// A network compiled to a program, with the lights it declares.
#[derive(Clone, Debug)]
pub struct Compiled {
    /// The material program.
    pub program: Program,
    /// The network's lights.
    pub lights: Vec<crate::nodes::LightDesc>,
}

/// Any error from network text to program.
#[derive(Debug, thiserror::Error)]
pub enum CompileError {
    /// The text is not a valid network file.
    #[error("malformed network: {0}")]
    Parse(#[from] crate::network::ParseError),
    /// Linking or lowering found problems.
    #[error("{0}")]
    Link(#[from] LinkErrors),
}

/// Parses, links and lowers a network given as JSON text.
pub fn compile_json(src: &str, lib: &NodeLibrary) -> Result<Compiled, CompileError> {
    let net = crate::network::Network::from_json(src)?;
    let linked = crate::link::link(&net, lib)?;
    let program = lower(&linked, lib)?;
    Ok(Compiled {
        program,
        lights: linked.lights,
    })
}
