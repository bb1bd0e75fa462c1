//! The lowerings of the MaterialX atoms, each the formula of the MaterialX specification
//! written with existing IR ops (one function per node, serving every type variant).
//!
//! This module owns the formulas; it must not decide which nodedef uses which lowering (the
//! table in [`super::atoms`] does). A float operand of a vector-typed node (`ND_add_color3FA`)
//! is broadcast; angles are in degrees, as MaterialX writes them.

use super::atoms_matrix as mx;
use crate::ir::{
    BinOp, Builder, ColorSpace, Filter, Intrinsic, Sampling, Space, Stream, TextureFile, UnOp,
    Value, Wrap, XformKind,
};
use crate::nodes::filtered_noise::{self, Fractal};
use crate::nodes::{LowVal, NodeInputs};
use crate::types::{ConstValue, Type};

type Out = Result<Vec<LowVal>, String>;

fn one(v: Value) -> Out {
    Ok(vec![LowVal::plain(v)])
}

/// The node's (first) output type.
fn out_ty(inp: &NodeInputs) -> Type {
    inp.def.outputs[0].ty.unwrap_or(Type::Float)
}

/// Input `port` broadcast to `ty` where it is a float and `ty` a vector.
fn get(b: &mut Builder, inp: &NodeInputs, port: &str, ty: Type) -> Value {
    let v = inp.get(port);
    b.splat_to(ty, v)
}

fn konst(b: &mut Builder, ty: Type, x: f64) -> Value {
    match ty {
        Type::Int => b.int(x as i32),
        _ => b.constant(
            ConstValue::from_floats(ty, &vec![x; ty.width()]).unwrap_or(ConstValue::Float(x)),
        ),
    }
}

fn bin(b: &mut Builder, inp: &NodeInputs, op: BinOp) -> Out {
    let ty = out_ty(inp);
    let (x, y) = (get(b, inp, "in1", ty), get(b, inp, "in2", ty));
    one(b.binary(op, x, y))
}

fn un(b: &mut Builder, inp: &NodeInputs, op: UnOp) -> Out {
    let x = inp.get("in");
    one(b.unary(op, x))
}

/// Applies a scalar function to each component of `v` (or to `v` if it is a float).
fn per_component(
    b: &mut Builder,
    v: Value,
    mut f: impl FnMut(&mut Builder, Value) -> Value,
) -> Value {
    let ty = b.ty(v);
    if !ty.is_vector() {
        return f(b, v);
    }
    let parts: Vec<Value> = (0..ty.width())
        .map(|i| {
            let c = b.extract(v, i);
            f(b, c)
        })
        .collect();
    b.construct(ty, &parts)
}

/// `in` of a node.
fn input(inp: &NodeInputs) -> Value {
    inp.get("in")
}

/// `in1 + in2` (matrices: element by element, see [`mx::elementwise`]).
pub fn add(b: &mut Builder, inp: &NodeInputs) -> Out {
    if mx::on_matrix(b, inp, "in1") {
        return mx::elementwise(b, inp, BinOp::Add);
    }
    bin(b, inp, BinOp::Add)
}
/// `in1 - in2` (matrices: element by element).
pub fn subtract(b: &mut Builder, inp: &NodeInputs) -> Out {
    if mx::on_matrix(b, inp, "in1") {
        return mx::elementwise(b, inp, BinOp::Sub);
    }
    bin(b, inp, BinOp::Sub)
}
/// `in1 * in2` (matrices: the matrix product, [`mx::multiply`]).
pub fn multiply(b: &mut Builder, inp: &NodeInputs) -> Out {
    if mx::on_matrix(b, inp, "in1") {
        return mx::multiply(b, inp);
    }
    bin(b, inp, BinOp::Mul)
}
/// `in1 / in2` (0 where `in2` is 0: the IR's total division; matrices: `in1 · in2⁻¹`,
/// [`mx::divide`]).
pub fn divide(b: &mut Builder, inp: &NodeInputs) -> Out {
    if mx::on_matrix(b, inp, "in1") {
        return mx::divide(b, inp);
    }
    bin(b, inp, BinOp::Div)
}
/// `in1 - in2 * floor(in1 / in2)` (GLSL `mod`; 0 where `in2` is 0).
pub fn modulo(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let (x, y) = (get(b, inp, "in1", ty), get(b, inp, "in2", ty));
    let q = b.div(x, y);
    let f = b.unary(UnOp::Floor, q);
    let p = b.mul(y, f);
    one(b.sub(x, p))
}
/// `x - floor(x)`.
pub fn fract(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Fract)
}
/// `amount - in`.
pub fn invert(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let (x, a) = (get(b, inp, "in", ty), get(b, inp, "amount", ty));
    one(b.sub(a, x))
}
/// `|in|`.
pub fn absval(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Abs)
}
/// `-1`, `0` or `1` per component.
pub fn sign(b: &mut Builder, inp: &NodeInputs) -> Out {
    let x = input(inp);
    one(per_component(b, x, |b, c| {
        let (z, p, n) = (b.float(0.0), b.float(1.0), b.float(-1.0));
        let gt = b.binary(BinOp::Gt, c, z);
        let lt = b.binary(BinOp::Lt, c, z);
        let neg = b.select(lt, n, z);
        b.select(gt, p, neg)
    }))
}

