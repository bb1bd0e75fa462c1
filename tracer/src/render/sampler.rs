//! The sample stage: the camera ray of sample `k` of a pixel, through the position the pixel
//! sampler gives, with its seed. It must not trace or shade.

use super::pixel::hash3;
use super::setup::Renderer;
use super::trace::RayState;
use crate::passes::RayMatch;

impl Renderer {
    /// The camera ray of sample `k` of pixel `(x, y)`.
    pub(super) fn camera_ray(&self, x: u32, y: u32, k: u32) -> RayState {
        let (px, py) = self.sampler.position(x, y, k, self.scene.settings.spp);
        let ray = self.camera.ray(px, py, self.differentials);
        RayState {
            o: ray.o,
            d: ray.d,
            ray: RayMatch::Camera,
            depth: 0,
            seed: hash3(x, y, k),
            diffs: ray.diffs,
        }
    }
}
