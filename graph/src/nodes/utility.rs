//! Standard nodes: utilities that look around the shaded point — `ambientOcclusion` (asks
//! the renderer's scene), `bump2d` (samples its input at moved texture coordinates
//! through a stream override, DESIGN §3), and `filterWidth` / `filterStep` (the pixel's
//! footprint of a value, for antialiased patterns).

use super::{LowVal, NodeDef, NodeInputs, NodeKind, NodeLibrary, port};
use crate::ir::{BinOp, Builder, Stream, Value};
use crate::types::{ConstValue, Type};

/// The step `bump2d` takes in `u` and in `v` for its finite differences: 2⁻¹⁰ (exact in
/// binary, so `uv + Δ` rounds once).
pub const BUMP_DELTA: f64 = 1.0 / 1024.0;

/// Registers the utility nodes.
pub fn register(lib: &mut NodeLibrary) {
    lib.add(ambient_occlusion_def());
    lib.add(bump2d_def());
    lib.add(filter_width_def());
    lib.add(filter_step_def());
}

fn filter_width_def() -> NodeDef {
    NodeDef {
        name: "filterWidth",
        category: "utility",
        doc: "The width of a float's footprint across the pixel (OSL's `filterwidth`): \
              `√(∂in/∂x² + ∂in/∂y²)`, from the screen-space derivatives the IR builds from \
              the ray differentials to `in` (docs/textures.md). 0 where `in` does not vary \
              across the pixel or there are no differentials. For filtering patterns of \
              one's own: a feature narrower than this aliases.",
        generic: &[],
        inputs: vec![port::float("in", 0.0, "The value (usually connected).")],
        outputs: vec![port::out("outValue", Type::Float, "The filter width, ≥ 0.")],
        lower: |b, inp| {
            let w = super::filtered::filter_width(b, inp.get("in"));
            Ok(vec![LowVal::plain(w)])
        },
        kind: NodeKind::Shading,
    }
}

fn filter_step_def() -> NodeDef {
    NodeDef {
        name: "filterStep",
        category: "utility",
        doc: "An antialiased step (RenderMan's `filterstep`, OSL's `aastep`, with a box \
              filter): the share of the interval `[in − w/2, in + w/2]` at or above `edge`, \
              `clamp((in + w/2 − edge) / w, 0, 1)`, where `w` is `filterWidth(in) · filter`. \
              Where the footprint is narrower than 1e-9 (or `filter ≤ 0`, or there are no \
              differentials) it is the plain step: 1 where `in ≥ edge`, else 0.",
        generic: &[],
        inputs: vec![
            port::float("edge", 0.5, "Where the step rises."),
            port::float("in", 0.0, "The value stepped (usually connected)."),
            port::float(
                "filter",
                1.0,
                "Scale of the footprint: 1 box-filters over the pixel, 0 or less is the \
                 plain step.",
            ),
        ],
        outputs: vec![port::out(
            "outValue",
            Type::Float,
            "The filtered step, in [0, 1].",
        )],
        lower: |b, inp| {
            let s =
                super::filtered::filter_step(b, inp.get("edge"), inp.get("in"), inp.get("filter"));
            Ok(vec![LowVal::plain(s)])
        },
        kind: NodeKind::Shading,
    }
}

fn ambient_occlusion_def() -> NodeDef {
    NodeDef {
        name: "ambientOcclusion",
        category: "utility",
        doc: "Ambient occlusion from the renderer's scene (like mental ray's \
              `mib_amb_occlusion`): `occ` is the fraction of `samples` cosine-weighted \
              directions around `normal` that travel `maxDistance` from `P` without hitting \
              anything, in [0, 1] (1: fully open), deterministic in the fragment's seed.\n\n\
              `outAlpha = occ`, `outColor = mix(dark, bright, occ)` (exactly `bright` where \
              `occ = 1`, `dark` where `occ = 0`). The outputs are plain values, not tagged \
              with a render component: a renderer's occlusion pass uses this node as an \
              override shader and takes `outColor` as it is (connected into a surface's \
              `ambientColor`, it lands in that surface's `indirect` part).\n\n\
              Without a scene, `occ = 1` (`outColor = bright`). `maxDistance` defaults to \
              1e30, in effect unbounded (any blocker counts); a `maxDistance` ≤ 0 (or a \
              zero normal) also gives `occ = 1`; `samples` below 1 counts as 1.",
        generic: &[],
        inputs: vec![
            port::stream(
                "normal",
                Type::Vec3,
                Stream::N,
                "Normal around which directions are sampled, world space (normalized).",
            ),
            port::int("samples", 16, "Number of sample directions (at least 1)."),
            port::float(
                "maxDistance",
                1e30,
                "How far a blocker counts, world units (1e30: unbounded).",
            ),
            port::color("bright", [1.0, 1.0, 1.0], "Color where fully open."),
            port::color("dark", [0.0, 0.0, 0.0], "Color where fully occluded."),
        ],
        outputs: vec![
            port::out(
                "outColor",
                Type::Color,
                "`mix(dark, bright, occ)` (no component parts).",
            ),
            port::out("outAlpha", Type::Float, "`occ`, in [0, 1]."),
        ],
        lower: lower_ambient_occlusion,
        kind: NodeKind::Shading,
    }
}

