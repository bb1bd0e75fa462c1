//! The MaterialX atoms that need screen-space derivatives or a tangent frame:
//! `heighttonormal` (and through it the library's `bump` graph) and the hex-tiling lookups
//! `hextiledimage` and `hextilednormalmap` (Mikkelsen, "Practical Real-Time Hex-Tiling",
//! JCGT 11(2), 2022), each the formula of MaterialX 1.39's own implementation written with
//! existing IR ops.
//!
//! Derivatives come from [`Builder::derivs`] (a texture's by a difference over the
//! footprint), so a `heighttonormal` of an image or a procedural reads the same footprint
//! a filtered lookup would. This module owns these formulas; it must not decide which
//! nodedef uses them (the table in [`super::atoms`] does).

use super::atoms_lower::{image_lookup, radians, texture_file};
use crate::closure::math::{scale as scale3, vec3};
use crate::ir::{BinOp, Builder, Filter, Sampling, UnOp, Value, Wrap};
use crate::nodes::{LowVal, NodeInputs};
use crate::types::Type;

type Out = Result<Vec<LowVal>, String>;

/// MaterialX's `M_FLOAT_EPS`.
const FLOAT_EPS: f64 = 1e-8;

fn one(v: Value) -> Out {
    Ok(vec![LowVal::plain(v)])
}

/// `heighttonormal` (`mx_heighttonormal_vector3`): the tangent-space normal of the height
/// field `in`, encoded in [0, 1]. The screen-space tangent frame is `(∂u/∂x, ∂v/∂x,
/// ∂h/∂x·s)` × `(∂u/∂y, ∂v/∂y, ∂h/∂y·s)` with `s = scale/16` (Sobel parity), flipped to
/// +z for mirrored coordinates, `(0, 0, 1)` where degenerate; that is the normal
/// `(−∂h/∂u·s, −∂h/∂v·s, 1)` whatever the footprint's size. Without derivatives (no ray
/// differentials, a constant height or constant coordinates) the flat `(0.5, 0.5, 1)`.
pub fn heighttonormal(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (h, tc) = (inp.get("in"), inp.get("texcoord"));
    let (Some(dh), Some(dtc)) = (b.derivs(h), b.derivs(tc)) else {
        return one(b.vec3([0.5, 0.5, 1.0]));
    };
    let sobel = b.float(1.0 / 16.0);
    let s = inp.get("scale");
    let k = b.mul(s, sobel);
    let axis = |b: &mut Builder, i: usize| {
        let u = b.extract(dtc[i], 0);
        let v = b.extract(dtc[i], 1);
        let hh = b.mul(dh[i], k);
        vec3(b, u, v, hh)
    };
    let t = axis(b, 0);
    let bt = axis(b, 1);
    let n = b.binary(BinOp::Cross, t, bt);
    let len2 = b.dot(n, n);
    let eps2 = b.float(FLOAT_EPS * FLOAT_EPS);
    let degenerate = b.binary(BinOp::Lt, len2, eps2);
    let nz = b.extract(n, 2);
    let zero = b.float(0.0);
    let mirrored = b.binary(BinOp::Lt, nz, zero);
    let flipped = b.unary(UnOp::Neg, n);
    let n = b.select(mirrored, flipped, n);
    let up = b.vec3([0.0, 0.0, 1.0]);
    let n = b.select(degenerate, up, n);
    let n = b.normalize(n);
    let half = b.vec3([0.5, 0.5, 0.5]);
    let n = b.mul(n, half);
    one(b.add(n, half))
}

/// The three tiles around a point: their lookup coordinates, blend weights (barycentric
/// in the hex grid) and rotations (radians) — `mx_hextile_coord`.
struct Tiles {
    coords: [Value; 3],
    weights: [Value; 3],
    rotations: [Value; 3],
}

/// `mx_hextile_hash` (Dave Hoskins' hash without sine): a vec2 → two numbers in [0, 1).
fn hash(b: &mut Builder, x: Value, y: Value) -> [Value; 2] {
    let p = vec3(b, x, y, x);
    let k = b.vec3([0.1031, 0.1030, 0.0973]);
    let p = b.mul(p, k);
    let p = b.unary(UnOp::Fract, p);
    let [p0, p1, p2] = [0, 1, 2].map(|i| b.extract(p, i));
    let rot = vec3(b, p1, p2, p0);
    let c = b.vec3([33.33, 33.33, 33.33]);
    let rot = b.add(rot, c);
    let d = b.dot(p, rot);
    let d = b.splat(Type::Vec3, d);
    let p = b.add(p, d);
    let [p0, p1, p2] = [0, 1, 2].map(|i| b.extract(p, i));
    let (a0, a1) = (b.add(p0, p1), b.add(p0, p2));
    let (r0, r1) = (b.mul(a0, p2), b.mul(a1, p1));
    [r0, r1].map(|r| b.unary(UnOp::Fract, r))
}

