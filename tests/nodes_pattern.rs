//! Pattern nodes (`checker`, `checker3d`, `ramp`, `noise`, `solidNoise`, `fractal`,
//! `cellNoise`) against hand-computed values and independent oracles, on ordinary and hard
//! inputs, in f32 and f64.
mod common;
use common::*;
use shadenet_graph::ir::{Builder, Stream};
use shadenet_graph::lower::{Literal, declare_output, lower_single};
use shadenet_graph::nodes::{InputVal, LowVal, NodeInputs, NodeLibrary};
use shadenet_graph::ops::noise;
use shadenet_graph::types::{ConstValue, Type};
use shadenet_runtime::Fragment;

// ---- harness shorthands ----

fn frag_uv(u: f32, v: f32) -> Fragment {
    let mut frag = plane_fragment();
    frag.uv = [u, v];
    frag
}

fn frag_p(x: f32, y: f32, z: f32) -> Fragment {
    let mut frag = plane_fragment();
    frag.p = [x, y, z];
    frag
}

fn eval(node: &str, inputs: &[(&str, Literal)], frag: &Fragment) -> Outputs {
    eval_node(node, Type::Float, inputs, frag, &[])
}

fn int(i: i32) -> Literal {
    Literal::Const(ConstValue::Int(i))
}

/// A ramp `keys` literal from (position, color) pairs.
fn keys(ks: &[(f64, [f64; 3])]) -> Literal {
    Literal::Array(
        ks.iter()
            .map(|(p, c)| vec![ConstValue::Float(*p), ConstValue::Color(*c)])
            .collect(),
    )
}