fn rounding(b: &mut Builder, inp: &NodeInputs, f: impl Fn(&mut Builder, Value) -> Value) -> Out {
    let x = input(inp);
    let r = f(b, x);
    if out_ty(inp) == Type::Int {
        return one(b.convert(Type::Int, r));
    }
    one(r)
}
/// `floor(in)` (an integer output converts the floored value).
pub fn floor(b: &mut Builder, inp: &NodeInputs) -> Out {
    rounding(b, inp, |b, x| b.unary(UnOp::Floor, x))
}
/// `ceil(in)`.
pub fn ceil(b: &mut Builder, inp: &NodeInputs) -> Out {
    rounding(b, inp, |b, x| b.unary(UnOp::Ceil, x))
}
/// Round half away from zero: `sign(x) * floor(|x| + 0.5)`.
pub fn round(b: &mut Builder, inp: &NodeInputs) -> Out {
    rounding(b, inp, |b, x| {
        per_component(b, x, |b, c| {
            let a = b.unary(UnOp::Abs, c);
            let h = b.float(0.5);
            let s = b.add(a, h);
            let f = b.unary(UnOp::Floor, s);
            let z = b.float(0.0);
            let neg = b.binary(BinOp::Lt, c, z);
            let nf = b.unary(UnOp::Neg, f);
            b.select(neg, nf, f)
        })
    })
}
/// `pow(in1, in2)` (0 for a negative base and a non-integer exponent).
pub fn power(b: &mut Builder, inp: &NodeInputs) -> Out {
    bin(b, inp, BinOp::Pow)
}
/// `sin(in)` (radians).
pub fn sin(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Sin)
}
/// `cos(in)`.
pub fn cos(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Cos)
}
/// `tan(in)`.
pub fn tan(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Tan)
}
/// `asin(in)` (argument clamped).
pub fn asin(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Asin)
}
/// `acos(in)` (argument clamped).
pub fn acos(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Acos)
}
/// `atan2(iny, inx)`.
pub fn atan2(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let (y, x) = (get(b, inp, "iny", ty), get(b, inp, "inx", ty));
    one(b.binary(BinOp::Atan2, y, x))
}
/// `sqrt(in)` (0 for negative input).
pub fn sqrt(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Sqrt)
}
/// Natural logarithm.
pub fn ln(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Log)
}
/// `e^in`.
pub fn exp(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Exp)
}
/// `min(max(in, low), high)`.
pub fn clamp(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let x = get(b, inp, "in", ty);
    let (lo, hi) = (get(b, inp, "low", ty), get(b, inp, "high", ty));
    one(b.clamp(x, lo, hi))
}
/// `min(in1, in2)`.
pub fn min(b: &mut Builder, inp: &NodeInputs) -> Out {
    bin(b, inp, BinOp::Min)
}
/// `max(in1, in2)`.
pub fn max(b: &mut Builder, inp: &NodeInputs) -> Out {
    bin(b, inp, BinOp::Max)
}
/// `in / |in|` (0 for the zero vector).
pub fn normalize(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Normalize)
}
/// `|in|`.
pub fn magnitude(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Length)
}
/// `|in1 - in2|`.
pub fn distance(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (x, y) = (inp.get("in1"), inp.get("in2"));
    one(b.binary(BinOp::Distance, x, y))
}
/// `in1 · in2`.
pub fn dotproduct(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (x, y) = (inp.get("in1"), inp.get("in2"));
    one(b.dot(x, y))
}
/// `in1 × in2`.
pub fn crossproduct(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (x, y) = (inp.get("in1"), inp.get("in2"));
    one(b.binary(BinOp::Cross, x, y))
}

/// `normalmap` (MaterialX 1.39 `mx_normalmap_vector2`): a tangent-space normal `in`
/// (encoded in [0, 1]; an all-zero `in` reads as +z) to world space with the frame of its
/// `normal`, `tangent` and `bitangent` inputs (the N, dP/du and dP/dv streams by default),
/// the tangent-plane part scaled by `scale` (float or vector2): `normalize(T·x·sx + B·y·sy
/// + N·z)`.
pub fn normalmap(b: &mut Builder, inp: &NodeInputs) -> Out {
    let v = inp.get("in");
    let (two, one_, zero) = (b.float(2.0), b.float(1.0), b.float(0.0));
    let len2 = b.dot(v, v);
    let empty = b.binary(BinOp::Eq, len2, zero);
    let two3 = b.splat(Type::Vec3, two);
    let one3 = b.splat(Type::Vec3, one_);
    let d = b.mul(v, two3);
    let d = b.sub(d, one3);
    let up = b.vec3([0.0, 0.0, 1.0]);
    let v = b.select(empty, up, d);
    let s = inp.get("scale");
    let (sx, sy) = if b.ty(s) == Type::Vec2 {
        (b.extract(s, 0), b.extract(s, 1))
    } else {
        (s, s)
    };
    let (x, y, z) = (b.extract(v, 0), b.extract(v, 1), b.extract(v, 2));
    let (x, y) = (b.mul(x, sx), b.mul(y, sy));
    let t = inp.get("tangent");
    let bt = inp.get("bitangent");
    let n = inp.get("normal");
    let tx = b.splat(Type::Vec3, x);
    let by = b.splat(Type::Vec3, y);
    let nz = b.splat(Type::Vec3, z);
    let t = b.mul(t, tx);
    let bt = b.mul(bt, by);
    let n = b.mul(n, nz);
    let r = b.add(t, bt);
    let r = b.add(r, n);
    one(b.unary(UnOp::Normalize, r))
}

/// A MaterialX space name: `model`/`object` → object, `world`, `camera`; empty → world.
fn space(s: &str) -> Result<Space, String> {
    match s {
        "" | "world" => Ok(Space::World),
        "model" | "object" => Ok(Space::Object),
        "camera" => Ok(Space::Camera),
        other => Err(format!(
            "space `{other}` is not one of model, object, world, camera"
        )),
    }
}

fn transform(b: &mut Builder, inp: &NodeInputs, kind: XformKind) -> Out {
    let from = space(inp.string("fromspace"))?;
    let to = space(inp.string("tospace"))?;
    let x = input(inp);
    if from == to {
        return one(x);
    }
    one(b.push(
        crate::ir::Op::Transform {
            kind,
            from,
            to,
            arg: x,
        },
        Some(Type::Vec3),
    ))
}
/// A point from `fromspace` to `tospace`.
pub fn transformpoint(b: &mut Builder, inp: &NodeInputs) -> Out {
    transform(b, inp, XformKind::Point)
}
/// A vector from `fromspace` to `tospace`.
pub fn transformvector(b: &mut Builder, inp: &NodeInputs) -> Out {
    transform(b, inp, XformKind::Vector)
}
/// A normal from `fromspace` to `tospace`.
pub fn transformnormal(b: &mut Builder, inp: &NodeInputs) -> Out {
    transform(b, inp, XformKind::Normal)
}

