//! Deferred shading: a group of tiles' camera samples traced first, the shading calls their
//! hits need binned per shader and environment, one `shade_many` per bin, then every sample
//! finished as the immediate path finishes it (same order of additions: same bits).

use super::compile::{Action, Specialized};
use super::film::{
    Layout, TileOut, add_override_beauty, add_parts, override_channels, put_override_pass,
};
use super::services::{BatchServices, HitServices};
use super::setup::Renderer;
use super::stats::TileStats;
use crate::passes::OverrideKind;
use shadenet_runtime::Fragment;
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
    /// The tiles of one group in the deferred mode: trace every camera sample, shade the
    /// hits per shader and environment in batches, then finish each sample as
    /// [`Renderer::camera_sample`] does.
    pub(super) fn render_group(
        &self,
        tiles: &[(u32, u32, u32, u32)],
        layout: &Layout,
        stats: &TileStats,
    ) -> Vec<TileOut> {
        let spp = self.scene.settings.spp;
        let stride = layout.stride;
        let nsamples: usize = tiles
            .iter()
            .map(|(x0, y0, x1, y1)| ((x1 - x0) * (y1 - y0)) as usize * spp as usize)
            .sum();
        let mut samples = vec![0.0f32; nsamples * stride];
        // 1. Trace: every sample's camera ray; each shading call a hit needs becomes a job
        //    of the batch of its shader and environment.
        let mut jobs: Vec<Job> = Vec::new();
        let mut batches: Vec<BatchKey> = Vec::new();
        let mut batch_of: HashMap<(usize, usize), usize> = HashMap::new();
        let mut s = 0usize;
        for &(x0, y0, x1, y1) in tiles {
            for y in y0..y1 {
                for x in x0..x1 {
                    for k in 0..spp {
                        let ray = self.camera_ray(x, y, k);
                        let sample = &mut samples[s * stride..(s + 1) * stride];
                        if let Some((action, prep)) = self.camera_hit(&ray, layout, sample, stats) {
                            let mut push = |sp: &Specialized, apply: Apply| {
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
                                    frag: self.fragment(sp, &ray, &prep),
                                    hit: self.services(&ray, &prep, stats),
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
                        s += 1;
                    }
                }
            }
        }
        // 2. Shade: one `shade_many` call per batch.
        let mut results = vec![(0usize, 0usize); jobs.len()]; // (start in `arena`, width)
        let mut arena: Vec<f32> = Vec::new();
        let mut out = Vec::new();
        let mut frags = Vec::new();
        for b in &batches {
            let env = &self.envs[b.instance];
            frags.clear();
            frags.extend(b.jobs.iter().map(|&j| jobs[j].frag));
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
            let width = out.len() / b.jobs.len().max(1);
            for (i, &j) in b.jobs.iter().enumerate() {
                results[j] = (arena.len() + i * width, width);
            }
            arena.extend_from_slice(&out[..width * b.jobs.len()]);
        }
        // 3. Finish: apply each job's outputs to its sample, in the order the immediate
        //    path applies them.
        for (job, &(start, width)) in jobs.iter().zip(&results) {
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
        // 4. Accumulate the samples into pixels, tile by tile, as `render_tile` does.
        let inv = 1.0 / spp as f32;
        let mut s = 0usize;
        let mut outs = Vec::with_capacity(tiles.len());
        for &(x0, y0, x1, y1) in tiles {
            let n = ((x1 - x0) * (y1 - y0)) as usize;
            let mut values = vec![0.0f32; n * stride];
            for dst in values.chunks_exact_mut(stride) {
                for _ in 0..spp {
                    let sample = &samples[s * stride..(s + 1) * stride];
                    for (d, v) in dst.iter_mut().zip(sample) {
                        *d += *v;
                    }
                    s += 1;
                }
                dst.iter_mut().for_each(|v| *v *= inv);
            }
            outs.push(TileOut { values });
        }
        outs
    }
}
