//! Four lanes at once of [`super::osl_noise`]'s generators — Perlin noise (`perlin2/3`,
//! `vperlin2/3`), cell noise (`cell2/3`, `vcell2/3`), MaterialX fractal noise (`fractal2/3`,
//! `vfractal2/3`) and Worley noise (`worley2/3` and their `_v2`/`_v3` forms) — for the JIT's
//! batch entry (issue 23): structure of arrays in and out, and per lane exactly the scalar
//! form's operations in the same order, so every lane has the scalar function's bits.
//!
//! Written as [`super::noise_x4`] is: every step a loop over `[f32; 4]` or `[u32; 4]` that
//! the compiler turns into SIMD. Bob Jenkins' hash (the bulk of the work) runs on four lanes
//! of u32 with wrapping arithmetic and rotates; `floor` and the saturating float → int
//! conversion are Rust's per lane (`f as i32`: truncation, saturating, NaN → 0, as the scalar
//! code); the gradient choices are bit masks and the negations sign-bit flips (exactly IEEE
//! negation); the scalar code's branches (the Worley insertion, the metric, the style, a lane
//! past its own octave count) are selects by lane, each lane keeping the value its branch
//! computes. Rust never contracts `a * b + c` into FMA. Worley's metric and style may differ
//! between lanes: each lane's distance is chosen from its own metric.
//!
//! Each function has a copy compiled for AVX2, SSE4.1 and the baseline, and
//! [`Path::Lanes`] (the scalar function once per lane, to measure against); the process's
//! copy is [`Path::chosen`], shared with the other four-lane helpers. Owns no semantics: a
//! change to the noise goes to [`super::osl_noise`] and is mirrored here; the tests hold the
//! two equal bit for bit on every path.

use super::noise_x4::X4;
use super::osl_noise::{self as scalar, MAX_OCTAVES, start};
use super::simd::Path;

/// Four u32 values, one per lane.
type U4 = [u32; 4];
/// Four i32 values, one per lane.
type I4 = [i32; 4];

#[inline(always)]
fn map<T>(f: impl Fn(usize) -> T) -> [T; 4] {
    [f(0), f(1), f(2), f(3)]
}

/// `[f(0), …, f(N − 1)]`, inlined (`std::array::from_fn` and `<[T; N]>::map` may leave
/// their closure a call, which then runs without the copy's target features).
#[inline(always)]
fn build<T: Copy + Default, const N: usize>(f: impl Fn(usize) -> T) -> [T; N] {
    let mut out = [T::default(); N];
    for (i, o) in out.iter_mut().enumerate() {
        *o = f(i);
    }
    out
}

/// `<[T; N]>::map`, inlined (see [`build`]).
trait Each<T, const N: usize> {
    fn each<U: Copy + Default>(self, f: impl Fn(T) -> U) -> [U; N];
}

impl<T: Copy, const N: usize> Each<T, N> for [T; N] {
    #[inline(always)]
    fn each<U: Copy + Default>(self, f: impl Fn(T) -> U) -> [U; N] {
        build(|i| f(self[i]))
    }
}

// ---- the hash on four lanes ----

/// The u32 lane arithmetic of the hash and the saturating float → int conversion as SSE2
/// instructions (x86-64's baseline, so every copy has them): written per lane, the compiler
/// leaves the rotates and Rust's saturating `as` one lane at a time inside the large noise
/// bodies. Each is the per-lane operation exactly: wrapping add and subtract, xor, rotate
/// left (`(a << k) | (a >> (32 − k))`, 0 < k < 32), and `f as i32` (truncation, `i32::MAX`
/// from 2³¹ up, `i32::MIN` below −2³¹, NaN → 0).
#[cfg(target_arch = "x86_64")]
mod sse2 {
    use super::{U4, X4};
    use std::arch::x86_64::*;

    // SAFETY (every `unsafe` below): SSE2 is part of x86-64's baseline, so every copy may
    // run these instructions.

    #[inline(always)]
    fn v(a: U4) -> __m128i {
        // SAFETY: both 16 bytes, every bit pattern a valid value of each.
        unsafe { std::mem::transmute::<U4, __m128i>(a) }
    }

    #[inline(always)]
    fn u(a: __m128i) -> U4 {
        // SAFETY: as in `v`.
        unsafe { std::mem::transmute::<__m128i, U4>(a) }
    }

    #[inline(always)]
    pub fn add(a: U4, b: U4) -> U4 {
        u(unsafe { _mm_add_epi32(v(a), v(b)) })
    }

    #[inline(always)]
    pub fn sub(a: U4, b: U4) -> U4 {
        u(unsafe { _mm_sub_epi32(v(a), v(b)) })
    }

    #[inline(always)]
    pub fn xor(a: U4, b: U4) -> U4 {
        u(unsafe { _mm_xor_si128(v(a), v(b)) })
    }

    #[inline(always)]
    pub fn rot(a: U4, k: u32) -> U4 {
        let a = v(a);
        u(unsafe {
            let left = _mm_sll_epi32(a, _mm_cvtsi32_si128(k as i32));
            let right = _mm_srl_epi32(a, _mm_cvtsi32_si128(32 - k as i32));
            _mm_or_si128(left, right)
        })
    }

    #[inline(always)]
    pub fn to_i32_bits(f: X4) -> U4 {
        // SAFETY: as in `v`.
        let x = unsafe { std::mem::transmute::<X4, __m128>(f) };
        // `cvttps2dq` gives 0x8000_0000 for NaN and out of range: flipped to 0x7FFF_FFFF
        // from 2³¹ up, cleared for NaN; below −2³¹ it is already i32::MIN.
        u(unsafe {
            let r = _mm_cvttps_epi32(x);
            let big = _mm_castps_si128(_mm_cmpge_ps(x, _mm_set1_ps(2_147_483_648.0)));
            let ordered = _mm_castps_si128(_mm_cmpord_ps(x, x));
            _mm_and_si128(_mm_xor_si128(r, big), ordered)
        })
    }
}

/// The same operations lane by lane, where there is no SSE2.
#[cfg(not(target_arch = "x86_64"))]
mod sse2 {
    use super::{U4, X4, map};

    #[inline(always)]
    pub fn add(a: U4, b: U4) -> U4 {
        map(|l| a[l].wrapping_add(b[l]))
    }