/// `deg` in radians.
pub(super) fn radians(b: &mut Builder, deg: Value) -> Value {
    let k = b.float(std::f64::consts::PI / 180.0);
    b.mul(deg, k)
}
/// `(c·x + s·y, −s·x + c·y)` with `amount` in degrees (MaterialX's `mx_rotate_vector2`).
pub fn rotate2d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let v = input(inp);
    let r = radians(b, inp.get("amount"));
    let (s, c) = (b.unary(UnOp::Sin, r), b.unary(UnOp::Cos, r));
    let (x, y) = (b.extract(v, 0), b.extract(v, 1));
    let (cx, sy) = (b.mul(c, x), b.mul(s, y));
    let (sx, cy) = (b.mul(s, x), b.mul(c, y));
    let rx = b.add(cx, sy);
    let ry = b.sub(cy, sx);
    one(b.construct(Type::Vec2, &[rx, ry]))
}
/// Rodrigues' rotation of `in` by `amount` degrees about `normalize(axis)`, in MaterialX's
/// convention (`v' = v·M`, so `in × axis` where Wikipedia's `v' = M·v` has `axis × in`:
/// MaterialX's GLSL and OSL implementations say so). Found by comparing with MaterialX's
/// OSL implementation (`tests/mtlx_genosl.rs`): the cross product was the other way round.
pub fn rotate3d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let v = input(inp);
    let k = b.normalize(inp.get("axis"));
    let r = radians(b, inp.get("amount"));
    let (s, c) = (b.unary(UnOp::Sin, r), b.unary(UnOp::Cos, r));
    let cs = b.splat(Type::Vec3, c);
    let ss = b.splat(Type::Vec3, s);
    let t1 = b.mul(v, cs);
    let kxv = b.binary(BinOp::Cross, v, k);
    let t2 = b.mul(kxv, ss);
    let kv = b.dot(k, v);
    let one_f = b.float(1.0);
    let omc = b.sub(one_f, c);
    let w = b.mul(kv, omc);
    let ws = b.splat(Type::Vec3, w);
    let t3 = b.mul(k, ws);
    let s12 = b.add(t1, t2);
    one(b.add(s12, t3))
}
/// `bg + (fg − bg)·mix`, exactly `bg` at 0 and `fg` at 1.
pub fn mix(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let (fg, bg) = (get(b, inp, "fg", ty), get(b, inp, "bg", ty));
    let t = inp.get("mix");
    one(b.mix(bg, fg, t))
}
/// `mix·f(fg, bg) + (1 − mix)·bg`, the compositing nodes' blend.
fn composite(
    b: &mut Builder,
    inp: &NodeInputs,
    f: impl FnOnce(&mut Builder, Value, Value, Type) -> Value,
) -> Out {
    let ty = out_ty(inp);
    let (fg, bg) = (get(b, inp, "fg", ty), get(b, inp, "bg", ty));
    let v = f(b, fg, bg, ty);
    let t = inp.get("mix");
    one(b.mix(bg, v, t))
}
/// `fg + bg`, blended by `mix`.
pub fn plus(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite(b, inp, |b, f, g, _| b.add(f, g))
}
/// `bg − fg`, blended by `mix`.
pub fn minus(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite(b, inp, |b, f, g, _| b.sub(g, f))
}
/// `|bg − fg|`, blended by `mix`.
pub fn difference(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite(b, inp, |b, f, g, _| {
        let d = b.sub(g, f);
        b.unary(UnOp::Abs, d)
    })
}
/// `1 − (1 − fg)(1 − bg)`, blended by `mix`.
pub fn screen(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite(b, inp, |b, f, g, ty| {
        let o = konst(b, ty, 1.0);
        let (a, c) = (b.sub(o, f), b.sub(o, g));
        let p = b.mul(a, c);
        b.sub(o, p)
    })
}
/// `1 − (1 − bg)/fg`, blended by `mix`; per component, 0 (not blended) where `|fg| <
/// 1e-8`, as MaterialX's implementations (`mx_burn_float`) define it. Found by comparing
/// with MaterialX's OSL implementation (`tests/mtlx_genosl.rs`): the blend of the total
/// division's 1 there was wrong.
pub fn burn(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let (fg, bg) = (get(b, inp, "fg", ty), get(b, inp, "bg", ty));
    let o = konst(b, ty, 1.0);
    let a = b.sub(o, bg);
    let q = b.div(a, fg);
    let v = b.sub(o, q);
    let t = inp.get("mix");
    let blended = b.mix(bg, v, t);
    let zero_where_small = |b: &mut Builder, f: Value, x: Value| {
        let af = b.unary(UnOp::Abs, f);
        let eps = b.float(1e-8);
        let small = b.binary(crate::ir::BinOp::Lt, af, eps);
        let z = b.float(0.0);
        b.select(small, z, x)
    };
    if ty == Type::Float {
        return one(zero_where_small(b, fg, blended));
    }
    let comps: Vec<Value> = (0..ty.width())
        .map(|k| {
            let (f, x) = (b.extract(fg, k), b.extract(blended, k));
            zero_where_small(b, f, x)
        })
        .collect();
    one(b.construct(ty, &comps))
}
/// `bg / (1 − fg)`, blended by `mix`.
pub fn dodge(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite(b, inp, |b, f, g, ty| {
        let o = konst(b, ty, 1.0);
        let a = b.sub(o, f);
        b.div(g, a)
    })
}
/// `in · mask`.
pub fn inside(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let (x, m) = (get(b, inp, "in", ty), get(b, inp, "mask", ty));
    one(b.mul(x, m))
}
/// `in · (1 − mask)`.
pub fn outside(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let (x, m) = (get(b, inp, "in", ty), get(b, inp, "mask", ty));
    let o = konst(b, ty, 1.0);
    let im = b.sub(o, m);
    one(b.mul(x, im))
}
/// `dot(in, lumacoeffs)` in every channel.
pub fn luminance(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (x, k) = (input(inp), inp.get("lumacoeffs"));
    one(on_rgb(b, x, |b, rgb| {
        let l = b.dot(rgb, k);
        b.splat(Type::Color, l)
    }))
}
/// RGB → HSV (hue in [0, 1)).
pub fn rgbtohsv(b: &mut Builder, inp: &NodeInputs) -> Out {
    let x = input(inp);
    one(on_rgb(b, x, |b, c| b.call(Intrinsic::RgbToHsv, &[c])))
}
/// HSV → RGB.
pub fn hsvtorgb(b: &mut Builder, inp: &NodeInputs) -> Out {
    let x = input(inp);
    one(on_rgb(b, x, |b, c| b.call(Intrinsic::HsvToRgb, &[c])))
}

