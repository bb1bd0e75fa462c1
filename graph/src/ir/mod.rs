//! The shading IR: typed SSA values in one arena, structured regions, no phis.
//!
//! A [`Program`] is one material. Every value is an [`Expr`] in `Program::exprs`, named by a
//! [`Value`] handle; a [`Block`] lists, in order, the values it computes and the values it
//! yields. Operands always come before their users (naga's rule), so one forward sweep
//! evaluates a block and one backward sweep finds what is live.
//!
//! Control flow is structured:
//! - [`Op::If`] evaluates one of two blocks; its results are the chosen block's yields, read
//!   with [`Op::Proj`].
//! - [`Op::Illuminance`] runs its body once per non-ambient light sample (inside it,
//!   [`Op::LightL`], [`Op::LightCl`] and [`Op::LightVisible`] read the current sample); its
//!   results are the sums of the body's yields over all samples (zero without lights). Blocked
//!   samples run the body too, with `light.visible = 0`: a shader multiplies what it lights by
//!   it, and can sum what the shadows take away.
//!
//! - [`Op::Loop`] carries values through iterations: with the carried values' current
//!   values readable as [`Op::LoopVar`], its `cond` block decides whether its `body` block
//!   runs again, and the body yields the next values; its results are the carried values
//!   when the condition fails, or when its loop nest has run [`LOOP_ITERATION_LIMIT`]
//!   bodies (the loop then stops, keeps the values it has, and the back end counts it).
//!
//! Two ops ask the renderer's scene for secondary rays: [`Op::Trace`] (radiance along a
//! direction) and [`Op::Occlusion`] (ambient occlusion). Like the light ops they read the
//! scene, so they are varying, never folded and never hoisted.
//!
//! A value defined inside a block is visible in that block and the blocks nested in it, never
//! outside: results leave a region only through its yields. Region exprs have no type of
//! their own (`ty == None`); every other expr has exactly one type.
//!
//! Rates ([`Rate`]) are derived, not stored: see [`rates`].
//!
//! A program prints in the IR text form (`Display`) and [`parse`] reads it back; the syntax
//! is documented at the top of `graph/src/ir/text.rs`. [`validate`](fn@validate) checks
//! that a program is well formed; passes and back ends may rely on what it checks.

mod builder;
mod derivs;
mod edit;
pub mod matrix;
mod text;
mod validate;

pub use builder::Builder;
pub use text::{ParseError, ParseErrorKind, parse};
pub use validate::{ValidationError, validate};

use crate::types::{ConstValue, Type};
use std::fmt;
use std::marker::PhantomData;
use std::num::NonZeroU32;

/// A typed index into an arena (naga's `Handle`): a non-zero `u32`, so `Option<Handle<T>>` is
/// four bytes.
pub struct Handle<T> {
    index: NonZeroU32,
    _marker: PhantomData<fn() -> T>,
}

impl<T> Handle<T> {
    /// The handle of the `index`-th (zero-based) element.
    pub fn new(index: usize) -> Self {
        let index = u32::try_from(index + 1)
            .ok()
            .and_then(NonZeroU32::new)
            .expect("arena larger than u32::MAX");
        Handle {
            index,
            _marker: PhantomData,
        }
    }

    /// The zero-based index of this handle in its arena.
    pub fn index(self) -> usize {
        self.index.get() as usize - 1
    }
}

impl<T> Clone for Handle<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Handle<T> {}
impl<T> PartialEq for Handle<T> {
    fn eq(&self, other: &Self) -> bool {
        self.index == other.index
    }
}
impl<T> Eq for Handle<T> {}
impl<T> PartialOrd for Handle<T> {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl<T> Ord for Handle<T> {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.index.cmp(&other.index)
    }
}
impl<T> std::hash::Hash for Handle<T> {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.index.hash(state)
    }
}
impl<T> fmt::Debug for Handle<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "v{}", self.index())
    }
}

/// A value of a program: the handle of the [`Expr`] that computes it.
pub type Value = Handle<Expr>;

/// One SSA value: its operation and its type (`None` for region exprs, which have results
/// instead, read by [`Op::Proj`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    /// What computes the value.
    pub op: Op,
    /// The value's type; `None` only for [`Op::If`] and [`Op::Illuminance`].
    pub ty: Option<Type>,
}

/// A straight-line list of values and the values it yields to its region.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Block {
    /// The values computed by this block, operands before users.
    pub body: Vec<Value>,
    /// The block's results (empty for the program's top-level block).
    pub yields: Vec<Value>,
}

/// Implicit per-fragment inputs (DESIGN §3), stored by the renderer in world space.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Stream {
    /// Shading position (vec3, point).
    P,
    /// Shading normal, unit length, facing the incoming ray (vec3, normal).
    N,
    /// Geometric normal (vec3, normal).
    Ng,
    /// Incident ray direction, from the eye to `P`, not normalized (vec3, vector).
    I,
    /// Surface parameterization (vec2).
    Uv,
    /// ∂P/∂u (vec3, vector).
    DPdu,
    /// ∂P/∂v (vec3, vector).
    DPdv,
    /// ∂P/∂x, the ray differential towards the next pixel in x (vec3, vector).
    DPdx,
    /// ∂P/∂y (vec3, vector).
    DPdy,
    /// Shutter time (float).
    Time,
    /// The ray type bit ([`RAY_CAMERA`] …) as an int.
    RayType,
    /// The ray depth: 0 for camera rays (int).
    RayDepth,
    /// Four uniform numbers in [0, 1) from the renderer's sampler for this shading point
    /// (vec4): a closure's BSDF sample takes its direction from `x, y`, its lobe from `z`
    /// and its Russian roulette from `w`. The tracer draws them from its Owen-scrambled
    /// Sobol sequence (dimensions per bounce), so images do not depend on threads; other
    /// callers give what their fragments hold (zeros by default).
    Rand,
}

/// Ray type codes carried by [`Stream::RayType`].
pub const RAY_CAMERA: i32 = 1;
/// Shadow ray.
pub const RAY_SHADOW: i32 = 2;
/// Reflection ray.
pub const RAY_REFLECTION: i32 = 4;
/// Refraction ray.
pub const RAY_REFRACTION: i32 = 8;
/// Diffuse (indirect) ray.
pub const RAY_DIFFUSE: i32 = 16;

