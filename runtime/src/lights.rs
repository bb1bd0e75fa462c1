//! Light samples: what arrives at a shaded point from each light (the light intrinsic that
//! every CPU back end calls).
//!
//! Units as in pbrt: a point or spot light's power is an intensity (W/sr) and arrives as
//! `I / r²`; a distant light's is an irradiance (W/m² perpendicular to it); ambient light is
//! a radiance with no direction, summed by the `ambient` op instead of the light loop.
//!
//! An environment light with an image map is importance-sampled by the map's luminance
//! ([`crate::envmap`]); its distribution is built once, in [`Light::from_desc`], and shared
//! by every clone of the light.
//!
//! A light shader's light ([`LightKind::Shader`]) is evaluated per sample by the evaluator
//! it carries (`crate::light_shader`'s, prepared once when the light is made and shared by
//! every clone): its `Cl` arrives as the program computed it (no `1/r²` is added: the shader
//! divides, as RSL's `pointlight` does).

use crate::envmap::EnvMap;
use shadenet_graph::nodes::shader_light::ShaderLightForm;
use shadenet_graph::nodes::{LightDesc, LightKind};
use shadenet_graph::ops::math;
use shadenet_graph::ops::{self, Real};
use std::sync::Arc;

/// A light as the runtime samples it.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// The light's description (kind, geometry, color × intensity).
    pub desc: LightDesc,
    /// For spot lights: cos of the angle where the cone is fully lit, and where it is dark.
    spot_cos: (f64, f64),
    /// For environment lights with a map: the map prepared for sampling.
    env: Option<Arc<EnvMap>>,
}

impl Light {
    /// Prepares a light for sampling (for an environment map, builds its distribution:
    /// prepare lights once and clone them, which shares it).
    pub fn from_desc(desc: &LightDesc) -> Light {
        let spot_cos = match desc.kind {
            LightKind::Spot {
                cone_angle,
                penumbra_angle,
                ..
            } => {
                let half = 0.5 * cone_angle;
                let (inner, outer) = if penumbra_angle >= 0.0 {
                    (half, half + penumbra_angle)
                } else {
                    (half + penumbra_angle, half)
                };
                let c = |a: f64| shadenet_graph::ops::math::cos(a.clamp(0.0, std::f64::consts::PI));
                (c(inner), c(outer))
            }
            _ => (1.0, 1.0),
        };
        let env = match &desc.kind {
            LightKind::Environment { map: Some(m), .. } => Some(Arc::new(EnvMap::new(m.clone()))),
            _ => None,
        };
        Light {
            desc: desc.clone(),
            spot_cos,
            env,
        }
    }

    /// For an environment light with a map, the map prepared for sampling.
    pub fn env_map(&self) -> Option<&EnvMap> {
        self.env.as_deref()
    }

    /// True for ambient lights (no direction; not part of the light loop).
    pub fn is_ambient(&self) -> bool {
        matches!(self.desc.kind, LightKind::Ambient)
    }
}

/// One light sample: unit direction towards the light, the color arriving, and where a
/// shadow ray must reach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample<F> {
    /// Unit direction from the point towards the light.
    pub l: [F; 3],
    /// Color arriving at the point (intensity / r² for positional lights; an area or
    /// environment sample's share of the Monte Carlo estimate).
    pub cl: [F; 3],
    /// The point on the light (far along `l` for distant and environment lights): the
    /// sample counts only if nothing blocks the segment to it.
    pub to: [F; 3],
    /// The density per solid angle of `l` under this light's sampling times its sample
    /// count (the `light.pdf` op; [`light_pdf`] for a direction); 0 for delta lights.
    pub pdf: F,
}

/// Distance used as "infinitely far" for shadow rays towards distant and environment lights.
pub const FAR: f64 = 1e7;

