//! OSL's colour spaces (issue 22): `transformc(from, to, c)` and `color("space", …)` with
//! every space OSL's colour system knows — rgb, hsv, hsl, YIQ, XYZ, xyY and (transformc)
//! sRGB — checked against values computed here from the definitions (OSL's
//! `opcolor_impl.h` formulas, the Rec. 709 / D65 primaries, published constants) and by
//! round trips, in f32 and f64, and the JIT bit for bit with the interpreter.

mod common;
use common::*;
use shadenet::lang::Dialect;

/// The D65 white point's XYZ at Y = 1 (x = 0.3127, y = 0.3290).
const D65: [f64; 3] = [0.3127 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290];

#[test]
fn color_spaces_are_osls() {
    // XYZ: RGB white is the D65 white; red is the first primary's XYZ scaled, whose
    // chromaticity is Rec. 709's (0.64, 0.33) and whose Y is Rec. 709's luma weight.
    osl_close("out = transformc(\"rgb\", \"XYZ\", color(1));", D65, 1e-6);
    let (red, _) = shade_osl_body("out = transformc(\"rgb\", \"XYZ\", color(1, 0, 0));");
    let sum: f64 = red.iter().sum();
    assert!((red[0] / sum - 0.64).abs() < 1e-6, "{red:?}");
    assert!((red[1] / sum - 0.33).abs() < 1e-6, "{red:?}");
    assert!((red[1] - 0.2126).abs() < 1e-4, "{red:?}");
    // xyY of the white: the white's chromaticity, luminance 1; black stays 0 (the guard).
    osl_close(
        "out = transformc(\"rgb\", \"xyY\", color(1));",
        [0.3127, 0.3290, 1.0],
        1e-6,
    );
    osl_close(
        "out = transformc(\"rgb\", \"xyY\", color(0));",
        [0.0; 3],
        0.0,
    );
    osl_close(
        "out = transformc(\"xyY\", \"rgb\", color(0.3127, 0.3290, 1));",
        [1.0; 3],
        1e-5,
    );
    // YIQ: OSL's matrix rows.
    osl_close(
        "out = transformc(\"rgb\", \"YIQ\", color(1, 0, 0));",
        [0.299, 0.596, 0.212],
        1e-6,
    );
    osl_close("out = color(\"YIQ\", 1, 0, 0);", [1.0; 3], 1e-6);
    // hsl: pure red is hue 0, saturation 1, lightness ½; a dark and a light colour take
    // the two saturation formulas; a grey has saturation 0.
    osl_close(
        "out = transformc(\"rgb\", \"hsl\", color(1, 0, 0));",
        [0.0, 1.0, 0.5],
        1e-6,
    );
    osl_close(
        "out = transformc(\"rgb\", \"hsl\", color(0.1, 0.2, 0.4));",
        [0.6111111, 0.6, 0.25],
        1e-6,
    );
    osl_close(
        "out = transformc(\"rgb\", \"hsl\", color(0.6, 0.8, 0.9));",
        [0.5555556, 0.6, 0.75],
        1e-6,
    );
    osl_close(
        "out = transformc(\"rgb\", \"hsl\", color(0.3));",
        [0.0, 0.0, 0.3],
        1e-7,
    );
    osl_close("out = color(\"hsl\", 0, 1, 0.5);", [1.0, 0.0, 0.0], 1e-6);
    osl_close("out = color(\"hsl\", 0.5, 0.5, 0);", [0.0; 3], 0.0);
    // sRGB: the transfer function's two pieces.
    osl_close(
        "out = transformc(\"sRGB\", \"rgb\", color(0.5, 0.04, 1));",
        [0.2140411, 0.04 / 12.92, 1.0],
        1e-6,
    );
    osl_close(
        "out = transformc(\"linear\", \"sRGB\", color(0.2140411, 0.001, 0));",
        [0.5, 0.01292, 0.0],
        1e-6,
    );
    // Round trips through every space (OSL's YIQ matrices are 4-digit inverses of each
    // other: 5·10⁻⁵ there).
    for s in ["hsv", "hsl", "YIQ", "XYZ", "xyY", "sRGB", "RGB"] {
        let tol = if s == "YIQ" { 5e-5 } else { 2e-6 };
        osl_close(
            &format!(
                "out = transformc(\"{s}\", \"rgb\", transformc(\"rgb\", \"{s}\", color(0.2, 0.5, 0.7)));"
            ),
            [0.2, 0.5, 0.7],
            tol,
        );
        osl_close(
            &format!(
                "out = transformc(\"XYZ\", \"{s}\", transformc(\"{s}\", \"XYZ\", color(0.3, 0.4, 0.2)));"
            ),
            [0.3, 0.4, 0.2],
            tol.max(4e-6),
        );
    }
}

/// The conversions lower to IR arithmetic the JIT runs bit for bit as the interpreter.
#[test]
fn color_spaces_run_on_the_jit_as_on_the_interpreter() {
    let src = r#"shader s(output color out = 0) {
        color c = color(u, v, 0.5 * u + 0.25);
        out = transformc("rgb", "hsl", c) + transformc("xyY", "rgb", color(0.3, 0.3, v))
            + color("YIQ", u, 0.1, -0.1) + transformc("sRGB", "XYZ", c);
    }"#;
    let p = compile_shader(src, Dialect::Osl).unwrap();
    assert_jit_is_interp(&p, 7, 5);
}

#[test]
fn unknown_color_spaces_are_errors() {
    for (body, want) in [
        (
            "color c = transformc(\"rgb\", \"lab\", color(1));",
            "`transformc`: unknown color space \"lab\"",
        ),
        (
            "color c = color(\"cmyk\", 1, 0, 0);",
            "unknown color space \"cmyk\"",
        ),
        (
            "point p = point(\"hsv\", 1, 0, 0);",
            "the space \"hsv\" is not available here",
        ),
    ] {
        let err = compile_shader(&format!("surface s() {{ {body} }}"), Dialect::Osl).unwrap_err();
        assert!(err.contains(want), "{body}\n→ {err}");
    }
}
