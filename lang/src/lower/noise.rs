//! OSL's noise builtins — `noise`, `snoise`, `cellnoise`, `hashnoise`, and the periodic
//! `pnoise`, `psnoise` — lowered onto the IR's OSL noise intrinsics (OSL's generators,
//! `shadenet_graph::ops::osl_noise`). It owns these rules:
//!
//! - An optional generator name first (`noise`, `pnoise`): `"perlin"` (signed),
//!   `"uperlin"` (`0.5 · (perlin + 1)`, the default), `"cell"`, `"hash"`, `"simplex"`
//!   (signed), `"usimplex"` (`0.5 · (simplex + 1)`); `snoise`/`psnoise` are `"perlin"`,
//!   `cellnoise` `"cell"`, `hashnoise` `"hash"`. `"gabor"` is refused as not built, any other
//!   name as unknown.
//! - The domain: `(x)`, `(x, y)`, `(p)` or `(p, t)` (ints widen); periodic forms add as many
//!   periods after it, of the same shapes.
//! - The result is a float, or a vector where the call is assigned to a triple (OSL's
//!   overloading by return type).
//! - Periodic Perlin noise wraps its lattice (OSL's `HashScalarPeriodic`: periods `max(1,
//!   ifloor(p))`); periodic cell noise wraps the coordinates first (OSL's
//!   `PeriodicCellNoise`: `s − P·floor(s/P)` with `P = max(1, floor(p))`), here IR
//!   arithmetic before the cell intrinsic. Periodic hash and simplex noise are refused, as
//!   OSL refuses them (it has no periodic form of either).
//!
//! It must not hold the generators' arithmetic (the ops module's).

use super::{Lower, Ty, Val};
use crate::source::Span;
use shadenet_graph::Type;
use shadenet_graph::ir::{Builder, Intrinsic, UnOp, Value};

/// A noise family.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Family {
    /// Perlin noise, signed or not.
    Perlin(bool),
    /// Cell noise.
    Cell,
    /// Hash noise.
    Hash,
    /// Simplex noise, signed or not.
    Simplex(bool),
}

impl Family {
    /// The family a generator name stands for, or why there is none.
    fn of(generator: &str) -> Result<Family, String> {
        Ok(match generator {
            "perlin" | "snoise" => Family::Perlin(true),
            "uperlin" | "noise" => Family::Perlin(false),
            "cell" | "cellnoise" => Family::Cell,
            "hash" | "hashnoise" => Family::Hash,
            "simplex" => Family::Simplex(true),
            "usimplex" => Family::Simplex(false),
            "gabor" => return Err("gabor noise is not built yet".into()),
            other => {
                return Err(format!(
                    "unknown noise generator \"{other}\" (OSL's: perlin, uperlin, cell, hash, simplex, usimplex, gabor)"
                ));
            }
        })
    }

    /// The intrinsic of this family for a float or vector result in `dim` dimensions
    /// (periodic Perlin where `periodic`).
    fn intrinsic(self, vector: bool, dim: usize, periodic: bool) -> Intrinsic {
        use Intrinsic as I;
        let forms = match (self, periodic) {
            (Family::Perlin(_), false) => [
                [I::OslPerlin1, I::OslPerlin2, I::OslPerlin3, I::OslPerlin4],
                [
                    I::OslVPerlin1,
                    I::OslVPerlin2,
                    I::OslVPerlin3,
                    I::OslVPerlin4,
                ],
            ],
            (Family::Perlin(_), true) => [
                [
                    I::OslPPerlin1,
                    I::OslPPerlin2,
                    I::OslPPerlin3,
                    I::OslPPerlin4,
                ],
                [
                    I::OslVPPerlin1,
                    I::OslVPPerlin2,
                    I::OslVPPerlin3,
                    I::OslVPPerlin4,
                ],
            ],
            (Family::Cell, _) => [
                [I::OslCell1, I::OslCell2, I::OslCell3, I::OslCell4],
                [I::OslVCell1, I::OslVCell2, I::OslVCell3, I::OslVCell4],
            ],
            (Family::Hash, _) => [
                [I::OslHash1, I::OslHash2, I::OslHash3, I::OslHash4],
                [I::OslVHash1, I::OslVHash2, I::OslVHash3, I::OslVHash4],
            ],
            (Family::Simplex(_), _) => [
                [
                    I::OslSimplex1,
                    I::OslSimplex2,
                    I::OslSimplex3,
                    I::OslSimplex4,
                ],
                [
                    I::OslVSimplex1,
                    I::OslVSimplex2,
                    I::OslVSimplex3,
                    I::OslVSimplex4,
                ],
            ],
        };
        forms[usize::from(vector)][dim - 1]
    }
}

/// A noise domain's IR operands (`(x, y)` as one vec2) and its dimension.
struct Domain {
    operands: Vec<Value>,
    dim: usize,
}

