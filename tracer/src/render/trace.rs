//! The trace stage: closest hits against the BVH and the emitters, the camera ray's hit
//! (misses and emitters go straight to the sample), and the prepared hit (surface, facing
//! normals, transferred differentials) shading starts from. It must not shade.

use super::compile::Action;
use super::film::Layout;
use super::setup::Renderer;
use super::stats::TileStats;
use crate::accel::Hit;
use crate::camera::RayDiffs;
use crate::passes::RayMatch;
use crate::scene::Emitter;
use glam::Vec3;
use shadenet_runtime::lights;
use std::sync::atomic::Ordering;

pub(super) enum Found {
    Miss,
    /// A visible area light: its radiance and the light loop's density of the direction
    /// that reached it (`lights::light_pdf`).
    Emitter([f32; 3], f32),
    Surface(Hit),
}

#[derive(Clone, Copy, Debug)]
pub(super) struct HitDiffs {
    pub(super) dpdx: Vec3,
    pub(super) dpdy: Vec3,
    pub(super) dddx: Vec3,
    pub(super) dddy: Vec3,
}

#[derive(Clone, Copy, Debug)]
pub(super) struct RayState {
    pub(super) o: Vec3,
    pub(super) d: Vec3,
    pub(super) ray: RayMatch,
    pub(super) depth: u32,
    pub(super) seed: u32,
    pub(super) diffs: Option<RayDiffs>,
    /// The density with which a closure's BSDF sampling drew this ray (0 for camera rays
    /// and rays not drawn that way): light sources it reaches are MIS-weighted with it.
    pub(super) bsdf_pdf: f32,
}

pub(super) struct Prepared {
    pub(super) surface: crate::accel::Surface,
    pub(super) ng_facing: Vec3,
    pub(super) n_facing: Vec3,
    pub(super) material: usize,
    pub(super) diffs: Option<HitDiffs>,
    /// The hit's triangle and barycentrics: where named attributes are interpolated.
    pub(super) prim: u32,
    pub(super) bary: [f32; 3],
}

/// One-sided quad hit distance (from the emitting side).
pub(super) fn hit_emitter(e: &Emitter, o: Vec3, d: Vec3) -> Option<f32> {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let n = e.edge_u.cross(e.edge_v);
    let dn = d.dot(n);
    if dn >= 0.0 {
        return None; // from behind or parallel
    }
    let t = (e.corner - o).dot(n) / dn;
    if t.is_nan() || t <= 0.0 {
        return None;
    }
    let q = o + d * t - e.corner;
    let (uu, vv, uv) = (
        e.edge_u.length_squared(),
        e.edge_v.length_squared(),
        e.edge_u.dot(e.edge_v),
    );
    let (qu, qv) = (q.dot(e.edge_u), q.dot(e.edge_v));
    let det = uu * vv - uv * uv;
    let s = (qu * vv - qv * uv) / det;
    let r = (qv * uu - qu * uv) / det;
    ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&r)).then_some(t as f32)
}

impl Renderer {
    /// Traces a camera ray: a miss or an emitter fills `sample` and gives `None`; a surface
    /// hit marks the sample covered and gives the action camera hits take and the prepared
    /// hit (shading is the caller's).
    pub(super) fn camera_hit(
        &self,
        ray: &RayState,
        layout: &Layout,
        sample: &mut [f32],
        stats: &TileStats,
    ) -> Option<(&Action, Prepared)> {
        stats.camera_rays.fetch_add(1, Ordering::Relaxed);
        let em = self.emission * 3;
        let found = self.intersect(ray.o, ray.d);
        let hit = match found {
            Found::Miss => {
                let bg = self.escaped(ray.d, 0.0);
                for c in 0..3 {
                    sample[em + c] += bg[c];
                }
                return None;
            }
            Found::Emitter(rad, _) => {
                for c in 0..3 {
                    sample[em + c] += rad[c];
                }
                sample[layout.ncomp * 3 + 3] = 1.0;
                return None;
            }
            Found::Surface(h) => h,
        };
        sample[layout.ncomp * 3 + 3] = 1.0;
        let action = self.action(ray.ray, ray.depth);
        let material = self.material_of(&hit);
        let uv = layout.overrides_need_uv || self.needs_uv(action, material);
        Some((action, self.prepare(ray, &hit, uv)))
    }

