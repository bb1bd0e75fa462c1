//! OSL's simplex noise (`noise("simplex", …)`, `noise("usimplex", …)`), 1D to 4D, float and
//! vector, ported operation for operation from OSL `src/liboslnoise/simplexnoise.cpp`
//! (Stefan Gustavson's simplex noise as Larry Gritz changed it for OSL: Jenkins' `bjfinal`
//! scrambles the corner lattice coordinates and a seed instead of a permutation table, so the
//! pattern does not repeat; vector noise is the float noise at seeds 0, 1, 2; the derivative
//! outputs are not ported: OSL computes them only for derivatives, which our IR takes by
//! differencing). The signed result is about [-1, 1]; OSL's `usimplex` is `0.5 · (s + 1)`,
//! lowered as IR arithmetic by the front end.
//!
//! Every float operation is the source's, in the source's order, so the f32 results are the
//! source's bits wherever its integer conversions are defined. Where the source is undefined
//! (C++ `int(floor(x))` outside the i32 range, NaN), the cell saturates (Rust `as`) and the
//! lattice sums wrap; a non-finite or huge coordinate then puts every corner outside its
//! radius and the noise is 0 — no panic, a finite result for every input. 1D takes the
//! offset as `x − floor(x)` (0 where not finite), which is the source's `x − float(i0)` for
//! every x whose cell fits an i32, and keeps huge inputs finite where the source's 1D form,
//! which skips the radius test, overflows.
//!
//! This module owns simplex noise's meaning; the back ends call it (the JIT's helpers) or
//! port it line by line (the GPU's WGSL library, `sn_osl_simplex*`). It must not touch the
//! Perlin, cell and hash generators ([`super::osl_noise`]).

use super::Real;
use super::osl_noise::{bjfinal, floorfrac};

/// OSL's `scramble(v0, v1, v2)`: `bjfinal(v0, v1, v2 ^ 0xdeadbeef)`.
fn scramble(v0: u32, v1: u32, v2: u32) -> u32 {
    bjfinal(v0, v1, v2 ^ 0xdead_beef)
}

/// OSL's 2D gradients (`grad2lut`).
const GRAD2: [[i8; 2]; 8] = [
    [-1, -1],
    [1, 0],
    [-1, 0],
    [1, 1],
    [-1, 1],
    [0, -1],
    [0, 1],
    [1, -1],
];

/// OSL's 3D gradients (`grad3lut`): the midpoints of a cube's 12 edges, four repeated.
const GRAD3: [[i8; 3]; 16] = [
    [1, 0, 1],
    [0, 1, 1],
    [-1, 0, 1],
    [0, -1, 1],
    [1, 0, -1],
    [0, 1, -1],
    [-1, 0, -1],
    [0, -1, -1],
    [1, -1, 0],
    [1, 1, 0],
    [-1, 1, 0],
    [-1, -1, 0],
    [1, 0, 1],
    [-1, 0, 1],
    [0, 1, -1],
    [0, -1, -1],
];

/// OSL's 4D gradients (`grad4lut`): the tesseract's 32 edges, in OSL's order.
const GRAD4: [[i8; 4]; 32] = {
    let mut g = [[0i8; 4]; 32];
    let mut n = 0;
    while n < 32 {
        // Block n / 8 has its zero on axis n / 8; the other three axes are ±1, the first
        // of them the slowest sign.
        let zero = n / 8;
        let signs = n % 8;
        let mut k = 0;
        let mut bit = 2i32;
        while k < 4 {
            if k != zero {
                g[n][k] = if (signs >> bit) & 1 == 1 { -1 } else { 1 };
                bit -= 1;
            }
            k += 1;
        }
        n += 1;
    }
    g
};