fn conditional(b: &mut Builder, inp: &NodeInputs, op: BinOp) -> Out {
    let (v1, v2) = (inp.get("value1"), inp.get("value2"));
    let cond = match (b.ty(v1), op) {
        (Type::Bool, BinOp::Eq) => b.binary(BinOp::Eq, v1, v2),
        (Type::Bool, _) => {
            let (x, y) = (b.convert(Type::Int, v1), b.convert(Type::Int, v2));
            b.binary(op, x, y)
        }
        _ => b.binary(op, v1, v2),
    };
    if inp.def.input("in1").is_none() {
        // The boolean variants (1.39) output the comparison itself.
        return one(cond);
    }
    let (a, c) = (inp.get("in1"), inp.get("in2"));
    one(b.select(cond, a, c))
}
/// `value1 > value2 ? in1 : in2`.
pub fn ifgreater(b: &mut Builder, inp: &NodeInputs) -> Out {
    conditional(b, inp, BinOp::Gt)
}
/// `value1 >= value2 ? in1 : in2`.
pub fn ifgreatereq(b: &mut Builder, inp: &NodeInputs) -> Out {
    conditional(b, inp, BinOp::Ge)
}
/// `value1 == value2 ? in1 : in2`.
pub fn ifequal(b: &mut Builder, inp: &NodeInputs) -> Out {
    conditional(b, inp, BinOp::Eq)
}
/// `in1 && in2`.
pub fn and(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (x, y) = (inp.get("in1"), inp.get("in2"));
    one(b.binary(BinOp::And, x, y))
}
/// `in1 || in2`.
pub fn or(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (x, y) = (inp.get("in1"), inp.get("in2"));
    one(b.binary(BinOp::Or, x, y))
}
/// `!in`.
pub fn not(b: &mut Builder, inp: &NodeInputs) -> Out {
    un(b, inp, UnOp::Not)
}
/// A scalar conversion (boolean/integer → float: 0 or 1, the integer's value).
pub fn convert(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let x = input(inp);
    one(b.convert(ty, x))
}
/// A vector from the components of `in1`, `in2` (, `in3`, `in4`) in order: floats, or the
/// components of vector inputs (`combine2` of a color3 and a float makes a color4).
pub fn combine(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let mut parts: Vec<Value> = Vec::new();
    for port in ["in1", "in2", "in3", "in4"] {
        if inp.def.input(port).is_none() {
            continue;
        }
        let v = inp.get(port);
        parts.extend(components(b, v));
    }
    if parts.len() != ty.width() {
        return Err(format!(
            "{} components make no {}",
            parts.len(),
            super::value::mx_name(ty)
        ));
    }
    one(b.construct(ty, &parts))
}

/// The float components of `v` (itself for a float).
fn components(b: &mut Builder, v: Value) -> Vec<Value> {
    let t = b.ty(v);
    if t.is_vector() {
        (0..t.width()).map(|i| b.extract(v, i)).collect()
    } else {
        vec![v]
    }
}

/// The colour of a color4 (its first three components) and its alpha.
fn rgb_alpha(b: &mut Builder, c: Value) -> (Value, Value) {
    let parts = components(b, c);
    let rgb = b.construct(Type::Color, &parts[..3]);
    (rgb, parts[3])
}

/// A color4 from a colour and an alpha.
fn with_alpha(b: &mut Builder, rgb: Value, a: Value) -> Value {
    let mut parts = components(b, rgb);
    parts.push(a);
    b.construct(Type::Color4, &parts)
}

/// `f` of the colour of `x`; a color4's alpha passes through unchanged.
fn on_rgb(b: &mut Builder, x: Value, f: impl FnOnce(&mut Builder, Value) -> Value) -> Value {
    if b.ty(x) != Type::Color4 {
        return f(b, x);
    }
    let (rgb, a) = rgb_alpha(b, x);
    let r = f(b, rgb);
    with_alpha(b, r, a)
}

/// `v · s` with `s` a float broadcast to `v`'s type.
fn scale(b: &mut Builder, v: Value, s: Value) -> Value {
    let ty = b.ty(v);
    let s = b.splat_to(ty, s);
    b.mul(v, s)
}

/// `(in.rgb · in.a, in.a)`.
pub fn premult(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (rgb, a) = rgb_alpha(b, input(inp));
    let r = scale(b, rgb, a);
    one(with_alpha(b, r, a))
}
/// `(in.rgb / in.a, in.a)` (0 where alpha is 0: the IR's total division).
pub fn unpremult(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (rgb, a) = rgb_alpha(b, input(inp));
    let aa = b.splat(Type::Color, a);
    let r = b.div(rgb, aa);
    one(with_alpha(b, r, a))
}

