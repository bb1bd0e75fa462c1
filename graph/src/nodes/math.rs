//! Standard nodes: math.
//!
//! Arithmetic, the elementary functions, vector geometry, interpolation and color
//! conversions. Most nodes are generic over `T` ∈ [`FLOAT_TYPES`] and work component-wise
//! on vectors; the geometric ones (`dot`, `length`, `normalize`, `distance`) take
//! `T` ∈ {vec2, vec3, color}. Every node inherits the total op semantics of
//! [`crate::ops`] (`x/0 = 0`, `sqrt(x<0) = 0`, …); what remains non-finite (overflow, a NaN
//! input) is left to the material output guard, which turns it into 0 and counts it.
//!
//! Component parts (DESIGN §8): `add`, `multiply`, `divide` (numerator), `mix` and `blend`
//! carry the render-component parts of their inputs through; every other node returns a
//! plain value.

use super::{
    FLOAT_TYPES, LowVal, LowerFn, NodeDef, NodeInputs, NodeLibrary, OutDef, PortDef, lowering, port,
};
use crate::ir::{BinOp, Builder, Intrinsic, UnOp, Value};
use crate::types::{ConstValue, Type};

/// The vector types the geometric nodes accept.
const VECTOR_TYPES: &[Type] = &[Type::Vec2, Type::Vec3, Type::Color];

/// Rec.709 luma weights (linear RGB).
const REC709: [f64; 3] = [0.2126, 0.7152, 0.0722];

fn node(
    name: &'static str,
    doc: &'static str,
    generic: &'static [Type],
    inputs: Vec<PortDef>,
    outputs: Vec<OutDef>,
    lower: LowerFn,
) -> NodeDef {
    NodeDef::shading("math", name, doc, generic, inputs, outputs, lower)
}

/// Unary component-wise nodes: (name, op, doc). Ports: `input` (T, default 0) → `out` (T).
const UNARY: &[(&str, UnOp, &str)] = &[
    (
        "abs",
        UnOp::Abs,
        "Absolute value, component-wise: `out = |input|`. A NaN stays NaN (the output guard \
         turns it into 0).",
    ),
    (
        "floor",
        UnOp::Floor,
        "Largest integer ≤ x, component-wise: `out = floor(input)`. Infinities and NaN pass \
         through (and are caught by the output guard).",
    ),
    (
        "ceil",
        UnOp::Ceil,
        "Smallest integer ≥ x, component-wise: `out = ceil(input)`. Infinities and NaN pass \
         through (and are caught by the output guard).",
    ),
    (
        "fract",
        UnOp::Fract,
        "Fractional part, component-wise: `out = input − floor(input)`, in [0, 1] for finite \
         input. A tiny negative input rounds to exactly 1 (`fract(−1e−9) = 1` in f32). An \
         infinite input gives NaN (caught by the output guard).",
    ),
    (
        "exp",
        UnOp::Exp,
        "Exponential, component-wise: `out = e^input`. Overflows to +inf above about 88.7 in \
         f32 (709.8 in f64); the output guard turns that into 0.",
    ),
    (
        "log",
        UnOp::Log,
        "Natural logarithm, component-wise: `out = ln(input)`; total: for `input ≤ 0` the \
         result is `ln(f32::MIN_POSITIVE) ≈ −87.3365` (in both precisions).",
    ),
    (
        "sqrt",
        UnOp::Sqrt,
        "Square root, component-wise: `out = √input`; total: 0 for `input < 0`.",
    ),
    (
        "sin",
        UnOp::Sin,
        "Sine of an angle in radians, component-wise.",
    ),
    (
        "cos",
        UnOp::Cos,
        "Cosine of an angle in radians, component-wise.",
    ),
    (
        "tan",
        UnOp::Tan,
        "Tangent of an angle in radians, component-wise. Near odd multiples of π/2 the result \
         is large but finite (the angle is never exactly π/2 in floating point).",
    ),
    (
        "asin",
        UnOp::Asin,
        "Arc sine in radians, component-wise; total: the argument is clamped to [−1, 1] \
         first, so `asin(2) = π/2`, `asin(−5) = −π/2`.",
    ),
    (
        "acos",
        UnOp::Acos,
        "Arc cosine in radians, component-wise; total: the argument is clamped to [−1, 1] \
         first, so `acos(2) = 0`, `acos(−5) = π`.",
    ),
];

