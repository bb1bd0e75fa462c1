//! OSL's noise generators, ported operation for operation: Bob Jenkins' integer hash
//! (`inthash`), signed Perlin noise (`snoise`, float and vector, 1D to 4D), cell noise
//! (`cellnoise`) and hash noise (`hashnoise`, cell noise of the coordinates' bits), float
//! and vector, 1D to 4D, and MaterialX's fractal and Worley noise built on them.
//!
//! Sources ported (docs/materialx.md, "Noise: OSL's generators", says how each was
//! checked): OSL `src/include/OSL/oslnoise.h` (the non-SIMD path: `inthash`, `bjmix`/`bjfinal` from
//! OpenImageIO's `hash.h`, `floorfrac`, `fade`, `grad`, `scale1` … `scale4`, `perlin` with
//! `OIIO::lerp`/`bilerp`/`trilerp`, `HashVector`'s `sliceup`, `CellNoise` and `inthashVec`), and
//! MaterialX 1.39 `libraries/stdlib/genglsl/lib/mx_noise.glsl` (`mx_fractal*_noise_*`,
//! `mx_worley_*`), which ports the same OSL functions and `genosl/include/mx_funcs.h`.
//! Every float operation is the source's, in the source's order; the f32 results are the
//! source's bits wherever the source's own integer conversions are defined.
//!
//! Where the source is undefined (C++ `int(floor(x))` of a coordinate outside the i32 range,
//! infinity or NaN), the lattice cell saturates (Rust `as`) and the fractional offset is
//! `x - floor(x)`, taken as 0 where it is not finite, as in [`super::noise`]: no panic, a
//! finite result for every finite or non-finite input. For in-range coordinates
//! `x - floor(x)` is exactly the source's `x - float(int(floor(x)))`.
//!
//! This module owns these generators' meaning; it must not touch the Maya-era Perlin noise
//! of [`super::noise`] (its images are baselines). The back ends call these functions (the
//! JIT's helpers) or port them line by line (the GPU's WGSL library, `sn_osl_*`).

use super::Real;

// ---- Bob Jenkins' lookup3 mixing (OpenImageIO `bjhash`), as OSL's `inthash` uses it ----

/// `bjmix` of OpenImageIO's `hash.h`: mixes three 32-bit values reversibly.
pub fn bjmix(a: u32, b: u32, c: u32) -> [u32; 3] {
    let (mut a, mut b, mut c) = (a, b, c);
    a = a.wrapping_sub(c);
    a ^= c.rotate_left(4);
    c = c.wrapping_add(b);
    b = b.wrapping_sub(a);
    b ^= a.rotate_left(6);
    a = a.wrapping_add(c);
    c = c.wrapping_sub(b);
    c ^= b.rotate_left(8);
    b = b.wrapping_add(a);
    a = a.wrapping_sub(c);
    a ^= c.rotate_left(16);
    c = c.wrapping_add(b);
    b = b.wrapping_sub(a);
    b ^= a.rotate_left(19);
    a = a.wrapping_add(c);
    c = c.wrapping_sub(b);
    c ^= b.rotate_left(4);
    b = b.wrapping_add(a);
    [a, b, c]
}

/// `bjfinal` of OpenImageIO's `hash.h`: the final mix of (a, b, c) into c.
pub fn bjfinal(a: u32, b: u32, c: u32) -> u32 {
    let (mut a, mut b, mut c) = (a, b, c);
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(14));
    a ^= c;
    a = a.wrapping_sub(c.rotate_left(11));
    b ^= a;
    b = b.wrapping_sub(a.rotate_left(25));
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(16));
    a ^= c;
    a = a.wrapping_sub(c.rotate_left(4));
    b ^= a;
    b = b.wrapping_sub(a.rotate_left(14));
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(24));
    c
}

/// The start value of lookup3's `hashword` for `len` keys with OSL's initval 13.
pub(crate) const fn start(len: u32) -> u32 {
    0xdead_beef_u32.wrapping_add(len << 2).wrapping_add(13)
}

/// OSL `inthash(k0)`.
pub fn inthash1(k0: u32) -> u32 {
    let s = start(1);
    bjfinal(s.wrapping_add(k0), s, s)
}

/// OSL `inthash(k0, k1)`.
pub fn inthash2(k0: u32, k1: u32) -> u32 {
    let s = start(2);
    bjfinal(s.wrapping_add(k0), s.wrapping_add(k1), s)
}

/// OSL `inthash(k0, k1, k2)`.
pub fn inthash3(k0: u32, k1: u32, k2: u32) -> u32 {
    let s = start(3);
    bjfinal(s.wrapping_add(k0), s.wrapping_add(k1), s.wrapping_add(k2))
}

/// OSL `inthash(k0, k1, k2, k3)`.
pub fn inthash4(k0: u32, k1: u32, k2: u32, k3: u32) -> u32 {
    let s = start(4);
    let [a, b, c] = bjmix(s.wrapping_add(k0), s.wrapping_add(k1), s.wrapping_add(k2));
    bjfinal(a.wrapping_add(k3), b, c)
}

/// OSL `bits_to_01`: `bits · (float)(1 / (2³² − 1))`, where that constant rounds to 2⁻³²
/// in f32: the f32 nearest `bits`, times 2⁻³² (exact). In [0, 1]: 1 for `bits` ≥
/// 0xFFFF_FF80.
pub fn bits_to_01<F: Real>(bits: u32) -> F {
    // One rounding (of `bits` to F), then an exact scaling by a power of two.
    F::from_f64(bits as f64) * F::from_f64(1.0 / 4_294_967_296.0)
}

// ---- Perlin noise ----

/// OSL `floorfrac`: the lattice cell `floor(x)` (saturating) and the offset in it (see the
/// module doc for coordinates the source leaves undefined).
pub(super) fn floorfrac<F: Real>(x: F) -> (i32, F) {
    let f = x.floor();
    let frac = x - f;
    let frac = if frac.is_finite() { frac } else { F::ZERO };
    (f.to_i32(), frac)
}

/// OSL `fade`: `t³(t(6t − 15) + 10)`.
fn fade<F: Real>(t: F) -> F {
    t * t * t * (t * (t * F::from_f64(6.0) - F::from_f64(15.0)) + F::from_f64(10.0))
}

/// OSL `negate_if`.
fn negate_if<F: Real>(v: F, cond: bool) -> F {
    if cond { -v } else { v }
}

/// OSL 2D `grad`: the dot product of (x, y) with one of (±1, ±2), (±2, ±1).
fn grad2<F: Real>(hash: u32, x: F, y: F) -> F {
    let h = hash & 7;
    let u = if h < 4 { x } else { y };
    let v = F::from_f64(2.0) * if h < 4 { y } else { x };
    negate_if(u, h & 1 != 0) + negate_if(v, h & 2 != 0)
}

/// OSL 3D `grad`: the dot product of (x, y, z) with a vector to one of the cube's edges.
fn grad3<F: Real>(hash: u32, x: F, y: F, z: F) -> F {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    negate_if(u, h & 1 != 0) + negate_if(v, h & 2 != 0)
}

/// `OIIO::bilerp(v0, v1, v2, v3, s, t)`: `(1−t)(v0(1−s) + v1 s) + t(v2(1−s) + v3 s)`.
fn bilerp<F: Real>(v: [F; 4], s: F, t: F) -> F {
    let s1 = F::ONE - s;
    (F::ONE - t) * (v[0] * s1 + v[1] * s) + t * (v[2] * s1 + v[3] * s)
}

/// `OIIO::trilerp(v0 … v7, s, t, r)`.
fn trilerp<F: Real>(v: [F; 8], s: F, t: F, r: F) -> F {
    let s1 = F::ONE - s;
    let t1 = F::ONE - t;
    let r1 = F::ONE - r;
    r1 * (t1 * (v[0] * s1 + v[1] * s) + t * (v[2] * s1 + v[3] * s))
        + r * (t1 * (v[4] * s1 + v[5] * s) + t * (v[6] * s1 + v[7] * s))
}

/// OSL `sliceup`: bytes 0, 1 and 2 of a hash, one per component of vector noise.
fn sliceup(h: u32) -> [u32; 3] {
    [h & 0xff, (h >> 8) & 0xff, (h >> 16) & 0xff]
}

/// The hash key of lattice coordinate `c` (plus `d`, 0 or 1): the coordinate itself, or
/// for periodic noise (`period` ≥ 1; 0: none) OSL's `imod(c + d, period)`, in `[0,
/// period)`.
fn key(c: i32, d: usize, period: i32) -> u32 {
    let c = c.wrapping_add(d as i32);
    if period > 0 {
        c.rem_euclid(period) as u32
    } else {
        c as u32
    }
}

/// OSL `HashScalarPeriodic`'s period of a coordinate: `max(1, ifloor(p))`.
fn period<F: Real>(p: F) -> i32 {
    p.floor().to_i32().max(1)
}

