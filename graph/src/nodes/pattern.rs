//! Standard nodes: pattern — checkers, ramps and noise, as lowerings to IR ops.
//!
//! Every pattern node returns a plain (component-free) `outColor` and a float `outAlpha`.
//! Where `outAlpha` is called the *luminance* of a color, it is the Rec. 709 luminance of
//! linear RGB: `0.2126·r + 0.7152·g + 0.0722·b` (so white gives 1, black 0).
//!
//! Patterns read varying data (uv, P), so choices between colors lower to `select` ops, never
//! to `If` regions: both sides are a handful of ops and the selects keep the program
//! straight-line for the SIMD and GPU back ends.
//!
//! Hard inputs. Cell indices are `floor` of the scaled coordinate converted to an int (the
//! conversion saturates and maps NaN to 0), so checkers give one of their two colors for any
//! coordinate, finite or not. Noise reads a non-finite coordinate component at the origin
//! of a valid lattice cell (NaN as 0, ±inf at the saturated cell: see [`crate::ops::noise`]),
//! and huge coordinates saturate to a valid cell, so noise stays finite. A ramp whose
//! parameter is NaN gives its first key's color. None of these nodes produces a non-finite
//! output from finite colors and parameters, except `fractal` with a `gain` so large that
//! its octave sum overflows, which the material output guard catches.

use super::port::{self, out};
use super::{LowVal, NodeDef, NodeInputs, NodeKind, NodeLibrary, PortDef, PortDefault, PortType};
use crate::ir::{
    BinOp, Builder, ColorSpace, Filter, Intrinsic, Op, Sampling, Stream, TextureFile, UnOp, Value,
};
use crate::types::{ConstValue, Type};
use std::cmp::Ordering;

/// Rec. 709 luminance weights of linear RGB.
const LUMA: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Registers the pattern nodes.
pub fn register(lib: &mut NodeLibrary) {
    lib.add(checker_def());
    lib.add(checker3d_def());
    lib.add(ramp_def());
    lib.add(noise_def());
    lib.add(solid_noise_def());
    lib.add(fractal_def());
    lib.add(cell_noise_def());
    lib.add(file_def());
}

// ---- shared helpers ----

/// The Rec. 709 luminance of a color (a float).
fn luminance(b: &mut Builder, c: Value) -> Value {
    let w = b.color(LUMA);
    b.dot(c, w)
}

/// A float as a grey color.
fn grey(b: &mut Builder, x: Value) -> Value {
    b.splat(Type::Color, x)
}

/// `outColor` (grey) and `outAlpha` from one float.
fn grey_outputs(b: &mut Builder, alpha: Value) -> Vec<LowVal> {
    let color = grey(b, alpha);
    vec![LowVal::plain(color), LowVal::plain(alpha)]
}

/// `v * s` with a float `s` splatted to `v`'s vector type.
fn scale_by(b: &mut Builder, v: Value, s: Value) -> Value {
    let ty = b.ty(v);
    let s = b.splat_to(ty, s);
    b.mul(v, s)
}

/// `0.5 + 0.5 · x`: a signed noise value mapped to about [0, 1].
fn unsigned(b: &mut Builder, x: Value) -> Value {
    let half = b.float(0.5);
    let hx = b.mul(half, x);
    b.add(half, hx)
}

/// Whether the integer cell `floor(cells)` (a vector of already-floored floats) has an even
/// sum of indices. Each index is converted to an int (saturating, NaN → 0) and the sum
/// wraps, so the answer is defined for every input.
fn even_cell(b: &mut Builder, cells: Value) -> Value {
    let n = b.ty(cells).width();
    let mut sum = None;
    for i in 0..n {
        let x = b.extract(cells, i);
        let k = b.convert(Type::Int, x);
        sum = Some(match sum {
            None => k,
            Some(s) => b.add(s, k),
        });
    }
    let sum = sum.unwrap_or_else(|| b.int(0));
    let two = b.int(2);
    let parity = b.binary(BinOp::Mod, sum, two);
    let zero = b.int(0);
    b.binary(BinOp::Eq, parity, zero)
}

