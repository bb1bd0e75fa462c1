//! One IR value → one WGSL expression, and the WGSL library those expressions call.
//!
//! (Interface fixed; bodies are being written. Every function here is pure text.)

use shadenet_graph::ir::{Program, Value};
use shadenet_graph::types::{ConstValue, Type};

/// The WGSL intrinsic library: every `sn_*` function the expressions of [`op_expr`] call.
/// Included once at the top of every kernel.
pub const LIBRARY: &str = include_str!("wgsl/lib.wgsl");

/// Texture lookup (`sn_texture(tex: u32, uv: vec2<f32>) -> vec4<f32>`), which reads the
/// bindings `sn_texels: array<vec4<f32>>` and `sn_tex_info: array<vec4<u32>>` (base, width,
/// height, 0): included only by kernels of programs with textures, after those bindings.
pub const TEXTURE_LIBRARY: &str = include_str!("wgsl/texture.wgsl");

/// Why a value cannot be written as one WGSL expression.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EmitError {
    /// The op reads buffers or is a region (streams, params, lights, textures, trace, If,
    /// Illuminance, Proj, ComponentEnabled, Transform, Ambient): the kernel writer handles it.
    #[error("{0} is not a pure op")]
    NotPure(String),
    /// The type has no WGSL form (strings).
    #[error("type {0} has no WGSL form")]
    Type(String),
}

/// The WGSL type of an IR type: `bool`, `i32`, `f32`, `vec2<f32>`, `vec3<f32>` (vec3 and
/// color), `array<vec4<f32>, 4>` (matrix44, rows).
pub fn wgsl_type(ty: Type) -> Result<&'static str, EmitError> {
    let _ = ty;
    Err(EmitError::Type("not written yet".into()))
}

/// An exact WGSL literal of a constant (floats round-trip bit for bit; non-finite and
/// subnormal floats as `bitcast<f32>(0x…u)`).
pub fn literal(c: &ConstValue) -> Result<String, EmitError> {
    let _ = c;
    Err(EmitError::Type("not written yet".into()))
}

/// The WGSL expression computing `v` from its operands, for the pure ops (`Const`, `Unary`,
/// `Binary` incl. `mulpoint`/`mulvector`, `Select`, `Construct`, `Extract`, `Splat`,
/// `Convert`, `Call`). `arg` names an operand's WGSL expression (a variable the kernel
/// writer declared).
pub fn op_expr(
    program: &Program,
    v: Value,
    arg: &mut dyn FnMut(Value) -> String,
) -> Result<String, EmitError> {
    let _ = (program, v, arg);
    Err(EmitError::NotPure("not written yet".into()))
}

/// How a value of type `ty` is stored in `f32` buffer columns (`sn_tmp`): one expression per
/// column, from the WGSL expression `e` of the value (floats as they are, ints as
/// `bitcast<f32>`, bools as 0/1).
pub fn store_columns(ty: Type, e: &str) -> Vec<String> {
    let _ = (ty, e);
    Vec::new()
}

/// The inverse of [`store_columns`]: the value of type `ty` from the WGSL expressions of its
/// columns.
pub fn load_columns(ty: Type, cols: &[String]) -> String {
    let _ = (ty, cols);
    String::new()
}

/// How an output of type `ty` is written to `sn_out`: one expression per column (floats as
/// they are, ints as `f32(i)`, bools as 0/1: the interpreter's output layout).
pub fn output_columns(ty: Type, e: &str) -> Vec<String> {
    let _ = (ty, e);
    Vec::new()
}

/// Columns a value of type `ty` takes (matrix44: 16; string: 1).
pub fn columns(ty: Type) -> usize {
    match ty {
        Type::Matrix44 => 16,
        t => t.width().max(1),
    }
}