/// Simple binary component-wise nodes: (name, op, first port (name, default, doc),
/// second port, doc). Output `out` (T).
type BinaryEntry = (
    &'static str,
    BinOp,
    (&'static str, f64, &'static str),
    (&'static str, f64, &'static str),
    &'static str,
);

const BINARY: &[BinaryEntry] = &[
    (
        "subtract",
        BinOp::Sub,
        ("input1", 0.0, "The minuend."),
        ("input2", 0.0, "The subtrahend."),
        "Difference, component-wise: `out = input1 − input2`. Carries no component parts \
         (subtract a shaded color's parts explicitly if needed).",
    ),
    (
        "min",
        BinOp::Min,
        ("input1", 0.0, "First operand."),
        ("input2", 0.0, "Second operand."),
        "Minimum, component-wise: `out = input1 < input2 ? input1 : input2`. A NaN in \
         `input1` yields `input2`; a NaN in `input2` yields `input2` (NaN) too.",
    ),
    (
        "max",
        BinOp::Max,
        ("input1", 0.0, "First operand."),
        ("input2", 0.0, "Second operand."),
        "Maximum, component-wise: `out = input1 > input2 ? input1 : input2`. A NaN in \
         `input1` yields `input2`; a NaN in `input2` yields `input2` (NaN) too.",
    ),
    (
        "mod",
        BinOp::Mod,
        ("input1", 0.0, "The dividend `a`."),
        ("input2", 1.0, "The divisor `b`."),
        "Floored modulo, component-wise (GLSL `mod`): `out = a − b·floor(a / b)`, with the \
         sign of `b`; total: `mod(a, 0) = 0`.",
    ),
    (
        "pow",
        BinOp::Pow,
        ("base", 0.0, "The base."),
        ("exponent", 1.0, "The exponent."),
        "Power, component-wise: `out = base^exponent`; total: a negative base with a \
         non-integer exponent gives 0 (`pow(−2, 3) = −8`, `pow(−2, 0.5) = 0`), and \
         `pow(0, e < 0) = 0` rather than infinity. Large results overflow to inf (guarded).",
    ),
    (
        "atan2",
        BinOp::Atan2,
        ("y", 0.0, "The ordinate."),
        ("x", 1.0, "The abscissa."),
        "Angle of the point (x, y) in radians, in [−π, π], component-wise: `out = atan2(y, \
         x)`; `atan2(0, 0) = 0` (IEEE: `atan2(±0, −0) = ±π`).",
    ),
];