/// The ray types and their names in the IR text, in bit order.
pub const RAY_TYPES: [(i32, &str); 5] = [
    (RAY_CAMERA, "camera"),
    (RAY_SHADOW, "shadow"),
    (RAY_REFLECTION, "reflection"),
    (RAY_REFRACTION, "refraction"),
    (RAY_DIFFUSE, "diffuse"),
];

/// The name of a ray type code (`None` for anything but one of the `RAY_*` bits).
pub fn ray_type_name(ray_type: i32) -> Option<&'static str> {
    RAY_TYPES
        .iter()
        .find(|(t, _)| *t == ray_type)
        .map(|(_, n)| *n)
}

/// The ray type code of a name written by [`ray_type_name`].
pub fn ray_type_from_name(name: &str) -> Option<i32> {
    RAY_TYPES.iter().find(|(_, n)| *n == name).map(|(t, _)| *t)
}

/// Whether [`Op::Trace`] may trace rays of this type: reflection, refraction or diffuse
/// (camera rays start at the eye, shadow rays are the light loop's).
pub fn is_traceable_ray_type(ray_type: i32) -> bool {
    matches!(ray_type, RAY_REFLECTION | RAY_REFRACTION | RAY_DIFFUSE)
}

impl Stream {
    /// Every stream, in a fixed order.
    pub const ALL: [Stream; 13] = [
        Stream::P,
        Stream::N,
        Stream::Ng,
        Stream::I,
        Stream::Uv,
        Stream::DPdu,
        Stream::DPdv,
        Stream::DPdx,
        Stream::DPdy,
        Stream::Time,
        Stream::RayType,
        Stream::RayDepth,
        Stream::Rand,
    ];

    /// The stream's name in network files and the IR text.
    pub fn name(self) -> &'static str {
        match self {
            Stream::P => "P",
            Stream::N => "N",
            Stream::Ng => "Ng",
            Stream::I => "I",
            Stream::Uv => "uv",
            Stream::DPdu => "dPdu",
            Stream::DPdv => "dPdv",
            Stream::DPdx => "dPdx",
            Stream::DPdy => "dPdy",
            Stream::Time => "time",
            Stream::RayType => "raytype",
            Stream::RayDepth => "raydepth",
            Stream::Rand => "rand",
        }
    }

    /// Parses a stream name.
    pub fn from_name(s: &str) -> Option<Stream> {
        Stream::ALL.into_iter().find(|x| x.name() == s)
    }

    /// The stream's bit in a set of streams held in a `u32` (`1 << position in`
    /// [`Stream::ALL`]).
    pub fn bit(self) -> u32 {
        1 << (self as u32)
    }

    /// The stream's type.
    pub fn ty(self) -> Type {
        match self {
            Stream::Uv => Type::Vec2,
            Stream::Time => Type::Float,
            Stream::RayType | Stream::RayDepth => Type::Int,
            Stream::Rand => Type::Vec4,
            _ => Type::Vec3,
        }
    }

    /// How the stream transforms between spaces (`None`: it does not).
    pub fn xform_kind(self) -> Option<XformKind> {
        match self {
            Stream::P => Some(XformKind::Point),
            Stream::N | Stream::Ng => Some(XformKind::Normal),
            Stream::I | Stream::DPdu | Stream::DPdv | Stream::DPdx | Stream::DPdy => {
                Some(XformKind::Vector)
            }
            _ => None,
        }
    }
}

/// Coordinate systems a stream can be read in (DESIGN §3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Space {
    /// The renderer's world space (streams are stored in it).
    World,
    /// Camera space: the eye at the origin looking down −z.
    Camera,
    /// The shaded object's space.
    Object,
}

impl Space {
    /// Every space.
    pub const ALL: [Space; 3] = [Space::World, Space::Camera, Space::Object];

    /// The space's name.
    pub fn name(self) -> &'static str {
        match self {
            Space::World => "world",
            Space::Camera => "camera",
            Space::Object => "object",
        }
    }

    /// Parses a space name.
    pub fn from_name(s: &str) -> Option<Space> {
        Space::ALL.into_iter().find(|x| x.name() == s)
    }
}

/// How a vec3 transforms under a matrix: as a point (with translation), a direction, or a
/// normal (inverse transpose).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum XformKind {
    /// `M * (p, 1)`.
    Point,
    /// `M * (v, 0)`.
    Vector,
    /// `(M⁻¹)ᵀ * (n, 0)`.
    Normal,
}

impl XformKind {
    /// Every kind.
    pub const ALL: [XformKind; 3] = [XformKind::Point, XformKind::Vector, XformKind::Normal];

    /// The kind's name.
    pub fn name(self) -> &'static str {
        match self {
            XformKind::Point => "point",
            XformKind::Vector => "vector",
            XformKind::Normal => "normal",
        }
    }

    /// Parses a kind name.
    pub fn from_name(s: &str) -> Option<XformKind> {
        XformKind::ALL.into_iter().find(|x| x.name() == s)
    }
}