/// Rec. 709 luminance, as the nodes document it.
fn luma(c: &[f64]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

const WHITE: [f64; 3] = [1.0, 1.0, 1.0];
const BLACK: [f64; 3] = [0.0, 0.0, 0.0];
const RED: [f64; 3] = [1.0, 0.0, 0.0];
const GREEN: [f64; 3] = [0.0, 1.0, 0.0];
const BLUE: [f64; 3] = [0.0, 0.0, 1.0];

/// Nothing was caught by the guard, the f64 value is `want` within `tol` and the f32 value
/// within `tol.max(1e-6)`.
fn expect(o: &Outputs, name: &str, want: &[f64], tol: f64, what: &str) {
    expect_tols(o, name, want, tol, tol.max(1e-6), what);
}

/// As [`expect`] with separate tolerances for the f64 and the f32 run.
fn expect_tols(o: &Outputs, name: &str, want: &[f64], tol64: f64, tol32: f64, what: &str) {
    assert_eq!(o.nonfinite32, 0, "{what}: guard caught non-finite values");
    assert_close(&o.get(name), want, tol64, &format!("{what} (f64) {name}"));
    assert_close(&o.get32(name), want, tol32, &format!("{what} (f32) {name}"));
}

/// A deterministic sweep of `n` values in [lo, hi) (a fixed linear congruential sequence,
/// rounded to f32).
fn sweep(n: usize, lo: f64, hi: f64, seed: u64) -> Vec<f32> {
    let mut x = seed;
    (0..n)
        .map(|_| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let r = (x >> 11) as f64 / (1u64 << 53) as f64;
            (lo + (hi - lo) * r) as f32
        })
        .collect()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

// ---- checker ----

/// Independent formulation of the documented cell rule (Maya's "lower half of the repeat in
/// u equals lower half in v"): color1 iff `fract(u) < 0.5` agrees with `fract(v) < 0.5`.
fn checker_is_color1(u: f64, v: f64) -> bool {
    let lower = |x: f64| x - x.floor() < 0.5;
    lower(u) == lower(v)
}

#[test]
fn checker_cells_by_hand() {
    // (u, v, color1?)
    let cases = [
        (0.25, 0.25, true),
        (0.75, 0.25, false),
        (0.25, 0.75, false),
        (0.75, 0.75, true),
        (1.25, 0.25, true),
        (1.75, 0.25, false),
        // negative uv continues the pattern
        (-0.25, 0.25, false),
        (-0.25, -0.25, true),
        (-0.75, 0.25, true),
        (-1.25, -3.75, false),
        // exact edges belong to the check above / to the right
        (0.0, 0.0, true),
        (0.5, 0.0, false),
        (0.5, 0.5, true),
        (1.0, 0.25, true),
        (0.25, 0.5, false),
        (-0.5, 0.25, false),
        (-0.5, -0.5, true),
        // just below an edge
        (-1e-7, 0.25, false),
        (0.499_999_97, 0.25, true),
    ];
    for (u, v, first) in cases {
        let o = eval("checker", &[], &frag_uv(u, v));
        let want = if first { WHITE } else { BLACK };
        expect(
            &o,
            "outColor",
            &want,
            0.0,
            &format!("checker at ({u}, {v})"),
        );
        expect(
            &o,
            "outAlpha",
            &[luma(&want)],
            1e-15,
            &format!("checker alpha at ({u}, {v})"),
        );
    }
}

#[test]
fn checker_matches_independent_rule_on_a_sweep() {
    let us = sweep(300, -5.0, 5.0, 1);
    let vs = sweep(300, -5.0, 5.0, 2);
    for (&u, &v) in us.iter().zip(&vs) {
        let o = eval(
            "checker",
            &[("color1", c(0.2, 0.4, 0.6)), ("color2", c(0.9, 0.1, 0.0))],
            &frag_uv(u, v),
        );
        let want = if checker_is_color1(u as f64, v as f64) {
            [0.2, 0.4, 0.6]
        } else {
            [0.9, 0.1, 0.0]
        };
        assert_close(
            &o.get("outColor"),
            &want,
            0.0,
            &format!("checker at ({u}, {v})"),
        );
    }
}

#[test]
fn checker_contrast_blends_towards_the_average() {
    let colors = [("color1", c(1.0, 0.0, 0.0)), ("color2", c(0.0, 0.0, 1.0))];
    // contrast 0.5: avg (0.5, 0, 0.5) + 0.5 (check − avg)
    for (u, want) in [(0.25, [0.75, 0.0, 0.25]), (0.75, [0.25, 0.0, 0.75])] {
        let mut inputs = colors.to_vec();
        inputs.push(("contrast", f(0.5)));
        let o = eval("checker", &inputs, &frag_uv(u, 0.25));
        expect(&o, "outColor", &want, 1e-15, "contrast 0.5");
        expect(&o, "outAlpha", &[luma(&want)], 1e-15, "contrast 0.5 alpha");
    }
    // contrast 0: the average everywhere
    for u in [0.25, 0.75] {
        let mut inputs = colors.to_vec();
        inputs.push(("contrast", f(0.0)));
        let o = eval("checker", &inputs, &frag_uv(u, 0.25));
        expect(&o, "outColor", &[0.5, 0.0, 0.5], 0.0, "contrast 0");
    }
}

#[test]
fn checker_non_finite_uv_gives_a_check_color() {
    // A NaN coordinate converts to cell index 0 (documented); nothing reaches the guard.
    for (u, v) in [(f32::NAN, 0.25), (0.25, f32::NAN), (f32::NAN, f32::NAN)] {
        let o = eval("checker", &[], &frag_uv(u, v));
        // The check of the point with each NaN coordinate replaced by 0.
        let uu = if u.is_nan() { 0.0 } else { u as f64 };
        let vv = if v.is_nan() { 0.0 } else { v as f64 };
        let want = if checker_is_color1(uu, vv) {
            WHITE
        } else {
            BLACK
        };
        expect(
            &o,
            "outColor",
            &want,
            0.0,
            &format!("checker at ({u}, {v})"),
        );
    }
    // ±inf and huge: saturated cells; always one of the two colors, finite.
    for (u, v) in [
        (f32::INFINITY, 0.25),
        (f32::NEG_INFINITY, 0.25),
        (f32::INFINITY, f32::INFINITY),
        (1e30, -1e30),
        (3e38, 0.25),
    ] {
        let o = eval("checker", &[], &frag_uv(u, v));
        assert_eq!(o.nonfinite32, 0, "checker at ({u}, {v})");
        let got = o.get("outColor");
        assert!(
            got == WHITE || got == BLACK,
            "checker at ({u}, {v}): {got:?}"
        );
        assert_eq!(
            o.get32("outColor"),
            got,
            "checker at ({u}, {v}): f32 vs f64"
        );
    }
}

/// f32 vs f64: the cell choice is exact in both (uv is f32 and `2u` is exact), so only the
/// contrast blend rounds: bound 1e-6 (a few f32 ulps of values ≤ 1).
#[test]
fn checker_f32_matches_f64() {
    let us = sweep(200, -3.0, 3.0, 3);
    let vs = sweep(200, -3.0, 3.0, 4);
    let mut worst: f64 = 0.0;
    for (&u, &v) in us.iter().zip(&vs) {
        let o = eval(
            "checker",
            &[
                ("color1", c(0.9, 0.3, 0.7)),
                ("color2", c(0.1, 0.6, 0.2)),
                ("contrast", f(0.3)),
            ],
            &frag_uv(u, v),
        );
        worst = worst.max(max_diff(&o.get("outColor"), &o.get32("outColor")));
        worst = worst.max(max_diff(&o.get("outAlpha"), &o.get32("outAlpha")));
    }
    assert!(worst <= 1e-6, "checker f32 vs f64: {worst}");
}

// ---- checker3d ----

/// Independent rule: color1 iff the integer cell of `p · scale` has an even index sum.
fn checker3d_is_color1(p: [f64; 3], scale: f64) -> bool {
    let s: i64 = p.iter().map(|x| (x * scale).floor() as i64).sum();
    s.rem_euclid(2) == 0
}

#[test]
fn checker3d_cells_by_hand() {
    let cases = [
        ([0.5, 0.5, 0.5], 1.0, true),
        ([1.5, 0.5, 0.5], 1.0, false),
        ([1.5, 1.5, 0.5], 1.0, true),
        ([1.5, 1.5, 1.5], 1.0, false),
        ([-0.5, 0.5, 0.5], 1.0, false),
        ([-0.5, -0.5, 0.5], 1.0, true),
        // faces belong to the cell on their positive side
        ([0.0, 0.0, 0.0], 1.0, true),
        ([1.0, 0.0, 0.0], 1.0, false),
        ([0.0, -1.0, 0.0], 1.0, false),
        // scale 2: checks of side 0.5
        ([0.4, 0.0, 0.0], 2.0, true),
        ([0.6, 0.0, 0.0], 2.0, false),
        ([0.6, 0.6, 0.0], 2.0, true),
        // scale 0: everything in cell 0
        ([7.3, -2.2, 5.5], 0.0, true),
    ];
    for (p, scale, first) in cases {
        let frag = frag_p(p[0] as f32, p[1] as f32, p[2] as f32);
        let o = eval("checker3d", &[("scale", f(scale))], &frag);
        let want = if first { WHITE } else { BLACK };
        expect(
            &o,
            "outColor",
            &want,
            0.0,
            &format!("checker3d at {p:?} × {scale}"),
        );
        expect(&o, "outAlpha", &[luma(&want)], 1e-15, "checker3d alpha");
    }
}

#[test]
fn checker3d_matches_independent_rule_on_a_sweep() {
    let xs = sweep(200, -4.0, 4.0, 5);
    let ys = sweep(200, -4.0, 4.0, 6);
    let zs = sweep(200, -4.0, 4.0, 7);
    for i in 0..200 {
        let p = [xs[i] as f64, ys[i] as f64, zs[i] as f64];
        let o = eval(
            "checker3d",
            &[
                ("scale", f(2.0)),
                ("color1", c(0.1, 0.2, 0.3)),
                ("color2", c(0.7, 0.8, 0.9)),
            ],
            &frag_p(xs[i], ys[i], zs[i]),
        );
        let want = if checker3d_is_color1(p, 2.0) {
            [0.1, 0.2, 0.3]
        } else {
            [0.7, 0.8, 0.9]
        };
        assert_close(
            &o.get("outColor"),
            &want,
            0.0,
            &format!("checker3d at {p:?}"),
        );
    }
}

#[test]
fn checker3d_hard_inputs_give_a_check_color() {
    // NaN → cell index 0 in that axis.
    let o = eval("checker3d", &[], &frag_p(f32::NAN, f32::NAN, f32::NAN));
    expect(&o, "outColor", &WHITE, 0.0, "checker3d at NaN");
    let o = eval("checker3d", &[], &frag_p(f32::NAN, 1.5, 0.5));
    expect(&o, "outColor", &BLACK, 0.0, "checker3d at (NaN, 1.5, 0.5)");
    for p in [
        [f32::INFINITY, 0.0, 0.0],
        [1e30, -1e30, 3e38],
        [f32::NEG_INFINITY, f32::INFINITY, 0.5],
    ] {
        let o = eval(
            "checker3d",
            &[("scale", f(10.0))],
            &frag_p(p[0], p[1], p[2]),
        );
        assert_eq!(o.nonfinite32, 0, "checker3d at {p:?}");
        let got = o.get("outColor");
        assert!(got == WHITE || got == BLACK, "checker3d at {p:?}: {got:?}");
        assert_eq!(o.get32("outColor"), got, "checker3d at {p:?}: f32 vs f64");
    }
}

/// f32 vs f64 with a scale that rounds (1.3): away from cell faces (farther than 1e-5 in the
/// scaled coordinate) both pick the same cell, so the colors agree exactly.
#[test]
fn checker3d_f32_matches_f64_away_from_faces() {
    let xs = sweep(300, -6.0, 6.0, 8);
    let ys = sweep(300, -6.0, 6.0, 9);
    let zs = sweep(300, -6.0, 6.0, 10);
    let mut compared = 0;
    for i in 0..300 {
        let p = [xs[i] as f64, ys[i] as f64, zs[i] as f64];
        let near_face = p.iter().any(|x| {
            let q = x * 1.3;
            (q - q.round()).abs() < 1e-5
        });
        if near_face {
            continue;
        }
        compared += 1;
        let o = eval(
            "checker3d",
            &[("scale", f(1.3))],
            &frag_p(xs[i], ys[i], zs[i]),
        );
        assert_eq!(o.get("outColor"), o.get32("outColor"), "checker3d at {p:?}");
    }
    assert!(compared > 250);
}

// ---- ramp ----

fn ramp(inputs: &[(&str, Literal)], u: f32, v: f32) -> Outputs {
    eval("ramp", inputs, &frag_uv(u, v))
}

/// Evaluates a black → white linear ramp of `type`, so the output grey is the parameter t
/// clamped to [0, 1].
fn ramp_t(ty: &str, u: f32, v: f32) -> f64 {
    let o = ramp(
        &[
            ("type", s(ty)),
            ("keys", keys(&[(0.0, BLACK), (1.0, WHITE)])),
        ],
        u,
        v,
    );
    assert_eq!(o.nonfinite32, 0);
    let c = o.get("outColor");
    assert!(c[0] == c[1] && c[1] == c[2], "{ty}: not grey: {c:?}");
    c[0]
}

#[test]
fn ramp_types_compute_the_documented_parameter() {
    // v, u, diagonal: dyadic coordinates, exact.
    assert_eq!(ramp_t("v", 0.375, 0.875), 0.875);
    assert_eq!(ramp_t("u", 0.375, 0.875), 0.375);
    assert_eq!(ramp_t("diagonal", 0.375, 0.875), 0.625);
    // radial: the angle of uv − (0.5, 0.5) counter-clockwise from +u, over 2π.
    let tol = 1e-12;
    assert!((ramp_t("radial", 0.75, 0.5) - 0.0).abs() <= tol);
    assert!((ramp_t("radial", 0.5, 0.75) - 0.25).abs() <= tol);
    assert!((ramp_t("radial", 0.25, 0.5) - 0.5).abs() <= tol);
    assert!((ramp_t("radial", 0.5, 0.25) - 0.75).abs() <= tol);
    assert!((ramp_t("radial", 0.5, 0.5) - 0.0).abs() <= tol, "center");
    // (−0.125, 0.375): second quadrant, angle π − atan(3).
    let want = (std::f64::consts::PI - 3f64.atan()) / std::f64::consts::TAU;
    assert!((ramp_t("radial", 0.375, 0.875) - want).abs() <= tol);
    // just below the seam (angle slightly less than 2π): t close to but below 1.
    let t = ramp_t("radial", 0.75, 0.499_999_97);
    assert!(t > 0.999_999 && t < 1.0, "radial just below the seam: {t}");
    // circular: 2·distance to the center; 1 at each edge midpoint.
    assert!((ramp_t("circular", 0.5, 0.5) - 0.0).abs() <= tol);
    assert!((ramp_t("circular", 0.5, 0.0) - 1.0).abs() <= tol);
    assert!((ramp_t("circular", 1.0, 0.5) - 1.0).abs() <= tol);
    assert!((ramp_t("circular", 0.625, 0.5) - 0.25).abs() <= tol);
    let want = 2.0 * (0.125f64 * 0.125 + 0.375 * 0.375).sqrt();
    assert!((ramp_t("circular", 0.375, 0.875) - want).abs() <= tol);
    // corner: √2, above the last key → the last key's color.
    assert_eq!(ramp_t("circular", 1.0, 1.0), 1.0);
}

#[test]
fn ramp_radial_parameter_stays_in_unit_interval() {
    // With keys (0, black) (1, white) and t ∈ [0, 1) the output is t; it must never reach
    // the last key's full white through a t of exactly 1.
    let us = sweep(300, 0.0, 1.0, 11);
    let vs = sweep(300, 0.0, 1.0, 12);
    for (&u, &v) in us.iter().zip(&vs) {
        let o = ramp(
            &[
                ("type", s("radial")),
                ("keys", keys(&[(0.0, BLACK), (1.0, WHITE)])),
            ],
            u,
            v,
        );
        for t in [o.get("outColor")[0], o.get32("outColor")[0]] {
            assert!((0.0..1.0).contains(&t), "radial t at ({u}, {v}) = {t}");
        }
        let want = {
            let a = ((v as f64) - 0.5).atan2((u as f64) - 0.5) / std::f64::consts::TAU;
            if a < 0.0 { a + 1.0 } else { a }
        };
        assert!(
            (o.get("outColor")[0] - want).abs() < 1e-12,
            "radial at ({u}, {v})"
        );
    }
}

#[test]
fn ramp_linear_interpolation_by_hand() {
    let k = keys(&[(0.0, RED), (0.5, GREEN), (1.0, BLUE)]);
    let cases: [(f32, [f64; 3]); 7] = [
        (0.0, RED),
        (0.125, [0.75, 0.25, 0.0]),
        (0.25, [0.5, 0.5, 0.0]),
        (0.5, GREEN),
        (0.75, [0.0, 0.5, 0.5]),
        (1.0, BLUE),
        (0.875, [0.0, 0.25, 0.75]),
    ];
    for (t, want) in cases {
        let o = ramp(&[("keys", k.clone())], 0.0, t);
        expect(&o, "outColor", &want, 1e-15, &format!("linear ramp at {t}"));
        expect(
            &o,
            "outAlpha",
            &[luma(&want)],
            1e-15,
            &format!("linear ramp alpha at {t}"),
        );
    }
}

#[test]
fn ramp_none_is_a_step_from_the_lower_key() {
    let k = keys(&[(0.0, RED), (0.5, GREEN), (1.0, BLUE)]);
    for (t, want) in [
        (-1.0, RED),
        (0.0, RED),
        (0.25, RED),
        (0.499_999_97, RED),
        (0.5, GREEN),
        (0.75, GREEN),
        (1.0, BLUE),
        (2.0, BLUE),
    ] {
        let o = ramp(&[("interpolation", s("none")), ("keys", k.clone())], 0.0, t);
        expect(&o, "outColor", &want, 0.0, &format!("step ramp at {t}"));
    }
}

#[test]
fn ramp_smooth_uses_smoothstep_weights() {
    let k = keys(&[(0.0, BLACK), (1.0, WHITE)]);
    for t in [0.0f32, 0.125, 0.25, 0.5, 0.75, 0.9, 1.0] {
        let w = t as f64;
        let want = w * w * (3.0 - 2.0 * w);
        let o = ramp(
            &[("interpolation", s("smooth")), ("keys", k.clone())],
            0.0,
            t,
        );
        expect(
            &o,
            "outColor",
            &[want; 3],
            1e-15,
            &format!("smooth ramp at {t}"),
        );
    }
    // a segment that does not start at 0: keys at 0.25 and 0.75, t = 0.375 → w = 0.25
    let k = keys(&[(0.25, RED), (0.75, BLUE)]);
    let o = ramp(&[("interpolation", s("smooth")), ("keys", k)], 0.0, 0.375);
    let w = 0.25 * 0.25 * (3.0 - 0.5);
    expect(
        &o,
        "outColor",
        &[1.0 - w, 0.0, w],
        1e-15,
        "smooth ramp mid-segment",
    );
}

#[test]
fn ramp_outside_the_keys_holds_the_end_colors() {
    let k = keys(&[(0.25, RED), (0.75, BLUE)]);
    for (t, want) in [
        (-3.0, RED),
        (0.0, RED),
        (0.25, RED),
        (0.75, BLUE),
        (1.0, BLUE),
        (7.5, BLUE),
    ] {
        for interp in ["none", "linear", "smooth"] {
            let o = ramp(&[("interpolation", s(interp)), ("keys", k.clone())], 0.0, t);
            expect(&o, "outColor", &want, 0.0, &format!("{interp} ramp at {t}"));
        }
    }
    // positions outside [0, 1] are fine too
    let k = keys(&[(-1.0, BLACK), (3.0, WHITE)]);
    let o = ramp(&[("keys", k)], 0.0, 0.0);
    expect(&o, "outColor", &[0.25; 3], 1e-15, "keys outside [0, 1]");
}

#[test]
fn ramp_unsorted_constant_keys_are_sorted() {
    let sorted = keys(&[(0.0, RED), (0.5, GREEN), (1.0, BLUE)]);
    let unsorted = keys(&[(1.0, BLUE), (0.0, RED), (0.5, GREEN)]);
    let reversed = keys(&[(1.0, BLUE), (0.5, GREEN), (0.0, RED)]);
    for interp in ["none", "linear", "smooth"] {
        for t in [-0.5f32, 0.0, 0.1, 0.25, 0.5, 0.6, 0.75, 1.0, 1.5] {
            let want = ramp(
                &[("interpolation", s(interp)), ("keys", sorted.clone())],
                0.0,
                t,
            );
            for k in [&unsorted, &reversed] {
                let got = ramp(&[("interpolation", s(interp)), ("keys", k.clone())], 0.0, t);
                assert_eq!(got.get("outColor"), want.get("outColor"), "{interp} at {t}");
                assert_eq!(
                    got.get32("outColor"),
                    want.get32("outColor"),
                    "{interp} at {t}"
                );
            }
        }
    }
    // and by hand: unsorted, linear, t = 0.75 → halfway green → blue
    let o = ramp(&[("keys", unsorted)], 0.0, 0.75);
    expect(&o, "outColor", &[0.0, 0.5, 0.5], 1e-15, "unsorted by hand");
}

#[test]
fn ramp_duplicate_positions_later_key_wins() {
    let k = keys(&[(0.0, RED), (0.5, GREEN), (0.5, WHITE), (1.0, BLUE)]);
    for (t, want) in [
        (0.25, [0.5, 0.5, 0.0]),
        (0.5, WHITE),
        (0.75, [0.5, 0.5, 1.0]),
        (1.0, BLUE),
    ] {
        let o = ramp(&[("keys", k.clone())], 0.0, t);
        expect(
            &o,
            "outColor",
            &want,
            1e-15,
            &format!("duplicate keys at {t}"),
        );
    }
    // just below the shared position: still approaching the earlier key's green
    let o = ramp(&[("keys", k.clone())], 0.0, 0.499_999_97);
    let c = o.get("outColor");
    assert!(c[1] > 0.999_99 && c[2] == 0.0, "below the duplicate: {c:?}");
    // every key at one position: a step at that position to the last key
    let k = keys(&[(0.5, RED), (0.5, GREEN), (0.5, BLUE)]);
    for interp in ["none", "linear", "smooth"] {
        for (t, want) in [(0.0, RED), (0.499_999_97, RED), (0.5, BLUE), (1.0, BLUE)] {
            let o = ramp(&[("interpolation", s(interp)), ("keys", k.clone())], 0.0, t);
            expect(
                &o,
                "outColor",
                &want,
                0.0,
                &format!("{interp}, all keys at 0.5, t = {t}"),
            );
        }
    }
    // unsorted with duplicates: the sort is stable, so the later of the two 0.5 keys in the
    // given order (green) wins.
    let k = keys(&[(0.5, WHITE), (1.0, BLUE), (0.0, RED), (0.5, GREEN)]);
    let o = ramp(&[("keys", k.clone())], 0.0, 0.5);
    expect(&o, "outColor", &GREEN, 0.0, "stable sort of duplicates");
    let o = ramp(&[("keys", k)], 0.0, 0.75);
    expect(
        &o,
        "outColor",
        &[0.0, 0.5, 0.5],
        1e-15,
        "after the duplicates",
    );
}

#[test]
fn ramp_duplicates_never_produce_non_finite_values() {
    let k = keys(&[
        (0.3, RED),
        (0.3, GREEN),
        (0.3, BLUE),
        (0.7, WHITE),
        (0.7, BLACK),
    ]);
    for interp in ["none", "linear", "smooth"] {
        for t in sweep(100, -0.5, 1.5, 13).into_iter().chain([0.3, 0.7]) {
            let o = ramp(&[("interpolation", s(interp)), ("keys", k.clone())], 0.0, t);
            assert_eq!(o.nonfinite32, 0, "{interp} at {t}");
            for x in o.get("outColor").into_iter().chain(o.get("outAlpha")) {
                // mixing colors in [0, 1] stays in [0, 1] up to rounding
                assert!(
                    x.is_finite() && (-1e-12..=1.0 + 1e-12).contains(&x),
                    "{interp} at {t}: {x}"
                );
            }
        }
    }
}

#[test]
fn ramp_single_key_and_no_keys() {
    for t in [-5.0f32, 0.0, 0.3, 0.9, 1.0, 4.0] {
        for interp in ["none", "linear", "smooth"] {
            let k = keys(&[(0.3, [0.2, 0.4, 0.8])]);
            let o = ramp(&[("interpolation", s(interp)), ("keys", k)], 0.0, t);
            expect(
                &o,
                "outColor",
                &[0.2, 0.4, 0.8],
                0.0,
                &format!("single key at {t}"),
            );
            let o = ramp(&[("interpolation", s(interp))], 0.0, t);
            expect(&o, "outColor", &BLACK, 0.0, &format!("no keys at {t}"));
            expect(
                &o,
                "outAlpha",
                &[0.0],
                0.0,
                &format!("no keys alpha at {t}"),
            );
        }
    }
}

#[test]
fn ramp_non_finite_parameter() {
    let k = keys(&[(0.0, RED), (0.5, GREEN), (1.0, BLUE)]);
    // NaN t: no comparison holds, so the first key's color (documented); finite.
    for ty in ["v", "u", "diagonal", "radial", "circular"] {
        let o = ramp(&[("type", s(ty)), ("keys", k.clone())], f32::NAN, f32::NAN);
        expect(&o, "outColor", &RED, 0.0, &format!("{ty} ramp at NaN"));
    }
    let o = ramp(&[("keys", k.clone())], 0.0, f32::INFINITY);
    expect(&o, "outColor", &BLUE, 0.0, "ramp at +inf");
    let o = ramp(&[("keys", k.clone())], 0.0, f32::NEG_INFINITY);
    expect(&o, "outColor", &RED, 0.0, "ramp at -inf");
    let o = ramp(
        &[("type", s("circular")), ("keys", k.clone())],
        f32::INFINITY,
        0.5,
    );
    expect(&o, "outColor", &BLUE, 0.0, "circular ramp at inf");
    let o = ramp(
        &[("type", s("radial")), ("keys", k)],
        f32::INFINITY,
        f32::INFINITY,
    );
    assert_eq!(o.nonfinite32, 0, "radial ramp at (inf, inf)");
}

#[test]
fn ramp_nan_key_position_is_ignored() {
    let k = keys(&[(f64::NAN, WHITE), (0.0, RED), (1.0, BLUE)]);
    for (t, want) in [(0.0, RED), (0.5, [0.5, 0.0, 0.5]), (1.0, BLUE), (2.0, BLUE)] {
        let o = ramp(&[("keys", k.clone())], 0.0, t);
        expect(&o, "outColor", &want, 1e-15, &format!("NaN key at {t}"));
    }
}

#[test]
fn ramp_rejects_unknown_options_without_panicking() {
    let lib = NodeLibrary::standard();
    let e = lower_single(&lib, "ramp", Type::Float, &[("type", s("box"))]).unwrap_err();
    assert!(e.contains("box"), "{e}");
    let e = lower_single(&lib, "ramp", Type::Float, &[("interpolation", s("cubic"))]).unwrap_err();
    assert!(e.contains("cubic"), "{e}");
}

/// Lowers a ramp whose key positions are *connected* (`time + position`, not constants) and
/// runs it at `t = v` with `time = 0`.
fn ramp_connected(ks: &[(f64, [f64; 3])], interp: &str, t: f32) -> Outputs {
    let lib = NodeLibrary::standard();
    let def = lib.get("ramp").expect("ramp is registered");
    let mut b = Builder::new("ramp");
    let uv = b.stream(Stream::Uv);
    let time = b.stream(Stream::Time);
    let arr = ks
        .iter()
        .map(|(p, col)| {
            let p = b.float(*p);
            let p = b.add(time, p);
            vec![LowVal::plain(p), LowVal::plain(b.color(*col))]
        })
        .collect();
    let inputs = NodeInputs {
        node: "ramp",
        def,
        generic: Type::Float,
        values: vec![
            InputVal::Value(LowVal::plain(uv)),
            InputVal::Str("v".into()),
            InputVal::Str(interp.into()),
            InputVal::Array(arr),
        ],
        upstream: None,
    };
    let outs = (def.lower)(&mut b, &inputs).expect("lowering");
    for (o, lv) in def.outputs.iter().zip(&outs) {
        declare_output(&mut b, o.name, lv);
    }
    let program = b.finish().expect("valid program");
    let mut frag = frag_uv(0.0, t);
    frag.time = 0.0;
    run_program(&program, &frag, &[], u32::MAX)
}

#[test]
fn ramp_connected_positions_use_the_given_order() {
    // Sorted connected keys behave exactly like constant ones.
    let ks = [(0.0, RED), (0.5, GREEN), (1.0, BLUE)];
    for t in [-0.5f32, 0.0, 0.25, 0.5, 0.75, 1.0, 2.0] {
        let want = ramp(&[("keys", keys(&ks))], 0.0, t);
        let got = ramp_connected(&ks, "linear", t);
        assert_eq!(
            got.get("outColor"),
            want.get("outColor"),
            "connected at {t}"
        );
    }
    // Unsorted connected keys are not reordered: the documented rule is "the segment from
    // the last key (in the given order) whose position is ≤ t". Keys (0.8, red), (0.2, blue):
    // below 0.2 → red (first key), from 0.2 on → blue (the last key).
    let ks = [(0.8, RED), (0.2, BLUE)];
    for (t, want) in [
        (0.0, RED),
        (0.1, RED),
        (0.2, BLUE),
        (0.5, BLUE),
        (0.9, BLUE),
    ] {
        let o = ramp_connected(&ks, "linear", t);
        expect(
            &o,
            "outColor",
            &want,
            0.0,
            &format!("unsorted connected at {t}"),
        );
    }
    // duplicate connected positions: still finite, later key wins
    let ks = [(0.0, RED), (0.5, GREEN), (0.5, WHITE), (1.0, BLUE)];
    let o = ramp_connected(&ks, "smooth", 0.5);
    expect(&o, "outColor", &WHITE, 0.0, "duplicate connected keys");
}

/// f32 vs f64 on continuous ramps (linear and smooth; a step ramp can differ by a whole step
/// where t rounds across a key): the parameter, the key positions (0.1 is not an f32) and the
/// weights round in f32, and a segment of width ≥ 0.15 amplifies those roundings at most
/// sevenfold, so bound 2e-6. The radial seam (angle 0, `v = 0.5`, `u > 0.5`) is a jump from
/// the last key to the first, and points within rounding of it land on either side: they are
/// skipped, as lattice boundaries are for noise.
#[test]
fn ramp_f32_matches_f64() {
    let k = keys(&[
        (0.9, [0.1, 0.9, 0.3]),
        (0.1, [0.7, 0.2, 0.5]),
        (0.45, [0.3, 0.3, 0.9]),
        (0.3, [1.0, 0.6, 0.0]),
        (0.7, [0.0, 0.1, 0.2]),
    ]);
    let us = sweep(120, -0.2, 1.2, 14);
    let vs = sweep(120, -0.2, 1.2, 15);
    let mut worst: f64 = 0.0;
    for ty in ["v", "u", "diagonal", "radial", "circular"] {
        for interp in ["linear", "smooth"] {
            for (&u, &v) in us.iter().zip(&vs) {
                if ty == "radial" && u > 0.5 && (v as f64 - 0.5).abs() < 1e-5 {
                    continue;
                }
                let o = ramp(
                    &[
                        ("type", s(ty)),
                        ("interpolation", s(interp)),
                        ("keys", k.clone()),
                    ],
                    u,
                    v,
                );
                worst = worst.max(max_diff(&o.get("outColor"), &o.get32("outColor")));
                worst = worst.max(max_diff(&o.get("outAlpha"), &o.get32("outAlpha")));
            }
        }
    }
    assert!(worst <= 2e-6, "ramp f32 vs f64: {worst}");
}

// ---- noise: an independent oracle ----
//
// Improved Perlin noise written from Perlin's paper ("Improving Noise", SIGGRAPH 2002): the
// reference permutation, the twelve edge gradients padded to sixteen as the paper lists
// them, the quintic fade 6t⁵ − 15t⁴ + 10t³, and the trilinear blend written as a weighted sum
// over the eight cell corners (the library nests lerps and picks gradients with bit tricks).

/// Perlin's reference permutation.
const PERM: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69,
    142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219,
    203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175,
    74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230,
    220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76,
    132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173,
    186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163,
    70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232,
    178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162,
    241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204,
    176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141,
    128, 195, 78, 66, 215, 61, 156, 180,
];

