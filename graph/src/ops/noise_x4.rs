//! Four lanes at once of [`super::noise`]'s f32 Perlin noise and fBm, for the JIT's batch
//! entry (issue 23): structure of arrays in and out, and per lane exactly the scalar form's
//! operations in the same order, so every lane has the scalar function's bits.
//!
//! The arithmetic is written as loops over `[f32; 4]` that the compiler turns into SIMD
//! (branches become selects; no FMA contraction: Rust never fuses `a * b + c`); only the
//! permutation lookups stay scalar. [`noise3_x4`] and [`fbm3_x4`] pick, once per process, a
//! copy compiled for AVX2 or SSE4.1 where the CPU has them (`floor` is then one instruction;
//! without SSE4.1 it is a call per lane), else the baseline copy (the choice: [`Path`], shared
//! with [`super::math_x4`]). Owns no semantics: a change to the noise goes to [`super::noise`]
//! and is mirrored here; the tests hold the two equal bit for bit.

use super::noise::PERM;
pub use super::simd::Path;

/// Four values, one per lane.
pub type X4 = [f32; 4];

#[inline(always)]
fn map(f: impl Fn(usize) -> f32) -> X4 {
    [f(0), f(1), f(2), f(3)]
}

#[inline(always)]
fn fade(t: X4) -> X4 {
    map(|l| {
        let t = t[l];
        t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
    })
}

#[inline(always)]
fn lerp(t: X4, a: X4, b: X4) -> X4 {
    map(|l| a[l] + t[l] * (b[l] - a[l]))
}

#[inline(always)]
fn perm(i: [i32; 4]) -> [i32; 4] {
    i.map(|i| PERM[(i & 255) as usize] as i32)
}

#[inline(always)]
fn add(a: [i32; 4], k: i32) -> [i32; 4] {
    a.map(|a| a.wrapping_add(k))
}

#[inline(always)]
fn add_i(a: [i32; 4], b: [i32; 4]) -> [i32; 4] {
    [0, 1, 2, 3].map(|l| a[l].wrapping_add(b[l]))
}

/// `noise::grad` per lane, without branches: the choices are bit masks and the negations
/// sign-bit flips (exactly IEEE negation), so the lanes vectorize and the bits are the
/// scalar form's.
#[inline(always)]
fn grad(hash: [i32; 4], x: X4, y: X4, z: X4) -> X4 {
    let pick = |c: bool, a: f32, b: f32| {
        let m = (c as u32).wrapping_neg();
        f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
    };
    map(|l| {
        let h = hash[l] & 15;
        let u = pick(h < 8, x[l], y[l]);
        let v = pick(h < 4, y[l], pick(h == 12 || h == 14, x[l], z[l]));
        let su = f32::from_bits(u.to_bits() ^ (((h & 1) as u32) << 31));
        let sv = f32::from_bits(v.to_bits() ^ (((h & 2) as u32) << 30));
        su + sv
    })
}

/// `noise::cell` per lane: the lattice cell and the fraction (0 where it is not finite).
#[inline(always)]
fn cell(x: X4) -> ([i32; 4], X4) {
    let f = x.map(f32::floor);
    let frac = map(|l| {
        let r = x[l] - f[l];
        if r.is_finite() { r } else { 0.0 }
    });
    (f.map(|f| f as i32), frac)
}

#[inline(always)]
fn minus_one(x: X4) -> X4 {
    x.map(|x| x - 1.0)
}

#[inline(always)]
fn noise3_body(p: [X4; 3]) -> X4 {
    let (xi, x) = cell(p[0]);
    let (yi, y) = cell(p[1]);
    let (zi, z) = cell(p[2]);
    let (u, v, w) = (fade(x), fade(y), fade(z));
    let (x1, y1, z1) = (minus_one(x), minus_one(y), minus_one(z));
    let a = add_i(perm(xi), yi);
    let aa = add_i(perm(a), zi);
    let ab = add_i(perm(add(a, 1)), zi);
    let b = add_i(perm(add(xi, 1)), yi);
    let ba = add_i(perm(b), zi);
    let bb = add_i(perm(add(b, 1)), zi);
    lerp(
        w,
        lerp(
            v,
            lerp(u, grad(perm(aa), x, y, z), grad(perm(ba), x1, y, z)),
            lerp(u, grad(perm(ab), x, y1, z), grad(perm(bb), x1, y1, z)),
        ),
        lerp(
            v,
            lerp(
                u,
                grad(perm(add(aa, 1)), x, y, z1),
                grad(perm(add(ba, 1)), x1, y, z1),
            ),
            lerp(
                u,
                grad(perm(add(ab, 1)), x, y1, z1),
                grad(perm(add(bb, 1)), x1, y1, z1),
            ),
        ),
    )
}

