//! The directional albedo of the Conty–Kulla sheen lobe (`closure::sheen`), as a table
//! computed by our own numerical integration, and its bilinear lookup — the IR intrinsic
//! `sheen_albedo`. It replaced MaterialX's rational fit, which is off by up to 0.1 and under
//! which `layer` gave standard_surface's sheen 8.4 % more than the white furnace's light.
//!
//! The lobe (`D = (2 + 1/r) s^(1/r)/(2π)` over Neubelt and Pettineo's `4(l + c − lc)`, no
//! shadowing) reflects more than it receives at grazing views of smooth roughness (5.3× at
//! 89.9° and `r = 0.005`). The closure divides it by `N(cos θo) N(cos θi)`, `N(x) = max(1,
//! E(x))` with `E` the lobe's own albedo: reciprocal, and it never reflects more than it
//! receives, while a lobe with `E ≤ 1` on both sides is untouched. Each node holds `(E, G)`:
//! `E` the raw lobe's albedo and `G = ∫ f cos θi / N(cos θi)`, so that the normalized lobe's
//! albedo (which `layer` subtracts) is `G / N(cos θo)` — `G` is smooth where `N(cos θo)` has
//! a kink, and dividing the lobe and its albedo by the same interpolated `N(cos θo)` leaves
//! only `G`'s interpolation error between them. Both are integrated over the half vector
//! `h` (`t = h.z`, `φ`): `E = ∫ D l (wo·h)/(l + c − lc) dt dφ` with `wi` the mirror of `wo`
//! about `h` (the Jacobian `4 wo·h` cancels the 4), on a midpoint grid of [`GRID_T`] ×
//! [`GRID_PHI`] (`φ` over half the circle: the lobe is symmetric), `N(cos θi)` read from
//! `E`'s own interpolation, as at run time. f64 with our own transcendentals, rounded to
//! f32.
//!
//! Nodes: [`N_COS`] uniform in `√cos θo`, [`N_ROUGH`] uniform in
//! `(r^(1/32) − r₀^(1/32))/(1 − r₀^(1/32))` over [0, 1], `r₀ = 0.005` (the lobe clamps `r`
//! there; its exponent is `1/r`). The 32nd root spaces the nodes almost as `ln r` would
//! (dense where `1/r` changes fast; the 8th root doubled the interpolation error) but is five
//! square roots, correctly rounded on every back end, where a logarithm left the GPU's lookup
//! a few ulps from the CPU's. The GPU's kernels read the table (2 × 32 × 12
//! floats) from the `sn_tables` buffer. Built once per process at the first lookup.
//!
//! This module owns the integration and the lookup; `closure::sheen` owns the lobe.

use super::Real;
use super::ggx_albedo::{axis, bilinear};
use super::math;
use std::f64::consts::PI;
use std::sync::OnceLock;

/// Nodes along `√cos θo`.
pub const N_COS: usize = 32;
/// Nodes along `(r^(1/32) − r₀^(1/32))/(1 − r₀^(1/32))`.
pub const N_ROUGH: usize = 12;
/// Integration points along `t = h.z`.
const GRID_T: usize = 256;
/// Integration points along `φ` (over `[0, π]`).
const GRID_PHI: usize = 96;
/// The lobe's smallest roughness (`closure::sheen`).
pub const MIN_ROUGHNESS: f64 = 0.005;
/// `r₀^(1/32)` as the lookups use it (f32, written into the WGSL library too).
pub const ROOT_MIN: f32 = 0.847_408_5;
/// `1/(1 − r₀^(1/32))` as the lookups use it (f32, written into the WGSL library too).
pub const INV_SPAN: f32 = 6.553_444;
/// The smallest `cos θo` integrated (the first node stands for 0).
const MIN_COS: f64 = 1e-4;