/// How many samples a light contributes to the light loop per shaded point (0 for ambient
/// light, which has no direction, and for an environment map that is black everywhere,
/// which gives no light).
pub fn sample_count(light: &Light) -> u32 {
    if light.env.as_ref().is_some_and(|e| e.is_black()) {
        return 0;
    }
    match light.desc.kind {
        LightKind::Ambient => 0,
        LightKind::Quad { samples, .. } | LightKind::Environment { samples, .. } => samples.max(1),
        _ => 1,
    }
}

/// Two uniform numbers in [0, 1) for sample `k` of light `light` at a fragment with `seed`
/// (a counter-based hash: deterministic, no state, the same in f32 and f64 runs).
pub fn random2(seed: u32, light: u32, k: u32) -> [f64; 2] {
    let mut h = seed
        .wrapping_mul(0x9e37_79b9)
        .wrapping_add(light.wrapping_mul(0x85eb_ca6b))
        .wrapping_add(k.wrapping_mul(0xc2b2_ae35));
    let mut next = || {
        h ^= h >> 16;
        h = h.wrapping_mul(0x7feb_352d);
        h ^= h >> 15;
        h = h.wrapping_mul(0x846c_a68b);
        h ^= h >> 16;
        let r = (h >> 8) as f64 / (1u32 << 24) as f64;
        h = h.wrapping_add(0x6a09_e667);
        r
    };
    [next(), next()]
}

fn v3<F: Real>(v: [f64; 3]) -> [F; 3] {
    v.map(F::from_f64)
}

