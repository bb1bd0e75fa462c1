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

use crate::ir::{BinOp, Builder, Op};
use crate::nodes::{LowVal, NodeInputs};
use crate::types::{ConstValue, Type};

type Out = Result<Vec<LowVal>, String>;

/// The attribute `geomcolor` with colour-set `index` reads.
pub fn color_set_name(index: i32) -> String {
    format!("COLOR_{index}")
}

/// Colour sets a `geomcolor` whose `index` is not a constant (a material parameter) can
/// reach: `COLOR_0` to `COLOR_7`, chosen per hit by the parameter's value (another value
/// gives the default).
pub const PARAM_COLOR_SETS: i32 = 8;

/// `geomcolor`: colour set `index` of the geometry, 0 where it has none (the nodedef's
/// default). The float variant reads the set's first channel. A constant index reads its
/// set; an index left as a parameter selects among sets 0 to [`PARAM_COLOR_SETS`] − 1 by
/// its value per hit.
pub fn geomcolor(b: &mut Builder, inp: &NodeInputs) -> Out {
    let index = inp.get("index");
    let ty = inp.def.outputs[0].ty.unwrap_or(Type::Float);
    let zero = b.zero(ty);
    if let Op::Const(ConstValue::Int(i)) = b.program().op(index) {
        let i = *i;
        if i < 0 {
            return Err(format!(
                "input `index`: {i} is not a colour set (0 or more)"
            ));
        }
        let v = b.attribute(&color_set_name(i), zero);
        return Ok(vec![LowVal::plain(v)]);
    }
    if b.ty(index) != Type::Int {
        return Err(format!("input `index`: an integer, not a {}", b.ty(index)));
    }
    let mut v = zero;
    for i in (0..PARAM_COLOR_SETS).rev() {
        let set = b.attribute(&color_set_name(i), zero);
        let k = b.int(i);
        let is = b.binary(BinOp::Eq, index, k);
        v = b.select(is, set, v);
    }
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