fn lower_ambient_occlusion(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let n = inp.get("normal");
    let samples = inp.get("samples");
    let max_distance = inp.get("maxDistance");
    let occ = b.occlusion(n, samples, max_distance);
    let color = b.mix(inp.get("dark"), inp.get("bright"), occ);
    Ok(vec![LowVal::plain(color), LowVal::plain(occ)])
}

fn bump2d_def() -> NodeDef {
    NodeDef {
        name: "bump2d",
        category: "utility",
        doc: "Bump mapping (Maya `bump2d`): perturbs `normal` as if the surface were \
              displaced along it by `bumpDepth · bumpValue`, where `bumpValue` is a height \
              field over the surface (typically a pattern's `outAlpha`).\n\n\
              The slopes are forward differences: `bumpValue` is evaluated again with the \
              implicit streams `uv` and `P` moved by one step `Δ = 2⁻¹⁰` in `u` (`uv + (Δ, \
              0)`, `P + Δ·dPdu`) and again in `v` (`uv + (0, Δ)`, `P + Δ·dPdv`) — a stream \
              override: the nodes upstream of `bumpValue` that read `uv` or `P` (through a \
              port default or by themselves) are lowered again with the moved values, the \
              others are shared — and `h_u = (h(u+Δ) − h)/Δ`, `h_v = (h(v+Δ) − h)/Δ`. A fixed \
              step keeps the result independent of ray differentials (no filtering); \
              features smaller than `Δ` in uv alias.\n\n\
              With `N = normalize(normal)` and `C = dPdu × dPdv`: `outNormal = normalize(N + \
              bumpDepth · (h_u (N × dPdv) + h_v (dPdu × N)) · (N·C)/|C|²)` — the normal of \
              the displaced surface `P + bumpDepth·h·N` to first order (Blinn 1978), turned \
              to `N`'s side: `(N·C)/|C|²` is `±1/|C|` when `N` is parallel to `C`. On the \
              plane `z = 0` with `dPdu = x`, `dPdv = y` and `h = k·u`, `outNormal = \
              normalize(−bumpDepth·k, 0, 1)`.\n\n\
              Where both slopes are exactly 0 (a constant `bumpValue`), `outNormal` is \
              `normal` itself, bit for bit. Zero tangents (`C = 0`) leave the normal's \
              direction unchanged (the division is total); a zero normal stays zero.",
        generic: &[],
        inputs: vec![
            port::float(
                "bumpValue",
                0.0,
                "Height; connect a pattern. Re-evaluated at `uv` moved by `Δ` in u and in v.",
            ),
            port::float(
                "bumpDepth",
                1.0,
                "Scale of the height (negative: dents instead of bumps).",
            ),
            port::stream(
                "normal",
                Type::Vec3,
                Stream::N,
                "Normal to perturb, world space.",
            ),
        ],
        outputs: vec![port::out(
            "outNormal",
            Type::Vec3,
            "The perturbed unit normal, world space (connect to a surface's `normal`).",
        )],
        lower: lower_bump2d,
        kind: NodeKind::Shading,
    }
}

/// `v · s` for a vector `v` and a float `s`.
fn scale(b: &mut Builder, v: Value, s: Value) -> Value {
    let ty = b.ty(v);
    let s = b.splat(ty, s);
    b.mul(v, s)
}

fn lower_bump2d(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let h = inp.get("bumpValue");
    let depth = inp.get("bumpDepth");
    let normal = inp.get("normal");
    let uv = b.stream(Stream::Uv);
    let p = b.stream(Stream::P);
    let dpdu = b.stream(Stream::DPdu);
    let dpdv = b.stream(Stream::DPdv);
    let delta = b.float(BUMP_DELTA);
    let inv_delta = b.float(1.0 / BUMP_DELTA);
    // h at one step along a direction: uv + step, P + Δ·tangent.
    let slope = |b: &mut Builder, step: [f64; 2], tangent: Value| {
        let step = b.constant(ConstValue::Vec2(step));
        let uv1 = b.add(uv, step);
        let dp = scale(b, tangent, delta);
        let p1 = b.add(p, dp);
        let h1 = inp.reevaluate(b, "bumpValue", &[(Stream::Uv, uv1), (Stream::P, p1)])?;
        let dh = b.sub(h1.value, h);
        Ok::<Value, String>(b.mul(dh, inv_delta))
    };
    let hu = slope(b, [BUMP_DELTA, 0.0], dpdu)?;
    let hv = slope(b, [0.0, BUMP_DELTA], dpdv)?;

    let n = b.normalize(normal);
    let a = b.binary(BinOp::Cross, n, dpdv);
    let c = b.binary(BinOp::Cross, dpdu, n);
    let ga = scale(b, a, hu);
    let gc = scale(b, c, hv);
    let g = b.add(ga, gc);
    let cr = b.binary(BinOp::Cross, dpdu, dpdv);
    let side = b.dot(n, cr);
    let len2 = b.dot(cr, cr);
    let s = b.div(side, len2);
    let k = b.mul(depth, s);
    let pert = scale(b, g, k);
    let bumped = b.add(n, pert);
    let bumped = b.normalize(bumped);
    let zero = b.float(0.0);
    let flat_u = b.binary(BinOp::Eq, hu, zero);
    let flat_v = b.binary(BinOp::Eq, hv, zero);
    let flat = b.binary(BinOp::And, flat_u, flat_v);
    let out = b.select(flat, normal, bumped);
    Ok(vec![LowVal::plain(out)])
}