/// `f(fg, bg)·mix + bg·(1 − mix)`, the color4 compositing operators' blend (MaterialX's
/// GLSL writes it in this form, not as `mix`).
fn composite4(
    b: &mut Builder,
    inp: &NodeInputs,
    f: impl FnOnce(&mut Builder, Value, Value) -> Value,
) -> Out {
    let (fg, bg) = (inp.get("fg"), inp.get("bg"));
    let m = inp.get("mix");
    let v = f(b, fg, bg);
    let o = b.float(1.0);
    let om = b.sub(o, m);
    let x = scale(b, v, m);
    let y = scale(b, bg, om);
    one(b.add(x, y))
}
/// `fg + bg·(1 − fg.a)`, blended by `mix`.
pub fn over(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite4(b, inp, |b, fg, bg| {
        let fa = b.extract(fg, 3);
        let o = b.float(1.0);
        let k = b.sub(o, fa);
        let t = scale(b, bg, k);
        b.add(fg, t)
    })
}
/// `fg · bg.a`, blended by `mix`.
pub fn in_(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite4(b, inp, |b, fg, bg| {
        let ba = b.extract(bg, 3);
        scale(b, fg, ba)
    })
}
/// `bg · fg.a`, blended by `mix`.
pub fn mask(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite4(b, inp, |b, fg, bg| {
        let fa = b.extract(fg, 3);
        scale(b, bg, fa)
    })
}
/// `fg · (1 − bg.a)`, blended by `mix`.
pub fn out(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite4(b, inp, |b, fg, bg| {
        let ba = b.extract(bg, 3);
        let o = b.float(1.0);
        let k = b.sub(o, ba);
        scale(b, fg, k)
    })
}
/// `(fg.rgb·fg.a + bg.rgb·(1 − fg.a), fg.a + bg.a·(1 − fg.a))`, blended by `mix`.
pub fn matte(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite4(b, inp, |b, fg, bg| {
        let (frgb, fa) = rgb_alpha(b, fg);
        let (brgb, ba) = rgb_alpha(b, bg);
        let o = b.float(1.0);
        let k = b.sub(o, fa);
        let x = scale(b, frgb, fa);
        let y = scale(b, brgb, k);
        let rgb = b.add(x, y);
        let bk = b.mul(ba, k);
        let a = b.add(fa, bk);
        with_alpha(b, rgb, a)
    })
}
/// Disjoint over: where `fg.a + bg.a ≤ 1`, `fg.rgb + bg.rgb`; else `fg.rgb + bg.rgb·(1 −
/// fg.a)/bg.a` (0 where `|bg.a| < 1e-6`); alpha `min(fg.a + bg.a, 1)`; blended by `mix`
/// (MaterialX's `mx_disjointover_color4`).
pub fn disjointover(b: &mut Builder, inp: &NodeInputs) -> Out {
    composite4(b, inp, |b, fg, bg| {
        let (frgb, fa) = rgb_alpha(b, fg);
        let (brgb, ba) = rgb_alpha(b, bg);
        let o = b.float(1.0);
        let sum = b.add(fa, ba);
        let under = b.binary(BinOp::Le, sum, o);
        let plain = b.add(frgb, brgb);
        let k = b.sub(o, fa);
        let x = b.div(k, ba);
        let sb = scale(b, brgb, x);
        let scaled = b.add(frgb, sb);
        let aba = b.unary(UnOp::Abs, ba);
        let eps = b.float(1e-6);
        let tiny = b.binary(BinOp::Lt, aba, eps);
        let zero = b.zero(Type::Color);
        let over = b.select(tiny, zero, scaled);
        let rgb = b.select(under, plain, over);
        let a = b.binary(BinOp::Min, sum, o);
        with_alpha(b, rgb, a)
    })
}
/// Component `index` of `in` (0 for an index out of range).
pub fn extract(b: &mut Builder, inp: &NodeInputs) -> Out {
    if mx::on_matrix(b, inp, "in") {
        return mx::extract(b, inp);
    }
    let (x, i) = (input(inp), inp.get("index"));
    let w = b.ty(x).width();
    let mut r = b.float(0.0);
    for k in (0..w).rev() {
        let c = b.extract(x, k);
        let ki = b.int(k as i32);
        let is = b.binary(BinOp::Eq, i, ki);
        r = b.select(is, c, r);
    }
    one(r)
}
/// `in` unchanged (a constant's `value`, a dot's `in`).
pub fn constant(_b: &mut Builder, inp: &NodeInputs) -> Out {
    Ok(vec![inp.low("value").clone()])
}
/// `in` unchanged.
pub fn dot(_b: &mut Builder, inp: &NodeInputs) -> Out {
    Ok(vec![inp.low("in").clone()])
}

fn stream_node(b: &mut Builder, inp: &NodeInputs, s: Stream, unit: bool) -> Out {
    let sp = space(inp.string("space"))?;
    let v = b.stream_in(s, sp);
    one(if unit { b.normalize(v) } else { v })
}
/// The shading position in `space`.
pub fn position(b: &mut Builder, inp: &NodeInputs) -> Out {
    stream_node(b, inp, Stream::P, false)
}
/// The shading normal in `space`.
pub fn normal(b: &mut Builder, inp: &NodeInputs) -> Out {
    stream_node(b, inp, Stream::N, true)
}
/// `normalize(dP/du)` in `space`.
pub fn tangent(b: &mut Builder, inp: &NodeInputs) -> Out {
    stream_node(b, inp, Stream::DPdu, true)
}
/// `normalize(dP/dv)` in `space`.
pub fn bitangent(b: &mut Builder, inp: &NodeInputs) -> Out {
    stream_node(b, inp, Stream::DPdv, true)
}
/// The uv stream (a vector3 variant has z = 0).
pub fn texcoord(b: &mut Builder, inp: &NodeInputs) -> Out {
    let uv = b.stream(Stream::Uv);
    if out_ty(inp) == Type::Vec3 {
        let (u, v) = (b.extract(uv, 0), b.extract(uv, 1));
        let z = b.float(0.0);
        return one(b.construct(Type::Vec3, &[u, v, z]));
    }
    one(uv)
}
/// The time stream, in seconds (`fps` does not change it).
pub fn time(b: &mut Builder, _inp: &NodeInputs) -> Out {
    one(b.stream(Stream::Time))
}

