//! The surface lowering (DESIGN §3, §12): a material's closure turned into the radiance it
//! sends to the viewer, with one part per render component — a path tracer's step.
//!
//! - **Direct light** (next-event estimation): one light loop; for each light sample `L`
//!   each lobe adds `weight · eval(wo, L) · Cl · visible · w_L` to its component, with the
//!   power heuristic `w_L = p_L² / (p_L² + p_B²)` between the loop's density `p_L`
//!   (`light.pdf`, 0 for point, spot and distant lights, whose weight is then 1) and the
//!   closure's sampling density `p_B` of `L`. `eval` is `f · |cos θi|`, so transmission
//!   lobes take light from behind the surface.
//! - **Indirect light** (BSDF sampling): one direction `wi` drawn from the closure with
//!   the `rand` stream (`x, y` the direction, `z` the lobe), traced as a `diffuse` ray when a
//!   diffuse lobe drew it, else as `reflection` or `refraction` by the side it leaves on,
//!   with its density, so the renderer weights the light sources it reaches by `p_B² /
//!   (p_B² + p_L²)`: together the two estimators count each light once. Each lobe's share
//!   `weight · eval(wo, wi) / p_B · L(wi)` goes to its component. From depth
//!   [`ROULETTE_DEPTH`] on the path continues with probability `q = min(max channel of the
//!   sample weight, 1)` (Russian roulette, `rand.w`), its light divided by `q`.
//! - **Ambient light** (`indirect`): `Σ weight · albedo(wo) · La` for ambient lights.
//! - **Emission** (`emission`): the EDF's radiance.
//! - **Cutout opacity** `o < 1`: every part is scaled by `o` and the rest, `(1 − o) ·
//!   trace(I)` (a refraction-type ray straight through), is part `transmission`.
//!
//! The builder's [`LightStrategy`] (a lowering option) can drop either estimator for area
//! lights and the environment: `light` gives the light loop weight 1 (the renderer then
//! gives BSDF-sampled rays' hits on those lights nothing), `bsdf` keeps only delta lights in
//! the loop, with weight 1 (BSDF-sampled rays then take their whole light). The
//! continuation is the same in every strategy: it carries the indirect light.
//!
//! Each component's work sits inside `component_enabled(k)`. It owns the light loop of
//! closures; it must not know lobe formulas or MaterialX nodes.

use super::math::{f, gt, lt, one_minus, scale};
use super::{Closure, Lobe};
use crate::ir::{BinOp, Builder, RAY_DIFFUSE, RAY_REFLECTION, RAY_REFRACTION, Stream, Value};
use crate::nodes::LowVal;
use crate::transport::LightStrategy;
use crate::types::Type;

/// The render component of ambient light.
pub const INDIRECT: &str = "indirect";
/// The render component of emitted light.
pub const EMISSION: &str = "emission";
/// The render component of light through cutouts and transmission lobes.
pub const TRANSMISSION: &str = "transmission";
/// The ray depth from which paths are continued by Russian roulette.
pub const ROULETTE_DEPTH: i32 = 3;

/// The radiance `closure` sends towards the viewer (color) with its component parts.
pub fn surface(b: &mut Builder, closure: &Closure) -> LowVal {
    let wo = crate::mtlx::atoms_closure::view_dir(b);
    let mut comps: Vec<&'static str> = Vec::new();
    for l in &closure.lobes {
        if !comps.contains(&l.component) {
            comps.push(l.component);
        }
    }
    let groups: Vec<Vec<&Lobe>> = comps
        .iter()
        .map(|c| closure.lobes.iter().filter(|l| l.component == *c).collect())
        .collect();
    let mut parts: Vec<(u8, Value)> = Vec::new();
    if !closure.lobes.is_empty() {
        let direct = direct(b, closure, &comps, &groups, wo);
        let indirect = continuation(b, closure, &comps, &groups, wo);
        for (k, name) in comps.iter().enumerate() {
            let v = b.add(direct[k], indirect[k]);
            parts.push((b.component(name), v));
        }
        let v = enabled(b, INDIRECT, |b| {
            let a = closure.albedo(b, wo);
            let la = b.ambient();
            b.mul(a, la)
        });
        add_part(&mut parts, b, INDIRECT, v);
    }
    if let Some(e) = closure.emission {
        let v = enabled(b, EMISSION, |_| e);
        add_part(&mut parts, b, EMISSION, v);
    }
    if let Some(o) = closure.opacity {
        cutout(b, &mut parts, o);
    }
    crate::nodes::lowering::sum_parts(b, Type::Color, parts)
}

