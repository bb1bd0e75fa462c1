//! The image of an image environment light: a lat-long (equirectangular) radiance map, its
//! orientation and the checks every source of lights applies to it ([`LightDesc::new`]).
//!
//! This module owns the description only (texels, rotation, the direction ↔ texel
//! convention). Preparing it for sampling (the importance-sampling distribution) is the
//! runtime's (`shadenet_runtime::envmap`); reading files is the tracer's.
//!
//! Orientation, world space with +y up: `v = θ / π` where θ is the angle from +y, so the top
//! row (`v = 0`) is straight up and the bottom row (`v = 1`) straight down; `u = 0.5 + φ /
//! 2π` with `φ = atan2(x, −z)`, so the centre column (`u = 0.5`) faces −z, `u = 0.75` faces
//! +x, `u = 0.25` faces −x and the left and right edges (`u = 0`, `u = 1`) face +z: seen
//! from inside the sphere looking along −z the image appears unmirrored. `rotation` turns
//! the map about +y by that angle, counter-clockwise seen from above (right-hand rule): at 90°
//! the centre column faces −x.
//!
//! [`LightDesc::new`]: super::LightDesc::new

use crate::ops::math;
use std::f64::consts::PI;

/// The largest side of an environment map, in texels.
pub const MAX_ENV_MAP_SIDE: u32 = 16384;
/// The most texels an environment map may have (8192 × 4096): about 0.9 GB once prepared
/// for sampling (12 bytes a texel, 16 for its sampling tables).
pub const MAX_ENV_MAP_TEXELS: u64 = 1 << 25;

/// A lat-long radiance map, rows top (up) to bottom (down), linear RGB.
#[derive(Clone, PartialEq)]
pub struct EnvImage {
    /// Where it came from (a file name), for messages.
    pub source: String,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width × height` texels, row by row from the top.
    pub texels: Vec<[f32; 3]>,
    /// Rotation about +y, radians (see the module documentation).
    pub rotation: f64,
}

impl std::fmt::Debug for EnvImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EnvImage")
            .field("source", &self.source)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("rotation", &self.rotation)
            .finish_non_exhaustive()
    }
}

impl EnvImage {
    /// What is wrong with the image, if anything: a size of 0 or beyond
    /// [`MAX_ENV_MAP_SIDE`] / [`MAX_ENV_MAP_TEXELS`], a texel count that does not match,
    /// a non-finite rotation, or a texel channel that is NaN, infinite or negative (named
    /// by its column and row from the top-left).
    pub fn check(&self) -> Result<(), String> {
        let (w, h) = (self.width, self.height);
        check_size(w, h)?;
        if self.texels.len() as u64 != w as u64 * h as u64 {
            return Err(format!(
                "{}: {} texels for a {w}×{h} image",
                self.source,
                self.texels.len()
            ));
        }
        if !self.rotation.is_finite() {
            return Err(format!("rotation {} is not a finite number", self.rotation));
        }
        for (i, t) in self.texels.iter().enumerate() {
            for (c, x) in t.iter().enumerate() {
                if !(x.is_finite() && *x >= 0.0) {
                    return Err(format!(
                        "{}: texel ({}, {}) has {} = {x}: radiance must be finite and ≥ 0",
                        self.source,
                        i % w as usize,
                        i / w as usize,
                        ["red", "green", "blue"][c]
                    ));
                }
            }
        }
        Ok(())
    }

    /// The texel at column `x`, row `y` (from the top).
    pub fn texel(&self, x: u32, y: u32) -> [f32; 3] {
        self.texels[y as usize * self.width as usize + x as usize]
    }

    /// `cos` and `sin` of the rotation (exactly 1 and 0 at 0).
    pub fn rotation_cos_sin(&self) -> (f64, f64) {
        (math::cos(self.rotation), math::sin(self.rotation))
    }
}

/// Whether a `width × height` map is within the limits (the error says which is not).
pub fn check_size(width: u32, height: u32) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!("the image is empty ({width}×{height} texels)"));
    }
    if width > MAX_ENV_MAP_SIDE
        || height > MAX_ENV_MAP_SIDE
        || width as u64 * height as u64 > MAX_ENV_MAP_TEXELS
    {
        return Err(format!(
            "{width}×{height} texels is too large: at most {MAX_ENV_MAP_SIDE} a side and \
             {MAX_ENV_MAP_TEXELS} in all"
        ));
    }
    Ok(())
}

/// The map coordinates `(u, v)` ∈ [0, 1]² of unit world direction `d` under rotation
/// `(cos, sin)` ([`EnvImage::rotation_cos_sin`]), and `sin θ` (θ from +y).
pub fn direction_to_uv(d: [f64; 3], (c, s): (f64, f64)) -> ([f64; 2], f64) {
    // Into the map's frame: R_y(−rotation) · d.
    let x = d[0] * c - d[2] * s;
    let z = d[0] * s + d[2] * c;
    let y = d[1];
    let sin_t = (x * x + z * z).sqrt();
    let theta = math::atan2(sin_t, y);
    let phi = math::atan2(x, -z);
    let u = 0.5 + phi * (0.5 / PI);
    let v = theta * (1.0 / PI);
    ([u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)], sin_t)
}

/// The unit world direction of map coordinates `(u, v)` under rotation `(cos, sin)`, and
/// `sin θ`: the inverse of [`direction_to_uv`].
pub fn uv_to_direction(uv: [f64; 2], (c, s): (f64, f64)) -> ([f64; 3], f64) {
    let theta = PI * uv[1];
    let phi = 2.0 * PI * (uv[0] - 0.5);
    let (sin_t, cos_t) = (math::sin(theta), math::cos(theta));
    let (xm, ym, zm) = (sin_t * math::sin(phi), cos_t, -sin_t * math::cos(phi));
    // Out of the map's frame: R_y(rotation) · d.
    ([xm * c + zm * s, ym, -xm * s + zm * c], sin_t)
}