fn ramp(b: &mut Builder, inp: &NodeInputs, axis: usize) -> Out {
    let ty = out_ty(inp);
    let (l, r) = (get(b, inp, "valuel", ty), get(b, inp, "valuer", ty));
    let uv = inp.get("texcoord");
    let t = b.extract(uv, axis);
    let (z, o) = (b.float(0.0), b.float(1.0));
    let t = b.clamp(t, z, o);
    one(b.mix(l, r, t))
}
/// `mix(valuel, valuer, clamp(u, 0, 1))`.
pub fn ramplr(b: &mut Builder, inp: &NodeInputs) -> Out {
    ramp(b, inp, 0)
}
/// `mix(valuet, valueb, clamp(v, 0, 1))` (the inputs are named `valuet`, `valueb`).
pub fn ramptb(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let (t_, b_) = (get(b, inp, "valuet", ty), get(b, inp, "valueb", ty));
    let uv = inp.get("texcoord");
    let v = b.extract(uv, 1);
    let (z, o) = (b.float(0.0), b.float(1.0));
    let v = b.clamp(v, z, o);
    one(b.mix(b_, t_, v))
}
fn split(b: &mut Builder, inp: &NodeInputs, axis: usize, lo: &str, hi: &str) -> Out {
    let ty = out_ty(inp);
    let (l, r) = (get(b, inp, lo, ty), get(b, inp, hi, ty));
    let uv = inp.get("texcoord");
    let t = b.extract(uv, axis);
    let c = inp.get("center");
    let past = b.binary(BinOp::Ge, t, c);
    one(b.select(past, r, l))
}
/// `u >= center ? valuer : valuel` (a hard edge; MaterialX's `aastep` antialiases it).
pub fn splitlr(b: &mut Builder, inp: &NodeInputs) -> Out {
    split(b, inp, 0, "valuel", "valuer")
}
/// `v >= center ? valuet : valueb`.
pub fn splittb(b: &mut Builder, inp: &NodeInputs) -> Out {
    split(b, inp, 1, "valueb", "valuet")
}

/// `v` (a float, vec2 or vec3 noise value) as the output type `ty`: a vec3's first two
/// components for vector2 (MaterialX `value.xy`), its components as a color for color3.
fn noise_as(b: &mut Builder, v: Value, ty: Type) -> Result<Value, String> {
    let from = b.ty(v);
    if from == ty {
        return Ok(v);
    }
    let n = ty.width();
    if !matches!(ty, Type::Vec2 | Type::Vec3 | Type::Color) || from.width() < n {
        return Err(format!("noise of type {ty} is not lowered"));
    }
    let parts: Vec<Value> = (0..n).map(|i| b.extract(v, i)).collect();
    Ok(b.construct(ty, &parts))
}

/// `p + offset` (a 2- or 3-component point and offset).
fn offset_point(b: &mut Builder, p: Value, offset: &[f64]) -> Value {
    let off = match offset {
        [x, y] => b.constant(ConstValue::Vec2([*x, *y])),
        _ => b.vec3([offset[0], offset[1], offset[2]]),
    };
    b.add(p, off)
}

/// A four-component value of type `ty` from a 3-vector `v` and a fourth float `w`.
fn four(b: &mut Builder, v: Value, w: Value, ty: Type) -> Value {
    let mut parts: Vec<Value> = (0..3).map(|i| b.extract(v, i)).collect();
    parts.push(w);
    b.construct(ty, &parts)
}

