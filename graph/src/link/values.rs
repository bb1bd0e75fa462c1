//! The value rules of a connection or a literal: which coercions a connection may make
//! ([`coercible`]) and how a JSON literal becomes a constant of a port's type ([`literal`]).
//!
//! It owns these two rules and their messages; it must not know nodes, names or networks
//! (the MaterialX reader uses [`literal`] too).

use crate::types::{ConstValue, Type};
use serde_json::Value as Json;

/// Whether a connection delivering `from` may feed a port of type `to`.
pub fn coercible(from: Type, to: Type) -> bool {
    from == to
        || (from == Type::Float && to.is_vector())
        || from.is_renaming_of(to)
        || (from == Type::Int && to == Type::Float)
        || (from == Type::Bool && matches!(to, Type::Int | Type::Float))
}

/// Converts a JSON literal to a constant of type `ty`: numbers for float/int (integral,
/// within i32), bools, arrays of 2/3/16 numbers (or 4 rows of 4) for vectors, colors and
/// matrices, a single number broadcast to a vector or color. Floats must be finite and fit
/// an f32.
pub fn literal(json: &Json, ty: Type) -> Result<ConstValue, String> {
    let num = |j: &Json| -> Result<f64, String> {
        let x = j
            .as_f64()
            .ok_or_else(|| format!("expects a number, not {j}"))?;
        if !x.is_finite() || x.abs() > f32::MAX as f64 {
            return Err(format!("{x} is out of range for a 32-bit float"));
        }
        Ok(x)
    };
    match ty {
        Type::Bool => json
            .as_bool()
            .map(ConstValue::Bool)
            .ok_or_else(|| format!("expects true or false, not {json}")),
        Type::Int => {
            let x = num(json).map_err(|_| format!("expects an integer, not {json}"))?;
            if x.fract() != 0.0 || x < i32::MIN as f64 || x > i32::MAX as f64 {
                return Err(format!("expects a 32-bit integer, not {json}"));
            }
            Ok(ConstValue::Int(x as i32))
        }
        Type::Float => num(json).map(ConstValue::Float),
        Type::Closure(k) => Err(format!(
            "is a {} (a closure): connect a closure node; closures have no literal values",
            k.name()
        )),
        Type::String => json
            .as_str()
            .map(|s| ConstValue::String(s.to_string()))
            .ok_or_else(|| format!("expects a string, not {json}")),
        Type::Vec2
        | Type::Vec3
        | Type::Color
        | Type::Vec4
        | Type::Color4
        | Type::Matrix33
        | Type::Matrix44 => {
            let n = ty.width();
            let k = ty.matrix_size();
            let flat: Vec<&Json> = match json {
                Json::Number(_) if !ty.is_matrix() => vec![json; n],
                Json::Array(rows) if ty.is_matrix() && rows.len() == k => {
                    let mut v = Vec::new();
                    for r in rows {
                        match r {
                            Json::Array(r) if r.len() == k => v.extend(r.iter()),
                            _ => {
                                return Err(format!("expects {k} rows of {k} numbers, not {json}"));
                            }
                        }
                    }
                    v
                }
                Json::Array(v) => v.iter().collect(),
                _ => return Err(format!("expects a {ty} ({n} numbers), not {json}")),
            };
            if flat.len() != n {
                return Err(format!(
                    "expects a {ty} of {n} numbers, not {} ({json})",
                    flat.len()
                ));
            }
            let v = flat.into_iter().map(num).collect::<Result<Vec<_>, _>>()?;
            Ok(ConstValue::from_floats(ty, &v).expect("width checked"))
        }
    }
}