/// The checker outputs: `color1` where `even` holds, else `color2` — box-filtered over the
/// footprint of the cell coordinates `cells` — pulled towards the average of the two by
/// `contrast`; `outAlpha` is the luminance of the result.
fn checker_outputs(b: &mut Builder, inp: &NodeInputs, cells: Value, even: Value) -> Vec<LowVal> {
    let c1 = inp.get("color1");
    let c2 = inp.get("color2");
    let contrast = inp.get("contrast");
    let scale = inp.get("filter");
    let w = super::filtered::checker_weight(b, cells, even, scale);
    let c = b.mix(c2, c1, w);
    let sum = b.add(c1, c2);
    let half = b.float(0.5);
    let avg = scale_by(b, sum, half);
    let color = b.mix(avg, c, contrast);
    let alpha = luminance(b, color);
    vec![LowVal::plain(color), LowVal::plain(alpha)]
}

/// The checker color ports shared by `checker` and `checker3d`.
fn checker_color_ports() -> Vec<super::PortDef> {
    vec![
        port::color(
            "color1",
            [1.0, 1.0, 1.0],
            "Color of the checks whose cell indices have an even sum (the one at the origin).",
        ),
        port::color("color2", [0.0, 0.0, 0.0], "Color of the other checks."),
        port::float(
            "contrast",
            1.0,
            "Blend from the average color (0) to the full checks (1); not clamped, so values \
             above 1 exaggerate and below 0 invert.",
        ),
        port::float(
            "filter",
            1.0,
            "Scale of the filter footprint (Maya's `filter`): 1 box-filters each check over \
             the pixel's footprint, larger values blur more, 0 or less turns filtering off.",
        ),
    ]
}

/// The `outColor` / `outAlpha` pair of a color pattern whose alpha is the luminance.
fn color_luma_outputs(what: &'static str) -> Vec<super::OutDef> {
    vec![
        out("outColor", Type::Color, what),
        out(
            "outAlpha",
            Type::Float,
            "Rec. 709 luminance of `outColor` (0.2126 r + 0.7152 g + 0.0722 b).",
        ),
    ]
}

/// The `outColor` / `outAlpha` pair of a grey noise pattern.
fn grey_noise_outputs(alpha_doc: &'static str) -> Vec<super::OutDef> {
    vec![
        out("outColor", Type::Color, "`outAlpha` as a grey color."),
        out("outAlpha", Type::Float, alpha_doc),
    ]
}

/// The `filter` port of the noise patterns (Maya's convention, as `checker`'s).
fn noise_filter_port() -> super::PortDef {
    port::float(
        "filter",
        1.0,
        "Scale of the filter footprint (Maya's `filter`): 1 fades the noise to its average \
         as it gets finer than the pixel's footprint, larger values blur more, 0 or less \
         turns filtering off.",
    )
}

// ---- checker ----

fn checker_def() -> NodeDef {
    let mut inputs = vec![port::stream(
        "uvCoord",
        Type::Vec2,
        Stream::Uv,
        "Texture coordinates; one unit square holds 2×2 checks.",
    )];
    inputs.extend(checker_color_ports());
    NodeDef {
        name: "checker",
        category: "pattern",
        doc: "A 2D checkerboard (Maya `checker`): each unit square of uv holds 2×2 checks.\n\n\
              The check at `uvCoord` is cell `(i, j) = (floor(2u), floor(2v))`; it is `color1` \
              where `i + j` is even — so `[0, 0.5)²` is `color1` — and `color2` elsewhere. \
              The result is `mix(avg, check, contrast)` with `avg = (color1 + color2) / 2`. \
              Cells are half-open: a point exactly on an edge belongs to the check above / to \
              the right of it (`u = 0.5` is in cell `i = 1`), and negative coordinates continue \
              the pattern (`u` in `[-0.5, 0)` is cell `i = -1`).\n\n\
              Filtering: the checks are box-filtered over the pixel's footprint (the \
              screen-space derivatives of `2·uvCoord`, width `√(∂x² + ∂y²)·filter` per \
              axis, analytically: the result blends the two colors by the even checks' share \
              of the box), so far checks fade to the average instead of aliasing. Where the \
              footprint is narrower than 1/1000 of a check on every axis (or there are no \
              ray differentials, or `filter = 0`) the result is exactly the unfiltered one.\n\n\
              Hard inputs: the cell index is converted to an int (saturating, NaN → 0), so a NaN \
              coordinate falls in cell 0, ±inf and huge coordinates in the saturated cell; the \
              output is always one of the two (finite) colors.",
        generic: &[],
        inputs,
        outputs: color_luma_outputs("The checker color."),
        lower: lower_checker,
        kind: NodeKind::Shading,
    }
}