/// The hashes of a 2D cell's corners, in `bilerp`'s order (`per`: the periods, 0 none).
fn corners2(x: i32, y: i32, per: [i32; 2]) -> [u32; 4] {
    std::array::from_fn(|k| inthash2(key(x, k & 1, per[0]), key(y, (k >> 1) & 1, per[1])))
}

/// The hashes of a 3D cell's corners, in `trilerp`'s order.
fn corners3(x: i32, y: i32, z: i32, per: [i32; 3]) -> [u32; 8] {
    std::array::from_fn(|k| {
        inthash3(
            key(x, k & 1, per[0]),
            key(y, (k >> 1) & 1, per[1]),
            key(z, (k >> 2) & 1, per[2]),
        )
    })
}

/// The corners' offsets from the point: (fx − dx, fy − dy), in `bilerp`'s order.
fn offsets2<F: Real>(fx: F, fy: F) -> [[F; 2]; 4] {
    let one = F::ONE;
    [
        [fx, fy],
        [fx - one, fy],
        [fx, fy - one],
        [fx - one, fy - one],
    ]
}

/// The corners' offsets (fx − dx, fy − dy, fz − dz), in `trilerp`'s order.
fn offsets3<F: Real>(fx: F, fy: F, fz: F) -> [[F; 3]; 8] {
    let one = F::ONE;
    std::array::from_fn(|k| {
        let o = |bit: usize, f: F| if (k >> bit) & 1 == 1 { f - one } else { f };
        [o(0, fx), o(1, fy), o(2, fz)]
    })
}

/// OSL `snoise(x, y)`: signed 2D Perlin noise, `0.6616 · bilerp(grad …)`, about [−1, 1];
/// 0 at every lattice point.
pub fn perlin2<F: Real>(p: [F; 2]) -> F {
    perlin2_at(p, [0; 2])
}

/// [`perlin2`] on a lattice with periods `per` (0: none).
fn perlin2_at<F: Real>(p: [F; 2], per: [i32; 2]) -> F {
    let (x, fx) = floorfrac(p[0]);
    let (y, fy) = floorfrac(p[1]);
    let (u, v) = (fade(fx), fade(fy));
    let h = corners2(x, y, per);
    let o = offsets2(fx, fy);
    let g = std::array::from_fn(|k| grad2(h[k], o[k][0], o[k][1]));
    F::from_f64(0.6616) * bilerp(g, u, v)
}

/// OSL `snoise(p)`: signed 3D Perlin noise, `0.9820 · trilerp(grad …)`, about [−1, 1];
/// 0 at every lattice point.
pub fn perlin3<F: Real>(p: [F; 3]) -> F {
    perlin3_at(p, [0; 3])
}

/// [`perlin3`] on a lattice with periods `per` (0: none).
fn perlin3_at<F: Real>(p: [F; 3], per: [i32; 3]) -> F {
    let (x, fx) = floorfrac(p[0]);
    let (y, fy) = floorfrac(p[1]);
    let (z, fz) = floorfrac(p[2]);
    let (u, v, w) = (fade(fx), fade(fy), fade(fz));
    let h = corners3(x, y, z, per);
    let o = offsets3(fx, fy, fz);
    let g = std::array::from_fn(|k| grad3(h[k], o[k][0], o[k][1], o[k][2]));
    F::from_f64(0.9820) * trilerp(g, u, v, w)
}

/// OSL `vector snoise(x, y)`: each component a 2D Perlin noise whose corner gradients come
/// from one byte of the corner's hash (OSL `HashVector`'s `sliceup`).
pub fn vperlin2<F: Real>(p: [F; 2]) -> [F; 3] {
    vperlin2_at(p, [0; 2])
}

/// [`vperlin2`] on a lattice with periods `per` (0: none).
fn vperlin2_at<F: Real>(p: [F; 2], per: [i32; 2]) -> [F; 3] {
    let (x, fx) = floorfrac(p[0]);
    let (y, fy) = floorfrac(p[1]);
    let (u, v) = (fade(fx), fade(fy));
    let h = corners2(x, y, per).map(sliceup);
    let o = offsets2(fx, fy);
    std::array::from_fn(|c| {
        let g = std::array::from_fn(|k| grad2(h[k][c], o[k][0], o[k][1]));
        F::from_f64(0.6616) * bilerp(g, u, v)
    })
}

/// OSL `vector snoise(p)`: [`vperlin2`] in 3D.
pub fn vperlin3<F: Real>(p: [F; 3]) -> [F; 3] {
    vperlin3_at(p, [0; 3])
}

/// [`vperlin3`] on a lattice with periods `per` (0: none).
fn vperlin3_at<F: Real>(p: [F; 3], per: [i32; 3]) -> [F; 3] {
    let (x, fx) = floorfrac(p[0]);
    let (y, fy) = floorfrac(p[1]);
    let (z, fz) = floorfrac(p[2]);
    let (u, v, w) = (fade(fx), fade(fy), fade(fz));
    let h = corners3(x, y, z, per).map(sliceup);
    let o = offsets3(fx, fy, fz);
    std::array::from_fn(|c| {
        let g = std::array::from_fn(|k| grad3(h[k][c], o[k][0], o[k][1], o[k][2]));
        F::from_f64(0.9820) * trilerp(g, u, v, w)
    })
}

/// OSL 1D `grad`: `x` times one of ±1 … ±8.
fn grad1<F: Real>(hash: u32, x: F) -> F {
    let h = hash & 15;
    let g = F::from_f64(f64::from(1 + (h & 7)));
    negate_if(g, h & 8 != 0) * x
}

/// OSL 4D `grad`: the dot product of (x, y, z, w) with a vector to one of the
/// hypercube's edges.
fn grad4<F: Real>(hash: u32, x: F, y: F, z: F, w: F) -> F {
    let h = hash & 31;
    let u = if h < 24 { x } else { y };
    let v = if h < 16 { y } else { z };
    let s = if h < 8 { z } else { w };
    negate_if(u, h & 1 != 0) + negate_if(v, h & 2 != 0) + negate_if(s, h & 4 != 0)
}

/// `OIIO::lerp(a, b, t)`: `a(1 − t) + b t`.
fn lerp<F: Real>(a: F, b: F, t: F) -> F {
    a * (F::ONE - t) + b * t
}

/// The hashes of a 4D cell's corners: `trilerp`'s order at `w`, then at `w + 1`.
fn corners4(c: [i32; 4], per: [i32; 4]) -> [u32; 16] {
    std::array::from_fn(|k| {
        let d = |a: usize| key(c[a], (k >> a) & 1, per[a]);
        inthash4(d(0), d(1), d(2), d(3))
    })
}

/// The corners' offsets (fx − dx, fy − dy, fz − dz, fw − dw), in [`corners4`]'s order.
fn offsets4<F: Real>(f: [F; 4]) -> [[F; 4]; 16] {
    std::array::from_fn(|k| {
        std::array::from_fn(|d| {
            if (k >> d) & 1 == 1 {
                f[d] - F::ONE
            } else {
                f[d]
            }
        })
    })
}

/// OSL `snoise(x)`: signed 1D Perlin noise, `0.25 · lerp(grad …)`, about [−1, 1]; 0 at
/// every integer.
pub fn perlin1<F: Real>(x: F) -> F {
    perlin1_at(x, 0)
}

/// [`perlin1`] on a lattice with period `per` (0: none).
fn perlin1_at<F: Real>(x: F, per: i32) -> F {
    let (xi, fx) = floorfrac(x);
    let u = fade(fx);
    let (h0, h1) = (inthash1(key(xi, 0, per)), inthash1(key(xi, 1, per)));
    F::from_f64(0.25) * lerp(grad1(h0, fx), grad1(h1, fx - F::ONE), u)
}

/// OSL `vector snoise(x)`: [`perlin1`] per component, the gradients from one byte of the
/// corner's hash each (`sliceup`).
pub fn vperlin1<F: Real>(x: F) -> [F; 3] {
    vperlin1_at(x, 0)
}

/// [`vperlin1`] on a lattice with period `per` (0: none).
fn vperlin1_at<F: Real>(x: F, per: i32) -> [F; 3] {
    let (xi, fx) = floorfrac(x);
    let u = fade(fx);
    let (h0, h1) = (
        sliceup(inthash1(key(xi, 0, per))),
        sliceup(inthash1(key(xi, 1, per))),
    );
    std::array::from_fn(|c| {
        F::from_f64(0.25) * lerp(grad1(h0[c], fx), grad1(h1[c], fx - F::ONE), u)
    })
}

