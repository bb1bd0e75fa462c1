//! Lowering: from a linked network to an IR [`Program`].
//!
//! Each node instance is lowered once, in dependency order, by its def's [`LowerFn`]; its
//! inputs are the values of what they are connected to (after the linker's coercions) or
//! their defaults. Material outputs become program outputs: an output whose value carries
//! render-component parts becomes one program output per part (DESIGN §8).

use crate::ir::{Builder, Program, Value};
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

/// Emits constant `c` as type `ty`: floats broadcast to vectors, ints and bools converted
/// to floats, vec3 and color interchangeable.
pub fn constant_as(b: &mut Builder, c: &ConstValue, ty: Type) -> Value {
    let out = match (c, ty) {
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
    };
    match out {
        Some(c) => b.constant(c),
        None => {
            b.fail(format!("constant {c} cannot be used as {ty}"));
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