/// Sample `k` (of [`sample_count`]) of light number `index` as seen from point `p`, with the
/// fragment's `seed`; `None` for ambient lights. A point at a light's position receives
/// nothing (the total division makes `I / 0 = 0`).
pub fn sample<F: Real>(
    light: &Light,
    index: u32,
    k: u32,
    p: [F; 3],
    seed: u32,
) -> Option<Sample<F>> {
    // A change here goes to `sample_x4` as well (the tests hold the two equal).
    let power: [F; 3] = v3(light.desc.power);
    let far = F::from_f64(FAR);
    let along = |l: [F; 3]| [p[0] + l[0] * far, p[1] + l[1] * far, p[2] + l[2] * far];
    match &light.desc.kind {
        LightKind::Ambient => None,
        LightKind::Distant { direction } => {
            let d: [F; 3] = v3(*direction);
            let l = ops::normalize(d.map(|x| -x));
            Some(Sample {
                l,
                cl: power,
                to: along(l),
                pdf: F::ZERO,
            })
        }
        LightKind::Point { position } => {
            let (l, inv_r2) = towards(v3(*position), p);
            Some(Sample {
                l,
                cl: power.map(|c| c * inv_r2),
                to: v3(*position),
                pdf: F::ZERO,
            })
        }
        LightKind::Quad {
            corner,
            edge_u,
            edge_v,
            samples,
        } => {
            let [s, t] = random2(seed, index, k);
            let (c, eu, ev): ([F; 3], [F; 3], [F; 3]) = (v3(*corner), v3(*edge_u), v3(*edge_v));
            let (s, t) = (F::from_f64(s), F::from_f64(t));
            let q: [F; 3] = std::array::from_fn(|i| c[i] + eu[i] * s + ev[i] * t);
            let n = ops::cross(eu, ev);
            let area = ops::length(&n);
            let n = ops::normalize(n);
            let (l, inv_r2) = towards(q, p);
            // Radiance L_e seen through the sample: E = L_e · cosθ_light · A / r² / N.
            let cos_light = ops::max(-ops::dot(&l, &n), F::ZERO);
            let n_s = F::from_f64((*samples).max(1) as f64);
            let w = ops::div(cos_light * area * inv_r2, n_s);
            // Solid-angle density of the uniform area sample, r² / (cos θ_light · A), times
            // the sample count: 1/w (0 where the sample sees the light edge-on or from behind).
            Some(Sample {
                l,
                cl: power.map(|c| c * w),
                to: q,
                pdf: ops::div(F::ONE, w),
            })
        }
        LightKind::Environment { samples, .. } if light.env.is_some() => {
            // Importance-sampled by the map: radiance / (pdf · N), in f64.
            let env = light.env.as_deref()?;
            let [u, v] = random2(seed, index, k);
            let (d, pdf, rad) = env.sample_with_radiance([u, v])?;
            let n = (*samples).max(1) as f64;
            let w = ops::div(1.0, pdf * n);
            let l: [F; 3] = v3(d);
            Some(Sample {
                l,
                cl: v3(std::array::from_fn(|c| light.desc.power[c] * rad[c] * w)),
                to: along(l),
                pdf: F::from_f64(pdf * n),
            })
        }
        LightKind::Environment { samples, .. } => {
            // Uniform directions on the sphere: pdf 1/(4π).
            let [u, v] = random2(seed, index, k);
            let z = 1.0 - 2.0 * u;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f64::consts::PI * v;
            let l: [F; 3] = v3([r * math::cos(phi), r * math::sin(phi), z]);
            let w = F::from_f64(4.0 * std::f64::consts::PI / (*samples).max(1) as f64);
            Some(Sample {
                l,
                cl: power.map(|c| c * w),
                to: along(l),
                pdf: ops::div(F::ONE, w),
            })
        }
        LightKind::Shader { program } => {
            let pf = p.map(|x| x.to_f64() as f32);
            let (cl, at) = program.eval().eval(pf);
            let wide = |v: [f32; 3]| v.map(|x| F::from_f64(x as f64));
            let (cl, at) = (wide(cl), wide(at));
            match program.form() {
                ShaderLightForm::Positional => Some(Sample {
                    l: towards(at, p).0,
                    cl,
                    to: at,
                    pdf: F::ZERO,
                }),
                ShaderLightForm::Directional => {
                    let l = ops::normalize(at.map(|x| -x));
                    Some(Sample {
                        l,
                        cl,
                        to: along(l),
                        pdf: F::ZERO,
                    })
                }
                ShaderLightForm::Ambient => None,
            }
        }
        LightKind::Spot {
            position,
            direction,
            dropoff,
            ..
        } => {
            let (l, inv_r2) = towards(v3(*position), p);
            let axis: [F; 3] = ops::normalize(v3(*direction));
            let cos_a = -ops::dot(&l, &axis);
            let cone = spot_cone(light, cos_a);
            let fall = if *dropoff > 0.0 {
                ops::pow(ops::max(cos_a, F::ZERO), F::from_f64(*dropoff))
            } else {
                F::ONE
            };
            let k = cone * fall * inv_r2;
            Some(Sample {
                l,
                cl: power.map(|c| c * k),
                to: v3(*position),
                pdf: F::ZERO,
            })
        }
    }
}

/// The light loop's density of direction `l` (unit) from `p` towards a point `q` on light
/// `light`, times its sample count: what [`Sample::pdf`] is for a sample in that direction,
/// for the renderer to weight a BSDF-sampled ray that reaches the light (power heuristic).
/// Quads: `N r² / (cos θ_light · A)` at the hit point `q` (0 from behind); constant
/// environments: `N / (4π)`; environment maps: `N` × [`EnvMap::pdf`] of `l` (0 for a black
/// map); 0 for delta and ambient lights.
pub fn light_pdf(light: &Light, p: [f64; 3], l: [f64; 3], q: [f64; 3]) -> f64 {
    match &light.desc.kind {
        LightKind::Quad {
            edge_u,
            edge_v,
            samples,
            ..
        } => {
            let n = ops::cross(*edge_u, *edge_v);
            let area = ops::length(&n);
            let n = ops::normalize(n);
            let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            let r2 = ops::dot(&d, &d);
            let cos = -ops::dot(&l, &n);
            if cos <= 0.0 || area <= 0.0 {
                return 0.0;
            }
            (*samples).max(1) as f64 * r2 / (cos * area)
        }
        LightKind::Environment { samples, .. } => match &light.env {
            Some(env) => (*samples).max(1) as f64 * env.pdf(l),
            None => (*samples).max(1) as f64 / (4.0 * std::f64::consts::PI),
        },
        _ => 0.0,
    }
}

