//! Four-lane forms of cell noise ([`super::noise::cellnoise3`]) and the HSV conversions
//! ([`super::rgb_to_hsv`], [`super::hsv_to_rgb`]) for the JIT's batch entry (issue 23): the
//! scalar f32 functions inlined four times into one copy per SIMD path, so the compiler may
//! run the lanes together (cell noise's floor, conversion and integer hash vectorize; the HSV
//! conversions' branches become selects where it can) while every lane does exactly the
//! scalar function's operations — the bits are the scalar ones by construction, and the tests
//! hold every path to them. The path is the one every four-lane helper shares
//! ([`super::simd::Path`], chosen once per process). Owns no semantics: a change goes to the
//! scalar functions.

use super::noise_x4::X4;
use super::simd::Path;

#[inline(always)]
fn cell_body(p: [X4; 3]) -> X4 {
    let mut out = [0.0f32; 4];
    for (l, o) in out.iter_mut().enumerate() {
        *o = super::noise::cellnoise3::<f32>([p[0][l], p[1][l], p[2][l]]);
    }
    out
}

#[inline(always)]
fn to_hsv_body(c: [X4; 3]) -> [X4; 3] {
    let mut out = [[0.0f32; 4]; 3];
    for l in 0..4 {
        let v = super::rgb_to_hsv::<f32>([c[0][l], c[1][l], c[2][l]]);
        for k in 0..3 {
            out[k][l] = v[k];
        }
    }
    out
}

#[inline(always)]
fn to_rgb_body(c: [X4; 3]) -> [X4; 3] {
    let mut out = [[0.0f32; 4]; 3];
    for l in 0..4 {
        let v = super::hsv_to_rgb::<f32>([c[0][l], c[1][l], c[2][l]]);
        for k in 0..3 {
            out[k][l] = v[k];
        }
    }
    out
}

/// Four results of three components, lane-major, as three components of four lanes.
fn soa(v: [[f32; 3]; 4]) -> [X4; 3] {
    std::array::from_fn(|k| std::array::from_fn(|l| v[l][k]))
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;

    #[target_feature(enable = "avx2")]
    pub fn cell_avx2(p: [X4; 3]) -> X4 {
        cell_body(p)
    }
    #[target_feature(enable = "avx2")]
    pub fn to_hsv_avx2(c: [X4; 3]) -> [X4; 3] {
        to_hsv_body(c)
    }
    #[target_feature(enable = "avx2")]
    pub fn to_rgb_avx2(c: [X4; 3]) -> [X4; 3] {
        to_rgb_body(c)
    }
    #[target_feature(enable = "sse4.1")]
    pub fn cell_sse41(p: [X4; 3]) -> X4 {
        cell_body(p)
    }
    #[target_feature(enable = "sse4.1")]
    pub fn to_hsv_sse41(c: [X4; 3]) -> [X4; 3] {
        to_hsv_body(c)
    }
    #[target_feature(enable = "sse4.1")]
    pub fn to_rgb_sse41(c: [X4; 3]) -> [X4; 3] {
        to_rgb_body(c)
    }
}

/// The scalar function once per lane, not inlined (what the batch entry did before; kept
/// to measure against): [`Path::Lanes`].
#[inline(never)]
fn lanes<R>(a: [X4; 3], f: impl Fn([f32; 3]) -> R) -> [R; 4] {
    std::array::from_fn(|l| f([a[0][l], a[1][l], a[2][l]]))
}

/// [`super::noise::cellnoise3`] (f32) of four points, `p[axis][lane]`, on `path` (which
/// must be [`Path::available`]).
pub fn cellnoise3_x4_on(path: Path, p: [X4; 3]) -> X4 {
    assert!(path.available(), "{path:?} is not available on this CPU");
    match path {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` checked the CPU has AVX2.
        Path::Avx2 => unsafe { x86::cell_avx2(p) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` checked the CPU has SSE4.1.
        Path::Sse41 => unsafe { x86::cell_sse41(p) },
        Path::Lanes => lanes(p, super::noise::cellnoise3::<f32>),
        _ => cell_body(p),
    }
}

/// [`super::rgb_to_hsv`] (f32) of four colours, `c[channel][lane]`, on `path` (which must be
/// [`Path::available`]).
pub fn rgb_to_hsv_x4_on(path: Path, c: [X4; 3]) -> [X4; 3] {
    assert!(path.available(), "{path:?} is not available on this CPU");
    match path {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` checked the CPU has AVX2.
        Path::Avx2 => unsafe { x86::to_hsv_avx2(c) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` checked the CPU has SSE4.1.
        Path::Sse41 => unsafe { x86::to_hsv_sse41(c) },
        Path::Lanes => soa(lanes(c, super::rgb_to_hsv::<f32>)),
        _ => to_hsv_body(c),
    }
}