/// The ranges and amounts of the randomization, each `(amount, range.x, range.y)`.
struct Jitter {
    rotation: [Value; 3],
    scale: [Value; 3],
    offset: [Value; 3],
}

fn jitter(b: &mut Builder, inp: &NodeInputs) -> Jitter {
    let mut read = |amount: &str, range: &str| {
        let r = inp.get(range);
        [inp.get(amount), b.extract(r, 0), b.extract(r, 1)]
    };
    let rotation = read("rotation", "rotationrange");
    let scale = read("scale", "scalerange");
    let offset = read("offset", "offsetrange");
    Jitter {
        rotation,
        scale,
        offset,
    }
}

/// `mx_hextile_coord`: the hex grid's three tiles around `coord`.
fn tiles(b: &mut Builder, coord: Value, j: &Jitter) -> Tiles {
    let sqrt3_2 = 3f64.sqrt() * 2.0;
    let k = b.float(sqrt3_2);
    let (cx, cy) = (b.extract(coord, 0), b.extract(coord, 1));
    let (sx, sy) = (b.mul(cx, k), b.mul(cy, k));
    // Skewed into the simplex grid: (x − y·tan 30°, 2·y·tan 30°).
    let (m, t2) = (b.float(-0.57735027), b.float(1.15470054));
    let my = b.mul(sy, m);
    let kx = b.add(sx, my);
    let ky = b.mul(sy, t2);
    let (fx, fy) = (b.unary(UnOp::Fract, kx), b.unary(UnOp::Fract, ky));
    let one_ = b.float(1.0);
    let fz = b.sub(one_, fx);
    let fz = b.sub(fz, fy);
    // s = step(0, −z): 1 in the upper triangle of the cell.
    let zero = b.float(0.0);
    let upper = b.binary(BinOp::Le, fz, zero);
    let s = b.select(upper, one_, zero);
    let two = b.float(2.0);
    let s2 = b.mul(s, two);
    let s2 = b.sub(s2, one_);
    let nz = b.unary(UnOp::Neg, fz);
    let w1 = b.mul(nz, s2);
    let fy_s2 = b.mul(fy, s2);
    let w2 = b.sub(s, fy_s2);
    let fx_s2 = b.mul(fx, s2);
    let w3 = b.sub(s, fx_s2);
    // Vertex ids (integers held in floats).
    let (bx, by) = (b.unary(UnOp::Floor, kx), b.unary(UnOp::Floor, ky));
    let (bxs, bys) = (b.add(bx, s), b.add(by, s));
    let ns = b.sub(one_, s);
    let (bxn, byn) = (b.add(bx, ns), b.add(by, ns));
    let ids = [(bxs, bys), (bxs, byn), (bxn, bys)];
    let seed = b.float(0.12345);
    let (r_lo, r_hi) = (radians(b, j.rotation[1]), radians(b, j.rotation[2]));
    let half = b.float(0.5);
    let mut coords = [zero; 3];
    let mut rotations = [zero; 3];
    for (i, (ix, iy)) in ids.into_iter().enumerate() {
        // The tile's centre.
        let hy = b.mul(iy, half);
        let ctrx = b.add(ix, hy);
        let ctrx = b.div(ctrx, k);
        let ctry = b.div(iy, t2);
        let ctry = b.div(ctry, k);
        let (hx_, hy_) = (b.add(ix, seed), b.add(iy, seed));
        let [rx, ry] = hash(b, hx_, hy_);
        let rxa = b.mul(rx, j.rotation[0]);
        let rot = b.mix(r_lo, r_hi, rxa);
        let sc = b.mix(j.scale[1], j.scale[2], ry);
        let sc = b.mix(one_, sc, j.scale[0]);
        let (ox, oy) = (b.mul(rx, j.offset[0]), b.mul(ry, j.offset[0]));
        let ox = b.mix(j.offset[1], j.offset[2], ox);
        let oy = b.mix(j.offset[1], j.offset[2], oy);
        // Rotated and scaled about the centre, then offset.
        let (dx, dy) = (b.sub(cx, ctrx), b.sub(cy, ctry));
        let (c, sn) = (b.unary(UnOp::Cos, rot), b.unary(UnOp::Sin, rot));
        let (dxc, dys) = (b.mul(dx, c), b.mul(dy, sn));
        let (dxs, dyc) = (b.mul(dx, sn), b.mul(dy, c));
        let u = b.sub(dxc, dys);
        let v = b.add(dxs, dyc);
        let u = b.div(u, sc);
        let v = b.div(v, sc);
        let u = b.add(u, ctrx);
        let u = b.add(u, ox);
        let v = b.add(v, ctry);
        let v = b.add(v, oy);
        coords[i] = b.construct(Type::Vec2, &[u, v]);
        rotations[i] = rot;
    }
    Tiles {
        coords,
        weights: [w1, w2, w3],
        rotations,
    }
}

