//! The scene services shaders call back into: secondary rays (`trace`), shadow rays
//! (`occluded`), probe rays (`probe`: OSL's `trace`, unshaded) and ambient occlusion, started from a hit with a robust offset and carrying
//! its differentials; a batch's services hand each fragment its own. It owns no shading.

use super::compile::Specialized;
use super::pixel::hash3;
use super::setup::Renderer;
use super::stats::{Stage, TileStats};
use super::trace::{HitDiffs, Prepared, RayState};
use crate::accel::orthonormal;
use crate::camera::RayDiffs;
use crate::geometry::{AttributeMap, Mesh, attribute_at};
use crate::passes::RayMatch;
use glam::Vec3;
use shadenet_graph::ops::math;
use shadenet_runtime::{ProbeHit, SceneServices};
use std::sync::atomic::Ordering;

/// The scene services of one hit: secondary rays start from its point with a robust
/// offset, and carry its differentials.
#[derive(Clone, Copy)]
pub(super) struct HitServices<'a> {
    pub(super) r: &'a Renderer,
    pub(super) stats: &'a TileStats,
    pub(super) p: Vec3,
    pub(super) ng_facing: Vec3,
    pub(super) n_facing: Vec3,
    pub(super) d_in: Vec3,
    pub(super) diffs: Option<HitDiffs>,
    pub(super) seed: u32,
    /// Where the shader being run finds its named attributes at this hit (`None`: it
    /// reads none, or these services belong to no hit).
    pub(super) attrs: Option<HitAttributes<'a>>,
}

/// The named attributes of one hit for one shader: its slots resolved on the hit's mesh,
/// the triangle's vertices and the barycentrics.
#[derive(Clone, Copy)]
pub(super) struct HitAttributes<'a> {
    pub(super) map: &'a AttributeMap,
    pub(super) mesh: &'a Mesh,
    pub(super) verts: [u32; 3],
    pub(super) bary: [f32; 3],
}

impl HitServices<'_> {
    /// The closest surface along a probe ray (see [`SceneServices::probe`]): one closest-hit
    /// traversal from the offset start, the hit's surface read as a shaded hit's is; counted
    /// with the secondary rays. Each field a shader reads is one probe op and one traversal
    /// (equal fields of one ray are merged by CSE); a memo across fields would need state
    /// the services, shared by threads, do not have.
    fn probe_ray(&self, origin: [f32; 3], dir: [f32; 3], lo: f32, hi: f32) -> Option<ProbeHit> {
        let d = Vec3::from(dir).normalize_or_zero();
        let o = Vec3::from(origin);
        let interval = hi.partial_cmp(&lo).is_some_and(|c| c.is_ge());
        if d == Vec3::ZERO || !o.is_finite() || !interval {
            return None;
        }
        self.stats.secondary_rays.fetch_add(1, Ordering::Relaxed);
        let start = self.start(o, d);
        let from = start + d * lo;
        let hit = self.r.accel.closest(from, d, (hi - lo).max(0.0))?;
        let s = self.r.accel.surface(&hit, true);
        Some(ProbeHit {
            distance: lo + hit.t,
            p: s.p.to_array(),
            n: s.n.to_array(),
            ng: s.ng.to_array(),
            uv: s.uv.to_array(),
        })
    }

    /// The start of a ray from `origin` towards `dir`: the hit point offset to the side
    /// `dir` leaves on, when `origin` is the hit point (never for detached services, whose
    /// point is NaN).
    pub(super) fn start(&self, origin: Vec3, dir: Vec3) -> Vec3 {
        let tol = 1e-4 * (1.0 + self.p.abs().max_element());
        if self.p.is_finite() && (origin - self.p).abs().max_element() <= tol {
            let side = if dir.dot(self.ng_facing) >= 0.0 {
                self.ng_facing
            } else {
                -self.ng_facing
            };
            crate::accel::offset_origin(self.p, side)
        } else {
            origin
        }
    }

    /// The differentials of a secondary ray leaving this hit along `dir`.
    pub(super) fn child_diffs(&self, ray: RayMatch, dir: Vec3) -> Option<RayDiffs> {
        let d = self.diffs?;
        let n = self.n_facing;
        let din = self.d_in;
        let (dddx, dddy) = match ray {
            // r = d − 2(d·n)n, flat normal: dr = dd − 2(dd·n)n.
            RayMatch::Reflection => (
                d.dddx - 2.0 * d.dddx.dot(n) * n,
                d.dddy - 2.0 * d.dddy.dot(n) * n,
            ),
            // Igehy's refraction: dT = η·dD − dμ·n, with η = sinθt / sinθi recovered from the
            // two directions and dμ = (η − η²(D·n)/(T·n))·d(D·n).
            RayMatch::Refraction => {
                let (di, dt) = (din.dot(n), dir.dot(n));
                let sin_i = din.cross(n).length();
                let sin_t = dir.cross(n).length();
                let eta = if sin_i > 1e-6 { sin_t / sin_i } else { 1.0 };
                let k = if dt.abs() > 1e-6 {
                    eta - eta * eta * di / dt
                } else {
                    0.0
                };
                (
                    eta * d.dddx - k * d.dddx.dot(n) * n,
                    eta * d.dddy - k * d.dddy.dot(n) * n,
                )
            }
            _ => return None,
        };
        let v = RayDiffs {
            dodx: d.dpdx,
            dddx,
            dody: d.dpdy,
            dddy,
        };
        [v.dodx, v.dddx, v.dody, v.dddy]
            .iter()
            .all(|x| x.is_finite())
            .then_some(v)
    }
}

