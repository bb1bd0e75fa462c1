//! The directional albedo of a GGX dielectric's reflection with the exact unpolarized
//! Fresnel (`closure::dielectric`), as a table computed by our own numerical integration,
//! and its trilinear lookup — the IR intrinsic `dielectric_albedo`.
//!
//! `layer(top, base)` gives the base `1 − albedo(top)`; with Schlick's split of the exact
//! Fresnel (`F0 A + B` of [`super::ggx_albedo`]) a dielectric top reflected more than its
//! albedo said (up to +1.8 % for one layer, +3.3 % under a coat), which the white furnace
//! showed as a gain. This table integrates the lobe itself: the mean of `G2/G1 · F(wo·h)`
//! over the visible-normal samples of [`super::ggx_albedo::for_each_sample`] (a 32 × 32
//! grid: the lookup's interpolation error dominates from there on, f64, our own transcendentals), rounded to f32.
//!
//! Nodes: [`N_COS`] uniform in `√cos θo`, [`N_ROUGH`] uniform in `α^¼` (as the GGX table)
//! and [`N_R`] uniform in `√r = F0^¼` over [0, 1], `r = |η − 1|/(η + 1)` (`r = 1` is `η = ∞`,
//! where `F ≡ 1`): near `η = 1` the albedo changes fastest (nothing is reflected at `η = 1`,
//! everything at grazing views for any `η > 1`), and nodes uniform in `r` were off by 0.32
//! at η = 1.1. The table is for the viewer on the side of the lower index (`η ≥ 1`); a viewer
//! inside (`η < 1`) reads the node of `1/η` (same `F0`), which misses total internal
//! reflection — `closure::dielectric` bounds that case from below with the exact Fresnel at
//! the view. 16 × 16 × 13 = 3328 floats: the GPU's WGSL library holds them in a private
//! array, and Mesa's lavapipe compiles arrays of that size in well under a second where a
//! 50 000-entry one took minutes. Built once per process at the first lookup: the
//! microfacet geometry of each `(cos θo, α)` node is shared by its `N_R` Fresnel values.
//!
//! This module owns the integration and the lookup; `closure::dielectric` decides how the
//! albedo is used.

use super::Real;
use super::ggx_albedo::{axis, bilinear, for_each_sample};
use std::sync::OnceLock;

/// Nodes along `√cos θo`.
pub const N_COS: usize = 16;
/// Nodes along `α^¼`.
pub const N_ROUGH: usize = 16;
/// Nodes along `√r = F0^¼`.
pub const N_R: usize = 13;
/// The integration grid's side per node.
const GRID: usize = 32;

/// The exact unpolarized Fresnel reflectance of a dielectric at `c = wo·h` (≥ 0) with
/// relative index `eta` (the formula of `closure::dielectric::fresnel`); 1 under total
/// internal reflection and for `eta = ∞`.
pub fn fresnel(c: f64, eta: f64) -> f64 {
    if eta.is_infinite() {
        return 1.0;
    }
    let g2 = eta * eta + c * c - 1.0;
    if g2 < 0.0 {
        return 1.0;
    }
    let g = g2.sqrt();
    let r1 = (g - c) / (g + c);
    let r2 = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    0.5 * r1 * r1 * (1.0 + r2 * r2)
}

/// The relative index of `r = |η − 1|/(η + 1) = √F0` (≥ 1; `∞` at `r = 1`).
pub fn eta_of(r: f64) -> f64 {
    if r >= 1.0 {
        f64::INFINITY
    } else {
        (1.0 + r) / (1.0 - r)
    }
}

/// The albedo at `cos θo = c` and roughness `a` for each index of `etas`, on an `n` × `n`
/// grid.
pub fn integrate_all(c: f64, a: f64, etas: &[f64], n: usize) -> Vec<f64> {
    let mut s = vec![0.0; etas.len()];
    for_each_sample(c, a, n, |w, vh| {
        let vh = vh.max(0.0);
        for (s, eta) in s.iter_mut().zip(etas) {
            *s += w * fresnel(vh, *eta);
        }
    });
    let k = (n * n) as f64;
    s.iter().map(|x| x / k).collect()
}

/// The albedo at `cos θo = c`, roughness `a` and relative index `eta` on an `n` × `n` grid.
pub fn integrate(c: f64, a: f64, eta: f64, n: usize) -> f64 {
    integrate_all(c, a, &[eta], n)[0]
}

/// The table: the albedo at node `(i, j, k)` at index `(k·N_ROUGH + j)·N_COS + i` (`i`
/// along `√cos θo`, `j` along `α^¼`, `k` along `F0^¼`), built on first use.
pub fn table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let etas: Vec<f64> = (0..N_R)
            .map(|k| eta_of((k as f64 / (N_R - 1) as f64).powi(2)))
            .collect();
        let mut t = vec![0.0f32; N_COS * N_ROUGH * N_R];
        for j in 0..N_ROUGH {
            let y = j as f64 / (N_ROUGH - 1) as f64;
            let r = y * y;
            for i in 0..N_COS {
                let x = i as f64 / (N_COS - 1) as f64;
                let e = integrate_all(x * x, r * r, &etas, GRID);
                for (k, e) in e.iter().enumerate() {
                    t[(k * N_ROUGH + j) * N_COS + i] = *e as f32;
                }
            }
        }
        t
    })
}