/// [`super::hsv_to_rgb`] (f32) of four colours, `c[channel][lane]`, on `path` (which must be
/// [`Path::available`]).
pub fn hsv_to_rgb_x4_on(path: Path, c: [X4; 3]) -> [X4; 3] {
    assert!(path.available(), "{path:?} is not available on this CPU");
    match path {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` checked the CPU has AVX2.
        Path::Avx2 => unsafe { x86::to_rgb_avx2(c) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` checked the CPU has SSE4.1.
        Path::Sse41 => unsafe { x86::to_rgb_sse41(c) },
        Path::Lanes => soa(lanes(c, super::hsv_to_rgb::<f32>)),
        _ => to_rgb_body(c),
    }
}

/// [`cellnoise3_x4_on`] on [`Path::chosen`].
pub fn cellnoise3_x4(p: [X4; 3]) -> X4 {
    cellnoise3_x4_on(Path::chosen(), p)
}

/// [`rgb_to_hsv_x4_on`] on [`Path::chosen`].
pub fn rgb_to_hsv_x4(c: [X4; 3]) -> [X4; 3] {
    rgb_to_hsv_x4_on(Path::chosen(), c)
}

/// [`hsv_to_rgb_x4_on`] on [`Path::chosen`].
pub fn hsv_to_rgb_x4(c: [X4; 3]) -> [X4; 3] {
    hsv_to_rgb_x4_on(Path::chosen(), c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hard values: the noise tests' (zeros, denormals, cell boundaries, huge, ±inf, NaN) and
    /// the hue sectors' boundaries.
    fn hard() -> Vec<f32> {
        let mut v = super::super::noise_x4::tests::HARD.to_vec();
        v.extend([
            f32::MIN_POSITIVE,
            1.000_000_1,
            1.0 / 6.0,
            2.0 / 6.0,
            0.5 + 1.0 / 6.0,
        ]);
        v.extend([5.0 / 6.0, 2.5, -7.25, 16_777_216.0]);
        v
    }

    /// Every triple of hard values, then deterministic random triples over a wide range.
    fn triples() -> Vec<[f32; 3]> {
        let mut v = Vec::new();
        let hard = hard();
        for &a in &hard {
            for &b in &hard {
                for &c in [0.0f32, 0.25, 1.0, -2.0, f32::NAN, 1e-45].iter() {
                    v.push([a, b, c]);
                    v.push([c, a, b]);
                    v.push([b, c, a]);
                }
            }
        }
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let u = (s >> 40) as f32 / (1u64 << 24) as f32;
            (u - 0.5) * if s & 1 == 0 { 4.0 } else { 4000.0 }
        };
        for _ in 0..4000 {
            v.push([next(), next(), next()]);
        }
        v
    }

    fn paths() -> Vec<Path> {
        let all = [Path::Lanes, Path::Base, Path::Sse41, Path::Avx2];
        for p in all {
            if !p.available() {
                println!("SKIPPED: the {p:?} copy: this CPU lacks the feature");
            }
        }
        all.into_iter().filter(|p| p.available()).collect()
    }

    fn check3(what: &str, x4: fn(Path, [X4; 3]) -> [X4; 3], scalar: fn([f32; 3]) -> [f32; 3]) {
        let ts = triples();
        for path in paths() {
            for chunk in ts.chunks(4) {
                let c: [X4; 3] =
                    std::array::from_fn(|k| std::array::from_fn(|l| chunk[l % chunk.len()][k]));
                let got = x4(path, c);
                for l in 0..4 {
                    let t = chunk[l % chunk.len()];
                    let want = scalar(t);
                    for k in 0..3 {
                        // A NaN's sign and payload are not the arithmetic's (IEEE 754 leaves
                        // which operand's NaN an operation returns open, and LLVM commutes
                        // operands at opt-level 3): NaN-ness is compared, every other value
                        // bit for bit.
                        let (g, w) = (got[k][l], want[k]);
                        assert!(
                            g.to_bits() == w.to_bits() || (g.is_nan() && w.is_nan()),
                            "{what} {path:?} of {t:?}: component {k}: {g} ({:#x}) vs {w} ({:#x})",
                            g.to_bits(),
                            w.to_bits()
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn cellnoise3_x4_has_the_scalar_bits_on_every_path() {
        let ts = triples();
        for path in paths() {
            for chunk in ts.chunks(4) {
                let p: [X4; 3] =
                    std::array::from_fn(|k| std::array::from_fn(|l| chunk[l % chunk.len()][k]));
                let got = cellnoise3_x4_on(path, p);
                for (l, g) in got.iter().enumerate() {
                    let t = chunk[l % chunk.len()];
                    let want = super::super::noise::cellnoise3::<f32>(t);
                    assert_eq!(g.to_bits(), want.to_bits(), "{path:?} at {t:?}");
                }
            }
        }
    }

    #[test]
    fn hsv_conversions_x4_have_the_scalar_bits_on_every_path() {
        check3(
            "rgb_to_hsv",
            rgb_to_hsv_x4_on,
            super::super::rgb_to_hsv::<f32>,
        );
        check3(
            "hsv_to_rgb",
            hsv_to_rgb_x4_on,
            super::super::hsv_to_rgb::<f32>,
        );
    }
}
