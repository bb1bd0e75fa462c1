//! Mipmap pyramids: level 0 is the decoded image, each coarser level half its size (rounded
//! down, at least 1) down to 1×1, for any size, not only powers of two.
//!
//! Every texel of a coarser level is the **exact box average** of the finer level over its
//! footprint: coarse texel `i` of a row covers fine texels `[i·n/m, (i+1)·n/m)` (n fine, m
//! coarse texels), whole texels with weight 1 and the partly covered ones at the ends with
//! their covered fraction, all divided by `n/m`. The weights are exact rationals (integers
//! over `n`); the 2D average is separable, so a level is a horizontal pass then a vertical
//! one. Odd sizes therefore keep the image's mean (up to f32 rounding) and never shift it by
//! half a texel as a 2×2 average with a dropped last column would.

/// One level of a pyramid: linear RGBA texels, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width * height` texels.
    pub texels: Vec<[f32; 4]>,
}

impl Level {
    /// The bytes its texels take.
    pub fn bytes(&self) -> u64 {
        self.texels.len() as u64 * 16
    }
}

/// A texture's levels, finest first, the last 1×1.
#[derive(Clone, Debug, PartialEq)]
pub struct Pyramid {
    levels: Vec<Level>,
}

impl Pyramid {
    /// Builds the pyramid of an image (`texels.len() == width * height`, both at least 1).
    pub fn build(width: u32, height: u32, texels: Vec<[f32; 4]>) -> Pyramid {
        debug_assert_eq!(texels.len() as u64, width as u64 * height as u64);
        let mut levels = vec![Level {
            width,
            height,
            texels,
        }];
        loop {
            let last = levels.last().expect("level 0 is there");
            if last.width == 1 && last.height == 1 {
                break;
            }
            let next = downsample(last);
            levels.push(next);
        }
        Pyramid { levels }
    }

    /// The levels, finest first.
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// The bytes all levels take.
    pub fn bytes(&self) -> u64 {
        self.levels.iter().map(Level::bytes).sum()
    }

    /// The bytes the pyramid of a `width × height` image will take (a bound computed before
    /// decoding: the levels' exact sizes summed).
    pub fn bytes_for(width: u32, height: u32) -> u64 {
        let (mut w, mut h, mut total) = (width as u64, height as u64, 0u64);
        loop {
            total = total.saturating_add(w.saturating_mul(h).saturating_mul(16));
            if w <= 1 && h <= 1 {
                return total;
            }
            (w, h) = (next_size(w), next_size(h));
        }
    }
}

/// The size of the next coarser level along one axis.
fn next_size(n: u64) -> u64 {
    (n / 2).max(1)
}

/// The box weights from `n` fine texels to `m` coarse ones: per coarse texel, the first
/// fine texel and up to four weights (the ratio `n/m` is below 3, or exactly 3 for 3 → 1, so
/// a footprint touches at most four fine texels).
fn weights(n: usize, m: usize) -> Vec<(usize, [f32; 4])> {
    (0..m)
        .map(|i| {
            // Footprint [i·n/m, (i+1)·n/m) in fine texels; in units of 1/m: [i·n, (i+1)·n).
            let (lo, hi) = (i * n, (i + 1) * n);
            let first = lo / m;
            let mut w = [0.0f32; 4];
            for (j, wj) in w.iter_mut().enumerate() {
                let k = first + j;
                let (a, b) = ((k * m).max(lo), ((k + 1) * m).min(hi));
                if b > a {
                    // (b − a)/m texels covered, divided by the footprint's n/m texels.
                    *wj = ((b - a) as f64 / n as f64) as f32;
                }
            }
            (first, w)
        })
        .collect()
}

/// Sum of up to four weighted texels of a strided sequence.
#[inline]
fn weighted(src: &[[f32; 4]], first: usize, stride: usize, w: &[f32; 4], len: usize) -> [f32; 4] {
    let mut acc = [0.0f32; 4];
    for (j, &wj) in w.iter().enumerate() {
        let k = first + j;
        if wj == 0.0 || k >= len {
            continue;
        }
        let t = src[k * stride];
        for c in 0..4 {
            acc[c] += wj * t[c];
        }
    }
    acc
}