/// The radiance an environment light sends along unit direction `-l` (what a ray leaving
/// the scene along `l` sees of it): its power, times the map's texel in that direction
/// when it has a map; `None` for the other kinds of light.
pub fn environment_radiance(light: &Light, l: [f64; 3]) -> Option<[f64; 3]> {
    match (&light.desc.kind, &light.env) {
        (LightKind::Environment { .. }, Some(env)) => {
            let rad = env.radiance(l);
            Some(std::array::from_fn(|c| light.desc.power[c] * rad[c]))
        }
        (LightKind::Environment { .. }, None) => Some(light.desc.power),
        _ => None,
    }
}

/// Unit direction from `p` to `pos` and `1 / r²` (0 where r = 0).
fn towards<F: Real>(pos: [F; 3], p: [F; 3]) -> ([F; 3], F) {
    let d = [pos[0] - p[0], pos[1] - p[1], pos[2] - p[2]];
    let r2 = ops::dot(&d, &d);
    (ops::normalize(d), ops::div(F::ONE, r2))
}

/// Four lanes of [`sample`] (f32) for one light and sample number, with per-lane points
/// `p[axis][lane]` and seeds: a point light runs the four lanes together (the scalar
/// arithmetic — [`towards`]'s dot product from 0, `sqrt`, the total divisions — on four-lane
/// arrays in the same order, the root and quotients as SSE2 vector instructions, which round
/// as the scalar ones do: the scalar bits); a spot light adds its cone and dropoff per lane
/// (the dropoff's `pow` four lanes at once); a distant light's direction is computed once for
/// the four; every other kind samples each lane with [`sample`].
pub fn sample_x4(
    light: &Light,
    index: u32,
    k: u32,
    p: [[f32; 4]; 3],
    seed: [u32; 4],
) -> [Option<Sample<f32>>; 4] {
    let power: [f32; 3] = v3(light.desc.power);
    let position = match &light.desc.kind {
        LightKind::Point { position } => position,
        LightKind::Distant { direction } => {
            // The direction is the same for every lane: computed once, as `sample` does.
            let d: [f32; 3] = v3(*direction);
            let l = ops::normalize(d.map(|x| -x));
            let far = FAR as f32;
            let mut out = [None; 4];
            for (lane, o) in out.iter_mut().enumerate() {
                let to = std::array::from_fn(|c| p[c][lane] + l[c] * far);
                *o = Some(Sample {
                    l,
                    cl: power,
                    to,
                    pdf: 0.0,
                });
            }
            return out;
        }
        LightKind::Spot {
            position,
            direction,
            dropoff,
            ..
        } => return spot_x4(light, v3(*position), v3(*direction), *dropoff, p),
        _ => {
            let mut out = [None; 4];
            for (lane, o) in out.iter_mut().enumerate() {
                *o = sample(
                    light,
                    index,
                    k,
                    [p[0][lane], p[1][lane], p[2][lane]],
                    seed[lane],
                );
            }
            return out;
        }
    };
    let pos: [f32; 3] = v3(*position);
    let (l, inv_r2) = towards_x4(pos, p);
    std::array::from_fn(|lane| {
        Some(Sample {
            l: [l[0][lane], l[1][lane], l[2][lane]],
            cl: power.map(|c| c * inv_r2[lane]),
            to: pos,
            pdf: 0.0,
        })
    })
}

/// A spot light's cone at `cos_a` (the cosine to its axis): 1 inside the lit edge, 0 outside
/// the dark edge, a smoothstep between.
fn spot_cone<F: Real>(light: &Light, cos_a: F) -> F {
    let (cos_in, cos_out) = (F::from_f64(light.spot_cos.0), F::from_f64(light.spot_cos.1));
    if cos_a >= cos_in {
        F::ONE
    } else if cos_a <= cos_out {
        F::ZERO
    } else {
        // smoothstep from the dark edge to the lit edge
        let t = ops::div(cos_a - cos_out, cos_in - cos_out);
        t * t * (F::from_f64(3.0) - F::from_f64(2.0) * t)
    }
}

