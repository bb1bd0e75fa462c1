//! Immediate shading: each tile's camera samples traced and shaded one by one, in pixel and
//! sample order, into the tile's pixels.

use super::compile::Action;
use super::film::{Layout, TileOut, add_override_beauty, add_parts, put_override_pass};
use super::setup::Renderer;
use super::stats::TileStats;
use super::trace::RayState;
use shadenet_runtime::ShadeOut;

impl Renderer {
    pub(super) fn render_tile(
        &self,
        x0: u32,
        y0: u32,
        x1: u32,
        y1: u32,
        layout: &Layout,
        stats: &TileStats,
    ) -> TileOut {
        let spp = self.scene.settings.spp;
        let mut values = vec![0.0f32; ((x1 - x0) * (y1 - y0)) as usize * layout.stride];
        let mut sample = vec![0.0f32; layout.stride];
        let mut out = ShadeOut {
            values: Vec::new(),
            nonfinite: 0,
        };
        let inv = 1.0 / spp as f32;
        for y in y0..y1 {
            for x in x0..x1 {
                let i = ((y - y0) * (x1 - x0) + (x - x0)) as usize;
                let dst = &mut values[i * layout.stride..(i + 1) * layout.stride];
                for k in 0..spp {
                    sample.iter_mut().for_each(|v| *v = 0.0);
                    let state = self.camera_ray(x, y, k);
                    self.camera_sample(&state, layout, &mut sample, &mut out, stats);
                    for (d, s) in dst.iter_mut().zip(&sample) {
                        *d += *s;
                    }
                }
                dst.iter_mut().for_each(|v| *v *= inv);
            }
        }
        TileOut { values }
    }

    /// One camera sample into `sample` (the per-pixel layout).
    pub(super) fn camera_sample(
        &self,
        ray: &RayState,
        layout: &Layout,
        sample: &mut [f32],
        out: &mut ShadeOut<f32>,
        stats: &TileStats,
    ) {
        let Some((action, prep)) = self.camera_hit(ray, layout, sample, stats) else {
            return;
        };
        match action {
            Action::Material(a) => {
                let sp = &self.shaders[prep.material][*a];
                self.shade(sp, ray, &prep, out, stats);
                add_parts(sp, &out.values, layout, sample);
            }
            Action::Override(o) => {
                let v = self.override_value(*o, ray, &prep, out, stats);
                add_override_beauty(v, layout, sample);
            }
        }
        for &(o, off) in &layout.overrides {
            let v = self.override_value(o, ray, &prep, out, stats);
            put_override_pass(o, off, v, sample);
        }
    }
}