/// The sixteen gradients of the paper: the twelve cube-edge directions, then (1,1,0),
/// (0,-1,1), (-1,1,0), (0,-1,-1) again.
const GRAD: [[f64; 3]; 16] = [
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, -1.0, 1.0],
    [0.0, 1.0, -1.0],
    [0.0, -1.0, -1.0],
    [1.0, 1.0, 0.0],
    [0.0, -1.0, 1.0],
    [-1.0, 1.0, 0.0],
    [0.0, -1.0, -1.0],
];

/// `p[i]` of the paper's doubled 512-entry table.
fn p(i: i64) -> i64 {
    PERM[(i & 255) as usize] as i64
}

/// Improved noise in f64, for ordinary (|x| < 2³¹) finite coordinates.
fn oracle_noise3(x: f64, y: f64, z: f64) -> f64 {
    let (fx, fy, fz) = (x.floor(), y.floor(), z.floor());
    let (i, j, k) = (fx as i64, fy as i64, fz as i64);
    let d = [x - fx, y - fy, z - fz];
    let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let s = d.map(fade);
    let mut sum = 0.0;
    for corner in 0..8 {
        let o = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
        let h = p(p(p(i + o[0]) + j + o[1]) + k + o[2]) & 15;
        let g = GRAD[h as usize];
        let mut dot = 0.0;
        let mut weight = 1.0;
        for a in 0..3 {
            dot += g[a] * (d[a] - o[a] as f64);
            weight *= if o[a] == 1 { s[a] } else { 1.0 - s[a] };
        }
        sum += weight * dot;
    }
    sum
}

