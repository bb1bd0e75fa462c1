//! A closure as a lobe list, and the list operations the closure nodes lower to (`mix`,
//! `add`, `multiply`, `layer`), plus the closure-wide `eval` and `sample` that the surface
//! lowering calls. It owns how lobes combine; each lobe's formulas stay in its own file.
//!
//! Sampling picks one lobe with probability proportional to the luminance of `weight ·
//! albedo(wo)` (the chance of the light it reflects) using `u.z`, which is then rescaled to
//! [0, 1) within the chosen lobe's share so the lobe may use it again (a dielectric picks
//! reflection or transmission with it). The closure's density of a direction is the
//! mixture `Σ p_k pdf_k(wi)` and the returned weight is the whole closure's `Σ w_k f_k
//! |cos θi|` over that density, so every lobe's light is counted whichever lobe drew the
//! direction (one-sample MIS over lobes with the balance heuristic).

use super::math::{div_pdf, f, f as f_, lt, luminance, one_minus, pos, scale, vec3};
use super::{Eval, Lobe, Sample};
use crate::ir::{BinOp, Builder, Value};
use crate::types::{ConstValue, Type};

/// A BSDF and EDF as lists: the scattering lobes and the emitted radiance.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Closure {
    /// The scattering lobes (a BSDF); empty for black.
    pub lobes: Vec<Lobe>,
    /// Emitted radiance towards the viewer (color; an EDF), `None` for none.
    pub emission: Option<Value>,
    /// Cutout opacity (float, a `surface`'s `opacity`); `None` is opaque. Where it is below
    /// 1 the rest of the light passes straight through the surface.
    pub opacity: Option<Value>,
}

impl Closure {
    /// A closure of one lobe.
    pub fn lobe(lobe: Lobe) -> Closure {
        Closure {
            lobes: vec![lobe],
            ..Closure::default()
        }
    }

    /// A closure that only emits `radiance` (color).
    pub fn emitter(radiance: Value) -> Closure {
        Closure {
            emission: Some(radiance),
            ..Closure::default()
        }
    }

    /// Every lobe weight and the emission multiplied by `k` (a float or a color).
    pub fn scaled(&self, b: &mut Builder, k: Value) -> Closure {
        let k = b.splat_to(Type::Color, k);
        // A weight that is 0 stays exactly 0 whatever `k` is, and a factor that is 0 makes
        // it exactly 0 whatever the weight is (`x · 0` does not fold: NaN, −0), so a lobe
        // whose weight or factor folds to 0 is deleted after scaling.
        let k_live = nonzero(b, k);
        let lobes = self
            .lobes
            .iter()
            .map(|l| {
                let live = l.nonzero(b);
                let live = b.binary(BinOp::And, live, k_live);
                let w = b.mul(l.weight, k);
                let zero = b.zero(Type::Color);
                Lobe {
                    weight: b.select(live, w, zero),
                    ..l.clone()
                }
            })
            .collect();
        let emission = self.emission.map(|e| b.mul(e, k));
        Closure {
            lobes,
            emission,
            opacity: self.opacity,
        }
    }

    /// The closure without its unbuilt lobes ([`Lobe::unbuilt`]) whose weight is the
    /// constant 0 in `p` (the program being built; parameters at their defaults,
    /// [`crate::opt::fold::constant`]); `Err` with the reasons of those whose weight is not.
    pub fn without_unbuilt(&self, p: &crate::ir::Program) -> Result<Closure, String> {
        let mut lobes = Vec::with_capacity(self.lobes.len());
        let mut refused = Vec::new();
        for l in &self.lobes {
            let Some(why) = &l.unbuilt else {
                lobes.push(l.clone());
                continue;
            };
            match crate::opt::fold::constant(p, l.weight) {
                Some(ConstValue::Color(c)) if c.iter().all(|x| *x == 0.0) => {}
                Some(c) => refused.push(format!("{why} (its lobe's weight is {c})")),
                None => refused.push(format!(
                    "{why} (its lobe's weight is not a compile-time 0; set the weight that mixes it in to 0)"
                )),
            }
        }
        if !refused.is_empty() {
            return Err(refused.join("; "));
        }
        Ok(Closure {
            lobes,
            ..self.clone()
        })
    }

