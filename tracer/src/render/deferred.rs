//! Deferred shading: a group of tiles' camera samples traced first, the shading calls their
//! hits need binned per shader and environment, one `shade_many` per bin, then every sample
//! finished as the immediate path finishes it (same order of additions: same bits).

use super::compile::{Action, Specialized};
use super::film::{
    Layout, TileOut, accumulate, add_override_beauty, add_parts, override_channels,
    put_override_pass,
};
use super::services::{BatchServices, HitServices};
use super::setup::Renderer;
use super::stats::{Stage, TileStats};
use super::trace::RayState;
use crate::passes::OverrideKind;
use shadenet_runtime::{Fragment, Fragments, packed_index, packed_len};
use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::Ordering;

/// Consecutive tiles (in the given order) grouped until each group holds at least
/// `min_samples` camera samples; every group has at least one tile.
pub(super) fn group_tiles(
    tiles: &[(u32, u32, u32, u32)],
    spp: usize,
    min_samples: usize,
) -> Vec<std::ops::Range<usize>> {
    let mut groups = Vec::new();
    let (mut start, mut n) = (0usize, 0usize);
    for (i, (x0, y0, x1, y1)) in tiles.iter().enumerate() {
        n += ((x1 - x0) * (y1 - y0)) as usize * spp;
        if n >= min_samples {
            groups.push(start..i + 1);
            start = i + 1;
            n = 0;
        }
    }
    if start < tiles.len() {
        groups.push(start..tiles.len());
    }
    groups
}

/// One deferred shading call: which sample it finishes and how, its fragment and its hit's
/// scene services.
pub(super) struct Job<'a> {
    pub(super) sample: usize,
    pub(super) apply: Apply,
    pub(super) frag: Fragment,
    pub(super) hit: HitServices<'a>,
}

/// How a deferred shading call's outputs finish its sample.
#[derive(Clone, Copy, Debug)]
pub(super) enum Apply {
    /// A material's parts (material, action).
    Parts(usize, usize),
    /// An override rule: the beauty.
    OverrideBeauty(OverrideKind),
    /// An override pass at this offset of the sample.
    OverridePass(OverrideKind, usize),
}

/// The jobs of one shader and environment (`instance`: whose environment; any instance's
/// when the shader does not read object space).
pub(super) struct BatchKey {
    pub(super) shader: Specialized,
    pub(super) instance: usize,
    pub(super) jobs: Vec<usize>,
}

impl Renderer {
    /// The tiles of one group in the deferred mode: the camera rays of every sample, traced;
    /// the hits shaded per shader and environment in batches; then each sample finished as
    /// the immediate path does and added into its pixel.
    pub(super) fn render_group(
        &self,
        tiles: &[(u32, u32, u32, u32)],
        layout: &Layout,
        stats: &TileStats,
    ) -> Vec<TileOut> {
        let spp = self.scene.settings.spp;
        let t = std::time::Instant::now();
        let mut rays = Vec::new();
        for &(x0, y0, x1, y1) in tiles {
            for y in y0..y1 {
                for x in x0..x1 {
                    self.camera_rays(x, y, &mut rays);
                }
            }
        }
        let t = stats.lap(Stage::Sample, t);
        let mut samples = vec![0.0f32; rays.len() * layout.stride];
        let (jobs, batches) = self.trace_group(&rays, layout, &mut samples, stats);
        let t = stats.lap(Stage::Trace, t);
        let (arena, results) = self.shade_batches(&jobs, &batches, stats);
        let t = stats.lap(Stage::Shade, t);
        self.finish_jobs(&jobs, &arena, &results, layout, &mut samples);
        let mut s = 0usize;
        let mut outs = Vec::with_capacity(tiles.len());
        for &(x0, y0, x1, y1) in tiles {
            let n = ((x1 - x0) * (y1 - y0)) as usize * spp as usize * layout.stride;
            let values = accumulate(&samples[s..s + n], spp, layout.stride);
            s += n;
            outs.push(TileOut { values });
        }
        stats.lap(Stage::Film, t);
        outs
    }

