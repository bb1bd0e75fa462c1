//! OSL's spectral colour builtins, `blackbody(T)` and `wavelength_color(λ)`, lowered to IR
//! arithmetic over the CIE 1931 colour-matching functions (380–780 nm every 5 nm, the
//! table OSL uses, from John Walker's public-domain `specrend.c`) and OSL's default colour
//! system, Rec. 709 primaries with a D65 white.
//!
//! - `blackbody(T)`: Planck's law at the 81 wavelengths, `M(λ) = c₁ / (λ⁵ (e^{c₂/λT} − 1))`
//!   times the 5 nm step, summed against the matching functions into XYZ, converted to RGB
//!   and clamped at 0 — OSL's `compute_blackbody_rgb`, with OSL's constants; below 800 K
//!   (Draper's point) OSL's "very very dim red" (10⁻⁶, 0, 0). OSL itself reads a table
//!   (values to the fifth power, interpolated) between 800 K and 12 000 K that it says is
//!   within 0.1 % of this computation; we compute everywhere, so we agree with OSL to that
//!   0.1 % there and up to float rounding elsewhere.
//! - `wavelength_color(λ)`: the matching functions interpolated at `λ` (OSL's index, the
//!   truncation of `(λ − 380)/5`, so 375–380 nm extrapolate from the first interval as
//!   OSL's do; 0 outside), to RGB, scaled by 1/2.52 and clamped at 0.
//!
//! Owns these two lowerings and their tables; it must not hold op semantics.

use super::Lower;
use shadenet_graph::Type;
use shadenet_graph::ir::{BinOp, Builder, UnOp, Value};

/// CIE 1931 x̄, ȳ, z̄ at 380, 385, …, 780 nm.
#[rustfmt::skip]
const CIE: [[f64; 3]; 81] = [
    [0.0014, 0.0000, 0.0065], [0.0022, 0.0001, 0.0105], [0.0042, 0.0001, 0.0201],
    [0.0076, 0.0002, 0.0362], [0.0143, 0.0004, 0.0679], [0.0232, 0.0006, 0.1102],
    [0.0435, 0.0012, 0.2074], [0.0776, 0.0022, 0.3713], [0.1344, 0.0040, 0.6456],
    [0.2148, 0.0073, 1.0391], [0.2839, 0.0116, 1.3856], [0.3285, 0.0168, 1.6230],
    [0.3483, 0.0230, 1.7471], [0.3481, 0.0298, 1.7826], [0.3362, 0.0380, 1.7721],
    [0.3187, 0.0480, 1.7441], [0.2908, 0.0600, 1.6692], [0.2511, 0.0739, 1.5281],
    [0.1954, 0.0910, 1.2876], [0.1421, 0.1126, 1.0419], [0.0956, 0.1390, 0.8130],
    [0.0580, 0.1693, 0.6162], [0.0320, 0.2080, 0.4652], [0.0147, 0.2586, 0.3533],
    [0.0049, 0.3230, 0.2720], [0.0024, 0.4073, 0.2123], [0.0093, 0.5030, 0.1582],
    [0.0291, 0.6082, 0.1117], [0.0633, 0.7100, 0.0782], [0.1096, 0.7932, 0.0573],
    [0.1655, 0.8620, 0.0422], [0.2257, 0.9149, 0.0298], [0.2904, 0.9540, 0.0203],
    [0.3597, 0.9803, 0.0134], [0.4334, 0.9950, 0.0087], [0.5121, 1.0000, 0.0057],
    [0.5945, 0.9950, 0.0039], [0.6784, 0.9786, 0.0027], [0.7621, 0.9520, 0.0021],
    [0.8425, 0.9154, 0.0018], [0.9163, 0.8700, 0.0017], [0.9786, 0.8163, 0.0014],
    [1.0263, 0.7570, 0.0011], [1.0567, 0.6949, 0.0010], [1.0622, 0.6310, 0.0008],
    [1.0456, 0.5668, 0.0006], [1.0026, 0.5030, 0.0003], [0.9384, 0.4412, 0.0002],
    [0.8544, 0.3810, 0.0002], [0.7514, 0.3210, 0.0001], [0.6424, 0.2650, 0.0000],
    [0.5419, 0.2170, 0.0000], [0.4479, 0.1750, 0.0000], [0.3608, 0.1382, 0.0000],
    [0.2835, 0.1070, 0.0000], [0.2187, 0.0816, 0.0000], [0.1649, 0.0610, 0.0000],
    [0.1212, 0.0446, 0.0000], [0.0874, 0.0320, 0.0000], [0.0636, 0.0232, 0.0000],
    [0.0468, 0.0170, 0.0000], [0.0329, 0.0119, 0.0000], [0.0227, 0.0082, 0.0000],
    [0.0158, 0.0057, 0.0000], [0.0114, 0.0041, 0.0000], [0.0081, 0.0029, 0.0000],
    [0.0058, 0.0021, 0.0000], [0.0041, 0.0015, 0.0000], [0.0029, 0.0010, 0.0000],
    [0.0020, 0.0007, 0.0000], [0.0014, 0.0005, 0.0000], [0.0010, 0.0004, 0.0000],
    [0.0007, 0.0002, 0.0000], [0.0005, 0.0002, 0.0000], [0.0003, 0.0001, 0.0000],
    [0.0002, 0.0001, 0.0000], [0.0002, 0.0001, 0.0000], [0.0001, 0.0000, 0.0000],
    [0.0001, 0.0000, 0.0000], [0.0001, 0.0000, 0.0000], [0.0000, 0.0000, 0.0000],
];