fn lower_checker(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let uv = inp.get("uvCoord");
    let two = b.constant(ConstValue::Vec2([2.0, 2.0]));
    let scaled = b.mul(uv, two);
    let cells = b.unary(UnOp::Floor, scaled);
    let even = even_cell(b, cells);
    Ok(checker_outputs(b, inp, scaled, even))
}

// ---- checker3d ----

fn checker3d_def() -> NodeDef {
    let mut inputs = vec![
        port::stream(
            "point",
            Type::Vec3,
            Stream::P,
            "Point to shade (world space unless connected to something else).",
        ),
        port::float(
            "scale",
            1.0,
            "Checks per unit length: each check is a cube of side 1/scale.",
        ),
    ];
    inputs.extend(checker_color_ports());
    NodeDef {
        name: "checker3d",
        category: "pattern",
        doc: "A solid (3D) checkerboard of cubes of side `1/scale`.\n\n\
              With `q = point · scale`, the cell is `(i, j, k) = floor(q)`; it is `color1` \
              where `i + j + k` is even (the cube `[0, 1/scale)³` is `color1`) and `color2` \
              elsewhere; the result is `mix(avg, check, contrast)` with `avg = (color1 + \
              color2) / 2`. Cells are half-open (a point on a face belongs to the cell on its \
              positive side). Filtered like `checker`, over the footprint of \
              `point · scale` (the derivatives of `P` are the ray differentials).\n\n\
              Hard inputs: as `checker` — cell indices are ints (saturating, NaN → 0), so every \
              coordinate, finite or not, gives one of the two colors. `scale = 0` puts every \
              point in cell 0 (`color1`).",
        generic: &[],
        inputs,
        outputs: color_luma_outputs("The checker color."),
        lower: lower_checker3d,
        kind: NodeKind::Shading,
    }
}

fn lower_checker3d(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let p = inp.get("point");
    let s = inp.get("scale");
    let q = scale_by(b, p, s);
    let cells = b.unary(UnOp::Floor, q);
    let even = even_cell(b, cells);
    Ok(checker_outputs(b, inp, q, even))
}

// ---- ramp ----

const RAMP_TYPES: &[&str] = &["v", "u", "diagonal", "radial", "circular"];
const RAMP_INTERPOLATIONS: &[&str] = &["none", "linear", "smooth"];

