//! Statistics shared by the sampling tests: Pearson's chi-square with its p-value.

use std::f64::consts::PI;

/// Pearson's chi-square over bins (observed, expected counts): bins expecting fewer than 5
/// are pooled into one (a pool still expecting fewer than 5 must not hold more than
/// `5 + 3√E` samples... a sample where nothing was expected fails at once). Returns the
/// statistic, the degrees of freedom and the p-value.
pub fn chi_square(observed: &[f64], expected: &[f64]) -> Result<(f64, usize, f64), String> {
    let (mut chi, mut bins) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (k, (&o, &e)) in observed.iter().zip(expected).enumerate() {
        if e < 5.0 {
            if e <= 1e-9 && o > 0.0 {
                return Err(format!("{o} samples in bin {k} where the pdf is 0"));
            }
            pool_o += o;
            pool_e += e;
        } else {
            chi += (o - e) * (o - e) / e;
            bins += 1;
        }
    }
    if pool_e >= 5.0 {
        chi += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        bins += 1;
    } else if pool_o > 10.0 + pool_e + 5.0 * pool_e.sqrt() {
        return Err(format!(
            "{pool_o} samples in bins expecting {pool_e} together"
        ));
    }
    let dof = bins.saturating_sub(1).max(1);
    Ok((chi, dof, gamma_q(dof as f64 / 2.0, chi / 2.0)))
}

/// The regularized upper incomplete gamma function `Q(a, x)` (series below `a + 1`, Lentz's
/// continued fraction above), so `Q(k/2, χ²/2)` is the chi-square p-value.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let ln_pre = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * ln_pre.exp()
    } else {
        let tiny = 1e-300;
        let mut bb = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / bb;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            bb += 2.0;
            d = an * d + bb;
            d = if d.abs() < tiny { tiny } else { d };
            c = bb + an / c;
            c = if c.abs() < tiny { tiny } else { c };
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        ln_pre.exp() * h
    }
}

/// `ln Γ(x)` (Lanczos, g = 7, n = 9).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}