/// Schlick's gain (`mx_schlick_gain`), `r` clamped to [0.001, 0.999].
fn gain(b: &mut Builder, x: Value, r: Value) -> Value {
    let (lo, hi) = (b.float(0.001), b.float(0.999));
    let rr = b.clamp(r, lo, hi);
    let (one_, two, half) = (b.float(1.0), b.float(2.0), b.float(0.5));
    let inv = b.div(one_, rr);
    let a = b.sub(inv, two);
    let x2 = b.mul(x, two);
    let t = b.sub(one_, x2);
    let a = b.mul(a, t);
    let ap1 = b.add(a, one_);
    let low = b.div(x, ap1);
    let amx = b.sub(a, x);
    let am1 = b.sub(a, one_);
    let high = b.div(amx, am1);
    let below = b.binary(BinOp::Lt, x, half);
    b.select(below, low, high)
}

/// `mx_hextile_compute_blend_weights`: `lum·w⁷` normalized, then through Schlick's gain
/// and normalized again where `falloff ≠ 0.5`. `w⁷` is `w⁴·w²·w` (three products where a
/// `pow` per weight cost more than the rest of the blend).
fn blend_weights(b: &mut Builder, lum: [Value; 3], w: [Value; 3], falloff: Value) -> [Value; 3] {
    let raw: [Value; 3] = [0, 1, 2].map(|i| {
        let w2 = b.mul(w[i], w[i]);
        let w4 = b.mul(w2, w2);
        let w6 = b.mul(w4, w2);
        let w7 = b.mul(w6, w[i]);
        b.mul(lum[i], w7)
    });
    let w = normalized(b, raw);
    let gained = [0, 1, 2].map(|i| gain(b, w[i], falloff));
    let gained = normalized(b, gained);
    let half = b.float(0.5);
    let plain = b.binary(BinOp::Eq, falloff, half);
    [0, 1, 2].map(|i| b.select(plain, w[i], gained[i]))
}

fn normalized(b: &mut Builder, w: [Value; 3]) -> [Value; 3] {
    let s = b.add(w[0], w[1]);
    let s = b.add(s, w[2]);
    w.map(|x| b.div(x, s))
}

/// The hex-tiled lookups of a node: the file's tiles, looked up periodic and filtered.
fn tile_lookups(
    b: &mut Builder,
    inp: &NodeInputs,
    t: u32,
    ty: Type,
) -> Result<(Tiles, [Value; 3]), String> {
    let tc = inp.get("texcoord");
    let tiling = inp.get("tiling");
    let coord = b.mul(tc, tiling);
    let j = jitter(b, inp);
    let tiles = tiles(b, coord, &j);
    let sampling = Sampling {
        filter: Filter::Anisotropic,
        wrap: [Wrap::Periodic; 2],
    };
    let mut looked = [coord; 3];
    for (i, c) in tiles.coords.iter().enumerate() {
        looked[i] = image_lookup(b, t, *c, sampling, ty)?;
    }
    Ok((tiles, looked))
}

/// `hextiledimage` (color3 and color4): three randomly rotated, scaled and offset copies of
/// the image blended by hex-grid weights sharpened by luminance (`falloffcontrast`,
/// `lumacoeffs`) and `falloff`; alpha is blended by the grid weights alone. `default` where
/// no file is named.
pub fn hextiledimage(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = inp.def.outputs[0].ty.unwrap_or(Type::Color);
    let Some(t) = texture_file(b, inp)? else {
        return Ok(vec![inp.low("default").clone()]);
    };
    let (tiles, c) = tile_lookups(b, inp, t, ty)?;
    let rgb: [Value; 3] = c.map(|c| {
        if ty == Type::Color {
            c
        } else {
            let p = [0, 1, 2].map(|k| b.extract(c, k));
            b.construct(Type::Color, &p)
        }
    });
    let coeffs = inp.get("lumacoeffs");
    let contrast = inp.get("falloffcontrast");
    let one_ = b.float(1.0);
    let lum = rgb.map(|c| {
        let l = b.dot(c, coeffs);
        b.mix(one_, l, contrast)
    });
    let falloff = inp.get("falloff");
    let w = blend_weights(b, lum, tiles.weights, falloff);
    let mut sum = b.zero(Type::Color);
    for (c, w) in rgb.iter().zip(w) {
        let ws = b.splat(Type::Color, w);
        let term = b.mul(*c, ws);
        sum = b.add(sum, term);
    }
    if ty == Type::Color {
        return one(sum);
    }
    let aw = blend_weights(b, [one_; 3], tiles.weights, falloff);
    let mut alpha = b.float(0.0);
    for (c, w) in c.iter().zip(aw) {
        let a = b.extract(*c, 3);
        let term = b.mul(a, w);
        alpha = b.add(alpha, term);
    }
    let p: Vec<Value> = (0..3).map(|k| b.extract(sum, k)).chain([alpha]).collect();
    one(b.construct(ty, &p))
}

