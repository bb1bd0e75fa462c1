//! Value types shared by networks and the IR, and constant values.
//!
//! A network port has a [`Type`]; the IR uses the same enum. `Color` and `Vec3` are both
//! three floats and lower to the same IR arithmetic, but stay distinct for type checking and
//! documentation (the linker coerces between them); `Color4` and `Vec4` likewise, with four.

use std::fmt;

/// The simple types of the shading system (DESIGN §3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Type {
    /// `true` / `false`.
    Bool,
    /// 32-bit signed integer, wrapping arithmetic.
    Int,
    /// Floating point scalar (f32 when shading, f64 in the reference interpreter).
    Float,
    /// Two floats (`u`, `v` or `x`, `y`).
    Vec2,
    /// Three floats: a point, vector or normal.
    Vec3,
    /// Three floats: linear RGB.
    Color,
    /// Four floats: a 4-vector (MaterialX `vector4`).
    Vec4,
    /// Four floats: linear RGB and alpha (MaterialX `color4`). Same arithmetic as `vec4`,
    /// distinct for type checking, as `color` is from `vec3`.
    Color4,
    /// A 3×3 matrix, row-major, vectors are columns (`M * v`): MaterialX `matrix33`.
    Matrix33,
    /// A 4×4 matrix, row-major, points are column vectors (`M * p`).
    Matrix44,
    /// A string; uniform only (file names, enum-like options), never reaches the IR.
    String,
    /// A closure or shader (MaterialX `BSDF`, `EDF`, `surfaceshader`, `material`, …): a
    /// compile-time lobe list (DESIGN §12, [`crate::closure`]), never an IR value.
    Closure(ClosureKind),
}

/// The closure and shader types (MaterialX's names).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ClosureKind {
    /// `BSDF`: scattering lobes.
    Bsdf,
    /// `EDF`: emission.
    Edf,
    /// `VDF`: the medium inside a surface. Only a vacuum is built (no lobes: a medium
    /// whose coefficients are 0); volumes are not.
    Vdf,
    /// `surfaceshader`: a BSDF, an EDF and an opacity.
    SurfaceShader,
    /// `volumeshader` (not built).
    VolumeShader,
    /// `displacementshader` (not built).
    DisplacementShader,
    /// `lightshader` (not built).
    LightShader,
    /// `material`: a surface shader bound for rendering.
    Material,
}

impl ClosureKind {
    /// Every closure kind.
    pub const ALL: [ClosureKind; 8] = [
        ClosureKind::Bsdf,
        ClosureKind::Edf,
        ClosureKind::Vdf,
        ClosureKind::SurfaceShader,
        ClosureKind::VolumeShader,
        ClosureKind::DisplacementShader,
        ClosureKind::LightShader,
        ClosureKind::Material,
    ];

    /// Whether values of this kind are built (BSDF, EDF, VDF, surfaceshader, material); the
    /// others (volume shaders, displacement, light shaders) are refused with a reason.
    pub fn is_built(self) -> bool {
        matches!(
            self,
            ClosureKind::Bsdf
                | ClosureKind::Edf
                | ClosureKind::Vdf
                | ClosureKind::SurfaceShader
                | ClosureKind::Material
        )
    }

    /// The MaterialX type name (`BSDF`, `surfaceshader`, …).
    pub fn name(self) -> &'static str {
        match self {
            ClosureKind::Bsdf => "BSDF",
            ClosureKind::Edf => "EDF",
            ClosureKind::Vdf => "VDF",
            ClosureKind::SurfaceShader => "surfaceshader",
            ClosureKind::VolumeShader => "volumeshader",
            ClosureKind::DisplacementShader => "displacementshader",
            ClosureKind::LightShader => "lightshader",
            ClosureKind::Material => "material",
        }
    }
}

impl Type {
    /// Every type, in a fixed order.
    pub const ALL: [Type; 11] = [
        Type::Bool,
        Type::Int,
        Type::Float,
        Type::Vec2,
        Type::Vec3,
        Type::Color,
        Type::Vec4,
        Type::Color4,
        Type::Matrix33,
        Type::Matrix44,
        Type::String,
    ];

