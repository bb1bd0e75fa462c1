//! Color spaces: from a texture file's stored values to the working space, linear Rec.709.
//!
//! A [`ColorSpace`] is a transfer function (decoding the stored, possibly non-linear value
//! to a linear one) and a set of primaries with a white point. The 3×3 matrix to linear
//! Rec.709 is computed here from the specifications' chromaticities, as MaterialX's `cmlib`
//! (through OpenColorIO) does: each space's RGB → XYZ normalized primary matrix (SMPTE RP
//! 177: the primaries' XYZ columns scaled so that RGB (1, 1, 1) is the white point with
//! Y = 1), a **Bradford** chromatic adaptation from the space's white to D65 where the whites
//! differ (ACES' white for AP1), then XYZ → Rec.709. Alpha is never converted.
//!
//! | space | primaries | white | transfer (stored → linear) |
//! |---|---|---|---|
//! | `lin_rec709` | Rec.709 (0.64, 0.33) (0.30, 0.60) (0.15, 0.06) | D65 (0.3127, 0.3290) | none |
//! | `srgb_texture` | Rec.709 | D65 | IEC 61966-2-1: `c/12.92` below 0.04045, else `((c+0.055)/1.055)^2.4` |
//! | `g22_rec709`, `g18_rec709` | Rec.709 | D65 | `c^2.2`, `c^1.8` |
//! | `rec709_display` | Rec.709 | D65 | `c^2.4` (BT.1886 with a zero black level, as MaterialX's cmlib) |
//! | `acescg`, `g22_ap1` | AP1 (0.713, 0.293) (0.165, 0.830) (0.128, 0.044) | ACES (0.32168, 0.33767) | none, `c^2.2` |
//! | `lin_adobergb`, `adobergb` | Adobe RGB (1998) (0.64, 0.33) (0.21, 0.71) (0.15, 0.06) | D65 | none, `c^(563/256)` |
//! | `lin_displayp3`, `srgb_displayp3` | Display P3 (0.680, 0.320) (0.265, 0.690) (0.150, 0.060) | D65 | none, sRGB's |
//!
//! `auto` is `srgb_texture` for 8- and 16-bit integer images and `lin_rec709` for floating
//! point ones; `raw` converts nothing. Transfer functions are odd (a negative value of a
//! float image decodes to minus the decoded magnitude) and use our own `pow`
//! (`shadenet_graph::ops::math::pow_f32`), never the platform's.

use super::decode::{Decoded, Samples};
use shadenet_graph::ir::ColorSpace;
use shadenet_graph::ops::math::pow_f32;

/// A 3×3 matrix, rows first.
pub type Mat3 = [[f64; 3]; 3];

/// Chromaticities `(x, y)` of red, green and blue, and of the white point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Primaries {
    /// Red, green, blue.
    pub rgb: [[f64; 2]; 3],
    /// The white point.
    pub white: [f64; 2],
}

/// D65 as ITU-R BT.709 gives it.
pub const D65: [f64; 2] = [0.3127, 0.3290];
/// Rec.709 / sRGB primaries with D65.
pub const REC709: Primaries = Primaries {
    rgb: [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]],
    white: D65,
};
/// ACES AP1 primaries with the ACES white point (SMPTE ST 2065-1, S-2014-004).
pub const AP1: Primaries = Primaries {
    rgb: [[0.713, 0.293], [0.165, 0.830], [0.128, 0.044]],
    white: [0.32168, 0.33767],
};
/// Adobe RGB (1998) primaries with D65.
pub const ADOBE_RGB: Primaries = Primaries {
    rgb: [[0.64, 0.33], [0.21, 0.71], [0.15, 0.06]],
    white: D65,
};
/// Display P3 primaries (DCI-P3's with D65).
pub const DISPLAY_P3: Primaries = Primaries {
    rgb: [[0.680, 0.320], [0.265, 0.690], [0.150, 0.060]],
    white: D65,
};

/// A stored value → linear value function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Transfer {
    /// The identity.
    Linear,
    /// The sRGB curve (IEC 61966-2-1).
    Srgb,
    /// A pure power `c^γ`.
    Gamma(f32),
}

impl Transfer {
    /// Stored → linear (odd: negative values decode to minus the decoded magnitude).
    pub fn decode(self, c: f32) -> f32 {
        if c < 0.0 {
            return -self.decode(-c);
        }
        match self {
            Transfer::Linear => c,
            Transfer::Srgb => {
                if c <= 0.04045 {
                    c / 12.92
                } else {
                    pow_f32((c + 0.055) / 1.055, 2.4)
                }
            }
            Transfer::Gamma(g) => pow_f32(c, g),
        }
    }