/// The 4D Perlin sum over corner hashes `h` and offsets `o`: `lerp(trilerp(g[0..8]),
/// trilerp(g[8..16]), fade(fw))` of the gradients `g`, unscaled.
fn perlin4_of<F: Real>(h: &[u32; 16], o: &[[F; 4]; 16], fade4: [F; 4]) -> F {
    let g: [F; 16] = std::array::from_fn(|k| grad4(h[k], o[k][0], o[k][1], o[k][2], o[k][3]));
    let [u, v, t, s] = fade4;
    let lo = trilerp(std::array::from_fn(|k| g[k]), u, v, t);
    let hi = trilerp(std::array::from_fn(|k| g[8 + k]), u, v, t);
    lerp(lo, hi, s)
}

/// OSL `snoise(p, t)`: signed 4D Perlin noise, `0.8344 · lerp(trilerp(…), trilerp(…))`,
/// about [−1, 1]; 0 at every lattice point.
pub fn perlin4<F: Real>(p: [F; 3], t: F) -> F {
    perlin4_at([p[0], p[1], p[2], t], [0; 4])
}

/// [`perlin4`] of `(x, y, z, t)` on a lattice with periods `per` (0: none).
fn perlin4_at<F: Real>(p: [F; 4], per: [i32; 4]) -> F {
    let c = p.map(floorfrac);
    let f = c.map(|(_, f)| f);
    let h = corners4(c.map(|(i, _)| i), per);
    F::from_f64(0.8344) * perlin4_of(&h, &offsets4(f), f.map(fade))
}

/// OSL `vector snoise(p, t)`: [`perlin4`] per component, one hash byte each.
pub fn vperlin4<F: Real>(p: [F; 3], t: F) -> [F; 3] {
    vperlin4_at([p[0], p[1], p[2], t], [0; 4])
}

/// [`vperlin4`] of `(x, y, z, t)` on a lattice with periods `per` (0: none).
fn vperlin4_at<F: Real>(p: [F; 4], per: [i32; 4]) -> [F; 3] {
    let c = p.map(floorfrac);
    let f = c.map(|(_, f)| f);
    let h = corners4(c.map(|(i, _)| i), per).map(sliceup);
    let o = offsets4(f);
    std::array::from_fn(|comp| {
        let hc = h.map(|s| s[comp]);
        F::from_f64(0.8344) * perlin4_of(&hc, &o, f.map(fade))
    })
}

// ---- periodic Perlin noise (`psnoise`): the lattice wraps (OSL `HashScalarPeriodic`) ----

/// OSL `psnoise(x, px)`: [`perlin1`] whose lattice repeats every `max(1, ifloor(px))`.
pub fn pperlin1<F: Real>(x: F, px: F) -> F {
    perlin1_at(x, period(px))
}

/// OSL `psnoise(x, y, px, py)`.
pub fn pperlin2<F: Real>(p: [F; 2], pp: [F; 2]) -> F {
    perlin2_at(p, pp.map(period))
}

/// OSL `psnoise(p, pp)`.
pub fn pperlin3<F: Real>(p: [F; 3], pp: [F; 3]) -> F {
    perlin3_at(p, pp.map(period))
}

/// OSL `psnoise(p, t, pp, pt)`.
pub fn pperlin4<F: Real>(p: [F; 3], t: F, pp: [F; 3], pt: F) -> F {
    perlin4_at([p[0], p[1], p[2], t], [pp[0], pp[1], pp[2], pt].map(period))
}

/// OSL `vector psnoise(x, px)`.
pub fn vpperlin1<F: Real>(x: F, px: F) -> [F; 3] {
    vperlin1_at(x, period(px))
}

/// OSL `vector psnoise(x, y, px, py)`.
pub fn vpperlin2<F: Real>(p: [F; 2], pp: [F; 2]) -> [F; 3] {
    vperlin2_at(p, pp.map(period))
}

/// OSL `vector psnoise(p, pp)`.
pub fn vpperlin3<F: Real>(p: [F; 3], pp: [F; 3]) -> [F; 3] {
    vperlin3_at(p, pp.map(period))
}

/// OSL `vector psnoise(p, t, pp, pt)`.
pub fn vpperlin4<F: Real>(p: [F; 3], t: F, pp: [F; 3], pt: F) -> [F; 3] {
    vperlin4_at([p[0], p[1], p[2], t], [pp[0], pp[1], pp[2], pt].map(period))
}

// ---- cell noise ----

/// OSL `CellNoise::transformToUint`: `ifloor(x)` (saturating; NaN → 0).
fn ifloor<F: Real>(x: F) -> u32 {
    x.floor().to_i32() as u32
}

/// OSL `HashNoise::transformToUint`: the bits of the coordinate as an f32 (a NaN's payload
/// included, as OSL's `bitcast` keeps it: no conversion on the way).
fn fbits<F: Real>(x: F) -> u32 {
    x.f32_bits()
}

/// OSL `inthash` of one to four keys.
fn hash_keys(k: &[u32]) -> u32 {
    match *k {
        [a] => inthash1(a),
        [a, b] => inthash2(a, b),
        [a, b, c] => inthash3(a, b, c),
        [a, b, c, d] => inthash4(a, b, c, d),
        _ => unreachable!("one to four keys"),
    }
}

/// OSL `inthashVec` of one to four keys: component k hashes the keys and k. Three keys
/// share one `bjmix` (`bjfinal(a + k, b, c)`), four too (`bjfinal(a + w, b + k, c)`).
fn vhash_keys(keys: &[u32]) -> [u32; 3] {
    match *keys {
        [x] => std::array::from_fn(|k| inthash2(x, k as u32)),
        [x, y] => std::array::from_fn(|k| inthash3(x, y, k as u32)),
        [x, y, z] => {
            let s = start(4);
            let [a, b, c] = bjmix(s.wrapping_add(x), s.wrapping_add(y), s.wrapping_add(z));
            std::array::from_fn(|k| bjfinal(a.wrapping_add(k as u32), b, c))
        }
        [x, y, z, w] => {
            let s = start(5);
            let [a, b, c] = bjmix(s.wrapping_add(x), s.wrapping_add(y), s.wrapping_add(z));
            let a = a.wrapping_add(w);
            std::array::from_fn(|k| bjfinal(a, b.wrapping_add(k as u32), c))
        }
        _ => unreachable!("one to four keys"),
    }
}

/// OSL `cellnoise(x, y)`: `bits_to_01(inthash(ifloor x, ifloor y))`, in [0, 1], constant
/// over each unit cell.
pub fn cell2<F: Real>(p: [F; 2]) -> F {
    bits_to_01(hash_keys(&p.map(ifloor)))
}

/// OSL `cellnoise(p)`: `bits_to_01(inthash(ifloor x, ifloor y, ifloor z))`, in [0, 1].
pub fn cell3<F: Real>(p: [F; 3]) -> F {
    bits_to_01(hash_keys(&p.map(ifloor)))
}

/// OSL `vector cellnoise(x, y)` (`inthashVec`): component k is
/// `bits_to_01(inthash(ifloor x, ifloor y, k))`.
pub fn vcell2<F: Real>(p: [F; 2]) -> [F; 3] {
    vhash_keys(&p.map(ifloor)).map(bits_to_01)
}

/// OSL `vector cellnoise(p)` (`inthashVec` of three keys): `inthash(x, y, z, k)` with the
/// `bjmix` shared, component k from `bjfinal(a + k, b, c)`.
pub fn vcell3<F: Real>(p: [F; 3]) -> [F; 3] {
    vhash_keys(&p.map(ifloor)).map(bits_to_01)
}

/// OSL `cellnoise(x)`: `bits_to_01(inthash(ifloor x))`, in [0, 1].
pub fn cell1<F: Real>(x: F) -> F {
    bits_to_01(hash_keys(&[ifloor(x)]))
}

/// OSL `cellnoise(p, t)`: `bits_to_01(inthash(ifloor x, ifloor y, ifloor z, ifloor t))`,
/// in [0, 1].
pub fn cell4<F: Real>(p: [F; 3], t: F) -> F {
    bits_to_01(hash_keys(&[p[0], p[1], p[2], t].map(ifloor)))
}

/// OSL `vector cellnoise(x)` (`inthashVec` of one key): component k is
/// `bits_to_01(inthash(ifloor x, k))`.
pub fn vcell1<F: Real>(x: F) -> [F; 3] {
    vhash_keys(&[ifloor(x)]).map(bits_to_01)
}

/// OSL `vector cellnoise(p, t)` (`inthashVec` of four keys): component k is
/// `bits_to_01(inthash(x, y, z, t, k))` — one `bjmix` of `x, y, z`, then `bjfinal(a + t,
/// b + k, c)`.
pub fn vcell4<F: Real>(p: [F; 3], t: F) -> [F; 3] {
    vhash_keys(&[p[0], p[1], p[2], t].map(ifloor)).map(bits_to_01)
}

// ---- hash noise: cell noise of the coordinates' bits ----

/// OSL `hashnoise(x)`: `bits_to_01(inthash(bits x))` — a different value for every f32.
pub fn hash1<F: Real>(x: F) -> F {
    bits_to_01(hash_keys(&[fbits(x)]))
}