    /// The name used in network files, docs and the IR text form.
    pub fn name(self) -> &'static str {
        match self {
            Type::Bool => "bool",
            Type::Int => "int",
            Type::Float => "float",
            Type::Vec2 => "vec2",
            Type::Vec3 => "vec3",
            Type::Color => "color",
            Type::Vec4 => "vec4",
            Type::Color4 => "color4",
            Type::Matrix33 => "matrix33",
            Type::Matrix44 => "matrix44",
            Type::String => "string",
            Type::Closure(k) => k.name(),
        }
    }

    /// Parses a type name as written by [`Type::name`] (value types and closure types).
    pub fn from_name(s: &str) -> Option<Type> {
        Type::ALL.into_iter().find(|t| t.name() == s).or_else(|| {
            ClosureKind::ALL
                .into_iter()
                .find(|k| k.name() == s)
                .map(Type::Closure)
        })
    }

    /// True for the closure and shader types.
    pub fn is_closure(self) -> bool {
        matches!(self, Type::Closure(_))
    }

    /// Number of scalar components (floats, ints or bools); 0 for strings.
    pub fn width(self) -> usize {
        match self {
            Type::Bool | Type::Int | Type::Float => 1,
            Type::Vec2 => 2,
            Type::Vec3 | Type::Color => 3,
            Type::Vec4 | Type::Color4 => 4,
            Type::Matrix33 => 9,
            Type::Matrix44 => 16,
            Type::String | Type::Closure(_) => 0,
        }
    }

    /// True for float-based vector types (`vec2`, `vec3`, `color`, `vec4`, `color4`).
    pub fn is_vector(self) -> bool {
        matches!(
            self,
            Type::Vec2 | Type::Vec3 | Type::Color | Type::Vec4 | Type::Color4
        )
    }

    /// True for the matrix types (`matrix33`, `matrix44`).
    pub fn is_matrix(self) -> bool {
        matches!(self, Type::Matrix33 | Type::Matrix44)
    }

    /// The matrix type with `n` rows and columns (3 or 4).
    pub fn matrix(n: usize) -> Option<Type> {
        match n {
            3 => Some(Type::Matrix33),
            4 => Some(Type::Matrix44),
            _ => None,
        }
    }

    /// Rows (and columns) of a matrix type; 0 for the others.
    pub fn matrix_size(self) -> usize {
        match self {
            Type::Matrix33 => 3,
            Type::Matrix44 => 4,
            _ => 0,
        }
    }

    /// True for `float` and the float vector types.
    pub fn is_float_based(self) -> bool {
        self == Type::Float || self.is_vector()
    }

    /// True for the colour types (`color`, `color4`).
    pub fn is_color(self) -> bool {
        matches!(self, Type::Color | Type::Color4)
    }

    /// Whether `self` and `other` are the same float vector under two names (color ↔ vec3,
    /// color4 ↔ vec4): a connection between them keeps every component.
    pub fn is_renaming_of(self, other: Type) -> bool {
        let three = |t: Type| matches!(t, Type::Vec3 | Type::Color);
        let four = |t: Type| matches!(t, Type::Vec4 | Type::Color4);
        (three(self) && three(other)) || (four(self) && four(other))
    }

    /// The type with `n` float components: 1 → float, 2 → vec2, 3 → vec3, 4 → vec4.
    pub fn float_vec(n: usize) -> Option<Type> {
        match n {
            1 => Some(Type::Float),
            2 => Some(Type::Vec2),
            3 => Some(Type::Vec3),
            4 => Some(Type::Vec4),
            _ => None,
        }
    }

    /// Names of the components a connection may select (`tex.outColor.r`).
    pub fn component_names(self) -> &'static [&'static str] {
        match self {
            Type::Vec2 => &["x", "y"],
            Type::Vec3 => &["x", "y", "z"],
            Type::Color => &["r", "g", "b"],
            Type::Vec4 => &["x", "y", "z", "w"],
            Type::Color4 => &["r", "g", "b", "a"],
            _ => &[],
        }
    }

    /// Index of a component by name; `u`/`v` alias `x`/`y` on vec2, and `x/y/z` work on
    /// colors, `r/g/b` on vectors (as in Maya).
    pub fn component_index(self, name: &str) -> Option<usize> {
        let idx = match name {
            "x" | "r" | "u" => 0,
            "y" | "g" | "v" => 1,
            "z" | "b" => 2,
            "w" | "a" => 3,
            _ => return None,
        };
        (idx < self.width() && self.is_vector()).then_some(idx)
    }
}

impl fmt::Display for Type {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A constant value. Floats are held as `f64` so the f64 reference interpreter sees literals
/// as written; the f32 paths round them to `f32` once, when a program is loaded.
#[derive(Clone, Debug, PartialEq)]
pub enum ConstValue {
    /// A boolean.
    Bool(bool),
    /// An integer.
    Int(i32),
    /// A float.
    Float(f64),
    /// A two-component vector.
    Vec2([f64; 2]),
    /// A point, vector or normal.
    Vec3([f64; 3]),
    /// A linear RGB color.
    Color([f64; 3]),
    /// A 4-vector.
    Vec4([f64; 4]),
    /// A linear RGBA color.
    Color4([f64; 4]),
    /// A row-major 3×3 matrix.
    Matrix33([f64; 9]),
    /// A row-major 4×4 matrix.
    Matrix44([f64; 16]),
    /// A string (uniform only).
    String(String),
}

impl ConstValue {
    /// The value's type.
    pub fn ty(&self) -> Type {
        match self {
            ConstValue::Bool(_) => Type::Bool,
            ConstValue::Int(_) => Type::Int,
            ConstValue::Float(_) => Type::Float,
            ConstValue::Vec2(_) => Type::Vec2,
            ConstValue::Vec3(_) => Type::Vec3,
            ConstValue::Color(_) => Type::Color,
            ConstValue::Vec4(_) => Type::Vec4,
            ConstValue::Color4(_) => Type::Color4,
            ConstValue::Matrix33(_) => Type::Matrix33,
            ConstValue::Matrix44(_) => Type::Matrix44,
            ConstValue::String(_) => Type::String,
        }
    }