    pub(super) fn intersect(&self, o: Vec3, d: Vec3) -> Found {
        let hit = self.accel.closest(o, d, f32::INFINITY);
        let tmax = hit.map_or(f32::INFINITY, |h| h.t);
        let mut best: Option<(f32, &crate::scene::Emitter)> = None;
        for e in &self.scene.emitters {
            if let Some(t) = hit_emitter(e, o, d)
                && t < tmax
                && best.is_none_or(|b| t < b.0)
            {
                best = Some((t, e));
            }
        }
        match (best, hit) {
            (Some((t, e)), _) => {
                let q = o + d * t;
                let pdf = shadenet_runtime::lights::light_pdf(
                    &self.lights[e.light],
                    o.as_dvec3().to_array(),
                    d.as_dvec3().to_array(),
                    q.as_dvec3().to_array(),
                );
                Found::Emitter(e.radiance.map(|x| x as f32), pdf as f32)
            }
            (None, Some(h)) => Found::Surface(h),
            (None, None) => Found::Miss,
        }
    }

    /// What a ray leaving the scene along `d` sees: every environment light's radiance in
    /// that direction, each weighted by the scene's light strategy for `bsdf_pdf` against the
    /// light loop's density of the direction for that light (the power heuristic with `mis`;
    /// in full for `bsdf_pdf = 0`).
    pub(super) fn escaped(&self, d: Vec3, bsdf_pdf: f32) -> [f32; 3] {
        let dir = d.as_dvec3().to_array();
        let mut sum = [0.0f32; 3];
        for l in &self.lights {
            let Some(rad) = lights::environment_radiance(l, dir) else {
                continue;
            };
            let w = if bsdf_pdf > 0.0 {
                let pdf = lights::light_pdf(l, [0.0; 3], dir, [0.0; 3]) as f32;
                self.bsdf_ray_weight(bsdf_pdf, pdf)
            } else {
                1.0
            };
            for (s, r) in sum.iter_mut().zip(rad) {
                *s += r as f32 * w;
            }
        }
        sum
    }

    pub(super) fn material_of(&self, hit: &Hit) -> usize {
        self.scene.instances[self.accel.instance(hit.prim) as usize].material
    }

    /// The surface at a hit (uv and tangents only with `uv_tangents`), with facing normals
    /// and transferred differentials.
    pub(super) fn prepare(&self, ray: &RayState, hit: &Hit, uv_tangents: bool) -> Prepared {
        let surface = self.accel.surface(hit, uv_tangents);
        let ng_facing = if surface.ng.dot(ray.d) <= 0.0 {
            surface.ng
        } else {
            -surface.ng
        };
        let n_facing = if surface.n.dot(ng_facing) >= 0.0 {
            surface.n
        } else {
            -surface.n
        };
        let material = self.scene.instances[surface.instance as usize].material;
        // Igehy's transfer onto the tangent plane: dP = dO + t·dD + dt·D.
        let diffs = ray.diffs.map(|rd| {
            let dn = ray.d.dot(surface.ng);
            let transfer = |d_o: Vec3, d_d: Vec3| -> Vec3 {
                if dn.abs() < 1e-12 {
                    return Vec3::ZERO;
                }
                let dt = -(d_o + hit.t * d_d).dot(surface.ng) / dn;
                let v = d_o + hit.t * d_d + dt * ray.d;
                if v.is_finite() { v } else { Vec3::ZERO }
            };
            HitDiffs {
                dpdx: transfer(rd.dodx, rd.dddx),
                dpdy: transfer(rd.dody, rd.dddy),
                dddx: rd.dddx,
                dddy: rd.dddy,
            }
        });
        Prepared {
            surface,
            ng_facing,
            n_facing,
            material,
            diffs,
            prim: hit.prim,
            bary: hit.bary,
        }
    }
}
