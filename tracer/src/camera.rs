//! The pinhole camera and its ray differentials.
//!
//! Pixel `(x, y)` (continuous, row 0 at the top) looks along `F + sx·R + sy·U`, with `sx =
//! (2x/W − 1)·tan(fov/2)·W/H` and `sy = (1 − 2y/H)·tan(fov/2)`, `fov` vertical. The ray
//! differentials are Igehy's (1999) exact derivatives of the normalized direction with
//! respect to the pixel coordinates; the origin does not move.

use crate::scene::CameraDesc;
use glam::Vec3;
use shadenet_graph::ops::math;

/// Ray differentials as derivatives of origin and direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayDiffs {
    /// ∂O/∂x.
    pub dodx: Vec3,
    /// ∂D/∂x.
    pub dddx: Vec3,
    /// ∂O/∂y.
    pub dody: Vec3,
    /// ∂D/∂y.
    pub dddy: Vec3,
}

impl RayDiffs {
    /// The differentials scaled by `s` (the footprint of one of several samples in a pixel).
    pub fn scaled(self, s: f32) -> RayDiffs {
        RayDiffs {
            dodx: self.dodx * s,
            dddx: self.dddx * s,
            dody: self.dody * s,
            dddy: self.dddy * s,
        }
    }

    /// The scale of a camera sample's differentials at `spp` samples per pixel:
    /// `max(1/8, 1/√spp)` (pbrt-v4's rule). Each sample's texture footprint shrinks to its
    /// share of the pixel, so filtered textures add little blur to the pixel filter and an
    /// image converges to the unfiltered one as `spp` grows.
    pub fn sample_scale(spp: u32) -> f32 {
        (1.0 / (spp.max(1) as f32).sqrt()).max(0.125)
    }
}

/// A camera ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraRay {
    /// Origin (the eye).
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// Differentials, when asked for.
    pub diffs: Option<RayDiffs>,
}

/// The camera's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// Per pixel step of `sx` and `sy`.
    step_x: f32,
    step_y: f32,
    width: f32,
    height: f32,
}

impl Camera {
    /// The camera of a scene (its description is validated: a non-degenerate frame).
    pub fn new(c: &CameraDesc) -> Camera {
        let f = (c.look_at - c.position).normalize();
        let r = f.cross(c.up).normalize();
        let u = r.cross(f);
        let tan = math::tan(0.5 * c.fov);
        let aspect = c.width as f64 / c.height as f64;
        Camera {
            eye: c.position.as_vec3(),
            forward: f.as_vec3(),
            right: r.as_vec3(),
            up: u.as_vec3(),
            step_x: (2.0 * tan * aspect / c.width as f64) as f32,
            step_y: (2.0 * tan / c.height as f64) as f32,
            width: c.width as f32,
            height: c.height as f32,
        }
    }

    /// The ray through continuous pixel position `(x, y)`.
    pub fn ray(&self, x: f32, y: f32, differentials: bool) -> CameraRay {
        let sx = (x - 0.5 * self.width) * self.step_x;
        let sy = (0.5 * self.height - y) * self.step_y;
        let v = self.forward + sx * self.right + sy * self.up;
        let len = v.length();
        let d = v / len;
        let diffs = differentials.then(|| {
            // d(v/|v|) = (dv − (dv·d)d)/|v|
            let dn = |dv: Vec3| (dv - dv.dot(d) * d) / len;
            RayDiffs {
                dodx: Vec3::ZERO,
                dddx: dn(self.right * self.step_x),
                dody: Vec3::ZERO,
                dddy: dn(-self.up * self.step_y),
            }
        });
        CameraRay {
            o: self.eye,
            d,
            diffs,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_footprints_shrink_with_the_sample_count_down_to_an_eighth() {
        let s = RayDiffs::sample_scale;
        assert_eq!(
            [s(0), s(1), s(4), s(16), s(64), s(1024)],
            [1.0, 1.0, 0.5, 0.25, 0.125, 0.125]
        );
        let d = RayDiffs {
            dodx: Vec3::X,
            dddx: Vec3::Y,
            dody: Vec3::Z,
            dddy: Vec3::ONE,
        };
        let h = d.scaled(0.5);
        assert_eq!(
            [h.dodx, h.dddx, h.dody, h.dddy],
            [Vec3::X * 0.5, Vec3::Y * 0.5, Vec3::Z * 0.5, Vec3::ONE * 0.5]
        );
    }
}
