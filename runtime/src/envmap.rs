//! Image environment lights prepared for sampling: the piecewise-constant 2D distribution
//! over a lat-long map (pbrt's `PiecewiseConstant2D`: a marginal over rows, a conditional
//! per row), its density per solid angle, and the map's radiance in a direction.
//!
//! The function sampled over a texel is the mean luminance (Rec. 709 weights) of the
//! radiance [`EnvMap::radiance`] returns inside it — the bilinear reconstruction's mean,
//! the texel's luminance filtered by `(1/8, 3/4, 1/8)` across and down (wrapping in `u`,
//! clamped at the poles as the lookup is) — times `sin θ` at its row's centre, so
//! directions are drawn in proportion to the light they bring (the `sin θ` accounts for
//! the rows near the poles covering less of the sphere). Wherever the radiance is not zero
//! the density is not zero either, and a dim texel beside the sun, whose lookups near the
//! shared edge blend in the sun, is sampled for it: weighting by the texel's own luminance
//! instead made such samples 50 to 500 times the mean and the estimate 4× noisier. It is built once per
//! light, when the light is prepared ([`crate::lights::Light::from_desc`]), and shared. The
//! orientation convention is `shadenet_graph::nodes::env_image`'s. Everything is f64 with
//! our own `sin`, `cos` and `atan2`, so the same seed gives the same direction, density
//! and radiance in f32 and f64 runs and on every platform.

use shadenet_graph::nodes::env_image::{EnvImage, direction_to_uv, uv_to_direction};
use shadenet_graph::ops::math;
use std::f64::consts::PI;
use std::sync::Arc;

/// An environment map ready to sample.
#[derive(Clone, PartialEq)]
pub struct EnvMap {
    image: Arc<EnvImage>,
    /// `cos` and `sin` of the rotation.
    rot: (f64, f64),
    /// Per row, `width + 1` entries: the normalized CDF over the row's columns.
    conditional: Vec<f64>,
    /// `height + 1` entries: the normalized CDF over rows.
    marginal: Vec<f64>,
    /// The sampled function per texel, row by row.
    func: Vec<f64>,
    /// The integral of the sampled function over `[0, 1]²` (0: the map is black).
    total: f64,
}

impl std::fmt::Debug for EnvMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EnvMap")
            .field("image", &self.image)
            .field("total", &self.total)
            .finish_non_exhaustive()
    }
}

/// Rec. 709 luminance of a texel.
fn luminance(t: [f32; 3]) -> f64 {
    0.2126 * t[0] as f64 + 0.7152 * t[1] as f64 + 0.0722 * t[2] as f64
}

/// Turns running sums `cdf[0] = 0 ≤ … ≤ cdf[n]` into a CDF ending at 1 (uniform steps where
/// the sum is 0).
fn normalize(cdf: &mut [f64]) {
    let n = cdf.len() - 1;
    let total = cdf[n];
    for (i, c) in cdf.iter_mut().enumerate() {
        *c = if total > 0.0 {
            *c / total
        } else {
            i as f64 / n as f64
        };
    }
}

/// The segment `o` of a normalized CDF holding `u` ∈ [0, 1) and where `u` falls in it, in
/// [0, 1) (a zero-width segment is never chosen while a wider one holds `u`).
fn sample_1d(cdf: &[f64], u: f64) -> (usize, f64) {
    let n = cdf.len() - 1;
    let o = cdf
        .partition_point(|&c| c <= u)
        .saturating_sub(1)
        .min(n - 1);
    let width = cdf[o + 1] - cdf[o];
    let du = if width > 0.0 {
        (u - cdf[o]) / width
    } else {
        0.0
    };
    (o, du.clamp(0.0, 1.0 - f64::EPSILON))
}

/// The function sampled, per texel: the mean luminance of the bilinear reconstruction over
/// the texel (luminance filtered by `(1/8, 3/4, 1/8)` both ways, wrapping across, clamped
/// down) times `sin θ` at the row's centre.
fn sampled_function(image: &EnvImage) -> Vec<f64> {
    let (w, h) = (image.width as usize, image.height as usize);
    let lum: Vec<f64> = image.texels.iter().map(|t| luminance(*t)).collect();
    const K: [f64; 3] = [0.125, 0.75, 0.125];
    // Across (wrapping), then down (clamped).
    let across: Vec<f64> = (0..w * h)
        .map(|k| {
            let (i, row) = (k % w, k - k % w);
            K[0] * lum[row + (i + w - 1) % w] + K[1] * lum[k] + K[2] * lum[row + (i + 1) % w]
        })
        .collect();
    (0..w * h)
        .map(|k| {
            let j = k / w;
            let (up, down) = (j.saturating_sub(1), (j + 1).min(h - 1));
            let f =
                K[0] * across[up * w + k % w] + K[1] * across[k] + K[2] * across[down * w + k % w];
            f * math::sin(PI * (j as f64 + 0.5) / h as f64)
        })
        .collect()
}

