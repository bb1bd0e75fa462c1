//! Light samples: what arrives at a shaded point from each light (the light intrinsic that
//! every CPU back end calls).
//!
//! Units as in pbrt: a point or spot light's power is an intensity (W/sr) and arrives as
//! `I / r²`; a distant light's is an irradiance (W/m² perpendicular to it); ambient light is
//! a radiance with no direction, summed by the `ambient` op instead of the light loop.

use shadenet_graph::nodes::{LightDesc, LightKind};
use shadenet_graph::ops::{self, Real};

/// A light as the runtime samples it.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// The light's description (kind, geometry, color × intensity).
    pub desc: LightDesc,
    /// For spot lights: cos of the angle where the cone is fully lit, and where it is dark.
    spot_cos: (f64, f64),
}

impl Light {
    /// Prepares a light for sampling.
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
                let c = |a: f64| a.clamp(0.0, std::f64::consts::PI).cos();
                (c(inner), c(outer))
            }
            _ => (1.0, 1.0),
        };
        Light {
            desc: desc.clone(),
            spot_cos,
        }
    }

    /// True for ambient lights (no direction; not part of the light loop).
    pub fn is_ambient(&self) -> bool {
        matches!(self.desc.kind, LightKind::Ambient)
    }
}

/// One light sample: unit direction towards the light, and the color arriving.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample<F> {
    /// Unit direction from the point towards the light.
    pub l: [F; 3],
    /// Color arriving at the point (intensity / r² for positional lights).
    pub cl: [F; 3],
}

fn v3<F: Real>(v: [f64; 3]) -> [F; 3] {
    v.map(F::from_f64)
}

/// Samples `light` as seen from point `p`; `None` for ambient lights. A point at the light's
/// position receives nothing (the total division makes `I / 0 = 0`).
pub fn sample<F: Real>(light: &Light, p: [F; 3]) -> Option<Sample<F>> {
    let power: [F; 3] = v3(light.desc.power);
    match &light.desc.kind {
        LightKind::Ambient => None,
        LightKind::Distant { direction } => {
            let d: [F; 3] = v3(*direction);
            Some(Sample {
                l: ops::normalize(d.map(|x| -x)),
                cl: power,
            })
        }
        LightKind::Point { position } => {
            let (l, inv_r2) = towards(v3(*position), p);
            Some(Sample {
                l,
                cl: power.map(|c| c * inv_r2),
            })
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
            let (cos_in, cos_out) = (F::from_f64(light.spot_cos.0), F::from_f64(light.spot_cos.1));
            let cone = if cos_a >= cos_in {
                F::ONE
            } else if cos_a <= cos_out {
                F::ZERO
            } else {
                // smoothstep from the dark edge to the lit edge
                let t = ops::div(cos_a - cos_out, cos_in - cos_out);
                t * t * (F::from_f64(3.0) - F::from_f64(2.0) * t)
            };
            let fall = if *dropoff > 0.0 {
                ops::pow(ops::max(cos_a, F::ZERO), F::from_f64(*dropoff))
            } else {
                F::ONE
            };
            let k = cone * fall * inv_r2;
            Some(Sample {
                l,
                cl: power.map(|c| c * k),
            })
        }
    }
}

/// Unit direction from `p` to `pos` and `1 / r²` (0 where r = 0).
fn towards<F: Real>(pos: [F; 3], p: [F; 3]) -> ([F; 3], F) {
    let d = [pos[0] - p[0], pos[1] - p[1], pos[2] - p[2]];
    let r2 = ops::dot(&d, &d);
    (ops::normalize(d), ops::div(F::ONE, r2))
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