    /// `a + c`: both lists, emissions summed; the opacity of whichever has one (the
    /// product where both do).
    pub fn add(b: &mut Builder, a: &Closure, c: &Closure) -> Closure {
        let mut lobes = a.lobes.clone();
        lobes.extend(c.lobes.iter().cloned());
        let emission = match (a.emission, c.emission) {
            (Some(x), Some(y)) => Some(b.add(x, y)),
            (x, y) => x.or(y),
        };
        let opacity = match (a.opacity, c.opacity) {
            (Some(x), Some(y)) => Some(b.mul(x, y)),
            (x, y) => x.or(y),
        };
        Closure {
            lobes,
            emission,
            opacity,
        }
    }

    /// MaterialX `mix(fg, bg, t)`: `fg · t + bg · (1 − t)` (`t` a float).
    pub fn mix(b: &mut Builder, bg: &Closure, fg: &Closure, t: Value) -> Closure {
        let om = one_minus(b, t);
        let fg = fg.scaled(b, t);
        let bg = bg.scaled(b, om);
        Closure::add(b, &bg, &fg)
    }

    /// MaterialX `layer(top, base)` seen from `wo` (world, unit): the top unchanged, the base
    /// scaled by `1 − Σ_top w · albedo(wo)` (clamped at 0), the light the top lets through.
    /// Emission of the base is scaled the same way.
    pub fn layer(b: &mut Builder, top: &Closure, base: &Closure, wo: Value) -> Closure {
        let through = top.albedo(b, wo);
        let through = one_minus(b, through);
        let zero = b.zero(Type::Color);
        let through = b.max(through, zero);
        let base = base.scaled(b, through);
        Closure::add(b, top, &base)
    }

    /// `Σ w · albedo(wo)` (color) over the lobes.
    pub fn albedo(&self, b: &mut Builder, wo: Value) -> Value {
        let mut sum = b.zero(Type::Color);
        for l in &self.lobes {
            let a = l.albedo(b, wo);
            sum = b.add(sum, a);
        }
        sum
    }

    /// The closure's value `Σ w f |cos θi|` and mixture density for world directions `wo`,
    /// `wi` (unit), with the selection probabilities of [`Closure::sample`].
    pub fn eval(&self, b: &mut Builder, wo: Value, wi: Value) -> Eval {
        let probs = self.selection(b, wo);
        self.eval_with(b, &probs, wo, wi)
    }

    fn eval_with(&self, b: &mut Builder, probs: &[Value], wo: Value, wi: Value) -> Eval {
        let mut value = b.zero(Type::Color);
        let mut pdf = f(b, 0.0);
        for (l, p) in self.lobes.iter().zip(probs) {
            let e = l.eval(b, wo, wi);
            let v = b.mul(l.weight, e.value);
            value = b.add(value, v);
            let q = b.mul(*p, e.pdf);
            pdf = b.add(pdf, q);
        }
        Eval { value, pdf }
    }

    /// The probability of sampling each lobe: `lum(w · albedo(wo))` normalized (all 0 when
    /// the closure reflects nothing).
    pub fn selection(&self, b: &mut Builder, wo: Value) -> Vec<Value> {
        let lum: Vec<Value> = self
            .lobes
            .iter()
            .map(|l| {
                let a = l.albedo(b, wo);
                let y = luminance(b, a);
                pos(b, y)
            })
            .collect();
        let mut total = f(b, 0.0);
        for y in &lum {
            total = b.add(total, *y);
        }
        lum.iter().map(|y| b.div(*y, total)).collect()
    }

    /// A direction drawn from the closure with uniform numbers `u` (vec3), world space.
    /// `pdf = 0` (and weight 0) where the closure reflects nothing.
    pub fn sample(&self, b: &mut Builder, wo: Value, u: Value) -> Sample {
        self.sample_classified(b, wo, u).0
    }