macro_rules! named_enum {
    ($(#[$m:meta])* $name:ident { $($(#[$vm:meta])* $v:ident = $s:literal),* $(,)? }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum $name { $($(#[$vm])* $v),* }
        impl $name {
            /// Every variant, in declaration order.
            pub const ALL: &'static [$name] = &[$($name::$v),*];
            /// The name used in the IR text form.
            pub fn name(self) -> &'static str { match self { $($name::$v => $s),* } }
            /// Parses a name written by [`Self::name`].
            pub fn from_name(s: &str) -> Option<Self> {
                Self::ALL.iter().copied().find(|x| x.name() == s)
            }
        }
    };
}

// Declared after `named_enum!`, which it uses.
mod texture;
pub use texture::{ColorSpace, Filter, Sampling, TextureFile, Wrap};

named_enum! {
    /// Unary operations. Component-wise on vectors unless noted; semantics in
    /// [`crate::ops`].
    UnOp {
        /// `-x` (floats, vectors, ints wrapping).
        Neg = "neg",
        /// Logical not (bool).
        Not = "not",
        /// `|x|`.
        Abs = "abs",
        /// Largest integer ≤ x.
        Floor = "floor",
        /// Smallest integer ≥ x.
        Ceil = "ceil",
        /// `x - floor(x)`.
        Fract = "fract",
        /// Square root; 0 for negative x.
        Sqrt = "sqrt",
        /// `e^x`.
        Exp = "exp",
        /// Natural log; `ln(f32::MIN_POSITIVE)` for x ≤ 0.
        Log = "log",
        /// Sine (radians).
        Sin = "sin",
        /// Cosine.
        Cos = "cos",
        /// Tangent.
        Tan = "tan",
        /// Arc sine, argument clamped to [-1, 1].
        Asin = "asin",
        /// Arc cosine, argument clamped to [-1, 1].
        Acos = "acos",
        /// Euclidean length of a vector → float.
        Length = "length",
        /// Unit vector; the zero vector stays zero.
        Normalize = "normalize",
        /// Bitwise complement `!x` of an int (OSL `~x`).
        BitNot = "bitnot",
    }
}

named_enum! {
    /// Binary operations. Arithmetic takes two operands of the same type (component-wise on
    /// vectors); the result type is given per op in [`crate::ops::binary_type`].
    BinOp {
        /// `a + b`.
        Add = "add",
        /// `a - b`.
        Sub = "sub",
        /// `a * b`.
        Mul = "mul",
        /// `a / b`; 0 where b is 0.
        Div = "div",
        /// `a - b * floor(a / b)` (sign of b, as GLSL `mod`); 0 where b is 0.
        Mod = "mod",
        /// `a^b`; 0 for a negative base with a non-integer exponent.
        Pow = "pow",
        /// `a < b ? a : b`.
        Min = "min",
        /// `a > b ? a : b`.
        Max = "max",
        /// `atan2(a, b)`, angle of the point (b, a).
        Atan2 = "atan2",
        /// Dot product of two vectors → float.
        Dot = "dot",
        /// Cross product of two vec3 → vec3.
        Cross = "cross",
        /// `length(a - b)` → float.
        Distance = "distance",
        /// `a < b` on scalars → bool.
        Lt = "lt",
        /// `a <= b` → bool.
        Le = "le",
        /// `a > b` → bool.
        Gt = "gt",
        /// `a >= b` → bool.
        Ge = "ge",
        /// `a == b` → bool.
        Eq = "eq",
        /// `a != b` → bool.
        Ne = "ne",
        /// Logical and (bool).
        And = "and",
        /// Logical or (bool).
        Or = "or",
        /// matrix44 × point (vec3, w = 1) → vec3.
        MulPoint = "mulpoint",
        /// matrix44 × vector (vec3, w = 0) → vec3.
        MulVector = "mulvector",
        /// Bitwise and of two ints.
        BitAnd = "bitand",
        /// Bitwise or of two ints.
        BitOr = "bitor",
        /// Bitwise exclusive or of two ints.
        BitXor = "bitxor",
        /// `a << b` on ints: the bits shifted out are lost; the count is `b`'s low five bits
        /// (`b mod 32`, as x86, Cranelift and WGSL take it), so any count is defined.
        Shl = "shl",
        /// `a >> b` on ints, arithmetic (the sign bit is copied in); the count as for `shl`.
        Shr = "shr",
    }
}

named_enum! {
    /// Pure built-in functions with more than two operands or non-trivial bodies. Each is
    /// defined once in [`crate::ops`] and called, never re-implemented, by every back end on
    /// the CPU.
    Intrinsic {
        /// Improved Perlin noise (Perlin 2002) of a vec2 → float in about [-1, 1].
        Noise2 = "noise2",
        /// Improved Perlin noise of a vec3 → float in about [-1, 1].
        Noise3 = "noise3",
        /// Fractal Brownian motion of noise3: (p: vec3, octaves: int, lacunarity: float,
        /// gain: float) → float.
        Fbm3 = "fbm3",
        /// Cell noise: a hash of floor(p) (vec3) → float in [0, 1).
        CellNoise3 = "cellnoise3",
        /// RGB → HSV (hue in [0, 1)) of a color.
        RgbToHsv = "rgb_to_hsv",
        /// HSV → RGB.
        HsvToRgb = "hsv_to_rgb",
        /// OSL `snoise(x, y)` (vec2 → float, about [-1, 1]), [`crate::ops::osl_noise`].
        OslPerlin2 = "osl_perlin2",
        /// OSL `snoise(p)` (vec3 → float).
        OslPerlin3 = "osl_perlin3",
        /// OSL `vector snoise(x, y)` (vec2 → vec3).
        OslVPerlin2 = "osl_vperlin2",
        /// OSL `vector snoise(p)` (vec3 → vec3).
        OslVPerlin3 = "osl_vperlin3",
        /// OSL `cellnoise(x, y)` (vec2 → float in [0, 1]).
        OslCell2 = "osl_cell2",
        /// OSL `cellnoise(p)` (vec3 → float in [0, 1]).
        OslCell3 = "osl_cell3",
        /// OSL `vector cellnoise(x, y)` (vec2 → vec3).
        OslVCell2 = "osl_vcell2",
        /// OSL `vector cellnoise(p)` (vec3 → vec3).
        OslVCell3 = "osl_vcell3",
        /// OSL `cellnoise(x)` (float → float in [0, 1]).
        OslCell1 = "osl_cell1",
        /// OSL `cellnoise(p, t)` (vec3, float → float in [0, 1]).
        OslCell4 = "osl_cell4",
        /// OSL `vector cellnoise(x)` (float → vec3).
        OslVCell1 = "osl_vcell1",
        /// OSL `vector cellnoise(p, t)` (vec3, float → vec3).
        OslVCell4 = "osl_vcell4",
        /// OSL `snoise(x)` (float → float, about [-1, 1]).
        OslPerlin1 = "osl_perlin1",
        /// OSL `snoise(p, t)` (vec3, float → float).
        OslPerlin4 = "osl_perlin4",
        /// OSL `vector snoise(x)` (float → vec3).
        OslVPerlin1 = "osl_vperlin1",
        /// OSL `vector snoise(p, t)` (vec3, float → vec3).
        OslVPerlin4 = "osl_vperlin4",
        /// OSL `hashnoise(x)`: a hash of the float's bits (float → float in [0, 1]).
        OslHash1 = "osl_hash1",
        /// OSL `hashnoise(x, y)` (vec2 → float).
        OslHash2 = "osl_hash2",
        /// OSL `hashnoise(p)` (vec3 → float).
        OslHash3 = "osl_hash3",
        /// OSL `hashnoise(p, t)` (vec3, float → float).
        OslHash4 = "osl_hash4",
        /// OSL `vector hashnoise(x)` (float → vec3).
        OslVHash1 = "osl_vhash1",
        /// OSL `vector hashnoise(x, y)` (vec2 → vec3).
        OslVHash2 = "osl_vhash2",
        /// OSL `vector hashnoise(p)` (vec3 → vec3).
        OslVHash3 = "osl_vhash3",
        /// OSL `vector hashnoise(p, t)` (vec3, float → vec3).
        OslVHash4 = "osl_vhash4",
        /// OSL `psnoise(x, px)`: periodic Perlin noise (float, period → float).
        OslPPerlin1 = "osl_pperlin1",
        /// OSL `psnoise(x, y, px, py)` (vec2, vec2 periods → float).
        OslPPerlin2 = "osl_pperlin2",
        /// OSL `psnoise(p, pp)` (vec3, vec3 periods → float).
        OslPPerlin3 = "osl_pperlin3",
        /// OSL `psnoise(p, t, pp, pt)` (vec3, float, vec3, float → float).
        OslPPerlin4 = "osl_pperlin4",
        /// OSL `vector psnoise(x, px)` (float, float → vec3).
        OslVPPerlin1 = "osl_vpperlin1",
        /// OSL `vector psnoise(x, y, px, py)` (vec2, vec2 → vec3).
        OslVPPerlin2 = "osl_vpperlin2",
        /// OSL `vector psnoise(p, pp)` (vec3, vec3 → vec3).
        OslVPPerlin3 = "osl_vpperlin3",
        /// OSL `vector psnoise(p, t, pp, pt)` (vec3, float, vec3, float → vec3).
        OslVPPerlin4 = "osl_vpperlin4",
        /// OSL `noise("simplex", x)`: signed simplex noise (float → float, about [-1, 1];
        /// [`crate::ops::osl_simplex`]).
        OslSimplex1 = "osl_simplex1",
        /// OSL `noise("simplex", x, y)` (vec2 → float).
        OslSimplex2 = "osl_simplex2",
        /// OSL `noise("simplex", p)` (vec3 → float).
        OslSimplex3 = "osl_simplex3",
        /// OSL `noise("simplex", p, t)` (vec3, float → float).
        OslSimplex4 = "osl_simplex4",
        /// OSL `vector noise("simplex", x)`: the float noise at seeds 0, 1, 2 (float → vec3).
        OslVSimplex1 = "osl_vsimplex1",
        /// OSL `vector noise("simplex", x, y)` (vec2 → vec3).
        OslVSimplex2 = "osl_vsimplex2",
        /// OSL `vector noise("simplex", p)` (vec3 → vec3).
        OslVSimplex3 = "osl_vsimplex3",
        /// OSL `vector noise("simplex", p, t)` (vec3, float → vec3).
        OslVSimplex4 = "osl_vsimplex4",
        /// MaterialX fractal noise of `osl_perlin2`: (p: vec2, octaves: int, lacunarity:
        /// float, diminish: float) → float.
        MxFractal2 = "mx_fractal2",
        /// MaterialX fractal noise of `osl_perlin3`: (p: vec3, int, float, float) → float.
        MxFractal3 = "mx_fractal3",
        /// MaterialX fractal noise of `osl_vperlin2`: (p: vec2, int, float, float) → vec3.
        MxVFractal2 = "mx_vfractal2",
        /// MaterialX fractal noise of `osl_vperlin3`: (p: vec3, int, float, float) → vec3.
        MxVFractal3 = "mx_vfractal3",
        /// MaterialX Worley noise: (p: vec2, jitter: float, style: int, metric: int) → F1
        /// (float).
        MxWorley2 = "mx_worley2",
        /// MaterialX Worley noise (p: vec2, …) → (F1, F2) (vec2).
        MxWorley2V2 = "mx_worley2_v2",
        /// MaterialX Worley noise (p: vec2, …) → (F1, F2, F3) (vec3).
        MxWorley2V3 = "mx_worley2_v3",
        /// MaterialX Worley noise (p: vec3, jitter: float, style: int, metric: int) → F1.
        MxWorley3 = "mx_worley3",
        /// MaterialX Worley noise (p: vec3, …) → (F1, F2) (vec2).
        MxWorley3V2 = "mx_worley3_v2",
        /// MaterialX Worley noise (p: vec3, …) → (F1, F2, F3) (vec3).
        MxWorley3V3 = "mx_worley3_v3",
        /// The directional albedo of a GGX lobe with Schlick's Fresnel, `(cos θo: float,
        /// α: float)` → `(A, B)` (vec2): it reflects `F0·A + F90·B`
        /// ([`crate::ops::ggx_albedo`], a table of our own integration).
        GgxAlbedo = "ggx_albedo",
        /// The directional albedo of a GGX dielectric's reflection with the exact Fresnel,
        /// `(cos θo: float, α: float, η: float)` → float
        /// ([`crate::ops::dielectric_albedo`], a table of our own integration).
        DielectricAlbedo = "dielectric_albedo",
        /// The directional albedo of the sheen lobe, `(cos θo: float, roughness: float)` →
        /// `(E, G)` (vec2): the raw lobe's albedo and the normalized lobe's albedo times
        /// `max(1, E)` ([`crate::ops::sheen_albedo`], a table of our own integration).
        SheenAlbedo = "sheen_albedo",
    }
}

/// What computes a value.
#[derive(Clone, Debug, PartialEq)]
pub enum Op {
    /// A constant of the expr's type.
    Const(ConstValue),
    /// A uniform material parameter (class compilation): index into `Program::params`.
    Param(u32),
    /// An implicit stream, in world space.
    Stream(Stream),
    /// A vec3 moved between spaces with the shading context's matrices.
    Transform {
        /// Point, vector or normal.
        kind: XformKind,
        /// The space `arg` is in.
        from: Space,
        /// The space of the result.
        to: Space,
        /// The vec3 to transform.
        arg: Value,
    },
    /// Whether render component `k` (index into `Program::components`) is active: bool,
    /// uniform.
    ComponentEnabled(u8),
    /// A unary operation.
    Unary(UnOp, Value),
    /// A binary operation.
    Binary(BinOp, Value, Value),
    /// `cond ? a : b`, both evaluated (a varying select).
    Select {
        /// The bool condition.
        cond: Value,
        /// Result where `cond` holds.
        a: Value,
        /// Result elsewhere.
        b: Value,
    },
    /// Merge: builds a vector of the expr's type from float scalars, or a matrix from its
    /// elements in row-major order (9 for a matrix33, 16 for a matrix44).
    Construct(Vec<Value>),
    /// Split: component `index` of a vector → float; element `index` (row-major) of a matrix.
    Extract(Value, u8),
    /// A float broadcast to every component of the expr's vector type.
    Splat(Value),
    /// A scalar conversion to the expr's type: int → float, float → int (truncation toward
    /// zero, saturating, NaN → 0), bool → int/float (0/1), int/float → bool (≠ 0).
    Convert(Value),
    /// A call of a pure built-in function.
    Call(Intrinsic, Vec<Value>),
    /// Structured conditional: evaluates `then_` where `cond` holds, `else_` elsewhere; results
    /// are the chosen block's yields.
    If {
        /// The bool condition.
        cond: Value,
        /// The block run when `cond` is true.
        then_: Block,
        /// The block run when `cond` is false.
        else_: Block,
    },
    /// Light loop: runs `body` once per non-ambient light sample seen from point `p` (world
    /// space), blocked samples included ([`Op::LightVisible`] tells them apart); results are
    /// the sums of its yields (float or vector) over the samples.
    Illuminance {
        /// The shaded point, world space.
        p: Value,
        /// The per-sample body.
        body: Block,
    },
    /// Inside an illuminance body: unit direction from the shaded point towards the light
    /// sample (vec3, world space).
    LightL,
    /// Inside an illuminance body: radiance-weighted color arriving from the sample, already
    /// divided by distance² where the light has a position (color).
    LightCl,
    /// Inside an illuminance body: whether the current light sample reaches the shaded point
    /// (float: 1.0 where it does, 0.0 where the renderer's scene blocks the segment from the
    /// point to the sample). Without a scene every sample is visible. [`Op::LightCl`] is the
    /// same for blocked and visible samples: a shader multiplies its lit terms by this value
    /// (and may sum `1 − visible` terms to see what the shadows remove).
    LightVisible,
    /// Inside an illuminance body: the density per solid angle with which the light loop
    /// draws the current sample's direction, times the number of samples it draws from that
    /// light (float): the light's term of a multiple-importance-sampling weight. 0 for lights
    /// with a delta distribution (point, spot, distant), which no BSDF sample can hit.
    LightPdf,
    /// Sum of the ambient lights' colors (color): light without direction.
    Ambient,
    /// Result `index` of a region (`If`, `Illuminance` or `Loop`).
    Proj(Value, u8),
    /// Structured loop with loop-carried values (a `while` loop in SSA form). The carried
    /// values start as `init`; before each iteration `cond` runs and yields one bool; where
    /// it is true `body` runs and yields the next carried values (as many, of the same types
    /// as `init`). Inside both blocks, [`Op::LoopVar`] reads a carried value's current
    /// value. The results (read with [`Op::Proj`]) are the carried values once `cond` yields
    /// false, or once the loop nest has run out of iterations ([`LOOP_ITERATION_LIMIT`]):
    /// then it stops with the values it has and the back end counts the stop
    /// (`ShadeOut::loop_limits`), the same on every back end.
    Loop {
        /// The carried values' initial values.
        init: Vec<Value>,
        /// Evaluated before every iteration: yields one bool, whether the body runs again.
        cond: Block,
        /// One iteration: yields the carried values' next values.
        body: Block,
    },
    /// Inside the `cond` or `body` of a loop: the current value of carried value `index` of
    /// the innermost enclosing [`Op::Loop`] (its type is that of `init[index]`).
    LoopVar(u8),
    /// A filtered lookup of texture `texture` (index into `Program::textures`) at `uv`: its
    /// linear RGB color (type color) or its alpha (type float). The footprint is the
    /// parallelogram spanned by the screen-space derivatives of `uv`; `sampling` says how
    /// it is filtered and what lies outside [0, 1]. Evaluated by the runtime's texture
    /// system (`Texture::lookup`); never folded.
    Texture {
        /// Index into `Program::textures`.
        texture: u32,
        /// Texture coordinates (vec2).
        uv: Value,
        /// ∂uv/∂x and ∂uv/∂y (vec2 each): the footprint. `None`: a point lookup (the finest
        /// level, as for a zero footprint).
        derivs: Option<[Value; 2]>,
        /// Filter and wrap modes.
        sampling: Sampling,
        /// Alpha (float) instead of color.
        alpha: bool,
    },
    /// The value of a named per-vertex (or per-object) attribute of the shaded geometry —
    /// a primvar such as a mesh's vertex colours — interpolated at the hit: attribute `slot`
    /// (index into `Program::attributes`, which gives its name and the expr's type: float,
    /// vec2, vec3, color, vec4 or color4), or `default` (same type) where the hit's geometry
    /// has no such attribute or no renderer is asking. Evaluated by the runtime's one lookup
    /// (`shadenet_runtime::attribute`) through the renderer's services; varying, never
    /// folded, never hoisted.
    Attribute {
        /// Index into `Program::attributes`.
        slot: u32,
        /// The value where the geometry lacks the attribute (the expr's type).
        default: Value,
    },
    /// Whether the hit's geometry has attribute `slot` (bool): true exactly where an
    /// [`Op::Attribute`] of the same slot gives the geometry's value rather than its
    /// default (same lookup, same width: the slot's type). OSL's `getattribute` returns it.
    /// Varying, never folded, never hoisted.
    AttributeFound {
        /// Index into `Program::attributes`.
        slot: u32,
    },
    /// Radiance (color) arriving at the shaded point along `dir` (a vec3, world space,
    /// normalized by the runtime): the renderer's scene traces a ray from the fragment's `P`
    /// (it offsets the origin itself) as a ray of type `ray_type` at depth `raydepth + 1` and
    /// shades what it hits. Black without a scene, and for a zero or non-finite `dir`. A pure function of the
    /// fragment and `dir` (two identical traces may be merged), but it reads the scene: it is
    /// varying, never folded and never hoisted.
    Trace {
        /// The direction of the ray (vec3, world space).
        dir: Value,
        /// The ray type code: [`RAY_REFLECTION`], [`RAY_REFRACTION`] or [`RAY_DIFFUSE`] (see
        /// [`is_traceable_ray_type`]).
        ray_type: i32,
        /// For a direction drawn by BSDF sampling: its solid-angle density (float), with
        /// which the renderer weights light sources the ray hits against the light loop's
        /// samples of them (power heuristic). `None`: the ray sees light sources at full
        /// weight (a mirror direction, or a light the loop does not sample).
        pdf: Option<Value>,
    },
    /// Ambient occlusion at the fragment's `P` around normal `n` (float in [0, 1]; 1 = fully
    /// open): the fraction of `samples` cosine-weighted directions the scene finds unblocked
    /// within `max_distance`, deterministic in the fragment's seed. 1 without a scene, for
    /// `max_distance ≤ 0` (or NaN) and for a zero or non-finite `n`; `samples < 1` counts as
    /// 1. Like [`Op::Trace`]: varying, never folded, never hoisted.
    Occlusion {
        /// The normal around which to sample (vec3, world space; normalized by the runtime).
        n: Value,
        /// Number of sample directions (int).
        samples: Value,
        /// How far a blocker counts (float, world units).
        max_distance: Value,
    },
    /// A probe ray: field `field` of the closest surface along the ray from `origin` in
    /// direction `dir` (vec3s, world space; the direction normalized by the runtime) at a
    /// distance in `[min_distance, max_distance]` (floats), found by the renderer's scene
    /// without shading it — OSL's `trace` and `getmessage("trace", …)`. The expr's type is
    /// the field's ([`ProbeField::ty`]); every field is 0 where the ray hits nothing, for a
    /// zero or non-finite direction and without a scene. Like [`Op::Trace`]: a pure function
    /// of its operands and the scene (equal probes may be merged; the renderer answers the
    /// fields of one ray with one traversal), varying, never folded, never hoisted.
    Probe {
        /// Which property of the hit.
        field: ProbeField,
        /// Where the ray starts (vec3, world space).
        origin: Value,
        /// Its direction (vec3, world space).
        dir: Value,
        /// The nearest distance a hit counts at (float).
        min_distance: Value,
        /// The farthest (float).
        max_distance: Value,
    },
    /// An effect: the fragment writes a message — OSL's `printf`, `warning` and `error` —
    /// formatted from `format` (C's printf conversions, [`crate::ops::printf`]) with the
    /// values of `args` (floats and aggregates rounded to f32, as the shader holds them).
    /// The only op that is kept for what it does rather than for its value: dead-code
    /// elimination keeps it (and the regions around it), and it is never merged, folded or
    /// hoisted; within a block, messages are written in the block's order. Its value is the
    /// int 0, which nothing reads. Varying.
    Print {
        /// What kind of message: printed output, a warning or an error.
        severity: Severity,
        /// The format: one conversion per arg, in order (conversions of arguments known at
        /// compile time are already spliced in as text).
        format: String,
        /// The values formatted (floats, ints, bools, vectors, colors, matrices).
        args: Vec<Value>,
    },
}

named_enum! {
    /// The properties of a probe ray's hit an [`Op::Probe`] reads (OSL's
    /// `getmessage("trace", name, …)` names).
    ProbeField {
        /// 1.0 where the ray hit a surface, else 0.0 (float).
        Hit = "hit",
        /// The distance to the hit (float).
        HitDist = "hitdist",
        /// The point hit (vec3).
        P = "P",
        /// The shading normal there (vec3, unit, by the surface's winding).
        N = "N",
        /// The geometric normal there (vec3, unit, by the winding).
        Ng = "Ng",
        /// The surface's first texture coordinate there (float).
        U = "u",
        /// Its second (float).
        V = "v",
    }
}

impl ProbeField {
    /// The type of the field's value: vec3 for points and normals, float otherwise.
    pub fn ty(self) -> Type {
        match self {
            ProbeField::P | ProbeField::N | ProbeField::Ng => Type::Vec3,
            _ => Type::Float,
        }
    }
}

named_enum! {
    /// The kinds of message an [`Op::Print`] writes.
    Severity {
        /// `printf`: output, written as is.
        Printf = "printf",
        /// `warning`: a warning about the shading of a fragment.
        Warning = "warning",
        /// `error`: an error in the shading of a fragment (the shader goes on running).
        Error = "error",
    }
}

impl Op {
    /// A short name of the op for messages and listings (`add`, `call noise`, `stream P`,
    /// `light.Cl`): what a back end names when it cannot compile or run an op.
    pub fn short_name(&self) -> String {
        match self {
            Op::Const(_) => "const".into(),
            Op::Param(i) => format!("param {i}"),
            Op::Stream(s) => format!("stream {}", s.name()),
            Op::Transform { .. } => "transform".into(),
            Op::ComponentEnabled(k) => format!("component_enabled {k}"),
            Op::Unary(u, _) => u.name().into(),
            Op::Binary(b, ..) => b.name().into(),
            Op::Select { .. } => "select".into(),
            Op::Construct(_) => "construct".into(),
            Op::Extract(..) => "extract".into(),
            Op::Splat(_) => "splat".into(),
            Op::Convert(_) => "convert".into(),
            Op::Call(i, _) => format!("call {}", i.name()),
            Op::If { .. } => "if".into(),
            Op::Illuminance { .. } => "illuminance".into(),
            Op::LightL => "light.L".into(),
            Op::LightCl => "light.Cl".into(),
            Op::LightVisible => "light.visible".into(),
            Op::LightPdf => "light.pdf".into(),
            Op::Trace { .. } => "trace".into(),
            Op::Occlusion { .. } => "occlusion".into(),
            Op::Ambient => "ambient".into(),
            Op::Proj(..) => "proj".into(),
            Op::Texture { .. } => "texture".into(),
            Op::Attribute { slot, .. } => format!("attribute {slot}"),
            Op::AttributeFound { slot } => format!("attribute.found {slot}"),
            Op::Loop { .. } => "loop".into(),
            Op::LoopVar(k) => format!("loop.var {k}"),
            Op::Print { severity, .. } => severity.name().into(),
            Op::Probe { field, .. } => format!("probe {}", field.name()),
        }
    }

    /// Calls `f` on every operand of this op (not on values inside nested blocks).
    pub fn for_each_operand(&self, mut f: impl FnMut(Value)) {
        match self {
            Op::Const(_)
            | Op::Param(_)
            | Op::Stream(_)
            | Op::ComponentEnabled(_)
            | Op::LightL
            | Op::LightCl
            | Op::LightVisible
            | Op::LightPdf
            | Op::LoopVar(_)
            | Op::AttributeFound { .. }
            | Op::Ambient => {}
            Op::Transform { arg, .. } => f(*arg),
            Op::Unary(_, a) | Op::Extract(a, _) | Op::Splat(a) | Op::Convert(a) => f(*a),
            Op::Binary(_, a, b) => {
                f(*a);
                f(*b)
            }
            Op::Select { cond, a, b } => {
                f(*cond);
                f(*a);
                f(*b)
            }
            Op::Construct(args)
            | Op::Call(_, args)
            | Op::Loop { init: args, .. }
            | Op::Print { args, .. } => args.iter().copied().for_each(f),
            Op::If { cond, .. } => f(*cond),
            Op::Illuminance { p, .. } => f(*p),
            Op::Proj(r, _) => f(*r),
            Op::Attribute { default, .. } => f(*default),
            Op::Texture { uv, derivs, .. } => {
                f(*uv);
                if let Some([dx, dy]) = derivs {
                    f(*dx);
                    f(*dy)
                }
            }
            Op::Trace { dir, pdf, .. } => {
                f(*dir);
                if let Some(p) = pdf {
                    f(*p)
                }
            }
            Op::Occlusion {
                n,
                samples,
                max_distance,
            } => {
                f(*n);
                f(*samples);
                f(*max_distance)
            }
            Op::Probe {
                origin,
                dir,
                min_distance,
                max_distance,
                ..
            } => {
                f(*origin);
                f(*dir);
                f(*min_distance);
                f(*max_distance)
            }
        }
    }

    /// The nested blocks of a region op (empty for other ops).
    pub fn blocks(&self) -> Vec<&Block> {
        match self {
            Op::If { then_, else_, .. } => vec![then_, else_],
            Op::Illuminance { body, .. } => vec![body],
            Op::Loop { cond, body, .. } => vec![cond, body],
            _ => Vec::new(),
        }
    }
}

/// How many loop bodies one loop *nest* runs at most per fragment, on every back end: each
/// execution of an outermost [`Op::Loop`] starts a budget of this many body runs, and every
/// body run of it or of a loop nested in it (at any depth, through `if` arms and light
/// loops) takes one. Where a loop's condition holds but the budget is spent, the loop stops
/// with the values it has and the stop is counted (then the enclosing loops stop at their
/// next test too). A shader whose loops never end costs at most this many iterations per
/// loop nest, whatever their nesting, instead of hanging a render.
pub const LOOP_ITERATION_LIMIT: u32 = 65536;

/// A declared uniform parameter of a program (class compilation).
#[derive(Clone, Debug, PartialEq)]
pub struct ParamDecl {
    /// The parameter's name (`node.port`).
    pub name: String,
    /// Its type.
    pub ty: Type,
    /// Its value when not overridden.
    pub default: ConstValue,
}

/// A named attribute a program reads ([`Op::Attribute`], [`Op::AttributeFound`]): what the renderer resolves once
/// per program and geometry (a mesh's attribute of this name, or none), so that no hit
/// compares names.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AttributeDecl {
    /// The attribute's name as the geometry spells it (`COLOR_0`, `TEXCOORD_1`, `Cd` …).
    pub name: String,
    /// The type it is read as: float, vec2, vec3, color, vec4 or color4.
    pub ty: Type,
}