#[inline(always)]
fn fbm3_body(p: [X4; 3], octaves: [i32; 4], lacunarity: X4, gain: X4) -> X4 {
    let octaves = octaves.map(|o| o.clamp(0, 16));
    let most = octaves.into_iter().max().unwrap_or(0);
    let mut sum = [0.0f32; 4];
    let mut amp = [1.0f32; 4];
    let mut freq = [1.0f32; 4];
    for i in 0..most {
        let q = p.map(|c| map(|l| c[l] * freq[l]));
        let n = noise3_body(q);
        // A lane past its own octave count keeps its sum (its amp and freq no longer
        // matter): each lane adds exactly the terms the scalar loop adds, in its order.
        sum = map(|l| {
            if i < octaves[l] {
                sum[l] + amp[l] * n[l]
            } else {
                sum[l]
            }
        });
        amp = map(|l| amp[l] * gain[l]);
        freq = map(|l| freq[l] * lacunarity[l]);
    }
    sum
}

type Noise3 = fn([X4; 3]) -> X4;
type Fbm3 = fn([X4; 3], [i32; 4], X4, X4) -> X4;

fn noise3_base(p: [X4; 3]) -> X4 {
    noise3_body(p)
}

fn fbm3_base(p: [X4; 3], o: [i32; 4], l: X4, g: X4) -> X4 {
    fbm3_body(p, o, l, g)
}

fn noise3_lanes(p: [X4; 3]) -> X4 {
    map(|l| super::noise::noise3::<f32>([p[0][l], p[1][l], p[2][l]]))
}

fn fbm3_lanes(p: [X4; 3], o: [i32; 4], la: X4, g: X4) -> X4 {
    map(|l| super::noise::fbm3::<f32>([p[0][l], p[1][l], p[2][l]], o[l], la[l], g[l]))
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;

    #[target_feature(enable = "avx2")]
    pub fn noise3_avx2(p: [X4; 3]) -> X4 {
        noise3_body(p)
    }
    #[target_feature(enable = "avx2")]
    pub fn fbm3_avx2(p: [X4; 3], o: [i32; 4], l: X4, g: X4) -> X4 {
        fbm3_body(p, o, l, g)
    }
    #[target_feature(enable = "sse4.1")]
    pub fn noise3_sse41(p: [X4; 3]) -> X4 {
        noise3_body(p)
    }
    #[target_feature(enable = "sse4.1")]
    pub fn fbm3_sse41(p: [X4; 3], o: [i32; 4], l: X4, g: X4) -> X4 {
        fbm3_body(p, o, l, g)
    }
}