/// Registers the math nodes.
pub fn register(lib: &mut NodeLibrary) {
    lib.add(node(
        "add",
        "Sum, component-wise: `out = input1 + input2`. Carries component parts when both \
         inputs have them (summed per component); if only one has parts the result is plain \
         (the untagged term belongs to no component).",
        FLOAT_TYPES,
        vec![
            port::generic("input1", 0.0, "First term."),
            port::generic("input2", 0.0, "Second term."),
        ],
        vec![port::out_generic("out", "`input1 + input2`.")],
        lower_add,
    ));
    lib.add(node(
        "multiply",
        "Product, component-wise: `out = input1 · input2`. If exactly one input has component \
         parts, each part is scaled by the other input (the product is linear in it); \
         otherwise the result is plain. Overflow gives inf (guarded).",
        FLOAT_TYPES,
        vec![
            port::generic("input1", 0.0, "First factor."),
            port::generic("input2", 1.0, "Second factor."),
        ],
        vec![port::out_generic("out", "`input1 · input2`.")],
        lower_multiply,
    ));
    lib.add(node(
        "divide",
        "Quotient, component-wise: `out = input1 / input2`; total: 0 wherever the divisor \
         component is 0 (`1/0 = 0`, `0/0 = 0`). If only `input1` has component parts, each \
         part is divided by `input2`; otherwise the result is plain.",
        FLOAT_TYPES,
        vec![
            port::generic("input1", 0.0, "The dividend."),
            port::generic("input2", 1.0, "The divisor."),
        ],
        vec![port::out_generic(
            "out",
            "`input1 / input2` (0 where `input2` is 0).",
        )],
        lower_divide,
    ));
    for &(name, _, doc) in UNARY {
        lib.add(node(
            name,
            doc,
            FLOAT_TYPES,
            vec![port::generic("input", 0.0, "The argument.")],
            vec![port::out_generic("out", "The result.")],
            lower_unary,
        ));
    }
    for &(name, _, (n1, d1, doc1), (n2, d2, doc2), doc) in BINARY {
        lib.add(node(
            name,
            doc,
            FLOAT_TYPES,
            vec![port::generic(n1, d1, doc1), port::generic(n2, d2, doc2)],
            vec![port::out_generic("out", "The result.")],
            lower_binary,
        ));
    }
    lib.add(node(
        "multiplyDivide",
        "Maya `multiplyDivide`, component-wise on vec3: `operation` \"noOperation\" gives \
         `input1`, \"multiply\" `input1 · input2`, \"divide\" `input1 / input2` (total: 0 \
         where a divisor component is 0), \"power\" `input1^input2` (total: a negative base \
         with a non-integer exponent gives 0, `0^negative = 0`).",
        &[],
        vec![
            port::vec3("input1", [0.0; 3], "First operand."),
            port::vec3("input2", [1.0; 3], "Second operand."),
            port::option(
                "operation",
                "multiply",
                &["noOperation", "multiply", "divide", "power"],
                "What to compute.",
            ),
        ],
        vec![port::out("output", Type::Vec3, "The result.")],
        lower_multiply_divide,
    ));
    lib.add(node(
        "dot",
        "Dot product: `out = Σ input1ᵢ · input2ᵢ` (summed left to right).",
        VECTOR_TYPES,
        vec![
            port::generic("input1", 0.0, "First vector."),
            port::generic("input2", 0.0, "Second vector."),
        ],
        vec![port::out("out", Type::Float, "The dot product.")],
        lower_dot,
    ));
    lib.add(node(
        "cross",
        "Cross product of two vec3: `out = input1 × input2` (right-handed: x × y = z). \
         Parallel or zero inputs give the zero vector.",
        &[],
        vec![
            port::vec3("input1", [0.0; 3], "First vector."),
            port::vec3("input2", [0.0; 3], "Second vector."),
        ],
        vec![port::out("out", Type::Vec3, "The cross product.")],
        lower_cross,
    ));
    lib.add(node(
        "normalize",
        "Unit vector: `out = input / length(input)`; total: the zero vector stays zero. In \
         f32 a vector whose squared length overflows (components above about 1.8e19) \
         normalizes to zero too, and so does one whose squared length underflows \
         (components below about 1e−23); components below about 1e−19 lose accuracy.",
        VECTOR_TYPES,
        vec![port::generic("input", 0.0, "The vector.")],
        vec![port::out_generic("out", "The unit vector (or zero).")],
        lower_normalize,
    ));
    lib.add(node(
        "length",
        "Euclidean length: `out = √(Σ inputᵢ²)`; 0 for the zero vector. Overflows to inf for \
         components above about 1.8e19 in f32 (guarded).",
        VECTOR_TYPES,
        vec![port::generic("input", 0.0, "The vector.")],
        vec![port::out("out", Type::Float, "The length.")],
        lower_length,
    ));
    lib.add(node(
        "distance",
        "Euclidean distance: `out = length(input1 − input2)`; 0 for equal inputs.",
        VECTOR_TYPES,
        vec![
            port::generic("input1", 0.0, "First point."),
            port::generic("input2", 0.0, "Second point."),
        ],
        vec![port::out("out", Type::Float, "The distance.")],
        lower_distance,
    ));
    lib.add(node(
        "clamp",
        "Maya `clamp`, component-wise: `output = min(max(input, min), max)`. If `min > max` \
         the result is `max`. A NaN input gives `min` (then limited by `max`).",
        FLOAT_TYPES,
        vec![
            port::generic("input", 0.0, "The value to limit."),
            port::generic("min", 0.0, "Lower bound."),
            port::generic("max", 1.0, "Upper bound."),
        ],
        vec![port::out_generic("output", "The clamped value.")],
        lower_clamp,
    ));
    lib.add(node(
        "mix",
        "Linear interpolation: `out = input1 · (1 − weight) + input2 · weight` (weight a \
         float, applied to every component); `weight = 0` gives `input1`, `1` gives \
         `input2`; weights outside [0, 1] extrapolate. Carries component parts when both \
         inputs have them: each part is mixed with the same weight (a component missing on \
         one side counts as 0 there); if only one input has parts the result is plain.",
        FLOAT_TYPES,
        vec![
            port::generic("input1", 0.0, "Value at weight 0."),
            port::generic("input2", 1.0, "Value at weight 1."),
            port::float("weight", 0.5, "Interpolation weight."),
        ],
        vec![port::out_generic("out", "The interpolated value.")],
        lower_mix,
    ));
    lib.add(node(
        "blend",
        "Maya `blendColors`: `output = color1 · blender + color2 · (1 − blender)`; \
         `blender = 1` gives `color1`, `0` gives `color2`; values outside [0, 1] \
         extrapolate. Carries component parts like `mix` (both colors must have parts).",
        &[],
        vec![
            port::color("color1", [1.0, 0.0, 0.0], "Color at blender 1."),
            port::color("color2", [0.0, 0.0, 1.0], "Color at blender 0."),
            port::float("blender", 0.5, "Blend weight of `color1`."),
        ],
        vec![port::out("output", Type::Color, "The blended color.")],
        lower_blend,
    ));
    lib.add(node(
        "smoothstep",
        "Hermite step, component-wise (GLSL): `t = clamp((x − edge0) / (edge1 − edge0), 0, \
         1)`, `out = t²·(3 − 2t)`. Where `edge0 == edge1` it is a hard step: `out = x ≥ \
         edge0 ? 1 : 0` (so exactly 1 at the edge). `edge0 > edge1` gives the mirrored, \
         decreasing curve. A NaN `x` gives 0.",
        FLOAT_TYPES,
        vec![
            port::generic("edge0", 0.0, "Where the curve leaves 0."),
            port::generic("edge1", 1.0, "Where the curve reaches 1."),
            port::generic("x", 0.0, "The value."),
        ],
        vec![port::out_generic("out", "The smoothed step.")],
        lower_smoothstep,
    ));
    lib.add(node(
        "remap",
        "Linear range remap, component-wise (like Maya `setRange`, but without clamping): \
         `outValue = newMin + (value − oldMin) / (oldMax − oldMin) · (newMax − newMin)`. \
         With the total division, `oldMin == oldMax` gives `newMin`. Values outside the old \
         range extrapolate; follow with `clamp` to limit them.",
        FLOAT_TYPES,
        vec![
            port::generic("value", 0.0, "The value to remap."),
            port::generic("oldMin", 0.0, "Start of the input range."),
            port::generic("oldMax", 1.0, "End of the input range."),
            port::generic("newMin", 0.0, "Start of the output range."),
            port::generic("newMax", 1.0, "End of the output range."),
        ],
        vec![port::out_generic("outValue", "The remapped value.")],
        lower_remap,
    ));
    lib.add(node(
        "invert",
        "Maya `reverse`, component-wise: `output = 1 − input`.",
        FLOAT_TYPES,
        vec![port::generic("input", 0.0, "The value.")],
        vec![port::out_generic("output", "`1 − input`.")],
        lower_invert,
    ));
    lib.add(node(
        "luminance",
        "Luminance of a linear RGB color with the Rec.709 weights: `outValue = 0.2126·r + \
         0.7152·g + 0.0722·b` (unlike Maya's `luminance`, which uses 0.3, 0.59, 0.11).",
        &[],
        vec![port::color("value", [0.0; 3], "The color.")],
        vec![port::out("outValue", Type::Float, "The luminance.")],
        lower_luminance,
    ));
    lib.add(node(
        "rgbToHsv",
        "Maya `rgbToHsv`: RGB → HSV with hue in [0, 1) (0 for greys), saturation \
         `(max − min) / max` (0 for black) and value `max`.",
        &[],
        vec![port::color("inRgb", [0.0; 3], "The RGB color.")],
        vec![port::out(
            "outHsv",
            Type::Color,
            "(hue, saturation, value) as a color.",
        )],
        lower_rgb_to_hsv,
    ));
    lib.add(node(
        "hsvToRgb",
        "Maya `hsvToRgb`: HSV → RGB; the hue wraps modulo 1, saturation and value are used \
         as given (not clamped).",
        &[],
        vec![port::color(
            "inHsv",
            [0.0; 3],
            "(hue, saturation, value) as a color.",
        )],
        vec![port::out("outRgb", Type::Color, "The RGB color.")],
        lower_hsv_to_rgb,
    ));
}