/// MaterialX `value · amplitude + pivot` of a Perlin noise: OSL `snoise` (float for a float
/// output, OSL's vector noise otherwise) of `p`, with `scalar`/`vector` the intrinsics of
/// `p`'s dimension.
fn noise_node(
    b: &mut Builder,
    inp: &NodeInputs,
    p: Value,
    (scalar, vector): (Intrinsic, Intrinsic),
    offset4: &[f64],
) -> Out {
    let ty = out_ty(inp);
    let n = if ty == Type::Float {
        b.call(scalar, &[p])
    } else if ty.width() == 4 {
        // MaterialX `mx_noise*_vector4`: the vector noise, and the float noise at
        // `p + (19, 73[, 29])` as the fourth component.
        let v = b.call(vector, &[p]);
        let q = offset_point(b, p, offset4);
        let w = b.call(scalar, &[q]);
        four(b, v, w, ty)
    } else {
        let v = b.call(vector, &[p]);
        noise_as(b, v, ty)?
    };
    // Filtered as the image node is: always, over the footprint (MaterialX has no filter
    // input).
    let on = b.float(1.0);
    let n = filtered_noise::noise(b, n, p, on);
    let amp = get(b, inp, "amplitude", ty);
    let amp = noise_as(b, amp, ty)?;
    let pivot = get(b, inp, "pivot", ty);
    let s = b.mul(n, amp);
    one(b.add(s, pivot))
}
/// `snoise(texcoord) · amplitude + pivot`: OSL's signed 2D Perlin noise
/// ([`crate::ops::osl_noise::perlin2`]; vector outputs from its vector noise), faded to
/// `pivot` over a coarse footprint ([`filtered_noise::noise`]).
pub fn noise2d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let p = inp.get("texcoord");
    noise_node(
        b,
        inp,
        p,
        (Intrinsic::OslPerlin2, Intrinsic::OslVPerlin2),
        &[19.0, 73.0],
    )
}
/// `snoise(position) · amplitude + pivot`: OSL's signed 3D Perlin noise, filtered as [`noise2d`].
pub fn noise3d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let p = inp.get("position");
    noise_node(
        b,
        inp,
        p,
        (Intrinsic::OslPerlin3, Intrinsic::OslVPerlin3),
        &[19.0, 73.0, 29.0],
    )
}
/// MaterialX `mx_fractal*_noise_*` of `p` times `amplitude`, the octaves finer than the
/// footprint dropped ([`filtered_noise::fractal`]): float and vector3 outputs from
/// the float and vector fractal noise, vector2 from the float fractal noise at `p` and at
/// `p + offset` (MaterialX's (19, 193[, 17])).
fn fractal(
    b: &mut Builder,
    inp: &NodeInputs,
    p: Value,
    (scalar, vector): (Intrinsic, Intrinsic),
    offset: &[f64],
) -> Out {
    let ty = out_ty(inp);
    let (oct, lac, dim) = (
        inp.get("octaves"),
        inp.get("lacunarity"),
        inp.get("diminish"),
    );
    // Filtered as the image node is: always, over the footprint of `p` (MaterialX has no
    // filter input); the offset points share it.
    let on = b.float(1.0);
    let width = filtered_noise::point_width(b, p, on);
    let args = [oct, lac, dim];
    let sum =
        |b: &mut Builder, f: Fractal, q: Value| filtered_noise::fractal(b, f, q, args, width, on);
    let (scalar, vector) = (mx_fractal(scalar), mx_fractal(vector));
    let n = match ty {
        Type::Float => sum(b, scalar, p),
        Type::Vec2 => {
            let q = offset_point(b, p, offset);
            let f0 = sum(b, scalar, p);
            let f1 = sum(b, scalar, q);
            b.construct(Type::Vec2, &[f0, f1])
        }
        // `mx_fractal*_noise_vec4`: the vector fractal and the float one at `p + offset`.
        ty if ty.width() == 4 => {
            let v = sum(b, vector, p);
            let q = offset_point(b, p, offset);
            let w = sum(b, scalar, q);
            four(b, v, w, ty)
        }
        _ => {
            let v = sum(b, vector, p);
            noise_as(b, v, ty)?
        }
    };
    let amp = get(b, inp, "amplitude", ty);
    let amp = noise_as(b, amp, ty)?;
    one(b.mul(n, amp))
}
/// A MaterialX fractal sum intrinsic with the OSL noise of its octaves.
fn mx_fractal(sum: Intrinsic) -> Fractal {
    let octave = match sum {
        Intrinsic::MxFractal2 => Intrinsic::OslPerlin2,
        Intrinsic::MxFractal3 => Intrinsic::OslPerlin3,
        Intrinsic::MxVFractal2 => Intrinsic::OslVPerlin2,
        _ => Intrinsic::OslVPerlin3,
    };
    Fractal {
        sum,
        octave,
        max_octaves: crate::ops::osl_noise::MAX_OCTAVES,
    }
}
/// `Σ_{i<octaves} diminishⁱ · snoise(texcoord · lacunarityⁱ) · amplitude` (MaterialX
/// `mx_fractal2d_noise_*`).
pub fn fractal2d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let p = inp.get("texcoord");
    let i = (Intrinsic::MxFractal2, Intrinsic::MxVFractal2);
    fractal(b, inp, p, i, &[19.0, 193.0])
}
/// `Σ_{i<octaves} diminishⁱ · snoise(position · lacunarityⁱ) · amplitude` (MaterialX
/// `mx_fractal3d_noise_*`).
pub fn fractal3d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let p = inp.get("position");
    let i = (Intrinsic::MxFractal3, Intrinsic::MxVFractal3);
    fractal(b, inp, p, i, &[19.0, 193.0, 17.0])
}
/// OSL `cellnoise(texcoord)`: a value in [0, 1] constant over each unit cell.
pub fn cellnoise2d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let p = inp.get("texcoord");
    one(b.call(Intrinsic::OslCell2, &[p]))
}
/// OSL `cellnoise(position)`.
pub fn cellnoise3d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let p = inp.get("position");
    one(b.call(Intrinsic::OslCell3, &[p]))
}
/// MaterialX `mx_worley_noise_*(p, jitter, style, 0)`: Euclidean F1 (float), (F1, F2)
/// (vector2) or (F1, F2, F3) (vector3); style 1 the cell noise of the nearest feature point.
fn worley(b: &mut Builder, inp: &NodeInputs, p: Value, by_width: [Intrinsic; 3]) -> Out {
    let ty = out_ty(inp);
    let i = match ty {
        Type::Float => by_width[0],
        Type::Vec2 => by_width[1],
        Type::Vec3 => by_width[2],
        other => return Err(format!("Worley noise of type {other} is not lowered")),
    };
    let (jitter, style) = (inp.get("jitter"), inp.get("style"));
    let metric = b.int(0);
    one(b.call(i, &[p, jitter, style, metric]))
}
/// 2D Worley noise of `texcoord` (MaterialX `worleynoise2d`).
pub fn worleynoise2d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let p = inp.get("texcoord");
    let i = [
        Intrinsic::MxWorley2,
        Intrinsic::MxWorley2V2,
        Intrinsic::MxWorley2V3,
    ];
    worley(b, inp, p, i)
}
/// 3D Worley noise of `position` (MaterialX `worleynoise3d`).
pub fn worleynoise3d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let p = inp.get("position");
    let i = [
        Intrinsic::MxWorley3,
        Intrinsic::MxWorley3V2,
        Intrinsic::MxWorley3V3,
    ];
    worley(b, inp, p, i)
}
/// A filtered texture lookup of `file` at `texcoord`, the file decoded from its
/// `colorspace` (none: the working space, linear Rec.709), filtered by `filtertype`
/// (`closest`; `linear` and `cubic` are the texture system's anisotropic filter) and
/// wrapped by `uaddressmode`/`vaddressmode` (`constant` reads `default` outside [0, 1]);
/// `default` where no file is named. Float and vector outputs take the color's first
/// channels.
pub fn image(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let Some(t) = texture_file(b, inp)? else {
        return Ok(vec![inp.low("default").clone()]);
    };
    let filter = match inp.string("filtertype") {
        "closest" => Filter::Closest,
        "linear" | "cubic" | "" => Filter::Anisotropic,
        other => {
            return Err(format!(
                "input `filtertype`: `{other}` is not closest, linear or cubic"
            ));
        }
    };
    let mut constant = [false; 2];
    let mut wrap = [Wrap::Periodic; 2];
    for (k, port) in ["uaddressmode", "vaddressmode"].into_iter().enumerate() {
        wrap[k] = match inp.string(port) {
            "periodic" | "" => Wrap::Periodic,
            "clamp" => Wrap::Clamp,
            "mirror" => Wrap::Mirror,
            "constant" => {
                constant[k] = true;
                Wrap::Black
            }
            other => {
                return Err(format!(
                    "input `{port}`: `{other}` is not constant, clamp, periodic or mirror"
                ));
            }
        };
    }
    let sampling = Sampling { filter, wrap };
    let uv = inp.get("texcoord");
    let looked = image_lookup(b, t, uv, sampling, ty)?;
    if !constant.contains(&true) {
        return one(looked);
    }
    // `constant`: the default outside [0, 1] along the axes that say so.
    let default = get(b, inp, "default", ty);
    let mut outside = None;
    for (k, _) in constant.iter().enumerate().filter(|(_, c)| **c) {
        let x = b.extract(uv, k);
        let (zero, one_) = (b.float(0.0), b.float(1.0));
        let lo = b.binary(BinOp::Lt, x, zero);
        let hi = b.binary(BinOp::Gt, x, one_);
        let o = b.binary(BinOp::Or, lo, hi);
        outside = Some(match outside {
            Some(p) => b.binary(BinOp::Or, p, o),
            None => o,
        });
    }
    let outside = outside.expect("an axis is constant");
    one(b.select(outside, default, looked))
}