/// OSL `hashnoise(x, y)`.
pub fn hash2<F: Real>(p: [F; 2]) -> F {
    bits_to_01(hash_keys(&p.map(fbits)))
}

/// OSL `hashnoise(p)`.
pub fn hash3<F: Real>(p: [F; 3]) -> F {
    bits_to_01(hash_keys(&p.map(fbits)))
}

/// OSL `hashnoise(p, t)`.
pub fn hash4<F: Real>(p: [F; 3], t: F) -> F {
    bits_to_01(hash_keys(&[p[0], p[1], p[2], t].map(fbits)))
}

/// OSL `vector hashnoise(x)` (`inthashVec` of the bits).
pub fn vhash1<F: Real>(x: F) -> [F; 3] {
    vhash_keys(&[fbits(x)]).map(bits_to_01)
}

/// OSL `vector hashnoise(x, y)`.
pub fn vhash2<F: Real>(p: [F; 2]) -> [F; 3] {
    vhash_keys(&p.map(fbits)).map(bits_to_01)
}

/// OSL `vector hashnoise(p)`.
pub fn vhash3<F: Real>(p: [F; 3]) -> [F; 3] {
    vhash_keys(&p.map(fbits)).map(bits_to_01)
}

/// OSL `vector hashnoise(p, t)`.
pub fn vhash4<F: Real>(p: [F; 3], t: F) -> [F; 3] {
    vhash_keys(&[p[0], p[1], p[2], t].map(fbits)).map(bits_to_01)
}

// ---- MaterialX fractal noise ----

/// The most octaves [`fractal2`] and friends sum (MaterialX loops `octaves` times; beyond
/// 32 octaves of lacunarity ≥ 2 the coordinates have lost every fractional bit).
pub const MAX_OCTAVES: i32 = 32;

/// MaterialX `mx_fractal2d_noise_float`: `Σ_{i<octaves} diminishⁱ · perlin2(p ·
/// lacunarityⁱ)`, accumulated as the source does (`result += amplitude · noise;
/// amplitude *= diminish; p *= lacunarity`); octaves clamped to [0, [`MAX_OCTAVES`]].
pub fn fractal2<F: Real>(p: [F; 2], octaves: i32, lacunarity: F, diminish: F) -> F {
    fractal(p, octaves, lacunarity, diminish, |q| [perlin2(q)])[0]
}

/// The fractal sum of any of the noises (`W` components) of a `D`-dimensional point: the
/// one loop [`fractal2`], [`fractal3`], [`vfractal2`] and [`vfractal3`] share.
fn fractal<F: Real, const D: usize, const W: usize>(
    p: [F; D],
    octaves: i32,
    lacunarity: F,
    diminish: F,
    noise: impl Fn([F; D]) -> [F; W],
) -> [F; W] {
    let (mut p, mut result, mut amplitude) = (p, [F::ZERO; W], F::ONE);
    for _ in 0..octaves.clamp(0, MAX_OCTAVES) {
        let n = noise(p);
        result = std::array::from_fn(|c| result[c] + amplitude * n[c]);
        amplitude = amplitude * diminish;
        p = p.map(|c| c * lacunarity);
    }
    result
}

/// MaterialX `mx_fractal3d_noise_float`: [`fractal2`] of [`perlin3`].
pub fn fractal3<F: Real>(p: [F; 3], octaves: i32, lacunarity: F, diminish: F) -> F {
    fractal(p, octaves, lacunarity, diminish, |q| [perlin3(q)])[0]
}

/// MaterialX `mx_fractal2d_noise_vec3`: [`fractal2`] of [`vperlin2`].
pub fn vfractal2<F: Real>(p: [F; 2], octaves: i32, lacunarity: F, diminish: F) -> [F; 3] {
    fractal(p, octaves, lacunarity, diminish, vperlin2)
}

/// MaterialX `mx_fractal3d_noise_vec3`: [`fractal3`] of [`vperlin3`].
pub fn vfractal3<F: Real>(p: [F; 3], octaves: i32, lacunarity: F, diminish: F) -> [F; 3] {
    fractal(p, octaves, lacunarity, diminish, vperlin3)
}

// ---- MaterialX Worley noise ----

/// `float(i)` of the source (rounded to nearest).
fn itof<F: Real>(i: i32) -> F {
    F::from_i32(i)
}

/// `mx_worley_cell_position` (2D): the jittered feature point of cell (X + x, Y + y),
/// relative to cell (X, Y).
fn cell_position2<F: Real>(x: i32, y: i32, cell: [i32; 2], jitter: F) -> [F; 2] {
    let q = [itof(x.wrapping_add(cell[0])), itof(y.wrapping_add(cell[1]))];
    let tmp = vcell2::<F>(q);
    let half = F::from_f64(0.5);
    let off = [tmp[0], tmp[1]].map(|o| (o - half) * jitter + half);
    [itof::<F>(x) + off[0], itof::<F>(y) + off[1]]
}

/// `mx_worley_cell_position` (3D).
fn cell_position3<F: Real>(x: i32, y: i32, z: i32, cell: [i32; 3], jitter: F) -> [F; 3] {
    let q = [
        itof(x.wrapping_add(cell[0])),
        itof(y.wrapping_add(cell[1])),
        itof(z.wrapping_add(cell[2])),
    ];
    let half = F::from_f64(0.5);
    let off = vcell3::<F>(q).map(|o| (o - half) * jitter + half);
    [
        itof::<F>(x) + off[0],
        itof::<F>(y) + off[1],
        itof::<F>(z) + off[2],
    ]
}

/// GLSL `max(a, b)`: `a < b ? b : a`.
fn gmax<F: Real>(a: F, b: F) -> F {
    if a < b { b } else { a }
}

/// `mx_worley_distance`'s metric of a difference: 2 Manhattan, 3 Chebyshev, otherwise the
/// squared Euclidean distance (its square root is taken at the end for metric 0).
fn metric_of<F: Real>(d: &[F], metric: i32) -> F {
    match metric {
        2 => d.iter().skip(1).fold(d[0].abs(), |s, x| s + x.abs()),
        3 => d.iter().skip(1).fold(d[0].abs(), |s, x| gmax(s, x.abs())),
        _ => d.iter().skip(1).fold(d[0] * d[0], |s, x| s + *x * *x),
    }
}

/// The sorted nearest distances (F1 ≤ F2 ≤ F3) of the 3×3 (×3) neighbourhood and the
/// nearest feature point relative to the point (`minpos`), as `mx_worley_noise_vec3`
/// computes them; `n` of the distances are kept (1, 2 or 3), the others stay 10⁶.
struct Nearest<F> {
    sqdist: [F; 3],
    minpos: [F; 3],
}

impl<F: Real> Nearest<F> {
    fn new() -> Self {
        Nearest {
            sqdist: [F::from_f64(1e6); 3],
            minpos: [F::ZERO; 3],
        }
    }

    /// The source's insertion for `n` kept distances (the float version keeps one, the
    /// vector2 version two, the vector3 version three).
    fn insert(&mut self, n: usize, dist: F, cellpos: [F; 3]) {
        let d = &mut self.sqdist;
        if dist < d[0] {
            if n > 2 {
                d[2] = d[1];
            }
            if n > 1 {
                d[1] = d[0];
            }
            d[0] = dist;
            self.minpos = cellpos;
        } else if n > 1 && dist < d[1] {
            if n > 2 {
                d[2] = d[1];
            }
            d[1] = dist;
        } else if n > 2 && dist < d[2] {
            d[2] = dist;
        }
    }
}

/// The distances of [`worley2`]'s search, or for style 1 the nearest feature point added to
/// the point (where the source looks up its cell noise).
fn worley2_search<F: Real>(p: [F; 2], jitter: F, metric: i32, n: usize) -> Nearest<F> {
    let (cx, lx) = floorfrac(p[0]);
    let (cy, ly) = floorfrac(p[1]);
    let mut near = Nearest::new();
    for x in -1..=1 {
        for y in -1..=1 {
            let cp = cell_position2(x, y, [cx, cy], jitter);
            let diff = [cp[0] - lx, cp[1] - ly];
            let dist = metric_of(&diff, metric);
            near.insert(n, dist, [diff[0], diff[1], F::ZERO]);
        }
    }
    near
}

/// [`worley2_search`] in 3D.
fn worley3_search<F: Real>(p: [F; 3], jitter: F, metric: i32, n: usize) -> Nearest<F> {
    let (cx, lx) = floorfrac(p[0]);
    let (cy, ly) = floorfrac(p[1]);
    let (cz, lz) = floorfrac(p[2]);
    let mut near = Nearest::new();
    for x in -1..=1 {
        for y in -1..=1 {
            for z in -1..=1 {
                let cp = cell_position3(x, y, z, [cx, cy, cz], jitter);
                let diff = [cp[0] - lx, cp[1] - ly, cp[2] - lz];
                let dist = metric_of(&diff, metric);
                near.insert(n, dist, diff);
            }
        }
    }
    near
}

