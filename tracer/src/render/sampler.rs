//! The sample stage: the camera rays of a pixel's samples, through the position the pixel
//! sampler gives, with its seed. It must not trace or shade.

use super::pixel::{hash3, pixel_seeds};
use super::setup::Renderer;
use super::trace::RayState;
use crate::passes::RayMatch;

impl Renderer {
    /// Appends the camera rays of every sample of pixel `(x, y)`, in sample order.
    pub(super) fn camera_rays(&self, x: u32, y: u32, rays: &mut Vec<RayState>) {
        let spp = self.scene.settings.spp;
        let seeds = pixel_seeds(x, y);
        rays.extend((0..spp).map(|k| {
            let (px, py) = self.sampler.position(x, y, seeds, k, spp);
            let ray = self.camera.ray(px, py, self.differentials);
            RayState {
                o: ray.o,
                d: ray.d,
                ray: RayMatch::Camera,
                depth: 0,
                seed: hash3(x, y, k),
                diffs: ray.diffs,
            }
        }));
    }
}
