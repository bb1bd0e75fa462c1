//! Immediate shading: each tile's camera samples traced and shaded one by one, in pixel and
//! sample order, into the tile's pixels.

use super::compile::Action;
use super::film::{Layout, TileOut, accumulate, add_override_beauty, add_parts, put_override_pass};
use super::setup::Renderer;
use super::stats::{Stage, TileStats};
use super::trace::{Prepared, RayState};
use shadenet_runtime::ShadeOut;
use std::time::Instant;

impl Renderer {
    /// One tile, a row of pixels at a time, stage by stage: the row's camera rays, their
    /// hits, the shading of each hit (in sample order), then the samples added into pixels.
    pub(super) fn render_tile(
        &self,
        (x0, y0, x1, y1): (u32, u32, u32, u32),
        layout: &Layout,
        stats: &TileStats,
    ) -> TileOut {
        let spp = self.scene.settings.spp;
        let stride = layout.stride;
        let row = (x1 - x0) as usize;
        let mut values = Vec::with_capacity(row * (y1 - y0) as usize * stride);
        let mut rays = Vec::with_capacity(row * spp as usize);
        let mut hits = Vec::with_capacity(row * spp as usize);
        let mut samples = vec![0.0f32; row * spp as usize * stride];
        let mut out = ShadeOut::default();
        let mut t = Instant::now();
        for y in y0..y1 {
            rays.clear();
            for x in x0..x1 {
                self.camera_rays(x, y, &mut rays);
            }
            t = stats.lap(Stage::Sample, t);
            samples.iter_mut().for_each(|v| *v = 0.0);
            hits.clear();
            for (ray, sample) in rays.iter().zip(samples.chunks_exact_mut(stride)) {
                hits.push(self.camera_hit(ray, layout, sample, stats));
            }
            t = stats.lap(Stage::Trace, t);
            for ((ray, hit), sample) in rays.iter().zip(&hits).zip(samples.chunks_exact_mut(stride))
            {
                if let Some(hit) = hit {
                    self.shade_camera_hit(hit, ray, layout, sample, &mut out, stats);
                }
            }
            t = stats.lap(Stage::Shade, t);
            values.extend(accumulate(&samples, spp, stride));
            t = stats.lap(Stage::Film, t);
        }
        TileOut { values }
    }

    /// Shades a camera hit into its sample (the per-pixel layout): the action's shader,
    /// then each override pass.
    fn shade_camera_hit(
        &self,
        (action, prep): &(&Action, Prepared),
        ray: &RayState,
        layout: &Layout,
        sample: &mut [f32],
        out: &mut ShadeOut<f32>,
        stats: &TileStats,
    ) {
        match action {
            Action::Material(a) => {
                let sp = &self.shaders[prep.material][*a];
                self.shade(sp, ray, prep, out, stats);
                add_parts(sp, &out.values, layout, sample);
            }
            Action::Override(o) => {
                let v = self.override_value(*o, ray, prep, out, stats);
                add_override_beauty(v, layout, sample);
            }
        }
        for &(o, off) in &layout.overrides {
            let v = self.override_value(o, ray, prep, out, stats);
            put_override_pass(o, off, v, sample);
        }
    }
}