    /// Traces every camera ray of a group: a miss or an emitter fills its sample; each
    /// shading call a hit needs becomes a job of the batch of its shader and environment.
    fn trace_group<'a>(
        &'a self,
        rays: &[RayState],
        layout: &Layout,
        samples: &mut [f32],
        stats: &'a TileStats,
    ) -> (Vec<Job<'a>>, Vec<BatchKey>) {
        let stride = layout.stride;
        let mut jobs: Vec<Job> = Vec::new();
        let mut batches: Vec<BatchKey> = Vec::new();
        let mut batch_of: HashMap<(usize, usize), usize> = HashMap::new();
        for (s, ray) in rays.iter().enumerate() {
            let sample = &mut samples[s * stride..(s + 1) * stride];
            let Some((action, prep)) = self.camera_hit(ray, layout, sample, stats) else {
                continue;
            };
            let mut push = |sp: &'a Specialized, apply: Apply| {
                let instance = prep.surface.instance as usize;
                let env = if sp.object_space {
                    instance
                } else {
                    usize::MAX
                };
                let key = (Arc::as_ptr(&sp.shader) as *const u8 as usize, env);
                let batch = *batch_of.entry(key).or_insert_with(|| {
                    batches.push(BatchKey {
                        shader: sp.clone(),
                        instance,
                        jobs: Vec::new(),
                    });
                    batches.len() - 1
                });
                batches[batch].jobs.push(jobs.len());
                jobs.push(Job {
                    sample: s,
                    apply,
                    frag: self.fragment(sp, ray, &prep),
                    hit: self.services(sp, ray, &prep, stats),
                });
            };
            match action {
                Action::Material(a) => {
                    push(
                        &self.shaders[prep.material][*a],
                        Apply::Parts(prep.material, *a),
                    );
                }
                Action::Override(o) => match self.override_shader(*o) {
                    Some(sp) => push(sp, Apply::OverrideBeauty(*o)),
                    None => add_override_beauty([0.0; 3], layout, sample),
                },
            }
            for &(o, off) in &layout.overrides {
                match self.override_shader(o) {
                    Some(sp) => push(sp, Apply::OverridePass(o, off)),
                    None => put_override_pass(o, off, [0.0; 3], sample),
                }
            }
        }
        (jobs, batches)
    }

    /// One `shade_many` call per batch. Returns the outputs of every job, one after the
    /// other, and each job's (start, width) in them.
    fn shade_batches(
        &self,
        jobs: &[Job],
        batches: &[BatchKey],
        stats: &TileStats,
    ) -> (Vec<f32>, Vec<(usize, usize)>) {
        let mut results = vec![(0usize, 0usize); jobs.len()];
        let mut arena: Vec<f32> = Vec::new();
        let mut out = Vec::new();
        let mut frags = Fragments::new();
        for b in batches {
            let env = &self.envs[b.instance];
            frags.clear();
            for &j in &b.jobs {
                frags.push(&jobs[j].frag);
            }
            let services = BatchServices {
                hits: b.jobs.iter().map(|&j| jobs[j].hit).collect(),
            };
            let r =
                b.shader
                    .shader
                    .shade_many(env, b.shader.mask, Some(&services), &frags, &mut out);
            let n = b.jobs.len() as u64;
            stats.shading_calls.fetch_add(n, Ordering::Relaxed);
            stats.nonfinite.fetch_add(r.nonfinite, Ordering::Relaxed);
            stats.batches.fetch_add(1, Ordering::Relaxed);
            stats.batched.fetch_add(n, Ordering::Relaxed);
            stats.largest.fetch_max(n, Ordering::Relaxed);
            if let Ok(mut t) = stats.times.lock() {
                t.add(&r.times);
            }
            // The packets' layout back to one job after the other.
            let width = out.len() / packed_len(1, b.jobs.len()).max(1);
            for (i, &j) in b.jobs.iter().enumerate() {
                results[j] = (arena.len(), width);
                arena.extend((0..width).map(|k| out[packed_index(width, i, k)]));
            }
        }
        (arena, results)
    }

    /// Applies each job's outputs to its sample, in the order the immediate path applies
    /// them.
    fn finish_jobs(
        &self,
        jobs: &[Job],
        arena: &[f32],
        results: &[(usize, usize)],
        layout: &Layout,
        samples: &mut [f32],
    ) {
        let stride = layout.stride;
        for (job, &(start, width)) in jobs.iter().zip(results) {
            let values = &arena[start..start + width];
            let sample = &mut samples[job.sample * stride..(job.sample + 1) * stride];
            match job.apply {
                Apply::Parts(m, a) => add_parts(&self.shaders[m][a], values, layout, sample),
                Apply::OverrideBeauty(o) => {
                    add_override_beauty(override_channels(o, values), layout, sample)
                }
                Apply::OverridePass(o, off) => {
                    put_override_pass(o, off, override_channels(o, values), sample)
                }
            }
        }
    }
}
