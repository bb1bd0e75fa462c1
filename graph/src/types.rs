//! Value types shared by networks and the IR, and constant values.
//!
//! A network port has a [`Type`]; the IR uses the same enum. `Color` and `Vec3` are both
//! three floats and lower to the same IR arithmetic, but stay distinct for type checking and
//! documentation (the linker coerces between them).

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
    /// A 4×4 matrix, row-major, points are column vectors (`M * p`).
    Matrix44,
    /// A string; uniform only (file names, enum-like options), never reaches the IR.
    String,
}

impl Type {
    /// Every type, in a fixed order.
    pub const ALL: [Type; 8] = [
        Type::Bool,
        Type::Int,
        Type::Float,
        Type::Vec2,
        Type::Vec3,
        Type::Color,
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
            Type::Matrix44 => "matrix44",
            Type::String => "string",
        }
    }

    /// Parses a type name as written by [`Type::name`].
    pub fn from_name(s: &str) -> Option<Type> {
        Type::ALL.into_iter().find(|t| t.name() == s)
    }

    /// Number of scalar components (floats, ints or bools); 0 for strings.
    pub fn width(self) -> usize {
        match self {
            Type::Bool | Type::Int | Type::Float => 1,
            Type::Vec2 => 2,
            Type::Vec3 | Type::Color => 3,
            Type::Matrix44 => 16,
            Type::String => 0,
        }
    }

    /// True for float-based vector types (`vec2`, `vec3`, `color`).
    pub fn is_vector(self) -> bool {
        matches!(self, Type::Vec2 | Type::Vec3 | Type::Color)
    }

    /// True for `float` and the float vector types.
    pub fn is_float_based(self) -> bool {
        matches!(self, Type::Float | Type::Vec2 | Type::Vec3 | Type::Color)
    }

    /// The type with `n` float components: 1 → float, 2 → vec2, 3 → vec3.
    pub fn float_vec(n: usize) -> Option<Type> {
        match n {
            1 => Some(Type::Float),
            2 => Some(Type::Vec2),
            3 => Some(Type::Vec3),
            _ => None,
        }
    }

    /// Names of the components a connection may select (`tex.outColor.r`).
    pub fn component_names(self) -> &'static [&'static str] {
        match self {
            Type::Vec2 => &["x", "y"],
            Type::Vec3 => &["x", "y", "z"],
            Type::Color => &["r", "g", "b"],
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
            Type::Matrix44 => {
                let mut m = [0.0; 16];
                m.copy_from_slice(v);
                ConstValue::Matrix44(m)
            }
            _ => return None,
        })
    }

    /// The zero of a type (false, 0, black, the zero matrix, the empty string).
    pub fn zero(ty: Type) -> ConstValue {
        match ty {
            Type::Bool => ConstValue::Bool(false),
            Type::Int => ConstValue::Int(0),
            Type::String => ConstValue::String(String::new()),
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