impl SceneServices for HitServices<'_> {
    fn attribute(&self, slot: u32, out: &mut [f32]) -> bool {
        let Some(h) = &self.attrs else {
            return false;
        };
        let Some(Some(i)) = h.map.get(slot as usize) else {
            return false;
        };
        let Some(a) = h.mesh.attributes.get(*i as usize) else {
            return false;
        };
        attribute_at(a, h.verts, h.bary, out);
        true
    }

    fn trace(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        ray_type: i32,
        depth: i32,
        bsdf_pdf: f32,
    ) -> [f32; 3] {
        let Some(ray) = RayMatch::from_code(ray_type) else {
            return [0.0; 3];
        };
        let depth = depth.max(0) as u32;
        if ray == RayMatch::Camera {
            return [0.0; 3];
        }
        let d = Vec3::from(dir).normalize_or_zero();
        let o = Vec3::from(origin);
        if d == Vec3::ZERO || !o.is_finite() {
            return [0.0; 3];
        }
        if depth > self.r.depth_limit(ray) {
            // Past the depth limit a BSDF-sampled ray still brings its MIS share of the
            // light sources it reaches (the light loop weighted its own share down), but
            // shades no surface; any other ray is black.
            if bsdf_pdf > 0.0 {
                return self.r.lights_only(self.start(o, d), d, bsdf_pdf);
            }
            return [0.0; 3];
        }
        let state = RayState {
            o: self.start(o, d),
            d,
            ray,
            depth,
            seed: hash3(
                self.seed,
                (ray_type as u32) << 8 | depth,
                d.x.to_bits() ^ d.y.to_bits().rotate_left(11) ^ d.z.to_bits().rotate_left(22),
            ),
            diffs: self.child_diffs(ray, d),
            bsdf_pdf,
        };
        self.r.radiance(&state, self.stats)
    }

    fn probe(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        min_distance: f32,
        max_distance: f32,
    ) -> Option<ProbeHit> {
        self.probe_ray(origin, dir, min_distance, max_distance)
    }

    fn occluded(&self, from: [f32; 3], to: [f32; 3]) -> bool {
        let count = self.stats.shadow_rays.fetch_add(1, Ordering::Relaxed);
        let (from, to) = (Vec3::from(from), Vec3::from(to));
        let v = to - from;
        let dist = v.length();
        if !(dist.is_finite() && dist > 0.0) {
            return false;
        }
        let d = v / dist;
        let o = self.start(from, d);
        // Stop just short of the light sample so the light's own surface never blocks it.
        let tmax = (to - o).length() * (1.0 - 1e-4);
        let accel = &self.r.accel;
        self.stats
            .sampled(Stage::ShadowTrace, count, || accel.occluded(o, d, tmax))
    }

    fn occlusion(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        samples: u32,
        max_distance: f32,
        seed: u32,
    ) -> f32 {
        let n = Vec3::from(n).normalize_or_zero();
        let p = Vec3::from(p);
        if n == Vec3::ZERO || samples == 0 || !p.is_finite() {
            return 1.0;
        }
        let (t, b) = orthonormal(n);
        let o = self.start(p, n);
        let max_distance = if max_distance > 0.0 {
            max_distance
        } else {
            0.0
        };
        let mut open = 0u32;
        for k in 0..samples {
            // Cosine-weighted (Malley): uniform on the disk, projected up.
            let [u1, u2] = shadenet_runtime::lights::random2(seed, 0x0cc1_u32, k);
            let r = u1.sqrt() as f32;
            let phi = (2.0 * std::f64::consts::PI * u2) as f32;
            let z = (1.0 - u1).max(0.0).sqrt() as f32;
            let d = (t * (r * math::cos_f32(phi)) + b * (r * math::sin_f32(phi)) + n * z)
                .normalize_or_zero();
            let count = self.stats.shadow_rays.fetch_add(1, Ordering::Relaxed);
            let accel = &self.r.accel;
            let hit = self.stats.sampled(Stage::ShadowTrace, count, || {
                accel.occluded(o, d, max_distance)
            });
            if !hit {
                open += 1;
            }
        }
        open as f32 / samples as f32
    }
}