fn lower_add(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    Ok(vec![lowering::add_parts(
        b,
        n.low("input1"),
        n.low("input2"),
    )])
}

fn lower_multiply(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let (x, y) = (n.low("input1"), n.low("input2"));
    let out = match (x.parts.is_empty(), y.parts.is_empty()) {
        (false, true) => lowering::map_parts(b, x, |b, v| b.mul(v, y.value)),
        (true, false) => lowering::map_parts(b, y, |b, v| b.mul(x.value, v)),
        _ => LowVal::plain(b.mul(x.value, y.value)),
    };
    Ok(vec![out])
}

fn lower_divide(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let (x, y) = (n.low("input1"), n.low("input2"));
    let out = if y.parts.is_empty() {
        lowering::map_parts(b, x, |b, v| b.div(v, y.value))
    } else {
        LowVal::plain(b.div(x.value, y.value))
    };
    Ok(vec![out])
}

/// The value of the `i`-th input port.
fn arg(n: &NodeInputs, i: usize) -> Value {
    n.get(n.def.inputs[i].name)
}

fn lower_unary(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let op = UNARY
        .iter()
        .find(|e| e.0 == n.def.name)
        .map(|e| e.1)
        .ok_or_else(|| format!("no unary op for node type `{}`", n.def.name))?;
    let x = arg(n, 0);
    Ok(vec![LowVal::plain(b.unary(op, x))])
}