/// The copy for `path`.
fn noise3_fn(path: Path) -> Noise3 {
    match path {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` checked the feature before this path was chosen.
        Path::Avx2 => |p| unsafe { x86::noise3_avx2(p) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        Path::Sse41 => |p| unsafe { x86::noise3_sse41(p) },
        Path::Lanes => noise3_lanes,
        _ => noise3_base,
    }
}

/// The copy for `path`.
fn fbm3_fn(path: Path) -> Fbm3 {
    match path {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` checked the feature before this path was chosen.
        Path::Avx2 => |p, o, l, g| unsafe { x86::fbm3_avx2(p, o, l, g) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        Path::Sse41 => |p, o, l, g| unsafe { x86::fbm3_sse41(p, o, l, g) },
        Path::Lanes => fbm3_lanes,
        _ => fbm3_base,
    }
}
/// [`super::noise::noise3`] (f32) of four points, `p[axis][lane]`, on the path `path`
/// (which must be [`Path::available`]).
pub fn noise3_x4_on(path: Path, p: [X4; 3]) -> X4 {
    assert!(path.available(), "{path:?} is not available on this CPU");
    noise3_fn(path)(p)
}

/// [`super::noise::fbm3`] (f32) of four points with per-lane parameters, on `path` (which
/// must be [`Path::available`]).
pub fn fbm3_x4_on(path: Path, p: [X4; 3], octaves: [i32; 4], lacunarity: X4, gain: X4) -> X4 {
    assert!(path.available(), "{path:?} is not available on this CPU");
    fbm3_fn(path)(p, octaves, lacunarity, gain)
}

/// [`super::noise::noise3`] (f32) of four points, `p[axis][lane]`, on [`Path::chosen`].
pub fn noise3_x4(p: [X4; 3]) -> X4 {
    noise3_fn(Path::chosen())(p)
}

/// [`super::noise::fbm3`] (f32) of four points with per-lane parameters, on
/// [`Path::chosen`].
pub fn fbm3_x4(p: [X4; 3], octaves: [i32; 4], lacunarity: X4, gain: X4) -> X4 {
    fbm3_fn(Path::chosen())(p, octaves, lacunarity, gain)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::super::noise;
    use super::*;

    /// Hard and ordinary coordinates: zeros, denormals, cell boundaries, huge, ±inf, NaN
    /// (shared with the other four-lane helpers' tests).
    pub(crate) const HARD: &[f32] = &[
        0.0,
        -0.0,
        1e-45,
        -1e-45,
        0.5,
        -0.5,
        1.0,
        -1.0,
        0.99999994,
        255.5,
        256.0,
        -256.25,
        8_388_608.5,
        3e9,
        -3e9,
        1e30,
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
    ];

    fn points() -> Vec<[f32; 3]> {
        let mut v = Vec::new();
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 64.0
        };
        for _ in 0..4000 {
            v.push([next(), next(), next()]);
        }
        for (i, &a) in HARD.iter().enumerate() {
            for &b in HARD {
                v.push([a, b, HARD[(i * 7) % HARD.len()]]);
            }
        }
        v
    }

    fn paths() -> Vec<Path> {
        let all = Path::ALL;
        for p in all.iter().filter(|p| !p.available()) {
            eprintln!("SKIPPED: the {p:?} copy: this CPU lacks the feature");
        }
        all.into_iter().filter(|p| p.available()).collect()
    }

    #[test]
    fn noise3_x4_has_the_scalar_bits_on_every_path() {
        let pts = points();
        for path in paths() {
            for chunk in pts.chunks(4) {
                let mut q = [[0.0f32; 4]; 3];
                for (l, p) in chunk.iter().enumerate() {
                    for a in 0..3 {
                        q[a][l] = p[a];
                    }
                }
                let got = noise3_x4_on(path, q);
                for (l, p) in chunk.iter().enumerate() {
                    let want = noise::noise3::<f32>(*p);
                    assert_eq!(got[l].to_bits(), want.to_bits(), "{path:?} at {p:?}");
                }
            }
        }
    }

    #[test]
    fn fbm3_x4_has_the_scalar_bits_with_per_lane_parameters() {
        let pts = points();
        let octaves = [0, 1, 5, 6, 16, 40, -3];
        let lac = [2.0, 2.1, 1.0, 0.0, -1.5, f32::NAN, 1e20];
        let gain = [0.5, 0.55, 1.0, 0.0, 2.0, f32::INFINITY, 1e-45];
        for path in paths() {
            for (c, chunk) in pts.chunks(4).enumerate() {
                let mut q = [[0.0f32; 4]; 3];
                let (mut o, mut la, mut g) = ([0i32; 4], [0.0f32; 4], [0.0f32; 4]);
                for (l, p) in chunk.iter().enumerate() {
                    for a in 0..3 {
                        q[a][l] = p[a];
                    }
                    o[l] = octaves[(c + l) % octaves.len()];
                    la[l] = lac[(c * 3 + l) % lac.len()];
                    g[l] = gain[(c * 5 + l) % gain.len()];
                }
                let got = fbm3_x4_on(path, q, o, la, g);
                for (l, p) in chunk.iter().enumerate() {
                    let want = noise::fbm3::<f32>(*p, o[l], la[l], g[l]);
                    assert_eq!(
                        got[l].to_bits(),
                        want.to_bits(),
                        "{path:?} at {p:?}, octaves {}, lacunarity {}, gain {}",
                        o[l],
                        la[l],
                        g[l]
                    );
                }
            }
        }
    }
}
