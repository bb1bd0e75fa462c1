//! Forward-mode screen-space derivatives (∂/∂x, ∂/∂y), built into the IR on demand.
//!
//! A filtered texture lookup (or a filtered procedural) needs the footprint of its
//! coordinates, and the coordinates are usually computed (`place2d`, scale, rotate, noise
//! distortion). [`Builder::derivs`] walks the ops that compute a value back to the implicit
//! streams and emits, after them, the chain rule's ops for ∂v/∂x and ∂v/∂y (OSL's dual
//! numbers, written out as ordinary ops). They are ordinary values: partial evaluation
//! folds and removes them like any other, so a material whose lookups are dead — or that
//! has none — pays nothing.
//!
//! Where the derivatives come from:
//! - `P`: the ray differentials `dPdx`, `dPdy`; `uv`: the same projected onto the surface's
//!   `dPdu`, `dPdv` (least squares, zero where they are degenerate); every other stream is
//!   taken as constant across the pixel.
//! - Linear and smooth ops by the chain rule; `floor`/`ceil`, comparisons, ints, bools and
//!   matrices have none.
//! - Intrinsics (noise, fractals, cell noise, HSV) and texture lookups by a one-sided
//!   difference over the footprint, `f(x + ∂x) − f(x)` (GLSL's `dFdx` of a lookup): what a
//!   filter or a bump needs is the size of the change, and the difference sees every octave.
//!   The moved lookup keeps the lookup's sampling and footprint, so the difference is of the
//!   filtered texture.
//! - Results of an `If`: a select of the arms' derivatives, the arms' computation rebuilt in a
//!   new `If` on the same condition where it lies inside them (not through regions nested in
//!   an arm). Illuminance sums and scene queries are taken as constant.
//!
//! This module only adds ops through the [`Builder`]; it must not edit ops already built.

use super::{BinOp, Builder, Intrinsic, Op, Stream, UnOp, Value, XformKind};
use crate::types::Type;
use std::collections::{BTreeSet, HashMap};

/// ∂v/∂x and ∂v/∂y; `None` where both are zero (a constant across the pixel).
type D = Option<[Value; 2]>;

impl Builder {
    /// The screen-space derivatives `[∂v/∂x, ∂v/∂y]` of a float-based value (float or
    /// vector), emitted as ops in the current block; `None` where they are zero or the type
    /// has none (ints, bools, matrices, closures).
    pub fn derivs(&mut self, v: Value) -> D {
        // The values `v` depends on through ops that carry derivatives, in arena order
        // (operands before users, as the builder creates them).
        let mut seen = BTreeSet::new();
        let mut stack = vec![v];
        while let Some(x) = stack.pop() {
            if !seen.insert(x) || !self.carries(x) {
                continue;
            }
            self.program().op(x).for_each_operand(|o| stack.push(o));
        }
        let mut memo: HashMap<Value, D> = HashMap::new();
        for x in seen {
            let d = if self.carries(x) {
                self.derive(x, &memo)
            } else {
                None
            };
            memo.insert(x, d);
        }
        memo.get(&v).copied().flatten()
    }

    /// Whether `x` can have non-zero derivatives: a float-based value.
    fn carries(&self, x: Value) -> bool {
        self.program()
            .expr(x)
            .ty
            .is_some_and(|t| t.is_float_based())
    }

