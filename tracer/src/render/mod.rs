//! The integrator as stages: camera rays, shading hits through specialized materials, the
//! scene services shaders call back into, and the tiles on rayon.
//!
//! # Stages
//!
//! Each stage is a file with one job; [`Renderer::render`] here is the loop that connects them.
//!
//! - `setup`: the [`Renderer`]: BVH, components, ray-match actions, compiled shaders
//!   (`compile` specializes and compiles them);
//! - `sampler`: the camera rays; `pixel` where camera samples sit (Sobol points through the
//!   pixel filter); `sobol` the Owen-scrambled Sobol points and the dimension plan;
//! - `trace`: closest hits (surfaces and emitters), occlusion, the prepared hit;
//! - `shade`: one shading call at a prepared hit, and secondary radiance;
//! - `services`: the scene services shaders call back into (trace, occluded, occlusion);
//! - `immediate` and `deferred`: the two ways camera hits reach the shaders (one by one,
//!   or binned per shader and environment into `shade_many` batches);
//! - `film`: the per-pixel layout, adding shading outputs to samples, composing layers;
//! - `stats`: the counters each thread keeps and the summary they add up to.
//!
//! # What a hit gets
//!
//! The fragment holds, in world space: `P` (from barycentrics), `N` (interpolated vertex
//! normal, flipped to the side of the geometric normal that faces the incoming ray), `Ng`
//! (the triangle's geometric normal **as wound**, counter-clockwise front — not flipped, so
//! a shader can tell entering from leaving a closed mesh by the sign of `I·Ng`), `I = P −
//! ray origin`, and, only when the specialized program's needs ask for them: `uv`, `dPdu`,
//! `dPdv` (from the triangle's uv parameterization) and `dPdx`, `dPdy` (ray differentials:
//! Igehy 1999, camera differentials transferred to the hit's tangent plane and carried
//! through reflection and refraction rays; diffuse rays drop them).
//!
//! # Determinism
//!
//! Pixel sample `k` of pixel `(x, y)` sits at point `k` of an Owen-scrambled Sobol sequence
//! seeded by the pixel (drawn through the pixel filter; pixel centres when `spp = 1`) and
//! gets `Fragment::seed = hash(x, y, k)`; secondary rays hash
//! the parent's seed with the ray type, depth and direction. Nothing depends on which thread
//! renders a tile, so images are bit-identical for any thread count.
//!
//! # Immediate and deferred shading
//!
//! In the **immediate** mode (the CPU back ends' default) each camera hit is shaded as soon
//! as it is found, one [`Shader::shade`] call per hit. In the **deferred** mode (chosen when
//! the back end [prefers batches](crate::shader::ShaderBackend::prefers_batches), the GPU,
//! or set with [`Renderer::set_shading_mode`]) a group of tiles of at least
//! [`DeferredOptions::group_samples`] camera samples is traced first; the shading calls its
//! hits need (the material's, the override rule's, each override pass's) are collected per
//! shader and environment and each such group is shaded with one [`Shader::shade_many`]
//! call; then every sample is finished exactly as the immediate path finishes it (same
//! film layout, same order of additions, same seeds and statistics), so for a CPU back end
//! the two modes give the same bits. Secondary hits shaded from inside a `trace` stay
//! immediate in both modes.
//!
//! The tracer's scene services carry per-hit state (the hit point the robust ray offset
//! starts from, the facing normals, the seed secondary rays hash, the ray differentials
//! they carry). A batch gets `BatchServices`: fragment `i`'s own services through
//! `SceneServices::fragment(i)`, which every back end's `shade_many` asks for (a ray that
//! belongs to no fragment starts detached, where asked).

mod compile;
mod deferred;
mod error;
mod film;
mod immediate;
mod pixel;
mod sampler;
mod services;
mod setup;
mod shade;
mod sobol;
mod stats;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_attributes;
mod trace;

/// The ray differentials live with the camera that starts them; re-exported here, where
/// secondary rays carry them on.
pub use crate::camera::RayDiffs;
pub use error::RenderError;
pub use pixel::{hash3, pixel_sample, pixel_seed};
pub use setup::{DeferredOptions, Renderer, ShadingMode};
pub use sobol::{Dim, GroupSeeds, sample1, sample2};
pub use stats::{RenderStats, StageTimes};