/// Planck's first radiation constant 2πhc² (W·m²), OSL's value.
const C1: f64 = 3.74183e-16;
/// Planck's second radiation constant hc/k (m·K), OSL's value.
const C2: f64 = 1.4388e-2;
/// Below this temperature (K) OSL's blackbody is the dim red [`DIM_RED`].
pub(crate) const DRAPER: f64 = 800.0;
/// OSL's blackbody below [`DRAPER`].
pub(crate) const DIM_RED: [f64; 3] = [1.0e-6, 0.0, 0.0];

/// The Rec. 709 (D65) XYZ → linear RGB matrix, rows giving R, G, B, derived from the
/// primaries' chromaticities as a colour system derives it.
pub(crate) fn xyz_to_rgb() -> [[f64; 3]; 3] {
    inverse(&rgb_to_xyz())
}

/// The linear Rec. 709 RGB → XYZ matrix (D65 white), rows giving X, Y, Z: the primaries'
/// XYZ at Y = 1 as columns, scaled so that RGB (1, 1, 1) is the white.
pub(crate) fn rgb_to_xyz() -> [[f64; 3]; 3] {
    let (prims, white) = ([(0.64, 0.33), (0.30, 0.60), (0.15, 0.06)], (0.3127, 0.3290));
    let xyz = |(x, y): (f64, f64)| [x / y, 1.0, (1.0 - x - y) / y];
    let p: Vec<[f64; 3]> = prims.iter().map(|&c| xyz(c)).collect();
    let m = [
        [p[0][0], p[1][0], p[2][0]],
        [p[0][1], p[1][1], p[2][1]],
        [p[0][2], p[1][2], p[2][2]],
    ];
    let s = mul(&inverse(&m), xyz(white));
    std::array::from_fn(|r| std::array::from_fn(|c| m[r][c] * s[c]))
}

fn mul(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| (0..3).map(|c| m[r][c] * v[c]).sum())
}

fn inverse(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let cof = |r: usize, c: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
        m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]
    };
    let det: f64 = (0..3).map(|c| m[0][c] * cof(0, c)).sum();
    std::array::from_fn(|r| std::array::from_fn(|c| cof(c, r) / det))
}