/// The scene services of a batch (see the module documentation): fragment `i`'s own
/// services through [`SceneServices::fragment`]; a direct call (a ray that belongs to no
/// fragment of the batch) gets detached services: the ray starts where asked, with a seed
/// hashed from the origin and no differentials.
pub(super) struct BatchServices<'a> {
    pub(super) hits: Vec<HitServices<'a>>,
}

impl<'a> BatchServices<'a> {
    /// Services for a ray from `origin` that belongs to no fragment.
    pub(super) fn detached(&self, origin: [f32; 3]) -> HitServices<'a> {
        HitServices {
            p: Vec3::NAN,
            ng_facing: Vec3::ZERO,
            n_facing: Vec3::ZERO,
            d_in: Vec3::ZERO,
            diffs: None,
            attrs: None,
            seed: hash3(
                origin[0].to_bits(),
                origin[1].to_bits(),
                origin[2].to_bits(),
            ),
            ..self.hits[0]
        }
    }
}

impl SceneServices for BatchServices<'_> {
    fn trace(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        ray_type: i32,
        depth: i32,
        bsdf_pdf: f32,
    ) -> [f32; 3] {
        self.detached(origin)
            .trace(origin, dir, ray_type, depth, bsdf_pdf)
    }

    fn occluded(&self, from: [f32; 3], to: [f32; 3]) -> bool {
        self.detached(from).occluded(from, to)
    }

    fn probe(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        min_distance: f32,
        max_distance: f32,
    ) -> Option<ProbeHit> {
        self.detached(origin)
            .probe(origin, dir, min_distance, max_distance)
    }

    fn occlusion(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        samples: u32,
        max_distance: f32,
        seed: u32,
    ) -> f32 {
        self.detached(p)
            .occlusion(p, n, samples, max_distance, seed)
    }

    fn fragment(&self, index: usize) -> Option<&dyn SceneServices> {
        self.hits.get(index).map(|h| h as &dyn SceneServices)
    }
}

impl Renderer {
    /// The services of a prepared hit for shader `sp` (which names the attributes it
    /// reads).
    pub(super) fn services<'a>(
        &'a self,
        sp: &'a Specialized,
        ray: &RayState,
        prep: &Prepared,
        stats: &'a TileStats,
    ) -> HitServices<'a> {
        let mesh = self.scene.instances[prep.surface.instance as usize].mesh;
        let attrs = sp.attributes.get(mesh).map(|map| HitAttributes {
            map,
            mesh: &self.scene.meshes[mesh],
            verts: self.accel.vertices(prep.prim),
            bary: prep.bary,
        });
        HitServices {
            attrs,
            r: self,
            stats,
            p: prep.surface.p,
            ng_facing: prep.ng_facing,
            n_facing: prep.n_facing,
            d_in: ray.d,
            diffs: prep.diffs,
            seed: ray.seed,
        }
    }

    pub(super) fn depth_limit(&self, ray: RayMatch) -> u32 {
        let s = &self.scene.settings;
        match ray {
            RayMatch::Camera => 0,
            RayMatch::Reflection => s.max_reflection_depth,
            RayMatch::Refraction => s.max_refraction_depth,
            RayMatch::Diffuse => s.max_diffuse_depth,
        }
    }
}
