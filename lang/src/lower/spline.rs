//! `spline(basis, x, knots…)` as OSL defines it (and RSL's `spline`, which is the same with
//! an optional basis, Catmull-Rom by default): the knots an array or the arguments after
//! `x`; `x` clamped to [0, 1] picks segment `floor(x · nsegs)` of the
//! `(nknots − 4) / step + 1` segments, whose four knots are combined with the basis matrix
//! row by row and evaluated by Horner's rule in the segment's `x` — the operations of OSL's
//! `spline_evaluate`, in its order. The bases are the RenderMan ones OSL tabulates:
//! `catmull-rom`, `bezier` (step 3), `bspline`, `hermite` (step 2), `linear` and `constant`
//! (the knot after the segment's start). Owns these rules; the arithmetic is IR ops.

mod inverse;

use super::{Lower, Ty, Val};
use crate::source::Span;
use shadenet_graph::ir::{BinOp, Builder, UnOp, Value};

/// A basis: its name, step between segments, and matrix (rows combine the four knots).
pub(super) type Basis = (&'static str, usize, [[f64; 4]; 4]);

/// OSL's spline bases.
const BASES: &[Basis] = &[
    (
        "catmull-rom",
        1,
        [
            [-1.0 / 2.0, 3.0 / 2.0, -3.0 / 2.0, 1.0 / 2.0],
            [1.0, -5.0 / 2.0, 2.0, -1.0 / 2.0],
            [-1.0 / 2.0, 0.0, 1.0 / 2.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
        ],
    ),
    (
        "bezier",
        3,
        [
            [-1.0, 3.0, -3.0, 1.0],
            [3.0, -6.0, 3.0, 0.0],
            [-3.0, 3.0, 0.0, 0.0],
            [1.0, 0.0, 0.0, 0.0],
        ],
    ),
    (
        "bspline",
        1,
        [
            [-1.0 / 6.0, 3.0 / 6.0, -3.0 / 6.0, 1.0 / 6.0],
            [0.5, -1.0, 0.5, 0.0],
            [-0.5, 0.0, 0.5, 0.0],
            [1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0, 0.0],
        ],
    ),
    (
        "hermite",
        2,
        [
            [2.0, 1.0, -2.0, 1.0],
            [-3.0, -2.0, 3.0, -1.0],
            [0.0, 1.0, 0.0, 0.0],
            [1.0, 0.0, 0.0, 0.0],
        ],
    ),
    (
        "linear",
        1,
        [
            [0.0; 4],
            [0.0; 4],
            [0.0, -1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
        ],
    ),
    ("constant", 1, [[0.0; 4]; 4]),
];

/// A spline call's arguments, lowered: the basis, `x`, the knots (of one type) and whether
/// any varies.
struct Args {
    basis: &'static Basis,
    x: Value,
    ks: Vec<Value>,
    ty: Ty,
    varying: bool,
}

impl<'a> Lower<'a> {
    /// `spline([basis,] x, knots…)` (the basis required in OSL) and OSL's
    /// `splineinverse(basis, y, knots…)`, or `None` when `name` is neither.
    pub(crate) fn spline(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
        span: Span,
    ) -> Option<Val> {
        let inverse = match name {
            "spline" => false,
            "splineinverse" => true,
            _ => return None,
        };
        let Some(a) = self.spline_args(b, name, args, span) else {
            return Some(Self::poison(b, Ty::Float));
        };
        if !inverse {
            let v = evaluate(b, a.basis, a.x, &a.ks, a.ty);
            return Some(Val::V {
                v,
                ty: a.ty,
                varying: a.varying,
            });
        }
        if a.ty != Ty::Float {
            self.error(
                format!("splineinverse takes float knots, not {}", a.ty.name()),
                span,
                "not float knots",
            );
            return Some(Self::poison(b, Ty::Float));
        }
        let v = inverse::inverse(b, a.basis, a.x, &a.ks);
        Some(Val::V {
            v,
            ty: Ty::Float,
            varying: a.varying,
        })
    }

    /// The arguments of `name` (`spline` or `splineinverse`): `[basis,] x` then the knots —
    /// one array, OSL's count and an array (its first `count` knots; the count a constant),
    /// or the remaining arguments; `None` after an error.
    fn spline_args(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
        span: Span,
    ) -> Option<Args> {
        let (basis, rest) = match args.split_first() {
            Some(((Val::Str(s), at), rest)) => {
                match BASES.iter().find(|(n, ..)| *n == s.as_str()) {
                    Some(basis) => (basis, rest),
                    None => {
                        let names: Vec<&str> = BASES.iter().map(|(n, ..)| *n).collect();
                        self.error(
                            format!(
                                "unknown spline basis \"{s}\" (the bases: {})",
                                names.join(", ")
                            ),
                            *at,
                            "not a basis",
                        );
                        return None;
                    }
                }
            }
            _ if self.dialect == crate::Dialect::Rsl && name == "spline" => (&BASES[0], args),
            _ => return self.spline_usage(name, span),
        };
        let Some(((x, xat), knots)) = rest.split_first() else {
            return self.spline_usage(name, span);
        };
        let knots: Vec<Val> = match knots {
            [(Val::Array(k), _)] => k.clone(),
            [(Val::V { v, ty: Ty::Int, .. }, at), (Val::Array(k), _)] => {
                let count = shadenet_graph::opt::fold::constant(b.program(), *v)
                    .as_ref()
                    .and_then(super::osl::const_number);
                match count {
                    Some(n) if n >= 0.0 && n as usize <= k.len() => k[..n as usize].to_vec(),
                    Some(n) => {
                        let msg = format!("knot count {n} is outside the array's {}", k.len());
                        self.error(msg, *at, "the count");
                        return None;
                    }
                    None => {
                        let msg = "a knot count known only while shading is not built: \
                                   pass a constant or the whole array";
                        self.error(msg, *at, "not a constant");
                        return None;
                    }
                }
            }
            k => k.iter().map(|(v, _)| v.clone()).collect(),
        };
        if knots.len() < 4 {
            self.error(
                format!("a spline needs at least 4 knots; it has {}", knots.len()),
                span,
                "too few knots",
            );
            return None;
        }
        let ty = match knots.iter().find_map(|k| match k {
            Val::V { ty, .. } if *ty != Ty::Int => Some(*ty),
            _ => None,
        }) {
            Some(t) if t == Ty::Float || t.is_triple() => t,
            _ => Ty::Float,
        };
        let mut varying = false;
        let mut ks = Vec::with_capacity(knots.len());
        for k in knots {
            match self.coerce(b, k, ty, span) {
                Val::V { v, varying: vy, .. } => {
                    varying |= vy;
                    ks.push(v);
                }
                _ => return None,
            }
        }
        let x = match self.coerce(b, x.clone(), Ty::Float, *xat) {
            Val::V { v, varying: vy, .. } => {
                varying |= vy;
                v
            }
            _ => return None,
        };
        Some(Args {
            basis,
            x,
            ks,
            ty,
            varying,
        })
    }

    /// The usage error of `name`.
    fn spline_usage(&mut self, name: &str, span: Span) -> Option<Args> {
        let what = if name == "spline" { "x" } else { "y" };
        self.error(
            format!(
                "{name} takes (string basis, float {what}, knots…), (string basis, float {what}, array) or (string basis, float {what}, int count, array)"
            ),
            span,
            "wrong arguments",
        );
        None
    }
}

/// OSL's `spline_evaluate` on knots `ks` (values of `ty`) at `x`.
pub(super) fn evaluate(
    b: &mut Builder,
    (name, step, m): &Basis,
    x: Value,
    ks: &[Value],
    ty: Ty,
) -> Value {
    let nsegs = (ks.len() - 4) / step + 1;
    let (zero, one) = (b.float(0.0), b.float(1.0));
    let x = b.clamp(x, zero, one);
    let n = b.float(nsegs as f64);
    let x = b.mul(x, n);
    // The segment: `(int) x`, at most nsegs − 1 (x ≥ 0 here, so truncation is floor).
    let seg = b.unary(UnOp::Floor, x);
    let last = b.float((nsegs - 1) as f64);
    let seg = b.min(seg, last);
    let pick = |b: &mut Builder, first: usize| -> Value {
        // The knot at `seg · step + first`, by a chain of selects over the segments.
        let mut acc = ks[first];
        for s in 1..nsegs {
            let here = b.float(s as f64);
            let at = b.binary(BinOp::Eq, seg, here);
            acc = b.select(at, ks[s * step + first], acc);
        }
        acc
    };
    if *name == "constant" {
        return pick(b, 1);
    }
    let x = b.sub(x, seg);
    let p: Vec<Value> = (0..4).map(|k| pick(b, k)).collect();
    let weighted = |b: &mut Builder, c: f64, v: Value| {
        let c = b.float(c);
        let c = b.splat_to(ty.ir(), c);
        b.mul(c, v)
    };
    let tk: Vec<Value> = m
        .iter()
        .map(|row| {
            let mut acc = weighted(b, row[0], p[0]);
            for j in 1..4 {
                let t = weighted(b, row[j], p[j]);
                acc = b.add(acc, t);
            }
            acc
        })
        .collect();
    let xs = if ty == Ty::Float {
        x
    } else {
        b.splat(ty.ir(), x)
    };
    let mut r = b.mul(tk[0], xs);
    r = b.add(r, tk[1]);
    r = b.mul(r, xs);
    r = b.add(r, tk[2]);
    r = b.mul(r, xs);
    b.add(r, tk[3])
}