/// The next coarser level: a horizontal box pass, then a vertical one.
fn downsample(fine: &Level) -> Level {
    let (w, h) = (fine.width as usize, fine.height as usize);
    let (cw, ch) = (next_size(w as u64) as usize, next_size(h as u64) as usize);
    let wx = weights(w, cw);
    let wy = weights(h, ch);
    let mut rows = Vec::with_capacity(cw * h);
    for row in fine.texels.chunks_exact(w) {
        rows.extend(wx.iter().map(|(first, ws)| weighted(row, *first, 1, ws, w)));
    }
    let mut texels = Vec::with_capacity(cw * ch);
    for (first, ws) in &wy {
        for x in 0..cw {
            texels.push(weighted(&rows[x..], *first, cw, ws, h));
        }
    }
    Level {
        width: cw as u32,
        height: ch as u32,
        texels,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic image with distinct values per texel and channel.
    fn image(w: u32, h: u32) -> Vec<[f32; 4]> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                [
                    x,
                    y,
                    (x * 7.0 + y * 13.0) % 5.0,
                    ((i * 37) % 11) as f32 / 10.0,
                ]
            })
            .collect()
    }

    /// The box average of `fine` over the rectangle `[x0, x1) × [y0, y1)` (fine texel units,
    /// fractional), brute force in f64.
    fn box_average(fine: &Level, x: (f64, f64), y: (f64, f64)) -> [f64; 4] {
        let mut acc = [0.0f64; 4];
        for j in 0..fine.height as usize {
            let cy = ((j + 1) as f64).min(y.1) - (j as f64).max(y.0);
            for i in 0..fine.width as usize {
                let cx = ((i + 1) as f64).min(x.1) - (i as f64).max(x.0);
                if cx > 0.0 && cy > 0.0 {
                    let t = fine.texels[j * fine.width as usize + i];
                    for c in 0..4 {
                        acc[c] += cx * cy * t[c] as f64;
                    }
                }
            }
        }
        let area = (x.1 - x.0) * (y.1 - y.0);
        acc.map(|a| a / area)
    }

    fn mean(l: &Level) -> [f64; 4] {
        let mut acc = [0.0f64; 4];
        for t in &l.texels {
            for c in 0..4 {
                acc[c] += t[c] as f64;
            }
        }
        acc.map(|a| a / l.texels.len() as f64)
    }

    #[test]
    fn levels_are_exact_box_averages_for_odd_sizes() {
        for (w, h) in [
            (7u32, 5u32),
            (5, 1),
            (1, 9),
            (3, 3),
            (13, 6),
            (2, 2),
            (17, 31),
        ] {
            let p = Pyramid::build(w, h, image(w, h));
            let levels = p.levels();
            let last = levels.last().unwrap();
            assert_eq!((last.width, last.height), (1, 1), "{w}×{h}");
            for pair in levels.windows(2) {
                let (fine, coarse) = (&pair[0], &pair[1]);
                assert_eq!(coarse.width, (fine.width / 2).max(1));
                assert_eq!(coarse.height, (fine.height / 2).max(1));
                let rx = fine.width as f64 / coarse.width as f64;
                let ry = fine.height as f64 / coarse.height as f64;
                for j in 0..coarse.height as usize {
                    for i in 0..coarse.width as usize {
                        let want = box_average(
                            fine,
                            (i as f64 * rx, (i + 1) as f64 * rx),
                            (j as f64 * ry, (j + 1) as f64 * ry),
                        );
                        let got = coarse.texels[j * coarse.width as usize + i];
                        for c in 0..4 {
                            assert!(
                                (got[c] as f64 - want[c]).abs() <= 1e-5 * want[c].abs().max(1.0),
                                "{w}×{h} level {}×{} texel ({i}, {j}) channel {c}: {} vs {}",
                                coarse.width,
                                coarse.height,
                                got[c],
                                want[c]
                            );
                        }
                    }
                }
                // The mean is preserved from level to level.
                let (a, b) = (mean(fine), mean(coarse));
                for c in 0..4 {
                    assert!(
                        (a[c] - b[c]).abs() <= 1e-5 * a[c].abs().max(1.0),
                        "{a:?} {b:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn sizes_and_bytes() {
        let p = Pyramid::build(6, 3, image(6, 3));
        let sizes: Vec<(u32, u32)> = p.levels().iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, vec![(6, 3), (3, 1), (1, 1)]);
        assert_eq!(p.bytes(), (18 + 3 + 1) * 16);
        assert_eq!(Pyramid::bytes_for(6, 3), p.bytes());
        assert_eq!(Pyramid::bytes_for(4096, 4096), {
            let mut s = 0u64;
            let mut n = 4096u64;
            loop {
                s += n * n * 16;
                if n == 1 {
                    break s;
                }
                n /= 2;
            }
        });
        // A constant image stays constant at every level, exactly.
        let p = Pyramid::build(5, 7, vec![[0.25, 0.5, 1.0, 0.75]; 35]);
        for l in p.levels() {
            assert!(l.texels.iter().all(|t| (t[0] - 0.25).abs() < 1e-7));
        }
    }
}