    /// The float components of a float-based or matrix value (empty for the others).
    pub fn floats(&self) -> &[f64] {
        match self {
            ConstValue::Float(x) => std::slice::from_ref(x),
            ConstValue::Vec2(v) => v,
            ConstValue::Vec3(v) | ConstValue::Color(v) => v,
            ConstValue::Vec4(v) | ConstValue::Color4(v) => v,
            ConstValue::Matrix33(m) => m,
            ConstValue::Matrix44(m) => m,
            _ => &[],
        }
    }

    /// Builds a float-based value of type `ty` from its components; `None` on a width
    /// mismatch or a non-float type.
    pub fn from_floats(ty: Type, v: &[f64]) -> Option<ConstValue> {
        if v.len() != ty.width() {
            return None;
        }
        Some(match ty {
            Type::Float => ConstValue::Float(v[0]),
            Type::Vec2 => ConstValue::Vec2([v[0], v[1]]),
            Type::Vec3 => ConstValue::Vec3([v[0], v[1], v[2]]),
            Type::Color => ConstValue::Color([v[0], v[1], v[2]]),
            Type::Vec4 => ConstValue::Vec4([v[0], v[1], v[2], v[3]]),
            Type::Color4 => ConstValue::Color4([v[0], v[1], v[2], v[3]]),
            Type::Matrix33 => {
                let mut m = [0.0; 9];
                m.copy_from_slice(v);
                ConstValue::Matrix33(m)
            }
            Type::Matrix44 => {
                let mut m = [0.0; 16];
                m.copy_from_slice(v);
                ConstValue::Matrix44(m)
            }
            _ => return None,
        })
    }

    /// The zero of a type (false, 0, black, the zero matrix, the empty string). Closures
    /// have no constant (an unset closure input is the empty lobe list, which the lowering
    /// gives): the float 0 stands in, so a caller that does not special-case them cannot
    /// panic.
    pub fn zero(ty: Type) -> ConstValue {
        match ty {
            Type::Bool => ConstValue::Bool(false),
            Type::Int => ConstValue::Int(0),
            Type::String => ConstValue::String(String::new()),
            Type::Closure(_) => ConstValue::Float(0.0),
            _ => ConstValue::from_floats(ty, &vec![0.0; ty.width()]).expect("float type"),
        }
    }

    /// The 4×4 identity matrix.
    pub fn identity() -> ConstValue {
        let mut m = [0.0; 16];
        for i in 0..4 {
            m[i * 5] = 1.0;
        }
        ConstValue::Matrix44(m)
    }
}

/// Writes a float so that parsing it back gives the same bits (`1.0`, `-0.0`, `inf`, `NaN`).
pub fn fmt_float(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        format!("{x:?}")
    }
}

impl fmt::Display for ConstValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConstValue::Bool(b) => write!(f, "{b}"),
            ConstValue::Int(i) => write!(f, "{i}"),
            ConstValue::String(s) => write!(f, "{s:?}"),
            other => {
                let v = other.floats();
                if v.len() == 1 {
                    f.write_str(&fmt_float(v[0]))
                } else {
                    let parts: Vec<String> = v.iter().map(|x| fmt_float(*x)).collect();
                    write!(f, "({})", parts.join(", "))
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_component_types() {
        for t in Type::ALL {
            assert_eq!(Type::from_name(t.name()), Some(t), "{t}");
        }
        assert_eq!((Type::Vec4.width(), Type::Color4.width()), (4, 4));
        assert!(Type::Vec4.is_vector() && Type::Color4.is_float_based());
        assert!(Type::Color4.is_color() && !Type::Vec4.is_color());
        assert_eq!(Type::float_vec(4), Some(Type::Vec4));
        assert_eq!(Type::Color4.component_index("a"), Some(3));
        assert_eq!(Type::Vec4.component_index("w"), Some(3));
        assert_eq!(
            Type::Color.component_index("a"),
            None,
            "a color has no alpha"
        );
        assert!(Type::Vec4.is_renaming_of(Type::Color4) && Type::Color4.is_renaming_of(Type::Vec4));
        assert!(!Type::Vec4.is_renaming_of(Type::Color) && !Type::Vec3.is_renaming_of(Type::Vec4));
        let c = ConstValue::from_floats(Type::Color4, &[1.0, 2.0, 3.0, 0.5]).unwrap();
        assert_eq!(c, ConstValue::Color4([1.0, 2.0, 3.0, 0.5]));
        assert_eq!(c.ty(), Type::Color4);
        assert_eq!(c.to_string(), "(1.0, 2.0, 3.0, 0.5)");
        assert_eq!(ConstValue::zero(Type::Vec4), ConstValue::Vec4([0.0; 4]));
        assert_eq!(ConstValue::from_floats(Type::Vec4, &[1.0, 2.0, 3.0]), None);
    }
}