impl<'a> Lower<'a> {
    /// `noise`, `snoise`, `cellnoise`, `hashnoise`, `pnoise`, `psnoise` on `args` (see the
    /// module doc); a float, or a vector where `want` is a triple.
    pub(crate) fn osl_noise(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
        span: Span,
        want: Option<Ty>,
    ) -> Val {
        let out_ty = match want {
            Some(t) if t.is_triple() => t,
            _ => Ty::Float,
        };
        let periodic = name == "pnoise" || name == "psnoise";
        let (generator, rest, gen_at) = match args.split_first() {
            Some(((Val::Str(g), at), rest)) if name == "noise" || name == "pnoise" => {
                (g.as_str(), rest, Some(*at))
            }
            _ => {
                let g = match name {
                    "noise" | "pnoise" => "uperlin",
                    "snoise" | "psnoise" => "perlin",
                    "cellnoise" => "cell",
                    _ => "hash",
                };
                (g, args, None)
            }
        };
        let family = match Family::of(generator) {
            Ok(f) => f,
            Err(why) => {
                self.error(format!("`{name}`: {why}"), gen_at.unwrap_or(span), "here");
                return Self::poison(b, out_ty);
            }
        };
        if periodic && matches!(family, Family::Hash | Family::Simplex(_)) {
            self.error(
                format!(
                    "`{name}`: OSL has no periodic \"{generator}\" noise (periodic generators: perlin, uperlin, cell)"
                ),
                gen_at.unwrap_or(span),
                "here",
            );
            return Self::poison(b, out_ty);
        }
        let Some((vals, varying)) = self.noise_numbers(b, name, rest) else {
            return Self::poison(b, out_ty);
        };
        let parts = if periodic {
            let (d, p) = vals.split_at(vals.len() / 2);
            match (domain(b, d), domain(b, p)) {
                (Some(d), Some(p)) if vals.len() % 2 == 0 && d.dim == p.dim => Some((d, Some(p))),
                _ => None,
            }
        } else {
            domain(b, &vals).map(|d| (d, None))
        };
        let Some((domain, periods)) = parts else {
            let periods = if periodic {
                ", each followed by as many periods"
            } else {
                ""
            };
            self.error(
                format!("`{name}` takes (float x), (float x, float y), (point p) or (point p, float t){periods}, after an optional generator name"),
                span,
                "wrong arguments",
            );
            return Self::poison(b, out_ty);
        };
        let vector = out_ty != Ty::Float;
        let v = match (family, periods) {
            (Family::Cell, Some(p)) => {
                // OSL's PeriodicCellNoise: the coordinates wrapped, then cell noise.
                let wrapped: Vec<Value> = domain
                    .operands
                    .iter()
                    .zip(&p.operands)
                    .map(|(s, per)| wrap(b, *s, *per))
                    .collect();
                b.call(family.intrinsic(vector, domain.dim, false), &wrapped)
            }
            (_, periods) => {
                let mut operands = domain.operands.clone();
                operands.extend(periods.iter().flat_map(|p| p.operands.clone()));
                b.call(
                    family.intrinsic(vector, domain.dim, periods.is_some()),
                    &operands,
                )
            }
        };
        let v = match family {
            Family::Perlin(false) | Family::Simplex(false) => unsigned(b, v, vector),
            _ => v,
        };
        let v = if vector && out_ty == Ty::Color {
            b.retype(Type::Color, v)
        } else {
            v
        };
        Val::V {
            v,
            ty: out_ty,
            varying,
        }
    }

    /// The numeric arguments of a noise call (ints as floats) and whether any varies;
    /// `None` after an error naming the one that is not a number.
    fn noise_numbers(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
    ) -> Option<(Vec<(Value, Ty)>, bool)> {
        let mut vals = Vec::new();
        let mut varying = false;
        for (v, at) in args {
            let Val::V { v, ty, varying: vy } = v else {
                self.error(
                    format!("`{name}` takes numbers and points"),
                    *at,
                    "not a number",
                );
                return None;
            };
            varying |= vy;
            let (v, ty) = match ty {
                Ty::Int => (b.convert(Type::Float, *v), Ty::Float),
                _ => (*v, *ty),
            };
            vals.push((v, ty));
        }
        Some((vals, varying))
    }
}

/// The domain `vals` give: `(x)`, `(x, y)` (one vec2), `(p)` or `(p, t)`.
fn domain(b: &mut Builder, vals: &[(Value, Ty)]) -> Option<Domain> {
    Some(match vals {
        [(x, Ty::Float)] => Domain {
            operands: vec![*x],
            dim: 1,
        },
        [(x, Ty::Float), (y, Ty::Float)] => Domain {
            operands: vec![b.construct(Type::Vec2, &[*x, *y])],
            dim: 2,
        },
        [(p, t)] if t.is_geometric() => Domain {
            operands: vec![*p],
            dim: 3,
        },
        [(p, t), (w, Ty::Float)] if t.is_geometric() => Domain {
            operands: vec![*p, *w],
            dim: 4,
        },
        _ => return None,
    })
}

/// OSL's unsigned Perlin or simplex noise from the signed: `0.5 · (n + 1)`.
fn unsigned(b: &mut Builder, v: Value, vector: bool) -> Value {
    let ty = if vector { Type::Vec3 } else { Type::Float };
    let one = b.float(1.0);
    let one = b.splat_to(ty, one);
    let half = b.float(0.5);
    let half = b.splat_to(ty, half);
    let s = b.add(v, one);
    b.mul(half, s)
}

/// OSL's `wrap(s, period)` (component-wise): `s − P·floor(s/P)` with `P = max(1,
/// floor(period))`.
fn wrap(b: &mut Builder, s: Value, period: Value) -> Value {
    let ty = b.ty(s);
    let p = b.unary(UnOp::Floor, period);
    let one = b.float(1.0);
    let one = b.splat_to(ty, one);
    let p = b.max(p, one);
    let q = b.div(s, p);
    let q = b.unary(UnOp::Floor, q);
    let k = b.mul(p, q);
    b.sub(s, k)
}