/// The texture table index of a node's `file` input with its `colorspace` (own or
/// inherited; none = the working space); `None` for an empty filename.
pub(super) fn texture_file(b: &mut Builder, inp: &NodeInputs) -> Result<Option<u32>, String> {
    let file = inp.string("file").to_string();
    if file.is_empty() {
        return Ok(None);
    }
    let cs = inp.string(&super::value::colorspace_port("file"));
    let colorspace = match cs {
        "" => ColorSpace::LinRec709,
        name => ColorSpace::parse(name).ok_or_else(|| {
            let known: Vec<&str> = ColorSpace::ALL.iter().map(|c| c.name()).collect();
            format!(
                "input `file`: unknown colorspace `{name}`; known: {}",
                known.join(", ")
            )
        })?,
    };
    Ok(Some(b.texture_index(&TextureFile {
        path: file,
        colorspace,
    })))
}

/// The lookup of [`image`] for an output of type `ty`.
pub(super) fn image_lookup(
    b: &mut Builder,
    t: u32,
    uv: Value,
    sampling: Sampling,
    ty: Type,
) -> Result<Value, String> {
    let c = b.texture(t, uv, sampling, false);
    Ok(match ty {
        Type::Color => c,
        Type::Color4 | Type::Vec4 => {
            let a = b.texture(t, uv, sampling, true);
            let mut parts = components(b, c);
            parts.push(a);
            b.construct(ty, &parts)
        }
        Type::Float => b.extract(c, 0),
        Type::Vec3 => {
            let parts: Vec<Value> = (0..3).map(|i| b.extract(c, i)).collect();
            b.construct(Type::Vec3, &parts)
        }
        Type::Vec2 => {
            let parts: Vec<Value> = (0..2).map(|i| b.extract(c, i)).collect();
            b.construct(Type::Vec2, &parts)
        }
        other => return Err(format!("image of type {other} is not lowered")),
    })
}

/// `outlow + (in − inlow)·(outhigh − outlow) / (inhigh − inlow)`, in that order (MaterialX's
/// GLSL); the division is the IR's total one (0 where `inhigh = inlow`).
pub fn remap(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let x = get(b, inp, "in", ty);
    let (il, ih) = (get(b, inp, "inlow", ty), get(b, inp, "inhigh", ty));
    let (ol, oh) = (get(b, inp, "outlow", ty), get(b, inp, "outhigh", ty));
    let d = b.sub(x, il);
    let r = b.sub(oh, ol);
    let n = b.mul(d, r);
    let w = b.sub(ih, il);
    let q = b.div(n, w);
    one(b.add(ol, q))
}
/// 1 where `in ≥ high`, 0 where `in ≤ low`, else `t²(3 − 2t)` with `t = (in − low)/(high −
/// low)` (MaterialX's `mx_smoothstep_float`), per component.
pub fn smoothstep(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = out_ty(inp);
    let (x, lo, hi) = (
        get(b, inp, "in", ty),
        get(b, inp, "low", ty),
        get(b, inp, "high", ty),
    );
    let parts: Vec<(Value, Value, Value)> = if ty.is_vector() {
        (0..ty.width())
            .map(|i| (b.extract(x, i), b.extract(lo, i), b.extract(hi, i)))
            .collect()
    } else {
        vec![(x, lo, hi)]
    };
    let out: Vec<Value> = parts
        .into_iter()
        .map(|(x, lo, hi)| {
            let (z, o) = (b.float(0.0), b.float(1.0));
            let d = b.sub(x, lo);
            let w = b.sub(hi, lo);
            let t = b.div(d, w);
            let two = b.float(2.0);
            let three = b.float(3.0);
            let tt = b.mul(t, t);
            let t2 = b.mul(two, t);
            let k = b.sub(three, t2);
            let s = b.mul(tt, k);
            let below = b.binary(BinOp::Le, x, lo);
            let s = b.select(below, z, s);
            let above = b.binary(BinOp::Ge, x, hi);
            b.select(above, o, s)
        })
        .collect();
    if ty.is_vector() {
        one(b.construct(ty, &out))
    } else {
        one(out[0])
    }
}