    /// The derivatives of `x` from those of its operands (`memo`).
    fn derive(&mut self, x: Value, memo: &HashMap<Value, D>) -> D {
        let d = |v: &Value| memo.get(v).copied().flatten();
        let op = self.program().op(x).clone();
        match op {
            Op::Stream(s) => self.stream_derivs(s),
            Op::Transform {
                kind,
                from,
                to,
                arg,
            } => {
                let kind = match kind {
                    XformKind::Point => XformKind::Vector,
                    k => k,
                };
                self.each(d(&arg), |b, a| {
                    b.push(
                        Op::Transform {
                            kind,
                            from,
                            to,
                            arg: a,
                        },
                        Some(Type::Vec3),
                    )
                })
            }
            Op::Unary(u, a) => self.unary_derivs(u, a, x, d(&a)),
            Op::Binary(o, a, b) => self.binary_derivs(o, a, b, x, d(&a), d(&b)),
            Op::Select { cond, a, b } => {
                let (da, db) = (d(&a), d(&b));
                if da.is_none() && db.is_none() {
                    return None;
                }
                let ty = self.ty(x);
                let (da, db) = (self.or_zero(da, ty), self.or_zero(db, ty));
                Some([0, 1].map(|k| self.select(cond, da[k], db[k])))
            }
            Op::Construct(args) => {
                let ty = self.ty(x);
                if !ty.is_vector() || args.iter().all(|a| d(a).is_none()) {
                    return None;
                }
                let parts: Vec<[Value; 2]> = args
                    .iter()
                    .map(|a| self.or_zero(d(a), Type::Float))
                    .collect();
                Some([0, 1].map(|k| {
                    let p: Vec<Value> = parts.iter().map(|p| p[k]).collect();
                    self.construct(ty, &p)
                }))
            }
            Op::Extract(a, i) => self.each(d(&a), |b, da| b.extract(da, i as usize)),
            Op::Splat(a) => {
                let ty = self.ty(x);
                self.each(d(&a), |b, da| b.splat(ty, da))
            }
            Op::Call(i, args) => self.call_derivs(i, &args, x, memo),
            Op::Texture {
                texture,
                uv,
                derivs,
                sampling,
                alpha,
            } => {
                let ty = self.ty(x);
                let du = d(&uv)?;
                Some([0, 1].map(|k| {
                    let moved = self.add(uv, du[k]);
                    let op = Op::Texture {
                        texture,
                        uv: moved,
                        derivs,
                        sampling,
                        alpha,
                    };
                    let f = self.push(op, Some(ty));
                    self.sub(f, x)
                }))
            }
            Op::Proj(region, i) => self.proj_derivs(region, i as usize),
            _ => None,
        }
    }

    /// Derivatives of result `i` of an `If` (an illuminance's sums have none): `select(cond,
    /// ∂then, ∂else)` where both arms yield values from outside the region; otherwise a new
    /// `If` on the same condition whose arms rebuild the yields' straight-line computation
    /// and yield its derivatives (an arm whose yield depends on a nested region gives zero).
    fn proj_derivs(&mut self, region: Value, i: usize) -> D {
        let Op::If { cond, then_, else_ } = self.program().op(region).clone() else {
            return None;
        };
        let (yt, ye) = (*then_.yields.get(i)?, *else_.yields.get(i)?);
        let ty = self.ty(yt);
        if !then_.body.contains(&yt) && !else_.body.contains(&ye) {
            let (dt, de) = (self.derivs(yt), self.derivs(ye));
            if dt.is_none() && de.is_none() {
                return None;
            }
            let (dt, de) = (self.or_zero(dt, ty), self.or_zero(de, ty));
            return Some([0, 1].map(|k| self.select(cond, dt[k], de[k])));
        }
        let r = self.if_(
            cond,
            |b| b.arm_derivs(&then_, yt, ty),
            |b| b.arm_derivs(&else_, ye, ty),
        );
        Some([r[0], r[1]])
    }

    /// In a new arm: the derivatives of `y`, yielded by `arm`, rebuilt from the arm's ops
    /// (zeros where `y` depends on a region nested in the arm).
    fn arm_derivs(&mut self, arm: &super::Block, y: Value, ty: Type) -> Vec<Value> {
        let y = if arm.body.contains(&y) {
            self.rebuild(arm, y)
        } else {
            Some(y)
        };
        let d = y.and_then(|y| self.derivs(y));
        self.or_zero(d, ty).to_vec()
    }

