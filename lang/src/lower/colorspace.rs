//! OSL's colour spaces: the names `transformc(from, to, c)` and `color("space", a, b, c)`
//! accept, and the conversions between each and linear RGB, built as IR arithmetic with the
//! formulas of OSL's `ColorSystem` (`opcolor_impl.h`), in its order of operations:
//!
//! - `"rgb"`, `"RGB"`, `"linear"`: linear Rec. 709 RGB, our working space (OSL's default
//!   colour system, Rec709);
//! - `"hsv"`: the hsv conversion of our MaterialX atoms (`ops::rgb_to_hsv`/`hsv_to_rgb`, Foley
//!   & van Dam as OSL's; OSL also returns grey below a saturation of 10⁻⁴, a difference of
//!   at most 10⁻⁴·v there — kept so that MaterialX's OSL `hsvtorgb` agrees with its atom);
//! - `"hsl"`: through hsv, as OSL converts it;
//! - `"YIQ"`: OSL's two matrices (NTSC);
//! - `"XYZ"`: CIE XYZ by the Rec. 709 primaries and D65 white (the matrix `blackbody`
//!   uses, [`super::spectral::xyz_to_rgb`]), `"xyY"` through XYZ (OSL's `1e-6` guards);
//! - `"sRGB"`: the sRGB transfer function (OSL's `transformc` only).
//!
//! It owns these conversions; parsing the call and its errors are `osl.rs`' and
//! `expr.rs`'.

use super::Ty;
use super::components::componentwise;
use shadenet_graph::ir::{BinOp, Builder, Intrinsic, Value};
use shadenet_graph::types::Type;

/// A colour space OSL names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Space {
    Rgb,
    Hsv,
    Hsl,
    Yiq,
    Xyz,
    XyY,
    Srgb,
}

/// The names accepted, for messages.
pub(crate) const NAMES: &str =
    "\"rgb\", \"RGB\", \"linear\", \"hsv\", \"hsl\", \"YIQ\", \"XYZ\", \"xyY\", \"sRGB\"";

/// The space named `name` (OSL's spelling, case-sensitive).
pub(crate) fn space(name: &str) -> Option<Space> {
    Some(match name {
        "rgb" | "RGB" | "linear" => Space::Rgb,
        "hsv" => Space::Hsv,
        "hsl" => Space::Hsl,
        "YIQ" => Space::Yiq,
        "XYZ" => Space::Xyz,
        "xyY" => Space::XyY,
        "sRGB" => Space::Srgb,
        _ => return None,
    })
}

/// `c` (a color in `from`) in `to`.
pub(crate) fn transform(b: &mut Builder, from: Space, to: Space, c: Value) -> Value {
    if from == to {
        return c;
    }
    let rgb = to_rgb(b, from, c);
    from_rgb(b, to, rgb)
}

/// `c` (a color in `space`) in linear RGB.
pub(crate) fn to_rgb(b: &mut Builder, space: Space, c: Value) -> Value {
    match space {
        Space::Rgb => c,
        Space::Hsv => b.call(Intrinsic::HsvToRgb, &[c]),
        Space::Hsl => hsl_to_rgb(b, c),
        Space::Yiq => row_times(b, c, YIQ_TO_RGB),
        Space::Xyz => row_times(b, c, xyz_to_rgb_rows()),
        Space::XyY => {
            let xyz = xyy_to_xyz(b, c);
            row_times(b, xyz, xyz_to_rgb_rows())
        }
        Space::Srgb => componentwise(b, c, Ty::Color, srgb_to_linear),
    }
}

/// `c` (linear RGB) in `space`.
pub(crate) fn from_rgb(b: &mut Builder, space: Space, c: Value) -> Value {
    match space {
        Space::Rgb => c,
        Space::Hsv => b.call(Intrinsic::RgbToHsv, &[c]),
        Space::Hsl => rgb_to_hsl(b, c),
        Space::Yiq => row_times(b, c, RGB_TO_YIQ),
        Space::Xyz => row_times(b, c, rgb_to_xyz_rows()),
        Space::XyY => {
            let xyz = row_times(b, c, rgb_to_xyz_rows());
            xyz_to_xyy(b, xyz)
        }
        Space::Srgb => componentwise(b, c, Ty::Color, linear_to_srgb),
    }
}

