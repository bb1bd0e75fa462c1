//! The geometry-property atoms of MaterialX: `geomcolor` and `geompropvalue`, lowered to
//! [`Op::Attribute`] (a named attribute of the shaded geometry, interpolated at the hit,
//! or a default where the geometry lacks it).
//!
//! Names: `geomcolor` with `index` n reads the attribute `COLOR_n` (glTF's name for colour
//! set n; the OBJ loader names its vertex colours `COLOR_0`); `geompropvalue` reads the
//! attribute its `geomprop` input names, as the geometry spells it. Attributes are floats:
//! the `integer` variant converts the interpolated value to an int (truncation toward zero,
//! as `convert` does), the `boolean` variant tests it for ≠ 0; their defaults are converted
//! the other way first. This module owns those rules; it must not resolve names against
//! geometry (the renderer does, once per program and mesh).

use crate::ir::{Builder, Op};
use crate::nodes::{LowVal, NodeInputs};
use crate::types::{ConstValue, Type};

type Out = Result<Vec<LowVal>, String>;

/// The attribute `geomcolor` with colour-set `index` reads.
pub fn color_set_name(index: i32) -> String {
    format!("COLOR_{index}")
}

/// `geomcolor`: colour set `index` (a constant integer) of the geometry, 0 where it has
/// none (the nodedef's default). The float variant reads the set's first channel.
pub fn geomcolor(b: &mut Builder, inp: &NodeInputs) -> Out {
    let index = match b.program().op(inp.get("index")) {
        Op::Const(ConstValue::Int(i)) if *i >= 0 => *i,
        Op::Const(ConstValue::Int(i)) => {
            return Err(format!(
                "input `index`: {i} is not a colour set (0 or more)"
            ));
        }
        _ => return Err("input `index`: must be a constant integer (it is uniform)".into()),
    };
    let ty = inp.def.outputs[0].ty.unwrap_or(Type::Float);
    let zero = b.zero(ty);
    let v = b.attribute(&color_set_name(index), zero);
    Ok(vec![LowVal::plain(v)])
}

/// `geompropvalue`: the geometry's attribute `geomprop`, or `default` where it has none
/// (an empty name reads nothing: `default`).
pub fn geompropvalue(b: &mut Builder, inp: &NodeInputs) -> Out {
    let name = inp.string("geomprop").to_string();
    let default = inp.get("default");
    if name.is_empty() {
        return Ok(vec![LowVal::plain(default)]);
    }
    let ty = b.ty(default);
    let v = match ty {
        Type::Int | Type::Bool => {
            let d = b.convert(Type::Float, default);
            let f = b.attribute(&name, d);
            b.convert(ty, f)
        }
        _ => b.attribute(&name, default),
    };
    Ok(vec![LowVal::plain(v)])
}