fn ramp_def() -> NodeDef {
    NodeDef {
        name: "ramp",
        category: "pattern",
        doc: "A color ramp (Maya `ramp`): colors at positions along a parameter `t` read from \
              `uvCoord`.\n\n\
              `t` by `type`: `v`: `t = v`; `u`: `t = u`; `diagonal`: `t = (u + v) / 2`; \
              `radial`: the angle of `uv − (0.5, 0.5)` counter-clockwise from the +u axis, \
              `t = atan2(v − 0.5, u − 0.5) / 2π` wrapped into [0, 1) (0 at the center); \
              `circular`: `t = 2 · |uv − (0.5, 0.5)|`, 0 at the center and 1 at the midpoint of \
              each edge of the unit square (√2 at its corners). `t` is not wrapped or clamped.\n\n\
              With keys `(p₀, c₀) … (pₙ₋₁, cₙ₋₁)` in increasing position: below `p₀` the result \
              is `c₀`, at or above `pₙ₋₁` it is `cₙ₋₁`; for `pᵢ ≤ t < pᵢ₊₁` it is, by \
              `interpolation`, `none`: `cᵢ` (a step); `linear`: `mix(cᵢ, cᵢ₊₁, w)` with \
              `w = (t − pᵢ) / (pᵢ₊₁ − pᵢ)`; `smooth`: the same with `w² (3 − 2w)`. \
              `t` exactly at a key gives that key's color. Positions may lie outside [0, 1].\n\n\
              Hard inputs. No keys: black (and `outAlpha` 0). One key: its color everywhere. \
              Unsorted keys: when every position is a constant, keys are sorted by position \
              when the node is lowered (a stable sort: keys at equal positions keep their \
              order; a NaN position sorts last and never matches). When any position is \
              connected, the keys are used in the given order and must be kept sorted by the \
              user: the result is then the segment starting at the last key, in the given order, \
              whose position is ≤ t, its weight clamped to [0, 1] (the last key's color if that \
              is the last key). Duplicate \
              positions: the later key wins at and above the shared position (the zero-width \
              segment between them is never visible; its weight would be the total division's \
              0, never NaN or inf). A NaN `t` (from a NaN uv) gives `c₀`; `t = ±inf` gives the \
              last / first key's color.",
        generic: &[],
        inputs: vec![
            port::stream(
                "uvCoord",
                Type::Vec2,
                Stream::Uv,
                "Texture coordinates the ramp parameter is read from.",
            ),
            port::option(
                "type",
                "v",
                RAMP_TYPES,
                "How `t` is computed from `uvCoord` (see the formulas above).",
            ),
            port::option(
                "interpolation",
                "linear",
                RAMP_INTERPOLATIONS,
                "How colors blend between adjacent keys.",
            ),
            port::array(
                "keys",
                vec![
                    ("position", Some(Type::Float)),
                    ("color", Some(Type::Color)),
                ],
                "The ramp's keys: a position along `t` and the color there.",
            ),
        ],
        outputs: color_luma_outputs("The ramp color at `t`."),
        lower: lower_ramp,
        kind: NodeKind::Shading,
    }
}

/// Orders constant positions for sorting: numbers by value (`-0 == +0`), every NaN equal
/// and after every number. A total preorder, so the sort cannot misbehave.
fn position_order(a: f64, b: f64) -> Ordering {
    match (a.is_nan(), b.is_nan()) {
        (false, false) => a.partial_cmp(&b).unwrap_or(Ordering::Equal),
        (false, true) => Ordering::Less,
        (true, false) => Ordering::Greater,
        (true, true) => Ordering::Equal,
    }
}

/// The ramp parameter `t` for a ramp type.
fn ramp_t(b: &mut Builder, ty: &str, uv: Value) -> Result<Value, String> {
    Ok(match ty {
        "v" => b.extract(uv, 1),
        "u" => b.extract(uv, 0),
        "diagonal" => {
            let u = b.extract(uv, 0);
            let v = b.extract(uv, 1);
            let s = b.add(u, v);
            let half = b.float(0.5);
            b.mul(s, half)
        }
        "radial" => {
            let half = b.float(0.5);
            let u = b.extract(uv, 0);
            let v = b.extract(uv, 1);
            let du = b.sub(u, half);
            let dv = b.sub(v, half);
            let angle = b.binary(BinOp::Atan2, dv, du);
            let inv_tau = b.float(1.0 / std::f64::consts::TAU);
            // a ∈ [-0.5, 0.5]; negative angles wrap by +1, and a sum that rounds up to 1
            // wraps to 0, so t ∈ [0, 1) in every precision.
            let a = b.mul(angle, inv_tau);
            let zero = b.float(0.0);
            let one = b.float(1.0);
            let neg = b.binary(BinOp::Lt, a, zero);
            let a1 = b.add(a, one);
            let t = b.select(neg, a1, a);
            let wrapped = b.binary(BinOp::Ge, t, one);
            b.select(wrapped, zero, t)
        }
        "circular" => {
            let center = b.constant(ConstValue::Vec2([0.5, 0.5]));
            let d = b.binary(BinOp::Distance, uv, center);
            let two = b.float(2.0);
            b.mul(d, two)
        }
        other => {
            return Err(format!(
                "input type: unknown ramp type `{other}` (one of: {})",
                RAMP_TYPES.join(", ")
            ));
        }
    })
}

