//! The surface lowering (DESIGN §3, §12): a material's closure turned into the radiance it
//! sends to the viewer, with one part per render component.
//!
//! - Direct light: per component, a light loop over the light samples summing each lobe's
//!   `weight · eval(wo, L) · Cl · visible` (`eval` is `f · |cos θi|`, so transmission lobes
//!   take light from behind the surface). Each component's loop sits inside
//!   `component_enabled(k)`, so a pass without it does none of its work.
//! - Ambient light (`indirect`): `Σ weight · albedo(wo) · La`, the light a uniform ambient
//!   radiance `La` reflects.
//! - Emission (`emission`): the EDF's radiance.
//! - Cutout opacity `o < 1`: every part is scaled by `o` and the rest, `(1 − o) ·
//!   trace(I)` (a refraction-type ray straight through), is part `transmission`.
//!
//! It owns the light loop of closures; it must not know lobe formulas or MaterialX nodes.

use super::Closure;
use super::math::{one_minus, scale};
use crate::ir::{Builder, RAY_REFRACTION, Stream, Value};
use crate::nodes::LowVal;
use crate::types::Type;

/// The render component of ambient light.
pub const INDIRECT: &str = "indirect";
/// The render component of emitted light.
pub const EMISSION: &str = "emission";
/// The render component of light through cutouts and transmission lobes.
pub const TRANSMISSION: &str = "transmission";

/// The radiance `closure` sends towards the viewer (color) with its component parts.
pub fn surface(b: &mut Builder, closure: &Closure) -> LowVal {
    let wo = crate::mtlx::atoms_closure::view_dir(b);
    let p = b.stream(Stream::P);
    let mut parts: Vec<(u8, Value)> = Vec::new();
    let mut comps: Vec<&'static str> = Vec::new();
    for l in &closure.lobes {
        if !comps.contains(&l.component) {
            comps.push(l.component);
        }
    }
    for name in comps {
        let lobes: Vec<_> = closure
            .lobes
            .iter()
            .filter(|l| l.component == name)
            .collect();
        let v = enabled(b, name, |b| {
            let sums = b.illuminance(p, |b, l, cl| {
                let vis = b.light_visible();
                let mut sum = b.zero(Type::Color);
                for lobe in &lobes {
                    let e = lobe.eval(b, wo, l);
                    let v = b.mul(lobe.weight, e.value);
                    sum = b.add(sum, v);
                }
                let lit = b.mul(sum, cl);
                vec![scale(b, lit, vis)]
            });
            sums[0]
        });
        parts.push((b.component(name), v));
    }
    if !closure.lobes.is_empty() {
        let v = enabled(b, INDIRECT, |b| {
            let a = closure.albedo(b, wo);
            let la = b.ambient();
            b.mul(a, la)
        });
        parts.push((b.component(INDIRECT), v));
    }
    if let Some(e) = closure.emission {
        let v = enabled(b, EMISSION, |_| e);
        parts.push((b.component(EMISSION), v));
    }
    if let Some(o) = closure.opacity {
        for (_, v) in parts.iter_mut() {
            *v = scale(b, *v, o);
        }
        let k = b.component(TRANSMISSION);
        let through = enabled(b, TRANSMISSION, |b| {
            // Only where some light passes: a constant opacity of 1 folds the ray away.
            let one = b.float(1.0);
            let thin = super::math::lt(b, o, one);
            let r = b.if_(
                thin,
                |b| {
                    let i = b.stream(Stream::I);
                    let t = b.trace(i, RAY_REFRACTION);
                    let rest = one_minus(b, o);
                    vec![scale(b, t, rest)]
                },
                |b| vec![b.zero(Type::Color)],
            );
            r[0]
        });
        match parts.iter_mut().find(|(c, _)| *c == k) {
            Some((_, v)) => *v = b.add(*v, through),
            None => parts.push((k, through)),
        }
    }
    crate::nodes::lowering::sum_parts(b, Type::Color, parts)
}

/// `f()` where component `name` is enabled, else black.
fn enabled(b: &mut Builder, name: &str, f: impl FnOnce(&mut Builder) -> Value) -> Value {
    let on = b.component_enabled(name);
    let r = b.if_(on, |b| vec![f(b)], |b| vec![b.zero(Type::Color)]);
    r[0]
}