/// The distances at the end of `mx_worley_noise_*`: square roots for metric 0.
fn finish<F: Real, const N: usize>(sqdist: [F; 3], metric: i32) -> [F; N] {
    std::array::from_fn(|k| {
        if metric == 0 {
            sqdist[k].sqrt()
        } else {
            sqdist[k]
        }
    })
}

/// MaterialX `mx_worley_noise_float(vec2 p, jitter, style, metric)`: style 1 gives the cell
/// noise of the nearest feature point, any other style the distance to it (F1) in the
/// metric (0 Euclidean, 1 squared Euclidean, 2 Manhattan, 3 Chebyshev, others squared).
pub fn worley2<F: Real>(p: [F; 2], jitter: F, style: i32, metric: i32) -> F {
    let near = worley2_search(p, jitter, metric, 1);
    if style == 1 {
        let m = near.minpos;
        cell2([m[0] + p[0], m[1] + p[1]])
    } else {
        finish::<F, 1>(near.sqdist, metric)[0]
    }
}

/// MaterialX `mx_worley_noise_vec2(vec2 p, …)`: (F1, F2), or for style 1 the first two
/// components of the vector cell noise of the nearest feature point.
pub fn worley2_v2<F: Real>(p: [F; 2], jitter: F, style: i32, metric: i32) -> [F; 2] {
    let near = worley2_search(p, jitter, metric, 2);
    if style == 1 {
        let m = near.minpos;
        let c = vcell2([m[0] + p[0], m[1] + p[1]]);
        [c[0], c[1]]
    } else {
        finish(near.sqdist, metric)
    }
}

/// MaterialX `mx_worley_noise_vec3(vec2 p, …)`: (F1, F2, F3), or for style 1 the vector
/// cell noise of the nearest feature point.
pub fn worley2_v3<F: Real>(p: [F; 2], jitter: F, style: i32, metric: i32) -> [F; 3] {
    let near = worley2_search(p, jitter, metric, 3);
    if style == 1 {
        let m = near.minpos;
        vcell2([m[0] + p[0], m[1] + p[1]])
    } else {
        finish(near.sqdist, metric)
    }
}

/// MaterialX `mx_worley_noise_float(vec3 p, …)`: [`worley2`] in 3D (27 cells).
pub fn worley3<F: Real>(p: [F; 3], jitter: F, style: i32, metric: i32) -> F {
    let near = worley3_search(p, jitter, metric, 1);
    if style == 1 {
        let m = near.minpos;
        cell3([m[0] + p[0], m[1] + p[1], m[2] + p[2]])
    } else {
        finish::<F, 1>(near.sqdist, metric)[0]
    }
}

/// MaterialX `mx_worley_noise_vec2(vec3 p, …)`: [`worley2_v2`] in 3D.
pub fn worley3_v2<F: Real>(p: [F; 3], jitter: F, style: i32, metric: i32) -> [F; 2] {
    let near = worley3_search(p, jitter, metric, 2);
    if style == 1 {
        let m = near.minpos;
        let c = vcell3([m[0] + p[0], m[1] + p[1], m[2] + p[2]]);
        [c[0], c[1]]
    } else {
        finish(near.sqdist, metric)
    }
}

