//! MaterialX value types and value strings: which of our [`Type`]s a MaterialX type is, and
//! how a `value="…"` string reads as a literal.
//!
//! This module owns the type mapping and the value syntax (comma-separated components,
//! `true`/`false`, row-major matrices); it must not look at documents or nodedefs.

use crate::types::Type;
use serde_json::{Value as Json, json};

/// What a MaterialX type is to us.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MxType {
    /// A value type we shade.
    Value(Type),
    /// A closure or shader type not built yet (volumeshader, displacementshader,
    /// lightshader); the built ones (BSDF, EDF, VDF, surfaceshader, material) are values of
    /// [`Type::Closure`].
    Closure,
    /// A value type with no IR type yet (arrays, uvmap…).
    Unsupported,
}

/// The closure and shader types of MaterialX.
pub const CLOSURE_TYPES: &[&str] = &[
    "BSDF",
    "EDF",
    "VDF",
    "surfaceshader",
    "displacementshader",
    "volumeshader",
    "lightshader",
    "material",
];

/// Classifies a MaterialX type name. `filename` and `string` are uniform strings;
/// `color3` is our `color`, `vector2/3` our `vec2/vec3`, `integer` our `int`.
pub fn classify(mx: &str) -> MxType {
    let t = match mx {
        "float" => Type::Float,
        "integer" => Type::Int,
        "boolean" => Type::Bool,
        "color3" => Type::Color,
        "vector2" => Type::Vec2,
        "vector3" => Type::Vec3,
        "color4" => Type::Color4,
        "vector4" => Type::Vec4,
        "matrix33" => Type::Matrix33,
        "matrix44" => Type::Matrix44,
        "string" | "filename" => Type::String,
        _ if CLOSURE_TYPES.contains(&mx) => {
            return match Type::from_name(mx) {
                Some(t @ Type::Closure(k)) if k.is_built() => MxType::Value(t),
                _ => MxType::Closure,
            };
        }
        _ => return MxType::Unsupported,
    };
    MxType::Value(t)
}

/// Why a MaterialX type has no IR type, for messages.
pub fn unsupported_reason(mx: &str) -> String {
    match mx {
        _ if CLOSURE_TYPES.contains(&mx) => {
            format!(
                "type {mx} is a closure kind that is not built yet (no volumes, displacement or light shaders)"
            )
        }
        _ => format!("type {mx} is not supported"),
    }
}

/// The MaterialX name of one of our types (the inverse of [`classify`]; strings read back as
/// `string`).
pub fn mx_name(t: Type) -> &'static str {
    match t {
        Type::Float => "float",
        Type::Int => "integer",
        Type::Bool => "boolean",
        Type::Color => "color3",
        Type::Vec2 => "vector2",
        Type::Vec3 => "vector3",
        Type::Color4 => "color4",
        Type::Vec4 => "vector4",
        Type::Matrix33 => "matrix33",
        Type::Matrix44 => "matrix44",
        Type::String => "string",
        Type::Closure(k) => k.name(),
    }
}

/// Reads a value string of type `ty` as the network literal the linker takes. Matrices are
/// written row-major with the translation in the last row (MaterialX's row-vector
/// convention) and are transposed to ours (column vectors, `M * p`).
pub fn literal(text: &str, ty: Type) -> Result<Json, String> {
    let t = text.trim();
    let floats = |n: usize| -> Result<Vec<f64>, String> {
        let parts: Vec<&str> = t.split(',').map(str::trim).collect();
        if parts.len() != n {
            return Err(format!(
                "`{text}` is not a {} ({n} comma-separated numbers)",
                mx_name(ty)
            ));
        }
        parts
            .iter()
            .map(|p| {
                p.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite() && x.abs() <= f32::MAX as f64)
                    .ok_or_else(|| format!("`{p}` is not a finite number (in `{text}`)"))
            })
            .collect()
    };
    Ok(match ty {
        Type::Closure(k) => {
            return Err(format!(
                "`{text}`: a {} input takes a connection, not a value",
                k.name()
            ));
        }
        Type::String => Json::String(text.to_string()),
        Type::Bool => match t {
            "true" => Json::Bool(true),
            "false" => Json::Bool(false),
            _ => return Err(format!("`{text}` is not a boolean (true or false)")),
        },
        Type::Int => t
            .parse::<i32>()
            .map(|i| json!(i))
            .map_err(|_| format!("`{text}` is not a 32-bit integer"))?,
        Type::Float => json!(floats(1)?[0]),
        Type::Vec2 | Type::Vec3 | Type::Color | Type::Vec4 | Type::Color4 => {
            json!(floats(ty.width())?)
        }
        Type::Matrix33 | Type::Matrix44 => {
            let k = ty.matrix_size();
            let m = floats(k * k)?;
            let rows: Vec<Vec<f64>> = (0..k)
                .map(|r| (0..k).map(|c| m[c * k + r]).collect())
                .collect();
            json!(rows)
        }
    })
}