fn lower_binary(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let op = BINARY
        .iter()
        .find(|e| e.0 == n.def.name)
        .map(|e| e.1)
        .ok_or_else(|| format!("no binary op for node type `{}`", n.def.name))?;
    let (x, y) = (arg(n, 0), arg(n, 1));
    Ok(vec![LowVal::plain(b.binary(op, x, y))])
}

fn lower_multiply_divide(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let (x, y) = (n.get("input1"), n.get("input2"));
    let v = match n.string("operation") {
        "noOperation" => x,
        "multiply" => b.mul(x, y),
        "divide" => b.div(x, y),
        "power" => b.binary(BinOp::Pow, x, y),
        other => {
            return Err(format!(
                "operation `{other}` is not one of noOperation, multiply, divide, power"
            ));
        }
    };
    Ok(vec![LowVal::plain(v)])
}

fn lower_dot(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let v = b.dot(n.get("input1"), n.get("input2"));
    Ok(vec![LowVal::plain(v)])
}

fn lower_cross(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let v = b.binary(BinOp::Cross, n.get("input1"), n.get("input2"));
    Ok(vec![LowVal::plain(v)])
}

fn lower_normalize(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let v = b.normalize(n.get("input"));
    Ok(vec![LowVal::plain(v)])
}

fn lower_length(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let v = b.unary(UnOp::Length, n.get("input"));
    Ok(vec![LowVal::plain(v)])
}

fn lower_distance(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let v = b.binary(BinOp::Distance, n.get("input1"), n.get("input2"));
    Ok(vec![LowVal::plain(v)])
}

fn lower_clamp(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let v = b.clamp(n.get("input"), n.get("min"), n.get("max"));
    Ok(vec![LowVal::plain(v)])
}

/// `x · (1 − w) + y · w` (`w` a float) with component parts: when both sides have parts,
/// part `k` is `xₖ · (1 − w) + yₖ · w`, a part missing on one side counting as 0; when only
/// one side has parts the result is plain (the other side's untagged term belongs to no
/// component).
fn mix_parts(b: &mut Builder, x: &LowVal, y: &LowVal, w: Value) -> LowVal {
    let value = b.mix(x.value, y.value, w);
    if x.parts.is_empty() || y.parts.is_empty() {
        return LowVal::plain(value);
    }
    let ty = b.ty(x.value);
    let one = b.float(1.0);
    let omw = b.sub(one, w);
    let omw = b.splat_to(ty, omw);
    let ws = b.splat_to(ty, w);
    let mut keys: Vec<u8> = x.parts.iter().map(|(k, _)| *k).collect();
    for (k, _) in &y.parts {
        if !keys.contains(k) {
            keys.push(*k);
        }
    }
    let find = |side: &LowVal, k: u8| side.parts.iter().find(|(j, _)| *j == k).map(|p| p.1);
    let parts = keys
        .into_iter()
        .map(|k| {
            let tx = find(x, k).map(|p| b.mul(p, omw));
            let ty_ = find(y, k).map(|p| b.mul(p, ws));
            let v = match (tx, ty_) {
                (Some(a), Some(c)) => b.add(a, c),
                (Some(a), None) | (None, Some(a)) => a,
                (None, None) => b.zero(ty),
            };
            (k, v)
        })
        .collect();
    LowVal::with_parts(value, parts)
}

fn lower_mix(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    Ok(vec![mix_parts(
        b,
        n.low("input1"),
        n.low("input2"),
        n.get("weight"),
    )])
}

fn lower_blend(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    // color1 · blender + color2 · (1 − blender) = mix(color2, color1, blender).
    Ok(vec![mix_parts(
        b,
        n.low("color2"),
        n.low("color1"),
        n.get("blender"),
    )])
}

