//! The shading frame of a lobe: an orthonormal basis around the shading normal turned to
//! face the viewer, with the tangent (for anisotropy) made orthogonal to it. It owns the
//! world ↔ local conversions; it must not know any lobe.

use super::math::{comp, lt, vec3};
use crate::ir::{BinOp, Builder, UnOp, Value};

/// An orthonormal frame `(t, b, n)` in world space (vec3 values) and whether the viewer is
/// behind the surface's own normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Unit tangent, orthogonal to `n`.
    pub t: Value,
    /// Unit bitangent, `n × t`.
    pub b: Value,
    /// Unit shading normal, turned to the viewer's side (`n · wo ≥ 0`).
    pub n: Value,
    /// Bool: the given normal pointed away from the viewer (the viewer is inside a closed
    /// dielectric: transmission lobes swap the indices of refraction).
    pub inside: Value,
}

impl Frame {
    /// The frame of `normal` (vec3, world, any length) and `tangent` (vec3, world, any length
    /// or zero) seen from `wo` (unit, towards the viewer).
    ///
    /// `n = ±normalize(normal)`, the sign making `n · wo ≥ 0`. `t` is `tangent` with its
    /// component along `n` removed, normalized; where that is zero (no tangent, or one along
    /// the normal) `t` comes from Duff et al.'s branchless basis (JCGT 2017) around `n`. A
    /// zero `normal` gives a zero `n`, so every cosine is 0 and every lobe returns 0.
    pub fn new(b: &mut Builder, normal: Value, tangent: Value, wo: Value) -> Frame {
        let n0 = b.normalize(normal);
        let d = b.dot(n0, wo);
        let zero = b.float(0.0);
        let inside = lt(b, d, zero);
        let neg = b.unary(UnOp::Neg, n0);
        let n = b.select(inside, neg, n0);
        let tn = b.dot(tangent, n);
        let along = super::math::scale(b, n, tn);
        let t0 = b.sub(tangent, along);
        let t0 = b.normalize(t0);
        let fallback = duff_tangent(b, n);
        let len = b.unary(UnOp::Length, t0);
        let half = b.float(0.5);
        let has = b.binary(BinOp::Gt, len, half);
        let t = b.select(has, t0, fallback);
        let bt = b.binary(BinOp::Cross, n, t);
        Frame {
            t,
            b: bt,
            n,
            inside,
        }
    }

    /// `w` (world) in this frame: `(w·t, w·b, w·n)`.
    pub fn to_local(&self, b: &mut Builder, w: Value) -> Value {
        let x = b.dot(w, self.t);
        let y = b.dot(w, self.b);
        let z = b.dot(w, self.n);
        vec3(b, x, y, z)
    }

    /// `l` (local) in world space: `l.x t + l.y b + l.z n`.
    pub fn to_world(&self, b: &mut Builder, l: Value) -> Value {
        let (x, y, z) = (comp(b, l, 0), comp(b, l, 1), comp(b, l, 2));
        let tx = super::math::scale(b, self.t, x);
        let by = super::math::scale(b, self.b, y);
        let nz = super::math::scale(b, self.n, z);
        let s = b.add(tx, by);
        b.add(s, nz)
    }
}

/// The tangent of Duff et al.'s orthonormal basis around unit `n`:
/// `s = sign(n.z)`, `a = −1/(s + n.z)`, `t = (1 + s n.x² a, s n.x n.y a, −s n.x)`.
pub(super) fn duff_tangent(b: &mut Builder, n: Value) -> Value {
    let (nx, ny, nz) = (comp(b, n, 0), comp(b, n, 1), comp(b, n, 2));
    let zero = b.float(0.0);
    let neg = lt(b, nz, zero);
    let (one, m1) = (b.float(1.0), b.float(-1.0));
    let s = b.select(neg, m1, one);
    let snz = b.add(s, nz);
    let a = b.div(m1, snz);
    let nx2 = b.mul(nx, nx);
    let sa = b.mul(s, a);
    let t0 = b.mul(sa, nx2);
    let t0 = b.add(one, t0);
    let nxy = b.mul(nx, ny);
    let t1 = b.mul(sa, nxy);
    let snx = b.mul(s, nx);
    let t2 = b.unary(UnOp::Neg, snx);
    vec3(b, t0, t1, t2)
}