#[test]
fn oracle_matches_perlins_published_value() {
    let mut seen = [false; 256];
    for &x in &PERM {
        seen[x as usize] = true;
    }
    assert!(seen.iter().all(|s| *s), "PERM is a permutation of 0..256");
    // The value of Perlin's Java reference ImprovedNoise.noise(3.14, 42, 7); 3.14 is that
    // test's input, not an approximation of π.
    #[allow(clippy::approx_constant)]
    let x = 3.14;
    let n = oracle_noise3(x, 42.0, 7.0);
    assert!((n - 0.136_919_958_784_000_12).abs() < 1e-15, "{n}");
}

fn solid(p: [f32; 3], inputs: &[(&str, Literal)]) -> Outputs {
    eval("solidNoise", inputs, &frag_p(p[0], p[1], p[2]))
}

fn points(n: usize, lo: f64, hi: f64, seed: u64) -> Vec<[f32; 3]> {
    let xs = sweep(n, lo, hi, seed);
    let ys = sweep(n, lo, hi, seed + 100);
    let zs = sweep(n, lo, hi, seed + 200);
    (0..n).map(|i| [xs[i], ys[i], zs[i]]).collect()
}

fn widen(p: [f32; 3]) -> [f64; 3] {
    p.map(|x| x as f64)
}

