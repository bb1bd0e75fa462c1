//! SSIM, the structural similarity of Wang, Bovik, Sheikh and Simoncelli (2004), as B8's
//! perceptual error: the mean over every pixel of
//! `(2 μx μy + C1)(2 σxy + C2) / ((μx² + μy² + C1)(σx² + σy² + C2))` on luminance, with the
//! paper's 11×11 Gaussian window (σ = 1.5) and constants `C1 = (K1 L)²`, `C2 = (K2 L)²`,
//! `K1 = 0.01`, `K2 = 0.03`, `L = 1`. Near the borders the window is cut to the image and its
//! weights renormalized (the paper keeps only the windows wholly inside; cutting keeps every
//! pixel, and small frames, in the mean). 1 means identical; lower is less similar.

/// `K1` of the paper.
pub const K1: f64 = 0.01;
/// `K2` of the paper.
pub const K2: f64 = 0.03;
/// The window's side, pixels.
pub const WINDOW: usize = 11;
/// The window's Gaussian standard deviation, pixels.
pub const SIGMA: f64 = 1.5;

/// The luminance (Rec. 709 weights) of linear RGB triples, clamped to `[0, 1]` (the range
/// `L = 1` assumes); a non-finite value counts as 0.
pub fn luminance(rgb: &[f32]) -> Vec<f64> {
    rgb.chunks_exact(3)
        .map(|p| {
            let y = 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
            if y.is_finite() {
                y.clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
        .collect()
}

/// The 1-D Gaussian weights of the window, centre at index `WINDOW / 2` (not normalized:
/// every use normalizes by the weights inside the image).
fn kernel() -> [f64; WINDOW] {
    let mut k = [0.0; WINDOW];
    let c = (WINDOW / 2) as f64;
    for (i, w) in k.iter_mut().enumerate() {
        let d = i as f64 - c;
        *w = (-d * d / (2.0 * SIGMA * SIGMA)).exp();
    }
    k
}

/// `v` (`w` × `h`, row-major) filtered by the window cut to the image: separable, each 1-D
/// pass normalized by the weights that fell inside (the 2-D weights are products, so this
/// is the 2-D normalization exactly).
fn blur(v: &[f64], w: usize, h: usize) -> Vec<f64> {
    let k = kernel();
    let r = WINDOW / 2;
    let pass = |src: &[f64], len: usize, lines: usize, at: &dyn Fn(usize, usize) -> usize| {
        let mut out = vec![0.0; src.len()];
        for line in 0..lines {
            for i in 0..len {
                let (lo, hi) = (i.saturating_sub(r), (i + r).min(len - 1));
                let (mut sum, mut norm) = (0.0, 0.0);
                for j in lo..=hi {
                    let kw = k[j + r - i];
                    sum += kw * src[at(line, j)];
                    norm += kw;
                }
                out[at(line, i)] = sum / norm;
            }
        }
        out
    };
    let rows = pass(v, w, h, &|y, x| y * w + x);
    pass(&rows, h, w, &|x, y| y * w + x)
}

/// Mean SSIM of two luminance images of `w` × `h` (row-major, values in `[0, 1]`); `None`
/// when the sizes disagree or the image is empty.
pub fn mean_ssim(a: &[f64], b: &[f64], w: usize, h: usize) -> Option<f64> {
    let n = w.checked_mul(h)?;
    if n == 0 || a.len() != n || b.len() != n {
        return None;
    }
    let prod = |f: &dyn Fn(f64, f64) -> f64| -> Vec<f64> {
        a.iter().zip(b).map(|(&x, &y)| f(x, y)).collect()
    };
    let mx = blur(a, w, h);
    let my = blur(b, w, h);
    let mxx = blur(&prod(&|x, _| x * x), w, h);
    let myy = blur(&prod(&|_, y| y * y), w, h);
    let mxy = blur(&prod(&|x, y| x * y), w, h);
    let (c1, c2) = ((K1 * 1.0).powi(2), (K2 * 1.0).powi(2));
    let mut sum = 0.0;
    for i in 0..n {
        let (ux, uy) = (mx[i], my[i]);
        let sx = mxx[i] - ux * ux;
        let sy = myy[i] - uy * uy;
        let sxy = mxy[i] - ux * uy;
        sum +=
            (2.0 * ux * uy + c1) * (2.0 * sxy + c2) / ((ux * ux + uy * uy + c1) * (sx + sy + c2));
    }
    Some(sum / n as f64)
}

/// Mean SSIM of two linear RGB images (triples) of `w` × `h`, on their [`luminance`].
pub fn mean_ssim_rgb(a: &[f32], b: &[f32], w: usize, h: usize) -> Option<f64> {
    mean_ssim(&luminance(a), &luminance(b), w, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic textured image: a sum of two sines, in [0.1, 0.9].
    fn pattern(w: usize, h: usize) -> Vec<f64> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                0.5 + 0.2 * (x * 0.7).sin() + 0.2 * (y * 1.3 + x * 0.2).cos()
            })
            .collect()
    }

    #[test]
    fn identical_images_score_one() {
        let a = pattern(40, 30);
        let s = mean_ssim(&a, &a, 40, 30).unwrap();
        assert!((s - 1.0).abs() < 1e-12, "{s}");
        // Smaller than the window: still every pixel.
        let a = pattern(5, 3);
        assert!((mean_ssim(&a, &a, 5, 3).unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_constant_offset_lowers_the_luminance_term_only() {
        // Flat images a and a + c: σ = 0 everywhere, so SSIM is the luminance term,
        // (2a(a + c) + C1) / (a² + (a + c)² + C1), at every pixel.
        let (a, c) = (0.3, 0.1);
        let x = vec![a; 20 * 15];
        let y = vec![a + c; 20 * 15];
        let c1 = (K1 * 1.0f64).powi(2);
        let want = (2.0 * a * (a + c) + c1) / (a * a + (a + c) * (a + c) + c1);
        let got = mean_ssim(&x, &y, 20, 15).unwrap();
        assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        // 0.2401 / 0.2501.
        assert!((want - 0.2401 / 0.2501).abs() < 1e-15 && want < 0.961);
    }

    #[test]
    fn more_noise_scores_lower_and_the_score_is_symmetric() {
        let a = pattern(32, 24);
        // A deterministic ±1 pattern as noise.
        let noisy = |amp: f64| -> Vec<f64> {
            a.iter()
                .enumerate()
                .map(|(i, v)| v + amp * if (i * 7919) % 13 < 6 { 1.0 } else { -1.0 })
                .collect()
        };
        let s1 = mean_ssim(&a, &noisy(0.02), 32, 24).unwrap();
        let s2 = mean_ssim(&a, &noisy(0.08), 32, 24).unwrap();
        assert!(1.0 > s1 && s1 > s2 && s2 > 0.0, "{s1} {s2}");
        let back = mean_ssim(&noisy(0.08), &a, 32, 24).unwrap();
        assert!((back - s2).abs() < 1e-12);
        // Inverting the structure around the mean scores below zero contrast-wise.
        let inv: Vec<f64> = a.iter().map(|v| 1.0 - v).collect();
        assert!(mean_ssim(&a, &inv, 32, 24).unwrap() < 0.0);
    }

    #[test]
    fn sizes_must_agree_and_luminance_clamps() {
        assert!(mean_ssim(&[0.0; 6], &[0.0; 5], 3, 2).is_none());
        assert!(mean_ssim(&[], &[], 0, 0).is_none());
        let l = luminance(&[1.0, 1.0, 1.0, 5.0, 5.0, 5.0, f32::NAN, 0.0, 0.0]);
        assert!(
            (l[0] - 1.0).abs() < 1e-12 && l[1] == 1.0 && l[2] == 0.0,
            "{l:?}"
        );
        let l = luminance(&[0.5, 0.0, 0.0]);
        assert!((l[0] - 0.1063).abs() < 1e-12);
    }
}