/// The types an [`Op::Attribute`] can read (floats of 1 to 4 components).
pub fn is_attribute_type(ty: Type) -> bool {
    matches!(
        ty,
        Type::Float | Type::Vec2 | Type::Vec3 | Type::Color | Type::Vec4 | Type::Color4
    )
}

/// One material output: a named value, optionally the part of it that belongs to one render
/// component. An output name with component parts has, as its total ("beauty"), the sum of
/// its parts.
#[derive(Clone, Debug, PartialEq)]
pub struct Output {
    /// The material output's name as declared in the network.
    pub name: String,
    /// The render component this part belongs to (index into `Program::components`), or
    /// `None` for an untagged output.
    pub component: Option<u8>,
    /// The value.
    pub value: Value,
}

/// One material: values, the prelude and the top-level block, outputs, component names,
/// parameters and textures.
///
/// The **prelude** holds values that depend only on constants and parameters (the uniform
/// hoisting pass moves them there): a back end evaluates it once per material instance, and
/// its values are visible to the top-level block. It contains no region and nothing that
/// reads the fragment, the lights, the component mask or a texture.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    /// The material's name.
    pub name: String,
    /// The arena of values; a [`Value`] indexes it.
    pub exprs: Vec<Expr>,
    /// Values computed once per material instance, before `body` (its `yields` stay empty).
    pub prelude: Block,
    /// The top-level block (its `yields` stay empty).
    pub body: Block,
    /// Outputs, in declaration order; parts of the same name are contiguous.
    pub outputs: Vec<Output>,
    /// Render component names; bit `i` of a component mask is `components[i]`.
    pub components: Vec<String>,
    /// Uniform parameters.
    pub params: Vec<ParamDecl>,
    /// Texture files, by index (paths as the network gave them, made absolute by the loader
    /// when the network came from a file), each with its color space.
    pub textures: Vec<TextureFile>,
    /// Named geometry attributes read by [`Op::Attribute`] and [`Op::AttributeFound`], by
    /// slot.
    pub attributes: Vec<AttributeDecl>,
}