/// Whether any coordinate of `q` lies within `eps` of an integer (a lattice cell face).
fn near_face(q: [f64; 3], eps: f64) -> bool {
    q.iter().any(|x| (x - x.round()).abs() < eps)
}

// ---- solidNoise ----

#[test]
fn solid_noise_matches_oracle() {
    for scale in [1.0, 2.5, 0.37] {
        for pt in points(200, -20.0, 20.0, 20) {
            let o = solid(pt, &[("scale", f(scale))]);
            let q = widen(pt).map(|x| x * scale);
            let want = 0.5 + 0.5 * oracle_noise3(q[0], q[1], q[2]);
            // f32: within the bound of `solid_noise_f32_matches_f64_away_from_faces`, doubled
            // as these points are not kept away from faces.
            let what = format!("solidNoise at {pt:?} × {scale}");
            expect_tols(&o, "outAlpha", &[want], 1e-12, 1e-5, &what);
            assert_close(
                &o.get("outColor"),
                &[want; 3],
                1e-12,
                "solidNoise color is grey",
            );
        }
    }
}

#[test]
fn solid_noise_is_zero_at_lattice_points() {
    for pt in [
        [0.0, 0.0, 0.0],
        [1.0, 2.0, 3.0],
        [-7.0, 12.0, -1.0],
        [255.0, 256.0, -300.0],
    ] {
        let o = solid(pt, &[]);
        assert_eq!(o.get("outAlpha"), vec![0.5], "at {pt:?}");
        assert_eq!(o.get32("outAlpha"), vec![0.5], "at {pt:?}");
    }
    // with a scale: (0.5, 1.5, -2.5) × 2 is a lattice point
    let o = solid([0.5, 1.5, -2.5], &[("scale", f(2.0))]);
    assert_eq!(o.get("outAlpha"), vec![0.5]);
}