/// A spot light's samples for four points: [`sample`]'s spot arithmetic per lane in the same
/// order ([`spot_cone`] shared), the distances by [`towards_x4`] and the dropoff's `pow` by
/// the four-lane math helpers (`ops::math_x4`, the scalar op's bits).
fn spot_x4(
    light: &Light,
    pos: [f32; 3],
    direction: [f32; 3],
    dropoff: f64,
    p: [[f32; 4]; 3],
) -> [Option<Sample<f32>>; 4] {
    let power: [f32; 3] = v3(light.desc.power);
    let (l, inv_r2) = towards_x4(pos, p);
    let axis = ops::normalize(direction);
    let mut cos_a = [0.0f32; 4];
    let mut cone = [0.0f32; 4];
    for lane in 0..4 {
        let lv = [l[0][lane], l[1][lane], l[2][lane]];
        cos_a[lane] = -ops::dot(&lv, &axis);
        cone[lane] = spot_cone(light, cos_a[lane]);
    }
    let fall = if dropoff > 0.0 {
        let base = cos_a.map(|c| ops::max(c, 0.0));
        (shadenet_graph::ops::math_x4::chosen().pow)(base, [dropoff as f32; 4])
    } else {
        [1.0; 4]
    };
    let mut out = [None; 4];
    for (lane, o) in out.iter_mut().enumerate() {
        let k = cone[lane] * fall[lane] * inv_r2[lane];
        *o = Some(Sample {
            l: [l[0][lane], l[1][lane], l[2][lane]],
            cl: power.map(|c| c * k),
            to: pos,
            pdf: 0.0,
        });
    }
    out
}

/// [`towards`] for four points at once.
fn towards_x4(pos: [f32; 3], p: [[f32; 4]; 3]) -> ([[f32; 4]; 3], [f32; 4]) {
    let mut d = [[0.0f32; 4]; 3];
    for c in 0..3 {
        for l in 0..4 {
            d[c][l] = pos[c] - p[c][l];
        }
    }
    // ops::dot: s = 0, then s + x·x per component, in order.
    let mut r2 = [0.0f32; 4];
    for dc in &d {
        for l in 0..4 {
            r2[l] += dc[l] * dc[l];
        }
    }
    // ops::normalize: each component over ops::sqrt of the same dot product, then the
    // total division (0 where the divisor is 0); inv_r2 = div(1, r2).
    let (len, inv) = sqrt_and_inverse(r2);
    let mut out = [[0.0f32; 4]; 3];
    for c in 0..3 {
        out[c] = total_div(d[c], len);
    }
    (out, inv)
}

