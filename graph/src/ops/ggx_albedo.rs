//! The directional albedo of a GGX microfacet lobe with Schlick's Fresnel, as a table
//! computed by our own numerical integration (issue 15: "GGX directional-albedo tables
//! computed by our own code"), and its bilinear lookup — the IR intrinsic `ggx_albedo`.
//!
//! A lobe with Fresnel `F0 + (F90 − F0)(1 − wo·h)⁵` reflects `F0·A + F90·B` of the light
//! arriving from `wo`; `(A, B)` depend on `cos θo` and the roughness `α` only. The table
//! holds them at [`N_COS`] × [`N_ROUGH`] nodes uniform in `√cos θo` and `α^¼` over [0, 1]
//! (the albedo changes fastest at grazing views and near a mirror), each integrated over a 64 × 64
//! midpoint grid of the visible-normal sampling square (spherical caps, Dupuy & Benyoub
//! 2023) in f64 with our own
//! transcendentals ([`super::math`]), rounded to f32. It is built once per process, at the
//! first lookup (about 4 M samples). Every back end reads the same table: the CPU ones call
//! [`ggx_albedo`], the GPU's WGSL library is written with it (`gpu::emit::library`).
//!
//! This module owns the integration and the lookup; the lobes decide what to do with the
//! albedo (`closure::ggx`).

use super::Real;
use super::math;
use std::sync::OnceLock;

/// Nodes along `√cos θo`.
pub const N_COS: usize = 32;
/// Nodes along `α^¼`.
pub const N_ROUGH: usize = 32;
/// The integration grid's side per node.
const GRID: usize = 64;
/// The smallest `cos θo` integrated (the first node stands for 0: the albedo's limit).
const MIN_COS: f64 = 1e-4;
/// The smallest `α` integrated (the first node stands for a mirror).
const MIN_ALPHA: f64 = 1e-4;

/// `(A, B)` at `cos θo = c` and roughness `a` (isotropic α), integrating the
/// visible-normal-sampled weight `G2/G1·(1 − (1 − wo·h)⁵)` and `G2/G1·(1 − wo·h)⁵` over an
/// `n` × `n` midpoint grid of the sampling square: the estimator is smooth in the square,
/// so the grid converges fast for every roughness.
pub fn integrate(c: f64, a: f64, n: usize) -> (f64, f64) {
    let (mut sa, mut sb) = (0.0, 0.0);
    for_each_sample(c, a, n, |w, vh| {
        let f = 1.0 - vh.max(0.0);
        let f5 = f * f * f * f * f;
        sa += w * (1.0 - f5);
        sb += w * f5;
    });
    let k = (n * n) as f64;
    (sa / k, sb / k)
}

/// The visible-normal samples of a GGX reflection at `cos θo = c` (clamped to
/// [1e-4, 1]) and roughness `a` (clamped to [1e-4, 1]) on an `n` × `n` midpoint grid of
/// the sampling square (spherical caps, Dupuy & Benyoub 2023): `visit(G2/G1, wo·h)` for
/// each sample whose mirror direction is above the horizon. The mean of `G2/G1 · F(wo·h)`
/// over all `n²` points is the directional albedo of the lobe with Fresnel `F`; the
/// tables of this module and [`super::dielectric_albedo`] integrate through it.
pub fn for_each_sample(c: f64, a: f64, n: usize, mut visit: impl FnMut(f64, f64)) {
    let c = c.clamp(MIN_COS, 1.0);
    let a = a.clamp(MIN_ALPHA, 1.0);
    let wo = [(1.0 - c * c).sqrt(), 0.0, c];
    let v = norm([wo[0] * a, wo[1] * a, wo[2]]);
    let g1o = 2.0 * c / (c + proj(a, wo));
    for i in 0..n {
        let u1 = (i as f64 + 0.5) / n as f64;
        let phi = 2.0 * std::f64::consts::PI * u1;
        let (sp, cp) = (math::sin(phi), math::cos(phi));
        for j in 0..n {
            let u2 = (j as f64 + 0.5) / n as f64;
            let z = (1.0 - u2) * (1.0 + v[2]) - v[2];
            let s = (1.0 - z * z).max(0.0).sqrt();
            // The visible hemisphere's normal (Dupuy & Benyoub 2023's spherical cap).
            let hs = [s * cp + v[0], s * sp + v[1], z + v[2]];
            let h = norm([hs[0] * a, hs[1] * a, hs[2].max(0.0)]);
            let vh = dot(wo, h);
            let wi = [
                2.0 * vh * h[0] - wo[0],
                2.0 * vh * h[1] - wo[1],
                2.0 * vh * h[2] - wo[2],
            ];
            if wi[2] <= 0.0 {
                continue;
            }
            let g2 = 2.0 * c * wi[2] / (proj(a, wo) * wi[2] + proj(a, wi) * c);
            visit(g2 / g1o, vh);
        }
    }
}