fn lower_ramp(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let interp = inp.string("interpolation");
    if !RAMP_INTERPOLATIONS.contains(&interp) {
        return Err(format!(
            "input interpolation: unknown interpolation `{interp}` (one of: {})",
            RAMP_INTERPOLATIONS.join(", ")
        ));
    }
    let uv = inp.get("uvCoord");
    let t = ramp_t(b, inp.string("type"), uv)?;

    let mut keys = Vec::new();
    for (i, rec) in inp.array("keys").iter().enumerate() {
        match rec.as_slice() {
            [pos, color, ..] => keys.push((pos.value, color.value)),
            _ => return Err(format!("input keys: element {i} lacks a position or color")),
        }
    }
    if keys.is_empty() {
        let black = b.zero(Type::Color);
        let alpha = b.float(0.0);
        return Ok(vec![LowVal::plain(black), LowVal::plain(alpha)]);
    }

    // Sort constant positions now (stable: equal positions keep their order).
    let constant_positions: Option<Vec<f64>> = keys
        .iter()
        .map(|(p, _)| match b.program().op(*p) {
            Op::Const(ConstValue::Float(x)) => Some(*x),
            _ => None,
        })
        .collect();
    if let Some(xs) = constant_positions {
        let mut order: Vec<usize> = (0..keys.len()).collect();
        order.sort_by(|&i, &j| position_order(xs[i], xs[j]));
        keys = order.into_iter().map(|i| keys[i]).collect();
    }

    // result = c₀; for each segment (pᵢ₋₁, pᵢ), where t ≥ pᵢ₋₁ the segment's color replaces
    // it; finally, where t ≥ pₙ₋₁, the last color. With sorted keys the last segment whose
    // start is ≤ t wins, which is the one containing t.
    let zero = b.float(0.0);
    let one = b.float(1.0);
    let two = b.float(2.0);
    let three = b.float(3.0);
    let mut result = keys[0].1;
    for pair in keys.windows(2) {
        let [(p0, c0), (p1, c1)] = [pair[0], pair[1]];
        let seg = match interp {
            "none" => c0,
            _ => {
                let num = b.sub(t, p0);
                let den = b.sub(p1, p0);
                // Total division: equal positions give 0; clamp maps NaN to 0 as well.
                let w = b.div(num, den);
                let w = b.clamp(w, zero, one);
                let w = if interp == "smooth" {
                    let w2 = b.mul(w, w);
                    let tw = b.mul(two, w);
                    let s = b.sub(three, tw);
                    b.mul(w2, s)
                } else {
                    w
                };
                b.mix(c0, c1, w)
            }
        };
        let inside = b.binary(BinOp::Ge, t, p0);
        result = b.select(inside, seg, result);
    }
    if let Some(&(pn, cn)) = keys.last().filter(|_| keys.len() > 1) {
        let above = b.binary(BinOp::Ge, t, pn);
        result = b.select(above, cn, result);
    }
    let alpha = luminance(b, result);
    Ok(vec![LowVal::plain(result), LowVal::plain(alpha)])
}

// ---- noise ----

