//! Pixel samples: where sample `k` of a pixel sits (Owen-scrambled Sobol points of the
//! [`Dim::Pixel`] group, drawn through the pixel filter) and the per-sample hashes. Pure
//! arithmetic: it must not trace or shade.

use super::sobol::{Dim, GroupSeeds};
use crate::scene::{FilterKind, PixelFilter};

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

/// The seed of a pixel's sample sequence (every group of the dimension plan derives its
/// own from it).
pub fn pixel_seed(x: u32, y: u32) -> u32 {
    hash3(x, y, 0x50_49_58_53)
}

/// The offset of sample `k` inside pixel `(x, y)` with a box filter one pixel wide: the
/// centre for one sample per pixel, else the Owen-scrambled Sobol point `k` of the pixel.
pub fn pixel_sample(x: u32, y: u32, k: u32, spp: u32) -> (f32, f32) {
    if spp <= 1 {
        return (0.5, 0.5);
    }
    let [u, v] = pixel_seeds(x, y).sample2(k);
    (u, v)
}

/// The seeds of pixel `(x, y)`'s [`Dim::Pixel`] group.
pub(super) fn pixel_seeds(x: u32, y: u32) -> GroupSeeds {
    GroupSeeds::new(pixel_seed(x, y), Dim::Pixel)
}

/// Bins of a tabulated filter's inverse CDF.
const FILTER_BINS: usize = 512;

/// Camera sample positions: the pixel filter as a sampling density (separable, one axis
/// tabulated once), applied to the sampler's points.
#[derive(Clone, Debug)]
pub(super) struct PixelSampler {
    filter: PixelFilter,
    /// The filter's CDF along one axis at `FILTER_BINS + 1` evenly spaced offsets over
    /// `[-width/2, width/2]` (empty for the box filter).
    cdf: Vec<f64>,
}

impl PixelSampler {
    /// The sampler of a filter.
    pub(super) fn new(filter: PixelFilter) -> PixelSampler {
        let half = f64::from(filter.width) / 2.0;
        let weight = |x: f64| -> f64 {
            match filter.kind {
                FilterKind::Box => 1.0,
                FilterKind::Gaussian => {
                    let sigma = f64::from(filter.width) / 6.0;
                    (-x * x / (2.0 * sigma * sigma)).exp()
                }
                FilterKind::BlackmanHarris => {
                    let t = std::f64::consts::TAU * (x + half) / (2.0 * half);
                    (0.35875 - 0.48829 * t.cos() + 0.14128 * (2.0 * t).cos()
                        - 0.01168 * (3.0 * t).cos())
                    .max(0.0)
                }
            }
        };
        let cdf = if filter.kind == FilterKind::Box {
            Vec::new()
        } else {
            let step = 2.0 * half / FILTER_BINS as f64;
            let mut cdf = vec![0.0f64; FILTER_BINS + 1];
            for i in 0..FILTER_BINS {
                let (a, b) = (-half + i as f64 * step, -half + (i + 1) as f64 * step);
                cdf[i + 1] = cdf[i] + 0.5 * (weight(a) + weight(b)) * step;
            }
            let total = cdf[FILTER_BINS].max(f64::MIN_POSITIVE);
            cdf.iter_mut().for_each(|c| *c /= total);
            cdf
        };
        PixelSampler { filter, cdf }
    }

    /// The offset from the pixel centre along one axis for a uniform `u` in [0, 1).
    fn offset(&self, u: f32) -> f32 {
        let half = self.filter.width / 2.0;
        if self.cdf.is_empty() {
            return (u - 0.5) * self.filter.width;
        }
        let u = f64::from(u);
        let i = self.cdf.partition_point(|&c| c <= u).clamp(1, FILTER_BINS) - 1;
        let (c0, c1) = (self.cdf[i], self.cdf[i + 1]);
        let t = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.5 };
        let x = (i as f64 + t) / FILTER_BINS as f64;
        (-f64::from(half) + x * 2.0 * f64::from(half)) as f32
    }

    /// Where sample `k` of `spp` of pixel `(x, y)` sits, in continuous pixel coordinates
    /// (`seeds`: the pixel's, [`pixel_seeds`], computed once per pixel by the caller): the
    /// centre for one sample per pixel; a plain one-pixel box keeps the point inside its
    /// pixel.
    pub(super) fn position(
        &self,
        x: u32,
        y: u32,
        seeds: GroupSeeds,
        k: u32,
        spp: u32,
    ) -> (f32, f32) {
        let (u, v) = if spp <= 1 {
            (0.5, 0.5)
        } else {
            let [u, v] = seeds.sample2(k);
            (u, v)
        };
        if spp <= 1 || (self.cdf.is_empty() && self.filter.width == 1.0) {
            return (x as f32 + u, y as f32 + v);
        }
        (
            x as f32 + 0.5 + self.offset(u),
            y as f32 + 0.5 + self.offset(v),
        )
    }
}