impl EnvMap {
    /// Builds the distribution of a (checked) map: `O(width × height)`, once per light.
    pub fn new(image: Arc<EnvImage>) -> EnvMap {
        let func = sampled_function(&image);
        let (w, h) = (image.width as usize, image.height as usize);
        let mut conditional = vec![0.0; h * (w + 1)];
        let mut marginal = vec![0.0; h + 1];
        for (j, cdf) in conditional.chunks_exact_mut(w + 1).enumerate() {
            for (i, f) in func[j * w..(j + 1) * w].iter().enumerate() {
                cdf[i + 1] = cdf[i] + f / w as f64;
            }
            marginal[j + 1] = marginal[j] + cdf[w] / h as f64;
            normalize(cdf);
        }
        let total = marginal[h];
        normalize(&mut marginal);
        EnvMap {
            rot: image.rotation_cos_sin(),
            image,
            conditional,
            marginal,
            func,
            total,
        }
    }

    /// The map.
    pub fn image(&self) -> &EnvImage {
        &self.image
    }

    /// Whether the map is black everywhere (then it gives no light and no samples).
    pub fn is_black(&self) -> bool {
        self.total <= 0.0
    }

    /// The density per solid angle with which [`EnvMap::sample`] draws unit direction
    /// `d`: `f(texel) / total / (2π² sin θ)`; 0 for a black map and at the poles.
    pub fn pdf(&self, d: [f64; 3]) -> f64 {
        let (uv, sin_t) = direction_to_uv(d, self.rot);
        self.pdf_at(uv, sin_t)
    }

    /// [`EnvMap::pdf`] and [`EnvMap::radiance`] of one direction, which it maps to the
    /// image once (what a light sample needs).
    pub fn pdf_and_radiance(&self, d: [f64; 3]) -> (f64, [f64; 3]) {
        let (uv, sin_t) = direction_to_uv(d, self.rot);
        (self.pdf_at(uv, sin_t), self.radiance_at(uv))
    }

    /// [`EnvMap::pdf`] at image coordinates `uv` whose row is at `sin θ = sin_t`.
    fn pdf_at(&self, uv: [f64; 2], sin_t: f64) -> f64 {
        if self.is_black() || sin_t <= 0.0 {
            return 0.0;
        }
        let (w, h) = (self.image.width as usize, self.image.height as usize);
        let i = ((uv[0] * w as f64) as usize).min(w - 1);
        let j = ((uv[1] * h as f64) as usize).min(h - 1);
        self.func[j * w + i] / self.total / (2.0 * PI * PI * sin_t)
    }

    /// A direction drawn by the map's luminance from two uniform numbers in [0, 1), and its
    /// density per solid angle ([`EnvMap::pdf`] of that direction, so the light loop's
    /// density and the renderer's agree to the bit); `None` for a black map.
    pub fn sample(&self, u: [f64; 2]) -> Option<([f64; 3], f64)> {
        let d = self.draw(u)?;
        Some((d, self.pdf(d)))
    }

    /// The direction [`EnvMap::sample`] draws for `u`, with its density and the map's
    /// radiance there, mapping it back to the image once ([`EnvMap::pdf_and_radiance`]);
    /// `None` for a black map.
    pub fn sample_with_radiance(&self, u: [f64; 2]) -> Option<([f64; 3], f64, [f64; 3])> {
        let d = self.draw(u)?;
        let (pdf, rad) = self.pdf_and_radiance(d);
        Some((d, pdf, rad))
    }

    /// The unit direction drawn for `u` (texel by the 2D distribution, then uniformly
    /// within it); `None` for a black map.
    fn draw(&self, u: [f64; 2]) -> Option<[f64; 3]> {
        if self.is_black() {
            return None;
        }
        let (w, h) = (self.image.width as usize, self.image.height as usize);
        let (j, dv) = sample_1d(&self.marginal, u[1]);
        let (i, du) = sample_1d(&self.conditional[j * (w + 1)..(j + 1) * (w + 1)], u[0]);
        let uv = [(i as f64 + du) / w as f64, (j as f64 + dv) / h as f64];
        Some(uv_to_direction(uv, self.rot).0)
    }

    /// The map's radiance in unit direction `d`: bilinear between texel centres, wrapping
    /// around in `u` and clamped at the poles.
    pub fn radiance(&self, d: [f64; 3]) -> [f64; 3] {
        let (uv, _) = direction_to_uv(d, self.rot);
        self.radiance_at(uv)
    }

    /// [`EnvMap::radiance`] at image coordinates `uv`.
    fn radiance_at(&self, uv: [f64; 2]) -> [f64; 3] {
        let (w, h) = (self.image.width as i64, self.image.height as i64);
        let x = uv[0] * w as f64 - 0.5;
        let y = uv[1] * h as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        if !(fx.is_finite() && fy.is_finite()) {
            return [0.0; 3];
        }
        let (x0, y0) = (x0 as i64, y0 as i64);
        let texel = |xi: i64, yi: i64| {
            let t = self
                .image
                .texel(xi.rem_euclid(w) as u32, yi.clamp(0, h - 1) as u32);
            t.map(|c| c as f64)
        };
        let (t00, t10) = (texel(x0, y0), texel(x0 + 1, y0));
        let (t01, t11) = (texel(x0, y0 + 1), texel(x0 + 1, y0 + 1));
        std::array::from_fn(|c| {
            let top = t00[c] + fx * (t10[c] - t00[c]);
            let bottom = t01[c] + fx * (t11[c] - t01[c]);
            top + fy * (bottom - top)
        })
    }
}