/// The albedo at `cos θo = cos`, roughness `alpha` and relative index `etap`: the table
/// interpolated trilinearly in `√cos θo`, `α^¼` and `√(|η − 1|/(η + 1))` (`η` below 0 and NaN
/// read as 0, above 10³⁰ as 10³⁰), each clamped to [0, 1]. The same operations in the same order at either
/// precision (and in the WGSL copy, `sn_dielectric_albedo`).
pub fn dielectric_albedo<F: Real>(cos: F, alpha: F, etap: F) -> F {
    let t = table();
    let x = axis(cos.sqrt(), N_COS);
    let y = axis(alpha.sqrt().sqrt(), N_ROUGH);
    let e = if etap > F::ZERO { etap } else { F::ZERO };
    let big = F::from_f64(1e30);
    let e = if e < big { e } else { big };
    let r = (e - F::ONE).abs() / (e + F::ONE);
    let (k, tz) = axis(r.sqrt(), N_R);
    let plane = |k: usize| {
        let at = |i: usize, j: usize| F::from_f64(f64::from(t[(k * N_ROUGH + j) * N_COS + i]));
        bilinear(at, x, y)
    };
    let (p0, p1) = (plane(k), plane(k + 1));
    p0 + (p1 - p0) * tz
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ops::ggx_albedo;

    /// The exact Fresnel against known values: 0.04 at normal incidence for η = 1.5, 1 at
    /// grazing, total internal reflection inside.
    #[test]
    fn fresnel_values() {
        assert!((fresnel(1.0, 1.5) - 0.04).abs() < 1e-12);
        assert!((fresnel(0.0, 1.5) - 1.0).abs() < 1e-12);
        assert_eq!(fresnel(0.3, 1.0 / 1.5), 1.0);
        assert_eq!(fresnel(0.3, f64::INFINITY), 1.0);
        assert!((fresnel(0.5, 1.0)).abs() < 1e-12);
    }

    /// At `F ≡ 1` (`r = 1`) the albedo is the white GGX albedo `A + B`; at `η = 1` nothing is
    /// reflected; a mirror reflects the exact Fresnel at the view.
    #[test]
    fn limits() {
        for &(c, a) in &[(0.2, 0.1), (0.7, 0.5), (1.0, 1.0)] {
            let (ga, gb) = ggx_albedo::integrate(c, a, GRID);
            assert!((integrate(c, a, f64::INFINITY, GRID) - (ga + gb)).abs() < 1e-12);
            assert!(integrate(c, a, 1.0, GRID) < 1e-12);
        }
        for c in [0.1, 0.5, 1.0] {
            let e = integrate(c, 0.0, 1.5, GRID);
            assert!((e - fresnel(c, 1.5)).abs() < 1e-3, "{c}: {e}");
        }
    }

    /// The lookup between the nodes against the integration there: the largest absolute
    /// error over a 24 × 24 grid of views and roughness offset from the table's, at
    /// η = 1.05, 1.1, 1.2, 1.33, 1.5, 1.8 and 2.4 (between the `F0^¼` nodes): measured
    /// 0.0050 where `cos θo ≥ 0.25` or `α ≥ 0.2`, 0.0193 at grazing views of smooth lobes
    /// (0.0093 at η = 1.5, as the GGX table's; the most at η = 1.05). Schlick's split, used
    /// before, is off by up to 0.32 there (at η = 1.05, grazing).
    #[test]
    fn lookup_error_against_integration() {
        let mut err = [0.0f64; 2];
        let mut schlick: f64 = 0.0;
        for eta in [1.05f64, 1.1, 1.2, 1.33, 1.5, 1.8, 2.4] {
            let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            for ci in 0..24 {
                let c = (ci as f64 + 0.37) / 24.0;
                for ri in 0..24 {
                    let r = (ri as f64 + 0.61) / 24.0;
                    let a = r * r;
                    let exact = integrate(c, a, eta, 96);
                    let l = dielectric_albedo(c, a, eta);
                    let e = &mut err[usize::from(c < 0.25 && a < 0.2)];
                    *e = e.max((exact - l).abs());
                    let [ga, gb] = ggx_albedo::ggx_albedo(c, a);
                    schlick = schlick.max((exact - (f0 * ga + gb)).abs());
                }
            }
        }
        eprintln!(
            "table max |error|: main {}, grazing/smooth {}, Schlick's split {schlick}",
            err[0], err[1]
        );
        assert!(err[0] < 6e-3 && err[1] < 2e-2, "{err:?}");
        assert!(schlick > 0.1, "{schlick}");
    }

    /// f32 and f64 lookups of the same arguments agree to f32 rounding; η and 1/η read the
    /// same node; out-of-range and NaN arguments read the edge nodes.
    #[test]
    fn lookup_edges() {
        let e = dielectric_albedo(0.5f64, 0.3, 1.5);
        let e32 = dielectric_albedo(0.5f32, 0.3, 1.5);
        assert!((e - f64::from(e32)).abs() < 1e-6);
        assert!((dielectric_albedo(0.5f64, 0.3, 1.0 / 1.5) - e).abs() < 1e-12);
        let at = |c: f64, a: f64, eta: f64| dielectric_albedo(c, a, eta);
        assert_eq!(at(2.0, 4.0, f64::INFINITY), at(1.0, 1.0, 1e300));
        assert_eq!(at(-1.0, -1.0, 1.0), at(0.0, 0.0, 1.0));
        assert_eq!(at(f64::NAN, f64::NAN, f64::NAN), at(0.0, 0.0, 0.0));
        assert_eq!(at(0.5, 0.5, -3.0), at(0.5, 0.5, 0.0));
    }
}