/// OSL's YIQ → RGB matrix, applied to a row vector (`c · M`).
const YIQ_TO_RGB: [[f64; 3]; 3] = [
    [1.0000, 1.0000, 1.0000],
    [0.9557, -0.2716, -1.1082],
    [0.6199, -0.6469, 1.7051],
];

/// OSL's RGB → YIQ matrix, applied to a row vector.
const RGB_TO_YIQ: [[f64; 3]; 3] = [
    [0.299, 0.596, 0.212],
    [0.587, -0.275, -0.523],
    [0.114, -0.321, 0.311],
];

/// The XYZ → RGB matrix as a row-vector matrix (OSL's `C * m_XYZ2RGB`): the transpose of
/// the column form.
fn xyz_to_rgb_rows() -> [[f64; 3]; 3] {
    let m = super::spectral::xyz_to_rgb();
    std::array::from_fn(|r| std::array::from_fn(|c| m[c][r]))
}

/// The RGB → XYZ matrix as a row-vector matrix.
fn rgb_to_xyz_rows() -> [[f64; 3]; 3] {
    let m = super::spectral::rgb_to_xyz();
    std::array::from_fn(|r| std::array::from_fn(|c| m[c][r]))
}

/// Row vector `c` times `m`: component `k` is `c.x·m[0][k] + c.y·m[1][k] + c.z·m[2][k]`,
/// summed left to right (Imath's order).
fn row_times(b: &mut Builder, c: Value, m: [[f64; 3]; 3]) -> Value {
    let x: [Value; 3] = std::array::from_fn(|i| b.extract(c, i));
    let out: Vec<Value> = (0..3)
        .map(|k| {
            let terms: Vec<Value> = (0..3)
                .map(|i| {
                    let w = b.float(m[i][k]);
                    b.mul(x[i], w)
                })
                .collect();
            let s = b.add(terms[0], terms[1]);
            b.add(s, terms[2])
        })
        .collect();
    b.construct(Type::Color, &out)
}

/// OSL's `hsl_to_rgb`: to hsv (`v = l ≤ ½ ? l(1 + s) : l(1 − s) + s`, `s' = (v − (2l − v)) / v`),
/// then hsv → RGB; black where `v ≤ 0`.
fn hsl_to_rgb(b: &mut Builder, c: Value) -> Value {
    let [h, s, l] = std::array::from_fn(|i| b.extract(c, i));
    let (one, half, two, zero) = (b.float(1.0), b.float(0.5), b.float(2.0), b.float(0.0));
    let low = b.binary(BinOp::Le, l, half);
    let v_low = {
        let t = b.add(one, s);
        b.mul(l, t)
    };
    let v_high = {
        let t = b.sub(one, s);
        let t = b.mul(l, t);
        b.add(t, s)
    };
    let v = b.select(low, v_low, v_high);
    let min = {
        let t = b.mul(two, l);
        b.sub(t, v)
    };
    let s2 = {
        let t = b.sub(v, min);
        b.div(t, v)
    };
    let hsv = b.construct(Type::Color, &[h, s2, v]);
    let rgb = b.call(Intrinsic::HsvToRgb, &[hsv]);
    let black = b.color([0.0; 3]);
    let dark = b.binary(BinOp::Le, v, zero);
    b.select(dark, black, rgb)
}