fn noise_def() -> NodeDef {
    NodeDef {
        name: "noise",
        category: "pattern",
        doc: "2D improved Perlin noise (Perlin 2002) over uv.\n\n\
              `outAlpha = 0.5 + 0.5 · amplitude · noise2(uvCoord · frequency)`, where `noise2` \
              lies in about [-1, 1] and is 0 at integer lattice points, so with `amplitude ≤ 1` \
              `outAlpha` stays in about [0, 1]; it is not clamped. `outColor` is `outAlpha` as \
              a grey.\n\n\
              Filtering: `noise2` fades to its average 0 (`outAlpha` to 0.5) as it gets finer \
              than the pixel's footprint, as one octave of `fractal` (weight `1 − smoothstep(0.1, \
              2.2, w)`; exactly the unfiltered value for `w ≤ 0.1`).\n\n\
              Hard inputs: a non-finite coordinate component is read at the origin of a \
              valid lattice cell (NaN as 0; ±inf at the saturated cell), so an all-NaN \
              coordinate gives noise 0 (`outAlpha = 0.5`); huge coordinates saturate to a \
              valid cell. The output is always finite.",
        generic: &[],
        inputs: vec![
            port::stream("uvCoord", Type::Vec2, Stream::Uv, "Texture coordinates."),
            port::float(
                "frequency",
                8.0,
                "Lattice cells per unit of uv (feature size about 1/frequency).",
            ),
            port::float(
                "amplitude",
                1.0,
                "Scale of the noise around 0.5 (1: about [0, 1]).",
            ),
            noise_filter_port(),
        ],
        outputs: grey_noise_outputs("`0.5 + 0.5 · amplitude · noise2(uvCoord · frequency)`."),
        lower: lower_noise,
        kind: NodeKind::Shading,
    }
}

fn lower_noise(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let uv = inp.get("uvCoord");
    let freq = inp.get("frequency");
    let amp = inp.get("amplitude");
    let q = scale_by(b, uv, freq);
    let n = b.call(Intrinsic::Noise2, &[q]);
    let n = super::filtered_noise::noise(b, n, q, inp.get("filter"));
    let n = b.mul(amp, n);
    let alpha = unsigned(b, n);
    Ok(grey_outputs(b, alpha))
}

// ---- solidNoise ----

fn point_scale_ports() -> Vec<super::PortDef> {
    vec![
        port::stream(
            "point",
            Type::Vec3,
            Stream::P,
            "Point to shade (world space unless connected to something else).",
        ),
        port::float(
            "scale",
            1.0,
            "Lattice cells per unit length (feature size about 1/scale).",
        ),
    ]
}

fn solid_noise_def() -> NodeDef {
    NodeDef {
        name: "solidNoise",
        category: "pattern",
        doc: "3D improved Perlin noise (Perlin 2002).\n\n\
              `outAlpha = 0.5 + 0.5 · noise3(point · scale)`, where `noise3` lies in about \
              [-1, 1] and is 0 at integer lattice points; not clamped. `outColor` is \
              `outAlpha` as a grey.\n\n\
              Filtering: `noise3` fades to its average 0 (`outAlpha` to 0.5) as it gets finer \
              than the pixel's footprint, as one octave of `fractal` (weight `1 − smoothstep(0.1, \
              2.2, w)`; exactly the unfiltered value for `w ≤ 0.1`).\n\n\
              Hard inputs: a non-finite coordinate component is read at the origin of a \
              valid lattice cell (NaN as 0; ±inf at the saturated cell), so an all-NaN \
              coordinate gives noise 0 (`outAlpha = 0.5`); huge coordinates saturate to a \
              valid cell. The output is always finite.",
        generic: &[],
        inputs: {
            let mut i = point_scale_ports();
            i.push(noise_filter_port());
            i
        },
        outputs: grey_noise_outputs("`0.5 + 0.5 · noise3(point · scale)`."),
        lower: lower_solid_noise,
        kind: NodeKind::Shading,
    }
}

fn lower_solid_noise(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let p = inp.get("point");
    let s = inp.get("scale");
    let q = scale_by(b, p, s);
    let n = b.call(Intrinsic::Noise3, &[q]);
    let n = super::filtered_noise::noise(b, n, q, inp.get("filter"));
    let alpha = unsigned(b, n);
    Ok(grey_outputs(b, alpha))
}