#[test]
fn solid_noise_is_continuous_across_cell_faces() {
    // Across the face x = k the value changes by at most |∇n|·2ε; |∇n| < 4 for improved
    // noise, so with ε = 1e-4 the jump is below 1e-3 (alpha: half of it).
    let eps = 1e-4;
    for pt in points(50, -10.0, 10.0, 30) {
        for axis in 0..3 {
            let k = (pt[axis] as f64).round();
            let mut below = pt;
            let mut above = pt;
            let mut on = pt;
            below[axis] = (k - eps) as f32;
            above[axis] = (k + eps) as f32;
            on[axis] = k as f32;
            let a = solid(below, &[]).get("outAlpha")[0];
            let b = solid(above, &[]).get("outAlpha")[0];
            let c = solid(on, &[]).get("outAlpha")[0];
            assert!(
                (a - b).abs() < 5e-4,
                "jump across face {axis} at {pt:?}: {a} vs {b}"
            );
            assert!(
                (a - c).abs() < 5e-4 && (b - c).abs() < 5e-4,
                "on the face at {pt:?}"
            );
        }
    }
}

#[test]
fn solid_noise_range_over_a_sweep() {
    let mut extreme: f64 = 0.0;
    for pt in points(2000, -50.0, 50.0, 40) {
        let o = solid(pt, &[("scale", f(0.73))]);
        for a in [o.get("outAlpha")[0], o.get32("outAlpha")[0]] {
            let n = 2.0 * a - 1.0;
            assert!(n.abs() <= 1.1, "noise {n} at {pt:?}");
            extreme = extreme.max(n.abs());
        }
    }
    assert!(extreme > 0.5, "the sweep saw only small values: {extreme}");
}

/// f32 vs f64, measured away from lattice faces (farther than 1e-4 in the scaled
/// coordinate), where both precisions pick the same cell. There the difference comes from
/// rounding `point · scale` (|q| ≤ 14, half an f32 ulp ≤ 1e-6, times |∇n| < 4) and from the
/// f32 evaluation of the fade polynomials and blends (a few 1e-7): bound 1e-5 on the noise,
/// 5e-6 on `outAlpha`. Near a face the two can pick adjacent cells; noise is continuous, so
/// they still agree, but the bound is stated only where the arithmetic is comparable.
#[test]
fn solid_noise_f32_matches_f64_away_from_faces() {
    let scale = 1.37;
    let mut worst: f64 = 0.0;
    let mut compared = 0;
    for pt in points(1000, -10.0, 10.0, 50) {
        let q = widen(pt).map(|x| x * scale);
        if near_face(q, 1e-4) {
            continue;
        }
        compared += 1;
        let o = solid(pt, &[("scale", f(scale))]);
        worst = worst.max(max_diff(&o.get("outAlpha"), &o.get32("outAlpha")));
    }
    assert!(compared > 900);
    assert!(worst <= 5e-6, "solidNoise f32 vs f64: {worst}");
}

// ---- noise (2D) ----