    /// Linear → stored, the inverse of [`Transfer::decode`] (for tests and writers).
    pub fn encode(self, l: f32) -> f32 {
        if l < 0.0 {
            return -self.encode(-l);
        }
        match self {
            Transfer::Linear => l,
            Transfer::Srgb => {
                if l <= 0.0031308 {
                    l * 12.92
                } else {
                    1.055 * pow_f32(l, 1.0 / 2.4) - 0.055
                }
            }
            Transfer::Gamma(g) => pow_f32(l, 1.0 / g),
        }
    }
}

/// How one color space's values become linear Rec.709: a transfer function, then a matrix
/// (`None`: the primaries are Rec.709's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conversion {
    /// Stored → linear in the space's own primaries.
    pub transfer: Transfer,
    /// Linear in the space's primaries → linear Rec.709 (rows first).
    pub matrix: Option<[[f32; 3]; 3]>,
}

impl Conversion {
    /// The conversion of `space` for an image whose samples are floating point (`float`)
    /// or integers (which decides `auto`).
    pub fn of(space: ColorSpace, float: bool) -> Conversion {
        let (transfer, primaries) = match space {
            ColorSpace::Auto if float => (Transfer::Linear, None),
            ColorSpace::Auto => (Transfer::Srgb, None),
            ColorSpace::Raw | ColorSpace::LinRec709 => (Transfer::Linear, None),
            ColorSpace::SrgbTexture => (Transfer::Srgb, None),
            ColorSpace::G22Rec709 => (Transfer::Gamma(2.2), None),
            ColorSpace::G18Rec709 => (Transfer::Gamma(1.8), None),
            // MaterialX's cmlib: a 2.4 power (BT.1886 with a zero black level).
            ColorSpace::Rec709Display => (Transfer::Gamma(2.4), None),
            ColorSpace::AcesCg => (Transfer::Linear, Some(AP1)),
            ColorSpace::G22Ap1 => (Transfer::Gamma(2.2), Some(AP1)),
            ColorSpace::LinAdobeRgb => (Transfer::Linear, Some(ADOBE_RGB)),
            ColorSpace::AdobeRgb => (Transfer::Gamma(563.0 / 256.0), Some(ADOBE_RGB)),
            ColorSpace::LinDisplayP3 => (Transfer::Linear, Some(DISPLAY_P3)),
            ColorSpace::SrgbDisplayP3 => (Transfer::Srgb, Some(DISPLAY_P3)),
        };
        Conversion {
            transfer,
            matrix: primaries.map(|p| to_lin_rec709(&p).map(|row| row.map(|x| x as f32))),
        }
    }

    /// Converts an RGB triple of decoded-linear values by the matrix.
    #[inline]
    pub fn apply_matrix(&self, rgb: [f32; 3]) -> [f32; 3] {
        match &self.matrix {
            None => rgb,
            Some(m) => {
                std::array::from_fn(|i| m[i][0] * rgb[0] + m[i][1] * rgb[1] + m[i][2] * rgb[2])
            }
        }
    }
}

fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

fn mul_vec(a: &Mat3, v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}

/// The inverse of a 3×3 matrix (by cofactors; the matrices here are far from singular).
pub fn invert(m: &Mat3) -> Mat3 {
    let c =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let cof: Mat3 = [
        [c(1, 2, 1, 2), -c(1, 2, 0, 2), c(1, 2, 0, 1)],
        [-c(0, 2, 1, 2), c(0, 2, 0, 2), -c(0, 2, 0, 1)],
        [c(0, 1, 1, 2), -c(0, 1, 0, 2), c(0, 1, 0, 1)],
    ];
    let det = m[0][0] * cof[0][0] + m[0][1] * cof[0][1] + m[0][2] * cof[0][2];
    // The inverse is the transposed cofactor matrix over the determinant.
    std::array::from_fn(|i| std::array::from_fn(|j| cof[j][i] / det))
}

/// XYZ (Y = 1) of a chromaticity.
fn xyz(xy: [f64; 2]) -> [f64; 3] {
    [xy[0] / xy[1], 1.0, (1.0 - xy[0] - xy[1]) / xy[1]]
}

/// The RGB → XYZ normalized primary matrix (SMPTE RP 177).
pub fn rgb_to_xyz(p: &Primaries) -> Mat3 {
    let cols = p.rgb.map(xyz);
    let pm: Mat3 = std::array::from_fn(|i| std::array::from_fn(|j| cols[j][i]));
    let s = mul_vec(&invert(&pm), xyz(p.white));
    std::array::from_fn(|i| std::array::from_fn(|j| pm[i][j] * s[j]))
}

/// The Bradford cone response matrix.
const BRADFORD: Mat3 = [
    [0.8951, 0.2664, -0.1614],
    [-0.7502, 1.7135, 0.0367],
    [0.0389, -0.0685, 1.0296],
];