    /// Copies into the current block the ops of `arm` that `y` depends on (in the arm's
    /// order, operands renamed to the copies); the copy of `y`, or `None` where one of them
    /// is a region.
    fn rebuild(&mut self, arm: &super::Block, y: Value) -> Option<Value> {
        let inside: BTreeSet<Value> = arm.body.iter().copied().collect();
        let mut need = BTreeSet::new();
        let mut stack = vec![y];
        while let Some(x) = stack.pop() {
            if !inside.contains(&x) || !need.insert(x) {
                continue;
            }
            if self.program().op(x).is_region() {
                return None;
            }
            self.program().op(x).for_each_operand(|o| stack.push(o));
        }
        let mut copies: HashMap<Value, Value> = HashMap::new();
        for &x in arm.body.iter().filter(|x| need.contains(x)) {
            let e = self.program().expr(x).clone();
            let mut op = e.op;
            for o in op.operands_mut() {
                if let Some(c) = copies.get(o) {
                    *o = *c;
                }
            }
            let c = self.push(op, e.ty);
            copies.insert(x, c);
        }
        copies.get(&y).copied()
    }

    /// Derivatives of an implicit stream.
    fn stream_derivs(&mut self, s: Stream) -> D {
        match s {
            Stream::P => Some([self.stream(Stream::DPdx), self.stream(Stream::DPdy)]),
            Stream::Uv => {
                // Least squares: dP/dx ≈ du·dPdu + dv·dPdv.
                let (pu, pv) = (self.stream(Stream::DPdu), self.stream(Stream::DPdv));
                let a = self.dot(pu, pu);
                let b = self.dot(pu, pv);
                let c = self.dot(pv, pv);
                let ac = self.mul(a, c);
                let bb = self.mul(b, b);
                let det = self.sub(ac, bb);
                Some([Stream::DPdx, Stream::DPdy].map(|axis| {
                    let dp = self.stream(axis);
                    let r0 = self.dot(pu, dp);
                    let r1 = self.dot(pv, dp);
                    let (c0, b1) = (self.mul(c, r0), self.mul(b, r1));
                    let (a1, b0) = (self.mul(a, r1), self.mul(b, r0));
                    let (nu, nv) = (self.sub(c0, b1), self.sub(a1, b0));
                    let du = self.div(nu, det);
                    let dv = self.div(nv, det);
                    self.construct(Type::Vec2, &[du, dv])
                }))
            }
            _ => None,
        }
    }

    /// Derivatives of a unary op `x = u(a)`.
    fn unary_derivs(&mut self, u: UnOp, a: Value, x: Value, da: D) -> D {
        use UnOp::*;
        let da = da?;
        let ty = self.ty(a);
        // ∂x = f'(a)·∂a, with the factor f'(a) computed once for both axes.
        let factor = match u {
            Neg => return Some(da.map(|d| self.unary(Neg, d))),
            Fract => return Some(da),
            Floor | Ceil | Not | BitNot => return None,
            Abs => {
                let parts: Vec<Value> = (0..ty.width())
                    .map(|i| {
                        let c = if ty.is_vector() {
                            self.extract(a, i)
                        } else {
                            a
                        };
                        let zero = self.float(0.0);
                        let neg = self.binary(BinOp::Lt, c, zero);
                        let (m, p) = (self.float(-1.0), self.float(1.0));
                        self.select(neg, m, p)
                    })
                    .collect();
                self.gather(ty, &parts)
            }
            Sqrt => {
                let two = self.splat_float(ty, 2.0);
                let t = self.mul(two, x);
                let one = self.splat_float(ty, 1.0);
                self.div(one, t)
            }
            Exp => x,
            Log => {
                let one = self.splat_float(ty, 1.0);
                self.div(one, a)
            }
            Sin => self.unary(Cos, a),
            Cos => {
                let s = self.unary(Sin, a);
                self.unary(Neg, s)
            }
            Tan => {
                let c = self.unary(Cos, a);
                let c2 = self.mul(c, c);
                let one = self.splat_float(ty, 1.0);
                self.div(one, c2)
            }
            Asin | Acos => {
                let one = self.splat_float(ty, 1.0);
                let a2 = self.mul(a, a);
                let r = self.sub(one, a2);
                let s = self.unary(Sqrt, r);
                let f = self.div(one, s);
                if u == Acos { self.unary(Neg, f) } else { f }
            }
            Length => {
                // ∂|a| = a·∂a / |a|.
                return Some(da.map(|d| {
                    let t = self.dot(a, d);
                    self.div(t, x)
                }));
            }
            Normalize => {
                // ∂(a/|a|) = (∂a − n (n·∂a)) / |a|.
                let len = self.unary(Length, a);
                let inv = self.div_float(1.0, len);
                return Some(da.map(|d| {
                    let nd = self.dot(x, d);
                    let s = self.splat_to(ty, nd);
                    let proj = self.mul(x, s);
                    let t = self.sub(d, proj);
                    let w = self.splat_to(ty, inv);
                    self.mul(t, w)
                }));
            }
        };
        Some(da.map(|d| self.mul(factor, d)))
    }