    #[inline(always)]
    pub fn sub(a: U4, b: U4) -> U4 {
        map(|l| a[l].wrapping_sub(b[l]))
    }

    #[inline(always)]
    pub fn xor(a: U4, b: U4) -> U4 {
        map(|l| a[l] ^ b[l])
    }

    #[inline(always)]
    pub fn rot(a: U4, k: u32) -> U4 {
        map(|l| a[l].rotate_left(k))
    }

    #[inline(always)]
    pub fn to_i32_bits(f: X4) -> U4 {
        map(|l| f[l] as i32 as u32)
    }
}

use sse2::{add, rot, sub, to_i32_bits, xor};

#[inline(always)]
fn addk(a: U4, k: u32) -> U4 {
    add(a, [k; 4])
}

/// [`scalar::bjmix`] per lane.
#[inline(always)]
fn bjmix(a: U4, b: U4, c: U4) -> [U4; 3] {
    let (mut a, mut b, mut c) = (a, b, c);
    a = sub(a, c);
    a = xor(a, rot(c, 4));
    c = add(c, b);
    b = sub(b, a);
    b = xor(b, rot(a, 6));
    a = add(a, c);
    c = sub(c, b);
    c = xor(c, rot(b, 8));
    b = add(b, a);
    a = sub(a, c);
    a = xor(a, rot(c, 16));
    c = add(c, b);
    b = sub(b, a);
    b = xor(b, rot(a, 19));
    a = add(a, c);
    c = sub(c, b);
    c = xor(c, rot(b, 4));
    b = add(b, a);
    [a, b, c]
}

/// [`scalar::bjfinal`] per lane.
#[inline(always)]
fn bjfinal(a: U4, b: U4, c: U4) -> U4 {
    let (mut a, mut b, mut c) = (a, b, c);
    c = xor(c, b);
    c = sub(c, rot(b, 14));
    a = xor(a, c);
    a = sub(a, rot(c, 11));
    b = xor(b, a);
    b = sub(b, rot(a, 25));
    c = xor(c, b);
    c = sub(c, rot(b, 16));
    a = xor(a, c);
    a = sub(a, rot(c, 4));
    b = xor(b, a);
    b = sub(b, rot(a, 14));
    c = xor(c, b);
    sub(c, rot(b, 24))
}

/// [`scalar::inthash2`] per lane.
#[inline(always)]
fn inthash2(k0: U4, k1: U4) -> U4 {
    let s = start(2);
    bjfinal(addk(k0, s), addk(k1, s), [s; 4])
}

/// [`scalar::inthash3`] per lane.
#[inline(always)]
fn inthash3(k0: U4, k1: U4, k2: U4) -> U4 {
    let s = start(3);
    bjfinal(addk(k0, s), addk(k1, s), addk(k2, s))
}

/// [`scalar::bits_to_01`] per lane.
#[inline(always)]
fn bits_to_01(bits: U4) -> X4 {
    map(|l| scalar::bits_to_01::<f32>(bits[l]))
}

// ---- Perlin noise ----

/// `floorfrac` per lane: the saturating lattice cell (as u32 bits, the hash's keys) and
/// the offset in it (0 where not finite).
#[inline(always)]
fn floorfrac(x: X4) -> (U4, X4) {
    let f = map(|l| x[l].floor());
    let frac = map(|l| {
        let r = x[l] - f[l];
        if r.is_finite() { r } else { 0.0 }
    });
    (to_i32_bits(f), frac)
}

#[inline(always)]
fn fade(t: X4) -> X4 {
    t.each(|t| t * t * t * (t * (t * 6.0 - 15.0) + 10.0))
}

#[inline(always)]
fn minus_one(x: X4) -> X4 {
    x.each(|x| x - 1.0)
}

