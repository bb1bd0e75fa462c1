//! The sampler: where sample `k` of a pixel sits inside it, the per-sample seed, and the
//! camera ray through it. It must not trace or shade.

use super::setup::Renderer;
use super::trace::RayState;
use crate::passes::RayMatch;

/// A 32-bit hash of three words (a counter-based generator: no state).
pub fn hash3(a: u32, b: u32, c: u32) -> u32 {
    let mut h = a
        .wrapping_mul(0x9e37_79b1)
        .wrapping_add(b.wrapping_mul(0x85eb_ca77))
        .wrapping_add(c.wrapping_mul(0xc2b2_ae3d))
        ^ 0x27d4_eb2f;
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297a_2d39);
    h ^= h >> 15;
    h
}

/// The offset of sample `k` inside pixel `(x, y)`: the centre for one sample per pixel,
/// else the R2 sequence rotated by a per-pixel hash (Cranley–Patterson).
pub fn pixel_sample(x: u32, y: u32, k: u32, spp: u32) -> (f32, f32) {
    if spp <= 1 {
        return (0.5, 0.5);
    }
    const A1: f64 = 0.754_877_666_246_692_7; // 1/φ₂
    const A2: f64 = 0.569_840_290_998_053_3; // 1/φ₂²
    let h = hash3(x, y, 0xa5a5_a5a5);
    let r0 = (h >> 16) as f64 / 65536.0;
    let r1 = (h & 0xffff) as f64 / 65536.0;
    let fx = (0.5 + A1 * k as f64 + r0).fract();
    let fy = (0.5 + A2 * k as f64 + r1).fract();
    (fx as f32, fy as f32)
}

impl Renderer {
    /// The camera ray of sample `k` of pixel `(x, y)`.
    pub(super) fn camera_ray(&self, x: u32, y: u32, k: u32) -> RayState {
        let spp = self.scene.settings.spp;
        let (jx, jy) = pixel_sample(x, y, k, spp);
        let ray = self
            .camera
            .ray(x as f32 + jx, y as f32 + jy, self.differentials);
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