fn norm(v: [f64; 3]) -> [f64; 3] {
    let l = dot(v, v).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Smith's `Λ`-related projected length `√(w_z² + α²(w_x² + w_y²))`.
fn proj(a: f64, w: [f64; 3]) -> f64 {
    (w[2] * w[2] + a * a * (w[0] * w[0] + w[1] * w[1])).sqrt()
}

/// The table, `(A, B)` at node `(i, j)` at index `j·N_COS + i` (`i` along `√cos θo`, `j`
/// along `α^¼`), built on first use.
pub fn table() -> &'static [[f32; 2]] {
    static TABLE: OnceLock<Vec<[f32; 2]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = Vec::with_capacity(N_COS * N_ROUGH);
        for j in 0..N_ROUGH {
            let y = j as f64 / (N_ROUGH - 1) as f64;
            let r = y * y;
            for i in 0..N_COS {
                let x = i as f64 / (N_COS - 1) as f64;
                let (a, b) = integrate(x * x, r * r, GRID);
                t.push([a as f32, b as f32]);
            }
        }
        t
    })
}

/// A table coordinate `x` clamped to [0, 1] (NaN to 0) on an axis of `n` nodes uniform over
/// [0, 1]: the node below (at most `n − 2`) and the fraction past it. Every table lookup
/// (and its WGSL copy, `sn_ggx_axis`) places its coordinates with it.
pub fn axis<F: Real>(x: F, n: usize) -> (usize, F) {
    let x = if x > F::ZERO { x } else { F::ZERO };
    let x = if x < F::ONE { x } else { F::ONE };
    let s = x * F::from_f64((n - 1) as f64);
    // `s ≥ 0`, so truncation is the floor (the WGSL copy's `floor`), without a call to
    // `floorf` (x86-64's baseline has no rounding instruction): 1.5 % of standard_surface's
    // shading time.
    let k = (s.to_i32().max(0) as usize).min(n - 2);
    (k, s - F::from_i32(k as i32))
}

/// The table value `at(i, j)` interpolated bilinearly at the axis positions `(i, tx)` and
/// `(j, ty)` ([`axis`]): along `i` on both rows, then between them. Every table lookup (and
/// the WGSL copy, `sn_table_bilinear`) interpolates with it, in this order.
pub fn bilinear<F: Real>(
    at: impl Fn(usize, usize) -> F,
    (i, tx): (usize, F),
    (j, ty): (usize, F),
) -> F {
    let lo = at(i, j) + (at(i + 1, j) - at(i, j)) * tx;
    let hi = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * tx;
    lo + (hi - lo) * ty
}