/// `c ? a : b` as a bit mask (exact copies of either).
#[inline(always)]
fn pick(c: bool, a: f32, b: f32) -> f32 {
    let m = (c as u32).wrapping_neg();
    f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

/// `negate_if(u, h & 1) + negate_if(v, h & 2)`: the negations as sign-bit flips.
#[inline(always)]
fn signed_sum(h: u32, u: f32, v: f32) -> f32 {
    let su = f32::from_bits(u.to_bits() ^ ((h & 1) << 31));
    let sv = f32::from_bits(v.to_bits() ^ ((h & 2) << 30));
    su + sv
}

/// OSL 2D `grad` per lane.
#[inline(always)]
fn grad2(hash: U4, x: X4, y: X4) -> X4 {
    map(|l| {
        let h = hash[l] & 7;
        let u = pick(h < 4, x[l], y[l]);
        let v = 2.0 * pick(h < 4, y[l], x[l]);
        signed_sum(h, u, v)
    })
}

/// OSL 3D `grad` per lane.
#[inline(always)]
fn grad3(hash: U4, x: X4, y: X4, z: X4) -> X4 {
    map(|l| {
        let h = hash[l] & 15;
        let u = pick(h < 8, x[l], y[l]);
        let v = pick(h < 4, y[l], pick(h == 12 || h == 14, x[l], z[l]));
        signed_sum(h, u, v)
    })
}

/// `OIIO::bilerp` per lane.
#[inline(always)]
fn bilerp(v: [X4; 4], s: X4, t: X4) -> X4 {
    map(|l| {
        let s1 = 1.0 - s[l];
        (1.0 - t[l]) * (v[0][l] * s1 + v[1][l] * s[l]) + t[l] * (v[2][l] * s1 + v[3][l] * s[l])
    })
}

/// `OIIO::trilerp` per lane.
#[inline(always)]
fn trilerp(v: [X4; 8], s: X4, t: X4, r: X4) -> X4 {
    map(|l| {
        let (s, t, r) = (s[l], t[l], r[l]);
        let (s1, t1, r1) = (1.0 - s, 1.0 - t, 1.0 - r);
        r1 * (t1 * (v[0][l] * s1 + v[1][l] * s) + t * (v[2][l] * s1 + v[3][l] * s))
            + r * (t1 * (v[4][l] * s1 + v[5][l] * s) + t * (v[6][l] * s1 + v[7][l] * s))
    })
}

/// The scale of 2D Perlin noise, rounded from f64 as the scalar code rounds it.
const SCALE2: f32 = 0.6616f64 as f32;
/// The scale of 3D Perlin noise.
const SCALE3: f32 = 0.9820f64 as f32;

/// A 2D cell of four lanes: corner hashes in `bilerp`'s order, the offsets' two values per
/// axis (`f`, `f − 1`), and the fade weights.
struct Cell2 {
    h: [U4; 4],
    o: [[X4; 2]; 2],
    w: [X4; 2],
}

#[inline(always)]
fn cell2_of(p: [X4; 2]) -> Cell2 {
    let (x, fx) = floorfrac(p[0]);
    let (y, fy) = floorfrac(p[1]);
    let (x1, y1) = (addk(x, 1), addk(y, 1));
    Cell2 {
        h: [
            inthash2(x, y),
            inthash2(x1, y),
            inthash2(x, y1),
            inthash2(x1, y1),
        ],
        o: [[fx, minus_one(fx)], [fy, minus_one(fy)]],
        w: [fade(fx), fade(fy)],
    }
}

/// One 2D Perlin value of a cell whose corner hashes are `h`.
#[inline(always)]
fn perlin2_of(c: &Cell2, h: [U4; 4]) -> X4 {
    let mut g = [[0.0; 4]; 4];
    for (k, g) in g.iter_mut().enumerate() {
        *g = grad2(h[k], c.o[0][k & 1], c.o[1][(k >> 1) & 1]);
    }
    bilerp(g, c.w[0], c.w[1]).each(|b| SCALE2 * b)
}

/// A 3D cell of four lanes (see [`Cell2`]), corners in `trilerp`'s order.
struct Cell3 {
    h: [U4; 8],
    o: [[X4; 2]; 3],
    w: [X4; 3],
}

#[inline(always)]
fn cell3_of(p: [X4; 3]) -> Cell3 {
    let (x, fx) = floorfrac(p[0]);
    let (y, fy) = floorfrac(p[1]);
    let (z, fz) = floorfrac(p[2]);
    let keys = [[x, addk(x, 1)], [y, addk(y, 1)], [z, addk(z, 1)]];
    Cell3 {
        h: {
            let mut h = [[0; 4]; 8];
            for (k, h) in h.iter_mut().enumerate() {
                *h = inthash3(keys[0][k & 1], keys[1][(k >> 1) & 1], keys[2][(k >> 2) & 1]);
            }
            h
        },
        o: [
            [fx, minus_one(fx)],
            [fy, minus_one(fy)],
            [fz, minus_one(fz)],
        ],
        w: [fade(fx), fade(fy), fade(fz)],
    }
}

/// One 3D Perlin value of a cell whose corner hashes are `h`.
#[inline(always)]
fn perlin3_of(c: &Cell3, h: [U4; 8]) -> X4 {
    let mut g = [[0.0; 4]; 8];
    for (k, g) in g.iter_mut().enumerate() {
        let o = &c.o;
        *g = grad3(h[k], o[0][k & 1], o[1][(k >> 1) & 1], o[2][(k >> 2) & 1]);
    }
    trilerp(g, c.w[0], c.w[1], c.w[2]).each(|t| SCALE3 * t)
}

/// `sliceup`'s byte `c` of each lane's hash.
#[inline(always)]
fn byte(h: U4, c: usize) -> U4 {
    h.each(|h| (h >> (8 * c)) & 0xff)
}

#[inline(always)]
fn perlin2_body(p: [X4; 2]) -> X4 {
    let c = cell2_of(p);
    perlin2_of(&c, c.h)
}

#[inline(always)]
fn perlin3_body(p: [X4; 3]) -> X4 {
    let c = cell3_of(p);
    perlin3_of(&c, c.h)
}

#[inline(always)]
fn vperlin2_body(p: [X4; 2]) -> [X4; 3] {
    let c = cell2_of(p);
    let mut out = [[0.0; 4]; 3];
    for (comp, out) in out.iter_mut().enumerate() {
        *out = perlin2_of(&c, c.h.each(|h| byte(h, comp)));
    }
    out
}

#[inline(always)]
fn vperlin3_body(p: [X4; 3]) -> [X4; 3] {
    let c = cell3_of(p);
    let mut out = [[0.0; 4]; 3];
    for (comp, out) in out.iter_mut().enumerate() {
        *out = perlin3_of(&c, c.h.each(|h| byte(h, comp)));
    }
    out
}

// ---- cell noise ----

/// `ifloor` per lane (saturating; NaN → 0).
#[inline(always)]
fn ifloor(x: X4) -> U4 {
    to_i32_bits(x.each(|x| x.floor()))
}

#[inline(always)]
fn cell2_body(p: [X4; 2]) -> X4 {
    bits_to_01(inthash2(ifloor(p[0]), ifloor(p[1])))
}

#[inline(always)]
fn cell3_body(p: [X4; 3]) -> X4 {
    bits_to_01(inthash3(ifloor(p[0]), ifloor(p[1]), ifloor(p[2])))
}

/// Components `0..W` of `vcell2`.
#[inline(always)]
fn vcell2_n<const W: usize>(p: [X4; 2]) -> [X4; W] {
    let (x, y) = (ifloor(p[0]), ifloor(p[1]));
    let mut out = [[0.0; 4]; W];
    for (k, out) in out.iter_mut().enumerate() {
        *out = bits_to_01(inthash3(x, y, [k as u32; 4]));
    }
    out
}

#[inline(always)]
fn vcell2_body(p: [X4; 2]) -> [X4; 3] {
    vcell2_n(p)
}

#[inline(always)]
fn vcell3_body(p: [X4; 3]) -> [X4; 3] {
    let s = start(4);
    let [a, b, c] = bjmix(
        addk(ifloor(p[0]), s),
        addk(ifloor(p[1]), s),
        addk(ifloor(p[2]), s),
    );
    let mut out = [[0.0; 4]; 3];
    for (k, out) in out.iter_mut().enumerate() {
        *out = bits_to_01(bjfinal(addk(a, k as u32), b, c));
    }
    out
}

// ---- fractal noise ----

/// The fractal sum of four lanes with per-lane octaves, lacunarity and diminish: a lane
/// past its own octave count keeps its sum (its amplitude and point no longer matter), so
/// each lane adds exactly the terms the scalar loop adds, in its order.
#[inline(always)]
fn fractal<N: Noise<D, W>, const D: usize, const W: usize>(
    p: [X4; D],
    octaves: I4,
    lacunarity: X4,
    diminish: X4,
) -> [X4; W] {
    let octaves = octaves.each(|o| o.clamp(0, MAX_OCTAVES));
    let most = octaves.into_iter().max().unwrap_or(0);
    let (mut p, mut result, mut amplitude) = (p, [[0.0f32; 4]; W], [1.0f32; 4]);
    for i in 0..most {
        let n = N::at(p);
        for (r, n) in result.iter_mut().zip(n) {
            *r = map(|l| {
                if i < octaves[l] {
                    r[l] + amplitude[l] * n[l]
                } else {
                    r[l]
                }
            });
        }
        amplitude = map(|l| amplitude[l] * diminish[l]);
        for c in p.iter_mut() {
            *c = map(|l| c[l] * lacunarity[l]);
        }
    }
    result
}

/// A noise of `D`-dimensional points with `W` components, for [`fractal`] (a trait rather
/// than a closure or fn pointer, so that its body is inlined into each SIMD copy).
trait Noise<const D: usize, const W: usize> {
    fn at(p: [X4; D]) -> [X4; W];
}

struct Perlin2;
struct Perlin3;
struct VPerlin2;
struct VPerlin3;

impl Noise<2, 1> for Perlin2 {
    #[inline(always)]
    fn at(p: [X4; 2]) -> [X4; 1] {
        [perlin2_body(p)]
    }
}
impl Noise<3, 1> for Perlin3 {
    #[inline(always)]
    fn at(p: [X4; 3]) -> [X4; 1] {
        [perlin3_body(p)]
    }
}
impl Noise<2, 3> for VPerlin2 {
    #[inline(always)]
    fn at(p: [X4; 2]) -> [X4; 3] {
        vperlin2_body(p)
    }
}
impl Noise<3, 3> for VPerlin3 {
    #[inline(always)]
    fn at(p: [X4; 3]) -> [X4; 3] {
        vperlin3_body(p)
    }
}

#[inline(always)]
fn fractal2_body(p: [X4; 2], o: I4, l: X4, d: X4) -> X4 {
    fractal::<Perlin2, 2, 1>(p, o, l, d)[0]
}

#[inline(always)]
fn fractal3_body(p: [X4; 3], o: I4, l: X4, d: X4) -> X4 {
    fractal::<Perlin3, 3, 1>(p, o, l, d)[0]
}

#[inline(always)]
fn vfractal2_body(p: [X4; 2], o: I4, l: X4, d: X4) -> [X4; 3] {
    fractal::<VPerlin2, 2, 3>(p, o, l, d)
}

#[inline(always)]
fn vfractal3_body(p: [X4; 3], o: I4, l: X4, d: X4) -> [X4; 3] {
    fractal::<VPerlin3, 3, 3>(p, o, l, d)
}

// ---- Worley noise ----

/// GLSL `max(a, b)`: `a < b ? b : a`.
#[inline(always)]
fn gmax(a: f32, b: f32) -> f32 {
    if a < b { b } else { a }
}

/// Which lanes measure in which metric: 2 Manhattan, 3 Chebyshev, any other squared
/// Euclidean (as `metric_of`).
#[derive(Clone, Copy)]
struct Metric {
    manhattan: [bool; 4],
    chebyshev: [bool; 4],
}

impl Metric {
    #[inline(always)]
    fn of(metric: I4) -> Metric {
        Metric {
            manhattan: map(|l| metric[l] == 2),
            chebyshev: map(|l| metric[l] == 3),
        }
    }
}

/// `metric_of` per lane: all three folds over the four lanes, each lane keeping its own
/// metric's.
#[inline(always)]
fn metric_of<const D: usize>(d: [X4; D], m: Metric) -> X4 {
    let abs = d.each(|c| c.each(|x| x.abs()));
    let (mut manhattan, mut chebyshev) = (abs[0], abs[0]);
    let mut squared = map(|l| d[0][l] * d[0][l]);
    for k in 1..D {
        manhattan = map(|l| manhattan[l] + abs[k][l]);
        chebyshev = map(|l| gmax(chebyshev[l], abs[k][l]));
        squared = map(|l| squared[l] + d[k][l] * d[k][l]);
    }
    map(|l| {
        if m.manhattan[l] {
            manhattan[l]
        } else if m.chebyshev[l] {
            chebyshev[l]
        } else {
            squared[l]
        }
    })
}

/// The `N` nearest distances and the nearest feature point, per lane (`Nearest`).
struct Nearest<const D: usize> {
    sqdist: [X4; 3],
    minpos: [X4; D],
}

impl<const D: usize> Nearest<D> {
    #[inline(always)]
    fn new() -> Self {
        Nearest {
            sqdist: [[1e6; 4]; 3],
            minpos: [[0.0; 4]; D],
        }
    }

    /// `Nearest::insert` for `n` kept distances, per lane as selects.
    #[inline(always)]
    fn insert(&mut self, n: usize, dist: X4, cellpos: [X4; D]) {
        let [d0, d1, d2] = self.sqdist;
        let lt0 = map(|l| dist[l] < d0[l]);
        let lt1 = map(|l| n > 1 && dist[l] < d1[l]);
        let lt2 = map(|l| n > 2 && dist[l] < d2[l]);
        let sel = |c: [bool; 4], a: X4, b: X4| map(|l| if c[l] { a[l] } else { b[l] });
        if n > 2 {
            let moved = map(|l| lt0[l] || lt1[l]);
            self.sqdist[2] = sel(moved, d1, sel(lt2, dist, d2));
        }
        if n > 1 {
            self.sqdist[1] = sel(lt0, d0, sel(lt1, dist, d1));
        }
        self.sqdist[0] = sel(lt0, dist, d0);
        self.minpos = build(|k| sel(lt0, cellpos[k], self.minpos[k]));
    }
}

/// `(o − 0.5) · jitter + 0.5` per lane.
#[inline(always)]
fn jittered(o: X4, jitter: X4) -> X4 {
    map(|l| (o[l] - 0.5) * jitter[l] + 0.5)
}

/// `worley2_search` per lane.
#[inline(always)]
fn worley2_search(p: [X4; 2], jitter: X4, metric: I4, n: usize) -> Nearest<2> {
    let m = Metric::of(metric);
    let (cx, lx) = floorfrac(p[0]);
    let (cy, ly) = floorfrac(p[1]);
    let mut near = Nearest::new();
    for x in -1i32..=1 {
        for y in -1i32..=1 {
            // cell_position2: the cell's key as a float, its vector cell noise, jittered.
            let q = [
                addk(cx, x as u32).each(|i| i as i32 as f32),
                addk(cy, y as u32).each(|i| i as i32 as f32),
            ];
            let [t0, t1] = vcell2_n::<2>(q);
            let (o0, o1) = (jittered(t0, jitter), jittered(t1, jitter));
            let cp = [o0.each(|o| x as f32 + o), o1.each(|o| y as f32 + o)];
            let diff = [map(|l| cp[0][l] - lx[l]), map(|l| cp[1][l] - ly[l])];
            near.insert(n, metric_of(diff, m), diff);
        }
    }
    near
}

/// `worley3_search` per lane.
#[inline(always)]
fn worley3_search(p: [X4; 3], jitter: X4, metric: I4, n: usize) -> Nearest<3> {
    let m = Metric::of(metric);
    let (cx, lx) = floorfrac(p[0]);
    let (cy, ly) = floorfrac(p[1]);
    let (cz, lz) = floorfrac(p[2]);
    let (cells, fracs) = ([cx, cy, cz], [lx, ly, lz]);
    let mut near = Nearest::new();
    for x in -1i32..=1 {
        for y in -1i32..=1 {
            for z in -1i32..=1 {
                let d = [x, y, z];
                let q: [X4; 3] = build(|a| addk(cells[a], d[a] as u32).each(|i| i as i32 as f32));
                let tmp = vcell3_body(q);
                let diff: [X4; 3] = build(|a| {
                    let o = jittered(tmp[a], jitter);
                    map(|l| (d[a] as f32 + o[l]) - fracs[a][l])
                });
                near.insert(n, metric_of(diff, m), diff);
            }
        }
    }
    near
}

/// `finish` per lane: square roots for the lanes of metric 0.
#[inline(always)]
fn finish<const N: usize>(sqdist: [X4; 3], metric: I4) -> [X4; N] {
    build(|k| {
        map(|l| {
            if metric[l] == 0 {
                sqdist[k][l].sqrt()
            } else {
                sqdist[k][l]
            }
        })
    })
}

/// The lanes of style 1 take `cell`, the others `dist`.
#[inline(always)]
fn by_style<const N: usize>(style: I4, dist: [X4; N], cell: [X4; N]) -> [X4; N] {
    let mut out = dist;
    for (o, c) in out.iter_mut().zip(cell) {
        *o = map(|l| if style[l] == 1 { c[l] } else { o[l] });
    }
    out
}

/// `minpos + p` per lane (where style 1 looks up its cell noise).
#[inline(always)]
fn at<const D: usize>(m: [X4; D], p: [X4; D]) -> [X4; D] {
    let mut out = m;
    for (o, p) in out.iter_mut().zip(p) {
        *o = map(|l| o[l] + p[l]);
    }
    out
}

#[inline(always)]
fn worley2_n<const N: usize>(p: [X4; 2], jitter: X4, style: I4, metric: I4) -> [X4; N] {
    let near = worley2_search(p, jitter, metric, N);
    let dist = finish(near.sqdist, metric);
    // The cell noise only where a lane wants it (style 1).
    if !style.contains(&1) {
        return dist;
    }
    let q = at(near.minpos, p);
    let cell = if N == 1 {
        [cell2_body(q); N]
    } else {
        vcell2_n::<N>(q)
    };
    by_style(style, dist, cell)
}

#[inline(always)]
fn worley3_n<const N: usize>(p: [X4; 3], jitter: X4, style: I4, metric: I4) -> [X4; N] {
    let near = worley3_search(p, jitter, metric, N);
    let dist = finish(near.sqdist, metric);
    if !style.contains(&1) {
        return dist;
    }
    let q = at(near.minpos, p);
    let cell = if N == 1 {
        [cell3_body(q); N]
    } else {
        let v = vcell3_body(q);
        let mut c = [[0.0; 4]; N];
        c.copy_from_slice(&v[..N]);
        c
    };
    by_style(style, dist, cell)
}

#[inline(always)]
fn worley2_body(p: [X4; 2], j: X4, s: I4, m: I4) -> X4 {
    worley2_n::<1>(p, j, s, m)[0]
}

#[inline(always)]
fn worley2_v2_body(p: [X4; 2], j: X4, s: I4, m: I4) -> [X4; 2] {
    worley2_n(p, j, s, m)
}

#[inline(always)]
fn worley2_v3_body(p: [X4; 2], j: X4, s: I4, m: I4) -> [X4; 3] {
    worley2_n(p, j, s, m)
}

#[inline(always)]
fn worley3_body(p: [X4; 3], j: X4, s: I4, m: I4) -> X4 {
    worley3_n::<1>(p, j, s, m)[0]
}

#[inline(always)]
fn worley3_v2_body(p: [X4; 3], j: X4, s: I4, m: I4) -> [X4; 2] {
    worley3_n(p, j, s, m)
}

#[inline(always)]
fn worley3_v3_body(p: [X4; 3], j: X4, s: I4, m: I4) -> [X4; 3] {
    worley3_n(p, j, s, m)
}

// ---- the scalar function once per lane ([`Path::Lanes`]) ----

/// Lane `l` of a structure-of-arrays point.
fn lane<const D: usize>(p: &[X4; D], l: usize) -> [f32; D] {
    std::array::from_fn(|a| p[a][l])
}

/// Four lane-major results of `W` components as `W` components of four lanes.
fn soa<const W: usize>(v: [[f32; W]; 4]) -> [X4; W] {
    std::array::from_fn(|k| map(|l| v[l][k]))
}

macro_rules! lanes_fns {
    ($($name:ident($p:ident: $d:literal $(, $a:ident: $t:ty)*) -> $w:literal = $f:expr;)*) => {$(
        #[inline(never)]
        fn $name($p: [X4; $d] $(, $a: $t)*) -> [X4; $w] {
            soa(std::array::from_fn(|l| {
                let r = $f(lane(&$p, l) $(, $a[l])*);
                wide(r)
            }))
        }
    )*};
}

/// A scalar result as an array of its components.
trait Wide<const W: usize> {
    fn wide(self) -> [f32; W];
}
impl Wide<1> for f32 {
    fn wide(self) -> [f32; 1] {
        [self]
    }
}
impl<const W: usize> Wide<W> for [f32; W] {
    fn wide(self) -> [f32; W] {
        self
    }
}
fn wide<const W: usize>(r: impl Wide<W>) -> [f32; W] {
    r.wide()
}

lanes_fns! {
    perlin2_lanes(p: 2) -> 1 = scalar::perlin2::<f32>;
    perlin3_lanes(p: 3) -> 1 = scalar::perlin3::<f32>;
    vperlin2_lanes(p: 2) -> 3 = scalar::vperlin2::<f32>;
    vperlin3_lanes(p: 3) -> 3 = scalar::vperlin3::<f32>;
    cell2_lanes(p: 2) -> 1 = scalar::cell2::<f32>;
    cell3_lanes(p: 3) -> 1 = scalar::cell3::<f32>;
    vcell2_lanes(p: 2) -> 3 = scalar::vcell2::<f32>;
    vcell3_lanes(p: 3) -> 3 = scalar::vcell3::<f32>;
    fractal2_lanes(p: 2, o: I4, la: X4, d: X4) -> 1 = scalar::fractal2::<f32>;
    fractal3_lanes(p: 3, o: I4, la: X4, d: X4) -> 1 = scalar::fractal3::<f32>;
    vfractal2_lanes(p: 2, o: I4, la: X4, d: X4) -> 3 = scalar::vfractal2::<f32>;
    vfractal3_lanes(p: 3, o: I4, la: X4, d: X4) -> 3 = scalar::vfractal3::<f32>;
    worley2_lanes(p: 2, j: X4, s: I4, m: I4) -> 1 = scalar::worley2::<f32>;
    worley2_v2_lanes(p: 2, j: X4, s: I4, m: I4) -> 2 = scalar::worley2_v2::<f32>;
    worley2_v3_lanes(p: 2, j: X4, s: I4, m: I4) -> 3 = scalar::worley2_v3::<f32>;
    worley3_lanes(p: 3, j: X4, s: I4, m: I4) -> 1 = scalar::worley3::<f32>;
    worley3_v2_lanes(p: 3, j: X4, s: I4, m: I4) -> 2 = scalar::worley3_v2::<f32>;
    worley3_v3_lanes(p: 3, j: X4, s: I4, m: I4) -> 3 = scalar::worley3_v3::<f32>;
}

// ---- the copies and the public functions ----

/// One result of one component as the bare four lanes.
trait Narrow<R> {
    fn narrow(self) -> R;
}
impl Narrow<X4> for [X4; 1] {
    fn narrow(self) -> X4 {
        self[0]
    }
}
impl<const W: usize> Narrow<[X4; W]> for [X4; W] {
    fn narrow(self) -> [X4; W] {
        self
    }
}

macro_rules! x4_fns {
    ($(
        $(#[$doc:meta])*
        $name:ident / $on:ident = $body:ident, $lanes:ident ($($a:ident: $t:ty),*) -> $r:ty;
    )*) => {
        #[cfg(target_arch = "x86_64")]
        mod x86 {
            use super::*;
            $(
                pub mod $name {
                    use super::*;
                    #[target_feature(enable = "avx2")]
                    pub fn avx2($($a: $t),*) -> $r {
                        $body($($a),*)
                    }
                    #[target_feature(enable = "sse4.1")]
                    pub fn sse41($($a: $t),*) -> $r {
                        $body($($a),*)
                    }
                }
            )*
        }
        $(
            $(#[$doc])*
            ///
            /// On `path`, which must be [`Path::available`].
            pub fn $on(path: Path, $($a: $t),*) -> $r {
                assert!(path.available(), "{path:?} is not available on this CPU");
                match path {
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: `available` checked the CPU has AVX2.
                    Path::Avx2 => unsafe { x86::$name::avx2($($a),*) },
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: `available` checked the CPU has SSE4.1.
                    Path::Sse41 => unsafe { x86::$name::sse41($($a),*) },
                    Path::Lanes => $lanes($($a),*).narrow(),
                    _ => $body($($a),*),
                }
            }

            #[doc = concat!("[`", stringify!($on), "`] on [`Path::chosen`].")]
            pub fn $name($($a: $t),*) -> $r {
                $on(Path::chosen(), $($a),*)
            }
        )*
    };
}

x4_fns! {
    /// [`scalar::perlin2`] (f32) of four points, `p[axis][lane]`.
    perlin2_x4 / perlin2_x4_on = perlin2_body, perlin2_lanes (p: [X4; 2]) -> X4;
    /// [`scalar::perlin3`] (f32) of four points.
    perlin3_x4 / perlin3_x4_on = perlin3_body, perlin3_lanes (p: [X4; 3]) -> X4;
    /// [`scalar::vperlin2`] (f32) of four points, `[component][lane]` out.
    vperlin2_x4 / vperlin2_x4_on = vperlin2_body, vperlin2_lanes (p: [X4; 2]) -> [X4; 3];
    /// [`scalar::vperlin3`] (f32) of four points.
    vperlin3_x4 / vperlin3_x4_on = vperlin3_body, vperlin3_lanes (p: [X4; 3]) -> [X4; 3];
    /// [`scalar::cell2`] (f32) of four points.
    cell2_x4 / cell2_x4_on = cell2_body, cell2_lanes (p: [X4; 2]) -> X4;
    /// [`scalar::cell3`] (f32) of four points.
    cell3_x4 / cell3_x4_on = cell3_body, cell3_lanes (p: [X4; 3]) -> X4;
    /// [`scalar::vcell2`] (f32) of four points.
    vcell2_x4 / vcell2_x4_on = vcell2_body, vcell2_lanes (p: [X4; 2]) -> [X4; 3];
    /// [`scalar::vcell3`] (f32) of four points.
    vcell3_x4 / vcell3_x4_on = vcell3_body, vcell3_lanes (p: [X4; 3]) -> [X4; 3];
    /// [`scalar::fractal2`] (f32) of four points with per-lane octaves, lacunarity and
    /// diminish.
    fractal2_x4 / fractal2_x4_on = fractal2_body, fractal2_lanes
        (p: [X4; 2], octaves: I4, lacunarity: X4, diminish: X4) -> X4;
    /// [`scalar::fractal3`] (f32) of four points with per-lane parameters.
    fractal3_x4 / fractal3_x4_on = fractal3_body, fractal3_lanes
        (p: [X4; 3], octaves: I4, lacunarity: X4, diminish: X4) -> X4;
    /// [`scalar::vfractal2`] (f32) of four points with per-lane parameters.
    vfractal2_x4 / vfractal2_x4_on = vfractal2_body, vfractal2_lanes
        (p: [X4; 2], octaves: I4, lacunarity: X4, diminish: X4) -> [X4; 3];
    /// [`scalar::vfractal3`] (f32) of four points with per-lane parameters.
    vfractal3_x4 / vfractal3_x4_on = vfractal3_body, vfractal3_lanes
        (p: [X4; 3], octaves: I4, lacunarity: X4, diminish: X4) -> [X4; 3];
    /// [`scalar::worley2`] (f32) of four points with per-lane jitter, style and metric.
    worley2_x4 / worley2_x4_on = worley2_body, worley2_lanes
        (p: [X4; 2], jitter: X4, style: I4, metric: I4) -> X4;
    /// [`scalar::worley2_v2`] (f32) of four points with per-lane parameters.
    worley2_v2_x4 / worley2_v2_x4_on = worley2_v2_body, worley2_v2_lanes
        (p: [X4; 2], jitter: X4, style: I4, metric: I4) -> [X4; 2];
    /// [`scalar::worley2_v3`] (f32) of four points with per-lane parameters.
    worley2_v3_x4 / worley2_v3_x4_on = worley2_v3_body, worley2_v3_lanes
        (p: [X4; 2], jitter: X4, style: I4, metric: I4) -> [X4; 3];
    /// [`scalar::worley3`] (f32) of four points with per-lane parameters.
    worley3_x4 / worley3_x4_on = worley3_body, worley3_lanes
        (p: [X4; 3], jitter: X4, style: I4, metric: I4) -> X4;
    /// [`scalar::worley3_v2`] (f32) of four points with per-lane parameters.
    worley3_v2_x4 / worley3_v2_x4_on = worley3_v2_body, worley3_v2_lanes
        (p: [X4; 3], jitter: X4, style: I4, metric: I4) -> [X4; 2];
    /// [`scalar::worley3_v3`] (f32) of four points with per-lane parameters.
    worley3_v3_x4 / worley3_v3_x4_on = worley3_v3_body, worley3_v3_lanes
        (p: [X4; 3], jitter: X4, style: I4, metric: I4) -> [X4; 3];
}

#[cfg(test)]
mod tests {
    use super::super::noise_x4::tests::HARD;
    use super::*;

    /// Random points (uniform in ±32, and bit patterns of every magnitude), then every pair
    /// of hard coordinates (with a third from the list), exact integers and negatives
    /// included.
    fn points() -> Vec<[f32; 3]> {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let mut v = Vec::new();
        for _ in 0..3000 {
            v.push(std::array::from_fn(|_| {
                ((next() >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 64.0
            }));
        }
        for _ in 0..500 {
            v.push(std::array::from_fn(|_| f32::from_bits(next() as u32)));
        }
        for _ in 0..200 {
            v.push(std::array::from_fn(|_| (next() % 41) as f32 - 20.0));
        }
        for (i, &a) in HARD.iter().enumerate() {
            for &b in HARD {
                v.push([a, b, HARD[(i * 7) % HARD.len()]]);
            }
        }
        v
    }

    fn paths() -> Vec<Path> {
        for p in Path::ALL.iter().filter(|p| !p.available()) {
            eprintln!("SKIPPED: the {p:?} copy: this CPU lacks the feature");
        }
        Path::ALL.into_iter().filter(|p| p.available()).collect()
    }

    /// Packets of four points as `[axis][lane]`, with the points.
    fn packets<const D: usize>() -> Vec<([X4; D], Vec<[f32; D]>)> {
        points()
            .chunks(4)
            .map(|c| {
                let pts: Vec<[f32; D]> = c.iter().map(|p| std::array::from_fn(|a| p[a])).collect();
                let q = std::array::from_fn(|a| map(|l| pts.get(l).map_or(0.0, |p| p[a])));
                (q, pts)
            })
            .collect()
    }

    /// Lane `l` of `got` has the bits of `want`.
    fn same<const W: usize>(got: [X4; W], l: usize, want: [f32; W], what: &dyn Fn() -> String) {
        for k in 0..W {
            assert_eq!(
                got[k][l].to_bits(),
                want[k].to_bits(),
                "{}: component {k}: {} vs scalar {}",
                what(),
                got[k][l],
                want[k]
            );
        }
    }

    macro_rules! plain {
        ($test:ident, $on:ident, $scalar:path, $d:literal) => {
            #[test]
            fn $test() {
                for path in paths() {
                    for (q, pts) in packets::<$d>() {
                        let got = $on(path, q);
                        for (l, p) in pts.iter().enumerate() {
                            let want = $scalar(*p);
                            same([got].wide_out(), l, wide(want), &|| {
                                format!("{path:?} at {p:?}")
                            });
                        }
                    }
                }
            }
        };
    }

    /// A four-lane result as `[component][lane]`.
    trait WideOut<const W: usize> {
        fn wide_out(self) -> [X4; W];
    }
    impl WideOut<1> for [X4; 1] {
        fn wide_out(self) -> [X4; 1] {
            self
        }
    }
    impl<const W: usize> WideOut<W> for [[X4; W]; 1] {
        fn wide_out(self) -> [X4; W] {
            self[0]
        }
    }

    plain!(
        perlin2_has_the_scalar_bits,
        perlin2_x4_on,
        scalar::perlin2::<f32>,
        2
    );
    plain!(
        perlin3_has_the_scalar_bits,
        perlin3_x4_on,
        scalar::perlin3::<f32>,
        3
    );
    plain!(
        vperlin2_has_the_scalar_bits,
        vperlin2_x4_on,
        scalar::vperlin2::<f32>,
        2
    );
    plain!(
        vperlin3_has_the_scalar_bits,
        vperlin3_x4_on,
        scalar::vperlin3::<f32>,
        3
    );
    plain!(
        cell2_has_the_scalar_bits,
        cell2_x4_on,
        scalar::cell2::<f32>,
        2
    );
    plain!(
        cell3_has_the_scalar_bits,
        cell3_x4_on,
        scalar::cell3::<f32>,
        3
    );
    plain!(
        vcell2_has_the_scalar_bits,
        vcell2_x4_on,
        scalar::vcell2::<f32>,
        2
    );
    plain!(
        vcell3_has_the_scalar_bits,
        vcell3_x4_on,
        scalar::vcell3::<f32>,
        3
    );

    const OCTAVES: [i32; 9] = [0, 1, 3, 6, 32, 40, -3, i32::MAX, i32::MIN];
    const LACUNARITY: [f32; 9] = [
        2.0,
        2.1,
        1.0,
        0.0,
        -1.5,
        f32::NAN,
        1e20,
        f32::INFINITY,
        -0.0,
    ];
    const DIMINISH: [f32; 8] = [0.5, 0.55, 1.0, 0.0, 2.0, f32::INFINITY, 1e-45, f32::NAN];

    /// Per-lane parameters of packet `c`: each list cycled at its own stride.
    fn params<A: Copy, B: Copy, C: Copy>(
        c: usize,
        a: &[A],
        b: &[B],
        d: &[C],
    ) -> ([A; 4], [B; 4], [C; 4]) {
        (
            map(|l| a[(c + l) % a.len()]),
            map(|l| b[(c * 3 + l) % b.len()]),
            map(|l| d[(c * 5 + l * 2) % d.len()]),
        )
    }

    macro_rules! fractal_test {
        ($test:ident, $on:ident, $scalar:path, $d:literal) => {
            #[test]
            fn $test() {
                for path in paths() {
                    // Per-lane parameters, then one set for all four lanes.
                    for (c, (q, pts)) in packets::<$d>().into_iter().enumerate() {
                        let (o, la, g) = if c % 2 == 0 {
                            params(c / 2, &OCTAVES[..6], &LACUNARITY, &DIMINISH)
                        } else {
                            ([6; 4], [2.1; 4], [0.55; 4])
                        };
                        let got = $on(path, q, o, la, g);
                        for (l, p) in pts.iter().enumerate() {
                            let want = $scalar(*p, o[l], la[l], g[l]);
                            same([got].wide_out(), l, wide(want), &|| {
                                format!(
                                    "{path:?} at {p:?}, octaves {}, lacunarity {}, diminish {}",
                                    o[l], la[l], g[l]
                                )
                            });
                        }
                    }
                }
            }
        };
    }

    fractal_test!(
        fractal2_has_the_scalar_bits,
        fractal2_x4_on,
        scalar::fractal2::<f32>,
        2
    );
    fractal_test!(
        fractal3_has_the_scalar_bits,
        fractal3_x4_on,
        scalar::fractal3::<f32>,
        3
    );
    fractal_test!(
        vfractal2_has_the_scalar_bits,
        vfractal2_x4_on,
        scalar::vfractal2::<f32>,
        2
    );
    fractal_test!(
        vfractal3_has_the_scalar_bits,
        vfractal3_x4_on,
        scalar::vfractal3::<f32>,
        3
    );

    #[test]
    fn fractal_octave_extremes_have_the_scalar_bits() {
        // i32::MAX and i32::MIN octaves (clamped to 32 and 0) next to ordinary lanes.
        let q = [[0.3, -7.25, 1e6, 12.5]; 3];
        for path in paths() {
            let o = [i32::MAX, i32::MIN, 2, 33];
            let got = fractal3_x4_on(path, q, o, [2.0; 4], [0.5; 4]);
            for l in 0..4 {
                let want = scalar::fractal3::<f32>([q[0][l]; 3], o[l], 2.0, 0.5);
                assert_eq!(got[l].to_bits(), want.to_bits(), "{path:?} lane {l}");
            }
        }
    }

    const JITTER: [f32; 8] = [1.0, 0.0, 0.5, 2.0, -1.0, f32::NAN, f32::INFINITY, 1e-45];
    const STYLE: [i32; 5] = [0, 1, 7, -1, 1];
    const METRIC: [i32; 7] = [0, 1, 2, 3, 9, -5, 0];

    macro_rules! worley_test {
        ($test:ident, $on:ident, $scalar:path, $d:literal) => {
            #[test]
            fn $test() {
                for path in paths() {
                    for (c, (q, pts)) in packets::<$d>().into_iter().enumerate() {
                        // Mixed lanes, then each (style, metric) for all four lanes.
                        let (j, s, m) = if c % 3 == 0 {
                            params(c / 3, &JITTER, &STYLE, &METRIC)
                        } else {
                            let k = c / 3;
                            ([JITTER[k % 4]; 4], [STYLE[k % 3]; 4], [METRIC[k % 6]; 4])
                        };
                        let got = $on(path, q, j, s, m);
                        for (l, p) in pts.iter().enumerate() {
                            let want = $scalar(*p, j[l], s[l], m[l]);
                            same([got].wide_out(), l, wide(want), &|| {
                                format!(
                                    "{path:?} at {p:?}, jitter {}, style {}, metric {}",
                                    j[l], s[l], m[l]
                                )
                            });
                        }
                    }
                }
            }
        };
    }

    worley_test!(
        worley2_has_the_scalar_bits,
        worley2_x4_on,
        scalar::worley2::<f32>,
        2
    );
    worley_test!(
        worley2_v2_has_the_scalar_bits,
        worley2_v2_x4_on,
        scalar::worley2_v2::<f32>,
        2
    );
    worley_test!(
        worley2_v3_has_the_scalar_bits,
        worley2_v3_x4_on,
        scalar::worley2_v3::<f32>,
        2
    );
    worley_test!(
        worley3_has_the_scalar_bits,
        worley3_x4_on,
        scalar::worley3::<f32>,
        3
    );
    worley_test!(
        worley3_v2_has_the_scalar_bits,
        worley3_v2_x4_on,
        scalar::worley3_v2::<f32>,
        3
    );
    worley_test!(
        worley3_v3_has_the_scalar_bits,
        worley3_v3_x4_on,
        scalar::worley3_v3::<f32>,
        3
    );
}