// ---- fractal ----

fn fractal_def() -> NodeDef {
    let mut inputs = point_scale_ports();
    inputs.extend([
        port::int(
            "octaves",
            4,
            "Number of noise layers, clamped to [0, 16] (0 gives a flat 0.5).",
        ),
        port::float(
            "lacunarity",
            2.0,
            "Frequency ratio between successive octaves.",
        ),
        port::float("gain", 0.5, "Amplitude ratio between successive octaves."),
        noise_filter_port(),
    ]);
    NodeDef {
        name: "fractal",
        category: "pattern",
        doc: "Fractal Brownian motion: a sum of octaves of 3D improved Perlin noise.\n\n\
              `outAlpha = 0.5 + 0.5 · fbm`, `fbm = Σ_{i < octaves} gainⁱ · noise3(point · \
              scale · lacunarityⁱ)`, octaves clamped to [0, 16]. With one octave it is exactly \
              `solidNoise`. The sum of amplitudes is `(1 − gainⁿ) / (1 − gain)` (1.875 for the \
              defaults), so `outAlpha` may leave [0, 1]; it is not clamped. `outColor` is \
              `outAlpha` as a grey.\n\n\
              Filtering: each octave fades to its average 0 as it gets finer than the pixel's \
              footprint: with `w = max(|∂q/∂x|, |∂q/∂y|) · filter` the footprint of `q = \
              point · scale`, octave `i` keeps the weight `1 − smoothstep(0.1, 2.2, \
              lacunarityⁱ · w)` (the measured attenuation of the noise under a box of width \
              `w`); the octaves past the band are not computed, and at most 5 fade at once \
              (with `lacunarity < 1.86` the finer ones in the band are dropped). Where no \
              octave fades (`lacunarity^(octaves−1) · w ≤ 0.1`, no ray differentials, \
              `lacunarity ≤ 1`, or `filter = 0`) the result is exactly the unfiltered one.\n\n\
              Hard inputs: as `solidNoise`, per octave — a coordinate that overflows at a high \
              octave (`point · scale · lacunarityⁱ` = ±inf) is read at the saturated lattice \
              cell's origin, so each octave stays finite. A `gain` so large that `gainⁱ · \
              noise` or the sum overflows (e.g. `gain = 1000` with 16 octaves in f32) makes the \
              output non-finite; the material output guard replaces it with 0 and counts it.",
        generic: &[],
        inputs,
        outputs: grey_noise_outputs("`0.5 + 0.5 · fbm(point · scale)`."),
        lower: lower_fractal,
        kind: NodeKind::Shading,
    }
}

fn lower_fractal(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let p = inp.get("point");
    let s = inp.get("scale");
    let octaves = inp.get("octaves");
    let lacunarity = inp.get("lacunarity");
    let gain = inp.get("gain");
    let q = scale_by(b, p, s);
    let scale = inp.get("filter");
    let w = super::filtered_noise::point_width(b, q, scale);
    let f = super::filtered_noise::Fractal {
        sum: Intrinsic::Fbm3,
        octave: Intrinsic::Noise3,
        max_octaves: 16,
    };
    let n = super::filtered_noise::fractal(b, f, q, [octaves, lacunarity, gain], w, scale);
    let alpha = unsigned(b, n);
    Ok(grey_outputs(b, alpha))
}

// ---- cellNoise ----

fn cell_noise_def() -> NodeDef {
    NodeDef {
        name: "cellNoise",
        category: "pattern",
        doc: "Cell noise: one pseudo-random value per unit cell of `point · scale`.\n\n\
              `outAlpha = cellnoise3(point · scale)`, a hash of the integer cell \
              `floor(point · scale)` mapped to [0, 1) (24 bits, identical in f32 and f64), \
              constant within each cell of side `1/scale`; cells are half-open (a point on a \
              face belongs to the cell on its positive side). `outColor` is `outAlpha` as a \
              grey.\n\n\
              Hard inputs: cell indices saturate (NaN → cell 0), so every coordinate gives a \
              value in [0, 1).",
        generic: &[],
        inputs: point_scale_ports(),
        outputs: grey_noise_outputs("`cellnoise3(point · scale)`, in [0, 1)."),
        lower: lower_cell_noise,
        kind: NodeKind::Shading,
    }
}