impl Program {
    /// The slot of attribute `name` read as `ty`, added to `Program::attributes` when new.
    pub fn attribute_slot(&mut self, name: &str, ty: Type) -> u32 {
        let decl = AttributeDecl {
            name: name.to_string(),
            ty,
        };
        match self.attributes.iter().position(|a| *a == decl) {
            Some(i) => i as u32,
            None => {
                self.attributes.push(decl);
                (self.attributes.len() - 1) as u32
            }
        }
    }

    /// Makes the relative paths of the texture table relative to `dir` (the folder of the
    /// file the program came from).
    pub fn resolve_textures(&mut self, dir: &std::path::Path) {
        for t in &mut self.textures {
            if std::path::Path::new(&t.path).is_relative() {
                t.path = dir.join(&t.path).to_string_lossy().into_owned();
            }
        }
    }

    /// The expr of a value.
    pub fn expr(&self, v: Value) -> &Expr {
        &self.exprs[v.index()]
    }

    /// The op of a value.
    pub fn op(&self, v: Value) -> &Op {
        &self.exprs[v.index()].op
    }

    /// The type of a non-region value. Region exprs have none: a valid program never uses
    /// one as an operand other than of [`Op::Proj`].
    pub fn ty(&self, v: Value) -> Type {
        self.exprs[v.index()]
            .ty
            .expect("region expr used as a typed value")
    }