/// `ops::sqrt` and `ops::div(1, x)` of four lanes: SSE2's `sqrtps` and `divps` round as the
/// scalar instructions do, and the rules' zeros are selected by masks.
#[cfg(target_arch = "x86_64")]
fn sqrt_and_inverse(x: [f32; 4]) -> ([f32; 4], [f32; 4]) {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is part of x86-64; the loads and stores are of four-float arrays.
    unsafe {
        let v = _mm_loadu_ps(x.as_ptr());
        let zero = _mm_setzero_ps();
        let root = _mm_andnot_ps(_mm_cmplt_ps(v, zero), _mm_sqrt_ps(v));
        let inv = _mm_andnot_ps(_mm_cmpeq_ps(v, zero), _mm_div_ps(_mm_set1_ps(1.0), v));
        let (mut r, mut i) = ([0.0f32; 4], [0.0f32; 4]);
        _mm_storeu_ps(r.as_mut_ptr(), root);
        _mm_storeu_ps(i.as_mut_ptr(), inv);
        (r, i)
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn sqrt_and_inverse(x: [f32; 4]) -> ([f32; 4], [f32; 4]) {
    (x.map(ops::sqrt), x.map(|v| ops::div(1.0, v)))
}

/// `ops::div(a, b)` of four lanes (0 where `b` is 0).
#[cfg(target_arch = "x86_64")]
fn total_div(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is part of x86-64; the loads and stores are of four-float arrays.
    unsafe {
        let (va, vb) = (_mm_loadu_ps(a.as_ptr()), _mm_loadu_ps(b.as_ptr()));
        let q = _mm_andnot_ps(_mm_cmpeq_ps(vb, _mm_setzero_ps()), _mm_div_ps(va, vb));
        let mut out = [0.0f32; 4];
        _mm_storeu_ps(out.as_mut_ptr(), q);
        out
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn total_div(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    std::array::from_fn(|l| ops::div(a[l], b[l]))
}

/// The sum of the ambient lights' power.
pub fn ambient<F: Real>(lights: &[Light]) -> [F; 3] {
    let mut s = [F::ZERO; 3];
    for l in lights.iter().filter(|l| l.is_ambient()) {
        let c: [F; 3] = v3(l.desc.power);
        s = [s[0] + c[0], s[1] + c[1], s[2] + c[2]];
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Four lanes of a point, a distant, a spot and a quad light from hard and ordinary
    /// points (zeros, denormals, huge, ±inf, NaN, the light's own position) give
    /// [`sample`]'s bits.
    #[test]
    fn sample_x4_has_the_scalar_bits() {
        let light =
            |kind| Light::from_desc(&LightDesc::new("l", kind, [20.0, 18.0, 15.0]).unwrap());
        let lights = [
            light(LightKind::Point {
                position: [1.0, 1.0, 2.0],
            }),
            light(LightKind::Distant {
                direction: [0.3, -0.5, -0.8],
            }),
            light(LightKind::Spot {
                position: [0.0, 0.0, 3.0],
                direction: [0.0, 0.0, -1.0],
                cone_angle: 0.8,
                penumbra_angle: 0.1,
                dropoff: 2.0,
            }),
            light(LightKind::Quad {
                corner: [-1.0, 2.0, -1.0],
                edge_u: [2.0, 0.0, 0.0],
                edge_v: [0.0, 0.0, 2.0],
                samples: 3,
            }),
        ];
        let hard = [
            0.0f32,
            -0.0,
            1.0,
            -2.5,
            1e-45,
            -3e-41,
            f32::MIN_POSITIVE,
            1e-30,
            1e30,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let mut points: Vec<[f32; 3]> = Vec::new();
        for &a in &hard {
            points.push([a, 0.25, -1.0]);
            points.push([1.0, a, 2.0]);
            points.push([0.5, 1.0, a]);
        }
        points.push([1.0, 1.0, 2.0]); // the point light's position
        // A sweep across the spot's cone, penumbra and outside (its axis is x = y = 0).
        points.extend((0..64).map(|i| [i as f32 * 0.05, 0.01, 0.0]));
        for (li, light) in lights.iter().enumerate() {
            for k in 0..sample_count(light).max(1) {
                for (c, chunk) in points.chunks(4).enumerate() {
                    let at = |l: usize| chunk[l % chunk.len()];
                    let p = std::array::from_fn(|a| std::array::from_fn(|l| at(l)[a]));
                    let seed = std::array::from_fn(|l| (c * 4 + l) as u32 * 7919);
                    let got = sample_x4(light, li as u32, k, p, seed);
                    for (l, g) in got.iter().enumerate() {
                        let want = sample::<f32>(light, li as u32, k, at(l), seed[l]);
                        let bits = |s: Option<Sample<f32>>| {
                            s.map(|s| [s.l, s.cl, s.to, [s.pdf; 3]].map(|v| v.map(f32::to_bits)))
                        };
                        assert_eq!(bits(*g), bits(want), "light {li} sample {k} at {:?}", at(l));
                    }
                }
            }
        }
    }
}