/// Applies the scalar lowering `f` to each component of `args` (all of type `ty`) and
/// rebuilds a `ty`; for a float `ty`, `f` is applied to `args` directly.
fn componentwise(
    b: &mut Builder,
    ty: Type,
    args: &[Value],
    f: impl Fn(&mut Builder, &[Value]) -> Value,
) -> Value {
    if !ty.is_vector() {
        return f(b, args);
    }
    let comps: Vec<Value> = (0..ty.width())
        .map(|i| {
            let a: Vec<Value> = args.iter().map(|&v| b.extract(v, i)).collect();
            f(b, &a)
        })
        .collect();
    b.construct(ty, &comps)
}

/// Scalar smoothstep (`a = [edge0, edge1, x]`), a hard step where the edges are equal.
pub(crate) fn smoothstep_scalar(b: &mut Builder, a: &[Value]) -> Value {
    let (e0, e1, x) = (a[0], a[1], a[2]);
    let num = b.sub(x, e0);
    let den = b.sub(e1, e0);
    let q = b.div(num, den);
    let zero = b.float(0.0);
    let one = b.float(1.0);
    let t = b.clamp(q, zero, one);
    let two = b.float(2.0);
    let three = b.float(3.0);
    let tt = b.mul(t, t);
    let twot = b.mul(two, t);
    let k = b.sub(three, twot);
    let smooth = b.mul(tt, k);
    let at_or_above = b.binary(BinOp::Ge, x, e0);
    let step = b.convert(Type::Float, at_or_above);
    let degenerate = b.binary(BinOp::Eq, e0, e1);
    b.select(degenerate, step, smooth)
}

fn lower_smoothstep(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let args = [n.get("edge0"), n.get("edge1"), n.get("x")];
    let v = componentwise(b, n.generic, &args, smoothstep_scalar);
    Ok(vec![LowVal::plain(v)])
}

fn lower_remap(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let (x, o0, o1) = (n.get("value"), n.get("oldMin"), n.get("oldMax"));
    let (n0, n1) = (n.get("newMin"), n.get("newMax"));
    let num = b.sub(x, o0);
    let den = b.sub(o1, o0);
    let t = b.div(num, den);
    let range = b.sub(n1, n0);
    let scaled = b.mul(t, range);
    let v = b.add(n0, scaled);
    Ok(vec![LowVal::plain(v)])
}

fn lower_invert(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let x = n.get("input");
    let ty = b.ty(x);
    let one = b.constant(
        ConstValue::from_floats(ty, &vec![1.0; ty.width()]).unwrap_or(ConstValue::Float(1.0)),
    );
    Ok(vec![LowVal::plain(b.sub(one, x))])
}

fn lower_luminance(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let w = b.constant(ConstValue::Color(REC709));
    let v = b.dot(n.get("value"), w);
    Ok(vec![LowVal::plain(v)])
}

fn lower_rgb_to_hsv(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let v = b.call(Intrinsic::RgbToHsv, &[n.get("inRgb")]);
    Ok(vec![LowVal::plain(v)])
}

fn lower_hsv_to_rgb(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let v = b.call(Intrinsic::HsvToRgb, &[n.get("inHsv")]);
    Ok(vec![LowVal::plain(v)])
}

#[cfg(test)]
mod tests {
    //! Component-part propagation, checked on the lowered ops directly (literal inputs in
    //! `lower_single` have no parts). Parts are built from constants and evaluated with
    //! [`crate::ops`] by a small recursive evaluator.

    use super::*;
    use crate::ir::{Op, Program};
    use crate::nodes::InputVal;
    use crate::ops::{self, Val};

    fn eval(p: &Program, v: Value) -> Vec<f64> {
        fn ev(p: &Program, v: Value) -> Val<f64> {
            match p.op(v) {
                Op::Const(c) => Val::from_const(c),
                Op::Binary(op, a, b) => ops::binary(*op, ev(p, *a), ev(p, *b)),
                Op::Unary(op, a) => ops::unary(*op, ev(p, *a)),
                Op::Select { cond, a, b } => ops::select(ev(p, *cond), ev(p, *a), ev(p, *b)),
                Op::Splat(a) => ops::splat(p.ty(v), ev(p, *a)),
                Op::Extract(a, i) => ops::extract(ev(p, *a), *i),
                Op::Construct(args) => {
                    let vals: Vec<Val<f64>> = args.iter().map(|a| ev(p, *a)).collect();
                    ops::construct(p.ty(v), &vals)
                }
                other => panic!("unexpected op {other:?}"),
            }
        }
        ev(p, v).floats().to_vec()
    }