    /// [`Closure::sample`] and whether the lobe that drew the direction is diffuse (bool;
    /// [`super::LobeKind::is_diffuse`]): the renderer's ray type for the continuation.
    pub fn sample_classified(&self, b: &mut Builder, wo: Value, u: Value) -> (Sample, Value) {
        let probs = self.selection(b, wo);
        let (u1, u2, u3) = (b.extract(u, 0), b.extract(u, 1), b.extract(u, 2));
        let mut wi = b.zero(Type::Vec3);
        let mut diffuse = b.boolean(false);
        let mut lo = f(b, 0.0);
        for (l, p) in self.lobes.iter().zip(&probs) {
            let hi = b.add(lo, *p);
            let rel = b.sub(u3, lo);
            let rel = div_pdf(b, rel, *p);
            let one = f(b, 0.999_999_9);
            let rel = b.min(rel, one);
            let ul = vec3(b, u1, u2, rel);
            let s = l.sample_world(b, wo, ul);
            let ge = lt(b, u3, lo);
            let ge = b.unary(crate::ir::UnOp::Not, ge);
            let below = lt(b, u3, hi);
            let inside = b.binary(crate::ir::BinOp::And, ge, below);
            wi = b.select(inside, s.wi, wi);
            let d = b.boolean(l.kind.is_diffuse());
            diffuse = b.select(inside, d, diffuse);
            lo = hi;
        }
        let e = self.eval_with(b, &probs, wo, wi);
        let weight = div_pdf(b, e.value, e.pdf);
        let s = Sample {
            wi,
            weight,
            pdf: e.pdf,
        };
        (s, diffuse)
    }
}

impl Lobe {
    /// `f()` where the lobe's weight is not zero (any channel), else `zero`: a lobe whose
    /// weight folds to 0 is dead code for the partial evaluator's dead-branch pass, and one
    /// whose weight is 0 at run time costs a branch.
    fn guarded(
        &self,
        b: &mut Builder,
        f: impl FnOnce(&mut Builder) -> Vec<Value>,
        zero: impl FnOnce(&mut Builder) -> Vec<Value>,
    ) -> Vec<Value> {
        let any = self.nonzero(b);
        b.if_(any, f, zero)
    }

    /// Whether any channel of the weight is non-zero (bool; NaN counts as non-zero).
    pub fn nonzero(&self, b: &mut Builder) -> Value {
        nonzero(b, self.weight)
    }

    /// `eval` for world directions (converted to the lobe's frame), unweighted.
    pub fn eval(&self, b: &mut Builder, wo: Value, wi: Value) -> Eval {
        let r = self.guarded(
            b,
            |b| {
                let lo = self.frame.to_local(b, wo);
                let li = self.frame.to_local(b, wi);
                let e = self.kind.eval_sided(b, self.frame.inside, lo, li);
                vec![e.value, e.pdf]
            },
            |b| vec![b.zero(Type::Color), b.float(0.0)],
        );
        Eval {
            value: r[0],
            pdf: r[1],
        }
    }

    /// `sample` with a world-space result, unweighted.
    pub fn sample_world(&self, b: &mut Builder, wo: Value, u: Value) -> Sample {
        let r = self.guarded(
            b,
            |b| {
                let lo = self.frame.to_local(b, wo);
                let s = self.kind.sample_sided(b, self.frame.inside, lo, u);
                vec![self.frame.to_world(b, s.wi), s.weight, s.pdf]
            },
            |b| vec![b.zero(Type::Vec3), b.zero(Type::Color), b.float(0.0)],
        );
        Sample {
            wi: r[0],
            weight: r[1],
            pdf: r[2],
        }
    }

    /// `weight · albedo(wo)` (color) for a world `wo`.
    pub fn albedo(&self, b: &mut Builder, wo: Value) -> Value {
        let r = self.guarded(
            b,
            |b| {
                let lo = self.frame.to_local(b, wo);
                let a = self.kind.albedo_sided(b, self.frame.inside, lo);
                vec![b.mul(self.weight, a)]
            },
            |b| vec![b.zero(Type::Color)],
        );
        r[0]
    }
}

/// Whether any channel of color `c` is non-zero (bool; NaN counts as non-zero).
fn nonzero(b: &mut Builder, c: Value) -> Value {
    let (r, g, bl) = (b.extract(c, 0), b.extract(c, 1), b.extract(c, 2));
    let z = f_(b, 0.0);
    let nr = b.binary(BinOp::Ne, r, z);
    let ng = b.binary(BinOp::Ne, g, z);
    let nb = b.binary(BinOp::Ne, bl, z);
    let any = b.binary(BinOp::Or, nr, ng);
    b.binary(BinOp::Or, any, nb)
}

/// `c · s` for a color `c` and float `s` (re-exported for the surface lowering).
pub fn scale_color(b: &mut Builder, c: Value, s: Value) -> Value {
    scale(b, c, s)
}