/// `∫ f cos θi / n(cos θi)` of the lobe at `cos θo = c`, roughness `r` (`n ≡ 1`: the raw
/// lobe's albedo), on a `nt` × `nphi` grid.
pub fn integrate(c: f64, r: f64, nt: usize, nphi: usize, n: &dyn Fn(f64) -> f64) -> f64 {
    let c = c.clamp(MIN_COS, 1.0);
    let r = r.max(MIN_ROUGHNESS);
    let so = (1.0 - c * c).sqrt();
    let k = (2.0 + 1.0 / r) / (2.0 * PI);
    let trig: Vec<(f64, f64)> = (0..nphi)
        .map(|p| {
            let phi = PI * (p as f64 + 0.5) / nphi as f64;
            (math::cos(phi), math::sin(phi))
        })
        .collect();
    let mut sum = 0.0;
    for it in 0..nt {
        let t = (it as f64 + 0.5) / nt as f64;
        let s2 = 1.0 - t * t;
        let d = k * math::pow(s2, 0.5 / r);
        let st = s2.sqrt();
        for (cp, _) in &trig {
            let vh = st * cp * so + t * c;
            if vh <= 0.0 {
                continue;
            }
            let l = 2.0 * vh * t - c;
            if l <= 0.0 {
                continue;
            }
            sum += d * l * vh / (l + c - l * c) / n(l);
        }
    }
    // dt dφ over [0, 1] × [0, 2π], by symmetry twice the half circle.
    sum * (1.0 / nt as f64) * (2.0 * PI / nphi as f64)
}

/// `cos θo` and `r` of node `(i, j)`.
fn node(i: usize, j: usize) -> (f64, f64) {
    let x = i as f64 / (N_COS - 1) as f64;
    let y = j as f64 / (N_ROUGH - 1) as f64;
    let root = f64::from(ROOT_MIN) + y / f64::from(INV_SPAN);
    (x * x, root.powi(32).max(MIN_ROUGHNESS))
}

/// The table, `(E, G)` at node `(i, j)` at index `j·N_COS + i` (`i` along `√cos θo`, `j`
/// along `r^(1/32)`), built on first use.
pub fn table() -> &'static [[f32; 2]] {
    static TABLE: OnceLock<Vec<[f32; 2]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let raw: Vec<[f32; 2]> = (0..N_ROUGH * N_COS)
            .map(|x| {
                let (c, r) = node(x % N_COS, x / N_COS);
                let e = integrate(c, r, GRID_T, GRID_PHI, &|_| 1.0);
                [e as f32, 0.0]
            })
            .collect();
        (0..N_ROUGH * N_COS)
            .map(|x| {
                let (c, r) = node(x % N_COS, x / N_COS);
                let n = |l: f64| lookup(&raw, l, r)[0].max(1.0);
                let e = integrate(c, r, GRID_T, GRID_PHI, &n);
                [raw[x][0], e as f32]
            })
            .collect()
    })
}

/// [`sheen_albedo`] on the table `t`.
fn lookup<F: Real>(t: &[[f32; 2]], cos: F, roughness: F) -> [F; 2] {
    let x = axis(cos.sqrt(), N_COS);
    let r0 = F::from_f64(MIN_ROUGHNESS);
    let r = if roughness > r0 { roughness } else { r0 };
    let root = r.sqrt().sqrt().sqrt().sqrt().sqrt() - F::from_f64(f64::from(ROOT_MIN));
    let y = root * F::from_f64(f64::from(INV_SPAN));
    let y = axis(y, N_ROUGH);
    [0, 1].map(|k| bilinear(|i, j| F::from_f64(f64::from(t[j * N_COS + i][k])), x, y))
}

