//! MaterialX's `flake2d` and `flake3d` (1.39): glitter flakes on a 3D lattice, written with
//! the operations of MaterialX's own `mx_flake` (stdlib `genosl/lib/mx_flake.osl`, the
//! reference the genosl cross-check compares with) in its order, so that the f32 back ends
//! give its bits. Of the 3 × 3 × 3 cells around the point, the flake whose rotated cube
//! holds the point and whose priority (OSL `cellnoise(cell, 3)`) is highest wins; its
//! normal samples a GGX lobe of `roughness` with OSL's 4D vector cell noise. The 27 cells
//! are unrolled into selects.
//!
//! This module owns the flake formula; the atom table ([`super::atoms`]) maps the nodes
//! onto it.

use crate::closure::math::scale;
use crate::ir::{BinOp, Builder, Intrinsic, UnOp, Value};
use crate::nodes::{LowVal, NodeInputs};
use crate::types::Type;

type Out = Result<Vec<LowVal>, String>;

/// `flake2d`: the 3D flake at `(texcoord.x, texcoord.y, 0)`.
pub fn flake2d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let uv = inp.get("texcoord");
    let (x, y) = (b.extract(uv, 0), b.extract(uv, 1));
    let zero = b.float(0.0);
    let p = b.construct(Type::Vec3, &[x, y, zero]);
    flake(b, inp, p)
}

/// `flake3d` at `position`.
pub fn flake3d(b: &mut Builder, inp: &NodeInputs) -> Out {
    let p = inp.get("position");
    flake(b, inp, p)
}

/// `mx_flake_density_to_probability`: the fitted rational curve of coverage `x`.
fn probability(b: &mut Builder, x: Value) -> Value {
    let k = [
        -26.19771808,
        26.39663835,
        85.53857017,
        -102.35069432,
        -101.42634862,
        118.45082288,
    ]
    .map(|c| b.float(c));
    let xx = b.mul(x, x);
    // (a·xx + b·x) / (c·xx·x + d·xx + e·x + f)
    let (t0, t1) = (b.mul(k[0], xx), b.mul(k[1], x));
    let num = b.add(t0, t1);
    let c = b.mul(k[2], xx);
    let c = b.mul(c, x);
    let d = b.mul(k[3], xx);
    let e = b.mul(k[4], x);
    let den = b.add(c, d);
    let den = b.add(den, e);
    let den = b.add(den, k[5]);
    b.div(num, den)
}

/// `2π · x` as the source writes it (`M_PI * 2.0 * x`).
fn two_pi(b: &mut Builder, x: Value) -> Value {
    let pi = b.float(std::f64::consts::PI);
    let two = b.float(2.0);
    let t = b.mul(pi, two);
    b.mul(t, x)
}

/// `mx_rotate_flake(p, i)`: Arvo's random rotation of `p` by the three numbers of `i`.
fn rotate(b: &mut Builder, p: Value, i: Value) -> Value {
    let [i0, i1, i2] = [0, 1, 2].map(|k| b.extract(i, k));
    let [p0, p1, p2] = [0, 1, 2].map(|k| b.extract(p, k));
    let theta = two_pi(b, i0);
    let phi = two_pi(b, i1);
    let two = b.float(2.0);
    let z = b.mul(i2, two);
    let r = b.unary(UnOp::Sqrt, z);
    let (sp, cp) = (b.unary(UnOp::Sin, phi), b.unary(UnOp::Cos, phi));
    let vx = b.mul(sp, r);
    let vy = b.mul(cp, r);
    let two_z = b.sub(two, z);
    let vz = b.unary(UnOp::Sqrt, two_z);
    let (st, ct) = (b.unary(UnOp::Sin, theta), b.unary(UnOp::Cos, theta));
    let (a, c) = (b.mul(vx, ct), b.mul(vy, st));
    let sx = b.sub(a, c);
    let (a, c) = (b.mul(vx, st), b.mul(vy, ct));
    let sy = b.add(a, c);
    // Row of the matrix times p: (m0·p0 + m1·p1) + m2·p2.
    let row = |b: &mut Builder, m: [Value; 3]| {
        let (x, y, z) = (b.mul(m[0], p0), b.mul(m[1], p1), b.mul(m[2], p2));
        let s = b.add(x, y);
        b.add(s, z)
    };
    let (vxsx, vysx, vzsx) = (b.mul(vx, sx), b.mul(vy, sx), b.mul(vz, sx));
    let m0 = [b.sub(vxsx, ct), b.add(vysx, st), vzsx];
    let r0 = row(b, m0);
    let (vxsy, vysy, vzsy) = (b.mul(vx, sy), b.mul(vy, sy), b.mul(vz, sy));
    let m1 = [b.sub(vxsy, st), b.sub(vysy, ct), vzsy];
    let r1 = row(b, m1);
    let one = b.float(1.0);
    let m2 = [b.mul(vx, vz), b.mul(vy, vz), b.sub(one, z)];
    let r2 = row(b, m2);
    b.construct(Type::Vec3, &[r0, r1, r2])
}