#[test]
fn noise_matches_oracle() {
    let us = sweep(300, -4.0, 4.0, 60);
    let vs = sweep(300, -4.0, 4.0, 61);
    for (freq, amp) in [(8.0, 1.0), (3.3, 0.7), (1.0, 2.0)] {
        for (&u, &v) in us.iter().zip(&vs) {
            let o = eval(
                "noise",
                &[("frequency", f(freq)), ("amplitude", f(amp))],
                &frag_uv(u, v),
            );
            let n = oracle_noise3(u as f64 * freq, v as f64 * freq, 0.0);
            let want = 0.5 + 0.5 * (amp * n);
            let what = format!("noise at ({u}, {v})");
            expect_tols(&o, "outAlpha", &[want], 1e-12, 1e-5, &what);
            assert_close(&o.get("outColor"), &[want; 3], 1e-12, "noise color is grey");
        }
    }
}

#[test]
fn noise_is_zero_at_lattice_points_and_bounded() {
    // default frequency 8: uv = (k/8, m/8) is a lattice point
    for (k, m) in [(0, 0), (1, 3), (-5, 7), (8, -8), (100, 33)] {
        let o = eval("noise", &[], &frag_uv(k as f32 / 8.0, m as f32 / 8.0));
        assert_eq!(o.get("outAlpha"), vec![0.5], "at ({k}, {m}) / 8");
        assert_eq!(o.get32("outAlpha"), vec![0.5], "at ({k}, {m}) / 8");
    }
    let us = sweep(2000, -10.0, 10.0, 62);
    let vs = sweep(2000, -10.0, 10.0, 63);
    let mut extreme: f64 = 0.0;
    for (&u, &v) in us.iter().zip(&vs) {
        let o = eval("noise", &[], &frag_uv(u, v));
        for a in [o.get("outAlpha")[0], o.get32("outAlpha")[0]] {
            let n = 2.0 * a - 1.0;
            assert!(n.abs() <= 1.1, "noise {n} at ({u}, {v})");
            extreme = extreme.max(n.abs());
        }
    }
    assert!(extreme > 0.5, "{extreme}");
}

/// f32 vs f64 with the default frequency 8: `uv · 8` is exact in both precisions, so both
/// pick the same lattice cell everywhere (no face to avoid) and only the evaluation rounds
/// (|q| ≤ 40): bound 5e-6 on `outAlpha`.
#[test]
fn noise_f32_matches_f64() {
    let us = sweep(1000, -5.0, 5.0, 64);
    let vs = sweep(1000, -5.0, 5.0, 65);
    let mut worst: f64 = 0.0;
    for (&u, &v) in us.iter().zip(&vs) {
        let o = eval("noise", &[], &frag_uv(u, v));
        worst = worst.max(max_diff(&o.get("outAlpha"), &o.get32("outAlpha")));
    }
    assert!(worst <= 5e-6, "noise f32 vs f64: {worst}");
}

// ---- fractal ----

fn fractal(pt: [f32; 3], octaves: i32, lac: f64, gain: f64, scale: f64) -> Outputs {
    eval(
        "fractal",
        &[
            ("octaves", int(octaves)),
            ("lacunarity", f(lac)),
            ("gain", f(gain)),
            ("scale", f(scale)),
        ],
        &frag_p(pt[0], pt[1], pt[2]),
    )
}

#[test]
fn fractal_with_one_octave_is_solid_noise() {
    for pt in points(200, -10.0, 10.0, 70) {
        let a = fractal(pt, 1, 2.3, 0.7, 1.7);
        let b = solid(pt, &[("scale", f(1.7))]);
        assert_eq!(a.get("outAlpha"), b.get("outAlpha"), "f64 at {pt:?}");
        assert_eq!(a.get32("outAlpha"), b.get32("outAlpha"), "f32 at {pt:?}");
        assert_eq!(a.get("outColor"), b.get("outColor"), "color at {pt:?}");
    }
}

#[test]
fn fractal_matches_oracle_sum() {
    for (octaves, lac, gain) in [(4, 2.0, 0.5), (3, 1.9, 0.6), (6, 2.7, 0.45)] {
        for pt in points(100, -5.0, 5.0, 71) {
            let o = fractal(pt, octaves, lac, gain, 1.3);
            let q = widen(pt).map(|x| x * 1.3);
            let fbm: f64 = (0..octaves)
                .map(|i| {
                    let fr = lac.powi(i);
                    gain.powi(i) * oracle_noise3(q[0] * fr, q[1] * fr, q[2] * fr)
                })
                .sum();
            let what = format!("fbm at {pt:?}");
            expect_tols(&o, "outAlpha", &[0.5 + 0.5 * fbm], 1e-10, 4e-5, &what);
        }
    }
}

#[test]
fn fractal_octave_count_is_clamped() {
    for pt in points(30, -5.0, 5.0, 72) {
        // 0 and negative: no octaves, a flat 0.5
        for n in [0, -3, i32::MIN] {
            let o = fractal(pt, n, 2.0, 0.5, 1.0);
            expect(&o, "outAlpha", &[0.5], 0.0, &format!("{n} octaves"));
        }
        // above 16: the same as 16
        let a = fractal(pt, 16, 2.0, 0.5, 1.0);
        for n in [17, 100, i32::MAX] {
            let b = fractal(pt, n, 2.0, 0.5, 1.0);
            assert_eq!(a.get("outAlpha"), b.get("outAlpha"), "{n} octaves");
        }
    }
    // lattice points with lacunarity 2: every octave is on the lattice
    let o = fractal([3.0, -4.0, 5.0], 8, 2.0, 0.5, 1.0);
    expect(&o, "outAlpha", &[0.5], 0.0, "fbm at a lattice point");
}

/// f32 vs f64, away from the faces of every octave's lattice: the coordinate rounding grows
/// with the octave frequency (×8 at the fourth octave, weighted by gain³ = 1/8), so each
/// octave contributes about the single-octave error: bound 2e-5 on `outAlpha` for 4 octaves.
#[test]
fn fractal_f32_matches_f64_away_from_faces() {
    let (scale, lac, gain, octaves): (f64, f64, f64, i32) = (1.37, 2.0, 0.5, 4);
    let mut worst: f64 = 0.0;
    let mut compared = 0;
    for pt in points(600, -6.0, 6.0, 73) {
        let q = widen(pt).map(|x| x * scale);
        let near = (0..octaves).any(|i| {
            let fr: f64 = lac.powi(i);
            near_face(q.map(|x| x * fr), 1e-4)
        });
        if near {
            continue;
        }
        compared += 1;
        let o = fractal(pt, octaves, lac, gain, scale);
        worst = worst.max(max_diff(&o.get("outAlpha"), &o.get32("outAlpha")));
    }
    assert!(compared > 450, "{compared}");
    assert!(worst <= 2e-5, "fractal f32 vs f64: {worst}");
}

// ---- cellNoise ----

fn cell(pt: [f32; 3], scale: f64) -> Outputs {
    eval(
        "cellNoise",
        &[("scale", f(scale))],
        &frag_p(pt[0], pt[1], pt[2]),
    )
}

