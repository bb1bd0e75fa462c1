//! Owen-scrambled Sobol points (Burley 2020, "Practical Hash-based Owen Scrambling", with
//! the improved Laine–Karras hash of Vegdahl 2021) and the renderer's fixed dimension plan.
//! Pure arithmetic: it owns no renderer state and must not trace or shade.
//!
//! Every group of the plan ([`Dim`]) is a 2D (or 1D) Sobol set padded with the others the way
//! Burley does: each group draws Sobol dimensions 0 and 1 (the best 2D projection) at an
//! index shuffled by a nested uniform scramble seeded per pixel and group, and each
//! coordinate is Owen-scrambled with its own seed. The first `2^m` samples of a pixel are
//! then a (0, m, 2)-net in every group, the groups are decorrelated from each other, and
//! pixels from their neighbours.

/// The dimension plan: what each sample dimension is for. Light, lobe and roulette
/// dimensions are per bounce (0 for the camera hit).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dim {
    /// Position in the pixel (2D).
    Pixel,
    /// Position on the lens (2D; the pinhole camera uses none).
    Lens,
    /// Time in the shutter (1D; no motion yet).
    Time,
    /// A light sample at a bounce (2D).
    Light(u32),
    /// A lobe sample at a bounce (2D).
    Lobe(u32),
    /// Russian roulette at a bounce (1D).
    Roulette(u32),
}

impl Dim {
    /// The group number: the seed of its shuffle and scrambles.
    fn group(self) -> u32 {
        match self {
            Dim::Pixel => 0,
            Dim::Lens => 1,
            Dim::Time => 2,
            Dim::Light(b) => 3 + 3 * b,
            Dim::Lobe(b) => 4 + 3 * b,
            Dim::Roulette(b) => 5 + 3 * b,
        }
    }
}

/// Sobol dimension 1's generator (Pascal's matrix): `v[i] = v[i-1] ^ (v[i-1] >> 1)`.
const SOBOL1: [u32; 32] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut i = 1;
    while i < 32 {
        v[i] = v[i - 1] ^ (v[i - 1] >> 1);
        i += 1;
    }
    v
};

/// Sobol dimension 1 by bytes: `SOBOL1_BYTES[j][b]` is the XOR of the generator columns that
/// the set bits of byte value `b` select at byte `j` of the index (four lookups per point
/// instead of a 32-step loop: shuffled indices use all 32 bits).
const SOBOL1_BYTES: [[u32; 256]; 4] = {
    let mut t = [[0u32; 256]; 4];
    let mut j = 0;
    while j < 4 {
        let mut b = 0;
        while b < 256 {
            let mut x = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if b >> bit & 1 != 0 {
                    x ^= SOBOL1[j * 8 + bit];
                }
                bit += 1;
            }
            t[j][b] = x;
            b += 1;
        }
        j += 1;
    }
    t
};

/// Sobol dimension 0 (van der Corput: the index's bits reversed) and 1 at `index`.
fn sobol2(index: u32) -> (u32, u32) {
    let [b0, b1, b2, b3] = index.to_le_bytes();
    let y = SOBOL1_BYTES[0][b0 as usize]
        ^ SOBOL1_BYTES[1][b1 as usize]
        ^ SOBOL1_BYTES[2][b2 as usize]
        ^ SOBOL1_BYTES[3][b3 as usize];
    (index.reverse_bits(), y)
}