/// The Planck weight `c₁ λ⁻⁵ Δλ` and exponent numerator `c₂ / λ` at table entry `i`.
pub(crate) fn planck_terms(i: usize) -> (f64, f64) {
    let wlm = (380.0 + 5.0 * i as f64) * 1e-9;
    (C1 / wlm.powi(5) * 5e-9, C2 / wlm)
}

impl Lower<'_> {
    /// `blackbody(t)` for a float `t` in kelvin: a color.
    pub(crate) fn blackbody(b: &mut Builder, t: Value) -> Value {
        let one = b.float(1.0);
        let mut xyz = b.color([0.0; 3]);
        for (i, cmf) in CIE.iter().enumerate() {
            if cmf.iter().all(|c| *c == 0.0) {
                continue;
            }
            let (k, a) = planck_terms(i);
            let (k, a) = (b.float(k), b.float(a));
            let x = b.div(a, t);
            let e = b.unary(UnOp::Exp, x);
            let d = b.sub(e, one);
            let me = b.div(k, d);
            let me = b.splat(Type::Color, me);
            let w = b.color(*cmf);
            let term = b.mul(me, w);
            xyz = b.add(xyz, term);
        }
        let rgb = to_rgb(b, xyz, 1.0);
        let draper = b.float(DRAPER);
        let cold = b.binary(BinOp::Lt, t, draper);
        let dim = b.color(DIM_RED);
        b.select(cold, dim, rgb)
    }

    /// `wavelength_color(l)` for a float `l` in nanometres: a color.
    pub(crate) fn wavelength_color(b: &mut Builder, l: Value) -> Value {
        let (base, step) = (b.float(380.0), b.float(5.0));
        let d = b.sub(l, base);
        let ii = b.div(d, step);
        let i = b.convert(Type::Int, ii);
        let fi = b.convert(Type::Float, i);
        let r = b.sub(ii, fi);
        let one = b.float(1.0);
        let zero = b.float(0.0);
        let one_r = b.sub(one, r);
        let next = b.int(1);
        let i1 = b.add(i, next);
        // The lerp of entries i and i + 1 as a sum over the table: entry k weighs 1 − r
        // where k = i and r where k = i + 1.
        let mut xyz = b.color([0.0; 3]);
        for (k, cmf) in CIE.iter().enumerate() {
            if cmf.iter().all(|c| *c == 0.0) {
                continue;
            }
            let kk = b.int(k as i32);
            let here = b.binary(BinOp::Eq, i, kk);
            let after = b.binary(BinOp::Eq, i1, kk);
            let w0 = b.select(here, one_r, zero);
            let w1 = b.select(after, r, zero);
            let w = b.add(w0, w1);
            let w = b.splat(Type::Color, w);
            let c = b.color(*cmf);
            let term = b.mul(w, c);
            xyz = b.add(xyz, term);
        }
        // OSL: zero where the index is below 0 or at 80 and above.
        let lo = b.int(0);
        let hi = b.int(80);
        let below = b.binary(BinOp::Lt, i, lo);
        let above = b.binary(BinOp::Ge, i, hi);
        let out = b.binary(BinOp::Or, below, above);
        let rgb = to_rgb(b, xyz, 1.0 / 2.52);
        let black = b.color([0.0; 3]);
        b.select(out, black, rgb)
    }
}

/// `xyz` to Rec. 709 RGB, scaled by `k`, clamped at 0.
fn to_rgb(b: &mut Builder, xyz: Value, k: f64) -> Value {
    let m = xyz_to_rgb();
    let rows: Vec<Value> = m
        .iter()
        .map(|row| {
            let w = b.color(row.map(|x| x * k));
            b.dot(xyz, w)
        })
        .collect();
    let rgb = b.construct(Type::Color, &rows);
    let zero = b.color([0.0; 3]);
    b.max(rgb, zero)
}