    /// The result types of a region expr (its yields' types).
    pub fn region_types(&self, v: Value) -> Vec<Type> {
        let block = match self.op(v) {
            Op::If { then_, .. } => then_,
            Op::Illuminance { body, .. } | Op::Loop { body, .. } => body,
            _ => return Vec::new(),
        };
        block.yields.iter().map(|y| self.ty(*y)).collect()
    }

    /// Index of a component name.
    pub fn component_index(&self, name: &str) -> Option<u8> {
        self.components
            .iter()
            .position(|c| c == name)
            .map(|i| i as u8)
    }

    /// Distinct output names, in declaration order.
    pub fn output_names(&self) -> Vec<&str> {
        let mut names: Vec<&str> = Vec::new();
        for o in &self.outputs {
            if !names.contains(&o.name.as_str()) {
                names.push(&o.name);
            }
        }
        names
    }

    /// Calls `f` on every value of `block` and of the blocks nested in it, in evaluation
    /// order (a region before the values of its blocks).
    pub fn walk(&self, block: &Block, f: &mut impl FnMut(Value)) {
        for &v in &block.body {
            f(v);
            for inner in self.op(v).blocks() {
                self.walk(inner, f);
            }
        }
    }

    /// Number of values in the prelude and the top-level block, nested blocks included (ops
    /// in the program).
    pub fn op_count(&self) -> usize {
        let mut n = 0;
        self.walk(&self.prelude, &mut |_| n += 1);
        self.walk(&self.body, &mut |_| n += 1);
        n
    }
}