/// OSL's table of the 4D simplex traversal (`simplex[64][4]`): for the six pairwise
/// comparisons of the offsets packed into an index, the rank of each coordinate (3 = the
/// largest); the 40 impossible combinations are zeros.
const SIMPLEX4: [[u8; 4]; 64] = [
    [0, 1, 2, 3],
    [0, 1, 3, 2],
    [0, 0, 0, 0],
    [0, 2, 3, 1],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [1, 2, 3, 0],
    [0, 2, 1, 3],
    [0, 0, 0, 0],
    [0, 3, 1, 2],
    [0, 3, 2, 1],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [1, 3, 2, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [1, 2, 0, 3],
    [0, 0, 0, 0],
    [1, 3, 0, 2],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [2, 3, 0, 1],
    [2, 3, 1, 0],
    [1, 0, 2, 3],
    [1, 0, 3, 2],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [2, 0, 3, 1],
    [0, 0, 0, 0],
    [2, 1, 3, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [2, 0, 1, 3],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [3, 0, 1, 2],
    [3, 0, 2, 1],
    [0, 0, 0, 0],
    [3, 1, 2, 0],
    [2, 1, 0, 3],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [0, 0, 0, 0],
    [3, 1, 0, 2],
    [0, 0, 0, 0],
    [3, 2, 0, 1],
    [3, 2, 1, 0],
];

/// The vector of a gradient table row.
fn g<F: Real, const D: usize>(row: [i8; D]) -> [F; D] {
    row.map(|c| F::from_i32(i32::from(c)))
}

/// OSL `grad1`: one of ±1 … ±8.
fn grad1<F: Real>(i: i32, seed: u32) -> F {
    let h = scramble(i as u32, seed, 0);
    let g = F::ONE + F::from_i32((h & 7) as i32);
    if h & 8 != 0 { -g } else { g }
}

/// The lattice cell of a skewed coordinate: OSL's `ifloor` (saturating, NaN → 0).
fn ifloor<F: Real>(x: F) -> i32 {
    x.floor().to_i32()
}

/// The skewed grid's cell of `p` and `p`'s offset from the cell's origin in unskewed
/// space: `s = (Σp)·F`, `c = ifloor(p + s)`, `x0 = p − (c − (Σc)·G)`, in the source's order.
fn skew<F: Real, const D: usize>(p: [F; D], f: f64, g: F) -> ([i32; D], [F; D]) {
    let mut sum = p[0];
    for x in &p[1..] {
        sum = sum + *x;
    }
    let s = sum * F::from_f64(f);
    let c: [i32; D] = std::array::from_fn(|d| ifloor(p[d] + s));
    let csum = c[1..].iter().fold(c[0], |a, x| a.wrapping_add(*x));
    let t = F::from_i32(csum) * g;
    (c, std::array::from_fn(|d| p[d] - (F::from_i32(c[d]) - t)))
}

/// A corner's offset: `x0 − o + kG` (`kg` the source's `k·G` for the corner's `k`).
fn offset<F: Real, const D: usize>(x0: [F; D], o: [i32; D], kg: F) -> [F; D] {
    std::array::from_fn(|d| x0[d] - F::from_i32(o[d]) + kg)
}

/// One corner's contribution in 2D–4D for each of `S` seeds: `t⁴ (g · x)` with
/// `t = 0.5 − |x|²` (subtracted coordinate by coordinate), 0 outside the corner's radius
/// (`t < 0`, or NaN). `t` is computed once; the gradient (`grad(seed)`) and the dot
/// product per seed, each in the source's order, so every seed's value has the bits of a
/// noise evaluated for that seed alone.
fn corner<F: Real, const D: usize, const S: usize>(
    x: [F; D],
    seeds: [u32; S],
    grad: impl Fn(u32) -> [F; D],
) -> [F; S] {
    let mut t = F::from_f64(0.5);
    for c in x {
        t = t - c * c;
    }
    if t >= F::ZERO {
        let t2 = t * t;
        let t4 = t2 * t2;
        seeds.map(|seed| {
            let grad = grad(seed);
            let mut dot = grad[0] * x[0];
            for d in 1..D {
                dot = dot + grad[d] * x[d];
            }
            t4 * dot
        })
    } else {
        [F::ZERO; S]
    }
}

/// OSL `simplexnoise1(x, seed)`: two corners, scaled by 0.36.
pub fn simplex1<F: Real>(x: F, seed: u32) -> F {
    let (i0, x0) = floorfrac(x);
    let i1 = i0.wrapping_add(1);
    let x1 = x0 - F::ONE;
    let one = |x: F, i: i32| {
        let t = F::ONE - x * x;
        let t2 = t * t;
        let t4 = t2 * t2;
        t4 * grad1::<F>(i, seed) * x
    };
    let (n0, n1) = (one(x0, i0), one(x1, i1));
    F::from_f64(0.36) * (n0 + n1)
}

/// OSL `simplexnoise2(x, y, seed)`: three corners of the skewed triangle grid, scaled by
/// 64.
pub fn simplex2<F: Real>(p: [F; 2], seed: u32) -> F {
    simplex2_seeds(p, [seed])[0]
}

/// [`simplex2`] for each of `S` seeds, the lattice walked once.
fn simplex2_seeds<F: Real, const S: usize>(p: [F; 2], seeds: [u32; S]) -> [F; S] {
    let g2 = F::from_f64(0.211324865);
    let (c, x0) = skew(p, 0.366025403, g2);
    let o1 = if x0[0] > x0[1] { [1, 0] } else { [0, 1] };
    let grad = |o: [i32; 2]| {
        move |seed| {
            let [i, j] = std::array::from_fn(|d| c[d].wrapping_add(o[d]) as u32);
            g(GRAD2[(scramble(i, j, seed) & 7) as usize])
        }
    };
    let n0 = corner(x0, seeds, grad([0; 2]));
    let n1 = corner(offset(x0, o1, g2), seeds, grad(o1));
    let n2 = corner(
        offset(x0, [1; 2], F::from_f64(2.0) * g2),
        seeds,
        grad([1; 2]),
    );
    std::array::from_fn(|s| F::from_f64(64.0) * (n0[s] + n1[s] + n2[s]))
}

/// The second and third corners' lattice offsets of the 3D simplex the offset `x0` lies
/// in, by OSL's comparisons.
fn order3<F: Real>(x0: F, y0: F, z0: F) -> ([i32; 3], [i32; 3]) {
    if x0 >= y0 {
        if y0 >= z0 {
            ([1, 0, 0], [1, 1, 0])
        } else if x0 >= z0 {
            ([1, 0, 0], [1, 0, 1])
        } else {
            ([0, 0, 1], [1, 0, 1])
        }
    } else if y0 < z0 {
        ([0, 0, 1], [0, 1, 1])
    } else if x0 < z0 {
        ([0, 1, 0], [0, 1, 1])
    } else {
        ([0, 1, 0], [1, 1, 0])
    }
}

/// OSL `simplexnoise3(x, y, z, seed)`: four corners of the skewed tetrahedral grid, scaled
/// by 68.
pub fn simplex3<F: Real>(p: [F; 3], seed: u32) -> F {
    simplex3_seeds(p, [seed])[0]
}

/// [`simplex3`] for each of `S` seeds, the lattice walked once.
fn simplex3_seeds<F: Real, const S: usize>(p: [F; 3], seeds: [u32; S]) -> [F; S] {
    let g3 = F::from_f64(0.166666667);
    let (c, x0) = skew(p, 0.333333333, g3);
    let (o1, o2) = order3(x0[0], x0[1], x0[2]);
    let kg = |k: f64| F::from_f64(k) * g3;
    let grad = |o: [i32; 3]| {
        move |seed| {
            let [i, j, k] = std::array::from_fn(|d| c[d].wrapping_add(o[d]) as u32);
            g(GRAD3[(scramble(i, j, scramble(k, seed, 0)) & 15) as usize])
        }
    };
    let n0 = corner(x0, seeds, grad([0; 3]));
    let n1 = corner(offset(x0, o1, g3), seeds, grad(o1));
    let n2 = corner(offset(x0, o2, kg(2.0)), seeds, grad(o2));
    let n3 = corner(offset(x0, [1; 3], kg(3.0)), seeds, grad([1; 3]));
    std::array::from_fn(|s| F::from_f64(68.0) * (n0[s] + n1[s] + n2[s] + n3[s]))
}

/// The index into [`SIMPLEX4`] of OSL's six comparisons of the 4D offsets.
fn order4<F: Real>(x: [F; 4]) -> usize {
    let bit = |c: bool, v: usize| if c { v } else { 0 };
    bit(x[0] > x[1], 32)
        | bit(x[0] > x[2], 16)
        | bit(x[1] > x[2], 8)
        | bit(x[0] > x[3], 4)
        | bit(x[1] > x[3], 2)
        | bit(x[2] > x[3], 1)
}

/// OSL `simplexnoise4(x, y, z, w, seed)`: five corners of the skewed 4D grid, scaled by 54.
pub fn simplex4<F: Real>(p: [F; 3], w: F, seed: u32) -> F {
    simplex4_seeds(p, w, [seed])[0]
}

/// [`simplex4`] for each of `S` seeds, the lattice walked once.
fn simplex4_seeds<F: Real, const S: usize>(p: [F; 3], w: F, seeds: [u32; S]) -> [F; S] {
    let g4 = F::from_f64(0.138196601);
    let (c, x0) = skew([p[0], p[1], p[2], w], 0.309016994, g4);
    let rank = SIMPLEX4[order4(x0)];
    // Corner k (1..=3) steps along the coordinates whose rank is at least 4 − k.
    let step = |k: u8| rank.map(|r| i32::from(r >= 4 - k));
    let (o1, o2, o3) = (step(1), step(2), step(3));
    let kg = |k: f64| F::from_f64(k) * g4;
    let grad = |o: [i32; 4]| {
        move |seed| {
            let [i, j, k, l] = std::array::from_fn(|d| c[d].wrapping_add(o[d]) as u32);
            g(GRAD4[(scramble(i, j, scramble(k, l, seed)) & 31) as usize])
        }
    };
    let n0 = corner(x0, seeds, grad([0; 4]));
    let n1 = corner(offset(x0, o1, g4), seeds, grad(o1));
    let n2 = corner(offset(x0, o2, kg(2.0)), seeds, grad(o2));
    let n3 = corner(offset(x0, o3, kg(3.0)), seeds, grad(o3));
    let n4 = corner(offset(x0, [1; 4], kg(4.0)), seeds, grad([1; 4]));
    std::array::from_fn(|s| F::from_f64(54.0) * (n0[s] + n1[s] + n2[s] + n3[s] + n4[s]))
}

/// OSL `vector noise("simplex", x)`: the 1D noise at seeds 0, 1, 2.
pub fn vsimplex1<F: Real>(x: F) -> [F; 3] {
    [0, 1, 2].map(|s| simplex1(x, s))
}

/// OSL `vector noise("simplex", x, y)`: seeds 0, 1, 2 (the lattice walked once, where
/// OSL walks it per seed: the same values).
pub fn vsimplex2<F: Real>(p: [F; 2]) -> [F; 3] {
    simplex2_seeds(p, [0, 1, 2])
}

/// OSL `vector noise("simplex", p)`.
pub fn vsimplex3<F: Real>(p: [F; 3]) -> [F; 3] {
    simplex3_seeds(p, [0, 1, 2])
}

/// OSL `vector noise("simplex", p, t)`.
pub fn vsimplex4<F: Real>(p: [F; 3], t: F) -> [F; 3] {
    simplex4_seeds(p, t, [0, 1, 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// OSL's `grad4lut` as printed in `simplexnoise.cpp`, against our generated table.
    #[test]
    fn grad4_table_is_osls() {
        let first_eight = [
            [0, 1, 1, 1],
            [0, 1, 1, -1],
            [0, 1, -1, 1],
            [0, 1, -1, -1],
            [0, -1, 1, 1],
            [0, -1, 1, -1],
            [0, -1, -1, 1],
            [0, -1, -1, -1],
        ];
        assert_eq!(GRAD4[..8], first_eight);
        assert_eq!(GRAD4[8], [1, 0, 1, 1]);
        assert_eq!(GRAD4[15], [-1, 0, -1, -1]);
        assert_eq!(GRAD4[17], [1, 1, 0, -1]);
        assert_eq!(GRAD4[22], [-1, -1, 0, 1]);
        assert_eq!(GRAD4[25], [1, 1, -1, 0]);
        assert_eq!(GRAD4[31], [-1, -1, -1, 0]);
        // Every row: one zero, three ±1, and no two rows alike.
        for (n, r) in GRAD4.iter().enumerate() {
            assert_eq!(r.iter().filter(|&&c| c == 0).count(), 1, "row {n}");
            assert!(GRAD4[..n].iter().all(|o| o != r), "row {n} repeats");
        }
    }

    /// The traversal table is each coordinate's rank among the four (ties to the later
    /// coordinate), for every ordering with ties: what the GPU's port computes instead.
    #[test]
    fn simplex4_table_is_the_ranks() {
        for n in 0..256u32 {
            let x: [f32; 4] = std::array::from_fn(|d| ((n >> (2 * d)) & 3) as f32);
            let rank: [u8; 4] = std::array::from_fn(|d| {
                (0..4)
                    .filter(|&e| e != d && if d < e { x[d] > x[e] } else { x[d] >= x[e] })
                    .count() as u8
            });
            assert_eq!(SIMPLEX4[order4(x)], rank, "offsets {x:?}");
        }
    }

    /// Zero at every lattice point: 1D at the integers exactly; 2D–4D at the unskewed
    /// corners `c − (Σc)·G` of the skewed grid, up to the offsets' rounding (each corner's
    /// gradient is dotted with an offset of about 0, the other corners are outside their
    /// radius).
    #[test]
    fn zero_on_the_lattice() {
        let unskew = |c: &[i32], g: f64| -> Vec<f64> {
            let t = f64::from(c.iter().sum::<i32>()) * g;
            c.iter().map(|&i| f64::from(i) - t).collect()
        };
        let (g2, g3, g4) = (
            (3.0 - 3f64.sqrt()) / 6.0,
            1.0 / 6.0,
            (5.0 - 5f64.sqrt()) / 20.0,
        );
        for i in -20..20 {
            assert_eq!(simplex1(i as f32, 0), 0.0, "1D at {i}");
            let c = [i, 3 - i, 2 * i, 7];
            let p = unskew(&c[..2], g2);
            let v = simplex2([p[0] as f32, p[1] as f32], 1);
            assert!(v.abs() < 1e-5, "2D at {c:?}: {v}");
            let p = unskew(&c[..3], g3);
            let v = simplex3([p[0] as f32, p[1] as f32, p[2] as f32], 2);
            assert!(v.abs() < 1e-5, "3D at {c:?}: {v}");
            let p = unskew(&c, g4);
            let v = simplex4([p[0] as f32, p[1] as f32, p[2] as f32], p[3] as f32, 0);
            assert!(v.abs() < 1e-5, "4D at {c:?}: {v}");
        }
    }

    /// Range, spread and continuity over many points; distinct seeds decorrelate.
    #[test]
    fn range_spread_and_continuity() {
        let mut rng = 0x2545_f491_u32;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 17;
            rng ^= rng << 5;
            (rng as f32 / u32::MAX as f32) * 200.0 - 100.0
        };
        type Gen = fn([f32; 4], u32) -> f32;
        let gens: [(&str, Gen); 4] = [
            ("1D", |p, s| simplex1(p[0], s)),
            ("2D", |p, s| simplex2([p[0], p[1]], s)),
            ("3D", |p, s| simplex3([p[0], p[1], p[2]], s)),
            ("4D", |p, s| simplex4([p[0], p[1], p[2]], p[3], s)),
        ];
        for (name, f) in gens {
            let (mut max, mut sum2, mut same) = (0f32, 0f64, 0);
            let n = 20_000;
            for _ in 0..n {
                let p = [next(), next(), next(), next()];
                let v = f(p, 0);
                max = max.max(v.abs());
                sum2 += f64::from(v * v);
                // A step of 1e-3 moves the value by less than the gradient bound allows.
                let q = p.map(|c| c + 1e-3);
                assert!((f(q, 0) - v).abs() < 0.08, "{name} jumps at {p:?}");
                same += usize::from(f(p, 1) == v);
            }
            let sd = (sum2 / f64::from(n)).sqrt();
            assert!(max <= 1.0, "{name}: max {max}");
            assert!(max > 0.6, "{name}: max {max} (too flat)");
            assert!(sd > 0.1 && sd < 0.5, "{name}: sd {sd}");
            assert!(
                same < n as usize / 20,
                "{name}: seeds 0 and 1 agree {same} times"
            );
        }
    }

    /// Non-finite and huge coordinates give a finite value (0: every corner is outside its
    /// radius), never a panic.
    #[test]
    fn hostile_coordinates() {
        for x in [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            3e9,
            -3e9,
            f32::MAX,
        ] {
            assert_eq!(simplex1(x, 0), 0.0, "1D at {x}");
            assert_eq!(simplex2([x, 0.5], 0), 0.0, "2D at {x}");
            assert_eq!(simplex3([0.5, x, 0.25], 0), 0.0, "3D at {x}");
            assert_eq!(simplex4([0.5, 0.25, x], 0.125, 0), 0.0, "4D at {x}");
            assert!(vsimplex4([x, x, x], x).iter().all(|v| v.is_finite()));
        }
    }

    /// The f64 form follows the f32 one to within f32 rounding.
    #[test]
    fn f64_follows_f32() {
        for k in 0..200 {
            let p = [
                k as f32 * 0.37 - 30.0,
                k as f32 * 0.11 + 2.5,
                7.25 - k as f32 * 0.05,
            ];
            let q = p.map(f64::from);
            let d = (simplex3(p, 0) as f64 - simplex3(q, 0)).abs();
            assert!(d < 1e-4, "3D at {p:?}: {d}");
            let d = (simplex4(p, p[0], 2) as f64 - simplex4(q, q[0], 2)).abs();
            assert!(d < 1e-4, "4D at {p:?}: {d}");
        }
    }

    /// Vector noise walks the lattice once for its three seeds: the same bits as the float
    /// noise at seeds 0, 1 and 2, over random, lattice-aligned and raw-bit coordinates, in
    /// f32 and f64.
    #[test]
    fn vector_noise_is_the_float_noise_per_seed() {
        let mut state = 0x9e37_79b9_u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        let bits32 = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let bits64 = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for k in 0..20_000 {
            let x: [f32; 4] = std::array::from_fn(|_| match k % 3 {
                0 => (next() as f32 / u32::MAX as f32 - 0.5) * 40.0,
                1 => (next() % 17) as f32 - 8.0,
                _ => f32::from_bits(next()),
            });
            let p = [x[0], x[1], x[2]];
            let per_seed = |f: &dyn Fn(u32) -> f32| [0, 1, 2].map(f);
            assert_eq!(
                bits32(&vsimplex2([x[0], x[1]])),
                bits32(&per_seed(&|s| simplex2([x[0], x[1]], s)))
            );
            assert_eq!(
                bits32(&vsimplex3(p)),
                bits32(&per_seed(&|s| simplex3(p, s)))
            );
            assert_eq!(
                bits32(&vsimplex4(p, x[3])),
                bits32(&per_seed(&|s| simplex4(p, x[3], s)))
            );
            let q = p.map(f64::from);
            let w = f64::from(x[3]);
            let per_seed64 = |f: &dyn Fn(u32) -> f64| [0, 1, 2].map(f);
            assert_eq!(
                bits64(&vsimplex3(q)),
                bits64(&per_seed64(&|s| simplex3(q, s)))
            );
            assert_eq!(
                bits64(&vsimplex4(q, w)),
                bits64(&per_seed64(&|s| simplex4(q, w, s)))
            );
        }
    }
}