    /// A color with parts: the parts are constants, the value their sum.
    fn tagged(b: &mut Builder, parts: &[(u8, [f64; 3])]) -> LowVal {
        let parts = parts
            .iter()
            .map(|(k, c)| (*k, b.constant(ConstValue::Color(*c))))
            .collect();
        lowering::sum_parts(b, Type::Color, parts)
    }

    fn plain(b: &mut Builder, c: [f64; 3]) -> LowVal {
        LowVal::plain(b.constant(ConstValue::Color(c)))
    }

    fn lower(b: &mut Builder, name: &str, values: Vec<InputVal>) -> LowVal {
        let mut lib = NodeLibrary::new();
        register(&mut lib);
        let def = lib.get(name).expect("registered");
        let n = NodeInputs {
            node: "n",
            def,
            generic: Type::Color,
            values,
            upstream: None,
        };
        let mut outs = (def.lower)(b, &n).expect("lowers");
        assert_eq!(outs.len(), 1);
        outs.remove(0)
    }

    fn val(v: LowVal) -> InputVal {
        InputVal::Value(v)
    }

    /// The parts of `r`, evaluated, in order.
    fn parts(b: &Builder, r: &LowVal) -> Vec<(u8, Vec<f64>)> {
        r.parts
            .iter()
            .map(|(k, p)| (*k, eval(b.program(), *p)))
            .collect()
    }

    fn close(a: &[f64], b: &[f64]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
    }

    /// The parts sum to the total.
    fn assert_consistent(b: &Builder, r: &LowVal) {
        let total = eval(b.program(), r.value);
        let mut sum = vec![0.0; total.len()];
        for (_, p) in parts(b, r) {
            for (s, x) in sum.iter_mut().zip(p) {
                *s += x;
            }
        }
        assert!(close(&sum, &total), "parts sum {sum:?} vs total {total:?}");
    }

    #[test]
    fn multiply_scales_the_parts_of_the_tagged_side() {
        for swap in [false, true] {
            let mut b = Builder::new("t");
            let x = tagged(&mut b, &[(0, [1.0, 2.0, 3.0]), (1, [0.5, 0.0, 4.0])]);
            let y = plain(&mut b, [2.0, 3.0, 0.5]);
            let values = if swap {
                vec![val(y), val(x)]
            } else {
                vec![val(x), val(y)]
            };
            let r = lower(&mut b, "multiply", values);
            let got = parts(&b, &r);
            assert_eq!(got.len(), 2);
            assert_eq!(got[0].0, 0);
            assert!(close(&got[0].1, &[2.0, 6.0, 1.5]), "{got:?}");
            assert_eq!(got[1].0, 1);
            assert!(close(&got[1].1, &[1.0, 0.0, 2.0]), "{got:?}");
            assert!(close(&eval(b.program(), r.value), &[3.0, 6.0, 3.5]));
            assert_consistent(&b, &r);
        }
    }

    #[test]
    fn multiply_of_two_tagged_or_two_plain_values_is_plain() {
        let mut b = Builder::new("t");
        let x = tagged(&mut b, &[(0, [1.0, 2.0, 3.0])]);
        let y = tagged(&mut b, &[(1, [2.0, 2.0, 2.0])]);
        let r = lower(&mut b, "multiply", vec![val(x), val(y)]);
        assert!(r.parts.is_empty());
        assert!(close(&eval(b.program(), r.value), &[2.0, 4.0, 6.0]));
        let (p, q) = (plain(&mut b, [1.0; 3]), plain(&mut b, [3.0; 3]));
        let r = lower(&mut b, "multiply", vec![val(p), val(q)]);
        assert!(r.parts.is_empty());
    }

    #[test]
    fn divide_divides_the_parts_of_the_numerator() {
        let mut b = Builder::new("t");
        let x = tagged(&mut b, &[(0, [1.0, 2.0, 3.0]), (2, [4.0, 4.0, 4.0])]);
        let y = plain(&mut b, [2.0, 0.0, 4.0]);
        let r = lower(&mut b, "divide", vec![val(x), val(y)]);
        let got = parts(&b, &r);
        assert_eq!(got.len(), 2);
        assert!(close(&got[0].1, &[0.5, 0.0, 0.75]), "{got:?}");
        assert_eq!(got[1].0, 2);
        assert!(close(&got[1].1, &[2.0, 0.0, 1.0]), "{got:?}");
        assert_consistent(&b, &r);
        // A tagged divisor: not linear, plain.
        let x = plain(&mut b, [1.0; 3]);
        let y = tagged(&mut b, &[(0, [2.0; 3])]);
        let r = lower(&mut b, "divide", vec![val(x), val(y)]);
        assert!(r.parts.is_empty());
    }