fn lower_cell_noise(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let p = inp.get("point");
    let s = inp.get("scale");
    let q = scale_by(b, p, s);
    let alpha = b.call(Intrinsic::CellNoise3, &[q]);
    Ok(grey_outputs(b, alpha))
}

// ---- file texture ----

fn file_def() -> NodeDef {
    NodeDef {
        name: "file",
        category: "pattern",
        doc: "An image file (Maya `file`): a filtered lookup with repeat wrapping.\n\n\
              `uv = (0, 0)` is the image's bottom-left corner. The file's values are \
              converted from `colorSpace` to linear Rec.709 (`auto`: 8- and 16-bit images \
              are sRGB, EXR and HDR linear); alpha is linear (1 where the image has none). \
              `filterType` filters over the footprint of uv's screen-space derivatives \
              (docs/textures.md). A relative path is relative to the network file. The file \
              is loaded when the material is prepared, and only if the optimized program \
              still reads it: a texture on a dead branch is never opened, a missing file on \
              a live one is an error naming the file.",
        generic: &[],
        inputs: vec![
            PortDef {
                name: "fileTextureName",
                ty: PortType::Simple(Type::String),
                default: PortDefault::Value(ConstValue::String(String::new())),
                options: &[],
                doc: "Path of the image file (PNG, JPEG, EXR, HDR; `<UDIM>` for tiles).",
            },
            PortDef {
                name: "colorSpace",
                ty: PortType::Simple(Type::String),
                default: PortDefault::Value(ConstValue::String(String::new())),
                options: &[],
                doc: "The color space of the file's values: a MaterialX name (`srgb_texture`, \
                      `lin_rec709`, `acescg`, …), `raw`, or empty for `auto`.",
            },
            PortDef {
                name: "filterType",
                ty: PortType::Simple(Type::String),
                default: PortDefault::Value(ConstValue::String(String::new())),
                options: &[],
                doc: "`closest`, `bilinear`, `trilinear` or `anisotropic` (empty: \
                      `anisotropic`).",
            },
            port::stream("uvCoord", Type::Vec2, Stream::Uv, "Texture coordinates."),
        ],
        outputs: vec![
            port::out("outColor", Type::Color, "The texel color, linear RGB."),
            port::out("outAlpha", Type::Float, "The texel alpha."),
        ],
        lower: lower_file,
        kind: NodeKind::Shading,
    }
}

fn lower_file(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let name = inp.string("fileTextureName");
    if name.is_empty() {
        return Err("`fileTextureName` is empty: name an image file".into());
    }
    let colorspace = match inp.string("colorSpace") {
        "" => ColorSpace::Auto,
        cs => ColorSpace::parse(cs).ok_or_else(|| {
            let known: Vec<&str> = ColorSpace::ALL.iter().map(|c| c.name()).collect();
            format!("`colorSpace`: unknown `{cs}`; known: {}", known.join(", "))
        })?,
    };
    let filter = match inp.string("filterType") {
        "" => Filter::Anisotropic,
        f => Filter::from_name(f).ok_or_else(|| {
            format!("`filterType`: `{f}` is not closest, bilinear, trilinear or anisotropic")
        })?,
    };
    let sampling = Sampling {
        filter,
        ..Sampling::default()
    };
    let uv = inp.get("uvCoord");
    let t = b.texture_index(&TextureFile {
        path: name.to_string(),
        colorspace,
    });
    let color = b.texture(t, uv, sampling, false);
    let alpha = b.texture(t, uv, sampling, true);
    Ok(vec![LowVal::plain(color), LowVal::plain(alpha)])
}