/// MaterialX `mx_worley_noise_vec3(vec3 p, …)`: [`worley2_v3`] in 3D.
pub fn worley3_v3<F: Real>(p: [F; 3], jitter: F, style: i32, metric: i32) -> [F; 3] {
    let near = worley3_search(p, jitter, metric, 3);
    if style == 1 {
        let m = near.minpos;
        vcell3([m[0] + p[0], m[1] + p[1], m[2] + p[2]])
    } else {
        finish(near.sqdist, metric)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// OSL's `reference_inthash<N>` (the loop-and-switch form of lookup3's `hashword` with
    /// initval 13), written independently of the unrolled functions above, with `bjmix` and
    /// `bjfinal` written out from lookup3's `mix`/`final` macros.
    fn reference_inthash(k: &[u32]) -> u32 {
        fn rot(x: u32, k: u32) -> u32 {
            x.rotate_left(k)
        }
        fn mix(a: &mut u32, b: &mut u32, c: &mut u32) {
            for (r, [x, y, z]) in [4, 6, 8, 16, 19, 4].into_iter().zip([
                [0, 1, 2],
                [1, 2, 0],
                [2, 0, 1],
                [0, 1, 2],
                [1, 2, 0],
                [2, 0, 1],
            ]) {
                let mut v = [*a, *b, *c];
                // x -= z; x ^= rot(z, r); z += y;
                v[x] = v[x].wrapping_sub(v[z]);
                v[x] ^= rot(v[z], r);
                v[z] = v[z].wrapping_add(v[y]);
                [*a, *b, *c] = v;
            }
        }
        fn fin(mut a: u32, mut b: u32, mut c: u32) -> u32 {
            c ^= b;
            c = c.wrapping_sub(rot(b, 14));
            a ^= c;
            a = a.wrapping_sub(rot(c, 11));
            b ^= a;
            b = b.wrapping_sub(rot(a, 25));
            c ^= b;
            c = c.wrapping_sub(rot(b, 16));
            a ^= c;
            a = a.wrapping_sub(rot(c, 4));
            b ^= a;
            b = b.wrapping_sub(rot(a, 14));
            c ^= b;
            c.wrapping_sub(rot(b, 24))
        }
        let mut len = k.len();
        let init = 0xdeadbeefu32
            .wrapping_add((len as u32) << 2)
            .wrapping_add(13);
        let (mut a, mut b, mut c) = (init, init, init);
        let mut k = k;
        while len > 3 {
            a = a.wrapping_add(k[0]);
            b = b.wrapping_add(k[1]);
            c = c.wrapping_add(k[2]);
            mix(&mut a, &mut b, &mut c);
            len -= 3;
            k = &k[3..];
        }
        if len == 0 {
            return c;
        }
        if len == 3 {
            c = c.wrapping_add(k[2]);
        }
        if len >= 2 {
            b = b.wrapping_add(k[1]);
        }
        a = a.wrapping_add(k[0]);
        fin(a, b, c)
    }

    const KEYS: [u32; 9] = [
        0,
        1,
        2,
        7,
        255,
        0x8000_0000,
        0xffff_ffff,
        0xdead_beef,
        12345,
    ];

    /// Cell noise of one and four dimensions (float and vector) is `bits_to_01` of OSL's
    /// `inthash` (lookup3's hashword) of the floored coordinates — with the component index
    /// as the last key for the vector forms — on keys around 0 and the integer limits.
    #[test]
    fn cell1_and_cell4_hash_their_floored_keys() {
        let xs = [-2.5f32, -0.25, 0.0, 0.75, 3.5, 1e10, -1e10, f32::NAN];
        let key = |x: f32| ifloor(x);
        for &x in &xs {
            assert_eq!(cell1(x), bits_to_01::<f32>(reference_inthash(&[key(x)])));
            let v = vcell1(x);
            for (k, c) in v.iter().enumerate() {
                assert_eq!(
                    *c,
                    bits_to_01::<f32>(reference_inthash(&[key(x), k as u32]))
                );
            }
            for &y in &xs[..4] {
                let p = [x, y, 0.5 - y];
                for &t in &[-1.5f32, 0.0, 2.0, 7.9] {
                    let keys = [key(p[0]), key(p[1]), key(p[2]), key(t)];
                    assert_eq!(cell4(p, t), bits_to_01::<f32>(reference_inthash(&keys)));
                    for (k, c) in vcell4(p, t).iter().enumerate() {
                        let mut five = keys.to_vec();
                        five.push(k as u32);
                        assert_eq!(*c, bits_to_01::<f32>(reference_inthash(&five)));
                    }
                }
            }
        }
        // The fourth coordinate matters.
        assert_ne!(cell4([0.5f32; 3], 0.0), cell4([0.5; 3], 1.0));
    }

    #[test]
    fn inthash_is_lookup3_hashword_with_initval_13() {
        for &x in &KEYS {
            assert_eq!(inthash1(x), reference_inthash(&[x]));
            for &y in &KEYS {
                assert_eq!(inthash2(x, y), reference_inthash(&[x, y]));
                for &z in &KEYS {
                    assert_eq!(inthash3(x, y, z), reference_inthash(&[x, y, z]));
                    for w in [0, 1, 2, 0xffff_ffff] {
                        assert_eq!(inthash4(x, y, z, w), reference_inthash(&[x, y, z, w]));
                    }
                }
            }
        }
        // The reference agrees with lookup3's own empty-input value (c = 0xdeadbeef + 13).
        assert_eq!(reference_inthash(&[]), 0xdead_beef + 13);
    }

    #[test]
    fn vector_cell_noise_hashes_an_extra_key_per_component() {
        // OSL's `inthashVec(k0, k1, k2)` is reference_inthash<4>(k0, k1, k2, component).
        for &x in &KEYS[..5] {
            for &y in &KEYS[..5] {
                for &z in &KEYS[..5] {
                    let p = [x as i32 as f32, y as i32 as f32, z as i32 as f32];
                    let keys = p.map(|c| c.floor() as i32 as u32);
                    let want: [f32; 3] = std::array::from_fn(|k| {
                        bits_to_01(reference_inthash(&[keys[0], keys[1], keys[2], k as u32]))
                    });
                    assert_eq!(vcell3(p), want);
                    let want: [f32; 3] = std::array::from_fn(|k| {
                        bits_to_01(reference_inthash(&[keys[0], keys[1], k as u32]))
                    });
                    assert_eq!(vcell2([p[0], p[1]]), want);
                }
            }
        }
    }

    #[test]
    fn bits_to_01_rounds_once_then_scales() {
        assert_eq!(bits_to_01::<f32>(0), 0.0);
        assert_eq!(bits_to_01::<f32>(1), 2f32.powi(-32));
        assert_eq!(bits_to_01::<f32>(0x8000_0000), 0.5);
        // The f32 nearest 0xFFFF_FF7F is 0xFFFF_FF00; from 0xFFFF_FF80 on it is 2³² (OSL's
        // cellnoise reaches 1).
        assert_eq!(bits_to_01::<f32>(0xffff_ff7f), 1.0 - 2f32.powi(-24));
        assert_eq!(bits_to_01::<f32>(0xffff_ff80), 1.0);
        assert_eq!(bits_to_01::<f32>(u32::MAX), 1.0);
    }

    /// Within the 6 significant digits OSL's test prints.
    fn close(got: f32, want: f32) -> bool {
        (got - want).abs() <= 2e-6
    }

    /// The values OSL's own unit test (`src/liboslnoise/oslnoise_test.cpp`, `test_perlin`)
    /// checks `snoise` and `vsnoise` against, 1D to 4D.
    #[test]
    fn osl_unit_test_perlin_values() {
        let s2 = [
            0.0, 0.0874839, 0.0, 0.219915, 0.0, -0.32144, 0.3308, 0.567027, 0.0,
        ];
        let s3 = [
            0.0, -0.298763, 0.12275, 0.0533643, 0.0, -0.106914, -0.61375, -0.504605, 0.0,
        ];
        let v2 = [
            [0.0, 0.0, 0.0],
            [0.0874839, 0.414739, 0.0248834],
            [0.0, 0.4962, -0.4962],
            [0.219915, 0.414739, -0.546962],
            [0.0, 0.0, 0.0],
            [-0.32144, -0.290742, 0.526898],
            [0.3308, 0.0, 0.4962],
            [0.567027, 0.290742, 0.14888],
            [0.0, 0.0, 0.0],
        ];
        let v3 = [
            [0.0, 0.0, 0.0],
            [-0.298763, -0.18861, 0.0753458],
            [0.12275, -0.491, 0.0],
            [0.0533643, -0.476305, -0.303479],
            [0.0, 0.0, 0.0],
            [-0.106914, 0.331779, 0.196719],
            [-0.61375, 0.36825, 0.0],
            [-0.504605, 0.0252173, 0.29568],
            [0.0, 0.0, 0.0],
        ];
        for i in 0..=8 {
            let x = i as f32 / 4.0;
            let (a, b) = (perlin2([x, x]), perlin3([x, x, x]));
            assert!(close(a, s2[i]), "snoise({x}, {x}) = {a}, OSL {}", s2[i]);
            assert!(close(b, s3[i]), "snoise(p = {x}) = {b}, OSL {}", s3[i]);
            let (a, b) = (vperlin2([x, x]), vperlin3([x, x, x]));
            for c in 0..3 {
                assert!(
                    close(a[c], v2[i][c]),
                    "vsnoise({x}, {x}) = {a:?}, OSL {:?}",
                    v2[i]
                );
                assert!(
                    close(b[c], v3[i][c]),
                    "vsnoise(p = {x}) = {b:?}, OSL {:?}",
                    v3[i]
                );
            }
        }
        // 1D and 4D: `snoise(x)`, `snoise(p, t)` with p = (x, x, x), t = x.
        let s1 = [
            0.0, 0.316772, 0.3125, 0.0604248, 0.0, 0.211304, 0.5625, 0.467651, 0.0,
        ];
        let s4 = [
            0.0, 0.261616, 0.1043, -0.0740929, 0.0, -0.0687704, -0.1043, 0.0645373, 0.0,
        ];
        let v1 = [
            [0.0, 0.0, 0.0],
            [0.316772, -0.416016, -0.267334],
            [0.3125, -0.75, -0.625],
            [0.0604248, -0.489258, -0.487061],
            [0.0, 0.0, 0.0],
            [0.211304, 0.43103, 0.351196],
            [0.5625, 0.5625, 0.1875],
            [0.467651, 0.247925, -0.124878],
            [0.0, 0.0, 0.0],
        ];
        let v4 = [
            [0.0, 0.0, 0.0],
            [0.261616, -0.0846003, 0.353395],
            [0.1043, -0.1043, -0.1043],
            [-0.0740929, -0.168687, -0.333449],
            [0.0, 0.0, 0.0],
            [-0.0687704, 0.0508762, 0.224071],
            [-0.1043, -0.15645, 0.0],
            [0.0645373, -0.14268, -0.229348],
            [0.0, 0.0, 0.0],
        ];
        for i in 0..=8 {
            let x = i as f32 / 4.0;
            let (a, b) = (perlin1(x), perlin4([x; 3], x));
            assert!(close(a, s1[i]), "snoise({x}) = {a}, OSL {}", s1[i]);
            assert!(close(b, s4[i]), "snoise(p, t = {x}) = {b}, OSL {}", s4[i]);
            let (a, b) = (vperlin1(x), vperlin4([x; 3], x));
            for c in 0..3 {
                assert!(
                    close(a[c], v1[i][c]),
                    "vsnoise({x}) = {a:?}, OSL {:?}",
                    v1[i]
                );
                assert!(
                    close(b[c], v4[i][c]),
                    "vsnoise(p, t = {x}) = {b:?}, OSL {:?}",
                    v4[i]
                );
            }
        }
    }

    /// `test_cell`'s values of `cellnoise` and `vcellnoise`, 1D to 4D, and its boundary checks.
    #[test]
    fn osl_unit_test_cell_values() {
        let c2 = [0.860313, 0.241469];
        let c3 = [0.611068, 0.149855];
        let vc2 = [
            [0.611068, 0.185824, 0.0413061],
            [0.73866, 0.149855, 0.984101],
        ];
        let vc3 = [[0.111573, 0.3251, 0.339947], [0.576891, 0.646492, 0.270396]];
        for i in 0..2 {
            let x = 0.5 + i as f32;
            assert!(close(cell2([x, x]), c2[i]));
            assert!(close(cell3([x, x, x]), c3[i]));
            let (a, b) = (vcell2([x, x]), vcell3([x, x, x]));
            for c in 0..3 {
                assert!(close(a[c], vc2[i][c]), "vcellnoise({x}, {x}) = {a:?}");
                assert!(close(b[c], vc3[i][c]), "vcellnoise(p = {x}) = {b:?}");
            }
        }
        let (c1, c4) = ([0.582426, 0.292355], [0.111573, 0.646492]);
        let vc1 = [
            [0.860313, 0.842521, 0.974821],
            [0.295013, 0.241469, 0.0633514],
        ];
        let vc4 = [
            [0.14575, 0.0431595, 0.531032],
            [0.847126, 0.733529, 0.911791],
        ];
        for i in 0..2 {
            let x = 0.5 + i as f32;
            assert!(close(cell1(x), c1[i]) && close(cell4([x; 3], x), c4[i]));
            let (a, b) = (vcell1(x), vcell4([x; 3], x));
            for c in 0..3 {
                assert!(close(a[c], vc1[i][c]), "vcellnoise({x}) = {a:?}");
                assert!(close(b[c], vc4[i][c]), "vcellnoise(p, t = {x}) = {b:?}");
            }
        }
        // test_cell's boundary checks.
        let c = |x: f32| cell2([x, 0.5]);
        assert_eq!(c(1.0001), c(1.0));
        assert_ne!(c(0.9999), c(1.0));
        assert_eq!(c(-0.0001), c(-1.0));
        assert_eq!(c(-1.0001), c(-2.0));
    }

    /// `test_hash`'s values of `hashnoise` and `vhashnoise`, 1D to 4D.
    #[test]
    fn osl_unit_test_hash_values() {
        // test_hash: `hashnoise` and `vhashnoise` at x = 0.5, 1.5 in 1D to 4D.
        let h = [
            [0.983315, 0.716016, 0.311887, 0.480826],
            [0.914303, 0.360764, 0.273953, 0.84257],
        ];
        let vh = [
            [
                [0.253513, 0.658608, 0.718555],
                [0.172726, 0.779528, 0.780237],
                [0.59078, 0.79799, 0.0202766],
                [0.297735, 0.240833, 0.386421],
            ],
            [
                [0.673784, 0.825515, 0.827693],
                [0.431263, 0.443849, 0.592155],
                [0.593547, 0.156555, 0.978352],
                [0.642915, 0.367309, 0.879035],
            ],
        ];
        for i in 0..2 {
            let x = 0.5 + i as f32;
            let got = [hash1(x), hash2([x; 2]), hash3([x; 3]), hash4([x; 3], x)];
            let vgot = [vhash1(x), vhash2([x; 2]), vhash3([x; 3]), vhash4([x; 3], x)];
            for d in 0..4 {
                assert!(
                    close(got[d], h[i][d]),
                    "hashnoise {}D({x}) = {}",
                    d + 1,
                    got[d]
                );
                for c in 0..3 {
                    let (g, w) = (vgot[d][c], vh[i][d][c]);
                    assert!(close(g, w), "vhashnoise {}D({x}) = {:?}", d + 1, vgot[d]);
                }
            }
        }
        // The bits as they are, a signalling NaN's included (a conversion on the way would
        // quiet it, and the GPU, which bitcasts, would disagree).
        let snan = f32::from_bits(0x7fbf_02b2);
        assert_eq!(hash1(snan), bits_to_01::<f32>(inthash1(0x7fbf_02b2)));
        assert_eq!(
            hash4([snan; 3], 0.1),
            bits_to_01::<f32>(inthash4(
                0x7fbf_02b2,
                0x7fbf_02b2,
                0x7fbf_02b2,
                0.1f32.to_bits()
            ))
        );
        // Discontinuous everywhere, unlike cell noise.
        for (a, b) in [
            (0.9999, 1.0),
            (1.0001, 1.0),
            (-0.0001, 0.0),
            (-1.0001, -1.0),
        ] {
            assert_ne!(hash1(a), hash1(b));
        }
    }

    /// A small deterministic generator (xorshift) for sample points.
    fn points(n: usize, scale: f32) -> impl Iterator<Item = [f32; 3]> {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 2.0 * scale
        };
        (0..n).map(move |_| [next(), next(), next()])
    }

    #[test]
    fn perlin_is_zero_on_the_lattice() {
        for p in points(2000, 1000.0) {
            let q = p.map(f32::floor);
            assert_eq!(perlin2([q[0], q[1]]), 0.0);
            assert_eq!(perlin3(q), 0.0);
            assert_eq!(vperlin2([q[0], q[1]]), [0.0; 3]);
            assert_eq!(vperlin3(q), [0.0; 3]);
        }
    }

    #[test]
    fn perlin_1d_and_4d_are_osls() {
        let mut seen = std::collections::BTreeSet::new();
        let (mut s1, mut q1, mut m1) = (0.0f64, 0.0f64, 0.0f32);
        let (mut s4, mut q4, mut m4) = (0.0f64, 0.0f64, 0.0f32);
        let n = 50_000;
        for p in points(n, 100.0) {
            let q = p.map(f32::floor);
            // Zero on the lattice, every component.
            assert_eq!(perlin1(q[0]), 0.0);
            assert_eq!(vperlin1(q[0]), [0.0; 3]);
            assert_eq!(perlin4(q, q[1]), 0.0);
            assert_eq!(vperlin4(q, q[2]), [0.0; 3]);
            // Halfway between two integers (fade 1/2) 1D noise is 0.25 · (g₀ − g₁)/4 with
            // OSL's gradients g ∈ ±{1 … 8}: 16 times it an integer in [−16, 16] (exact).
            let h = perlin1(q[0] + 0.5) * 16.0;
            assert!(h.fract() == 0.0 && h.abs() <= 16.0, "{h}");
            seen.insert(h as i32);
            // Continuous across cell boundaries.
            let eps = 1.0 / 1024.0;
            let d1 = (perlin1(q[0] - eps) - perlin1(q[0])).abs();
            let d4 =
                (perlin4([q[0] - eps, p[1], p[2]], p[0]) - perlin4([q[0], p[1], p[2]], p[0])).abs();
            assert!(d1 <= 8.0 * eps && d4 <= 8.0 * eps, "{d1} {d4}");
            let (a, b) = (perlin1(p[0]), perlin4(p, p[0] * 0.7));
            (s1, q1, m1) = (s1 + a as f64, q1 + (a * a) as f64, m1.max(a.abs()));
            (s4, q4, m4) = (s4 + b as f64, q4 + (b * b) as f64, m4.max(b.abs()));
            let v = vperlin4(p, p[1]);
            m4 = v
                .iter()
                .chain(&vperlin1(p[2]))
                .fold(m4, |m, x| m.max(x.abs()));
        }
        // Every difference of two gradients appears (−16 … 16 but ±15 and 0 need g₀ = g₁
        // or neighbours: at least 25 distinct values).
        assert!(seen.len() >= 25, "{seen:?}");
        let n = n as f64;
        let (mean1, sd1) = (s1 / n, (q1 / n - (s1 / n).powi(2)).sqrt());
        let (mean4, sd4) = (s4 / n, (q4 / n - (s4 / n).powi(2)).sqrt());
        // Measured (these points): 1D mean −0.0027, sd 0.3054, max |n| 0.938; 4D mean
        // −0.0018, sd 0.2433, max |n| 0.99999570 (vector components included).
        assert!(
            mean1.abs() < 0.01 && (0.28..0.33).contains(&sd1),
            "{mean1} {sd1}"
        );
        assert!(
            mean4.abs() < 0.01 && (0.22..0.27).contains(&sd4),
            "{mean4} {sd4}"
        );
        assert!(m1 <= 1.0 && m4 <= 1.0, "{m1} {m4}");
        // The vector forms' components are the scalar noise of one hash byte each: the
        // scalar noise itself uses the whole hash (grad masks it), so component 0 equals
        // it wherever the low byte decides the gradient — always (grad1 reads bits 0-3,
        // grad4 bits 0-4).
        for p in points(1000, 30.0) {
            assert_eq!(vperlin1(p[0])[0], perlin1(p[0]));
            assert_eq!(vperlin4(p, p[1])[0], perlin4(p, p[1]));
        }
    }

    #[test]
    fn periodic_perlin_repeats_and_is_perlin_inside_one_period() {
        for p in points(3000, 40.0) {
            // Periods 1 to 7 from the point (a fractional period floors; below 1 is 1).
            let per = p.map(|c| (c.abs() % 7.0).floor().max(0.5) + 0.25);
            let whole = per.map(|c| c.floor().max(1.0));
            // One period on: the same value (coordinates on an 1/8 grid stay exact).
            let q = p.map(|c| (c * 8.0).round() / 8.0);
            let on: [f32; 3] = std::array::from_fn(|k| q[k] + whole[k]);
            assert_eq!(pperlin1(q[0], per[0]), pperlin1(on[0], per[0]));
            assert_eq!(
                pperlin2([q[0], q[1]], [per[0], per[1]]),
                pperlin2([on[0], on[1]], [per[0], per[1]])
            );
            assert_eq!(pperlin3(q, per), pperlin3(on, per));
            assert_eq!(
                pperlin4(q, q[0], per, per[1]),
                pperlin4(on, on[0] + whole[1] - whole[0], per, per[1])
            );
            assert_eq!(vpperlin3(q, per), vpperlin3(on, per));
            assert_eq!(
                vpperlin4(q, q[1], per, per[2]),
                vpperlin4(on, q[1] + whole[2], per, per[2])
            );
            // Inside [0, P − 1) no corner wraps: the plain noise.
            let inside = whole.map(|w| (w - 1.0).max(0.0));
            let r: [f32; 3] = std::array::from_fn(|k| (p[k].abs() / 40.0) * inside[k]);
            if inside.iter().all(|w| *w > 0.0) {
                assert_eq!(pperlin3(r, per), perlin3(r));
                assert_eq!(vpperlin1(r[0], per[0]), vperlin1(r[0]));
                assert_eq!(
                    vpperlin2([r[0], r[1]], [per[0], per[1]]),
                    vperlin2([r[0], r[1]])
                );
            }
        }
        // A period below 1 is 1: every corner hashes the same key, so the lattice's
        // gradients agree and the noise is that one gradient's ramp.
        assert_eq!(pperlin1(0.3f32, 0.0), pperlin1(0.3, 1.0));
        assert_eq!(pperlin1(5.25f32, -4.0), pperlin1(0.25, 1.0));
    }

    #[test]
    fn ranges_statistics_and_frequency() {
        let n = 100_000;
        let (mut s2, mut q2, mut m2) = (0.0f64, 0.0f64, 0.0f32);
        let (mut s3, mut q3, mut m3) = (0.0f64, 0.0f64, 0.0f32);
        let mut sc = 0.0f64;
        for p in points(n, 100.0) {
            let a = perlin2([p[0], p[1]]);
            let b = perlin3(p);
            let v = vperlin3(p);
            let c = cell3(p);
            assert!((0.0..=1.0).contains(&c));
            assert!(vcell3(p).iter().all(|c| (0.0..=1.0).contains(c)));
            (s2, q2, m2) = (s2 + a as f64, q2 + (a * a) as f64, m2.max(a.abs()));
            (s3, q3, m3) = (s3 + b as f64, q3 + (b * b) as f64, m3.max(b.abs()));
            m3 = v.iter().fold(m3, |m, x| m.max(x.abs()));
            sc += c as f64;
        }
        let n = n as f64;
        let (mean2, sd2) = (s2 / n, (q2 / n - (s2 / n).powi(2)).sqrt());
        let (mean3, sd3) = (s3 / n, (q3 / n - (s3 / n).powi(2)).sqrt());
        // Measured (these 10⁵ points): 2D mean 0.0021, sd 0.3188, max |n| 0.9943; 3D mean
        // 0.0008, sd 0.2650, max |n| 0.9627 (vector components included); cell mean 0.5015.
        assert!(
            mean2.abs() < 0.005 && (0.29..0.35).contains(&sd2),
            "{mean2} {sd2}"
        );
        assert!(
            mean3.abs() < 0.005 && (0.24..0.29).contains(&sd3),
            "{mean3} {sd3}"
        );
        assert!(m2 <= 1.0 && m3 <= 1.0, "{m2} {m3}");
        assert!((sc / n - 0.5).abs() < 0.005, "{}", sc / n);
        // Frequency: the lattice has unit cells; samples two cells apart along a line are
        // uncorrelated (measured -0.006), samples 1/16 apart strongly correlated (0.989).
        let corr = |d: f32| {
            let (mut sxy, mut sxx) = (0.0f64, 0.0f64);
            for p in points(20_000, 100.0) {
                let a = perlin3(p) as f64;
                let b = perlin3([p[0] + d, p[1], p[2]]) as f64;
                (sxy, sxx) = (sxy + a * b, sxx + a * a);
            }
            sxy / sxx
        };
        let (near, far) = (corr(1.0 / 16.0), corr(2.0));
        assert!(near > 0.9 && far.abs() < 0.1, "{near} {far}");
    }

    #[test]
    fn continuous_across_cell_boundaries() {
        // Lipschitz: the gradient of 3D Perlin noise is bounded (by 0.982·(about 3·1.875)).
        let eps = 1.0 / 1024.0;
        for p in points(5000, 50.0) {
            let q = [p[0].floor(), p[1], p[2]];
            let (l, r) = (perlin3([q[0] - eps, q[1], q[2]]), perlin3(q));
            assert!((l - r).abs() <= 8.0 * eps, "{q:?}: {l} {r}");
            let (l, r) = (perlin2([q[0] - eps, q[1]]), perlin2([q[0], q[1]]));
            assert!((l - r).abs() <= 8.0 * eps, "{q:?}: {l} {r}");
        }
    }

    #[test]
    fn fractal_sums_octaves_as_materialx_does() {
        for p in points(200, 10.0) {
            assert_eq!(fractal3(p, 0, 2.0, 0.5), 0.0);
            assert_eq!(fractal3(p, 1, 2.0, 0.5), perlin3(p));
            let want = perlin3(p) + 0.5 * perlin3(p.map(|c| c * 2.0));
            assert_eq!(fractal3(p, 2, 2.0, 0.5), want);
            let want = perlin2([p[0], p[1]]) + 0.25 * perlin2([p[0] * 3.0, p[1] * 3.0]);
            assert_eq!(fractal2([p[0], p[1]], 2, 3.0, 0.25), want);
            let v = vperlin3(p);
            let w = vperlin3(p.map(|c| c * 2.0));
            let want: [f32; 3] = std::array::from_fn(|c| v[c] + 0.5 * w[c]);
            assert_eq!(vfractal3(p, 2, 2.0, 0.5), want);
            assert_eq!(fractal3(p, -5, 2.0, 0.5), 0.0);
            assert_eq!(
                fractal3(p, i32::MAX, 1.0, 1.0),
                fractal3(p, MAX_OCTAVES, 1.0, 1.0)
            );
        }
    }

    #[test]
    fn worley_without_jitter_is_the_distance_to_the_nearest_cell_centre() {
        for p in points(3000, 20.0) {
            let d2 = |q: [f32; 2]| {
                let mut best = f32::MAX;
                for i in -2..=2 {
                    for j in -2..=2 {
                        let c = [q[0].floor() + i as f32 + 0.5, q[1].floor() + j as f32 + 0.5];
                        best = best.min(((c[0] - q[0]).powi(2) + (c[1] - q[1]).powi(2)).sqrt());
                    }
                }
                best
            };
            let q = [p[0], p[1]];
            let w = worley2(q, 0.0, 0, 0);
            assert!((w - d2(q)).abs() < 1e-4, "{q:?}: {w} vs {}", d2(q));
            // Style 1: the cell noise of the nearest feature point's cell.
            let c = [(q[0] - 0.5).round() + 0.5, (q[1] - 0.5).round() + 0.5];
            if (w - 0.5f32.sqrt()).abs() > 1e-3 && ((q[0].fract().abs() - 0.5).abs() > 1e-3) {
                assert_eq!(worley2(q, 0.0, 1, 0), cell2(c), "{q:?}");
            }
        }
    }

    #[test]
    fn worley_distances_are_sorted_and_consistent() {
        for p in points(3000, 20.0) {
            for jitter in [1.0, 0.5, 2.0] {
                let f = worley3_v3(p, jitter, 0, 0);
                assert!(f[0] <= f[1] && f[1] <= f[2], "{f:?}");
                assert_eq!(worley3_v2(p, jitter, 0, 0), [f[0], f[1]]);
                assert_eq!(worley3(p, jitter, 0, 0), f[0]);
                assert!(f[0] <= 3f32.sqrt() * (1.0 + jitter));
                let sq = worley3(p, jitter, 0, 1);
                assert_eq!(sq.sqrt(), f[0]);
                let q = [p[0], p[1]];
                let g = worley2_v3(q, jitter, 0, 0);
                assert!(g[0] <= g[1] && g[1] <= g[2], "{g:?}");
                assert_eq!(worley2(q, jitter, 0, 0), g[0]);
                // Manhattan ≥ Euclidean ≥ Chebyshev for the nearest point of each.
                let (m, c) = (worley2(q, jitter, 0, 2), worley2(q, jitter, 0, 3));
                assert!(m >= g[0] - 1e-6 && c <= g[0] + 1e-6, "{m} {} {c}", g[0]);
                let s = worley3_v3(p, jitter, 1, 0);
                assert!(s.iter().all(|x| (0.0..=1.0).contains(x)));
                assert_eq!(worley3(p, jitter, 1, 0), {
                    // style 1 of the float version: float cell noise at the same point as
                    // the vector version's.
                    let near = worley3_search(p, jitter, 0, 1);
                    let m = near.minpos;
                    cell3([m[0] + p[0], m[1] + p[1], m[2] + p[2]])
                });
            }
        }
    }

    #[test]
    fn hard_coordinates_neither_panic_nor_leave_the_range() {
        let hard = [
            0.0,
            -0.0,
            1e-45,
            -1e-45,
            1e-38,
            0.5,
            -0.5,
            8_388_608.5,
            3e9,
            -3e9,
            1e30,
            -1e30,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        for &x in &hard {
            for &y in &hard {
                let p = [x, y, 0.25];
                assert!(perlin2([x, y]).abs() <= 1.0);
                assert!(perlin3(p).abs() <= 1.0);
                assert!(vperlin3(p).iter().all(|v| v.abs() <= 1.0));
                assert!((0.0..=1.0).contains(&cell3(p)));
                assert!(fractal3(p, 4, 2.0, 0.5).is_finite() || !x.is_finite() || x.abs() > 1e30);
                let w = worley3_v3(p, 1.0, 0, 0);
                assert!(w.iter().all(|v| v.is_finite()), "{p:?}: {w:?}");
                let w = worley2_v3([x, y], 1.0, 1, 0);
                assert!(w.iter().all(|v| (0.0..=1.0).contains(v)), "{p:?}: {w:?}");
            }
        }
    }

    #[test]
    fn f64_agrees_with_f32() {
        for p in points(2000, 30.0) {
            let a = perlin3(p);
            let b = perlin3(p.map(|c| c as f64));
            assert!((a as f64 - b).abs() < 1e-5, "{p:?}: {a} {b}");
            assert_eq!(cell3(p) as f64, cell3(p.map(|c| c as f64)) as f32 as f64);
        }
    }
}