    /// Derivatives of a binary op `x = o(a, b)`.
    fn binary_derivs(&mut self, o: BinOp, a: Value, b: Value, x: Value, da: D, db: D) -> D {
        use BinOp::*;
        if matches!(o, MulPoint | MulVector) {
            // The matrix is taken as constant: ∂(m × p) = m × ∂p as a vector.
            return self.each(db, |bl, d| bl.binary(MulVector, a, d));
        }
        if da.is_none() && db.is_none() {
            return None;
        }
        let ty = self.ty(a);
        if !ty.is_float_based() {
            return None;
        }
        match o {
            Add | Sub => self.sum(da, db, |bl, p, q| bl.binary(o, p, q), o == Sub),
            Mul => {
                let l = self.each(da, |bl, d| bl.mul(d, b));
                let r = self.each(db, |bl, d| bl.mul(a, d));
                self.sum(l, r, |bl, p, q| bl.add(p, q), false)
            }
            Div => {
                // ∂(a/b) = (∂a − x·∂b) / b.
                let xd = self.each(db, |bl, d| bl.mul(x, d));
                let n = self.sum(da, xd, |bl, p, q| bl.sub(p, q), true);
                self.each(n, |bl, t| bl.div(t, b))
            }
            Mod => {
                // a − b·floor(a/b): ∂a − ∂b·floor(a/b).
                let q = self.div(a, b);
                let f = self.unary(UnOp::Floor, q);
                let fd = self.each(db, |bl, d| bl.mul(d, f));
                self.sum(da, fd, |bl, p, q| bl.sub(p, q), true)
            }
            Pow => {
                // ∂(a^b) = b·a^(b−1)·∂a + a^b·ln(a)·∂b.
                let l = match da {
                    Some(da) => {
                        let one = self.splat_float(ty, 1.0);
                        let e = self.sub(b, one);
                        let p = self.binary(Pow, a, e);
                        let f = self.mul(b, p);
                        Some(da.map(|d| self.mul(f, d)))
                    }
                    None => None,
                };
                let r = match db {
                    Some(db) => {
                        let ln = self.unary(UnOp::Log, a);
                        let f = self.mul(x, ln);
                        Some(db.map(|d| self.mul(f, d)))
                    }
                    None => None,
                };
                self.sum(l, r, |bl, p, q| bl.add(p, q), false)
            }
            Min | Max => {
                let cmp = if o == Min { Lt } else { Gt };
                let (da, db) = (self.or_zero(da, ty), self.or_zero(db, ty));
                Some([0, 1].map(|k| {
                    let parts: Vec<Value> = (0..ty.width())
                        .map(|i| {
                            let pick = |bl: &mut Builder, v: Value| {
                                if ty.is_vector() { bl.extract(v, i) } else { v }
                            };
                            let (ai, bi) = (pick(self, a), pick(self, b));
                            let (dai, dbi) = (pick(self, da[k]), pick(self, db[k]));
                            let c = self.binary(cmp, ai, bi);
                            self.select(c, dai, dbi)
                        })
                        .collect();
                    self.gather(ty, &parts)
                }))
            }
            Atan2 => {
                // atan2(a, b): (b·∂a − a·∂b) / (a² + b²).
                let (a2, b2) = (self.mul(a, a), self.mul(b, b));
                let r = self.add(a2, b2);
                let l = self.each(da, |bl, d| bl.mul(b, d));
                let rr = self.each(db, |bl, d| bl.mul(a, d));
                let n = self.sum(l, rr, |bl, p, q| bl.sub(p, q), true);
                self.each(n, |bl, t| bl.div(t, r))
            }
            Dot => {
                let l = self.each(da, |bl, d| bl.dot(d, b));
                let r = self.each(db, |bl, d| bl.dot(a, d));
                self.sum(l, r, |bl, p, q| bl.add(p, q), false)
            }
            Cross => {
                let l = self.each(da, |bl, d| bl.binary(Cross, d, b));
                let r = self.each(db, |bl, d| bl.binary(Cross, a, d));
                self.sum(l, r, |bl, p, q| bl.add(p, q), false)
            }
            Distance => {
                // ∂|a − b| = (a − b)·(∂a − ∂b) / |a − b|.
                let diff = self.sub(a, b);
                let dd = self.sum(da, db, |bl, p, q| bl.sub(p, q), true);
                self.each(dd, |bl, d| {
                    let t = bl.dot(diff, d);
                    bl.div(t, x)
                })
            }
            _ => None,
        }
    }