/// `v` rotated by `angle` radians about the unit `axis` (right-handed, Rodrigues):
/// `v·cos + (axis × v)·sin + axis·(axis·v)·(1 − cos)` — what MaterialX's
/// `transform(mx_axis_rotation_matrix(N, −angle), v)` computes with OSL's row vectors.
fn rotate_about(b: &mut Builder, v: Value, axis: Value, angle: Value) -> Value {
    let (c, s) = (b.unary(UnOp::Cos, angle), b.unary(UnOp::Sin, angle));
    let vc = scale3(b, v, c);
    let axv = b.binary(BinOp::Cross, axis, v);
    let axv = scale3(b, axv, s);
    let one_ = b.float(1.0);
    let omc = b.sub(one_, c);
    let d = b.dot(axis, v);
    let d = b.mul(d, omc);
    let along = scale3(b, axis, d);
    let r = b.add(vc, axv);
    b.add(r, along)
}

/// `v` minus its parts along the unit vectors `along`, normalized (Gram–Schmidt).
fn orthonormal(b: &mut Builder, v: Value, along: &[Value]) -> Value {
    let mut r = v;
    for a in along {
        let d = b.dot(v, *a);
        let p = scale3(b, *a, d);
        r = b.sub(r, p);
    }
    b.normalize(r)
}

/// `mx_normals_to_gradient`: the surface gradient of `np` relative to `n`.
fn gradient(b: &mut Builder, n: Value, np: Value) -> Value {
    let d = b.dot(n, np);
    let dn = scale3(b, n, d);
    let g = b.sub(dn, np);
    let ad = b.unary(UnOp::Abs, d);
    let eps = b.float(1e-8);
    let m = b.max(eps, ad);
    let inv = b.float(1.0);
    let inv = b.div(inv, m);
    scale3(b, g, inv)
}

/// `hextilednormalmap`: three hex tiles of a tangent-space normal map (`flip_g` flips the
/// green channel), each decoded in the tangent frame rotated about `normal` by the tile's
/// rotation (scaled by `strength`, made orthonormal), blended as surface gradients
/// (Mikkelsen 2020) with the grid weights and `falloff`. `normal` where no file is named.
pub fn hextilednormalmap(b: &mut Builder, inp: &NodeInputs) -> Out {
    let n = inp.get("normal");
    let Some(t) = texture_file(b, inp)? else {
        return one(n);
    };
    let (tiles, c) = tile_lookups(b, inp, t, Type::Vec3)?;
    let (tg, bt) = (inp.get("tangent"), inp.get("bitangent"));
    let strength = inp.get("strength");
    let flip = inp.get("flip_g");
    let (one_, two) = (b.float(1.0), b.float(2.0));
    let mut normals = [n; 3];
    for i in 0..3 {
        let [x, y, z] = [0, 1, 2].map(|k| b.extract(c[i], k));
        let fy = b.sub(one_, y);
        let y = b.select(flip, fy, y);
        let [x, y, z] = [x, y, z].map(|v| {
            let v = b.mul(v, two);
            b.sub(v, one_)
        });
        let ti = rotate_about(b, tg, n, tiles.rotations[i]);
        let ti = scale3(b, ti, strength);
        let bi = rotate_about(b, bt, n, tiles.rotations[i]);
        let bi = scale3(b, bi, strength);
        let tn = orthonormal(b, ti, &[n]);
        let bn = orthonormal(b, bi, &[n, tn]);
        let (tx, by, nz) = (scale3(b, tn, x), scale3(b, bn, y), scale3(b, n, z));
        let s = b.add(tx, by);
        let s = b.add(s, nz);
        normals[i] = b.normalize(s);
    }
    let falloff = inp.get("falloff");
    let w = blend_weights(b, [one_; 3], tiles.weights, falloff);
    let zero = b.float(0.0);
    let mut gg = b.zero(Type::Vec3);
    for (ni, wi) in normals.iter().zip(w) {
        let wi = b.clamp(wi, zero, one_);
        let g = gradient(b, n, *ni);
        let g = scale3(b, g, wi);
        gg = b.add(gg, g);
    }
    let r = b.sub(n, gg);
    one(b.normalize(r))
}