use crate::film::{Film, Window};
use deferred::group_tiles;
use film::TileOut;
use rayon::prelude::*;
use stats::TileStats;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

impl Renderer {
    /// Renders every tile on the current rayon pool, calling `progress(done, total)` after
    /// each tile. Returns the film and the statistics.
    pub fn render(&self, progress: &(dyn Fn(u64, u64) + Sync)) -> (Film, RenderStats) {
        let (w, h) = (self.scene.camera.width, self.scene.camera.height);
        self.render_window(Window::full(w, h), progress)
    }

    /// Loop executions the iteration limit stopped, over the renderer's shaders so far.
    fn loop_limits(&self) -> u64 {
        let shaders = self.shaders.iter().flatten();
        let all = shaders.chain(self.overrides.iter().map(|(_, s)| s));
        all.map(|s| s.shader.loop_limits()).sum()
    }

    /// Renders only the pixels of `window` (which [`Window::new`] has checked against the
    /// frame; a window reaching outside it is clipped), in tiles of the scene's tile size
    /// from the window's corner: each pixel gets exactly the bits it has in a full render
    /// (see Determinism), so region renders of a frame's parts assemble into the full
    /// render (`shadenet merge`).
    pub fn render_window(
        &self,
        window: Window,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> (Film, RenderStats) {
        let start = Instant::now();
        let loops_before = self.loop_limits();
        let (fw, fh) = (self.scene.camera.width, self.scene.camera.height);
        let window = Window {
            x0: window.x0.min(fw),
            y0: window.y0.min(fh),
            x1: window.x1.min(fw),
            y1: window.y1.min(fh),
        };
        let w = window.width();
        let ts = self.scene.settings.tile_size.max(1);
        let mut tiles = Vec::new();
        for y0 in (window.y0..window.y1).step_by(ts as usize) {
            for x0 in (window.x0..window.x1).step_by(ts as usize) {
                tiles.push((x0, y0, (x0 + ts).min(window.x1), (y0 + ts).min(window.y1)));
            }
        }
        let total = tiles.len() as u64;
        let done = AtomicU64::new(0);
        let layout = self.layout();
        let (outs, tile_stats): (Vec<TileOut>, Vec<TileStats>) = match self.mode {
            ShadingMode::Immediate => tiles
                .par_iter()
                .map(|&tile| {
                    let stats = TileStats::default();
                    let out = self.render_tile(tile, &layout, &stats);
                    let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                    progress(d, total);
                    (out, stats)
                })
                .unzip(),
            ShadingMode::Deferred(opts) => {
                let spp = self.scene.settings.spp as usize;
                let groups = group_tiles(&tiles, spp, opts.group_samples);
                let results: Vec<(Vec<TileOut>, TileStats)> = groups
                    .par_iter()
                    .map(|g| {
                        let stats = TileStats::default();
                        let outs = self.render_group(&tiles[g.clone()], &layout, &stats);
                        let d = done.fetch_add(g.len() as u64, Ordering::Relaxed) + g.len() as u64;
                        progress(d, total);
                        (outs, stats)
                    })
                    .collect();
                let mut outs = Vec::with_capacity(tiles.len());
                let mut stats = Vec::with_capacity(results.len());
                for (o, s) in results {
                    outs.extend(o);
                    stats.push(s);
                }
                (outs, stats)
            }
        };
        let t_film = Instant::now();
        let mut acc = vec![0.0f32; window.pixels() * layout.stride];
        let mut stats = self.stats.clone();
        for ((x0, y0, x1, _), out) in tiles.iter().zip(outs) {
            let tw = (x1 - x0) as usize;
            for (i, px) in out.values.chunks_exact(layout.stride).enumerate() {
                let (x, y) = (
                    (x0 - window.x0) as usize + i % tw,
                    (y0 - window.y0) as usize + i / tw,
                );
                let dst = (y * w as usize + x) * layout.stride;
                acc[dst..dst + layout.stride].copy_from_slice(px);
            }
        }
        for ts in tile_stats {
            ts.add_to(&mut stats);
        }
        stats.loop_limits = self.loop_limits() - loops_before;
        let film = self.compose(&acc, &layout, window);
        stats.stages.film += t_film.elapsed();
        stats.render_time = start.elapsed();
        (film, stats)
    }
}