/// How often a value changes (DESIGN §4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Rate {
    /// Known at compile time.
    Const,
    /// Fixed per material instance (parameters, the component mask).
    Uniform,
    /// Changes per fragment.
    Varying,
}

impl Rate {
    /// The rate's name.
    pub fn name(self) -> &'static str {
        match self {
            Rate::Const => "const",
            Rate::Uniform => "uniform",
            Rate::Varying => "varying",
        }
    }
}

/// Derives the rate of every value (indexed like `Program::exprs`; values not reachable from
/// the top-level block get `Const`). A value's rate is the highest of its operands'; streams,
/// light samples (and their visibility), ambient light, the scene queries (`trace`,
/// `occlusion`, `probe`) and messages (`print`) are varying; parameters and component queries uniform;
/// a region's results are at least as varying as its condition or point and everything it
/// yields.
pub fn rates(program: &Program) -> Vec<Rate> {
    let mut rates = vec![Rate::Const; program.exprs.len()];
    let mut carried = Vec::new();
    rate_block(program, &program.prelude, &mut rates, &mut carried);
    rate_block(program, &program.body, &mut rates, &mut carried);
    rates
}

/// `carried`: the rates of the carried values of the enclosing loops, innermost last.
fn rate_block(program: &Program, block: &Block, rates: &mut [Rate], carried: &mut Vec<Vec<Rate>>) {
    for &v in &block.body {
        let op = program.op(v);
        let mut r = match op {
            Op::Const(_) => Rate::Const,
            Op::Param(_) | Op::ComponentEnabled(_) | Op::Texture { .. } => Rate::Uniform,
            Op::Stream(_)
            | Op::LightL
            | Op::LightCl
            | Op::LightVisible
            | Op::LightPdf
            | Op::Ambient
            | Op::Trace { .. }
            | Op::Attribute { .. }
            | Op::AttributeFound { .. }
            | Op::Occlusion { .. }
            | Op::Probe { .. }
            | Op::Print { .. } => Rate::Varying,
            Op::Illuminance { .. } => Rate::Varying,
            Op::LoopVar(k) => carried
                .last()
                .and_then(|c| c.get(*k as usize))
                .copied()
                .unwrap_or(Rate::Const),
            _ => Rate::Const,
        };
        op.for_each_operand(|a| r = r.max(rates[a.index()]));
        if let Op::Loop { init, cond, body } = op {
            r = rate_loop(program, init, cond, body, rates, carried);
        }
        for inner in op.blocks() {
            if matches!(op, Op::Loop { .. }) {
                break;
            }
            rate_block(program, inner, rates, carried);
            for y in &inner.yields {
                r = r.max(rates[y.index()]);
            }
        }
        rates[v.index()] = r;
    }
}

/// A loop's carried values are as varying as their initial values, their next values and
/// the condition (a varying trip count makes every carried value varying): iterated to the
/// fixed point (each round raises at least one rate, so it ends within 2·n + 1 rounds).
/// Returns the loop's rate: the highest carried rate and the condition's.
fn rate_loop(
    program: &Program,
    init: &[Value],
    cond: &Block,
    body: &Block,
    rates: &mut [Rate],
    carried: &mut Vec<Vec<Rate>>,
) -> Rate {
    let mut cur: Vec<Rate> = init.iter().map(|v| rates[v.index()]).collect();
    loop {
        carried.push(cur.clone());
        rate_block(program, cond, rates, carried);
        rate_block(program, body, rates, carried);
        carried.pop();
        let c = cond.yields.iter().map(|y| rates[y.index()]).max();
        let c = c.unwrap_or(Rate::Const);
        let next: Vec<Rate> = cur
            .iter()
            .enumerate()
            .map(|(k, r)| {
                let y = body.yields.get(k).map_or(Rate::Const, |y| rates[y.index()]);
                (*r).max(y).max(c)
            })
            .collect();
        if next == cur {
            return cur.into_iter().fold(c, Rate::max);
        }
        cur = next;
    }
}
