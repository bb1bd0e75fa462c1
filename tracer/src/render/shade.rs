//! The shade stage for single hits: the action a ray type and depth select, one shading call
//! at a prepared hit (its fragment, services and environment), override values, and the
//! radiance along a secondary ray. Batches are the deferred stage's.

use super::compile::{Action, Specialized};
use super::film::override_channels;
use super::sampler::rand4;
use super::setup::Renderer;
use super::stats::{Stage, TileStats};
use super::trace::{Found, Prepared, RayState};
use crate::passes::{OverrideKind, RayMatch};
use shadenet_runtime::{Fragment, ShadeCtx, ShadeOut};
use std::sync::atomic::Ordering;

impl Renderer {
    pub(super) fn action(&self, ray: RayMatch, depth: u32) -> &Action {
        let row = &self.table[RayMatch::ALL.iter().position(|r| *r == ray).unwrap_or(0)];
        &row[(depth as usize).min(row.len() - 1)]
    }

    /// Runs a specialized shader on a prepared hit into `out`.
    pub(super) fn shade(
        &self,
        sp: &Specialized,
        ray: &RayState,
        prep: &Prepared,
        out: &mut ShadeOut<f32>,
        stats: &TileStats,
    ) {
        let frag = self.fragment(sp, ray, prep);
        let services = self.services(sp, ray, prep, stats);
        let env = &self.envs[prep.surface.instance as usize];
        let ctx = ShadeCtx {
            frag,
            env,
            mask: sp.mask,
            scene: Some(&services),
        };
        sp.shader.shade(&ctx, out);
        stats.shading_calls.fetch_add(1, Ordering::Relaxed);
        stats
            .nonfinite
            .fetch_add(out.nonfinite as u64, Ordering::Relaxed);
    }

    /// The fragment a specialized shader gets at a prepared hit (uv, tangents and
    /// differentials only where it reads them).
    pub(super) fn fragment(&self, sp: &Specialized, ray: &RayState, prep: &Prepared) -> Fragment {
        let s = &prep.surface;
        let mut frag = Fragment {
            p: s.p.to_array(),
            n: prep.n_facing.to_array(),
            ng: s.ng.to_array(),
            i: (s.p - ray.o).to_array(),
            ray_type: ray.ray.code(),
            ray_depth: ray.depth as i32,
            seed: ray.seed,
            rand: rand4(ray.seed),
            ..Fragment::default()
        };
        if sp.uv_tangents {
            frag.uv = s.uv.to_array();
            frag.dpdu = s.dpdu.to_array();
            frag.dpdv = s.dpdv.to_array();
        }
        if sp.differentials
            && let Some(d) = prep.diffs
        {
            frag.dpdx = d.dpdx.to_array();
            frag.dpdy = d.dpdy.to_array();
        }
        frag
    }

    /// The value of an override shader at a hit: its channels (up to 3 floats), a
    /// one-channel value (depth, occlusion) repeated in all three so that an override rule
    /// shows it as grey in the beauty.
    pub(super) fn override_value(
        &self,
        kind: OverrideKind,
        ray: &RayState,
        prep: &Prepared,
        out: &mut ShadeOut<f32>,
        stats: &TileStats,
    ) -> [f32; 3] {
        let Some(sp) = self.override_shader(kind) else {
            return [0.0; 3];
        };
        self.shade(sp, ray, prep, out, stats);
        override_channels(kind, &out.values)
    }

    /// The compiled override shader of a kind.
    pub(super) fn override_shader(&self, kind: OverrideKind) -> Option<&Specialized> {
        self.overrides
            .iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, sp)| sp)
    }

    /// Whether the shader an action picks for `material` reads uv or tangents.
    pub(super) fn needs_uv(&self, action: &Action, material: usize) -> bool {
        match action {
            Action::Material(a) => self.shaders[material][*a].uv_tangents,
            Action::Override(o) => self.override_needs_uv(*o),
        }
    }

    pub(super) fn override_needs_uv(&self, kind: OverrideKind) -> bool {
        self.overrides
            .iter()
            .any(|(k, s)| *k == kind && s.uv_tangents)
    }

    /// The weight of what a BSDF-sampled ray of density `bsdf_pdf` finds on a light source
    /// the light loop samples with density `light_pdf`: the scene's light strategy's
    /// ([`shadenet_graph::LightStrategy::bsdf_ray_weight`]; the power heuristic with `mis`).
    pub(super) fn bsdf_ray_weight(&self, bsdf_pdf: f32, light_pdf: f32) -> f32 {
        self.scene
            .settings
            .light_strategy
            .bsdf_ray_weight(bsdf_pdf, light_pdf)
    }

    /// What a BSDF-sampled ray of density `bsdf_pdf` from `o` along `d` sees of the light
    /// sources alone (MIS-weighted): an area light or the environment; black where a
    /// surface is in the way.
    pub(super) fn lights_only(&self, o: glam::Vec3, d: glam::Vec3, bsdf_pdf: f32) -> [f32; 3] {
        match self.intersect(o, d) {
            Found::Miss => self.escaped(d, bsdf_pdf),
            Found::Emitter(r, pdf) => r.map(|x| x * self.bsdf_ray_weight(bsdf_pdf, pdf)),
            Found::Surface(_) => [0.0; 3],
        }
    }

    /// Radiance along a secondary ray: the total of what it hits, shaded with the action
    /// its ray type and depth select.
    pub(super) fn radiance(&self, ray: &RayState, stats: &TileStats) -> [f32; 3] {
        let n = stats.secondary_rays.fetch_add(1, Ordering::Relaxed);
        let found = stats.sampled(Stage::SecondaryTrace, n, || self.intersect(ray.o, ray.d));
        let hit = match found {
            Found::Miss => return self.escaped(ray.d, ray.bsdf_pdf),
            Found::Emitter(r, pdf) => {
                let w = self.bsdf_ray_weight(ray.bsdf_pdf, pdf);
                return r.map(|x| x * w);
            }
            Found::Surface(h) => h,
        };
        let action = self.action(ray.ray, ray.depth);
        let uv = self.needs_uv(action, self.material_of(&hit));
        let prep = self.prepare(ray, &hit, uv);
        let mut out = ShadeOut::default();
        match action {
            Action::Material(a) => {
                let sp = &self.shaders[prep.material][*a];
                self.shade(sp, ray, &prep, &mut out, stats);
                let mut sum = [0.0f32; 3];
                for part in sp.parts.iter().filter(|p| p.beauty) {
                    for (c, s) in sum.iter_mut().enumerate().take(part.width.min(3)) {
                        *s += out.values[part.offset + c];
                    }
                }
                sum
            }
            Action::Override(o) => self.override_value(*o, ray, &prep, &mut out, stats),
        }
    }
}