/// `(A, B)` at `cos θo = cos` and roughness `alpha`: the table interpolated bilinearly in
/// `√cos θo` and `α^¼`, both clamped to [0, 1] (NaN reads the first node). The same
/// operations in the same order at either precision.
pub fn ggx_albedo<F: Real>(cos: F, alpha: F) -> [F; 2] {
    let t = table();
    let x = axis(cos.sqrt(), N_COS);
    let y = axis(alpha.sqrt().sqrt(), N_ROUGH);
    [0, 1].map(|k| bilinear(|i, j| F::from_f64(f64::from(t[j * N_COS + i][k])), x, y))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The integration converges: 64² and 256² grids agree to 2e-3 at the sharpest
    /// grazing lobe and far closer elsewhere.
    #[test]
    fn integration_converges() {
        for &(c, a) in &[
            (0.1, 0.05),
            (0.5, 0.3),
            (0.9, 1.0),
            (0.02, 0.6),
            (0.3, 1e-4),
        ] {
            let (a1, b1) = integrate(c, a, GRID);
            let (a2, b2) = integrate(c, a, 256);
            assert!((a1 - a2).abs() < 2e-3 && (b1 - b2).abs() < 2e-3, "{c} {a}");
        }
    }

    /// A mirror reflects Schlick's Fresnel exactly: `A = 1 − (1 − c)⁵`, `B = (1 − c)⁵`.
    #[test]
    fn the_mirror_limit_is_schlicks_fresnel() {
        for c in [0.05, 0.3, 0.7, 1.0] {
            let (a, b) = integrate(c, 0.0, GRID);
            let f5 = (1.0f64 - c).powi(5);
            assert!(
                (a - (1.0 - f5)).abs() < 1e-3 && (b - f5).abs() < 1e-3,
                "{c}"
            );
        }
    }

    /// The lookup between the nodes against the integration there: the largest absolute
    /// error of `A`, `B` and `A + B` over a 40 × 40 grid offset from the table's (measured:
    /// 0.0064, 0.0009, 0.0064 where `cos θo ≥ 0.25` or `α ≥ 0.2`; 0.0054, 0.0094, 0.0070 at
    /// grazing views of smooth lobes) — MaterialX's rational fit, which this replaced, is
    /// off by up to 0.022 and 0.112 there.
    #[test]
    fn lookup_error_against_integration() {
        let mut err = [[0.0f64; 3]; 2];
        for ci in 0..40 {
            let c = (ci as f64 + 0.37) / 40.0;
            for ri in 0..40 {
                let r = (ri as f64 + 0.61) / 40.0;
                let a = r * r;
                let (ia, ib) = integrate(c, a, 128);
                let [la, lb] = ggx_albedo(c, a);
                let e = &mut err[usize::from(c < 0.25 && a < 0.2)];
                e[0] = e[0].max((ia - la).abs());
                e[1] = e[1].max((ib - lb).abs());
                e[2] = e[2].max((ia + ib - la - lb).abs());
            }
        }
        eprintln!(
            "table max |error| (A, B, A+B): main {:?}, grazing/smooth {:?}",
            err[0], err[1]
        );
        assert!(err[0].iter().all(|e| *e < 8e-3), "{err:?}");
        assert!(err[1].iter().all(|e| *e < 1.2e-2), "{err:?}");
    }

    /// f32 and f64 lookups of the same arguments agree to f32 rounding; out-of-range and
    /// NaN arguments read the edge nodes.
    #[test]
    fn lookup_edges() {
        let [a, b] = ggx_albedo(0.5f64, 0.3);
        let [a32, b32] = ggx_albedo(0.5f32, 0.3);
        assert!((a - f64::from(a32)).abs() < 1e-6 && (b - f64::from(b32)).abs() < 1e-6);
        assert_eq!(ggx_albedo(2.0f64, 4.0), ggx_albedo(1.0f64, 1.0));
        assert_eq!(ggx_albedo(-1.0f64, -1.0), ggx_albedo(0.0f64, 0.0));
        assert_eq!(ggx_albedo(f64::NAN, f64::NAN), ggx_albedo(0.0f64, 0.0));
    }
}