#[test]
fn cell_noise_is_constant_within_a_cell_and_in_unit_interval() {
    let mut values = Vec::new();
    for base in points(100, -50.0, 50.0, 80) {
        let corner = base.map(|x| x.floor());
        let v0 = cell(corner, 1.0).get("outAlpha")[0];
        assert!((0.0..1.0).contains(&v0), "cell value {v0}");
        // points inside the same cell, including its lower faces
        for off in [
            [0.5, 0.5, 0.5],
            [0.0, 0.0, 0.0],
            [0.999, 0.001, 0.3],
            [0.25, 0.75, 0.0],
        ] {
            let pt = [corner[0] + off[0], corner[1] + off[1], corner[2] + off[2]];
            let o = cell(pt, 1.0);
            assert_eq!(o.get("outAlpha"), vec![v0], "cell of {corner:?} at {pt:?}");
            assert_eq!(o.get32("outAlpha"), vec![v0], "f32 at {pt:?}");
            assert_eq!(o.get("outColor"), vec![v0; 3]);
        }
        values.push(v0);
    }
    values.sort_by(f64::total_cmp);
    values.dedup();
    assert!(
        values.len() >= 95,
        "only {} distinct values over 100 cells",
        values.len()
    );
}

#[test]
fn cell_noise_cells_are_half_open_and_scaled() {
    // (1, 0, 0) belongs to the cell [1, 2) × [0, 1)²
    let on_face = cell([1.0, 0.0, 0.0], 1.0).get("outAlpha");
    assert_eq!(on_face, cell([1.5, 0.5, 0.5], 1.0).get("outAlpha"));
    // negative coordinates: floor(-0.5) = -1
    assert_eq!(
        cell([-0.5, 0.5, 0.5], 1.0).get("outAlpha"),
        cell([-0.1, 0.9, 0.2], 1.0).get("outAlpha")
    );
    // scale 4: cells of side 1/4
    assert_eq!(
        cell([0.1, 0.1, 0.1], 4.0).get("outAlpha"),
        cell([0.2, 0.2, 0.2], 4.0).get("outAlpha")
    );
    // 0.3 × 4 = 1.2 is in cell (1, 1, 1), not (0, 0, 0)
    assert_eq!(
        cell([0.3, 0.3, 0.3], 4.0).get("outAlpha"),
        cell([1.2, 1.2, 1.2], 1.0).get("outAlpha")
    );
    assert_ne!(
        cell([0.3, 0.3, 0.3], 4.0).get("outAlpha"),
        cell([0.2, 0.2, 0.2], 4.0).get("outAlpha")
    );
}

/// f32 vs f64: the value is 24 bits of an integer hash of the cell, exact in both, so away
/// from faces (where `point · scale` may round into the next cell) they agree exactly.
#[test]
fn cell_noise_f32_matches_f64_away_from_faces() {
    let mut compared = 0;
    for pt in points(500, -20.0, 20.0, 81) {
        let q = widen(pt).map(|x| x * 1.37);
        if near_face(q, 1e-4) {
            continue;
        }
        compared += 1;
        let o = cell(pt, 1.37);
        assert_eq!(o.get("outAlpha"), o.get32("outAlpha"), "at {pt:?}");
    }
    assert!(compared > 450);
}

// ---- noise: hard inputs ----

#[test]
fn noise_nodes_survive_huge_and_non_finite_coordinates() {
    let huge = [
        [1e30, 0.3, 0.7],
        [1e30, 1e30, 1e30],
        [-1e30, 2.5, -1e30],
        [3e38, -3e38, 0.1],
    ];
    let bad = [
        [f32::NAN, 0.3, 0.7],
        [f32::INFINITY, 0.0, 0.0],
        [f32::NEG_INFINITY, f32::NAN, 1.5],
    ];
    for pt in huge.iter().chain(&bad) {
        let frag = frag_p(pt[0], pt[1], pt[2]);
        let frag_uv2 = frag_uv(pt[0], pt[1]);
        let runs = [
            ("solidNoise", eval("solidNoise", &[], &frag)),
            (
                "solidNoise×1e30",
                eval("solidNoise", &[("scale", f(1e30))], &frag),
            ),
            ("fractal", eval("fractal", &[("octaves", int(16))], &frag)),
            ("cellNoise", eval("cellNoise", &[], &frag)),
            ("noise", eval("noise", &[], &frag_uv2)),
        ];
        for (what, o) in runs {
            assert_eq!(o.nonfinite32, 0, "{what} at {pt:?}");
            for a in [o.get("outAlpha")[0], o.get32("outAlpha")[0]] {
                assert!(a.is_finite(), "{what} at {pt:?}: {a}");
                // fbm's amplitudes sum to < 2 with the default gain
                let (lo, hi) = if what == "fractal" {
                    (-0.6, 1.6)
                } else {
                    (-0.05, 1.05)
                };
                assert!((lo..=hi).contains(&a), "{what} at {pt:?}: {a}");
            }
        }
    }
    // A NaN component reads as 0 (documented): all-NaN gives noise 0, outAlpha 0.5, and
    // one NaN component the value with that component 0.
    for (pt, same_as) in [
        ([f32::NAN; 3], [0.0, 0.0, 0.0]),
        ([f32::NAN, 0.3, 0.7], [0.0, 0.3, 0.7]),
        ([1.6, f32::NAN, -2.2], [1.6, 0.0, -2.2]),
    ] {
        let o = eval("solidNoise", &[], &frag_p(pt[0], pt[1], pt[2]));
        let want = eval(
            "solidNoise",
            &[],
            &frag_p(same_as[0], same_as[1], same_as[2]),
        );
        assert_eq!(o.get("outAlpha"), want.get("outAlpha"), "at {pt:?}");
        assert_eq!(o.get32("outAlpha"), want.get32("outAlpha"), "at {pt:?}");
    }
    let o = eval("solidNoise", &[], &frag_p(f32::NAN, f32::NAN, f32::NAN));
    assert_eq!(o.get("outAlpha"), vec![0.5]);
    // scale 1e30 puts every octave of a moderate point far out; still finite.
    let o = fractal([0.3, 0.6, 0.9], 16, 1e10, 0.5, 1e30);
    assert_eq!(o.nonfinite32, 0);
    assert!(o.get32("outAlpha")[0].is_finite());
}

/// Saturated lattice cells (|x| ≥ 2³¹) used to overflow the permutation-index additions in
/// `noise3`, a panic in debug builds.
#[test]
fn noise3_does_not_overflow_at_saturated_cells() {
    for p in [[3e9, 3e9, 3e9], [-3e9, 3e9, -3e9], [1e30, 0.5, 0.25]] {
        let n64 = noise::noise3::<f64>(p);
        let n32 = noise::noise3::<f32>(p.map(|x| x as f32));
        assert!(n64.is_finite() && n64.abs() <= 1.1, "{p:?}: {n64}");
        assert!(n32.is_finite() && n32.abs() <= 1.1, "{p:?}: {n32}");
    }
}

#[test]
fn fractal_overflowing_gain_is_caught_by_the_guard() {
    // gain^15 = 1e45 overflows f32: the sum becomes ±inf or NaN there, and the output guard
    // replaces it with 0 and counts it (documented); f64 stays finite.
    let o = fractal([0.3, 0.6, 0.9], 16, 2.0, 1e3, 1.0);
    assert!(
        o.nonfinite32 > 0,
        "expected the guard to catch the f32 overflow"
    );
    assert_eq!(o.get32("outAlpha"), vec![0.0]);
    assert!(o.get("outAlpha")[0].is_finite());
}