/// The name of the string port that carries a filename input's `colorspace` to an atom's
/// lowering (`file` → `file_colorspace`): the translator sets it, the library declares it,
/// the `image` lowering reads it.
pub fn colorspace_port(input: &str) -> String {
    format!("{input}_colorspace")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_of_every_type() {
        assert_eq!(
            literal("0.5, 1, 2", Type::Color).unwrap(),
            json!([0.5, 1.0, 2.0])
        );
        assert_eq!(literal(" 3 ", Type::Int).unwrap(), json!(3));
        assert_eq!(literal("true", Type::Bool).unwrap(), json!(true));
        assert_eq!(literal("1,2", Type::Vec2).unwrap(), json!([1.0, 2.0]));
        assert_eq!(
            literal("0.5, 1, 2, 0.25", Type::Color4).unwrap(),
            json!([0.5, 1.0, 2.0, 0.25])
        );
        assert!(
            literal("1,2,3", Type::Vec4)
                .unwrap_err()
                .contains("vector4")
        );
        assert_eq!(literal("a b", Type::String).unwrap(), json!("a b"));
        let m = "1,0,0,0, 0,1,0,0, 0,0,1,0, 5,6,7,1";
        let j = literal(m, Type::Matrix44).unwrap();
        assert_eq!(
            j[0],
            json!([1.0, 0.0, 0.0, 5.0]),
            "translation moves to the last column"
        );
        assert!(literal("1,2", Type::Color).unwrap_err().contains("color3"));
        assert!(literal("nan", Type::Float).is_err());
        assert!(literal("1e39", Type::Float).is_err());
        assert!(literal("yes", Type::Bool).is_err());
    }

    #[test]
    fn type_classes() {
        assert_eq!(classify("color3"), MxType::Value(Type::Color));
        use crate::types::ClosureKind;
        assert_eq!(
            classify("BSDF"),
            MxType::Value(Type::Closure(ClosureKind::Bsdf))
        );
        assert_eq!(
            classify("material"),
            MxType::Value(Type::Closure(ClosureKind::Material))
        );
        // A VDF is built as a vacuum (or refused by its atom).
        assert_eq!(
            classify("VDF"),
            MxType::Value(Type::Closure(ClosureKind::Vdf))
        );
        assert_eq!(classify("volumeshader"), MxType::Closure);
        assert_eq!(classify("displacementshader"), MxType::Closure);
        assert_eq!(classify("color4"), MxType::Value(Type::Color4));
        assert_eq!(classify("vector4"), MxType::Value(Type::Vec4));
        assert_eq!(classify("matrix33"), MxType::Value(Type::Matrix33));
        assert_eq!(classify("uvmap"), MxType::Unsupported);
        // MaterialX rows (row vectors) become our columns.
        assert_eq!(
            literal("1,2,3, 4,5,6, 7,8,9", Type::Matrix33).unwrap(),
            json!([[1.0, 4.0, 7.0], [2.0, 5.0, 8.0], [3.0, 6.0, 9.0]])
        );
    }
}