/// OSL's `rgb_to_hsl`: hue of hsv, `l` the mean of the smallest and largest channel, `s`
/// their difference over `max + min` (`l ≤ ½`) or `2 − max − min`; 0 for a grey.
fn rgb_to_hsl(b: &mut Builder, c: Value) -> Value {
    let [r, g, bl] = std::array::from_fn(|i| b.extract(c, i));
    let min = {
        let t = b.min(g, bl);
        b.min(r, t)
    };
    let hsv = b.call(Intrinsic::RgbToHsv, &[c]);
    let (h, max) = (b.extract(hsv, 0), b.extract(hsv, 2));
    let (half, two, zero) = (b.float(0.5), b.float(2.0), b.float(0.0));
    let l = {
        let t = b.add(min, max);
        b.div(t, two)
    };
    let low = b.binary(BinOp::Le, l, half);
    let spread = b.sub(max, min);
    let below = b.add(max, min);
    let above = {
        let t = b.sub(two, max);
        b.sub(t, min)
    };
    let divisor = b.select(low, below, above);
    let s = b.div(spread, divisor);
    let grey = b.binary(BinOp::Eq, min, max);
    let s = b.select(grey, zero, s);
    b.construct(Type::Color, &[h, s, l])
}

/// OSL's `xyY_to_XYZ`: `Y / y` (0 where `y ≤ 10⁻⁶`) times `x` and `1 − x − y`.
fn xyy_to_xyz(b: &mut Builder, c: Value) -> Value {
    let [x, y, yy] = std::array::from_fn(|i| b.extract(c, i));
    let (eps, zero, one) = (b.float(1.0e-6), b.float(0.0), b.float(1.0));
    let ok = b.binary(BinOp::Gt, y, eps);
    let ratio = b.div(yy, y);
    let y_y = b.select(ok, ratio, zero);
    let big_x = b.mul(y_y, x);
    let z = {
        let t = b.sub(one, x);
        let t = b.sub(t, y);
        b.mul(y_y, t)
    };
    b.construct(Type::Color, &[big_x, yy, z])
}

/// OSL's `XYZ_to_xyY`: `X` and `Y` over `X + Y + Z` (0 where the sum is below 10⁻⁶), then `Y`.
fn xyz_to_xyy(b: &mut Builder, c: Value) -> Value {
    let [x, y, z] = std::array::from_fn(|i| b.extract(c, i));
    let (eps, zero, one) = (b.float(1.0e-6), b.float(0.0), b.float(1.0));
    let n = {
        let t = b.add(x, y);
        b.add(t, z)
    };
    let ok = b.binary(BinOp::Ge, n, eps);
    let inv = b.div(one, n);
    let inv = b.select(ok, inv, zero);
    let (cx, cy) = (b.mul(x, inv), b.mul(y, inv));
    b.construct(Type::Color, &[cx, cy, y])
}

/// sRGB's decoding: `x / 12.92` up to 0.04045, `((x + 0.055) / 1.055)^2.4` above.
fn srgb_to_linear(b: &mut Builder, x: Value) -> Value {
    let lin = {
        let k = b.float(1.0 / 12.92);
        b.mul(x, k)
    };
    let curve = {
        let (a, k, e) = (b.float(0.055), b.float(1.0 / 1.055), b.float(2.4));
        let t = b.add(x, a);
        let t = b.mul(t, k);
        b.binary(BinOp::Pow, t, e)
    };
    let edge = b.float(0.04045);
    let low = b.binary(BinOp::Le, x, edge);
    b.select(low, lin, curve)
}

/// sRGB's encoding: `12.92·x` up to 0.0031308, `1.055·x^(1/2.4) − 0.055` above.
fn linear_to_srgb(b: &mut Builder, x: Value) -> Value {
    let lin = {
        let k = b.float(12.92);
        b.mul(k, x)
    };
    let curve = {
        let (k, e, a) = (b.float(1.055), b.float(1.0 / 2.4), b.float(0.055));
        let t = b.binary(BinOp::Pow, x, e);
        let t = b.mul(k, t);
        b.sub(t, a)
    };
    let edge = b.float(0.0031308);
    let low = b.binary(BinOp::Le, x, edge);
    b.select(low, lin, curve)
}