/// The Bradford chromatic adaptation (XYZ → XYZ) from white `src` to white `dst`.
pub fn bradford(src: [f64; 2], dst: [f64; 2]) -> Mat3 {
    let s = mul_vec(&BRADFORD, xyz(src));
    let d = mul_vec(&BRADFORD, xyz(dst));
    let scale: Mat3 =
        std::array::from_fn(|i| std::array::from_fn(|j| if i == j { d[i] / s[i] } else { 0.0 }));
    mul(&invert(&BRADFORD), &mul(&scale, &BRADFORD))
}

/// Linear RGB in primaries `p` → linear Rec.709 (D65), adapting the white by Bradford
/// where it is not D65.
pub fn to_lin_rec709(p: &Primaries) -> Mat3 {
    let to_xyz = rgb_to_xyz(p);
    let adapted = if p.white == REC709.white {
        to_xyz
    } else {
        mul(&bradford(p.white, REC709.white), &to_xyz)
    };
    mul(&invert(&rgb_to_xyz(&REC709)), &adapted)
}

/// A decoded image's texels in the working space, RGBA: its samples through `space`'s
/// transfer (a table for 8- and 16-bit samples) and matrix; alpha is the stored value
/// (normalized for integers); Y is replicated to RGB; a missing alpha is 1.
pub fn to_working(d: Decoded, space: ColorSpace) -> Vec<[f32; 4]> {
    let conv = Conversion::of(space, matches!(d.samples, Samples::F32(_)));
    let n = d.channels;
    let decode = |c: f32| conv.transfer.decode(c);
    let mut texels = match &d.samples {
        Samples::U8(v) => {
            let lut: [f32; 256] = std::array::from_fn(|b| decode(b as f32 / 255.0));
            expand(v, n, |b| lut[b as usize], |b| b as f32 / 255.0)
        }
        Samples::U16(v) => {
            let lut: Vec<f32> = (0..=u16::MAX).map(|b| decode(b as f32 / 65535.0)).collect();
            expand(v, n, |b| lut[b as usize], |b| b as f32 / 65535.0)
        }
        Samples::F32(v) if conv.transfer == Transfer::Linear => expand(v, n, |x| x, |x| x),
        Samples::F32(v) => expand(v, n, decode, |x| x),
    };
    apply_matrix_all(&conv, &mut texels);
    texels
}

/// Texels from samples of `n` channels (Y, YA, RGB, RGBA).
fn expand<T: Copy>(
    v: &[T],
    n: usize,
    color: impl Fn(T) -> f32,
    alpha: impl Fn(T) -> f32,
) -> Vec<[f32; 4]> {
    v.chunks_exact(n.max(1))
        .map(|p| match n {
            1 => {
                let y = color(p[0]);
                [y, y, y, 1.0]
            }
            2 => {
                let y = color(p[0]);
                [y, y, y, alpha(p[1])]
            }
            3 => [color(p[0]), color(p[1]), color(p[2]), 1.0],
            _ => [color(p[0]), color(p[1]), color(p[2]), alpha(p[3])],
        })
        .collect()
}