/// Adds `v` to component `name`'s part (a new part if there is none).
fn add_part(parts: &mut Vec<(u8, Value)>, b: &mut Builder, name: &str, v: Value) {
    let k = b.component(name);
    match parts.iter_mut().find(|(c, _)| *c == k) {
        Some((_, p)) => *p = b.add(*p, v),
        None => parts.push((k, v)),
    }
}

/// The light loop: per component, the lobes' MIS-weighted direct light.
fn direct(
    b: &mut Builder,
    closure: &Closure,
    comps: &[&'static str],
    groups: &[Vec<&Lobe>],
    wo: Value,
) -> Vec<Value> {
    let p = b.stream(Stream::P);
    let on: Vec<Value> = comps.iter().map(|c| b.component_enabled(c)).collect();
    let strategy = b.light_strategy();
    b.illuminance(p, |b, l, cl| match strategy {
        LightStrategy::Mis => {
            let vis = b.light_visible();
            let lp = b.light_pdf();
            let bp = closure.eval(b, wo, l).pdf;
            let w = light_weight(b, lp, bp);
            let k = b.mul(vis, w);
            let lit = scale(b, cl, k);
            lit_lobes(b, groups, &on, wo, l, lit)
        }
        LightStrategy::Light => {
            let vis = b.light_visible();
            let lit = scale(b, cl, vis);
            lit_lobes(b, groups, &on, wo, l, lit)
        }
        LightStrategy::Bsdf => {
            // Only delta lights (`light.pdf` = 0, which no BSDF sample reaches) light the
            // closure here; the shadow ray of any other light is never traced.
            let lp = b.light_pdf();
            let zero = f(b, 0.0);
            let delta = b.binary(BinOp::Le, lp, zero);
            b.if_(
                delta,
                |b| {
                    let vis = b.light_visible();
                    let lit = scale(b, cl, vis);
                    lit_lobes(b, groups, &on, wo, l, lit)
                },
                |b| groups.iter().map(|_| b.zero(Type::Color)).collect(),
            )
        }
    })
}

/// Per component, `Σ weight · eval(wo, l) · lit` over its lobes (0 where it is off).
fn lit_lobes(
    b: &mut Builder,
    groups: &[Vec<&Lobe>],
    on: &[Value],
    wo: Value,
    l: Value,
    lit: Value,
) -> Vec<Value> {
    groups
        .iter()
        .zip(on)
        .map(|(lobes, on)| {
            let r = b.if_(
                *on,
                |b| {
                    let mut sum = b.zero(Type::Color);
                    for lobe in lobes {
                        let e = lobe.eval(b, wo, l);
                        let v = b.mul(lobe.weight, e.value);
                        sum = b.add(sum, v);
                    }
                    vec![b.mul(sum, lit)]
                },
                |b| vec![b.zero(Type::Color)],
            );
            r[0]
        })
        .collect()
}

/// The power heuristic's weight of a light sample of density `l` against BSDF sampling of
/// density `c`: `l² / (l² + c²)`; 1 for a delta light (`l = 0`, which no BSDF sample can
/// reach) and where the BSDF cannot draw the direction (`c = 0`).
fn light_weight(b: &mut Builder, l: Value, c: Value) -> Value {
    let l2 = b.mul(l, l);
    let c2 = b.mul(c, c);
    let s = b.add(l2, c2);
    let w = b.div(l2, s);
    let zero = f(b, 0.0);
    let delta = b.binary(BinOp::Le, l, zero);
    let none = b.binary(BinOp::Le, c, zero);
    let full = b.binary(BinOp::Or, delta, none);
    let one = f(b, 1.0);
    b.select(full, one, w)
}

/// The BSDF-sampled continuation: per component, the lobes' share of the light along one
/// sampled direction (0 in every component that is off).
fn continuation(
    b: &mut Builder,
    closure: &Closure,
    comps: &[&'static str],
    groups: &[Vec<&Lobe>],
    wo: Value,
) -> Vec<Value> {
    let on: Vec<Value> = comps.iter().map(|c| b.component_enabled(c)).collect();
    let mut any = b.boolean(false);
    for o in &on {
        any = b.binary(BinOp::Or, any, *o);
    }
    b.if_(
        any,
        |b| {
            let rand = b.stream(Stream::Rand);
            let xyz = [b.extract(rand, 0), b.extract(rand, 1), b.extract(rand, 2)];
            let u = b.construct(Type::Vec3, &xyz);
            let (s, diffuse) = closure.sample_classified(b, wo, u);
            let q = roulette(b, s.weight);
            let uw = b.extract(rand, 3);
            let survive = lt(b, uw, q);
            let zero = f(b, 0.0);
            let has = gt(b, s.pdf, zero);
            let go = b.binary(BinOp::And, has, survive);
            let light = b.if_(
                go,
                |b| vec![trace_kind(b, s.wi, s.pdf, diffuse, wo)],
                |b| vec![b.zero(Type::Color)],
            )[0];
            let inv = b.mul(s.pdf, q);
            groups
                .iter()
                .zip(&on)
                .map(|(lobes, on)| {
                    b.if_(
                        *on,
                        |b| {
                            let mut sum = b.zero(Type::Color);
                            for lobe in lobes {
                                let e = lobe.eval(b, wo, s.wi);
                                let v = b.mul(lobe.weight, e.value);
                                sum = b.add(sum, v);
                            }
                            let share = super::math::div_pdf(b, sum, inv);
                            vec![b.mul(share, light)]
                        },
                        |b| vec![b.zero(Type::Color)],
                    )[0]
                })
                .collect()
        },
        |b| comps.iter().map(|_| b.zero(Type::Color)).collect(),
    )
}

/// The probability of continuing a path: 1 before [`ROULETTE_DEPTH`], then the largest
/// channel of the sample weight clamped to [0.05, 1].
fn roulette(b: &mut Builder, weight: Value) -> Value {
    let (r, g, bl) = (
        b.extract(weight, 0),
        b.extract(weight, 1),
        b.extract(weight, 2),
    );
    let m = b.max(r, g);
    let m = b.max(m, bl);
    let (lo, one) = (f(b, 0.05), f(b, 1.0));
    let q = b.clamp(m, lo, one);
    let depth = b.stream(Stream::RayDepth);
    let k = b.int(ROULETTE_DEPTH);
    let deep = b.binary(BinOp::Ge, depth, k);
    b.select(deep, q, one)
}

/// Traces the continuation: a `diffuse` ray when a diffuse lobe drew it, else
/// `refraction` when it leaves through the surface (`wi` and `wo` on opposite sides of
/// `N`), else `reflection`.
fn trace_kind(b: &mut Builder, wi: Value, pdf: Value, diffuse: Value, wo: Value) -> Value {
    let n = b.stream(Stream::N);
    let a = b.dot(wi, n);
    let c = b.dot(wo, n);
    let ac = b.mul(a, c);
    let zero = f(b, 0.0);
    let through = lt(b, ac, zero);
    b.if_(
        diffuse,
        |b| vec![b.trace_sampled(wi, RAY_DIFFUSE, pdf)],
        |b| {
            b.if_(
                through,
                |b| vec![b.trace_sampled(wi, RAY_REFRACTION, pdf)],
                |b| vec![b.trace_sampled(wi, RAY_REFLECTION, pdf)],
            )
        },
    )[0]
}

/// Scales every part by the opacity `o` and adds the light through the cutout.
fn cutout(b: &mut Builder, parts: &mut Vec<(u8, Value)>, o: Value) {
    for (_, v) in parts.iter_mut() {
        *v = scale(b, *v, o);
    }
    let through = enabled(b, TRANSMISSION, |b| {
        // Only where some light passes: a constant opacity of 1 folds the ray away.
        let one = f(b, 1.0);
        let thin = lt(b, o, one);
        b.if_(
            thin,
            |b| {
                let i = b.stream(Stream::I);
                let t = b.trace(i, RAY_REFRACTION);
                let rest = one_minus(b, o);
                vec![scale(b, t, rest)]
            },
            |b| vec![b.zero(Type::Color)],
        )[0]
    });
    add_part(parts, b, TRANSMISSION, through);
}

/// `f()` where component `name` is enabled, else black.
fn enabled(b: &mut Builder, name: &str, f: impl FnOnce(&mut Builder) -> Value) -> Value {
    let on = b.component_enabled(name);
    let r = b.if_(on, |b| vec![f(b)], |b| vec![b.zero(Type::Color)]);
    r[0]
}