    /// Derivatives of an intrinsic call by a one-sided difference over the footprint.
    fn call_derivs(
        &mut self,
        i: Intrinsic,
        args: &[Value],
        x: Value,
        memo: &HashMap<Value, D>,
    ) -> D {
        let ds: Vec<D> = args
            .iter()
            .map(|a| memo.get(a).copied().flatten())
            .collect();
        if ds.iter().all(|d| d.is_none()) {
            return None;
        }
        Some([0, 1].map(|k| {
            let moved: Vec<Value> = args
                .iter()
                .zip(&ds)
                .map(|(a, d)| match d {
                    Some(d) => self.add(*a, d[k]),
                    None => *a,
                })
                .collect();
            let f = self.call(i, &moved);
            self.sub(f, x)
        }))
    }

    /// `f` applied to both derivatives, if there are any.
    fn each(&mut self, d: D, mut f: impl FnMut(&mut Builder, Value) -> Value) -> D {
        d.map(|d| d.map(|v| f(self, v)))
    }

    /// `p ∘ q` where both exist, `p` or (`q`, negated when `negate_right`) alone otherwise.
    fn sum(
        &mut self,
        p: D,
        q: D,
        mut f: impl FnMut(&mut Builder, Value, Value) -> Value,
        negate_right: bool,
    ) -> D {
        match (p, q) {
            (Some(p), Some(q)) => Some([0, 1].map(|k| f(self, p[k], q[k]))),
            (Some(p), None) => Some(p),
            (None, Some(q)) if negate_right => Some(q.map(|v| self.unary(UnOp::Neg, v))),
            (None, q) => q,
        }
    }

    /// The derivatives, or two zeros of type `ty`.
    fn or_zero(&mut self, d: D, ty: Type) -> [Value; 2] {
        d.unwrap_or_else(|| {
            let z = self.zero(ty);
            [z, z]
        })
    }

    /// A float constant broadcast to `ty`.
    fn splat_float(&mut self, ty: Type, x: f64) -> Value {
        let f = self.float(x);
        self.splat_to(ty, f)
    }

    /// `x / v` for a float `v`.
    fn div_float(&mut self, x: f64, v: Value) -> Value {
        let c = self.float(x);
        self.div(c, v)
    }

    /// A vector of type `ty` from its components, or the one float when `ty` is float.
    fn gather(&mut self, ty: Type, parts: &[Value]) -> Value {
        if ty.is_vector() {
            self.construct(ty, parts)
        } else {
            parts[0]
        }
    }
}