/// `mx_flake(size, roughness, coverage, position, N, tangent, bitangent)` → `id`, `rand`,
/// `presence`, `flakenormal`.
fn flake(b: &mut Builder, inp: &NodeInputs, position: Value) -> Out {
    let size = inp.get("size");
    let roughness = inp.get("roughness");
    let coverage = inp.get("coverage");
    let (zero, one) = (b.float(0.0), b.float(1.0));
    let coverage = b.clamp(coverage, zero, one);
    let prob = probability(b, coverage);
    // flake_diameter = 1.5 / sqrt(3.0)
    let (k15, k3) = (b.float(1.5), b.float(3.0));
    let sqrt3 = b.unary(UnOp::Sqrt, k3);
    let diameter = b.div(k15, sqrt3);
    let dd = b.mul(diameter, diameter);
    let reach = b.mul(dd, k3);
    let size3 = b.splat_to(Type::Vec3, size);
    let p = b.div(position, size3);
    let base = b.unary(UnOp::Floor, p);
    let half = b.float(0.5);
    let half = b.splat_to(Type::Vec3, half);

    let mut priority = zero;
    let mut cell = b.zero(Type::Vec3);
    for i in -1..2 {
        for j in -1..2 {
            for k in -1..2 {
                let offset = b.vec3([f64::from(i), f64::from(j), f64::from(k)]);
                let cell_pos = b.add(base, offset);
                let pp = b.sub(p, cell_pos);
                let pp = b.sub(pp, half);
                let d2 = b.dot(pp, pp);
                let far = b.binary(BinOp::Ge, d2, reach);
                let near = b.unary(UnOp::Not, far);
                let noise = b.call(Intrinsic::OslCell3, &[cell_pos]);
                let absent = b.binary(BinOp::Gt, noise, prob);
                let present = b.unary(UnOp::Not, absent);
                let mine = b.call(Intrinsic::OslCell4, &[cell_pos, k3]);
                let below = b.binary(BinOp::Lt, mine, priority);
                let above = b.unary(UnOp::Not, below);
                let rot = b.call(Intrinsic::OslVCell3, &[cell_pos]);
                let q = rotate(b, pp, rot);
                let mut take = b.binary(BinOp::And, near, present);
                take = b.binary(BinOp::And, take, above);
                for c in 0..3 {
                    let x = b.extract(q, c);
                    let x = b.unary(UnOp::Abs, x);
                    let inside = b.binary(BinOp::Le, x, diameter);
                    take = b.binary(BinOp::And, take, inside);
                }
                priority = b.select(take, mine, priority);
                cell = b.select(take, cell_pos, cell);
            }
        }
    }

    let n = inp.get("normal");
    let tangent = inp.get("tangent");
    let bitangent = inp.get("bitangent");
    let two = b.float(2.0);
    let noise = b.call(Intrinsic::OslVCell4, &[cell, two]);
    let [xi0, xi1, rand] = [0, 1, 2].map(|c| b.extract(noise, c));
    let ids = b.float(16_777_215.0);
    let scaled = b.mul(rand, ids);
    let id = b.convert(Type::Int, scaled);
    let phi = two_pi(b, xi0);
    // tan θ = r² √ξ1 / √(1 − ξ1) (GGX), sin θ = tan θ / √(1 + tan² θ), cos θ = √(1 − sin² θ)
    let rr = b.mul(roughness, roughness);
    let s1 = b.unary(UnOp::Sqrt, xi1);
    let t = b.mul(rr, s1);
    let om = b.sub(one, xi1);
    let s2 = b.unary(UnOp::Sqrt, om);
    let tan = b.div(t, s2);
    let tt = b.mul(tan, tan);
    let opt = b.add(one, tt);
    let s3 = b.unary(UnOp::Sqrt, opt);
    let sin = b.div(tan, s3);
    let ss = b.mul(sin, sin);
    let oms = b.sub(one, ss);
    let cos = b.unary(UnOp::Sqrt, oms);
    // tangent · cos φ · sin θ + bitangent · sin φ · sin θ + N · cos θ
    let (cp, sp) = (b.unary(UnOp::Cos, phi), b.unary(UnOp::Sin, phi));
    let a = scale(b, tangent, cp);
    let a = scale(b, a, sin);
    let c = scale(b, bitangent, sp);
    let c = scale(b, c, sin);
    let d = scale(b, n, cos);
    let sum = b.add(a, c);
    let sum = b.add(sum, d);
    let normal = b.normalize(sum);

    // No flake: id 0, rand 0, presence 0, the surface normal.
    let none = b.binary(BinOp::Le, priority, zero);
    let id0 = b.int(0);
    let outs = [
        b.select(none, id0, id),
        b.select(none, zero, rand),
        b.select(none, zero, priority),
        b.select(none, n, normal),
    ];
    Ok(outs.into_iter().map(LowVal::plain).collect())
}
