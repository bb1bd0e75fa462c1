//! Procedural noise: improved Perlin noise (Perlin 2002), fBm and cell noise.
//!
//! Lattice coordinates are computed as `floor(x)` in the evaluation precision and hashed as
//! integers, so f32 and f64 runs pick the same lattice cell except within rounding of a cell
//! boundary. Huge or non-finite coordinates saturate to a valid cell (never a panic).

use super::Real;

/// Ken Perlin's reference permutation (Improved Noise, 2002). The GPU back end's WGSL noise
/// reads the same table (written into its library from here).
pub const PERM: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69,
    142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219,
    203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175,
    74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230,
    220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76,
    132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173,
    186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163,
    70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232,
    178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162,
    241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204,
    176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141,
    128, 195, 78, 66, 215, 61, 156, 180,
];

fn perm(i: i32) -> i32 {
    PERM[(i & 255) as usize] as i32
}

fn fade<F: Real>(t: F) -> F {
    let c6 = F::from_f64(6.0);
    let c15 = F::from_f64(15.0);
    let c10 = F::from_f64(10.0);
    t * t * t * (t * (t * c6 - c15) + c10)
}

fn lerp<F: Real>(t: F, a: F, b: F) -> F {
    a + t * (b - a)
}

fn grad<F: Real>(hash: i32, x: F, y: F, z: F) -> F {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

/// Lattice cell and fractional offset of a coordinate.
fn cell<F: Real>(x: F) -> (i32, F) {
    let f = x.floor();
    let frac = x - f;
    // A non-finite coordinate has no meaningful fraction: use the cell origin.
    let frac = if frac.is_finite() { frac } else { F::ZERO };
    (f.to_i32(), frac)
}

/// Improved Perlin noise of a point, in about [-1, 1]; 0 at every lattice point.
pub fn noise3<F: Real>(p: [F; 3]) -> F {
    let (xi, x) = cell(p[0]);
    let (yi, y) = cell(p[1]);
    let (zi, z) = cell(p[2]);
    let (u, v, w) = (fade(x), fade(y), fade(z));
    let one = F::ONE;
    let a = perm(xi).wrapping_add(yi);
    let aa = perm(a).wrapping_add(zi);
    let ab = perm(a.wrapping_add(1)).wrapping_add(zi);
    let b = perm(xi.wrapping_add(1)).wrapping_add(yi);
    let ba = perm(b).wrapping_add(zi);
    let bb = perm(b.wrapping_add(1)).wrapping_add(zi);
    lerp(
        w,
        lerp(
            v,
            lerp(u, grad(perm(aa), x, y, z), grad(perm(ba), x - one, y, z)),
            lerp(
                u,
                grad(perm(ab), x, y - one, z),
                grad(perm(bb), x - one, y - one, z),
            ),
        ),
        lerp(
            v,
            lerp(
                u,
                grad(perm(aa.wrapping_add(1)), x, y, z - one),
                grad(perm(ba.wrapping_add(1)), x - one, y, z - one),
            ),
            lerp(
                u,
                grad(perm(ab.wrapping_add(1)), x, y - one, z - one),
                grad(perm(bb.wrapping_add(1)), x - one, y - one, z - one),
            ),
        ),
    )
}

/// Improved Perlin noise of a 2D point: `noise3(x, y, 0)`.
pub fn noise2<F: Real>(x: F, y: F) -> F {
    noise3([x, y, F::ZERO])
}

/// Fractal Brownian motion: `Σ_{i<octaves} gain^i · noise3(p · lacunarity^i)`, octaves
/// clamped to [0, 16].
pub fn fbm3<F: Real>(p: [F; 3], octaves: i32, lacunarity: F, gain: F) -> F {
    let mut sum = F::ZERO;
    let mut amp = F::ONE;
    let mut freq = F::ONE;
    for _ in 0..octaves.clamp(0, 16) {
        sum = sum + amp * noise3(p.map(|c| c * freq));
        amp = amp * gain;
        freq = freq * lacunarity;
    }
    sum
}

/// Cell noise: a value in [0, 1) constant over each unit cell `floor(p)`, the same in f32 and
/// f64 (24 bits of an integer hash).
#[inline]
pub fn cellnoise3<F: Real>(p: [F; 3]) -> F {
    let mut h: u32 = 0x9e37_79b9;
    for c in p {
        let i = c.floor().to_i32() as u32;
        h ^= i.wrapping_mul(0x85eb_ca6b);
        h = h.rotate_left(13).wrapping_mul(0xc2b2_ae35);
    }
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    F::from_f64((h >> 8) as f64 / (1u32 << 24) as f64)
}