    #[test]
    fn add_sums_parts_per_component_and_drops_them_for_untagged_terms() {
        let mut b = Builder::new("t");
        let x = tagged(&mut b, &[(0, [1.0, 0.0, 0.0]), (1, [0.0, 1.0, 0.0])]);
        let y = tagged(&mut b, &[(1, [0.0, 2.0, 0.0]), (2, [0.0, 0.0, 3.0])]);
        let r = lower(&mut b, "add", vec![val(x.clone()), val(y)]);
        let got = parts(&b, &r);
        let keys: Vec<u8> = got.iter().map(|p| p.0).collect();
        assert_eq!(keys, vec![0, 1, 2]);
        assert!(close(&got[1].1, &[0.0, 3.0, 0.0]), "{got:?}");
        assert_consistent(&b, &r);
        let z = plain(&mut b, [1.0; 3]);
        let r = lower(&mut b, "add", vec![val(x), val(z)]);
        assert!(r.parts.is_empty());
        assert!(close(&eval(b.program(), r.value), &[2.0, 2.0, 1.0]));
    }

    #[test]
    fn mix_mixes_parts_with_missing_components_as_zero() {
        let mut b = Builder::new("t");
        let x = tagged(&mut b, &[(0, [4.0, 0.0, 0.0]), (1, [0.0, 4.0, 0.0])]);
        let y = tagged(&mut b, &[(1, [0.0, 8.0, 0.0]), (2, [0.0, 0.0, 8.0])]);
        let w = b.float(0.25);
        let r = lower(
            &mut b,
            "mix",
            vec![val(x.clone()), val(y), val(LowVal::plain(w))],
        );
        let got = parts(&b, &r);
        let keys: Vec<u8> = got.iter().map(|p| p.0).collect();
        assert_eq!(keys, vec![0, 1, 2]);
        assert!(close(&got[0].1, &[3.0, 0.0, 0.0]), "{got:?}");
        assert!(close(&got[1].1, &[0.0, 5.0, 0.0]), "{got:?}");
        assert!(close(&got[2].1, &[0.0, 0.0, 2.0]), "{got:?}");
        assert_consistent(&b, &r);
        // One untagged side: plain.
        let z = plain(&mut b, [1.0; 3]);
        let r = lower(&mut b, "mix", vec![val(x), val(z), val(LowVal::plain(w))]);
        assert!(r.parts.is_empty());
    }

    #[test]
    fn blend_weights_color1_by_blender() {
        let mut b = Builder::new("t");
        let c1 = tagged(&mut b, &[(0, [1.0, 0.0, 0.0])]);
        let c2 = tagged(&mut b, &[(1, [0.0, 0.0, 1.0])]);
        let w = b.float(0.75);
        let r = lower(
            &mut b,
            "blend",
            vec![val(c1), val(c2), val(LowVal::plain(w))],
        );
        let got = parts(&b, &r);
        let find = |k: u8| got.iter().find(|p| p.0 == k).map(|p| p.1.clone());
        assert!(
            close(&find(0).expect("part 0"), &[0.75, 0.0, 0.0]),
            "{got:?}"
        );
        assert!(
            close(&find(1).expect("part 1"), &[0.0, 0.0, 0.25]),
            "{got:?}"
        );
        assert!(close(&eval(b.program(), r.value), &[0.75, 0.0, 0.25]));
        assert_consistent(&b, &r);
    }

    #[test]
    fn unary_and_binary_tables_name_registered_nodes() {
        let mut lib = NodeLibrary::new();
        register(&mut lib);
        for (name, ..) in UNARY {
            assert!(lib.get(name).is_some(), "{name}");
        }
        for (name, ..) in BINARY {
            assert!(lib.get(name).is_some(), "{name}");
        }
        for d in lib.defs() {
            assert!(!d.doc.is_empty(), "{} has no doc", d.name);
            assert!(d.inputs.iter().all(|p| !p.doc.is_empty()), "{}", d.name);
            assert!(d.outputs.iter().all(|p| !p.doc.is_empty()), "{}", d.name);
        }
    }
}