/// The Laine–Karras style permutation, improved constants (Vegdahl 2021): each output bit
/// depends only on the input bits below it, so on reversed bits it is a nested uniform
/// (Owen) scramble.
fn lk_hash(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Owen scramble of a 32-bit fixed-point coordinate (or a shuffle of an index).
fn owen(x: u32, seed: u32) -> u32 {
    lk_hash(x.reverse_bits(), seed).reverse_bits()
}

/// A well-mixed 32-bit hash of two words (for seeds).
fn mix(a: u32, b: u32) -> u32 {
    let mut h = (u64::from(a) << 32 | u64::from(b)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    h ^= h >> 29;
    h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    h ^= h >> 32;
    h as u32
}

/// A 32-bit fixed-point value as a float in [0, 1) (24 bits: never rounds up to 1).
fn unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// The seeds of one pixel's 2D group: the index shuffle's and each coordinate's scramble's
/// (computed once per pixel and group, used for each of its samples).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GroupSeeds([u32; 3]);

impl GroupSeeds {
    /// The seeds of group `dim` of the pixel whose seed is `pixel_seed`.
    pub fn new(pixel_seed: u32, dim: Dim) -> GroupSeeds {
        let seed = mix(pixel_seed, dim.group());
        GroupSeeds([
            mix(seed, 0x5348_5546),
            mix(seed, 0x5843_4f30),
            mix(seed, 0x5843_4f31),
        ])
    }

    /// Sample `index` of the group: a point of [0, 1)².
    pub fn sample2(self, index: u32) -> [f32; 2] {
        let [shuffle, sx, sy] = self.0;
        let (a, b) = sobol2(owen(index, shuffle));
        [unit(owen(a, sx)), unit(owen(b, sy))]
    }
}

/// Sample `index` of the pixel whose seed is `pixel_seed`, in the 2D group `dim`: a point
/// of [0, 1)².
pub fn sample2(pixel_seed: u32, index: u32, dim: Dim) -> [f32; 2] {
    GroupSeeds::new(pixel_seed, dim).sample2(index)
}

/// Sample `index` of a pixel in the 1D group `dim` (time, roulette): a value in [0, 1).
pub fn sample1(pixel_seed: u32, index: u32, dim: Dim) -> f32 {
    let seed = mix(pixel_seed, dim.group());
    let i = owen(index, mix(seed, 0x5348_5546));
    unit(owen(i.reverse_bits(), mix(seed, 0x5843_4f30)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first 2^m samples of a pixel are a (0, m, 2)-net: every elementary interval of
    /// area 2^-m (2^a × 2^(m−a) cells) holds exactly one point, in each group and pixel.
    #[test]
    fn the_first_power_of_two_samples_are_a_net() {
        for (pixel, dim) in [(0u32, Dim::Pixel), (12345, Dim::Pixel), (7, Dim::Light(2))] {
            for m in [2u32, 4, 6] {
                let n = 1u32 << m;
                let pts: Vec<[f32; 2]> = (0..n).map(|k| sample2(pixel, k, dim)).collect();
                for a in 0..=m {
                    let (cx, cy) = (1u32 << a, 1u32 << (m - a));
                    let mut seen = vec![0u32; n as usize];
                    for p in &pts {
                        let i = (p[0] * cx as f32) as u32;
                        let j = (p[1] * cy as f32) as u32;
                        seen[(j * cx + i) as usize] += 1;
                    }
                    assert!(
                        seen.iter().all(|&c| c == 1),
                        "pixel {pixel} {dim:?} m={m} cells {cx}x{cy}: {seen:?}"
                    );
                }
            }
        }
    }

    /// The byte tables give the generator matrix's product bit for bit.
    #[test]
    fn sobol_by_bytes_is_the_matrix_product() {
        for i in [0u32, 1, 2, 3, 255, 256, 0xdead_beef, u32::MAX, 0x8000_0001] {
            let mut y = 0u32;
            for (bit, col) in SOBOL1.iter().enumerate() {
                if i >> bit & 1 != 0 {
                    y ^= col;
                }
            }
            assert_eq!(sobol2(i), (i.reverse_bits(), y), "index {i:#x}");
        }
        // Dimension 1's first points: 1/2, then 3/4 and 1/4.
        let unit = |x: u32| x as f64 / 2f64.powi(32);
        let ys: Vec<f64> = (0..4).map(|i| unit(sobol2(i).1)).collect();
        assert_eq!(ys, [0.0, 0.5, 0.75, 0.25]);
    }

    /// Different pixels and groups get different points; 1D samples stratify too.
    #[test]
    fn pixels_and_groups_are_decorrelated_and_1d_stratifies() {
        assert_ne!(sample2(1, 0, Dim::Pixel), sample2(2, 0, Dim::Pixel));
        assert_ne!(sample2(1, 0, Dim::Pixel), sample2(1, 0, Dim::Lens));
        let mut seen = [0u32; 16];
        for k in 0..16 {
            let v = sample1(99, k, Dim::Roulette(0));
            assert!((0.0..1.0).contains(&v));
            seen[(v * 16.0) as usize] += 1;
        }
        assert_eq!(seen, [1; 16]);
    }
}