/// `(E, G)` at `cos θo = cos` and `roughness`: the table interpolated bilinearly in
/// `√cos θo` and `(r^(1/32) − r₀^(1/32))/(1 − r₀^(1/32))` (`r` below `r₀` and NaN read as
/// `r₀`), both clamped to [0, 1] (NaN reads the first node). The same operations in the same
/// order at either precision (and in the WGSL copy, `sn_sheen_albedo`).
pub fn sheen_albedo<F: Real>(cos: F, roughness: F) -> [F; 2] {
    lookup(table(), cos, roughness)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The half-vector integration against a plain one over `wi` (uniform in `cos θi` and
    /// `φ`, a fine grid) of the lobe's formula.
    #[test]
    fn integration_matches_the_lobe_over_wi() {
        for &(c, r) in &[(0.9, 1.0), (0.5, 0.3), (0.2, 0.1), (0.05, 0.5)] {
            let (nl, np) = (800, 400);
            let mut s = 0.0;
            let so = (1.0f64 - c * c).sqrt();
            let wo = [so, 0.0, c];
            for a in 0..nl {
                let l = (a as f64 + 0.5) / nl as f64;
                let sl = (1.0 - l * l).sqrt();
                for p in 0..np {
                    let phi = 2.0 * PI * (p as f64 + 0.5) / np as f64;
                    let wi = [sl * phi.cos(), sl * phi.sin(), l];
                    let h = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
                    let hl = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
                    let hz = h[2] / hl;
                    let d = (2.0 + 1.0 / r) * (1.0 - hz * hz).powf(0.5 / r) / (2.0 * PI);
                    s += d / (4.0 * (l + c - l * c)) * l;
                }
            }
            let direct = s * (1.0 / nl as f64) * (2.0 * PI / np as f64);
            let e = integrate(c, r, GRID_T, GRID_PHI, &|_| 1.0);
            assert!(
                (e - direct).abs() < 2e-3 * direct.max(1.0),
                "{c} {r}: {e} vs {direct}"
            );
        }
    }

    /// The lookup between the nodes against the integration there (a 20 × 20 grid offset
    /// from the table's): the normalized lobe's albedo `G / N(cos θo)` (both the lookup's
    /// and the integral's divided by the interpolated `N`, as the closure does) within 0.01
    /// (measured 0.0067), never above 1 beyond 0.002, and `E` within 1.5 % (measured 1.0 %,
    /// relative where it exceeds 1).
    #[test]
    fn lookup_error_against_integration() {
        let t = table();
        let mut err = [0.0f64; 2];
        let mut most: f64 = 0.0;
        for ci in 0..20 {
            let c = ((ci as f64 + 0.37) / 20.0).powi(2);
            for ri in 0..20 {
                let r = ((ri as f64 + 0.61) / 20.0).powi(2);
                let raw = integrate(c, r, 512, 192, &|_| 1.0);
                let n = |l: f64| lookup(t, l, r)[0].max(1.0);
                let g = integrate(c, r, 512, 192, &n);
                let [le, lg] = sheen_albedo(c, r);
                let nc = le.max(1.0);
                err[0] = err[0].max((raw - le).abs() / raw.max(1.0));
                err[1] = err[1].max((g - lg).abs() / nc);
                most = most.max(g / nc);
            }
        }
        eprintln!(
            "sheen table: E rel error {}, albedo error {}, largest {most}",
            err[0], err[1]
        );
        assert!(err[0] < 0.015 && err[1] < 0.01, "{err:?}");
        assert!(most <= 1.002, "{most}");
    }

    /// The raw lobe gains energy at grazing views of smooth roughness; the normalized one
    /// never exceeds 1 at the nodes, and is the raw one where both sides reflect ≤ 1.
    #[test]
    fn normalization() {
        let t = table();
        let at = |i: usize, j: usize| t[j * N_COS + i];
        assert!(at(0, 0)[0] > 3.0, "{:?}", at(0, 0));
        assert!(t.iter().all(|e| e[1] / e[0].max(1.0) <= 1.002), "{t:?}");
        // Roughness 1: the lobe reflects < 1 everywhere, untouched.
        for i in 0..N_COS {
            let [e, g] = at(i, N_ROUGH - 1);
            assert!(e < 1.0 && (e - g).abs() < 1e-6, "{i}: {e} {g}");
        }
    }

    /// f32 and f64 lookups agree to f32 rounding; out-of-range and NaN arguments read the
    /// edge nodes.
    #[test]
    fn lookup_edges() {
        let [a, b] = sheen_albedo(0.5f64, 0.3);
        let [a32, b32] = sheen_albedo(0.5f32, 0.3);
        assert!((a - f64::from(a32)).abs() < 1e-5 && (b - f64::from(b32)).abs() < 1e-6);
        let (hi, one) = (sheen_albedo(2.0f64, 4.0), sheen_albedo(1.0f64, 1.0));
        assert!((hi[0] - one[0]).abs() < 1e-6 && (hi[1] - one[1]).abs() < 1e-6);
        assert_eq!(sheen_albedo(f64::NAN, f64::NAN), sheen_albedo(0.0f64, 0.0));
    }
}