/// Converts texels in place from `conv`'s primaries to linear Rec.709 (alpha untouched):
/// the transfer is applied already; this applies the matrix.
pub fn apply_matrix_all(conv: &Conversion, texels: &mut [[f32; 4]]) {
    if conv.matrix.is_none() {
        return;
    }
    for t in texels {
        let [r, g, b] = conv.apply_matrix([t[0], t[1], t[2]]);
        *t = [r, g, b, t[3]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Mat3, b: &Mat3, tol: f64) {
        for i in 0..3 {
            for j in 0..3 {
                assert!(
                    (a[i][j] - b[i][j]).abs() <= tol,
                    "[{i}][{j}]: {} vs {}\n{a:?}\n{b:?}",
                    a[i][j],
                    b[i][j]
                );
            }
        }
    }

    #[test]
    fn primary_matrices_follow_their_definition() {
        for p in [REC709, AP1, ADOBE_RGB, DISPLAY_P3] {
            let m = rgb_to_xyz(&p);
            // RGB white is the white point with Y = 1.
            let w = mul_vec(&m, [1.0; 3]);
            let want = xyz(p.white);
            for i in 0..3 {
                assert!((w[i] - want[i]).abs() < 1e-12, "{p:?}: {w:?}");
            }
            // Each primary's column has the primary's chromaticity.
            for (c, xy) in p.rgb.iter().enumerate() {
                let col = [m[0][c], m[1][c], m[2][c]];
                let sum = col[0] + col[1] + col[2];
                assert!((col[0] / sum - xy[0]).abs() < 1e-12);
                assert!((col[1] / sum - xy[1]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn matrices_match_the_specifications() {
        // ACES AP1 → XYZ as S-2014-004 (ACEScg) publishes it, to 10 digits.
        close(
            &rgb_to_xyz(&AP1),
            &[
                [0.6624541811, 0.1340042065, 0.1561876870],
                [0.2722287168, 0.6740817658, 0.0536895174],
                [-0.0055746495, 0.0040607335, 1.0103391003],
            ],
            1e-6,
        );
        // Rec.709 luminance weights (BT.709 item 3.3, to 4 digits).
        let y = rgb_to_xyz(&REC709)[1];
        for (a, b) in y.iter().zip([0.2126, 0.7152, 0.0722]) {
            assert!((a - b).abs() < 5e-5, "{y:?}");
        }
        // ACEScg → linear Rec.709 (Bradford), as OpenColorIO's ACES config and MaterialX's
        // generated `lin_ap1_to_lin_rec709` give it.
        close(
            &to_lin_rec709(&AP1),
            &[
                [1.7050509926579815, -0.6217921206570056, -0.0832588720009797],
                [
                    -0.1302564175070435,
                    1.1408047365754048,
                    -0.010548319068357653,
                ],
                [
                    -0.024003356804618042,
                    -0.1289689760649709,
                    1.1529723328695858,
                ],
            ],
            1e-6,
        );
        // Display P3 → Rec.709 (same white: no adaptation), first row as OpenColorIO gives it.
        let p3 = to_lin_rec709(&DISPLAY_P3);
        assert!((p3[0][0] - 1.22494017628056).abs() < 1e-6, "{p3:?}");
        assert!((p3[0][1] + 0.2249401762805581).abs() < 1e-6, "{p3:?}");
        assert!(p3[0][2].abs() < 1e-6, "{p3:?}");
        // Adobe RGB shares red and blue with Rec.709: only green mixes (MaterialX's
        // `mx_lin_adobergb_to_lin_rec709`, whose digits end at 1e-9).
        let a = to_lin_rec709(&ADOBE_RGB);
        close(
            &a,
            &[
                [1.39835574, -0.398355744, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, -0.0429289893, 1.0429289893],
            ],
            1e-6,
        );
        // Every matrix maps white to white.
        for p in [AP1, ADOBE_RGB, DISPLAY_P3] {
            let w = mul_vec(&to_lin_rec709(&p), [1.0; 3]);
            assert!(w.iter().all(|c| (c - 1.0).abs() < 1e-12), "{w:?}");
        }
    }

    #[test]
    fn srgb_round_trips() {
        // Every 8-bit code decodes and encodes back to itself.
        for b in 0..=255u32 {
            let c = b as f32 / 255.0;
            let back = Transfer::Srgb.encode(Transfer::Srgb.decode(c));
            assert_eq!((back * 255.0).round() as u32, b);
            assert!((back - c).abs() < 2e-6, "{b}: {back} vs {c}");
        }
        // And linear values through encode → decode.
        for i in 0..=1000 {
            let l = i as f32 / 1000.0;
            let back = Transfer::Srgb.decode(Transfer::Srgb.encode(l));
            assert!((back - l).abs() <= 2e-6 * l.max(1e-3), "{l}: {back}");
        }
        // The curve's published points: 0.04045 → 0.04045/12.92, 0.5 → 0.214041, 1 → 1.
        assert_eq!(Transfer::Srgb.decode(0.04045), 0.04045 / 12.92);
        assert!((Transfer::Srgb.decode(0.5) - 0.214_041_14).abs() < 1e-6);
        assert_eq!(Transfer::Srgb.decode(1.0), 1.0);
        // Odd extension for negative float values.
        assert_eq!(Transfer::Srgb.decode(-0.5), -Transfer::Srgb.decode(0.5));
        for t in [
            Transfer::Gamma(2.2),
            Transfer::Gamma(2.4),
            Transfer::Gamma(563.0 / 256.0),
        ] {
            for i in 0..=100 {
                let l = i as f32 / 100.0;
                assert!((t.decode(t.encode(l)) - l).abs() < 1e-5, "{t:?} {l}");
            }
        }
    }

    #[test]
    fn conversions_by_name() {
        assert_eq!(
            Conversion::of(ColorSpace::Auto, false).transfer,
            Transfer::Srgb
        );
        assert_eq!(
            Conversion::of(ColorSpace::Auto, true).transfer,
            Transfer::Linear
        );
        assert_eq!(
            Conversion::of(ColorSpace::Raw, false),
            Conversion::of(ColorSpace::LinRec709, true)
        );
        assert!(
            Conversion::of(ColorSpace::SrgbTexture, true)
                .matrix
                .is_none()
        );
        let aces = Conversion::of(ColorSpace::AcesCg, true);
        let white = aces.apply_matrix([1.0; 3]);
        assert!(white.iter().all(|c| (c - 1.0).abs() < 1e-6), "{white:?}");
        assert_eq!(
            Conversion::of(ColorSpace::AdobeRgb, false).transfer,
            Transfer::Gamma(563.0 / 256.0)
        );
    }
}
