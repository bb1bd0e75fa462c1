//! The sample stage: the camera rays of a pixel's samples, through the position the pixel
//! sampler gives, with its seed. It must not trace or shade.

use super::pixel::{hash3, pixel_seeds};
use super::setup::Renderer;
use super::trace::RayState;
use crate::camera::RayDiffs;
use crate::passes::RayMatch;

/// Four uniform numbers in [0, 1) for a shading point's BSDF sample (the `rand` stream),
/// hashed from the ray's seed, which is unique per pixel sample, bounce and direction.
/// (Drawing them from the Sobol sequence's higher dimensions is the next step.)
pub(super) fn rand4(seed: u32) -> [f32; 4] {
    std::array::from_fn(|k| {
        let h = hash3(seed, 0x5bd1_e995, k as u32);
        (h >> 8) as f32 / (1u32 << 24) as f32
    })
}

impl Renderer {
    /// Appends the camera rays of every sample of pixel `(x, y)`, in sample order.
    pub(super) fn camera_rays(&self, x: u32, y: u32, rays: &mut Vec<RayState>) {
        let spp = self.scene.settings.spp;
        let seeds = pixel_seeds(x, y);
        let scale = RayDiffs::sample_scale(spp);
        rays.extend((0..spp).map(|k| {
            let (px, py) = self.sampler.position(x, y, seeds, k, spp);
            let mut ray = self.camera.ray(px, py, self.differentials);
            ray.diffs = ray.diffs.map(|d| d.scaled(scale));
            RayState {
                o: ray.o,
                d: ray.d,
                ray: RayMatch::Camera,
                depth: 0,
                seed: hash3(x, y, k),
                diffs: ray.diffs,
                bsdf_pdf: 0.0,
            }
        }));
    }
}
